//! The tile manager's run-time half (`units::tile_manager`,
//! [`TileManager`]): kernels issued by kernel setup and finished by the
//! rasterizer or the compositor, kernel setup's line cursor, and the
//! retired bits the hole fill waits on.
//!
//! Doc rules checked: a line is complete once kernel setup has moved past
//! it and its count is 0, lines completing in schedule order; a tile is
//! retired once every line up to its retirement line is complete, and
//! tiles no line can touch are retired from the start (rule 1); the tick
//! says whether a tile retired. The engine ticks it once a cycle after
//! kernel setup: a tile whose last kernel finishes in cycle N retires in
//! the tick of cycle N, not before. A property test drives it against a
//! model written from the doc.

use crate::common;

use postwarp_rtl::units::tile_manager::TileManager;
use proptest::prelude::*;

#[test]
fn a_tile_retires_in_the_tick_of_the_cycle_its_last_kernel_finishes_and_not_before() {
    // Tiles 0 and 1 retire after line 0, tile 2 after line 1.
    let mut m = TileManager::new(2, &[Some(0), Some(0), Some(1)]);
    m.kernel_issued(0);
    m.kernel_issued(0);
    // Cycle N - 1: kernel setup has moved past line 0; one kernel finished.
    m.kernel_done(0);
    assert!(!m.tick(1), "N - 1: a kernel of line 0 in flight");
    assert!(!m.is_retired(0) && !m.is_retired(1));
    // Cycle N: the last one finishes.
    m.kernel_done(0);
    assert!(m.tick(1), "N: line 0 complete");
    assert!(m.is_retired(0) && m.is_retired(1) && !m.is_retired(2));
    assert!(!m.tick(1), "nothing more to retire");
}

#[test]
fn a_line_is_complete_only_once_kernel_setup_has_moved_past_it() {
    let mut m = TileManager::new(2, &[Some(0), Some(1)]);
    // Line 0 has no kernel in flight but kernel setup is still on it.
    assert!(!m.tick(0));
    assert!(!m.is_retired(0));
    assert!(m.tick(1) && m.is_retired(0) && !m.is_retired(1));
}

#[test]
fn lines_complete_in_schedule_order() {
    let mut m = TileManager::new(3, &[Some(0), Some(1), Some(2)]);
    m.kernel_issued(0);
    m.kernel_issued(1);
    m.kernel_done(1);
    // Line 1 is empty, but line 0 is not: neither tile 0 nor tile 1 retires.
    assert!(!m.tick(3));
    assert!((0..3).all(|t| !m.is_retired(t)));
    m.kernel_done(0);
    assert!(m.tick(3));
    assert!((0..3).all(|t| m.is_retired(t)), "all three lines complete at once");
}

#[test]
fn tiles_no_line_can_touch_are_retired_from_the_start() {
    let m = TileManager::new(1, &[None, Some(0), None]);
    assert!(m.is_retired(0) && !m.is_retired(1) && m.is_retired(2));
}

/// One event of a warp, as the units make them.
#[derive(Clone, Debug)]
enum Op {
    /// Kernel setup emits a kernel of its current line.
    Issue,
    /// Kernel setup moves to the next line.
    Advance,
    /// The `k`-th kernel in flight (mod their number) is done.
    Done(usize),
    /// The engine's tick (phase 7).
    Tick,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![3 => Just(Op::Issue), 1 => Just(Op::Advance), 3 => any::<usize>().prop_map(Op::Done), 2 => Just(Op::Tick)]
}

proptest! {
    #![proptest_config(common::prop_config(256))]

    /// Against a model of the doc: after every tick, a tile is retired iff
    /// no line can touch it or every line up to its retirement line is
    /// complete (kernel setup past it, nothing in flight, and the same for
    /// every earlier line); the tick returns true iff some tile retired.
    #[test]
    fn retired_bits_follow_the_doc(
        lines in 1usize..6,
        retire in prop::collection::vec(prop::option::of(0u32..6), 1..10),
        ops in prop::collection::vec(op(), 0..60),
    ) {
        let retire: Vec<Option<u32>> = retire.into_iter().map(|r| r.map(|l| l % lines as u32)).collect();
        let mut m = TileManager::new(lines, &retire);
        let mut cursor = 0usize;
        let mut in_flight: Vec<u32> = Vec::new(); // the line of each kernel in flight
        let mut retired: Vec<bool> = retire.iter().map(Option::is_none).collect();
        for (t, &r) in retired.iter().enumerate() {
            prop_assert_eq!(m.is_retired(t as u32), r);
        }
        for o in ops {
            match o {
                Op::Issue if cursor < lines => {
                    m.kernel_issued(cursor);
                    in_flight.push(cursor as u32);
                }
                Op::Advance if cursor < lines => cursor += 1,
                Op::Done(k) if !in_flight.is_empty() => {
                    let line = in_flight.remove(k % in_flight.len());
                    m.kernel_done(line);
                }
                Op::Tick => {
                    // Complete: a prefix of the lines kernel setup has passed.
                    let complete = (0..cursor).take_while(|&l| !in_flight.contains(&(l as u32))).count();
                    let before = retired.clone();
                    for (t, r) in retire.iter().enumerate() {
                        retired[t] = r.is_none_or(|l| (l as usize) < complete);
                    }
                    let newly = retired != before;
                    prop_assert_eq!(m.tick(cursor), newly);
                    for (t, &r) in retired.iter().enumerate() {
                        prop_assert_eq!(m.is_retired(t as u32), r, "tile {}", t);
                    }
                }
                _ => {}
            }
        }
    }
}
