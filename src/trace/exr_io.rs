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
//!   `valid` (1 = known, 0 = unknown: metrics skip the pixel); optional
//!   `nondiffuse` (1 = some sample of the pixel sees a specular or
//!   transparent surface: the mask of `docs/non-diffuse.md`).
//! - v2 layers, one record per super-sample of their reference (channel
//!   lists in [`read_fragment_layer`] and [`read_ray_tree_layer`]).
//!
//! Rules: where a surface is claimed, `Z` must be finite and positive, with
//! a finite `f32` reciprocal (so `Z >= 1/f32::MAX`, about 2.9e-39), and the
//! slopes finite; colours must be finite everywhere. Violations are errors
//! naming the file, the sample and the channel. Where no surface is claimed
//! (`valid` = 0) `Z` and the slopes are ignored, whatever they hold (NaN
//! included), and read as 0. The header is checked before any pixel is
//! decoded: one part, flat (not deep) data, the size the manifest gives,
//! every channel at full resolution; so a header claiming an absurd size is
//! an error, never a huge allocation. Files are written lossless to a
//! temporary name and renamed: ZIP compressed for what a trace stores
//! ([`ExrPacking::Small`]), run-length encoded for the frames a run writes
//! ([`ExrPacking::Fast`]: about a quarter less CPU for the whole `golden`
//! process on `traces/motorcycle`, files about a fifth larger). Blocks are
//! written in increasing order either way, so the bytes do not depend on
//! the thread count.

use super::layers::{Fragment, FragmentLayer, Node, NodeImage, RayTreeLayer, SpecularMaterial};
use super::{LoadedReference, SlopeSource, TraceError, TruthImage};
use crate::io_util::write_atomically;
use bitvec::vec::BitVec;
use exr::math::Vec2;
use exr::meta::MetaData;
use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, Layer, LayerAttributes, WritableImage, f16};
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
    reference_of_channels(Channels::decode(bytes, file, expected)?, expected)
}

/// Check a reference image's decoded channels (module rules) and convert
/// them to the loaded reference. Each channel is taken out of the decoded
/// ones as it becomes a plane (moved when stored as float), so the decoded
/// channels and the image are never both held whole (a loaded reference's
/// peak memory).
fn reference_of_channels(mut ch: Channels, expected: (u32, u32)) -> Result<LoadedReference, TraceError> {
    let (w, h) = expected;
    let n = w as usize * h as usize;
    let colour = ch.take_rgb()?;
    let z = ch.take_f32s("Z")?.ok_or_else(|| ch.err("missing channel `Z` (depth)"))?;
    let valid = ch.take_bits("valid")?.unwrap_or_else(|| BitVec::repeat(true, n));
    let object_id = ch.take_u32s("id")?.unwrap_or_else(|| vec![0; n]);
    let dx = ch.take_f32s("dinvz_dx")?;
    let dy = ch.take_f32s("dinvz_dy")?;
    let (inv_z_slopes, slopes) = match (dx, dy) {
        (Some(dx), Some(dy)) => (dx.into_iter().zip(dy).map(|(a, b)| [a, b]).collect(), SlopeSource::Exact),
        (None, None) => (vec![[0.0; 2]; n], SlopeSource::FiniteDifference),
        _ => return Err(ch.err("has only one of the channels `dinvz_dx`, `dinvz_dy`; expected both or neither")),
    };
    ch.list = Vec::new();
    let mut img = SampleImage { width: w, height: h, colour, z, inv_z_slopes, object_id, valid };
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
    let mut ch = Channels::decode(bytes, file, expected)?;
    let nondiffuse = ch.take_bits("nondiffuse")?;
    let seen = ch.take_bits("seen")?;
    let colour = ch.take_rgb()?;
    let n = expected.0 as usize * expected.1 as usize;
    let known = ch.take_bits("valid")?.unwrap_or_else(|| BitVec::repeat(true, n));
    Ok(TruthImage { width: expected.0, height: expected.1, colour, known, nondiffuse, seen })
}

/// Write a reference image. Slope channels are written only for
/// [`SlopeSource::Exact`]; `valid` only if some sample has no surface.
pub fn write_reference_image(path: &Path, img: &SampleImage, slopes: SlopeSource) -> Result<(), TraceError> {
    write_reference_image_packed(path, img, slopes, ExrPacking::Small)
}

/// How an EXR's pixel blocks are compressed (both lossless).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrPacking {
    /// ZIP, 16 scanlines per block: the trace's own files.
    Small,
    /// Run-length, one scanline per block: frames written by runs.
    Fast,
}

impl ExrPacking {
    fn encoding(self) -> Encoding {
        match self {
            ExrPacking::Small => Encoding::SMALL_LOSSLESS,
            ExrPacking::Fast => Encoding {
                compression: exr::compression::Compression::RLE,
                blocks: exr::image::Blocks::ScanLines,
                line_order: exr::meta::attribute::LineOrder::Increasing,
            },
        }
    }
}

/// [`write_reference_image`] with the blocks compressed as `packing` says.
pub fn write_reference_image_packed(
    path: &Path,
    img: &SampleImage,
    slopes: SlopeSource,
    packing: ExrPacking,
) -> Result<(), TraceError> {
    let planes = SamplePlanes {
        size: (img.width, img.height),
        colour: |i| img.colour[i],
        valid: &img.valid,
        z: |i| img.z[i],
        slopes: (slopes == SlopeSource::Exact).then_some(|i| img.inv_z_slopes[i]),
        id: |i| img.object_id[i],
    };
    write_sample_planes(path, &planes, packing)
}

/// A reference image's planes, some as functions of the sample index, for
/// [`write_sample_planes`] (a derived frame's planes need no
/// [`SampleImage`] copy).
pub struct SamplePlanes<'a, C, Z, S, I>
where
    C: Fn(usize) -> [f32; 3],
    Z: Fn(usize) -> f32,
    S: Fn(usize) -> [f32; 2],
    I: Fn(usize) -> u32,
{
    /// Width and height (samples).
    pub size: (u32, u32),
    /// Linear RGB of sample `i`.
    pub colour: C,
    /// Set where a surface is (Z and slopes are written as 0 elsewhere).
    pub valid: &'a BitVec,
    /// Z of sample `i` where valid.
    pub z: Z,
    /// 1/Z slopes of sample `i`, when exact (`None`: no slope channels).
    pub slopes: Option<S>,
    /// Object id of sample `i` (the channel is left out when every id is 0).
    pub id: I,
}

/// Write `p` as [`write_reference_image_packed`] writes a [`SampleImage`]
/// of the same values: the same channels, the same bytes.
pub fn write_sample_planes<C, Z, S, I>(
    path: &Path,
    p: &SamplePlanes<'_, C, Z, S, I>,
    packing: ExrPacking,
) -> Result<(), TraceError>
where
    C: Fn(usize) -> [f32; 3],
    Z: Fn(usize) -> f32,
    S: Fn(usize) -> [f32; 2],
    I: Fn(usize) -> u32,
{
    let n = p.size.0 as usize * p.size.1 as usize;
    let mut list: Vec<AnyChannel<FlatSamples>> = rgb_channels_of(n, &p.colour);
    let masked =
        |f: &dyn Fn(usize) -> f32| -> Vec<f32> { (0..n).map(|i| if p.valid[i] { f(i) } else { 0.0 }).collect() };
    list.push(AnyChannel::new("Z", FlatSamples::F32(masked(&p.z))));
    if let Some(s) = &p.slopes {
        list.push(AnyChannel::new("dinvz_dx", FlatSamples::F32(masked(&|i| s(i)[0]))));
        list.push(AnyChannel::new("dinvz_dy", FlatSamples::F32(masked(&|i| s(i)[1]))));
    }
    let id: Vec<u32> = (0..n).map(&p.id).collect();
    if id.iter().any(|&i| i != 0) {
        list.push(AnyChannel::new("id", FlatSamples::U32(id)));
    }
    if p.valid.not_any() || !p.valid.all() {
        list.push(mask_channel(p.valid));
    }
    write_channels(path, p.size, list, packing)
}

/// Write a ground-truth image (`valid` only if some pixel is unknown).
pub fn write_truth_image(path: &Path, t: &TruthImage) -> Result<(), TraceError> {
    let mut list = rgb_channels(&t.colour);
    if !t.known.all() {
        list.push(mask_channel(&t.known));
    }
    if let Some(m) = &t.seen {
        list.push(bit_channel("seen", m));
    }
    if let Some(m) = &t.nondiffuse {
        list.push(bit_channel("nondiffuse", m));
    }
    write_channels(path, (t.width, t.height), list, ExrPacking::Small)
}

fn rgb_channels(colour: &[[f32; 3]]) -> Vec<AnyChannel<FlatSamples>> {
    rgb_channels_of(colour.len(), &|i| colour[i])
}

/// The R, G, B channels (f16) of `n` samples whose colours `colour` gives.
fn rgb_channels_of(n: usize, colour: &impl Fn(usize) -> [f32; 3]) -> Vec<AnyChannel<FlatSamples>> {
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(k, name)| {
            AnyChannel::new(*name, FlatSamples::F16((0..n).map(|i| f16::from_f32(colour(i)[k])).collect()))
        })
        .collect()
}

fn mask_channel(mask: &BitVec) -> AnyChannel<FlatSamples> {
    bit_channel("valid", mask)
}

fn bit_channel(name: &str, mask: &BitVec) -> AnyChannel<FlatSamples> {
    AnyChannel::new(name, FlatSamples::F16(mask.iter().map(|b| f16::from_f32(if *b { 1.0 } else { 0.0 })).collect()))
}

fn write_channels(
    path: &Path,
    size: (u32, u32),
    list: Vec<AnyChannel<FlatSamples>>,
    packing: ExrPacking,
) -> Result<(), TraceError> {
    let channels = AnyChannels::sort(list.into_iter().collect());
    let layer = Layer::new(
        (size.0 as usize, size.1 as usize),
        LayerAttributes::named("postwarp"),
        packing.encoding(),
        channels,
    );
    let image = Image::from_layer(layer);
    // Blocks are compressed in parallel and written in increasing order
    // (`LineOrder::Increasing`): the same bytes whatever the thread count.
    // Reading stays sequential: a panic of the decoder on a malformed file
    // inside exr's own thread pool would abort the process instead of
    // becoming that file's error.
    write_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| TraceError::file(path, format!("cannot write EXR: {e}")))
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
        // A panic in the third-party decoder on a malformed file is that
        // file's error, not a crash of the tool.
        let list = std::panic::catch_unwind(|| super::exr_blocks::decode_channels(bytes))
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
            .map_err(|e| TraceError::file(path, format!("not a readable OpenEXR image: {e}")))?;
        Ok(Channels { path: path.to_path_buf(), list })
    }

    fn err(&self, msg: impl Into<String>) -> TraceError {
        TraceError::file(&self.path, msg)
    }

    /// The position of channel `name`, checked to hold half or float
    /// samples (`None` if absent).
    fn float_channel(&self, name: &str) -> Result<Option<usize>, TraceError> {
        match self.list.iter().position(|(n, _)| n == name) {
            Some(k) if matches!(self.list[k].1, FlatSamples::U32(_)) => {
                Err(self.err(format!("channel `{name}` is uint; expected half or float")))
            }
            k => Ok(k),
        }
    }

    /// The position of channel `name`, checked to hold uint samples
    /// (`None` if absent).
    fn uint_channel(&self, name: &str) -> Result<Option<usize>, TraceError> {
        match self.list.iter().position(|(n, _)| n == name) {
            Some(k) if !matches!(self.list[k].1, FlatSamples::U32(_)) => {
                Err(self.err(format!("channel `{name}` is half or float; expected uint")))
            }
            k => Ok(k),
        }
    }

    fn f32s(&self, name: &str) -> Result<Option<Vec<f32>>, TraceError> {
        Ok(self.float_channel(name)?.map(|k| self.list[k].1.values_as_f32().collect()))
    }

    fn u32s(&self, name: &str) -> Result<Option<Vec<u32>>, TraceError> {
        Ok(self.uint_channel(name)?.map(|k| match &self.list[k].1 {
            FlatSamples::U32(v) => v.clone(),
            _ => unreachable!("checked to be uint"),
        }))
    }

    /// [`Channels::f32s`], taking the channel out of the list (its samples
    /// moved, not copied, when stored as float): a decoder that takes each
    /// channel as it makes a plane never holds both whole.
    fn take_f32s(&mut self, name: &str) -> Result<Option<Vec<f32>>, TraceError> {
        let Some(k) = self.float_channel(name)? else { return Ok(None) };
        Ok(Some(match self.list.remove(k).1 {
            FlatSamples::F32(v) => v,
            other => other.values_as_f32().collect(),
        }))
    }

    /// [`Channels::u32s`], taking the channel out of the list.
    fn take_u32s(&mut self, name: &str) -> Result<Option<Vec<u32>>, TraceError> {
        let Some(k) = self.uint_channel(name)? else { return Ok(None) };
        match self.list.remove(k).1 {
            FlatSamples::U32(v) => Ok(Some(v)),
            _ => unreachable!("checked to be uint"),
        }
    }

    /// The `R`, `G`, `B` channels, taken out of the list, as one finite
    /// colour per sample. The channels are read as they are stored, not
    /// first widened to float planes: a trace's half colour would
    /// otherwise be held three times over while it is converted (a loaded
    /// reference's peak memory).
    fn take_rgb(&mut self) -> Result<Vec<[f32; 3]>, TraceError> {
        let mut planes = Vec::with_capacity(3);
        for name in ["R", "G", "B"] {
            let k = self.float_channel(name)?.ok_or_else(|| self.err(format!("missing colour channel `{name}`")))?;
            planes.push(self.list.remove(k).1);
        }
        let n = planes[0].len();
        let mut out = Vec::with_capacity(n);
        let mut rgb = planes.iter().map(|p| p.values_as_f32());
        let (r, g, b) = (rgb.next(), rgb.next(), rgb.next());
        let (Some(r), Some(g), Some(b)) = (r, g, b) else { unreachable!("three channels taken") };
        for (i, ((r, g), b)) in r.zip(g).zip(b).enumerate() {
            let c = [r, g, b];
            if !c.iter().all(|v| v.is_finite()) {
                return Err(self.err(format!("pixel {i}: colour {c:?} is not finite")));
            }
            out.push(c);
        }
        Ok(out)
    }

    /// A 0/1 channel, taken out of the list, as bits (`None` if absent),
    /// read as it is stored.
    fn take_bits(&mut self, name: &str) -> Result<Option<BitVec>, TraceError> {
        let Some(k) = self.float_channel(name)? else { return Ok(None) };
        let v = self.list.remove(k).1;
        let mut m = BitVec::with_capacity(v.len());
        for (i, x) in v.values_as_f32().enumerate() {
            match x {
                1.0 => m.push(true),
                0.0 => m.push(false),
                _ => return Err(self.err(format!("sample {i}: `{name}` = {x}; expected 0 or 1"))),
            }
        }
        Ok(Some(m))
    }

    /// A required half/float channel.
    fn need_f32s(&self, name: &str) -> Result<Vec<f32>, TraceError> {
        self.f32s(name)?.ok_or_else(|| self.err(format!("missing channel `{name}`")))
    }

    /// A required uint channel.
    fn need_u32s(&self, name: &str) -> Result<Vec<u32>, TraceError> {
        self.u32s(name)?.ok_or_else(|| self.err(format!("missing channel `{name}` (uint)")))
    }

    /// Required `P.R`, `P.G`, `P.B` channels (prefix `P`), finite.
    fn rgb_named(&self, prefix: &str) -> Result<Vec<[f32; 3]>, TraceError> {
        let planes: Vec<Vec<f32>> =
            ["R", "G", "B"].iter().map(|c| self.need_f32s(&format!("{prefix}.{c}"))).collect::<Result<_, _>>()?;
        let mut out = Vec::with_capacity(planes[0].len());
        for (i, ((r, g), b)) in planes[0].iter().zip(&planes[1]).zip(&planes[2]).enumerate() {
            let c = [*r, *g, *b];
            if !c.iter().all(|v| v.is_finite()) {
                return Err(self.err(format!("sample {i}: `{prefix}` colour {c:?} is not finite")));
            }
            out.push(c);
        }
        Ok(out)
    }

    /// `(x, y)` of sample `i` in a `w`-wide image, for messages.
    fn xy(i: usize, w: u32) -> (usize, usize) {
        (i % w as usize, i / w as usize)
    }
}

/// Depth a layer claims: finite, positive, with a finite reciprocal.
fn depth_ok(z: f32) -> bool {
    z.is_finite() && z > 0.0 && (1.0 / z).is_finite()
}

/// Read a transparent-fragment layer of `expected` `(width, height)`
/// samples storing `max` fragments per sample. Channels: `count` (uint,
/// 0 to `max`: fragments of the sample, nearest first); `opaque.R`,
/// `opaque.G`, `opaque.B` (colour of the opaque surface behind them); and
/// for each slot `k` in 0..`max`: `fK.R`, `fK.G`, `fK.B` (colour),
/// `fK.A` (opacity, 0 to 1), `fK.Z` (depth along the optical axis). Slots
/// at or past `count` are ignored (read as zeros); the others must have a
/// finite positive depth, not nearer than the slot before (ray order).
pub fn read_fragment_layer(path: &Path, expected: (u32, u32), max: u32) -> Result<FragmentLayer, TraceError> {
    let bytes = read_image_file(path)?;
    let ch = Channels::decode(&bytes, path, expected)?;
    let mut layer = FragmentLayer::empty(expected.0, expected.1, max);
    let count = ch.need_u32s("count")?;
    layer.opaque = ch.rgb_named("opaque")?;
    let n = max as usize;
    for k in 0..n {
        let c = ch.rgb_named(&format!("f{k}"))?;
        let a = ch.need_f32s(&format!("f{k}.A"))?;
        let z = ch.need_f32s(&format!("f{k}.Z"))?;
        for i in 0..layer.len() {
            if (k as u32) >= count[i].min(max) {
                continue;
            }
            let (x, y) = Channels::xy(i, expected.0);
            if !(0.0..=1.0).contains(&a[i]) {
                return Err(
                    ch.err(format!("sample ({x}, {y}): fragment {k} opacity f{k}.A = {}; expected 0 to 1", a[i]))
                );
            }
            if !depth_ok(z[i]) {
                return Err(ch.err(format!(
                    "sample ({x}, {y}): fragment {k} depth f{k}.Z = {:e}; expected a finite positive depth",
                    z[i]
                )));
            }
            layer.fragments[i * n + k] = Fragment { colour: c[i], alpha: a[i], z: z[i] };
        }
    }
    for (i, &c) in count.iter().enumerate() {
        let (x, y) = Channels::xy(i, expected.0);
        if c > max {
            return Err(ch.err(format!("sample ({x}, {y}): count = {c}; expected at most max = {max} fragments")));
        }
        layer.count[i] = c as u8;
        let f = layer.at(i);
        if let Some(k) = (1..f.len()).find(|&k| f[k].z < f[k - 1].z) {
            return Err(ch.err(format!(
                "sample ({x}, {y}): fragment {k} (Z = {}) is nearer than fragment {} (Z = {}); expected ray order, \
                 nearest first",
                f[k].z,
                k - 1,
                f[k - 1].z
            )));
        }
    }
    Ok(layer)
}

/// Write a transparent-fragment layer (channels as [`read_fragment_layer`]).
pub fn write_fragment_layer(path: &Path, l: &FragmentLayer) -> Result<(), TraceError> {
    let n = l.max as usize;
    let mut list = vec![AnyChannel::new("count", FlatSamples::U32(l.count.iter().map(|&c| c as u32).collect()))];
    list.extend(rgb_channels_named("opaque", &l.opaque));
    for k in 0..n {
        let slot: Vec<Fragment> = (0..l.len()).map(|i| l.fragments[i * n + k]).collect();
        let colour: Vec<[f32; 3]> = slot.iter().map(|f| f.colour).collect();
        list.extend(rgb_channels_named(&format!("f{k}"), &colour));
        list.push(AnyChannel::new(
            format!("f{k}.A").as_str(),
            FlatSamples::F16(slot.iter().map(|f| f16::from_f32(f.alpha)).collect()),
        ));
        list.push(AnyChannel::new(format!("f{k}.Z").as_str(), FlatSamples::F32(slot.iter().map(|f| f.z).collect())));
    }
    write_channels(path, (l.width, l.height), list, ExrPacking::Small)
}

/// Read a ray-tree layer of `expected` `(width, height)` samples with
/// material table `materials`. Channels: for each node `N` of `diffuse`,
/// `reflect`, `refract`: `N.R`, `N.G`, `N.B` (radiance, tint included,
/// Fresnel not), `N.Z` (depth: the root's along the optical axis, a
/// child's from the parent's hit along the child ray); `valid` (uint bits:
/// 1 diffuse, 2 reflect, 4 refract); `material` (uint: 0 none, `k` the
/// table's `k`-th entry). A valid node needs a finite positive depth; a
/// reflection or refraction needs a material, a refraction a dielectric;
/// depths of nodes that are not valid are ignored (read as 0).
pub fn read_ray_tree_layer(
    path: &Path,
    expected: (u32, u32),
    materials: &[SpecularMaterial],
) -> Result<RayTreeLayer, TraceError> {
    let bytes = read_image_file(path)?;
    let ch = Channels::decode(&bytes, path, expected)?;
    let mut layer = RayTreeLayer::empty(expected.0, expected.1, materials.to_vec());
    let valid = ch.need_u32s("valid")?;
    let material = ch.need_u32s("material")?;
    for i in 0..layer.len() {
        let (x, y) = Channels::xy(i, expected.0);
        if valid[i] > 7 {
            return Err(ch.err(format!("sample ({x}, {y}): valid = {}; expected bits 1, 2, 4 (at most 7)", valid[i])));
        }
        if material[i] as usize > materials.len() {
            return Err(ch.err(format!(
                "sample ({x}, {y}): material = {}; the manifest's table has {} entries",
                material[i],
                materials.len()
            )));
        }
        layer.valid[i] = valid[i] as u8;
        layer.material[i] = material[i] as u8;
        let specular = valid[i] as u8 & (Node::Reflect.bit() | Node::Refract.bit());
        match layer.material_at(i) {
            None if specular != 0 => {
                return Err(ch.err(format!(
                    "sample ({x}, {y}): a reflection or refraction node is valid but material = 0; expected the \
                     index of its material"
                )));
            }
            Some(SpecularMaterial::Mirror) if layer.has(i, Node::Refract) => {
                return Err(ch.err(format!(
                    "sample ({x}, {y}): a refraction node on a `mirror` material; expected a dielectric (an index of \
                     refraction)"
                )));
            }
            _ => {}
        }
    }
    for node in Node::ALL {
        let colour = ch.rgb_named(node.name())?;
        let mut depth = ch.need_f32s(&format!("{}.Z", node.name()))?;
        for (i, z) in depth.iter_mut().enumerate() {
            if !layer.has(i, node) {
                *z = 0.0;
            } else if !depth_ok(*z) {
                let (x, y) = Channels::xy(i, expected.0);
                return Err(ch.err(format!(
                    "sample ({x}, {y}): {}.Z = {z:e} where the node is valid; expected a finite positive depth",
                    node.name()
                )));
            }
        }
        layer.nodes[node as usize] = NodeImage { colour, depth };
    }
    Ok(layer)
}

/// Write a ray-tree layer (channels as [`read_ray_tree_layer`]).
pub fn write_ray_tree_layer(path: &Path, l: &RayTreeLayer) -> Result<(), TraceError> {
    let mut list = vec![
        AnyChannel::new("valid", FlatSamples::U32(l.valid.iter().map(|&v| v as u32).collect())),
        AnyChannel::new("material", FlatSamples::U32(l.material.iter().map(|&v| v as u32).collect())),
    ];
    for node in Node::ALL {
        let img = &l.nodes[node as usize];
        list.extend(rgb_channels_named(node.name(), &img.colour));
        let depth: Vec<f32> =
            img.depth.iter().enumerate().map(|(i, &z)| if l.has(i, node) { z } else { 0.0 }).collect();
        list.push(AnyChannel::new(format!("{}.Z", node.name()).as_str(), FlatSamples::F32(depth)));
    }
    write_channels(path, (l.width, l.height), list, ExrPacking::Small)
}

fn rgb_channels_named(prefix: &str, colour: &[[f32; 3]]) -> Vec<AnyChannel<FlatSamples>> {
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(k, c)| {
            AnyChannel::new(
                format!("{prefix}.{c}").as_str(),
                FlatSamples::F16(colour.iter().map(|v| f16::from_f32(v[k])).collect()),
            )
        })
        .collect()
}
