//! Schollmeyer et al.'s warp (seed 000, TVCG 2017): the adaptive grid of
//! opaque pixels from the surface-estimation quadtree (`quadtree`, `grid`;
//! methods `schollmeyer-cross`, `-partial`, `-irregular`), the depth-aware
//! low-pass hole fill (`low_pass_fill`, `low-pass`), and the A-buffer ray
//! casting of transparent fragments through a min-max depth quadtree
//! (`minmax`, `transparent`; `schollmeyer-transparent` and the baseline
//! `schollmeyer-glass-depth`).

pub mod grid;
pub mod low_pass_fill;
pub mod minmax;
pub mod quadtree;
pub mod transparent;
