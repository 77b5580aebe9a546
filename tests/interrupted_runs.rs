//! Output folders are never half-written: `make-trace`, `golden` and
//! `simulate` killed halfway (SIGKILL, no clean-up in the child) leave the
//! `--out` folder absent, or the complete old one; the next run removes the
//! leftover and writes it complete and new. An existing `--out` is refused
//! without `--force`, and two runs are never mixed.

#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn cmd(args: &[String]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_postwarp"));
    c.args(args).stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

fn run(args: &[String]) -> String {
    let o = cmd(args).output().unwrap();
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run's temporary folder beside `target`, once it holds a file.
fn staging_with_a_file(target: &Path) -> Option<PathBuf> {
    let name = target.file_name()?.to_string_lossy().into_owned();
    let prefix = format!(".{name}.postwarp-tmp-");
    for e in std::fs::read_dir(target.parent()?).ok()?.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        if n.starts_with(&prefix)
            && walk(&e.path()).iter().any(|f| f.extension().is_some_and(|x| x == "png" || x == "exr"))
        {
            return Some(e.path());
        }
    }
    None
}

/// Every file under `d`, sorted.
fn walk(d: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(d) else { return out };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() { out.extend(walk(&p)) } else { out.push(p) }
    }
    out.sort();
    out
}

/// Every file of `d` with its bytes, paths relative to `d`.
fn snapshot(d: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    walk(d).into_iter().map(|p| (p.strip_prefix(d).unwrap().to_path_buf(), std::fs::read(&p).unwrap())).collect()
}

/// Start `args` and kill it once its temporary folder holds an image (at
/// most 30 000 polls of 1 ms; a run that ends first is left to end).
/// Returns whether it was killed before finishing.
fn kill_halfway(args: &[String], target: &Path) -> bool {
    let mut child: Child = cmd(args).spawn().unwrap();
    for _ in 0..30_000 {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        if staging_with_a_file(target).is_some() {
            child.kill().unwrap();
            child.wait().unwrap();
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    true
}

/// A run's folder is complete: the trace loads with every image, or the
/// report loads with every frame's files.
fn assert_complete(kind: &str, dir: &Path, frames: usize) {
    match kind {
        "make-trace" => {
            let t = postwarp::trace::Trace::open(dir).unwrap();
            assert_eq!(t.derived.len(), frames);
            for i in 0..t.references.len() {
                t.load_reference(i).unwrap();
            }
            for i in 0..frames {
                t.load_truth(i).unwrap().unwrap();
            }
        }
        _ => {
            let r = postwarp::report::load(dir).unwrap();
            let n = match &r {
                postwarp::report::Report::Golden(g) => g.frames.len(),
                postwarp::report::Report::Simulate(s) => s.frames.len(),
                postwarp::report::Report::Method(m) => m.frames.len(),
            };
            assert_eq!(n, frames, "{kind}: report frames");
            for k in 0..frames {
                for f in [format!("frame-{k:04}.png"), format!("frame-{k:04}.exr"), format!("diff-{k:04}.png")] {
                    assert!(dir.join(&f).is_file(), "{kind}: {f} missing in {}", dir.display());
                }
            }
        }
    }
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".postwarp-"))
        .collect()
}

#[test]
fn killed_runs_leave_no_folder_or_the_old_one_and_the_next_run_is_complete() {
    let tmp = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.display().to_string();
    // A small trace for golden and simulate: 4 frames of 64x48.
    let trace = tmp.path().join("small");
    run(&[
        "make-trace",
        "--scene",
        "occluders",
        "--width",
        "64",
        "--height",
        "48",
        "--frames",
        "4",
        "--out",
        &s(&trace),
    ]
    .map(String::from));
    let mut killed = 0;
    for kind in ["make-trace", "golden", "simulate"] {
        let out = tmp.path().join(kind);
        let args = |force: bool| -> Vec<String> {
            let mut a: Vec<String> = match kind {
                "make-trace" => {
                    ["make-trace", "--scene", "occluders", "--width", "96", "--height", "72", "--frames", "4"]
                        .iter()
                        .map(|x| x.to_string())
                        .collect()
                }
                k => vec![k.to_string(), s(&trace)],
            };
            a.extend(["--out".to_string(), s(&out)]);
            if force {
                a.push("--force".into());
            }
            a
        };
        let frames = 4;
        // 1. Fresh target, killed: nothing under the target name.
        killed += kill_halfway(&args(false), &out) as usize;
        if out.exists() {
            assert_complete(kind, &out, frames);
        } else {
            // The next run reports and removes the leftover, and is complete.
            let err = run(&args(false));
            assert!(err.contains("left by an interrupted run"), "{kind}: {err}");
        }
        assert_complete(kind, &out, frames);
        assert!(leftovers(tmp.path()).is_empty(), "{kind}: {:?}", leftovers(tmp.path()));
        // 2. Without --force an existing folder is refused and left alone.
        let before = snapshot(&out);
        let o = cmd(&args(false)).output().unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("already exists; give --force"), "{kind}: {err}");
        assert_eq!(err.matches("error:").count(), 1, "{kind}: printed once: {err}");
        assert_eq!(snapshot(&out), before);
        // 3. --force, killed: the complete old folder, byte for byte.
        killed += kill_halfway(&args(true), &out) as usize;
        let after = snapshot(&out);
        if after != before {
            assert_complete(kind, &out, frames);
        }
        // 4. --force to the end: complete and new (no file of another run).
        run(&args(true));
        assert_complete(kind, &out, frames);
        assert!(leftovers(tmp.path()).is_empty(), "{kind}: {:?}", leftovers(tmp.path()));
    }
    assert!(killed >= 3, "only {killed} of 6 runs were caught halfway: the test did not interrupt anything");
}

/// Two runs into one --out at once: both finish, one wins whole, the other
/// is refused; the folder never holds frames of both.
#[test]
fn two_runs_into_one_folder_are_not_mixed() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("o");
    let golden = |m: &str| -> Vec<String> {
        let t = root().join("traces/occluders").display().to_string();
        let mut a = vec!["golden".to_string(), t, "--out".into(), out.display().to_string()];
        if m != "mark-aa" {
            a.extend(["--method".to_string(), m.to_string(), "--runs".into(), "1".into()]);
        }
        a
    };
    let a = cmd(&golden("mark-aa")).spawn().unwrap();
    let b = cmd(&golden("forward-splat")).spawn().unwrap();
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    assert!(a.status.success() != b.status.success(), "exactly one wins: {a:?} {b:?}");
    let loser = if a.status.success() { &b } else { &a };
    let err = String::from_utf8_lossy(&loser.stderr);
    assert!(err.contains("already exists") || err.contains("appeared while this run was working"), "{err}");
    let r = postwarp::report::load(&out).unwrap();
    let want = if a.status.success() { "mark-aa" } else { "forward-splat" };
    let method = match r {
        postwarp::report::Report::Golden(g) => g.method,
        postwarp::report::Report::Method(m) => m.method,
        other => panic!("{other:?}"),
    };
    assert_eq!(method, want);
    // The golden model writes EXR frames, the method does not: no mix.
    let exr = out.join("frame-0000.exr").exists();
    assert_eq!(exr, want == "mark-aa", "frames of the other run in the folder");
    assert!(leftovers(tmp.path()).is_empty(), "{:?}", leftovers(tmp.path()));
}
