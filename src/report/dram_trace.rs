//! `postwarp simulate --dram-trace FILE`: every DRAM request of the run as
//! a trace that a DRAM simulator replays open-loop
//! (`docs/memory-layout.md`, "Request traces").
//!
//! Formats ([`DramTraceFormat`]):
//! - `dramsim3`: one text line `0xADDR READ|WRITE CYCLE` per transaction,
//!   as DRAMsim3's `TraceBasedCPU` reads it (umd-memsys/DRAMsim3
//!   `src/cpu.cc`, `src/common.cc`: hex address, type, decimal cycle);
//! - `ramulator2`: one text line `LD|ST 0xADDR` per transaction, no time,
//!   as Ramulator 2's `LoadStoreTrace` frontend reads it
//!   (CMU-SAFARI/ramulator2 `src/frontend/impl/memory_trace/loadstore_trace.cpp`);
//! - `gem5`: gem5's protobuf packet trace (gem5/gem5 `src/proto/packet.proto`,
//!   read by `util/decode_packet_trace.py`): the magic `0x356d6567`
//!   (`gem5`, 4 bytes little-endian), then a varint-length-prefixed
//!   `PacketHeader` (`obj_id` 1 = `postwarp`, `tick_freq` 3 = 10¹², one
//!   `id_strings` 4 entry per client), then one varint-length-prefixed
//!   `Packet` per transaction (`tick` 1, `cmd` 2: `ReadReq` = 1,
//!   `WriteReq` = 4 of `MemCmd` in `src/mem/packet.hh`; `addr` 3; `size` 4;
//!   `pkt_id` 6 = the client's number in `Client::ALL`).
//!
//! Rules:
//! 1. A transaction is one DRAM burst (`dram_burst_bytes`): a request of
//!    `n` bursts (its size rounded up, as the DRAM moves it) is `n`
//!    transactions at its address plus `0, burst, 2·burst, …`, all at the
//!    request's acceptance cycle. So the trace holds exactly the report's
//!    `dram_transactions` (`(dram_read_bytes + dram_write_bytes) /
//!    dram_burst_bytes`), in acceptance order.
//! 2. Time: frames follow one another with no gap, so frame `k`'s cycle 0
//!    is the sum of the cycles of frames `0..k`; a request's time is that
//!    offset plus its acceptance cycle. The DRAMsim3 cycle is that engine
//!    cycle (one DRAM clock per engine clock: the ideal channel has no
//!    clock of its own); the gem5 tick is that cycle in picoseconds at
//!    `clock_hz`, rounded down. Times never decrease.
//! 3. A name ending in `.gz` is gzip-compressed (whatever the format; gem5
//!    reads it directly, the text readers need it unpacked).
//! 4. The file is written under a temporary name beside it and renamed by
//!    [`DramTraceWriter::finish`]; dropped unfinished (an error), the
//!    temporary is removed.
//!
//! Addresses are those of the frame's memory map (`postwarp_rtl::mem::layout`);
//! every frame's map starts at address 0.

use anyhow::Context;
use postwarp_rtl::mem::{Access, Client};
use postwarp_rtl::timeline::RequestSpan;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The trace formats of `--dram-trace-format`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum DramTraceFormat {
    /// DRAMsim3 `TraceBasedCPU`: `0xADDR READ|WRITE CYCLE`.
    Dramsim3,
    /// Ramulator 2 `LoadStoreTrace`: `LD|ST 0xADDR`.
    Ramulator2,
    /// gem5 protobuf packet trace.
    Gem5,
}

/// gem5's packet-trace magic number, `gem5` read as a little-endian u32.
pub const GEM5_MAGIC: u32 = 0x356d_6567;

/// gem5 ticks per second (ticks are picoseconds).
pub const GEM5_TICK_FREQ: u64 = 1_000_000_000_000;

/// gem5 `MemCmd::ReadReq`.
pub const GEM5_READ_REQ: u32 = 1;

/// gem5 `MemCmd::WriteReq`.
pub const GEM5_WRITE_REQ: u32 = 4;

/// A trace being written, frame after frame.
pub struct DramTraceWriter {
    format: DramTraceFormat,
    burst: u64,
    clock_hz: u64,
    out: Option<Sink>,
    path: PathBuf,
    tmp: PathBuf,
    /// Engine cycles of the frames written so far (rule 2).
    offset: u64,
    transactions: u64,
    buf: Vec<u8>,
}

impl DramTraceWriter {
    /// Start `path` in `format` for a channel of `burst`-byte bursts at
    /// `clock_hz` (rules 3 and 4).
    ///
    /// # Errors
    /// The temporary file cannot be created (the message names `path`).
    pub fn create(path: &Path, format: DramTraceFormat, burst: u64, clock_hz: u64) -> anyhow::Result<Self> {
        if path.is_dir() {
            anyhow::bail!("--dram-trace {}: is a directory; expected a file name to write", path.display());
        }
        let tmp = crate::io_util::temp_path(path);
        let file = File::create(&tmp)
            .with_context(|| format!("--dram-trace {}: cannot create the file (or its temporary)", path.display()))?;
        let file = BufWriter::with_capacity(1 << 20, file);
        let gz = path.extension().is_some_and(|e| e == "gz");
        let out = if gz {
            Sink::Gz(flate2::write::GzEncoder::new(file, flate2::Compression::fast()))
        } else {
            Sink::Plain(file)
        };
        let mut w = DramTraceWriter {
            format,
            burst,
            clock_hz,
            out: Some(out),
            path: path.to_path_buf(),
            tmp,
            offset: 0,
            transactions: 0,
            buf: Vec::new(),
        };
        if format == DramTraceFormat::Gem5 {
            let mut head = GEM5_MAGIC.to_le_bytes().to_vec();
            let mut msg = Vec::new();
            put_bytes(&mut msg, 1, b"postwarp");
            put_varint_field(&mut msg, 3, GEM5_TICK_FREQ);
            for c in Client::ALL {
                let mut entry = Vec::new();
                put_varint_field(&mut entry, 1, c.index() as u64);
                put_bytes(&mut entry, 2, c.name().as_bytes());
                put_bytes(&mut msg, 4, &entry);
            }
            put_varint(&mut head, msg.len() as u64);
            head.extend_from_slice(&msg);
            w.write(&head)?;
        }
        Ok(w)
    }

    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        let out = self.out.as_mut().expect("not finished");
        out.write_all(bytes).with_context(|| format!("--dram-trace {}: writing", self.path.display()))
    }

    /// Append one frame's `requests` (in acceptance order, times from the
    /// frame's cycle 0), a frame of `cycles` engine cycles (rule 2).
    ///
    /// # Errors
    /// A write fails.
    pub fn frame(&mut self, requests: &[RequestSpan], cycles: u64) -> anyhow::Result<()> {
        let mut buf = std::mem::take(&mut self.buf);
        buf.clear();
        for r in requests {
            let cycle = self.offset + r.accepted.get();
            let write = r.access == Access::Write;
            let n = r.bytes.div_ceil(self.burst);
            for i in 0..n {
                let addr = r.addr + i * self.burst;
                match self.format {
                    DramTraceFormat::Dramsim3 => {
                        let _ = writeln!(buf, "{addr:#x} {} {cycle}", if write { "WRITE" } else { "READ" });
                    }
                    DramTraceFormat::Ramulator2 => {
                        let _ = writeln!(buf, "{} {addr:#x}", if write { "ST" } else { "LD" });
                    }
                    DramTraceFormat::Gem5 => {
                        let tick = (u128::from(cycle) * u128::from(GEM5_TICK_FREQ) / u128::from(self.clock_hz)) as u64;
                        let mut msg = [0u8; 48];
                        let len = {
                            let mut m = Slice { buf: &mut msg, len: 0 };
                            m.varint_field(1, tick);
                            m.varint_field(2, u64::from(if write { GEM5_WRITE_REQ } else { GEM5_READ_REQ }));
                            m.varint_field(3, addr);
                            m.varint_field(4, self.burst);
                            m.varint_field(6, r.client.index() as u64);
                            m.len
                        };
                        put_varint(&mut buf, len as u64);
                        buf.extend_from_slice(&msg[..len]);
                    }
                }
            }
            self.transactions += n;
            if buf.len() >= 1 << 20 {
                self.write(&buf)?;
                buf.clear();
            }
        }
        self.write(&buf)?;
        self.buf = buf;
        self.offset += cycles;
        Ok(())
    }

    /// Transactions written so far (rule 1).
    pub fn transactions(&self) -> u64 {
        self.transactions
    }

    /// Flush, close and move the file into place; the transactions written.
    ///
    /// # Errors
    /// Flushing, compressing or renaming fails (the message names the file).
    pub fn finish(mut self) -> anyhow::Result<u64> {
        let out = self.out.take().expect("not finished");
        let done = out.finish().with_context(|| format!("--dram-trace {}: writing", self.path.display()));
        if let Err(e) = done {
            let _ = std::fs::remove_file(&self.tmp);
            return Err(e);
        }
        std::fs::rename(&self.tmp, &self.path)
            .with_context(|| format!("--dram-trace {}: moving the finished file into place", self.path.display()))?;
        Ok(self.transactions)
    }
}

/// Where the bytes go: the temporary file, plain or through gzip.
enum Sink {
    Plain(BufWriter<File>),
    Gz(flate2::write::GzEncoder<BufWriter<File>>),
}

impl Sink {
    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            Sink::Plain(w) => w.write_all(bytes),
            Sink::Gz(w) => w.write_all(bytes),
        }
    }

    /// Write the gzip trailer if any, flush and sync the file.
    fn finish(self) -> std::io::Result<()> {
        let file = match self {
            Sink::Plain(w) => w,
            Sink::Gz(w) => w.finish()?,
        };
        file.into_inner().map_err(|e| e.into_error())?.sync_all()
    }
}

impl Drop for DramTraceWriter {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// A fixed buffer a packet message is encoded into.
struct Slice<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl Slice<'_> {
    fn byte(&mut self, b: u8) {
        self.buf[self.len] = b;
        self.len += 1;
    }

    fn varint(&mut self, mut v: u64) {
        while v >= 0x80 {
            self.byte(v as u8 | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    fn varint_field(&mut self, field: u32, v: u64) {
        self.varint(u64::from(field) << 3);
        self.varint(v);
    }
}

/// Protobuf base-128 varint.
fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A varint field (wire type 0).
fn put_varint_field(out: &mut Vec<u8>, field: u32, v: u64) {
    put_varint(out, u64::from(field) << 3);
    put_varint(out, v);
}

/// A length-delimited field (wire type 2): a string or a nested message.
fn put_bytes(out: &mut Vec<u8>, field: u32, bytes: &[u8]) {
    put_varint(out, u64::from(field) << 3 | 2);
    put_varint(out, bytes.len() as u64);
    out.extend_from_slice(bytes);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varints_are_protobufs() {
        let mut v = Vec::new();
        put_varint(&mut v, 300);
        assert_eq!(v, [0xac, 0x02]);
        let mut m = [0u8; 48];
        let mut s = Slice { buf: &mut m, len: 0 };
        s.varint_field(1, 150);
        assert_eq!(&m[..3], [0x08, 0x96, 0x01]);
        assert_eq!(GEM5_MAGIC.to_le_bytes(), *b"gem5");
    }
}
