//! Hybrid-aperture imaging: sensors (real and virtual apertures), the frame-by-frame driver that
//! feeds has-dsp back-projection, point-cloud extraction and fusion.

pub mod sensors;

pub use sensors::{nyquist_spacing_m, pair_resolution_m, PlanarArray, VirtualAperture};
