//! `postwarp golden` end to end on the bundled traces.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn golden(trace: &str, out: &Path, extra: &[&str]) -> (String, Value) {
    run("golden", trace, out, extra)
}

/// `postwarp CMD traces/TRACE --out OUT EXTRA…`: its stdout and report.
fn run(cmd: &str, trace: &str, out: &Path, extra: &[&str]) -> (String, Value) {
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .arg(cmd)
        .arg(root().join("traces").join(trace))
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    (String::from_utf8(o.stdout).unwrap(), report)
}

#[test]
fn hole_fill_raises_quality_on_room() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fill) = golden("room", &dir.path().join("fill"), &[]);
    let (_, bare) = golden("room", &dir.path().join("bare"), &["--no-hole-fill"]);
    let m = |r: &Value, k: &str| r["mean"][k].as_f64().unwrap();
    assert!(m(&bare, "hole_fraction") > 0.0, "room must have holes for this test to mean anything");
    assert!(
        m(&fill, "psnr_luma_db") > m(&bare, "psnr_luma_db"),
        "{} vs {}",
        m(&fill, "psnr_luma_db"),
        m(&bare, "psnr_luma_db")
    );
    assert!(m(&fill, "ssim_luma") > m(&bare, "ssim_luma"));
    assert_eq!(m(&fill, "empty_samples"), 0.0, "the fill reaches every hole on room");
}

#[test]
fn printed_table_and_report_agree() {
    let dir = tempfile::tempdir().unwrap();
    let (stdout, report) = golden("occluders", dir.path(), &["--flip"]);
    let keys = [
        "psnr_rgb_db",
        "psnr_rgb_covered_db",
        "psnr_rgb_common_db",
        "psnr_luma_db",
        "ssim_luma",
        "flip_mean",
        "hole_fraction",
        "delta_e20_fraction",
        "host_ms",
    ];
    let scale = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 100.0, 100.0, 1.0];
    let decimals = [2, 2, 2, 2, 4, 4, 2, 2, 1];
    let frames = report["frames"].as_array().unwrap();
    let mut rows = 0;
    for line in stdout.lines() {
        let cells: Vec<&str> = line.split_whitespace().collect();
        if cells.len() != 10 {
            continue;
        }
        let entry = match cells[0] {
            "mean" => &report["mean"],
            i => match i.parse::<usize>() {
                Ok(i) => &frames[i],
                Err(_) => continue,
            },
        };
        for (k, key) in keys.iter().enumerate() {
            let want = format!("{:.*}", decimals[k], entry[key].as_f64().unwrap() * scale[k]);
            assert_eq!(cells[k + 1], want, "{key} of row {}", cells[0]);
        }
        rows += 1;
    }
    assert_eq!(rows, frames.len() + 1, "{stdout}");
    for f in frames {
        for key in [
            "index",
            "psnr_rgb_db",
            "psnr_rgb_covered_db",
            "psnr_luma_db",
            "ssim_luma",
            "flip_mean",
            "hole_fraction",
            "delta_e20_fraction",
            "host_ms",
            "kernel_sizes",
            "fragments_per_pixel",
            "forced_merges",
            "hole_samples",
        ] {
            assert!(f.get(key).is_some(), "frame lacks {key}");
        }
    }
}

/// FLIP is scored only with `--flip`: without it the report says so
/// (`flip` = false), every FLIP key is null and the table prints `-`;
/// every other score is the same number either way. The same for
/// `simulate`.
#[test]
fn flip_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let (stdout, without) = golden("occluders", &dir.path().join("a"), &[]);
    let (_, with) = golden("occluders", &dir.path().join("b"), &["--flip"]);
    assert_eq!((&without["flip"], &with["flip"]), (&Value::Bool(false), &Value::Bool(true)));
    let (fa, fb) = (without["frames"].as_array().unwrap(), with["frames"].as_array().unwrap());
    assert_eq!(fa.len(), fb.len());
    for (a, b) in fa.iter().zip(fb) {
        for key in ["flip_mean", "flip_mean_common"] {
            assert!(a[key].is_null(), "{key} without --flip: {}", a[key]);
            assert!(b[key].as_f64().is_some_and(|v| v > 0.0), "{key} with --flip: {}", b[key]);
        }
        for key in ["psnr_rgb_db", "psnr_luma_db", "ssim_luma", "ssim_luma_common", "delta_e20_fraction"] {
            assert_eq!(a[key], b[key], "{key}");
        }
    }
    assert!(without["mean"]["flip_mean"].is_null() && with["mean"]["flip_mean"].as_f64().is_some());
    let mean_row: Vec<&str> = stdout
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|c| c.first() == Some(&"mean"))
        .unwrap_or_else(|| panic!("a mean row in {stdout}"));
    assert_eq!(mean_row[6], "-", "the FLIP column of {mean_row:?}");

    let sim = |out: &Path, extra: &[&str]| run("simulate", "occluders", out, extra).1;
    let (a, b) = (sim(&dir.path().join("s"), &[]), sim(&dir.path().join("t"), &["--flip"]));
    assert_eq!((&a["flip"], &b["flip"]), (&Value::Bool(false), &Value::Bool(true)));
    assert!(a["mean"]["vs_truth"]["flip_mean"].is_null(), "{}", a["mean"]["vs_truth"]);
    assert!(b["mean"]["vs_truth"]["flip_mean"].as_f64().is_some(), "{}", b["mean"]["vs_truth"]);
    assert_eq!(a["mean"]["vs_truth"]["psnr_luma_db"], b["mean"]["vs_truth"]["psnr_luma_db"]);
}

/// The frame names (`frame-NNNN.png`) in `dir`, sorted.
fn frame_pngs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| rd.map(|e| e.unwrap().file_name().to_string_lossy().to_string()).collect())
        .unwrap_or_default();
    names.retain(|n| n.starts_with("frame-") && n.ends_with(".png"));
    names.sort();
    names
}

/// The golden images of every bundled trace, compared on decoded pixels
/// (so a PNG encoder change does not matter), with the same set of frames:
/// a missing or an extra frame fails. Set `UPDATE_GOLDEN=1` to rewrite
/// `tests/data/golden/` after an intended change.
#[test]
fn golden_images_match_the_committed_ones() {
    let update = std::env::var_os("UPDATE_GOLDEN").is_some();
    let dir = tempfile::tempdir().unwrap();
    for trace in ["room", "slants", "hairball", "occluders", "motorcycle"] {
        let out = dir.path().join(trace);
        golden(trace, &out, &[]);
        let want_dir = root().join("tests/data/golden").join(trace);
        let got = frame_pngs(&out);
        assert!(!got.is_empty(), "{trace}: no frames");
        if update {
            std::fs::create_dir_all(&want_dir).unwrap();
            for stale in frame_pngs(&want_dir) {
                std::fs::remove_file(want_dir.join(stale)).unwrap();
            }
            for name in &got {
                std::fs::copy(out.join(name), want_dir.join(name)).unwrap();
            }
        }
        let want = frame_pngs(&want_dir);
        assert_eq!(got, want, "{trace}: frames written differ from {} (UPDATE_GOLDEN=1 rewrites)", want_dir.display());
        for name in &got {
            let a = image::open(out.join(name)).unwrap().to_rgb8();
            let b = image::open(want_dir.join(name)).unwrap().to_rgb8();
            assert_eq!(a.dimensions(), b.dimensions(), "{trace}/{name}: size differs");
            let differing = a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count();
            assert!(differing == 0, "{trace}/{name}: {differing} pixels differ from {}", want_dir.join(name).display());
        }
    }
}

#[test]
fn motorcycle_reports_whole_and_covered_psnr() {
    let dir = tempfile::tempdir().unwrap();
    let (_, r) = golden("motorcycle", dir.path(), &[]);
    let f = &r["frames"][0];
    let whole = f["psnr_rgb_db"].as_f64().unwrap();
    let covered = f["psnr_rgb_covered_db"].as_f64().unwrap();
    // A warp of the left view must beat the unwarped left image (12.6 dB) by far.
    assert!(whole > 18.0, "{whole}");
    assert!(covered >= whole, "covered pixels score at least the whole image: {covered} vs {whole}");
    assert_eq!(r["references"]["slopes"][0], "finite-difference", "Middlebury has no slopes: the report says so");
    // Issue 15's done-when: RVS 4.0's 21.7 dB + 1 dB, no black pixel; the
    // never-seen strip reported apart from the holes.
    assert!(whole >= 22.7, "{whole}");
    assert_eq!(f["empty_samples"], 0);
    let unseen = f["unseen_fraction"].as_f64().unwrap();
    assert!((0.02..0.06).contains(&unseen), "the right border strip is about 3.7 % of the image: {unseen}");
    assert_eq!(unseen, f["unseen_pixels"].as_f64().unwrap() / f["display_pixels"].as_f64().unwrap());
    assert!(f["hole_fraction"].as_f64().unwrap() > unseen, "holes inside the image come on top of the strip");
    assert_eq!(r["mean"]["unseen_fraction"], f["unseen_fraction"], "one frame: the mean is the frame");
    let common = f["psnr_rgb_common_db"].as_f64().unwrap();
    assert!(common > whole && f["common_pixels"].as_u64() < f["covered_pixels"].as_u64(), "{common}");
}

#[test]
fn every_report_key_is_documented() {
    let doc = std::fs::read_to_string(root().join("docs/report.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (_, r) = golden("slants", dir.path(), &[]);
    for key in r["frames"][0].as_object().unwrap().keys() {
        assert!(doc.contains(&format!("| `{key}` |")), "docs/report.md lacks `{key}`");
    }
    for key in r.as_object().unwrap().keys() {
        // The key lists give top-level keys as table rows too
        // (`tests/report_docs.rs` checks every nested key and its unit).
        assert!(doc.contains(&format!("| `{key}` |")), "docs/report.md lacks top-level `{key}`");
    }
}
