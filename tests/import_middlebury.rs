//! Import the bundled Middlebury 2014 "Motorcycle" quarter-size pair and
//! check the trace against the source files, read independently of the
//! importer (the disparity is parsed here, not with `postwarp::import::pfm`).

use glam::DVec3;
use postwarp::import::FillUnknownDepth;
use postwarp::import::middlebury::{ImportError, import_middlebury, import_middlebury_with};
use postwarp::picture::linear_to_srgb8;
use postwarp::trace::{SlopeSource, Trace};
use std::path::{Path, PathBuf};

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/middlebury2014-motorcycle-quarter")
}

// Values of the bundled calib.txt.
const F: f64 = 994.978;
const DOFFS: f64 = 31.086;
const BASELINE_MM: f64 = 193.001;
const W: u32 = 741;
const H: u32 = 500;

/// The disparity, rows top-to-bottom, parsed from the PFM bytes by hand:
/// header `Pf\n741 500\n-1\n` (checked), little-endian, rows bottom-to-top.
fn disparity() -> Vec<f32> {
    let bytes = std::fs::read(data_dir().join("disp0.pfm")).unwrap();
    let mut lines = bytes.splitn(4, |&b| b == b'\n');
    assert_eq!(lines.next().unwrap(), b"Pf");
    assert_eq!(lines.next().unwrap(), format!("{W} {H}").as_bytes());
    let scale: f64 = std::str::from_utf8(lines.next().unwrap()).unwrap().trim().parse().unwrap();
    assert!(scale < 0.0, "bundled file is little-endian");
    let data = lines.next().unwrap();
    assert_eq!(data.len(), (W * H * 4) as usize);
    let (w, h) = (W as usize, H as usize);
    let mut out = vec![0.0f32; w * h];
    for (i, c) in data.chunks_exact(4).enumerate() {
        let (x, file_row) = (i % w, i / w);
        out[(h - 1 - file_row) * w + x] = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    }
    out
}

fn import(fill: FillUnknownDepth) -> (tempfile::TempDir, Trace) {
    let out = tempfile::tempdir().unwrap();
    let manifest = import_middlebury_with(&data_dir(), out.path(), fill).unwrap();
    assert!(manifest.is_file(), "{}", manifest.display());
    let t = Trace::open(&manifest).unwrap();
    (out, t)
}

#[test]
fn bundled_pair_imports_with_depth_cameras_and_truth() {
    let (_out, t) = import(FillUnknownDepth::None);
    let disp = disparity();
    assert_eq!((t.display.width, t.display.height, t.display.supersample), (W, H, 1));
    assert_eq!(t.references.len(), 1);
    assert_eq!(t.derived.len(), 1);
    assert_eq!(t.derived[0].references, vec![0]);
    assert_eq!((t.references[0].time_s, t.derived[0].time_s), (0.0, 0.0));
    let notes = t.notes.join("\n");
    for want in ["middlebury2014-motorcycle-quarter", "Scharstein et al., GCPR 2014", "metres", "doffs"] {
        assert!(notes.contains(want), "notes lack {want:?}:\n{notes}");
    }

    // Cameras.
    let left = t.references[0].camera;
    let right = t.derived[0].camera;
    assert_eq!(
        (left.intrinsics.fx, left.intrinsics.fy, left.intrinsics.cx, left.intrinsics.cy),
        (F, F, 311.193, 254.877)
    );
    assert_eq!((right.intrinsics.cx, right.intrinsics.cy), (342.279, 254.877));
    assert_eq!((left.intrinsics.width, left.intrinsics.height), (W, H));
    assert_eq!(left.pose.position, DVec3::ZERO);
    assert_eq!(right.pose.position, DVec3::new(BASELINE_MM / 1000.0, 0.0, 0.0));

    // Depth, validity, ids, slopes.
    let r = t.load_reference(0).unwrap();
    assert_eq!(r.slopes, SlopeSource::FiniteDifference);
    let s = &r.samples;
    assert_eq!((s.width, s.height), (W, H));
    let first_hole = disp.iter().position(|d| !d.is_finite()).expect("bundled data has unknown pixels");
    let hx = (first_hole % W as usize) as u32;
    let hy = (first_hole / W as usize) as u32;
    let probes = [(0, 0), (370, 250), (740, 499), (100, 400), (600, 80), (hx, hy)];
    let mut checked_valid = 0;
    for (x, y) in probes {
        let i = (y * W + x) as usize;
        let d = disp[i];
        if !d.is_finite() {
            assert!(!s.valid[i], "pixel ({x}, {y}) has disparity {d} but is valid");
            continue;
        }
        checked_valid += 1;
        assert!(s.valid[i], "pixel ({x}, {y}) with disparity {d} is not valid");
        let z = BASELINE_MM * F / (d as f64 + DOFFS) / 1000.0;
        let rel = (s.z[i] as f64 - z).abs() / z;
        assert!(rel < 1e-6, "pixel ({x}, {y}): Z {} vs {z} (d = {d})", s.z[i]);

        // Right camera: the left pixel's 3D point projects to (x - d, y).
        let p = left.unproject(x as f64, y as f64, z);
        let (q, _) = right.project(p).unwrap();
        assert!((q.x - (x as f64 - d as f64)).abs() < 1e-6, "({x}, {y}) d={d}: x' = {}", q.x);
        assert!((q.y - y as f64).abs() < 1e-6, "({x}, {y}): y' = {}", q.y);
        // The same through the stored f32 depth (looser: f32 rounding of Z).
        let (q, _) = right.project(left.unproject(x as f64, y as f64, s.z[i] as f64)).unwrap();
        assert!((q.x - (x as f64 - d as f64)).abs() < 1e-4, "({x}, {y}) stored Z: x' = {}", q.x);
    }
    assert!(checked_valid >= 4, "too few valid probes: {checked_valid}");
    assert!(!s.valid[first_hole]);

    // The whole mask: valid exactly where the disparity is finite (every
    // finite disparity here gives a positive depth).
    let finite = disp.iter().filter(|d| d.is_finite()).count();
    for (i, d) in disp.iter().enumerate() {
        assert_eq!(s.valid[i], d.is_finite(), "pixel {i}, disparity {d}");
    }
    assert!(s.object_id.iter().all(|&id| id == 0));
    let frac = s.valid.count_ones() as f64 / s.len() as f64;
    assert_eq!(s.valid.count_ones(), finite);
    eprintln!("valid left pixels: {} of {} = {:.4} %", finite, s.len(), 100.0 * frac);
    assert!((0.92..0.935).contains(&frac), "README says 7.3 % unknown; got valid fraction {frac}");

    // Colour of the reference: im0 round-trips to its sRGB codes.
    let im0 = image::open(data_dir().join("im0.png")).unwrap().to_rgb8();
    let im1 = image::open(data_dir().join("im1.png")).unwrap().to_rgb8();
    let truth = t.load_truth(0).unwrap().expect("derived frame has ground truth");
    assert_eq!((truth.width, truth.height), (W, H));
    assert!(truth.known.all(), "every truth pixel is known");
    for (x, y) in [(0, 0), (1, 0), (370, 250), (740, 499), (123, 456), (hx, hy)] {
        let i = (y * W + x) as usize;
        assert_eq!(truth.colour[i].map(linear_to_srgb8), im1.get_pixel(x, y).0, "truth pixel ({x}, {y})");
        assert_eq!(s.colour[i].map(linear_to_srgb8), im0.get_pixel(x, y).0, "reference pixel ({x}, {y})");
    }
}

fn copy_folder(to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(data_dir()).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

fn import_err(src: &Path) -> ImportError {
    let out = tempfile::tempdir().unwrap();
    import_middlebury(src, &out.path().join("trace")).unwrap_err()
}

#[test]
fn missing_folder_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("no-such-folder");
    let msg = import_err(&src).to_string();
    assert!(msg.contains("no-such-folder") && msg.contains("not a directory"), "{msg}");
}

#[test]
fn missing_disparity_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("pair");
    copy_folder(&src);
    std::fs::remove_file(src.join("disp0.pfm")).unwrap();
    let msg = import_err(&src).to_string();
    assert!(msg.contains("disp0.pfm") && msg.contains("missing"), "{msg}");
}

#[test]
fn calib_without_baseline_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("pair");
    copy_folder(&src);
    let calib = std::fs::read_to_string(src.join("calib.txt")).unwrap();
    let broken: String = calib.lines().filter(|l| !l.starts_with("baseline")).map(|l| format!("{l}\n")).collect();
    assert_ne!(broken, calib);
    std::fs::write(src.join("calib.txt"), broken).unwrap();
    let e = import_err(&src);
    let msg = e.to_string();
    assert!(msg.contains("calib.txt") && msg.contains("baseline"), "{msg}");
    assert!(matches!(e, ImportError::Input { ref file, .. } if file.ends_with("calib.txt")), "{e:?}");
}

#[test]
fn truncated_disparity_is_named() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("pair");
    copy_folder(&src);
    let bytes = std::fs::read(src.join("disp0.pfm")).unwrap();
    std::fs::write(src.join("disp0.pfm"), &bytes[..bytes.len() / 2]).unwrap();
    let msg = import_err(&src).to_string();
    assert!(msg.contains("disp0.pfm") && msg.contains("truncated"), "{msg}");
}

/// `--fill-unknown-depth background` changes only the samples whose
/// disparity is unknown: each takes the depth of the farther (smaller
/// disparity) of its nearest known row neighbours; every measured sample,
/// every colour and the whole ground truth stay as with `none`.
#[test]
fn filling_unknown_depth_changes_only_the_unknown_samples() {
    let disp = disparity();
    let (_a, none) = import(FillUnknownDepth::None);
    let (_b, bg) = import(FillUnknownDepth::Background);
    let (n, b) = (none.load_reference(0).unwrap().samples, bg.load_reference(0).unwrap().samples);
    assert_eq!(n.colour, b.colour);
    let depth = |d: f32| (BASELINE_MM * F / (d as f64 + DOFFS) / 1000.0) as f32;
    let w = W as usize;
    let mut filled = 0;
    for (i, &d) in disp.iter().enumerate() {
        if d.is_finite() {
            assert!(n.valid[i] && b.valid[i], "measured sample {i}");
            assert_eq!(n.z[i].to_bits(), b.z[i].to_bits(), "measured sample {i}: depth changed");
            continue;
        }
        assert!(!n.valid[i], "unknown sample {i} has a surface without the fill");
        let (x, row) = (i % w, &disp[i - i % w..i - i % w + w]);
        let left = row[..x].iter().rev().find(|d| d.is_finite());
        let right = row[x + 1..].iter().find(|d| d.is_finite());
        let want = match (left, right) {
            (Some(&l), Some(&r)) => Some(l.min(r)),
            (l, r) => l.or(r).copied(),
        };
        match want {
            Some(d) => {
                assert!(b.valid[i], "unknown sample {i} not filled");
                assert_eq!(b.z[i].to_bits(), depth(d).to_bits(), "sample {i}: the farther neighbour's depth");
                filled += 1;
            }
            None => assert!(!b.valid[i]),
        }
    }
    assert!(filled > 20_000, "7.35 % of the pixels are unknown: {filled} filled");
    let (tn, tb) = (none.load_truth(0).unwrap().unwrap(), bg.load_truth(0).unwrap().unwrap());
    assert_eq!((tn.colour, tn.known, tn.seen.clone()), (tb.colour, tb.known, tb.seen));
}

/// The truth's `seen` mask: the right view's pixels the left view sees.
/// The strip past the smallest disparity (7.2 px) at the right border is
/// unseen on every row; most of the image is seen.
#[test]
fn the_truth_marks_what_the_left_view_sees() {
    let (_out, t) = import(FillUnknownDepth::default());
    let seen = t.load_truth(0).unwrap().unwrap().seen.expect("imported truth has a seen mask");
    let (w, h) = (W as usize, H as usize);
    for y in 0..h {
        for x in w - 7..w {
            assert!(!seen[y * w + x], "({x}, {y}) lies beyond the left view");
        }
    }
    let share = seen.count_ones() as f64 / seen.len() as f64;
    assert!((0.80..0.88).contains(&share), "seen share {share}");
}
