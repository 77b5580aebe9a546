//! Trace format v2 (reads v1): a text manifest naming the display
//! geometry, the reference frames (OpenEXR image + camera, and in v2
//! optional layers: transparent fragments, a ray tree; `layers`) and the
//! derived frames to synthesize (camera, which references to warp,
//! optional ground truth). The grammar is in `docs/trace-format.md`; this
//! module is its only parser and writer. A trace without layers is written
//! as version 1, byte for byte as before v2 existed.
//!
//! A trace is a directory holding the manifest [`MANIFEST_NAME`] and the
//! images it names (paths relative to the manifest's directory).

mod error;
mod exr_blocks;
mod exr_io;
pub mod layers;
mod parse;
mod write;

pub use error::TraceError;
pub use exr_io::{
    ExrPacking, SamplePlanes, decode_reference_image, decode_truth_image, read_reference_image, read_truth_image,
    write_reference_image, write_reference_image_packed, write_sample_planes, write_truth_image,
};
pub use parse::parse_manifest;
pub use write::{TraceWriter, format_manifest};

use bitvec::vec::BitVec;
use postwarp_rtl::{Camera, FrameCommands, SampleImage};
use std::path::{Path, PathBuf};

/// The newest manifest version this build reads and writes (it reads
/// every version from [`MIN_TRACE_VERSION`] up).
pub const TRACE_VERSION: u32 = 2;
/// The oldest manifest version this build reads.
pub const MIN_TRACE_VERSION: u32 = 1;
/// File name of the manifest inside a trace directory.
pub const MANIFEST_NAME: &str = "postwarp.trace";
/// Largest accepted image side, in pixels.
pub const MAX_SIDE: u32 = 16384;
/// Largest accepted super-sampling factor (samples per pixel per axis).
pub const MAX_SUPERSAMPLE: u32 = 4;
/// Most reference frames one derived frame may warp (the source-number
/// plane and the better-reference mask are sized for it; TR98 uses 2).
pub const MAX_REFS_PER_FRAME: usize = 8;
/// Largest accepted number of samples in one image (2^28).
pub const MAX_SAMPLES: u64 = 1 << 28;

/// Display geometry: the derived frames' size and super-sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Display {
    /// Derived-frame width (pixels).
    pub width: u32,
    /// Derived-frame height (pixels).
    pub height: u32,
    /// Super-samples per pixel along each axis (all images of the trace).
    pub supersample: u32,
}

/// A reference frame: an image with depth, rendered (or captured) at `camera`.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceFrame {
    /// Time the frame stands for (seconds from the start of the trace).
    pub time_s: f64,
    /// Camera, in pixels (the image holds `supersample²` samples per pixel).
    pub camera: Camera,
    /// EXR image, relative to the trace directory.
    pub image: PathBuf,
    /// Optional v2 layers (`layer` statements) of this reference.
    pub layers: layers::ReferenceLayers,
}

/// A derived frame: a viewpoint to synthesize from reference frames.
#[derive(Clone, Debug, PartialEq)]
pub struct DerivedFrame {
    /// Time of the frame (seconds from the start of the trace).
    pub time_s: f64,
    /// Camera, in display pixels (size = display size).
    pub camera: Camera,
    /// Indices of the reference frames to warp, in warp order.
    pub references: Vec<usize>,
    /// Ground-truth EXR image (display pixels), relative to the trace directory.
    pub truth: Option<PathBuf>,
}

/// A parsed trace manifest.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// Display geometry.
    pub display: Display,
    /// Free-text notes (`note` statements), in order: provenance, units.
    pub notes: Vec<String>,
    /// Reference frames, by index.
    pub references: Vec<ReferenceFrame>,
    /// Derived frames, by index.
    pub derived: Vec<DerivedFrame>,
    /// Directory the image paths are relative to (not part of the manifest).
    pub dir: PathBuf,
    /// The manifest file this trace was read from (empty if built in memory).
    pub manifest: PathBuf,
}

/// How a reference image's 1/Z slopes were obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlopeSource {
    /// Supplied by the producer (channels `dinvz_dx`, `dinvz_dy`).
    Exact,
    /// Absent from the file: computed from depth by finite differences.
    FiniteDifference,
}

impl SlopeSource {
    /// Short name used in reports.
    pub fn name(self) -> &'static str {
        match self {
            SlopeSource::Exact => "exact",
            SlopeSource::FiniteDifference => "finite-difference",
        }
    }
}

/// A reference image as loaded: samples plus where the slopes came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedReference {
    /// Per-sample planes.
    pub samples: SampleImage,
    /// Origin of `samples.inv_z_slopes`.
    pub slopes: SlopeSource,
}

/// Ground truth at display resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct TruthImage {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Linear RGB per pixel.
    pub colour: Vec<[f32; 3]>,
    /// Set where the truth is known; metrics skip the other pixels.
    pub known: BitVec,
    /// Set where some sample of the pixel sees a specular or transparent
    /// surface (channel `nondiffuse`; `None` if the file has none): the
    /// mask `docs/non-diffuse.md` scores on its own.
    pub nondiffuse: Option<BitVec>,
    /// Set where some reference sees the surface the pixel shows (channel
    /// `seen`; `None` if the file has none: every pixel counts as seen):
    /// the visibility term of the common mask (`docs/metrics.md`).
    pub seen: Option<BitVec>,
}

impl Trace {
    /// Read and check a trace: `path` is a trace directory or a manifest file.
    /// Checks the manifest and that every image it names exists; image
    /// contents are checked when loaded.
    pub fn open(path: &Path) -> Result<Trace, TraceError> {
        let manifest = if path.is_dir() { path.join(MANIFEST_NAME) } else { path.to_path_buf() };
        let text =
            crate::io_util::read_text(&manifest, "trace manifest (postwarp.trace, or a trace directory holding one)")
                .map_err(|e| TraceError::file(&manifest, e.message))?;
        let dir = manifest.parent().map(Path::to_path_buf).unwrap_or_default();
        let mut trace = parse_manifest(&text, &manifest)?;
        trace.dir = dir;
        trace.manifest = manifest;
        trace.check_images_exist(&text)?;
        Ok(trace)
    }

    /// Every image file the manifest names, relative to the trace
    /// directory: reference images, their layers, ground truth.
    pub fn image_files(&self) -> impl Iterator<Item = &PathBuf> {
        self.references
            .iter()
            .flat_map(|r| std::iter::once(&r.image).chain(r.layers.iter().map(|l| l.image())))
            .chain(self.derived.iter().filter_map(|d| d.truth.as_ref()))
    }

    /// The manifest version this trace needs: 2 if a reference has layers,
    /// else 1 (what [`format_manifest`] writes).
    pub fn format_version(&self) -> u32 {
        if self.references.iter().any(|r| !r.layers.is_empty()) { 2 } else { 1 }
    }

    fn check_images_exist(&self, text: &str) -> Result<(), TraceError> {
        let names = self.image_files();
        for name in names {
            let full = self.dir.join(name);
            if let Err(e) = crate::io_util::check_input_file(&full, "image file") {
                let line = parse::line_mentioning(text, name);
                return Err(TraceError::at(&self.manifest, line, e.to_string()));
            }
        }
        Ok(())
    }

    /// Number of the manifest line that declares reference `i` (1-based), for
    /// error messages about its image.
    fn reference_line(&self, i: usize) -> Option<usize> {
        let text = std::fs::read_to_string(&self.manifest).ok()?;
        parse::statement_line(&text, "reference", i)
    }

    fn derived_line(&self, i: usize) -> Option<usize> {
        let text = std::fs::read_to_string(&self.manifest).ok()?;
        parse::statement_line(&text, "derived", i)
    }

    /// Load and check reference frame `i`'s image. Slopes absent from the
    /// file are computed by finite differences (see [`SlopeSource`]).
    pub fn load_reference(&self, i: usize) -> Result<LoadedReference, TraceError> {
        let r = &self.references[i];
        let ss = self.display.supersample;
        let (w, h) = (r.camera.intrinsics.width * ss, r.camera.intrinsics.height * ss);
        exr_io::read_reference_image(&self.dir.join(&r.image), (w, h))
            .map_err(|e| e.referenced_from(&self.manifest, self.reference_line(i)))
    }

    /// Load and check reference frame `i`'s layers (none for a v1 trace).
    /// Their images have the reference image's sample grid.
    pub fn load_layers(&self, i: usize) -> Result<layers::Layers, TraceError> {
        let r = &self.references[i];
        let ss = self.display.supersample;
        let size = (r.camera.intrinsics.width * ss, r.camera.intrinsics.height * ss);
        let named_at =
            |image: &Path| std::fs::read_to_string(&self.manifest).ok().and_then(|t| parse::line_mentioning(&t, image));
        let mut out = layers::Layers::default();
        if let Some(layers::LayerStatement::Fragments { image, max }) = &r.layers.fragments {
            out.fragments = Some(
                layers::read_fragment_layer(&self.dir.join(image), size, *max)
                    .map_err(|e| e.referenced_from(&self.manifest, named_at(image)))?,
            );
        }
        if let Some(layers::LayerStatement::RayTree { image, materials }) = &r.layers.raytree {
            out.raytree = Some(
                layers::read_ray_tree_layer(&self.dir.join(image), size, materials)
                    .map_err(|e| e.referenced_from(&self.manifest, named_at(image)))?,
            );
        }
        Ok(out)
    }

    /// The layer kinds some reference of the trace declares, in
    /// [`layers::LAYER_KINDS`] order (empty for a v1 trace).
    pub fn layer_kinds(&self) -> Vec<&'static str> {
        let has = |f: fn(&layers::ReferenceLayers) -> bool| self.references.iter().any(|r| f(&r.layers));
        let present = [has(|l| l.fragments.is_some()), has(|l| l.raytree.is_some())];
        layers::LAYER_KINDS.iter().zip(present).filter(|(_, p)| *p).map(|(k, _)| *k).collect()
    }

    /// True if some reference of the trace has layers (a v2 trace).
    pub fn has_layers(&self) -> bool {
        self.format_version() > 1
    }

    /// For each reference frame, the last derived frame that warps it
    /// (references no derived frame uses are absent): a runner drops a
    /// loaded reference once past it.
    pub fn last_use(&self) -> std::collections::HashMap<usize, usize> {
        let mut last = std::collections::HashMap::new();
        for (k, f) in self.derived.iter().enumerate() {
            for &r in &f.references {
                last.insert(r, k);
            }
        }
        last
    }

    /// Load and check derived frame `i`'s ground truth, if it has one.
    pub fn load_truth(&self, i: usize) -> Result<Option<TruthImage>, TraceError> {
        let Some(p) = &self.derived[i].truth else {
            return Ok(None);
        };
        read_truth_image(&self.dir.join(p), (self.display.width, self.display.height))
            .map(Some)
            .map_err(|e| e.referenced_from(&self.manifest, self.derived_line(i)))
    }

    /// The frame commands for derived frame `i`.
    pub fn frame_commands(&self, i: usize) -> FrameCommands {
        let d = &self.derived[i];
        let refs: Vec<(usize, Camera)> = d.references.iter().map(|&r| (r, self.references[r].camera)).collect();
        FrameCommands::new(i, d.camera, self.display.supersample, &refs)
    }
}
