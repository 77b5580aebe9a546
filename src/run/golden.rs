//! `postwarp golden`: run the golden model over every derived frame of a
//! trace, score each frame against its ground truth, write the images and
//! the report.
//!
//! Rules:
//! 1. Each reference frame is loaded and passed through the A-buffer once,
//!    and dropped after the last derived frame that uses it.
//! 2. Frames run one after another on one thread, so `host_ms` is the
//!    single-core time of `warp_frame` (reference preparation is reported
//!    separately as `prepare_ms`). The frame's truth decodes on another
//!    core meanwhile (it shares the memory bus, not the core); the engine
//!    alone is `postwarp bench`'s `engine golden` row.
//! 3. Outputs per frame: `frame-NNNN.png` (resolved), `frame-NNNN.exr`
//!    (derived samples in the reference-image format: colour, Z, slopes,
//!    `valid` = real surface), `holes-NNNN.png`, and with ground truth
//!    `diff-NNNN.png`. Then `report.json`. All written atomically.

use super::frame_exr::{Planes, derived_samples, write_frame_exr};
use crate::golden::config::GoldenConfig;
use crate::golden::frame::{GoldenFrame, PreparedReference, Warper, prepare_reference_owned};
use crate::report::GoldenReport;
use crate::report::golden::{GoldenCounters, GoldenFrame as FrameEntry, GoldenReferences};
use crate::report::images::write_hole_mask;
use crate::report::quality::{Pixels, Scores};
use crate::report::table;
use crate::trace::Trace;
use anyhow::Context;
use postwarp_rtl::SampleImage;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// What a golden run produced.
pub struct GoldenRun {
    /// The report (`report.json` contents).
    pub report: GoldenReport,
    /// The printed table.
    pub table: String,
}

fn planes(f: &GoldenFrame) -> Planes<'_> {
    let d = &f.samples;
    Planes {
        width: d.width,
        height: d.height,
        colour: &d.colour,
        inv_z: &d.inv_z,
        slopes: &d.slopes,
        source: &d.source,
        real: &d.real,
    }
}

/// The derived frame's samples in the reference-image format.
pub fn frame_samples(f: &GoldenFrame) -> SampleImage {
    derived_samples(&planes(f))
}

/// Run the golden model on `trace` with `cfg`, writing into `out`; FLIP
/// is scored only with `flip`.
pub fn run_golden(trace: &Trace, cfg: &GoldenConfig, flip: bool, out: &Path) -> anyhow::Result<GoldenRun> {
    cfg.validate().map_err(|e| anyhow::anyhow!("golden configuration: {e}"))?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let ss = trace.display.supersample;
    let (w, h) = (trace.display.width, trace.display.height);
    let last_use = trace.last_use();
    let mut prepared: HashMap<usize, PreparedReference> = HashMap::new();
    let mut slopes: Vec<Option<String>> = vec![None; trace.references.len()];
    let mut prepare_ms = 0.0;
    let mut frames = Vec::new();
    let mut warper = Warper::new();
    warper.trim_frames(true);
    let bar = crate::progress::bar(trace.derived.len() as u64, "golden");
    for (k, f) in trace.derived.iter().enumerate() {
        // The frame's ground truth loads beside its references and warp
        // (another core's work; a one-reference frame leaves it free).
        let (truth, warped) = rayon::join(
            || trace.load_truth(k),
            || -> anyhow::Result<(GoldenFrame, f64)> {
                // The references not yet prepared, loaded and prepared in
                // parallel (each alone: the same planes whatever the thread
                // count).
                let mut missing: Vec<usize> =
                    f.references.iter().copied().filter(|r| !prepared.contains_key(r)).collect();
                missing.sort_unstable();
                missing.dedup();
                let loaded: Vec<anyhow::Result<(usize, String, PreparedReference, f64)>> = missing
                    .par_iter()
                    .map(|&r| {
                        let loaded = trace.load_reference(r)?;
                        let slopes = loaded.slopes.name().to_string();
                        let t = Instant::now();
                        let p = prepare_reference_owned(loaded.samples, ss, cfg);
                        Ok((r, slopes, p, t.elapsed().as_secs_f64() * 1e3))
                    })
                    .collect();
                for l in loaded {
                    let (r, name, p, ms) = l?;
                    slopes[r] = Some(name);
                    prepared.insert(r, p);
                    prepare_ms += ms;
                }
                let cmd = trace.frame_commands(k);
                let refs: Vec<&PreparedReference> = f.references.iter().map(|r| &prepared[r]).collect();
                // The last frame's working buffers go as soon as its last
                // warp is done, before it is resolved, scored and written.
                warper.keep_buffers(k + 1 < trace.derived.len());
                let t = Instant::now();
                let frame = warper.warp_frame(&cmd, &refs, cfg);
                Ok((frame, t.elapsed().as_secs_f64() * 1e3))
            },
        );
        let (frame, host_ms) = warped?;
        let truth = truth?;
        // References this frame was the last to use go before scoring and
        // writing, which need memory of their own.
        prepared.retain(|r, _| last_use[r] > k);
        // Scoring (with the heat-map) beside writing the frame's files.
        let (quality, written) = rayon::join(
            || super::score::score_frame(truth.as_ref(), k, (w, h), &frame.pixels, &frame.covered, flip, Some(out)),
            || write_frame_files(out, k, &frame, w, h, ss),
        );
        let quality = quality?;
        written?;
        frames.push(FrameEntry::new(
            k,
            Scores::of(quality.as_ref()),
            Pixels::of(quality.as_ref()),
            host_ms,
            w as u64 * h as u64,
            GoldenCounters::of(&frame.stats),
        ));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let report = GoldenReport::new(
        trace.manifest.display().to_string(),
        flip,
        method_name(cfg).into(),
        cfg.clone(),
        GoldenReferences { slopes, prepare_ms },
        frames,
    );
    let table = table::golden_table(&report);
    crate::report::write(&report, out)?;
    Ok(GoldenRun { report, table })
}

/// The report's `method` name for a golden configuration.
pub fn method_name(cfg: &GoldenConfig) -> &'static str {
    match cfg.reconstruction {
        crate::golden::config::Reconstruction::AaRect => "mark-aa",
        crate::golden::config::Reconstruction::General => "mark-general",
    }
}

fn write_frame_files(out: &Path, k: usize, f: &GoldenFrame, w: u32, h: u32, ss: u32) -> anyhow::Result<()> {
    let (exr, pngs) = rayon::join(
        || write_frame_exr(&out.join(format!("frame-{k:04}.exr")), &planes(f)),
        || -> anyhow::Result<()> {
            crate::picture::write_png(&out.join(format!("frame-{k:04}.png")), w, h, &f.pixels)?;
            write_hole_mask(&out.join(format!("holes-{k:04}.png")), w, h, ss, &f.samples.real, &f.samples.hole)
        },
    );
    exr?;
    pngs
}
