//! Trace format v2's optional per-reference layers (`docs/trace-format.md`,
//! "Layers"): what a renderer knows beyond one opaque diffuse surface per
//! sample, for the methods that warp it (seed 000's A-buffer, seed 004's
//! ray tree).
//!
//! - **Transparent fragments** (`kind=fragments`): up to `max` (N)
//!   semi-transparent fragments per sample in ray order (nearest first),
//!   each with colour, opacity and depth, plus the colour of the opaque
//!   surface behind them (what a deferred renderer's G-buffer holds while
//!   the fragments sit in its A-buffer). The reference image's own colour
//!   is the composite of both; its depth is the opaque surface's
//!   (semi-transparent surfaces write no depth).
//! - **Ray tree** (`kind=raytree`): seed 004's RGBZ ray tree with three
//!   nodes, diffuse root, first reflection, first refraction: per node an
//!   RGB radiance image not multiplied by the view-dependent Fresnel term
//!   (tints, which are view-independent, are multiplied in) and a depth:
//!   the root's along the optical axis, as the reference image's `Z`; a
//!   child's the distance from the parent's hit point to the child ray's
//!   hit along the (unit) child ray. A validity bit per node and a
//!   material index per sample into the layer's material table, which says
//!   how the nodes weigh: a `mirror` (reflection weight 1) or a dielectric
//!   of a given index of refraction (Fresnel weights).
//!
//! The manifest names a layer with one `layer` statement after its
//! reference ([`LayerStatement`]); the images are OpenEXR files read and
//! written by `exr_io` ([`read_fragment_layer`], [`read_ray_tree_layer`]).
//! Unknown kinds are refused with file and line, so a reader never
//! silently drops data a producer meant to pass on.

use std::path::PathBuf;

/// Most transparent fragments a fragment layer may store per sample.
pub const MAX_FRAGMENTS: u32 = 16;
/// Most entries of a ray-tree layer's material table (indices are 8-bit,
/// 0 meaning "no specular material").
pub const MAX_MATERIALS: usize = 255;

/// The layer kinds this build reads, as the manifest spells them.
pub const LAYER_KINDS: [&str; 2] = ["fragments", "raytree"];

/// How the reflection and refraction nodes of a ray-tree sample weigh in
/// the composite (a material-table entry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpecularMaterial {
    /// A mirror: the reflection node at weight 1 (tinted, no Fresnel term;
    /// a metal), no refraction.
    Mirror,
    /// A dielectric of index of refraction `ior` (outside: 1): reflection
    /// at the Fresnel reflectance `F`, refraction at `1 − F`.
    Dielectric {
        /// Index of refraction inside the surface (> 0; glass 1.5).
        ior: f64,
    },
}

impl SpecularMaterial {
    /// Weights of the reflection and refraction nodes for a ray meeting a
    /// surface of unit normal `n` with unit direction `d` (any side):
    /// `(1, 0)` for a mirror; the unpolarised Fresnel reflectance and its
    /// complement for a dielectric (total internal reflection gives
    /// `(1, 0)`).
    pub fn weights(&self, d: glam::DVec3, n: glam::DVec3) -> (f64, f64) {
        match *self {
            SpecularMaterial::Mirror => (1.0, 0.0),
            SpecularMaterial::Dielectric { ior } => {
                let f = fresnel(d, n, ior);
                (f, 1.0 - f)
            }
        }
    }

    /// Ratio of indices `η = n_from / n_to` for a ray of unit direction `d`
    /// meeting a surface of outward unit normal `n`: entering (`d·n < 0`)
    /// `1/ior`, leaving `ior`; 1 for a mirror.
    pub fn eta(&self, d: glam::DVec3, n: glam::DVec3) -> f64 {
        match *self {
            SpecularMaterial::Mirror => 1.0,
            SpecularMaterial::Dielectric { ior } => {
                if d.dot(n) < 0.0 {
                    1.0 / ior
                } else {
                    ior
                }
            }
        }
    }

    /// The manifest token: `mirror` or the index of refraction.
    pub fn token(&self) -> String {
        match self {
            SpecularMaterial::Mirror => "mirror".into(),
            SpecularMaterial::Dielectric { ior } => ior.to_string(),
        }
    }
}

/// Unpolarised Fresnel reflectance of a dielectric of index `ior`
/// (outside 1) for a ray of unit direction `d` meeting outward unit normal
/// `n` from either side; 1 under total internal reflection.
pub fn fresnel(d: glam::DVec3, n: glam::DVec3, ior: f64) -> f64 {
    let cos_i = -d.dot(n);
    let (eta_i, eta_t, cos_i) = if cos_i >= 0.0 { (1.0, ior, cos_i) } else { (ior, 1.0, -cos_i) };
    let sin_t2 = (eta_i / eta_t).powi(2) * (1.0 - cos_i * cos_i).max(0.0);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    let rp = (eta_i * cos_t - eta_t * cos_i) / (eta_i * cos_t + eta_t * cos_i);
    (0.5 * (rs * rs + rp * rp)).clamp(0.0, 1.0)
}

/// Mirror reflection of direction `d` about unit normal `n` (GLSL `reflect`).
pub fn reflect(d: glam::DVec3, n: glam::DVec3) -> glam::DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` at unit normal `n` facing against `d`
/// (`d·n <= 0`) with index ratio `eta` (GLSL `refract`); `None` under total
/// internal reflection.
pub fn refract(d: glam::DVec3, n: glam::DVec3, eta: f64) -> Option<glam::DVec3> {
    let c = d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - c * c);
    if k < 0.0 { None } else { Some(eta * d - (eta * c + k.sqrt()) * n) }
}

/// The node of a ray tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Node {
    /// The root: what the camera ray sees, diffusely shaded.
    Diffuse = 0,
    /// The first mirror reflection.
    Reflect = 1,
    /// The first refraction.
    Refract = 2,
}

impl Node {
    /// Every node, in order (their index is their validity bit).
    pub const ALL: [Node; 3] = [Node::Diffuse, Node::Reflect, Node::Refract];

    /// Channel prefix in the layer image.
    pub fn name(self) -> &'static str {
        match self {
            Node::Diffuse => "diffuse",
            Node::Reflect => "reflect",
            Node::Refract => "refract",
        }
    }

    /// Bit of the `valid` channel.
    pub fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// A `layer` statement of the manifest: which reference, which image, and
/// what the kind needs to read it.
#[derive(Clone, Debug, PartialEq)]
pub enum LayerStatement {
    /// `kind=fragments image=PATH max=N`.
    Fragments {
        /// Image file, relative to the trace directory.
        image: PathBuf,
        /// Fragments stored per sample (1 to [`MAX_FRAGMENTS`]).
        max: u32,
    },
    /// `kind=raytree image=PATH materials=M1,M2,...`.
    RayTree {
        /// Image file, relative to the trace directory.
        image: PathBuf,
        /// Material table (index 1 is the first entry).
        materials: Vec<SpecularMaterial>,
    },
}

impl LayerStatement {
    /// The image it names.
    pub fn image(&self) -> &PathBuf {
        match self {
            LayerStatement::Fragments { image, .. } | LayerStatement::RayTree { image, .. } => image,
        }
    }

    /// The manifest's `kind=` value.
    pub fn kind(&self) -> &'static str {
        match self {
            LayerStatement::Fragments { .. } => LAYER_KINDS[0],
            LayerStatement::RayTree { .. } => LAYER_KINDS[1],
        }
    }

    /// The fields after `layer I` (as the writer prints them).
    pub fn fields(&self) -> String {
        match self {
            LayerStatement::Fragments { image, max } => {
                format!("kind=fragments image={} max={max}", image.display())
            }
            LayerStatement::RayTree { image, materials } => {
                let m: Vec<String> = materials.iter().map(SpecularMaterial::token).collect();
                format!("kind=raytree image={} materials={}", image.display(), m.join(","))
            }
        }
    }
}

/// The layers a reference frame declares (none in a v1 trace).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReferenceLayers {
    /// The transparent-fragment layer, if any.
    pub fragments: Option<LayerStatement>,
    /// The ray-tree layer, if any.
    pub raytree: Option<LayerStatement>,
}

impl ReferenceLayers {
    /// True if the reference declares no layer.
    pub fn is_empty(&self) -> bool {
        self.fragments.is_none() && self.raytree.is_none()
    }

    /// The declared layers, fragments first.
    pub fn iter(&self) -> impl Iterator<Item = &LayerStatement> {
        self.fragments.iter().chain(self.raytree.iter())
    }
}

/// Parse the fields of a `layer` statement (after its reference index).
pub(super) fn parse_layer_fields(f: &mut super::parse::Fields) -> Result<LayerStatement, String> {
    let kind = f.take("kind")?;
    let image = f.path("image")?;
    match kind.as_str() {
        "fragments" => {
            let max: u32 = f.num("max")?;
            if !(1..=MAX_FRAGMENTS).contains(&max) {
                return Err(format!("max = {max}; expected 1 to {MAX_FRAGMENTS} fragments per sample"));
            }
            Ok(LayerStatement::Fragments { image, max })
        }
        "raytree" => {
            let list = f.take("materials")?;
            let mut materials = Vec::new();
            for tok in list.split(',') {
                let m = match tok {
                    "mirror" => SpecularMaterial::Mirror,
                    t => match t.parse::<f64>() {
                        Ok(ior) if ior.is_finite() && ior > 0.0 => SpecularMaterial::Dielectric { ior },
                        _ => {
                            return Err(format!(
                                "materials: `{tok}` is neither `mirror` nor a positive index of refraction"
                            ));
                        }
                    },
                };
                materials.push(m);
            }
            if materials.len() > MAX_MATERIALS {
                return Err(format!("materials lists {} entries; at most {MAX_MATERIALS}", materials.len()));
            }
            Ok(LayerStatement::RayTree { image, materials })
        }
        other => Err(format!("unknown layer kind `{other}`; expected one of `{}`", LAYER_KINDS.join("`, `"))),
    }
}

/// One transparent fragment.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fragment {
    /// Linear RGB, not multiplied by the opacity.
    pub colour: [f32; 3],
    /// Opacity (0 = invisible, 1 = hides what is behind).
    pub alpha: f32,
    /// Depth along the reference camera's optical axis (scene units).
    pub z: f32,
}

/// A reference's transparent-fragment layer (`kind=fragments`), one entry
/// per sample of the reference image.
#[derive(Clone, Debug, PartialEq)]
pub struct FragmentLayer {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Fragments stored per sample (N).
    pub max: u32,
    /// Fragments of each sample (0 to N), the first `count` of its N slots.
    pub count: Vec<u8>,
    /// Colour of the opaque surface behind the fragments (the background
    /// colour where the ray hits none): the image the opaque warp takes.
    pub opaque: Vec<[f32; 3]>,
    /// N slots per sample (`i·N + k`), nearest first; slots past `count`
    /// hold zeros.
    pub fragments: Vec<Fragment>,
}

impl FragmentLayer {
    /// An empty layer (no fragment anywhere, opaque colour black).
    pub fn empty(width: u32, height: u32, max: u32) -> FragmentLayer {
        let n = width as usize * height as usize;
        FragmentLayer {
            width,
            height,
            max,
            count: vec![0; n],
            opaque: vec![[0.0; 3]; n],
            fragments: vec![Fragment::default(); n * max as usize],
        }
    }

    /// The fragments of sample `i`, nearest first.
    pub fn at(&self, i: usize) -> &[Fragment] {
        let n = self.max as usize;
        &self.fragments[i * n..i * n + self.count[i] as usize]
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.count.len()
    }

    /// True if the layer has no sample.
    pub fn is_empty(&self) -> bool {
        self.count.is_empty()
    }
}

/// One node image of a ray tree.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeImage {
    /// Linear RGB radiance, tint included, Fresnel not.
    pub colour: Vec<[f32; 3]>,
    /// Depth (scene units): the root's along the optical axis, a child's
    /// from the parent's hit along the child ray; 0 where the node is not
    /// valid.
    pub depth: Vec<f32>,
}

/// A reference's ray-tree layer (`kind=raytree`).
#[derive(Clone, Debug, PartialEq)]
pub struct RayTreeLayer {
    /// Width (samples).
    pub width: u32,
    /// Height (samples).
    pub height: u32,
    /// Material table; sample material `k >= 1` is `materials[k − 1]`.
    pub materials: Vec<SpecularMaterial>,
    /// Node images, indexed by [`Node`].
    pub nodes: [NodeImage; 3],
    /// Validity bits per sample ([`Node::bit`]).
    pub valid: Vec<u8>,
    /// Material index per sample (0 = no specular material).
    pub material: Vec<u8>,
}

impl RayTreeLayer {
    /// An empty layer (no valid node anywhere).
    pub fn empty(width: u32, height: u32, materials: Vec<SpecularMaterial>) -> RayTreeLayer {
        let n = width as usize * height as usize;
        let node = || NodeImage { colour: vec![[0.0; 3]; n], depth: vec![0.0; n] };
        RayTreeLayer {
            width,
            height,
            materials,
            nodes: [node(), node(), node()],
            valid: vec![0; n],
            material: vec![0; n],
        }
    }

    /// True if `node` is valid at sample `i`.
    pub fn has(&self, i: usize, node: Node) -> bool {
        self.valid[i] & node.bit() != 0
    }

    /// The material of sample `i`, if it has one.
    pub fn material_at(&self, i: usize) -> Option<SpecularMaterial> {
        let k = self.material[i] as usize;
        (k > 0).then(|| self.materials[k - 1])
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.valid.len()
    }

    /// True if the layer has no sample.
    pub fn is_empty(&self) -> bool {
        self.valid.is_empty()
    }
}

/// The loaded layers of one reference frame (both `None` for a v1 trace).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layers {
    /// Transparent fragments.
    pub fragments: Option<FragmentLayer>,
    /// Ray tree.
    pub raytree: Option<RayTreeLayer>,
}

pub use super::exr_io::{read_fragment_layer, read_ray_tree_layer, write_fragment_layer, write_ray_tree_layer};

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn fresnel_of_glass_at_normal_incidence_and_grazing() {
        let n = DVec3::Z;
        let f0 = fresnel(-DVec3::Z, n, 1.5);
        assert!((f0 - 0.04).abs() < 1e-12, "{f0}");
        // From inside at normal incidence: the same 4 %.
        assert!((fresnel(DVec3::Z, n, 1.5) - 0.04).abs() < 1e-12);
        let grazing = fresnel(DVec3::new(1.0, 0.0, -1e-4).normalize(), n, 1.5);
        assert!(grazing > 0.99, "{grazing}");
        // Past the critical angle (41.8 deg) inside glass: total reflection.
        let d = DVec3::new(0.8, 0.0, 0.6); // 53 deg from the normal, leaving
        assert_eq!(fresnel(d, n, 1.5), 1.0);
        let m = SpecularMaterial::Dielectric { ior: 1.5 };
        let (r, t) = m.weights(-DVec3::Z, n);
        assert!((r + t - 1.0).abs() < 1e-15);
        assert_eq!(SpecularMaterial::Mirror.weights(-DVec3::Z, n), (1.0, 0.0));
    }

    #[test]
    fn refraction_follows_snell_and_reflection_mirrors() {
        let n = DVec3::Z;
        let d = DVec3::new(0.6, 0.0, -0.8);
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-12);
        let sin_i = 0.6;
        let sin_t = t.x;
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-12, "{sin_i} vs {sin_t}");
        assert_eq!(reflect(d, n), DVec3::new(0.6, 0.0, 0.8));
        assert!(refract(DVec3::new(0.8, 0.0, -0.6), n, 1.5).is_none(), "total internal reflection");
    }
}
