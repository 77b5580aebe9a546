//! The timing regression net: every `FrameStats` counter of every frame of
//! every bundled trace, at the default configuration, at a small-cache one
//! and at the `hmd2026` preset (wide lanes), compared exactly with the
//! snapshots in `tests/data/stats/`.
//!
//! A change that moves a cycle, a byte or a miss fails here. When the change
//! is intended, rewrite the snapshots with `UPDATE_STATS=1 cargo test --test
//! suite hw_stats_snapshot::` and say in the commit why the figures moved.

use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, HwReference};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The configurations snapshotted, by name.
fn configs() -> Vec<(&'static str, EngineConfig)> {
    vec![
        ("default", EngineConfig::default()),
        (
            "small-cache",
            EngineConfig { dest_cache_bytes: 16 * 1024, source_cache_bytes: 8 * 1024, ..EngineConfig::default() },
        ),
        ("hmd2026", EngineConfig::preset("hmd2026").expect("preset")),
    ]
}

/// The snapshot text of `trace` under `cfg`: a header, then per frame its
/// counters, one `name = value` line each.
fn snapshot(trace: &str, config_name: &str, cfg: &EngineConfig) -> String {
    let t = Trace::open(&root().join("traces").join(trace)).unwrap();
    let cfg = EngineConfig { supersample: t.display.supersample, ..cfg.clone() };
    let mut engine = Engine::new(cfg.clone()).unwrap();
    let mut s = String::new();
    let _ = writeln!(s, "# hardware-model counters: traces/{trace}, configuration `{config_name}`");
    let _ =
        writeln!(s, "# rewrite after an intended change: UPDATE_STATS=1 cargo test --test suite hw_stats_snapshot::");
    let mut refs: HashMap<usize, HwReference> = HashMap::new();
    for k in 0..t.derived.len() {
        for &r in &t.derived[k].references {
            refs.entry(r).or_insert_with(|| HwReference::new(&t.load_reference(r).unwrap().samples, &cfg));
        }
        let hw: Vec<&HwReference> = t.derived[k].references.iter().map(|r| &refs[r]).collect();
        let out = engine.run_frame(&t.frame_commands(k), &hw);
        for (name, u) in postwarp_rtl::engine::UNITS.iter().zip(&out.stats.units) {
            assert_eq!(
                u.total(),
                out.stats.cycles,
                "{trace} frame {k} {config_name}: {name} cycles do not tile the frame"
            );
            assert_eq!(u.stall_by_reason.iter().sum::<u64>(), u.stall, "{trace} frame {k}: {name} stall reasons");
        }
        let _ = writeln!(s, "frame {k}");
        for (name, value) in out.stats.flat() {
            let _ = writeln!(s, "{name} = {value}");
        }
    }
    s
}

/// The first lines where two snapshots differ, for the failure message.
fn first_differences(want: &str, got: &str) -> String {
    let mut out = String::new();
    let mut frame = "";
    let mut n = 0;
    for (w, g) in want.lines().zip(got.lines()) {
        if g.starts_with("frame ") {
            frame = g;
        }
        if w != g && n < 12 {
            let _ = writeln!(out, "  [{frame}] want `{w}`, got `{g}`");
            n += 1;
        }
    }
    let (lw, lg) = (want.lines().count(), got.lines().count());
    if lw != lg {
        let _ = writeln!(out, "  want {lw} lines, got {lg}");
    }
    out
}

fn check(trace: &str) {
    let update = std::env::var_os("UPDATE_STATS").is_some();
    let dir = root().join("tests/data/stats");
    for (name, cfg) in configs() {
        let got = snapshot(trace, name, &cfg);
        let path: PathBuf = dir.join(format!("{trace}.{name}.txt"));
        if update {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &got).unwrap();
            continue;
        }
        let want = std::fs::read_to_string(&path)
            .unwrap_or_else(|_| panic!("missing {} (UPDATE_STATS=1 writes it)", path.display()));
        assert!(
            want == got,
            "{}: counters differ from the snapshot (UPDATE_STATS=1 rewrites it after an intended change):\n{}",
            path.display(),
            first_differences(&want, &got)
        );
    }
}

#[test]
fn room_counters_match_the_snapshot() {
    check("room");
}

#[test]
fn slants_counters_match_the_snapshot() {
    check("slants");
}

#[test]
fn hairball_counters_match_the_snapshot() {
    check("hairball");
}

#[test]
fn occluders_counters_match_the_snapshot() {
    check("occluders");
}

#[test]
fn motorcycle_counters_match_the_snapshot() {
    check("motorcycle");
}

#[test]
fn every_snapshot_belongs_to_a_bundled_trace_and_configuration() {
    let traces = ["room", "slants", "hairball", "occluders", "motorcycle"];
    let names: Vec<&str> = configs().iter().map(|c| c.0).collect();
    let mut n = 0;
    for e in std::fs::read_dir(root().join("tests/data/stats")).unwrap() {
        let file = e.unwrap().file_name().to_string_lossy().to_string();
        let stem = file.strip_suffix(".txt").unwrap_or_else(|| panic!("tests/data/stats/{file}: not a snapshot"));
        let (trace, config) = stem.split_once('.').unwrap_or_else(|| panic!("tests/data/stats/{file}: bad name"));
        assert!(traces.contains(&trace) && names.contains(&config), "tests/data/stats/{file}: stale snapshot");
        n += 1;
    }
    assert_eq!(n, traces.len() * names.len(), "one snapshot per trace and configuration");
    assert!(Path::new(&root().join("tests/data/stats")).is_dir());
}
