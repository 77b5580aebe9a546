//! The source cache's smallest size (`docs/units.md`, fetch rule 2): the
//! largest block a reference can pack to
//! (`postwarp_rtl::config::largest_block_bytes`). A reference whose every
//! sample is a surface of its own reaches it exactly; no block of the
//! bundled traces' references exceeds it; `Engine::new` refuses a cache
//! one byte smaller, at the trace's super-sampling, with a message naming
//! the knob and what the bound was computed from.

use postwarp::trace::Trace;
use postwarp_rtl::SampleImage;
use postwarp_rtl::config::{EngineConfig, largest_block_bytes};
use postwarp_rtl::engine::{Engine, HwReference};
use std::path::PathBuf;

/// The largest packed block of `r` (blocks of `tile_size / ss` pixels).
fn largest_block(r: &HwReference, cfg: &EngineConfig) -> u64 {
    let side = cfg.tile_size / cfg.supersample;
    let (bw, bh) = (r.packed.width_pixels().div_ceil(side), r.packed.height_pixels().div_ceil(side));
    let mut most = 0;
    for by in 0..bh {
        for bx in 0..bw {
            most = most.max(r.packed.bytes_in_pixels(bx * side, by * side, (bx + 1) * side, (by + 1) * side));
        }
    }
    most
}

/// `w x h` samples, each a surface of its own: depths a factor of 10
/// apart within every pixel, and a different object for each.
fn every_sample_its_own_surface(w: u32, h: u32, ss: u32) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for y in 0..h {
        for x in 0..w {
            let i = img.index(x, y);
            let k = (y % ss) * ss + x % ss;
            img.z[i] = 10f32.powi(k as i32);
            img.colour[i] = [k as f32 / 16.0, 0.5, 0.25];
            img.object_id[i] = k;
            img.valid.set(i, true);
        }
    }
    img
}

fn configs(ss: u32) -> Vec<EngineConfig> {
    let base = EngineConfig { supersample: ss, ..EngineConfig::default() };
    let mut out: Vec<EngineConfig> =
        [0, 1, 2, 3, 4, 16].iter().map(|&f| EngineConfig { abuffer_fragments: f, ..base.clone() }).collect();
    out.push(EngineConfig { tile_size: 16, ..base });
    out
}

#[test]
fn a_reference_of_separate_samples_packs_a_block_to_the_bound_exactly() {
    for ss in [1, 2, 4] {
        for cfg in configs(ss) {
            let img = every_sample_its_own_surface(40, 24, ss);
            let r = HwReference::new(&img, &cfg);
            let what = format!("ss {ss}, {} fragments, tile {}", cfg.abuffer_fragments, cfg.tile_size);
            assert_eq!(largest_block(&r, &cfg), largest_block_bytes(&cfg), "{what}");
            // The engine refuses a source cache one byte short of it.
            let short = EngineConfig { source_cache_bytes: largest_block_bytes(&cfg) - 1, ..cfg.clone() };
            let e = Engine::new(short).err().unwrap_or_else(|| panic!("{what}: accepted"));
            assert!(e.starts_with("source_cache_bytes = "), "{what}: {e}");
            assert!(
                e.contains(&format!("supersample {ss}")) && e.contains(&format!("tile_size {}", cfg.tile_size)),
                "{e}"
            );
            assert!(Engine::new(EngineConfig { source_cache_bytes: largest_block_bytes(&cfg), ..cfg }).is_ok());
        }
    }
}

#[test]
fn no_block_of_a_bundled_reference_exceeds_the_bound() {
    for trace in ["hairball", "room", "motorcycle"] {
        let t = Trace::open(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap();
        let img = t.load_reference(0).unwrap().samples;
        for cfg in configs(t.display.supersample) {
            let r = HwReference::new(&img, &cfg);
            let (got, bound) = (largest_block(&r, &cfg), largest_block_bytes(&cfg));
            assert!(
                got <= bound,
                "{trace}, {} fragments, tile {}: {got} > {bound}",
                cfg.abuffer_fragments,
                cfg.tile_size
            );
        }
    }
}
