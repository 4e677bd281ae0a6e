//! The Markdown rendering of a [`ChannelReport`] (`report.md` of `has-sim channel`), written
//! from the typed report: the error percentiles against the paper's, beam selection, the tracer
//! and timings. Numbers print as `report.json` holds them.

use std::fmt::Write;

use serde::Serialize;

use super::{ChannelReport, ErrorStats};

/// A report number as `report.json` holds it: a non-finite value is `null` there, NaN here.
fn num(x: Option<f64>) -> f64 {
    x.filter(|v| v.is_finite()).unwrap_or(f64::NAN)
}

/// A value as `report.json` prints it (`5.0`, not Rust's `5`; `null` for a non-finite number).
fn js<T: Serialize>(x: &T) -> String {
    serde_json::to_string(x).unwrap_or_else(|_| "null".to_string())
}

/// p50, p90 and p95 of parameter `k` of `s`.
fn quantiles(s: &ErrorStats, k: usize) -> [f64; 3] {
    [s.p50, s.p90, s.p95].map(|q| num(q.to_array()[k]))
}

impl ChannelReport {
    /// The report as Markdown.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        self.write_markdown(&mut s)
            .expect("writing to a String cannot fail");
        s
    }

    fn write_markdown(&self, s: &mut String) -> std::fmt::Result {
        let c = self;
        writeln!(s, "# has-sim channel — {}\n", c.scenario)?;
        writeln!(
            s,
            "Preset `{}`, twin `{}`, fc {} GHz, all objects concrete; BS at {}, {} UEs of which {} kept (strongest true path loses < {} dB), paths within {} dB of each UE's strongest.\n",
            c.preset,
            c.twin_mesh,
            js(&c.fc_ghz),
            js(&c.bs_position),
            c.ues.total,
            c.ues.kept,
            js(&c.max_loss_db),
            js(&c.window_db)
        )?;
        writeln!(
            s,
            "| error of matched paths | p50 | p90 | p95 | paper p90 | goal p90 |"
        )?;
        writeln!(s, "|---|---|---|---|---|---|")?;
        let (paper, goal) = (c.paper_p90.to_array(), c.goal_p90.to_array());
        for (k, label) in ["delay (ns)", "AoA (°)", "AoD (°)", "ZoA (°)", "ZoD (°)"]
            .iter()
            .enumerate()
        {
            let [p50, p90, p95] = quantiles(&c.all, k);
            writeln!(
                s,
                "| {label} | {p50:.3} | {p90:.3} | {p95:.3} | {} | {} |",
                js(&paper[k]),
                js(&goal[k])
            )?;
        }
        let p = &c.paths;
        writeln!(
            s,
            "\n{} matched pairs ({} true→twin, {} twin→true). Paths in the window: {} true, {} twin (of {} / {} traced). Unmatched (distance > {}): {} true paths without a twin counterpart, {} twin paths without a true one.",
            c.all.count, p.matched_true_to_twin, p.matched_twin_to_true, p.true_kept, p.twin_kept, p.true_total, p.twin_total, js(&p.unmatched_distance), p.unmatched_true, p.unmatched_twin
        )?;
        writeln!(
            s,
            "\n| true→twin by order of the true path | pairs | unmatched % | p90 delay (ns) | p90 AoA (°) | p90 AoD (°) | p90 ZoA (°) | p90 ZoD (°) |"
        )?;
        writeln!(s, "|---|---|---|---|---|---|---|---|")?;
        for (order, st) in &c.true_to_twin_by_order {
            let q = st.stats.p90.to_array().map(num);
            writeln!(
                s,
                "| {order} | {} | {:.1} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
                st.stats.count,
                num(Some(st.unmatched_pct)),
                q[0],
                q[1],
                q[2],
                q[3],
                q[4]
            )?;
        }
        let vb = &c.via_building;
        let [d, aoa, aod, zoa, zod] = std::array::from_fn(|k| quantiles(vb, k));
        writeln!(
            s,
            "\nPairs whose source path reflects off the building (not only the known ground): {}; p50 / p90 / p95 delay {:.3} / {:.3} / {:.3} ns, AoA {:.2} / {:.2} / {:.2}°, AoD {:.2} / {:.2} / {:.2}°, ZoA {:.2} / {:.2} / {:.2}°, ZoD {:.2} / {:.2} / {:.2}°.",
            vb.count,
            d[0], d[1], d[2],
            aoa[0], aoa[1], aoa[2],
            aod[0], aod[1], aod[2],
            zoa[0], zoa[1], zoa[2],
            zod[0], zod[1], zod[2],
        )?;
        let vm = &c.via_building_matched;
        let q = vm.p90.to_array().map(num);
        writeln!(
            s,
            "Of those, {} have a counterpart within distance {}: p90 delay {:.3} ns, AoA {:.2}°, AoD {:.2}°, ZoA {:.2}°, ZoD {:.2}°.",
            vm.count,
            js(&c.paths.unmatched_distance),
            q[0],
            q[1],
            q[2],
            q[3],
            q[4],
        )?;
        let b = &c.beam;
        let loss = b.loss_db.as_ref();
        writeln!(
            s,
            "\nBeam selection ({}): the beam picked from the twin's paths is the true best beam for {:.1} % of {} kept UEs, within 1 dB of it for {:.1} %; loss p50 {:.2} dB, p90 {:.2} dB.",
            b.codebook,
            num(Some(b.agreement_pct)),
            b.ues,
            num(Some(b.within_1db_pct)),
            num(loss.and_then(|l| l.p50)),
            num(loss.and_then(|l| l.p90))
        )?;
        let t = &c.timings_s;
        let tr = &c.tracer;
        let f = |x: f64| num(Some(x));
        writeln!(
            s,
            "\nTracer: order {}, {} SBR rays, line of sight and specular reflections (no diffraction); {} / {} facets and {} / {} candidate sequences (true / twin). Wall {:.1} s (twin reconstruction {:.1} s, tracing {:.1} + {:.1} s), {:.0} / {:.0} paths/s (true / twin) on {} threads.",
            tr.max_order, tr.sbr_rays, tr.facets_true, tr.facets_twin, tr.candidates_true, tr.candidates_twin,
            f(t.wall), f(t.twin_reconstruction), f(t.prepare_true) + f(t.trace_true), f(t.prepare_twin) + f(t.trace_twin),
            f(c.paths_per_s.true_scene), f(c.paths_per_s.twin), c.threads
        )?;
        let cv = &c.conventions;
        writeln!(
            s,
            "\nConventions: {}; {}; percentiles: {}; {}.",
            cv.matching, cv.angles, cv.percentile, cv.beam
        )?;
        Ok(())
    }
}
