//! The hardware model against the golden model on the bundled traces.

use postwarp::golden::frame::{Warper, prepare_reference};
use postwarp::run::hw_config::golden_config_for;
use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, HwReference};
use std::path::Path;

fn compare(trace: &str, frames: &[usize], cfg: EngineConfig) {
    let t = Trace::open(&Path::new(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap();
    let gcfg = golden_config_for(&cfg);
    let mut engine = Engine::new(cfg.clone()).unwrap();
    let mut warper = Warper::new();
    for &k in frames {
        let f = &t.derived[k];
        let loaded: Vec<_> = f.references.iter().map(|&r| t.load_reference(r).unwrap().samples).collect();
        let golden_refs: Vec<_> = loaded.iter().map(|s| prepare_reference(s, cfg.supersample, &gcfg)).collect();
        let hw_refs: Vec<_> = loaded.iter().map(|s| HwReference::new(s, &cfg)).collect();
        let cmd = t.frame_commands(k);
        let g = warper.warp_frame(&cmd, &golden_refs.iter().collect::<Vec<_>>(), &gcfg);
        let h = engine.run_frame(&cmd, &hw_refs.iter().collect::<Vec<_>>());
        let d = &g.samples;
        let mut diff = 0;
        for i in 0..d.len() {
            let same = d.colour[i] == h.frame.samples[i].colour
                && d.real[i] == h.frame.real[i]
                && d.hole[i] == h.frame.hole[i]
                && (!d.real[i] || d.inv_z[i] == h.frame.samples[i].inv_z);
            if !same {
                if diff < 5 {
                    eprintln!(
                        "{trace} frame {k} sample {} ({}, {}): golden {:?} {:?} real {} hole {} / hw {:?} {:?} real {} hole {}",
                        i,
                        i % d.width as usize,
                        i / d.width as usize,
                        d.colour[i],
                        d.inv_z[i],
                        d.real[i],
                        d.hole[i],
                        h.frame.samples[i].colour,
                        h.frame.samples[i].inv_z,
                        h.frame.real[i],
                        h.frame.hole[i]
                    );
                }
                diff += 1;
            }
        }
        eprintln!("{trace} frame {k}: {} cycles, {diff} differing samples, stats {:?}", h.stats.cycles, h.stats.units);
        assert_eq!(diff, 0, "{trace} frame {k}: hardware differs from golden");
        assert_eq!(g.pixels, h.pixels);
    }
}

#[test]
fn room_first_frame_matches_golden() {
    compare("room", &[0], EngineConfig::default());
}

#[test]
fn every_bundled_trace_matches_golden_bit_for_bit() {
    for trace in ["room", "slants", "hairball", "occluders", "motorcycle"] {
        let t = Trace::open(&Path::new(env!("CARGO_MANIFEST_DIR")).join("traces").join(trace)).unwrap();
        let frames: Vec<usize> = (0..t.derived.len()).collect();
        let cfg = EngineConfig { supersample: t.display.supersample, ..EngineConfig::default() };
        compare(trace, &frames, cfg);
    }
}
