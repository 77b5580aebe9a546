//! The scene description format (TOML) and its translation into a
//! renderable [`World`]. The format is documented key by key in
//! `docs/scene-format.md`; keep the two in step.
//!
//! Rules:
//! - unknown keys are errors everywhere (`deny_unknown_fields`), so a typo
//!   never silently falls back to a default;
//! - every number is checked (finite; radii, sizes, cells and periods > 0;
//!   axis vectors non-zero; colours in [0, 1]) and every error names the
//!   scene (file path or built-in name), the line and the object or
//!   material it is about;
//! - model and image paths are `bundled:<file>` (embedded in the binary) or
//!   relative to the scene file's directory (the current directory for text
//!   given without one);
//! - nothing here panics on user input.
//!
//! Not modelled: includes of other scene files, variables, per-object
//! transforms beyond what each kind documents, animation.

use super::SceneError;
use super::builtin;
use super::geometry::{Cuboid, Cylinder, Plane, Sphere};
use super::mesh::{MeshData, MeshInstance};
use super::texture::{Image, Material, Optics, Texture};
use super::world::{Object, Shape, World};
use super::{SplineSpec, TrackedSpec, Waypoint};
use glam::DVec3;
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use toml::Spanned;

type V3 = [f64; 3];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    #[serde(default)]
    description: String,
    background: Option<V3>,
    light: Option<Spanned<LightDesc>>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<MaterialDesc>>,
    #[serde(default)]
    objects: Vec<Spanned<ObjectDesc>>,
    spline: Spanned<SplineSpec>,
    tracked: Option<Spanned<TrackedSpec>>,
    ray_depth: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDesc {
    direction: Option<V3>,
    ambient: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDesc {
    colour: V3,
    texture: Option<TextureDesc>,
    opacity: Option<f64>,
    reflect: Option<V3>,
    refract: Option<V3>,
    ior: Option<f64>,
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
enum TextureDesc {
    Checker { cell: f64, colour: V3 },
    Stripes { period: f64, axis: V3, colour: V3 },
    Noise { scale: f64, amplitude: f64, octaves: Option<u32> },
    Image { file: String },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Kind {
    Plane,
    Box,
    Sphere,
    Cylinder,
    Rod,
    Mesh,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Plane => "plane",
            Kind::Box => "box",
            Kind::Sphere => "sphere",
            Kind::Cylinder => "cylinder",
            Kind::Rod => "rod",
            Kind::Mesh => "mesh",
        }
    }

    /// (required keys, optional keys) besides `kind`, `name`, `material`.
    fn keys(self) -> (&'static [&'static str], &'static [&'static str]) {
        match self {
            Kind::Plane => (&["centre"], &["half_u", "half_v", "normal"]),
            Kind::Box => (&["centre", "half_size"], &["yaw_deg"]),
            Kind::Sphere => (&["centre", "radius"], &[]),
            Kind::Cylinder => (&["base", "axis", "radius", "height"], &[]),
            Kind::Rod => (&["from", "to", "radius"], &[]),
            Kind::Mesh => (&["file", "size", "position"], &["rotate_deg"]),
        }
    }
}

/// One `[[objects]]` table. A flat struct (not a tagged enum) so that TOML
/// type errors point at the offending key; which keys a kind takes is
/// checked in [`ObjectDesc::check_keys`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDesc {
    kind: Kind,
    name: Option<String>,
    material: Option<String>,
    centre: Option<V3>,
    half_u: Option<V3>,
    half_v: Option<V3>,
    normal: Option<V3>,
    half_size: Option<V3>,
    yaw_deg: Option<f64>,
    radius: Option<f64>,
    base: Option<V3>,
    axis: Option<V3>,
    height: Option<f64>,
    from: Option<V3>,
    to: Option<V3>,
    file: Option<String>,
    size: Option<f64>,
    rotate_deg: Option<V3>,
    position: Option<V3>,
}

impl ObjectDesc {
    fn present(&self) -> Vec<&'static str> {
        let v3 = [
            ("centre", &self.centre),
            ("half_u", &self.half_u),
            ("half_v", &self.half_v),
            ("normal", &self.normal),
            ("half_size", &self.half_size),
            ("base", &self.base),
            ("axis", &self.axis),
            ("from", &self.from),
            ("to", &self.to),
            ("rotate_deg", &self.rotate_deg),
            ("position", &self.position),
        ];
        let f = [("yaw_deg", &self.yaw_deg), ("radius", &self.radius), ("height", &self.height), ("size", &self.size)];
        let mut keys: Vec<&'static str> = v3.iter().filter(|(_, v)| v.is_some()).map(|(k, _)| *k).collect();
        keys.extend(f.iter().filter(|(_, v)| v.is_some()).map(|(k, _)| *k));
        if self.file.is_some() {
            keys.push("file");
        }
        keys
    }

    fn check_keys(&self) -> Result<(), String> {
        let (required, optional) = self.kind.keys();
        let all: Vec<&str> = required.iter().chain(optional).copied().collect();
        for key in self.present() {
            if !all.contains(&key) {
                return Err(format!(
                    "`{key}` is not a key of a {} object (its keys: {}, name, material)",
                    self.kind.name(),
                    all.join(", ")
                ));
            }
        }
        let present = self.present();
        if let Some(missing) = required.iter().find(|k| !present.contains(k)) {
            return Err(format!("missing `{missing}` (a {} object needs: {})", self.kind.name(), required.join(", ")));
        }
        Ok(())
    }
}

/// A required key (presence checked by [`ObjectDesc::check_keys`]).
fn req<T: Copy>(v: Option<T>, key: &str) -> Result<T, String> {
    v.ok_or_else(|| format!("missing `{key}`"))
}

/// Default light: from above, a little from +x and +z (towards the light).
pub const DEFAULT_LIGHT_DIRECTION: [f64; 3] = [0.35, 1.0, 0.25];
/// Default ambient fraction.
pub const DEFAULT_AMBIENT: f64 = 0.3;
/// Colour of objects without a `material`.
pub const DEFAULT_COLOUR: [f32; 3] = [0.7, 0.7, 0.7];
/// Default `ray_depth`: specular bounces a ray may take.
pub const DEFAULT_RAY_DEPTH: u32 = 4;
/// Largest `ray_depth`.
pub const MAX_RAY_DEPTH: u32 = 16;

/// Everything a [`super::Scene`] holds, checked.
pub struct Compiled {
    pub name: String,
    pub description: String,
    pub background: [f32; 3],
    pub to_light: DVec3,
    pub ambient: f32,
    pub world: World,
    pub spline: SplineSpec,
    pub tracked: TrackedSpec,
    /// Indices into `world.objects` of the objects written as `kind = "rod"`
    /// (the scene's thin features), in file order.
    pub rods: Vec<usize>,
    /// Specular bounces a ray may take (`ray_depth`).
    pub ray_depth: u32,
}

struct Ctx<'a> {
    text: &'a str,
    origin: &'a str,
    base_dir: Option<&'a Path>,
    /// False: only `bundled:` models and textures (no file is read).
    files_allowed: bool,
    mesh_cache: HashMap<PathBuf, Arc<MeshData>>,
    image_cache: HashMap<PathBuf, Arc<Image>>,
}

impl Ctx<'_> {
    fn line(&self, span: std::ops::Range<usize>) -> usize {
        self.text.get(..span.start).map_or(0, |s| s.matches('\n').count()) + 1
    }

    fn err(&self, span: std::ops::Range<usize>, what: &str, msg: impl std::fmt::Display) -> SceneError {
        SceneError::new(self.origin, format!("line {}: {what}: {msg}", self.line(span)))
    }

    fn resolve(&self, file: &str) -> Result<Source, String> {
        if let Some(name) = file.strip_prefix("bundled:") {
            return Ok(Source::Bundled(name.to_string()));
        }
        if file.is_empty() {
            return Err("empty file name".into());
        }
        if !self.files_allowed {
            return Err(format!("`{file}`: only `bundled:` models and textures may be named here"));
        }
        let p = Path::new(file);
        Ok(Source::File(match self.base_dir {
            Some(dir) if p.is_relative() => dir.join(p),
            _ => p.to_path_buf(),
        }))
    }

    fn mesh(&mut self, file: &str) -> Result<Arc<MeshData>, String> {
        match self.resolve(file)? {
            Source::Bundled(name) => builtin::bundled_mesh(&name),
            Source::File(path) => {
                if let Some(m) = self.mesh_cache.get(&path) {
                    return Ok(m.clone());
                }
                let bytes =
                    std::fs::read(&path).map_err(|e| format!("cannot read model file {}: {e}", path.display()))?;
                let data = Arc::new(MeshData::from_obj_bytes(&bytes).map_err(|e| format!("{}: {e}", path.display()))?);
                self.mesh_cache.insert(path, data.clone());
                Ok(data)
            }
        }
    }

    fn image(&mut self, file: &str) -> Result<Arc<Image>, String> {
        match self.resolve(file)? {
            Source::Bundled(name) => builtin::bundled_image(&name),
            Source::File(path) => {
                if let Some(m) = self.image_cache.get(&path) {
                    return Ok(m.clone());
                }
                let bytes =
                    std::fs::read(&path).map_err(|e| format!("cannot read texture file {}: {e}", path.display()))?;
                let img = Arc::new(Image::decode(&bytes).map_err(|e| format!("{}: {e}", path.display()))?);
                self.image_cache.insert(path, img.clone());
                Ok(img)
            }
        }
    }
}

enum Source {
    Bundled(String),
    File(PathBuf),
}

fn finite(v: V3, key: &str) -> Result<DVec3, String> {
    let d = DVec3::from(v);
    if d.is_finite() { Ok(d) } else { Err(format!("`{key}` must be finite, got {v:?}")) }
}

fn nonzero(v: V3, key: &str) -> Result<DVec3, String> {
    let d = finite(v, key)?;
    if d.length_squared() > 0.0 { Ok(d) } else { Err(format!("`{key}` must be a non-zero vector")) }
}

fn positive(x: f64, key: &str) -> Result<f64, String> {
    if x.is_finite() && x > 0.0 { Ok(x) } else { Err(format!("`{key}` must be > 0, got {x}")) }
}

fn colour(v: V3, key: &str) -> Result<[f32; 3], String> {
    if v.iter().all(|c| (0.0..=1.0).contains(c)) {
        Ok(v.map(|c| c as f32))
    } else {
        Err(format!("`{key}` must be linear RGB with each channel in [0, 1], got {v:?}"))
    }
}

fn check_waypoint(w: &Waypoint, key: &str) -> Result<(), String> {
    if !w.position.is_finite() || !w.look_at.is_finite() {
        return Err(format!("{key}: position and look_at must be finite"));
    }
    let d = w.look_at - w.position;
    if d.length_squared() == 0.0 {
        return Err(format!("{key}: look_at must differ from position"));
    }
    if d.normalize().y.abs() > 0.999 {
        return Err(format!("{key}: the view direction must not be (nearly) vertical (y is up)"));
    }
    Ok(())
}

/// Parse and check a scene description.
pub fn compile(text: &str, base_dir: Option<&Path>, origin: &str) -> Result<Compiled, SceneError> {
    compile_in(text, base_dir, true, origin)
}

/// [`compile`], but reading no file: a model or texture other than
/// `bundled:` is an error. For untrusted text (the fuzz targets).
pub fn compile_bundled_only(text: &str, origin: &str) -> Result<Compiled, SceneError> {
    compile_in(text, None, false, origin)
}

fn compile_in(text: &str, base_dir: Option<&Path>, files_allowed: bool, origin: &str) -> Result<Compiled, SceneError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneError::new(origin, e.to_string().trim_end()))?;
    let mut ctx =
        Ctx { text, origin, base_dir, files_allowed, mesh_cache: HashMap::new(), image_cache: HashMap::new() };

    let background = match file.background {
        None => [0.0; 3],
        Some(b) => colour(b, "background").map_err(|e| SceneError::new(origin, e))?,
    };
    let (to_light, ambient) = match &file.light {
        None => (DVec3::from(DEFAULT_LIGHT_DIRECTION).normalize(), DEFAULT_AMBIENT),
        Some(l) => {
            let span = l.span();
            let l = l.get_ref();
            let dir = nonzero(l.direction.unwrap_or(DEFAULT_LIGHT_DIRECTION), "direction")
                .map_err(|e| ctx.err(span.clone(), "[light]", e))?;
            let ambient = l.ambient.unwrap_or(DEFAULT_AMBIENT);
            if !(0.0..=1.0).contains(&ambient) {
                return Err(ctx.err(span, "[light]", format!("`ambient` must be in [0, 1], got {ambient}")));
            }
            (dir.normalize(), ambient)
        }
    };

    // Materials, by name; index 0 is the default grey.
    let mut materials = vec![Material { colour: DEFAULT_COLOUR, texture: None, optics: Default::default() }];
    let mut material_index: HashMap<&str, usize> = HashMap::new();
    let mut material_needs_uv: Vec<bool> = vec![false];
    for (name, m) in &file.materials {
        let span = m.span();
        let what = format!("material `{name}`");
        let m = m.get_ref();
        let base = colour(m.colour, "colour").map_err(|e| ctx.err(span.clone(), &what, e))?;
        let texture = match &m.texture {
            None => None,
            Some(t) => Some(texture(&mut ctx, t).map_err(|e| ctx.err(span.clone(), &what, format!("texture: {e}")))?),
        };
        let optics = optics(m).map_err(|e| ctx.err(span.clone(), &what, e))?;
        material_needs_uv.push(matches!(texture, Some(Texture::Image(_))));
        material_index.insert(name.as_str(), materials.len());
        materials.push(Material { colour: base, texture, optics });
    }

    let mut objects = Vec::with_capacity(file.objects.len());
    let mut rods = Vec::new();
    for (i, o) in file.objects.iter().enumerate() {
        let span = o.span();
        let o = o.get_ref();
        let what = match &o.name {
            Some(n) => format!("objects[{i}] ({} `{n}`)", o.kind.name()),
            None => format!("objects[{i}] ({})", o.kind.name()),
        };
        o.check_keys().map_err(|e| ctx.err(span.clone(), &what, e))?;
        let material = match o.material.as_deref() {
            None => 0,
            Some(m) => *material_index.get(m).ok_or_else(|| {
                let known: Vec<&str> = file.materials.keys().map(String::as_str).collect();
                ctx.err(span.clone(), &what, format!("unknown material `{m}` (defined: {})", list(&known)))
            })?,
        };
        let shape = shape(&mut ctx, o).map_err(|e| ctx.err(span.clone(), &what, e))?;
        if material_needs_uv[material] && !shape.has_uv() {
            return Err(ctx.err(
                span,
                &what,
                "its material has an image texture, which needs texture coordinates \
                 (a mesh with UVs or a finite plane)",
            ));
        }
        if matches!(o.kind, Kind::Rod) {
            rods.push(objects.len());
        }
        objects.push(Object { shape, material });
    }

    let spline_span = file.spline.span();
    let spline = file.spline.into_inner();
    if spline.waypoints.len() < 2 {
        return Err(ctx.err(
            spline_span,
            "[spline]",
            format!("needs at least 2 waypoints ([[spline.waypoints]]), got {}", spline.waypoints.len()),
        ));
    }
    for (i, w) in spline.waypoints.iter().enumerate() {
        check_waypoint(w, &format!("waypoints[{i}]")).map_err(|e| ctx.err(spline_span.clone(), "[spline]", e))?;
    }
    positive(spline.duration_s, "duration_s").map_err(|e| ctx.err(spline_span.clone(), "[spline]", e))?;

    let tracked = match file.tracked {
        None => TrackedSpec { start: spline.waypoints[0].clone(), scale: 1.0 },
        Some(t) => {
            let span = t.span();
            let t = t.into_inner();
            check_waypoint(&t.start, "start").map_err(|e| ctx.err(span.clone(), "[tracked]", e))?;
            positive(t.scale, "scale").map_err(|e| ctx.err(span, "[tracked]", e))?;
            t
        }
    };

    let ray_depth = file.ray_depth.unwrap_or(DEFAULT_RAY_DEPTH);
    if !(1..=MAX_RAY_DEPTH).contains(&ray_depth) {
        return Err(SceneError::new(
            origin,
            format!("`ray_depth` must be 1 to {MAX_RAY_DEPTH} specular bounces, got {ray_depth}"),
        ));
    }
    let name = file.name.unwrap_or_else(|| {
        Path::new(origin).file_stem().map_or_else(|| origin.to_string(), |s| s.to_string_lossy().into_owned())
    });
    Ok(Compiled {
        name,
        description: file.description,
        background,
        to_light,
        ambient: ambient as f32,
        world: World::new(materials, objects),
        spline,
        tracked,
        rods,
        ray_depth,
    })
}

/// The optics keys of a material, checked: `opacity` in [0, 1] and, below
/// 1, none of the specular keys (a semi-transparent fragment is thin and
/// does not refract); `reflect` and `refract` tints in [0, 1]; `refract`
/// needs `ior`; `ior` finite and > 0.
fn optics(m: &MaterialDesc) -> Result<Optics, String> {
    let opacity = m.opacity.unwrap_or(1.0);
    if !(0.0..=1.0).contains(&opacity) {
        return Err(format!("`opacity` must be in [0, 1], got {opacity}"));
    }
    let reflect = m.reflect.map(|c| colour(c, "reflect")).transpose()?;
    let refract = m.refract.map(|c| colour(c, "refract")).transpose()?;
    let ior = m.ior.map(|x| positive(x, "ior")).transpose()?;
    if opacity < 1.0 && (reflect.is_some() || refract.is_some() || ior.is_some()) {
        return Err("a semi-transparent material (`opacity` < 1) takes no `reflect`, `refract` or `ior`: \
                    its fragments are thin and composited as they are"
            .into());
    }
    if refract.is_some() && ior.is_none() {
        return Err("`refract` needs `ior` (the index of refraction inside the surface)".into());
    }
    Ok(Optics { opacity: opacity as f32, reflect, refract, ior })
}

fn list(items: &[&str]) -> String {
    if items.is_empty() { "none".into() } else { items.join(", ") }
}

fn texture(ctx: &mut Ctx, t: &TextureDesc) -> Result<Texture, String> {
    Ok(match t {
        TextureDesc::Checker { cell, colour: c } => {
            Texture::Checker { cell: positive(*cell, "cell")?, other: colour(*c, "colour")? }
        }
        TextureDesc::Stripes { period, axis, colour: c } => Texture::Stripes {
            period: positive(*period, "period")?,
            axis: nonzero(*axis, "axis")?.normalize(),
            other: colour(*c, "colour")?,
        },
        TextureDesc::Noise { scale, amplitude, octaves } => {
            let octaves = octaves.unwrap_or(3);
            if !(1..=12).contains(&octaves) {
                return Err(format!("`octaves` must be in 1..=12, got {octaves}"));
            }
            if !(amplitude.is_finite() && *amplitude >= 0.0) {
                return Err(format!("`amplitude` must be >= 0, got {amplitude}"));
            }
            Texture::Noise { scale: positive(*scale, "scale")?, amplitude: *amplitude, octaves }
        }
        TextureDesc::Image { file } => Texture::Image(ctx.image(file)?),
    })
}

fn shape(ctx: &mut Ctx, o: &ObjectDesc) -> Result<Shape, String> {
    Ok(match o.kind {
        Kind::Plane => {
            let c = finite(req(o.centre, "centre")?, "centre")?;
            match (o.half_u, o.half_v, o.normal) {
                (Some(u), Some(v), None) => {
                    let (u, v) = (nonzero(u, "half_u")?, nonzero(v, "half_v")?);
                    if u.normalize().cross(v.normalize()).length() < 1e-9 {
                        return Err("`half_u` and `half_v` must not be parallel".into());
                    }
                    Shape::Plane(Plane::finite(c, u, v))
                }
                (None, None, Some(n)) => Shape::Plane(Plane::infinite(c, nonzero(n, "normal")?)),
                _ => {
                    return Err("give either `half_u` and `half_v` (a finite rectangle) or `normal` \
                                (an unbounded plane)"
                        .into());
                }
            }
        }
        Kind::Box => {
            let half_size = req(o.half_size, "half_size")?;
            let h = finite(half_size, "half_size")?;
            if h.min_element() <= 0.0 {
                return Err(format!("`half_size` must be > 0 in every axis, got {half_size:?}"));
            }
            let yaw = o.yaw_deg.unwrap_or(0.0);
            if !yaw.is_finite() {
                return Err("`yaw_deg` must be finite".into());
            }
            Shape::Box(Cuboid::new(finite(req(o.centre, "centre")?, "centre")?, h, yaw))
        }
        Kind::Sphere => Shape::Sphere(Sphere::new(
            finite(req(o.centre, "centre")?, "centre")?,
            positive(req(o.radius, "radius")?, "radius")?,
        )),
        Kind::Cylinder => Shape::Cylinder(Cylinder::new(
            finite(req(o.base, "base")?, "base")?,
            nonzero(req(o.axis, "axis")?, "axis")?,
            positive(req(o.radius, "radius")?, "radius")?,
            positive(req(o.height, "height")?, "height")?,
        )),
        Kind::Rod => {
            let (a, b) = (finite(req(o.from, "from")?, "from")?, finite(req(o.to, "to")?, "to")?);
            let axis = b - a;
            if axis.length_squared() == 0.0 {
                return Err("`from` and `to` must differ (zero-length rod)".into());
            }
            Shape::Cylinder(Cylinder::new(a, axis, positive(req(o.radius, "radius")?, "radius")?, axis.length()))
        }
        Kind::Mesh => {
            let size = positive(req(o.size, "size")?, "size")?;
            let rot = finite(o.rotate_deg.unwrap_or([0.0; 3]), "rotate_deg")?;
            let pos = finite(req(o.position, "position")?, "position")?;
            let file = o.file.as_deref().ok_or("missing `file`")?;
            let data = ctx.mesh(file)?;
            Shape::Mesh(MeshInstance::new(data, rot, size, pos)?)
        }
    })
}
