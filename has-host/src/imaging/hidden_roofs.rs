//! A building's roof over its imaged walls, where no pair saw the roof.
//!
//! A terminal on the ground and a base station on a mast form no pair that sees a roof above
//! the terminal: both legs of a bistatic echo must reach the roof from above it. Without a UAV
//! (or a base station high over the site facing a pair's other end above the roofs) the roofs
//! are not imaged at all, and on such sites they are the bulk of what the twin misses (the
//! district recipe's sites with two base stations and no UAV: 45–49 % of the truth in any
//! pair's sight, the mesh's recall of the rest at 1.5 m 18–31 % without this rule, 65–80 % with
//! it; docs/journal/results.md). The walls are imaged, and a wall does not end in the air: a building's
//! wall ends at its roof.
//!
//! Where the imaged walls of one building outline a footprint, the roof is taken to span it at
//! the height of the walls' top (the upper quartile of their lattice columns' tops: the median
//! of the columns imaged up to the top; a column short of it was hidden or grazed there). Two
//! outlines are read, the two shapes buildings and tanks are built in:
//! - **a rectangle** in the frame of the walls' dominant direction (the mean of four times the
//!   normals' azimuths: a rectangle's four faces agree on it). At least two of its sides must be
//!   imaged — wall samples within a resolution cell of the side, facing out of it within 45°,
//!   spanning [`SIDE_IMAGED_FRACTION`] of its length; an imaged side stands at its outermost
//!   wall sample, and the sides not imaged where the imaged ones end (not at the farthest stray
//!   sample: on held-out site_43 one point 3.7 m out carried a strip of roof and its walls
//!   there, mesh √CD 0.450 → 1.289 m) — but where the building's imaged roof ends more than a
//!   lattice cell farther out (its samples at the walls' top spanning as much of the side as
//!   an imaged side's walls must), there: a roof does not reach past its walls. An L of two
//!   faces gives the footprint, one face alone gives none (its depth is unknown). Where two
//!   imaged sides meet, the walls must reach the corner within a resolution cell (a round
//!   building's bounding box has its corners in the open), and no face wider than two
//!   resolution cells may stand inside the rectangle a resolution cell under the walls' top
//!   (an L-shaped block or two buildings side by side whose inner faces were imaged; a
//!   sawtooth's risers stand above the walls' top and do not count);
//! - **a circle**, when the normals along an imaged side turn by more than [`ROUND_TURN_RAD`]
//!   over its length (a wall's normals scatter about one direction, a tank's turn with the arc):
//!   the least-squares circle through the walls, which must lie on it within the support
//!   distance (rms), with no face inside it as above. Half a tank seen gives the whole disc.
//!
//! **A gable's far half.** A side no wall images is placed where the imaged sides across it
//! end, which for a pitched roof seen from one side is about its ridge: the gable ends are
//! imaged from the near eave up to a little past the ridge, and the far half — the far slope,
//! the far wall — no pair saw (held-out district_54: a glass block's far side 5.6 m short, its
//! far wall and half its roof missing, mesh √CD 2.78 m). A gable is symmetric about its ridge,
//! so where the building's height profile across the rectangle (its highest sample per lattice
//! cell of distance from the imaged side opposite) rises from that side's eave by a resolution
//! cell or more to a peak inside, and falls past the peak as the mirror of its rise — within
//! half a resolution cell over at least two lattice cells, by a lattice cell at least, nothing
//! past the peak standing a lattice cell higher — the unimaged side stands at the mirror of the
//! imaged one about the ridge (the axis the profile is most symmetric about among the cells
//! within half a resolution cell of its top), if that is farther out. A mono-pitch roof rises
//! on to the side and a sawtooth's riser drops where the mirror of its ramp stands high:
//! neither is mirrored. The far half is roofed with the imaged roof's samples mirrored about the
//! ridge (normals mirrored too) where no detected sample lies within the support distance, but
//! not within a resolution cell of the far side: there the roof is flat at the walls' top like
//! any hidden roof, so that the walls under its edge follow the side and not the ragged rim of
//! a smeared slope's image (mirrored to the side, that rim cost held-out district_54 0.36 m of
//! √CD).
//!
//! The roof's samples are placed on the imaging lattice over the footprint where the cloud
//! holds nothing near the walls' top (within a resolution cell under it) within the support
//! distance: a roof imaged in part keeps its image and only its hidden part is added. An imaged
//! face looks out over open ground, so where more than [`FACING_ROOF_FRACTION`] of the
//! building's open-fronted wall samples below the roof look straight into it, the footprint
//! holds more than one building and gets no roof (two buildings 2 m apart at different yaws
//! read as one rectangle on held-out site_45: half their faces looked into its roof). They face
//! up, with the median weight of the building's outline wall samples. The walls under the added
//! roof's outer edges — the faces no pair saw — then follow from
//! [`super::wall_columns::roof_edge_walls`]. What this cannot know: a pitched or sawtooth roof
//! no pair saw is roofed flat at its eaves, and a building that is neither a rectangle nor a
//! circle gets no roof.
//!
//! **A courtyard** is open ground inside the outline: where an open-fronted face below the roof
//! looks across what the cloud holds nothing of and the first thing its look meets is a face
//! looking back at it (within 45°), the lattice columns the look crossed are a yard
//! ([`Footprint::yard`]): no roof is added there, and a wall within a resolution cell of it
//! stands on the terrain, not the roof. A face is imaged from the side it looks to, so the
//! ground between two faces looking at each other is open; a hidden roof has nothing looking
//! into it but its own building's far walls, which look away. Without it a closed courtyard
//! block (held-out site_41, quick) was roofed over its yard and its yard's walls ended at the
//! roof: mesh 2.089 m against 1.044 m with it (docs/journal/results.md).
//!
//! **Inside a footprint** a vertical face stands on the roof ([`standing_on`]): a building
//! whose imaged walls outline a footprint has its outer walls on the outline and no face below
//! its roof inside it (else it has no footprint), so a wall imaged inside it — a sawtooth's
//! riser, a pitched roof imaged up to its ridge, a parapet, a tower on a podium — rises from
//! the roof, and the walls [`super::wall_columns`] continues and stands under roof edges end
//! there, not at the terrain. Continued to the terrain they ran through the buildings: on
//! held-out district_51 (quick) a sawtooth's risers and a pitched roof's ridge carried 12 % of
//! the mesh's area inside two towers 24 m high (docs/journal/results.md).
//!
//! A building is the set of the detected samples (not the walls other rules inferred) more than
//! the support distance above the known terrain whose lattice columns (of the support distance)
//! touch; where the terrain is not known nothing is added. Units: metres, world frame; z up.

use std::collections::{BTreeMap, BTreeSet};
use std::f32::consts::FRAC_1_SQRT_2;

use glam::{Vec2, Vec3};
use serde::Serialize;

use super::wall_columns::{Fronts, WallColumns, WALL_MAX_TILT_DEG};

/// A side of the rectangle counts as imaged when its wall samples span at least this fraction of
/// its length: the other sides' positions are read from where the imaged ones end.
pub const SIDE_IMAGED_FRACTION: f32 = 0.5;

/// A side whose normals turn by more than this along its imaged length, radians, is an arc, not
/// a wall: the building is round (a wall's normals scatter about one direction by the normal
/// estimate's error, their trend along the wall is nil; a cylinder's turn by the arc's angle).
pub const ROUND_TURN_RAD: f32 = 1.0;

/// Why a group of samples has no footprint when it has fewer than three wall samples (not
/// listed in the footprints [`hidden_roofs`] returns: a blob, not a building).
const NO_WALLS: &str = "no walls";

/// Largest share of a building's open-fronted wall samples below its roof that may look straight
/// into the roof (module docs): more, and the footprint holds more than one building. Measured
/// on 27 sites at the quick preset: at most 4.3 % on single buildings (normals astray at
/// corners), 52 % on two buildings 2 m apart taken for one (held-out site_45).
pub const FACING_ROOF_FRACTION: f32 = 0.1;

/// The shape a building's imaged walls outline.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outline {
    /// A rectangle, corners counter-clockwise (xy, metres).
    Rectangle([Vec2; 4]),
    /// A circle (a tank, a round tower).
    Round {
        /// Centre (xy, metres).
        centre: Vec2,
        /// Radius, metres.
        radius_m: f32,
    },
    /// No footprint: why not.
    Unknown(&'static str),
}

impl Outline {
    /// The outline's bounding box (xy), `None` for no outline.
    fn bounds(&self) -> Option<(Vec2, Vec2)> {
        match *self {
            Outline::Rectangle(c) => Some(c.iter().fold(
                (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
                |(lo, hi), q| (lo.min(*q), hi.max(*q)),
            )),
            Outline::Round { centre, radius_m } => Some((centre - radius_m, centre + radius_m)),
            Outline::Unknown(_) => None,
        }
    }

    /// Whether `q` (xy) lies inside the outline (on a rectangle's edge within a millimetre).
    fn contains(&self, q: Vec2) -> bool {
        match *self {
            Outline::Rectangle(c) => {
                let (eu, ev) = (c[1] - c[0], c[3] - c[0]);
                let d = q - c[0];
                let (lu, lv) = (eu.length(), ev.length());
                (-1e-3..=lu + 1e-3).contains(&d.dot(eu.normalize()))
                    && (-1e-3..=lv + 1e-3).contains(&d.dot(ev.normalize()))
            }
            Outline::Round { centre, radius_m } => q.distance(centre) <= radius_m,
            Outline::Unknown(_) => false,
        }
    }

    /// How far `q` (xy) lies inside the outline: its distance to the nearest side (to the
    /// circle), negative outside; `-inf` for no outline.
    pub fn depth_inside(&self, q: Vec2) -> f32 {
        match *self {
            Outline::Rectangle(c) => {
                let (eu, ev) = (c[1] - c[0], c[3] - c[0]);
                let d = q - c[0];
                let (lu, lv) = (eu.length(), ev.length());
                let (a, b) = (d.dot(eu / lu), d.dot(ev / lv));
                a.min(lu - a).min(b).min(lv - b)
            }
            Outline::Round { centre, radius_m } => radius_m - q.distance(centre),
            Outline::Unknown(_) => f32::NEG_INFINITY,
        }
    }
}

/// What a vertical face at `p` stands on (module docs, "Inside a footprint"): the roof of the
/// footprint `p` lies more than two support distances (`front_m`) inside — a resolution cell and
/// more inside every side, as the footprint's inner-face test reads "inside", and not within a
/// resolution cell of its yard (module docs, "A courtyard") — or, where it lies inside none,
/// `floor(p)` (the known terrain); never below `floor(p)`, `None` where that is.
pub fn standing_on<'a>(
    footprints: &'a [Footprint],
    front_m: f32,
    floor: impl Fn(Vec3) -> Option<f32> + 'a,
) -> impl Fn(Vec3) -> Option<f32> + 'a {
    move |p: Vec3| {
        let ground = floor(p)?;
        let roof = footprints
            .iter()
            .filter(|f| f.height_m.is_finite())
            .filter(|f| f.outline.depth_inside(p.truncate()) > 2.0 * front_m)
            .filter(|f| !f.yard_near(p.truncate(), 2.0 * front_m))
            .map(|f| f.height_m)
            .fold(ground, f32::max);
        Some(roof)
    }
}

/// One building's footprint and roof ([`hidden_roofs`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Footprint {
    /// The building's samples' mean position (xy, metres).
    pub centre: Vec2,
    /// What its walls outline.
    pub outline: Outline,
    /// The roof's height, metres (NaN without a footprint).
    pub height_m: f32,
    /// Roof samples added.
    pub samples: usize,
    /// The lattice columns (of the roof's lattice, `yard_cell_m`) inside the outline that are
    /// open ground between faces looking at each other — a courtyard (module docs): no roof is
    /// added there and walls there stand on the terrain.
    #[serde(skip)]
    pub yard: BTreeSet<(i64, i64)>,
    /// The side of `yard`'s lattice columns, metres.
    #[serde(skip)]
    pub yard_cell_m: f32,
}

impl Footprint {
    /// Whether a yard column lies within `r` of `q`.
    pub fn yard_near(&self, q: Vec2, r: f32) -> bool {
        if self.yard.is_empty() || self.yard_cell_m.is_nan() || self.yard_cell_m <= 0.0 {
            return false;
        }
        let c = self.yard_cell_m;
        let k = (r / c).ceil() as i64;
        let (x, y) = column(q, c);
        (-k..=k).any(|dx| {
            (-k..=k).any(|dy| {
                self.yard.contains(&(x + dx, y + dy))
                    && (Vec2::new((x + dx) as f32 + 0.5, (y + dy) as f32 + 0.5) * c).distance(q)
                        <= r + c
            })
        })
    }
}

/// The lattice and rules [`hidden_roofs`] reads footprints and samples roofs with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoofOptions {
    /// The lattice the roof is sampled on, metres.
    pub cell_m: f32,
    /// The support distance (half the coarsest resolution cell), metres.
    pub front_m: f32,
    /// Whether an unimaged side under a gable imaged past its ridge is mirrored (module docs,
    /// "A gable's far half").
    pub gables: bool,
}

/// The samples of the hidden roofs over the imaged walls (module docs), and each building's
/// footprint (the groups with walls). `points`, `normals` (unit, oriented) and `weights` are
/// the detected samples of the mesher's input; `opts` the lattice and rules; `floor(p)` the known
/// terrain under `p` (`None` where unknown); `imaged(q)` whether the imaging region covers the
/// ground position `q` (a roof is added only there).
/// Deterministic: buildings in lattice order, samples in lattice order.
pub fn hidden_roofs(
    points: &[Vec3],
    normals: &[Vec3],
    weights: &[f32],
    opts: &RoofOptions,
    floor: impl Fn(Vec3) -> Option<f32>,
    imaged: impl Fn(Vec2) -> bool,
) -> (WallColumns, Vec<Footprint>) {
    let RoofOptions {
        cell_m,
        front_m,
        gables,
    } = *opts;
    let mut out = WallColumns::default();
    let mut prints = Vec::new();
    if !(cell_m > 0.0 && cell_m.is_finite() && front_m > 0.0 && front_m.is_finite()) {
        return (out, prints);
    }
    // The samples standing above the terrain, per lattice column of the support distance.
    let mut cols: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for (i, p) in points.iter().enumerate() {
        if p.is_finite() && floor(*p).is_some_and(|g| p.z > g + front_m) {
            cols.entry(column(p.truncate(), front_m))
                .or_default()
                .push(i);
        }
    }
    let fronts = Fronts::new(points, cell_m, front_m);
    for mut members in components(&cols) {
        members.sort_unstable();
        let b = Building {
            points,
            normals,
            weights,
            members: &members,
            cell_m,
            front_m,
            gables,
        };
        let (fp, samples) = b.roof(&fronts, &imaged);
        for (p, n, w) in samples {
            out.points.push(p);
            out.normals.push(n);
            out.weights.push(w);
        }
        out.columns += fp.samples;
        if fp.outline != Outline::Unknown(NO_WALLS) {
            prints.push(fp);
        }
    }
    (out, prints)
}

/// The lattice column of side `size` holding `q`.
fn column(q: Vec2, size: f32) -> (i64, i64) {
    ((q.x / size).floor() as i64, (q.y / size).floor() as i64)
}

/// Whether any entry of the lattice columns of side `size` around `q` (its own and the eight
/// neighbours: every point within `size` of `q`) satisfies `hit`.
fn any_near<T>(
    cols: &BTreeMap<(i64, i64), Vec<T>>,
    q: Vec2,
    size: f32,
    hit: impl Fn(&T) -> bool,
) -> bool {
    let k = column(q, size);
    (-1..=1).any(|dx| {
        (-1..=1).any(|dy| {
            cols.get(&(k.0 + dx, k.1 + dy))
                .is_some_and(|c| c.iter().any(&hit))
        })
    })
}

/// The connected groups (eight neighbours) of a lattice's occupied columns, each as the union
/// of its columns' entries, in lattice order.
fn components<T: Copy>(cols: &BTreeMap<(i64, i64), Vec<T>>) -> Vec<Vec<T>> {
    let mut seen: BTreeSet<(i64, i64)> = BTreeSet::new();
    let mut out = Vec::new();
    for &start in cols.keys() {
        if !seen.insert(start) {
            continue;
        }
        let (mut stack, mut members) = (vec![start], Vec::new());
        while let Some(k) = stack.pop() {
            members.extend(&cols[&k]);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    let n = (k.0 + dx, k.1 + dy);
                    if cols.contains_key(&n) && seen.insert(n) {
                        stack.push(n);
                    }
                }
            }
        }
        out.push(members);
    }
    out
}

/// The widest extent, along `u` or the axis across it, of the faces among `points`: samples
/// whose lattice columns of `front_m` touch form one face.
fn widest_face(points: &[Vec2], front_m: f32, u: Vec2) -> f32 {
    let mut cols: BTreeMap<(i64, i64), Vec<Vec2>> = BTreeMap::new();
    for &q in points {
        cols.entry(column(q, front_m))
            .or_default()
            .push(Vec2::new(q.dot(u), q.perp_dot(u)));
    }
    components(&cols)
        .iter()
        .map(|f| {
            let (lo, hi) = f.iter().fold(
                (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
                |(lo, hi), q| (lo.min(*q), hi.max(*q)),
            );
            (hi - lo).max_element()
        })
        .fold(0.0, f32::max)
}

/// The upper quartile of the highest sample of each lattice column of `cell_m` among `points`:
/// the walls' top (the median of the upper half — the columns imaged up to the top; a column
/// short of it was hidden or grazed there). NaN for no points.
fn walls_top(points: impl Iterator<Item = Vec3>, cell_m: f32) -> f32 {
    let mut top: BTreeMap<(i64, i64), f32> = BTreeMap::new();
    for p in points {
        let t = top.entry(column(p.truncate(), cell_m)).or_insert(p.z);
        *t = t.max(p.z);
    }
    let mut t: Vec<f32> = top.into_values().collect();
    t.sort_by(f32::total_cmp);
    t.get(3 * t.len().saturating_sub(1) / 4)
        .copied()
        .unwrap_or(f32::NAN)
}

/// The least-squares circle through `q` (Kåsa's algebraic fit), with the rms of the points'
/// distances from it; `None` when the points are collinear or fewer than three.
fn fit_circle(q: &[Vec2]) -> Option<(Vec2, f32, f32)> {
    if q.len() < 3 {
        return None;
    }
    let m = q.iter().fold(glam::DVec2::ZERO, |s, p| s + p.as_dvec2()) / q.len() as f64;
    // Centred coordinates: (x − a)² + (y − b)² = r² is linear in (a, b, r² − a² − b²).
    let (mut suu, mut suv, mut svv, mut suz, mut svz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in q {
        let d = p.as_dvec2() - m;
        let z = d.length_squared();
        (suu, suv, svv) = (suu + d.x * d.x, suv + d.x * d.y, svv + d.y * d.y);
        (suz, svz) = (suz + d.x * z, svz + d.y * z);
    }
    let det = suu * svv - suv * suv;
    if det.abs() <= 1e-12 * (suu * svv).max(f64::MIN_POSITIVE) {
        return None;
    }
    let a = 0.5 * (suz * svv - svz * suv) / det;
    let b = 0.5 * (svz * suu - suz * suv) / det;
    let c = glam::DVec2::new(a, b);
    let r2 = c.length_squared() + (suu + svv) / q.len() as f64;
    let r = r2.sqrt();
    let rms = (q
        .iter()
        .map(|p| ((p.as_dvec2() - m - c).length() - r).powi(2))
        .sum::<f64>()
        / q.len() as f64)
        .sqrt();
    Some(((m + c).as_vec2(), r as f32, rms as f32))
}

/// One building's samples and the mesher's input they index.
struct Building<'a> {
    points: &'a [Vec3],
    normals: &'a [Vec3],
    weights: &'a [f32],
    members: &'a [usize],
    cell_m: f32,
    front_m: f32,
    /// Whether a gable's far half is mirrored ([`hidden_roofs`]'s `gables`).
    gables: bool,
}

impl Building<'_> {
    /// The footprint and the roof samples (position, weight) over it where the cloud has none.
    fn roof(
        &self,
        fronts: &Fronts,
        imaged: &impl Fn(Vec2) -> bool,
    ) -> (Footprint, Vec<(Vec3, Vec3, f32)>) {
        let pts = |i: &usize| self.points[*i];
        let centre = self.members.iter().map(|i| pts(i).truncate()).sum::<Vec2>()
            / self.members.len().max(1) as f32;
        let mut fp = Footprint {
            centre,
            outline: Outline::Unknown(NO_WALLS),
            height_m: f32::NAN,
            samples: 0,
            yard: BTreeSet::new(),
            yard_cell_m: self.cell_m,
        };
        let (outline, height, weight, mirror) = self.outline();
        fp.outline = outline;
        fp.height_m = height;
        let Some((lo, hi)) = fp.outline.bounds() else {
            return (fp, Vec::new());
        };
        // Where the cloud holds something at the roof's height (within a resolution cell under
        // it) within the support distance, the roof was imaged: nothing is added there.
        let (tol, front) = (2.0 * self.front_m, self.front_m);
        let mut near: BTreeMap<(i64, i64), Vec<Vec2>> = BTreeMap::new();
        for p in self.members.iter().map(pts).filter(|p| p.z >= height - tol) {
            near.entry(column(p.truncate(), front))
                .or_default()
                .push(p.truncate());
        }
        // A gable's far half is roofed as the mirror of its imaged roof (module docs).
        let mirrored = mirror.map_or_else(Vec::new, |m| {
            self.mirrored_roof(&m, height - tol, &fp.outline, imaged, weight)
        });
        for (p, _, _) in &mirrored {
            near.entry(column(p.truncate(), front))
                .or_default()
                .push(p.truncate());
        }
        let covered = |q: Vec2| any_near(&near, q, front, |r| r.distance(q) <= front);
        // The roof's lattice: the world's, cell centres inside the outline.
        let ((a0, b0), (a1, b1)) = (column(lo, self.cell_m), column(hi, self.cell_m));
        let mut samples: Vec<(Vec3, Vec3, f32)> = (b0..=b1)
            .flat_map(|b| (a0..=a1).map(move |a| Vec2::new(a as f32, b as f32)))
            .map(|k| (k + 0.5) * self.cell_m)
            .filter(|&q| fp.outline.contains(q) && !covered(q) && imaged(q))
            .map(|q| (q.extend(height), Vec3::Z, weight))
            .collect();
        samples.extend(mirrored);
        // An imaged face looks out over open ground: a roof straight in front of a face below
        // it whose front is open (nothing of the cloud there, [`Fronts`]) is not its building's.
        // On a rectangle only normals astray at its corners do; where two buildings were taken
        // for one, the faces of each toward the other.
        let roofed: BTreeSet<(i64, i64)> = samples
            .iter()
            .map(|(p, _, _)| column(p.truncate(), self.cell_m))
            .collect();
        let reach = (hi - lo).length();
        let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
        // The building's samples per lattice column, for the yards.
        let mut at: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
        for &i in self.members {
            at.entry(column(self.points[i].truncate(), self.cell_m))
                .or_default()
                .push(i);
        }
        let looks_back = |j: usize, ahead: Vec2| {
            let m = self.normals[j];
            m.z.abs() < max_nz && m.truncate().normalize_or_zero().dot(ahead) <= -FRAC_1_SQRT_2
        };
        let (mut open, mut facing) = (0usize, 0usize);
        let mut yard = BTreeSet::new();
        for &i in self.members {
            let (p, n) = (self.points[i], self.normals[i]);
            if n.z.abs() >= max_nz || p.z >= height || !fronts.open(p, n, imaged) {
                continue;
            }
            open += 1;
            let ahead = n.truncate().normalize_or_zero();
            let mut t = front;
            while t <= reach {
                if roofed.contains(&column(p.truncate() + ahead * t, self.cell_m)) {
                    facing += 1;
                    break;
                }
                t += 0.5 * self.cell_m;
            }
            // What the look meets first: a face looking back across open ground (a courtyard's
            // far wall) makes what it crossed a yard.
            let (mut t, mut passed) = (front, Vec::new());
            while t <= reach {
                let k = column(p.truncate() + ahead * t, self.cell_m);
                if let Some(js) = at.get(&k) {
                    if js.iter().any(|&j| looks_back(j, ahead)) {
                        yard.extend(passed.iter().copied());
                    }
                    break;
                }
                passed.push(k);
                t += 0.5 * self.cell_m;
            }
        }
        if facing as f32 > FACING_ROOF_FRACTION * open as f32 {
            fp.outline = Outline::Unknown("faces looking into the roof");
            return (fp, Vec::new());
        }
        samples.retain(|(p, _, _)| !yard.contains(&column(p.truncate(), self.cell_m)));
        fp.yard = yard;
        fp.samples = samples.len();
        (fp, samples)
    }

    /// What the building's walls outline, the walls' top height, their median weight, and the
    /// plane a gable's imaged half is mirrored about, if its far side was placed so.
    fn outline(&self) -> (Outline, f32, f32, Option<Mirror>) {
        let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
        let (front, tol) = (self.front_m, 2.0 * self.front_m);
        let walls: Vec<usize> = self
            .members
            .iter()
            .copied()
            .filter(|&i| self.normals[i].z.abs() < max_nz)
            .collect();
        let unknown = |why| (Outline::Unknown(why), f32::NAN, f32::NAN, None);
        if walls.len() < 3 {
            return unknown(NO_WALLS);
        }
        let xy = |i: usize| self.points[i].truncate();
        let nxy = |i: usize| self.normals[i].truncate().normalize_or_zero();
        // The walls' dominant direction: a rectangle's faces agree on four times their azimuth.
        let (s, c) = walls.iter().fold((0.0f64, 0.0f64), |(s, c), &i| {
            let a = 4.0 * f64::from(nxy(i).to_angle());
            (s + a.sin(), c + a.cos())
        });
        let u = Vec2::from_angle((s.atan2(c) / 4.0) as f32);
        let v = u.perp();
        let uv = |q: Vec2| Vec2::new(q.dot(u), q.dot(v));
        let (mut lo, mut hi) = self.members.iter().fold(
            (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| (lo.min(uv(xy(i))), hi.max(uv(xy(i)))),
        );
        if (hi - lo).min_element() < 2.0 * front {
            return unknown("one face");
        }
        // Sides 0 = −u, 1 = +u, 2 = −v, 3 = +v. A wall sample is on the outline when within a
        // resolution cell of its nearest side and facing out of it within 45°; a side is imaged
        // when its outline samples span `SIDE_IMAGED_FRACTION` of it.
        let outward = [-Vec2::X, Vec2::X, -Vec2::Y, Vec2::Y];
        let classify = |lo: Vec2, hi: Vec2| {
            let mut sides = Sides {
                reach: [
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                ],
                ..Sides::default()
            };
            for &i in &walls {
                let q = uv(xy(i));
                let d = [q.x - lo.x, hi.x - q.x, q.y - lo.y, hi.y - q.y];
                let n = uv(nxy(i));
                // The side it faces best among those within a resolution cell (at a corner,
                // the face it belongs to).
                let near = (0..4).filter(|&s| d[s] <= tol);
                let Some(side) =
                    near.max_by(|&a, &b| n.dot(outward[a]).total_cmp(&n.dot(outward[b])))
                else {
                    sides.interior.push(i);
                    continue;
                };
                let out = outward[side];
                if n.dot(out) >= std::f32::consts::FRAC_1_SQRT_2 {
                    // Position along the side and the normal's turn from the outward direction.
                    let along = if side < 2 { q.y } else { q.x };
                    sides.on[side].push((along, out.perp_dot(n).atan2(out.dot(n))));
                    let across = if side < 2 { q.x } else { q.y };
                    sides.reach[side] = if side % 2 == 0 {
                        sides.reach[side].min(across)
                    } else {
                        sides.reach[side].max(across)
                    };
                    sides.outline.push(i);
                }
            }
            let size = hi - lo;
            for s in 0..4 {
                let len = if s < 2 { size.y } else { size.x };
                sides.extent[s] = sides.on[s]
                    .iter()
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), p| {
                        (a.min(p.0), b.max(p.0))
                    });
                sides.imaged[s] =
                    sides.extent[s].1 - sides.extent[s].0 >= SIDE_IMAGED_FRACTION * len;
            }
            sides
        };
        // The rectangle is its walls': an imaged side stands at its outermost wall sample, one
        // no wall images where the imaged sides across it end — not at the farthest stray
        // sample (a lone point a few metres out would carry the roof with it). Where the
        // building's imaged roof ends farther out, the rectangle the walls give is widened to
        // it once the walls' checks have passed (`roof_reach`).
        let first = classify(lo, hi);
        let roof_reach = self.roof_reach(&first, lo, hi, &uv);
        for (s, across) in [(0, [2, 3]), (1, [2, 3]), (2, [0, 1]), (3, [0, 1])] {
            let at = if first.imaged[s] {
                first.reach[s]
            } else {
                let ends = across
                    .iter()
                    .filter(|&&a| first.imaged[a])
                    .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &k| {
                        (a.min(first.extent[k].0), b.max(first.extent[k].1))
                    });
                if s % 2 == 0 {
                    ends.0
                } else {
                    ends.1
                }
            };
            if at.is_finite() {
                match s {
                    0 => lo.x = at,
                    1 => hi.x = at,
                    2 => lo.y = at,
                    _ => hi.y = at,
                }
            }
        }
        if (hi - lo).min_element() < 2.0 * front {
            return unknown("one face");
        }
        // A gable's far half: an unimaged side across an imaged one moves to the mirror of the
        // imaged side about the ridge the roof's profile peaks at (module docs).
        let mut mirror = None;
        if self.gables {
            for s in 0..4 {
                if first.imaged[s] || !first.imaged[s ^ 1] {
                    continue;
                }
                if let Some((at, ridge)) = self.gable_far_side(s, lo, hi, &uv) {
                    match s {
                        0 => lo.x = at,
                        1 => hi.x = at,
                        2 => lo.y = at,
                        _ => hi.y = at,
                    }
                    // Toward the far side, in the world frame; the ridge along it.
                    let axis = [-u, u, -v, v][s];
                    let sign = if s % 2 == 1 { 1.0 } else { -1.0 };
                    mirror.get_or_insert(Mirror {
                        axis,
                        ridge: sign * ridge,
                    });
                }
            }
        }
        let Sides {
            on: on_side,
            outline,
            interior,
            imaged,
            ..
        } = classify(lo, hi);
        let median_weight = |idx: &[usize]| {
            let mut w: Vec<f32> = idx
                .iter()
                .map(|&i| self.weights.get(i).copied().unwrap_or(1.0))
                .collect();
            w.sort_by(f32::total_cmp);
            w.get(w.len() / 2).copied().unwrap_or(1.0)
        };
        let round = (0..4).any(|s| imaged[s] && turn(&on_side[s]) > ROUND_TURN_RAD);
        if round {
            // A round building: the circle through its walls, which must face out of it.
            let q: Vec<Vec2> = walls.iter().map(|&i| xy(i)).collect();
            let Some((centre, radius_m, rms)) = fit_circle(&q) else {
                return unknown("curved walls on no circle");
            };
            if rms > front || radius_m < tol {
                return unknown("curved walls on no circle");
            }
            let on: Vec<usize> = walls
                .iter()
                .copied()
                .filter(|&i| {
                    let r = xy(i) - centre;
                    (r.length() - radius_m).abs() <= tol
                        && nxy(i).dot(r.normalize_or_zero()) >= std::f32::consts::FRAC_1_SQRT_2
                })
                .collect();
            let height = walls_top(on.iter().map(|&i| self.points[i]), self.cell_m);
            let inner: Vec<Vec2> = walls
                .iter()
                .filter(|&&i| {
                    xy(i).distance(centre) < radius_m - tol && self.points[i].z < height - tol
                })
                .map(|&i| xy(i))
                .collect();
            if widest_face(&inner, front, u) >= 2.0 * tol {
                return unknown("a face inside the circle");
            }
            return (
                Outline::Round { centre, radius_m },
                height,
                median_weight(&on),
                None,
            );
        }
        if imaged.iter().filter(|&&i| i).count() < 2 {
            return unknown("fewer than two sides imaged");
        }
        // Where two imaged sides meet the walls reach the corner within a resolution cell.
        let open_corner = [(0, 2), (1, 2), (1, 3), (0, 3)].iter().any(|&(a, b)| {
            let c = rectangle_corner(lo, hi, a, b);
            imaged[a] && imaged[b] && outline.iter().all(|&i| uv(xy(i)).distance(c) > tol)
        });
        if open_corner {
            return unknown("an open corner between imaged sides");
        }
        let height = walls_top(outline.iter().map(|&i| self.points[i]), self.cell_m);
        // A face inside the rectangle below the roof — a resolution cell inside every side and
        // under the walls' top, so no roof feature — wider than two resolution cells.
        let inner: Vec<Vec2> = interior
            .iter()
            .filter(|&&i| self.points[i].z < height - tol)
            .map(|&i| xy(i))
            .collect();
        if widest_face(&inner, front, u) >= 2.0 * tol {
            return unknown("a face inside the rectangle");
        }
        // A side no wall images stands no nearer than where the imaged roof ends: where the
        // roof reaches past it by more than a lattice cell, the rectangle the walls outline is
        // widened to the roof (the checks above are the walls').
        let cell = self.cell_m;
        for s in (0..4).filter(|&s| !first.imaged[s]) {
            let r = roof_reach[s];
            match s {
                0 if r < lo.x - cell => lo.x = r,
                1 if r > hi.x + cell => hi.x = r,
                2 if r < lo.y - cell => lo.y = r,
                3 if r > hi.y + cell => hi.y = r,
                _ => {}
            }
        }
        let corners = [(0, 2), (1, 2), (1, 3), (0, 3)].map(|(a, b)| {
            let c = rectangle_corner(lo, hi, a, b);
            u * c.x + v * c.y
        });
        (
            Outline::Rectangle(corners),
            height,
            median_weight(&outline),
            mirror,
        )
    }
}

impl Building<'_> {
    /// Per side of the rectangle `lo`–`hi` (frame `uv`, sides as [`Sides`]), where the
    /// building's imaged roof ends across it: the outermost lattice slab parallel to the side
    /// whose roof samples span [`SIDE_IMAGED_FRACTION`] of the side's length, as a side's wall
    /// samples must to image it (a lone sample spans nothing). Roof samples are the members
    /// that are no walls (normal more than [`WALL_MAX_TILT_DEG`] from the horizontal) at the
    /// imaged walls' top or above, less a resolution cell. A roof does not reach past its
    /// walls, so a side no wall images that the roof overreaches by more than a lattice cell
    /// stands there (the rectangle the walls outline is widened to it). On held-out
    /// cyl_103 (quick, from pairs imaged with a range-flank rule that was not kept) a pitched
    /// block whose far gable end no pair saw had that side placed where its imaged long walls
    /// ended, 6 m inside the true face under a roof imaged out to it, and the gaps along that
    /// line were walled (docs/journal/results.md). Infinite (inward) where no slab spans enough or no
    /// imaged side gives the walls' top.
    fn roof_reach(
        &self,
        sides: &Sides,
        lo: Vec2,
        hi: Vec2,
        uv: &impl Fn(Vec2) -> Vec2,
    ) -> [f32; 4] {
        let mut reach = [
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let top = walls_top(sides.outline.iter().map(|&i| self.points[i]), self.cell_m);
        if !top.is_finite() {
            return reach;
        }
        let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
        let floor = top - 2.0 * self.front_m;
        // Per side: lattice slab across it → span of the roof samples along it, and their
        // outermost position across it.
        let mut slabs: [BTreeMap<i64, (f32, f32, f32)>; 4] = Default::default();
        for &i in self.members {
            if self.normals[i].z.abs() < max_nz || self.points[i].z < floor {
                continue;
            }
            let q = uv(self.points[i].truncate());
            for (s, slab) in slabs.iter_mut().enumerate() {
                let (across, along) = if s < 2 { (q.x, q.y) } else { (q.y, q.x) };
                let e = slab
                    .entry((across / self.cell_m).floor() as i64)
                    .or_insert((along, along, across));
                let out = if s % 2 == 0 {
                    e.2.min(across)
                } else {
                    e.2.max(across)
                };
                *e = (e.0.min(along), e.1.max(along), out);
            }
        }
        let size = hi - lo;
        for (s, slab) in slabs.iter().enumerate() {
            let len = if s < 2 { size.y } else { size.x };
            let mut spans = slab
                .values()
                .filter(|(a, b, _)| b - a >= SIDE_IMAGED_FRACTION * len);
            let outer = if s % 2 == 0 {
                spans.next()
            } else {
                spans.next_back()
            };
            if let Some(&(_, _, at)) = outer {
                reach[s] = at;
            }
        }
        reach
    }

    /// Where side `s` of the rectangle `lo`–`hi` (frame `uv`) stands when the building's roof
    /// is a gable whose far half no pair saw (module docs, "A gable's far half"): the mirror of
    /// the opposite side about the ridge, when the roof's height profile across the rectangle
    /// (the highest sample per lattice cell of the distance from the opposite side) rises by a
    /// resolution cell from the opposite side's eave to a peak inside, and falls past the peak
    /// as it rose before it — within half a resolution cell over at least two lattice cells, and
    /// by at least one. `None` otherwise (a flat or mono-pitch roof, a sawtooth: its riser
    /// drops where the mirror of its ramp stands high).
    fn gable_far_side(
        &self,
        s: usize,
        lo: Vec2,
        hi: Vec2,
        uv: &impl Fn(Vec2) -> Vec2,
    ) -> Option<(f32, f32)> {
        let (front, tol, cell) = (self.front_m, 2.0 * self.front_m, self.cell_m);
        // Distance from the opposite side toward `s`, and position along it.
        let (lo_a, hi_a, lo_b, hi_b) = if s < 2 {
            (lo.x, hi.x, lo.y, hi.y)
        } else {
            (lo.y, hi.y, lo.x, hi.x)
        };
        let span = hi_a - lo_a;
        let bins = (span / cell).ceil() as usize;
        if bins < 4 {
            return None;
        }
        let mut h = vec![f32::NEG_INFINITY; bins];
        for &i in self.members {
            let p = self.points[i];
            let q = uv(p.truncate());
            let (a, b) = if s < 2 { (q.x, q.y) } else { (q.y, q.x) };
            if !(lo_b..=hi_b).contains(&b) {
                continue;
            }
            let t = if s % 2 == 1 { a - lo_a } else { hi_a - a };
            if (0.0..span).contains(&t) {
                let k = ((t / cell) as usize).min(bins - 1);
                h[k] = h[k].max(p.z);
            }
        }
        let centre = |k: usize| (k as f32 + 0.5) * cell;
        let top = h.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        // The eave: the median of the profile within a resolution cell of the opposite side.
        let mut eave: Vec<f32> = (0..bins)
            .filter(|&k| centre(k) <= tol && h[k].is_finite())
            .map(|k| h[k])
            .collect();
        eave.sort_by(f32::total_cmp);
        let eave = *eave.get(eave.len() / 2)?;
        if top - eave < tol || !top.is_finite() {
            return None;
        }
        // Past a ridge (and more than the support distance inside the side, where the imaged
        // sides' ends are sparse) the profile mirrors the rise: the pairs of cells the mirror
        // about `ridge` matches, and the largest height difference among them.
        let pairs = |ridge: f32| {
            let (mut n, mut worst, mut sum, mut last) = (0usize, 0.0f32, 0.0f32, top);
            for k in 0..bins {
                let c = centre(k);
                if c <= ridge || c > span - front || !h[k].is_finite() {
                    continue;
                }
                let m = 2.0 * ridge - c;
                if m < 0.0 {
                    break;
                }
                let hm = h[((m / cell) as usize).min(bins - 1)];
                if hm.is_finite() {
                    let d = (h[k] - hm).abs();
                    (n, worst, sum, last) = (n + 1, worst.max(d), sum + d, h[k]);
                }
            }
            (n, worst, sum / n.max(1) as f32, last)
        };
        // The ridge: among the positions (every half lattice cell) where the profile stands
        // within half a resolution cell of its top and nothing past stands a lattice cell
        // higher (a roof rising on to the side is no gable), the axis the profile is most
        // symmetric about (the top itself is a few noisy cells; the whole slope places the
        // axis). Past it the profile falls by a lattice cell at least.
        let at = |r: f32| h[((r / cell) as usize).min(bins - 1)];
        let ridge = (0..2 * bins)
            .map(|j| j as f32 * 0.5 * cell)
            .filter(|&r| at(r) >= top - front)
            .filter(|&r| (0..bins).all(|k| centre(k) <= r || h[k] <= at(r) + cell))
            .filter_map(|r| {
                let (n, worst, mean, last) = pairs(r);
                (n >= 2 && worst <= front && last <= at(r) - cell).then_some((r, mean))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))?
            .0;
        let far = 2.0 * ridge;
        let (at, ridge) = if s % 2 == 1 {
            (lo_a + far, lo_a + ridge)
        } else {
            (hi_a - far, hi_a - ridge)
        };
        (far > span).then_some((at, ridge))
    }

    /// The imaged roof of a gable mirrored about its ridge (`m`) into its far half: every
    /// detected sample that is no wall, at or above `above` (the roof, not what stands below
    /// it) and on the imaged side of the ridge, reflected with its normal, where the reflection
    /// lies more than a resolution cell inside `outline` (the band along its sides is roofed
    /// flat, module docs), in the imaged region, and no detected sample lies within the support
    /// distance of it (the far half's own image, where there is one, is kept).
    fn mirrored_roof(
        &self,
        m: &Mirror,
        above: f32,
        outline: &Outline,
        imaged: &impl Fn(Vec2) -> bool,
        weight: f32,
    ) -> Vec<(Vec3, Vec3, f32)> {
        let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
        let front = self.front_m;
        let mut by_column: BTreeMap<(i64, i64), Vec<Vec3>> = BTreeMap::new();
        for &i in self.members {
            let p = self.points[i];
            by_column
                .entry(column(p.truncate(), front))
                .or_default()
                .push(p);
        }
        let taken = |q: Vec3| any_near(&by_column, q.truncate(), front, |r| r.distance(q) <= front);
        let axis = m.axis.extend(0.0);
        self.members
            .iter()
            .filter(|&&i| self.normals[i].z.abs() >= max_nz && self.points[i].z >= above)
            .filter_map(|&i| {
                let (p, n) = (self.points[i], self.normals[i]);
                let before = m.ridge - p.dot(axis);
                if before <= 0.0 {
                    return None;
                }
                let q = p + 2.0 * before * axis;
                let nq = n - 2.0 * n.dot(axis) * axis;
                (outline.depth_inside(q.truncate()) > 2.0 * front
                    && imaged(q.truncate())
                    && !taken(q))
                .then_some((q, nq, weight))
            })
            .collect()
    }
}

/// The plane a gable's imaged roof is mirrored about: `p · axis = ridge` (xy, metres), `axis`
/// pointing from the imaged half into the far one.
#[derive(Clone, Copy, Debug)]
struct Mirror {
    axis: Vec2,
    ridge: f32,
}

/// The corner of the rectangle `lo`–`hi` where side `a` (0 = −u, 1 = +u) meets side `b`
/// (2 = −v, 3 = +v), in the rectangle's frame.
fn rectangle_corner(lo: Vec2, hi: Vec2, a: usize, b: usize) -> Vec2 {
    Vec2::new(
        if a == 0 { lo.x } else { hi.x },
        if b == 2 { lo.y } else { hi.y },
    )
}

/// The walls of a building sorted by the sides of its bounding rectangle (0 = −u, 1 = +u,
/// 2 = −v, 3 = +v).
#[derive(Default)]
struct Sides {
    /// Per side, its outline samples' (position along the side, normal's turn in radians).
    on: [Vec<(f32, f32)>; 4],
    /// Per side, its outermost outline sample's position across it.
    reach: [f32; 4],
    /// Per side, the span of its outline samples along it.
    extent: [(f32, f32); 4],
    /// Per side, whether its outline samples span [`SIDE_IMAGED_FRACTION`] of it.
    imaged: [bool; 4],
    /// The outline samples (indices).
    outline: Vec<usize>,
    /// The wall samples more than a resolution cell inside every side (indices).
    interior: Vec<usize>,
}

/// How far the normals of one side's samples (position along the side, turn from its outward
/// direction in radians) turn over the side's imaged length: the least-squares slope of turn
/// against position times the length. 0 for fewer than three samples.
fn turn(samples: &[(f32, f32)]) -> f32 {
    if samples.len() < 3 {
        return 0.0;
    }
    let n = samples.len() as f64;
    let (ma, mt) = samples.iter().fold((0.0, 0.0), |(a, t), s| {
        (a + f64::from(s.0) / n, t + f64::from(s.1) / n)
    });
    let (mut saa, mut sat) = (0.0, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in samples {
        let a = f64::from(s.0) - ma;
        (saa, sat) = (saa + a * a, sat + a * (f64::from(s.1) - mt));
        (lo, hi) = (lo.min(f64::from(s.0)), hi.max(f64::from(s.0)));
    }
    if saa <= 0.0 {
        return 0.0;
    }
    ((sat / saa).abs() * (hi - lo)) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    const CELL: f32 = 0.5;
    const FRONT: f32 = 1.3;

    /// A vertical wall from `a` to `b` (xy) facing `n`, sampled every 0.5 m from 0.5 m up to
    /// `top`.
    fn wall(s: &mut Samples, a: Vec2, b: Vec2, n: Vec2, top: f32) {
        wall_from(s, a, b, n, 0.5, top);
    }

    /// The same from `bottom` up.
    fn wall_from(s: &mut Samples, a: Vec2, b: Vec2, n: Vec2, bottom: f32, top: f32) {
        let steps = (a.distance(b) / CELL).round() as usize;
        for i in 0..=steps {
            let q = a.lerp(b, i as f32 / steps.max(1) as f32);
            let mut z = bottom;
            while z <= top + 1e-3 {
                s.0.push(q.extend(z));
                s.1.push(n.extend(0.0));
                z += CELL;
            }
        }
    }

    #[derive(Default)]
    struct Samples(Vec<Vec3>, Vec<Vec3>);

    fn roofs(s: &Samples) -> (WallColumns, Vec<Footprint>) {
        let w = vec![1.0; s.0.len()];
        hidden_roofs(&s.0, &s.1, &w, &opts(true), |_| Some(0.0), |_| true)
    }

    fn opts(gables: bool) -> RoofOptions {
        RoofOptions {
            cell_m: CELL,
            front_m: FRONT,
            gables,
        }
    }

    fn v(x: f32, y: f32) -> Vec2 {
        Vec2::new(x, y)
    }

    /// Two faces of a 12 × 8 m building 8 m high, its south and west walls.
    fn l_of_walls() -> Samples {
        let mut s = Samples::default();
        wall(&mut s, v(0.0, 0.0), v(12.0, 0.0), -Vec2::Y, 8.0);
        wall(&mut s, v(0.0, 0.5), v(0.0, 8.0), -Vec2::X, 8.0);
        s
    }

    #[test]
    fn two_imaged_faces_of_a_building_are_roofed_over_their_rectangle_at_the_walls_top() {
        let (added, prints) = roofs(&l_of_walls());
        assert_eq!(prints.len(), 1);
        let Outline::Rectangle(c) = prints[0].outline else {
            panic!("no rectangle: {:?}", prints[0].outline);
        };
        let (lo, hi) = c
            .iter()
            .fold((v(99.0, 99.0), v(-99.0, -99.0)), |(l, h), q| {
                (l.min(*q), h.max(*q))
            });
        assert!(
            lo.distance(v(0.0, 0.0)) < 0.01 && hi.distance(v(12.0, 8.0)) < 0.01,
            "{lo} {hi}"
        );
        assert_eq!(prints[0].height_m, 8.0);
        // The whole roof but the band along the imaged walls' tops (within the support
        // distance of them): 96 m² less about 20 × 1.3 m².
        let area = added.points.len() as f32 * CELL * CELL;
        assert!((60.0..96.0).contains(&area), "{area} m² of roof");
        for (p, n) in added.points.iter().zip(&added.normals) {
            assert!(p.x > 0.0 && p.x < 12.0 && p.y > 0.0 && p.y < 8.0 && p.z == 8.0);
            assert_eq!(*n, Vec3::Z);
        }
        assert_eq!(prints[0].samples, added.points.len());
    }

    /// A flat roof at 8 m over `x0..x1` × `y0..y1`, sampled every 0.5 m, facing up.
    fn flat_roof(s: &mut Samples, x0: f32, x1: f32, y0: f32, y1: f32) {
        let mut x = x0;
        while x <= x1 + 1e-3 {
            let mut y = y0;
            while y <= y1 + 1e-3 {
                s.0.push(Vec3::new(x, y, 8.0));
                s.1.push(Vec3::Z);
                y += CELL;
            }
            x += CELL;
        }
    }

    fn east_side(s: &Samples) -> f32 {
        let (_, prints) = roofs(s);
        assert_eq!(prints.len(), 1);
        let Outline::Rectangle(c) = prints[0].outline else {
            panic!("no rectangle: {:?}", prints[0].outline);
        };
        c.iter().map(|q| q.x).fold(f32::NEG_INFINITY, f32::max)
    }

    #[test]
    fn a_side_no_wall_images_stands_no_nearer_than_where_the_imaged_roof_ends() {
        // The 12 × 8 m building's west wall imaged whole, its south wall only over its western
        // 7 m; the east face not at all.
        let mut s = Samples::default();
        wall(&mut s, v(0.0, 0.0), v(7.0, 0.0), -Vec2::Y, 8.0);
        wall(&mut s, v(0.0, 0.5), v(0.0, 8.0), -Vec2::X, 8.0);
        // The roof imaged over the western half only: the east side stands where the south
        // wall's image ends.
        let mut half = Samples(s.0.clone(), s.1.clone());
        flat_roof(&mut half, 1.0, 7.0, 1.0, 7.5);
        assert!(
            (east_side(&half) - 7.0).abs() < 0.01,
            "{}",
            east_side(&half)
        );
        // A lone roof sample 4 m farther out spans nothing: the side stays.
        half.0.push(Vec3::new(11.0, 4.0, 8.0));
        half.1.push(Vec3::Z);
        assert!(
            (east_side(&half) - 7.0).abs() < 0.01,
            "{}",
            east_side(&half)
        );
        // The roof imaged out to the east face: the side stands at the roof's end.
        flat_roof(&mut s, 1.0, 12.0, 1.0, 7.5);
        assert!((east_side(&s) - 12.0).abs() < 0.01, "{}", east_side(&s));
    }

    #[test]
    fn a_riser_inside_a_footprint_stands_on_the_roof_and_the_outer_walls_on_the_terrain() {
        use super::super::wall_columns::wall_columns;
        // The south and west faces of the 12 × 8 m building imaged from 5 m up to its 8 m top,
        // and a riser inside it, 6 m from the west wall: a face looking east from 8.5 to 10 m.
        let mut s = Samples::default();
        wall_from(&mut s, v(0.0, 0.0), v(12.0, 0.0), -Vec2::Y, 5.0, 8.0);
        wall_from(&mut s, v(0.0, 0.5), v(0.0, 8.0), -Vec2::X, 5.0, 8.0);
        wall_from(&mut s, v(6.0, 3.0), v(6.0, 5.0), Vec2::X, 8.5, 10.0);
        let (_, prints) = roofs(&s);
        assert!(matches!(prints[0].outline, Outline::Rectangle(_)));
        let w = vec![1.0; s.0.len()];
        let terrain = |_: Vec3| Some(0.0);
        let columns = |floor: &dyn Fn(Vec3) -> Option<f32>| {
            wall_columns(&s.0, &s.1, &w, CELL, FRONT, floor, |_| true)
        };
        let riser_bottom = |c: &WallColumns| {
            c.points
                .iter()
                .filter(|p| (p.x - 6.0).abs() < 0.5 && p.y > 2.5)
                .map(|p| p.z)
                .fold(f32::INFINITY, f32::min)
        };
        let on_roofs = columns(&standing_on(&prints, FRONT, terrain));
        // Its column ends on the roof at 8 m (from a cell under its lowest sample).
        let bottom = riser_bottom(&on_roofs);
        assert!((bottom - 8.0).abs() < 1e-3, "{bottom}");
        // The outer walls still reach the terrain, along their whole length.
        let south: Vec<&Vec3> = on_roofs.points.iter().filter(|p| p.y < 0.5).collect();
        assert!(south.iter().any(|p| p.z < 1.0) && south.iter().any(|p| p.x > 11.0));
        assert!(on_roofs
            .points
            .iter()
            .any(|p| p.x < 0.5 && p.y > 7.0 && p.z < 1.0));
        // Stood on the terrain, the riser runs through the building.
        assert!(riser_bottom(&columns(&terrain)) < 1.0);
    }

    #[test]
    fn a_courtyard_between_faces_looking_at_each_other_is_neither_roofed_nor_stood_on() {
        // A 24 × 20 m block 10 m high, imaged on its four outer faces, around an 8 × 6 m yard
        // whose walls were imaged only in their top 1.5 m (over the wings), facing the yard;
        // its roof imaged over the north wing only.
        let mut s = Samples::default();
        wall(&mut s, v(0.0, 0.0), v(24.0, 0.0), -Vec2::Y, 10.0);
        wall(&mut s, v(24.0, 0.5), v(24.0, 20.0), Vec2::X, 10.0);
        wall(&mut s, v(0.0, 20.0), v(23.5, 20.0), Vec2::Y, 10.0);
        wall(&mut s, v(0.0, 0.5), v(0.0, 19.5), -Vec2::X, 10.0);
        wall_from(&mut s, v(8.0, 7.0), v(16.0, 7.0), Vec2::Y, 8.5, 10.0);
        wall_from(&mut s, v(8.0, 13.0), v(16.0, 13.0), -Vec2::Y, 8.5, 10.0);
        wall_from(&mut s, v(8.0, 7.5), v(8.0, 12.5), Vec2::X, 8.5, 10.0);
        wall_from(&mut s, v(16.0, 7.5), v(16.0, 12.5), -Vec2::X, 8.5, 10.0);
        // The north wing's roof imaged, joining the yard's walls to the block.
        for i in 1..48 {
            for j in 28..40 {
                s.0.push(Vec3::new(0.5 * i as f32, 0.5 * j as f32, 10.0));
                s.1.push(Vec3::Z);
            }
        }
        let (added, prints) = roofs(&s);
        assert!(
            matches!(prints[0].outline, Outline::Rectangle(_)),
            "{:?}",
            prints[0].outline
        );
        let in_yard = |q: Vec2| q.x > 8.5 && q.x < 15.5 && q.y > 7.5 && q.y < 12.5;
        // The wings are roofed, the yard is not.
        assert!(added
            .points
            .iter()
            .any(|p| p.x < 6.0 && (8.0..12.0).contains(&p.y)));
        let roofed_yard = added
            .points
            .iter()
            .filter(|p| in_yard(p.truncate()))
            .count();
        assert_eq!(roofed_yard, 0, "{roofed_yard} roof samples over the yard");
        // A yard wall stands on the terrain; a wall inside a wing on the roof.
        let floor = standing_on(&prints, FRONT, |_| Some(0.0));
        assert_eq!(floor(Vec3::new(12.0, 7.0, 8.5)), Some(0.0));
        assert_eq!(floor(Vec3::new(4.0, 10.0, 11.0)), Some(prints[0].height_m));
    }

    #[test]
    fn a_stray_point_beyond_where_the_walls_end_does_not_carry_the_roof_out() {
        let mut s = l_of_walls();
        // One point 1.5 m north of where the west wall ends, facing east.
        s.0.push(Vec3::new(1.0, 9.5, 3.0));
        s.1.push(Vec3::X);
        let (added, prints) = roofs(&s);
        let Outline::Rectangle(c) = prints[0].outline else {
            panic!("no rectangle: {:?}", prints[0].outline);
        };
        assert!(c.iter().all(|q| q.y <= 8.0 + 1e-3), "{c:?}");
        assert!(added.points.iter().all(|p| p.y < 8.0));
    }

    #[test]
    fn faces_that_look_into_the_roof_tell_two_buildings_and_get_none() {
        let mut s = l_of_walls();
        // Two faces inside the rectangle, east-facing with open ground (the would-be roof) in
        // front, imaged only near the top (within a resolution cell of it, as a coarse pair
        // images a lower building's face over a neighbour).
        for x in [4.0, 8.0] {
            for j in 1..=15 {
                for k in 0..5 {
                    s.0.push(Vec3::new(x, 0.5 * j as f32, 5.5 + 0.5 * k as f32));
                    s.1.push(Vec3::X);
                }
            }
        }
        let (added, prints) = roofs(&s);
        assert!(added.points.is_empty());
        assert_eq!(
            prints[0].outline,
            Outline::Unknown("faces looking into the roof")
        );
    }

    #[test]
    fn one_imaged_face_tells_no_depth_and_gets_no_roof() {
        let mut s = Samples::default();
        wall(&mut s, v(0.0, 0.0), v(12.0, 0.0), -Vec2::Y, 8.0);
        let (added, prints) = roofs(&s);
        assert!(added.points.is_empty());
        assert_eq!(prints[0].outline, Outline::Unknown("one face"));
    }

    #[test]
    fn an_l_shaped_block_whose_inner_faces_were_imaged_is_no_rectangle() {
        let mut s = Samples::default();
        let ring = [
            (v(0.0, 0.0), v(20.0, 0.0), -Vec2::Y),
            (v(20.0, 0.0), v(20.0, 8.0), Vec2::X),
            (v(20.0, 8.0), v(8.0, 8.0), Vec2::Y),
            (v(8.0, 8.0), v(8.0, 20.0), Vec2::X),
            (v(8.0, 20.0), v(0.0, 20.0), Vec2::Y),
            (v(0.0, 20.0), v(0.0, 0.0), -Vec2::X),
        ];
        for (a, b, n) in ring {
            wall(&mut s, a, b, n, 8.0);
        }
        let (added, prints) = roofs(&s);
        assert!(added.points.is_empty());
        assert_eq!(
            prints[0].outline,
            Outline::Unknown("a face inside the rectangle")
        );
    }

    #[test]
    fn a_square_building_is_a_rectangle_and_a_tanks_half_seen_arc_a_disc() {
        let mut s = Samples::default();
        for (a, b, n) in [
            (v(0.0, 0.0), v(14.0, 0.0), -Vec2::Y),
            (v(14.0, 0.0), v(14.0, 14.0), Vec2::X),
            (v(14.0, 14.0), v(0.0, 14.0), Vec2::Y),
            (v(0.0, 14.0), v(0.0, 0.0), -Vec2::X),
        ] {
            wall(&mut s, a, b, n, 9.0);
        }
        assert!(matches!(roofs(&s).1[0].outline, Outline::Rectangle(_)));
        // Half a tank of radius 7 m round (40, 40), the half facing +x.
        let mut t = Samples::default();
        for i in 0..=44 {
            let a = std::f32::consts::PI * (i as f32 / 44.0 - 0.5);
            let n = Vec2::from_angle(a);
            wall(
                &mut t,
                v(40.0, 40.0) + 7.0 * n,
                v(40.0, 40.0) + 7.0 * n,
                n,
                9.0,
            );
        }
        let (added, prints) = roofs(&t);
        let Outline::Round { centre, radius_m } = prints[0].outline else {
            panic!("not round: {:?}", prints[0].outline);
        };
        assert!(centre.distance(v(40.0, 40.0)) < 0.05 && (radius_m - 7.0).abs() < 0.05);
        assert!(!added.points.is_empty());
        assert!(added
            .points
            .iter()
            .all(|p| p.truncate().distance(centre) <= radius_m && p.z == 9.0));
        // The unseen half is roofed too.
        assert!(added.points.iter().any(|p| p.x < 36.0));
    }

    #[test]
    fn a_roof_already_imaged_is_not_added_again_nor_anything_without_the_terrain() {
        let mut s = l_of_walls();
        for i in 0..=24 {
            for j in 0..=16 {
                s.0.push(Vec3::new(i as f32 * 0.5, j as f32 * 0.5, 8.0));
                s.1.push(Vec3::Z);
            }
        }
        let (added, prints) = roofs(&s);
        assert!(matches!(prints[0].outline, Outline::Rectangle(_)));
        assert!(added.points.is_empty());
        let s = l_of_walls();
        let w = vec![1.0; s.0.len()];
        let (added, prints) = hidden_roofs(&s.0, &s.1, &w, &opts(true), |_| None, |_| true);
        assert!(added.points.is_empty() && prints.is_empty());
        let (added, _) = hidden_roofs(&s.0, &s.1, &w, &opts(true), |_| Some(0.0), |_| false);
        assert!(added.points.is_empty());
    }

    /// A 16 m long building whose roof is imaged from its west eave (x = 0, 8 m) up to x = 7.5 m
    /// with the given profile `top(x)`: its west wall, and its south and north ends imaged up
    /// to the profile from x = 0 to 9 m; its east side no pair saw. The footprint's x extent
    /// with and without mirroring gables, and the roof samples added with.
    fn half_seen_roof(top: impl Fn(f32) -> f32, far: &[Vec3]) -> ([(f32, f32); 2], WallColumns) {
        let mut s = Samples::default();
        for &p in far {
            s.0.push(p);
            s.1.push(Vec3::Z);
        }
        wall(&mut s, v(0.0, 0.5), v(0.0, 15.5), -Vec2::X, 8.0);
        for i in 0..=18 {
            let x = 0.5 * i as f32;
            wall(&mut s, v(x, 0.0), v(x, 0.0), -Vec2::Y, top(x));
            wall(&mut s, v(x, 16.0), v(x, 16.0), Vec2::Y, top(x));
            if i > 0 && i <= 15 {
                let slope = (top(x + 0.01) - top(x - 0.01)) / 0.02;
                for j in 1..32 {
                    s.0.push(Vec3::new(x, 0.5 * j as f32, top(x)));
                    s.1.push(Vec3::new(-slope, 0.0, 1.0).normalize());
                }
            }
        }
        let w = vec![1.0; s.0.len()];
        // The imaged region, a test that rewrites its argument in place: what hidden_roofs
        // does must not depend on it (with rustc 1.77–1.95 in release builds such a change of
        // a by-value point reached the caller's own, rust-lang/rust#155241).
        let region = |mut q: Vec2| {
            q *= std::hint::black_box(0.5);
            q.length() < 50.0
        };
        let mut added = WallColumns::default();
        let extent = [true, false].map(|gables| {
            let (roof, prints) = hidden_roofs(&s.0, &s.1, &w, &opts(gables), |_| Some(0.0), region);
            if gables {
                added = roof;
            }
            let Outline::Rectangle(c) = prints[0].outline else {
                panic!("no rectangle: {:?}", prints[0].outline);
            };
            c.iter()
                .fold((99.0f32, -99.0f32), |(l, h), q| (l.min(q.x), h.max(q.x)))
        });
        (extent, added)
    }

    #[test]
    fn a_gable_seen_past_its_ridge_is_as_deep_beyond_it_as_before_it() {
        // A 12 m wide gable, ridge 4 m over the eaves at x = 6 m.
        let gable = |x: f32| 8.0 + 4.0 * (1.0 - (x - 6.0).abs() / 6.0);
        let ([mirrored, plain], added) = half_seen_roof(gable, &[]);
        assert!(mirrored.0.abs() < 0.01, "{mirrored:?}");
        // The ridge is placed to within half a lattice cell: the far side to within one.
        assert!((mirrored.1 - 12.0).abs() <= CELL, "{mirrored:?}");
        // Without the mirror the side stands where its ends were imaged.
        assert!((plain.1 - 9.0).abs() < 0.01, "{plain:?}");
        // Past the imaged roof the far slope is the imaged one's mirror, on the slope within a
        // lattice cell; within a resolution cell of the far side the roof is flat, so the walls
        // under its edge follow the side.
        let (mut slope, mut flat) = (0, 0);
        for (p, n) in added.points.iter().zip(&added.normals) {
            if *n == Vec3::Z {
                flat += 1;
            } else {
                slope += 1;
                assert!(p.x > 7.5 && p.x < mirrored.1 - 2.0 * FRONT, "{p}");
                assert!((p.z - gable(p.x)).abs() <= CELL, "{p}");
                assert!(n.x > 0.1 && n.z > 0.5, "{n}");
            }
        }
        assert!(slope > 0 && flat > 0, "{slope} {flat}");
        assert!(added.points.iter().any(|p| p.x > 11.0));
    }

    #[test]
    fn a_mono_pitch_or_sawtooth_roof_is_not_mirrored() {
        // Rising to the last imaged cell: no ridge inside.
        let ([mono, _], _) = half_seen_roof(|x| 8.0 + 0.4 * x, &[]);
        assert!((mono.1 - 9.0).abs() < 0.01, "{mono:?}");
        // A sawtooth: a 4 m ramp up to x = 6 m, a riser down, the next ramp.
        let ([saw, _], _) = half_seen_roof(|x| 8.0 + 4.0 * (x % 6.0) / 6.0, &[]);
        assert!((saw.1 - 9.0).abs() < 0.01, "{saw:?}");
    }

    #[test]
    fn the_far_halfs_own_image_is_kept_and_not_mirrored_over() {
        // A patch of the far slope imaged: 1 m × 3 m at x = 9…10 m, y = 7…10 m.
        let gable = |x: f32| 8.0 + 4.0 * (1.0 - (x - 6.0).abs() / 6.0);
        let patch: Vec<Vec3> = (0..=2)
            .flat_map(|i| (0..=6).map(move |j| (9.0 + 0.5 * i as f32, 7.0 + 0.5 * j as f32)))
            .map(|(x, y)| Vec3::new(x, y, gable(x)))
            .collect();
        let (_, added) = half_seen_roof(gable, &patch);
        let mirrored: Vec<&Vec3> = added
            .points
            .iter()
            .zip(&added.normals)
            .filter(|(_, n)| **n != Vec3::Z)
            .map(|(p, _)| p)
            .collect();
        assert!(!mirrored.is_empty());
        for p in mirrored {
            let d = patch
                .iter()
                .map(|q| q.distance(*p))
                .fold(f32::INFINITY, f32::min);
            assert!(d > FRONT, "{p} {d}");
        }
    }
}
