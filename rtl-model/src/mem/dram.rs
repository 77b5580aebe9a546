//! DRAM: one shared, bandwidth- and latency-limited off-chip memory channel.
//!
//! Job: accept read and write requests from the warper's memory clients,
//! return each one when its backend says it is done (by default after a
//! fixed latency plus its transfer time on a shared data bus), and count
//! bytes per client (DRAMsim3's `WillAccept`/`Add`/`ClockTick` protocol).
//!
//! Backends (`mem::backend`): the timing below is the `ideal` backend's
//! ([`Dram::new`]); [`Dram::with_backend`] puts any [`DramBackend`] (e.g.
//! DRAMsim3, `src/dram/` of the `postwarp` crate) behind the same channel.
//! The channel rules (one command port, `max_outstanding`, burst rounding
//! of the counted bytes, the counters) hold for every backend; an external
//! backend may complete requests out of acceptance order.
//!
//! API ([`Dram`]): `new(DramConfig)`; each cycle the engine calls
//! `tick(now)` first, then clients call `will_accept(now)`,
//! `request(now, client, access, bytes, tag) -> Result<(), Request>` (a
//! refused request is handed back) and `completed(now) -> Option<(tag,
//! client)>`; `counters()`, `stats()` (a [`Stats`] with [`DRAM_STATS`]),
//! `reset_counters()`, `outstanding()`.
//!
//! Knobs ([`DramConfig`]): `peak_bytes_per_cycle` (bytes/cycle),
//! `latency_cycles` (cycles), `burst_bytes` (bytes), `max_outstanding`
//! (requests).
//!
//! Timing rules (a serialization model of the data bus):
//! - Every request is rounded up to whole bursts: it moves
//!   `ceil(bytes / burst_bytes) * burst_bytes` bytes, and that rounded amount
//!   is what occupies the bus and what the byte counters count.
//! - The data bus moves at most `peak_bytes_per_cycle` bytes in each cycle,
//!   reads and writes alike (one bidirectional bus). Transfers are served in
//!   acceptance order; a transfer may start in the middle of a cycle where
//!   the previous one ended, so two small transfers can share a cycle. Hence
//!   over any window of c cycles at most `peak_bytes_per_cycle * c` bytes
//!   move.
//! - A request accepted at cycle A cannot start its transfer before cycle
//!   A + `latency_cycles` (command, array access and controller time,
//!   pipelined across requests). Its transfer starts at the later of that and
//!   the end of the previous transfer, takes `bytes / peak` cycles of bus
//!   time, and the request is *completed* — returned by `completed` — from
//!   the first cycle after its last byte moved. Alone on an idle bus a
//!   request therefore completes at exactly
//!   A + `latency_cycles` + `ceil(rounded bytes / peak_bytes_per_cycle)`.
//!   Writes complete the same way (the acknowledgement returns after the
//!   data has been written).
//! - Completions come back in acceptance order.
//! - Backpressure: `will_accept(now)` is false, and `request` refuses, when
//!   a request was already accepted this cycle (one command port) or when
//!   `max_outstanding` requests are outstanding. A request stays outstanding
//!   until `completed` returns it, so a client that does not drain its
//!   completions eventually blocks the channel.
//! - `tick(now)` must be called once per cycle, with consecutive cycles,
//!   before any other call of that cycle; the other calls must pass the same
//!   `now` (debug assertions).
//!
//! Stats (units in [`DRAM_STATS`]): bytes read and written, in total and per
//! [`Client`], counted when a request is accepted; requests; bytes requested
//! before burst rounding; cycles with a refused request (counted once per
//! cycle); cycles with at least one request outstanding; the sum over
//! cycles of the requests outstanding, and their most at once; a histogram
//! of per-request latency from acceptance to completion, and the same for
//! reads alone. The backend's own counters: [`Dram::backend_counters`].
//! Bandwidth utilisation, mean occupancy and rounding overhead are ratios
//! of these and are derived by reports.
//!
//! Not modelled: banks, rows and row-buffer hits, refresh, read/write
//! turnaround, command scheduling or reordering, multiple channels, error
//! correction, and any traffic of the renderer or display sharing the
//! memory (give the warper a lower `peak_bytes_per_cycle` to account for it).

use std::collections::VecDeque;

use super::backend::{BackendCounters, DramBackend, IdealBackend, NextEvent};
use crate::clock::Cycle;
use crate::stats::{Histogram, StatDef, Stats};
use crate::timeline::RequestSpan;

/// Who asked for the data (one byte counter pair per client).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Client {
    /// Reference frames read in A-buffer format by the fetch/expand unit.
    ReferenceFetch,
    /// Destination tiles read into the destination cache.
    TileFill,
    /// Destination tiles written back from the destination cache.
    TileWriteBack,
    /// The finished derived frame written out (A-buffer packer / display).
    Output,
}

impl Client {
    /// Every client, in counter order.
    pub const ALL: [Client; 4] = [Client::ReferenceFetch, Client::TileFill, Client::TileWriteBack, Client::Output];

    /// Position in [`Client::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Snake-case name, as used in stat names.
    pub const fn name(self) -> &'static str {
        match self {
            Client::ReferenceFetch => "reference_fetch",
            Client::TileFill => "tile_fill",
            Client::TileWriteBack => "tile_write_back",
            Client::Output => "output",
        }
    }
}

/// Direction of a transfer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// Memory to chip.
    Read,
    /// Chip to memory.
    Write,
}

/// A memory request, as handed back when refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request<T = u64> {
    /// Who asked.
    pub client: Client,
    /// Read or write.
    pub access: Access,
    /// First byte's DRAM address (bytes; `docs/memory-layout.md`).
    pub addr: u64,
    /// Bytes asked for (before rounding to bursts).
    pub bytes: u64,
    /// The client's identifier, returned on completion.
    pub tag: T,
}

/// The DRAM knobs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DramConfig {
    /// Peak data-bus bandwidth (bytes/cycle).
    pub peak_bytes_per_cycle: u64,
    /// Cycles from acceptance to the earliest start of the data transfer
    /// (cycles).
    pub latency_cycles: u64,
    /// Transfer granule; requests are rounded up to whole bursts (bytes).
    pub burst_bytes: u64,
    /// Requests accepted and not yet returned by `completed` (requests).
    pub max_outstanding: usize,
}

impl DramConfig {
    /// Check the knobs; the message names the knob as `EngineConfig` does.
    pub fn validate(&self) -> Result<(), String> {
        // The ranges are the hardware knobs' (`config::KNOBS`).
        use crate::config::check_knob;
        use crate::knob::KnobValue::Int;
        check_knob("dram_peak_bytes_per_cycle", Int(self.peak_bytes_per_cycle))?;
        check_knob("dram_latency_cycles", Int(self.latency_cycles))?;
        check_knob("dram_burst_bytes", Int(self.burst_bytes))?;
        check_knob("dram_max_outstanding", Int(self.max_outstanding as u64))
    }

    /// `bytes` rounded up to whole bursts (bytes).
    #[inline]
    pub fn rounded(&self, bytes: u64) -> u64 {
        bytes.div_ceil(self.burst_bytes) * self.burst_bytes
    }
}

/// Every DRAM stat, in report order.
pub const DRAM_STATS: &[StatDef] = &[
    StatDef::counter("dram.bytes_read", "bytes", "bytes read, all clients, rounded up to whole bursts"),
    StatDef::counter("dram.bytes_written", "bytes", "bytes written, all clients, rounded up to whole bursts"),
    StatDef::counter("dram.bytes_read.reference_fetch", "bytes", "bytes read for reference frames (A-buffer format)"),
    StatDef::counter("dram.bytes_written.reference_fetch", "bytes", "bytes written by the reference fetch unit"),
    StatDef::counter("dram.bytes_read.tile_fill", "bytes", "bytes read to fill destination tiles"),
    StatDef::counter("dram.bytes_written.tile_fill", "bytes", "bytes written by the tile fill path"),
    StatDef::counter("dram.bytes_read.tile_write_back", "bytes", "bytes read by the tile write-back path"),
    StatDef::counter("dram.bytes_written.tile_write_back", "bytes", "bytes written back from destination tiles"),
    StatDef::counter("dram.bytes_read.output", "bytes", "bytes read by the output path"),
    StatDef::counter("dram.bytes_written.output", "bytes", "bytes of the finished derived frame written out"),
    StatDef::counter("dram.requests", "requests", "requests accepted"),
    StatDef::counter("dram.requested_bytes", "bytes", "bytes asked for, before rounding up to bursts"),
    StatDef::counter("dram.refused_cycles", "cycles", "cycles in which at least one request was refused"),
    StatDef::counter("dram.outstanding_cycles", "cycles", "cycles with at least one request outstanding"),
    StatDef::histogram("dram.latency", "cycles", "per request: cycles from acceptance to completion"),
    StatDef::counter(
        "dram.outstanding_request_cycles",
        "request-cycles",
        "requests outstanding, summed over cycles (mean occupancy = this / cycles)",
    ),
    StatDef::counter("dram.peak_outstanding", "requests", "most requests outstanding at once"),
    StatDef::histogram("dram.read_latency", "cycles", "per read request: cycles from acceptance to completion"),
];

/// Raw event counts of a [`Dram`] since it was made (or last reset).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DramCounters {
    /// Bytes read, all clients (bytes, rounded to bursts).
    pub bytes_read: u64,
    /// Bytes written, all clients (bytes, rounded to bursts).
    pub bytes_written: u64,
    /// Bytes read per client, indexed by [`Client::index`] (bytes).
    pub client_bytes_read: [u64; 4],
    /// Bytes written per client, indexed by [`Client::index`] (bytes).
    pub client_bytes_written: [u64; 4],
    /// Requests accepted (requests).
    pub requests: u64,
    /// Bytes asked for before burst rounding (bytes).
    pub requested_bytes: u64,
    /// Cycles with at least one refused request (cycles).
    pub refused_cycles: u64,
    /// Cycles ticked with at least one request outstanding (cycles).
    pub outstanding_cycles: u64,
    /// Acceptance-to-completion latency per request (cycles).
    pub latency: Histogram,
    /// Requests outstanding, summed over the cycles ticked (request-cycles).
    pub outstanding_request_cycles: u64,
    /// Most requests outstanding at once (requests).
    pub peak_outstanding: u64,
    /// Acceptance-to-completion latency per read request (cycles); writes
    /// are `latency` minus this, bin by bin.
    pub read_latency: Histogram,
}

#[derive(Clone, Copy, Debug)]
struct InFlight<T> {
    tag: T,
    client: Client,
    /// For latency recorded at completion (a backend that did not know the
    /// completion cycle at acceptance): when it was accepted, whether it
    /// reads, and its span's index when recording (else `usize::MAX`).
    accepted: Cycle,
    read: bool,
    late: bool,
    span: usize,
}

/// The timing behind the channel: the ideal model inline (no dynamic
/// dispatch on the hot path), or any other backend.
enum Backend {
    Ideal(IdealBackend),
    Other(Box<dyn DramBackend>),
}

impl Backend {
    #[inline]
    fn get(&self) -> &dyn DramBackend {
        match self {
            Backend::Ideal(b) => b,
            Backend::Other(b) => b.as_ref(),
        }
    }

    #[inline]
    fn get_mut(&mut self) -> &mut dyn DramBackend {
        match self {
            Backend::Ideal(b) => b,
            Backend::Other(b) => b.as_mut(),
        }
    }
}

impl std::fmt::Debug for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Backend({})", self.get().name())
    }
}

/// The DRAM model. See the module documentation for the timing rules.
#[derive(Debug)]
pub struct Dram<T = u64> {
    cfg: DramConfig,
    backend: Backend,
    /// Requests accepted and not yet returned, by id: slot `i` holds id
    /// `first_id + i` (`None` once returned out of order).
    in_flight: VecDeque<Option<InFlight<T>>>,
    /// The id of `in_flight`'s first slot.
    first_id: u64,
    /// Requests in `in_flight` not yet returned.
    outstanding: usize,
    /// A finished request the backend returned, not yet handed out
    /// (`completed` peeks one ahead to answer `next_completion`).
    ready: Option<(u64, Cycle)>,
    last_accept: Option<Cycle>,
    last_refused: Option<Cycle>,
    now: Option<Cycle>,
    counters: DramCounters,
    /// Every accepted request's lifetime, when recording (a timeline).
    spans: Option<Vec<RequestSpan>>,
}

impl<T: Copy> Dram<T> {
    /// A DRAM with knobs `cfg` and the ideal backend, idle.
    ///
    /// # Panics
    /// If `cfg` does not validate.
    pub fn new(cfg: DramConfig) -> Dram<T> {
        Dram::with(cfg, Backend::Ideal(IdealBackend::new(cfg)))
    }

    /// A DRAM with knobs `cfg` (the channel's: port, `max_outstanding`,
    /// burst rounding of the counters) timed by `backend`, idle.
    ///
    /// # Panics
    /// If `cfg` does not validate.
    pub fn with_backend(cfg: DramConfig, backend: Box<dyn DramBackend>) -> Dram<T> {
        Dram::with(cfg, Backend::Other(backend))
    }

    fn with(cfg: DramConfig, backend: Backend) -> Dram<T> {
        cfg.validate().unwrap_or_else(|e| panic!("invalid DRAM configuration: {e}"));
        Dram {
            cfg,
            backend,
            in_flight: VecDeque::with_capacity(cfg.max_outstanding),
            first_id: 0,
            outstanding: 0,
            ready: None,
            last_accept: None,
            last_refused: None,
            now: None,
            counters: DramCounters::default(),
            spans: None,
        }
    }

    /// The knobs.
    pub fn config(&self) -> &DramConfig {
        &self.cfg
    }

    /// Advance to cycle `now` (called once per cycle, before any other call
    /// of that cycle).
    #[inline]
    pub fn tick(&mut self, now: Cycle) {
        debug_assert!(
            self.now.is_none_or(|prev| now == prev.next()),
            "Dram::tick({now}) after tick({:?}): cycles must be consecutive",
            self.now
        );
        self.now = Some(now);
        self.backend.get_mut().tick(now);
        if self.outstanding > 0 {
            self.counters.outstanding_cycles += 1;
            self.counters.outstanding_request_cycles += self.outstanding as u64;
        }
    }

    /// Jump from the current cycle to `now`, as if `tick` had been called
    /// for every cycle in between, when the caller knows nothing completes
    /// before `now` (an idle stretch: see [`Dram::next_completion`]). With
    /// `refusing`, a request was offered and refused in each cycle after
    /// the current one up to `now` (they count as refused cycles).
    pub fn skip_to(&mut self, now: Cycle, refusing: bool) {
        let prev = self.now.expect("skip_to before the first tick");
        debug_assert!(now > prev, "skip_to({now}) from {prev}");
        debug_assert!(self.next_completion().is_none_or(|c| c >= now), "a completion would be skipped");
        debug_assert!(!refusing || !self.has_room(), "a request refused with room");
        self.backend.get_mut().skip_to(now);
        if self.outstanding > 0 {
            self.counters.outstanding_cycles += now - prev;
            self.counters.outstanding_request_cycles += self.outstanding as u64 * (now - prev);
        }
        if refusing {
            self.counters.refused_cycles += now - prev;
            self.last_refused = Some(now);
        }
        self.now = Some(now);
    }

    /// The cycle from which the next outstanding request completes: with
    /// the ideal backend the oldest one's; with a backend that cannot say
    /// ([`NextEvent::EveryCycle`]) the next cycle, so that no cycle is
    /// skipped while it works.
    #[inline]
    pub fn next_completion(&self) -> Option<Cycle> {
        if let Some((_, done)) = self.ready {
            return Some(done);
        }
        match self.backend.get().next_event() {
            NextEvent::Idle => None,
            NextEvent::At(t) => Some(t),
            NextEvent::EveryCycle => Some(self.now.map_or(Cycle(1), Cycle::next)),
        }
    }

    /// True if fewer than `max_outstanding` requests are outstanding (a
    /// request in a later cycle would be accepted).
    #[inline]
    pub fn has_room(&self) -> bool {
        self.outstanding < self.cfg.max_outstanding
    }

    /// True if a request at `now` would be accepted.
    #[inline]
    pub fn will_accept(&self, now: Cycle) -> bool {
        self.check_now(now);
        self.last_accept != Some(now) && self.outstanding < self.cfg.max_outstanding
    }

    /// The `dram_backend` name of the timing behind the channel.
    pub fn backend_name(&self) -> &'static str {
        self.backend.get().name()
    }

    /// Ask for a transfer of `bytes` (more than 0) at `now`. On refusal the
    /// request is handed back and the cycle counts as a refused cycle.
    ///
    /// # Panics
    /// If `bytes` is 0.
    #[inline]
    pub fn request(
        &mut self,
        now: Cycle,
        client: Client,
        access: Access,
        addr: u64,
        bytes: u64,
        tag: T,
    ) -> Result<(), Request<T>> {
        assert!(bytes > 0, "DRAM request of 0 bytes");
        if !self.will_accept(now) {
            if self.last_refused != Some(now) {
                self.counters.refused_cycles += 1;
                self.last_refused = Some(now);
            }
            return Err(Request { client, access, addr, bytes, tag });
        }
        let rounded = self.cfg.rounded(bytes);
        let id = self.first_id + self.in_flight.len() as u64;
        let known = self.backend.get_mut().accept(now, id, access, addr, bytes);
        self.last_accept = Some(now);
        let read = access == Access::Read;
        let span = match (&mut self.spans, known) {
            (Some(spans), None) => {
                // Completed later: the span's end is filled in then.
                spans.push(RequestSpan { client, access, addr, bytes: rounded, accepted: now, done: now });
                spans.len() - 1
            }
            _ => usize::MAX,
        };
        self.in_flight.push_back(Some(InFlight { tag, client, accepted: now, read, late: known.is_none(), span }));
        self.outstanding += 1;
        self.counters.peak_outstanding = self.counters.peak_outstanding.max(self.outstanding as u64);

        let c = &mut self.counters;
        c.requests += 1;
        c.requested_bytes += bytes;
        match access {
            Access::Read => {
                c.bytes_read += rounded;
                c.client_bytes_read[client.index()] += rounded;
            }
            Access::Write => {
                c.bytes_written += rounded;
                c.client_bytes_written[client.index()] += rounded;
            }
        }
        if let Some(done) = known {
            c.latency.record(done - now);
            if read {
                c.read_latency.record(done - now);
            }
            if let Some(spans) = &mut self.spans {
                spans.push(RequestSpan { client, access, addr, bytes: rounded, accepted: now, done });
            }
        }
        Ok(())
    }

    /// Start recording every accepted request's lifetime (for a timeline).
    pub fn record_requests(&mut self) {
        self.spans.get_or_insert_with(Vec::new);
    }

    /// The requests recorded so far (empty unless recording).
    pub fn take_requests(&mut self) -> Vec<RequestSpan> {
        self.spans.take().unwrap_or_default()
    }

    /// The oldest outstanding request, if it has completed by `now`:
    /// `(tag, client)`. Frees its outstanding slot.
    #[inline]
    pub fn completed(&mut self, now: Cycle) -> Option<(T, Client)> {
        self.check_now(now);
        let (id, done) = match self.ready.take() {
            Some(r) => r,
            None => self.backend.get_mut().pop_done(now)?,
        };
        if done > now {
            self.ready = Some((id, done));
            return None;
        }
        let slot = (id - self.first_id) as usize;
        let f = self.in_flight[slot].take().expect("a backend returned a request twice");
        while self.in_flight.front().is_some_and(Option::is_none) {
            self.in_flight.pop_front();
            self.first_id += 1;
        }
        self.outstanding -= 1;
        if f.late {
            self.completed_late(&f, done);
        }
        Some((f.tag, f.client))
    }

    /// The latency and span of a request whose completion the backend did
    /// not know at acceptance.
    #[cold]
    fn completed_late(&mut self, f: &InFlight<T>, done: Cycle) {
        self.counters.latency.record(done - f.accepted);
        if f.read {
            self.counters.read_latency.record(done - f.accepted);
        }
        if let Some(s) = self.spans.as_mut().and_then(|s| s.get_mut(f.span)) {
            s.done = done;
        }
    }

    /// Requests accepted and not yet returned by `completed`.
    #[inline]
    pub fn outstanding(&self) -> usize {
        self.outstanding
    }

    /// Raw counts so far.
    pub fn counters(&self) -> &DramCounters {
        &self.counters
    }

    /// The backend's own counts since it was made (0 for the ideal one).
    pub fn backend_counters(&self) -> BackendCounters {
        self.backend.get().counters()
    }

    /// Zero the counts (e.g. at a frame boundary); requests in flight stay.
    /// The backend's own counters are not reset.
    pub fn reset_counters(&mut self) {
        self.counters = DramCounters::default();
        self.last_refused = None;
    }

    /// The counts as a [`Stats`] declaring [`DRAM_STATS`].
    pub fn stats(&self) -> Stats {
        let c = &self.counters;
        let mut s = Stats::new(DRAM_STATS);
        s.add_count("dram.bytes_read", c.bytes_read);
        s.add_count("dram.bytes_written", c.bytes_written);
        for (i, client) in Client::ALL.into_iter().enumerate() {
            // Stat i of each direction, laid out as in DRAM_STATS.
            let read = DRAM_STATS[2 + 2 * i].name;
            let written = DRAM_STATS[3 + 2 * i].name;
            debug_assert_eq!(read, format!("dram.bytes_read.{}", client.name()));
            debug_assert_eq!(written, format!("dram.bytes_written.{}", client.name()));
            s.add_count(read, c.client_bytes_read[i]);
            s.add_count(written, c.client_bytes_written[i]);
        }
        s.add_count("dram.requests", c.requests);
        s.add_count("dram.requested_bytes", c.requested_bytes);
        s.add_count("dram.refused_cycles", c.refused_cycles);
        s.add_count("dram.outstanding_cycles", c.outstanding_cycles);
        for (v, n) in c.latency.bins() {
            s.record_n("dram.latency", v, n);
        }
        s.add_count("dram.outstanding_request_cycles", c.outstanding_request_cycles);
        s.add_count("dram.peak_outstanding", c.peak_outstanding);
        for (v, n) in c.read_latency.bins() {
            s.record_n("dram.read_latency", v, n);
        }
        s
    }

    /// The ideal backend's first free bus slot (tests of the schedule).
    #[cfg(test)]
    fn bus_free_slot(&self) -> u64 {
        match &self.backend {
            Backend::Ideal(b) => b.bus_free_slot(),
            Backend::Other(_) => 0,
        }
    }

    fn check_now(&self, now: Cycle) {
        debug_assert!(self.now == Some(now), "Dram used at cycle {now} but last ticked at {:?}", self.now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::backend::{BackendCounters, IdealBackend};

    const CFG: DramConfig =
        DramConfig { peak_bytes_per_cycle: 16, latency_cycles: 10, burst_bytes: 32, max_outstanding: 8 };

    /// Tick from `from` up to and including `to`.
    fn tick_to(d: &mut Dram, from: Cycle, to: Cycle) {
        for t in from.get()..=to.get() {
            d.tick(Cycle(t));
        }
    }

    #[test]
    fn a_single_read_completes_at_accept_plus_latency_plus_transfer_and_not_before() {
        for (peak, latency, bytes) in [(16, 10, 64), (16, 0, 64), (8, 3, 32), (16, 10, 1), (64, 100, 64), (3, 5, 32)] {
            let cfg =
                DramConfig { peak_bytes_per_cycle: peak, latency_cycles: latency, burst_bytes: 32, max_outstanding: 4 };
            let mut d = Dram::new(cfg);
            let accept = Cycle(5);
            tick_to(&mut d, Cycle(0), accept);
            d.request(accept, Client::ReferenceFetch, Access::Read, 0, bytes, 77).unwrap();
            let transfer = cfg.rounded(bytes).div_ceil(peak);
            let done = accept + latency + transfer;
            tick_to(&mut d, accept.next(), done - 1);
            assert_eq!(d.completed(done - 1), None, "{cfg:?} {bytes}: early");
            d.tick(done);
            assert_eq!(d.completed(done), Some((77, Client::ReferenceFetch)), "{cfg:?} {bytes}");
            assert_eq!(d.outstanding(), 0);
            assert_eq!(d.counters().latency.bins().collect::<Vec<_>>(), [(done - accept, 1)]);
        }
    }

    #[test]
    fn a_request_is_rounded_up_to_whole_bursts() {
        let mut d = Dram::new(CFG);
        d.tick(Cycle(0));
        d.request(Cycle(0), Client::TileFill, Access::Read, 0, 33, 0).unwrap();
        d.tick(Cycle(1));
        d.request(Cycle(1), Client::TileWriteBack, Access::Write, 0, 1, 1).unwrap();
        d.tick(Cycle(2));
        d.request(Cycle(2), Client::Output, Access::Write, 0, 64, 2).unwrap();
        let c = d.counters();
        assert_eq!(c.client_bytes_read[Client::TileFill.index()], 64);
        assert_eq!(c.client_bytes_written[Client::TileWriteBack.index()], 32);
        assert_eq!(c.client_bytes_written[Client::Output.index()], 64);
        assert_eq!((c.bytes_read, c.bytes_written, c.requested_bytes), (64, 96, 98));
        // 33 bytes occupy the bus for two bursts = 64 bytes = 4 cycles.
        assert_eq!(c.latency.get(10 + 4), 1);
    }

    /// Issue `n` requests of `bytes` from rotating clients as fast as the
    /// DRAM accepts them and drain completions; returns (cycle of the last
    /// completion, the DRAM).
    fn run_back_to_back(cfg: DramConfig, n: u64, bytes: u64) -> (Cycle, Dram) {
        let mut d = Dram::new(cfg);
        let (mut issued, mut done, mut now) = (0u64, 0u64, Cycle(0));
        let mut last = Cycle(0);
        loop {
            d.tick(now);
            while let Some((tag, _)) = d.completed(now) {
                assert_eq!(tag, done, "completions in acceptance order");
                done += 1;
                last = now;
            }
            if done == n {
                return (last, d);
            }
            if issued < n {
                let client = Client::ALL[(issued % 4) as usize];
                let access = if issued % 3 == 0 { Access::Write } else { Access::Read };
                if d.request(now, client, access, 0, bytes, issued).is_ok() {
                    issued += 1;
                }
            }
            now = now.next();
        }
    }

    #[test]
    fn back_to_back_requests_take_at_least_total_bytes_over_peak_cycles() {
        for (cfg, n, bytes) in [
            (CFG, 100, 64),
            (CFG, 100, 8),
            (
                DramConfig { peak_bytes_per_cycle: 68, latency_cycles: 100, burst_bytes: 64, max_outstanding: 32 },
                500,
                64,
            ),
            (DramConfig { peak_bytes_per_cycle: 5, latency_cycles: 0, burst_bytes: 4, max_outstanding: 2 }, 50, 7),
        ] {
            let (last, d) = run_back_to_back(cfg, n, bytes);
            let total = d.counters().bytes_read + d.counters().bytes_written;
            assert_eq!(total, n * cfg.rounded(bytes));
            let min_cycles = total.div_ceil(cfg.peak_bytes_per_cycle);
            assert!(last.get() >= min_cycles, "{cfg:?}: {n} x {bytes} B done at {last} < {min_cycles}");
            // And the bus is actually kept busy when requests are big enough
            // to cover the latency with max_outstanding in flight.
            if cfg == CFG && bytes == 64 {
                assert!(last.get() <= min_cycles + cfg.latency_cycles + 4, "{last}");
            }
        }
    }

    #[test]
    fn bytes_in_any_window_stay_under_peak() {
        // Replay the schedule: a request's bytes occupy byte slots
        // [start, end); count slots per cycle and check each cycle <= peak.
        let cfg = DramConfig { peak_bytes_per_cycle: 12, latency_cycles: 2, burst_bytes: 8, max_outstanding: 16 };
        let mut d = Dram::new(cfg);
        let mut per_cycle = vec![0u64; 4096];
        let mut prev_free = 0;
        for t in 0..200u64 {
            d.tick(Cycle(t));
            while d.completed(Cycle(t)).is_some() {}
            let before = d.bus_free_slot();
            if d.request(Cycle(t), Client::ALL[(t % 4) as usize], Access::Read, 0, 1 + t % 20, t).is_ok() {
                let end = d.bus_free_slot();
                let start = end - cfg.rounded(1 + t % 20);
                assert!(start >= before.max(prev_free));
                for slot in start..end {
                    per_cycle[(slot / cfg.peak_bytes_per_cycle) as usize] += 1;
                }
                prev_free = end;
            }
        }
        assert!(per_cycle.iter().all(|&b| b <= cfg.peak_bytes_per_cycle));
    }

    #[test]
    fn per_client_counters_sum_to_the_totals() {
        let (_, d) = run_back_to_back(CFG, 97, 40);
        let c = d.counters();
        assert_eq!(c.client_bytes_read.iter().sum::<u64>(), c.bytes_read);
        assert_eq!(c.client_bytes_written.iter().sum::<u64>(), c.bytes_written);
        assert!(c.bytes_read > 0 && c.bytes_written > 0);
        assert_eq!(c.requests, 97);
        assert_eq!(c.latency.count(), 97);
        let s = d.stats();
        let by_client: u64 =
            Client::ALL.iter().map(|cl| s.counter(&format!("dram.bytes_read.{}", cl.name())).unwrap()).sum();
        assert_eq!(Some(by_client), s.counter("dram.bytes_read"));
        let by_client: u64 =
            Client::ALL.iter().map(|cl| s.counter(&format!("dram.bytes_written.{}", cl.name())).unwrap()).sum();
        assert_eq!(Some(by_client), s.counter("dram.bytes_written"));
        assert_eq!(s.defs(), DRAM_STATS);
    }

    #[test]
    fn one_request_per_cycle_and_at_most_max_outstanding() {
        let cfg = DramConfig { max_outstanding: 2, ..CFG };
        let mut d = Dram::new(cfg);
        d.tick(Cycle(0));
        assert!(d.will_accept(Cycle(0)));
        d.request(Cycle(0), Client::Output, Access::Write, 0, 32, 0).unwrap();
        assert!(!d.will_accept(Cycle(0)));
        let refused = d.request(Cycle(0), Client::TileFill, Access::Read, 0, 32, 1);
        assert_eq!(
            refused,
            Err(Request { client: Client::TileFill, access: Access::Read, addr: 0, bytes: 32, tag: 1 })
        );
        d.tick(Cycle(1));
        d.request(Cycle(1), Client::TileFill, Access::Read, 0, 32, 1).unwrap();
        d.tick(Cycle(2));
        assert!(!d.will_accept(Cycle(2)), "two outstanding");
        assert!(d.request(Cycle(2), Client::TileFill, Access::Read, 0, 32, 2).is_err());
        assert!(d.request(Cycle(2), Client::TileFill, Access::Read, 0, 32, 2).is_err());
        assert_eq!(d.counters().refused_cycles, 2);
        // First completes at 0 + 10 + 2 = 12, second at max(11*16, 12*16 + 0)... = 14.
        tick_to(&mut d, Cycle(3), Cycle(12));
        assert!(!d.will_accept(Cycle(12)));
        assert_eq!(d.completed(Cycle(12)), Some((0, Client::Output)));
        assert!(d.will_accept(Cycle(12)));
        assert_eq!(d.completed(Cycle(12)), None);
        tick_to(&mut d, Cycle(13), Cycle(14));
        assert_eq!(d.completed(Cycle(14)), Some((1, Client::TileFill)));
        assert_eq!(d.counters().outstanding_cycles, 14);
    }

    #[test]
    fn invalid_configs_name_the_knob() {
        for (cfg, knob) in [
            (DramConfig { peak_bytes_per_cycle: 0, ..CFG }, "dram_peak_bytes_per_cycle"),
            (DramConfig { latency_cycles: 2_000_000, ..CFG }, "dram_latency_cycles"),
            (DramConfig { burst_bytes: 48, ..CFG }, "dram_burst_bytes"),
            (DramConfig { burst_bytes: 0, ..CFG }, "dram_burst_bytes"),
            (DramConfig { max_outstanding: 0, ..CFG }, "dram_max_outstanding"),
        ] {
            let e = cfg.validate().unwrap_err();
            assert!(e.starts_with(knob), "{e}");
        }
        assert_eq!(CFG.validate(), Ok(()));
    }

    /// Drive two channels with the same random-ish request stream, cycle
    /// by cycle, and return what each handed back, per cycle.
    fn same_stream(mut a: Dram, mut b: Dram, cycles: u64) -> (Vec<(u64, u64, Client)>, Dram, Dram) {
        let mut out = vec![];
        for t in 0..cycles {
            let now = Cycle(t);
            a.tick(now);
            b.tick(now);
            loop {
                let (x, y) = (a.completed(now), b.completed(now));
                assert_eq!(x, y, "cycle {t}");
                let Some((tag, client)) = x else { break };
                out.push((t, tag, client));
            }
            assert_eq!(a.next_completion(), b.next_completion(), "cycle {t}");
            if t % 7 != 3 {
                let client = Client::ALL[(t % 4) as usize];
                let access = if t % 3 == 0 { Access::Write } else { Access::Read };
                let bytes = 1 + (t * 37) % 200;
                let (x, y) = (
                    a.request(now, client, access, t * 64, bytes, t),
                    b.request(now, client, access, t * 64, bytes, t),
                );
                assert_eq!(x, y, "cycle {t}");
            }
        }
        (out, a, b)
    }

    #[test]
    fn the_ideal_backend_through_the_trait_is_todays_model() {
        for cfg in [CFG, DramConfig { peak_bytes_per_cycle: 5, latency_cycles: 0, burst_bytes: 4, max_outstanding: 2 }]
        {
            let inline: Dram = Dram::new(cfg);
            let boxed: Dram = Dram::with_backend(cfg, Box::new(IdealBackend::new(cfg)));
            let (out, a, b) = same_stream(inline, boxed, 600);
            assert!(out.len() > 30, "{cfg:?}: {} completions", out.len());
            assert_eq!(a.counters(), b.counters());
            assert_eq!(format!("{:?}", a.stats()), format!("{:?}", b.stats()));
            assert_eq!((a.backend_name(), b.backend_name()), ("ideal", "ideal"));
            assert_eq!(a.backend_counters(), BackendCounters::default());
        }
    }

    /// A backend that knows nothing at acceptance: each request completes
    /// `10 + id % 5` cycles after it, so later ones can finish first.
    struct Shuffled {
        now: Cycle,
        pending: Vec<(u64, Cycle)>,
    }

    impl DramBackend for Shuffled {
        fn name(&self) -> &'static str {
            "shuffled"
        }
        fn tick(&mut self, now: Cycle) {
            self.now = now;
        }
        fn skip_to(&mut self, now: Cycle) {
            self.now = now;
        }
        fn accept(&mut self, now: Cycle, id: u64, _: Access, _: u64, _: u64) -> Option<Cycle> {
            self.pending.push((id, now + (10 + id % 5)));
            None
        }
        fn pop_done(&mut self, now: Cycle) -> Option<(u64, Cycle)> {
            let i = self.pending.iter().position(|&(_, d)| d <= now)?;
            Some(self.pending.remove(i))
        }
        fn next_event(&self) -> NextEvent {
            if self.pending.is_empty() { NextEvent::Idle } else { NextEvent::EveryCycle }
        }
    }

    #[test]
    fn an_external_backend_completes_out_of_order_and_is_counted_at_completion() {
        let mut d: Dram = Dram::with_backend(CFG, Box::new(Shuffled { now: Cycle(0), pending: vec![] }));
        d.record_requests();
        d.tick(Cycle(0));
        assert_eq!(d.next_completion(), None, "idle");
        // Ids 0..4, accepted at cycles 0..4, finish at 10, 12, 14, 16, 18;
        // id 5, accepted at 5, at 15: before ids 3 and 4.
        let mut done = vec![];
        for t in 0..40 {
            if t > 0 {
                d.tick(Cycle(t));
            }
            while let Some((tag, _)) = d.completed(Cycle(t)) {
                done.push((t, tag));
            }
            if t < 6 {
                d.request(Cycle(t), Client::TileFill, Access::Read, 0, 32, t).unwrap();
                assert_eq!(d.next_completion(), Some(Cycle(t + 1)), "unknown: every cycle");
            }
        }
        assert_eq!(done, [(10, 0), (12, 1), (14, 2), (15, 5), (16, 3), (18, 4)]);
        assert_eq!(d.outstanding(), 0);
        let c = d.counters();
        assert_eq!(c.latency.bins().collect::<Vec<_>>(), [(10, 2), (11, 1), (12, 1), (13, 1), (14, 1)]);
        assert_eq!(c.read_latency, c.latency);
        assert_eq!(c.peak_outstanding, 6);
        let spans = d.take_requests();
        assert_eq!(spans.iter().map(|s| s.done.get()).collect::<Vec<_>>(), [10, 12, 14, 16, 18, 15]);
    }

    #[test]
    #[should_panic(expected = "0 bytes")]
    fn a_zero_byte_request_panics() {
        let mut d = Dram::new(CFG);
        d.tick(Cycle(0));
        let _ = d.request(Cycle(0), Client::Output, Access::Read, 0, 0, 0);
    }
}
