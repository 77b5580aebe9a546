//! Display read: after the last warp, the display controller reads the
//! finished frame from memory as the packer wrote it back.
//!
//! Job: queue one read per tile of the frame's packed bytes, in tile
//! order, at the memory port's lowest priority. The engine then runs the
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

use crate::mem::{Access, Client, MemPort, Req, Tag};

/// Queue the display's reads of a frame whose tiles occupy `packed_bytes`
/// in memory.
pub fn queue_frame_read(port: &mut MemPort, packed_bytes: &[u64]) {
    for &bytes in packed_bytes {
        port.output(Req { client: Client::Output, access: Access::Read, addr: 0, bytes, tag: Tag::Output });
    }
}
