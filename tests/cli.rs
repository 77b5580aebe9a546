//! The `postwarp` binary end to end, as a user runs it.

use std::path::Path;
use std::process::Command;

fn postwarp(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().expect("run postwarp")
}

fn ok(args: &[&str]) -> String {
    let out = postwarp(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "postwarp {args:?} failed: {stderr}");
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn every_subcommand_has_help() {
    let top = ok(&["--help"]);
    for sub in ["info", "make-trace", "import-middlebury", "golden"] {
        assert!(top.contains(sub), "{sub} missing from --help");
        let h = ok(&[sub, "--help"]);
        assert!(h.len() > 200, "{sub} --help too short: {h}");
    }
}

#[test]
fn make_trace_then_info_reads_it_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t");
    let out_s = out.to_str().unwrap();
    ok(&["make-trace", "--scene", "room", "--out", out_s, "--width", "32", "--height", "24", "--frames", "7"]);
    let info = ok(&["info", out_s]);
    // 7 derived frames at 30 Hz span 0.2 s: references at 0, 0.2 and 0.4 s.
    assert!(info.contains("reference frames: 3"), "{info}");
    assert!(info.contains("derived frames: 7"), "{info}");
    assert!(info.contains("display    32x24 px, 2x2 samples"), "{info}");
    assert!(info.contains("exact"), "rendered traces carry exact slopes: {info}");
    assert!(out.join("preview/truth-0000.png").is_file());
    // Frame 6 (t = 0.2 s) warps references 1 and 2.
    assert!(info.lines().any(|l| l.trim_start().starts_with("6 ") && l.contains("1,2")), "{info}");
}

#[test]
fn make_trace_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str| {
        let out = dir.path().join(name);
        ok(&[
            "make-trace",
            "--scene",
            "occluders",
            "--out",
            out.to_str().unwrap(),
            "--width",
            "24",
            "--height",
            "18",
            "--frames",
            "2",
            "--path",
            "tracked",
        ]);
        out
    };
    let (a, b) = (run("a"), run("b"));
    for f in ["ref/0000.exr", "ref/0001.exr", "truth/0000.exr", "truth/0001.exr"] {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f} differs");
    }
    let strip = |p: &Path| {
        std::fs::read_to_string(p.join("postwarp.trace"))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with("note made by"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(strip(&a), strip(&b));
}

#[test]
fn bad_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = postwarp(&["info", dir.path().join("missing").to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: ") && err.contains("missing"), "{err}");
    assert!(!err.contains("panicked"), "{err}");

    let out = postwarp(&["make-trace", "--scene", "nosuchscene", "--out", dir.path().to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("nosuchscene") && err.contains("room"), "{err}");

    let out = postwarp(&["make-trace", "--scene", "room", "--out", dir.path().to_str().unwrap(), "--supersample", "9"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--supersample"), "{err}");
}

#[test]
fn absurd_make_trace_sizes_and_rates_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let base = ["make-trace", "--scene", "room", "--out", out];
    for (extra, want) in [
        // 2^32 samples per display frame (was rendered, then refused by the parser, or ran out of memory).
        (
            &["--width", "16384", "--height", "16384", "--supersample", "4", "--ref-fov", "5x5"][..],
            "display frames of 16384x16384 pixels at 4x4 samples would hold 4294967296 samples",
        ),
        // References of about 15286x7094 px at 4x4 samples (the display itself fits).
        (
            &[
                "--width",
                "4096",
                "--height",
                "2048",
                "--supersample",
                "4",
                "--display-hfov",
                "90",
                "--ref-fov",
                "150x120",
            ],
            "reference frames of 1528",
        ),
        // Ratio of rates overflowing the reference count (was a panic: attempt to add with overflow).
        (&["--ref-rate", "1e300", "--derived-rate", "1e-300", "--frames", "2"], "reference frames at --ref-rate"),
    ] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let o = postwarp(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.starts_with("error: ") && err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!dir.path().join("postwarp.trace").exists(), "nothing is written");
}

#[test]
fn bundled_traces_are_readable() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("traces");
    let mut n = 0;
    for entry in std::fs::read_dir(&root).unwrap() {
        let p = entry.unwrap().path();
        if p.join("postwarp.trace").is_file() {
            let info = ok(&["info", p.to_str().unwrap()]);
            assert!(info.contains("derived frames:"), "{}: {info}", p.display());
            n += 1;
        }
    }
    assert!(n >= 5, "expected the four scene traces and Motorcycle in traces/, found {n}");
}
