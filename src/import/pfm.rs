//! Portable Float Map (PFM) reader: the format Middlebury uses for disparity.
//!
//! Format: an ASCII header of three whitespace-separated fields after the
//! magic — `PF` (3 channels, RGB interleaved) or `Pf` (1 channel) — then
//! `width height`, then `scale`, whose sign gives the byte order of the data
//! (negative = little-endian, positive = big-endian; its magnitude is
//! ignored). Exactly one whitespace byte ends the header, followed by
//! `width · height · channels` IEEE-754 `f32` values, rows stored
//! bottom-to-top.
//!
//! Rules: [`read_pfm`] returns rows top-to-bottom; values are passed through
//! unchanged (`inf`, `NaN` included: what they mean is the caller's
//! business). Every malformed input is an error naming the file and what was
//! expected — bad magic, bad header, zero or absurd sizes (more than
//! [`MAX_SIDE`] a side), truncated data, trailing bytes — never a panic.

use crate::trace::MAX_SIDE;
use std::fmt;
use std::path::{Path, PathBuf};

/// A decoded PFM image.
#[derive(Clone, Debug, PartialEq)]
pub struct PfmImage {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Values per pixel: 1 (`Pf`) or 3 (`PF`).
    pub channels: usize,
    /// `width · height · channels` values, row-major, rows top-to-bottom,
    /// channels interleaved.
    pub data: Vec<f32>,
}

impl PfmImage {
    /// Value of channel `c` at pixel `(x, y)` (`y = 0` is the top row).
    pub fn get(&self, x: u32, y: u32, c: usize) -> f32 {
        self.data[(y as usize * self.width as usize + x as usize) * self.channels + c]
    }
}

/// A PFM file that could not be read: the file and what was wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct PfmError {
    /// The file at fault.
    pub file: PathBuf,
    /// What was wrong and what was expected.
    pub message: String,
}

impl fmt::Display for PfmError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.message)
    }
}

impl std::error::Error for PfmError {}

/// Read a PFM file (rows returned top-to-bottom).
pub fn read_pfm(path: &Path) -> Result<PfmImage, PfmError> {
    let bytes = crate::io_util::read_input(path, "PFM file").map_err(|e| err(path, e.message))?;
    parse_pfm(&bytes, path)
}

/// Decode PFM bytes; `file` only names the source in errors.
pub fn parse_pfm(bytes: &[u8], file: &Path) -> Result<PfmImage, PfmError> {
    let mut pos = 0;
    let magic = token(bytes, &mut pos);
    let channels = match magic {
        Some(b"Pf") => 1,
        Some(b"PF") => 3,
        _ => {
            let shown = magic.map(lossy).unwrap_or_default();
            return Err(err(file, format!("bad magic `{shown}`: expected `Pf` (greyscale) or `PF` (colour) PFM")));
        }
    };
    let width = size_field(bytes, &mut pos, file, "width")?;
    let height = size_field(bytes, &mut pos, file, "height")?;
    let scale_tok = token(bytes, &mut pos).ok_or_else(|| header_err(file, "scale", "end of file"))?;
    let scale = std::str::from_utf8(scale_tok)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s != 0.0)
        .ok_or_else(|| header_err(file, "scale", &format!("`{}`", lossy(scale_tok))))?;
    // Exactly one whitespace byte separates the header from the data.
    match bytes.get(pos) {
        Some(b) if b.is_ascii_whitespace() => pos += 1,
        _ => return Err(err(file, "bad header: expected a single whitespace byte after the scale, then the data")),
    }
    let little_endian = scale < 0.0;

    let (w, h) = (width as usize, height as usize);
    let n = w * h * channels;
    let need = n * 4;
    let data = &bytes[pos..];
    if data.len() < need {
        return Err(err(
            file,
            format!(
                "truncated data: a {width}x{height} {} PFM needs {need} bytes of data after the header, found {}",
                if channels == 1 { "greyscale" } else { "colour" },
                data.len()
            ),
        ));
    }
    if data.len() > need {
        return Err(err(
            file,
            format!(
                "{} unexpected bytes after the {need} bytes of {width}x{height}x{channels} data \
                 (wrong size in the header?)",
                data.len() - need
            ),
        ));
    }
    let row_len = w * channels;
    let mut out = Vec::with_capacity(n);
    for y in 0..h {
        // Row y from the top is row h-1-y in file order (bottom-to-top).
        let row = &data[(h - 1 - y) * row_len * 4..(h - y) * row_len * 4];
        out.extend(row.chunks_exact(4).map(|c| {
            let b = [c[0], c[1], c[2], c[3]];
            if little_endian { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }
        }));
    }
    Ok(PfmImage { width, height, channels, data: out })
}

fn err(file: &Path, message: impl Into<String>) -> PfmError {
    PfmError { file: file.to_path_buf(), message: message.into() }
}

fn header_err(file: &Path, field: &str, found: &str) -> PfmError {
    let expected = match field {
        "scale" => "a finite non-zero number (negative = little-endian, positive = big-endian)".to_string(),
        _ => format!("an integer from 1 to {MAX_SIDE}"),
    };
    err(file, format!("bad header: {field} is {found}; expected {expected}"))
}

/// Longest header token accepted (keeps a binary file from being read as one).
const MAX_TOKEN: usize = 32;

/// Skip whitespace, then return the next whitespace-delimited token (at most
/// [`MAX_TOKEN`] bytes; a longer run is returned truncated, which no field
/// accepts), leaving `pos` just after it.
fn token<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let start = *pos;
    while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() && *pos - start < MAX_TOKEN {
        *pos += 1;
    }
    if *pos == start { None } else { Some(&bytes[start..*pos]) }
}

fn size_field(bytes: &[u8], pos: &mut usize, file: &Path, field: &str) -> Result<u32, PfmError> {
    let tok = token(bytes, pos).ok_or_else(|| header_err(file, field, "missing (end of file)"))?;
    let text = lossy(tok);
    let v: u64 = text.parse().map_err(|_| header_err(file, field, &format!("`{text}`")))?;
    if v == 0 || v > MAX_SIDE as u64 {
        return Err(err(file, format!("absurd size: {field} is {v}; expected an integer from 1 to {MAX_SIDE}")));
    }
    Ok(v as u32)
}

fn lossy(tok: &[u8]) -> String {
    tok.iter().map(|&b| show_byte(b)).collect()
}

fn show_byte(b: u8) -> String {
    if b.is_ascii_graphic() { (b as char).to_string() } else { format!("\\x{b:02x}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PFM file's bytes: `rows_top_down` are written bottom-to-top.
    fn pfm_bytes(magic: &str, w: usize, scale: &str, rows_top_down: &[Vec<f32>]) -> Vec<u8> {
        let h = rows_top_down.len();
        let mut b = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        let le = scale.starts_with('-');
        for row in rows_top_down.iter().rev() {
            for v in row {
                b.extend(if le { v.to_le_bytes() } else { v.to_be_bytes() });
            }
        }
        b
    }

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn little_endian_greyscale_rows_come_back_top_to_bottom() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![vec![1.0, 2.0, 3.0], vec![4.0, f32::INFINITY, -6.5]];
        let p = write(dir.path(), "le.pfm", &pfm_bytes("Pf", 3, "-1.0", &rows));
        let img = read_pfm(&p).unwrap();
        assert_eq!((img.width, img.height, img.channels), (3, 2, 1));
        assert_eq!(img.data, vec![1.0, 2.0, 3.0, 4.0, f32::INFINITY, -6.5]);
        assert_eq!(img.get(0, 0, 0), 1.0, "top-left");
        assert_eq!(img.get(2, 1, 0), -6.5, "bottom-right");
        // The file itself stores the bottom row first.
        let raw = std::fs::read(&p).unwrap();
        let first = raw.len() - 6 * 4;
        assert_eq!(f32::from_le_bytes(raw[first..first + 4].try_into().unwrap()), 4.0);
    }

    #[test]
    fn big_endian_colour() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![vec![0.5, 0.25, 0.125, 1.0, 2.0, 3.0], vec![-1.0, -2.0, -3.0, 7.0, 8.0, 9.0]];
        let p = write(dir.path(), "be.pfm", &pfm_bytes("PF", 2, "1.0", &rows));
        let img = read_pfm(&p).unwrap();
        assert_eq!((img.width, img.height, img.channels), (2, 2, 3));
        assert_eq!(img.get(0, 0, 2), 0.125);
        assert_eq!(img.get(1, 0, 1), 2.0);
        assert_eq!(img.get(0, 1, 0), -1.0);
        assert_eq!(img.get(1, 1, 2), 9.0);
    }

    #[test]
    fn scale_magnitude_is_ignored_and_header_whitespace_is_flexible() {
        let mut b = b"Pf 2\t1\r\n-0.0039\n".to_vec();
        for v in [1.5f32, 2.5] {
            b.extend(v.to_le_bytes());
        }
        let img = parse_pfm(&b, Path::new("x.pfm")).unwrap();
        assert_eq!(img.data, vec![1.5, 2.5]);
    }

    #[test]
    fn big_and_little_endian_differ_on_the_same_bytes() {
        let mut be = pfm_bytes("Pf", 1, "1", &[vec![1.0f32]]);
        assert_eq!(parse_pfm(&be, Path::new("a.pfm")).unwrap().data, vec![1.0]);
        // Flip the sign of the scale but keep the big-endian data: reads as LE.
        be.splice(7..8, *b"-1"); // "Pf\n1 1\n1\n": the scale is byte 7
        let v = parse_pfm(&be, Path::new("a.pfm")).unwrap().data[0];
        assert_eq!(v, f32::from_le_bytes(1.0f32.to_be_bytes()));
    }

    #[test]
    fn truncated_data_names_the_file_and_sizes() {
        let dir = tempfile::tempdir().unwrap();
        let mut b = pfm_bytes("Pf", 3, "-1", &[vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 6.0]]);
        b.truncate(b.len() - 3);
        let p = write(dir.path(), "short.pfm", &b);
        let e = read_pfm(&p).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("short.pfm") && msg.contains("truncated") && msg.contains("24 bytes"), "{msg}");
        assert!(msg.contains("found 21"), "{msg}");
    }

    #[test]
    fn trailing_bytes_are_an_error() {
        let mut b = pfm_bytes("Pf", 1, "-1", &[vec![1.0]]);
        b.push(b'\n');
        let msg = parse_pfm(&b, Path::new("long.pfm")).unwrap_err().to_string();
        assert!(msg.contains("long.pfm") && msg.contains("1 unexpected bytes"), "{msg}");
    }

    #[test]
    fn bad_magic_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "img.pfm", b"P6\n1 1\n255\n\0\0\0");
        let msg = read_pfm(&p).unwrap_err().to_string();
        assert!(msg.contains("img.pfm") && msg.contains("bad magic `P6`") && msg.contains("`Pf`"), "{msg}");
        for bytes in [&b""[..], b"\x89PNG\r\n", b"PFX 1 1 -1\n"] {
            let msg = parse_pfm(bytes, Path::new("m.pfm")).unwrap_err().to_string();
            assert!(msg.contains("m.pfm: bad magic"), "{msg}");
        }
    }

    #[test]
    fn bad_headers_are_errors_not_panics() {
        let cases: &[(&[u8], &str)] = &[
            (b"Pf\n", "width is missing"),
            (b"Pf\nabc 2\n-1\n", "width is `abc`"),
            (b"Pf\n2 -2\n-1\n", "height is `-2`"),
            (b"Pf\n2 2\n", "scale is end of file"),
            (b"Pf\n2 2\n0\n", "scale is `0`"),
            (b"Pf\n2 2\nnan\n", "scale is `nan`"),
            (b"Pf\n1 1\n-1", "single whitespace byte"),
            (b"Pf\n99999999999999999999999999 1\n-1\n", "width is `"),
        ];
        for (bytes, want) in cases {
            let msg = parse_pfm(bytes, Path::new("h.pfm")).unwrap_err().to_string();
            assert!(msg.starts_with("h.pfm: ") && msg.contains(want), "{msg} (wanted {want})");
        }
    }

    #[test]
    fn zero_and_absurd_sizes_are_rejected_before_allocating() {
        for (hdr, want) in [
            ("Pf\n0 5\n-1\n", "width is 0"),
            ("Pf\n5 0\n-1\n", "height is 0"),
            ("PF\n16385 2\n-1\n", "width is 16385"),
            ("Pf\n4 4000000000\n-1\n", "height is 4000000000"),
        ] {
            let msg = parse_pfm(hdr.as_bytes(), Path::new("big.pfm")).unwrap_err().to_string();
            assert!(msg.contains("big.pfm") && msg.contains("absurd size") && msg.contains(want), "{msg}");
        }
        // 16384 a side is allowed by the header check (then fails as truncated).
        let msg = parse_pfm(b"Pf\n16384 1\n-1\n", Path::new("ok.pfm")).unwrap_err().to_string();
        assert!(msg.contains("truncated"), "{msg}");
    }

    #[test]
    fn missing_file_names_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("nope.pfm");
        let msg = read_pfm(&p).unwrap_err().to_string();
        assert!(msg.contains("nope.pfm: does not exist; expected the PFM file"), "{msg}");
    }
}
