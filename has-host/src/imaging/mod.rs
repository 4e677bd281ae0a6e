//! Hybrid-aperture imaging: the frame-by-frame driver that feeds has-dsp back-projection, pair
//! planning, point-cloud extraction and fusion, and the twin's surface. It reads the scenario file
//! ([`crate::scenario`]) and images with the sensors of [`crate::sensors`] (re-exported here).

pub mod centroid;
pub mod coarse_range;
pub mod confirmation;
pub mod detection;
pub mod driver;
pub mod facing;
pub mod finer_height;
pub mod free_space;
pub mod hidden_roofs;
pub mod outline_walls;
pub mod pair_cell;
pub mod run;
pub mod sidelobes;
pub mod surface;
pub mod terrain_echo;
pub mod valleys;
pub mod wall_columns;
pub mod world;

pub use crate::scenario::{Backprojection, Detection, Pairing, Scenario, ScenarioError};
pub use crate::sensors;

/// The scenario file's former name here; the type is [`crate::scenario::Scenario`].
pub type ImagingScenario = Scenario;
pub use crate::sensors::{nyquist_spacing_m, pair_resolution_m, PlanarArray, VirtualAperture};
pub use driver::{
    image_pair, survey_pair, ImagingError, PairImage, PairPlan, PairStats, RunOptions,
};
pub use run::{
    build_world, check_memory, choose_pairs, every_facing_pair, every_pairing,
    facing_base_stations, fuse, fuse_images, memory_estimate, observable_truth, observing_pairs,
    observing_sensors, plan_pairs, resolution_cell_m, resolves_the_site, run_imaging, share_pct,
    support_distance_m, survey_pairs, FusedCloud, RunError, RunResult,
};
pub use surface::{surface, Surface, SurfaceOptions, VisibilityFiltered};
pub use world::{Terrain, World};
