//! OpenEXR images of a trace: reference frames and ground truth.
//!
//! Channels (also in `docs/trace-format.md`):
//! - reference frames, one record per super-sample: `R`, `G`, `B` linear
//!   colour (half or float; written as half); `Z` depth along the optical axis
//!   (float, scene units); optional `dinvz_dx`, `dinvz_dy` screen-space slopes
//!   of 1/Z per sample step (float; both or neither); optional `id` object id
//!   (uint); optional `valid` (1 = the sample sees a surface, 0 = no surface;
//!   absent = every sample sees one).
//! - ground truth, one record per display pixel: `R`, `G`, `B`; optional
//!   `valid` (1 = known, 0 = unknown: metrics skip the pixel).
//!
//! Rules: where a surface is claimed, `Z` must be finite and positive, with
//! a finite `f32` reciprocal (so `Z >= 1/f32::MAX`, about 2.9e-39), and the
//! slopes finite; colours must be finite everywhere. Violations are errors
//! naming the file, the sample and the channel. Where no surface is claimed
//! (`valid` = 0) `Z` and the slopes are ignored, whatever they hold (NaN
//! included), and read as 0. The header is checked before any pixel is
//! decoded: one part, flat (not deep) data, the size the manifest gives,
//! every channel at full resolution; so a header claiming an absurd size is
//! an error, never a huge allocation. Files are written ZIP compressed
//! (lossless) to a temporary name and renamed.

use super::{LoadedReference, SlopeSource, TraceError, TruthImage};
use crate::io_util::write_atomically;
use bitvec::vec::BitVec;
use exr::math::Vec2;
use exr::meta::MetaData;
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, ReadChannels, ReadLayers,
    WritableImage, f16, read,
};
use postwarp_rtl::SampleImage;
use std::io::Cursor;
use std::path::Path;

/// The bytes of an image file; a missing file is named as such.
fn read_image_file(path: &Path) -> Result<Vec<u8>, TraceError> {
    crate::io_util::read_input(path, "image file").map_err(|e| TraceError::file(path, e.message))
}

/// Read a reference image of `expected` `(width, height)` samples.
pub fn read_reference_image(path: &Path, expected: (u32, u32)) -> Result<LoadedReference, TraceError> {
    decode_reference_image(&read_image_file(path)?, path, expected)
}

/// Decode the bytes of a reference image file of `expected` `(width,
/// height)` samples; `file` only names the source in errors.
pub fn decode_reference_image(bytes: &[u8], file: &Path, expected: (u32, u32)) -> Result<LoadedReference, TraceError> {
    let ch = Channels::decode(bytes, file, expected)?;
    let (w, h) = expected;
    let n = w as usize * h as usize;
    let mut img = SampleImage::empty(w, h);
    img.colour = ch.rgb()?;
    img.z = ch.f32s("Z")?.ok_or_else(|| ch.err("missing channel `Z` (depth)"))?;
    img.valid = ch.mask()?;
    if let Some(ids) = ch.u32s("id")? {
        img.object_id = ids;
    }
    let dx = ch.f32s("dinvz_dx")?;
    let dy = ch.f32s("dinvz_dy")?;
    let slopes = match (dx, dy) {
        (Some(dx), Some(dy)) => {
            img.inv_z_slopes = dx.into_iter().zip(dy).map(|(a, b)| [a, b]).collect();
            SlopeSource::Exact
        }
        (None, None) => SlopeSource::FiniteDifference,
        _ => return Err(ch.err("has only one of the channels `dinvz_dx`, `dinvz_dy`; expected both or neither")),
    };
    for i in 0..n {
        let (x, y) = (i % w as usize, i / w as usize);
        if !img.valid[i] {
            // No surface: depth and slopes mean nothing; never pass on NaN.
            img.z[i] = 0.0;
            img.inv_z_slopes[i] = [0.0; 2];
            continue;
        }
        let z = img.z[i];
        // 1/Z must be a finite f32 too (Z >= 2.9e-39), or slopes from
        // finite differences, and the engines' 1/Z, would be infinite.
        if !(z.is_finite() && z > 0.0 && (1.0 / z).is_finite()) {
            return Err(ch.err(format!(
                "sample ({x}, {y}): depth Z = {z:e} where a surface is claimed; expected a finite positive depth \
                 whose reciprocal is finite (Z >= {:e}; mark samples without a surface with valid = 0)",
                1.0 / f32::MAX
            )));
        }
        if slopes == SlopeSource::Exact && !img.inv_z_slopes[i].iter().all(|s| s.is_finite()) {
            return Err(ch.err(format!("sample ({x}, {y}): 1/Z slope {:?} is not finite", img.inv_z_slopes[i])));
        }
    }
    if slopes == SlopeSource::FiniteDifference {
        img.slopes_from_depth();
    }
    Ok(LoadedReference { samples: img, slopes })
}

/// Read a ground-truth image of `expected` `(width, height)` pixels.
pub fn read_truth_image(path: &Path, expected: (u32, u32)) -> Result<TruthImage, TraceError> {
    decode_truth_image(&read_image_file(path)?, path, expected)
}

/// Decode the bytes of a ground-truth image file of `expected` `(width,
/// height)` pixels; `file` only names the source in errors.
pub fn decode_truth_image(bytes: &[u8], file: &Path, expected: (u32, u32)) -> Result<TruthImage, TraceError> {
    let ch = Channels::decode(bytes, file, expected)?;
    Ok(TruthImage { width: expected.0, height: expected.1, colour: ch.rgb()?, known: ch.mask()? })
}

/// Write a reference image. Slope channels are written only for
/// [`SlopeSource::Exact`]; `valid` only if some sample has no surface.
pub fn write_reference_image(path: &Path, img: &SampleImage, slopes: SlopeSource) -> Result<(), TraceError> {
    let mut list: Vec<AnyChannel<FlatSamples>> = rgb_channels(&img.colour);
    let masked =
        |v: &[f32]| -> Vec<f32> { v.iter().enumerate().map(|(i, &z)| if img.valid[i] { z } else { 0.0 }).collect() };
    list.push(AnyChannel::new("Z", FlatSamples::F32(masked(&img.z))));
    if slopes == SlopeSource::Exact {
        let dx: Vec<f32> = img.inv_z_slopes.iter().map(|s| s[0]).collect();
        let dy: Vec<f32> = img.inv_z_slopes.iter().map(|s| s[1]).collect();
        list.push(AnyChannel::new("dinvz_dx", FlatSamples::F32(masked(&dx))));
        list.push(AnyChannel::new("dinvz_dy", FlatSamples::F32(masked(&dy))));
    }
    if img.object_id.iter().any(|&i| i != 0) {
        list.push(AnyChannel::new("id", FlatSamples::U32(img.object_id.clone())));
    }
    if img.valid.not_any() || !img.valid.all() {
        list.push(mask_channel(&img.valid));
    }
    write_channels(path, (img.width, img.height), list)
}

/// Write a ground-truth image (`valid` only if some pixel is unknown).
pub fn write_truth_image(path: &Path, t: &TruthImage) -> Result<(), TraceError> {
    let mut list = rgb_channels(&t.colour);
    if !t.known.all() {
        list.push(mask_channel(&t.known));
    }
    write_channels(path, (t.width, t.height), list)
}

fn rgb_channels(colour: &[[f32; 3]]) -> Vec<AnyChannel<FlatSamples>> {
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(k, name)| AnyChannel::new(*name, FlatSamples::F16(colour.iter().map(|c| f16::from_f32(c[k])).collect())))
        .collect()
}

fn mask_channel(mask: &BitVec) -> AnyChannel<FlatSamples> {
    AnyChannel::new("valid", FlatSamples::F16(mask.iter().map(|b| f16::from_f32(if *b { 1.0 } else { 0.0 })).collect()))
}

fn write_channels(path: &Path, size: (u32, u32), list: Vec<AnyChannel<FlatSamples>>) -> Result<(), TraceError> {
    let channels = AnyChannels::sort(list.into_iter().collect());
    let layer = Layer::new(
        (size.0 as usize, size.1 as usize),
        LayerAttributes::named("postwarp"),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| {
        image.write().non_parallel().to_file(tmp).map_err(|e| TraceError::file(path, format!("cannot write EXR: {e}")))
    })
}

/// The channels of one EXR layer, checked against the expected size.
struct Channels {
    path: std::path::PathBuf,
    list: Vec<(String, FlatSamples)>,
}

impl Channels {
    /// Check the header against `expected`, then decode the pixels.
    fn decode(bytes: &[u8], path: &Path, expected: (u32, u32)) -> Result<Channels, TraceError> {
        let unreadable = |e: exr::error::Error| TraceError::file(path, format!("not a readable OpenEXR image: {e}"));
        // The header first: nothing is allocated for the pixels until the
        // size and the channels are known to be what the manifest says.
        let meta = MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(unreadable)?;
        let [header] = meta.headers.as_slice() else {
            return Err(TraceError::file(
                path,
                format!("has {} parts; expected a single-part OpenEXR image", meta.headers.len()),
            ));
        };
        if header.deep {
            return Err(TraceError::file(path, "holds deep data; expected a flat (scan-line or tiled) image"));
        }
        let size = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        let want = (expected.0 as u64, expected.1 as u64);
        if size != want {
            return Err(TraceError::file(
                path,
                format!("image is {}x{}; expected {}x{} as the manifest says", size.0, size.1, want.0, want.1),
            ));
        }
        if let Some(c) = header.channels.list.iter().find(|c| c.sampling != Vec2(1, 1)) {
            return Err(TraceError::file(
                path,
                format!(
                    "channel `{}` is subsampled ({}x{}); expected every channel at full resolution",
                    c.name, c.sampling.0, c.sampling.1
                ),
            ));
        }
        let decode = || {
            read()
                .no_deep_data()
                .largest_resolution_level()
                .all_channels()
                .first_valid_layer()
                .all_attributes()
                .non_parallel()
                .from_buffered(Cursor::new(bytes))
        };
        // A panic in the third-party decoder on a malformed file is that
        // file's error, not a crash of the tool.
        let image = std::panic::catch_unwind(decode)
            .map_err(|p| {
                let why =
                    p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned());
                TraceError::file(
                    path,
                    format!(
                        "not a readable OpenEXR image: the decoder failed ({}); expected a well-formed file",
                        why.unwrap_or_else(|| "panic".into())
                    ),
                )
            })?
            .map_err(unreadable)?;
        let layer = image.layer_data;
        let n = want.0 * want.1;
        if (layer.size.0 as u64, layer.size.1 as u64) != want {
            return Err(TraceError::file(path, format!("decoded layer is {}x{}", layer.size.0, layer.size.1)));
        }
        let mut list = Vec::with_capacity(layer.channel_data.list.len());
        for c in layer.channel_data.list {
            if c.sample_data.len() as u64 != n {
                return Err(TraceError::file(
                    path,
                    format!("channel `{}` has {} samples; expected {n}", c.name, c.sample_data.len()),
                ));
            }
            list.push((c.name.to_string(), c.sample_data));
        }
        Ok(Channels { path: path.to_path_buf(), list })
    }

    fn err(&self, msg: impl Into<String>) -> TraceError {
        TraceError::file(&self.path, msg)
    }

    fn get(&self, name: &str) -> Option<&FlatSamples> {
        self.list.iter().find(|(n, _)| n == name).map(|(_, s)| s)
    }

    fn f32s(&self, name: &str) -> Result<Option<Vec<f32>>, TraceError> {
        match self.get(name) {
            None => Ok(None),
            Some(FlatSamples::U32(_)) => Err(self.err(format!("channel `{name}` is uint; expected half or float"))),
            Some(s) => Ok(Some(s.values_as_f32().collect())),
        }
    }

    fn u32s(&self, name: &str) -> Result<Option<Vec<u32>>, TraceError> {
        match self.get(name) {
            None => Ok(None),
            Some(FlatSamples::U32(v)) => Ok(Some(v.clone())),
            Some(_) => Err(self.err(format!("channel `{name}` is half or float; expected uint"))),
        }
    }

    fn rgb(&self) -> Result<Vec<[f32; 3]>, TraceError> {
        let mut planes = Vec::with_capacity(3);
        for name in ["R", "G", "B"] {
            planes.push(self.f32s(name)?.ok_or_else(|| self.err(format!("missing colour channel `{name}`")))?);
        }
        let mut out = Vec::with_capacity(planes[0].len());
        for (i, ((r, g), b)) in planes[0].iter().zip(&planes[1]).zip(&planes[2]).enumerate() {
            let c = [*r, *g, *b];
            if !c.iter().all(|v| v.is_finite()) {
                return Err(self.err(format!("pixel {i}: colour {c:?} is not finite")));
            }
            out.push(c);
        }
        Ok(out)
    }

    fn mask(&self) -> Result<BitVec, TraceError> {
        let n = self.list.first().map(|(_, s)| s.len()).unwrap_or(0);
        match self.f32s("valid")? {
            None => Ok(BitVec::repeat(true, n)),
            Some(v) => {
                let mut m = BitVec::with_capacity(n);
                for (i, x) in v.into_iter().enumerate() {
                    match x {
                        1.0 => m.push(true),
                        0.0 => m.push(false),
                        _ => return Err(self.err(format!("sample {i}: `valid` = {x}; expected 0 or 1"))),
                    }
                }
                Ok(m)
            }
        }
    }
}
