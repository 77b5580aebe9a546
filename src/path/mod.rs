//! Camera paths through a scene, and the motion predictor that places
//! reference frames.
//!
//! - [`spline::SplinePath`]: a Catmull-Rom spline through scene waypoints
//!   (the paper's machine-room walk-through used a known spline path).
//! - [`tracked::TrackedPath`]: a real recorded hand-held trajectory (TUM
//!   RGB-D fr1/xyz, bundled), applied as relative motion from a start pose
//!   (the paper's kitchen walk-through used a tracked head path).
//! - [`predict::predict_pose`]: velocity extrapolation, as the paper's
//!   test-bed predicted reference viewpoints 400 ms ahead.

pub mod predict;
pub mod spline;
pub mod tracked;

use postwarp_rtl::Pose;

/// A camera pose as a function of time.
pub trait CameraPath {
    /// Pose at time `t` (seconds). Times outside `[0, duration]` clamp to the
    /// ends; NaN is the start.
    fn pose(&self, t: f64) -> Pose;
    /// Length of the path (seconds).
    fn duration(&self) -> f64;
}
