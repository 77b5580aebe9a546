//! Schollmeyer et al.'s warp (seed 000, IEEE VR 2017): the adaptive grid
//! of opaque pixels from the surface-estimation quadtree (`quadtree`,
//! `grid`; methods `schollmeyer-cross`, `-partial`, `-irregular`) and the
//! depth-aware low-pass hole fill (`low_pass_fill`, `low-pass`).

pub mod grid;
pub mod low_pass_fill;
pub mod quadtree;
