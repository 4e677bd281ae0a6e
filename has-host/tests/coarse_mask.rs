//! The coarse pass's mask keeps what the fine pass would image: a building's face imaged through
//! a panel whose range-independent resolution is finer than the coarse lattice.
//!
//! One 12 m × 8 m × 6 m hall, one base station 32 m away whose 32 × 32 panel is 2 m wide (the
//! elements 2 λ apart), one vehicle track 8 m in front of the hall's south face; the quick
//! preset's lattices (fine 0.5 m, coarse 1.5 m) and thinning. A point sample of the full-band image
//! on the 1.5 m lattice kept nothing of the face (the fine pass then imaged nothing: an empty
//! cloud); with the mask taken also from range profiles low-passed to its lattice
//! (`has_host::imaging::coarse_range`) the face is imaged.

use glam::Vec3;
use has_host::imaging::{self, RunOptions};
use has_host::scenario::Scenario;

const SCENE: &str = r#"
description = "one hall, one wide panel, one track"
[scene]
description = "hall"
[[scene.objects]]
kind = "ground"
name = "yard"
material = "concrete"
min = [-60.0, -60.0]
max = [60.0, 60.0]
z = 0.0
[[scene.objects]]
kind = "building"
name = "hall"
material = "concrete"
center = [0.0, 0.0]
size = [12.0, 8.0, 6.0]
[radar]
fc_ghz = 10.0
bandwidth_mhz = 400.0
[[base_stations]]
name = "BS1"
position = [-25.0, -20.0, 15.0]
boresight_deg = 38.7
width_m = 2.0
[[apertures]]
name = "V1"
kind = "vehicle"
start = [-3.0, -12.0, 1.5]
end = [0.0, -12.0, 1.5]
[imaging]
region_min = [-15.0, -15.0, 0.5]
region_max = [15.0, 15.0, 12.0]
voxel_m = 0.5
coarse_voxel_m = 1.5
element_step = 4
position_step = 4
scatterer_density_per_m2 = 6.0
ground_objects = ["yard"]
truth_objects = ["hall"]
"#;

fn points(coarse_voxel_m: f32) -> Vec<Vec3> {
    let mut sc = Scenario::from_toml_str(SCENE).unwrap();
    sc.imaging.coarse_voxel_m = coarse_voxel_m;
    sc.validate().unwrap();
    let world = imaging::build_world(&sc).unwrap();
    let plans = imaging::choose_pairs(&sc, &world).unwrap();
    assert_eq!(plans.len(), 1);
    imaging::image_pair(&sc, &world, &plans[0], RunOptions::default(), &|_, _| {})
        .unwrap()
        .points
}

/// Points within `d` of the hall's south face (y = −4, x in [−6, 6], z in [0, 6]).
fn on_south_face(p: &[Vec3], d: f32) -> usize {
    p.iter()
        .filter(|q| (q.y + 4.0).abs() < d && q.x.abs() < 6.0 + d && q.z < 6.0 + d)
        .count()
}

#[test]
fn a_face_is_imaged_through_a_coarse_lattice_wider_than_its_range_resolution() {
    // The face the track sees is 12 m × 6 m: at least one point per 4 m² of it within one
    // fine voxel of the face, on the 1.5 m lattice as on a 0.75 m one (half the spacing: path
    // offsets up to 0.75 m, where the full-band Hann pulse keeps −3 dB).
    let coarse = points(1.5);
    let finer = points(0.75);
    let (a, b) = (on_south_face(&coarse, 0.5), on_south_face(&finer, 0.5));
    assert!(
        a >= 18,
        "1.5 m lattice: {a} points on the face ({} in all)",
        coarse.len()
    );
    assert!(
        b >= 18,
        "0.75 m lattice: {b} points on the face ({} in all)",
        finer.len()
    );
}
