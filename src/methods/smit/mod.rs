//! Smit et al.'s three reconstructions of a warped reference (seed 001,
//! Smit et al., C&G 2010): point splats (`smit-point`), quad splats
//! (`smit-quad`) and a warped mesh (`smit-mesh`, `smit-mesh-connected`),
//! with the paper's level-0 hole classification.
//!
//! Layers, each depending only on the ones above it:
//! - `warp`: the per-sample warp, Jacobian, culling and depth test all
//!   three share;
//! - `geometry`: splat footprints, quad corners and the mesh's 2x2-group
//!   triangles;
//! - `errors`: level-0 holes split into occlusion and sampling errors;
//! - `point`, `quad`, `mesh`: the reconstructions.

pub mod errors;
pub mod geometry;
pub mod mesh;
pub mod point;
pub mod quad;
pub mod warp;
