//! A building outside the region does not leave its grating lobes inside it.
//!
//! One base station, one UAV climbing straight up, a small metal hall at `p` near the panel's
//! boresight, and an empty yard (the region) around `q`, the mirror image of `p` through the
//! vertical plane of the UAV's track and the base station. `q` lies on the track's focusing ring
//! of `p` (the same distance from every transmit position) and at `p`'s distance and elevation
//! from the panel, so the pair tells them apart by azimuth alone; the panel's element pitch is
//! chosen so that `q`'s direction sine along the panel lies exactly one grating-lobe step from
//! `p`'s. The hall's echo then focuses at `q` too, through the panel's grating lobe. With nothing
//! imaged at the hall, those lobes stood in the empty yard as detections; imaged where the
//! detections' aliases fall (`imaging.alias_test`), each lobe meets the stronger echo it came
//! from and is dropped. Imaged in a region of its own, the hall keeps its detections: its
//! weaker voxels are not judged against the lobe its peak lays at `q`.

use glam::Vec3;
use has_host::imaging::{self, RunOptions};
use has_host::scenario::Scenario;

const BS: Vec3 = Vec3::new(-25.0, -20.0, 15.0);
const BORESIGHT_DEG: f32 = 38.7;
const P: Vec3 = Vec3::new(0.0, 0.0, 4.0);
const TRACK: Vec3 = Vec3::new(-10.0, 10.0, 4.0);
const WAVELENGTH_M: f32 = 0.029_979_246;
const COLS: f32 = 32.0;

/// `q`: `p` mirrored through the vertical plane holding the track and the base station.
fn hall_site() -> Vec3 {
    let d = (BS - TRACK).with_z(0.0).normalize();
    let r = (P - TRACK).with_z(0.0);
    let along = d * r.dot(d);
    TRACK + along - (r - along) + Vec3::Z * (P.z - TRACK.z)
}

/// The panel width whose column pitch puts `q` one grating-lobe step from `p`.
fn panel_width_m(q: Vec3) -> f32 {
    let b = BORESIGHT_DEG.to_radians();
    let tangent = Vec3::new(-b.sin(), b.cos(), 0.0);
    let sine = |x: Vec3| (x - BS).normalize().dot(tangent);
    COLS * WAVELENGTH_M / (sine(q) - sine(P)).abs()
}

/// Where the region is: around the empty yard at the hall's alias, or around the hall.
#[derive(Clone, Copy)]
enum Region {
    Yard,
    Hall,
}

fn scene(alias_test: bool, region: Region) -> String {
    let q = hall_site();
    let c = match region {
        Region::Yard => q,
        Region::Hall => P,
    };
    format!(
        r#"
description = "a hall and an empty yard at its grating lobe"
[scene]
description = "yard and hall"
[[scene.objects]]
kind = "ground"
name = "yard"
material = "concrete"
min = [-80.0, -80.0]
max = [80.0, 80.0]
z = 0.0
[[scene.objects]]
kind = "building"
name = "hall"
material = "metal"
center = [{px}, {py}]
size = [2.0, 2.0, {ph}]
[radar]
fc_ghz = 10.0
bandwidth_mhz = 400.0
[[base_stations]]
name = "BS1"
position = [{bx}, {by}, {bz}]
boresight_deg = {BORESIGHT_DEG}
width_m = {w}
[[apertures]]
name = "UAV"
kind = "uav"
start = [{tx}, {ty}, {t0}]
end = [{tx}, {ty}, {t1}]
[[pairs]]
bs = "BS1"
aperture = "UAV"
[imaging]
region_min = [{rx0}, {ry0}, 0.5]
region_max = [{rx1}, {ry1}, 8.0]
voxel_m = 0.5
coarse_voxel_m = 1.5
element_step = 4
position_step = 4
scatterer_density_per_m2 = 6.0
ground_objects = ["yard"]
truth_objects = ["hall"]
alias_test = {alias_test}
"#,
        px = P.x,
        py = P.y,
        ph = P.z + 2.0,
        rx0 = c.x - 6.0,
        ry0 = c.y - 6.0,
        rx1 = c.x + 6.0,
        ry1 = c.y + 6.0,
        bx = BS.x,
        by = BS.y,
        bz = BS.z,
        w = panel_width_m(q),
        tx = TRACK.x,
        ty = TRACK.y,
        t0 = TRACK.z - 1.5,
        t1 = TRACK.z + 1.5,
    )
}

/// The pair's detections in the region and the voxels imaged at the aliases.
fn in_region(alias_test: bool, region: Region) -> (Vec<Vec3>, usize) {
    let sc = Scenario::from_toml_str(&scene(alias_test, region)).unwrap();
    sc.validate().unwrap();
    let world = imaging::build_world(&sc).unwrap();
    let plans = imaging::choose_pairs(&sc, &world).unwrap();
    assert_eq!(plans.len(), 1);
    let im =
        imaging::image_pair(&sc, &world, &plans[0], RunOptions::default(), &|_, _| {}).unwrap();
    (im.points, im.stats.alias_voxels)
}

#[test]
fn the_geometry_puts_the_hall_on_a_grating_lobe_of_the_yard() {
    let q = hall_site();
    let sc = Scenario::from_toml_str(&scene(true, Region::Yard)).unwrap();
    assert!((sc.wavelength_m() as f32 - WAVELENGTH_M).abs() < 1e-6);
    // Far from the hall, at its distance from the panel and the track.
    assert!(q.distance(P) > 20.0, "{q}");
    assert!((q.distance(BS) - P.distance(BS)).abs() < 1e-3);
    assert!((q.distance(TRACK) - P.distance(TRACK)).abs() < 1e-3);
    let aliases = sc.array(0).grating_aliases(WAVELENGTH_M, q, TRACK);
    assert!(
        aliases.iter().any(|a| a.distance(P) < 0.05),
        "{P} not among {aliases:?}"
    );
}

#[test]
fn the_lobes_of_a_hall_outside_the_region_are_judged_against_the_hall() {
    let (without, none) = in_region(false, Region::Yard);
    let (with, imaged) = in_region(true, Region::Yard);
    assert_eq!(none, 0);
    assert!(imaged > 0, "nothing imaged at the aliases");
    // The yard holds nothing: what the pair detects in it is the hall's lobes (and the stated
    // false-alarm budget, one per image).
    assert!(
        without.len() >= 10,
        "the scene should put the hall's lobes in the yard: {} points without the test",
        without.len()
    );
    assert!(
        with.len() * 10 <= without.len(),
        "{} of {} lobe points kept: {:?}",
        with.len(),
        without.len(),
        &with[..with.len().min(8)]
    );
}

#[test]
fn the_hall_in_its_own_region_keeps_its_detections() {
    let (without, _) = in_region(false, Region::Hall);
    let (with, imaged) = in_region(true, Region::Hall);
    assert!(imaged > 0, "nothing imaged at the aliases");
    assert!(without.len() >= 10, "{} points of the hall", without.len());
    assert!(
        with.len() * 5 >= without.len() * 4,
        "{} of the hall's {} points kept",
        with.len(),
        without.len()
    );
}
