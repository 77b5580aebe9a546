//! `postwarp golden --method NAME [--hole-fill NAME]`: run any comparison
//! method (`methods`) over every derived frame of a trace, score each frame
//! against its ground truth, write the images and the report.
//!
//! Rules (the same for every method; `methods` module doc):
//! 1. Each reference frame is loaded once and passed through
//!    [`Reconstruction::prepare`], timed apart (`prepare_ms`), and dropped
//!    after the last derived frame that uses it.
//! 2. Each frame runs `runs` times on this thread into a fresh output
//!    frame allocated before the clock starts; `host_ms` is the median. All
//!    runs must give the same samples (else the run fails: the method is
//!    not deterministic).
//!    The timed section is [`timing::timed`](super::timing::timed): one at a
//!    time in the process.
//! 3. Outputs per frame: `frame-NNNN.png`, `holes-NNNN.png` and, with
//!    ground truth, `diff-NNNN.png`; then `report.json`. All written
//!    atomically. [`measure_method`] without an output directory writes
//!    nothing and returns the same report (`postwarp sweep`).

use crate::methods::{self, HoleFill, Input, MethodFrame, Prepared, Reconstruction};
use crate::report::MethodReport;
use crate::report::images::write_hole_mask;
use crate::report::method::{MethodCounters, MethodFrame as FrameEntry, MethodHeader, MethodReferences};
use crate::report::quality::{Pixels, Scores};
use crate::report::table;
use crate::trace::Trace;
use anyhow::Context;
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

use super::timing::timed;

/// What a method run produced.
pub struct MethodRun {
    /// The report (`report.json` contents).
    pub report: MethodReport,
    /// The printed table.
    pub table: String,
}

/// Median of `v` (not empty).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Run `rec` + `fill` on `trace`, `runs` times per frame, writing the
/// frames and `report.json` into `out`, with a progress bar on a terminal.
pub fn run_method(
    trace: &Trace,
    rec: &dyn Reconstruction,
    fill: &dyn HoleFill,
    runs: u32,
    flip: bool,
    out: &Path,
) -> anyhow::Result<MethodRun> {
    let bar = crate::progress::bar(trace.derived.len() as u64, rec.info().name);
    let r = measure_method(trace, rec, fill, runs, flip, Some(out), &bar)?;
    bar.finish_and_clear();
    Ok(r)
}

/// Run `rec` + `fill` on `trace`, `runs` times per frame, and build the
/// report (FLIP only with `flip`); with `out`, also write the frame files
/// and `report.json` there. `bar` advances once per frame.
pub fn measure_method(
    trace: &Trace,
    rec: &dyn Reconstruction,
    fill: &dyn HoleFill,
    runs: u32,
    flip: bool,
    out: Option<&Path>,
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<MethodRun> {
    anyhow::ensure!(runs >= 1, "--runs must be at least 1");
    if let Some(out) = out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    }
    let ss = trace.display.supersample;
    let (w, h) = (trace.display.width, trace.display.height);
    let last_use = trace.last_use();
    let mut loaded: HashMap<usize, (postwarp_rtl::SampleImage, Prepared)> = HashMap::new();
    let mut prepare_ms = 0.0;
    let mut frames = Vec::new();
    for (k, f) in trace.derived.iter().enumerate() {
        for &r in &f.references {
            if let std::collections::hash_map::Entry::Vacant(e) = loaded.entry(r) {
                let img = trace.load_reference(r)?.samples;
                let layers = trace.load_layers(r)?;
                let t = Instant::now();
                let p = rec.prepare_layers(&img, &layers, &trace.references[r].camera, ss);
                prepare_ms += t.elapsed().as_secs_f64() * 1e3;
                e.insert((img, p));
            }
        }
        let cmd = trace.frame_commands(k);
        let refs: Vec<&postwarp_rtl::SampleImage> = f.references.iter().map(|r| &loaded[r].0).collect();
        let prepared: Vec<&Prepared> = f.references.iter().map(|r| &loaded[r].1).collect();
        let input = Input { cmd: &cmd, refs: &refs, prepared: &prepared };
        let mut times = Vec::new();
        let mut frame: Option<MethodFrame> = None;
        for run in 0..runs {
            let empty = input.empty_frame();
            let (got, ms) = timed(|| methods::render(rec, fill, &input, empty));
            times.push(ms);
            if let Some(first) = &frame {
                anyhow::ensure!(
                    first.samples == got.samples,
                    "method {} with hole fill {} gave different samples on run {run} of frame {k}: not deterministic",
                    rec.info().name,
                    fill.info().name
                );
            } else {
                frame = Some(got);
            }
        }
        let frame = frame.expect("runs >= 1");
        // The truth loads after the timed runs, which have the core alone.
        let truth = trace.load_truth(k)?;
        let quality = super::score::score_frame(truth.as_ref(), k, (w, h), &frame.pixels, &frame.covered, flip, out)?;
        if let Some(out) = out {
            crate::picture::write_png(&out.join(format!("frame-{k:04}.png")), w, h, &frame.pixels)?;
            write_hole_mask(
                &out.join(format!("holes-{k:04}.png")),
                w,
                h,
                ss,
                &frame.samples.real,
                &frame.samples.hole,
            )?;
        }
        let empty = (0..frame.samples.len()).filter(|&i| !frame.samples.real[i] && !frame.samples.hole[i]).count();
        frames.push(FrameEntry {
            index: k,
            scores: Scores::of(quality.as_ref()),
            pixels: Pixels::of(quality.as_ref()),
            host_ms: median(times),
            primitives: frame.reconstruction.primitives,
            hole_samples: frame.samples.hole.count_ones() as u64,
            empty_samples: empty as u64,
            reconstruction: MethodCounters(frame.reconstruction.extra.clone()),
            hole_fill: MethodCounters(frame.hole_fill.extra.clone()),
        });
        loaded.retain(|r, _| last_use[r] > k);
        bar.inc(1);
    }
    let info = rec.info();
    let header = MethodHeader {
        trace: trace.manifest.display().to_string(),
        flip,
        method: info.name.into(),
        hole_fill: fill.info().name.into(),
        paper: info.paper.into(),
        primitive: info.primitive.into(),
        runs,
    };
    let report = MethodReport::new(header, MethodReferences { prepare_ms }, frames);
    let table = table::method_table(&report);
    if let Some(out) = out {
        crate::report::write(&report, out)?;
    }
    Ok(MethodRun { report, table })
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(vec![7.0]), 7.0);
    }
}
