//! `postwarp simulate --dram-trace FILE --dram-trace-format F`: each format
//! read back as its tool's reader reads it, written here from the format
//! described in `docs/memory-layout.md` ("Request traces"):
//! - DRAMsim3 (`TraceBasedCPU`): `hex address, type, decimal cycle` per
//!   line, a write iff the type is `WRITE`;
//! - Ramulator 2 (`LoadStoreTrace`): exactly two tokens, `LD` or `ST` and a
//!   `0x` hex address;
//! - gem5: magic `gem5`, a varint-length-prefixed `PacketHeader`, then
//!   varint-length-prefixed `Packet`s with their required fields.
//!
//! Every trace holds the report's `dram_transactions`, its writes the
//! written bytes' bursts, every address inside the frame's memory map, and
//! times never decrease.

use postwarp::trace::Trace;
use postwarp_rtl::config::EngineConfig;
use postwarp_rtl::engine::HwReference;
use postwarp_rtl::mem::MemoryLayout;
use serde_json::Value;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn simulate(out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_postwarp"))
        .arg("simulate")
        .arg(root().join("traces/room"))
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// Run with `--dram-trace file --dram-trace-format format`; the report.
fn traced(dir: &Path, name: &str, format: &str) -> (Value, PathBuf) {
    let out = dir.join(format!("run-{name}"));
    let file = dir.join(name);
    let o = simulate(&out, &["--dram-trace", file.to_str().unwrap(), "--dram-trace-format", format]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let report: Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let n = report["total"]["dram_transactions"].as_u64().unwrap();
    assert!(stdout.contains(&format!("({n} transactions)")), "{stdout}");
    (report, file)
}

/// What every format is checked against: the report's counts and the
/// frames' memory maps.
struct Expect {
    transactions: u64,
    writes: u64,
    burst: u64,
    clock_hz: u64,
    /// Per frame: cycles, transactions, memory map.
    frames: Vec<(u64, u64, MemoryLayout)>,
}

impl Expect {
    fn of(report: &Value) -> Expect {
        let cfg = EngineConfig::default();
        let t = Trace::open(&root().join("traces/room")).unwrap();
        let cfg = EngineConfig { supersample: t.display.supersample, ..cfg };
        let (w, h) = (t.display.width * cfg.supersample, t.display.height * cfg.supersample);
        let burst = cfg.dram_burst_bytes;
        let frames = report["frames"]
            .as_array()
            .unwrap()
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let refs: Vec<(u32, u32)> = t.derived[k]
                    .references
                    .iter()
                    .map(|&r| {
                        let hw = HwReference::new(&t.load_reference(r).unwrap().samples, &cfg);
                        (hw.width, hw.height)
                    })
                    .collect();
                let layout = MemoryLayout::new(&cfg, (w, h), &refs);
                (f["cycles"].as_u64().unwrap(), f["dram_transactions"].as_u64().unwrap(), layout)
            })
            .collect();
        let total = &report["total"];
        Expect {
            transactions: total["dram_transactions"].as_u64().unwrap(),
            writes: total["dram_write_bytes"].as_u64().unwrap() / burst,
            burst,
            clock_hz: cfg.clock_hz,
            frames,
        }
    }

    /// Frame of engine cycle `c` (frames back to back).
    fn frame_at(&self, c: u64) -> usize {
        let mut at = 0;
        for (k, f) in self.frames.iter().enumerate() {
            if c < at + f.0 {
                return k;
            }
            at += f.0;
        }
        panic!("cycle {c} after the last frame ({at} cycles)")
    }

    /// `addr` lies in a region of frame `k`'s map (any frame if `None`),
    /// on a burst boundary.
    fn check_addr(&self, addr: u64, k: Option<usize>, at: &str) {
        assert_eq!(addr % self.burst, 0, "{at}: {addr:#x} not on a burst");
        let inside = |l: &MemoryLayout| l.region_of(addr).is_some_and(|r| addr + self.burst <= r.end());
        match k {
            Some(k) => assert!(inside(&self.frames[k].2), "{at}: {addr:#x} outside frame {k}'s memory map"),
            None => assert!(self.frames.iter().any(|f| inside(&f.2)), "{at}: {addr:#x} outside every memory map"),
        }
    }
}

#[test]
fn the_dramsim3_trace_parses_as_trace_based_cpu_reads_it_and_replays_the_reports_transactions() {
    let dir = tempfile::tempdir().unwrap();
    let (report, file) = traced(dir.path(), "room.trace", "dramsim3");
    let e = Expect::of(&report);
    let text = std::fs::read_to_string(&file).unwrap();
    let (mut n, mut writes, mut last) = (0u64, 0u64, 0u64);
    let mut per_frame = vec![0u64; e.frames.len()];
    for (i, line) in text.lines().enumerate() {
        let at = format!("line {}", i + 1);
        // `is >> hex >> addr >> type >> dec >> time`.
        let t: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(t.len(), 3, "{at}: `{line}`");
        let hex = t[0].strip_prefix("0x").unwrap_or_else(|| panic!("{at}: `{}` lacks 0x", t[0]));
        let addr = u64::from_str_radix(hex, 16).unwrap_or_else(|_| panic!("{at}: bad address"));
        assert!(t[1] == "READ" || t[1] == "WRITE", "{at}: type `{}`", t[1]);
        writes += u64::from(t[1] == "WRITE");
        let cycle: u64 = t[2].parse().unwrap_or_else(|_| panic!("{at}: bad cycle `{}`", t[2]));
        assert!(cycle >= last, "{at}: cycle {cycle} before {last}");
        last = cycle;
        let k = e.frame_at(cycle);
        per_frame[k] += 1;
        e.check_addr(addr, Some(k), &at);
        n += 1;
    }
    assert_eq!(n, e.transactions, "lines vs the report's dram_transactions");
    assert_eq!(writes, e.writes, "WRITE lines vs the report's written bursts");
    let want: Vec<u64> = e.frames.iter().map(|f| f.1).collect();
    assert_eq!(per_frame, want, "transactions per frame");
    assert!(n > 0 && writes > 0 && writes < n);
}

#[test]
fn the_ramulator2_trace_parses_as_load_store_trace_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let (report, file) = traced(dir.path(), "room.ls", "ramulator2");
    let e = Expect::of(&report);
    let text = std::fs::read_to_string(&file).unwrap();
    let (mut n, mut stores) = (0u64, 0u64);
    for (i, line) in text.lines().enumerate() {
        let at = format!("line {}", i + 1);
        let t: Vec<&str> = line.split(' ').collect();
        assert_eq!(t.len(), 2, "{at}: `{line}` is not two tokens");
        stores += match t[0] {
            "LD" => 0,
            "ST" => 1,
            other => panic!("{at}: `{other}` is neither LD nor ST"),
        };
        let hex = t[1].strip_prefix("0x").unwrap_or_else(|| panic!("{at}: `{}` lacks 0x", t[1]));
        // std::stoll: must fit a signed 64-bit integer.
        let addr = i64::from_str_radix(hex, 16).unwrap_or_else(|_| panic!("{at}: bad address")) as u64;
        e.check_addr(addr, None, &at);
        n += 1;
    }
    assert_eq!((n, stores), (e.transactions, e.writes));
}

/// One protobuf field: number, and a varint or the bytes of a
/// length-delimited value.
enum Field<'a> {
    Varint(u64),
    Bytes(&'a [u8]),
}

fn varint(b: &[u8], at: &mut usize) -> u64 {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let byte = *b.get(*at).expect("varint runs past the end");
        *at += 1;
        v |= u64::from(byte & 0x7f) << shift;
        if byte & 0x80 == 0 {
            return v;
        }
    }
    panic!("varint longer than 10 bytes")
}

fn fields(msg: &[u8]) -> Vec<(u64, Field<'_>)> {
    let (mut at, mut out) = (0, Vec::new());
    while at < msg.len() {
        let key = varint(msg, &mut at);
        let f = match key & 7 {
            0 => Field::Varint(varint(msg, &mut at)),
            2 => {
                let n = varint(msg, &mut at) as usize;
                at += n;
                Field::Bytes(&msg[at - n..at])
            }
            w => panic!("wire type {w} not used by packet.proto"),
        };
        out.push((key >> 3, f));
    }
    out
}

fn get(f: &[(u64, Field<'_>)], n: u64) -> Option<u64> {
    f.iter().find_map(|(k, v)| match v {
        Field::Varint(x) if *k == n => Some(*x),
        _ => None,
    })
}

/// Decode a gem5 packet trace (protolib's `decodeMessage` loop); checks
/// every message, returns (packets, writes).
fn decode_gem5(b: &[u8], e: &Expect) -> (u64, u64) {
    assert_eq!(u32::from_le_bytes(b[..4].try_into().unwrap()), 0x356d6567, "magic");
    assert_eq!(&b[..4], b"gem5");
    let mut at = 4;
    let len = varint(b, &mut at) as usize;
    let header = fields(&b[at..at + len]);
    at += len;
    let obj = header.iter().find_map(|(k, v)| match v {
        Field::Bytes(s) if *k == 1 => Some(std::str::from_utf8(s).unwrap()),
        _ => None,
    });
    assert_eq!(obj, Some("postwarp"), "obj_id (required)");
    assert_eq!(get(&header, 3), Some(1_000_000_000_000), "tick_freq (required)");
    let ids: Vec<(Option<u64>, String)> = header
        .iter()
        .filter_map(|(k, v)| match v {
            Field::Bytes(m) if *k == 4 => {
                let f = fields(m);
                let name = f.iter().find_map(|(k, v)| match v {
                    Field::Bytes(s) if *k == 2 => Some(String::from_utf8(s.to_vec()).unwrap()),
                    _ => None,
                });
                Some((get(&f, 1), name.unwrap()))
            }
            _ => None,
        })
        .collect();
    assert_eq!(ids.len(), 4, "one id string per client: {ids:?}");
    let (mut n, mut writes, mut last) = (0u64, 0u64, 0u64);
    let tick_per_cycle = 1e12 / e.clock_hz as f64;
    while at < b.len() {
        let len = varint(b, &mut at);
        assert!(len < 1 << 32, "protolib reads a 32-bit length");
        let p = fields(&b[at..at + len as usize]);
        at += len as usize;
        let req = |f| get(&p, f).unwrap_or_else(|| panic!("packet {n}: required field {f} missing"));
        let (tick, cmd, addr, size) = (req(1), req(2), req(3), req(4));
        assert!(cmd == 1 || cmd == 4, "packet {n}: cmd {cmd} is neither ReadReq nor WriteReq");
        writes += u64::from(cmd == 4);
        assert_eq!(size, e.burst, "packet {n}: size");
        assert!(tick >= last, "packet {n}: tick {tick} before {last}");
        last = tick;
        let k = e.frame_at((tick as f64 / tick_per_cycle).round() as u64);
        e.check_addr(addr, Some(k), &format!("packet {n}"));
        assert!(get(&p, 6).is_some_and(|id| ids.iter().any(|(k, _)| *k == Some(id))), "packet {n}: pkt_id");
        n += 1;
    }
    assert_eq!(at, b.len(), "a message runs past the end");
    (n, writes)
}

#[test]
fn the_gem5_trace_decodes_as_decode_packet_trace_reads_it_plain_and_gzipped() {
    let dir = tempfile::tempdir().unwrap();
    let (report, file) = traced(dir.path(), "room.pb", "gem5");
    let e = Expect::of(&report);
    let plain = std::fs::read(&file).unwrap();
    assert_eq!(decode_gem5(&plain, &e), (e.transactions, e.writes));
    // `.gz`: gzip of the same bytes.
    let (_, gz) = traced(dir.path(), "room.pb.gz", "gem5");
    let mut unzipped = Vec::new();
    flate2::read::GzDecoder::new(std::fs::File::open(&gz).unwrap()).read_to_end(&mut unzipped).unwrap();
    assert_eq!(&std::fs::read(&gz).unwrap()[..2], [0x1f, 0x8b], "gzip magic");
    assert_eq!(unzipped, plain, "the .gz trace is the plain trace compressed");
    // No temporary left beside the files.
    let names: Vec<String> =
        std::fs::read_dir(dir.path()).unwrap().map(|d| d.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn bad_formats_and_unwritable_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = simulate(&out, &["--dram-trace", dir.path().join("t").to_str().unwrap(), "--dram-trace-format", "vcd"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("vcd") && err.contains("dramsim3") && err.contains("gem5"), "{err}");
    // A file under a regular file cannot be created: named, nothing run.
    std::fs::write(dir.path().join("plain"), b"x").unwrap();
    let bad = dir.path().join("plain/trace.txt");
    let o = simulate(&out, &["--dram-trace", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("--dram-trace") && err.contains(&bad.display().to_string()), "{err}");
    assert!(!out.exists(), "the run's folder was left behind");
}
