//! Decoding the pixels of a flat, single-part OpenEXR image on rayon's
//! pool: the file's chunks are decompressed in parallel, a batch at a
//! time, and placed into the channels in file order.
//!
//! Why: exr's own sequential decoder made loading a reference the longest
//! serial step of `simulate` (`docs/performance.md`), and exr's own
//! parallel decoder runs on a thread pool of its own, where a panic while
//! decompressing a malformed chunk aborts the process. On rayon's pool a
//! panic returns to the caller, whose `catch_unwind` makes it that file's
//! error.
//!
//! Rules:
//! 1. Only blocks of the largest resolution level are read (exr's
//!    `largest_resolution_level`); the caller has checked that the file
//!    has one part, no deep data and no subsampled channel.
//! 2. At most [`BATCH`] blocks are held decompressed at once; each batch is
//!    placed in file order, so even a malformed file whose blocks overlap
//!    decodes to the same samples on any number of threads.
//! 3. A block line outside the image, or whose bytes do not fit its
//!    channel's sample type, is an error. A panic inside exr's own code
//!    (decompression, or a block shorter than its lines) reaches the
//!    caller's `catch_unwind`, on any thread.
//! 4. Samples that no block covers stay zero, as exr's decoder leaves them.
//!
//! Not handled: deep data, multi-part files, subsampled channels (refused
//! by the caller).

use exr::block::UncompressedBlock;
use exr::block::chunk::Chunk;
use exr::meta::attribute::SampleType;
use exr::prelude::{FlatSamples, Vec2, f16};
use rayon::prelude::*;
use std::io::Cursor;

/// Blocks decompressed together (rule 2): a few per thread of a small
/// machine, a few MB of a 2000-sample-wide image.
const BATCH: usize = 16;

/// The channels of the file's one part, in the header's order (sorted by
/// name), each `width x height` samples of the file's sample type.
pub(super) fn decode_channels(bytes: &[u8]) -> Result<Vec<(String, FlatSamples)>, String> {
    let reader = exr::block::read(Cursor::new(bytes), false).map_err(|e| e.to_string())?;
    let meta = reader.meta_data().clone();
    let header = meta.headers.first().ok_or_else(|| invalid("no header"))?;
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    let n = w.checked_mul(h).ok_or_else(|| invalid("image size"))?;
    let mut planes: Vec<(String, FlatSamples)> = header
        .channels
        .list
        .iter()
        .map(|c| {
            let samples = match c.sample_type {
                SampleType::F16 => FlatSamples::F16(vec![f16::ZERO; n]),
                SampleType::F32 => FlatSamples::F32(vec![0.0; n]),
                SampleType::U32 => FlatSamples::U32(vec![0; n]),
            };
            (c.name.to_string(), samples)
        })
        .collect();
    let mut chunks = reader.filter_chunks(false, |_, _, block| block.level == Vec2(0, 0)).map_err(|e| e.to_string())?;
    let mut batch: Vec<Chunk> = Vec::with_capacity(BATCH);
    loop {
        batch.clear();
        for chunk in chunks.by_ref().take(BATCH) {
            batch.push(chunk.map_err(|e| e.to_string())?);
        }
        if batch.is_empty() {
            return Ok(planes);
        }
        let blocks: Vec<UncompressedBlock> = std::mem::take(&mut batch)
            .into_par_iter()
            .map(|c| UncompressedBlock::decompress_chunk(c, &meta, false))
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?;
        for block in &blocks {
            place(block, header, (w, h), &mut planes)?;
        }
    }
}

/// Copy a decompressed block's lines into the channels (rule 3).
fn place(
    block: &UncompressedBlock,
    header: &exr::meta::header::Header,
    (w, h): (usize, usize),
    planes: &mut [(String, FlatSamples)],
) -> Result<(), String> {
    for line in block.lines(&header.channels) {
        let at = line.location;
        let (x, y, count) = (at.position.x(), at.position.y(), at.sample_count);
        if y >= h || x.checked_add(count).is_none_or(|end| end > w) {
            return Err(invalid("block line outside the image"));
        }
        let start = y * w + x;
        let Some((_, samples)) = planes.get_mut(at.channel) else {
            return Err(invalid("block line of an unknown channel"));
        };
        let fits = |size: usize| line.value.len() == count * size;
        match samples {
            FlatSamples::F16(v) if fits(2) => {
                line.read_samples_into_slice(&mut v[start..start + count]).map_err(|e| e.to_string())?
            }
            FlatSamples::F32(v) if fits(4) => {
                line.read_samples_into_slice(&mut v[start..start + count]).map_err(|e| e.to_string())?
            }
            FlatSamples::U32(v) if fits(4) => {
                line.read_samples_into_slice(&mut v[start..start + count]).map_err(|e| e.to_string())?
            }
            _ => return Err(invalid("block line size does not match its sample type")),
        }
    }
    Ok(())
}

/// A malformed file's error.
fn invalid(what: &str) -> String {
    format!("invalid: {what}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::prelude::{
        AnyChannel, AnyChannels, Blocks, Encoding, Image, Layer, LayerAttributes, LineOrder, ReadChannels, ReadLayers,
        SmallVec, WritableImage, read,
    };

    /// A `w x h` image with a half, a float and a uint channel of
    /// position-dependent values, written with `encoding`.
    fn file(w: usize, h: usize, encoding: Encoding) -> Vec<u8> {
        let n = w * h;
        let half: Vec<f16> = (0..n).map(|i| f16::from_f32((i % 97) as f32 / 7.0)).collect();
        let float: Vec<f32> = (0..n).map(|i| (i as f32 * 0.37).sin() * 1e3).collect();
        let uint: Vec<u32> = (0..n).map(|i| (i as u32).wrapping_mul(2_654_435_761)).collect();
        let channels = AnyChannels::sort(SmallVec::from_vec(vec![
            AnyChannel::new("R", FlatSamples::F16(half)),
            AnyChannel::new("Z", FlatSamples::F32(float)),
            AnyChannel::new("id", FlatSamples::U32(uint)),
        ]));
        let layer = Layer::new((w, h), LayerAttributes::default(), encoding, channels);
        let mut bytes = Vec::new();
        Image::from_layer(layer).write().to_buffered(std::io::Cursor::new(&mut bytes)).expect("written");
        bytes
    }

    /// exr's own sequential decoder, the reference.
    fn sequential(bytes: &[u8]) -> Vec<(String, FlatSamples)> {
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_buffered(Cursor::new(bytes))
            .expect("exr decodes its own file");
        image.layer_data.channel_data.list.into_iter().map(|c| (c.name.to_string(), c.sample_data)).collect()
    }

    fn on_threads(threads: usize, bytes: &[u8]) -> Vec<(String, FlatSamples)> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| decode_channels(bytes)).expect("decoded")
    }

    #[test]
    fn every_encoding_decodes_as_exr_itself_does_on_any_thread_count() {
        use exr::compression::Compression::*;
        let tiles = Blocks::Tiles(Vec2(16, 8));
        for compression in [Uncompressed, RLE, ZIP1, ZIP16, PIZ, PXR24] {
            for blocks in [Blocks::ScanLines, tiles] {
                for line_order in [LineOrder::Increasing, LineOrder::Decreasing] {
                    let bytes = file(53, 41, Encoding { compression, blocks, line_order });
                    let want = sequential(&bytes);
                    for threads in [1, 3] {
                        let got = on_threads(threads, &bytes);
                        assert_eq!(got, want, "{compression:?} {blocks:?} {line_order:?} on {threads} threads");
                    }
                }
            }
        }
    }

    #[test]
    fn a_damaged_file_is_an_error_or_a_panic_the_caller_catches_never_a_hang() {
        let bytes = file(40, 40, Encoding::SMALL_LOSSLESS);
        // Every truncation and a flipped byte in each stretch of the chunks.
        for cut in (0..bytes.len()).step_by(97) {
            let r = std::panic::catch_unwind(|| decode_channels(&bytes[..cut]));
            assert!(!matches!(r, Ok(Ok(_))), "a file cut at byte {cut} of {} decoded", bytes.len());
        }
        for at in (bytes.len() / 2..bytes.len()).step_by(61) {
            let mut b = bytes.clone();
            b[at] ^= 0x5a;
            // Decoding either fails or gives whole planes; it returns.
            if let Ok(Ok(planes)) = std::panic::catch_unwind(|| decode_channels(&b)) {
                assert!(planes.iter().all(|(_, s)| s.len() == 40 * 40));
            }
        }
    }
}
