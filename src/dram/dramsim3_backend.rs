//! The DRAMsim3 backend (`dram_backend = "dramsim3"`, cargo feature
//! `dramsim3`): a closed loop through DRAMsim3 (the `dramsim3` crate, a
//! binding that bundles it), behind the channel of `postwarp_rtl::mem`.
//!
//! Job: turn each request the channel accepts into DRAMsim3 transactions,
//! clock DRAMsim3 at its own rate, and complete the request when DRAMsim3
//! has returned all of its transactions.
//!
//! Rules:
//! 1. Transactions: DRAMsim3 moves `bus_width / 8 × BL` bytes per
//!    transaction (64 bytes for DDR3/DDR4/HBM2 and the 1st-generation
//!    LPDDR, 128 for LPDDR4 x16 BL16). A request of `bytes` at `addr` is
//!    the transactions at the aligned addresses covering `[addr, addr +
//!    bytes)`, reads or writes as the request.
//! 2. Order: transactions enter DRAMsim3 in acceptance order, as fast as
//!    `WillAcceptTransaction` allows (at most its queue per channel), one
//!    DRAM cycle after another; a refused head waits (no bypass).
//! 3. Completion: DRAMsim3's callback for an address and direction
//!    completes the oldest transaction waiting with that address and
//!    direction (DRAMsim3 merges equal addresses: a read of an address
//!    with a write pending returns at once). A request completes in the
//!    engine cycle whose DRAM cycles returned its last transaction.
//!    Writes complete when DRAMsim3 acknowledges them (it buffers them:
//!    one DRAM cycle after they enter).
//! 4. Clock: DRAM cycles per engine cycle = engine period / `tCK` =
//!    `1e12 / (clock_hz × tck_ps)` with `tCK` from the ini rounded to
//!    picoseconds; an integer accumulator gains `1e12` per engine cycle
//!    and pays `clock_hz × tck_ps` per DRAM cycle, so the ratio is exact
//!    and deterministic (no drift, no floating point). Skipped engine
//!    cycles tick DRAMsim3 as often as ticking them would (refresh goes
//!    on); while transactions are in DRAMsim3 the engine ticks every cycle
//!    (`NextEvent::EveryCycle`).
//! 5. Each frame gets a fresh DRAMsim3 (the engine's memory is idle at a
//!    frame's start).
//!
//! Stats: `BackendCounters` (DRAM cycles, peak bytes of those cycles,
//! transactions, row hits/misses/conflicts by `rows`). DRAMsim3's own
//! statistics and energy are not reachable through the binding (no
//! `PrintStats`), so energy is not reported.
//!
//! Not modelled: the controller's reordering of requests before DRAMsim3
//! (the channel is in order), multiple engine-side channels.

use super::ini::{Geometry, Ini};
use super::rows::{RowOutcome, RowTracker};
use postwarp_rtl::clock::Cycle;
use postwarp_rtl::mem::{Access, BackendCounters, DramBackend, DramBackendFactory, NextEvent};
use std::collections::{HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// DRAMsim3's constructor bumps a global counter: one at a time.
static CREATE: Mutex<()> = Mutex::new(());

/// The ini DRAMsim3 reads and its output directory, removed when the last
/// backend of a configuration is gone.
struct Files {
    dir: PathBuf,
    ini: PathBuf,
}

impl Drop for Files {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A factory of DRAMsim3 backends for configuration `ini` with address
/// mapping `mapping` (empty: the ini's) and engine clock `clock_hz`.
pub fn factory(ini: &Ini, mapping: &str, clock_hz: u64) -> Result<DramBackendFactory, String> {
    let geometry = Geometry::of(ini, mapping)?;
    static N: AtomicU64 = AtomicU64::new(0);
    let dir = std::env::temp_dir().join(format!(
        "postwarp-dramsim3-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let files = Files { ini: dir.join("config.ini"), dir };
    std::fs::write(&files.ini, ini.for_dramsim3(&geometry.mapping))
        .map_err(|e| format!("writing {}: {e}", files.ini.display()))?;
    let files = Arc::new(files);
    Ok(Arc::new(move || Box::new(Dramsim3::new(files.clone(), geometry.clone(), clock_hz)) as Box<dyn DramBackend>))
}

/// One frame's DRAMsim3 (module doc).
pub struct Dramsim3 {
    sys: dramsim3::MemorySystem,
    _files: Arc<Files>,
    transaction_bytes: u64,
    peak_bytes_per_cycle: u64,
    /// Rule 4: gained per engine cycle, paid per DRAM cycle, the balance.
    gain: u128,
    cost: u128,
    balance: u128,
    now: Cycle,
    /// Transactions not yet in DRAMsim3: (address, write, request id).
    queue: VecDeque<(u64, bool, u64)>,
    /// Transactions in DRAMsim3 by (address, write): request ids, oldest first.
    waiting: HashMap<(u64, bool), VecDeque<u64>>,
    in_sim: usize,
    /// Transactions still to return, per request.
    left: HashMap<u64, u32>,
    /// Finished requests: (id, engine cycle).
    done: VecDeque<(u64, Cycle)>,
    rows: RowTracker,
    counters: BackendCounters,
}

impl Dramsim3 {
    fn new(files: Arc<Files>, geometry: Geometry, clock_hz: u64) -> Dramsim3 {
        let sys = {
            let _one = CREATE.lock().unwrap_or_else(|p| p.into_inner());
            dramsim3::MemorySystem::new(&files.ini, &files.dir).expect("paths without NUL bytes")
        };
        let (gain, cost) = geometry.clock_ratio(clock_hz);
        Dramsim3 {
            sys,
            _files: files,
            transaction_bytes: geometry.transaction_bytes,
            peak_bytes_per_cycle: geometry.bus_bytes_per_cycle * geometry.channels,
            gain,
            cost,
            balance: 0,
            now: Cycle::ZERO,
            queue: VecDeque::new(),
            waiting: HashMap::new(),
            in_sim: 0,
            left: HashMap::new(),
            done: VecDeque::new(),
            rows: RowTracker::new(geometry),
            counters: BackendCounters::default(),
        }
    }

    /// One DRAM cycle: hand DRAMsim3 what it accepts (rule 2), then clock it.
    fn dram_cycle(&mut self) {
        while let Some(&(addr, write, id)) = self.queue.front() {
            if !self.sys.can_add(addr, write) {
                break;
            }
            let added = self.sys.add(addr, write);
            debug_assert!(added);
            self.queue.pop_front();
            self.waiting.entry((addr, write)).or_default().push_back(id);
            self.in_sim += 1;
            let c = &mut self.counters;
            match self.rows.access(addr) {
                RowOutcome::Hit => c.row_hits += 1,
                RowOutcome::Miss => c.row_misses += 1,
                RowOutcome::Conflict => c.row_conflicts += 1,
            }
        }
        let Dramsim3 { sys, waiting, left, done, in_sim, now, .. } = self;
        sys.tick(|addr, write| {
            let Some(id) = waiting.get_mut(&(addr, write)).and_then(VecDeque::pop_front) else {
                debug_assert!(false, "DRAMsim3 returned {addr:#x} (write {write}) that nobody waits for");
                return;
            };
            *in_sim -= 1;
            let n = left.get_mut(&id).expect("a request of the transaction");
            *n -= 1;
            if *n == 0 {
                left.remove(&id);
                done.push_back((id, *now));
            }
        });
        self.counters.dram_cycles += 1;
        self.counters.peak_bytes += self.peak_bytes_per_cycle;
    }
}

impl DramBackend for Dramsim3 {
    fn name(&self) -> &'static str {
        "dramsim3"
    }

    fn tick(&mut self, now: Cycle) {
        self.now = now;
        self.balance += self.gain;
        while self.balance >= self.cost {
            self.balance -= self.cost;
            self.dram_cycle();
        }
    }

    fn skip_to(&mut self, now: Cycle) {
        for t in self.now.get() + 1..=now.get() {
            self.tick(Cycle(t));
        }
    }

    fn accept(&mut self, _now: Cycle, id: u64, access: Access, addr: u64, bytes: u64) -> Option<Cycle> {
        let t = self.transaction_bytes;
        let first = addr / t * t;
        let last = (addr + bytes.max(1) - 1) / t * t;
        let n = (last - first) / t + 1;
        let write = access == Access::Write;
        for k in 0..n {
            self.queue.push_back((first + k * t, write, id));
        }
        self.left.insert(id, n as u32);
        let c = &mut self.counters;
        if write {
            c.write_transactions += n;
        } else {
            c.read_transactions += n;
        }
        c.transaction_bytes += n * t;
        None
    }

    fn pop_done(&mut self, now: Cycle) -> Option<(u64, Cycle)> {
        if self.done.front().is_some_and(|&(_, d)| d <= now) { self.done.pop_front() } else { None }
    }

    fn next_event(&self) -> NextEvent {
        if let Some(&(_, d)) = self.done.front() {
            NextEvent::At(d)
        } else if self.queue.is_empty() && self.in_sim == 0 {
            NextEvent::Idle
        } else {
            NextEvent::EveryCycle
        }
    }

    fn counters(&self) -> BackendCounters {
        self.counters.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(name: &str, mapping: &str) -> Box<dyn DramBackend> {
        factory(&Ini::load(name).unwrap(), mapping, 100_000_000).unwrap()()
    }

    /// Tick until every accepted request is done; (id, cycle) in order.
    fn drain(b: &mut dyn DramBackend, mut now: u64) -> Vec<(u64, u64)> {
        let mut out = vec![];
        while b.next_event() != NextEvent::Idle {
            now += 1;
            b.tick(Cycle(now));
            while let Some((id, c)) = b.pop_done(Cycle(now)) {
                out.push((id, c.get()));
            }
            assert!(now < 1_000_000, "DRAMsim3 never finished");
        }
        out
    }

    #[test]
    fn a_read_takes_dram_time_and_the_clock_ratio_holds() {
        let mut b = one("DDR4_8Gb_x8_3200", "");
        b.tick(Cycle(0));
        assert_eq!(b.accept(Cycle(0), 0, Access::Read, 4096, 128), None);
        let done = drain(b.as_mut(), 0);
        assert_eq!(done.len(), 1);
        // tRCD + CL = 44 DRAM cycles of 0.63 ns at least: over 2 engine cycles of 10 ns.
        assert!(done[0].1 >= 3, "{done:?}");
        let c = b.counters();
        assert_eq!((c.read_transactions, c.transaction_bytes, c.row_misses), (2, 128, 1));
        assert_eq!(c.row_hits, 1, "the second 64 bytes are in the same row");
        // 1e12 / (1e8 × 630) = 15.87… DRAM cycles per engine cycle.
        let ticks = c.dram_cycles as f64 / (done[0].1 + 1) as f64;
        assert!((ticks - 15.873).abs() < 1.0 / (done[0].1 + 1) as f64, "{ticks}");
        assert_eq!(c.peak_bytes, c.dram_cycles * 16);
    }

    #[test]
    fn runs_are_deterministic_and_skipping_ticks_the_dram_clock() {
        let run = |skip: bool| {
            let mut b = one("HBM2_8Gb_x128", "");
            b.tick(Cycle(0));
            for i in 0..40u64 {
                let access = if i % 3 == 0 { Access::Write } else { Access::Read };
                b.accept(Cycle(0), i, access, i * 4096 + (i % 5) * 64, 64 + i % 100);
            }
            let done = drain(b.as_mut(), 0);
            let end = done.last().unwrap().1;
            if skip {
                b.skip_to(Cycle(end + 500));
            } else {
                for t in end + 1..=end + 500 {
                    b.tick(Cycle(t));
                }
            }
            (done, b.counters())
        };
        let (a, ca) = run(true);
        assert_eq!(a.len(), 40);
        assert_eq!((a, ca.clone()), run(true));
        assert_eq!(ca, run(false).1);
    }
}
