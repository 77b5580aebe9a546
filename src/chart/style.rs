//! How series look: a colour and a marker shape per series, so that
//! methods differ in both (readable in grey print and by colour-blind
//! readers). Colours are the Okabe–Ito palette, darkened where pale on
//! white; 8 colours and 7 shapes cycle independently, so the first 56
//! series all differ.

use plotters::prelude::*;

/// Series colours (Okabe–Ito).
pub const COLOURS: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(68, 68, 68),    // dark grey (for black)
    RGBColor(184, 160, 0),   // dark yellow
];

/// Marker shapes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shape {
    /// Filled circle.
    Circle,
    /// Filled triangle, point up.
    TriangleUp,
    /// Filled square.
    Square,
    /// Filled diamond.
    Diamond,
    /// Filled triangle, point down.
    TriangleDown,
    /// Diagonal cross.
    Cross,
    /// Upright plus.
    Plus,
}

/// Shapes in order of use.
pub const SHAPES: [Shape; 7] =
    [Shape::Circle, Shape::TriangleUp, Shape::Square, Shape::Diamond, Shape::TriangleDown, Shape::Cross, Shape::Plus];

/// Colour and shape of series number `i`.
pub fn series_style(i: usize) -> (RGBColor, Shape) {
    (COLOURS[i % COLOURS.len()], SHAPES[i % SHAPES.len()])
}

/// Draw marker `shape` of `colour` centred on pixel `c`, `r` pixels in
/// radius, on `area` (pixel coordinates).
pub fn draw_marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: (i32, i32),
    r: i32,
    shape: Shape,
    colour: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let fill = colour.filled();
    let line = colour.stroke_width(2);
    let (x, y) = c;
    match shape {
        Shape::Circle => area.draw(&Circle::new(c, r, fill)),
        Shape::Square => area.draw(&Rectangle::new([(x - r + 1, y - r + 1), (x + r - 1, y + r - 1)], fill)),
        Shape::TriangleUp => {
            area.draw(&Polygon::new(vec![(x, y - r - 1), (x + r, y + r - 1), (x - r, y + r - 1)], fill))
        }
        Shape::TriangleDown => {
            area.draw(&Polygon::new(vec![(x, y + r + 1), (x + r, y - r + 1), (x - r, y - r + 1)], fill))
        }
        Shape::Diamond => {
            area.draw(&Polygon::new(vec![(x, y - r - 1), (x + r + 1, y), (x, y + r + 1), (x - r - 1, y)], fill))
        }
        Shape::Cross => {
            area.draw(&PathElement::new(vec![(x - r, y - r), (x + r, y + r)], line))?;
            area.draw(&PathElement::new(vec![(x - r, y + r), (x + r, y - r)], line))
        }
        Shape::Plus => {
            area.draw(&PathElement::new(vec![(x - r - 1, y), (x + r + 1, y)], line))?;
            area.draw(&PathElement::new(vec![(x, y - r - 1), (x, y + r + 1)], line))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_56_series_differ_in_colour_or_shape() {
        let styles: Vec<_> = (0..56).map(series_style).collect();
        for i in 0..56 {
            for j in 0..i {
                assert_ne!(styles[i], styles[j], "{i} {j}");
            }
        }
        // Neighbours differ in both.
        for i in 1..56 {
            assert_ne!(styles[i].0, styles[i - 1].0);
            assert_ne!(styles[i].1, styles[i - 1].1);
        }
    }
}
