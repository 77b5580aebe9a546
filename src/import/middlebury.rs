//! Middlebury 2014 stereo importer: a rectified stereo folder (`im0.png`,
//! `im1.png`, `disp0.pfm`, `calib.txt`; Scharstein et al., GCPR 2014) to a
//! trace with one reference frame (the left view, with depth from the
//! ground-truth disparity) and one derived frame (the right camera, with the
//! real right image as ground truth).
//!
//! Rules:
//! - scene units are metres; the left camera sits at the origin with the
//!   identity orientation, the right camera at `(+baseline, 0, 0)` (OpenCV
//!   axes: x right, y down, z forward), both at time 0;
//! - depth `Z = baseline · f / (d + doffs)` (Middlebury's formula, mm), then
//!   ÷ 1000; a pixel is valid only where `d` is finite (`inf` = unknown) —
//!   after the fill below — and the resulting `Z` is a finite positive `f32`;
//!   a disparity that is negative, NaN or `-inf` is an error naming the
//!   pixel (Middlebury writes none, and a negative one would otherwise
//!   give a plausible positive depth);
//! - PNG colours are 8-bit sRGB and are converted to linear RGB
//!   ([`srgb_to_linear`]); object ids are 0; slopes are not supplied
//!   ([`SlopeSource::FiniteDifference`]); every truth pixel is known;
//! - `calib.txt` must describe a rectified pair (same `f` and `cy` in both
//!   cameras, `doffs = cx1 − cx0`), so that a left pixel `(x, y)` with
//!   disparity `d` projects to `(x − d, y)` in the right camera; keys other
//!   than `cam0`, `cam1`, `doffs`, `baseline`, `width`, `height` are ignored;
//! - every size (both images, the PFM, `width`/`height`) must agree;
//! - unknown disparity: with `--fill-unknown-depth background` (the
//!   default) an unknown pixel takes the farther known neighbour's
//!   disparity on its row (`depth_fill.rs`); with `none` it has no surface;
//! - the truth's `seen` mask: the right pixels the left view sees by the
//!   measured disparity (`visibility.rs`), whatever the fill;
//! - every failure is an [`ImportError`] naming the file (and the line and
//!   key for `calib.txt`); the importer prints nothing.

use crate::picture::srgb_to_linear;
use crate::trace::{self, MAX_SIDE, SlopeSource, TraceError, TraceWriter, TruthImage};
use bitvec::vec::BitVec;
use glam::{DQuat, DVec3};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage};
use std::fmt;
use std::path::{Path, PathBuf};

use super::depth_fill::{FillUnknownDepth, fill_background};
use super::pfm::{PfmError, read_pfm};
use super::visibility::seen_from_disparity;

/// Names of the files of a Middlebury 2014 folder.
pub const LEFT_IMAGE: &str = "im0.png";
/// Right view.
pub const RIGHT_IMAGE: &str = "im1.png";
/// Left-view disparity (pixels; `inf` = unknown).
pub const LEFT_DISPARITY: &str = "disp0.pfm";
/// Calibration.
pub const CALIB: &str = "calib.txt";

/// Largest mismatch (pixels) tolerated between `doffs` and `cx1 − cx0`, and
/// between the two cameras' `cy` (rounding in `calib.txt`).
pub const RECTIFIED_TOLERANCE_PX: f64 = 0.01;

/// An import failure.
#[derive(Clone, Debug, PartialEq)]
pub enum ImportError {
    /// A source file (or the source folder) is missing or wrong.
    Input {
        /// The file at fault.
        file: PathBuf,
        /// 1-based line, for text files.
        line: Option<usize>,
        /// What was wrong and what was expected.
        message: String,
    },
    /// Writing the trace failed.
    Trace(TraceError),
}

impl ImportError {
    fn input(file: &Path, line: Option<usize>, message: impl Into<String>) -> ImportError {
        ImportError::Input { file: file.to_path_buf(), line, message: message.into() }
    }
}

impl fmt::Display for ImportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImportError::Input { file, line, message } => {
                write!(f, "{}", file.display())?;
                if let Some(l) = line {
                    write!(f, ":{l}")?;
                }
                write!(f, ": {message}")
            }
            ImportError::Trace(e) => write!(f, "cannot write the trace: {e}"),
        }
    }
}

impl std::error::Error for ImportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ImportError::Input { .. } => None,
            ImportError::Trace(e) => Some(e),
        }
    }
}

impl From<TraceError> for ImportError {
    fn from(e: TraceError) -> Self {
        ImportError::Trace(e)
    }
}

impl From<PfmError> for ImportError {
    fn from(e: PfmError) -> Self {
        ImportError::Input { file: e.file, line: None, message: e.message }
    }
}

/// A Middlebury camera matrix `[fx 0 cx; 0 fy cy; 0 0 1]` (pixels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraMatrix {
    /// Focal length along x.
    pub fx: f64,
    /// Focal length along y.
    pub fy: f64,
    /// Principal point x.
    pub cx: f64,
    /// Principal point y.
    pub cy: f64,
}

/// The keys of `calib.txt` the importer uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calib {
    /// Left camera.
    pub cam0: CameraMatrix,
    /// Right camera.
    pub cam1: CameraMatrix,
    /// `cx1 − cx0` (pixels).
    pub doffs: f64,
    /// Camera baseline (millimetres).
    pub baseline_mm: f64,
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
}

impl Calib {
    /// Depth in metres of a left pixel with disparity `d`, `None` where there
    /// is no surface (non-finite disparity, or a non-positive or non-finite
    /// depth as an `f32`).
    pub fn depth_m(&self, d: f32) -> Option<f32> {
        if !d.is_finite() {
            return None;
        }
        let denom = d as f64 + self.doffs;
        if denom <= 0.0 {
            return None;
        }
        let z = (self.baseline_mm * self.cam0.fx / denom / 1000.0) as f32;
        (z.is_finite() && z > 0.0).then_some(z)
    }

    /// The left camera: cam0 at the origin, identity orientation.
    pub fn left_camera(&self) -> Camera {
        Camera {
            intrinsics: self.intrinsics(&self.cam0),
            pose: Pose { position: DVec3::ZERO, orientation: DQuat::IDENTITY },
        }
    }

    /// The right camera: cam1 at `(+baseline in metres, 0, 0)`, identity
    /// orientation.
    pub fn right_camera(&self) -> Camera {
        Camera {
            intrinsics: self.intrinsics(&self.cam1),
            pose: Pose { position: DVec3::new(self.baseline_mm / 1000.0, 0.0, 0.0), orientation: DQuat::IDENTITY },
        }
    }

    fn intrinsics(&self, m: &CameraMatrix) -> Intrinsics {
        Intrinsics { width: self.width, height: self.height, fx: m.fx, fy: m.fy, cx: m.cx, cy: m.cy }
    }
}

/// Read and check `calib.txt`.
pub fn read_calib(path: &Path) -> Result<Calib, ImportError> {
    let text = crate::io_util::read_text(path, "calibration file (calib.txt)")
        .map_err(|e| ImportError::input(path, None, e.message))?;
    parse_calib(&text, path)
}

/// Parse `calib.txt` text; `file` only names the source in errors.
pub fn parse_calib(text: &str, file: &Path) -> Result<Calib, ImportError> {
    const KEYS: [&str; 6] = ["cam0", "cam1", "doffs", "baseline", "width", "height"];
    // (value, line) per used key.
    let mut found: [Option<(&str, usize)>; 6] = [None; 6];
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let s = raw.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let Some((key, value)) = s.split_once('=') else {
            return Err(ImportError::input(file, Some(line), format!("expected `key=value`, found `{s}`")));
        };
        let key = key.trim();
        if let Some(k) = KEYS.iter().position(|&k| k == key) {
            if let Some((_, first)) = found[k] {
                return Err(ImportError::input(
                    file,
                    Some(line),
                    format!("key `{key}` given twice (first on line {first})"),
                ));
            }
            found[k] = Some((value.trim(), line));
        }
    }
    let get = |k: usize| {
        found[k].ok_or_else(|| {
            let what = match KEYS[k] {
                "cam0" | "cam1" => "=[f 0 cx; 0 f cy; 0 0 1] (pixels)",
                "doffs" => "=<cx1 - cx0 in pixels>",
                "baseline" => "=<camera baseline in mm>",
                _ => "=<pixels>",
            };
            ImportError::input(file, None, format!("missing key `{}` (expected a line `{}{what}`)", KEYS[k], KEYS[k]))
        })
    };
    let number = |k: usize| -> Result<(f64, usize), ImportError> {
        let (v, line) = get(k)?;
        let x: f64 = v.parse().ok().filter(|x: &f64| x.is_finite()).ok_or_else(|| {
            ImportError::input(file, Some(line), format!("key `{}`: `{v}` is not a finite number", KEYS[k]))
        })?;
        Ok((x, line))
    };
    let size = |k: usize| -> Result<u32, ImportError> {
        let (v, line) = get(k)?;
        v.parse::<u32>().ok().filter(|&n| n > 0 && n <= MAX_SIDE).ok_or_else(|| {
            ImportError::input(
                file,
                Some(line),
                format!("key `{}`: `{v}` is not an integer from 1 to {MAX_SIDE}", KEYS[k]),
            )
        })
    };
    let matrix = |k: usize| -> Result<(CameraMatrix, usize), ImportError> {
        let (v, line) = get(k)?;
        let m = parse_matrix(v).map_err(|why| {
            ImportError::input(
                file,
                Some(line),
                format!("key `{}`: {why}; expected `[f 0 cx; 0 f cy; 0 0 1]` with f > 0", KEYS[k]),
            )
        })?;
        Ok((m, line))
    };
    let (cam0, _) = matrix(0)?;
    let (cam1, cam1_line) = matrix(1)?;
    let (doffs, doffs_line) = number(2)?;
    let (baseline_mm, baseline_line) = number(3)?;
    let width = size(4)?;
    let height = size(5)?;
    if baseline_mm <= 0.0 {
        return Err(ImportError::input(
            file,
            Some(baseline_line),
            format!("key `baseline`: {baseline_mm} mm; expected a positive baseline"),
        ));
    }
    let same_f = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs());
    if !same_f(cam0.fx, cam1.fx) || !same_f(cam0.fy, cam1.fy) || (cam0.cy - cam1.cy).abs() > RECTIFIED_TOLERANCE_PX {
        return Err(ImportError::input(
            file,
            Some(cam1_line),
            format!(
                "key `cam1`: fx {}, fy {}, cy {} differ from cam0's ({}, {}, {}); expected a rectified pair \
                 (same focal lengths and cy)",
                cam1.fx, cam1.fy, cam1.cy, cam0.fx, cam0.fy, cam0.cy
            ),
        ));
    }
    if (doffs - (cam1.cx - cam0.cx)).abs() > RECTIFIED_TOLERANCE_PX {
        return Err(ImportError::input(
            file,
            Some(doffs_line),
            format!(
                "key `doffs`: {doffs} px, but cx1 - cx0 = {} px; expected them equal \
                 (within {RECTIFIED_TOLERANCE_PX} px)",
                cam1.cx - cam0.cx
            ),
        ));
    }
    Ok(Calib { cam0, cam1, doffs, baseline_mm, width, height })
}

/// Parse `[fx 0 cx; 0 fy cy; 0 0 1]`; the error says what was wrong.
fn parse_matrix(v: &str) -> Result<CameraMatrix, String> {
    let inner = v
        .strip_prefix('[')
        .and_then(|s| s.strip_suffix(']'))
        .ok_or_else(|| format!("`{v}` is not a bracketed matrix"))?;
    let rows: Vec<&str> = inner.split(';').collect();
    if rows.len() != 3 {
        return Err(format!("`{v}` has {} rows", rows.len()));
    }
    let mut m = [[0.0f64; 3]; 3];
    for (r, row) in rows.iter().enumerate() {
        let vals: Vec<&str> = row.split_whitespace().collect();
        if vals.len() != 3 {
            return Err(format!("row {} of `{v}` has {} entries", r + 1, vals.len()));
        }
        for (c, t) in vals.iter().enumerate() {
            m[r][c] = t
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`{t}` in `{v}` is not a finite number"))?;
        }
    }
    if m[0][1] != 0.0 || m[1][0] != 0.0 || m[2] != [0.0, 0.0, 1.0] {
        return Err(format!("`{v}` is not a pinhole matrix without skew"));
    }
    if m[0][0] <= 0.0 || m[1][1] <= 0.0 {
        return Err(format!("`{v}` has a non-positive focal length"));
    }
    Ok(CameraMatrix { fx: m[0][0], fy: m[1][1], cx: m[0][2], cy: m[1][2] })
}

/// A Middlebury pair read into memory, ready to be written as a trace.
#[derive(Clone, Debug, PartialEq)]
pub struct MiddleburyPair {
    /// Name of the source folder (for provenance).
    pub source_name: String,
    /// The calibration.
    pub calib: Calib,
    /// Left (reference) camera.
    pub left_camera: Camera,
    /// Right (derived) camera.
    pub right_camera: Camera,
    /// The left view: linear colour, depth in metres, validity.
    pub left: SampleImage,
    /// The right view as ground truth (linear colour, all known).
    pub right_truth: TruthImage,
    /// Number of valid left pixels (after the fill of unknown depth).
    pub valid_pixels: usize,
    /// Left pixels with a measured (finite) disparity.
    pub measured_pixels: usize,
    /// What was done with unknown depth.
    pub fill: FillUnknownDepth,
}

impl MiddleburyPair {
    /// Fraction of left pixels with a known depth.
    pub fn valid_fraction(&self) -> f64 {
        self.valid_pixels as f64 / self.left.len() as f64
    }
}

/// Read and check a Middlebury 2014 folder (no output written), unknown
/// depth treated the default way ([`FillUnknownDepth::default`]).
pub fn read_middlebury(src: &Path) -> Result<MiddleburyPair, ImportError> {
    read_middlebury_with(src, FillUnknownDepth::default())
}

/// [`read_middlebury`] with unknown depth treated as `fill` says
/// (`depth_fill.rs`). The truth's `seen` mask comes from the measured
/// disparity, before any fill (`visibility.rs`).
pub fn read_middlebury_with(src: &Path, fill: FillUnknownDepth) -> Result<MiddleburyPair, ImportError> {
    if !src.is_dir() {
        return Err(ImportError::input(
            src,
            None,
            format!(
                "not a directory; expected a Middlebury 2014 stereo folder holding \
                 {LEFT_IMAGE}, {RIGHT_IMAGE}, {LEFT_DISPARITY} and {CALIB}"
            ),
        ));
    }
    for name in [CALIB, LEFT_IMAGE, RIGHT_IMAGE, LEFT_DISPARITY] {
        let p = src.join(name);
        if !p.is_file() {
            return Err(ImportError::input(
                &p,
                None,
                format!(
                    "missing; a Middlebury 2014 folder holds {LEFT_IMAGE}, {RIGHT_IMAGE}, {LEFT_DISPARITY} and {CALIB}"
                ),
            ));
        }
    }
    let calib_path = src.join(CALIB);
    let calib = read_calib(&calib_path)?;
    let (w, h) = (calib.width, calib.height);
    let size_note = |what: &str, (iw, ih): (u32, u32)| {
        format!("{what} is {iw}x{ih} but {} says width={w} height={h}", calib_path.display())
    };

    let left_colour = read_png_linear(&src.join(LEFT_IMAGE), (w, h), &size_note)?;
    let right_colour = read_png_linear(&src.join(RIGHT_IMAGE), (w, h), &size_note)?;
    let disp_path = src.join(LEFT_DISPARITY);
    let disp = read_pfm(&disp_path)?;
    if disp.channels != 1 {
        return Err(ImportError::input(
            &disp_path,
            None,
            "is a colour (PF) PFM; expected a greyscale (Pf) disparity map",
        ));
    }
    if (disp.width, disp.height) != (w, h) {
        return Err(ImportError::input(&disp_path, None, size_note("the disparity map", (disp.width, disp.height))));
    }

    check_disparities(&disp.data, w, &disp_path)?;
    let seen = seen_from_disparity(&disp.data, w, h);
    let measured = disp.data.iter().filter(|&&d| calib.depth_m(d).is_some()).count();
    let mut data = disp.data;
    if fill == FillUnknownDepth::Background {
        fill_background(&mut data, w);
    }
    let mut left = SampleImage::empty(w, h);
    left.colour = left_colour;
    let mut valid_pixels = 0;
    for (i, &d) in data.iter().enumerate() {
        if let Some(z) = calib.depth_m(d) {
            left.z[i] = z;
            left.valid.set(i, true);
            valid_pixels += 1;
        }
    }
    let n = left.len();
    let right_truth = TruthImage {
        width: w,
        height: h,
        colour: right_colour,
        known: BitVec::repeat(true, n),
        nondiffuse: None,
        seen: Some(seen),
    };
    let source_name = src
        .canonicalize()
        .ok()
        .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| src.display().to_string());
    Ok(MiddleburyPair {
        source_name,
        left_camera: calib.left_camera(),
        right_camera: calib.right_camera(),
        calib,
        left,
        right_truth,
        valid_pixels,
        measured_pixels: measured,
        fill,
    })
}

/// Disparities are `+inf` (unknown, Middlebury's marker) or finite and at
/// least 0 (pixels): a negative, NaN or `-inf` value is not one Middlebury
/// writes, so the file is refused rather than read as a surface (a
/// negative `d` would still give a positive depth `b·f/(d + doffs)`
/// whenever `d > -doffs`). The error names the first such pixel (x right,
/// y down) and how many there are.
fn check_disparities(data: &[f32], width: u32, path: &Path) -> Result<(), ImportError> {
    let bad = |d: f32| d.is_nan() || d < 0.0;
    let Some(first) = data.iter().position(|&d| bad(d)) else { return Ok(()) };
    let n = data.iter().filter(|&&d| bad(d)).count();
    let (x, y) = (first as u32 % width, first as u32 / width);
    Err(ImportError::input(
        path,
        None,
        format!(
            "pixel ({x}, {y}) has disparity {}; expected a disparity >= 0 pixels, or inf where unknown ({n} such \
             pixels)",
            data[first]
        ),
    ))
}

/// Read an 8-bit PNG of `expected` size as linear RGB.
fn read_png_linear(
    path: &Path,
    expected: (u32, u32),
    size_note: &dyn Fn(&str, (u32, u32)) -> String,
) -> Result<Vec<[f32; 3]>, ImportError> {
    use image::ColorType;
    let bytes = crate::io_util::read_input(path, "PNG image").map_err(|e| ImportError::input(path, None, e.message))?;
    let decode_err = |e: image::ImageError| ImportError::input(path, None, format!("cannot decode as PNG: {e}"));
    // The size from the header first: nothing is decoded at a wrong size.
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png);
    let size = reader().into_dimensions().map_err(decode_err)?;
    if size != expected {
        return Err(ImportError::input(path, None, size_note("the image", size)));
    }
    let img = reader().decode().map_err(decode_err)?;
    match img.color() {
        ColorType::L8 | ColorType::La8 | ColorType::Rgb8 | ColorType::Rgba8 => {}
        other => {
            return Err(ImportError::input(
                path,
                None,
                format!("has pixel type {other:?}; expected 8-bit sRGB (RGB, RGBA, grey)"),
            ));
        }
    }
    if (img.width(), img.height()) != expected {
        return Err(ImportError::input(path, None, size_note("the image", (img.width(), img.height()))));
    }
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    Ok(img.to_rgb8().pixels().map(|p| p.0.map(|c| lut[c as usize])).collect())
}

/// Import a Middlebury 2014 folder `src` as a trace in directory `out`;
/// returns the manifest path.
pub fn import_middlebury(src: &Path, out: &Path) -> Result<PathBuf, ImportError> {
    import_middlebury_with(src, out, FillUnknownDepth::default())
}

/// [`import_middlebury`] with unknown depth treated as `fill` says.
pub fn import_middlebury_with(src: &Path, out: &Path, fill: FillUnknownDepth) -> Result<PathBuf, ImportError> {
    let pair = read_middlebury_with(src, fill)?;
    write_trace(&pair, out)
}

/// Write a pair read by [`read_middlebury`] as a trace in `out`; returns the
/// manifest path.
pub fn write_trace(pair: &MiddleburyPair, out: &Path) -> Result<PathBuf, ImportError> {
    let c = &pair.calib;
    let display = trace::Display { width: c.width, height: c.height, supersample: 1 };
    let mut w = TraceWriter::new(out, display)?;
    w.note(format!(
        "source: Middlebury 2014 stereo folder `{}` (Scharstein et al., GCPR 2014, \"High-Resolution Stereo Datasets \
         with Subpixel-Accurate Ground Truth\")",
        pair.source_name
    ));
    w.note(format!(
        "reference 0 = left view {LEFT_IMAGE} (cam0, at the origin); derived 0 = right camera cam1 at \
         (+baseline, 0, 0), ground truth = {RIGHT_IMAGE}, every pixel known; time 0; colours: sRGB PNG converted \
         to linear RGB"
    ));
    w.note(format!(
        "depth unit: metres; Z = baseline * f / (d + doffs) / 1000 with d from {LEFT_DISPARITY}, baseline = {} mm, \
         f = {} px, doffs = {} px",
        c.baseline_mm, c.cam0.fx, c.doffs
    ));
    let n = pair.left.len();
    let unknown = match pair.fill {
        FillUnknownDepth::None => "pixels with non-finite disparity (unknown) have no surface".to_string(),
        FillUnknownDepth::Background => format!(
            "--fill-unknown-depth background: {} pixels of unknown disparity take the farther known neighbour's on \
             their row (a heuristic of the importer)",
            pair.valid_pixels - pair.measured_pixels
        ),
    };
    w.note(format!(
        "valid: {} of {n} left pixels ({:.2} %), {} measured ({:.2} %); {unknown}; object ids 0; 1/Z slopes not \
         supplied (finite differences); truth `seen`: right pixels the left view sees by the measured disparity",
        pair.valid_pixels,
        100.0 * pair.valid_fraction(),
        pair.measured_pixels,
        100.0 * pair.measured_pixels as f64 / n as f64
    ));
    let r = w.add_reference(0.0, pair.left_camera, &pair.left, SlopeSource::FiniteDifference)?;
    w.add_derived(0.0, pair.right_camera, vec![r], Some(&pair.right_truth))?;
    Ok(w.finish()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CALIB_TEXT: &str = "cam0=[100 0 1.5; 0 100 1; 0 0 1]\ncam1=[100 0 3.5; 0 100 1; 0 0 1]\ndoffs=2\n\
                              baseline=50\nwidth=4\nheight=3\nndisp=16\nvmin=1\n";

    fn parse(text: &str) -> Result<Calib, ImportError> {
        parse_calib(text, Path::new("dir/calib.txt"))
    }

    #[test]
    fn parses_middlebury_keys_and_ignores_others() {
        let c = parse(CALIB_TEXT).unwrap();
        assert_eq!(c.cam0, CameraMatrix { fx: 100.0, fy: 100.0, cx: 1.5, cy: 1.0 });
        assert_eq!(c.cam1.cx, 3.5);
        assert_eq!((c.doffs, c.baseline_mm, c.width, c.height), (2.0, 50.0, 4, 3));
        // Z = 50 mm · 100 / (3 + 2) = 1000 mm = 1 m.
        assert_eq!(c.depth_m(3.0), Some(1.0));
        assert_eq!(c.depth_m(f32::INFINITY), None);
        assert_eq!(c.depth_m(f32::NAN), None);
        assert_eq!(c.depth_m(-2.0), None, "d + doffs = 0");
        assert_eq!(c.depth_m(-5.0), None, "negative depth");
    }

    #[test]
    fn right_camera_sees_disparity_as_a_leftward_shift() {
        let c = parse(CALIB_TEXT).unwrap();
        let (l, r) = (c.left_camera(), c.right_camera());
        for (x, y, d) in [(0.0, 0.0, 3.0), (3.0, 2.0, 0.5), (1.25, 1.75, 7.0)] {
            let z = c.baseline_mm * c.cam0.fx / (d + c.doffs) / 1000.0;
            let (p, _) = r.project(l.unproject(x, y, z)).unwrap();
            assert!((p.x - (x - d)).abs() < 1e-9 && (p.y - y).abs() < 1e-9, "{p:?}");
        }
    }

    #[test]
    fn calib_errors_name_file_line_and_key() {
        let cases: Vec<(String, &str)> = vec![
            (CALIB_TEXT.replace("baseline=50\n", ""), "dir/calib.txt: missing key `baseline`"),
            (CALIB_TEXT.replace("baseline=50", "baseline=abc"), "dir/calib.txt:4: key `baseline`: `abc`"),
            (CALIB_TEXT.replace("baseline=50", "baseline=-5"), "dir/calib.txt:4: key `baseline`: -5 mm"),
            (CALIB_TEXT.replace("width=4", "width=0"), "dir/calib.txt:5: key `width`: `0`"),
            (CALIB_TEXT.replace("height=3", "height=3.5"), "dir/calib.txt:6: key `height`: `3.5`"),
            (
                CALIB_TEXT.replace("; 0 0 1]\ncam1", "]\ncam1"),
                "dir/calib.txt:1: key `cam0`: `[100 0 1.5; 0 100 1]` has 2 rows",
            ),
            (
                CALIB_TEXT.replace("[100 0 1.5", "[100 0.1 1.5"),
                "dir/calib.txt:1: key `cam0`: `[100 0.1 1.5; 0 100 1; 0 0 1]` is not a pinhole",
            ),
            (CALIB_TEXT.replace("[100 0 3.5", "[100 0 x"), "dir/calib.txt:2: key `cam1`: `x` in"),
            (
                CALIB_TEXT.replace("[100 0 3.5", "100 0 3.5"),
                "dir/calib.txt:2: key `cam1`: `100 0 3.5; 0 100 1; 0 0 1]` is not a bracketed",
            ),
            (CALIB_TEXT.replace("[100 0 3.5; 0 100", "[101 0 3.5; 0 101"), "dir/calib.txt:2: key `cam1`: fx 101"),
            (CALIB_TEXT.replace("doffs=2", "doffs=2.5"), "dir/calib.txt:3: key `doffs`: 2.5 px, but cx1 - cx0 = 2 px"),
            (format!("{CALIB_TEXT}doffs=2\n"), "dir/calib.txt:9: key `doffs` given twice (first on line 3)"),
            (format!("{CALIB_TEXT}garbage\n"), "dir/calib.txt:9: expected `key=value`, found `garbage`"),
        ];
        for (text, want) in cases {
            let msg = parse(&text).unwrap_err().to_string();
            assert!(msg.starts_with(want), "got: {msg}\nwanted: {want}");
        }
    }

    /// A 4x3 Middlebury folder matching `CALIB_TEXT`.
    fn synthetic_folder(dir: &Path, disp_top_down: &[f32; 12]) {
        std::fs::write(dir.join(CALIB), CALIB_TEXT).unwrap();
        for (name, base) in [(LEFT_IMAGE, 0u8), (RIGHT_IMAGE, 100)] {
            let img = image::RgbImage::from_fn(4, 3, |x, y| image::Rgb([base + x as u8, base + 10 * y as u8, 255]));
            img.save(dir.join(name)).unwrap();
        }
        let mut pfm = b"Pf\n4 3\n-1\n".to_vec();
        for row in disp_top_down.chunks(4).rev() {
            for v in row {
                pfm.extend(v.to_le_bytes());
            }
        }
        std::fs::write(dir.join(LEFT_DISPARITY), pfm).unwrap();
    }

    #[test]
    fn reads_a_synthetic_folder() {
        let dir = tempfile::tempdir().unwrap();
        let inf = f32::INFINITY;
        let disp = [3.0, 8.0, inf, 1.0, 0.5, 2.0, inf, 0.0, 3.0, 3.0, 3.0, inf];
        synthetic_folder(dir.path(), &disp);
        let p = read_middlebury_with(dir.path(), FillUnknownDepth::None).unwrap();
        assert_eq!((p.valid_pixels, p.measured_pixels), (9, 9));
        assert!((p.valid_fraction() - 9.0 / 12.0).abs() < 1e-12);
        let valid: Vec<bool> = p.left.valid.iter().map(|b| *b).collect();
        let want = [true, true, false, true, true, true, false, true, true, true, true, false];
        assert_eq!(valid, want);
        assert_eq!(p.left.z[0], 1.0);
        assert_eq!(p.left.z[1], 0.5); // 5000 / 10 mm
        assert_eq!(p.left.z[p.left.index(1, 1)], 1.25);
        assert!(p.left.object_id.iter().all(|&id| id == 0));
        // Colours: sRGB codes to linear, row-major top-down.
        assert_eq!(p.left.colour[p.left.index(3, 2)], [srgb_to_linear(3), srgb_to_linear(20), 1.0]);
        assert_eq!(p.right_truth.colour[5], [srgb_to_linear(101), srgb_to_linear(110), 1.0]);
        assert!(p.right_truth.known.all());
        assert_eq!(p.right_camera.pose.position, DVec3::new(0.05, 0.0, 0.0));
        // The default fills each unknown pixel from its row's farther known
        // neighbour: (2, 0) between d = 8 and 1 takes 1; (2, 1) between 2
        // and 0 takes 0; (3, 2) only has 3 on its left.
        let b = read_middlebury(dir.path()).unwrap();
        assert_eq!((b.valid_pixels, b.measured_pixels, b.fill), (12, 9, FillUnknownDepth::Background));
        assert_eq!(b.left.z[2], p.calib.depth_m(1.0).unwrap());
        assert_eq!(b.left.z[b.left.index(2, 1)], p.calib.depth_m(0.0).unwrap());
        assert_eq!(b.left.z[b.left.index(3, 2)], p.calib.depth_m(3.0).unwrap());
        assert_eq!(b.right_truth.seen, p.right_truth.seen, "seen from the measured disparity");
    }

    #[test]
    fn negative_and_nan_disparities_are_refused_naming_the_pixel() {
        let dir = tempfile::tempdir().unwrap();
        for (bad, text) in [(-2.0, "-2"), (f32::NAN, "NaN"), (f32::NEG_INFINITY, "-inf")] {
            let mut disp = [3.0; 12];
            disp[6] = bad; // (2, 1) in the top-down order
            disp[11] = bad;
            synthetic_folder(dir.path(), &disp);
            let msg = read_middlebury(dir.path()).unwrap_err().to_string();
            assert!(msg.contains("disp0.pfm: pixel (2, 1) has disparity"), "{msg}");
            assert!(msg.contains(&format!("disparity {text};")) && msg.contains("(2 such pixels)"), "{msg}");
        }
    }

    #[test]
    fn size_mismatches_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        synthetic_folder(dir.path(), &[1.0; 12]);
        image::RgbImage::new(5, 3).save(dir.path().join(RIGHT_IMAGE)).unwrap();
        let msg = read_middlebury(dir.path()).unwrap_err().to_string();
        assert!(
            msg.contains("im1.png: the image is 5x3 but") && msg.contains("calib.txt says width=4 height=3"),
            "{msg}"
        );

        synthetic_folder(dir.path(), &[1.0; 12]);
        std::fs::write(
            dir.path().join(LEFT_DISPARITY),
            b"Pf\n3 4\n-1\n".iter().chain(&[0u8; 48]).copied().collect::<Vec<_>>(),
        )
        .unwrap();
        let msg = read_middlebury(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("disp0.pfm: the disparity map is 3x4 but"), "{msg}");

        synthetic_folder(dir.path(), &[1.0; 12]);
        std::fs::write(dir.path().join(LEFT_IMAGE), b"not a png").unwrap();
        let msg = read_middlebury(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("im0.png: cannot decode as PNG"), "{msg}");
    }

    #[test]
    fn png_of_the_wrong_size_is_rejected_from_its_header() {
        let dir = tempfile::tempdir().unwrap();
        synthetic_folder(dir.path(), &[1.0; 12]);
        // A PNG header claiming 16384x16384 RGB pixels and no pixel data:
        // read to its size, never decoded.
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut chunk = |kind: &[u8], data: &[u8]| {
            let body: Vec<u8> = kind.iter().chain(data).copied().collect();
            let mut crc = flate2::Crc::new();
            crc.update(&body);
            png.extend((data.len() as u32).to_be_bytes());
            png.extend(&body);
            png.extend(crc.sum().to_be_bytes());
        };
        let ihdr: Vec<u8> = [16384u32.to_be_bytes(), 16384u32.to_be_bytes()].concat();
        chunk(b"IHDR", &[&ihdr[..], &[8, 2, 0, 0, 0]].concat());
        chunk(b"IDAT", &[]);
        chunk(b"IEND", &[]);
        std::fs::write(dir.path().join(LEFT_IMAGE), png).unwrap();
        let msg = read_middlebury(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("im0.png: the image is 16384x16384 but"), "{msg}");
    }

    #[test]
    fn missing_inputs_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let msg = read_middlebury(&dir.path().join("absent")).unwrap_err().to_string();
        assert!(msg.contains("absent: not a directory"), "{msg}");
        synthetic_folder(dir.path(), &[1.0; 12]);
        std::fs::remove_file(dir.path().join(RIGHT_IMAGE)).unwrap();
        let msg = read_middlebury(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("im1.png: missing"), "{msg}");
    }
}
