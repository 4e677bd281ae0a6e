//! Walls stand on the terrain: the part of a wall that no pair saw, below the part that pairs
//! did see, added to the mesher's input.
//!
//! What the imaging cannot give is what no pair has in line of sight; on the suite's and the
//! random sites' quick runs that is the bulk of the remaining Chamfer error (the observable truth
//! is recovered at 98–100 % recall within 1.5 m, the hidden at 29–64 %), and most of the hidden
//! truth is the lower storeys of walls whose upper part was imaged — a terminal on the ground
//! sees a wall's foot only across open ground, a base station on a mast sees it over the roofs
//! of nothing. A building's wall does not end in the air: below the lowest sample of a wall
//! the wall continues down to whatever stands under it.
//!
//! A wall sample is one whose oriented normal is within [`WALL_MAX_TILT_DEG`] of horizontal and
//! whose front is open (`front_m`: the distance one fused point stands for, the support
//! distance, half the coarsest resolution cell): nothing of the cloud at its own height (± one
//! lattice cell) from one cell to `front_m` ahead of it along its normal — it is on the outer
//! face of the wall's image, which is a resolution cell thick and rough — and nothing within
//! `front_m` of its height from there to two `front_m` ahead, the street in front of a face.
//! (Asked over the whole height window from the first cell on, as an earlier form did,
//! the test passed almost nothing of a rough face: on held-out site_35, 25 of 602 wall samples
//! along the lower rim of a face whose lower storeys another building hides, each blocked by its
//! own image's bulges a cell ahead; docs/journal/results.md.) The front test is what tells a building's
//! face from the vertical smear of a roof: a terminal on the ground resolves height poorly, so a
//! flat roof's image is a slab metres thick, and inside it PCA normals come out horizontal as
//! often as not — a column dropped from there runs through the building (site_16, quick: a
//! quarter of the added samples, the mesh's false surface 2.5 → 24.5 %). A roof's smear has
//! more roof in front of it at its own height; a face has the street. So, per column of the
//! voxel lattice (`cell_m` × `cell_m` in x and y), below the column's lowest wall sample and the
//! rest of its image under it (samples reached down the column without a gap over one and a
//! half cells: at the lower rim of a wall's image the PCA normals turn vertical and the rim reads
//! as roof) and down to the first lower sample of the column or of its neighbours (a lower roof
//! the wall rises from, or the wall's lower part imaged half a cell aside) or, where there is
//! none, to the known terrain, [`wall_columns`] places samples every
//! `cell_m` with the wall sample's normal and weight — where a neighbouring column continues too:
//! a wall is a surface, and one column alone is one normal's say-so whose support band would
//! carry metres of mesh (the rotated factory, quick: two such columns from roof samples with
//! badly estimated normals, √CD 0.87 → 0.99 m in a trial).
//!
//! **Under the roofs' outer edges** ([`roof_edge_walls`]): where a roof was imaged and the wall
//! under its edge was not — a wall facing away from every terminal and base station, seen by no
//! pair, is the bulk of what the random sites miss (on their quick runs 83–96 % of the squared
//! completeness error is truth more than 1.5 m from the cloud, and nearly all of it lies under a
//! detected roof; docs/journal/results.md) — the roof does not hang in the air either: a roof column
//! that looks out over open ground is a building's edge, and a wall stands under it down to the
//! terrain. Open ground is what the cloud holds nothing of up to the roof's height — or, when
//! what the look meets lies more than a resolution cell away, another building's face looking
//! back along it: a face is imaged from the side it looks to, so between two buildings the
//! ground before it is open, where a hole in a roof has roof on its far side and a building's
//! own far wall looks away. Without it a glass block's side 8–10 m across a passage from a
//! block as tall (held-out district_51, quick) had no wall under its imaged roof edge — the
//! other building, met first at its roof, closed every look — and held most of the mesh's error.
//! A face is a wall sample with an open front, as below the walls: at a building's corner the
//! normals fitted across its two faces point along one of them, and oriented toward the pair
//! that imaged them they look back at the building's own roof with their wall's image in front
//! of them (held-out site_48, quick: a 15 m wall 4.5 m inside a glass sawtooth block, opened
//! that way). And the open ground in front of a face stands under the sky: its street, from
//! `front_m` to two `front_m` ahead, holds nothing from `front_m` above the face up to the look's
//! height. A building's roof imaged in parts can hold, under a far part, samples of its own
//! wall whose normals point back inside; a look from where the near part ends crossed the
//! unimaged stretch, met the far part and took them for another building's face (held-out
//! cyl_94, quick: walls 6 m inside a sawtooth block).
//!
//! **An edge is a line, not a pillar.** An edge column's wall stands where the edge continues
//! past it: a neighbouring lattice column is an edge too, or another edge column facing the same
//! way (within 45°) stands within half a support distance. A roof imaged sparsely (a sample or
//! two per square metre, its edge columns two or three lattice cells apart) has few edge columns
//! that touch on the lattice, and which touch depends on how the rim falls on it, so with the
//! lattice alone a wall stood or not as the site was turned. Edges near each other that face
//! different ways are not one edge: over a courtyard, stray roof-height samples are edges facing
//! every way, and joined by distance alone they stood a wall inside the yard. Half a support
//! distance is a quarter of the coarsest resolution cell: a gap that narrow between two samples
//! of a rim is a gap of its image, not of the building.
//!
//! **A notch in a roof's image is not the wall's line.** A roof is detected in part, and a
//! stretch of its rim narrower than a resolution cell can go undetected while the rim on both
//! sides of it was imaged; the edge columns in that notch stood their wall up to a resolution
//! cell inside the building (held-out site_37, quick: the mesh's false surface 3.1 %). An edge
//! column with an edge column farther out on both sides of it along its edge (within `front_m`;
//! farther out by more than a lattice cell and at most a resolution cell, its top within
//! `front_m`) stands its wall on the line between them (`notch_depth`). Dropping such columns
//! instead left the wall missing across the notch, and the mesh bulged out through the gap
//! (site_11: a 3 m stretch of a glass sawtooth block's wall). A recess wider than a resolution
//! cell has no such neighbours in its middle and keeps its wall.
//!
//! **Beyond the imaging region nothing was imaged**, so nothing is known to be open there. A
//! wall's front counts only where the region reaches two `front_m` past the sample (the street
//! its front test reads). A roof's look counts only where the region reaches one `front_m` past
//! the roof column: the roof's image ends within half a resolution cell (`front_m`) of where the
//! roof ends, so a border nearer than that may cut the roof, and one farther leaves the ground
//! the wall stands on inside the region. A region drawn through a building otherwise stood a wall
//! along the cut (the factory with its region ending at x = 5 m, inside the hall, quick: 23 of 28
//! roof-edge columns along the cut, the mesh's false surface 8.9 %; 0.8 % without them). Two
//! `front_m` would drop the walls of buildings whose region ends a few metres past them (the
//! neighbour across the street drawn out of the region).
//!
//! Only the mesh uses them: the fused cloud (what the pairs detected) is unchanged, and where the
//! terrain is not known nothing is added. Units: metres, world frame; z up.

use std::collections::{BTreeMap, HashSet};

use glam::{Vec2, Vec3};

/// Largest angle between a sample's normal and the horizontal at which the sample is taken as a
/// wall, degrees. Roofs are flat or pitched well below 70° (a normal at least 20° from the
/// horizontal); a PCA normal of a wall imaged with voxel-scale scatter stays within a few degrees
/// of it.
pub const WALL_MAX_TILT_DEG: f32 = 20.0;

/// Samples added below the walls ([`wall_columns`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WallColumns {
    /// Positions, metres.
    pub points: Vec<Vec3>,
    /// One unit normal per point: the wall sample's it continues.
    pub normals: Vec<Vec3>,
    /// One weight per point: the wall sample's.
    pub weights: Vec<f32>,
    /// Columns that got samples.
    pub columns: usize,
}

impl WallColumns {
    /// Appends the samples to the mesher's input; returns how many.
    pub fn append_to(
        self,
        points: &mut Vec<Vec3>,
        normals: &mut Vec<Vec3>,
        weights: &mut Vec<f32>,
    ) -> usize {
        let n = self.points.len();
        points.extend(self.points);
        normals.extend(self.normals);
        weights.extend(self.weights);
        n
    }

    /// One column of samples under `at`, from `hi` down to `lo` every `cell_m`, each with the
    /// normal and the weight (1 when none is given) of the sample it continues.
    pub(super) fn push_column(
        &mut self,
        at: Vec3,
        normal: Vec3,
        weight: Option<&f32>,
        (hi, lo): (f32, f32),
        cell_m: f32,
    ) {
        let mut z = hi;
        while z >= lo {
            self.points.push(Vec3::new(at.x, at.y, z));
            self.normals.push(normal);
            self.weights.push(weight.copied().unwrap_or(1.0));
            z -= cell_m;
        }
        self.columns += 1;
    }
}

/// A lattice column and its eight neighbours.
pub(super) fn neighbours((x, y): (i64, i64)) -> impl Iterator<Item = (i64, i64)> {
    (-1..=1).flat_map(move |dx| (-1..=1).map(move |dy| (x + dx, y + dy)))
}

/// The lowest height of a column's image reached down from `from` without a gap of more than
/// one and a half lattice cells between consecutive samples (`heights`: the column's samples,
/// any order): a surface a pair resolves poorly in height is imaged as a slab, and what stands
/// under the surface starts under the slab.
fn image_bottom(heights: &[f32], from: f32, cell_m: f32) -> f32 {
    let mut below: Vec<f32> = heights.iter().copied().filter(|&z| z <= from).collect();
    below.sort_by(|a, b| b.total_cmp(a));
    let mut bottom = from;
    for z in below {
        if bottom - z > 1.5 * cell_m {
            break;
        }
        bottom = z;
    }
    bottom
}

/// The lattice cell of side `cell_m` holding `p`.
fn cell_of(p: Vec3, cell_m: f32) -> (i64, i64, i64) {
    (
        (p.x / cell_m).floor() as i64,
        (p.y / cell_m).floor() as i64,
        (p.z / cell_m).floor() as i64,
    )
}

/// The cloud's occupancy on the lattice, asked whether a wall sample's front is open (module
/// docs): nothing of the cloud at the sample's own height (± a cell) from one cell to `front_m`
/// ahead of it along its normal — the outer face of the wall's image, whose resolution cell is
/// about `front_m` thick and rough — and nothing within `front_m` of its height from there to
/// two `front_m` ahead; and the imaging region reaching that far.
pub(super) struct Fronts {
    occupied: HashSet<(i64, i64, i64)>,
    cell_m: f32,
    front_m: f32,
    steps: i64,
}

impl Fronts {
    /// The occupancy of `points` on a lattice of `cell_m`, for fronts `front_m` deep.
    pub(super) fn new(points: &[Vec3], cell_m: f32, front_m: f32) -> Self {
        Fronts {
            occupied: points
                .iter()
                .filter(|p| p.is_finite())
                .map(|&p| cell_of(p, cell_m))
                .collect(),
            cell_m,
            front_m,
            steps: (front_m / cell_m).ceil() as i64,
        }
    }

    /// Whether the sample at `p` with normal `n` has an open front; `imaged(q)` whether the
    /// imaging region covers the ground position `q`.
    pub(super) fn open(&self, p: Vec3, n: Vec3, imaged: impl Fn(Vec2) -> bool) -> bool {
        let (cell, steps) = (self.cell_m, self.steps);
        let ahead = Vec3::new(n.x, n.y, 0.0).normalize_or_zero();
        imaged((p + ahead * (2 * steps) as f32 * cell).truncate())
            && (1..=2 * steps).all(|j| {
                let q = cell_of(p + ahead * (j as f32 * cell), cell);
                let dz = if j <= steps { 1 } else { steps };
                (-dz..=dz).all(|dz| !self.occupied.contains(&(q.0, q.1, q.2 + dz)))
            })
    }

    /// Whether the street in front of a face at `p` facing `n` (horizontal), from `front_m` to
    /// two `front_m` ahead, holds nothing of the cloud from `front_m` above the face up to `z`:
    /// open ground in front of a face stands under the sky.
    pub(super) fn open_overhead(&self, p: Vec3, n: Vec2, z: f32) -> bool {
        let (cell, steps) = (self.cell_m, self.steps);
        let ahead = n.extend(0.0).normalize_or_zero();
        let (lo, hi) = (
            cell_of(p + Vec3::Z * self.front_m, cell).2 + 1,
            (z / cell).floor() as i64,
        );
        (steps + 1..=2 * steps).all(|j| {
            let q = cell_of(p + ahead * (j as f32 * cell), cell);
            (lo..=hi).all(|kz| !self.occupied.contains(&(q.0, q.1, kz)))
        })
    }
}

/// Whether a lattice cell and a front depth make sense (positive, finite; the front may be 0).
fn usable(cell_m: f32, front_m: f32) -> bool {
    cell_m > 0.0 && cell_m.is_finite() && front_m >= 0.0 && front_m.is_finite()
}

/// The samples that continue each column's lowest open-fronted wall sample down to the first
/// lower sample of the column or of a neighbouring one, or to the terrain, in the columns whose
/// neighbour continues too (module docs). `points`, `normals` (unit, oriented) and `weights`
/// are the mesher's input, one entry each per sample; `front_m` the depth of the open front a
/// wall needs; `floor(p)` is the height the column under `p` ends at (the known terrain, not
/// below the imaging region), `None` where it is not known; `imaged(q)` whether the imaging
/// region covers the ground position `q` — a front that reaches beyond it is not known to be open (module
/// docs). Deterministic: columns in lattice order, samples top down.
pub fn wall_columns(
    points: &[Vec3],
    normals: &[Vec3],
    weights: &[f32],
    cell_m: f32,
    front_m: f32,
    floor: impl Fn(Vec3) -> Option<f32>,
    imaged: impl Fn(Vec2) -> bool,
) -> WallColumns {
    let mut out = WallColumns::default();
    if !usable(cell_m, front_m) {
        return out;
    }
    let max_nz = WALL_MAX_TILT_DEG.to_radians().sin();
    let lattice = |p: Vec3| cell_of(p, cell_m);
    let fronts = Fronts::new(points, cell_m, front_m);
    let open_front = |p: Vec3, n: Vec3| fronts.open(p, n, &imaged);
    // Per lattice column: the lowest wall sample (index) and every sample's height.
    #[derive(Default)]
    struct Column {
        wall: Option<usize>,
        heights: Vec<f32>,
    }
    let mut cols: BTreeMap<(i64, i64), Column> = BTreeMap::new();
    for (i, (p, n)) in points.iter().zip(normals).enumerate() {
        if !p.is_finite() {
            continue;
        }
        let (x, y, _) = lattice(*p);
        let c = cols.entry((x, y)).or_default();
        c.heights.push(p.z);
        if n.z.abs() < max_nz && c.wall.is_none_or(|w| p.z < points[w].z) && open_front(*p, *n) {
            c.wall = Some(i);
        }
    }
    // Each wall's span: from a cell under its lowest sample down to a cell above the first
    // sample more than a cell under it in its own or a neighbouring lattice column (the wall's
    // own image is a resolution cell thick: a lower part imaged beside it ends the column), or
    // to the terrain.
    let spans: BTreeMap<(i64, i64), (usize, f32, f32)> = cols
        .iter()
        .filter_map(|(&key, c)| {
            let w = c.wall?;
            let top = points[w];
            let ground = floor(top)?;
            let bottom = image_bottom(&c.heights, top.z, cell_m);
            let under = neighbours(key)
                .filter_map(|k| cols.get(&k))
                .flat_map(|c| c.heights.iter().copied())
                .filter(|&z| z < bottom - cell_m)
                .fold(f32::NEG_INFINITY, f32::max);
            let (hi, lo) = (bottom - cell_m, ground.max(under + cell_m));
            (hi >= lo).then_some((key, (w, hi, lo)))
        })
        .collect();
    // A wall is a surface, not a pillar: a span counts where a neighbouring lattice column has
    // one too (a lone column is one sample's normal, and its support band would carry metres of
    // surface).
    for (&key, &(w, hi, lo)) in &spans {
        if neighbours(key).any(|k| k != key && spans.contains_key(&k)) {
            out.push_column(points[w], normals[w], weights.get(w), (hi, lo), cell_m);
        }
    }
    out
}

/// Azimuths at which [`roof_edge_walls`] looks out from a roof column (every 11.25°).
pub const EDGE_AZIMUTHS: usize = 32;

/// A wall sample looks back along a roof edge's ray when its normal is within 45° of the
/// reverse of the ray (the cosine).
pub const FACE_BACK_MIN_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Two roof-edge columns face the same way when their facings are within 45° (the cosine): a
/// straight edge's open sector is a quarter of the horizon, and its middle, the facing, moves by
/// up to half of that where the edge runs askew to the lattice.
pub const SAME_EDGE_MIN_COS: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Smallest open sector of the horizon that makes a roof column an edge, degrees. Seen from one
/// of its columns through the lattice of columns, a straight edge opens a quarter of the horizon
/// (the rays within 45° of its line cross its neighbouring columns, which hold roof), less where
/// it runs askew to the lattice; half of that is asked. A gap between imaged parts of a roof
/// (the holes of a roof detected in part) opens only the narrow angle its far side leaves.
pub const EDGE_MIN_OPEN_DEG: f32 = 45.0;

/// The samples of the walls under the outer edges of the imaged roofs (module docs). A column
/// whose highest sample faces up (a roof: its normal more than [`WALL_MAX_TILT_DEG`] from the
/// horizontal) is an edge when, over a contiguous sector of at least [`EDGE_MIN_OPEN_DEG`] of
/// azimuth (looked at in [`EDGE_AZIMUTHS`] directions), the cloud holds nothing up to `front_m`
/// above the roof's height as far as it reaches: beyond an edge is the open ground the wall
/// stands on. Under it, from a cell below the roof down to the first lower sample of the
/// column or of its neighbours or to `floor`, samples every `cell_m` facing the middle of the
/// open sector, with the roof sample's weight — where the edge continues: a neighbouring column
/// is an edge too, or an edge column facing within 45° of the same way stands within half a
/// support distance (module docs).
/// A hole in a roof (a part no pair detected) has roof on its far side and is no edge; nor is a
/// roof inside a building whose walls were imaged, nor one that faces another building — unless
/// what a look meets first lies more than a resolution cell (two `front_m`) away and within a
/// resolution cell past it, in its column or the next, stands a wall sample more than a
/// resolution cell under the roof's height whose normal is within 45° of looking back
/// ([`FACE_BACK_MIN_COS`]), whose front is open as a wall sample's is ([`wall_columns`]) and
/// whose street holds nothing from `front_m` above it up to the look's height: another
/// building's face across open ground (module docs).
/// An edge column in a notch of its rim's image stands its wall on the rim's line
/// (`notch_depth`).
/// Arguments as [`wall_columns`]. Deterministic: columns in lattice order, samples top down.
pub fn roof_edge_walls(
    points: &[Vec3],
    normals: &[Vec3],
    weights: &[f32],
    cell_m: f32,
    front_m: f32,
    floor: impl Fn(Vec3) -> Option<f32>,
    imaged: impl Fn(Vec2) -> bool,
) -> WallColumns {
    let mut out = WallColumns::default();
    if !usable(cell_m, front_m) {
        return out;
    }
    let min_nz = WALL_MAX_TILT_DEG.to_radians().sin();
    let key = |p: Vec3| ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64);
    // Per lattice column: its samples' heights and its highest sample.
    let mut cols: BTreeMap<(i64, i64), (Vec<f32>, usize)> = BTreeMap::new();
    for (i, p) in points.iter().enumerate() {
        if !p.is_finite() {
            continue;
        }
        let c = cols.entry(key(*p)).or_insert((Vec::new(), i));
        c.0.push(p.z);
        if p.z > points[c.1].z {
            c.1 = i;
        }
    }
    let (Some((&first, _)), Some((&last, _))) = (cols.first_key_value(), cols.last_key_value())
    else {
        return out;
    };
    // The lowest sample of every column on a dense grid over the cloud's footprint.
    let (x0, x1) = (first.0, last.0);
    let (y0, y1) = cols
        .keys()
        .fold((i64::MAX, i64::MIN), |(a, b), k| (a.min(k.1), b.max(k.1)));
    let (nx, ny) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut lowest = vec![f32::INFINITY; nx * ny];
    for (&(x, y), (h, _)) in &cols {
        let i = (y - y0) as usize * nx + (x - x0) as usize;
        lowest[i] = h.iter().copied().fold(f32::INFINITY, f32::min);
    }
    // Per column, its faces: the wall samples with an open front (position, horizontal normal).
    // A sample with its own wall's image in front of it is no face looking anywhere: at a
    // building's corner the normals fitted across its two faces point along one of them, and
    // oriented toward the pair that imaged them they "look back" at a roof from under it.
    let fronts = Fronts::new(points, cell_m, front_m);
    let mut faces: BTreeMap<(i64, i64), Vec<(Vec3, Vec2)>> = BTreeMap::new();
    for (p, n) in points.iter().zip(normals) {
        if p.is_finite() && n.z.abs() < min_nz && fronts.open(*p, *n, &imaged) {
            faces
                .entry(key(*p))
                .or_default()
                .push((*p, n.truncate().normalize_or_zero()));
        }
    }
    let facing_back = FACE_BACK_MIN_COS;
    // Whether, looking from `p` along `u`, the cloud stays above `z` as far as it reaches, or
    // what first holds something at or under `z` is, more than a resolution cell away, another
    // face looking back across the open ground between under the roof's height.
    let open = |p: Vec3, u: Vec3, z: f32| {
        if !imaged((p + u * front_m).truncate()) {
            return false;
        }
        let own = key(p);
        let mut t = cell_m;
        loop {
            let k = key(p + u * t);
            if !((x0..=x1).contains(&k.0) && (y0..=y1).contains(&k.1)) {
                return true;
            }
            let i = (k.1 - y0) as usize * nx + (k.0 - x0) as usize;
            if k != own && lowest[i] <= z {
                if t <= 2.0 * front_m {
                    return false;
                }
                // The face looking back: in the columns next to the ray from what it met on
                // for a resolution cell.
                let looks_back = |c: &(i64, i64)| {
                    faces.get(c).is_some_and(|f| {
                        f.iter().any(|&(at, n)| {
                            at.z < z - 2.0 * front_m
                                && n.dot(u.truncate()) <= -facing_back
                                && fronts.open_overhead(at, n, z)
                        })
                    })
                };
                let mut s = 0.0;
                while s <= 2.0 * front_m {
                    if neighbours(key(p + u * (t + s))).any(|c| looks_back(&c)) {
                        return true;
                    }
                    s += 0.5 * cell_m;
                }
                return false;
            }
            t += 0.5 * cell_m;
        }
    };
    let azimuth = |j: usize| {
        let a = std::f32::consts::TAU * j as f32 / EDGE_AZIMUTHS as f32;
        Vec3::new(a.cos(), a.sin(), 0.0)
    };
    let need = (EDGE_MIN_OPEN_DEG / 360.0 * EDGE_AZIMUTHS as f32).ceil() as usize;
    let spans: BTreeMap<(i64, i64), (usize, Vec3, f32, f32)> = cols
        .iter()
        .filter_map(|(&k, (_, top))| {
            let (top, n) = (*top, normals.get(*top)?);
            let roof = points[top];
            if n.z < min_nz {
                return None;
            }
            let clear: Vec<bool> = (0..EDGE_AZIMUTHS)
                .map(|j| open(roof, azimuth(j), roof.z + front_m))
                .collect();
            // The longest contiguous run of open azimuths, around the circle.
            let (mut best, mut best_end, mut run) = (0, 0, 0);
            for j in 0..2 * EDGE_AZIMUTHS {
                run = if clear[j % EDGE_AZIMUTHS] { run + 1 } else { 0 };
                if run > best {
                    (best, best_end) = (run.min(EDGE_AZIMUTHS), j);
                }
            }
            if best < need {
                return None;
            }
            let facing = (0..best)
                .map(|i| azimuth((best_end + EDGE_AZIMUTHS - i) % EDGE_AZIMUTHS))
                .sum::<Vec3>()
                .normalize_or_zero();
            if facing == Vec3::ZERO {
                return None;
            }
            let ground = floor(roof)?;
            // The roof's image reaches down its column without a gap of more than a cell (a
            // roof seen by a pair that resolves height poorly is a slab; a wall imaged under the
            // edge continues it to the ground): the wall starts under that.
            let bottom = image_bottom(&cols[&k].0, roof.z, cell_m);
            let under = neighbours(k)
                .filter_map(|c| cols.get(&c))
                .flat_map(|(h, _)| h.iter().copied())
                .filter(|&z| z < bottom - cell_m)
                .fold(f32::NEG_INFINITY, f32::max);
            let (hi, lo) = (bottom - cell_m, ground.max(under + cell_m));
            (hi >= lo).then_some((k, (top, facing, hi, lo)))
        })
        .collect();
    // A column carries its wall where its edge continues: a neighbouring lattice column is an
    // edge too, or another edge facing the same way (within 45°) stands within half a support
    // distance (module docs); a carrying column in a notch of the rim's image stands its wall on
    // the rim's line.
    let reach = (0.5 * front_m / cell_m).ceil() as i64;
    let continues = |k: (i64, i64), top: usize, n: Vec3| {
        let (p, n) = (points[top], n.truncate());
        let same_edge = |c: (i64, i64)| {
            spans.get(&c).is_some_and(|&(other, m, ..)| {
                (points[other] - p).truncate().length() <= 0.5 * front_m
                    && m.truncate().dot(n) >= SAME_EDGE_MIN_COS
            })
        };
        neighbours(k).any(|c| c != k && spans.contains_key(&c))
            || (-reach..=reach)
                .flat_map(|dx| (-reach..=reach).map(move |dy| (k.0 + dx, k.1 + dy)))
                .any(|c| c != k && same_edge(c))
    };
    let carrying: BTreeMap<(i64, i64), (usize, Vec3, f32, f32)> = spans
        .iter()
        .filter(|(&k, &(top, n, ..))| continues(k, top, n))
        .map(|(k, v)| (*k, *v))
        .collect();
    for (&k, &(top, n, hi, lo)) in &carrying {
        let out_m = notch_depth(&carrying, points, k, top, n, cell_m, front_m).unwrap_or(0.0);
        out.push_column(
            points[top] + n * out_m,
            n,
            weights.get(top),
            (hi, lo),
            cell_m,
        );
    }
    out
}

/// How far a roof-edge column stands inside the line of its rim, metres, when it stands in a
/// notch of the rim's image: on both sides of it along its edge (within `front_m`) a carrying
/// edge column stands farther out along its facing `n` by more than a lattice cell and at most a
/// resolution cell (two `front_m`), its top within `front_m` of this one's. The depth is the
/// nearest such column's on each side, interpolated by their distances along the edge. `None`
/// where the column is on its rim's line.
fn notch_depth(
    carrying: &BTreeMap<(i64, i64), (usize, Vec3, f32, f32)>,
    points: &[Vec3],
    k: (i64, i64),
    top: usize,
    n: Vec3,
    cell_m: f32,
    front_m: f32,
) -> Option<f32> {
    let p = points[top];
    let (n, along) = (n.truncate(), Vec2::new(-n.y, n.x));
    let reach = (2.0 * front_m / cell_m).ceil() as i64 + 1;
    // Per side of the column along its edge: the nearest such column (distance along, depth).
    let mut nearest = [(f32::INFINITY, 0.0); 2];
    for dx in -reach..=reach {
        for dy in -reach..=reach {
            let c = (k.0 + dx, k.1 + dy);
            let Some(&(other, ..)) = carrying.get(&c).filter(|_| c != k) else {
                continue;
            };
            let q = points[other];
            let d = (q - p).truncate();
            let (a, depth) = (d.dot(along), d.dot(n));
            let beside = a != 0.0 && a.abs() <= front_m;
            if beside && (q.z - p.z).abs() <= front_m && depth > cell_m && depth <= 2.0 * front_m {
                let side = &mut nearest[usize::from(a < 0.0)];
                if a.abs() < side.0 {
                    *side = (a.abs(), depth);
                }
            }
        }
    }
    let [(a1, d1), (a2, d2)] = nearest;
    (a1.is_finite() && a2.is_finite()).then(|| (d1 * a2 + d2 * a1) / (a1 + a2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wall in the plane y = 0 facing −y, sampled from `z0` to `z1` every 0.5 m along x 0–2 m.
    fn wall(z0: f32, z1: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
        let mut p = Vec::new();
        let mut z = z0;
        while z <= z1 + 1e-4 {
            for k in 0..4 {
                p.push(Vec3::new(0.25 + 0.5 * k as f32, -0.1, z));
            }
            z += 0.5;
        }
        let n = vec![Vec3::NEG_Y; p.len()];
        let w = vec![0.5; p.len()];
        (p, n, w)
    }

    /// The lowest and the highest added sample's height.
    fn z_range(c: &WallColumns) -> (f32, f32) {
        c.points
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.z), hi.max(p.z))
            })
    }

    /// Appends a row of samples at `y`, height `z`, over the wall's four lattice columns.
    fn add_row(
        (p, n, w): &mut (Vec<Vec3>, Vec<Vec3>, Vec<f32>),
        y: f32,
        z: f32,
        normal: Vec3,
        weight: f32,
    ) {
        for k in 0..4 {
            p.push(Vec3::new(0.25 + 0.5 * k as f32, y, z));
            n.push(normal);
            w.push(weight);
        }
    }

    #[test]
    fn a_wall_seen_only_above_continues_to_the_terrain() {
        let (p, n, w) = wall(6.0, 10.0);
        let c = wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |_| true);
        assert_eq!(c.columns, 4);
        // Each column from 5.5 m down to the terrain at 0.5 m: 11 samples.
        assert_eq!(c.points.len(), 4 * 11);
        let (zmin, zmax) = z_range(&c);
        assert!(
            (zmin - 0.5).abs() < 1e-4 && (zmax - 5.5).abs() < 1e-4,
            "{zmin} {zmax}"
        );
        assert!(c.normals.iter().all(|&m| m == Vec3::NEG_Y));
        assert!(c.weights.iter().all(|&x| x == 0.5));
    }

    #[test]
    fn a_wall_whose_images_lower_rim_reads_as_a_roof_still_continues_to_the_terrain() {
        // A wall imaged as a slab: at its lower rim a neighbourhood is half a slab, and the PCA
        // normal turns vertical (two rows at 5.0 and 5.5 m facing down). The wall continues
        // under the rim, not under its lowest wall-facing sample.
        let mut s = wall(6.0, 10.0);
        for z in [5.0, 5.5] {
            add_row(&mut s, -0.1, z, Vec3::NEG_Z, 0.5);
        }
        let c = wall_columns(&s.0, &s.1, &s.2, 0.5, 2.0, |_| Some(0.5), |_| true);
        assert_eq!(c.columns, 4);
        // Each column from 4.5 m down to the terrain at 0.5 m: 9 samples.
        assert_eq!(c.points.len(), 4 * 9);
        let (_, zmax) = z_range(&c);
        assert!((zmax - 4.5).abs() < 1e-4, "{zmax}");
    }

    #[test]
    fn a_wall_with_scatter_just_in_front_of_its_image_still_continues_from_its_outer_face() {
        // Stray samples half a metre in front of the face (normals up: not walls) at 6.25 and
        // 9.25 m: within a resolution cell ahead they only close the front at their own height,
        // the face between them is still the outer face of the wall's image.
        let mut s = wall(6.0, 10.0);
        for z in [6.25, 9.25] {
            add_row(&mut s, -0.6, z, Vec3::Z, 0.1);
        }
        let c = wall_columns(&s.0, &s.1, &s.2, 0.5, 2.0, |_| Some(0.5), |_| true);
        assert_eq!(c.columns, 4);
        // Each column from under the image's bottom (6.0 m) at 5.5 m down to 0.5 m.
        assert_eq!(c.points.len(), 4 * 11);
        // The same strays two metres ahead, where the street should be open, close the front.
        let mut s = wall(6.0, 10.0);
        for z in [6.25, 7.75, 9.25] {
            add_row(&mut s, -3.1, z, Vec3::Z, 0.1);
        }
        let c = wall_columns(&s.0, &s.1, &s.2, 0.5, 2.0, |_| Some(0.5), |_| true);
        assert!(c.points.is_empty(), "{}", c.points.len());
    }

    #[test]
    fn a_wall_rising_from_a_lower_roof_stops_at_the_roof() {
        // A tower's wall from 12 m up, the hall's roof (normal up) at 8 m in the same columns.
        let mut s = wall(12.0, 20.0);
        add_row(&mut s, -0.2, 8.0, Vec3::Z, 1.0);
        let c = wall_columns(&s.0, &s.1, &s.2, 0.5, 2.0, |_| Some(0.5), |_| true);
        let (zmin, _) = z_range(&c);
        assert!((zmin - 8.5).abs() < 1e-4, "{zmin}");
        assert_eq!(c.points.len(), 4 * 7);
    }

    #[test]
    fn a_lone_pillar_is_not_a_wall_and_a_lower_part_imaged_beside_ends_the_wall() {
        // One lattice column of wall samples: one normal's say-so, nothing added.
        let (p, n, w) = wall(6.0, 10.0);
        let one: Vec<usize> = (0..p.len()).filter(|i| i % 4 == 0).collect();
        let pick = |v: &[Vec3]| one.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let c = wall_columns(
            &pick(&p),
            &pick(&n),
            &vec![0.5; one.len()],
            0.5,
            2.0,
            |_| Some(0.5),
            |_| true,
        );
        assert!(c.points.is_empty());
        // The wall's lower part imaged half a cell behind its upper part (the image is a
        // resolution cell thick): the columns stop above it.
        let (mut p, mut n, mut w) = (p, n, w);
        let (lp, ln, lw) = wall(0.5, 3.0);
        p.extend(lp.iter().map(|q| *q + Vec3::new(0.0, 0.5, 0.0)));
        n.extend(ln);
        w.extend(lw);
        let c = wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |_| true);
        let (zmin, _) = z_range(&c);
        assert!((zmin - 3.5).abs() < 1e-4, "{zmin}");
    }

    #[test]
    fn a_roofs_vertical_smear_is_not_a_wall() {
        // A flat roof at 13.5 m imaged as a slab 12–15 m thick, 10 m × 10 m, every sample with a
        // horizontal normal (the worst case of PCA inside a slab): no face has an open front but
        // those on the slab's rim, whose columns then stand at the roof's edge.
        let (mut p, mut n) = (Vec::new(), Vec::new());
        for i in 0..20 {
            for j in 0..20 {
                for k in 0..7 {
                    p.push(Vec3::new(
                        0.25 + 0.5 * i as f32,
                        0.25 + 0.5 * j as f32,
                        12.0 + 0.5 * k as f32,
                    ));
                    n.push(Vec3::NEG_Y);
                }
            }
        }
        let w = vec![1.0; p.len()];
        let c = wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |_| true);
        assert!(!c.points.is_empty());
        // Facing −y, only the row at the slab's −y rim has nothing ahead of it.
        assert!(
            c.points.iter().all(|q| q.y < 0.5),
            "{:?}",
            c.points.iter().map(|q| q.y).fold(0.0f32, f32::max)
        );
        assert_eq!(c.columns, 20);
    }

    #[test]
    fn roofs_and_walls_seen_to_the_ground_add_nothing_nor_does_an_unknown_terrain() {
        // A wall imaged down to the terrain.
        let (p, n, w) = wall(0.5, 10.0);
        assert!(wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |_| true)
            .points
            .is_empty());
        // A flat roof: no wall sample.
        let roof: Vec<Vec3> = (0..16)
            .map(|k| Vec3::new((k % 4) as f32, (k / 4) as f32, 10.0))
            .collect();
        let up = vec![Vec3::Z; roof.len()];
        assert!(
            wall_columns(&roof, &up, &[1.0; 16], 0.5, 2.0, |_| Some(0.5), |_| true)
                .points
                .is_empty()
        );
        // A pitched roof at 45°: not a wall either.
        let tilted = vec![Vec3::new(0.0, -1.0, 1.0).normalize(); roof.len()];
        assert!(wall_columns(
            &roof,
            &tilted,
            &[1.0; 16],
            0.5,
            2.0,
            |_| Some(0.5),
            |_| true
        )
        .points
        .is_empty());
        // A wall seen above, but no terrain known under it.
        let (p, n, w) = wall(6.0, 10.0);
        assert!(wall_columns(&p, &n, &w, 0.5, 2.0, |_| None, |_| true)
            .points
            .is_empty());
        // A nonsensical cell.
        assert!(
            wall_columns(&p, &n, &w, f32::NAN, 2.0, |_| Some(0.5), |_| true)
                .points
                .is_empty()
        );
    }

    /// A flat roof at `z`, sampled every 0.5 m over `[x0, x1] × [y0, y1]` (normals up), less the
    /// samples `hole` says to leave out.
    fn roof(
        (x0, x1): (f32, f32),
        (y0, y1): (f32, f32),
        z: f32,
        hole: impl Fn(Vec3) -> bool,
    ) -> Vec<Vec3> {
        let mut p = Vec::new();
        let mut x = x0;
        while x <= x1 + 1e-4 {
            let mut y = y0;
            while y <= y1 + 1e-4 {
                let q = Vec3::new(x, y, z);
                if !hole(q) {
                    p.push(q);
                }
                y += 0.5;
            }
            x += 0.5;
        }
        p
    }

    /// Appends a face in the plane x = `x` over y 0–10.5 m, `rows` rows every 0.5 m from 0.5 m
    /// up, with `normal`.
    fn face(p: &mut Vec<Vec3>, n: &mut Vec<Vec3>, x: f32, rows: usize, normal: Vec3) {
        for k in 0..21 {
            for j in 0..rows {
                p.push(Vec3::new(x, 0.25 + 0.5 * k as f32, 0.5 + 0.5 * j as f32));
                n.push(normal);
            }
        }
    }

    fn edges(p: &[Vec3], floor: Option<f32>) -> WallColumns {
        let n = vec![Vec3::Z; p.len()];
        roof_edge_walls(p, &n, &vec![0.7; p.len()], 0.5, 2.0, |_| floor, |_| true)
    }

    #[test]
    fn a_roof_seen_without_its_walls_stands_on_walls_at_its_outer_edges() {
        let p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        let c = edges(&p, Some(0.5));
        assert!(c.columns >= 30, "{} columns", c.columns);
        let centre = Vec3::new(5.25, 5.25, 0.0);
        for (q, n) in c.points.iter().zip(&c.normals) {
            // On the rim, facing out, level, from under the roof to the terrain.
            let r = *q - centre;
            assert!(r.x.abs().max(r.y.abs()) > 4.4, "{q} is not on the rim");
            assert!(n.z == 0.0 && n.dot(r.with_z(0.0)) > 0.0, "{q} faces {n}");
            assert!(q.z >= 0.5 - 1e-4 && q.z <= 9.5 + 1e-4, "{q}");
        }
        assert!(c.weights.iter().all(|&w| w == 0.7));
        let (zmin, _) = z_range(&c);
        assert!((zmin - 0.5).abs() < 1e-4, "{zmin}");
    }

    #[test]
    fn a_sparsely_imaged_roof_stands_on_its_walls_and_two_lone_samples_facing_apart_do_not() {
        // Roof samples every metre, two lattice cells apart: no edge column has an edge column
        // among its lattice neighbours, but each has one along its rim within half a support
        // distance (1 m), facing the same way.
        let p: Vec<Vec3> = (0..=10)
            .flat_map(|i| (0..=10).map(move |j| Vec3::new(0.25 + i as f32, 0.25 + j as f32, 10.0)))
            .collect();
        let c = edges(&p, Some(0.5));
        let centre = Vec3::new(5.25, 5.25, 0.0);
        let on_rim = |q: &Vec3| {
            let r = *q - centre;
            r.x.abs().max(r.y.abs()) > 4.4
        };
        for side in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y] {
            let under = c.normals.iter().filter(|n| n.dot(side) > 0.9).count();
            assert!(under >= 7 * 19, "{under} samples facing {side}");
        }
        assert!(c.points.iter().all(on_rim), "a wall stood inside");
        // Two lone roof samples a metre apart: each is an edge facing away from the other, and
        // a wall is a surface, not two pillars back to back.
        let lone = [Vec3::new(0.25, 0.25, 10.0), Vec3::new(1.25, 0.25, 10.0)];
        assert_eq!(edges(&lone, Some(0.5)).columns, 0);
    }

    #[test]
    fn a_hole_in_a_roof_is_no_edge() {
        // A roof detected in part: a 4 m × 4 m hole in its middle has roof all round it.
        let hole = |q: Vec3| (3.0..7.5).contains(&q.x) && (3.0..7.5).contains(&q.y);
        let c = edges(&roof((0.25, 10.25), (0.25, 10.25), 10.0, hole), Some(0.5));
        assert!(c.columns > 0);
        assert!(
            c.points.iter().all(|q| !hole(*q)),
            "a wall stood in the hole"
        );
        // Nor does a roof whose walls were imaged down to the terrain add anything: under its
        // rim the wall's samples are already there.
        let mut p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        let mut n = vec![Vec3::Z; p.len()];
        let mut z = 0.5;
        while z < 10.0 {
            for k in 0..21 {
                let t = 0.25 + 0.5 * k as f32;
                for (q, m) in [
                    (Vec3::new(t, 0.25, z), Vec3::NEG_Y),
                    (Vec3::new(t, 10.25, z), Vec3::Y),
                    (Vec3::new(0.25, t, z), Vec3::NEG_X),
                    (Vec3::new(10.25, t, z), Vec3::X),
                ] {
                    p.push(q);
                    n.push(m);
                }
            }
            z += 0.5;
        }
        let c = roof_edge_walls(
            &p,
            &n,
            &vec![1.0; p.len()],
            0.5,
            2.0,
            |_| Some(0.5),
            |_| true,
        );
        assert!(
            c.points.is_empty(),
            "{} samples: {:?}",
            c.points.len(),
            &c.points[..c.points.len().min(6)]
        );
    }

    #[test]
    fn a_roof_facing_another_building_has_no_edge_on_that_side() {
        // Two roofs, 10 m and 12 m high, across a 4 m street along x = 10.5 … 14.5.
        let mut p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        p.extend(roof((14.75, 24.75), (0.25, 10.25), 12.0, |_| false));
        let c = edges(&p, Some(0.5));
        assert!(c.columns > 0);
        // The walls stand on the far sides (x = 0, x = 25, and y = 0, y = 10 on both); none on
        // the street's sides, facing the other building (within 45° of +x for the first roof,
        // of −x for the second).
        assert!(c.points.iter().any(|q| q.x < 1.0) && c.points.iter().any(|q| q.x > 24.0));
        for (q, n) in c.points.iter().zip(&c.normals) {
            let toward = if q.x < 12.5 { Vec3::X } else { Vec3::NEG_X };
            // (Away from the corners, which look past the other building's ends.)
            let street_side = (q.x - 12.5).abs() < 3.0 && (2.0..8.5).contains(&q.y);
            assert!(
                !(street_side && n.dot(toward) > 0.7),
                "a wall at {q} faces {n} across the street"
            );
        }
    }

    #[test]
    fn a_roof_across_open_ground_from_a_face_looking_back_has_its_edge() {
        // The street of the test above, the second building's face on it imaged (facing −x,
        // 0.5–11.5 m): a pair saw it from the street, so the ground before it is open and the
        // first roof's street side is an edge.
        let mut p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        p.extend(roof((14.75, 24.75), (0.25, 10.25), 12.0, |_| false));
        let mut n = vec![Vec3::Z; p.len()];
        face(&mut p, &mut n, 14.6, 23, Vec3::NEG_X);
        let walls = |p: &[Vec3], n: &[Vec3]| {
            roof_edge_walls(p, n, &vec![0.7; p.len()], 0.5, 2.0, |_| Some(0.5), |_| true)
        };
        let street_side = |q: &Vec3, m: &Vec3| {
            (q.x - 10.25).abs() < 0.3 && (2.0..8.5).contains(&q.y) && m.dot(Vec3::X) > 0.7
        };
        let c = walls(&p, &n);
        let on_street = c
            .points
            .iter()
            .zip(&c.normals)
            .filter(|(q, m)| street_side(q, m));
        let heights: Vec<f32> = on_street.map(|(q, _)| q.z).collect();
        assert!(
            heights.len() >= 13 * 18,
            "{} samples on the street side",
            heights.len()
        );
        assert!(heights
            .iter()
            .all(|&z| (0.5 - 1e-4..=9.5 + 1e-4).contains(&z)));
        // A taller part adjoining the roof (its face within a resolution cell of the roof's
        // edge) is no open ground: the same face moved to x = 11 m stands on the roof.
        for q in p.iter_mut().filter(|q| q.x == 14.6) {
            q.x = 11.0;
        }
        let c = walls(&p, &n);
        assert!(
            !c.points
                .iter()
                .zip(&c.normals)
                .any(|(q, m)| street_side(q, m)),
            "a wall under the roof against the taller part"
        );
    }

    #[test]
    fn samples_looking_back_with_a_walls_image_in_front_of_them_are_no_face() {
        // A roof 10 m high, and 8 m east of its edge a face looking back at it (facing −x,
        // 0.5–11.5 m): the ground between is open, the roof's east side an edge.
        let mut p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        let mut n = vec![Vec3::Z; p.len()];
        face(&mut p, &mut n, 18.6, 23, Vec3::NEG_X);
        let east = |c: &WallColumns| {
            c.points
                .iter()
                .zip(&c.normals)
                .filter(|(q, m)| {
                    (q.x - 10.25).abs() < 0.3 && (3.5..7.0).contains(&q.y) && m.x > 0.7
                })
                .count()
        };
        let walls = |p: &[Vec3], n: &[Vec3]| {
            roof_edge_walls(p, n, &vec![0.7; p.len()], 0.5, 2.0, |_| Some(0.5), |_| true)
        };
        // (Away from the corners, which look past the face's ends.)
        assert!(east(&walls(&p, &n)) >= 7 * 18);
        // The same samples with a wall's image 2 m in front of them, at their heights (normals
        // along it): they are part of an image seen along its face — at a building's corner the
        // normals fitted across its two faces point along one of them — not a face across open
        // ground. The look meets that image first, more than a resolution cell away.
        face(&mut p, &mut n, 16.6, 23, Vec3::Y);
        assert_eq!(
            east(&walls(&p, &n)),
            0,
            "a wall's image in front opened the edge"
        );
    }

    #[test]
    fn a_face_under_a_roof_is_no_face_looking_back_across_open_ground() {
        // One building 20 m long whose roof (10 m) was imaged in two parts, x 0–10.5 m and
        // 14.5–20.5 m, and under the far part a wall's image whose normals point back inside
        // (facing −x, 0.5–7.5 m high, at x = 18.6 m). The look east from where the first part
        // ends crosses the unimaged stretch, meets the far part more than a resolution cell
        // away and finds those samples; but the street in front of a face across open ground
        // is open up to the roof, and theirs is under the far part: no edge there.
        let mut p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        p.extend(roof((14.75, 20.25), (0.25, 10.25), 10.0, |_| false));
        let mut n = vec![Vec3::Z; p.len()];
        face(&mut p, &mut n, 18.6, 15, Vec3::NEG_X);
        let c = roof_edge_walls(
            &p,
            &n,
            &vec![0.7; p.len()],
            0.5,
            2.0,
            |_| Some(0.5),
            |_| true,
        );
        let inside = c
            .points
            .iter()
            .zip(&c.normals)
            .filter(|(q, m)| (q.x - 10.25).abs() < 0.3 && (2.0..8.5).contains(&q.y) && m.x > 0.7)
            .count();
        assert_eq!(inside, 0, "a wall where the roof's first part ends");
        // The building's outer east edge still stands on its wall.
        assert!(c.points.iter().any(|q| q.x > 20.0));
    }

    #[test]
    fn a_notch_in_a_roofs_image_narrower_than_a_resolution_cell_keeps_the_wall_on_the_rim() {
        // A roof 10 m high, 0–10.5 m square, whose image misses a 2 m stretch of its east rim
        // 2 m deep (y 4–6 m): the wall stands on the rim's line across the notch, not 2 m
        // inside the building.
        let notch = |q: Vec3| q.x > 8.6 && (4.0..6.0).contains(&q.y);
        let c = edges(&roof((0.25, 10.25), (0.25, 10.25), 10.0, notch), Some(0.5));
        let across = |c: &WallColumns, x: std::ops::Range<f32>| {
            c.points
                .iter()
                .zip(&c.normals)
                .filter(|(q, m)| (4.0..6.0).contains(&q.y) && x.contains(&q.x) && m.x > 0.7)
                .count()
        };
        assert!(
            across(&c, 9.75..10.75) >= 2 * 19,
            "no wall across the notch"
        );
        assert_eq!(across(&c, 7.0..9.75), 0, "a wall stood in the notch");
        // A recess wider than a resolution cell (5 m, 3 m deep) is the building's own shape:
        // its wall stays on the recess's line.
        let recess = |q: Vec3| q.x > 7.6 && (3.0..8.0).contains(&q.y);
        let c = edges(&roof((0.25, 10.25), (0.25, 10.25), 10.0, recess), Some(0.5));
        let inner = c
            .points
            .iter()
            .zip(&c.normals)
            .filter(|(q, m)| (4.5..6.5).contains(&q.y) && m.x > 0.7)
            .collect::<Vec<_>>();
        assert!(!inner.is_empty() && inner.iter().all(|(q, _)| (q.x - 7.25).abs() < 0.3));
    }

    #[test]
    fn the_imaging_regions_border_is_no_roof_edge() {
        // A roof imaged up to the border of the imaging region at x = 10.5 m: the building may
        // go on beyond it, nothing there was imaged. Walls stand on the other three sides only.
        let p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        let n = vec![Vec3::Z; p.len()];
        let inside = |q: Vec2| q.x <= 10.5;
        let c = roof_edge_walls(&p, &n, &vec![0.7; p.len()], 0.5, 2.0, |_| Some(0.5), inside);
        assert!(
            c.points.iter().any(|q| q.x < 1.0),
            "no wall on the far side"
        );
        for (q, m) in c.points.iter().zip(&c.normals) {
            assert!(m.x < 0.7, "a wall at {q} faces {m}, out of the region");
        }
        // The whole roof in the region: the border side has its wall again.
        let all = edges(&p, Some(0.5));
        assert!(all.points.iter().zip(&all.normals).any(|(_, m)| m.x > 0.7));
        // A region that ends 3 m past the roof (more than `front_m`, less than two): the street
        // in front of the wall is in the region, and so is the wall.
        let street = |q: Vec2| q.x <= 13.25;
        let c = roof_edge_walls(&p, &n, &vec![0.7; p.len()], 0.5, 2.0, |_| Some(0.5), street);
        assert!(c.points.iter().zip(&c.normals).any(|(_, m)| m.x > 0.7));
    }

    #[test]
    fn a_wall_facing_out_of_the_imaging_region_near_its_border_is_not_continued() {
        // The wall faces −y at y = −0.1; the region ends 1 m in front of it, within the street
        // its front test asks to be open: nothing is known to be open there.
        let (p, n, w) = wall(6.0, 10.0);
        let c = wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |q| q.y > -1.1);
        assert!(c.points.is_empty(), "{}", c.points.len());
        let c = wall_columns(&p, &n, &w, 0.5, 2.0, |_| Some(0.5), |q| q.y > -10.0);
        assert_eq!(c.columns, 4);
    }

    #[test]
    fn no_terrain_no_walls_nor_from_walls_or_with_a_bad_cell() {
        let p = roof((0.25, 10.25), (0.25, 10.25), 10.0, |_| false);
        assert!(edges(&p, None).points.is_empty());
        assert!(edges(&[], Some(0.5)).points.is_empty());
        let n = vec![Vec3::Z; p.len()];
        let w = vec![1.0; p.len()];
        assert!(
            roof_edge_walls(&p, &n, &w, f32::NAN, 2.0, |_| Some(0.5), |_| true)
                .points
                .is_empty()
        );
        // A wall's samples (normals level) are not a roof.
        let (wp, wn, ww) = wall(6.0, 10.0);
        assert!(
            roof_edge_walls(&wp, &wn, &ww, 0.5, 2.0, |_| Some(0.5), |_| true)
                .points
                .is_empty()
        );
    }
}
