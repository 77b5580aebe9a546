//! Property tests of the trace format: generated traces print and parse
//! back to themselves; layout freedom (field order, spacing, comments, CRLF)
//! does not change the trace; malformed manifests, made by mutating a valid
//! printed one, are errors (never panics) that name the file and the line
//! at fault; and a reference image's samples without a surface read as
//! depth 0 and slopes 0, whatever the file holds there. Generated traces
//! carry v2 layers on some references (then print as version 2). Case counts:
//! `common::prop_config` (`PROPTEST_CASES` raises them).

use crate::common;

use glam::{DQuat, DVec3};
use postwarp::trace::layers::{LayerStatement, MAX_FRAGMENTS, ReferenceLayers, SpecularMaterial};
use postwarp::trace::{
    DerivedFrame, Display, MAX_REFS_PER_FRAME, MAX_SAMPLES, MAX_SIDE, ReferenceFrame, Trace, TraceError,
    format_manifest, parse_manifest,
};
use postwarp_rtl::{Camera, Intrinsics, Pose};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const FILE: &str = "gen/postwarp.trace";

/// Any finite f64, from tiny subnormals to the largest, both signs.
fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => -1e3f64..1e3,
        1 => prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO | prop::num::f64::NEGATIVE,
        1 => Just(-0.0),
    ]
}

/// A positive finite focal length.
fn focal() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.01f64..1e5, 1 => prop::num::f64::POSITIVE.prop_filter("finite", |f| f.is_finite())]
}

fn unit_quaternion() -> impl Strategy<Value = DQuat> {
    prop_oneof![
        1 => Just(DQuat::IDENTITY),
        4 => prop::array::uniform4(-1.0f64..1.0)
            .prop_filter("not near zero", |q| q.iter().map(|x| x * x).sum::<f64>() > 1e-3)
            .prop_map(|q| DQuat::from_array(q).normalize()),
    ]
}

fn camera(width: u32, height: u32) -> impl Strategy<Value = Camera> {
    (focal(), focal(), finite(), finite(), prop::array::uniform3(finite()), unit_quaternion()).prop_map(
        move |(fx, fy, cx, cy, p, q)| Camera {
            intrinsics: Intrinsics { width, height, fx, fy, cx, cy },
            pose: Pose { position: DVec3::from_array(p), orientation: q },
        },
    )
}

/// Image sides: mostly small, sometimes up to the limit.
fn side() -> impl Strategy<Value = u32> {
    prop_oneof![3 => 1u32..64, 1 => 1u32..=MAX_SIDE]
}

fn display() -> impl Strategy<Value = Display> {
    (side(), side(), 1u32..=4)
        .prop_filter("at most MAX_SAMPLES", |&(w, h, s)| w as u64 * h as u64 * (s as u64).pow(2) <= MAX_SAMPLES)
        .prop_map(|(width, height, supersample)| Display { width, height, supersample })
}

/// A relative path without white space (values hold no spaces).
fn image_path() -> impl Strategy<Value = PathBuf> {
    prop_oneof![3 => "[a-z0-9_/.-]{1,16}\\.exr", 1 => "[^\\s]{1,12}"].prop_map(PathBuf::from)
}

/// A note as the writer keeps it: one line, no surrounding white space.
fn note() -> impl Strategy<Value = String> {
    "[^\\n\\r]{0,40}".prop_map(|s| s.trim().to_string())
}

/// A ray-tree material-table entry.
fn specular_material() -> impl Strategy<Value = SpecularMaterial> {
    prop_oneof![
        1 => Just(SpecularMaterial::Mirror),
        2 => (0.01f64..10.0).prop_map(|ior| SpecularMaterial::Dielectric { ior }),
        1 => prop::num::f64::POSITIVE
            .prop_filter("finite", |f| f.is_finite())
            .prop_map(|ior| SpecularMaterial::Dielectric { ior }),
    ]
}

/// A reference's v2 layers: mostly none.
fn layers() -> impl Strategy<Value = ReferenceLayers> {
    let fragments =
        (image_path(), 1u32..=MAX_FRAGMENTS).prop_map(|(image, max)| LayerStatement::Fragments { image, max });
    let raytree = (image_path(), prop::collection::vec(specular_material(), 1..4))
        .prop_map(|(image, materials)| LayerStatement::RayTree { image, materials });
    prop_oneof![
        2 => Just(ReferenceLayers::default()),
        1 => (prop::option::of(fragments), prop::option::of(raytree))
            .prop_map(|(fragments, raytree)| ReferenceLayers { fragments, raytree }),
    ]
}

fn reference(d: Display) -> impl Strategy<Value = ReferenceFrame> {
    (side(), side())
        .prop_filter("at most MAX_SAMPLES", move |&(w, h)| {
            w as u64 * h as u64 * (d.supersample as u64).pow(2) <= MAX_SAMPLES
        })
        .prop_flat_map(|(w, h)| (finite(), camera(w, h), image_path(), layers()))
        .prop_map(|(time_s, camera, image, layers)| ReferenceFrame { time_s, camera, image, layers })
}

fn derived(d: Display, n_refs: usize) -> impl Strategy<Value = DerivedFrame> {
    let refs =
        prop::sample::subsequence((0..n_refs).collect::<Vec<_>>(), 1..=n_refs.min(MAX_REFS_PER_FRAME)).prop_shuffle();
    (finite(), camera(d.width, d.height), refs, prop::option::of(image_path()))
        .prop_map(|(time_s, camera, references, truth)| DerivedFrame { time_s, camera, references, truth })
}

/// A valid trace as the parser returns it for [`FILE`].
fn trace() -> impl Strategy<Value = Trace> {
    (display(), 1usize..=10, 1usize..=6, prop::collection::vec(note(), 0..3)).prop_flat_map(
        |(d, n_refs, n_der, notes)| {
            (prop::collection::vec(reference(d), n_refs), prop::collection::vec(derived(d, n_refs), n_der)).prop_map(
                move |(references, derived)| Trace {
                    display: d,
                    notes: notes.clone(),
                    references,
                    derived,
                    dir: PathBuf::new(),
                    manifest: PathBuf::from(FILE),
                },
            )
        },
    )
}

fn parse(text: &str) -> Result<Trace, TraceError> {
    parse_manifest(text, Path::new(FILE))
}

/// `e` is at `line` of [`FILE`], and its message says so first.
fn assert_at_line(e: &TraceError, line: usize) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert_eq!(e.line, Some(line), "{}", msg);
    prop_assert!(msg.starts_with(&format!("{FILE}:{line}: ")), "{}", msg);
    Ok(())
}

fn lines(text: &str) -> Vec<String> {
    text.lines().map(str::to_string).collect()
}

fn join(lines: &[String]) -> String {
    lines.iter().map(|l| format!("{l}\n")).collect()
}

/// What a line of a printed manifest is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Version,
    Note,
    Display,
    Reference(usize),
    Layer(usize),
    Derived(usize),
}

fn kind(line: &str) -> Kind {
    let mut t = line.split_whitespace();
    match (t.next(), t.next().and_then(|i| i.parse().ok())) {
        (Some("postwarp-trace"), _) => Kind::Version,
        (Some("note"), _) => Kind::Note,
        (Some("display"), _) => Kind::Display,
        (Some("reference"), Some(i)) => Kind::Reference(i),
        (Some("layer"), Some(i)) => Kind::Layer(i),
        (Some("derived"), Some(i)) => Kind::Derived(i),
        _ => panic!("not a printed line: {line}"),
    }
}

proptest! {
    #![proptest_config(common::prop_config(96))]

    /// Print → parse gives the same trace, and printing it again the same
    /// text (numbers in shortest round-trip form).
    #[test]
    fn print_parse_round_trip(t in trace()) {
        let text = format_manifest(&t);
        let back = parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        prop_assert_eq!(&back, &t);
        prop_assert_eq!(format_manifest(&back), text);
    }

    /// Field order, runs of spaces and tabs, blank lines, comment lines and
    /// CRLF line ends do not change the trace.
    #[test]
    fn layout_does_not_change_the_trace(
        t in trace(),
        seed in any::<u64>(),
        crlf in any::<bool>(),
    ) {
        let mut rng = seed;
        let mut next = |n: usize| {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((rng >> 33) % n as u64) as usize
        };
        let mut out = Vec::new();
        for (i, line) in lines(&format_manifest(&t)).into_iter().enumerate() {
            let k = kind(&line);
            if i > 0 {
                match next(3) {
                    0 => out.push(String::new()),
                    1 => out.push(format!("#{}", " reference 0 garbage=1".repeat(next(2)))),
                    _ => {}
                }
            }
            let mut toks: Vec<String> = line.split(' ').map(str::to_string).collect();
            let fixed = match k {
                Kind::Version | Kind::Note => toks.len(),
                Kind::Display => 1,
                Kind::Reference(_) | Kind::Layer(_) | Kind::Derived(_) => 2,
            };
            // Shuffle the key=value fields (Fisher-Yates).
            for a in (fixed + 1..toks.len()).rev() {
                let b = fixed + next(a - fixed + 1);
                toks.swap(a, b);
            }
            let sep = [" ", "  ", "\t", " \t "][next(4)];
            let body = if k == Kind::Note { line.clone() } else { toks.join(sep) };
            out.push(format!("{}{body}{}", if i > 0 && next(2) == 0 { "  " } else { "" }, ["", " ", "\t"][next(3)]));
        }
        let text: String = out.iter().map(|l| format!("{l}{}", if crlf { "\r\n" } else { "\n" })).collect();
        let back = parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{text}")))?;
        prop_assert_eq!(back, t);
    }

    /// Deleting a line: the version, display, or a frame that is not the
    /// last of its kind is an error at exactly the line that now stands in
    /// its place (for a reference with layers: its first layer line, which
    /// now names a reference not declared). Deleting a note, a layer, or
    /// the last frame of a kind, may leave a valid trace; then the check is
    /// only that an error names a line.
    #[test]
    fn deleted_line_is_an_error_at_that_line(t in trace(), pick in any::<prop::sample::Index>()) {
        let mut ls = lines(&format_manifest(&t));
        let k = pick.index(ls.len());
        let what = kind(&ls[k]);
        ls.remove(k);
        let r = parse(&join(&ls));
        let (n_refs, n_der) = (t.references.len(), t.derived.len());
        let layered = |i: usize| !t.references[i].layers.is_empty();
        match what {
            Kind::Version | Kind::Display => assert_at_line(&r.unwrap_err(), k + 1)?,
            Kind::Reference(i) if layered(i) => {
                let e = r.unwrap_err();
                assert_at_line(&e, k + 1)?;
                prop_assert!(e.message.contains(&format!("layer index `{i}`")), "{}", e);
            }
            Kind::Layer(_) => prop_assert!(r.is_ok(), "{:?}", r),
            Kind::Reference(i) if i + 1 < n_refs => {
                let e = r.unwrap_err();
                assert_at_line(&e, k + 1)?;
                prop_assert!(e.message.contains(&format!("expected {i}")), "{}", e);
            }
            Kind::Derived(i) if i + 1 < n_der => assert_at_line(&r.unwrap_err(), k + 1)?,
            Kind::Reference(i) => {
                // The last reference: fine unless a derived frame warps it.
                let used = t.derived.iter().any(|d| d.references.contains(&i));
                prop_assert_eq!(r.is_err(), used);
                if let Err(e) = r {
                    prop_assert!(e.line.is_some_and(|l| l > k && l <= ls.len()), "{}", e);
                }
            }
            Kind::Derived(_) => {
                prop_assert_eq!(r.is_err(), n_der == 1);
                if let Err(e) = r {
                    assert_at_line(&e, ls.len())?; // "no `derived` statement", at the last line
                }
            }
            Kind::Note => prop_assert!(r.is_ok(), "{:?}", r),
        }
    }

    /// Duplicating a line is an error at the copy, except for a note.
    #[test]
    fn duplicated_line_is_an_error_at_the_copy(t in trace(), pick in any::<prop::sample::Index>()) {
        let mut ls = lines(&format_manifest(&t));
        let k = pick.index(ls.len());
        ls.insert(k + 1, ls[k].clone());
        let r = parse(&join(&ls));
        if kind(&ls[k]) == Kind::Note {
            prop_assert!(r.is_ok(), "{:?}", r);
        } else {
            assert_at_line(&r.unwrap_err(), k + 2)?;
        }
    }

    /// A number replaced by garbage (NaN, infinities, words, nothing, a
    /// number too large for any field's type) is an error at its line.
    /// Replaced by a negative or merely large number it may stay valid
    /// (a time or a position may be anything finite), so then the check is
    /// only: no panic, and an error, if any, is at that line.
    #[test]
    fn corrupted_number_is_an_error_at_its_line(
        t in trace(),
        pick_line in any::<prop::sample::Index>(),
        pick_num in any::<prop::sample::Index>(),
        garbage in prop_oneof![
            Just("NaN"), Just("nan"), Just("inf"), Just("-inf"), Just("infinity"), Just("abc"), Just(""),
            Just("1e999"), Just("0x10"), Just("1_0"), Just("١"), Just("1;2"),
        ],
        maybe_valid in prop_oneof![
            Just("-1"), Just("-0"), Just("0"), Just("1e20"), Just("4294967296"), Just("99999999999999999999999"),
        ],
        use_garbage in any::<bool>(),
    ) {
        let mut ls = lines(&format_manifest(&t));
        let statements: Vec<usize> = (0..ls.len())
            .filter(|&i| matches!(kind(&ls[i]), Kind::Display | Kind::Reference(_) | Kind::Layer(_) | Kind::Derived(_)))
            .collect();
        let k = statements[pick_line.index(statements.len())];
        // Number tokens: maximal runs of [0-9.eE+-] after `=`, `,`, `x` or the index position.
        let line = ls[k].clone();
        let spans = number_spans(&line);
        let (a, b) = spans[pick_num.index(spans.len())];
        let with = if use_garbage { garbage } else { maybe_valid };
        ls[k] = format!("{}{with}{}", &line[..a], &line[b..]);
        let r = parse(&join(&ls));
        if use_garbage {
            assert_at_line(&r.unwrap_err(), k + 1)?;
        } else if let Err(e) = r {
            assert_at_line(&e, k + 1)?;
        }
    }

    /// Cutting the text inside a line (dropping the rest of the file): the
    /// version or display line cut is always an error at that line; any
    /// other cut may leave a valid shorter trace (e.g. the last digits of a
    /// quaternion component, within the 1e-6 tolerance), so then: no panic,
    /// and an error, if any, is at the cut line, now the last.
    #[test]
    fn truncated_text_is_an_error_at_the_cut(t in trace(), pick_line in any::<prop::sample::Index>(), at in any::<prop::sample::Index>()) {
        let ls = lines(&format_manifest(&t));
        let k = pick_line.index(ls.len());
        let chars: Vec<char> = ls[k].chars().collect();
        // Keep 1 to len - 1 characters: the line is cut, not removed.
        let cut: String = chars[..1 + at.index(chars.len() - 1)].iter().collect();
        let mut text = join(&ls[..k]);
        text.push_str(&cut);
        // Whatever the line, a cut is an error at the cut: the text no
        // longer ends with a line break, so it is never read as a shorter
        // trace.
        let e = parse(&text).unwrap_err();
        assert_at_line(&e, k + 1)?;
        prop_assert!(e.message.contains("cut off"), "{}", e);
    }

    /// Another version number on line 1 is refused, naming line 1.
    #[test]
    fn unknown_version_is_refused_at_line_1(t in trace(), v in prop_oneof![0u64..1, 3u64..u64::MAX]) {
        let mut ls = lines(&format_manifest(&t));
        ls[0] = format!("postwarp-trace {v}");
        let e = parse(&join(&ls)).unwrap_err();
        assert_at_line(&e, 1)?;
        if v <= u32::MAX as u64 {
            prop_assert!(e.message.contains(&format!("unsupported trace version {v}")), "{}", e);
        } else {
            prop_assert!(e.message.contains("not a number"), "{}", e);
        }
    }

    /// An unknown statement keyword anywhere after line 1, or an unknown
    /// field on a statement, is an error at its line.
    #[test]
    fn unknown_keyword_or_field_is_an_error_at_its_line(
        t in trace(),
        keyword in "[a-z_]{1,12}",
        field in "[a-z_]{1,12}",
        pick in any::<prop::sample::Index>(),
        as_field in any::<bool>(),
    ) {
        prop_assume!(!["note", "display", "reference", "derived", "layer"].contains(&keyword.as_str()));
        let known = ["width", "height", "supersample", "time", "image", "size", "refs", "truth", "fx", "fy", "cx", "cy",
            "position", "orientation", "kind", "max", "materials"];
        prop_assume!(!known.contains(&field.as_str()));
        let mut ls = lines(&format_manifest(&t));
        if as_field {
            let statements: Vec<usize> = (0..ls.len())
                .filter(|&i| matches!(kind(&ls[i]), Kind::Display | Kind::Reference(_) | Kind::Layer(_) | Kind::Derived(_)))
                .collect();
            let k = statements[pick.index(statements.len())];
            ls[k].push_str(&format!(" {field}=1"));
            let e = parse(&join(&ls)).unwrap_err();
            assert_at_line(&e, k + 1)?;
            prop_assert!(e.message.contains(&format!("unknown field `{field}`")), "{}", e);
        } else {
            let k = 1 + pick.index(ls.len());
            ls.insert(k, format!("{keyword} 0 width=1"));
            let e = parse(&join(&ls)).unwrap_err();
            assert_at_line(&e, k + 1)?;
            prop_assert!(e.message.contains(&format!("unknown statement `{keyword}`")), "{}", e);
        }
    }

    /// Arbitrary text never panics the parser; an error always names a line
    /// that exists (line 1 for empty text).
    #[test]
    fn arbitrary_text_never_panics(text in prop_oneof![
        ".{0,200}",
        "postwarp-trace 1\n(display|reference|derived|note)[ a-z0-9=.,x-]{0,80}\n(reference|derived) [0-9] [ a-z0-9=.,x-]{0,120}",
    ]) {
        match parse(&text) {
            Ok(t) => prop_assert_eq!(parse(&format_manifest(&t)).ok(), Some(t)),
            Err(e) => {
                let n = text.lines().count().max(1);
                prop_assert!(e.line.is_some_and(|l| (1..=n).contains(&l)), "{} (of {} lines)", e, n);
                prop_assert!(e.to_string().starts_with(FILE), "{}", e);
            }
        }
    }
}

/// Byte spans of the number tokens of a printed statement line: the frame
/// index and every number in a `key=value` field (list items and the two
/// sides of `size=WxH` separately); never inside a path.
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut pos = 0;
    for (n, tok) in line.split(' ').enumerate() {
        let start = pos;
        pos += tok.len() + 1;
        if n == 1 && !tok.contains('=') {
            spans.push((start, start + tok.len()));
            continue;
        }
        let Some((key, value)) = tok.split_once('=') else { continue };
        if key == "image" || key == "truth" {
            continue;
        }
        let mut item = start + key.len() + 1;
        let seps: &[char] = if key == "size" { &['x'] } else { &[','] };
        for part in value.split(seps) {
            spans.push((item, item + part.len()));
            item += part.len() + 1;
        }
    }
    spans
}

/// Any f32, weighted towards what must never leak out of a loader.
fn garbage_f32() -> impl Strategy<Value = f32> {
    prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(-1.0f32), Just(0.0f32), any::<f32>(),]
}

/// A 4x3 reference image with exact slopes and a `valid` channel, as bytes.
fn reference_exr(cells: &[(bool, f32, f32, f32)]) -> Vec<u8> {
    use exr::prelude::*;
    let n = cells.len();
    let f = |v: Vec<f32>| FlatSamples::F32(v);
    let list: Vec<AnyChannel<FlatSamples>> = vec![
        AnyChannel::new("R", f(vec![0.5; n])),
        AnyChannel::new("G", f(vec![0.25; n])),
        AnyChannel::new("B", f(vec![0.125; n])),
        AnyChannel::new("Z", f(cells.iter().map(|c| c.1).collect())),
        AnyChannel::new("dinvz_dx", f(cells.iter().map(|c| c.2).collect())),
        AnyChannel::new("dinvz_dy", f(cells.iter().map(|c| c.3).collect())),
        AnyChannel::new("valid", f(cells.iter().map(|c| if c.0 { 1.0 } else { 0.0 }).collect())),
    ];
    let layer = Layer::new((4, 3), LayerAttributes::named("t"), Encoding::UNCOMPRESSED, AnyChannels::sort(list.into()));
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer).write().to_buffered(&mut out).unwrap();
    out.into_inner()
}

proptest! {
    #![proptest_config(common::prop_config(32))]

    /// A sample without a surface (`valid` = 0) reads as depth 0 and slopes
    /// 0 whatever the file holds there (NaN, infinities, negatives); a
    /// sample with one keeps its depth and slopes exactly.
    #[test]
    fn samples_without_a_surface_read_as_zero(
        cells in prop::collection::vec(
            (any::<bool>(), garbage_f32(), garbage_f32(), garbage_f32(), 1e-3f32..1e6, -1.0f32..1.0, -1.0f32..1.0),
            12,
        ),
    ) {
        let cells: Vec<(bool, f32, f32, f32)> = cells
            .into_iter()
            .map(|(v, gz, gx, gy, z, sx, sy)| if v { (true, z, sx, sy) } else { (false, gz, gx, gy) })
            .collect();
        let r = postwarp::trace::decode_reference_image(&reference_exr(&cells), Path::new("t.exr"), (4, 3))
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        for (i, &(valid, z, sx, sy)) in cells.iter().enumerate() {
            prop_assert_eq!(r.samples.valid[i], valid);
            if valid {
                prop_assert_eq!((r.samples.z[i], r.samples.inv_z_slopes[i]), (z, [sx, sy]));
            } else {
                prop_assert_eq!((r.samples.z[i], r.samples.inv_z_slopes[i]), (0.0, [0.0, 0.0]));
            }
        }
    }
}
