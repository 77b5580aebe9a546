//! The golden model warps the same frames at every vector level
//! (`golden::vector_level`): random built-in scenes at random small display
//! sizes (odd widths leave every loop a partial vector at its end),
//! super-sampling 1 to 3, in the float and fixed datapaths and with the
//! general reconstruction, warped by a warper held to the baseline and by
//! one at the host's widest level: planes, pixels and counters equal bit
//! for bit.

use postwarp::golden::config::{GoldenConfig, Reconstruction};
use postwarp::golden::frame::{Warper, prepare_reference};
use postwarp::run::hw_config::golden_config_for;
use postwarp::scene::Scene;
use postwarp::trace::Trace;
use postwarp::tracegen::{TraceSpec, make_trace};
use postwarp_rtl::config::EngineConfig;
use proptest::prelude::*;

use crate::common;

/// Warp every derived frame of a `w`x`h` trace of `scene` at `ss`x`ss`
/// samples under datapath `mode` (0 float, 1 fixed, 2 general) at both
/// levels; the first difference, or how many kernels were drawn.
fn compare(scene: &str, (w, h, ss, mode): (u32, u32, u32, u32)) -> Result<u64, String> {
    let dir = tempfile::tempdir().unwrap();
    let spec = TraceSpec { width: w, height: h, supersample: ss, frames: 2, truth: false, ..TraceSpec::default() };
    let s = Scene::builtin(scene).unwrap();
    let manifest = make_trace(&s, &spec, &dir.path().join("t"), "props_vector_level").unwrap();
    let t = Trace::open(&manifest).unwrap();
    let cfg = match mode {
        0 => GoldenConfig::default(),
        1 => golden_config_for(&EngineConfig { supersample: ss, arith: "fixed".into(), ..EngineConfig::default() }),
        _ => GoldenConfig { reconstruction: Reconstruction::General, ..GoldenConfig::default() },
    };
    let (mut baseline, mut widest) = (Warper::new(), Warper::new());
    baseline.baseline_instructions(true);
    let mut kernels = 0;
    for k in 0..t.derived.len() {
        let refs: Vec<_> = t.derived[k]
            .references
            .iter()
            .map(|&r| prepare_reference(&t.load_reference(r).unwrap().samples, ss, &cfg))
            .collect();
        let refs: Vec<_> = refs.iter().collect();
        let cmd = t.frame_commands(k);
        let (a, b) = (baseline.warp_frame(&cmd, &refs, &cfg), widest.warp_frame(&cmd, &refs, &cfg));
        if a.samples != b.samples || (&a.pixels, &a.covered, &a.unseen) != (&b.pixels, &b.covered, &b.unseen) {
            return Err(format!("frame {k}: planes or pixels differ"));
        }
        if a.stats != b.stats {
            return Err(format!("frame {k}: counters differ: {:?} against {:?}", a.stats, b.stats));
        }
        kernels += a.stats.kernel_sizes.iter().flatten().sum::<u64>();
    }
    Ok(kernels)
}

proptest! {
    #![proptest_config(common::prop_config(16))]

    #[test]
    fn every_vector_level_warps_the_same_frames(
        scene in 0..Scene::builtin_names().len(),
        w in 3u32..=37,
        h in 3u32..=29,
        ss in 1u32..=3,
        mode in 0u32..=2,
    ) {
        let name = Scene::builtin_names()[scene];
        let r = compare(name, (w, h, ss, mode));
        prop_assert!(r.is_ok(), "{} at {}x{} px, {}x{} samples, mode {}: {}", name, w, h, ss, ss, mode, r.unwrap_err());
        prop_assert!(r.unwrap() > 0, "{} at {}x{}: nothing was drawn", name, w, h);
    }
}
