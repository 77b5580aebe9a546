//! Motion prediction for reference viewpoints.
//!
//! A reference frame for time `T` is rendered at the pose predicted from the
//! path at `T − interval` by constant-velocity extrapolation: linear velocity
//! and angular velocity estimated causally by a backward difference over
//! [`VELOCITY_WINDOW_S`], then `p = p(t0) + v·interval`,
//! `q = exp(ω·interval)·q(t0)`. `interval = 0` puts references exactly on the
//! path. Times before the path's start clamp to the start (zero velocity).

use super::CameraPath;
use glam::DQuat;
use postwarp_rtl::Pose;

/// Backward-difference window for the velocity estimate (seconds).
pub const VELOCITY_WINDOW_S: f64 = 0.05;

/// The pose predicted for time `t` from `interval` seconds earlier.
pub fn predict_pose(path: &dyn CameraPath, t: f64, interval: f64) -> Pose {
    if interval <= 0.0 {
        return path.pose(t);
    }
    let t0 = (t - interval).max(0.0);
    let now = path.pose(t0);
    let h = VELOCITY_WINDOW_S.min(t0);
    if h <= 0.0 {
        return now;
    }
    let before = path.pose(t0 - h);
    let v = (now.position - before.position) / h;
    let mut dq = now.orientation * before.orientation.inverse();
    if dq.w < 0.0 {
        dq = -dq;
    }
    let (axis, angle) = dq.to_axis_angle();
    let omega = axis * (angle / h);
    let span = t - t0;
    let rot = if omega.length() > 0.0 { DQuat::from_scaled_axis(omega * span) } else { DQuat::IDENTITY };
    Pose { position: now.position + v * span, orientation: (rot * now.orientation).normalize() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Constant linear and angular velocity: prediction is exact.
    struct Uniform;
    impl CameraPath for Uniform {
        fn pose(&self, t: f64) -> Pose {
            let t = t.max(0.0);
            Pose { position: DVec3::new(0.5 * t, 0.0, 0.0), orientation: DQuat::from_rotation_y(0.3 * t) }
        }
        fn duration(&self) -> f64 {
            10.0
        }
    }

    #[test]
    fn constant_velocity_is_predicted_exactly() {
        let p = predict_pose(&Uniform, 2.0, 0.4);
        let truth = Uniform.pose(2.0);
        assert!((p.position - truth.position).length() < 1e-9);
        assert!(p.orientation.dot(truth.orientation).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn before_the_start_clamps_and_zero_interval_is_exact() {
        assert_eq!(predict_pose(&Uniform, 0.2, 0.4), Uniform.pose(0.0));
        assert_eq!(predict_pose(&Uniform, 1.3, 0.0), Uniform.pose(1.3));
    }
}
