//! A pair's resolution cell at a place, as an information matrix over the directions it
//! resolves.
//!
//! A pair places an echo to within its resolution along four directions
//! ([`crate::sensors::pair_resolution_axes`]): the bistatic range gradient (bandwidth), the
//! terminal's track (synthetic aperture), and the panel's two axes (its width and height). The
//! lattice's voxel blurs every imaged position by up to one voxel per axis, so each resolution is
//! widened to `δ' = √(δ² + v²)`. The information matrix `J = Σ a aᵀ/δ'²` then gives the pair's
//! resolution along any unit direction `n` as `1/√(nᵀJn)`: how far apart along `n` two places
//! must lie for the pair to tell them apart, and how far along `n` the pair's image of a surface
//! may lie from the surface itself.
//!
//! Units: metres, hertz; world frame.

use glam::{DMat3, Vec3};

use crate::sensors::{pair_resolution_axes, PlanarArray, VirtualAperture};

/// What a pair resolves at a place: its panel, its aperture, the carrier's wavelength and the
/// bandwidth ([`crate::sensors::pair_resolution_axes`]), and the lattice's voxel edge, which
/// blurs every offset between two imaged points by up to one voxel per axis.
#[derive(Clone, Debug)]
pub struct PairCell {
    /// The base station's receive panel.
    pub array: PlanarArray,
    /// The terminal's transmit track.
    pub aperture: VirtualAperture,
    /// Carrier wavelength, metres.
    pub wavelength_m: f32,
    /// Bandwidth, Hz.
    pub bandwidth_hz: f32,
    /// Imaging voxel edge, metres.
    pub voxel_m: f32,
}

impl PairCell {
    /// The pair's information matrix at `p`, `J = Σ a aᵀ/δ'²` over its four resolved directions
    /// `a` with resolutions `δ' = √(δ² + v²)` (voxel `v`).
    pub(crate) fn information(&self, p: Vec3) -> DMat3 {
        let v2 = (self.voxel_m as f64).powi(2);
        let mut j = DMat3::ZERO;
        for (a, d) in pair_resolution_axes(
            p,
            &self.array,
            &self.aperture,
            self.wavelength_m,
            self.bandwidth_hz,
        ) {
            let a = a.as_dvec3();
            let w = 1.0 / ((d as f64).powi(2) + v2).max(1e-12);
            j += DMat3::from_cols(a * a.x, a * a.y, a * a.z) * w;
        }
        j
    }

    /// Whether the pair could have placed an echo from `p` at `q`: the offset within one
    /// resolution cell, across the surface through `p` where it has one (normal `n`: along the
    /// surface a pair detects a surface's cells sparsely, and the support distance bounds the
    /// offset), in every direction otherwise.
    pub(crate) fn resolves_apart(&self, p: Vec3, q: Vec3, normal: Option<Vec3>) -> bool {
        let j = self.information(p);
        let d = (q - p).as_dvec3();
        match normal {
            Some(n) => {
                let n = n.as_dvec3();
                let across = d.dot(n);
                across * across * n.dot(j * n) > 1.0
            }
            None => d.dot(j * d) > 1.0,
        }
    }
}

/// The resolution along the unit direction `n` of a pair whose information matrix is `j`,
/// `1/√(nᵀJn)`, metres (infinite where the pair resolves nothing along `n`).
pub(crate) fn resolution_along_m(j: &DMat3, n: Vec3) -> f32 {
    let n = n.as_dvec3();
    let info = n.dot(*j * n);
    if info > 0.0 {
        (1.0 / info.sqrt()) as f32
    } else {
        f32::INFINITY
    }
}
