//! `postwarp score`: the frames a run wrote (`frame-NNNN.png` of `postwarp
//! golden`, `golden --method`, `simulate`, each run of `compare`) scored
//! again against the trace's ground truth, over the whole image and over
//! the truth's non-diffuse mask (`docs/non-diffuse.md`): the pixels where
//! a specular or semi-transparent surface is seen, and the rest.
//!
//! Rules:
//! 1. A frame PNG holds the 8-bit sRGB codes every metric scores
//!    (`docs/metrics.md`), and [`crate::picture::srgb_to_linear`] inverts
//!    them exactly: the whole-image scores equal the run's `report.json`
//!    (`psnr_luma_db`, `ssim_luma`, `flip_mean`; tested).
//! 2. Regions: `whole` = the truth's known pixels; `mask` = known pixels
//!    of the truth's `nondiffuse` mask; `rest` = known pixels outside it.
//!    A region is scored as [`crate::metrics::evaluate`] scores known
//!    pixels: the others are excluded (and, inside SSIM and FLIP windows,
//!    taken from the truth).
//! 3. Per region, each metric is the mean over the frames that have a
//!    ground truth (frames whose region is empty are left out of its
//!    mean); `mask_share` is the mean share of known pixels in the mask.
//! 4. A trace without the mask (a v1 trace, or a diffuse scene) gives only
//!    `whole`.
//! 5. A sweep run with `images = true` ([`sweep_region`]): every row of
//!    its `results.csv` scored again over one region from
//!    `DIR/images/<point>/` (the trace named by that run's `report.json`),
//!    written back as a `results.csv` whose `psnr_luma_db`, `ssim_luma`
//!    and `flip_mean` are the region's and whose `spec` ends in
//!    `-<region>`: `postwarp chart` draws it (the stability chart of the
//!    region) like any sweep's.
//!
//! Units: PSNR in dB, SSIM and FLIP unitless (1 = identical, 0 =
//! identical), shares as fractions.

use crate::metrics::{MetricInput, evaluate};
use crate::picture::srgb_to_linear;
use crate::report::Report;
use crate::trace::Trace;
use anyhow::{Context, bail};
use bitvec::vec::BitVec;
use std::path::{Path, PathBuf};

/// The region names, in column order.
pub const REGIONS: [&str; 3] = ["whole", "mask", "rest"];

/// Mean scores of one region.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RegionScore {
    /// Luma PSNR (dB).
    pub psnr_luma_db: f64,
    /// Luma SSIM (1 = identical).
    pub ssim_luma: f64,
    /// Mean FLIP (0 = identical).
    pub flip_mean: f64,
    /// Frames scored.
    pub frames: usize,
}

/// One run directory's scores.
#[derive(Clone, Debug, PartialEq)]
pub struct RunScore {
    /// The run directory.
    pub dir: PathBuf,
    /// `method + hole_fill` from its `report.json` (the directory name if
    /// it has none).
    pub label: String,
    /// Per [`REGIONS`] (`None` where the trace has no mask).
    pub regions: [Option<RegionScore>; 3],
    /// Mean share of known pixels in the mask.
    pub mask_share: Option<f64>,
}

/// The trace manifest and the `method + hole_fill` label of the run in
/// `dir`, read from its `report.json` through the typed reports.
pub fn run_header(dir: &Path) -> anyhow::Result<(String, String)> {
    Ok(match crate::report::load(dir)? {
        Report::Golden(r) => (r.trace, r.method),
        Report::Method(r) => (r.trace, format!("{} + {}", r.method, r.hole_fill)),
        Report::Simulate(r) => (r.trace, r.method),
    })
}

fn label(dir: &Path) -> String {
    match run_header(dir) {
        Ok((_, label)) => label,
        Err(_) => dir.file_name().map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into()),
    }
}

/// Read `dir/frame-<k>.png` as linear RGB of `w x h` pixels.
fn read_frame(dir: &Path, k: usize, (w, h): (u32, u32)) -> anyhow::Result<Vec<[f32; 3]>> {
    let path = dir.join(format!("frame-{k:04}.png"));
    let img = image::open(&path).with_context(|| format!("reading {}", path.display()))?.to_rgb8();
    if img.dimensions() != (w, h) {
        bail!("{}: {}x{} pixels; expected the trace's display {w}x{h}", path.display(), img.width(), img.height());
    }
    Ok(img.pixels().map(|p| p.0.map(srgb_to_linear)).collect())
}

/// Rules 1–4 for the frames in `dir`.
pub fn score_run(trace: &Trace, dir: &Path) -> anyhow::Result<RunScore> {
    let size = (trace.display.width, trace.display.height);
    let mut sums = [[0.0f64; 3]; 3];
    let mut counts = [0usize; 3];
    let (mut share_sum, mut share_n, mut has_mask) = (0.0, 0usize, false);
    for k in 0..trace.derived.len() {
        let Some(truth) = trace.load_truth(k)? else { continue };
        let image = read_frame(dir, k, size)?;
        let mut regions: Vec<(usize, BitVec)> = vec![(0, truth.known.clone())];
        if let Some(m) = &truth.nondiffuse {
            has_mask = true;
            let inside = truth.known.clone() & m.clone();
            let outside = truth.known.clone() & !m.clone();
            share_sum += inside.count_ones() as f64 / truth.known.count_ones().max(1) as f64;
            share_n += 1;
            regions.push((1, inside));
            regions.push((2, outside));
        }
        for (r, known) in regions {
            if known.not_any() {
                continue;
            }
            let q = evaluate(&MetricInput {
                width: size.0,
                height: size.1,
                image: &image,
                truth: &truth.colour,
                known: &known,
                covered: None,
                common: None,
                seen: None,
                // Scoring again is analysis, not a timed run: always FLIP.
                flip: true,
            })?;
            for (s, v) in sums[r].iter_mut().zip([q.psnr_luma_db, q.ssim_luma, q.flip_mean]) {
                *s += v;
            }
            counts[r] += 1;
        }
    }
    if counts[0] == 0 {
        bail!("{}: no derived frame has a ground truth to score against", trace.manifest.display());
    }
    let region = |r: usize| {
        (counts[r] > 0).then(|| {
            let n = counts[r] as f64;
            RegionScore {
                psnr_luma_db: sums[r][0] / n,
                ssim_luma: sums[r][1] / n,
                flip_mean: sums[r][2] / n,
                frames: counts[r],
            }
        })
    };
    Ok(RunScore {
        dir: dir.to_path_buf(),
        label: label(dir),
        regions: [region(0), if has_mask { region(1) } else { None }, if has_mask { region(2) } else { None }],
        mask_share: (share_n > 0).then(|| share_sum / share_n as f64),
    })
}

/// Rule 5 for the sweep in `dir` and region `region` (one of
/// [`REGIONS`]): the text of the region's `results.csv`.
pub fn sweep_region(dir: &Path, region: &str) -> anyhow::Result<String> {
    let r = REGIONS
        .iter()
        .position(|x| *x == region)
        .ok_or_else(|| anyhow::anyhow!("--region {region}: expected one of {}", REGIONS.join(", ")))?;
    let path = dir.join("results.csv");
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let rows = crate::report::csv::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let Some((header, rows)) = rows.split_first() else { bail!("{}: empty", path.display()) };
    let col = |name: &str| {
        header.iter().position(|h| h == name).ok_or_else(|| anyhow::anyhow!("{}: no `{name}` column", path.display()))
    };
    let (c_spec, c_point) = (col("spec")?, col("point")?);
    let metric_cols = [col("psnr_luma_db")?, col("ssim_luma")?, col("flip_mean")?];
    let mut traces: std::collections::HashMap<String, Trace> = std::collections::HashMap::new();
    let mut out = crate::report::csv::line(header);
    for row in rows {
        let mut row = row.clone();
        let run = dir.join("images").join(&row[c_point]);
        let (manifest, _) = run_header(&run).context("run the sweep with `images = true`")?;
        if !traces.contains_key(&manifest) {
            traces.insert(manifest.clone(), Trace::open(Path::new(&manifest))?);
        }
        let s = score_run(&traces[&manifest], &run)?;
        let reg = s.regions[r];
        for (c, v) in
            metric_cols.iter().zip([reg.map(|x| x.psnr_luma_db), reg.map(|x| x.ssim_luma), reg.map(|x| x.flip_mean)])
        {
            row[*c] = num(v);
        }
        row[c_spec] = format!("{}-{region}", row[c_spec]);
        out += &crate::report::csv::line(&row);
    }
    Ok(out)
}

/// The CSV header of [`csv`].
pub fn header() -> String {
    let mut cols = vec!["run".to_string(), "label".to_string()];
    for r in REGIONS {
        for m in ["psnr_luma_db", "ssim_luma", "flip_mean"] {
            cols.push(format!("{r}_{m}"));
        }
    }
    cols.push("mask_share".into());
    cols.join(",")
}

fn num(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite()).map_or_else(String::new, |x| x.to_string())
}

/// The scores as CSV (a header line, then a row per run).
pub fn csv(rows: &[RunScore]) -> String {
    let mut s = header() + "\n";
    for r in rows {
        let mut cols = vec![r.dir.display().to_string(), r.label.clone()];
        for reg in &r.regions {
            cols.push(num(reg.map(|x| x.psnr_luma_db)));
            cols.push(num(reg.map(|x| x.ssim_luma)));
            cols.push(num(reg.map(|x| x.flip_mean)));
        }
        cols.push(num(r.mask_share));
        s += &(cols.join(",") + "\n");
    }
    s
}

/// The scores as a Markdown table.
pub fn markdown(rows: &[RunScore]) -> String {
    let mut s = String::from(
        "| run | whole PSNR dB | whole SSIM | whole FLIP | mask PSNR dB | mask SSIM | mask FLIP | rest PSNR dB | rest SSIM | rest FLIP | mask share |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let f = |v: Option<f64>, d: usize| v.filter(|x| x.is_finite()).map_or_else(|| "–".into(), |x| format!("{x:.d$}"));
    for r in rows {
        s += &format!("| {} |", r.label);
        for reg in &r.regions {
            s += &format!(
                " {} | {} | {} |",
                f(reg.map(|x| x.psnr_luma_db), 2),
                f(reg.map(|x| x.ssim_luma), 4),
                f(reg.map(|x| x.flip_mean), 4)
            );
        }
        s +=
            &format!(" {} |\n", f(r.mask_share.map(|x| 100.0 * x), 1) + if r.mask_share.is_some() { " %" } else { "" });
    }
    s
}
