//! `postwarp import-middlebury`: a Middlebury 2014 stereo folder → trace.

use crate::import::FillUnknownDepth;
use crate::picture::{box_filter, write_png};
use crate::trace::Trace;
use std::path::{Path, PathBuf};

/// Flags of `postwarp import-middlebury`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Middlebury 2014 folder with im0.png, im1.png, disp0.pfm, calib.txt.
    pub dir: PathBuf,
    /// Output trace directory (must not exist, unless --force; written
    /// under a temporary name beside it and renamed when complete).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
    /// Unknown disparity: `background` gives a pixel the farther known
    /// neighbour's disparity on its row (a heuristic, docs/real-data.md);
    /// `none` leaves it without a surface.
    #[arg(long, value_enum, default_value_t = FillUnknownDepth::default())]
    pub fill_unknown_depth: FillUnknownDepth,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let out = crate::io_util::OutDir::create(&a.out, a.force, &[&a.dir])?;
    let manifest = crate::import::middlebury::import_middlebury_with(&a.dir, out.path(), a.fill_unknown_depth)?;
    write_previews(&manifest)?;
    let dir = out.commit()?;
    eprintln!("wrote {}", dir.join(crate::trace::MANIFEST_NAME).display());
    Ok(())
}

/// PNG previews next to a trace: `preview/ref-NNNN.png` (box-filtered
/// colour) and `preview/truth-NNNN.png`, for people to look at.
pub fn write_previews(manifest: &Path) -> anyhow::Result<()> {
    let t = Trace::open(manifest)?;
    let dir = t.dir.join("preview");
    let ss = t.display.supersample;
    for i in 0..t.references.len() {
        let r = t.load_reference(i)?.samples;
        let px = box_filter(r.width, r.height, ss, &r.colour);
        write_png(&dir.join(format!("ref-{i:04}.png")), r.width / ss, r.height / ss, &px)?;
    }
    for i in 0..t.derived.len() {
        if let Some(truth) = t.load_truth(i)? {
            write_png(&dir.join(format!("truth-{i:04}.png")), truth.width, truth.height, &truth.colour)?;
        }
    }
    Ok(())
}
