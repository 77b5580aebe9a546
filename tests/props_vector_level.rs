//! The golden model warps the same frames at every vector level
//! (`golden::vector_level`): a warper held to the build's baseline and one
//! at the host's widest level (AVX2 on most x86-64 hosts) give the same
//! planes, pixels and counters, floats compared bit for bit, in the float
//! and fixed datapaths and with the general reconstruction:
//! - on two bundled traces (a rendered one with several references, a real
//!   pair);
//! - on random built-in scenes at random small display sizes (odd widths
//!   leave every vectorised loop a partial vector at its end),
//!   super-sampling 1 to 3 (a property).
//!
//! The test profile builds the golden model at O2 (`Cargo.toml`), where its
//! loops are vectorised: the AVX2 copy compared here is four-lane code, as
//! in a release build.

use postwarp::golden::config::{GoldenConfig, Reconstruction};
use postwarp::golden::frame::{GoldenFrame, Warper, prepare_reference};
use postwarp::golden::vector_level::VectorLevel;
use postwarp::run::hw_config::golden_config_for;
use postwarp::scene::Scene;
use postwarp::trace::Trace;
use postwarp::tracegen::{TraceSpec, make_trace};
use postwarp_rtl::config::EngineConfig;
use proptest::prelude::*;
use std::path::Path;

use crate::common;

/// The configurations compared: float, fixed, general reconstruction.
fn configs(ss: u32) -> [(&'static str, GoldenConfig); 3] {
    let fixed = golden_config_for(&EngineConfig { supersample: ss, arith: "fixed".into(), ..EngineConfig::default() });
    let general = GoldenConfig { reconstruction: Reconstruction::General, ..GoldenConfig::default() };
    [("float", GoldenConfig::default()), ("fixed", fixed), ("general", general)]
}

/// The bits of every float a frame holds (sample planes, then pixels).
fn float_bits(f: &GoldenFrame) -> Vec<u32> {
    let d = &f.samples;
    let mut v = Vec::new();
    v.extend(d.colour.iter().flatten().map(|x| x.to_bits()));
    v.extend(d.inv_z.iter().map(|x| x.to_bits()));
    v.extend(d.slopes.iter().flatten().map(|x| x.to_bits()));
    v.extend(d.fill_colour.iter().flatten().map(|x| x.to_bits()));
    v.extend(d.fill_weight.iter().map(|x| x.to_bits()));
    v.extend(f.pixels.iter().flatten().map(|x| x.to_bits()));
    v
}

/// Warp derived frame `k` of `t` under `cfg` at both levels; the first
/// difference, or how many kernels were drawn.
fn compare_frame(t: &Trace, k: usize, cfg: &GoldenConfig) -> Result<u64, String> {
    let ss = t.display.supersample;
    let refs: Vec<_> = t.derived[k]
        .references
        .iter()
        .map(|&r| prepare_reference(&t.load_reference(r).unwrap().samples, ss, cfg))
        .collect();
    let refs: Vec<_> = refs.iter().collect();
    let (mut baseline, mut widest) = (Warper::new(), Warper::new());
    baseline.baseline_instructions(true);
    assert_eq!(baseline.vector_level(), VectorLevel::BASELINE);
    assert_eq!(widest.vector_level(), VectorLevel::detect());
    let cmd = t.frame_commands(k);
    let (a, b) = (baseline.warp_frame(&cmd, &refs, cfg), widest.warp_frame(&cmd, &refs, cfg));
    if float_bits(&a) != float_bits(&b) {
        return Err(format!("frame {k}: float planes or pixels differ"));
    }
    let (x, y) = (&a.samples, &b.samples);
    if (&x.source, &x.hole, &x.real, &x.fill_valid, &x.fill_distance, &x.splat)
        != (&y.source, &y.hole, &y.real, &y.fill_valid, &y.fill_distance, &y.splat)
        || (&a.covered, &a.unseen) != (&b.covered, &b.unseen)
    {
        return Err(format!("frame {k}: integer or bit planes differ"));
    }
    if a.stats != b.stats {
        return Err(format!("frame {k}: counters differ: {:?} against {:?}", a.stats, b.stats));
    }
    Ok(a.stats.kernel_sizes.iter().flatten().sum::<u64>())
}

#[test]
fn an_avx2_host_warps_with_avx2() {
    #[cfg(target_arch = "x86_64")]
    {
        let all = ["avx2", "bmi1", "bmi2", "lzcnt"];
        let has = std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("bmi2")
            && std::arch::is_x86_feature_detected!("lzcnt");
        let want = if has { "avx2" } else { "baseline" };
        assert_eq!(Warper::new().vector_level().name(), want, "host features {all:?} present: {has}");
    }
    assert_eq!(VectorLevel::BASELINE.name(), "baseline");
}

#[test]
fn bundled_traces_warp_the_same_at_every_level() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("traces");
    let mut compared = 0;
    for name in ["room", "motorcycle"] {
        let t = Trace::open(&root.join(name)).unwrap();
        for (what, cfg) in configs(t.display.supersample) {
            let k = t.derived.len() - 1;
            let kernels = compare_frame(&t, k, &cfg).unwrap_or_else(|e| panic!("{name} {what}: {e}"));
            assert!(kernels > 0, "{name} {what}: something was drawn");
            compared += 1;
        }
    }
    assert_eq!(compared, 6);
}

/// Every derived frame of a `w`x`h` trace of `scene` at `ss`x`ss` samples
/// under configuration `mode` of [`configs`], at both levels.
fn compare_scene(scene: &str, (w, h, ss, mode): (u32, u32, u32, usize)) -> Result<u64, String> {
    let dir = tempfile::tempdir().unwrap();
    let spec = TraceSpec { width: w, height: h, supersample: ss, frames: 2, truth: false, ..TraceSpec::default() };
    let s = Scene::builtin(scene).unwrap();
    let manifest = make_trace(&s, &spec, &dir.path().join("t"), "props_vector_level").unwrap();
    let t = Trace::open(&manifest).unwrap();
    let cfg = configs(ss)[mode].1.clone();
    (0..t.derived.len()).map(|k| compare_frame(&t, k, &cfg)).sum()
}

proptest! {
    #![proptest_config(common::prop_config(16))]

    #[test]
    fn every_vector_level_warps_the_same_frames(
        scene in 0..Scene::builtin_names().len(),
        w in 3u32..=37,
        h in 3u32..=29,
        ss in 1u32..=3,
        mode in 0usize..3,
    ) {
        let name = Scene::builtin_names()[scene];
        let r = compare_scene(name, (w, h, ss, mode));
        prop_assert!(r.is_ok(), "{} at {}x{} px, {}x{} samples, {}: {}", name, w, h, ss, ss, configs(ss)[mode].0, r.unwrap_err());
        prop_assert!(r.unwrap() > 0, "{} at {}x{}: nothing was drawn", name, w, h);
    }
}
