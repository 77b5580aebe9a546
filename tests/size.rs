//! `postwarp size` end to end on a tiny generated trace (room, 32x24, 2
//! frames), and once on the bundled `traces/slants` (first frame, 25 dB):
//! the configuration it prints is loadable and meets the floor,
//! one step smaller does not (one fragment or super-sampling fewer fails
//! the floor; half the cache has capacity misses), the destination cache
//! and tile size do not change the image, and bad flags are refused
//! clearly.

use postwarp::report::csv;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

fn postwarp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The tiny trace, made once by `postwarp make-trace` (so `size` renders
/// it again at other super-samplings).
fn tiny() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    let d = DIR.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let t = d.path().join("room");
        let o = postwarp(&[
            "make-trace",
            "--scene",
            "room",
            "--out",
            s(&t),
            "--width",
            "32",
            "--height",
            "24",
            "--frames",
            "2",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        d
    });
    Box::leak(Box::new(d.path().join("room")))
}

fn table(dir: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut rows = csv::parse(&std::fs::read_to_string(dir.join("candidates.csv")).unwrap()).unwrap();
    let head = rows.remove(0);
    (head, rows)
}

fn col(head: &[String], name: &str) -> usize {
    head.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"))
}

/// The checks of "one step smaller fails" on the `candidates.csv` of a
/// successful `size` run in `out` with floor `floor` (dB): (a) the quality
/// stage stopped at the first candidate meeting the floor, and every
/// smaller one (one fragment fewer, a lower super-sampling) is under it;
/// (b) one cache step smaller (half the tiles) than the chosen one has
/// capacity misses, unless it is the engine's minimum of 8 tiles. Returns
/// the number of quality-stage runs.
fn assert_one_step_smaller_fails(out: &Path, floor: f64) -> usize {
    let (head, rows) = table(out);
    let c = |r: &Vec<String>, n: &str| r[col(&head, n)].clone();
    let chosen = rows.iter().find(|r| c(r, "chosen") == "true").expect("a chosen row");
    let quality: Vec<&Vec<String>> = rows.iter().filter(|r| c(r, "stage") == "quality").collect();
    let (last, smaller) = quality.split_last().expect("quality-stage runs");
    assert!(c(last, "psnr_luma_db").parse::<f64>().unwrap() >= floor);
    assert_eq!(
        (c(last, "supersample"), c(last, "abuffer_fragments")),
        (c(chosen, "supersample"), c(chosen, "abuffer_fragments"))
    );
    for r in smaller {
        assert!(c(r, "psnr_luma_db").parse::<f64>().unwrap() < floor, "{r:?}");
        assert_eq!(c(r, "passes"), "false");
    }
    assert_eq!(c(chosen, "capacity_misses"), "0");
    let tiles: u64 = c(chosen, "dest_cache_tiles").parse().unwrap();
    if tiles > 8 {
        let half = rows
            .iter()
            .find(|r| {
                c(r, "stage") == "cache"
                    && c(r, "tile_size_samples") == c(chosen, "tile_size_samples")
                    && c(r, "dest_cache_tiles") == (tiles / 2).to_string()
            })
            .expect("the step below was tried");
        assert!(c(half, "capacity_misses").parse::<u64>().unwrap() > 0, "{half:?}");
    }
    quality.len()
}

#[test]
fn on_a_bundled_trace_the_configuration_one_step_smaller_fails_the_floor() {
    let out = tempfile::tempdir().unwrap();
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("traces/slants");
    let o = postwarp(&["size", s(&dir), "--min-psnr", "25", "--frames", "1", "--out", s(out.path())]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}{text}", String::from_utf8_lossy(&o.stderr));
    assert!(
        text.contains("smallest configuration") && text.contains("GB/s") && text.contains("cycles per frame"),
        "{text}"
    );
    let runs = assert_one_step_smaller_fails(out.path(), 25.0);
    assert!(runs >= 2, "the first quality candidate already passed: nothing smaller was shown to fail");
}

#[test]
fn smallest_configuration_meets_the_floor_and_one_step_smaller_does_not() {
    let work = tempfile::tempdir().unwrap();
    // A first run with an unreachable floor runs every quality candidate and fails clearly.
    let first = work.path().join("first");
    let o = postwarp(&["size", s(tiny()), "--min-psnr", "99", "--out", s(&first)]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no configuration meets the floor") && err.contains("best mean luma PSNR"), "{err}");
    // The files line lists what was written: no config.toml without a configuration.
    let text = String::from_utf8_lossy(&o.stdout);
    let files = text.lines().find(|l| l.starts_with("files: ")).unwrap_or_else(|| panic!("{text}"));
    assert!(!first.join("config.toml").exists() && !files.contains("config.toml"), "{files}");
    assert!(files.contains("size.json") && files.contains("candidates.csv"), "{files}");
    let (head, rows) = table(&first);
    let (psnr, ss, frags) = (col(&head, "psnr_luma_db"), col(&head, "supersample"), col(&head, "abuffer_fragments"));
    let order: Vec<(u32, u32)> = rows.iter().map(|r| (r[ss].parse().unwrap(), r[frags].parse().unwrap())).collect();
    assert_eq!(order, [(1, 1), (2, 1), (2, 2), (2, 3), (2, 4), (4, 1), (4, 2), (4, 3), (4, 4)]);
    let q: Vec<f64> = rows.iter().map(|r| r[psnr].parse().unwrap()).collect();
    // The floor: the best quality reached, less a tiny epsilon.
    let best = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let first_best = q.iter().position(|&x| x >= best - 1e-6).unwrap();
    assert!(first_best > 0, "the first candidate is already the best ({q:?}): the test would mean nothing");
    let floor = best - 1e-6;

    let out = work.path().join("found");
    let o = postwarp(&["size", s(tiny()), "--min-psnr", &format!("{floor}"), "--out", s(&out)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}{text}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("smallest configuration") && text.contains("dest_cache_bytes = "), "{text}");
    assert!(text.lines().any(|l| l.starts_with("files: ") && l.contains("config.toml")), "{text}");
    // The configuration is loadable by `simulate --config`, and says what
    // its quality figure was scored against.
    let toml = std::fs::read_to_string(out.join("config.toml")).unwrap();
    assert!(
        toml.contains("# quality: mean luma PSNR") && toml.contains("against the ground truth of traces/"),
        "{toml}"
    );
    assert!(toml.contains("(rendered at 4x4)"), "{toml}");
    let cfg = postwarp::run::hw_config_toml::from_text(&toml, &out.join("config.toml")).unwrap();
    let (head, rows) = table(&out);
    let c = |r: &Vec<String>, n: &str| r[col(&head, n)].clone();
    let chosen: Vec<&Vec<String>> = rows.iter().filter(|r| c(r, "chosen") == "true").collect();
    assert_eq!(chosen.len(), 1);
    let chosen = chosen[0];
    assert_eq!(c(chosen, "stage"), "cache");
    assert_eq!(c(chosen, "dest_cache_bytes"), cfg.dest_cache_bytes.to_string());
    assert_eq!(c(chosen, "tile_size_samples"), cfg.tile_size.to_string());
    assert_eq!(c(chosen, "capacity_misses"), "0");
    let quality_runs = assert_one_step_smaller_fails(&out, floor);
    assert_eq!(quality_runs, first_best + 1);
    let last = rows.iter().rfind(|r| c(r, "stage") == "quality").unwrap();
    assert_eq!(
        (c(last, "supersample"), c(last, "abuffer_fragments")),
        (cfg.supersample.to_string(), cfg.abuffer_fragments.to_string())
    );
    // Every cache-stage run made the same image (same quality, golden-identical).
    for r in rows.iter().filter(|r| c(r, "stage") == "cache") {
        assert_eq!(c(r, "psnr_luma_db"), c(last, "psnr_luma_db"));
        assert_eq!(c(r, "golden_identical_frames"), "2");
    }
    // Some tile size needed more than the minimum, so (b) is tested somewhere.
    assert!(
        rows.iter().any(|r| c(r, "stage") == "cache" && c(r, "capacity_misses") != "0"),
        "no cache-stage run had capacity misses"
    );
    // Same inputs, same bytes.
    let again = work.path().join("again");
    let o2 = postwarp(&["size", s(tiny()), "--min-psnr", &format!("{floor}"), "--out", s(&again)]);
    assert!(o2.status.success());
    for f in ["candidates.csv", "config.toml"] {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), std::fs::read(again.join(f)).unwrap(), "{f}");
    }
}

#[test]
fn destination_cache_and_tile_size_do_not_change_the_image() {
    let work = tempfile::tempdir().unwrap();
    let mut frames = Vec::new();
    for (name, toml) in
        [("small", "tile_size = 4\ndest_cache_bytes = 2048\n"), ("big", "tile_size = 16\ndest_cache_bytes = 4194304\n")]
    {
        let cfg = work.path().join(format!("{name}.toml"));
        std::fs::write(&cfg, toml).unwrap();
        let out = work.path().join(name);
        let o = postwarp(&["simulate", s(tiny()), "--config", s(&cfg), "--out", s(&out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
        assert_eq!(r["total"]["identical_frames"], 2);
        frames.push((0..2).map(|k| std::fs::read(out.join(format!("frame-{k:04}.png"))).unwrap()).collect::<Vec<_>>());
        if name == "small" {
            assert!(r["total"]["dest_cache"]["misses_capacity"].as_u64().unwrap() > 0, "the small cache should thrash");
        }
    }
    assert_eq!(frames[0], frames[1]);
}

#[test]
fn bad_flags_are_refused_clearly() {
    let cases: [(Vec<&str>, &str); 5] = [
        (vec!["--min-psnr", "30", "--max-dram-overhead", "-1"], "--max-dram-overhead -1: expected a fraction >= 0"),
        (vec!["--min-psnr", "-5"], "--min-psnr -5: expected a PSNR of 0 dB or more"),
        (vec!["--min-psnr", "30", "--min-ssim", "2"], "--min-ssim 2: expected an SSIM from 0 to 1"),
        (vec!["--min-psnr", "30", "--preset", "nope"], "--preset"),
        (vec!["--min-psnr", "30", "--frames", "0"], "--frames 0"),
    ];
    for (flags, msg) in cases {
        let mut args = vec!["size", s(tiny())];
        args.extend(flags);
        let o = postwarp(&args);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(msg), "{args:?}: {err}");
    }
    let missing = PathBuf::from("no/such/trace");
    let o = postwarp(&["size", s(&missing), "--min-psnr", "30"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("no/such/trace: no such trace"));
}

#[test]
fn every_candidates_column_is_documented_with_its_unit() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/size.md")).unwrap();
    for (name, unit, _) in postwarp::size::output::CSV_COLUMNS {
        assert!(
            doc.lines().any(|l| l.contains(&format!("| `{name}` |")) && l.contains(unit)),
            "docs/size.md: no table row for `{name}` ({unit})"
        );
    }
}

#[test]
fn a_dram_allowance_buys_a_smaller_cache_within_it() {
    let work = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = work.path().join(name);
        let mut args = vec!["size", s(tiny()), "--min-psnr", "0", "--out", s(&out)];
        args.extend(extra);
        let o = postwarp(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        table(&out)
    };
    let (head, strict) = run("strict", &[]);
    let (_, loose) = run("loose", &["--max-dram-overhead", "0.5"]);
    let c = |r: &Vec<String>, name: &str| r[col(&head, name)].clone();
    let num = |r: &Vec<String>, name: &str| c(r, name).parse::<f64>().unwrap();
    let chosen = |rows: &[Vec<String>]| rows.iter().find(|r| c(r, "chosen") == "true").unwrap().clone();
    let (a, b) = (chosen(&strict), chosen(&loose));
    assert!(num(&b, "dest_cache_bytes") <= num(&a, "dest_cache_bytes"), "{a:?} vs {b:?}");
    // Within the allowance of its own tile size's miss-free cache.
    let free = loose
        .iter()
        .find(|r| {
            c(r, "stage") == "cache"
                && c(r, "tile_size_samples") == c(&b, "tile_size_samples")
                && c(r, "capacity_misses") == "0"
        })
        .unwrap();
    assert!(num(&b, "dram_bytes_per_frame") <= 1.5 * num(free, "dram_bytes_per_frame"), "{b:?} vs {free:?}");
    // A smaller cache was taken somewhere, or none existed under the allowance.
    let smaller_within =
        loose.iter().any(|r| c(r, "stage") == "cache" && c(r, "capacity_misses") != "0" && c(r, "passes") == "true");
    assert!(smaller_within || num(&b, "dest_cache_bytes") == num(&a, "dest_cache_bytes"));
}
