//! The memory port: the warper's one command port into the DRAM channel.
//!
//! Job: hold the memory requests the units have queued and issue at most
//! one per cycle to the DRAM, by priority.
//!
//! Ports: in, requests queued by the fetch unit (source blocks), the
//! destination cache (tile loads and raw spills), the A-buffer packer
//! (write-backs) and the display (frame reads); out, one request per cycle
//! to [`Dram::request`].
//!
//! Throughput: one request issued per cycle (the DRAM's single command
//! port); a request of 0 bytes is dropped without reaching the DRAM.
//!
//! Rules:
//! 1. Priority: demand tile loads > write-backs and spills > source
//!    and tile prefetch (one queue) > display reads. Within a queue, oldest first.
//! 2. Only the head of the highest non-empty queue is offered; if the DRAM
//!    refuses it, nothing is issued this cycle (no bypass).
//! 3. Every request carries a [`Tag`] that comes back on its completion.
//!
//! Not modelled: the queues' capacity (the packer limits the write queue
//! itself), request merging, address generation (requests carry the
//! addresses of the memory map, `mem::layout`, computed by their units).

use super::dram::{Access, Client, Dram};
use crate::clock::Cycle;
use std::collections::VecDeque;

/// What a DRAM request is for, returned with its completion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Tag {
    /// A reference block read for the source cache: the block number and
    /// the number of the warp that asked (a prefetch still in flight when
    /// its warp ends is dropped on arrival, not given to the next warp's
    /// cache).
    Block {
        /// The block.
        block: u32,
        /// The warp's number in the frame's warp order.
        warp: u32,
    },
    /// A destination tile load (tile number); `fresh` for a compulsory
    /// load (the tile's cache-only planes are reset on arrival), not for a
    /// raw reload after a spill.
    Tile {
        /// The tile.
        tile: u32,
        /// Compulsory (true) or capacity (false) load.
        fresh: bool,
    },
    /// A tile write-back or spill (nothing to do on completion).
    Write,
    /// A display read (nothing to do on completion).
    Output,
}

/// A queued request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Req {
    /// Who asks.
    pub client: Client,
    /// Read or write.
    pub access: Access,
    /// First byte's DRAM address (bytes; `docs/memory-layout.md`).
    pub addr: u64,
    /// Bytes (before burst rounding; 0 is dropped).
    pub bytes: u64,
    /// Returned on completion.
    pub tag: Tag,
}

/// The request queues of the memory port.
#[derive(Clone, Debug, Default)]
pub struct MemPort {
    demand: VecDeque<Req>,
    writes: VecDeque<Req>,
    prefetch: VecDeque<Req>,
    output: VecDeque<Req>,
    /// Requests in all four queues.
    queued: usize,
}

impl MemPort {
    /// No request is waiting.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.queued == 0
    }

    /// Queue a demand tile load.
    pub fn demand(&mut self, r: Req) {
        self.demand.push_back(r);
        self.queued += 1;
    }

    /// Queue a write-back or spill.
    pub fn write(&mut self, r: Req) {
        self.writes.push_back(r);
        self.queued += 1;
    }

    /// Queue a source-block read.
    pub fn prefetch(&mut self, r: Req) {
        self.prefetch.push_back(r);
        self.queued += 1;
    }

    /// Queue a display read.
    pub fn output(&mut self, r: Req) {
        self.output.push_back(r);
        self.queued += 1;
    }

    /// Requests waiting in all queues (requests).
    #[inline]
    pub fn queued(&self) -> usize {
        self.queued
    }

    /// Writes waiting (requests).
    #[inline]
    pub fn writes_waiting(&self) -> usize {
        self.writes.len()
    }

    /// Issue at most one request at `now` (rules 1–2); true if one was
    /// accepted by the DRAM.
    #[inline(always)]
    pub fn issue(&mut self, dram: &mut Dram<Tag>, now: Cycle) -> bool {
        self.queued > 0 && self.issue_queued(dram, now)
    }

    #[inline(never)]
    fn issue_queued(&mut self, dram: &mut Dram<Tag>, now: Cycle) -> bool {
        for q in [&mut self.demand, &mut self.writes, &mut self.prefetch, &mut self.output] {
            // 0-byte requests are dropped; the next request of the same
            // queue is the head then (rule 1: a lower queue never passes).
            while q.front().is_some_and(|r| r.bytes == 0) {
                q.pop_front();
                self.queued -= 1;
            }
            if let Some(r) = q.front() {
                return match dram.request(now, r.client, r.access, r.addr, r.bytes, r.tag) {
                    Ok(()) => {
                        q.pop_front();
                        self.queued -= 1;
                        true
                    }
                    Err(_) => false,
                };
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::DramConfig;

    fn req(client: Client, tag: Tag) -> Req {
        Req { client, access: Access::Read, addr: 0, bytes: 32, tag }
    }

    #[test]
    fn one_request_per_cycle_by_priority() {
        let cfg = DramConfig { peak_bytes_per_cycle: 32, latency_cycles: 0, burst_bytes: 32, max_outstanding: 8 };
        let mut d: Dram<Tag> = Dram::new(cfg);
        let mut p = MemPort::default();
        p.output(req(Client::Output, Tag::Output));
        p.prefetch(req(Client::ReferenceFetch, Tag::Block { block: 7, warp: 0 }));
        p.write(Req { bytes: 0, ..req(Client::TileWriteBack, Tag::Write) });
        p.demand(req(Client::TileFill, Tag::Tile { tile: 3, fresh: true }));
        let mut order = vec![];
        for t in 0..4 {
            d.tick(Cycle(t));
            while let Some((tag, _)) = d.completed(Cycle(t)) {
                order.push(tag);
            }
            assert_eq!(p.issue(&mut d, Cycle(t)), t < 3, "cycle {t}");
            assert!(!p.issue(&mut d, Cycle(t)), "a second request in cycle {t}");
        }
        // The 0-byte write was dropped, never issued.
        assert_eq!(order, [Tag::Tile { tile: 3, fresh: true }, Tag::Block { block: 7, warp: 0 }, Tag::Output]);
        assert!(p.is_empty());
    }
}
