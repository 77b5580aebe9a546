//! `postwarp info TRACE`: what a trace holds, read back from disk (every
//! image is loaded and checked).

use crate::trace::Trace;
use postwarp_rtl::camera::EpipoleKind;
use postwarp_rtl::{Camera, WarpSetup};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Flags of `postwarp info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest).
    pub trace: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let trace = Trace::open(&a.trace)?;
    print!("{}", summary(&trace)?);
    Ok(())
}

fn epipole_text(k: EpipoleKind, cam: &Camera, e: &postwarp_rtl::Epipole) -> String {
    let inside = if e.inside(&cam.intrinsics) { " inside" } else { "" };
    match k {
        EpipoleKind::Front { point } => format!("front ({:.1}, {:.1}){inside}", point.x, point.y),
        EpipoleKind::Behind { point } => format!("behind ({:.1}, {:.1}){inside}", point.x, point.y),
        EpipoleKind::Infinity { direction } => format!("infinity dir ({:.3}, {:.3})", direction.x, direction.y),
        EpipoleKind::Coincident => "none (same centre)".to_string(),
    }
}

/// The text `postwarp info` prints.
pub fn summary(t: &Trace) -> anyhow::Result<String> {
    let mut s = String::new();
    let d = t.display;
    let ss = d.supersample;
    writeln!(s, "trace      {} (format v{})", t.manifest.display(), crate::trace::TRACE_VERSION)?;
    for n in &t.notes {
        writeln!(s, "note       {n}")?;
    }
    let dk = t.derived[0].camera.intrinsics;
    let (fh, fv) = dk.fov_deg();
    writeln!(
        s,
        "display    {}x{} px, {ss}x{ss} samples per pixel ({}x{} samples), fov {fh:.1}x{fv:.1} deg",
        d.width,
        d.height,
        d.width * ss,
        d.height * ss
    )?;
    writeln!(s, "\nreference frames: {}", t.references.len())?;
    writeln!(
        s,
        "{:>4} {:>8} {:>11} {:>11} {:>11} {:>21} {:>9} {:>18}",
        "#", "time_s", "pixels", "samples", "fov_deg", "depth_range", "surface", "slopes"
    )?;
    for (i, r) in t.references.iter().enumerate() {
        let loaded = t.load_reference(i)?;
        let k = r.camera.intrinsics;
        let (h, v) = k.fov_deg();
        let range = match loaded.samples.depth_range() {
            Some((lo, hi)) => format!("{lo:.3} .. {hi:.3}"),
            None => "no surface".into(),
        };
        let cover = 100.0 * loaded.samples.valid.count_ones() as f64 / loaded.samples.len().max(1) as f64;
        writeln!(
            s,
            "{i:>4} {:>8.3} {:>11} {:>11} {:>11} {range:>21} {cover:>8.1}% {:>18}",
            r.time_s,
            format!("{}x{}", k.width, k.height),
            format!("{}x{}", k.width * ss, k.height * ss),
            format!("{h:.1}x{v:.1}"),
            loaded.slopes.name()
        )?;
    }
    writeln!(s, "\nderived frames: {}", t.derived.len())?;
    writeln!(
        s,
        "{:>4} {:>8} {:>6} {:>5}  per reference: move (m), turn (deg), epipole in reference px, epipole in derived px",
        "#", "time_s", "refs", "truth"
    )?;
    for (i, f) in t.derived.iter().enumerate() {
        let refs: Vec<String> = f.references.iter().map(|r| r.to_string()).collect();
        if let Some(truth) = t.load_truth(i)? {
            let unknown = truth.known.count_zeros();
            if unknown > 0 {
                writeln!(s, "     (frame {i}: {unknown} ground-truth pixels marked unknown)")?;
            }
        }
        writeln!(
            s,
            "{i:>4} {:>8.3} {:>6} {:>5}",
            f.time_s,
            refs.join(","),
            if f.truth.is_some() { "yes" } else { "no" }
        )?;
        for &r in &f.references {
            let rc = t.references[r].camera;
            let w = WarpSetup::new(&rc, &f.camera);
            let moved = (f.camera.pose.position - rc.pose.position).length();
            let turn = rc.pose.orientation.angle_between(f.camera.pose.orientation).to_degrees();
            writeln!(
                s,
                "{:>26} {r}: move {moved:.4}, turn {turn:.2}, in ref {}, in derived {}",
                "ref",
                epipole_text(w.epipole_reference.kind(), &rc, &w.epipole_reference),
                epipole_text(w.epipole_derived.kind(), &f.camera, &w.epipole_derived)
            )?;
        }
    }
    Ok(s)
}
