//! `report.json` of a reconstruction run ([`ReconstructRunReport`]: the library's
//! [`ReconstructReport`] with the scenario's name, the preset and the process's peak memory) and
//! its Markdown rendering (`report.md` of `has-sim reconstruct`), written from the typed report.

use std::fmt::Write;

use serde::Serialize;

use super::ReconstructReport;
use crate::metrics::ObservableCompleteness;

/// `report.json` of `reconstruct`: the library's report with what only the run knows.
#[derive(Clone, Debug, Serialize)]
pub struct ReconstructRunReport {
    /// The scenario file (or the bundled one).
    pub scenario: String,
    /// `quick` or `default`.
    pub preset: &'static str,
    /// [`crate::scenario::Scenario::digest`] of the scenario as run (preset and seed applied):
    /// `reconstruct --from-pairs` compares it, not the file's name.
    pub scenario_digest: String,
    /// The seed of the scatterers and the noise (`imaging.seed`, or `--seed`).
    pub seed: u64,
    /// Peak resident memory of the process, MiB.
    pub peak_rss_mib: Option<f64>,
    /// The reconstruction's figures.
    #[serde(flatten)]
    pub reconstruction: ReconstructReport,
}

impl ReconstructRunReport {
    /// The report as Markdown: the cloud's and the mesh's metrics against the paper's Table 1,
    /// the completeness of the observable and hidden truth, one row per pair, timings.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        self.write_markdown(&mut s)
            .expect("writing to a String cannot fail");
        s
    }

    fn write_markdown(&self, s: &mut String) -> std::fmt::Result {
        let report = self;
        let r = &report.reconstruction;
        let pc = &r.imaging.point_cloud;
        writeln!(s, "# has-sim reconstruct — {}", report.scenario)?;
        writeln!(
            s,
            "\nPreset `{}`, back-projection path `{}`, echoes `{}`, voxel {:?} m.\n",
            report.preset, r.path, r.echo, r.imaging.voxel_m
        )?;
        writeln!(s, "| imaging point cloud | this run | paper (Table 1) |")?;
        writeln!(s, "|---|---|---|")?;
        writeln!(
            s,
            "| √Chamfer distance | {:.3} m | 1.18 m |",
            pc.metrics.sqrt_chamfer_m
        )?;
        for f in pc.metrics.fscores() {
            let d = f.threshold_m;
            let paper = if d == 1.5 { "94" } else { "—" };
            writeln!(
                s,
                "| F-score (d = {d} m) | {:.1} (P {:.1}, R {:.1}) | {paper} |",
                f.fscore_pct, f.precision_pct, f.recall_pct
            )?;
        }
        writeln!(
            s,
            "| points | {} ({} unconfirmed by the pairs that see them, {} terrain echoes, {} copies of a surface a finer pair placed at another height removed, {} moved to the finer pairs' height of their surface; {} of the pairs' detections were their own terrain echoes, which confirm nothing) | — |",
            pc.metrics.points,
            pc.unconfirmed_removed,
            pc.terrain_echoes_removed,
            pc.finer_heights_removed,
            pc.finer_heights_refined,
            pc.pair_ground_echoes
        )?;
        if let Some(m) = &r.mesh {
            writeln!(s, "\n| reconstructed mesh | this run | paper (Table 1) |")?;
            writeln!(s, "|---|---|---|")?;
            writeln!(
                s,
                "| √Chamfer distance | {:.3} m | 0.96 m |",
                m.metrics.sqrt_chamfer_m
            )?;
            for (f, paper) in m.metrics.fscores().iter().zip(["—", "—", "96"]) {
                writeln!(
                    s,
                    "| F-score (d = {:.1} m) | {:.1} (P {:.1}, R {:.1}) | {paper} |",
                    f.threshold_m, f.fscore_pct, f.precision_pct, f.recall_pct
                )?;
            }
            writeln!(
                s,
                "| rms distance to / from the truth | {:.3} / {:.3} m (cloud {:.3} / {:.3} m) | — |",
                m.metrics.rms_to_truth_m,
                m.metrics.rms_from_truth_m,
                pc.metrics.rms_to_truth_m,
                pc.metrics.rms_from_truth_m
            )?;
            writeln!(
                s,
                "| false surface (area > 1.5 m from the truth) / area against the truth's | {:.1} % / {:.2} ({:.0} of {:.0} m²) | — |",
                m.false_surface_pct_1_5m, m.area_ratio, m.area_m2, m.truth_area_m2
            )?;
            writeln!(
                s,
                "| vertices / faces | {} / {} (watertight: {}) | — |",
                m.vertices, m.faces, m.watertight
            )?;
            writeln!(
                s,
                "\nMesh: screened Poisson depth {} (cell {:.3} m), {}, clipped to the imaging region and to {:.2} m (half the coarsest pair resolution cell) of the fused points, components under {:.2} of the largest area dropped; {:.1} s. Sampled at {:?} points per m² for the metrics.",
                m.depth,
                m.cell_m,
                match m.trim_median_fraction {
                    Some(f) => format!("trimmed below {f:.2} × the median support density"),
                    None => "no density trim".to_string(),
                },
                m.support_distance_m.unwrap_or(f32::NAN),
                m.min_component_fraction,
                m.seconds,
                m.sample_density_per_m2
            )?;
            let roofed = m.footprints.iter().filter(|f| f.samples > 0).count();
            writeln!(
                s,
                "Inferred in the mesher's input: {} samples continuing walls down to what they stand on, {} of roofs over {} of {} buildings whose imaged walls outline a footprint and whose roof no pair saw, {} of walls under the outer edges of roofs, {} of walls across the gaps along the footprints' sides, {} of roof slopes and faces meeting in valleys; {} of these lay where a pair's leg ran through to a surface beyond and were left out.",
                m.wall_column_samples,
                m.hidden_roof_samples,
                roofed,
                m.footprints.len(),
                m.roof_edge_samples,
                m.outline_wall_samples,
                m.valley_samples,
                m.free_space_samples
            )?;
            if let Some(v) = &m.visibility_filter {
                writeln!(
                    s,
                    "Visibility consistency: {} of {} fused points were hidden by a first-pass surface from every sensor that observed them (margin {:?} m) and were left out of the mesh.",
                    v.removed_points, v.input_points, v.margin_m as f64
                )?;
            }
        }
        if let Some(t) = &r.planar_twin {
            match (&t.metrics, &t.error) {
                (Some(tm), _) => {
                    writeln!(
                        s,
                        "\n| planar twin (`twin.obj`, `twin.city.json`, `twin.xml`) | this run |"
                    )?;
                    writeln!(s, "|---|---|")?;
                    writeln!(
                        s,
                        "| √Chamfer distance | {:.3} m |",
                        tm.cloud.sqrt_chamfer_m
                    )?;
                    let f = &tm.cloud.fscores;
                    writeln!(
                        s,
                        "| F-score (d = 1.5 m) | {:.1} (P {:.1}, R {:.1}) |",
                        f.fscore_1_5m, f.precision_1_5m, f.recall_1_5m
                    )?;
                    writeln!(
                        s,
                        "| false surface (area > 1.5 m from the truth) / area against the truth's | {:.1} % / {:.2} |",
                        tm.area.false_surface_pct, tm.area.area_ratio
                    )?;
                    writeln!(
                        s,
                        "| faces: walls / roofs / ground (inferred) | {} / {} / {} ({}) in {} buildings, watertight: {}; {:.1} s |",
                        t.faces[1],
                        t.faces[2],
                        t.faces[3],
                        t.inferred_faces,
                        t.buildings,
                        t.watertight,
                        t.seconds
                    )?;
                }
                (None, e) => writeln!(
                    s,
                    "\nPlanar twin: not built ({}).",
                    e.as_deref().unwrap_or("no reason recorded")
                )?,
            }
        }
        let obs = |v: Option<&ObservableCompleteness>, observable: bool| {
            let part = v.and_then(|v| if observable { v.observable } else { v.hidden });
            match part {
                Some(p) => format!("{:.3} m / {:.1} %", p.rms_from_truth_m, p.recall_1_5m),
                None => "— (no such truth points)".to_string(),
            }
        };
        let mo = r.mesh.as_ref().map(|m| &m.observable_truth);
        let gt = &r.imaging.ground_truth;
        writeln!(
            s,
            "\n{:.1} % of the ground truth is in line of sight of some imaged pair (both legs), {:.1} % of some pairing of the scenario's base stations and apertures; the rest can only be inferred. Completeness (rms distance from the truth / recall at 1.5 m): observable part — cloud {}, mesh {}; hidden part — cloud {}, mesh {}.",
            gt.observable_pct,
            gt.observable_any_pairing_pct,
            obs(Some(&pc.observable_truth), true),
            obs(mo, true),
            obs(Some(&pc.observable_truth), false),
            obs(mo, false),
        )?;
        writeln!(s, "\n## Pairs\n")?;
        writeln!(
            s,
            "| pair | positions × elements | resolution cell m | points | fine voxels | BP s | synth s |"
        )?;
        writeln!(s, "|---|---|---|---|---|---|---|")?;
        for p in &r.imaging.pairs {
            let st = &p.stats;
            writeln!(
                s,
                "| {} | {} × {} | {:.2} | {} | {} / {} | {:.1} | {:.1} |",
                p.name,
                st.frames,
                st.elements,
                p.resolution_cell_m,
                p.points,
                st.fine_voxels,
                st.region_voxels,
                st.bp_s,
                st.synth_s,
            )?;
        }
        let t = &r.timings_s;
        writeln!(
            s,
            "\nWall {:.1} s (imaging {:.1} s, of which back-projection {:.1} s); {:.3e} backprojections at {:.3e}/s on {} threads.",
            t.wall, t.imaging, t.backprojection, r.backprojections, r.backprojections_per_s, r.threads
        )?;
        if let Some(p) = report.peak_rss_mib {
            writeln!(s, "Peak resident memory {p:.0} MiB.")?;
        }
        writeln!(
            s,
            "\nGround truth: {} points at {:?} per m² on {}. Conventions: {}; {}.",
            pc.metrics.truth_points,
            gt.density_per_m2,
            gt.surfaces,
            r.conventions.chamfer,
            r.conventions.fscore
        )?;
        Ok(())
    }
}
