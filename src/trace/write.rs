//! Manifest and trace writer: [`Trace`] → text, and [`TraceWriter`], which
//! writes a trace directory image by image and the manifest last. Numbers are
//! printed in Rust's shortest round-trip form, so writing then parsing gives
//! the same trace.

use super::*;
use crate::io_util::write_bytes_atomically;
use std::fmt::Write as _;

/// The manifest text of `t`.
pub fn format_manifest(t: &Trace) -> String {
    let mut s = format!("postwarp-trace {TRACE_VERSION}\n");
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
        write_reference_image(&self.trace.dir.join(&rel), image, slopes)?;
        self.trace.references.push(ReferenceFrame { time_s, camera, image: rel });
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
