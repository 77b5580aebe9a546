//! State-machine property test of the destination tile cache
//! (`postwarp_rtl::units::tile_cache`) against a reference model written
//! from its module doc, driven the way the engine drives it
//! (`rtl-model/src/engine.rs`, `Machine::want_tile`):
//!
//! - an access is `hit(t, now, counted)` and, when that is false,
//!   `access(t, now, counted, pinned)`; `counted` is false for a retry;
//! - a `Compulsory` or `Capacity` look-up starts a load, delivered later by
//!   `loaded(t, now)` (loads complete in any order: demand tiles of
//!   different sizes, first-warp tiles cleared at once);
//! - a spilled tile is written out raw and comes back raw on its capacity
//!   miss; a compulsory miss brings the tile as the previous warp released
//!   it (empty in the frame's first warp);
//! - units write a tile only while it is resident;
//! - `release(t)` only on a resident tile; a warp ends with every used tile
//!   released, then `begin_warp()`.
//!
//! The model keeps tile states, last-use times and the replacement rule
//! (least recently used unpinned resident tile, ties to the lowest tile
//! number) in plain maps, and tile *contents* as a running hash of the
//! writes; the harness moves contents the way the engine's memory traffic
//! does, so a wrong hit, a wrong victim or a compulsory miss where a
//! capacity miss was due shows up as lost writes.

use crate::common;

use postwarp_rtl::clock::Cycle;
use postwarp_rtl::units::tile_cache::{Lookup, TileCache, TileCacheCounters, TileState};
use proptest::prelude::*;
use std::collections::BTreeMap;

/// One step of the driver.
#[derive(Clone, Debug)]
enum Op {
    /// The clock moves on by `dt` cycles (0: several operations in a cycle).
    Tick { dt: u64 },
    /// A unit's access to `tile` as the engine makes it: `hit` first unless
    /// `direct` (then straight to `access`), pinning `pinned` (and the tile
    /// itself if `pin_self`), counted unless a retry.
    Access { tile: u32, counted: bool, direct: bool, pin_self: bool, pinned: Vec<u32> },
    /// The `which`-th load in flight (mod their number) arrives.
    Arrive { which: usize },
    /// A unit writes `value` into `tile` if it is resident (the engine only
    /// writes after a successful access).
    Write { tile: u32, value: u64 },
    /// The tile manager releases the `which`-th resident tile (mod their number).
    Release { which: usize },
    /// The warp ends: every load arrives, every used tile comes back and is
    /// released, then `begin_warp`.
    EndWarp,
}

fn op(tiles: u32) -> impl Strategy<Value = Op> {
    let tile = 0..tiles;
    prop_oneof![
        2 => (0u64..3).prop_map(|dt| Op::Tick { dt }),
        8 => (tile.clone(), any::<bool>(), prop::bool::weighted(0.2), any::<bool>(), prop::collection::vec(0..tiles, 0..4))
            .prop_map(|(tile, counted, direct, pin_self, pinned)| Op::Access { tile, counted, direct, pin_self, pinned }),
        4 => any::<usize>().prop_map(|which| Op::Arrive { which }),
        3 => (tile, any::<u64>()).prop_map(|(tile, value)| Op::Write { tile, value }),
        2 => any::<usize>().prop_map(|which| Op::Release { which }),
        1 => Just(Op::EndWarp),
    ]
}

/// The kind of slot a load in flight will fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum LoadKind {
    Compulsory,
    Capacity,
}

/// The reference model (module doc rules 1–5) plus the data the harness
/// moves around.
struct Model {
    capacity: usize,
    state: Vec<TileState>,
    /// Resident tiles and their last use (cycle).
    last_use: BTreeMap<u32, u64>,
    /// Loads in flight, in the order they started.
    loading: Vec<(u32, LoadKind)>,
    counters: TileCacheCounters,
    /// What every tile must hold: the hash of the writes since the frame began.
    expected: Vec<u64>,
    /// Harness data: tiles on chip, tiles spilled raw, tiles as released
    /// (A-buffer format in memory).
    on_chip: BTreeMap<u32, u64>,
    spilled: BTreeMap<u32, u64>,
    memory: Vec<u64>,
    first_warp: bool,
    now: u64,
}

fn mix(h: u64, v: u64) -> u64 {
    (h ^ v).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(29)
}

/// Contents of a tile never written (cleared on chip in the first warp).
fn empty(t: u32) -> u64 {
    mix(0x5eed, t as u64)
}

impl Model {
    fn new(capacity: usize, tiles: usize) -> Model {
        Model {
            capacity,
            state: vec![TileState::Untouched; tiles],
            last_use: BTreeMap::new(),
            loading: Vec::new(),
            counters: TileCacheCounters::default(),
            expected: (0..tiles as u32).map(empty).collect(),
            on_chip: BTreeMap::new(),
            spilled: BTreeMap::new(),
            memory: (0..tiles as u32).map(empty).collect(),
            first_warp: true,
            now: 0,
        }
    }

    /// Tiles holding a slot: resident or loading.
    fn held(&self) -> usize {
        self.last_use.len() + self.loading.len()
    }

    /// Rule 4's victim: least recently used unpinned resident tile, ties to
    /// the lowest number.
    fn victim(&self, pinned: &[u32]) -> Option<u32> {
        self.last_use.iter().filter(|(t, _)| !pinned.contains(t)).min_by_key(|&(&t, &u)| (u, t)).map(|(&t, _)| t)
    }

    /// The model's answer to an access (rule 2–4), applied to the model.
    fn access(&mut self, t: u32, counted: bool, pinned: &[u32]) -> (Lookup, Option<u32>) {
        let ti = t as usize;
        match self.state[ti] {
            TileState::Resident => {
                self.last_use.insert(t, self.now);
                if counted {
                    self.counters.accesses += 1;
                    self.counters.hits += 1;
                }
                (Lookup::Hit, None)
            }
            TileState::Loading => {
                if counted {
                    self.counters.accesses += 1;
                    self.counters.misses_late += 1;
                }
                (Lookup::Wait, None)
            }
            st @ (TileState::Untouched | TileState::Spilled) => {
                let mut victim = None;
                if self.held() >= self.capacity {
                    let Some(v) = self.victim(pinned) else { return (Lookup::Full, None) };
                    self.last_use.remove(&v);
                    self.state[v as usize] = TileState::Spilled;
                    self.counters.spills += 1;
                    victim = Some(v);
                }
                let kind = if st == TileState::Untouched { LoadKind::Compulsory } else { LoadKind::Capacity };
                self.state[ti] = TileState::Loading;
                self.loading.push((t, kind));
                if counted {
                    self.counters.accesses += 1;
                    match kind {
                        LoadKind::Compulsory => {
                            self.counters.misses_compulsory += 1;
                            self.counters.misses_demand += 1;
                        }
                        LoadKind::Capacity => self.counters.misses_capacity += 1,
                    }
                }
                let l = if kind == LoadKind::Compulsory { Lookup::Compulsory } else { Lookup::Capacity };
                (l, victim)
            }
            TileState::Released => unreachable!("the driver never touches a released tile"),
        }
    }
}

/// The cache under test beside the model.
struct Harness {
    cache: TileCache,
    m: Model,
    /// Spills and loads seen (for the summary checks).
    spills_seen: u64,
    loads_started: u64,
}

impl Harness {
    fn new(capacity: usize, tiles: usize) -> Harness {
        Harness {
            cache: TileCache::new(capacity, tiles),
            m: Model::new(capacity, tiles),
            spills_seen: 0,
            loads_started: 0,
        }
    }

    /// One access, the engine's way; returns true when the tile is resident.
    fn access(&mut self, t: u32, counted: bool, direct: bool, pinned: &[u32]) -> Result<bool, TestCaseError> {
        let now = self.m.now;
        if self.m.state[t as usize] == TileState::Released {
            return Ok(false); // the schedule never does this (see `released_tiles_panic`)
        }
        let got = if !direct && self.cache.hit(t, Cycle(now), counted) {
            (Lookup::Hit, None)
        } else {
            if !direct {
                prop_assert_ne!(self.m.state[t as usize], TileState::Resident, "hit() missed a resident tile {}", t);
            }
            self.cache.access(t, Cycle(now), counted, pinned)
        };
        let want = self.m.access(t, counted, pinned);
        prop_assert_eq!(got, want, "access to tile {} at {} pinned {:?}", t, now, pinned);
        if let Some(v) = got.1 {
            // The victim goes out raw with what it holds.
            self.spills_seen += 1;
            let data = self.m.on_chip.remove(&v);
            prop_assert!(data.is_some(), "spilled tile {} was not on chip", v);
            prop_assert!(!pinned.contains(&v), "spilled pinned tile {}", v);
            self.m.spilled.insert(v, data.unwrap());
        }
        match got.0 {
            Lookup::Hit => prop_assert!(self.m.on_chip.contains_key(&t), "hit on tile {} not on chip", t),
            Lookup::Compulsory | Lookup::Capacity => self.loads_started += 1,
            Lookup::Wait | Lookup::Full => {}
        }
        Ok(got.0 == Lookup::Hit)
    }

    /// The `which`-th load in flight arrives.
    fn arrive(&mut self, which: usize) -> Result<(), TestCaseError> {
        if self.m.loading.is_empty() {
            return Ok(());
        }
        let (t, kind) = self.m.loading.remove(which % self.m.loading.len());
        self.cache.loaded(t, Cycle(self.m.now));
        self.m.state[t as usize] = TileState::Resident;
        self.m.last_use.insert(t, self.m.now);
        let data = match kind {
            // As the previous warp released it, or cleared in the first warp.
            LoadKind::Compulsory if self.m.first_warp => empty(t),
            LoadKind::Compulsory => {
                prop_assert!(!self.m.spilled.contains_key(&t), "compulsory miss on spilled tile {}", t);
                self.m.memory[t as usize]
            }
            LoadKind::Capacity => {
                let d = self.m.spilled.remove(&t);
                prop_assert!(d.is_some(), "capacity miss on tile {} never spilled", t);
                d.unwrap()
            }
        };
        self.m.on_chip.insert(t, data);
        Ok(())
    }

    fn write(&mut self, t: u32, value: u64) -> Result<(), TestCaseError> {
        if self.cache.state(t) != TileState::Resident {
            return Ok(());
        }
        let d = self.m.on_chip.get_mut(&t);
        prop_assert!(d.is_some(), "resident tile {} not on chip", t);
        let d = d.unwrap();
        *d = mix(*d, value);
        self.m.expected[t as usize] = mix(self.m.expected[t as usize], value);
        Ok(())
    }

    fn release(&mut self, t: u32) -> Result<(), TestCaseError> {
        self.cache.release(t);
        self.m.last_use.remove(&t);
        self.m.state[t as usize] = TileState::Released;
        let d = self.m.on_chip.remove(&t);
        prop_assert_eq!(d, Some(self.m.expected[t as usize]), "tile {} released with other contents", t);
        self.m.memory[t as usize] = d.unwrap();
        Ok(())
    }

    /// The end of a warp as the engine's release order makes it: every
    /// load arrives, every tile used in the warp comes back and leaves.
    fn end_warp(&mut self) -> Result<(), TestCaseError> {
        while !self.m.loading.is_empty() {
            self.arrive(0)?;
        }
        let resident: Vec<u32> = self.m.last_use.keys().copied().collect();
        for t in resident {
            self.release(t)?;
        }
        // Spilled tiles come back (the packer's access pins its own tile;
        // with nothing else held there is room) and leave.
        let spilled: Vec<u32> = self.m.spilled.keys().copied().collect();
        for t in spilled {
            prop_assert!(!self.access(t, false, false, &[t])?);
            self.arrive(0)?;
            prop_assert!(self.access(t, false, false, &[t])?);
            self.release(t)?;
        }
        prop_assert_eq!(self.cache.occupancy(), 0);
        prop_assert!(self.m.spilled.is_empty() && self.m.on_chip.is_empty());
        self.cache.begin_warp();
        self.m.state.fill(TileState::Untouched);
        self.m.first_warp = false;
        Ok(())
    }

    /// Everything observable agrees with the model.
    fn check(&self) -> Result<(), TestCaseError> {
        for t in 0..self.m.state.len() as u32 {
            prop_assert_eq!(self.cache.state(t), self.m.state[t as usize], "state of tile {}", t);
        }
        prop_assert_eq!(self.cache.occupancy(), self.m.held());
        prop_assert!(self.cache.occupancy() <= self.cache.capacity());
        prop_assert_eq!(&self.cache.counters, &self.m.counters);
        let k = &self.cache.counters;
        prop_assert_eq!(k.accesses, k.hits + k.misses_demand + k.misses_late + k.misses_capacity);
        prop_assert_eq!(k.misses_compulsory, k.misses_demand + k.prefetches);
        prop_assert_eq!(k.spills, self.spills_seen);
        // A load is a miss, counted unless the look-up that started it was
        // marked as a retry (`docs/stats.md`: the packer's look-ups and
        // retries are never counted, even when they reload a tile).
        prop_assert!(k.misses_compulsory + k.misses_capacity <= self.loads_started);
        // What is on chip is what the writes made it.
        prop_assert!(self.m.on_chip.len() <= self.m.capacity);
        for (&t, &d) in &self.m.on_chip {
            prop_assert_eq!(d, self.m.expected[t as usize], "contents of resident tile {}", t);
        }
        for (&t, &d) in &self.m.spilled {
            prop_assert_eq!(d, self.m.expected[t as usize], "contents of spilled tile {}", t);
        }
        Ok(())
    }
}

fn scenario() -> impl Strategy<Value = (usize, u32, Vec<Op>)> {
    (1usize..6, 1u32..12)
        .prop_flat_map(|(capacity, tiles)| (Just(capacity), Just(tiles), prop::collection::vec(op(tiles), 1..200)))
}

proptest! {
    #![proptest_config(common::prop_config(256))]

    /// Step by step, the cache's look-ups, victims, states, occupancy,
    /// counters and the contents its decisions move equal the model's.
    #[test]
    fn tile_cache_follows_the_reference_model((capacity, tiles, ops) in scenario()) {
        let mut h = Harness::new(capacity, tiles as usize);
        prop_assert_eq!(h.cache.capacity(), capacity);
        for op in &ops {
            match op {
                Op::Tick { dt } => h.m.now += dt,
                Op::Access { tile, counted, direct, pin_self, pinned } => {
                    let mut pins = pinned.clone();
                    if *pin_self {
                        pins.push(*tile);
                    }
                    h.access(*tile, *counted, *direct, &pins)?;
                }
                Op::Arrive { which } => h.arrive(*which)?,
                Op::Write { tile, value } => h.write(*tile, *value)?,
                Op::Release { which } => {
                    let resident: Vec<u32> = h.m.last_use.keys().copied().collect();
                    if !resident.is_empty() {
                        h.release(resident[which % resident.len()])?;
                    }
                }
                Op::EndWarp => h.end_warp()?,
            }
            h.check()?;
        }
        h.end_warp()?;
        h.check()?;
        // Everything written reached memory.
        prop_assert_eq!(&h.m.memory, &h.m.expected);
    }

    /// With room for every tile: no spill and no capacity miss; every tile
    /// used in a warp is exactly one compulsory miss, every later access a
    /// hit or a wait.
    #[test]
    fn a_cache_holding_every_tile_only_misses_compulsorily(
        tiles in 1u32..10,
        accesses in prop::collection::vec((0u32..10, any::<bool>()), 1..100),
    ) {
        let mut c = TileCache::new(tiles as usize, tiles as usize);
        let mut used = std::collections::BTreeSet::new();
        let mut hits = 0;
        for (now, &(t, arrive)) in accesses.iter().enumerate() {
            let t = t % tiles;
            let (l, v) = c.access(t, Cycle(now as u64), true, &[]);
            prop_assert_eq!(v, None);
            match l {
                Lookup::Compulsory => prop_assert!(used.insert(t), "second compulsory miss on {}", t),
                Lookup::Hit => hits += 1,
                Lookup::Wait => {}
                Lookup::Capacity | Lookup::Full => prop_assert!(false, "{:?} with room for every tile", l),
            }
            if arrive && c.state(t) == TileState::Loading {
                c.loaded(t, Cycle(now as u64));
            }
        }
        let k = &c.counters;
        prop_assert_eq!((k.misses_compulsory, k.misses_capacity, k.spills, k.hits), (used.len() as u64, 0, 0, hits));
    }
}

/// Using a tile again after its release in the same warp is a programming
/// error (rule 5, `docs/units.md`): the cache panics rather than reload it.
#[test]
#[should_panic(expected = "used after its release")]
fn released_tiles_panic() {
    let mut c = TileCache::new(2, 2);
    assert_eq!(c.access(1, Cycle(0), true, &[]).0, Lookup::Compulsory);
    c.loaded(1, Cycle(0));
    c.release(1);
    let _ = c.access(1, Cycle(1), true, &[]);
}
