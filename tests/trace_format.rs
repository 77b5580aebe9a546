//! Trace format v1 (still read by this v2 build): round trips, and every
//! error names the file and line. v2's layers: `tests/trace_layers.rs`.

use glam::{DQuat, DVec3};
use postwarp::trace::{
    Display, SlopeSource, Trace, TraceError, TraceWriter, TruthImage, format_manifest, parse_manifest,
};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage};
use std::path::Path;

use crate::common;

fn camera(w: u32, h: u32, x: f64, yaw: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics { width: w, height: h, fx: 20.5, fy: 20.25, cx: (w as f64 - 1.0) / 2.0, cy: 3.1 },
        pose: Pose { position: DVec3::new(x, 1.6, -0.1), orientation: DQuat::from_rotation_y(yaw) },
    }
}

fn samples(w: u32, h: u32, seed: f32) -> SampleImage {
    let mut s = SampleImage::empty(w, h);
    for i in 0..s.len() {
        s.colour[i] = [seed * 0.1, (i % 7) as f32 / 7.0, 0.5];
        s.z[i] = 2.0 + i as f32 * 0.01 + seed;
        s.inv_z_slopes[i] = [0.001 * i as f32, -0.002];
        s.object_id[i] = (i % 3) as u32;
        s.valid.set(i, i % 11 != 0);
    }
    s
}

/// A small trace on disk: 2 references (6x4 px, ss 2), 2 derived frames (4x3).
fn write_trace(dir: &Path) -> Trace {
    let display = Display { width: 4, height: 3, supersample: 2 };
    let mut w = TraceWriter::new(dir, display).unwrap();
    w.note("made by the trace_format test");
    let a = w.add_reference(0.0, camera(6, 4, 0.0, 0.0), &samples(12, 8, 0.0), SlopeSource::Exact).unwrap();
    let b = w.add_reference(0.2, camera(6, 4, 0.1, 0.05), &samples(12, 8, 1.0), SlopeSource::FiniteDifference).unwrap();
    let truth = TruthImage {
        width: 4,
        height: 3,
        colour: (0..12).map(|i| [i as f32 / 12.0, 0.25, 0.75]).collect(),
        known: (0..12).map(|i| i != 5).collect(),
        nondiffuse: None,
        seen: Some((0..12).map(|i| i % 3 != 0).collect()),
    };
    w.add_derived(1.0 / 30.0, camera(4, 3, 0.02, 0.01), vec![a, b], Some(&truth)).unwrap();
    w.add_derived(2.0 / 30.0, camera(4, 3, 0.04, 0.02), vec![b, a], None).unwrap();
    w.finish().unwrap();
    Trace::open(dir).unwrap()
}

#[test]
fn manifest_print_parse_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let t = write_trace(dir.path());
    let text = format_manifest(&t);
    let back = parse_manifest(&text, &t.manifest).unwrap();
    assert_eq!(back.display, t.display);
    assert_eq!(back.notes, t.notes);
    assert_eq!(back.references, t.references);
    assert_eq!(back.derived, t.derived);
    assert_eq!(format_manifest(&back), text);
}

#[test]
fn images_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let t = write_trace(dir.path());
    let r0 = t.load_reference(0).unwrap();
    assert_eq!(r0.slopes, SlopeSource::Exact);
    let want = samples(12, 8, 0.0);
    assert_eq!(r0.samples.valid, want.valid);
    assert_eq!(r0.samples.object_id, want.object_id);
    for i in want.valid.iter_ones() {
        assert_eq!(r0.samples.z[i], want.z[i], "depth is stored as float, exactly");
        assert_eq!(r0.samples.inv_z_slopes[i], want.inv_z_slopes[i]);
        for k in 0..3 {
            // colour is stored as half: within half precision.
            assert!((r0.samples.colour[i][k] - want.colour[i][k]).abs() <= want.colour[i][k].abs() / 1024.0 + 1e-6);
        }
    }
    let r1 = t.load_reference(1).unwrap();
    assert_eq!(r1.slopes, SlopeSource::FiniteDifference, "slopes absent are computed, and said so");
    let truth = t.load_truth(0).unwrap().expect("frame 0 has truth");
    assert!(!truth.known[5] && truth.known[4]);
    assert!(t.load_truth(1).unwrap().is_none());
    // Frame commands carry the cameras on the sample grid.
    let cmd = t.frame_commands(0);
    assert_eq!(cmd.warps.len(), 2);
    assert_eq!(cmd.warps[0].reference_camera.intrinsics.width, 12);
}

const GOOD: &str = "postwarp-trace 1
display width=4 height=3 supersample=2
reference 0 time=0 image=a.exr size=6x4 fx=20 fy=20 cx=2.5 cy=1.5 position=0,0,0 orientation=0,0,0,1
derived 0 time=0.1 refs=0 fx=20 fy=20 cx=1.5 cy=1 position=0.1,0,0 orientation=0,0,0,1
";

/// Replace line `n` (1-based) of GOOD with `line` and parse.
fn parse_with(n: usize, line: &str) -> TraceError {
    let mut lines: Vec<&str> = GOOD.lines().collect();
    lines[n - 1] = line;
    let text = lines.join("\n") + "\n";
    parse_manifest(&text, Path::new("t/postwarp.trace")).expect_err(line)
}

fn assert_err(e: &TraceError, line: usize, needle: &str) {
    let msg = e.to_string();
    assert_eq!(e.line, Some(line), "{msg}");
    assert!(msg.starts_with(&format!("t/postwarp.trace:{line}: ")), "{msg}");
    assert!(msg.contains(needle), "`{msg}` should mention `{needle}`");
}

#[test]
fn good_manifest_parses() {
    let t = parse_manifest(GOOD, Path::new("t/postwarp.trace")).unwrap();
    assert_eq!(t.references.len(), 1);
    assert_eq!(t.derived[0].references, vec![0]);
}

#[test]
fn unknown_version_is_an_error_naming_line_1() {
    assert_err(&parse_with(1, "postwarp-trace 3"), 1, "unsupported trace version 3");
    assert_err(&parse_with(1, "postwarp-trace 0"), 1, "reads versions 1 to 2");
    assert_err(&parse_with(1, "hello"), 1, "expected the version line");
}

#[test]
fn zero_and_absurd_sizes_are_errors() {
    assert_err(&parse_with(2, "display width=0 height=3 supersample=2"), 2, "width = 0");
    assert_err(&parse_with(2, "display width=16385 height=3 supersample=2"), 2, "expected 1 to 16384");
    assert_err(&parse_with(2, "display width=4 height=3 supersample=9"), 2, "supersample = 9");
    assert_err(&parse_with(2, "display width=16384 height=16384 supersample=4"), 2, "samples");
    let r = "reference 0 time=0 image=a.exr size=0x4 fx=20 fy=20 cx=2.5 cy=1.5 position=0,0,0 orientation=0,0,0,1";
    assert_err(&parse_with(3, r), 3, "width = 0");
    let r = "reference 0 time=0 image=a.exr size=6x99999 fx=20 fy=20 cx=2.5 cy=1.5 position=0,0,0 orientation=0,0,0,1";
    assert_err(&parse_with(3, r), 3, "height = 99999");
}

#[test]
fn malformed_statements_name_their_line() {
    let base = "reference 0 time=0 image=a.exr size=6x4 fx=20 fy=20 cx=2.5 cy=1.5 position=0,0,0 orientation=0,0,0,1";
    assert_err(&parse_with(3, &base.replace("fx=20", "fx=-1")), 3, "positive");
    assert_err(&parse_with(3, &base.replace("fx=20", "fx=NaN")), 3, "finite");
    assert_err(&parse_with(3, &base.replace("time=0", "time=inf")), 3, "finite");
    assert_err(&parse_with(3, &base.replace("position=0,0,0", "position=0,0")), 3, "expected 3 numbers");
    assert_err(&parse_with(3, &base.replace("orientation=0,0,0,1", "orientation=0,0,0,2")), 3, "unit quaternion");
    assert_err(&parse_with(3, &base.replace(" fy=20", "")), 3, "missing field `fy=`");
    assert_err(&parse_with(3, &format!("{base} colour=red")), 3, "unknown field `colour`");
    assert_err(&parse_with(3, &base.replace("reference 0", "reference 1")), 3, "expected 0");
    assert_err(&parse_with(3, "frobnicate 0"), 3, "unknown statement");
    let d = "derived 0 time=0.1 refs=3 fx=20 fy=20 cx=1.5 cy=1 position=0.1,0,0 orientation=0,0,0,1";
    assert_err(&parse_with(4, d), 4, "names reference 3");
    assert_err(&parse_with(4, &d.replace("refs=3", "refs=0,0")), 4, "twice");
    let many = (0..9).map(|i| i.to_string()).collect::<Vec<_>>().join(",");
    assert_err(&parse_with(4, &d.replace("refs=3", &format!("refs={many}"))), 4, "at most 8");
}

fn small_trace_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    write_trace(dir.path());
    dir
}

#[test]
fn missing_image_names_the_manifest_line() {
    let dir = small_trace_dir();
    std::fs::remove_file(dir.path().join("truth/0000.exr")).unwrap();
    let e = Trace::open(dir.path()).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("postwarp.trace:6:"), "{msg}");
    assert!(msg.contains("truth/0000.exr") && msg.contains("does not exist"), "{msg}");
}

#[test]
fn unreadable_image_names_the_file_and_manifest_line() {
    let dir = small_trace_dir();
    std::fs::write(dir.path().join("ref/0001.exr"), b"not an exr").unwrap();
    let t = Trace::open(dir.path()).unwrap();
    let msg = t.load_reference(1).unwrap_err().to_string();
    assert!(msg.contains("ref/0001.exr") && msg.contains("not a readable OpenEXR"), "{msg}");
    assert!(msg.contains("postwarp.trace:5)"), "{msg}");
}

#[test]
fn bad_depth_where_a_surface_is_claimed_is_an_error() {
    for (bad, what) in [(f32::NAN, "NaN"), (f32::INFINITY, "inf"), (0.0, "0"), (-1.0, "-1"), (1e-40, "1e-40")] {
        let dir = small_trace_dir();
        let mut s = samples(12, 8, 0.0);
        let i = s.index(3, 2);
        s.valid.set(i, true);
        s.z[i] = bad;
        postwarp::trace::write_reference_image(&dir.path().join("ref/0000.exr"), &s, SlopeSource::Exact).unwrap();
        let t = Trace::open(dir.path()).unwrap();
        let msg = t.load_reference(0).unwrap_err().to_string();
        assert!(msg.contains("ref/0000.exr") && msg.contains("sample (3, 2)"), "{what}: {msg}");
        assert!(msg.contains(&format!("Z = {what}")), "{what}: {msg}");
        assert!(msg.contains("postwarp.trace:4)"), "{msg}");
    }
}

#[test]
fn depth_without_a_surface_is_ignored() {
    let dir = small_trace_dir();
    let mut s = samples(12, 8, 0.0);
    s.valid.set(0, false);
    s.z[0] = f32::NAN;
    postwarp::trace::write_reference_image(&dir.path().join("ref/0000.exr"), &s, SlopeSource::Exact).unwrap();
    let r = Trace::open(dir.path()).unwrap().load_reference(0).unwrap();
    assert!(!r.samples.valid[0]);
}

#[test]
fn image_of_the_wrong_size_is_an_error() {
    let dir = small_trace_dir();
    postwarp::trace::write_reference_image(&dir.path().join("ref/0000.exr"), &samples(10, 8, 0.0), SlopeSource::Exact)
        .unwrap();
    let msg = Trace::open(dir.path()).unwrap().load_reference(0).unwrap_err().to_string();
    assert!(msg.contains("image is 10x8; expected 12x8"), "{msg}");
}

#[test]
fn missing_manifest_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let msg = Trace::open(&dir.path().join("nothing")).unwrap_err().to_string();
    assert!(msg.contains("nothing: does not exist; expected the trace manifest"), "{msg}");
    let empty = dir.path().join("empty.trace");
    std::fs::write(&empty, "").unwrap();
    let msg = Trace::open(&empty).unwrap_err().to_string();
    assert!(msg.contains("empty.trace:1:"), "{msg}");
}

/// Write an EXR of 12x8 samples with exactly the given channels.
fn write_exr(path: &Path, channels: Vec<(&str, exr::prelude::FlatSamples)>) {
    use exr::prelude::*;
    let list: Vec<AnyChannel<FlatSamples>> = channels.into_iter().map(|(n, s)| AnyChannel::new(n, s)).collect();
    let layer = Layer::new(
        (12, 8),
        LayerAttributes::named("t"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(list.into_iter().collect()),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

fn f32s(v: f32) -> exr::prelude::FlatSamples {
    exr::prelude::FlatSamples::F32(vec![v; 96])
}

/// Replace reference 0's image by one with `channels`, and load it.
fn load_with(channels: Vec<(&str, exr::prelude::FlatSamples)>) -> String {
    let dir = small_trace_dir();
    write_exr(&dir.path().join("ref/0000.exr"), channels);
    let t = Trace::open(dir.path()).unwrap();
    let msg = t.load_reference(0).unwrap_err().to_string();
    assert!(msg.contains("ref/0000.exr") && msg.contains("postwarp.trace:4)"), "{msg}");
    msg
}

fn rgbz() -> Vec<(&'static str, exr::prelude::FlatSamples)> {
    vec![("R", f32s(0.5)), ("G", f32s(0.5)), ("B", f32s(0.5)), ("Z", f32s(2.0))]
}

#[test]
fn every_image_channel_error_is_named() {
    // A well-formed image loads.
    let dir = small_trace_dir();
    write_exr(&dir.path().join("ref/0000.exr"), rgbz());
    assert!(Trace::open(dir.path()).unwrap().load_reference(0).is_ok());

    let mut no_z = rgbz();
    no_z.pop();
    assert!(load_with(no_z).contains("missing channel `Z`"));

    let mut no_g = rgbz();
    no_g.remove(1);
    assert!(load_with(no_g).contains("missing colour channel `G`"));

    let mut one_slope = rgbz();
    one_slope.push(("dinvz_dx", f32s(0.0)));
    assert!(load_with(one_slope).contains("expected both or neither"));

    let mut uint_z = rgbz();
    uint_z[3] = ("Z", exr::prelude::FlatSamples::U32(vec![2; 96]));
    assert!(load_with(uint_z).contains("channel `Z` is uint"));

    let mut float_id = rgbz();
    float_id.push(("id", f32s(1.0)));
    assert!(load_with(float_id).contains("channel `id` is half or float; expected uint"));

    let mut nan_colour = rgbz();
    nan_colour[0] = ("R", f32s(f32::NAN));
    assert!(load_with(nan_colour).contains("is not finite"));

    let mut inf_slope = rgbz();
    inf_slope.push(("dinvz_dx", f32s(f32::INFINITY)));
    inf_slope.push(("dinvz_dy", f32s(0.0)));
    assert!(load_with(inf_slope).contains("slope"));

    let mut bad_valid = rgbz();
    bad_valid.push(("valid", f32s(0.5)));
    assert!(load_with(bad_valid).contains("`valid` = 0.5; expected 0 or 1"));
}

#[test]
fn the_documented_example_parses() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/trace-format.md")).unwrap();
    let ex = doc.find("Example: the first lines").expect("example paragraph");
    let start = ex + doc[ex..].find("```\n").expect("example block") + 4;
    let end = start + doc[start..].find("```").unwrap();
    let t = parse_manifest(&doc[start..end], Path::new("docs/trace-format.md")).unwrap();
    assert_eq!(t.display.width, 128);
    assert_eq!(t.derived[0].references, vec![0, 1]);
}

/// The bytes of a 12x8 EXR with exactly the given channels.
fn exr_bytes(channels: Vec<(&str, exr::prelude::FlatSamples)>) -> Vec<u8> {
    use exr::prelude::*;
    let list: Vec<AnyChannel<FlatSamples>> = channels.into_iter().map(|(n, s)| AnyChannel::new(n, s)).collect();
    let layer = Layer::new(
        (12, 8),
        LayerAttributes::named("t"),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(list.into_iter().collect()),
    );
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).unwrap();
    out.into_inner()
}

fn decode(bytes: &[u8], expected: (u32, u32)) -> Result<postwarp::trace::LoadedReference, String> {
    postwarp::trace::decode_reference_image(bytes, Path::new("d/img.exr"), expected).map_err(|e| e.to_string())
}

#[test]
fn absurd_header_size_is_refused_before_decoding() {
    let mut b = exr_bytes(rgbz());
    assert!(decode(&b, (12, 8)).is_ok());
    // dataWindow = box2i (xMin, yMin, xMax, yMax): claim 10^9 x 10^9 pixels.
    let at = b.windows(17).position(|w| w == b"dataWindow\0box2i\0").expect("dataWindow attribute") + 17 + 4;
    for (k, v) in [(8, 999_999_999i32), (12, 999_999_999)] {
        b[at + k..at + k + 4].copy_from_slice(&v.to_le_bytes());
    }
    for expected in [(12, 8), (16384, 16384)] {
        let msg = decode(&b, expected).unwrap_err();
        assert!(msg.starts_with("d/img.exr: image is 1000000000x1000000000; expected"), "{msg}");
    }
}

#[test]
fn multi_part_or_subsampled_images_are_refused() {
    use exr::prelude::*;
    let layer = |name: &str| {
        let list: Vec<AnyChannel<FlatSamples>> = rgbz().into_iter().map(|(n, s)| AnyChannel::new(n, s)).collect();
        Layer::new((12, 8), LayerAttributes::named(name), Encoding::UNCOMPRESSED, AnyChannels::sort(list.into()))
    };
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((12, 8))), vec![layer("a"), layer("b")])
        .write()
        .to_buffered(&mut out)
        .unwrap();
    let msg = decode(out.get_ref(), (12, 8)).unwrap_err();
    assert!(msg.contains("has 2 parts; expected a single-part"), "{msg}");

    // exr writes no subsampled channels: patch the channel list instead
    // (name, NUL, pixel type i32, pLinear u8, 3 reserved, xSampling i32, ySampling i32).
    let mut channels = rgbz();
    channels.push(("dinvz_dx", f32s(0.0)));
    channels.push(("dinvz_dy", f32s(0.0)));
    let mut b = exr_bytes(channels);
    let at = b.windows(9).position(|w| w == b"dinvz_dx\0").expect("channel list entry") + 9 + 8;
    for k in [0, 4] {
        b[at + k..at + k + 4].copy_from_slice(&2i32.to_le_bytes());
    }
    let msg = decode(&b, (12, 8)).unwrap_err();
    assert!(msg.contains("channel `dinvz_dx` is subsampled (2x2)"), "{msg}");
}

/// A manifest cut off mid-line (the example of issue 17: five of six
/// derived frames gone, the last orientation cut mid-number) is an error at
/// the cut; one cut at a line break still ends in one, so only mid-line
/// cuts are caught this way, and those are what an interrupted copy leaves.
#[test]
fn a_manifest_cut_mid_line_is_an_error_at_the_cut() {
    let dir = small_trace_dir();
    let text = std::fs::read_to_string(dir.path().join("postwarp.trace")).unwrap();
    let cut = &text[..text.rfind("orientation=").unwrap() + "orientation=0.9".len()];
    let lines = cut.lines().count();
    let e = parse_manifest(cut, Path::new("t/postwarp.trace")).unwrap_err();
    assert_eq!(e.line, Some(lines), "{e}");
    assert!(e.to_string().contains("cut off (truncated)"), "{e}");
    // Cut in the middle of a statement's fields: the same, not "missing field".
    let cut = &text[..text.rfind(" fx=").unwrap()];
    let e = parse_manifest(cut, Path::new("t/postwarp.trace")).unwrap_err();
    assert!(e.to_string().contains("cut off"), "{e}");
    // An earlier error is still reported as itself.
    let bad = cut.replacen("display width=4", "display width=0", 1);
    let e = parse_manifest(&bad, Path::new("t/postwarp.trace")).unwrap_err();
    assert_eq!(e.line, Some(3), "{e}");
}

/// Only regular files are opened: a directory or a symbolic-link loop given
/// where an image is expected is named for what it is, a FIFO manifest is
/// refused without blocking, a byte-order mark is named.
#[test]
fn inputs_that_are_not_regular_files_are_named_for_what_they_are() {
    let dir = small_trace_dir();
    let truth = dir.path().join("truth/0000.exr");
    std::fs::remove_file(&truth).unwrap();
    std::fs::create_dir(&truth).unwrap();
    let msg = Trace::open(dir.path()).unwrap_err().to_string();
    assert!(msg.contains("truth/0000.exr: is a directory; expected the image file"), "{msg}");
    assert!(msg.contains("postwarp.trace:6:"), "{msg}");
    #[cfg(unix)]
    {
        std::fs::remove_dir(&truth).unwrap();
        std::os::unix::fs::symlink(&truth, &truth).unwrap();
        let msg = Trace::open(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("symbolic link that cannot be resolved"), "{msg}");
        let fifo = dir.path().join("fifo.trace");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        // Bounded: a reader that opened it would get end of file, not hang.
        let msg = common::fifo::unblocked(&fifo, || Trace::open(&fifo).unwrap_err().to_string());
        assert!(msg.contains("fifo.trace: is a FIFO (named pipe); expected the trace manifest"), "{msg}");
    }
    let m = dir.path().join("postwarp.trace");
    let text = std::fs::read_to_string(&m).unwrap();
    std::fs::write(&m, format!("\u{feff}{text}")).unwrap();
    let msg = Trace::open(dir.path()).unwrap_err().to_string();
    assert!(msg.contains("byte-order mark"), "{msg}");
    let e = parse_manifest(&format!("\u{feff}{text}"), &m).unwrap_err();
    assert!(e.to_string().contains(":1: line 1 starts with a UTF-8 byte-order mark"), "{e}");
}
