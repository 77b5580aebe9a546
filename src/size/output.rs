//! What `postwarp size` prints and writes: the configuration as TOML
//! (loadable by `postwarp simulate --config`), its cost, the candidates as
//! a table, and in `--out DIR`: `config.toml`, `size.json`,
//! `candidates.csv`.

use super::Outcome;
use super::candidate::{Candidate, Stage};
use crate::io_util::write_bytes_atomically;
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;

/// (column, unit, description) of `candidates.csv`, in order.
pub const CSV_COLUMNS: &[(&str, &str, &str)] = &[
    ("stage", "—", "quality (super-samples, fragments) or cache (cache, tile size)"),
    ("supersample", "samples", "super-samples per pixel along each axis"),
    ("abuffer_fragments", "fragments/pixel", "A-buffer fragments per pixel in memory"),
    ("tile_size_samples", "samples", "side of a destination tile"),
    ("dest_cache_bytes", "bytes", "destination tile cache capacity"),
    ("dest_cache_tiles", "tiles", "destination tile cache capacity in tiles"),
    ("psnr_luma_db", "dB", "mean luma PSNR against ground truth"),
    ("ssim_luma", "1", "mean luma SSIM"),
    ("capacity_misses", "misses", "destination-cache capacity misses, all frames"),
    ("cycles_per_frame", "cycles", "mean engine cycles per frame"),
    ("dram_bytes_per_frame", "bytes", "mean DRAM bytes read + written per frame"),
    ("dram_gbps_at_target_rate", "GB/s", "DRAM bandwidth at target_frame_rate_hz, every view"),
    ("frame_rate_at_clock_hz", "Hz", "frames per second at clock_hz, every view"),
    ("golden_identical_frames", "frames", "frames bit-identical to the golden model"),
    ("passes", "—", "met the stage's test (quality floor; no capacity misses)"),
    ("chosen", "—", "the configuration reported"),
];

fn opt(x: Option<f64>) -> String {
    x.map_or(String::new(), |v| format!("{v}"))
}

/// `candidates.csv` text.
pub fn csv(o: &Outcome) -> String {
    let mut s = CSV_COLUMNS.iter().map(|c| c.0).collect::<Vec<_>>().join(",") + "\n";
    for (i, c) in o.candidates.iter().enumerate() {
        let stage = match c.stage {
            Stage::Quality => "quality",
            Stage::Cache => "cache",
        };
        let _ = writeln!(
            s,
            "{stage},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            c.supersample,
            c.abuffer_fragments,
            c.tile_size,
            c.dest_cache_bytes,
            c.dest_cache_tiles,
            opt(c.psnr_luma_db),
            opt(c.ssim_luma),
            c.capacity_misses,
            c.cycles_per_frame,
            c.dram_bytes_per_frame,
            c.dram_gbps_at_target_rate,
            c.frame_rate_at_clock_hz,
            c.golden_identical_frames,
            c.passes,
            o.chosen == Some(i),
        );
    }
    s
}

/// What the chosen configuration's quality figure was scored against, as
/// lines of text (the config file's header and the printed report).
pub fn scored_against(o: &Outcome) -> Vec<String> {
    let (Some(i), Some(c)) = (o.chosen, o.config.as_ref()) else { return Vec::new() };
    let q = &o.candidates[i];
    // A path in the output folder is named relative to it (the folder can
    // move; the files stay the same bytes wherever it is).
    let shown = |p: &std::path::Path| match o.out.as_deref().and_then(|d| p.strip_prefix(d).ok()) {
        Some(rest) => format!("{} (in the output folder)", rest.display()),
        None => p.display().to_string(),
    };
    let on = o.scored_on().map_or_else(|| o.trace.display().to_string(), shown);
    let (truth_ss, truth_dir) = (&o.truth.0, shown(&o.truth.1));
    let mut v = vec![format!(
        "quality: mean luma PSNR {:.3} dB, SSIM {:.4} over {} frames, measured by `postwarp simulate`'s code on the \
             trace {on} ({}x{} super-samples) against the ground truth of {truth_dir} (rendered at {truth_ss}x{truth_ss})",
        q.psnr_luma_db.unwrap_or(f64::NAN),
        q.ssim_luma.unwrap_or(f64::NAN),
        q.frames,
        c.supersample,
        c.supersample,
    )];
    let own = o.own_supersample;
    if o.scored_on() == Some(o.truth.1.as_path()) {
        v.push(format!("reproduce: postwarp simulate {on} --config config.toml --out OUT"));
    } else if c.supersample == own {
        v.push(format!(
            "`postwarp simulate {on} --config config.toml` scores against that trace's own ground truth \
             ({own}x{own}) instead, so it can report another figure"
        ));
    } else {
        v.push(format!(
            "`postwarp simulate {on} --config config.toml` scores against that trace's own ground truth instead; on \
             {} it runs at the trace's {own}x{own} super-samples; either can report another figure",
            o.trace.display()
        ));
    }
    v
}

/// The configuration as TOML for `postwarp simulate --config`.
pub fn toml(o: &Outcome) -> Option<String> {
    let c = o.config.as_ref()?;
    let mut s = String::new();
    let _ = writeln!(s, "# postwarp size {}: {}", o.trace.display(), o.floor.describe());
    for line in scored_against(o) {
        let _ = writeln!(s, "# {line}");
    }
    let _ =
        writeln!(s, "# simulate it on a trace with supersample = {} (the trace's super-sampling wins)", c.supersample);
    let _ = writeln!(s, "preset = \"{}\"", o.preset);
    let _ = writeln!(s, "supersample = {}", c.supersample);
    let _ = writeln!(s, "abuffer_fragments = {}", c.abuffer_fragments);
    let _ = writeln!(s, "tile_size = {}", c.tile_size);
    let _ = writeln!(s, "dest_cache_bytes = {}", c.dest_cache_bytes);
    Some(s)
}

fn row(s: &mut String, c: &Candidate, chosen: bool) {
    let _ = writeln!(
        s,
        "{:>7} {:>3} {:>5} {:>5} {:>9.2} {:>6} {:>9.3} {:>7.4} {:>8} {:>10.0} {:>8.3} {:>9.1} {:>5}",
        match c.stage {
            Stage::Quality => "quality",
            Stage::Cache => "cache",
        },
        c.supersample,
        c.abuffer_fragments,
        c.tile_size,
        c.dest_cache_bytes as f64 / 1024.0,
        c.dest_cache_tiles,
        c.psnr_luma_db.unwrap_or(f64::NAN),
        c.ssim_luma.unwrap_or(f64::NAN),
        c.capacity_misses,
        c.cycles_per_frame,
        c.dram_gbps_at_target_rate,
        c.frame_rate_at_clock_hz,
        if chosen {
            "<=="
        } else if c.passes {
            "yes"
        } else {
            "no"
        }
    );
}

/// The printed report.
pub fn text(o: &Outcome) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "trace: {}", o.trace.display());
    let _ = writeln!(s, "{}", o.ss_source.describe(&o.supersamples));
    let _ = writeln!(s, "floor: {}; other knobs: preset {}", o.floor.describe(), o.preset);
    let _ = writeln!(s, "candidates (in order run; pass = meets the floor (quality) / no capacity misses (cache)):");
    let _ = writeln!(
        s,
        "{:>7} {:>3} {:>5} {:>5} {:>9} {:>6} {:>9} {:>7} {:>8} {:>10} {:>8} {:>9} {:>5}",
        "stage",
        "ss",
        "frags",
        "tile",
        "cache_KiB",
        "tiles",
        "psnr_luma",
        "ssim",
        "cap_miss",
        "cycles",
        "GB/s@tgt",
        "fps@clk",
        "pass"
    );
    for (i, c) in o.candidates.iter().enumerate() {
        row(&mut s, c, o.chosen == Some(i));
    }
    if let (Some(i), Some(t)) = (o.chosen, toml(o)) {
        let c = &o.candidates[i];
        let _ = writeln!(s, "\nsmallest configuration:\n{t}");
        for line in scored_against(o) {
            let _ = writeln!(s, "{line}");
        }
        let _ = writeln!(
            s,
            "needs: {:.0} cycles per frame, {:.3} GB/s of DRAM at {} Hz x {} views, {:.1} frames per second at {} MHz; mean luma PSNR {:.3} dB, SSIM {:.4}",
            c.cycles_per_frame,
            c.dram_gbps_at_target_rate,
            o.config.as_ref().map_or(0.0, |c| c.target_frame_rate_hz),
            o.config.as_ref().map_or(0, |c| c.views),
            c.frame_rate_at_clock_hz,
            o.config.as_ref().map_or(0, |c| c.clock_hz) as f64 / 1e6,
            c.psnr_luma_db.unwrap_or(f64::NAN),
            c.ssim_luma.unwrap_or(f64::NAN),
        );
    }
    if let Some(b) = &o.budget {
        s.push_str(&crate::report::budget::text(b));
    }
    s
}

/// `size.json` contents.
pub fn json(o: &Outcome) -> serde_json::Value {
    json!({
        "trace": o.trace.display().to_string(),
        "floor": {"min_psnr_db": o.floor.min_psnr_db, "min_ssim": o.floor.min_ssim},
        "preset": o.preset,
        "supersamples": o.supersamples,
        "supersample_source": match &o.ss_source {
            super::SsSource::Regenerated { command, .. } => json!({"regenerated_from": command}),
            super::SsSource::Fixed { reason } => json!({"fixed": reason}),
        },
        "config": o.config.as_ref().map(crate::run::hw_config_toml::to_json),
        "scored_against": scored_against(o),
        "chosen": o.chosen.map(|i| &o.candidates[i]),
        "budget": o.budget.as_ref().map(crate::report::budget::to_json),
        "candidates": o.candidates,
    })
}

/// Write `candidates.csv`, `size.json` and (if found) `config.toml` into `dir`.
pub fn write_files(o: &Outcome, dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    write_bytes_atomically(&dir.join("candidates.csv"), csv(o).as_bytes())?;
    let j = serde_json::to_string_pretty(&json(o))? + "\n";
    write_bytes_atomically(&dir.join("size.json"), j.as_bytes())?;
    if let Some(t) = toml(o) {
        write_bytes_atomically(&dir.join("config.toml"), t.as_bytes())?;
    }
    Ok(())
}
