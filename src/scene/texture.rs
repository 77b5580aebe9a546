//! Surface colour: procedural solid textures and image textures.
//!
//! Rules:
//! - every texture is a pure function of the hit (world point, surface
//!   orientation, texture coordinates): no random state, no dependence on the
//!   view, the pixel or the thread, so renders are reproducible bit for bit;
//! - solid textures (`checker`, `stripes`, `noise`) are evaluated at the
//!   world point moved [`INSET`] metres into the surface along the
//!   (unflipped) normal, so a face lying exactly on a cell boundary (a floor
//!   at y = 0) does not flicker between two cells from rounding;
//! - `noise` is value noise on the integer lattice with a fixed integer hash
//!   of the lattice point, smoothstep-interpolated, summed over octaves;
//! - image textures are decoded once, stored as linear RGB (sRGB decode),
//!   sampled bilinearly with wrap-around, OBJ convention (v = 0 at the
//!   bottom row of the image).
//!
//! Not modelled: mip-mapping or any other filtering across the sample
//! footprint (super-sampling does the anti-aliasing), alpha, normal maps.

use crate::picture::srgb_to_linear;
use glam::DVec3;
use std::sync::Arc;

/// Distance (metres) inside the surface where solid textures are evaluated.
pub const INSET: f64 = 1e-4;

/// A decoded image texture in linear RGB.
#[derive(Debug)]
pub struct Image {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
}

impl Image {
    /// Decode PNG (or any format the `image` crate was built with).
    pub fn decode(bytes: &[u8]) -> Result<Image, String> {
        let img = image::load_from_memory(bytes).map_err(|e| format!("cannot decode image ({e})"))?.to_rgb8();
        let (width, height) = (img.width() as usize, img.height() as usize);
        if width == 0 || height == 0 {
            return Err("the image is empty".into());
        }
        let texels = img.pixels().map(|p| p.0.map(srgb_to_linear)).collect();
        Ok(Image { width, height, texels })
    }

    /// Bilinear lookup at `(u, v)`, wrapping; v = 0 is the bottom row.
    pub fn sample(&self, uv: [f64; 2]) -> [f32; 3] {
        let x = uv[0].rem_euclid(1.0) * self.width as f64 - 0.5;
        let y = (1.0 - uv[1].rem_euclid(1.0)) * self.height as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let wrap = |i: f64, n: usize| (i as i64).rem_euclid(n as i64) as usize;
        let (xa, xb) = (wrap(x0, self.width), wrap(x0 + 1.0, self.width));
        let (ya, yb) = (wrap(y0, self.height), wrap(y0 + 1.0, self.height));
        let t = |x: usize, y: usize| self.texels[y * self.width + x];
        let (a, b, c, d) = (t(xa, ya), t(xb, ya), t(xa, yb), t(xb, yb));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

/// A texture: modulates or replaces the material's base colour.
#[derive(Clone, Debug)]
pub enum Texture {
    /// 3D checkerboard of cubes of side `cell` alternating base and `other`.
    Checker {
        /// Cube side (metres).
        cell: f64,
        /// Second colour.
        other: [f32; 3],
    },
    /// Slabs perpendicular to `axis` (unit), `period` metres per base+other pair.
    Stripes {
        /// Full period (metres).
        period: f64,
        /// Unit axis across the stripes.
        axis: DVec3,
        /// Second colour.
        other: [f32; 3],
    },
    /// Base colour × (1 + amplitude·(2·noise − 1)), noise in [0, 1].
    Noise {
        /// Feature size of the first octave (metres).
        scale: f64,
        /// Relative brightness variation.
        amplitude: f64,
        /// Number of octaves (each half the size and half the weight).
        octaves: u32,
    },
    /// Image × base colour, looked up by texture coordinates.
    Image(Arc<Image>),
}

/// A material: base colour, optional texture, and how light leaves the
/// surface besides its diffuse colour.
#[derive(Clone, Debug)]
pub struct Material {
    /// Linear RGB base colour.
    pub colour: [f32; 3],
    /// Optional texture.
    pub texture: Option<Texture>,
    /// Transparency, reflection, refraction (`docs/scene-format.md`).
    pub optics: Optics,
}

/// How light leaves a surface besides its diffuse colour (the keys
/// `opacity`, `reflect`, `refract`, `ior` of a material). The default is
/// an opaque diffuse surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optics {
    /// Opacity in [0, 1]: below 1 the surface is a semi-transparent
    /// fragment (thin, no refraction) that the camera sees through.
    pub opacity: f32,
    /// Tint of the mirror reflection (linear RGB), if the surface reflects.
    pub reflect: Option<[f32; 3]>,
    /// Tint of the refraction (linear RGB), if the surface refracts.
    pub refract: Option<[f32; 3]>,
    /// Index of refraction: the reflection and refraction weigh by the
    /// Fresnel terms (reflection tint white unless `reflect` says).
    pub ior: Option<f64>,
}

impl Default for Optics {
    fn default() -> Self {
        Optics { opacity: 1.0, reflect: None, refract: None, ior: None }
    }
}

impl Optics {
    /// A semi-transparent surface (opacity below 1).
    pub fn is_transparent(&self) -> bool {
        self.opacity < 1.0
    }

    /// A surface with a reflection or a refraction node.
    pub fn is_specular(&self) -> bool {
        self.reflection_tint().is_some() || self.refract.is_some()
    }

    /// Tint of the reflection node: `reflect`, else white for a dielectric
    /// (`ior` given), else none.
    pub fn reflection_tint(&self) -> Option<[f32; 3]> {
        self.reflect.or(self.ior.map(|_| [1.0; 3]))
    }

    /// The ray-tree material (how the nodes weigh), for specular surfaces.
    pub fn specular_material(&self) -> Option<crate::trace::layers::SpecularMaterial> {
        use crate::trace::layers::SpecularMaterial;
        match self.ior {
            Some(ior) => Some(SpecularMaterial::Dielectric { ior }),
            None => self.reflect.map(|_| SpecularMaterial::Mirror),
        }
    }
}

impl Material {
    /// Albedo at world point `p` on a surface with (unflipped) unit normal
    /// `n` and optional texture coordinates.
    pub fn albedo(&self, p: DVec3, n: DVec3, uv: Option<[f64; 2]>) -> [f32; 3] {
        let base = self.colour;
        let inside = p - n * INSET;
        match &self.texture {
            None => base,
            Some(Texture::Checker { cell, other }) => {
                let c = (inside / *cell).floor();
                let parity = (c.x as i64 + c.y as i64 + c.z as i64).rem_euclid(2);
                if parity == 0 { base } else { *other }
            }
            Some(Texture::Stripes { period, axis, other }) => {
                let s = (2.0 * inside.dot(*axis) / period).floor() as i64;
                if s.rem_euclid(2) == 0 { base } else { *other }
            }
            Some(Texture::Noise { scale, amplitude, octaves }) => {
                let v = fractal_noise(inside / *scale, *octaves);
                let f = (1.0 + amplitude * (2.0 * v - 1.0)) as f32;
                base.map(|c| (c * f).clamp(0.0, 1.0))
            }
            Some(Texture::Image(img)) => match uv {
                Some(uv) => {
                    let t = img.sample(uv);
                    std::array::from_fn(|k| (base[k] * t[k]).clamp(0.0, 1.0))
                }
                None => base,
            },
        }
    }
}

/// A fixed 64-bit mix of a lattice point to [0, 1).
fn lattice_value(x: i64, y: i64, z: i64) -> f64 {
    let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (z as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
    // SplitMix64 finaliser.
    h ^= h >> 30;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^= h >> 31;
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Trilinear value noise with smoothstep weights, in [0, 1].
fn value_noise(p: DVec3) -> f64 {
    let c = p.floor();
    let f = p - c;
    let s = f * f * (DVec3::splat(3.0) - 2.0 * f);
    let (x, y, z) = (c.x as i64, c.y as i64, c.z as i64);
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let v = |dx: i64, dy: i64, dz: i64| lattice_value(x + dx, y + dy, z + dz);
    let x00 = lerp(v(0, 0, 0), v(1, 0, 0), s.x);
    let x10 = lerp(v(0, 1, 0), v(1, 1, 0), s.x);
    let x01 = lerp(v(0, 0, 1), v(1, 0, 1), s.x);
    let x11 = lerp(v(0, 1, 1), v(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// Octaves of value noise (frequency ×2, weight ×½ each), normalised to [0, 1].
fn fractal_noise(p: DVec3, octaves: u32) -> f64 {
    let (mut sum, mut norm, mut weight, mut freq) = (0.0, 0.0, 1.0, 1.0);
    for _ in 0..octaves.max(1) {
        sum += weight * value_noise(p * freq);
        norm += weight;
        weight *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_on_a_cell_boundary_is_stable() {
        let m = Material {
            colour: [1.0, 1.0, 1.0],
            texture: Some(Texture::Checker { cell: 1.0, other: [0.0, 0.0, 0.0] }),
            optics: Optics::default(),
        };
        // A floor at y = 0 seen from above, with rounding noise either side.
        for y in [0.0, 1e-15, -1e-15] {
            assert_eq!(m.albedo(DVec3::new(0.5, y, 0.5), DVec3::Y, None), [0.0, 0.0, 0.0]);
            assert_eq!(m.albedo(DVec3::new(1.5, y, 0.5), DVec3::Y, None), [1.0, 1.0, 1.0]);
        }
    }

    #[test]
    fn noise_is_deterministic_and_bounded() {
        let mut lo: f64 = 1.0;
        let mut hi: f64 = 0.0;
        for i in 0..1000 {
            let p = DVec3::new(i as f64 * 0.137, -(i as f64) * 0.071, 3.3);
            let v = fractal_noise(p, 3);
            assert_eq!(v, fractal_noise(p, 3));
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!(lo >= 0.0 && hi <= 1.0 && hi - lo > 0.3, "{lo} {hi}");
    }

    #[test]
    fn image_sampling_wraps_and_flips_v() {
        // 2x1 image: left texel black, right white (sRGB 255 → 1.0).
        let img = Image { width: 2, height: 1, texels: vec![[0.0; 3], [1.0; 3]] };
        assert_eq!(img.sample([0.25, 0.5]), [0.0; 3]);
        assert_eq!(img.sample([0.75, 0.5]), [1.0; 3]);
        assert_eq!(img.sample([0.5, 0.5]), [0.5; 3]);
        assert_eq!(img.sample([1.25, -3.5]), [0.0; 3]);
    }
}
