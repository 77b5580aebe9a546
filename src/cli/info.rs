//! `postwarp info TRACE [--json]`: what a trace holds, read back from disk
//! (every image is loaded and checked), as a table or as JSON
//! ([`TraceInfo`], the same numbers).

use crate::trace::Trace;
use postwarp_rtl::camera::EpipoleKind;
use postwarp_rtl::{Camera, WarpSetup};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Flags of `postwarp info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Trace directory (or its `postwarp.trace` manifest).
    pub trace: PathBuf,
    /// Print JSON instead of the table (the same numbers; keys as in
    /// `postwarp::cli::info::TraceInfo`).
    #[arg(long)]
    pub json: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let trace = Trace::open(&a.trace)?;
    let info = trace_info(&trace)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        print!("{}", summary(&info)?);
    }
    Ok(())
}

/// The display of a trace.
#[derive(Clone, Debug, Serialize)]
pub struct DisplayInfo {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Super-samples per pixel along each axis (samples).
    pub supersample: u32,
    /// Horizontal and vertical field of view of the derived frames (degrees).
    pub fov_deg: [f64; 2],
}

/// One reference frame.
#[derive(Clone, Debug, Serialize)]
pub struct ReferenceInfo {
    /// Index in the trace.
    pub index: usize,
    /// Time (s).
    pub time_s: f64,
    /// Size (pixels).
    pub pixels: [u32; 2],
    /// Size (samples).
    pub samples: [u32; 2],
    /// Field of view (degrees).
    pub fov_deg: [f64; 2],
    /// Nearest and farthest depth where there is a surface (scene units),
    /// or `null` for none.
    pub depth_range: Option<[f32; 2]>,
    /// Share of samples with a surface (fraction).
    pub surface_fraction: f64,
    /// Where the 1/Z slopes come from (`exact`, `finite-difference`).
    pub slopes: &'static str,
}

/// An epipole, in JSON.
#[derive(Clone, Debug, Serialize)]
pub struct EpipoleInfo {
    /// `front`, `behind`, `infinity` or `none` (same centre).
    pub kind: &'static str,
    /// The point (pixels) for `front` / `behind`, the unit direction for
    /// `infinity`.
    pub at: Option<[f64; 2]>,
    /// The point lies inside the image.
    pub inside: bool,
}

/// One derived frame against one of its references.
#[derive(Clone, Debug, Serialize)]
pub struct WarpInfo {
    /// The reference's index.
    pub reference: usize,
    /// Distance between the camera centres (scene units).
    pub move_units: f64,
    /// Rotation between the orientations (degrees).
    pub turn_deg: f64,
    /// The epipole in the reference image.
    pub epipole_reference: EpipoleInfo,
    /// The epipole in the derived image.
    pub epipole_derived: EpipoleInfo,
}

/// One derived frame.
#[derive(Clone, Debug, Serialize)]
pub struct DerivedInfo {
    /// Index in the trace.
    pub index: usize,
    /// Time (s).
    pub time_s: f64,
    /// Reference frames it warps, in order.
    pub references: Vec<usize>,
    /// It has ground truth.
    pub truth: bool,
    /// Ground-truth pixels marked unknown (pixels; `null` without truth).
    pub unknown_truth_pixels: Option<usize>,
    /// Per reference: motion and epipoles.
    pub warps: Vec<WarpInfo>,
}

/// Everything `postwarp info` reports.
#[derive(Clone, Debug, Serialize)]
pub struct TraceInfo {
    /// The manifest.
    pub trace: String,
    /// Trace format version.
    pub format_version: u32,
    /// The manifest's notes.
    pub notes: Vec<String>,
    /// The display.
    pub display: DisplayInfo,
    /// Reference frames.
    pub references: Vec<ReferenceInfo>,
    /// Derived frames.
    pub derived: Vec<DerivedInfo>,
}

fn epipole(e: &postwarp_rtl::Epipole, cam: &Camera) -> EpipoleInfo {
    let inside = e.inside(&cam.intrinsics);
    let (kind, at) = match e.kind() {
        EpipoleKind::Front { point } => ("front", Some([point.x, point.y])),
        EpipoleKind::Behind { point } => ("behind", Some([point.x, point.y])),
        EpipoleKind::Infinity { direction } => ("infinity", Some([direction.x, direction.y])),
        EpipoleKind::Coincident => ("none", None),
    };
    EpipoleInfo { kind, at, inside }
}

/// Read everything about `t` (loads every image).
pub fn trace_info(t: &Trace) -> anyhow::Result<TraceInfo> {
    let d = t.display;
    let ss = d.supersample;
    let (fh, fv) = t.derived[0].camera.intrinsics.fov_deg();
    let mut references = Vec::new();
    for (i, r) in t.references.iter().enumerate() {
        let loaded = t.load_reference(i)?;
        let k = r.camera.intrinsics;
        let (h, v) = k.fov_deg();
        references.push(ReferenceInfo {
            index: i,
            time_s: r.time_s,
            pixels: [k.width, k.height],
            samples: [k.width * ss, k.height * ss],
            fov_deg: [h, v],
            depth_range: loaded.samples.depth_range().map(|(lo, hi)| [lo, hi]),
            surface_fraction: loaded.samples.valid.count_ones() as f64 / loaded.samples.len().max(1) as f64,
            slopes: loaded.slopes.name(),
        });
    }
    let mut derived = Vec::new();
    for (i, f) in t.derived.iter().enumerate() {
        let unknown = t.load_truth(i)?.map(|truth| truth.known.count_zeros());
        let warps = f
            .references
            .iter()
            .map(|&r| {
                let rc = t.references[r].camera;
                let w = WarpSetup::new(&rc, &f.camera);
                WarpInfo {
                    reference: r,
                    move_units: (f.camera.pose.position - rc.pose.position).length(),
                    turn_deg: rc.pose.orientation.angle_between(f.camera.pose.orientation).to_degrees(),
                    epipole_reference: epipole(&w.epipole_reference, &rc),
                    epipole_derived: epipole(&w.epipole_derived, &f.camera),
                }
            })
            .collect();
        derived.push(DerivedInfo {
            index: i,
            time_s: f.time_s,
            references: f.references.clone(),
            truth: f.truth.is_some(),
            unknown_truth_pixels: unknown,
            warps,
        });
    }
    Ok(TraceInfo {
        trace: t.manifest.display().to_string(),
        format_version: crate::trace::TRACE_VERSION,
        notes: t.notes.clone(),
        display: DisplayInfo { width: d.width, height: d.height, supersample: ss, fov_deg: [fh, fv] },
        references,
        derived,
    })
}

fn epipole_text(e: &EpipoleInfo) -> String {
    let inside = if e.inside { " inside" } else { "" };
    match (e.kind, e.at) {
        ("front", Some([x, y])) => format!("front ({x:.1}, {y:.1}){inside}"),
        ("behind", Some([x, y])) => format!("behind ({x:.1}, {y:.1}){inside}"),
        ("infinity", Some([x, y])) => format!("infinity dir ({x:.3}, {y:.3})"),
        _ => "none (same centre)".to_string(),
    }
}

/// The text `postwarp info` prints.
pub fn summary(t: &TraceInfo) -> anyhow::Result<String> {
    let mut s = String::new();
    let d = &t.display;
    let ss = d.supersample;
    writeln!(s, "trace      {} (format v{})", t.trace, t.format_version)?;
    for n in &t.notes {
        writeln!(s, "note       {n}")?;
    }
    writeln!(
        s,
        "display    {}x{} px, {ss}x{ss} samples per pixel ({}x{} samples), fov {:.1}x{:.1} deg",
        d.width,
        d.height,
        d.width * ss,
        d.height * ss,
        d.fov_deg[0],
        d.fov_deg[1]
    )?;
    writeln!(s, "\nreference frames: {}", t.references.len())?;
    writeln!(
        s,
        "{:>4} {:>8} {:>11} {:>11} {:>11} {:>21} {:>9} {:>18}",
        "#", "time_s", "pixels", "samples", "fov_deg", "depth_range", "surface", "slopes"
    )?;
    for r in &t.references {
        let range = match r.depth_range {
            Some([lo, hi]) => format!("{lo:.3} .. {hi:.3}"),
            None => "no surface".into(),
        };
        writeln!(
            s,
            "{:>4} {:>8.3} {:>11} {:>11} {:>11} {range:>21} {:>8.1}% {:>18}",
            r.index,
            r.time_s,
            format!("{}x{}", r.pixels[0], r.pixels[1]),
            format!("{}x{}", r.samples[0], r.samples[1]),
            format!("{:.1}x{:.1}", r.fov_deg[0], r.fov_deg[1]),
            100.0 * r.surface_fraction,
            r.slopes
        )?;
    }
    writeln!(s, "\nderived frames: {}", t.derived.len())?;
    writeln!(
        s,
        "{:>4} {:>8} {:>6} {:>5}  per reference: move (m), turn (deg), epipole in reference px, epipole in derived px",
        "#", "time_s", "refs", "truth"
    )?;
    for f in &t.derived {
        let refs: Vec<String> = f.references.iter().map(|r| r.to_string()).collect();
        if let Some(unknown) = f.unknown_truth_pixels.filter(|&u| u > 0) {
            writeln!(s, "     (frame {}: {unknown} ground-truth pixels marked unknown)", f.index)?;
        }
        writeln!(
            s,
            "{:>4} {:>8.3} {:>6} {:>5}",
            f.index,
            f.time_s,
            refs.join(","),
            if f.truth { "yes" } else { "no" }
        )?;
        for w in &f.warps {
            writeln!(
                s,
                "{:>26} {}: move {:.4}, turn {:.2}, in ref {}, in derived {}",
                "ref",
                w.reference,
                w.move_units,
                w.turn_deg,
                epipole_text(&w.epipole_reference),
                epipole_text(&w.epipole_derived)
            )?;
        }
    }
    Ok(s)
}
