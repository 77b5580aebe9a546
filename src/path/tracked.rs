//! A real recorded camera trajectory applied to a scene.
//!
//! The bundled trajectory is TUM RGB-D `freiburg1_xyz` ground truth (motion
//! capture at 100 Hz, 30 s, hand-held; Sturm et al., IROS 2012, CC BY 4.0),
//! `data/motion/tum_fr1_xyz_groundtruth.txt.gz`. Lines are
//! `timestamp tx ty tz qx qy qz qw` (camera-to-world, optical frame).
//! The motion is taken relative to the first pose, scaled, and applied from a
//! start pose in the scene: `position = start.p + start.q·(scale·q0⁻¹(p − p0))`,
//! `orientation = start.q·q0⁻¹·q`. Between records the pose is interpolated
//! (linear position, slerp orientation).

use super::CameraPath;
use flate2::read::GzDecoder;
use glam::{DQuat, DVec3};
use postwarp_rtl::Pose;
use std::io::Read;

/// The bundled trajectory file, gzip-compressed.
pub const TUM_FR1_XYZ_GZ: &[u8] = include_bytes!("../../data/motion/tum_fr1_xyz_groundtruth.txt.gz");

/// A recorded trajectory placed in a scene.
#[derive(Clone, Debug)]
pub struct TrackedPath {
    times: Vec<f64>,
    poses: Vec<Pose>,
}

/// Parse a TUM trajectory text; `name` is used in error messages.
pub fn parse_tum(text: &str, name: &str) -> Result<Vec<(f64, Pose)>, String> {
    let mut out: Vec<(f64, Pose)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|t| t.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("{name}:{}: expected `timestamp tx ty tz qx qy qz qw` numbers", i + 1))?;
        if v.len() != 8 || !v.iter().all(|x| x.is_finite()) {
            return Err(format!("{name}:{}: expected 8 finite numbers, got {}", i + 1, v.len()));
        }
        let q = DQuat::from_xyzw(v[4], v[5], v[6], v[7]);
        if (q.length() - 1.0).abs() > 1e-2 {
            return Err(format!("{name}:{}: orientation is not a unit quaternion", i + 1));
        }
        if let Some(&(t, _)) = out.last()
            && v[0] <= t
        {
            return Err(format!("{name}:{}: timestamps must increase", i + 1));
        }
        out.push((v[0], Pose { position: DVec3::new(v[1], v[2], v[3]), orientation: q.normalize() }));
    }
    if out.len() < 2 {
        return Err(format!("{name}: a trajectory needs at least 2 poses"));
    }
    Ok(out)
}

impl TrackedPath {
    /// The bundled TUM fr1/xyz trajectory, starting `skip_s` seconds in.
    pub fn bundled(start: Pose, scale: f64, skip_s: f64) -> Result<TrackedPath, String> {
        let mut text = String::new();
        GzDecoder::new(TUM_FR1_XYZ_GZ).read_to_string(&mut text).map_err(|e| format!("bundled trajectory: {e}"))?;
        let records = parse_tum(&text, "tum_fr1_xyz_groundtruth.txt")?;
        TrackedPath::from_records(&records, start, scale, skip_s)
    }

    /// Place `records` relative to `start`, scaled by `scale`, from `skip_s`
    /// seconds after the first record.
    pub fn from_records(records: &[(f64, Pose)], start: Pose, scale: f64, skip_s: f64) -> Result<TrackedPath, String> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(format!("trajectory scale {scale}; expected a positive number"));
        }
        let Some(&(first_t, _)) = records.first() else {
            return Err("the trajectory has no poses; expected at least 2".into());
        };
        if let Some(i) = records.iter().position(|(t, p)| {
            !(t.is_finite() && p.position.is_finite() && p.orientation.is_finite() && p.orientation.is_normalized())
        }) {
            return Err(format!("trajectory pose {i}: expected a finite time, position and a unit quaternion"));
        }
        if let Some(i) = records.windows(2).position(|w| w[1].0 <= w[0].0) {
            return Err(format!("trajectory pose {}: timestamps must increase", i + 1));
        }
        let t0 = first_t + skip_s.max(0.0);
        let kept: Vec<&(f64, Pose)> = records.iter().filter(|r| r.0 >= t0).collect();
        if kept.len() < 2 {
            return Err(format!("the trajectory is shorter than the {skip_s} s skipped"));
        }
        let first = kept[0].1;
        let q0_inv = first.orientation.inverse();
        let mut times = Vec::with_capacity(kept.len());
        let mut poses = Vec::with_capacity(kept.len());
        for &&(t, p) in &kept {
            let rel_p = q0_inv * (p.position - first.position) * scale;
            let rel_q = q0_inv * p.orientation;
            times.push(t - kept[0].0);
            poses.push(Pose {
                position: start.position + start.orientation * rel_p,
                orientation: (start.orientation * rel_q).normalize(),
            });
        }
        Ok(TrackedPath { times, poses })
    }
}

impl CameraPath for TrackedPath {
    fn pose(&self, t: f64) -> Pose {
        let n = self.times.len();
        // NaN is the start too (it would index before it).
        if t.is_nan() || t <= 0.0 {
            return self.poses[0];
        }
        if t >= self.times[n - 1] {
            return self.poses[n - 1];
        }
        let i = self.times.partition_point(|&x| x <= t) - 1;
        let (a, b) = (self.poses[i], self.poses[i + 1]);
        let u = (t - self.times[i]) / (self.times[i + 1] - self.times[i]);
        Pose {
            position: a.position.lerp(b.position, u),
            orientation: a.orientation.slerp(b.orientation, u).normalize(),
        }
    }

    fn duration(&self) -> f64 {
        *self.times.last().unwrap_or(&0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bundled_trajectory_loads_and_starts_at_the_start_pose() {
        let start = Pose::look_at(DVec3::new(1.0, 1.6, 2.0), DVec3::new(1.0, 1.0, 5.0), DVec3::Y);
        let p = TrackedPath::bundled(start, 1.0, 0.0).unwrap();
        assert!((p.duration() - 30.0).abs() < 1.0, "{}", p.duration());
        let p0 = p.pose(0.0);
        assert!((p0.position - start.position).length() < 1e-12);
        assert!(p0.orientation.dot(start.orientation).abs() > 1.0 - 1e-12);
        // Hand-held motion: it moves, but by less than a metre in 5 s at scale 1.
        let d = (p.pose(5.0).position - start.position).length();
        assert!(d > 0.01 && d < 1.0, "{d}");
    }

    #[test]
    fn scale_scales_displacement_only() {
        let start = Pose::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y);
        let a = TrackedPath::bundled(start, 1.0, 0.0).unwrap();
        let b = TrackedPath::bundled(start, 2.0, 0.0).unwrap();
        let (pa, pb) = (a.pose(3.0), b.pose(3.0));
        assert!((pb.position - 2.0 * pa.position).length() < 1e-9);
        assert!(pa.orientation.dot(pb.orientation).abs() > 1.0 - 1e-12);
    }

    #[test]
    fn nan_time_is_the_start_and_no_records_an_error() {
        let recs =
            [(0.0, Pose::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y)), (1.0, Pose::look_at(DVec3::X, DVec3::Z, DVec3::Y))];
        let start = Pose::look_at(DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 1.0, 5.0), DVec3::Y);
        let p = TrackedPath::from_records(&recs, start, 1.0, 0.0).unwrap();
        assert_eq!(p.pose(f64::NAN), p.pose(0.0));
        assert_eq!(p.pose(f64::INFINITY), p.pose(1.0));
        assert!(TrackedPath::from_records(&[], start, 1.0, 0.0).unwrap_err().contains("no poses"));
        assert!(TrackedPath::from_records(&recs, start, 1.0, f64::NAN).is_ok(), "NaN skip is no skip");
        let backwards = [recs[1], recs[0]];
        assert!(TrackedPath::from_records(&backwards, start, 1.0, 0.0).unwrap_err().contains("must increase"));
        let nan = [recs[0], (f64::NAN, recs[1].1)];
        assert!(TrackedPath::from_records(&nan, start, 1.0, 0.0).unwrap_err().contains("pose 1"));
    }

    #[test]
    fn bad_records_are_errors() {
        assert!(parse_tum("1 2 3", "x").unwrap_err().contains("x:1"));
        assert!(parse_tum("1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1", "x").unwrap_err().contains("increase"));
    }
}
