//! The one font of every chart: DejaVu Sans, bundled in
//! `assets/fonts/` (licence beside it) and compiled in, registered with
//! plotters once per process. The SVG backend needs it too: it measures
//! text to lay out axes and legends, although the SVG names the family
//! and lets the viewer draw the glyphs.

use std::sync::OnceLock;

/// The family name charts use.
pub const FAMILY: &str = "sans-serif";

static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Register the bundled font (once; later calls return the first result).
pub fn register() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, DEJAVU_SANS)
            .map_err(|_| "the bundled font assets/fonts/DejaVuSans.ttf does not parse".to_string())
    })
    .clone()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_bundled_font_registers() {
        assert_eq!(super::register(), Ok(()));
        assert_eq!(super::register(), Ok(()));
    }
}
