//! Catmull-Rom spline path: positions and look-at targets interpolated
//! through the waypoints, uniformly in time; the camera looks at the
//! interpolated target with world +y up.

use super::CameraPath;
use glam::DVec3;
use postwarp_rtl::Pose;

/// A spline through `(position, look_at)` waypoints over `duration_s`.
#[derive(Clone, Debug)]
pub struct SplinePath {
    positions: Vec<DVec3>,
    targets: Vec<DVec3>,
    duration_s: f64,
}

impl SplinePath {
    /// A path through the waypoints (at least 2) over `duration_s` seconds.
    pub fn new(waypoints: &[(DVec3, DVec3)], duration_s: f64) -> Result<SplinePath, String> {
        if waypoints.len() < 2 {
            return Err(format!("a spline path needs at least 2 waypoints, got {}", waypoints.len()));
        }
        if !(duration_s.is_finite() && duration_s > 0.0) {
            return Err(format!("spline duration {duration_s} s; expected a positive number of seconds"));
        }
        for (i, (p, t)) in waypoints.iter().enumerate() {
            if (*t - *p).length() < 1e-9 {
                return Err(format!("waypoint {i} looks at its own position"));
            }
        }
        Ok(SplinePath {
            positions: waypoints.iter().map(|w| w.0).collect(),
            targets: waypoints.iter().map(|w| w.1).collect(),
            duration_s,
        })
    }
}

/// Uniform Catmull-Rom through `pts` at parameter `u` in [0, 1].
fn catmull_rom(pts: &[DVec3], u: f64) -> DVec3 {
    let segs = pts.len() - 1;
    let s = (u.clamp(0.0, 1.0) * segs as f64).min(segs as f64 - 1e-12);
    let i = s.floor() as usize;
    let t = s - i as f64;
    let p1 = pts[i];
    let p2 = pts[i + 1];
    let p0 = if i == 0 { 2.0 * p1 - p2 } else { pts[i - 1] };
    let p3 = if i + 2 < pts.len() { pts[i + 2] } else { 2.0 * p2 - p1 };
    let (t2, t3) = (t * t, t * t * t);
    0.5 * ((2.0 * p1)
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)
}

impl CameraPath for SplinePath {
    fn pose(&self, t: f64) -> Pose {
        // NaN is the start, as for every path.
        let u = if t.is_nan() { 0.0 } else { t / self.duration_s };
        let p = catmull_rom(&self.positions, u);
        let target = catmull_rom(&self.targets, u);
        Pose::look_at(p, target, DVec3::Y)
    }

    fn duration(&self) -> f64 {
        self.duration_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_through_waypoints_and_clamps() {
        let w = [
            (DVec3::ZERO, DVec3::Z),
            (DVec3::new(1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 1.0)),
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(1.0, 1.0, 1.0)),
        ];
        let s = SplinePath::new(&w, 2.0).unwrap();
        assert!((s.pose(0.0).position - w[0].0).length() < 1e-12);
        assert!((s.pose(1.0).position - w[1].0).length() < 1e-12);
        assert!((s.pose(2.0).position - w[2].0).length() < 1e-9);
        assert_eq!(s.pose(-1.0), s.pose(0.0));
        assert_eq!(s.pose(f64::NAN), s.pose(0.0));
        assert_eq!(s.pose(f64::INFINITY), s.pose(2.0));
        assert!(SplinePath::new(&w[..1], 1.0).is_err());
        assert!(SplinePath::new(&w, 0.0).is_err());
    }
}
