//! Trace format v2's layers (`docs/trace-format.md`, "Layers"): transparent
//! fragments and ray trees round-trip through the writer and the reader; v1
//! traces still load; malformed `layer` statements and layer images are
//! errors naming the file and the line; `make-trace --scene gallery` writes
//! a v2 trace that `info` reads and `simulate` says it ignored.

use glam::{DQuat, DVec3};
use postwarp::trace::layers::{
    Fragment, FragmentLayer, LayerStatement, Layers, Node, RayTreeLayer, SpecularMaterial, read_fragment_layer,
};
use postwarp::trace::{Display, SlopeSource, Trace, TraceError, TraceWriter, TruthImage, parse_manifest};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn postwarp(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().expect("run postwarp")
}

fn camera(w: u32, h: u32, x: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics { width: w, height: h, fx: 20.0, fy: 20.0, cx: (w as f64 - 1.0) / 2.0, cy: 1.5 },
        pose: Pose { position: DVec3::new(x, 1.0, 0.0), orientation: DQuat::IDENTITY },
    }
}

/// 12x8 samples (a 6x4-pixel reference at 2x2).
fn samples() -> SampleImage {
    let mut s = SampleImage::empty(12, 8);
    for i in 0..s.len() {
        s.colour[i] = [0.5, 0.25, 0.125];
        s.z[i] = 3.0 + i as f32 * 0.01;
        s.valid.set(i, true);
    }
    s
}

/// Layers whose values are exact in half precision (colours, opacity).
fn layers() -> Layers {
    let mut f = FragmentLayer::empty(12, 8, 3);
    for i in 0..f.len() {
        f.opaque[i] = [0.75, 0.5, 0.25];
        let n = (i % 4).min(3);
        f.count[i] = n as u8;
        for k in 0..n {
            f.fragments[i * 3 + k] = Fragment {
                colour: [0.25 * k as f32, 0.5, 1.0],
                alpha: 0.125 * (k + 1) as f32,
                z: 1.0 + k as f32 * 0.5,
            };
        }
    }
    let mut t = RayTreeLayer::empty(12, 8, vec![SpecularMaterial::Mirror, SpecularMaterial::Dielectric { ior: 1.5 }]);
    for i in 0..t.len() {
        t.nodes[Node::Diffuse as usize].colour[i] = [0.5, 0.5, 0.5];
        t.nodes[Node::Diffuse as usize].depth[i] = 3.0 + i as f32 * 0.01;
        t.valid[i] = Node::Diffuse.bit();
        match i % 3 {
            1 => {
                t.material[i] = 1;
                t.valid[i] |= Node::Reflect.bit();
                t.nodes[Node::Reflect as usize].colour[i] = [0.25, 0.75, 0.5];
                t.nodes[Node::Reflect as usize].depth[i] = 2.5;
            }
            2 => {
                t.material[i] = 2;
                t.valid[i] |= Node::Reflect.bit() | Node::Refract.bit();
                t.nodes[Node::Reflect as usize].colour[i] = [0.125, 0.25, 0.5];
                t.nodes[Node::Reflect as usize].depth[i] = 4.0;
                t.nodes[Node::Refract as usize].colour[i] = [0.0, 1.0, 0.5];
                t.nodes[Node::Refract as usize].depth[i] = 0.3125;
            }
            _ => {}
        }
    }
    Layers { fragments: Some(f), raytree: Some(t) }
}

/// A v2 trace: reference 0 with both layers, reference 1 with none.
fn write_v2(dir: &Path) -> Trace {
    let mut w = TraceWriter::new(dir, Display { width: 4, height: 3, supersample: 2 }).unwrap();
    let a = w.add_reference_with_layers(0.0, camera(6, 4, 0.0), &samples(), SlopeSource::Exact, &layers()).unwrap();
    let b = w.add_reference(0.2, camera(6, 4, 0.1), &samples(), SlopeSource::Exact).unwrap();
    let truth = TruthImage {
        width: 4,
        height: 3,
        colour: vec![[0.5; 3]; 12],
        known: bitvec::vec::BitVec::repeat(true, 12),
        nondiffuse: Some((0..12).map(|i| i % 5 == 0).collect()),
        seen: None,
    };
    w.add_derived(1.0 / 30.0, camera(4, 3, 0.05), vec![a, b], Some(&truth)).unwrap();
    w.finish().unwrap();
    Trace::open(dir).unwrap()
}

#[test]
fn layers_round_trip_through_writer_and_reader() {
    let dir = tempfile::tempdir().unwrap();
    let t = write_v2(dir.path());
    assert_eq!(t.format_version(), 2);
    let text = std::fs::read_to_string(&t.manifest).unwrap();
    assert!(text.starts_with("postwarp-trace 2\n"), "{text}");
    assert!(text.contains("layer 0 kind=fragments image=ref/0000-fragments.exr max=3\n"), "{text}");
    assert!(text.contains("layer 0 kind=raytree image=ref/0000-raytree.exr materials=mirror,1.5\n"), "{text}");
    assert_eq!(parse_manifest(&text, &t.manifest).unwrap().references, t.references);
    assert_eq!(t.layer_kinds(), vec!["fragments", "raytree"]);
    let got = t.load_layers(0).unwrap();
    assert_eq!(got, layers(), "every value is exact in the stored precision");
    assert_eq!(t.load_layers(1).unwrap(), Layers::default());
    let truth = t.load_truth(0).unwrap().unwrap();
    assert_eq!(truth.nondiffuse.unwrap(), (0..12).map(|i| i % 5 == 0).collect::<bitvec::vec::BitVec>());
}

#[test]
fn version_1_traces_still_load() {
    for name in ["room", "slants", "occluders", "hairball", "motorcycle"] {
        let t = Trace::open(&root().join("traces").join(name)).unwrap();
        assert_eq!(t.format_version(), 1, "{name}");
        let text = std::fs::read_to_string(&t.manifest).unwrap();
        assert!(text.starts_with("postwarp-trace 1\n"), "{name}");
        assert!(t.layer_kinds().is_empty());
        assert_eq!(t.load_layers(0).unwrap(), Layers::default());
        assert!(t.load_reference(0).is_ok());
        assert!(t.load_truth(0).unwrap().is_some_and(|tr| tr.nondiffuse.is_none()), "{name}");
    }
}

const V2: &str = "postwarp-trace 2
display width=4 height=3 supersample=2
reference 0 time=0 image=a.exr size=6x4 fx=20 fy=20 cx=2.5 cy=1.5 position=0,0,0 orientation=0,0,0,1
layer 0 kind=fragments image=a-f.exr max=4
derived 0 time=0.1 refs=0 fx=20 fy=20 cx=1.5 cy=1 position=0.1,0,0 orientation=0,0,0,1
";

/// Replace line `n` (1-based) of V2 with `line`, parse, expect an error
/// at `n` mentioning `needle`.
fn refused(n: usize, line: &str, needle: &str) {
    let mut lines: Vec<&str> = V2.lines().collect();
    lines[n - 1] = line;
    let e = parse_manifest(&lines.join("\n"), Path::new("t/postwarp.trace")).expect_err(line);
    let msg = e.to_string();
    assert_eq!(e.line, Some(n), "{msg}");
    assert!(msg.starts_with(&format!("t/postwarp.trace:{n}: ")), "{msg}");
    assert!(msg.contains(needle), "`{msg}` should mention `{needle}`");
}

#[test]
fn malformed_layer_statements_name_file_and_line() {
    let t = parse_manifest(V2, Path::new("t/postwarp.trace")).unwrap();
    assert_eq!(t.references[0].layers.fragments, Some(LayerStatement::Fragments { image: "a-f.exr".into(), max: 4 }));
    refused(
        4,
        "layer 0 kind=depth-peel image=x.exr",
        "unknown layer kind `depth-peel`; expected one of `fragments`, `raytree`",
    );
    refused(
        4,
        "layer 1 kind=fragments image=x.exr max=4",
        "layer index `1`; expected a reference declared before it (0 to 0)",
    );
    refused(4, "layer 0 kind=fragments image=x.exr max=0", "max = 0; expected 1 to 16");
    refused(4, "layer 0 kind=fragments image=x.exr max=17", "max = 17");
    refused(4, "layer 0 kind=fragments image=x.exr", "missing field `max=`");
    refused(4, "layer 0 kind=fragments image=x.exr max=2 colour=red", "unknown field `colour`");
    refused(4, "layer 0 kind=raytree image=x.exr materials=mirror,glass", "`glass` is neither `mirror` nor");
    refused(4, "layer 0 kind=raytree image=x.exr materials=-1.5", "`-1.5` is neither");
    refused(4, "layer 0 kind=raytree image=x.exr materials=NaN", "`NaN` is neither");
    refused(4, "layer 0 kind=raytree image=x.exr", "missing field `materials=`");
    // In a version 1 file, at the layer line.
    let e =
        parse_manifest(&V2.replace("postwarp-trace 2", "postwarp-trace 1"), Path::new("t/postwarp.trace")).unwrap_err();
    assert_eq!(e.line, Some(4), "{e}");
    assert!(e.message.contains("`layer` statements need trace format version 2"), "{e}");
    // A second layer of the same kind, at the second.
    let text = V2.replace("max=4\n", "max=4\nlayer 0 kind=fragments image=b.exr max=2\n");
    let e = parse_manifest(&text, Path::new("t/postwarp.trace")).unwrap_err();
    assert_eq!(e.line, Some(5), "{e}");
    assert!(e.message.contains("second `fragments` layer for reference 0"), "{e}");
    // One of each kind is fine.
    let text = V2.replace("max=4\n", "max=4\nlayer 0 kind=raytree image=b.exr materials=1.33\n");
    let t = parse_manifest(&text, Path::new("t/postwarp.trace")).unwrap();
    assert_eq!(
        t.references[0].layers.raytree,
        Some(LayerStatement::RayTree {
            image: "b.exr".into(),
            materials: vec![SpecularMaterial::Dielectric { ior: 1.33 }]
        })
    );
}

#[test]
fn missing_layer_image_names_the_layer_line() {
    let dir = tempfile::tempdir().unwrap();
    write_v2(dir.path());
    std::fs::remove_file(dir.path().join("ref/0000-raytree.exr")).unwrap();
    let e = Trace::open(dir.path()).unwrap_err().to_string();
    assert!(e.contains("postwarp.trace:5:") && e.contains("0000-raytree.exr") && e.contains("does not exist"), "{e}");
}

/// Write an EXR of 12x8 samples with exactly the given channels.
fn write_exr(path: &Path, channels: Vec<(String, exr::prelude::FlatSamples)>) {
    use exr::prelude::*;
    let list: Vec<AnyChannel<FlatSamples>> =
        channels.into_iter().map(|(n, s)| AnyChannel::new(n.as_str(), s)).collect();
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

fn u32s(v: u32) -> exr::prelude::FlatSamples {
    exr::prelude::FlatSamples::U32(vec![v; 96])
}

/// The channels of a fragment layer of max 2 where every sample holds the
/// fragments `z0`, `z1` (count 2) of opacity `a`.
fn fragment_channels(count: u32, z0: f32, z1: f32, a: f32) -> Vec<(String, exr::prelude::FlatSamples)> {
    let mut c = vec![("count".to_string(), u32s(count))];
    for ch in ["R", "G", "B"] {
        c.push((format!("opaque.{ch}"), f32s(0.5)));
        c.push((format!("f0.{ch}"), f32s(0.5)));
        c.push((format!("f1.{ch}"), f32s(0.5)));
    }
    c.extend([
        ("f0.A".to_string(), f32s(a)),
        ("f1.A".to_string(), f32s(a)),
        ("f0.Z".to_string(), f32s(z0)),
        ("f1.Z".to_string(), f32s(z1)),
    ]);
    c
}

/// Replace reference 0's layer `file` with `channels` and load its layers:
/// the error, which must name the image and the manifest's layer line.
fn layer_error(file: &str, line: usize, channels: Vec<(String, exr::prelude::FlatSamples)>) -> String {
    let dir = tempfile::tempdir().unwrap();
    write_v2(dir.path());
    write_exr(&dir.path().join("ref").join(file), channels);
    let t = Trace::open(dir.path()).unwrap();
    let e: TraceError = t.load_layers(0).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains(file) && msg.contains(&format!("postwarp.trace:{line})")), "{msg}");
    msg
}

#[test]
fn every_fragment_layer_error_is_named() {
    let frag = |c| layer_error("0000-fragments.exr", 4, c);
    // The layer says max=3; a file with count 4 is refused.
    let mut c = fragment_channels(2, 1.0, 2.0, 0.5);
    for k in 2..3 {
        for ch in ["R", "G", "B", "A", "Z"] {
            c.push((format!("f{k}.{ch}"), f32s(1.0)));
        }
    }
    let ok = c.clone();
    let mut bad = ok.clone();
    bad[0] = ("count".into(), u32s(4));
    assert!(frag(bad).contains("count = 4; expected at most max = 3"));
    let mut bad = ok.clone();
    bad.retain(|(n, _)| n != "f1.Z");
    assert!(frag(bad).contains("missing channel `f1.Z`"));
    let swap = |z0: f32, z1: f32, a: f32| {
        let mut c = fragment_channels(2, z0, z1, a);
        c.extend(ok.iter().filter(|(n, _)| n.starts_with("f2")).cloned());
        c
    };
    assert!(frag(swap(2.0, 1.0, 0.5)).contains("fragment 1 (Z = 1) is nearer than fragment 0 (Z = 2)"));
    assert!(frag(swap(f32::NAN, 1.0, 0.5)).contains("fragment 0 depth f0.Z = NaN"));
    assert!(frag(swap(-1.0, 1.0, 0.5)).contains("expected a finite positive depth"));
    assert!(frag(swap(1.0, 2.0, 1.5)).contains("opacity f0.A = 1.5; expected 0 to 1"));
    let mut bad = ok.clone();
    bad[0] = ("count".into(), f32s(1.0));
    assert!(frag(bad).contains("channel `count` is half or float; expected uint"));
    // Slots past `count` are ignored, whatever they hold.
    let mut c = swap(1.0, f32::NAN, 0.5);
    c[0] = ("count".into(), u32s(1));
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.exr");
    write_exr(&p, c);
    let l = read_fragment_layer(&p, (12, 8), 3).unwrap();
    assert!(l.count.iter().all(|&c| c == 1) && l.fragments.iter().skip(1).step_by(3).all(|f| f.z == 0.0));
}

#[test]
fn every_ray_tree_layer_error_is_named() {
    let tree = |valid: u32, material: u32, reflect_z: f32| {
        let mut c = vec![("valid".to_string(), u32s(valid)), ("material".to_string(), u32s(material))];
        for node in ["diffuse", "reflect", "refract"] {
            for ch in ["R", "G", "B"] {
                c.push((format!("{node}.{ch}"), f32s(0.5)));
            }
            c.push((format!("{node}.Z"), f32s(if node == "reflect" { reflect_z } else { 2.0 })));
        }
        c
    };
    let rt = |c| layer_error("0000-raytree.exr", 5, c);
    assert!(rt(tree(8, 1, 1.0)).contains("valid = 8; expected bits 1, 2, 4"));
    assert!(rt(tree(3, 3, 1.0)).contains("material = 3; the manifest's table has 2 entries"));
    assert!(rt(tree(3, 0, 1.0)).contains("material = 0; expected the index of its material"));
    assert!(rt(tree(5, 1, 1.0)).contains("a refraction node on a `mirror` material"));
    assert!(rt(tree(3, 1, f32::INFINITY)).contains("reflect.Z = inf where the node is valid"));
    let mut c = tree(3, 1, 1.0);
    c.retain(|(n, _)| n != "refract.G");
    assert!(rt(c).contains("missing channel `refract.G`"));
    // A depth where the node is not valid is ignored.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.exr");
    write_exr(&p, tree(1, 0, f32::NAN));
    let l = postwarp::trace::layers::read_ray_tree_layer(&p, (12, 8), &[SpecularMaterial::Mirror]).unwrap();
    assert!(l.nodes[Node::Reflect as usize].depth.iter().all(|&z| z == 0.0));
}

#[test]
fn make_trace_gallery_writes_a_v2_trace_that_info_reads_and_simulate_ignores() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("gallery");
    let o = postwarp(&[
        "make-trace",
        "--scene",
        "gallery",
        "--out",
        out.to_str().unwrap(),
        "--width",
        "40",
        "--height",
        "30",
        "--frames",
        "2",
        "--supersample",
        "1",
        "--fragments",
        "2",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t = Trace::open(&out).unwrap();
    assert_eq!(t.format_version(), 2);
    assert_eq!(t.layer_kinds(), vec!["fragments", "raytree"]);
    let l = t.load_layers(0).unwrap();
    let f = l.fragments.unwrap();
    assert_eq!(f.max, 2);
    assert!(f.count.contains(&2), "two rows of windows: some rays cross two panes");
    let rt = l.raytree.unwrap();
    assert_eq!(rt.materials, vec![SpecularMaterial::Mirror, SpecularMaterial::Dielectric { ior: 1.5 }]);
    assert!((0..rt.len()).any(|i| rt.has(i, Node::Reflect)) && (0..rt.len()).any(|i| rt.has(i, Node::Refract)));
    let mask = t.load_truth(0).unwrap().unwrap().nondiffuse.expect("a non-diffuse scene's truth has the mask");
    let share = mask.count_ones() as f64 / mask.len() as f64;
    assert!(share > 0.1 && share < 0.9, "{share}");

    let o = postwarp(&["info", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("(format v2)"), "{text}");
    assert!(text.contains("fragments: ") && text.contains("of max 2"), "{text}");
    assert!(text.contains("ray tree: valid diffuse 100.0%") && text.contains("materials mirror, 1.5"), "{text}");
    assert!(text.contains("% of ground-truth pixels specular or transparent"), "{text}");

    let sim = dir.path().join("sim");
    let o = postwarp(&["simulate", out.to_str().unwrap(), "--out", sim.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sim.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["ignored_layers"], serde_json::json!(["fragments", "raytree"]));
    // A diffuse scene gives a v1 trace; its report names no ignored layer.
    let room = dir.path().join("room");
    let args = ["make-trace", "--scene", "room", "--out", room.to_str().unwrap(), "--width", "32", "--height", "24"];
    assert!(postwarp(&[&args[..], &["--frames", "1", "--supersample", "1"]].concat()).status.success());
    assert_eq!(Trace::open(&room).unwrap().format_version(), 1);
    let o = postwarp(&["simulate", room.to_str().unwrap(), "--out", dir.path().join("r").to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r/report.json")).unwrap()).unwrap();
    assert_eq!(report["ignored_layers"], serde_json::json!([]));
}

#[test]
fn the_documented_layer_example_parses() {
    let doc = std::fs::read_to_string(root().join("docs/trace-format.md")).unwrap();
    let ex = doc.find("Example (the first reference of a `gallery` trace)").expect("layer example");
    let start = ex + doc[ex..].find("```\n").expect("example block") + 4;
    let end = start + doc[start..].find("```").unwrap();
    let text = format!(
        "postwarp-trace 2\ndisplay width=128 height=96 supersample=2\n{}derived 0 time=0 refs=0 fx=110 fy=110 cx=63.5 \
         cy=47.5 position=0,0,0 orientation=0,0,0,1\n",
        &doc[start..end]
    );
    let t = parse_manifest(&text, Path::new("docs/trace-format.md")).unwrap();
    assert_eq!(t.layer_kinds(), vec!["fragments", "raytree"]);
}
