//! # has-host
//!
//! The host (std) side of hybrid aperture sensing: scenes and materials, the BVH ray tracer,
//! propagation paths, echo synthesis, the imaging driver that feeds `has-dsp` frame by frame,
//! fusion, surface reconstruction and metrics.
//!
//! Conventions: metres, seconds, hertz; positions `glam::Vec3` in one right-handed frame with z up;
//! angles in radians inside, degrees only in reports.
#![forbid(unsafe_code)]

pub mod imaging;

pub use has_dsp::geometry::{bistatic_range, wavelength_m, C_M_PER_S};

pub mod beam;
pub mod bench;
pub mod channel;
pub mod channel_experiment;
pub mod disjoint_sets;
pub mod echo;
pub mod html;
pub(crate) mod impairments;
pub mod io;
pub mod knn;
pub mod linalg;
pub mod localize;
pub mod material;
pub mod memory;
pub mod mesh;
pub mod meshing;
pub mod metrics;
pub mod multipath;
pub mod observability;
pub mod paths;
pub mod propagation;
pub mod reconstruction;
pub mod scenario;
pub mod scene;
pub mod sensors;
pub mod shapes;
pub mod suite;
pub mod twin;

pub use material::Material;
pub use scene::{Hit, Object, Scene, SceneError};
