//! The keys of a generated trace in a sweep specification (`[[traces]]`
//! with `scene = ...`): each sets one [`TraceSpec`] field, with the unit
//! and default of `postwarp make-trace`.

use crate::tracegen::{PathKind, TraceSpec};

/// (key, unit, description, `results.csv` column) of every
/// generated-trace key besides `scene` and `name`, in canonical order (axes
/// multiply in this order, and the columns follow it).
pub const TRACE_FIELDS: &[(&str, &str, &str, &str)] = &[
    ("width", "pixels", "display width", "width_pixels"),
    ("height", "pixels", "display height", "height_pixels"),
    ("supersample", "samples", "super-samples per pixel along each axis (1 to 4)", "supersample"),
    ("frames", "frames", "derived frames", "frames"),
    ("camera_path", "spline|tracked", "the scene's spline, or the bundled hand-held trajectory", "camera_path"),
    ("display_hfov", "degrees", "display horizontal field of view", "display_hfov_deg"),
    ("ref_hfov", "degrees", "reference horizontal field of view", "ref_hfov_deg"),
    ("ref_vfov", "degrees", "reference vertical field of view", "ref_vfov_deg"),
    ("ref_rate", "Hz", "reference frame rate", "ref_rate_hz"),
    ("derived_rate", "Hz", "derived frame rate", "derived_rate_hz"),
    ("prediction", "s", "prediction interval of reference viewpoints", "prediction_s"),
    ("start", "s", "path time of the first derived frame", "start_s"),
    ("truth", "bool", "render ground truth (without it no quality is scored)", "truth"),
    (
        "derived_offset_x",
        "scene units",
        "stress: derived camera moved right of its path pose (camera x)",
        "derived_offset_x_units",
    ),
    (
        "derived_offset_y",
        "scene units",
        "stress: derived camera moved down from its path pose (camera y)",
        "derived_offset_y_units",
    ),
    (
        "derived_offset_z",
        "scene units",
        "stress: derived camera moved forward along its view axis (camera z)",
        "derived_offset_z_units",
    ),
    (
        "derived_roll",
        "degrees",
        "stress: derived camera rolled about its view axis, in [-180, 180]",
        "derived_roll_deg",
    ),
    (
        "path_offset_y",
        "scene units",
        "stress: every camera (references and derived) moved up along world y",
        "path_offset_y_units",
    ),
    (
        "depth_bits",
        "bits",
        "stress: reference depth (1/z) quantised to this many bits, 0 = exact (0 to 24)",
        "depth_bits",
    ),
    (
        "depth_range_scale",
        "factor",
        "stress: quantised 1/z range as a multiple of the reference's own (needs depth_bits)",
        "depth_range_scale",
    ),
    (
        "rod_radius_scale",
        "factor",
        "stress: radius of the scene's rods multiplied by this (0 to 50)",
        "rod_radius_scale",
    ),
    (
        "rod_scale",
        "factor",
        "stress: the scene's rods scaled about their centre, radius and all (0 to 50)",
        "rod_scale",
    ),
    (
        "nondiffuse_scale",
        "factor",
        "stress: mirror and glass share of the view, every window, mirror and glass object scaled about its base",
        "nondiffuse_scale",
    ),
];

/// The stress keys (the last of [`TRACE_FIELDS`]): hashed into a generated
/// trace's identity only when not at their default, so traces made before
/// they existed keep their directories.
pub const STRESS_FIELDS: &[&str] = &[
    "derived_offset_x",
    "derived_offset_y",
    "derived_offset_z",
    "derived_roll",
    "path_offset_y",
    "depth_bits",
    "depth_range_scale",
    "rod_radius_scale",
    "rod_scale",
    "nondiffuse_scale",
];

fn whole(v: &toml::Value, lo: u64, hi: u64, unit: &str) -> Result<u64, String> {
    match v.as_integer() {
        Some(n) if n >= 0 && (lo..=hi).contains(&(n as u64)) => Ok(n as u64),
        _ => Err(format!("expected a whole number of {unit} from {lo} to {hi}, got {v}")),
    }
}

fn real(v: &toml::Value) -> Result<f64, String> {
    v.as_float().or_else(|| v.as_integer().map(|n| n as f64)).ok_or_else(|| format!("expected a number, got {v}"))
}

fn in_range(v: &toml::Value, ok: impl Fn(f64) -> bool, what: &str) -> Result<f64, String> {
    let x = real(v)?;
    if x.is_finite() && ok(x) { Ok(x) } else { Err(format!("expected {what}, got {v}")) }
}

/// Set field `key` of `spec` from `v`; the error says what was expected.
pub fn set(spec: &mut TraceSpec, key: &str, v: &toml::Value) -> Result<(), String> {
    use crate::trace::{MAX_SIDE, MAX_SUPERSAMPLE};
    let fov = |v| in_range(v, |x| x > 0.0 && x < 179.0, "degrees in (0, 179)");
    match key {
        "width" => spec.width = whole(v, 1, MAX_SIDE.into(), "pixels")? as u32,
        "height" => spec.height = whole(v, 1, MAX_SIDE.into(), "pixels")? as u32,
        "supersample" => spec.supersample = whole(v, 1, MAX_SUPERSAMPLE.into(), "samples")? as u32,
        "frames" => spec.frames = whole(v, 1, 100_000, "frames")? as usize,
        "camera_path" => {
            spec.path = match v.as_str() {
                Some("spline") => PathKind::Spline,
                Some("tracked") => PathKind::Tracked,
                _ => return Err(format!("expected \"spline\" or \"tracked\", got {v}")),
            }
        }
        "display_hfov" => spec.display_hfov_deg = fov(v)?,
        "ref_hfov" => spec.ref_fov_deg.0 = fov(v)?,
        "ref_vfov" => spec.ref_fov_deg.1 = fov(v)?,
        "ref_rate" => spec.ref_rate_hz = in_range(v, |x| x > 0.0, "a positive rate in Hz")?,
        "derived_rate" => spec.derived_rate_hz = in_range(v, |x| x > 0.0, "a positive rate in Hz")?,
        "prediction" => spec.prediction_s = in_range(v, |x| x >= 0.0, "seconds >= 0")?,
        "start" => spec.start_s = in_range(v, |x| x >= 0.0, "seconds >= 0")?,
        "truth" => spec.truth = v.as_bool().ok_or_else(|| format!("expected true or false, got {v}"))?,
        "derived_offset_x" => spec.derived_offset[0] = in_range(v, |_| true, "a finite number of scene units")?,
        "derived_offset_y" => spec.derived_offset[1] = in_range(v, |_| true, "a finite number of scene units")?,
        "derived_offset_z" => spec.derived_offset[2] = in_range(v, |_| true, "a finite number of scene units")?,
        "derived_roll" => spec.derived_roll_deg = in_range(v, |x| x.abs() <= 180.0, "degrees in [-180, 180]")?,
        "path_offset_y" => spec.path_offset_y = in_range(v, |_| true, "a finite number of scene units")?,
        "depth_bits" => {
            spec.depth_bits = whole(v, 0, crate::tracegen::MAX_DEPTH_BITS.into(), "bits")? as u32;
        }
        "depth_range_scale" => {
            let max = crate::tracegen::MAX_DEPTH_RANGE_SCALE;
            spec.depth_range_scale = in_range(v, |x| (1.0..=max).contains(&x), &format!("a factor from 1 to {max}"))?;
        }
        "rod_radius_scale" | "rod_scale" => {
            let max = crate::tracegen::MAX_ROD_SCALE;
            let x = in_range(v, |x| x > 0.0 && x <= max, &format!("a factor in (0, {max}]"))?;
            if key == "rod_scale" { spec.rod_scale = x } else { spec.rod_radius_scale = x }
        }
        "nondiffuse_scale" => {
            let max = crate::tracegen::MAX_NONDIFFUSE_SCALE;
            spec.nondiffuse_scale = in_range(v, |x| x > 0.0 && x <= max, &format!("a factor in (0, {max}]"))?;
        }
        _ => return Err("not a trace field".into()),
    }
    Ok(())
}

/// The value of field `key` of `spec` as CSV text.
pub fn get(spec: &TraceSpec, key: &str) -> String {
    match key {
        "width" => spec.width.to_string(),
        "height" => spec.height.to_string(),
        "supersample" => spec.supersample.to_string(),
        "frames" => spec.frames.to_string(),
        "camera_path" => match spec.path {
            PathKind::Spline => "spline".into(),
            PathKind::Tracked => "tracked".into(),
        },
        "display_hfov" => spec.display_hfov_deg.to_string(),
        "ref_hfov" => spec.ref_fov_deg.0.to_string(),
        "ref_vfov" => spec.ref_fov_deg.1.to_string(),
        "ref_rate" => spec.ref_rate_hz.to_string(),
        "derived_rate" => spec.derived_rate_hz.to_string(),
        "prediction" => spec.prediction_s.to_string(),
        "start" => spec.start_s.to_string(),
        "truth" => spec.truth.to_string(),
        "derived_offset_x" => spec.derived_offset[0].to_string(),
        "derived_offset_y" => spec.derived_offset[1].to_string(),
        "derived_offset_z" => spec.derived_offset[2].to_string(),
        "derived_roll" => spec.derived_roll_deg.to_string(),
        "path_offset_y" => spec.path_offset_y.to_string(),
        "depth_bits" => spec.depth_bits.to_string(),
        "depth_range_scale" => spec.depth_range_scale.to_string(),
        "rod_radius_scale" => spec.rod_radius_scale.to_string(),
        "rod_scale" => spec.rod_scale.to_string(),
        "nondiffuse_scale" => spec.nondiffuse_scale.to_string(),
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_field_round_trips_and_bad_values_say_what_was_expected() {
        let mut s = TraceSpec::default();
        for (k, v) in [
            ("width", toml::Value::Integer(64)),
            ("height", toml::Value::Integer(48)),
            ("supersample", toml::Value::Integer(1)),
            ("frames", toml::Value::Integer(2)),
            ("camera_path", toml::Value::String("tracked".into())),
            ("display_hfov", toml::Value::Float(50.0)),
            ("ref_hfov", toml::Value::Integer(70)),
            ("ref_vfov", toml::Value::Float(50.5)),
            ("ref_rate", toml::Value::Float(10.0)),
            ("derived_rate", toml::Value::Integer(60)),
            ("prediction", toml::Value::Float(0.1)),
            ("start", toml::Value::Float(0.25)),
            ("truth", toml::Value::Boolean(false)),
        ] {
            set(&mut s, k, &v).unwrap();
            let back: toml::Value = match &v {
                toml::Value::String(x) => toml::Value::String(x.clone()),
                toml::Value::Boolean(b) => toml::Value::Boolean(*b),
                _ => get(&s, k).parse::<f64>().map(toml::Value::Float).unwrap(),
            };
            assert_eq!(real(&back).ok(), real(&v).ok(), "{k}");
        }
        assert_eq!(TRACE_FIELDS.len(), 23);
        for (k, v) in [
            ("derived_offset_x", 0.5),
            ("derived_offset_z", -1.0),
            ("derived_roll", 30.0),
            ("path_offset_y", -1.0),
            ("depth_bits", 8.0),
            ("depth_range_scale", 1024.0),
            ("rod_radius_scale", 0.25),
            ("rod_scale", 4.0),
            ("nondiffuse_scale", 1.5),
        ] {
            let val = if k == "depth_bits" { toml::Value::Integer(v as i64) } else { toml::Value::Float(v) };
            set(&mut s, k, &val).unwrap();
            assert_eq!(get(&s, k).parse::<f64>().unwrap(), v, "{k}");
        }
        assert!(set(&mut s, "derived_roll", &toml::Value::Float(181.0)).unwrap_err().contains("[-180, 180]"));
        assert!(set(&mut s, "depth_bits", &toml::Value::Integer(25)).unwrap_err().contains("0 to 24"));
        assert!(set(&mut s, "depth_range_scale", &toml::Value::Float(0.5)).unwrap_err().contains("from 1"));
        assert!(set(&mut s, "rod_radius_scale", &toml::Value::Float(0.0)).unwrap_err().contains("(0, 50]"));
        assert!(s.validate().is_ok());
        assert!(set(&mut s, "width", &toml::Value::Integer(0)).unwrap_err().contains("pixels"));
        assert!(set(&mut s, "supersample", &toml::Value::Integer(5)).unwrap_err().contains("1 to 4"));
        assert!(set(&mut s, "camera_path", &toml::Value::String("x".into())).unwrap_err().contains("spline"));
        assert!(set(&mut s, "prediction", &toml::Value::Float(-1.0)).unwrap_err().contains(">= 0"));
        assert!(set(&mut s, "frames", &toml::Value::Float(1.5)).unwrap_err().contains("whole number"));
    }
}
