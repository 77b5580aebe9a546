//! Pinhole cameras and the 3D-warp quantities derived from them.
//!
//! Conventions (OpenCV): camera x right, y down, z forward; depth `Z` is
//! measured along the optical axis. Image coordinates are in pixels with the
//! centre of pixel `(i, j)` at `(i, j)`; `(cx, cy)` is the principal point in
//! those coordinates. A pose holds the centre of projection `position` and the
//! camera-to-world rotation `orientation` (a unit quaternion).
//!
//! McMillan's planar form (`docs/warper-reference.md` §1): `P = [u | v | o]` maps
//! the homogeneous pixel `(x, y, 1)` to a world-space ray direction; a point
//! is `X = C + P·(x, y, 1) / δ` with generalized disparity `δ = S · (1/Z)`.
//! With `u = R·(1/fx, 0, 0)`, `v = R·(0, 1/fy, 0)`, `o = R·(−cx/fx, −cy/fy, 1)`
//! we get `S = 1`, so `δ = 1/Z`.

use glam::{DMat3, DQuat, DVec2, DVec3};

/// Pinhole intrinsics, in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Focal length along x (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point x (pixels; pixel centres at integers).
    pub cx: f64,
    /// Principal point y (pixels; pixel centres at integers).
    pub cy: f64,
}

impl Intrinsics {
    /// Intrinsics of a `width x height` image with square pixels, the given
    /// horizontal field of view (degrees) and the principal point at the
    /// image centre.
    pub fn from_hfov(width: u32, height: u32, hfov_deg: f64) -> Intrinsics {
        let f = 0.5 * width as f64 / (0.5 * hfov_deg.to_radians()).tan();
        Intrinsics { width, height, fx: f, fy: f, cx: 0.5 * (width as f64 - 1.0), cy: 0.5 * (height as f64 - 1.0) }
    }

    /// Horizontal and vertical field of view (degrees) covered by the image's
    /// pixel area (edge to edge).
    pub fn fov_deg(&self) -> (f64, f64) {
        let h = ((self.cx + 0.5) / self.fx).atan() + ((self.width as f64 - 0.5 - self.cx) / self.fx).atan();
        let v = ((self.cy + 0.5) / self.fy).atan() + ((self.height as f64 - 0.5 - self.cy) / self.fy).atan();
        (h.to_degrees(), v.to_degrees())
    }

    /// The intrinsics of the super-sample grid: `ss x ss` samples per pixel,
    /// sample centres at integer sample coordinates. Pixel coordinate `x`
    /// maps to sample coordinate `ss·(x + 0.5) − 0.5`.
    pub fn sample_grid(&self, ss: u32) -> Intrinsics {
        let s = ss as f64;
        Intrinsics {
            width: self.width * ss,
            height: self.height * ss,
            fx: self.fx * s,
            fy: self.fy * s,
            cx: (self.cx + 0.5) * s - 0.5,
            cy: (self.cy + 0.5) * s - 0.5,
        }
    }
}

/// Camera pose: centre of projection and camera-to-world rotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Centre of projection in world coordinates (scene units).
    pub position: DVec3,
    /// Camera-to-world rotation (unit quaternion).
    pub orientation: DQuat,
}

impl Pose {
    /// A pose at `position` looking at `target`, with `up` (world) giving the
    /// roll: camera −y points as close to `up` as possible.
    pub fn look_at(position: DVec3, target: DVec3, up: DVec3) -> Pose {
        let z = (target - position).normalize();
        let x = z.cross(up).normalize();
        // Camera y points down: y = z × x.
        let y = z.cross(x);
        let m = DMat3::from_cols(x, y, z);
        Pose { position, orientation: DQuat::from_mat3(&m).normalize() }
    }

    /// Camera-to-world rotation matrix.
    pub fn rotation(&self) -> DMat3 {
        DMat3::from_quat(self.orientation)
    }

    /// World point to camera coordinates.
    pub fn world_to_camera(&self, x: DVec3) -> DVec3 {
        self.orientation.inverse() * (x - self.position)
    }
}

/// A pinhole camera: intrinsics plus pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Intrinsics (pixels).
    pub intrinsics: Intrinsics,
    /// Pose (world).
    pub pose: Pose,
}

impl Camera {
    /// The same camera seen on its `ss x ss` super-sample grid.
    pub fn sample_grid(&self, ss: u32) -> Camera {
        Camera { intrinsics: self.intrinsics.sample_grid(ss), pose: self.pose }
    }

    /// World-space direction (not normalised) of the ray through image point
    /// `(x, y)`; its camera-space z component is 1.
    pub fn ray_direction(&self, x: f64, y: f64) -> DVec3 {
        let k = &self.intrinsics;
        self.pose.orientation * DVec3::new((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0)
    }

    /// Project a world point: image coordinates and depth `Z` (camera z).
    /// `None` if the point is not in front of the camera (`Z <= 0`).
    pub fn project(&self, x: DVec3) -> Option<(DVec2, f64)> {
        let c = self.pose.world_to_camera(x);
        if c.z <= 0.0 {
            return None;
        }
        let k = &self.intrinsics;
        Some((DVec2::new(k.fx * c.x / c.z + k.cx, k.fy * c.y / c.z + k.cy), c.z))
    }

    /// World point seen at image point `(x, y)` at depth `z`.
    pub fn unproject(&self, x: f64, y: f64, z: f64) -> DVec3 {
        self.pose.position + self.ray_direction(x, y) * z
    }

    /// McMillan's planar form of this camera.
    pub fn planar(&self) -> PlanarCamera {
        let k = &self.intrinsics;
        let r = self.pose.rotation();
        let u = r * DVec3::new(1.0 / k.fx, 0.0, 0.0);
        let v = r * DVec3::new(0.0, 1.0 / k.fy, 0.0);
        let o = r * DVec3::new(-k.cx / k.fx, -k.cy / k.fy, 1.0);
        PlanarCamera { p: DMat3::from_cols(u, v, o), centre: self.pose.position }
    }
}

/// McMillan's planar pinhole camera: `P = [u | v | o]` and centre `C`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarCamera {
    /// The 3x3 matrix `[u | v | o]` (columns in world units per pixel).
    pub p: DMat3,
    /// Centre of projection `C` (world).
    pub centre: DVec3,
}

impl PlanarCamera {
    /// The scale `S = n·o` between disparity and 1/Z (`δ = S / Z`), where `n`
    /// is the unit normal `u×v/|u×v|`.
    pub fn s(&self) -> f64 {
        let n = self.p.x_axis.cross(self.p.y_axis).normalize();
        n.dot(self.p.z_axis)
    }
}

/// An epipole: the image of another camera's centre of projection, in
/// homogeneous image coordinates `(ex, ey, ew)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epipole {
    /// Homogeneous epipole `(ex, ey, ew)`.
    pub h: DVec3,
}

/// Where an epipole lies, for printing and for choosing a traversal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EpipoleKind {
    /// The other centre is in front of this image plane (`ew > 0`): the
    /// occlusion-compatible order moves *toward* `point`.
    Front {
        /// Epipole in image coordinates (pixels).
        point: DVec2,
    },
    /// The other centre is behind this image plane (`ew < 0`): the order moves
    /// *away from* `point`.
    Behind {
        /// Epipole in image coordinates (pixels).
        point: DVec2,
    },
    /// `ew = 0` (to a relative tolerance): epipole at infinity in `direction`.
    Infinity {
        /// Unit direction in the image plane.
        direction: DVec2,
    },
    /// The two centres coincide: every ordering is compatible.
    Coincident,
}

impl Epipole {
    /// Relative tolerance under which `|ew|` counts as zero.
    pub const INFINITY_TOL: f64 = 1e-12;

    /// Classify the epipole.
    pub fn kind(&self) -> EpipoleKind {
        let h = self.h;
        let len = h.length();
        if len == 0.0 {
            return EpipoleKind::Coincident;
        }
        if h.z.abs() <= Self::INFINITY_TOL * len {
            return EpipoleKind::Infinity { direction: DVec2::new(h.x, h.y).normalize() };
        }
        let point = DVec2::new(h.x / h.z, h.y / h.z);
        if h.z > 0.0 { EpipoleKind::Front { point } } else { EpipoleKind::Behind { point } }
    }

    /// The occlusion-compatible traversal direction at image point `p`:
    /// `D(p) = (ex − px·ew, ey − py·ew)` (`docs/warper-reference.md` §2).
    pub fn direction_at(&self, p: DVec2) -> DVec2 {
        DVec2::new(self.h.x - p.x * self.h.z, self.h.y - p.y * self.h.z)
    }

    /// True if the epipole is a finite point inside the image rectangle
    /// `[-0.5, w-0.5] x [-0.5, h-0.5]`.
    pub fn inside(&self, k: &Intrinsics) -> bool {
        match self.kind() {
            EpipoleKind::Front { point } | EpipoleKind::Behind { point } => {
                point.x >= -0.5
                    && point.y >= -0.5
                    && point.x <= k.width as f64 - 0.5
                    && point.y <= k.height as f64 - 0.5
            }
            _ => false,
        }
    }
}

/// Everything the 3D warp of one reference camera to one derived camera
/// needs (`docs/warper-reference.md` §1–2). Image coordinates are those of the
/// cameras given (use [`Camera::sample_grid`] to work in super-samples).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpSetup {
    /// `H = P2⁻¹·P1`.
    pub h: DMat3,
    /// `ê = P2⁻¹·(C1 − C2)`.
    pub e_hat: DVec3,
    /// Disparity scale of the reference camera (`δ = s1 · 1/Z1`).
    pub s1: f64,
    /// Disparity scale of the derived camera (`1/Z2 = δ / (s2·W)`).
    pub s2: f64,
    /// Epipole in the reference image: `ē = P1⁻¹·(C2 − C1)`.
    pub epipole_reference: Epipole,
    /// Epipole in the derived image: `ê` itself, seen as homogeneous point.
    pub epipole_derived: Epipole,
}

/// The image of one sample under the warp equation (both engines' transform
/// units build their `Transformed` from it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectedPoint {
    /// Derived-image position (x', y').
    pub position: DVec2,
    /// Derived-camera 1/Z.
    pub inv_z: f64,
    /// The homogeneous `W`; `W <= 0` means behind the derived camera.
    pub w: f64,
}

impl WarpSetup {
    /// Set up the warp from `reference` to `derived`.
    pub fn new(reference: &Camera, derived: &Camera) -> WarpSetup {
        let p1 = reference.planar();
        let p2 = derived.planar();
        let p2_inv = p2.p.inverse();
        let p1_inv = p1.p.inverse();
        let h = p2_inv * p1.p;
        let e_hat = p2_inv * (p1.centre - p2.centre);
        WarpSetup {
            h,
            e_hat,
            s1: p1.s(),
            s2: p2.s(),
            epipole_reference: Epipole { h: p1_inv * (p2.centre - p1.centre) },
            epipole_derived: Epipole { h: e_hat },
        }
    }

    /// Warp reference image point `(x, y)` with reference `1/Z` to the derived
    /// image: `N = H·(x, y, 1) + δ·ê`, `δ = s1/Z1`, `x' = N.x/W`, `y' = N.y/W`,
    /// `1/Z2 = δ/(s2·W)`.
    pub fn warp(&self, x: f64, y: f64, inv_z: f64) -> ProjectedPoint {
        let delta = self.s1 * inv_z;
        let n = self.h * DVec3::new(x, y, 1.0) + self.e_hat * delta;
        let w = n.z;
        ProjectedPoint { position: DVec2::new(n.x / w, n.y / w), inv_z: delta / (self.s2 * w), w }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(pos: DVec3, yaw_deg: f64) -> Camera {
        Camera {
            intrinsics: Intrinsics { width: 100, height: 80, fx: 50.0, fy: 50.0, cx: 49.5, cy: 39.5 },
            pose: Pose { position: pos, orientation: DQuat::from_rotation_y(yaw_deg.to_radians()) },
        }
    }

    #[test]
    fn identity_pose_projects_by_hand() {
        let c = cam(DVec3::ZERO, 0.0);
        // (1, -2, 4) → x = 50·1/4 + 49.5 = 62, y = 50·(−2)/4 + 39.5 = 14.5.
        let (p, z) = c.project(DVec3::new(1.0, -2.0, 4.0)).unwrap();
        assert_eq!((p.x, p.y, z), (62.0, 14.5, 4.0));
        assert!(c.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
        let back = c.unproject(62.0, 14.5, 4.0);
        assert!((back - DVec3::new(1.0, -2.0, 4.0)).length() < 1e-12);
    }

    #[test]
    fn planar_form_has_unit_s_and_maps_pixels_to_rays() {
        let c = cam(DVec3::new(1.0, 2.0, 3.0), 30.0);
        let p = c.planar();
        assert!((p.s() - 1.0).abs() < 1e-12);
        let d = p.p * DVec3::new(10.0, 20.0, 1.0);
        assert!((d - c.ray_direction(10.0, 20.0)).length() < 1e-12);
    }

    #[test]
    fn sample_grid_maps_pixel_centres() {
        let k = Intrinsics { width: 4, height: 3, fx: 10.0, fy: 10.0, cx: 1.5, cy: 1.0 };
        let s = k.sample_grid(2);
        assert_eq!((s.width, s.height, s.fx, s.cx, s.cy), (8, 6, 20.0, 3.5, 2.5));
        // Pixel 0 covers samples 0 and 1, whose centres are at pixel x = -0.25 and 0.25.
        let to_pixel = |xs: f64| (xs + 0.5) / 2.0 - 0.5;
        assert_eq!((to_pixel(0.0), to_pixel(1.0)), (-0.25, 0.25));
    }

    #[test]
    fn warp_matches_reprojection_and_gives_derived_depth() {
        let r = cam(DVec3::ZERO, 0.0);
        let d = cam(DVec3::new(0.3, -0.1, 0.2), 5.0);
        let s = WarpSetup::new(&r, &d);
        for &(x, y, z) in &[(10.0, 20.0, 3.0), (70.0, 5.0, 10.0), (49.5, 39.5, 1.5)] {
            let world = r.unproject(x, y, z);
            let (p, z2) = d.project(world).unwrap();
            let w = s.warp(x, y, 1.0 / z);
            assert!(w.w > 0.0);
            assert!((w.position - p).length() < 1e-9, "{:?} vs {:?}", w.position, p);
            assert!((w.inv_z - 1.0 / z2).abs() < 1e-12);
        }
    }

    #[test]
    fn epipole_by_hand_forward_motion() {
        // Derived camera 1 unit straight ahead: its centre projects to the
        // principal point of the reference, in front (ew > 0).
        let r = cam(DVec3::ZERO, 0.0);
        let d = cam(DVec3::new(0.0, 0.0, 1.0), 0.0);
        let s = WarpSetup::new(&r, &d);
        match s.epipole_reference.kind() {
            EpipoleKind::Front { point } => {
                assert!((point - DVec2::new(49.5, 39.5)).length() < 1e-12)
            }
            k => panic!("expected front epipole, got {k:?}"),
        }
        assert!(s.epipole_reference.inside(&r.intrinsics));
        // In the derived image the reference centre is straight behind.
        assert!(matches!(s.epipole_derived.kind(), EpipoleKind::Behind { .. }));
    }

    #[test]
    fn epipole_behind_the_camera() {
        // Derived camera behind and to the right: ē = P1⁻¹·(C2 − C1) with
        // C2 − C1 = (1, 0, −2) gives (1/50 − 49.5·(−2)·... ) — by hand:
        // P1⁻¹·d = (fx·dx/dz·dz + cx·dz, ...) = (50·1 + 49.5·(−2), 39.5·(−2), −2).
        let r = cam(DVec3::ZERO, 0.0);
        let d = cam(DVec3::new(1.0, 0.0, -2.0), 0.0);
        let s = WarpSetup::new(&r, &d);
        let e = s.epipole_reference.h;
        assert!((e - DVec3::new(50.0 - 99.0, -79.0, -2.0)).length() < 1e-9, "{e:?}");
        match s.epipole_reference.kind() {
            EpipoleKind::Behind { point } => {
                assert!((point - DVec2::new(24.5, 39.5)).length() < 1e-9)
            }
            k => panic!("expected behind, got {k:?}"),
        }
    }

    #[test]
    fn epipole_at_infinity_for_sideways_motion() {
        let r = cam(DVec3::ZERO, 0.0);
        let d = cam(DVec3::new(0.5, 0.0, 0.0), 0.0);
        let s = WarpSetup::new(&r, &d);
        match s.epipole_reference.kind() {
            EpipoleKind::Infinity { direction } => {
                assert!((direction - DVec2::new(1.0, 0.0)).length() < 1e-12)
            }
            k => panic!("expected infinity, got {k:?}"),
        }
        // The occlusion-compatible direction is the same constant everywhere.
        assert_eq!(s.epipole_reference.direction_at(DVec2::new(3.0, 7.0)), DVec2::new(25.0, 0.0));
    }

    #[test]
    fn look_at_points_the_optical_axis() {
        let p = Pose::look_at(DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 5.0), DVec3::new(0.0, -1.0, 0.0));
        let fwd = p.orientation * DVec3::Z;
        assert!((fwd - DVec3::Z).length() < 1e-12);
        // up = −y world: camera y (down) must be world +y.
        assert!((p.orientation * DVec3::Y - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn fov_round_trip() {
        let k = Intrinsics::from_hfov(640, 480, 60.0);
        let (h, v) = k.fov_deg();
        assert!((h - 60.0).abs() < 1e-9);
        assert!((v - 46.83).abs() < 0.01, "{v}");
    }
}
