//! Frame commands: the engines' input contract.
//!
//! The host side (the `postwarp` crate) turns each derived frame of a trace
//! into one [`FrameCommands`]: the derived camera, the display geometry, and
//! one [`ReferenceWarp`] per reference frame to warp, in warp order. Both the
//! golden model and the hardware model execute exactly these commands.

use crate::camera::{Camera, WarpSetup};

/// Warp one reference frame into the derived frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceWarp {
    /// Index of the reference frame in the trace.
    pub reference: usize,
    /// Reference camera on its super-sample grid.
    pub reference_camera: Camera,
    /// Warp parameters on the super-sample grids of both cameras.
    pub setup: WarpSetup,
}

/// Everything needed to produce one derived frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameCommands {
    /// Index of the derived frame in the trace.
    pub derived: usize,
    /// Derived camera in display pixels.
    pub derived_camera: Camera,
    /// Super-samples per pixel along each axis.
    pub supersample: u32,
    /// Reference warps in the order they are executed.
    pub warps: Vec<ReferenceWarp>,
}

impl FrameCommands {
    /// Build the commands for a derived frame from its camera and the cameras
    /// of the references it warps (`(trace index, camera in pixels)`).
    pub fn new(
        derived: usize,
        derived_camera: Camera,
        supersample: u32,
        references: &[(usize, Camera)],
    ) -> FrameCommands {
        let dst = derived_camera.sample_grid(supersample);
        let warps = references
            .iter()
            .map(|&(reference, cam)| {
                let src = cam.sample_grid(supersample);
                ReferenceWarp { reference, reference_camera: src, setup: WarpSetup::new(&src, &dst) }
            })
            .collect();
        FrameCommands { derived, derived_camera, supersample, warps }
    }
}
