//! Side-by-side crops of PNG images, for documentation pages
//! (`docs/real-data.md`): the same rectangle of every input, left to right
//! with a 4-pixel white gap, scaled up by an integer factor (nearest
//! neighbour, so pixels stay visible), written atomically as one PNG.
//!
//! `cargo run --release --example crops -- OUT.png X Y W H SCALE IN.png...`

use anyhow::{Context, bail, ensure};
use std::path::Path;

const GAP: u32 = 4;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 7 {
        bail!("usage: crops OUT.png X Y W H SCALE IN.png...");
    }
    let num = |i: usize, what: &str| -> anyhow::Result<u32> {
        a[i].parse().with_context(|| format!("{what} = {:?}: expected a whole number", a[i]))
    };
    let (x, y, w, h, s) = (num(1, "X")?, num(2, "Y")?, num(3, "W")?, num(4, "H")?, num(5, "SCALE")?);
    ensure!(w > 0 && h > 0 && s > 0, "W, H and SCALE must be at least 1");
    let inputs = &a[6..];
    let n = inputs.len() as u32;
    let mut out = image::RgbImage::from_pixel(n * w * s + (n - 1) * GAP, h * s, image::Rgb([255, 255, 255]));
    for (k, p) in inputs.iter().enumerate() {
        let img = image::open(p).with_context(|| format!("reading {p}"))?.to_rgb8();
        ensure!(
            x + w <= img.width() && y + h <= img.height(),
            "{p} is {}x{}; the crop {w}x{h} at ({x}, {y}) does not fit",
            img.width(),
            img.height()
        );
        let x0 = k as u32 * (w * s + GAP);
        for j in 0..h * s {
            for i in 0..w * s {
                out.put_pixel(x0 + i, j, *img.get_pixel(x + i / s, y + j / s));
            }
        }
    }
    let path = Path::new(&a[0]);
    let mut bytes = Vec::new();
    out.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)?;
    postwarp::io_util::write_bytes_atomically(path, &bytes)?;
    println!("wrote {} ({}x{})", path.display(), out.width(), out.height());
    Ok(())
}
