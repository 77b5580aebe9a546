//! The DRAM statistics of `report.json` (issue 16, item 4) with the default
//! `ideal` backend, on the bundled room trace: latency histograms by
//! direction that add up to the requests, their mean / p50 / p99, queue
//! occupancy, per-client utilisation and achieved bandwidth derived from
//! the counters, the backend's own counters 0; and `dram_backend =
//! "dramsim3"` refused with a clear message in a build without it.

use postwarp::report::dram::LatencySummary;
use postwarp::run::simulate::measure_hardware;
use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn sum(h: &BTreeMap<String, u64>) -> u64 {
    h.values().sum()
}

#[test]
fn the_ideal_backend_reports_latency_occupancy_and_bandwidth() {
    let trace = Trace::open(&root().join("traces/room")).unwrap();
    let cfg = EngineConfig::default();
    let r = measure_hardware(&trace, &cfg, false, None, &indicatif::ProgressBar::hidden()).unwrap().report;
    for f in &r.frames {
        let c = &f.counters;
        let reads = sum(&c.dram_read_latency);
        assert_eq!(reads + sum(&c.dram_write_latency), c.dram_requests, "frame {}", f.index);
        assert!(reads > 0 && sum(&c.dram_write_latency) > 0);
        // The ideal latency is at least dram_latency_cycles plus one cycle of transfer.
        let min = |h: &BTreeMap<String, u64>| h.keys().map(|k| k.parse::<u64>().unwrap()).min().unwrap();
        assert!(min(&c.dram_read_latency) > cfg.dram_latency_cycles);
        let rl = f.rates.dram.dram_read_latency_cycles.clone().unwrap();
        assert!(rl.p50 <= rl.p99 && rl.p99 <= rl.max && rl.mean <= rl.max, "{rl:?}");
        assert!(rl.mean > cfg.dram_latency_cycles as f64);
        let hist: BTreeMap<String, f64> = c.dram_read_latency.iter().map(|(k, &n)| (k.clone(), n as f64)).collect();
        assert_eq!(LatencySummary::of(&hist), Some(rl));
        // Occupancy: at most dram_max_outstanding at once, and the mean below the peak.
        assert!(c.dram_peak_outstanding >= 1 && c.dram_peak_outstanding <= cfg.dram_max_outstanding as u64);
        let mean_out = f.rates.dram.dram_mean_outstanding.unwrap();
        assert!(mean_out > 0.0 && mean_out <= c.dram_peak_outstanding as f64, "{mean_out}");
        assert!(c.dram_outstanding_request_cycles >= c.dram_outstanding_cycles);
        assert!(c.port_peak_queued >= 1 && f.rates.dram.port_mean_queued.unwrap() <= c.port_peak_queued as f64);
        assert!(c.dram_requested_bytes <= c.dram_read_bytes + c.dram_write_bytes);
        assert!(c.dram_refused_cycles <= c.cycles && c.dram_outstanding_cycles <= c.cycles);
        // Bandwidth: achieved = bytes over the frame's time; per-client utilisations add up.
        let bytes = (c.dram_read_bytes + c.dram_write_bytes) as f64;
        let achieved = f.rates.dram.dram_achieved_gbps.unwrap();
        assert!((achieved - bytes * cfg.clock_hz as f64 / c.cycles as f64 / 1e9).abs() < 1e-9);
        assert!(achieved <= cfg.dram_peak_bytes_per_cycle as f64 * cfg.clock_hz as f64 / 1e9);
        let u = f.rates.dram.dram_utilisation_by_client.clone().unwrap();
        let total = u.reference_fetch + u.tile_fill + u.tile_write_back + u.output;
        assert!((total - f.rates.dram_utilisation.unwrap()).abs() < 1e-12);
        // No backend of its own: zeros, and no backend rates.
        assert_eq!(c.dram_backend, Default::default());
        assert_eq!(f.rates.dram.dram_row_hit_rate, None);
        assert_eq!(f.rates.dram.dram_backend_utilisation, None);
    }
    // `total` sums the histograms; `mean`'s percentiles come from the summed counts.
    assert_eq!(
        sum(&r.total.counters.dram_read_latency),
        r.frames.iter().map(|f| sum(&f.counters.dram_read_latency)).sum::<u64>()
    );
    assert!(r.mean.rates.dram.dram_read_latency_cycles.is_some());
}

#[test]
fn dramsim3_without_the_feature_says_how_to_rebuild() {
    if postwarp::dram::HAS_DRAMSIM3 {
        return; // tests/dram_dramsim3.rs runs it.
    }
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("ds3.toml");
    std::fs::write(&config, "dram_backend = \"dramsim3\"\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["simulate", "traces/room", "--out"])
        .arg(dir.path().join("out"))
        .arg("--config")
        .arg(&config)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ds3.toml") && err.contains("--features dramsim3"), "{err}");
}
