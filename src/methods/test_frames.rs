//! Test fixtures shared by the methods' unit tests (compiled for tests
//! only): a small pinhole camera on the x axis and a synthetic reference
//! image whose colour encodes each sample's position.

use glam::{DQuat, DVec3};
use postwarp_rtl::{Camera, Intrinsics, Pose, SampleImage};

/// A `w x h`-pixel camera at `x` on the x axis looking down +z (focal
/// length 50 pixels, principal point at the centre).
pub fn cam(w: u32, h: u32, x: f64) -> Camera {
    Camera {
        intrinsics: Intrinsics {
            width: w,
            height: h,
            fx: 50.0,
            fy: 50.0,
            cx: 0.5 * (w as f64 - 1.0),
            cy: 0.5 * (h as f64 - 1.0),
        },
        pose: Pose { position: DVec3::new(x, 0.0, 0.0), orientation: DQuat::IDENTITY },
    }
}

/// A `w x h`-sample image where `depth(x, y)` gives Z (or `None` for no
/// surface); red and green encode the position and `blue(x, y)` is the
/// third channel.
pub fn image(w: u32, h: u32, blue: impl Fn(u32, u32) -> f32, depth: impl Fn(u32, u32) -> Option<f32>) -> SampleImage {
    let mut img = SampleImage::empty(w, h);
    for y in 0..h {
        for x in 0..w {
            let i = img.index(x, y);
            img.colour[i] = [x as f32 / w as f32, y as f32 / h as f32, blue(x, y)];
            if let Some(z) = depth(x, y) {
                img.z[i] = z;
                img.valid.set(i, true);
            }
        }
    }
    img
}
