//! Built-in scenes and bundled assets, embedded in the binary.
//!
//! Rules: the built-in scene descriptions are the files in `scenes/` at the
//! repository root, embedded verbatim (`include_str!`), so what users read
//! and copy is exactly what runs. Models and textures come from
//! `data/models/` (`include_bytes!`) and are named in scene files as
//! `bundled:<file>`. Each bundled asset is parsed (and, for meshes, its BVH
//! built) at most once per process and then shared.
//!
//! Not modelled: loading extra bundles at run time.

use super::mesh::MeshData;
use super::texture::Image;
use std::sync::{Arc, OnceLock};

/// Built-in scenes: (name, TOML text).
pub const SCENES: [(&str, &str); 5] = [
    ("room", include_str!("../../scenes/room.toml")),
    ("slants", include_str!("../../scenes/slants.toml")),
    ("hairball", include_str!("../../scenes/hairball.toml")),
    ("occluders", include_str!("../../scenes/occluders.toml")),
    ("gallery", include_str!("../../scenes/gallery.toml")),
];

/// Names of the built-in scenes, in [`SCENES`] order.
pub const SCENE_NAMES: [&str; 5] = [SCENES[0].0, SCENES[1].0, SCENES[2].0, SCENES[3].0, SCENES[4].0];

const MESHES: [(&str, &[u8]); 4] = [
    ("stanford-bunny.obj", include_bytes!("../../data/models/stanford-bunny.obj")),
    ("teapot.obj", include_bytes!("../../data/models/teapot.obj")),
    ("spot.obj", include_bytes!("../../data/models/spot.obj")),
    ("cow.obj", include_bytes!("../../data/models/cow.obj")),
];

const IMAGES: [(&str, &[u8]); 1] = [("spot_texture.png", include_bytes!("../../data/models/spot_texture.png"))];

type Cached<T> = OnceLock<Result<Arc<T>, String>>;
static MESH_CACHE: [Cached<MeshData>; 4] = [OnceLock::new(), OnceLock::new(), OnceLock::new(), OnceLock::new()];
static IMAGE_CACHE: [Cached<Image>; 1] = [OnceLock::new()];

fn known(names: &[&str]) -> String {
    names.iter().map(|n| format!("bundled:{n}")).collect::<Vec<_>>().join(", ")
}

/// The bundled mesh `name` (a file name in `data/models/`).
pub fn bundled_mesh(name: &str) -> Result<Arc<MeshData>, String> {
    let Some(i) = MESHES.iter().position(|(n, _)| *n == name) else {
        let names: Vec<&str> = MESHES.iter().map(|(n, _)| *n).collect();
        return Err(format!("no bundled model `bundled:{name}` (bundled models: {})", known(&names)));
    };
    MESH_CACHE[i]
        .get_or_init(|| MeshData::from_obj_bytes(MESHES[i].1).map(Arc::new).map_err(|e| format!("bundled:{name}: {e}")))
        .clone()
}

/// The bundled image `name` (a file name in `data/models/`).
pub fn bundled_image(name: &str) -> Result<Arc<Image>, String> {
    let Some(i) = IMAGES.iter().position(|(n, _)| *n == name) else {
        let names: Vec<&str> = IMAGES.iter().map(|(n, _)| *n).collect();
        return Err(format!("no bundled texture `bundled:{name}` (bundled textures: {})", known(&names)));
    };
    IMAGE_CACHE[i]
        .get_or_init(|| Image::decode(IMAGES[i].1).map(Arc::new).map_err(|e| format!("bundled:{name}: {e}")))
        .clone()
}
