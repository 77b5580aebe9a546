//! `postwarp golden`: run the golden model over every derived frame of a
//! trace, score each frame against its ground truth, write the images and
//! the report.
//!
//! Rules:
//! 1. Each reference frame is loaded and passed through the A-buffer once,
//!    and dropped after the last derived frame that uses it.
//! 2. Frames run one after another on one thread, so `host_ms` is the
//!    single-core time of `warp_frame` (reference preparation is reported
//!    separately as `prepare_ms`).
//! 3. Outputs per frame: `frame-NNNN.png` (resolved), `frame-NNNN.exr`
//!    (derived samples in the reference-image format: colour, Z, slopes,
//!    `valid` = real surface), `holes-NNNN.png`, and with ground truth
//!    `diff-NNNN.png`. Then `report.json`. All written atomically.

use crate::golden::config::GoldenConfig;
use crate::golden::frame::{GoldenFrame, PreparedReference, Warper, prepare_reference};
use crate::report::images::write_hole_mask;
use crate::report::{frame_entry, mean_entry, table};
use crate::trace::{SlopeSource, Trace, write_reference_image};
use anyhow::Context;
use postwarp_rtl::SampleImage;
use serde_json::{Value, json};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// What a golden run produced.
pub struct GoldenRun {
    /// The report (`report.json` contents).
    pub report: Value,
    /// The printed table.
    pub table: String,
}

/// The derived frame's samples in the reference-image format.
pub fn frame_samples(f: &GoldenFrame) -> SampleImage {
    let d = &f.samples;
    let mut s = SampleImage::empty(d.width, d.height);
    for i in 0..d.len() {
        s.colour[i] = d.colour[i];
        s.inv_z_slopes[i] = d.slopes[i];
        // `id` holds 1 + the writing reference's position in the warp list.
        s.object_id[i] = if d.real[i] { d.source[i] as u32 + 1 } else { 0 };
        if d.real[i] {
            s.z[i] = 1.0 / d.inv_z[i];
            s.valid.set(i, true);
        }
    }
    s
}

/// Run the golden model on `trace` with `cfg`, writing into `out`.
pub fn run_golden(trace: &Trace, cfg: &GoldenConfig, out: &Path) -> anyhow::Result<GoldenRun> {
    cfg.validate().map_err(|e| anyhow::anyhow!("golden configuration: {e}"))?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let ss = trace.display.supersample;
    let (w, h) = (trace.display.width, trace.display.height);
    let last_use = trace.last_use();
    let mut prepared: HashMap<usize, PreparedReference> = HashMap::new();
    let mut slopes = vec![Value::Null; trace.references.len()];
    let mut prepare_ms = 0.0;
    let mut frames = Vec::new();
    let mut warper = Warper::new();
    let bar = crate::progress::bar(trace.derived.len() as u64, "golden");
    for (k, f) in trace.derived.iter().enumerate() {
        for &r in &f.references {
            if let std::collections::hash_map::Entry::Vacant(e) = prepared.entry(r) {
                let loaded = trace.load_reference(r)?;
                slopes[r] = json!(loaded.slopes.name());
                let t = Instant::now();
                e.insert(prepare_reference(&loaded.samples, ss, cfg));
                prepare_ms += t.elapsed().as_secs_f64() * 1e3;
            }
        }
        let cmd = trace.frame_commands(k);
        let refs: Vec<&PreparedReference> = f.references.iter().map(|r| &prepared[r]).collect();
        let t = Instant::now();
        let frame = warper.warp_frame(&cmd, &refs, cfg);
        let host_ms = t.elapsed().as_secs_f64() * 1e3;
        let quality = super::score::score_frame(trace, k, (w, h), &frame.pixels, &frame.covered, Some(out))?;
        write_frame_files(out, k, &frame, w, h, ss)?;
        frames.push(frame_entry(k, quality.as_ref(), host_ms, stats_json(&frame)));
        prepared.retain(|r, _| last_use[r] > k);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let mean = mean_entry(&frames);
    let table = table::render(&frames, &mean);
    let report = json!({
        "trace": trace.manifest.display().to_string(),
        "method": method_name(cfg),
        "config": serde_json::to_value(cfg)?,
        "references": {"slopes": slopes, "prepare_ms": prepare_ms},
        "frames": frames,
        "mean": mean,
    });
    let text = serde_json::to_string_pretty(&report)? + "\n";
    crate::io_util::write_bytes_atomically(&out.join("report.json"), text.as_bytes())?;
    Ok(GoldenRun { report, table })
}

/// The report's `method` name for a golden configuration.
pub fn method_name(cfg: &GoldenConfig) -> &'static str {
    match cfg.reconstruction {
        crate::golden::config::Reconstruction::AaRect => "mark-aa",
        crate::golden::config::Reconstruction::General => "mark-general",
    }
}

fn stats_json(f: &GoldenFrame) -> Value {
    serde_json::to_value(&f.stats).expect("stats serialize")
}

fn write_frame_files(out: &Path, k: usize, f: &GoldenFrame, w: u32, h: u32, ss: u32) -> anyhow::Result<()> {
    crate::picture::write_png(&out.join(format!("frame-{k:04}.png")), w, h, &f.pixels)?;
    write_reference_image(&out.join(format!("frame-{k:04}.exr")), &frame_samples(f), SlopeSource::Exact)?;
    write_hole_mask(&out.join(format!("holes-{k:04}.png")), w, h, ss, &f.samples.real, &f.samples.hole)?;
    Ok(())
}
