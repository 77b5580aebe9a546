//! Display read: after the last warp, the display controller reads the
//! finished frame from memory as the packer wrote it back.
//!
//! Job: queue one read per tile of the frame's packed bytes, in tile
//! order, from the tile's slot of the memory map (`mem::layout`,
//! `dest_tiles`: the display reads the frame in place), at the memory port's lowest priority. The engine then runs the
//! memory until every read has completed; those cycles are part of the
//! frame's `cycles`, with every warper unit idle.
//!
//! Ports: out, display reads (`Client::Output`) to the memory port.
//!
//! Throughput: the channel's; one request per tile.
//!
//! Rules: a tile never written back (0 bytes) costs no request (the port
//! drops 0-byte requests).
//!
//! Not modelled: the display's scan-out timing and its line buffers; the
//! box filter (`units::resolve`) runs outside the cycle count.

use super::dest_cache::DestCache;
use crate::mem::{Access, Client, MemPort, Req, Tag};

/// Queue the display's reads of the frame whose tiles `cache` last wrote
/// back (their packed sizes and addresses).
pub fn queue_frame_read(port: &mut MemPort, cache: &DestCache) {
    for (t, &bytes) in cache.packed_bytes().iter().enumerate() {
        let addr = cache.tile_addr(t as u32);
        port.output(Req { client: Client::Output, access: Access::Read, addr, bytes, tag: Tag::Output });
    }
}
