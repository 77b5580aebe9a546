//! `timeline-NNNN.json`: one derived frame of the hardware model in the
//! Chrome trace event format, which ui.perfetto.dev and chrome://tracing
//! open (`postwarp simulate --timeline`, `docs/units.md`, "Timeline").
//!
//! Layout: process 1 "units" has one track per unit (in `UNITS` order)
//! and a "warps" track; process 2 "DRAM" has one counter per client
//! (requests in flight) and a bandwidth counter; process 3 "occupancy" has
//! one counter per queue (FIFOs, memory port, destination cache).
//!
//! Rules:
//! 1. A unit's intervals tile the frame: they are contiguous from cycle 0
//!    to the frame's last cycle, and their `args` (cycles per state) sum to
//!    the unit's busy, stall-by-reason and idle counters in `report.json`.
//! 2. A run of one state at least `resolution` cycles long is one
//!    interval named after its state (`busy`, `stall: dram`, …, `idle`);
//!    shorter runs are merged into a `mixed` interval of about
//!    `resolution` cycles whose `args` give the cycles of each state and
//!    whose name says the state that had most of them.
//! 3. Counters are sampled once per window of `resolution` cycles (rounded
//!    up to the model's occupancy window, 64 cycles): the window's mean and
//!    maximum, emitted when they change.
//! 4. Time stamps are microseconds at the configured clock; every event
//!    also carries its first cycle and length in cycles (`cycle`, `cycles`).

use postwarp_rtl::engine::UNITS;
use postwarp_rtl::mem::Client;
use postwarp_rtl::timeline::{OCCUPANCY_WINDOW, Timeline};
use postwarp_rtl::units::{Run, StallReason, UnitState};
use serde_json::{Map, Value, json};

/// Default `--timeline-resolution` (cycles).
pub const DEFAULT_RESOLUTION: u64 = 4096;

/// What the file says about where it came from (`otherData`).
pub struct TimelineMeta<'a> {
    /// The trace's manifest, as given.
    pub trace: &'a str,
    /// Derived frame index.
    pub frame: usize,
    /// Engine clock (Hz).
    pub clock_hz: u64,
    /// Interval and counter resolution (cycles, rule 2).
    pub resolution: u64,
}

/// The state names of rule 2, in `args` order.
const STATES: [&str; 6] = ["busy", "stall_dram", "stall_tile", "stall_fifo_full", "stall_upstream", "idle"];

fn state_index(s: UnitState) -> usize {
    match s {
        UnitState::Busy => 0,
        UnitState::Stall(r) => 1 + r.index(),
        UnitState::Idle => 5,
    }
}

/// Interval name of a state.
fn state_name(i: usize) -> String {
    match i {
        0 => "busy".into(),
        5 => "idle".into(),
        _ => format!("stall: {}", StallReason::ALL[i - 1].name()),
    }
}

/// Chrome's reserved colour names, so the states read at a glance.
fn colour(i: usize) -> &'static str {
    match i {
        0 => "good",
        1 | 2 => "terrible",
        3 | 4 => "bad",
        _ => "grey",
    }
}

/// The Chrome trace of one frame (module doc), as JSON bytes.
pub fn chrome_trace(t: &Timeline, meta: &TimelineMeta<'_>) -> Vec<u8> {
    let res = meta.resolution.max(1);
    // Microseconds, rounded to the nanosecond (what the viewers resolve).
    let us = |cycle: u64| (cycle as f64 * 1e9 / meta.clock_hz as f64).round() / 1e3;
    let mut ev: Vec<Value> = Vec::new();
    let name = |pid: u32, tid: Option<u32>, kind: &str, n: &str| {
        let mut e = json!({"name": kind, "ph": "M", "pid": pid, "args": {"name": n}});
        if let Some(tid) = tid {
            e["tid"] = json!(tid);
        }
        e
    };
    ev.push(name(1, None, "process_name", "units"));
    ev.push(name(2, None, "process_name", "DRAM"));
    ev.push(name(3, None, "process_name", "occupancy"));
    for (u, unit) in UNITS.iter().enumerate() {
        let tid = u as u32 + 1;
        ev.push(name(1, Some(tid), "thread_name", unit));
        ev.push(json!({"name": "thread_sort_index", "ph": "M", "pid": 1, "tid": tid, "args": {"sort_index": tid}}));
        for (first, end, cycles) in intervals(&t.units[u], res) {
            let top = (0..STATES.len()).max_by_key(|&i| (cycles[i], std::cmp::Reverse(i))).unwrap_or(5);
            let pure = cycles.iter().filter(|&&c| c > 0).count() == 1;
            let label = if pure { state_name(top) } else { format!("mixed, mostly {}", state_name(top)) };
            let mut args = Map::new();
            args.insert("cycle".into(), json!(first));
            args.insert("cycles".into(), json!(end - first));
            for (i, c) in cycles.iter().enumerate() {
                if *c > 0 {
                    args.insert(STATES[i].into(), json!(c));
                }
            }
            ev.push(json!({
                "name": label, "cat": unit, "ph": "X", "pid": 1, "tid": tid,
                "ts": us(first), "dur": us(end - first), "cname": colour(top), "args": args,
            }));
        }
    }
    let warps_tid = UNITS.len() as u32 + 1;
    ev.push(name(1, Some(warps_tid), "thread_name", "warps"));
    ev.push(json!({"name": "thread_sort_index", "ph": "M", "pid": 1, "tid": warps_tid, "args": {"sort_index": 0}}));
    for (j, (a, b)) in t.warps.iter().enumerate() {
        let (a, b) = (a.get(), b.get());
        ev.push(json!({
            "name": format!("warp {j}"), "ph": "X", "pid": 1, "tid": warps_tid,
            "ts": us(a), "dur": us(b - a), "args": {"cycle": a, "cycles": b - a},
        }));
    }
    let win = res.div_ceil(OCCUPANCY_WINDOW) * OCCUPANCY_WINDOW;
    let windows = t.cycles.div_ceil(win) as usize;
    dram_counters(t, win, windows, meta.clock_hz, &us, &mut ev);
    for o in &t.occupancy {
        let per = (win / OCCUPANCY_WINDOW) as usize;
        let series: Vec<(f64, u64)> = (0..windows)
            .map(|w| {
                let r = (w * per).min(o.sum.len())..((w + 1) * per).min(o.sum.len());
                let sum: u64 = o.sum[r.clone()].iter().sum();
                let max = o.max[r].iter().copied().max().unwrap_or(0);
                (milli(sum as f64 / window_len(w, win, t.cycles) as f64), max)
            })
            .collect();
        let label = match o.capacity {
            Some(c) => format!("{} ({}, capacity {c})", o.name, o.unit),
            None => format!("{} ({}, unbounded)", o.name, o.unit),
        };
        counter(&mut ev, 3, &label, win, &us, &series, |(mean, max)| json!({"mean": mean, "max": max}));
    }
    let doc = json!({
        "displayTimeUnit": "ns",
        "otherData": {
            "trace": meta.trace, "frame": meta.frame, "clock_hz": meta.clock_hz,
            "cycles": t.cycles, "resolution_cycles": res, "counter_window_cycles": win,
        },
        "traceEvents": ev,
    });
    let mut bytes = serde_json::to_vec(&doc).expect("a timeline serializes");
    bytes.push(b'\n');
    bytes
}

/// `v` rounded to three decimals (counter values: the viewers plot them,
/// more digits only make the file larger).
fn milli(v: f64) -> f64 {
    (v * 1e3).round() / 1e3
}

/// Cycles of window `w` (the last one may be short).
fn window_len(w: usize, win: u64, cycles: u64) -> u64 {
    (cycles - w as u64 * win).min(win).max(1)
}

/// Per client, the mean requests in flight per window; and the bandwidth
/// of completed requests per client (GB/s).
fn dram_counters(t: &Timeline, win: u64, windows: usize, clock_hz: u64, us: &dyn Fn(u64) -> f64, ev: &mut Vec<Value>) {
    let n = Client::ALL.len();
    let mut flight = vec![vec![0u64; windows]; n];
    let mut bytes = vec![vec![0u64; windows]; n];
    for r in &t.requests {
        let c = r.client.index();
        let (a, b) = (r.accepted.get(), r.done.get().max(r.accepted.get()));
        let mut at = a;
        while at < b {
            let w = (at / win) as usize;
            let end = ((w as u64 + 1) * win).min(b);
            if w < windows {
                flight[c][w] += end - at;
            }
            at = end;
        }
        let w = ((b.saturating_sub(1)) / win) as usize;
        if w < windows {
            bytes[c][w] += r.bytes;
        }
    }
    for (c, client) in Client::ALL.iter().enumerate() {
        let series: Vec<f64> =
            (0..windows).map(|w| milli(flight[c][w] as f64 / window_len(w, win, t.cycles) as f64)).collect();
        let label = format!("in flight: {}", client.name());
        counter(ev, 2, &label, win, us, &series, |v| json!({"requests": v}));
    }
    let gbps: Vec<Vec<f64>> = (0..windows)
        .map(|w| {
            let secs = window_len(w, win, t.cycles) as f64 / clock_hz as f64;
            (0..n).map(|c| milli(bytes[c][w] as f64 / secs / 1e9)).collect()
        })
        .collect();
    counter(ev, 2, "bandwidth (GB/s)", win, us, &gbps, |v| {
        let mut m = Map::new();
        for (c, client) in Client::ALL.iter().enumerate() {
            m.insert(client.name().into(), json!(v[c]));
        }
        Value::Object(m)
    });
}

/// One counter track: a sample at every window whose value differs from
/// the last sample's, and a last sample at the frame's end.
fn counter<T: PartialEq>(
    ev: &mut Vec<Value>,
    pid: u32,
    name: &str,
    win: u64,
    us: &dyn Fn(u64) -> f64,
    series: &[T],
    args: impl Fn(&T) -> Value,
) {
    let mut last: Option<&T> = None;
    for (w, v) in series.iter().enumerate() {
        if last != Some(v) {
            let cycle = w as u64 * win;
            ev.push(json!({"name": name, "ph": "C", "pid": pid, "ts": us(cycle), "args": args(v)}));
            last = Some(v);
        }
    }
}

/// Rule 2 over one unit's runs: `(first cycle, end cycle, cycles per
/// state)` per interval, contiguous.
fn intervals(runs: &[Run], res: u64) -> Vec<(u64, u64, [u64; 6])> {
    let mut out = Vec::new();
    let mut pending: Option<(u64, u64, [u64; 6])> = None;
    for r in runs {
        let (a, b) = (r.start.get(), r.end.get());
        let mut cycles = [0u64; 6];
        cycles[state_index(r.state)] = b - a;
        if b - a >= res {
            out.extend(pending.take());
            out.push((a, b, cycles));
            continue;
        }
        let p = pending.get_or_insert((a, a, [0; 6]));
        p.1 = b;
        p.2[state_index(r.state)] += b - a;
        if p.1 - p.0 >= res {
            out.extend(pending.take());
        }
    }
    out.extend(pending);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use postwarp_rtl::clock::Cycle;

    fn run(state: UnitState, a: u64, b: u64) -> Run {
        Run { state, start: Cycle(a), end: Cycle(b) }
    }

    #[test]
    fn short_runs_merge_into_mixed_intervals_that_keep_every_cycle() {
        let stall = UnitState::Stall(StallReason::Tile);
        let runs = [
            run(UnitState::Busy, 0, 3),
            run(stall, 3, 5),
            run(UnitState::Busy, 5, 9),
            run(UnitState::Idle, 9, 40),
            run(UnitState::Busy, 40, 41),
        ];
        let iv = intervals(&runs, 8);
        assert_eq!(iv.len(), 3);
        assert_eq!((iv[0].0, iv[0].1, iv[0].2), (0, 9, [7, 0, 2, 0, 0, 0]));
        assert_eq!((iv[1].0, iv[1].1, iv[1].2[5]), (9, 40, 31));
        assert_eq!((iv[2].0, iv[2].1), (40, 41));
        assert!(iv.windows(2).all(|w| w[0].1 == w[1].0));
        // Resolution 1: every run is its own interval.
        assert_eq!(intervals(&runs, 1).len(), runs.len());
    }
}
