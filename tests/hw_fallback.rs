//! The fallback fill (golden `fallback_fill.rs`, hardware
//! `units::fallback_fill`) on a frame with an unseen border: the derived
//! camera moved sideways past what the reference saw, so Mark's epipolar
//! passes leave a strip along the image border empty.
//!
//! Checked: with `fallback_fill` on, no sample is left empty and the strip
//! is what both models report as unseen; off, the strip stays empty
//! (black); the hardware model's frame equals the golden model's bit for
//! bit at several configurations (2x2 samples, so changed pixels are
//! re-packed with real samples beside them; a small cache, so the pass
//! spills and reloads tiles; wide lanes); the pass's cycles and bytes are
//! counted, and the engine's idle skipping stays exact through it.

use crate::common::{Layer, at_x, render};
use postwarp::golden::frame::{GoldenFrame, prepare_reference, warp_frame};
use postwarp::run::hw_config::golden_config_for;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, FrameOutput, HwReference};
use postwarp_rtl::{Camera, FrameCommands, SampleImage};

const W: u32 = 40;
const H: u32 = 24;
const SS: u32 = 2;

fn stripes(x: f64) -> [f32; 3] {
    let v = 0.2 + 0.6 * (x * 3.0).sin().abs() as f32;
    [v, 0.5, 1.0 - v]
}

fn red(_: f64) -> [f32; 3] {
    [1.0, 0.1, 0.1]
}

/// The reference at the origin, a foreground bar in front of a backdrop
/// that ends inside the derived view; the derived camera 0.4 to the right.
fn scene() -> (Camera, SampleImage, FrameCommands) {
    let layers =
        [Layer { z: 8.0, x0: -100.0, x1: 100.0, colour: stripes }, Layer { z: 3.0, x0: -0.3, x1: 0.25, colour: red }];
    let reference = at_x(W, H, 0.0);
    let img = render(&reference, SS, &layers);
    let derived = at_x(W, H, 0.4);
    let cmd = FrameCommands::new(0, derived, SS, &[(0, reference)]);
    (reference, img, cmd)
}

fn golden(cfg: &EngineConfig, img: &SampleImage, cmd: &FrameCommands) -> GoldenFrame {
    let g = golden_config_for(cfg);
    let p = prepare_reference(img, SS, &g);
    warp_frame(cmd, &[&p], &g)
}

fn hardware(cfg: &EngineConfig, img: &SampleImage, cmd: &FrameCommands, skip: bool) -> FrameOutput {
    let mut e = Engine::new(cfg.clone()).unwrap();
    e.skip_idle(skip);
    e.run_frame(cmd, &[&HwReference::new(img, cfg)])
}

fn empty(real: &bitvec::vec::BitVec, hole: &bitvec::vec::BitVec) -> usize {
    (0..real.len()).filter(|&i| !real[i] && !hole[i]).count()
}

fn bits(v: &[[f32; 3]]) -> Vec<[u32; 3]> {
    v.iter().map(|c| c.map(f32::to_bits)).collect()
}

fn configs() -> Vec<(&'static str, EngineConfig)> {
    let base = EngineConfig { supersample: SS, ..EngineConfig::default() };
    vec![
        ("default", base.clone()),
        ("small-cache", EngineConfig { dest_cache_bytes: 8 * 8 * 16 * 8, ..base.clone() }),
        ("wide", EngineConfig { hole_fill_per_cycle: 4, rects_per_cycle: 4, transform_throughput: 4, ..base.clone() }),
        ("raw", EngineConfig { abuffer_fragments: 0, ..base }),
    ]
}

#[test]
fn without_the_fallback_the_unseen_border_stays_black() {
    let (_, img, cmd) = scene();
    let cfg = EngineConfig { supersample: SS, fallback_fill: false, ..EngineConfig::default() };
    let g = golden(&cfg, &img, &cmd);
    assert!(empty(&g.samples.real, &g.samples.hole) > 2 * H as usize, "a strip stays empty");
    assert!(g.unseen.not_any());
    let hw = hardware(&cfg, &img, &cmd, true);
    assert_eq!(hw.stats.empty_samples as usize, empty(&g.samples.real, &g.samples.hole));
    assert_eq!((hw.stats.fallback_cycles, hw.stats.fallback_filled), (0, 0));
}

#[test]
fn the_fallback_leaves_no_empty_sample_and_both_models_agree_bit_for_bit() {
    let (_, img, cmd) = scene();
    let off = golden(&EngineConfig { supersample: SS, fallback_fill: false, ..EngineConfig::default() }, &img, &cmd);
    let strip = empty(&off.samples.real, &off.samples.hole);
    for (name, cfg) in configs() {
        let g = golden(&cfg, &img, &cmd);
        assert_eq!(empty(&g.samples.real, &g.samples.hole), 0, "{name}: golden leaves an empty sample");
        assert_eq!(g.stats.fallback_filled as usize, strip, "{name}: the fallback fills exactly the strip");
        assert_eq!(g.stats.fallback_unreached, 0);
        // The unseen pixels hold the strip's samples (and only pixels with one).
        let pw = W as usize;
        for (p, unseen) in g.unseen.iter().enumerate() {
            let (px, py) = (p % pw, p / pw);
            let any_empty = (0..4).any(|k| {
                let i = (py * 2 + k / 2) * (2 * pw) + px * 2 + k % 2;
                !off.samples.real[i] && !off.samples.hole[i]
            });
            assert_eq!(*unseen, any_empty, "{name}: pixel ({px}, {py})");
        }
        let hw = hardware(&cfg, &img, &cmd, true);
        assert_eq!(hw.stats.empty_samples, 0, "{name}");
        assert_eq!(bits(&hw.frame.plane(|s| s.colour)), bits(&g.samples.colour), "{name}: colour plane");
        assert_eq!(hw.frame.hole, g.samples.hole, "{name}: hole plane");
        assert_eq!(hw.frame.real, g.samples.real, "{name}: real plane");
        let w = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(w(&hw.frame.plane(|s| s.fill_weight)), w(&g.samples.fill_weight), "{name}: weights");
        assert_eq!(bits(&hw.pixels), bits(&g.pixels), "{name}: pixels");
        assert_eq!(hw.unseen, g.unseen, "{name}: unseen pixels");
        let s = &hw.stats;
        assert_eq!(s.fallback_filled as usize, strip, "{name}");
        assert_eq!(s.unseen_pixels as usize, g.unseen.count_ones(), "{name}");
        assert!(s.fallback_cycles >= s.fallback_visits / cfg.hole_fill_per_cycle as u64, "{name}: {s:?}");
        assert!(s.fallback_tile_loads > 0 && s.fallback_tiles_written > 0, "{name}: {s:?}");
        assert!(s.fallback_visits < (4 * W * H) as u64, "{name}: clean tiles are skipped");
        for (unit, u) in postwarp_rtl::engine::UNITS.iter().zip(&s.units) {
            assert_eq!(u.total(), s.cycles, "{name}: {unit} cycles tile the frame");
        }
        if name == "small-cache" {
            assert!(s.dest_cache.spills > 0, "the small cache spills: {s:?}");
        }
    }
}

#[test]
fn the_fallback_costs_cycles_and_bytes_and_skipping_stays_exact() {
    let (_, img, cmd) = scene();
    for (name, cfg) in configs() {
        let on = hardware(&cfg, &img, &cmd, true);
        let off = hardware(&EngineConfig { fallback_fill: false, ..cfg.clone() }, &img, &cmd, true);
        assert!(on.stats.cycles > off.stats.cycles, "{name}: the pass takes cycles");
        assert!(on.stats.fallback_cycles > 0 && off.stats.fallback_cycles == 0, "{name}");
        assert!(on.stats.dram.bytes_read > off.stats.dram.bytes_read, "{name}: tiles read back");
        assert!(on.stats.dram.bytes_written > off.stats.dram.bytes_written, "{name}: changed tiles written");
        let stepped = hardware(&cfg, &img, &cmd, false);
        assert_eq!(stepped.stats.flat(), on.stats.flat(), "{name}: stepping every cycle");
        assert_eq!(bits(&stepped.pixels), bits(&on.pixels), "{name}");
    }
}
