//! The factorised back-projection through the imaging driver: one small pair imaged with exact
//! and with factorised back-projection of the same frames finds the same building.

use glam::Vec3;
use has_host::imaging::{self, Backprojection, RunOptions};
use has_host::scenario::Scenario;

/// A 8 m × 6 m × 5 m block, one base station 30 m away with a 16 × 16 panel at λ/2 (0.25 m ×
/// 0.25 m, no grating lobes), one vehicle track 8 m in front of the block.
const SCENE: &str = r#"
description = "one block, one base station, one track"
[scene]
description = "block"
[[scene.objects]]
kind = "ground"
name = "yard"
material = "concrete"
min = [-60.0, -60.0]
max = [60.0, 60.0]
z = 0.0
[[scene.objects]]
kind = "building"
name = "block"
material = "concrete"
center = [0.0, 0.0]
size = [8.0, 6.0, 5.0]
[radar]
fc_ghz = 10.0
bandwidth_mhz = 400.0
[[base_stations]]
name = "BS"
position = [-22.0, -22.0, 10.0]
boresight_deg = 45.0
rows = 16
cols = 16
width_m = 0.24
height_m = 0.24
[[apertures]]
name = "V"
kind = "vehicle"
start = [-2.0, -11.0, 1.5]
end = [1.0, -11.0, 1.5]
[imaging]
region_min = [-8.0, -8.0, 0.5]
region_max = [8.0, 8.0, 7.0]
voxel_m = 0.5
coarse_voxel_m = 1.5
position_step = 4
scatterer_density_per_m2 = 4.0
ground_objects = ["yard"]
truth_objects = ["block"]
seed = 3
"#;

/// Distance from `p` to the block's surface (the box [−4, 4] × [−3, 3] × [0, 5]).
fn to_block(p: Vec3) -> f32 {
    let (lo, hi) = (Vec3::new(-4.0, -3.0, 0.0), Vec3::new(4.0, 3.0, 5.0));
    let outside = (lo - p).max(p - hi).max(Vec3::ZERO).length();
    let inside = (p - lo).min(hi - p).min_element();
    if outside > 0.0 {
        outside
    } else {
        inside
    }
}

fn points(bp: Backprojection) -> Vec<Vec3> {
    let mut sc = Scenario::from_toml_str(SCENE).unwrap();
    sc.imaging.backprojection = bp;
    sc.imaging.subarray = 4;
    sc.validate().unwrap();
    let world = imaging::build_world(&sc).unwrap();
    let plans = imaging::choose_pairs(&sc, &world).unwrap();
    assert_eq!(plans.len(), 1);
    let img =
        imaging::image_pair(&sc, &world, &plans[0], RunOptions::default(), &|_, _| {}).unwrap();
    img.points
}

#[test]
fn factorised_and_exact_back_projection_image_the_same_walls() {
    let exact = points(Backprojection::Exact);
    let fact = points(Backprojection::Factorised);
    let median = |v: &[Vec3]| {
        let mut d: Vec<f32> = v.iter().map(|&p| to_block(p)).collect();
        d.sort_by(f32::total_cmp);
        d[d.len() / 2]
    };
    let (me, mf) = (median(&exact), median(&fact));
    println!(
        "exact: {} points, median distance to the block {me:.2} m; factorised: {} points, {mf:.2} m",
        exact.len(),
        fact.len()
    );
    assert!(exact.len() >= 20 && fact.len() >= 20);
    // Both within a voxel of the walls the pair sees (a wrong lattice orientation or steering
    // sign defocuses the factorised image and scatters its points).
    assert!(me <= 0.5 && mf <= 0.5, "{me} {mf}");
    // The same detections up to the approximation: each factorised point has an exact one
    // within a voxel and a half for most points.
    let near = fact
        .iter()
        .filter(|p| exact.iter().any(|q| q.distance(**p) <= 0.75))
        .count();
    println!(
        "{near} of {} factorised points within 0.75 m of an exact one",
        fact.len()
    );
    assert!(near * 10 >= fact.len() * 9, "{near} of {}", fact.len());
}
