//! Trace generation: render a scene along a camera path into a trace, as the
//! paper's test-bed did (TR98 §11).
//!
//! Rules:
//! 1. Derived frames at `derived_rate_hz` (30 Hz) from path time `start_s`.
//! 2. Reference frames at `ref_rate_hz` (5 Hz): reference `j` stands for time
//!    `j / ref_rate_hz` and is rendered at the pose predicted
//!    `prediction_s` (400 ms) earlier by velocity extrapolation
//!    ([`crate::path::predict`]), so prediction error is real.
//! 3. Each derived frame at time `τ` warps the previous reference
//!    (`j = floor(τ·ref_rate)`) and the next one (`j + 1`), in that order.
//! 4. Reference frames have the display's focal length and an enlarged
//!    field of view (default 88°x68° for a 60°x47° display, the paper's
//!    kitchen), so they hold more pixels than the display.
//! 5. Ground truth is rendered at every derived frame with the same
//!    super-sampling and box-filtered to display pixels.
//! 6. A scene with semi-transparent, mirror or refracting materials gives a
//!    v2 trace: every reference gets a fragment layer (up to `fragments`
//!    per sample) if the scene has semi-transparent materials and a
//!    ray-tree layer if it has specular ones, and every ground truth the
//!    `nondiffuse` mask (a pixel is in it when any of its samples is). A
//!    diffuse scene gives a v1 trace, byte for byte as before v2.

pub mod seen;
use crate::path::CameraPath;
use crate::path::predict::predict_pose;
use crate::path::spline::SplinePath;
use crate::path::tracked::TrackedPath;
use crate::picture::box_filter;
use crate::scene::Scene;
use crate::trace::{Display, SlopeSource, TraceWriter, TruthImage};
use anyhow::{Context, bail};
use postwarp_rtl::{Camera, Intrinsics, Pose};
use std::path::{Path, PathBuf};

/// Which camera path to follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PathKind {
    /// Catmull-Rom spline through the scene's waypoints.
    Spline,
    /// The bundled real hand-held trajectory, placed at the scene's start pose.
    Tracked,
}

/// Every knob of trace generation (units in the field docs).
#[derive(Clone, Debug, PartialEq)]
pub struct TraceSpec {
    /// Display width (pixels).
    pub width: u32,
    /// Display height (pixels).
    pub height: u32,
    /// Super-samples per pixel along each axis.
    pub supersample: u32,
    /// Number of derived frames.
    pub frames: usize,
    /// Camera path.
    pub path: PathKind,
    /// Display horizontal field of view (degrees); the vertical one follows
    /// from the aspect ratio with square pixels.
    pub display_hfov_deg: f64,
    /// Reference field of view, horizontal and vertical (degrees).
    pub ref_fov_deg: (f64, f64),
    /// Reference frame rate (Hz).
    pub ref_rate_hz: f64,
    /// Derived frame rate (Hz).
    pub derived_rate_hz: f64,
    /// Prediction interval for reference viewpoints (seconds).
    pub prediction_s: f64,
    /// Path time of the first derived frame (seconds). The default, 0.5 s,
    /// lets the first reference be predicted from real motion (a reference
    /// predicted from before the path starts sits at the start pose).
    pub start_s: f64,
    /// Render ground truth for every derived frame.
    pub truth: bool,
    /// Stress: offset of every derived camera from its path pose, in its own
    /// camera frame (x right, y down, z forward; scene units). Default 0.
    pub derived_offset: [f64; 3],
    /// Stress: roll of every derived camera about its view axis, relative to
    /// its path pose (degrees, clockwise on screen). Default 0.
    pub derived_roll_deg: f64,
    /// Stress: every camera of the path, references and derived, moved up
    /// along world y (scene units; negative = down, towards a floor at y =
    /// 0). Default 0.
    pub path_offset_y: f64,
    /// Stress: quantise reference depth (1/z) to this many bits over the
    /// reference's own 1/z range (0 = exact, the default; 1 to 24 bits).
    pub depth_bits: u32,
    /// Stress: the fixed-point range of `depth_bits` made this many times
    /// wider than the reference's own 1/z range, towards the camera (a depth
    /// buffer whose near plane is closer than the nearest surface): factor
    /// >= 1, default 1; needs `depth_bits` > 0.
    pub depth_range_scale: f64,
    /// Stress: radius of every `rod` object of the scene (its thin features)
    /// multiplied by this factor (> 0; default 1).
    pub rod_radius_scale: f64,
    /// Stress: every `rod` object scaled — ends, length and radius — by this
    /// factor about the mean of the rods' mid-points (> 0; default 1): on a
    /// flat arrangement such as a fence, thinner rods at the same coverage.
    pub rod_scale: f64,
    /// Most transparent fragments stored per reference sample in a v2
    /// trace's fragment layer (1 to 16; default 4). Rendering composites
    /// every fragment whatever this is.
    pub fragments: u32,
    /// Stress: every object of a semi-transparent, mirror or refracting
    /// material scaled by this factor about the middle of its base (> 0,
    /// default 1; `Scene::with_nondiffuse_scaled`): the non-diffuse share
    /// of the view.
    pub nondiffuse_scale: f64,
}

impl Default for TraceSpec {
    fn default() -> Self {
        TraceSpec {
            width: 320,
            height: 240,
            supersample: 2,
            frames: 15,
            path: PathKind::Spline,
            display_hfov_deg: 60.0,
            ref_fov_deg: (88.0, 68.0),
            ref_rate_hz: 5.0,
            derived_rate_hz: 30.0,
            prediction_s: 0.4,
            start_s: 0.5,
            truth: true,
            derived_offset: [0.0; 3],
            derived_roll_deg: 0.0,
            depth_bits: 0,
            path_offset_y: 0.0,
            rod_radius_scale: 1.0,
            rod_scale: 1.0,
            depth_range_scale: 1.0,
            fragments: 4,
            nondiffuse_scale: 1.0,
        }
    }
}

impl TraceSpec {
    /// Check every knob; the message names the knob.
    pub fn validate(&self) -> anyhow::Result<()> {
        use crate::trace::{MAX_SIDE, MAX_SUPERSAMPLE};
        if self.width == 0 || self.height == 0 || self.width > MAX_SIDE || self.height > MAX_SIDE {
            bail!("--width/--height {}x{}: expected 1 to {MAX_SIDE} pixels", self.width, self.height);
        }
        if !(1..=MAX_SUPERSAMPLE).contains(&self.supersample) {
            bail!("--supersample {}: expected 1 to {MAX_SUPERSAMPLE}", self.supersample);
        }
        check_samples("display frames", self.width, self.height, self.supersample)?;
        if self.frames == 0 {
            bail!("--frames 0: expected at least one derived frame");
        }
        let fov_ok = |v: f64| v.is_finite() && v > 0.0 && v < 179.0;
        if !fov_ok(self.display_hfov_deg) {
            bail!("--display-hfov {}: expected degrees in (0, 179)", self.display_hfov_deg);
        }
        if !fov_ok(self.ref_fov_deg.0) || !fov_ok(self.ref_fov_deg.1) {
            bail!("--ref-fov {}x{}: expected degrees in (0, 179)", self.ref_fov_deg.0, self.ref_fov_deg.1);
        }
        for (name, v) in [("--ref-rate", self.ref_rate_hz), ("--derived-rate", self.derived_rate_hz)] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{name} {v}: expected a positive rate in Hz");
            }
        }
        if !(self.prediction_s.is_finite() && self.prediction_s >= 0.0) {
            bail!("--prediction {}: expected seconds >= 0", self.prediction_s);
        }
        if !(self.start_s.is_finite() && self.start_s >= 0.0) {
            bail!("--start {}: expected seconds >= 0", self.start_s);
        }
        if !self.derived_offset.iter().all(|v| v.is_finite()) {
            bail!("derived_offset {:?}: expected finite scene units", self.derived_offset);
        }
        if !self.path_offset_y.is_finite() {
            bail!("path_offset_y {}: expected finite scene units", self.path_offset_y);
        }
        if !(self.derived_roll_deg.is_finite() && self.derived_roll_deg.abs() <= 180.0) {
            bail!("derived_roll {}: expected degrees in [-180, 180]", self.derived_roll_deg);
        }
        if self.depth_bits > MAX_DEPTH_BITS {
            bail!("depth_bits {}: expected 0 (exact) to {MAX_DEPTH_BITS}", self.depth_bits);
        }
        if !(self.depth_range_scale >= 1.0 && self.depth_range_scale <= MAX_DEPTH_RANGE_SCALE) {
            bail!("depth_range_scale {}: expected a factor in [1, {MAX_DEPTH_RANGE_SCALE}]", self.depth_range_scale);
        }
        if self.depth_range_scale != 1.0 && self.depth_bits == 0 {
            bail!(
                "depth_range_scale {} widens the range of quantised depth: set depth_bits (1 to {MAX_DEPTH_BITS}) too",
                self.depth_range_scale
            );
        }
        for (name, v) in [("rod_radius_scale", self.rod_radius_scale), ("rod_scale", self.rod_scale)] {
            if !(v > 0.0 && v <= MAX_ROD_SCALE) {
                bail!("{name} {v}: expected a factor in (0, {MAX_ROD_SCALE}]");
            }
        }
        let max_f = crate::trace::layers::MAX_FRAGMENTS;
        if !(1..=max_f).contains(&self.fragments) {
            bail!("--fragments {}: expected 1 to {max_f} fragments per sample", self.fragments);
        }
        if !(self.nondiffuse_scale > 0.0 && self.nondiffuse_scale <= MAX_NONDIFFUSE_SCALE) {
            bail!("nondiffuse_scale {}: expected a factor in (0, {MAX_NONDIFFUSE_SCALE}]", self.nondiffuse_scale);
        }
        // As `make_trace` counts them, in f64 so that no ratio overflows.
        let refs = ((self.frames - 1) as f64 * self.ref_rate_hz / self.derived_rate_hz + 1e-9).floor() + 2.0;
        if refs.is_nan() || refs > MAX_REFERENCE_FRAMES as f64 {
            bail!(
                "--frames {} at --derived-rate {} Hz needs {refs} reference frames at --ref-rate {} Hz; \
                 at most {MAX_REFERENCE_FRAMES}",
                self.frames,
                self.derived_rate_hz,
                self.ref_rate_hz
            );
        }
        Ok(())
    }

    /// Display intrinsics.
    pub fn display_intrinsics(&self) -> Intrinsics {
        Intrinsics::from_hfov(self.width, self.height, self.display_hfov_deg)
    }

    /// Reference intrinsics: the display's focal length, the reference field
    /// of view, principal point at the centre.
    pub fn reference_intrinsics(&self) -> anyhow::Result<Intrinsics> {
        let f = self.display_intrinsics().fx;
        let side = |fov: f64| (2.0 * f * (0.5 * fov.to_radians()).tan()).round().max(1.0) as u32;
        let (w, h) = (side(self.ref_fov_deg.0), side(self.ref_fov_deg.1));
        if w > crate::trace::MAX_SIDE || h > crate::trace::MAX_SIDE {
            bail!("reference frames would be {w}x{h} pixels: lower --ref-fov or the display size");
        }
        check_samples("reference frames", w, h, self.supersample)?;
        Ok(Intrinsics { width: w, height: h, fx: f, fy: f, cx: 0.5 * (w as f64 - 1.0), cy: 0.5 * (h as f64 - 1.0) })
    }

    /// The derived camera's pose: the path pose `base` moved by the stress
    /// knobs (`path_offset_y`, then `derived_offset` in its camera frame, then `derived_roll_deg`
    /// about its view axis). Equal to `base` at the defaults.
    pub fn derived_pose(&self, base: Pose) -> Pose {
        let base = self.path_pose(base);
        if self.derived_offset == [0.0; 3] && self.derived_roll_deg == 0.0 {
            return base;
        }
        let off = glam::DVec3::from_array(self.derived_offset);
        let roll = glam::DQuat::from_rotation_z(self.derived_roll_deg.to_radians());
        Pose { position: base.position + base.orientation * off, orientation: (base.orientation * roll).normalize() }
    }

    /// A camera pose on the path moved by `path_offset_y` (references and
    /// derived cameras alike).
    pub fn path_pose(&self, mut p: Pose) -> Pose {
        p.position.y += self.path_offset_y;
        p
    }

    /// The stress knobs away from their defaults, as one provenance line
    /// (`None` when every one is at its default).
    pub fn stress_note(&self, scene: &Scene) -> Option<String> {
        let mut parts = Vec::new();
        if self.derived_offset != [0.0; 3] {
            parts.push(format!("derived cameras offset {:?} (camera x, y, z; scene units)", self.derived_offset));
        }
        if self.derived_roll_deg != 0.0 {
            parts.push(format!("derived cameras rolled {} deg", self.derived_roll_deg));
        }
        if self.path_offset_y != 0.0 {
            parts.push(format!("every camera moved {} scene units up", self.path_offset_y));
        }
        if self.depth_bits != 0 {
            parts.push(format!(
                "reference 1/z quantised to {} bits over {}x its own range",
                self.depth_bits, self.depth_range_scale
            ));
        }
        if self.rod_radius_scale != 1.0 {
            parts.push(format!("the scene's {} rods at {}x their radius", scene.rod_count(), self.rod_radius_scale));
        }
        if self.rod_scale != 1.0 {
            let c = scene.rod_centre();
            parts.push(format!(
                "the scene's {} rods scaled {}x about their centre ({:.3}, {:.3}, {:.3})",
                scene.rod_count(),
                self.rod_scale,
                c.x,
                c.y,
                c.z
            ));
        }
        if self.nondiffuse_scale != 1.0 {
            parts.push(format!(
                "the scene's {} semi-transparent, mirror and refracting objects scaled {}x about their bases",
                scene.nondiffuse_count(),
                self.nondiffuse_scale
            ));
        }
        (!parts.is_empty()).then(|| format!("stress: {}", parts.join("; ")))
    }

    /// Index of the reference frame at or before derived frame `k`.
    pub fn previous_reference(&self, k: usize) -> usize {
        // Exact when the rates divide: 30 Hz / 5 Hz gives 6 derived per reference.
        let r = k as f64 * self.ref_rate_hz / self.derived_rate_hz;
        (r + 1e-9).floor() as usize
    }
}

/// Largest `rod_radius_scale` and `rod_scale` (a hairball rod of 10 mm
/// radius becomes 0.5 m).
pub const MAX_ROD_SCALE: f64 = 50.0;

/// Largest `nondiffuse_scale`.
pub const MAX_NONDIFFUSE_SCALE: f64 = 10.0;

/// `scene` as `spec` renders it: with its rods changed by
/// `rod_radius_scale` and `rod_scale`, and its non-diffuse objects by
/// `nondiffuse_scale` (borrowed unchanged at the defaults).
pub fn stressed_scene<'a>(scene: &'a Scene, spec: &TraceSpec) -> std::borrow::Cow<'a, Scene> {
    let rods = spec.rod_radius_scale != 1.0 || spec.rod_scale != 1.0;
    let nondiffuse = spec.nondiffuse_scale != 1.0;
    match (rods, nondiffuse) {
        (false, false) => std::borrow::Cow::Borrowed(scene),
        (true, false) => std::borrow::Cow::Owned(scene.with_rods_scaled(spec.rod_radius_scale, spec.rod_scale)),
        (false, true) => std::borrow::Cow::Owned(scene.with_nondiffuse_scaled(spec.nondiffuse_scale)),
        (true, true) => std::borrow::Cow::Owned(
            scene.with_rods_scaled(spec.rod_radius_scale, spec.rod_scale).with_nondiffuse_scaled(spec.nondiffuse_scale),
        ),
    }
}

/// The pixel mask of a `width x height` display from a sample mask at `ss
/// x ss` samples per pixel: a pixel is set when any of its samples is.
pub fn pixel_mask(samples: &bitvec::vec::BitVec, width: u32, height: u32, ss: u32) -> bitvec::vec::BitVec {
    let sw = (width * ss) as usize;
    let mut m = bitvec::vec::BitVec::repeat(false, (width * height) as usize);
    for i in samples.iter_ones() {
        let (x, y) = (i % sw, i / sw);
        m.set((y / ss as usize) * width as usize + x / ss as usize, true);
    }
    m
}

/// Largest `depth_range_scale` (2^30: wastes 30 bits).
pub const MAX_DEPTH_RANGE_SCALE: f64 = 1_073_741_824.0;

/// Most bits of `depth_bits`.
pub const MAX_DEPTH_BITS: u32 = 24;

/// Quantise the finite positive depths of `depth` (1/z per sample is what
/// the warper interpolates) to `bits` bits, to the nearest level, over
/// their own 1/z range `[lo, hi]` widened to `[lo, lo + range_scale·(hi −
/// lo)]` (`range_scale` >= 1: a near plane closer than the nearest
/// surface); `bits == 0` leaves them exact. Infinite or non-positive
/// depths (background) are kept.
pub fn quantise_depth(depth: &mut [f32], bits: u32, range_scale: f64) {
    if bits == 0 {
        return;
    }
    let inv: Vec<f64> = depth.iter().filter(|d| d.is_finite() && **d > 0.0).map(|d| 1.0 / *d as f64).collect();
    let lo = inv.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = inv.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || hi <= lo {
        return;
    }
    let levels = ((1u64 << bits) - 1) as f64;
    let span = (hi - lo) * range_scale.max(1.0);
    for d in depth.iter_mut().filter(|d| d.is_finite() && **d > 0.0) {
        let q = ((1.0 / *d as f64 - lo) / span * levels).round() / levels;
        *d = (1.0 / (lo + q * span)) as f32;
    }
}

/// Most reference frames one trace may need (`--frames` and the rates).
pub const MAX_REFERENCE_FRAMES: usize = 100_000;

/// `w x h` pixels at `ss x ss` samples must fit one image of a trace.
fn check_samples(what: &str, w: u32, h: u32, ss: u32) -> anyhow::Result<()> {
    let n = w as u64 * h as u64 * (ss as u64).pow(2);
    if n > crate::trace::MAX_SAMPLES {
        bail!(
            "{what} of {w}x{h} pixels at {ss}x{ss} samples would hold {n} samples; at most {} \
             (lower the size or --supersample)",
            crate::trace::MAX_SAMPLES
        );
    }
    Ok(())
}

/// Build the camera path `kind` of `scene`.
pub fn scene_path(scene: &Scene, kind: PathKind) -> anyhow::Result<Box<dyn CameraPath>> {
    Ok(match kind {
        PathKind::Spline => {
            let w: Vec<_> = scene.spline.waypoints.iter().map(|w| (w.position, w.look_at)).collect();
            Box::new(SplinePath::new(&w, scene.spline.duration_s).map_err(anyhow::Error::msg)?)
        }
        PathKind::Tracked => {
            let s = &scene.tracked.start;
            let start = Pose::look_at(s.position, s.look_at, glam::DVec3::Y);
            Box::new(TrackedPath::bundled(start, scene.tracked.scale, 0.0).map_err(anyhow::Error::msg)?)
        }
    })
}

/// Render `scene` along `spec` into a trace in `out`; `command` is recorded
/// as provenance. Returns the manifest path.
pub fn make_trace(scene: &Scene, spec: &TraceSpec, out: &Path, command: &str) -> anyhow::Result<PathBuf> {
    make_trace_with(scene, spec, out, command, true)
}

/// [`make_trace`], with a progress bar only if `progress` (and stderr is a
/// terminal): parallel callers (`postwarp sweep`) turn it off.
pub fn make_trace_with(
    scene: &Scene,
    spec: &TraceSpec,
    out: &Path,
    command: &str,
    progress: bool,
) -> anyhow::Result<PathBuf> {
    spec.validate()?;
    let scene = &*stressed_scene(scene, spec);
    let path = scene_path(scene, spec.path)?;
    let display = spec.display_intrinsics();
    let ref_k = spec.reference_intrinsics()?;
    let last = spec.frames - 1;
    let n_refs = spec.previous_reference(last) + 2;
    let ss = spec.supersample;

    let mut w = TraceWriter::new(out, Display { width: spec.width, height: spec.height, supersample: ss })?;
    w.note(format!("made by: {command}"));
    w.note(format!("scene: {} ({})", scene.name, scene.description));
    w.note(format!(
        "path: {:?}, references at {} Hz predicted {} s ahead, derived at {} Hz from t = {} s; depth unit: metres",
        spec.path, spec.ref_rate_hz, spec.prediction_s, spec.derived_rate_hz, spec.start_s
    ));
    let (rh, rv) = ref_k.fov_deg();
    let (dh, dv) = display.fov_deg();
    w.note(format!("field of view: display {dh:.1}x{dv:.1} deg, references {rh:.1}x{rv:.1} deg"));
    if let Some(stress) = spec.stress_note(scene) {
        w.note(stress);
    }

    let steps = (n_refs + if spec.truth { spec.frames } else { 0 }) as u64;
    // The references as warped, for the truth's visibility (`seen`).
    let mut rendered: Vec<(Camera, postwarp_rtl::SampleImage)> = Vec::with_capacity(n_refs);
    let bar = if progress { crate::progress::bar(steps, "rendering") } else { indicatif::ProgressBar::hidden() };
    for j in 0..n_refs {
        let t = j as f64 / spec.ref_rate_hz;
        let pose = spec.path_pose(predict_pose(path.as_ref(), spec.start_s + t, spec.prediction_s));
        let cam = Camera { intrinsics: ref_k, pose };
        let r = scene.render_layers(&cam, ss, spec.fragments);
        let mut img = r.samples;
        quantise_depth(&mut img.z, spec.depth_bits, spec.depth_range_scale);
        let layers = crate::trace::layers::Layers { fragments: r.fragments, raytree: r.raytree };
        w.add_reference_with_layers(t, cam, &img, SlopeSource::Exact, &layers)
            .with_context(|| format!("writing reference {j}"))?;
        if spec.truth {
            rendered.push((cam, img));
        }
        bar.inc(1);
    }
    for k in 0..spec.frames {
        let t = k as f64 / spec.derived_rate_hz;
        let cam = Camera { intrinsics: display, pose: spec.derived_pose(path.pose(spec.start_s + t)) };
        let prev = spec.previous_reference(k);
        let truth = if spec.truth {
            let r = scene.render_layers(&cam, ss, spec.fragments);
            let img = r.samples;
            bar.inc(1);
            let nondiffuse = (scene.has_transparency() || scene.has_specular())
                .then(|| pixel_mask(&r.nondiffuse, spec.width, spec.height, ss));
            let refs: Vec<(Camera, &postwarp_rtl::SampleImage)> =
                [prev, prev + 1].iter().map(|&j| (rendered[j].0, &rendered[j].1)).collect();
            Some(TruthImage {
                width: spec.width,
                height: spec.height,
                colour: box_filter(img.width, img.height, ss, &img.colour),
                known: bitvec::vec::BitVec::repeat(true, (spec.width * spec.height) as usize),
                nondiffuse,
                seen: Some(seen::seen_pixels(&cam, &img, ss, &refs)),
            })
        } else {
            None
        };
        w.add_derived(t, cam, vec![prev, prev + 1], truth.as_ref())?;
    }
    bar.finish_and_clear();
    Ok(w.finish()?)
}

/// The cameras of derived frame `k` under `spec`, as [`make_trace`] places
/// them: its two references `(trace index, camera)` and its own camera.
/// `scene` is already stressed ([`stressed_scene`]).
fn frame_cameras(scene: &Scene, spec: &TraceSpec, k: usize) -> anyhow::Result<(Vec<(usize, Camera)>, Camera)> {
    let path = scene_path(scene, spec.path)?;
    let ref_k = spec.reference_intrinsics()?;
    let prev = spec.previous_reference(k);
    let cams: Vec<(usize, Camera)> = [prev, prev + 1]
        .into_iter()
        .map(|j| {
            let t = j as f64 / spec.ref_rate_hz;
            let pose = spec.path_pose(predict_pose(path.as_ref(), spec.start_s + t, spec.prediction_s));
            (j, Camera { intrinsics: ref_k, pose })
        })
        .collect();
    let t = k as f64 / spec.derived_rate_hz;
    let derived =
        Camera { intrinsics: spec.display_intrinsics(), pose: spec.derived_pose(path.pose(spec.start_s + t)) };
    Ok((cams, derived))
}

/// Write derived frame `k` of `scene` under `spec` as a trace of its own
/// into `out` (which must not exist): the two references [`frame_in_memory`]
/// renders (`refs`, in its order) and the derived frame with its ground
/// truth, rendered as [`make_trace`] renders it. Returns the manifest path.
/// `postwarp bench` times whole `simulate` processes on it.
pub fn write_frame_trace(
    scene: &Scene,
    spec: &TraceSpec,
    k: usize,
    refs: &[postwarp_rtl::SampleImage],
    out: &Path,
) -> anyhow::Result<PathBuf> {
    spec.validate()?;
    let ss = spec.supersample;
    let scene = &*stressed_scene(scene, spec);
    let (cams, derived) = frame_cameras(scene, spec, k)?;
    anyhow::ensure!(
        refs.len() == cams.len(),
        "derived frame {k} warps {} references; {} given",
        cams.len(),
        refs.len()
    );
    let mut w = TraceWriter::new(out, Display { width: spec.width, height: spec.height, supersample: ss })?;
    w.note(format!("derived frame {k} of scene {} alone (postwarp bench); depth unit: metres", scene.name));
    let mut list = Vec::new();
    for ((j, cam), img) in cams.iter().zip(refs) {
        list.push(w.add_reference(*j as f64 / spec.ref_rate_hz, *cam, img, SlopeSource::Exact)?);
    }
    let img = scene.render_layers(&derived, ss, spec.fragments).samples;
    let seen_by: Vec<(Camera, &postwarp_rtl::SampleImage)> = cams.iter().map(|(_, c)| *c).zip(refs).collect();
    let truth = TruthImage {
        width: spec.width,
        height: spec.height,
        colour: box_filter(img.width, img.height, ss, &img.colour),
        known: bitvec::vec::BitVec::repeat(true, (spec.width * spec.height) as usize),
        nondiffuse: None,
        seen: Some(seen::seen_pixels(&derived, &img, ss, &seen_by)),
    };
    w.add_derived(k as f64 / spec.derived_rate_hz, derived, list, Some(&truth))?;
    Ok(w.finish()?)
}

/// Derived frame `k` of `scene` under `spec`, built in memory exactly as
/// [`make_trace`] writes it (colour rounded to half, as the trace stores
/// it): its commands and the rendered samples of its two references. For
/// benchmarks that must not depend on files.
pub fn frame_in_memory(
    scene: &Scene,
    spec: &TraceSpec,
    k: usize,
) -> anyhow::Result<(postwarp_rtl::FrameCommands, Vec<postwarp_rtl::SampleImage>)> {
    let ss = spec.supersample;
    let scene = &*stressed_scene(scene, spec);
    let (cams, derived) = frame_cameras(scene, spec, k)?;
    let cmd = postwarp_rtl::FrameCommands::new(k, derived, ss, &cams);
    let refs = cams
        .iter()
        .map(|(_, cam)| {
            let mut img = scene.render(cam, ss);
            quantise_depth(&mut img.z, spec.depth_bits, spec.depth_range_scale);
            for c in img.colour.iter_mut().flatten() {
                *c = exr::prelude::f16::from_f32(*c).to_f32();
            }
            img
        })
        .collect();
    Ok((cmd, refs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_geometry_by_default() {
        let s = TraceSpec { width: 640, height: 480, ..TraceSpec::default() };
        let d = s.display_intrinsics();
        assert!((d.fx - 554.256).abs() < 1e-3, "{}", d.fx);
        let r = s.reference_intrinsics().unwrap();
        // docs/warper-reference.md: 68°x88° references ≈ 1071x745 for a 640x480 display.
        assert_eq!((r.width, r.height), (1070, 748));
    }

    #[test]
    fn derived_frames_pick_previous_and_next_references() {
        let s = TraceSpec::default();
        assert_eq!(s.previous_reference(0), 0);
        assert_eq!(s.previous_reference(5), 0);
        assert_eq!(s.previous_reference(6), 1);
        assert_eq!(s.previous_reference(13), 2);
    }

    #[test]
    fn stress_knobs_move_the_derived_camera_in_its_own_frame() {
        let base = Pose::look_at(glam::DVec3::new(1.0, 2.0, 3.0), glam::DVec3::new(1.0, 2.0, 0.0), glam::DVec3::Y);
        let s = TraceSpec::default();
        assert_eq!(s.derived_pose(base), base);
        // Looking down -z with y up: camera x is world +x... or -x; 0.5 along it.
        let s = TraceSpec { derived_offset: [0.5, 0.0, 1.0], path_offset_y: -1.0, ..TraceSpec::default() };
        let p = s.derived_pose(base);
        let d = p.position - base.position;
        assert!(
            (d - (base.orientation * glam::DVec3::new(0.5, 0.0, 1.0) + glam::DVec3::new(0.0, -1.0, 0.0))).length()
                < 1e-12
        );
        assert!((d.z + 1.0).abs() < 1e-12, "forward is -z here: {d}");
        let s = TraceSpec { derived_roll_deg: 90.0, ..TraceSpec::default() };
        let r = s.derived_pose(base).orientation * glam::DVec3::X;
        assert!((r - base.orientation * glam::DVec3::Y).length() < 1e-12, "camera x turns to the old camera y");
        assert!(TraceSpec { derived_roll_deg: 181.0, ..TraceSpec::default() }.validate().is_err());
        assert!(TraceSpec { depth_bits: 25, ..TraceSpec::default() }.validate().is_err());
    }

    #[test]
    fn depth_quantisation_has_at_most_2_to_the_bits_levels_in_inverse_depth() {
        let mut z: Vec<f32> = (1..=1000).map(|i| i as f32 * 0.1).chain([f32::INFINITY, 0.0]).collect();
        let exact = z.clone();
        quantise_depth(&mut z, 0, 1.0);
        assert_eq!(z, exact);
        let mut wide = z.clone();
        quantise_depth(&mut z, 3, 1.0);
        let mut levels: Vec<u32> = z[..1000].iter().map(|d| (1.0 / d).to_bits()).collect();
        levels.sort();
        levels.dedup();
        assert!(levels.len() <= 8, "{}", levels.len());
        assert_eq!(&z[1000..], &[f32::INFINITY, 0.0], "background kept");
        assert!((z[0] - 0.1).abs() < 1e-6 && (z[999] - 100.0).abs() < 1e-3, "the range's ends are levels");

        // A range 8 times wider at 6 bits leaves 63/8 steps over the
        // samples' own range: at most 9 levels (about 3 bits' worth).
        quantise_depth(&mut wide, 6, 8.0);
        let mut levels: Vec<u32> = wide[..1000].iter().map(|d| d.to_bits()).collect();
        levels.sort();
        levels.dedup();
        assert!((6..=9).contains(&levels.len()), "{}", levels.len());
        assert!((wide[999] - 100.0).abs() < 1e-3, "the far end is still a level");
        assert!(wide.iter().take(1000).all(|d| d.is_finite() && *d > 0.0));
        let e = TraceSpec { depth_range_scale: 4.0, ..TraceSpec::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("depth_bits"), "{e}");
        assert!(TraceSpec { depth_range_scale: 0.5, depth_bits: 8, ..TraceSpec::default() }.validate().is_err());
        assert!(TraceSpec { depth_range_scale: 4.0, depth_bits: 8, ..TraceSpec::default() }.validate().is_ok());
    }

    #[test]
    fn rod_radius_scale_widens_only_the_rods() {
        let scene = Scene::builtin("hairball").unwrap();
        assert_eq!(scene.rod_count(), 360);
        let spec = TraceSpec { rod_radius_scale: 2.5, ..TraceSpec::default() };
        let wide = stressed_scene(&scene, &spec);
        for (a, b) in scene.rod_radii().iter().zip(wide.rod_radii()) {
            assert!((b - 2.5 * a).abs() < 1e-12, "{a} -> {b}");
        }
        assert_eq!(wide.object_count(), scene.object_count());
        assert!(matches!(stressed_scene(&scene, &TraceSpec::default()), std::borrow::Cow::Borrowed(_)));
        assert!(spec.stress_note(&scene).unwrap().contains("360 rods at 2.5x"));
        // Rendered, the rods cover more samples (about 2.5 times, less
        // where they overlap each other).
        let small = TraceSpec { width: 48, height: 36, ..spec.clone() };
        let path = scene_path(&scene, small.path).unwrap();
        let cam = Camera { intrinsics: small.display_intrinsics(), pose: path.pose(small.start_s) };
        let rod_samples = |s: &Scene| s.render(&cam, 1).object_id.iter().filter(|&&id| s.is_rod(id)).count();
        let (thin, thick) = (rod_samples(&scene), rod_samples(&wide));
        assert!(thin > 20 && thick as f64 > 1.6 * thin as f64, "{thin} -> {thick}");
        assert!(TraceSpec::default().stress_note(&scene).is_none());
        for bad in [0.0, -1.0, f64::NAN, 51.0] {
            let e = TraceSpec { rod_radius_scale: bad, ..TraceSpec::default() }.validate().unwrap_err();
            assert!(e.to_string().contains("rod_radius_scale"), "{e}");
            let e = TraceSpec { rod_scale: bad, ..TraceSpec::default() }.validate().unwrap_err();
            assert!(e.to_string().contains("rod_scale"), "{e}");
        }

        // rod_scale: radii and distances from the centre scale together;
        // the centre stays.
        let both = TraceSpec { rod_radius_scale: 2.0, rod_scale: 0.25, ..TraceSpec::default() };
        let small = stressed_scene(&scene, &both);
        for (a, b) in scene.rod_radii().iter().zip(small.rod_radii()) {
            assert!((b - 0.5 * a).abs() < 1e-12, "{a} -> {b}");
        }
        assert!((small.rod_centre() - scene.rod_centre()).length() < 1e-9);
    }

    #[test]
    fn bad_knobs_name_the_flag() {
        let e = TraceSpec { supersample: 7, ..TraceSpec::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("--supersample"));
        let e = TraceSpec { frames: 0, ..TraceSpec::default() }.validate().unwrap_err();
        assert!(e.to_string().contains("--frames"));
    }
}
