//! The deterministic CPU scene renderer that makes synthetic traces.
//!
//! A [`Scene`] is loaded from a TOML description (a built-in one, embedded
//! from `scenes/`, or a user file; format in `docs/scene-format.md`) and
//! rendered by casting one ray per super-sample ([`Scene::render`]). For
//! every sample it yields linear RGB colour, depth `Z` along the optical
//! axis, the exact screen-space slopes of 1/Z from the tangent plane at the
//! hit, the object id (1-based position in the scene file) and whether a
//! surface was hit. It also carries the camera paths the trace generator
//! follows through the scene ([`SplineSpec`], [`TrackedSpec`]).
//!
//! Rules: world units are metres, y is up; intersection in `f64`; the
//! result depends only on the scene and the camera (same bytes for any
//! thread count); user input never causes a panic, only a [`SceneError`].
//!
//! Materials may also be semi-transparent (thin fragments composited front
//! to back), mirrors (with a tint) and refractors (index of refraction,
//! tint, Fresnel weights), with a bounded ray depth ([`Scene::render_layers`]
//! also returns the transparent fragments, the ray tree and the mask of
//! non-diffuse samples that a v2 trace stores).
//!
//! Not modelled: shadows, glossy or any view-dependent light other than
//! mirror reflection and refraction, lights other than one directional
//! light plus ambient, motion within a frame. Files: `description`
//! (format), `geometry` (analytic shapes), `mesh` (OBJ meshes), `bvh`,
//! `texture` (textures and optics), `world` (objects and the nearest-hit
//! query), `render` (primary rays and layers), `shade` (surface radiance,
//! fragments, secondary rays), `builtin` (embedded scenes and models).

mod builtin;
mod bvh;
pub(crate) mod description;
pub(crate) mod geometry;
pub(crate) mod mesh;
mod render;
mod shade;
mod texture;
mod world;

use glam::DVec3;
use serde::{Deserialize, Deserializer};
use std::fmt;
use std::path::Path;

/// A camera waypoint: where the camera is and what it looks at (world,
/// metres; the camera's up is world +y).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Waypoint {
    /// Centre of projection.
    #[serde(deserialize_with = "de_vec3")]
    pub position: DVec3,
    /// Point on the optical axis.
    #[serde(deserialize_with = "de_vec3")]
    pub look_at: DVec3,
}

fn de_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<DVec3, D::Error> {
    <[f64; 3]>::deserialize(d).map(DVec3::from)
}

/// The camera path for `--path spline`: a Catmull-Rom spline through the
/// waypoints, travelled in `duration_s` seconds. At least 2 waypoints.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SplineSpec {
    /// Waypoints in order (>= 2).
    pub waypoints: Vec<Waypoint>,
    /// Time to travel the whole path (seconds, > 0).
    pub duration_s: f64,
}

/// Where a recorded head trajectory (relative motion) is placed: its first
/// pose maps to `start`, and its translations are multiplied by `scale`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackedSpec {
    /// Pose the recorded trajectory starts from.
    pub start: Waypoint,
    /// Factor on the recorded translations (> 0).
    pub scale: f64,
}

/// Why a scene could not be loaded. The message names the scene (file path
/// or `builtin:<name>`) and, where it applies, the line, object or key and
/// what was expected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    origin: String,
    message: String,
}

impl SceneError {
    fn new(origin: &str, message: impl Into<String>) -> SceneError {
        SceneError { origin: origin.to_string(), message: message.into() }
    }

    /// The scene the error is about (file path or `builtin:<name>`).
    pub fn origin(&self) -> &str {
        &self.origin
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.message.contains('\n') {
            // Multi-line TOML diagnostics read better starting on their own line.
            write!(f, "{}:\n{}", self.origin, self.message)
        } else {
            write!(f, "{}: {}", self.origin, self.message)
        }
    }
}

impl std::error::Error for SceneError {}

/// A loaded, renderable scene (cheap to clone: meshes are shared).
#[derive(Clone)]
pub struct Scene {
    /// Short name (`name` key, else the file stem).
    pub name: String,
    /// One-paragraph description.
    pub description: String,
    /// Camera path for `--path spline`.
    pub spline: SplineSpec,
    /// Placement of recorded trajectories for `--path tracked`.
    pub tracked: TrackedSpec,
    background: [f32; 3],
    /// Unit vector toward the light.
    to_light: DVec3,
    ambient: f32,
    world: world::World,
    /// Objects written as `kind = "rod"` (indices into `world.objects`).
    rods: Vec<usize>,
    /// Specular bounces a ray may take.
    ray_depth: u32,
    /// The ray-tree material table (specular materials, deduplicated, in
    /// material order) and each world material's 1-based index in it (0:
    /// not specular).
    specular_table: (Vec<crate::trace::layers::SpecularMaterial>, Vec<u8>),
}

/// A render with everything a v2 trace stores ([`Scene::render_layers`]).
pub struct Rendered {
    /// The reference image: composited colour; depth, slopes and id of the
    /// first surface that is not semi-transparent.
    pub samples: postwarp_rtl::SampleImage,
    /// Transparent fragments (scenes with a semi-transparent material).
    pub fragments: Option<crate::trace::layers::FragmentLayer>,
    /// The ray tree (scenes with a mirror or refracting material).
    pub raytree: Option<crate::trace::layers::RayTreeLayer>,
    /// Per sample: the ray met a semi-transparent fragment, or its first
    /// other surface reflects or refracts.
    pub nondiffuse: bitvec::vec::BitVec,
}

/// The ray-tree material table of the materials some object uses, in
/// material order, deduplicated; and each material's 1-based index in it.
fn specular_table(world: &world::World) -> (Vec<crate::trace::layers::SpecularMaterial>, Vec<u8>) {
    let mut table = Vec::new();
    let used: Vec<bool> = (0..world.materials.len()).map(|m| world.objects.iter().any(|o| o.material == m)).collect();
    let index = world
        .materials
        .iter()
        .zip(used)
        .map(|(m, used)| match m.optics.specular_material().filter(|_| used) {
            None => 0,
            Some(s) => match table.iter().position(|t| *t == s) {
                Some(k) => k as u8 + 1,
                None => {
                    table.push(s);
                    table.len() as u8
                }
            },
        })
        .collect();
    (table, index)
}

impl fmt::Debug for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scene")
            .field("name", &self.name)
            .field("objects", &self.world.objects.len())
            .field("materials", &self.world.materials.len())
            .field("spline", &self.spline)
            .field("tracked", &self.tracked)
            .finish_non_exhaustive()
    }
}

impl Scene {
    /// Names of the built-in scenes.
    pub fn builtin_names() -> &'static [&'static str] {
        &builtin::SCENE_NAMES
    }

    /// The TOML text of a built-in scene (what `scenes/<name>.toml` holds).
    pub fn builtin_source(name: &str) -> Option<&'static str> {
        builtin::SCENES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
    }

    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        match Scene::builtin_source(name) {
            Some(text) => Scene::from_toml_str(text, None, &format!("builtin:{name}")),
            None => Err(SceneError::new(
                name,
                format!("no built-in scene of that name (built-in scenes: {})", builtin::SCENE_NAMES.join(", ")),
            )),
        }
    }

    /// Load a scene description file; relative model paths are resolved
    /// against its directory.
    pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
        let origin = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError::new(&origin, format!("cannot read scene file: {e}")))?;
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Scene::from_toml_str(&text, Some(dir), &origin)
    }

    /// A built-in scene if `name_or_path` is one of [`Scene::builtin_names`],
    /// else a scene file.
    pub fn load(name_or_path: &str) -> Result<Scene, SceneError> {
        if builtin::SCENE_NAMES.contains(&name_or_path) {
            return Scene::builtin(name_or_path);
        }
        let path = Path::new(name_or_path);
        if !path.exists() && path.extension().is_none() && !name_or_path.contains(['/', '\\']) {
            return Err(SceneError::new(
                name_or_path,
                format!("neither a built-in scene ({}) nor an existing scene file", builtin::SCENE_NAMES.join(", ")),
            ));
        }
        Scene::from_file(path)
    }

    /// Parse a scene description. `base_dir` resolves relative model and
    /// texture paths (the current directory if `None`); `origin` names the
    /// scene in error messages.
    pub fn from_toml_str(text: &str, base_dir: Option<&Path>, origin: &str) -> Result<Scene, SceneError> {
        let c = description::compile(text, base_dir, origin)?;
        let specular_table = specular_table(&c.world);
        if specular_table.0.len() > crate::trace::layers::MAX_MATERIALS {
            return Err(SceneError::new(
                origin,
                format!(
                    "{} different specular materials; a ray tree holds at most {}",
                    specular_table.0.len(),
                    crate::trace::layers::MAX_MATERIALS
                ),
            ));
        }
        Ok(Scene {
            ray_depth: c.ray_depth,
            specular_table,
            name: c.name,
            description: c.description,
            spline: c.spline,
            tracked: c.tracked,
            background: c.background,
            to_light: c.to_light,
            ambient: c.ambient,
            world: c.world,
            rods: c.rods,
        })
    }

    /// Number of `rod` objects (the scene's thin features).
    pub fn rod_count(&self) -> usize {
        self.rods.len()
    }

    /// True if object `id` (as in [`postwarp_rtl::SampleImage::object_id`],
    /// index + 1) was written as a `rod`.
    pub fn is_rod(&self, id: u32) -> bool {
        id > 0 && self.rods.binary_search(&(id as usize - 1)).is_ok()
    }

    /// Radii of the `rod` objects (scene units), in file order.
    pub fn rod_radii(&self) -> Vec<f64> {
        self.rod_cylinders().map(|c| c.radius()).collect()
    }

    /// Mean of the `rod` objects' mid-points (scene units; the origin if
    /// there is none): the centre about which `rod_scale` scales them.
    pub fn rod_centre(&self) -> DVec3 {
        let mids: Vec<DVec3> = self.rod_cylinders().map(|c| c.mid_point()).collect();
        mids.iter().sum::<DVec3>() / mids.len().max(1) as f64
    }

    fn rod_cylinders(&self) -> impl Iterator<Item = &geometry::Cylinder> {
        self.rods.iter().filter_map(|&i| match &self.world.objects[i].shape {
            world::Shape::Cylinder(c) => Some(c),
            _ => None,
        })
    }

    /// This scene with its `rod` objects (the thin features) changed by two
    /// stress factors (both > 0; 1 leaves them): `radius_scale` multiplies
    /// each rod's radius alone; `scale` then scales every rod — ends,
    /// length and radius — about the mean of the rods' mid-points, so a
    /// flat arrangement of rods keeps the fraction of the view it covers
    /// while each rod gets thinner or wider. Other objects, ids and
    /// materials are unchanged; the BVH is rebuilt.
    pub fn with_rods_scaled(&self, radius_scale: f64, scale: f64) -> Scene {
        let centre = self.rod_centre();
        let mut objects = self.world.objects.clone();
        for &i in &self.rods {
            if let world::Shape::Cylinder(c) = &objects[i].shape {
                objects[i].shape =
                    world::Shape::Cylinder(c.with_radius_scaled(radius_scale).scaled_about(centre, scale));
            }
        }
        Scene {
            name: self.name.clone(),
            description: self.description.clone(),
            spline: self.spline.clone(),
            tracked: self.tracked.clone(),
            background: self.background,
            to_light: self.to_light,
            ambient: self.ambient,
            world: world::World::new(self.world.materials.clone(), objects),
            rods: self.rods.clone(),
            ray_depth: self.ray_depth,
            specular_table: self.specular_table.clone(),
        }
    }

    /// True if object `i` (index, id − 1) has a semi-transparent or
    /// specular material.
    fn is_nondiffuse_object(&self, i: usize) -> bool {
        let o = &self.world.materials[self.world.objects[i].material].optics;
        o.is_transparent() || o.is_specular()
    }

    /// Number of objects with a semi-transparent, mirror or refracting
    /// material.
    pub fn nondiffuse_count(&self) -> usize {
        (0..self.world.objects.len()).filter(|&i| self.is_nondiffuse_object(i)).count()
    }

    /// True if some object's material is semi-transparent (a v2 trace of
    /// the scene has fragment layers).
    pub fn has_transparency(&self) -> bool {
        self.world.objects.iter().any(|o| self.world.materials[o.material].optics.is_transparent())
    }

    /// True if some object's material reflects or refracts (a v2 trace of
    /// the scene has ray-tree layers).
    pub fn has_specular(&self) -> bool {
        self.world.objects.iter().any(|o| self.world.materials[o.material].optics.is_specular())
    }

    /// This scene with every object of a semi-transparent, mirror or
    /// refracting material scaled by `factor` (> 0; 1 leaves them) about
    /// the middle of the bottom of its bounding box, so that what stands on
    /// the floor stays on it and a pane or a mirror stays in its plane: the
    /// stress knob of the non-diffuse share of the view. Meshes and
    /// unbounded planes keep their size; other objects, ids and materials
    /// are unchanged; the BVH is rebuilt.
    pub fn with_nondiffuse_scaled(&self, factor: f64) -> Scene {
        let mut objects = self.world.objects.clone();
        for (i, o) in objects.iter_mut().enumerate() {
            if self.is_nondiffuse_object(i) {
                o.shape = o.shape.scaled_about_base(factor);
            }
        }
        Scene {
            name: self.name.clone(),
            description: self.description.clone(),
            spline: self.spline.clone(),
            tracked: self.tracked.clone(),
            background: self.background,
            to_light: self.to_light,
            ambient: self.ambient,
            world: world::World::new(self.world.materials.clone(), objects),
            rods: self.rods.clone(),
            ray_depth: self.ray_depth,
            specular_table: self.specular_table.clone(),
        }
    }

    /// Specular bounces a ray may take (`ray_depth`).
    pub fn ray_depth(&self) -> u32 {
        self.ray_depth
    }

    /// The ray-tree material table of the scene (what a v2 trace's
    /// `materials=` lists).
    pub fn specular_materials(&self) -> &[crate::trace::layers::SpecularMaterial] {
        &self.specular_table.0
    }

    /// Number of objects (object ids run from 1 to this).
    pub fn object_count(&self) -> usize {
        self.world.objects.len()
    }

    /// Colour of rays that hit nothing (linear RGB).
    pub fn background(&self) -> [f32; 3] {
        self.background
    }

    /// Render `camera` (in pixels) at `ss x ss` samples per pixel: result is
    /// `width·ss x height·ss` samples (empty if `ss` is 0).
    pub fn render(&self, camera: &postwarp_rtl::Camera, ss: u32) -> postwarp_rtl::SampleImage {
        render::render(self, camera, ss, 1).samples
    }

    /// [`Scene::render`] with the v2 layers: up to `max_fragments` (1 to
    /// [`crate::trace::layers::MAX_FRAGMENTS`]) transparent fragments per
    /// sample if the scene has semi-transparent materials, the ray tree if
    /// it has specular ones, and the non-diffuse mask.
    pub fn render_layers(&self, camera: &postwarp_rtl::Camera, ss: u32, max_fragments: u32) -> Rendered {
        render::render(self, camera, ss, max_fragments)
    }
}
