//! The comparison of one UE's link on the true scene and on the digital twin (paper §2): the
//! twin's objects (the reconstructed mesh plus the known ground, all one material), the matched
//! multipath sets and the beam each scene would choose.
//!
//! Units: delays ns, gains dB, angles degrees (as in [`crate::multipath::PathParams`]).

use crate::material::Material;
use crate::scenario::{ChannelSpec, ScenarioError, TableFields};
use crate::scene::Object;

/// Fields of the `[channel]` table named in this module's errors.
const CHANNEL: TableFields = TableFields::new("channel");

/// `objects` with every material set to `material`.
pub fn with_material(mut objects: Vec<Object>, material: Material) -> Vec<Object> {
    for o in &mut objects {
        o.material = material;
    }
    objects
}

/// The twin's objects: the reconstructed `mesh` objects plus the objects of `truth` named in
/// `known` (renamed `known/<name>` so they never clash with the mesh's names), all `material`.
///
/// # Errors
/// [`ScenarioError::Invalid`] naming `channel.known_objects` for a name that is not an object of
/// `truth`.
pub fn twin_objects(
    mesh: Vec<Object>,
    truth: &[Object],
    known: &[String],
    material: Material,
) -> Result<Vec<Object>, ScenarioError> {
    let mut out = mesh;
    for name in known {
        let Some(o) = truth.iter().find(|o| &o.name == name) else {
            return Err(CHANNEL.invalid(
                "known_objects",
                name,
                "the name of an object of the scene",
            ));
        };
        let mut o = o.clone();
        o.name = format!("known/{}", o.name);
        out.push(o);
    }
    Ok(with_material(out, material))
}

/// The comparison of one UE's link on the two scenes.
#[derive(Clone, Debug, PartialEq)]
pub struct UeOutcome {
    /// Gain of the strongest true path, dB (`None`: no true path).
    pub strongest_true_db: Option<f64>,
    /// Kept for the statistics: the strongest true path loses less than `max_loss_db`.
    pub kept: bool,
    /// True paths within the window of the strongest true path.
    pub true_paths: Vec<crate::multipath::PathParams>,
    /// Twin paths within the window of the strongest twin path.
    pub twin_paths: Vec<crate::multipath::PathParams>,
    /// The Chamfer matching of the two windowed sets (empty when not kept or no twin path).
    pub matches: crate::multipath::ChamferMatch,
    /// Beam selection (only for kept UEs).
    pub beam: Option<BeamOutcome>,
}

/// Beam selection of one UE: the beam picked from the twin's paths judged on the true channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamOutcome {
    /// Best beam on the true channel (all true paths).
    pub true_best: usize,
    /// Its gain on the true channel, linear power.
    pub true_best_gain: f64,
    /// Beam picked from the twin's paths (`None`: the twin has no path).
    pub predicted: Option<usize>,
    /// The true channel's gain on the predicted beam, linear power (0 without a prediction).
    pub predicted_gain_on_true: f64,
}

impl BeamOutcome {
    /// True if the predicted beam is the true best beam.
    pub fn agrees(&self) -> bool {
        self.predicted == Some(self.true_best)
    }

    /// Gain lost on the true channel by using the predicted beam instead of the best, dB (≥ 0;
    /// infinite without a prediction).
    pub fn loss_db(&self) -> f64 {
        if self.predicted.is_none() || self.predicted_gain_on_true <= 0.0 {
            return f64::INFINITY;
        }
        10.0 * (self.true_best_gain / self.predicted_gain_on_true).log10()
    }
}

/// Compares one UE's paths on the true scene and on the twin (see [`crate::multipath`] and
/// [`crate::beam`]): kept if the strongest true path loses less than `spec.max_loss_db`; each
/// set windowed at `spec.window_db` below its own strongest path; Chamfer matching of the two
/// windowed sets; beam selection from all paths of each scene.
///
/// # Errors
/// A bad window or matching scale ([`crate::multipath::MultipathError`]).
pub fn compare_ue(
    spec: &ChannelSpec,
    codebook: &crate::beam::DftCodebook,
    truth: &[crate::paths::Path],
    twin: &[crate::paths::Path],
) -> Result<UeOutcome, crate::multipath::MultipathError> {
    use crate::beam::Ray;
    use crate::multipath::{chamfer_match, strongest_db, within_window, ChamferMatch, PathParams};
    let tp: Vec<PathParams> = truth.iter().map(PathParams::from).collect();
    let wp: Vec<PathParams> = twin.iter().map(PathParams::from).collect();
    let strongest_true_db = strongest_db(&tp);
    let kept = strongest_true_db.is_some_and(|g| -g < spec.max_loss_db);
    let true_paths = within_window(&tp, spec.window_db)?;
    let twin_paths = within_window(&wp, spec.window_db)?;
    let mut out = UeOutcome {
        strongest_true_db,
        kept,
        true_paths,
        twin_paths,
        matches: ChamferMatch {
            forward: Vec::new(),
            backward: Vec::new(),
        },
        beam: None,
    };
    if !kept {
        return Ok(out);
    }
    out.matches = chamfer_match(&out.true_paths, &out.twin_paths, &spec.match_scale())?;
    let true_rays: Vec<Ray> = truth.iter().map(Ray::from).collect();
    let twin_rays: Vec<Ray> = twin.iter().map(Ray::from).collect();
    let gains = codebook.beam_gains(&true_rays);
    if let Some((true_best, true_best_gain)) = crate::beam::best_of(&gains) {
        let predicted = codebook.best_beam(&twin_rays).map(|(b, _)| b);
        out.beam = Some(BeamOutcome {
            true_best,
            true_best_gain,
            predicted,
            predicted_gain_on_true: predicted.map_or(0.0, |b| gains[b]),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::channel::tests::{factory_scene, spec};
    use glam::{DVec3, Vec3};

    #[test]
    fn twin_adds_known_objects_all_concrete() {
        let scene = factory_scene();
        let mesh = vec![Object {
            thickness_m: None,
            name: "mesh".into(),
            material: Material::Glass,
            triangles: vec![[Vec3::ZERO, Vec3::X, Vec3::Y]],
        }];
        let t = twin_objects(
            mesh.clone(),
            &scene.objects,
            &["yard".into()],
            Material::Concrete,
        )
        .unwrap();
        let names: Vec<&str> = t.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["mesh", "known/yard"]);
        assert!(t.iter().all(|o| o.material == Material::Concrete));
        let e = twin_objects(mesh, &scene.objects, &["road".into()], Material::Concrete)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("channel.known_objects: \"road\""), "{e}");
    }

    fn path(
        delay_ns: f64,
        gain_db: f64,
        aod_deg: f64,
        zod_deg: f64,
        reflections: &[u32],
    ) -> crate::paths::Path {
        use crate::paths::Interaction;
        let amp = 10f64.powf(gain_db / 20.0);
        let interactions = if reflections.is_empty() {
            vec![Interaction::Los]
        } else {
            reflections
                .iter()
                .map(|&object| Interaction::Reflection {
                    object,
                    facet: 0,
                    point: DVec3::ZERO,
                })
                .collect()
        };
        crate::paths::Path {
            delay_s: delay_ns * 1e-9,
            length_m: delay_ns * 1e-9 * crate::C_M_PER_S,
            a: num_complex::Complex64::new(amp, 0.0),
            jones: [[num_complex::Complex64::new(0.0, 0.0); 2]; 2],
            aod: aod_deg.to_radians(),
            zod: zod_deg.to_radians(),
            aoa: (aod_deg + 180.0).to_radians(),
            zoa: (180.0 - zod_deg).to_radians(),
            interactions,
        }
    }

    #[test]
    fn identical_twin_has_zero_errors_and_agreeing_beam() {
        let s = spec();
        let cb =
            crate::beam::DftCodebook::new(32, 32, 0.5, s.bs_boresight_deg.to_radians()).unwrap();
        let truth = [
            path(200.0, -80.0, 40.0, 95.0, &[]),
            path(203.0, -86.0, 40.0, 100.0, &[0]),
            path(260.0, -99.0, 70.0, 94.0, &[1]),
            // 25 dB below the strongest: outside the 20 dB window.
            path(300.0, -105.0, 10.0, 93.0, &[1, 0]),
        ];
        let o = compare_ue(&s, &cb, &truth, &truth).unwrap();
        assert!(o.kept);
        assert_eq!(o.strongest_true_db, Some(-80.0));
        assert_eq!(o.true_paths.len(), 3);
        assert_eq!(o.true_paths[2].objects(), &[1]);
        assert_eq!(o.matches.forward.len(), 3);
        assert_eq!(o.matches.backward.len(), 3);
        assert!(o.matches.all().all(|m| m.distance == 0.0 && m.from == m.to));
        let b = o.beam.unwrap();
        assert!(b.agrees());
        assert_eq!(b.loss_db(), 0.0);
    }

    #[test]
    fn weak_ue_is_dropped_and_empty_twin_loses_the_beam() {
        let s = spec();
        let cb = crate::beam::DftCodebook::new(32, 32, 0.5, 0.0).unwrap();
        // Strongest path loses exactly 110 dB: not "< 110 dB", dropped.
        let weak = [path(500.0, -110.0, 40.0, 95.0, &[])];
        let o = compare_ue(&s, &cb, &weak, &weak).unwrap();
        assert!(!o.kept && o.beam.is_none() && o.matches.forward.is_empty());
        let o = compare_ue(&s, &cb, &[], &[]).unwrap();
        assert!(!o.kept && o.strongest_true_db.is_none());
        let ok = [path(500.0, -109.9, 40.0, 95.0, &[])];
        let o = compare_ue(&s, &cb, &ok, &[]).unwrap();
        assert!(o.kept && o.matches.forward.is_empty() && o.twin_paths.is_empty());
        let b = o.beam.unwrap();
        assert!(!b.agrees() && b.predicted.is_none());
        assert_eq!(b.loss_db(), f64::INFINITY);
    }
}
