//! Checks of the propagation-path tracer (`has_host::paths`) and of `H(f)` (`has_host::channel`)
//! against closed forms: two-ray ground reflection, a 90° corner, blocking, duplicates on shared
//! edges, a noisy (reconstruction-like) wall, SBR candidates against exhaustive enumeration.

use glam::{DVec3, Vec3};
use has_host::channel::{frequency_response, frequency_response_at};
use has_host::paths::{
    CandidateMode, Interaction, Path, PathError, Polarization, Tracer, TracerConfig,
};
use has_host::propagation::{free_space_amplitude, fresnel_reflection, slab_coefficients};
use has_host::{Material, Object, Scene, C_M_PER_S};
use num_complex::Complex64;

const F_HZ: f64 = 10e9;

fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> Vec<[Vec3; 3]> {
    vec![[a, b, c], [a, c, d]]
}

fn object(name: &str, material: Material, triangles: Vec<[Vec3; 3]>) -> Object {
    Object {
        thickness_m: None,
        name: name.into(),
        material,
        triangles,
    }
}

fn ground(half: f32) -> Object {
    object(
        "ground",
        Material::Concrete,
        quad(
            Vec3::new(-half, -half, 0.0),
            Vec3::new(half, -half, 0.0),
            Vec3::new(half, half, 0.0),
            Vec3::new(-half, half, 0.0),
        ),
    )
}

/// Axis-aligned box building, outward counter-clockwise faces (no bottom).
fn building(name: &str, lo: Vec3, hi: Vec3) -> Object {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let (x0, y0, z0, x1, y1, z1) = (lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
    let mut t = Vec::new();
    t.extend(quad(
        p(x0, y0, z0),
        p(x1, y0, z0),
        p(x1, y0, z1),
        p(x0, y0, z1),
    )); // -y
    t.extend(quad(
        p(x1, y0, z0),
        p(x1, y1, z0),
        p(x1, y1, z1),
        p(x1, y0, z1),
    )); // +x
    t.extend(quad(
        p(x1, y1, z0),
        p(x0, y1, z0),
        p(x0, y1, z1),
        p(x1, y1, z1),
    )); // +y
    t.extend(quad(
        p(x0, y1, z0),
        p(x0, y0, z0),
        p(x0, y0, z1),
        p(x0, y1, z1),
    )); // -x
    t.extend(quad(
        p(x0, y0, z1),
        p(x1, y0, z1),
        p(x1, y1, z1),
        p(x0, y1, z1),
    )); // roof
    object(name, Material::Concrete, t)
}

fn config(pol: Polarization, order: usize) -> TracerConfig {
    TracerConfig {
        frequency_hz: F_HZ,
        max_order: order,
        polarization: pol,
        ..TracerConfig::default()
    }
}

/// Ground distance, transmitter and receiver (heights `h1`, `h2`, y = 7 m) of a ground bounce at
/// grazing angle `psi` (rad) on z = 0.
fn two_ray_ends(h1: f64, h2: f64, psi: f64) -> (f64, DVec3, DVec3) {
    let d = (h1 + h2) / psi.tan();
    (
        d,
        DVec3::new(-0.3 * d, 7.0, h1),
        DVec3::new(0.7 * d, 7.0, h2),
    )
}

fn reflections(p: &Path) -> Vec<(u32, DVec3)> {
    p.interactions
        .iter()
        .filter_map(|i| match i {
            Interaction::Reflection { object, point, .. } => Some((*object, *point)),
            _ => None,
        })
        .collect()
}

/// Two-ray model over a concrete ground: for grazing angles 1°…70° and both polarisations the
/// tracer finds exactly LOS + one ground bounce, with
/// * delays equal to the closed forms `√(d² + (h1 ∓ h2)²)/c`: both sides are f64 from the same
///   inputs (the image through the exact plane z = 0 is exact), so 1e-9 relative is generous;
/// * reflected amplitude `λ/(4πL)·R(θ)` with `R = R∥` (V) or `R⊥` (H) at `cos θ = sin ψ`, checked
///   as gain within 0.01 dB and as a complex number within 1e-9 relative (same formula chain,
///   only rounding differs); the cross-polar terms vanish (the plane of incidence contains θ̂).
#[test]
fn two_ray_ground_reflection_matches_closed_form_both_polarisations() {
    let scene = Scene::new(vec![ground(5000.0)]).unwrap();
    let (h1, h2) = (10.0f64, 1.5f64);
    let lambda = C_M_PER_S / F_HZ;
    let eta = Material::Concrete.complex_permittivity(F_HZ);
    for pol in [Polarization::Vertical, Polarization::Horizontal] {
        let tracer = Tracer::new(&scene, config(pol, 3)).unwrap();
        for psi_deg in [1.0f64, 5.0, 15.0, 23.6, 40.0, 70.0] {
            let psi = psi_deg.to_radians();
            let (d, tx, rx) = two_ray_ends(h1, h2, psi);
            let paths = tracer.paths(tx, rx).unwrap();
            assert_eq!(paths.len(), 2, "ψ = {psi_deg}°: {paths:?}");
            let (los, refl) = (&paths[0], &paths[1]);
            assert_eq!(los.interactions, vec![Interaction::Los]);
            assert_eq!(refl.order(), 1);
            let l1 = (d * d + (h1 - h2).powi(2)).sqrt();
            let l2 = (d * d + (h1 + h2).powi(2)).sqrt();
            let dt = refl.delay_s - los.delay_s;
            let dt_expected = (l2 - l1) / C_M_PER_S;
            assert!(
                ((dt - dt_expected) / dt_expected).abs() < 1e-9,
                "ψ = {psi_deg}°: Δτ {dt} vs {dt_expected}"
            );
            assert!(((refl.delay_s * C_M_PER_S - l2) / l2).abs() < 1e-9);
            let f = fresnel_reflection(eta, psi.sin());
            let r = match pol {
                Polarization::Vertical => f.tm,
                Polarization::Horizontal => f.te,
            };
            let expected = free_space_amplitude(l2, lambda)
                * r
                * Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * (l2 / lambda).fract());
            let gain_expected = 20.0 * expected.norm().log10();
            assert!(
                (refl.gain_db() - gain_expected).abs() < 0.01,
                "ψ = {psi_deg}° {pol:?}: {} dB vs {gain_expected} dB",
                refl.gain_db()
            );
            assert!(
                (refl.a - expected).norm() < 1e-9 * expected.norm(),
                "ψ = {psi_deg}° {pol:?}: a = {} vs {expected}",
                refl.a
            );
            let cross = refl.jones[0][1].norm() + refl.jones[1][0].norm();
            assert!(
                cross < 1e-9 * expected.norm().max(1e-12),
                "cross-pol {cross}"
            );
            // LOS: free space, identity Jones matrix.
            let los_amp = free_space_amplitude(l1, lambda);
            assert!((los.a.norm() - los_amp).abs() < 1e-12 * los_amp);
            // Reflection point on the ground at the specular position.
            let (_, p) = reflections(refl)[0];
            let x_spec = tx.x + d * h1 / (h1 + h2);
            assert!((p - DVec3::new(x_spec, 7.0, 0.0)).length() < 1e-9 * d);
        }
    }
}

/// A material with a thickness reflects as a slab (ITU-R P.2040-3 eq. 43, as Sionna RT): the
/// ground bounce off a 0.1 m brick ground is `λ/(4πL)·R_slab(θ)` to 1e-9 relative, both
/// polarisations, and differs from the half-space's by what the slab's internal reflections
/// add (more than 0.5 dB at some angle of the sweep); the LOS is untouched.
#[test]
fn a_material_with_a_thickness_reflects_as_a_slab() {
    let mut slab_ground = ground(5000.0);
    slab_ground.material = Material::Brick;
    slab_ground.thickness_m = Some(0.1);
    let scene = Scene::new(vec![slab_ground]).unwrap();
    let (h1, h2) = (10.0f64, 1.5f64);
    let lambda = C_M_PER_S / F_HZ;
    let eta = Material::Brick.complex_permittivity(F_HZ);
    let mut largest_difference_db: f64 = 0.0;
    for pol in [Polarization::Vertical, Polarization::Horizontal] {
        let tracer = Tracer::new(&scene, config(pol, 1)).unwrap();
        for psi_deg in [2.0f64, 10.0, 30.0, 60.0, 85.0] {
            let psi = psi_deg.to_radians();
            let (d, tx, rx) = two_ray_ends(h1, h2, psi);
            let paths = tracer.paths(tx, rx).unwrap();
            assert_eq!(paths.len(), 2, "ψ = {psi_deg}°: {paths:?}");
            let refl = &paths[1];
            let l2 = (d * d + (h1 + h2).powi(2)).sqrt();
            let pick = |f: has_host::propagation::Fresnel| match pol {
                Polarization::Vertical => f.tm,
                Polarization::Horizontal => f.te,
            };
            let r = pick(slab_coefficients(eta, psi.sin(), 0.1, lambda).reflection);
            let expected = free_space_amplitude(l2, lambda)
                * r
                * Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * (l2 / lambda).fract());
            assert!(
                (refl.a - expected).norm() < 1e-9 * expected.norm(),
                "ψ = {psi_deg}° {pol:?}: a = {} vs {expected}",
                refl.a
            );
            let half = pick(fresnel_reflection(eta, psi.sin()));
            largest_difference_db =
                largest_difference_db.max((20.0 * (r.norm() / half.norm()).log10()).abs());
        }
    }
    assert!(largest_difference_db > 0.5, "{largest_difference_db} dB");
}

/// The V-polarised ground bounce nearly vanishes at the Brewster angle of concrete
/// (`tan θ_B = √εr`, grazing ψ_B = 90° − θ_B ≈ 23.6°): over a 1° sweep of ψ, |a·4πL/λ| is smallest
/// within 1° of ψ_B and below 0.05 there (concrete is lossy, so |R∥| does not reach 0; at 10 GHz
/// Im η ≈ −0.3 gives a minimum ≈ 0.03), while the H bounce stays above 0.5 there.
#[test]
fn vertical_ground_bounce_has_brewster_minimum_of_concrete() {
    let scene = Scene::new(vec![ground(2000.0)]).unwrap();
    let lambda = C_M_PER_S / F_HZ;
    let er = Material::Concrete.relative_permittivity(F_HZ);
    let psi_b = 90.0 - er.sqrt().atan().to_degrees();
    let mut best = (f64::INFINITY, 0.0);
    let tv = Tracer::new(&scene, config(Polarization::Vertical, 1)).unwrap();
    let th = Tracer::new(&scene, config(Polarization::Horizontal, 1)).unwrap();
    for i in 5..=45 {
        let psi = (i as f64).to_radians();
        let d = 20.0 / psi.tan();
        let tx = DVec3::new(0.0, 0.0, 10.0);
        let rx = DVec3::new(d, 0.0, 10.0);
        let p = tv.paths(tx, rx).unwrap();
        let r = p[1].a.norm() / free_space_amplitude(p[1].length_m, lambda);
        if r < best.0 {
            best = (r, i as f64);
        }
        if (i as f64 - psi_b).abs() < 1.0 {
            let ph = th.paths(tx, rx).unwrap();
            let rh = ph[1].a.norm() / free_space_amplitude(ph[1].length_m, lambda);
            assert!(rh > 0.5, "|R⊥| = {rh} at ψ = {i}°");
        }
    }
    assert!(
        (best.1 - psi_b).abs() <= 1.0,
        "minimum at {}°, ψ_B = {psi_b}°",
        best.1
    );
    assert!(best.0 < 0.05, "|R∥| min {}", best.0);
}

/// Two walls meeting at 90° along the z axis (x = 0 for y ≥ 0 and y = 0 for x ≥ 0): LOS, one
/// bounce on each wall and exactly one double bounce, whose unfolded length is the distance from
/// the receiver to the transmitter mirrored through both walls, (−x, −y, z).
#[test]
fn corner_double_bounce_exists_with_image_delay() {
    let wall_a = object(
        "wall_a",
        Material::Concrete,
        quad(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 30.0, 0.0),
            Vec3::new(0.0, 30.0, 10.0),
            Vec3::new(0.0, 0.0, 10.0),
        ),
    );
    let wall_b = object(
        "wall_b",
        Material::Metal,
        quad(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::new(30.0, 0.0, 10.0),
            Vec3::new(30.0, 0.0, 0.0),
        ),
    );
    let scene = Scene::new(vec![wall_a, wall_b]).unwrap();
    let tx = DVec3::new(3.0, 5.0, 1.5);
    let rx = DVec3::new(6.0, 2.0, 2.5);
    for candidates in [
        CandidateMode::Sbr { rays: 50_000 },
        CandidateMode::Exhaustive,
    ] {
        let tracer = Tracer::new(
            &scene,
            TracerConfig {
                candidates,
                ..config(Polarization::Vertical, 3)
            },
        )
        .unwrap();
        let paths = tracer.paths(tx, rx).unwrap();
        let orders: Vec<usize> = paths.iter().map(Path::order).collect();
        assert_eq!(orders.iter().filter(|&&o| o == 0).count(), 1, "{orders:?}");
        assert_eq!(orders.iter().filter(|&&o| o == 1).count(), 2, "{orders:?}");
        let doubles: Vec<&Path> = paths.iter().filter(|p| p.order() == 2).collect();
        assert_eq!(doubles.len(), 1, "{orders:?}");
        assert!(orders.iter().all(|&o| o <= 2), "{orders:?}");
        let l = (rx - DVec3::new(-3.0, -5.0, 1.5)).length();
        assert!(((doubles[0].length_m - l) / l).abs() < 1e-12);
        assert!(((doubles[0].delay_s * C_M_PER_S - l) / l).abs() < 1e-12);
        // Wall a first (the ray from rx toward the double image crosses y = 0 at x > 0).
        let objs: Vec<u32> = reflections(doubles[0]).iter().map(|r| r.0).collect();
        assert_eq!(objs, vec![0, 1]);
        // Sorted by delay.
        assert!(paths.windows(2).all(|w| w[0].delay_s <= w[1].delay_s));
        // Departure / arrival angles of the LOS path (Sionna conventions).
        let d = rx - tx;
        let los = &paths[0];
        assert!((los.aod - d.y.atan2(d.x)).abs() < 1e-12);
        assert!((los.zod - (d.z / d.length()).acos()).abs() < 1e-12);
        assert!((los.aoa - (-d.y).atan2(-d.x)).abs() < 1e-12);
        assert!((los.zoa - (-d.z / d.length()).acos()).abs() < 1e-12);
    }
}

/// A wall between transmitter and receiver removes the LOS path and every path through it; the
/// ground bounce crosses the wall too (the wall stands on the ground), so nothing arrives.
#[test]
fn wall_between_tx_and_rx_blocks_los_and_ground_bounce() {
    let wall = object(
        "wall",
        Material::Concrete,
        quad(
            Vec3::new(10.0, -50.0, 0.0),
            Vec3::new(10.0, 50.0, 0.0),
            Vec3::new(10.0, 50.0, 8.0),
            Vec3::new(10.0, -50.0, 8.0),
        ),
    );
    let scene = Scene::new(vec![ground(200.0), wall]).unwrap();
    let tracer = Tracer::new(&scene, config(Polarization::Vertical, 3)).unwrap();
    // Ground specular point at x = 11, behind the wall (x = 10) seen from the transmitter.
    let tx = DVec3::new(5.0, 0.0, 1.5);
    let rx = DVec3::new(17.0, 0.0, 1.5);
    let paths = tracer.paths(tx, rx).unwrap();
    assert!(paths.is_empty(), "{paths:?}");
    // Raised above the wall top, both ends see each other again, and the receiver on the same
    // side sees the wall bounce.
    let paths = tracer.paths(tx, DVec3::new(17.0, 0.0, 30.0)).unwrap();
    assert!(paths.iter().any(|p| p.order() == 0));
    let same_side = tracer.paths(tx, DVec3::new(2.0, 3.0, 1.5)).unwrap();
    assert!(same_side
        .iter()
        .any(|p| p.order() == 1 && reflections(p)[0].0 == 1));
}

/// One specular point on a vertex shared by six triangles of six different objects (so six
/// facets): exactly one ground-bounce path, not one per triangle.
#[test]
fn shared_vertex_gives_one_path_not_one_per_triangle() {
    let mut objects = Vec::new();
    for i in -1..1 {
        for j in -1..1 {
            let (x0, y0) = (i as f32 * 10.0, j as f32 * 10.0);
            let (x1, y1) = (x0 + 10.0, y0 + 10.0);
            objects.push(object(
                &format!("tile{i}{j}"),
                Material::Concrete,
                quad(
                    Vec3::new(x0, y0, 0.0),
                    Vec3::new(x1, y0, 0.0),
                    Vec3::new(x1, y1, 0.0),
                    Vec3::new(x0, y1, 0.0),
                ),
            ));
        }
    }
    let scene = Scene::new(objects).unwrap();
    let tracer = Tracer::new(&scene, config(Polarization::Vertical, 2)).unwrap();
    assert_eq!(tracer.facets().facets.len(), 4);
    let paths = tracer
        .paths(DVec3::new(-3.0, -3.0, 2.0), DVec3::new(3.0, 3.0, 2.0))
        .unwrap();
    let bounces: Vec<&Path> = paths.iter().filter(|p| p.order() == 1).collect();
    assert_eq!(bounces.len(), 1, "{paths:?}");
    assert!(reflections(bounces[0])[0].1.length() < 1e-9);
}

/// A reconstruction-like wall: the plane x = 0, 10 m × 5 m, cut into 0.25 m triangles (1 600 of
/// them) whose vertices are displaced along x by up to ±1 cm (deterministic pseudo-noise). With the
/// default facet tolerances the wall is one facet, and the single bounce is found with an unfolded
/// length within a bound derived from the fit:
/// * the facet normal is the normalised vector area `Σ area·n = ½∮ r × dr` of the boundary loop;
///   its tilt components are `∮ x dz` and `∮ x dy` (integration by parts), at most
///   1 cm·(2·5 m) and 1 cm·(2·10 m) against an x component ≥ 50 m² − …, so tilt ≤ √(0.1²+0.2²)/50
///   ≈ 0.0045 rad;
/// * the plane passes through the area-weighted centroid, |x| ≤ 1 cm;
/// * so the distance of the transmitter to the plane errs by ≤ 1 cm + tilt·8.73 m (farthest wall
///   point from the transmitter's foot) and the image moves by ≤ 2·that + 2·h·tilt (h = 4 m), which
///   bounds the length error (first order in the image displacement): 0.134 m.
#[test]
fn noisy_wall_is_one_facet_and_reflects_within_fit_bound() {
    let n = 40;
    let step = 0.25f32;
    let noise = |i: i32, j: i32| {
        let h = ((i * 7919 + j * 104_729) as u32).wrapping_mul(2_654_435_761);
        (h as f32 / u32::MAX as f32 - 0.5) * 0.02
    };
    let v = |i: i32, j: i32| Vec3::new(noise(i, j), i as f32 * step, j as f32 * step);
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n / 2 {
            tris.extend(quad(v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)));
        }
    }
    let scene = Scene::new(vec![object("wall", Material::Concrete, tris)]).unwrap();
    let tracer = Tracer::new(&scene, config(Polarization::Vertical, 2)).unwrap();
    assert_eq!(tracer.facets().facets.len(), 1);
    let facet = &tracer.facets().facets[0];
    let tilt = (2.0 * (1.0 - facet.normal.x.abs())).max(0.0).sqrt();
    assert!(tilt <= 0.0045, "tilt {tilt}");
    let tx = DVec3::new(4.0, 2.0, 1.5);
    let rx = DVec3::new(3.0, 8.0, 2.0);
    let paths = tracer.paths(tx, rx).unwrap();
    let b: Vec<&Path> = paths.iter().filter(|p| p.order() == 1).collect();
    assert_eq!(b.len(), 1, "{paths:?}");
    let exact = (rx - DVec3::new(-4.0, 2.0, 1.5)).length();
    let bound = 2.0 * (0.01 + 0.0045 * 8.73) + 2.0 * 4.0 * 0.0045;
    assert!(
        (b[0].length_m - exact).abs() < bound,
        "{} vs {exact}",
        b[0].length_m
    );
}

/// Shoot-and-bounce candidates (default 200 000 rays) find the same paths as the exhaustive
/// enumeration of facet sequences in a small city (ground + 4 buildings, 21 facets) at order 2,
/// for receivers spread over the streets: the candidate search may only miss paths if a facet
/// sequence's lit region falls between rays, which at 0.5° spacing and < 100 m range does not
/// happen for 10 m facets.
#[test]
fn sbr_candidates_find_the_exhaustive_paths_in_a_small_city() {
    let scene = Scene::new(vec![
        ground(200.0),
        building(
            "b0",
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(30.0, 25.0, 12.0),
        ),
        building(
            "b1",
            Vec3::new(-30.0, 8.0, 0.0),
            Vec3::new(-12.0, 30.0, 18.0),
        ),
        building(
            "b2",
            Vec3::new(-25.0, -30.0, 0.0),
            Vec3::new(-8.0, -10.0, 9.0),
        ),
        building(
            "b3",
            Vec3::new(12.0, -28.0, 0.0),
            Vec3::new(35.0, -9.0, 15.0),
        ),
    ])
    .unwrap();
    let exh = Tracer::new(
        &scene,
        TracerConfig {
            candidates: CandidateMode::Exhaustive,
            ..config(Polarization::Vertical, 2)
        },
    )
    .unwrap();
    let sbr = Tracer::new(&scene, config(Polarization::Vertical, 2)).unwrap();
    assert_eq!(exh.facets().facets.len(), 21);
    let tx = DVec3::new(0.0, 0.0, 10.0);
    let ce = exh.prepare_tx(tx).unwrap();
    let cs = sbr.prepare_tx(tx).unwrap();
    let rxs: Vec<DVec3> = (0..40)
        .map(|i| {
            let a = i as f64 * 2.399;
            let r = 5.0 + (i as f64 * 1.7) % 60.0;
            DVec3::new(r * a.cos(), r * a.sin(), 1.5)
        })
        .collect();
    let pe = exh.trace_many(&ce, &rxs).unwrap();
    let ps = sbr.trace_many(&cs, &rxs).unwrap();
    let mut total = 0;
    for (i, (e, s)) in pe.iter().zip(&ps).enumerate() {
        let de: Vec<f64> = e.iter().map(|p| p.delay_s).collect();
        let ds: Vec<f64> = s.iter().map(|p| p.delay_s).collect();
        assert_eq!(de, ds, "rx {i} at {:?}", rxs[i]);
        total += e.len();
    }
    assert!(
        total > 100,
        "only {total} paths: the scene is not exercising reflections"
    );
}

/// `H(f)` of one path is `a·e^{−j2π f τ}` at every subcarrier (FFT order, as has_dsp::ofdm),
/// and of two paths the sum; both to 1e-12 relative (a few roundings of a unit phasor).
#[test]
fn frequency_response_of_paths_is_sum_of_delayed_phasors() {
    let scene = Scene::new(vec![ground(500.0)]).unwrap();
    let tracer = Tracer::new(&scene, config(Polarization::Vertical, 1)).unwrap();
    let paths = tracer
        .paths(DVec3::new(0.0, 0.0, 10.0), DVec3::new(80.0, 5.0, 1.5))
        .unwrap();
    assert_eq!(paths.len(), 2);
    let (n, df) = (64usize, 400e6 / 64.0);
    let h1 = frequency_response(&paths[..1], n, df).unwrap();
    let h2 = frequency_response(&paths, n, df).unwrap();
    for k in 0..n {
        let f = has_dsp::ofdm::subcarrier_offset_hz(k, n, df);
        let e = |p: &Path| {
            p.a * Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * f * p.delay_s)
        };
        let one = e(&paths[0]);
        assert!((h1[k] - one).norm() < 1e-12 * one.norm(), "k = {k}");
        let two = one + e(&paths[1]);
        assert!((h2[k] - two).norm() < 1e-12 * paths[0].a.norm(), "k = {k}");
    }
    let at = frequency_response_at(&paths[..1], &[0.0]);
    assert!((at[0] - paths[0].a).norm() < 1e-15);
}

#[test]
fn bad_inputs_are_errors_naming_the_field() {
    let scene = Scene::new(vec![ground(10.0)]).unwrap();
    let e = Tracer::new(
        &scene,
        TracerConfig {
            frequency_hz: f64::NAN,
            ..TracerConfig::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("frequency_hz"), "{e}");
    let e = Tracer::new(
        &scene,
        TracerConfig {
            max_order: 9,
            ..TracerConfig::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("max_order: 9"), "{e}");
    let e = Tracer::new(
        &scene,
        TracerConfig {
            candidates: CandidateMode::Sbr { rays: 0 },
            ..TracerConfig::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("sbr_rays"), "{e}");
    let tracer = Tracer::new(&scene, TracerConfig::default()).unwrap();
    let e = tracer
        .paths(DVec3::new(f64::NAN, 0.0, 1.0), DVec3::ONE)
        .unwrap_err();
    assert!(matches!(e, PathError::NonFinitePosition { what: "tx", .. }));
    assert!(e.to_string().starts_with("tx: position (NaN"), "{e}");
    let c = tracer.prepare_tx(DVec3::new(0.0, 0.0, 1.0)).unwrap();
    let e = tracer
        .trace_many(&c, &[DVec3::ONE, DVec3::new(0.0, f64::INFINITY, 1.0)])
        .unwrap_err();
    assert!(e.to_string().starts_with("rx: position (0, inf"), "{e}");
    let e = tracer
        .paths(DVec3::new(0.0, 2e6, 1.0), DVec3::ONE)
        .unwrap_err();
    assert!(matches!(e, PathError::FarPosition { what: "tx", .. }));
    assert!(
        e.to_string().starts_with("tx: position (0, 2000000, 1)"),
        "{e}"
    );
    let e = Tracer::new(
        &scene,
        TracerConfig {
            candidates: CandidateMode::Sbr {
                rays: has_host::paths::MAX_SBR_RAYS + 1,
            },
            ..TracerConfig::default()
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().starts_with("sbr_rays: 1073741825"), "{e}");
    // Concrete's ITU-R P.2040 fit is stated for 1–100 GHz.
    for f in [0.5e9, 1e30] {
        let e = Tracer::new(
            &scene,
            TracerConfig {
                frequency_hz: f,
                ..TracerConfig::default()
            },
        )
        .err()
        .unwrap();
        assert!(matches!(e, PathError::MaterialFrequency { .. }), "{e}");
        assert!(e.to_string().contains("material concrete"), "{e}");
    }
    let e = frequency_response(&[], 0, 1e6).unwrap_err();
    assert!(e.to_string().contains("n_subcarriers"), "{e}");
    let e = frequency_response(&[], 8, -1.0).unwrap_err();
    assert!(e.to_string().contains("spacing_hz: -1"), "{e}");
}

/// On the city-block fixture (14 buildings, 84 facets), the default SBR candidates give exactly
/// the paths of the exhaustive enumeration (≈ 586 000 facet sequences) at order 3 for 24 street
/// UEs: same count and same delays (both come from the same f64 image chain).
#[test]
fn sbr_matches_exhaustive_on_city_block_fixture_at_order_3() {
    let spec = has_host::scenario::SceneSpec::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/city_block.toml"
    )))
    .unwrap();
    let scene = spec.build().unwrap();
    let exh = Tracer::new(
        &scene,
        TracerConfig {
            candidates: CandidateMode::Exhaustive,
            ..TracerConfig::default()
        },
    )
    .unwrap();
    let sbr = Tracer::new(&scene, TracerConfig::default()).unwrap();
    let tx = DVec3::new(0.0, 0.0, 25.0);
    let rxs: Vec<DVec3> = (0..60)
        .map(|i| {
            let a = i as f64 * 2.399;
            let r = 20.0 + (i as f64 * 13.7) % 110.0;
            DVec3::new(r * a.cos(), r * a.sin(), 1.5)
        })
        .filter(|p| {
            scene
                .closest_hit(p.as_vec3(), Vec3::Z, 0.0, f32::INFINITY)
                .is_none()
        })
        .take(24)
        .collect();
    assert_eq!(rxs.len(), 24);
    let pe = exh.trace_many(&exh.prepare_tx(tx).unwrap(), &rxs).unwrap();
    let ps = sbr.trace_many(&sbr.prepare_tx(tx).unwrap(), &rxs).unwrap();
    let mut total = 0;
    for (i, (e, s)) in pe.iter().zip(&ps).enumerate() {
        let de: Vec<f64> = e.iter().map(|p| p.delay_s).collect();
        let ds: Vec<f64> = s.iter().map(|p| p.delay_s).collect();
        assert_eq!(de, ds, "rx {i} at {:?}", rxs[i]);
        total += e.len();
    }
    assert!(total >= 48, "only {total} paths");
}
