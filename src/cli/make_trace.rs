//! `postwarp make-trace`: render a scene into a trace.

use crate::scene::Scene;
use crate::tracegen::{PathKind, TraceSpec, make_trace};
use std::path::PathBuf;

/// Flags of `postwarp make-trace` (defaults follow the paper's test-bed).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Built-in scene name (room, slants, hairball, occluders) or a scene
    /// description file (TOML, see docs/scene-format.md).
    #[arg(long)]
    pub scene: String,
    /// Output trace directory (must not exist, unless --force; written
    /// under a temporary name beside it and renamed when complete).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace --out if it exists: its contents are removed, not mixed with
    /// this run's (the new folder takes its place only when complete).
    #[arg(long)]
    pub force: bool,
    /// Display width (pixels).
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// Display height (pixels).
    #[arg(long, default_value_t = 240)]
    pub height: u32,
    /// Super-samples per pixel along each axis (1 to 4).
    #[arg(long, default_value_t = 2)]
    pub supersample: u32,
    /// Number of derived frames.
    #[arg(long, default_value_t = 15)]
    pub frames: usize,
    /// Camera path: the scene's spline, or the bundled real hand-held
    /// trajectory placed at the scene's start pose.
    #[arg(long, value_enum, default_value_t = PathKind::Spline)]
    pub path: PathKind,
    /// Display horizontal field of view (degrees).
    #[arg(long, default_value_t = 60.0)]
    pub display_hfov: f64,
    /// Reference field of view HxV (degrees); the paper's kitchen used 88x68.
    #[arg(long, default_value = "88x68", value_parser = parse_fov)]
    pub ref_fov: (f64, f64),
    /// Reference frame rate (Hz).
    #[arg(long, default_value_t = 5.0)]
    pub ref_rate: f64,
    /// Derived frame rate (Hz).
    #[arg(long, default_value_t = 30.0)]
    pub derived_rate: f64,
    /// Prediction interval for reference viewpoints (seconds); 0 puts
    /// references exactly on the path.
    #[arg(long, default_value_t = 0.4)]
    pub prediction: f64,
    /// Path time of the first derived frame (seconds); at least the
    /// prediction interval, so the first reference is predicted from real
    /// motion.
    #[arg(long, default_value_t = 0.5)]
    pub start: f64,
    /// Do not render ground truth.
    #[arg(long)]
    pub no_truth: bool,
}

fn parse_fov(s: &str) -> Result<(f64, f64), String> {
    let (h, v) = s.split_once('x').ok_or_else(|| format!("`{s}`: expected HxV degrees, e.g. 88x68"))?;
    let p = |x: &str| x.trim().parse::<f64>().map_err(|_| format!("`{x}` is not a number of degrees"));
    Ok((p(h)?, p(v)?))
}

impl Args {
    /// The trace specification these flags describe.
    pub fn spec(&self) -> TraceSpec {
        TraceSpec {
            width: self.width,
            height: self.height,
            supersample: self.supersample,
            frames: self.frames,
            path: self.path,
            display_hfov_deg: self.display_hfov,
            ref_fov_deg: self.ref_fov,
            ref_rate_hz: self.ref_rate,
            derived_rate_hz: self.derived_rate,
            prediction_s: self.prediction,
            start_s: self.start,
            truth: !self.no_truth,
            ..TraceSpec::default()
        }
    }
}

/// The `make-trace` flags of a command line as written in a trace's
/// `note made by:` line (`postwarp make-trace --scene ...`), or `None` if
/// it is not one or does not parse.
pub fn parse_made_by(command: &str) -> Option<Args> {
    #[derive(clap::Parser)]
    struct Line {
        #[command(flatten)]
        args: Args,
    }
    use clap::Parser as _;
    let words: Vec<&str> = command.split_whitespace().collect();
    let rest = match words.as_slice() {
        [p, "make-trace", rest @ ..] if p.ends_with("postwarp") => rest,
        _ => return None,
    };
    Line::try_parse_from(std::iter::once("make-trace").chain(rest.iter().copied())).ok().map(|l| l.args)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    // A path is opened only if it is a regular file (a FIFO would block
    // the scene reader); the scene's own errors name it, once.
    let as_path = std::path::Path::new(&a.scene);
    if Scene::builtin_source(&a.scene).is_none() && std::fs::symlink_metadata(as_path).is_ok() {
        crate::io_util::check_input_file(as_path, "scene description (TOML, docs/scene-format.md)")?;
    }
    let scene = Scene::load(&a.scene)?;
    let spec = a.spec();
    let command = std::iter::once("postwarp".to_string()).chain(std::env::args().skip(1)).collect::<Vec<_>>().join(" ");
    let start = std::time::Instant::now();
    let scene_file = std::path::Path::new(&a.scene);
    let inputs: &[&std::path::Path] = if scene_file.is_file() { &[scene_file] } else { &[] };
    let out = crate::io_util::OutDir::create(&a.out, a.force, inputs)?;
    let manifest = make_trace(&scene, &spec, out.path(), &command)?;
    // Write a PNG preview of each reference and ground-truth frame beside the trace.
    crate::cli::import::write_previews(&manifest)?;
    let dir = out.commit()?;
    eprintln!("wrote {} in {:.1} s", dir.join(crate::trace::MANIFEST_NAME).display(), start.elapsed().as_secs_f64());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn made_by_lines_give_back_the_flags() {
        let a = parse_made_by(
            "postwarp make-trace --scene room --out traces/room --width 128 --height 96 --frames 6 --ref-fov 75x52",
        )
        .unwrap();
        let s = a.spec();
        assert_eq!((a.scene.as_str(), s.width, s.height, s.frames, s.supersample), ("room", 128, 96, 6, 2));
        assert_eq!(s.ref_fov_deg, (75.0, 52.0));
        assert!(parse_made_by("postwarp import-middlebury --in x --out y").is_none());
        assert!(parse_made_by("postwarp make-trace --scene room --bogus 1").is_none());
    }
}
