//! The SRAM and arithmetic budget (`docs/budget.md`) against its formulas
//! written out here from the knobs, not through `postwarp_rtl::budget`'s
//! helpers; `report.json` of `postwarp simulate` carries it with totals
//! that are the sums of its entries; `postwarp size` prints the SRAM total.

use postwarp_rtl::budget::{Budget, Sizes, StoreKind};
use postwarp_rtl::config::EngineConfig;
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bytes(entries: u64, bits: u64) -> u64 {
    (entries * bits).div_ceil(8)
}

/// Bits of a value in the test's own reading of the knobs (docs/budget.md,
/// "Widths"): FP32 planes and FP64 values between units in float mode; in
/// fixed mode a "Qm_n" format is m + n bits, a value between units the
/// widest of the geometry formats.
struct Bits {
    colour: u64,
    inv_z: u64,
    slope: u64,
    weight: u64,
    wide: u64,
}

fn bits_of(c: &EngineConfig) -> Bits {
    if c.arith != "fixed" {
        return Bits { colour: 32, inv_z: 32, slope: 32, weight: 32, wide: 64 };
    }
    let q = |f: &str| -> u64 {
        let (m, n) = f.trim_start_matches('Q').split_once('_').unwrap();
        m.parse::<u64>().unwrap() + n.parse::<u64>().unwrap()
    };
    let wide = [&c.q_position, &c.q_inv_z, &c.q_slope, &c.q_corner, &c.q_ref_inv_z].map(|f| q(f)).into_iter().max();
    Bits {
        colour: q(&c.q_colour),
        inv_z: q(&c.q_inv_z),
        slope: q(&c.q_slope),
        weight: q(&c.q_hole_weight),
        wide: wide.unwrap(),
    }
}

/// Every store's bytes by the documented formulas (docs/budget.md), for a
/// derived frame of `dw x dh` samples and reference lines of `line` samples.
fn expected(c: &EngineConfig, (dw, dh): (u64, u64), line: u64) -> Vec<(&'static str, bool, u64)> {
    let Bits { colour: cb, inv_z: iz, slope: sl, weight: wt, wide } = bits_of(c);
    let tile = c.tile_size as u64;
    let slots = c.dest_cache_bytes / (tile * tile * 16);
    let samples = slots * tile * tile;
    let frame_tiles = dw.div_ceil(tile) * dh.div_ceil(tile);
    let ss = c.supersample as u64;
    let f = c.abuffer_fragments as u64;
    let rate = c.rects_per_cycle as u64;
    let packed_tile = (tile / ss).pow(2) * (1 + 16 * f);
    let raw_tile = tile * tile * 16;
    // Kernel: line 32, sample 2x32, position 2 wide, 1/Z wide, box 4 wide,
    // colour and fill colour 3 colour each, reference 1/Z wide, slopes 2.
    let kernel = 32 + 2 * 32 + 2 * wide + wide + 4 * wide + 6 * cb + wide + 2 * sl;
    // Stamp: line 32, rect 4x64 + 2x32 + 1, candidate 3 colour + 1/Z + 2
    // slopes + 8 + 3 colour, sample 2x32, reference 1/Z wide, slopes 2,
    // mask 32 + 1, flag 1.
    let stamp = 32 + (256 + 64 + 1) + (6 * cb + iz + 2 * sl + 8) + 64 + wide + 2 * sl + 33 + 1;
    // Packer: fragment (3 colour, 1/Z, 2 slopes, mask 16, flag, key 32,
    // weight), 4 FP64 sums (the packer stays float), pixel count 32.
    let packer = (3 * cb + iz + 2 * sl + 16 + 1 + 32 + wt) + 4 * 64 + 32;
    vec![
        ("source_cache.data", true, c.source_cache_bytes),
        ("dest_cache.plane1_colour", true, bytes(samples, 3 * cb)),
        ("dest_cache.plane2_inv_z", true, bytes(samples, iz)),
        ("dest_cache.plane3_slopes", true, bytes(samples, 2 * sl)),
        ("dest_cache.plane4_source", true, bytes(samples, 8)),
        ("dest_cache.plane5_hole", true, bytes(samples, 1)),
        ("dest_cache.plane6_fill_colour", true, bytes(samples, 3 * cb)),
        ("dest_cache.plane7_fill_valid", true, bytes(samples, 1)),
        ("dest_cache.plane8_fill_distance", true, bytes(samples, 8)),
        ("dest_cache.plane9_fill_weight", true, bytes(samples, wt)),
        ("dest_cache.real", true, bytes(samples, 1)),
        ("dest_cache.tags", false, bytes(slots, 35)),
        ("line_buffer.warps", true, bytes(4 * line, 4 * wide + 1)),
        ("line_buffer.groups", true, bytes(4 * line, 2 + 2 * wide)),
        ("line_buffer.records", true, bytes(4 * line, wide + 2 * sl + 3 * cb + 32)),
        (
            "transform.pipeline",
            false,
            bytes(c.transform_throughput as u64 * (c.transform_latency as u64 + 1), 4 * 32 + wide + 2 * sl),
        ),
        ("kernel_fifo", false, bytes(2 * rate, kernel)),
        ("stamp_fifo", false, bytes(2 * rate, stamp)),
        ("composite.miss_queue", false, bytes(c.composite_miss_queue as u64, stamp + 128 + 3)),
        ("hole_fill.taps", false, bytes(c.hole_fill_per_cycle as u64 * 5, 3 * cb + 1 + 8 + 64)),
        ("hole_fill.dirty", false, if c.fallback_fill { bytes(frame_tiles, 1) } else { 0 }),
        ("tile_manager.retired", false, bytes(frame_tiles, 1)),
        ("packer.registers", false, if f == 0 { 0 } else { bytes(c.packer_pixels_per_cycle as u64 * ss * ss, packer) }),
        ("packer.write_buffer", true, 8 * packed_tile.max(raw_tile)),
    ]
}

fn check(c: &EngineConfig, b: &Budget, derived: (u64, u64), line: u64) {
    let want = expected(c, derived, line);
    let got: Vec<(&str, bool, u64)> = b.stores.iter().map(|s| (s.name, s.kind == StoreKind::Sram, s.bytes)).collect();
    assert_eq!(got, want);
    let sram: u64 = want.iter().filter(|w| w.1).map(|w| w.2).sum();
    let all: u64 = want.iter().map(|w| w.2).sum();
    assert_eq!((b.totals.sram_bytes, b.totals.store_bytes), (sram, all));
    assert_eq!(b.totals.register_bytes, all - sram);
}

/// The reference line of a configuration alone: ⌈1.6725 · max(display) · ss⌉.
fn default_line(c: &EngineConfig) -> u64 {
    (c.display_width.max(c.display_height) as f64 * c.supersample as f64 * 1.6725).ceil() as u64
}

#[test]
fn the_presets_budgets_are_their_formulas() {
    for name in ["mark1998", "hmd2026"] {
        let c = EngineConfig::preset(name).unwrap();
        let b = Budget::of(&c);
        let ss = c.supersample as u64;
        let derived = (c.display_width as u64 * ss, c.display_height as u64 * ss);
        assert_eq!(b.sizes.reference_line as u64, default_line(&c), "{name}");
        check(&c, &b, derived, default_line(&c));
    }
    // mark1998 by hand: 1024 tiles of 64 samples, 339 bits a sample.
    let b = Budget::of(&EngineConfig::default());
    let planes: u64 = b
        .stores
        .iter()
        .filter(|s| s.name.starts_with("dest_cache.") && s.name != "dest_cache.tags")
        .map(|s| s.bytes)
        .sum();
    assert_eq!(planes, 65536 * 339 / 8);
}

#[test]
fn doubling_the_destination_cache_changes_exactly_its_stores() {
    let c = EngineConfig::default();
    let mut d = c.clone();
    d.dest_cache_bytes *= 2;
    let (a, b) = (Budget::of(&c), Budget::of(&d));
    check(&d, &b, (1280, 960), default_line(&d));
    for (x, y) in a.stores.iter().zip(&b.stores) {
        if x.unit == "dest_cache" {
            assert_eq!(y.bytes, 2 * x.bytes, "{}", x.name);
        } else {
            assert_eq!(x, y, "{}", x.name);
        }
    }
    assert_eq!(a.datapaths, b.datapaths, "the cache size changes no datapath");
    // Other knobs: fragments off removes the packer's registers; a second
    // rasterizer lane doubles the FIFOs and the stamp datapaths.
    let mut e = c.clone();
    e.abuffer_fragments = 0;
    let be = Budget::of(&e);
    check(&e, &be, (1280, 960), default_line(&e));
    assert!(be.datapaths.iter().any(|p| p.function.contains("pack_in_place") && p.instances.mul == 0));
    let mut r = c.clone();
    r.rects_per_cycle *= 2;
    let br = Budget::of(&r);
    check(&r, &br, (1280, 960), default_line(&r));
    let comp = |b: &Budget| b.datapaths.iter().find(|p| p.unit == "composite").unwrap().instances;
    assert_eq!(comp(&br), comp(&a).times(2));
}

#[test]
fn operator_counts_are_per_item_times_rate_and_the_area_adds_up() {
    let c = EngineConfig::preset("hmd2026").unwrap();
    let b = Budget::sized(&c, Sizes { derived: (4000, 4000), reference_line: 6690 });
    let mut sum = postwarp_rtl::budget::Ops::default();
    for p in &b.datapaths {
        assert_eq!(p.instances, p.per_item.times(p.items_per_cycle), "{}", p.function);
        sum = sum.plus(p.instances);
    }
    assert_eq!(b.totals.instances, sum);
    // The transform's warp: 20 mul, 14 add, 2 recip, 1 sqrt, 1 cmp per sample, 16 lanes.
    let warp = b.datapaths.iter().find(|p| p.function.ends_with("warp_run")).unwrap();
    assert_eq!((warp.instances.mul, warp.instances.recip, warp.instances.sqrt), (320, 32, 16));
    let t = &b.totals;
    let parts = t.sram_area_mm2 + t.register_area_mm2 + t.logic_area_mm2;
    assert!((t.area_mm2 - parts).abs() < 1e-9 * parts);
    let stores: f64 = b.stores.iter().map(|s| s.area_mm2).sum();
    assert!((stores - t.sram_area_mm2 - t.register_area_mm2).abs() < 1e-9 * stores);
}

fn sum_bytes(stores: &[Value], kind: Option<&str>) -> u64 {
    stores.iter().filter(|s| kind.is_none_or(|k| s["kind"] == k)).map(|s| s["bytes"].as_u64().unwrap()).sum()
}

#[test]
fn simulate_reports_the_budget_and_its_totals_are_its_sums() {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["simulate", root().join("traces/room").to_str().unwrap(), "--out"])
        .arg(dir.path().join("s"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: Value = serde_json::from_str(&std::fs::read_to_string(dir.path().join("s/report.json")).unwrap()).unwrap();
    let b = &r["budget"];
    let stores = b["stores"].as_array().unwrap();
    let t = &b["totals"];
    assert_eq!(t["store_bytes"].as_u64().unwrap(), sum_bytes(stores, None));
    assert_eq!(t["sram_bytes"].as_u64().unwrap(), sum_bytes(stores, Some("sram")));
    assert_eq!(t["register_bytes"].as_u64().unwrap(), sum_bytes(stores, Some("registers")));
    for s in stores {
        let (e, bits) = (s["entries"].as_u64().unwrap(), s["bits_per_entry"].as_u64().unwrap());
        assert_eq!(s["bytes"].as_u64().unwrap(), bytes(e, bits), "{}", s["name"]);
    }
    let mul: u64 = b["datapaths"].as_array().unwrap().iter().map(|p| p["instances"]["mul"].as_u64().unwrap()).sum();
    assert_eq!(t["instances"]["mul"].as_u64().unwrap(), mul);
    // Sized for the trace: its frame and its largest reference.
    let trace = postwarp::trace::Trace::open(&root().join("traces/room")).unwrap();
    let ss = trace.display.supersample as u64;
    let derived = (trace.display.width as u64 * ss, trace.display.height as u64 * ss);
    let line =
        trace.references.iter().map(|f| f.camera.intrinsics.width.max(f.camera.intrinsics.height)).max().unwrap();
    assert_eq!(b["reference_line_samples"].as_u64().unwrap(), line as u64 * ss);
    let c = EngineConfig { supersample: ss as u32, ..EngineConfig::default() };
    let want: u64 = expected(&c, derived, line as u64 * ss).iter().map(|w| w.2).sum();
    assert_eq!(t["store_bytes"].as_u64().unwrap(), want);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("on-chip stores") && out.contains("area estimate"), "{out}");
}

#[test]
fn size_prints_the_sram_total_of_the_configuration_it_picks() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("size");
    let o = Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .args(["size", root().join("traces/slants").to_str().unwrap(), "--min-psnr", "25", "--frames", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let j: Value = serde_json::from_str(&std::fs::read_to_string(out.join("size.json")).unwrap()).unwrap();
    let stores = j["budget"]["stores"].as_array().unwrap();
    let sram = sum_bytes(stores, Some("sram"));
    assert_eq!(j["budget"]["totals"]["sram_bytes"].as_u64().unwrap(), sram);
    assert!(text.contains(&format!("SRAM total: {sram} bytes")), "{text}");
    assert!(text.contains("dest_cache.plane9_fill_weight"), "{text}");
    // The budget is of the configuration chosen.
    let cache = j["config"]["dest_cache_bytes"].as_u64().unwrap();
    let tile = j["config"]["tile_size"].as_u64().unwrap();
    let plane1 = stores.iter().find(|s| s["name"] == "dest_cache.plane1_colour").unwrap();
    assert_eq!(plane1["bytes"].as_u64().unwrap(), cache / (tile * tile * 16) * tile * tile * 96 / 8);
}

#[test]
fn simulate_budget_prints_a_configuration_alone() {
    for name in ["mark1998", "hmd2026"] {
        let o = Command::new(env!("CARGO_BIN_EXE_postwarp"))
            .args(["simulate", "--preset", name, "--budget"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8_lossy(&o.stdout);
        let want: u64 = {
            let c = EngineConfig::preset(name).unwrap();
            let ss = c.supersample as u64;
            let d = (c.display_width as u64 * ss, c.display_height as u64 * ss);
            expected(&c, d, default_line(&c)).iter().filter(|w| w.1).map(|w| w.2).sum()
        };
        assert!(text.contains(&format!("SRAM total: {want} bytes")), "{name}: {text}");
    }
}

/// `arith = "fixed"`: the planes at the Q formats' widths (docs/budget.md,
/// "Widths"), values between units at the widest geometry format, the
/// quantised datapaths as integer datapaths of the widest format, the
/// A-buffer packer still FP64.
#[test]
fn the_fixed_mode_budget_uses_the_q_formats_widths() {
    let c = EngineConfig {
        arith: "fixed".into(),
        q_colour: "Q1_11".into(),
        q_inv_z: "Q4_20".into(),
        q_slope: "Q4_12".into(),
        q_hole_weight: "Q2_14".into(),
        ..EngineConfig::default()
    };
    c.validate().unwrap();
    let b = Budget::of(&c);
    let samples = 1024 * 64;
    let store = |n: &str| b.stores.iter().find(|s| s.name == n).map(|s| s.bytes).unwrap();
    assert_eq!(store("dest_cache.plane1_colour"), bytes(samples, 3 * 12));
    assert_eq!(store("dest_cache.plane2_inv_z"), bytes(samples, 24));
    assert_eq!(store("dest_cache.plane3_slopes"), bytes(samples, 2 * 16));
    assert_eq!(store("dest_cache.plane6_fill_colour"), bytes(samples, 3 * 12));
    assert_eq!(store("dest_cache.plane9_fill_weight"), bytes(samples, 16));
    // Warps: position 2 x Q16_16, 1/Z Q4_20, E Q4_12 at the widest (32), valid bit.
    assert_eq!(store("line_buffer.warps"), bytes(4 * default_line(&c), 4 * 32 + 1));
    let format = |f: &str| b.datapaths.iter().find(|d| d.function.contains(f)).map(|d| d.format.name()).unwrap();
    assert_eq!(format("warp_run"), "int32", "Q18_14, Q8_24, Q16_16: 32 bits at most");
    assert_eq!(format("pack_in_place"), "fp64", "the A-buffer stays float");
    // Every store and the totals, from the test's own widths: these
    // formats, the bundled `configs/fixed.toml` defaults and `fixed-minimal`.
    check(&c, &b, (1280, 960), default_line(&c));
    let defaults = EngineConfig { arith: "fixed".into(), ..EngineConfig::default() };
    check(&defaults, &Budget::of(&defaults), (1280, 960), default_line(&defaults));
    let minimal = EngineConfig::preset("fixed-minimal").unwrap();
    check(&minimal, &Budget::of(&minimal), (1280, 960), default_line(&minimal));
    let float = Budget::of(&EngineConfig::default());
    assert!(b.totals.sram_bytes < float.totals.sram_bytes && b.totals.area_mm2 < float.totals.area_mm2);
}
