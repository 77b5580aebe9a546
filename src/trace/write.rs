//! Manifest and trace writer: [`Trace`] → text, and [`TraceWriter`], which
//! writes a trace directory image by image and the manifest last. Numbers are
//! printed in Rust's shortest round-trip form, so writing then parsing gives
//! the same trace.

use super::*;
use crate::io_util::write_bytes_atomically;
use std::fmt::Write as _;

/// The manifest text of `t`.
pub fn format_manifest(t: &Trace) -> String {
    let mut s = format!("postwarp-trace {}\n", t.format_version());
    for n in &t.notes {
        let _ = writeln!(s, "note {n}");
    }
    let d = t.display;
    let _ = writeln!(s, "display width={} height={} supersample={}", d.width, d.height, d.supersample);
    for (i, r) in t.references.iter().enumerate() {
        let k = &r.camera.intrinsics;
        let _ = writeln!(
            s,
            "reference {i} time={} image={} size={}x{} {}",
            r.time_s,
            r.image.display(),
            k.width,
            k.height,
            camera_fields(&r.camera)
        );
        for l in r.layers.iter() {
            let _ = writeln!(s, "layer {i} {}", l.fields());
        }
    }
    for (i, f) in t.derived.iter().enumerate() {
        let refs: Vec<String> = f.references.iter().map(|r| r.to_string()).collect();
        let _ = write!(s, "derived {i} time={} refs={}", f.time_s, refs.join(","));
        if let Some(p) = &f.truth {
            let _ = write!(s, " truth={}", p.display());
        }
        let _ = writeln!(s, " {}", camera_fields(&f.camera));
    }
    s
}

fn camera_fields(c: &Camera) -> String {
    let k = &c.intrinsics;
    let p = c.pose.position;
    let q = c.pose.orientation;
    format!(
        "fx={} fy={} cx={} cy={} position={},{},{} orientation={},{},{},{}",
        k.fx, k.fy, k.cx, k.cy, p.x, p.y, p.z, q.x, q.y, q.z, q.w
    )
}

/// Writes a trace directory: images as they are added, the manifest on
/// [`TraceWriter::finish`].
pub struct TraceWriter {
    trace: Trace,
}

impl TraceWriter {
    /// Start a trace in `dir` (created if needed).
    pub fn new(dir: &Path, display: Display) -> Result<TraceWriter, TraceError> {
        std::fs::create_dir_all(dir).map_err(|e| TraceError::io(dir, &e))?;
        let manifest = dir.join(MANIFEST_NAME);
        Ok(TraceWriter {
            trace: Trace {
                display,
                notes: Vec::new(),
                references: Vec::new(),
                derived: Vec::new(),
                dir: dir.to_path_buf(),
                manifest,
            },
        })
    }

    /// Add a `note` line (provenance, units). Line breaks become spaces and
    /// surrounding white space is dropped, as the parser drops it, so the
    /// note reads back exactly as kept.
    pub fn note(&mut self, text: impl Into<String>) {
        self.trace.notes.push(text.into().replace(['\n', '\r'], " ").trim().to_string());
    }

    /// Add a reference frame and write its image as `ref/NNNN.exr`.
    pub fn add_reference(
        &mut self,
        time_s: f64,
        camera: Camera,
        image: &SampleImage,
        slopes: SlopeSource,
    ) -> Result<usize, TraceError> {
        self.add_reference_with_layers(time_s, camera, image, slopes, &layers::Layers::default())
    }

    /// Add a reference frame with its v2 layers: the image as
    /// `ref/NNNN.exr`, a fragment layer as `ref/NNNN-fragments.exr`, a ray
    /// tree as `ref/NNNN-raytree.exr` (each the image's sample grid).
    pub fn add_reference_with_layers(
        &mut self,
        time_s: f64,
        camera: Camera,
        image: &SampleImage,
        slopes: SlopeSource,
        with: &layers::Layers,
    ) -> Result<usize, TraceError> {
        let ss = self.trace.display.supersample;
        let i = self.trace.references.len();
        let rel = PathBuf::from(format!("ref/{i:04}.exr"));
        let want = (camera.intrinsics.width * ss, camera.intrinsics.height * ss);
        if (image.width, image.height) != want {
            return Err(TraceError::file(
                &self.trace.dir.join(&rel),
                format!("reference image is {}x{} samples; expected {}x{}", image.width, image.height, want.0, want.1),
            ));
        }
        let mut decl = layers::ReferenceLayers::default();
        let size_err = |rel: &Path, what: &str, w: u32, h: u32| {
            TraceError::file(
                &self.trace.dir.join(rel),
                format!("{what} layer is {w}x{h} samples; expected the image's {}x{}", want.0, want.1),
            )
        };
        if let Some(f) = &with.fragments {
            let rel = PathBuf::from(format!("ref/{i:04}-fragments.exr"));
            if (f.width, f.height) != want {
                return Err(size_err(&rel, "fragment", f.width, f.height));
            }
            layers::write_fragment_layer(&self.trace.dir.join(&rel), f)?;
            decl.fragments = Some(layers::LayerStatement::Fragments { image: rel, max: f.max });
        }
        if let Some(t) = &with.raytree {
            let rel = PathBuf::from(format!("ref/{i:04}-raytree.exr"));
            if (t.width, t.height) != want {
                return Err(size_err(&rel, "ray-tree", t.width, t.height));
            }
            layers::write_ray_tree_layer(&self.trace.dir.join(&rel), t)?;
            decl.raytree = Some(layers::LayerStatement::RayTree { image: rel, materials: t.materials.clone() });
        }
        write_reference_image(&self.trace.dir.join(&rel), image, slopes)?;
        self.trace.references.push(ReferenceFrame { time_s, camera, image: rel, layers: decl });
        Ok(i)
    }

    /// Add a derived frame, writing its ground truth (if any) as `truth/NNNN.exr`.
    pub fn add_derived(
        &mut self,
        time_s: f64,
        camera: Camera,
        references: Vec<usize>,
        truth: Option<&TruthImage>,
    ) -> Result<usize, TraceError> {
        let i = self.trace.derived.len();
        let d = self.trace.display;
        let truth = match truth {
            None => None,
            Some(t) => {
                let rel = PathBuf::from(format!("truth/{i:04}.exr"));
                if (t.width, t.height) != (d.width, d.height) {
                    return Err(TraceError::file(
                        &self.trace.dir.join(&rel),
                        format!(
                            "truth is {}x{}; expected the display size {}x{}",
                            t.width, t.height, d.width, d.height
                        ),
                    ));
                }
                write_truth_image(&self.trace.dir.join(&rel), t)?;
                Some(rel)
            }
        };
        self.trace.derived.push(DerivedFrame { time_s, camera, references, truth });
        Ok(i)
    }

    /// Write the manifest (atomically) and return its path.
    pub fn finish(self) -> Result<PathBuf, TraceError> {
        let text = format_manifest(&self.trace);
        // Check what we are about to write parses: a writer bug must not
        // produce a trace nobody can read.
        parse_manifest(&text, &self.trace.manifest)?;
        write_bytes_atomically(&self.trace.manifest, text.as_bytes())
            .map_err(|e| TraceError::io(&self.trace.manifest, &e))?;
        Ok(self.trace.manifest)
    }
}
