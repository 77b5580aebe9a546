//! `postwarp info TRACE`: what a trace holds, read back from disk (every
//! image is loaded and checked, v2 layers included: per reference, the
//! transparent fragments — samples with any, their mean and largest
//! number, how many were stored out of the layer's maximum — and the ray
//! tree — samples with a valid reflection and refraction node, the
//! material table; per derived frame, the share of ground-truth pixels in
//! the non-diffuse mask).

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

/// One line about a fragment layer.
fn fragment_text(f: &crate::trace::layers::FragmentLayer) -> String {
    let with = f.count.iter().filter(|&&c| c > 0).count();
    let total: u64 = f.count.iter().map(|&c| c as u64).sum();
    let most = f.count.iter().copied().max().unwrap_or(0);
    let full = f.count.iter().filter(|&&c| c as u32 == f.max).count();
    format!(
        "fragments: {:.1}% of samples have any; {:.2} per such sample, at most {most} of max {} ({:.1}% of samples at the max)",
        100.0 * with as f64 / f.len().max(1) as f64,
        total as f64 / with.max(1) as f64,
        f.max,
        100.0 * full as f64 / f.len().max(1) as f64
    )
}

/// One line about a ray-tree layer.
fn ray_tree_text(rt: &crate::trace::layers::RayTreeLayer) -> String {
    use crate::trace::layers::Node;
    let n = rt.len().max(1) as f64;
    let count = |node: Node| (0..rt.len()).filter(|&i| rt.has(i, node)).count() as f64;
    let table: Vec<String> = rt.materials.iter().map(|m| m.token()).collect();
    format!(
        "ray tree: valid diffuse {:.1}%, reflect {:.1}%, refract {:.1}% of samples; materials {}",
        100.0 * count(Node::Diffuse) / n,
        100.0 * count(Node::Reflect) / n,
        100.0 * count(Node::Refract) / n,
        table.join(", ")
    )
}

/// The text `postwarp info` prints.
pub fn summary(t: &Trace) -> anyhow::Result<String> {
    let mut s = String::new();
    let d = t.display;
    let ss = d.supersample;
    writeln!(s, "trace      {} (format v{})", t.manifest.display(), t.format_version())?;
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
        let layers = t.load_layers(i)?;
        if let Some(f) = &layers.fragments {
            writeln!(s, "{:>14}{}", "", fragment_text(f))?;
        }
        if let Some(rt) = &layers.raytree {
            writeln!(s, "{:>14}{}", "", ray_tree_text(rt))?;
        }
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
            if let Some(m) = &truth.nondiffuse {
                let share = 100.0 * m.count_ones() as f64 / m.len().max(1) as f64;
                writeln!(s, "     (frame {i}: {share:.1}% of ground-truth pixels specular or transparent)")?;
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
