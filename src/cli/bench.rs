//! `postwarp bench`: host time of the standard frames, per engine and per
//! whole process, the figures users quote (docs/performance.md).
//!
//! Rules:
//! 1. Engine rows time one call on frames already in memory, in a
//!    one-thread pool (as `cargo bench` does): `golden` is
//!    `Warper::warp_frame` on the A-buffered references (at the host's
//!    widest vector level, and again as `golden baseline-instructions` at
//!    the build's baseline: `golden::vector_level`), `forward-splat`
//!    is `forward_splat_with` on the same references and 1/Z planes,
//!    `hardware-model` is `Engine::run_frame` (preset mark1998) on the
//!    references packed once, as the engine runs by default (its
//!    look-ahead threads on a multi-core host: 2 threads), and
//!    `hardware-model one-thread` the same with `Engine::look_ahead(false)`.
//!    Their samples are the valid samples of both references after the
//!    A-buffer.
//! 2. Process rows time a child process of this same binary from spawn to
//!    exit with every core: `golden` on the real pair (`--real-pair`,
//!    default `traces/motorcycle`), without and with `--flip` (what
//!    scoring FLIP costs), and on the standard frame written as a
//!    one-frame trace, `simulate` on that trace. Their samples are all
//!    samples of the references the trace's derived frames warp (summed
//!    over frames); peak RSS is the child's own `VmHWM` (it writes it at
//!    exit into the file [`PEAK_RSS_ENV`] names), and bytes per reference sample divide it by the largest number of
//!    reference samples one derived frame warps.
//! 3. Each measurement runs `--repeats` times (after one untimed warm-up
//!    for engine rows); best and median are printed. Samples per second
//!    use the best time.
//! 4. `--hmd` adds one process row, run once: `simulate --preset hmd2026`
//!    of derived frame [`crate::bench::FRAME`] at the headset's display
//!    size ([`crate::bench::hmd_spec`]; 200x200 with `--quick`), written
//!    into the scratch directory and deleted after (the peak RSS of the
//!    headset case).
//! 5. The last line splits `engine golden` by phase
//!    (`golden::phase_times`): the mean over `--repeats` more frames with
//!    the phase timers on (after a warm-up frame), run after its row so
//!    that the row holds no timer; `other` is the frames' time outside
//!    every phase.

use crate::bench::{BenchFrame, quick_spec, standard_spec};
use crate::golden::config::GoldenConfig;
use crate::golden::frame::{PreparedReference, Warper, inv_z_plane, prepare_reference};
use crate::golden::phase_times;
use crate::golden::vector_level::VectorLevel;
use crate::methods::baselines::forward_splat::forward_splat_with;
use crate::trace::Trace;
use anyhow::Context;
use postwarp_rtl::SampleImage;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::{Engine, HwReference};
use std::ffi::OsString;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Flags of `postwarp bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Runs of each measurement; best and median are printed [default: 5, 2 with --quick].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: Option<u32>,
    /// A small synthetic frame (160x120 with 2x2 samples) instead of the
    /// 640x480 one, for tests; the real pair is unchanged.
    #[arg(long)]
    pub quick: bool,
    /// The real pair timed as a whole `golden` process (a trace directory).
    #[arg(long, default_value = "traces/motorcycle")]
    pub real_pair: PathBuf,
    /// Also time one whole `simulate --preset hmd2026` of a frame of the
    /// headset's size (2000x2000 pixels, 2x2 samples, the standard frame's
    /// scene and path), rendered here and deleted after: about 80 M
    /// reference samples, minutes and several GB. Runs once. With
    /// --quick, a 200x200 frame on the same preset (for tests).
    #[arg(long)]
    pub hmd: bool,
}

/// Best and median of repeated timings (seconds).
#[derive(Clone, Copy, Debug)]
struct Times {
    best: f64,
    median: f64,
}

impl Times {
    fn of(mut t: Vec<f64>) -> Times {
        t.sort_by(f64::total_cmp);
        let n = t.len();
        let median = if n % 2 == 1 { t[n / 2] } else { (t[n / 2 - 1] + t[n / 2]) / 2.0 };
        Times { best: t[0], median }
    }
}

/// One row of the printed table.
struct Row {
    what: String,
    input: String,
    threads: usize,
    times: Times,
    samples: u64,
    /// Peak RSS (bytes) and the reference samples it is divided by.
    peak: Option<(u64, u64)>,
}

/// Time `f` `n` times (after one untimed run if `warm`).
fn repeat(n: u32, warm: bool, mut f: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<Times> {
    if warm {
        f()?;
    }
    let mut t = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64());
    }
    Ok(Times::of(t))
}

/// The 1-, 5- and 15-minute load averages (`/proc/loadavg`), if readable.
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".into())
}

/// A scratch directory removed when dropped.
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run this binary with `args` to completion; its wall time and peak RSS
/// (bytes, as the child reports it through [`PEAK_RSS_ENV`]). Standard output is discarded,
/// standard error kept in `log` and quoted on failure.
fn run_child(args: &[OsString], log: &Path) -> anyhow::Result<(f64, Option<u64>)> {
    let exe = std::env::current_exe().context("postwarp bench: cannot find its own executable")?;
    let err = std::fs::File::create(log).with_context(|| format!("creating {}", log.display()))?;
    let peak_file = log.with_extension("peak");
    let _ = std::fs::remove_file(&peak_file);
    let t = Instant::now();
    let child = std::process::Command::new(&exe)
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(err)
        .env(PEAK_RSS_ENV, &peak_file)
        .spawn()
        .with_context(|| format!("cannot run {}", exe.display()))?;
    let status = child.wait_with_output().context("waiting for a child process")?.status;
    let s = t.elapsed().as_secs_f64();
    let ok = status.success();
    let peak = std::fs::read_to_string(&peak_file).ok().and_then(|t| t.trim().parse::<u64>().ok());
    if !ok {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        let cmd: Vec<String> = args.iter().map(|a| a.to_string_lossy().into_owned()).collect();
        anyhow::bail!("`postwarp {}` failed:\n{}", cmd.join(" "), text.trim_end());
    }
    Ok((s, peak))
}

/// Environment variable naming a file into which a `postwarp` process
/// writes its peak RSS (bytes, `VmHWM` of `/proc/self/status`) when it
/// ends. `postwarp bench` sets it for its children: `getrusage` of a child
/// would include the pages it shared with this (larger) process at fork.
pub const PEAK_RSS_ENV: &str = "POSTWARP_PEAK_RSS_FILE";

/// This process's peak RSS (bytes), where `/proc/self/status` reports it.
pub fn peak_rss() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.trim_start_matches("VmHWM:").trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kib * 1024)
}

/// Write [`peak_rss`] (decimal bytes, or nothing if unknown) to `file`.
pub fn write_peak_rss(file: &Path) {
    let text = peak_rss().map(|b| b.to_string()).unwrap_or_default();
    if let Err(e) = std::fs::write(file, text) {
        eprintln!("warning: {}: cannot write the peak RSS: {e}", file.display());
    }
}

/// Samples of the references each derived frame of `t` warps: the sum over
/// frames and the largest one frame warps.
fn trace_samples(t: &Trace) -> (u64, u64) {
    let ss = t.display.supersample as u64;
    let per_frame: Vec<u64> = t
        .derived
        .iter()
        .map(|f| {
            f.references
                .iter()
                .map(|&r| {
                    let k = &t.references[r].camera.intrinsics;
                    k.width as u64 * k.height as u64 * ss * ss
                })
                .sum()
        })
        .collect();
    (per_frame.iter().sum(), per_frame.iter().copied().max().unwrap_or(0))
}

/// Time whole processes `postwarp <cmd> TRACE --out DIR --force <extra>`.
fn process_row(
    cmd: &str,
    extra: &[&str],
    trace_path: &Path,
    input: String,
    scratch: &Path,
    repeats: u32,
    threads: usize,
) -> anyhow::Result<Row> {
    let trace = Trace::open(trace_path)?;
    let (samples, per_frame) = trace_samples(&trace);
    let out = scratch.join(format!("out-{cmd}"));
    let mut args: Vec<OsString> = vec![cmd.into(), trace_path.into(), "--out".into(), out.into(), "--force".into()];
    args.extend(extra.iter().map(OsString::from));
    let log = scratch.join(format!("{cmd}.log"));
    let mut peak = 0u64;
    let mut have_peak = false;
    let times = repeat(repeats, false, || {
        let (_, p) = run_child(&args, &log)?;
        if let Some(p) = p {
            peak = peak.max(p);
            have_peak = true;
        }
        Ok(())
    })?;
    Ok(Row {
        what: format!("process {cmd}{}", if extra.contains(&"--flip") { " --flip" } else { "" }),
        input,
        threads,
        times,
        samples,
        peak: have_peak.then_some((peak, per_frame)),
    })
}

fn fmt_row(r: &Row) -> String {
    let rate = r.samples as f64 / r.times.best / 1e6;
    let (mb, per) = match r.peak {
        Some((b, n)) if n > 0 => (format!("{:.1}", b as f64 / 1e6), format!("{:.1}", b as f64 / n as f64)),
        _ => ("-".into(), "-".into()),
    };
    format!(
        "| {} | {} | {} | {:.4} | {:.4} | {:.2} | {} | {} |",
        r.what, r.input, r.threads, r.times.best, r.times.median, rate, mb, per
    )
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let repeats = a.repeats.unwrap_or(if a.quick { 2 } else { 5 });
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    anyhow::ensure!(
        a.real_pair.exists(),
        "{}: no such trace; run from the repository (traces/motorcycle is bundled) or pass --real-pair DIR",
        a.real_pair.display()
    );
    let load_before = load();
    let spec = if a.quick { quick_spec() } else { standard_spec() };
    let frame = BenchFrame::new(spec)?;
    let frame_name = format!(
        "{} {}x{} {}x{} frame {}",
        crate::bench::SCENE,
        frame.spec.width,
        frame.spec.height,
        frame.spec.supersample,
        frame.spec.supersample,
        crate::bench::FRAME
    );
    let mut rows = Vec::new();

    // Engines, one thread (the hardware model also as it runs by default),
    // frames in memory.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().context("one-thread pool")?;
    let gcfg = GoldenConfig::default();
    let prepared: Vec<PreparedReference> =
        frame.refs.iter().map(|img| prepare_reference(img, frame.spec.supersample, &gcfg)).collect();
    let valid: u64 = prepared.iter().map(|p| p.samples.valid.count_ones() as u64).sum();
    // The level `engine golden` runs at (`Warper::new` detects the same).
    let level = VectorLevel::detect();
    let time_golden = |baseline: bool| -> anyhow::Result<Row> {
        let refs: Vec<&PreparedReference> = prepared.iter().collect();
        let mut warper = Warper::new();
        warper.baseline_instructions(baseline);
        let t = pool.install(|| {
            repeat(repeats, true, || {
                black_box(warper.warp_frame(&frame.cmd, &refs, &gcfg));
                Ok(())
            })
        })?;
        let what = if baseline { "engine golden baseline-instructions" } else { "engine golden" };
        Ok(Row { what: what.into(), input: frame_name.clone(), threads: 1, times: t, samples: valid, peak: None })
    };
    rows.push(time_golden(false)?);
    // Where its time goes: as many frames again with the phase timers on
    // (after the row, so its figures hold no timer).
    let (phases, phases_total) = {
        let refs: Vec<&PreparedReference> = prepared.iter().collect();
        let mut warper = Warper::new();
        pool.install(|| {
            // Warmed up as the row was: buffers grown before the timers run.
            black_box(warper.warp_frame(&frame.cmd, &refs, &gcfg));
            phase_times::enable(true);
            phase_times::take();
            let t = Instant::now();
            for _ in 0..repeats {
                black_box(warper.warp_frame(&frame.cmd, &refs, &gcfg));
            }
            let total = t.elapsed().as_secs_f64();
            phase_times::enable(false);
            (phase_times::take(), total)
        })
    };
    {
        let refs: Vec<&SampleImage> = prepared.iter().map(|p| &p.samples).collect();
        // The splat's input: each reference's 1/Z plane, made outside the timing.
        let planes: Vec<Vec<f64>> = prepared.iter().map(|p| inv_z_plane(&p.samples)).collect();
        let inv_z: Vec<&[f64]> = planes.iter().map(Vec::as_slice).collect();
        let t = pool.install(|| {
            repeat(repeats, true, || {
                black_box(forward_splat_with(&frame.cmd, &refs, &inv_z));
                Ok(())
            })
        })?;
        rows.push(Row {
            what: "engine forward-splat".into(),
            input: frame_name.clone(),
            threads: 1,
            times: t,
            samples: valid,
            peak: None,
        });
    }
    rows.push(time_golden(true)?);
    drop(prepared);
    {
        let cfg = EngineConfig::default();
        let hw: Vec<HwReference> = frame.refs.iter().map(|i| HwReference::new(i, &cfg)).collect();
        let hw: Vec<&HwReference> = hw.iter().collect();
        let mut engine = Engine::new(cfg).map_err(|e| anyhow::anyhow!("mark1998: {e}"))?;
        // As the engine runs by default (kernel setup's lines computed on
        // another thread where there is a second core), then all on one.
        let ahead = engine.looks_ahead();
        for (what, look_ahead, threads) in [
            ("engine hardware-model", ahead, if ahead { 2 } else { 1 }),
            ("engine hardware-model one-thread", false, 1),
        ] {
            engine.look_ahead(look_ahead);
            let t = pool.install(|| {
                repeat(repeats, true, || {
                    black_box(engine.run_frame(&frame.cmd, &hw).stats.cycles);
                    Ok(())
                })
            })?;
            rows.push(Row {
                what: what.into(),
                input: frame_name.clone(),
                threads,
                times: t,
                samples: valid,
                peak: None,
            });
        }
    }

    // Whole processes of this binary.
    let scratch = Scratch(std::env::temp_dir().join(format!("postwarp-bench-{}", std::process::id())));
    let _ = std::fs::remove_dir_all(&scratch.0);
    std::fs::create_dir_all(&scratch.0).with_context(|| format!("creating {}", scratch.0.display()))?;
    let frame_trace = frame.write_trace(&scratch.0.join("frame-trace"))?;
    drop(frame);
    let real = Trace::open(&a.real_pair)?;
    let real_name = format!(
        "{} {}x{} {}x{}",
        a.real_pair.display(),
        real.display.width,
        real.display.height,
        real.display.supersample,
        real.display.supersample
    );
    rows.push(process_row("golden", &[], &a.real_pair, real_name.clone(), &scratch.0, repeats, cores)?);
    rows.push(process_row("golden", &["--flip"], &a.real_pair, real_name, &scratch.0, repeats, cores)?);
    rows.push(process_row("golden", &[], &frame_trace, frame_name.clone(), &scratch.0, repeats, cores)?);
    rows.push(process_row("simulate", &[], &frame_trace, frame_name, &scratch.0, repeats, cores)?);
    if a.hmd {
        let spec = crate::bench::hmd_spec(a.quick);
        let name = format!(
            "{} {}x{} {}x{} frame {}, preset hmd2026",
            crate::bench::SCENE,
            spec.width,
            spec.height,
            spec.supersample,
            spec.supersample,
            crate::bench::FRAME
        );
        let trace = BenchFrame::new(spec)?.write_trace(&scratch.0.join("hmd-trace"))?;
        let row = process_row("simulate", &["--preset", "hmd2026"], &trace, name, &scratch.0, 1, cores)?;
        std::fs::remove_dir_all(scratch.0.join("hmd-trace")).ok();
        rows.push(row);
    }

    println!(
        "postwarp bench: {cores} cores, {repeats} repeats per row; load average {load_before} before, {} after; \
         golden warps at vector level {}",
        load(),
        level.name()
    );
    println!(
        "| row | input | threads | best s | median s | M samples/s (best) | peak RSS MB | peak B per reference sample |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!("{}", fmt_row(r));
    }
    let ratio = rows[1].times.best / rows[0].times.best;
    println!("golden/forward-splat throughput ratio: {ratio:.3} (best times, same frame, one thread)");
    let baseline = rows[2].times.best;
    println!(
        "golden at the baseline level: {:.3} of the splat's throughput; the widest level ({}) takes {:.3} of its time",
        rows[1].times.best / baseline,
        level.name(),
        rows[0].times.best / baseline
    );
    let ms = |s: f64| format!("{:.2}", s * 1e3 / repeats as f64);
    let mut split: Vec<String> = phases.iter().map(|(p, s)| format!("{} {}", p.name(), ms(*s))).collect();
    let timed: f64 = phases.iter().map(|p| p.1).sum();
    split.push(format!("{} {}", phase_times::OTHER, ms((phases_total - timed).max(0.0))));
    println!("engine golden by phase, mean ms per frame over {repeats} more frames: {}", split.join(", "));
    Ok(())
}
