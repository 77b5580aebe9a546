//! The DRAM part of `postwarp simulate`'s report: the channel's and the
//! backend's counters (latency histograms by direction, queue occupancy,
//! DRAMsim3's transactions and row-buffer outcomes) and the rates derived
//! from them at report time (achieved bandwidth, per-client utilisation,
//! latency mean / p50 / p99, mean occupancy, row-hit rate).
//!
//! Percentiles are nearest-rank: p50 is the smallest latency at or below
//! which at least half the requests fall (`docs/stats.md`).
//!
//! Energy: the `dramsim3` binding does not expose DRAMsim3's statistics, so
//! no energy is reported.

use super::hardware::{ByClient, HwCounters, ReadWrite};
use super::keys::{KeyDoc, Reduce, Shape, nested, scalar};
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::mem::BackendCounters;
use postwarp_rtl::stats::Histogram;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The DRAM backend's own counters (0 for `ideal`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DramBackendCounters<N> {
    /// DRAM clock cycles simulated (DRAM cycles).
    pub dram_cycles: N,
    /// Bytes the DRAM data bus could have moved in them (bytes).
    pub peak_bytes: N,
    /// Read transactions (transactions).
    pub read_transactions: N,
    /// Write transactions (transactions).
    pub write_transactions: N,
    /// Bytes of the transactions (bytes).
    pub transaction_bytes: N,
    /// Transactions to the open row (transactions).
    pub row_hits: N,
    /// Transactions to a bank with no open row (transactions).
    pub row_misses: N,
    /// Transactions to a bank with another row open (transactions).
    pub row_conflicts: N,
}

impl DramBackendCounters<u64> {
    /// From the engine's counters.
    pub fn of(b: &BackendCounters) -> Self {
        DramBackendCounters {
            dram_cycles: b.dram_cycles,
            peak_bytes: b.peak_bytes,
            read_transactions: b.read_transactions,
            write_transactions: b.write_transactions,
            transaction_bytes: b.transaction_bytes,
            row_hits: b.row_hits,
            row_misses: b.row_misses,
            row_conflicts: b.row_conflicts,
        }
    }
}

/// A latency histogram as `report.json` holds it: `{"cycles": requests}`.
pub fn histogram_map(h: &Histogram) -> BTreeMap<String, u64> {
    h.bins().filter(|&(_, n)| n > 0).map(|(v, n)| (v.to_string(), n)).collect()
}

/// `all − reads`, bin by bin: the writes' histogram.
pub fn writes_of(all: &Histogram, reads: &Histogram) -> BTreeMap<String, u64> {
    all.bins().map(|(v, n)| (v, n - reads.get(v))).filter(|&(_, n)| n > 0).map(|(v, n)| (v.to_string(), n)).collect()
}

/// Mean, p50, p99 and max of a latency histogram.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LatencySummary {
    /// Mean latency (cycles).
    pub mean: f64,
    /// Nearest-rank median (cycles).
    pub p50: f64,
    /// Nearest-rank 99th percentile (cycles).
    pub p99: f64,
    /// Largest latency (cycles).
    pub max: f64,
}

impl LatencySummary {
    /// Of `{"cycles": count}` (counts may be fractional: a mean); `None`
    /// without requests or with a key that is not a number.
    pub fn of(h: &BTreeMap<String, f64>) -> Option<LatencySummary> {
        let mut bins: Vec<(f64, f64)> =
            h.iter().map(|(k, &n)| Some((k.parse::<u64>().ok()? as f64, n))).collect::<Option<_>>()?;
        bins.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n: f64 = bins.iter().map(|b| b.1).sum();
        if n <= 0.0 {
            return None;
        }
        let rank = |p: f64| {
            let want = (p * n).ceil().max(f64::MIN_POSITIVE);
            let mut seen = 0.0;
            for &(v, c) in &bins {
                seen += c;
                // Counts that are means (n / frames) carry rounding error.
                if seen >= want * (1.0 - 1e-12) {
                    return v;
                }
            }
            bins[bins.len() - 1].0
        };
        Some(LatencySummary {
            mean: bins.iter().map(|(v, c)| v * c).sum::<f64>() / n,
            p50: rank(0.5),
            p99: rank(0.99),
            max: bins[bins.len() - 1].0,
        })
    }
}

/// The DRAM rates of counters `c` under `cfg` (module doc).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DramRates {
    /// Bytes moved over the frame's time at the clock (GB/s).
    pub dram_achieved_gbps: Option<f64>,
    /// Per client, bytes over the bytes the channel's peak could move in
    /// the frame's cycles (fraction).
    pub dram_utilisation_by_client: Option<ByClient<f64>>,
    /// Read latency (cycles).
    pub dram_read_latency_cycles: Option<LatencySummary>,
    /// Write latency (cycles).
    pub dram_write_latency_cycles: Option<LatencySummary>,
    /// Mean requests outstanding in the DRAM (requests).
    pub dram_mean_outstanding: Option<f64>,
    /// Mean requests waiting in the memory port's queues (requests).
    pub port_mean_queued: Option<f64>,
    /// The backend's DRAM peak over the frame's time (GB/s).
    pub dram_backend_peak_gbps: Option<f64>,
    /// Transaction bytes over the backend's peak bytes (fraction).
    pub dram_backend_utilisation: Option<f64>,
    /// Row hits over transactions (fraction).
    pub dram_row_hit_rate: Option<f64>,
}

fn ratio(a: f64, b: f64) -> Option<f64> {
    (b > 0.0 && (a / b).is_finite()).then(|| a / b)
}

impl DramRates {
    /// The rates of `c` (one frame's counters, or the mean) under `cfg`.
    pub fn of(c: &HwCounters<f64>, cfg: &EngineConfig) -> DramRates {
        let seconds = c.cycles / cfg.clock_hz as f64;
        let bytes = c.dram_read_bytes + c.dram_write_bytes;
        let peak = c.cycles * cfg.dram_peak_bytes_per_cycle as f64;
        let b = &c.dram_backend;
        let rw = |x: &ReadWrite<f64>| x.read + x.write;
        let by = &c.dram_bytes_by_client;
        DramRates {
            dram_achieved_gbps: ratio(bytes, seconds * 1e9),
            dram_utilisation_by_client: (peak > 0.0).then(|| ByClient {
                reference_fetch: rw(&by.reference_fetch) / peak,
                tile_fill: rw(&by.tile_fill) / peak,
                tile_write_back: rw(&by.tile_write_back) / peak,
                output: rw(&by.output) / peak,
            }),
            dram_read_latency_cycles: LatencySummary::of(&c.dram_read_latency),
            dram_write_latency_cycles: LatencySummary::of(&c.dram_write_latency),
            dram_mean_outstanding: ratio(c.dram_outstanding_request_cycles, c.cycles),
            port_mean_queued: ratio(c.port_queued_request_cycles, c.cycles),
            dram_backend_peak_gbps: ratio(b.peak_bytes, seconds * 1e9),
            dram_backend_utilisation: ratio(b.transaction_bytes, b.peak_bytes),
            dram_row_hit_rate: ratio(b.row_hits, b.row_hits + b.row_misses + b.row_conflicts),
        }
    }
}

fn backend_keys() -> Vec<KeyDoc> {
    vec![
        scalar("dram_cycles", "DRAM cycles", Reduce::Sum, "DRAM clock cycles the backend simulated (0: ideal)"),
        scalar(
            "peak_bytes",
            "bytes",
            Reduce::Sum,
            "bytes the backend's DRAM data bus could have moved in those cycles, every channel (0: ideal)",
        ),
        scalar(
            "read_transactions",
            "transactions",
            Reduce::Sum,
            "read transactions handed to DRAMsim3 (a request is the transactions covering its bytes; 0: ideal)",
        ),
        scalar("write_transactions", "transactions", Reduce::Sum, "write transactions handed to DRAMsim3 (0: ideal)"),
        scalar(
            "transaction_bytes",
            "bytes",
            Reduce::Sum,
            "bytes of those transactions at DRAMsim3's transaction size, bus_width / 8 x BL (0: ideal)",
        ),
        scalar(
            "row_hits",
            "transactions",
            Reduce::Sum,
            "transactions to the row last opened in their bank, counted from the addresses and the mapping in the \
             order they enter DRAMsim3 (open page; 0: ideal)",
        ),
        scalar("row_misses", "transactions", Reduce::Sum, "transactions to a bank with no row opened yet (0: ideal)"),
        scalar(
            "row_conflicts",
            "transactions",
            Reduce::Sum,
            "transactions to a bank whose open row is another one (0: ideal)",
        ),
    ]
}

const fn map(key: &'static str, unit: &'static str, reduce: Reduce, meaning: &'static str) -> KeyDoc {
    KeyDoc { key, unit, reduce, shape: Shape::Map, meaning }
}

/// The DRAM rows of [`HwCounters`], in field order (after `dram_requests`).
pub fn counter_keys() -> Vec<KeyDoc> {
    vec![
        scalar("dram_requested_bytes", "bytes", Reduce::Sum, "bytes the clients asked for, before rounding to bursts"),
        scalar(
            "dram_refused_cycles",
            "cycles",
            Reduce::Sum,
            "cycles in which the DRAM refused a request (port or full)",
        ),
        scalar("dram_outstanding_cycles", "cycles", Reduce::Sum, "cycles with at least one DRAM request outstanding"),
        scalar(
            "dram_outstanding_request_cycles",
            "request-cycles",
            Reduce::Sum,
            "DRAM requests outstanding, summed over cycles (the queue occupancy's integral)",
        ),
        scalar("dram_peak_outstanding", "requests", Reduce::Max, "most DRAM requests outstanding at once"),
        scalar(
            "port_queued_request_cycles",
            "request-cycles",
            Reduce::Sum,
            "requests waiting in the memory port's four queues at the end of each cycle, summed over cycles",
        ),
        scalar("port_peak_queued", "requests", Reduce::Max, "most requests waiting in the memory port's queues"),
        map(
            "dram_read_latency",
            "requests",
            Reduce::Sum,
            "histogram of read requests by latency, key = cycles from acceptance to completion (as a string)",
        ),
        map("dram_write_latency", "requests", Reduce::Sum, "histogram of write requests by latency, key = cycles"),
        nested(
            "dram_backend",
            Reduce::Sum,
            backend_keys,
            "the DRAM backend's own counters (`dram_backend`; all 0 for `ideal`)",
        ),
    ]
}

fn latency_keys() -> Vec<KeyDoc> {
    vec![
        scalar("mean", "cycles", Reduce::Derived, "mean latency"),
        scalar("p50", "cycles", Reduce::Derived, "nearest-rank median: half the requests took at most this"),
        scalar("p99", "cycles", Reduce::Derived, "nearest-rank 99th percentile"),
        scalar("max", "cycles", Reduce::Derived, "largest latency"),
    ]
}

fn by_client_utilisation_keys() -> Vec<KeyDoc> {
    ["reference_fetch", "tile_fill", "tile_write_back", "output"]
        .into_iter()
        .map(|k| scalar(k, "fraction", Reduce::Derived, "the client's read + write bytes over cycles x peak"))
        .collect()
}

/// The rows of [`DramRates`], in field order.
pub fn rate_keys() -> Vec<KeyDoc> {
    vec![
        scalar(
            "dram_achieved_gbps",
            "GB/s",
            Reduce::Derived,
            "`(dram_read_bytes + dram_write_bytes) x clock_hz / cycles / 1e9`: the bandwidth the channel delivered over \
             the frame's time at the clock (`null` for 0 cycles)",
        ),
        nested(
            "dram_utilisation_by_client",
            Reduce::Derived,
            by_client_utilisation_keys,
            "per client, `(read + write) / (cycles x dram_peak_bytes_per_cycle)`; they sum to `dram_utilisation` \
             (the ideal channel's peak; see `dram_backend_utilisation` for DRAMsim3's)",
        ),
        nested(
            "dram_read_latency_cycles",
            Reduce::Derived,
            latency_keys,
            "of `dram_read_latency`: mean, p50, p99, max (`null` without reads)",
        ),
        nested(
            "dram_write_latency_cycles",
            Reduce::Derived,
            latency_keys,
            "of `dram_write_latency`: mean, p50, p99, max (`null` without writes)",
        ),
        scalar(
            "dram_mean_outstanding",
            "requests",
            Reduce::Derived,
            "`dram_outstanding_request_cycles / cycles`: mean DRAM queue occupancy",
        ),
        scalar(
            "port_mean_queued",
            "requests",
            Reduce::Derived,
            "`port_queued_request_cycles / cycles`: mean memory-port queue occupancy",
        ),
        scalar(
            "dram_backend_peak_gbps",
            "GB/s",
            Reduce::Derived,
            "`dram_backend.peak_bytes x clock_hz / cycles / 1e9`: the DRAMsim3 part's peak (`null` for ideal)",
        ),
        scalar(
            "dram_backend_utilisation",
            "fraction",
            Reduce::Derived,
            "`dram_backend.transaction_bytes / dram_backend.peak_bytes`: share of the DRAMsim3 part's peak the \
             transactions used (`null` for ideal)",
        ),
        scalar(
            "dram_row_hit_rate",
            "fraction",
            Reduce::Derived,
            "`row_hits / (row_hits + row_misses + row_conflicts)` of `dram_backend` (`null` for ideal)",
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_nearest_rank() {
        let h: BTreeMap<String, f64> = [("10", 50.0), ("12", 49.0), ("100", 1.0)].map(|(k, n)| (k.into(), n)).into();
        let s = LatencySummary::of(&h).unwrap();
        assert_eq!((s.p50, s.p99, s.max), (10.0, 12.0, 100.0));
        assert_eq!(s.mean, (500.0 + 588.0 + 100.0) / 100.0);
        // Means of counts (divided by frames) give the same percentiles.
        let third: BTreeMap<String, f64> = h.iter().map(|(k, n)| (k.clone(), n / 3.0)).collect();
        assert_eq!(LatencySummary::of(&third).unwrap().p99, 12.0);
        assert_eq!(LatencySummary::of(&BTreeMap::new()), None);
    }

    #[test]
    fn writes_are_all_minus_reads() {
        let (mut all, mut reads) = (Histogram::default(), Histogram::default());
        for v in [5, 5, 7, 9] {
            all.record(v);
        }
        reads.record(5);
        reads.record(9);
        let w = writes_of(&all, &reads);
        assert_eq!(w, [("5".to_string(), 1), ("7".to_string(), 1)].into());
        assert_eq!(histogram_map(&reads).len(), 2);
    }
}
