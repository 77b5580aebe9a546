//! The fixed-point datapath mode (`arith = "fixed"`, `docs/fixed-point.md`):
//! hardware and golden model bit-identical on every bundled trace with
//! their saturation counts equal; the default formats saturate nothing and
//! stay within a small PSNR of float; a narrowed format saturates and
//! changes the image; bad formats are refused naming the knob.

use postwarp::golden::config::GoldenConfig;
use postwarp::golden::frame::{GoldenFrame, SaturationCounts, Warper, prepare_reference};
use postwarp::run::hw_config::golden_config_for;
use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use postwarp_rtl::frame_stats::Saturations;
use postwarp_rtl::knob::{KnobValue, set_by_name};
use std::path::Path;

const TRACES: [&str; 5] = ["room", "slants", "hairball", "occluders", "motorcycle"];

fn open(trace: &str) -> Trace {
    Trace::open(&Path::new(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap()
}

fn fixed(t: &Trace) -> EngineConfig {
    EngineConfig { supersample: t.display.supersample, arith: "fixed".into(), ..EngineConfig::default() }
}

/// Frames `frames` of `t` through both engines under `cfg`.
fn run(t: &Trace, frames: &[usize], cfg: &EngineConfig) -> Vec<(GoldenFrame, FrameOutput)> {
    let gcfg = golden_config_for(cfg);
    gcfg.validate().unwrap();
    let mut engine = Engine::new(cfg.clone()).unwrap();
    let mut warper = Warper::new();
    frames
        .iter()
        .map(|&k| {
            let f = &t.derived[k];
            let loaded: Vec<_> = f.references.iter().map(|&r| t.load_reference(r).unwrap().samples).collect();
            let g_refs: Vec<_> = loaded.iter().map(|s| prepare_reference(s, cfg.supersample, &gcfg)).collect();
            let h_refs: Vec<_> = loaded.iter().map(|s| HwReference::new(s, cfg)).collect();
            let cmd = t.frame_commands(k);
            let g = warper.warp_frame(&cmd, &g_refs.iter().collect::<Vec<_>>(), &gcfg);
            let h = engine.run_frame(&cmd, &h_refs.iter().collect::<Vec<_>>());
            (g, h)
        })
        .collect()
}

fn set_text(cfg: &mut EngineConfig, knob: &str, v: &str) {
    set_by_name(postwarp_rtl::config::KNOBS, cfg, knob, KnobValue::Text(v.into())).unwrap();
}

fn same_counts(g: &SaturationCounts, h: &Saturations) -> bool {
    [g.fetch, g.transform, g.kernel_setup, g.raster, g.hole_fill] == h.values()
}

/// Sample planes and pixels equal; the saturation counts equal.
fn assert_identical(what: &str, g: &GoldenFrame, h: &FrameOutput) {
    let d = &g.samples;
    let diff = (0..d.len())
        .filter(|&i| {
            d.colour[i] != h.frame.samples[i].colour
                || d.real[i] != h.frame.real[i]
                || d.hole[i] != h.frame.hole[i]
                || (d.real[i] && d.inv_z[i] != h.frame.samples[i].inv_z)
        })
        .count();
    assert_eq!(diff, 0, "{what}: {diff} samples differ between hardware and golden");
    assert_eq!(g.pixels, h.pixels, "{what}: pixels");
    let (gs, hs) = (g.stats.saturations.expect("golden counts in fixed mode"), h.stats.saturations.expect("hw counts"));
    assert!(same_counts(&gs, &hs), "{what}: saturations golden {gs:?} hardware {hs:?}");
}

fn frames_of(t: &Trace) -> Vec<usize> {
    let n = t.derived.len();
    if n > 1 { vec![0, n - 1] } else { vec![0] }
}

fn psnr(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let se: f64 = a.iter().zip(b).map(|(p, q)| (0..3).map(|k| (p[k] as f64 - q[k] as f64).powi(2)).sum::<f64>()).sum();
    let mse = se / (3 * a.len()) as f64;
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (1.0 / mse).log10() }
}

#[test]
fn fixed_mode_hardware_equals_golden_on_every_bundled_trace() {
    for trace in TRACES {
        let t = open(trace);
        // Every frame (the other tests take the first and last).
        let frames: Vec<usize> = (0..t.derived.len()).collect();
        for (k, (g, h)) in frames.iter().zip(run(&t, &frames, &fixed(&t))) {
            assert_identical(&format!("{trace} frame {k}"), &g, &h);
        }
    }
}

#[test]
fn default_formats_saturate_nothing_and_stay_close_to_float() {
    for trace in TRACES {
        let t = open(trace);
        let frames = frames_of(&t);
        let float = EngineConfig { supersample: t.display.supersample, ..EngineConfig::default() };
        let fx = run(&t, &frames, &fixed(&t));
        let fl = run(&t, &frames, &float);
        for (k, ((_, hx), (_, hf))) in frames.iter().zip(fx.iter().zip(&fl)) {
            assert!(hf.stats.saturations.is_none(), "float mode counts no saturation");
            let s = hx.stats.saturations.unwrap();
            assert_eq!(s, Saturations::default(), "{trace} frame {k}: default formats saturated");
            let p = psnr(&hx.pixels, &hf.pixels);
            eprintln!("{trace} frame {k}: fixed vs float PSNR {p:.1} dB");
            assert!(p > 40.0, "{trace} frame {k}: fixed vs float PSNR {p:.1} dB");
        }
    }
}

#[test]
fn narrowed_formats_saturate_change_the_image_and_agree() {
    let t = open("room");
    let frames = [0, 5];
    let base = run(&t, &frames, &fixed(&t));
    for (knob, value, stage) in
        [("q_position", "Q7_16", 1usize), ("q_hole_weight", "Q1_4", 4), ("q_slope", "Q1_2", 1), ("q_colour", "Q1_3", 0)]
    {
        let mut cfg = fixed(&t);
        set_text(&mut cfg, knob, value);
        cfg.validate().unwrap();
        let out = run(&t, &frames, &cfg);
        let mut changed = false;
        let mut sat = [0u64; 5];
        for (k, ((g, h), (_, b))) in frames.iter().zip(out.iter().zip(&base)) {
            assert_identical(&format!("room frame {k}, {knob} = {value}"), g, h);
            for (a, v) in sat.iter_mut().zip(h.stats.saturations.unwrap().values()) {
                *a += v;
            }
            changed |= h.pixels != b.pixels;
        }
        eprintln!("{knob} = {value}: saturations {sat:?}");
        assert!(sat[stage] > 0, "{knob} = {value}: stage {} counted nothing: {sat:?}", Saturations::STAGES[stage]);
        assert!(changed, "{knob} = {value}: the image did not change");
    }
}

#[test]
fn bad_formats_are_refused_naming_the_knob() {
    for bad in ["Q0_0", "Q40_40", "X16_16", "Q16"] {
        for knob in ["q_position", "q_hole_weight", "q_ref_coord"] {
            let mut cfg = EngineConfig { arith: "fixed".into(), ..EngineConfig::default() };
            set_text(&mut cfg, knob, bad);
            let e = cfg.validate().unwrap_err();
            assert!(e.starts_with(&format!("{knob} = \"{bad}\": expected a Q format")), "{knob} = {bad}: {e}");
            let mut g = GoldenConfig { arith: "fixed".into(), ..GoldenConfig::default() };
            set_by_name(postwarp::golden::config::KNOBS, &mut g, knob, KnobValue::Text(bad.into())).unwrap();
            let e = g.validate().unwrap_err();
            assert!(e.starts_with(&format!("{knob} = \"{bad}\": expected a Q format")), "golden {knob} = {bad}: {e}");
        }
    }
    // Valid formats the datapath cannot use within the schedule's margin.
    let cfg = EngineConfig { arith: "fixed".into(), q_reciprocal: "Q8_8".into(), ..EngineConfig::default() };
    let e = cfg.validate().unwrap_err();
    assert!(e.starts_with("q_reciprocal = \"Q8_8\": expected at least 16 fraction bits"), "{e}");
    let cfg =
        EngineConfig { arith: "fixed".into(), recip_table_bits: 2, recip_iterations: 1, ..EngineConfig::default() };
    assert!(cfg.validate().unwrap_err().starts_with("recip_iterations = 1"));
    let cfg = EngineConfig { arith: "fixedpoint".into(), ..EngineConfig::default() };
    assert!(cfg.validate().unwrap_err().starts_with("arith = \"fixedpoint\": expected one of \"float\", \"fixed\""));
    // The golden general path has no fixed mode.
    let g = GoldenConfig {
        arith: "fixed".into(),
        reconstruction: postwarp::golden::config::Reconstruction::General,
        ..GoldenConfig::default()
    };
    assert!(g.validate().unwrap_err().starts_with("arith = \"fixed\": expected reconstruction = \"aa-rect\""));
}

/// `postwarp simulate --config configs/fixed.toml`: every frame identical
/// to the golden model, `saturations` in `report.json` (described with
/// units), the printed line; and `--budget` prints other widths than float.
#[test]
fn the_bundled_fixed_configuration_runs_through_the_cli() {
    use postwarp::report::keys::undescribed;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fx");
    let cfg = root.join("configs/fixed.toml");
    let run = |args: &[&str]| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_postwarp")).args(args).output().unwrap();
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let trace = root.join("traces/occluders");
    let printed =
        run(&["simulate", trace.to_str().unwrap(), "--out", out.to_str().unwrap(), "--config", cfg.to_str().unwrap()]);
    assert!(printed.contains("6 of 6 identical to the golden model"), "{printed}");
    assert!(printed.contains("saturations over the frames: fetch 0, transform 0"), "{printed}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["config"]["arith"], "fixed");
    assert_eq!(r["total"]["saturations"]["hole_fill"], 0);
    assert!(r["frames"][0]["saturations"]["transform"].is_u64());
    let mut missing = Vec::new();
    undescribed(&r, &postwarp::report::simulate::report_keys(), "", &mut missing);
    assert!(missing.is_empty(), "{missing:?}");
    // The golden model alone reports its own saturations in fixed mode.
    let gcfg = dir.path().join("golden.toml");
    std::fs::write(&gcfg, "arith = \"fixed\"\n").unwrap();
    let gout = dir.path().join("g");
    run(&["golden", trace.to_str().unwrap(), "--out", gout.to_str().unwrap(), "--config", gcfg.to_str().unwrap()]);
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(gout.join("report.json")).unwrap()).unwrap();
    assert_eq!(g["total"]["saturations"]["fetch"], 0, "{}", g["total"]);
    assert!(g["frames"][0]["saturations"]["raster"].is_u64());
    let mut missing = Vec::new();
    undescribed(&g, &postwarp::report::golden::report_keys(), "", &mut missing);
    assert!(missing.is_empty(), "{missing:?}");
    let fixed = run(&["simulate", "--config", cfg.to_str().unwrap(), "--budget"]);
    let float = run(&["simulate", "--preset", "mark1998", "--budget"]);
    assert_ne!(fixed, float, "the fixed mode's widths differ");
}
