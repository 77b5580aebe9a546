//! Hole fills that belong to no one paper's reconstruction: stretching the
//! nearest real sample (`stretch`) and hierarchical pull-push
//! (`pull-push`, Gortler et al.'s Lumigraph fill, which seed 004 runs per
//! ray-tree node). Each paper's own fill sits in its folder: `epipolar` in
//! `mark.rs`, `didyk-inpaint` in `didyk/`, `low-pass` in `schollmeyer/`.

pub mod pull_push;
pub mod stretch;
