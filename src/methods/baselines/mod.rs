//! Baselines no paper of ours proposes but every one compares against: a
//! plain per-sample forward splat with a depth test (`forward-splat`) and
//! a mesh through every sample, discontinuities included (`rubber-sheet`).

pub mod forward_splat;
pub mod rubber_sheet;
