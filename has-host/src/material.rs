//! Radio materials after ITU-R P.2040-3 (Table 3): relative permittivity `εr = a·f^b` and
//! conductivity `σ = c·f^d` with `f` in GHz, σ in S/m.
//!
//! Names follow Sionna RT's `itu_*` radio materials (`"itu_concrete"`, `"itu_metal"`, ...); the
//! plain names (`"concrete"`) are accepted too. The complex relative permittivity is
//! `η = εr − j·σ/(ε0·ω) = εr − j·17.98·σ/f_GHz`.

use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Vacuum permittivity, F/m.
pub const EPSILON_0: f64 = 8.854_187_812_8e-12;

/// One of the ITU-R P.2040 materials.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Material {
    /// Vacuum / air (no interaction).
    Vacuum,
    /// Concrete.
    Concrete,
    /// Brick.
    Brick,
    /// Plasterboard.
    Plasterboard,
    /// Wood.
    Wood,
    /// Glass.
    Glass,
    /// Ceiling board.
    CeilingBoard,
    /// Chipboard.
    Chipboard,
    /// Plywood.
    Plywood,
    /// Marble (Sionna's street-canyon scenes use it).
    Marble,
    /// Floorboard.
    Floorboard,
    /// Metal (σ = 10⁷ S/m).
    Metal,
    /// Very dry ground.
    VeryDryGround,
    /// Medium dry ground.
    MediumDryGround,
    /// Wet ground.
    WetGround,
}

/// `(material, name, a, b, c, d, f_min_ghz, f_max_ghz)`, ITU-R P.2040-3 Table 3.
type ItuRow = (Material, &'static str, f64, f64, f64, f64, f64, f64);

const ITU_TABLE: [ItuRow; 15] = [
    (Material::Vacuum, "vacuum", 1.0, 0.0, 0.0, 0.0, 0.001, 100.0),
    (
        Material::Concrete,
        "concrete",
        5.24,
        0.0,
        0.0462,
        0.7822,
        1.0,
        100.0,
    ),
    (Material::Brick, "brick", 3.91, 0.0, 0.0238, 0.16, 1.0, 40.0),
    (
        Material::Plasterboard,
        "plasterboard",
        2.73,
        0.0,
        0.0085,
        0.9395,
        1.0,
        100.0,
    ),
    (
        Material::Wood,
        "wood",
        1.99,
        0.0,
        0.0047,
        1.0718,
        0.001,
        100.0,
    ),
    (
        Material::Glass,
        "glass",
        6.31,
        0.0,
        0.0036,
        1.3394,
        0.1,
        100.0,
    ),
    (
        Material::CeilingBoard,
        "ceiling_board",
        1.48,
        0.0,
        0.0011,
        1.0750,
        1.0,
        100.0,
    ),
    (
        Material::Chipboard,
        "chipboard",
        2.58,
        0.0,
        0.0217,
        0.7800,
        1.0,
        100.0,
    ),
    (
        Material::Plywood,
        "plywood",
        2.71,
        0.0,
        0.33,
        0.0,
        1.0,
        40.0,
    ),
    (
        Material::Marble,
        "marble",
        7.074,
        0.0,
        0.0055,
        0.9262,
        1.0,
        60.0,
    ),
    (
        Material::Floorboard,
        "floorboard",
        3.66,
        0.0,
        0.0044,
        1.3515,
        50.0,
        100.0,
    ),
    (Material::Metal, "metal", 1.0, 0.0, 1e7, 0.0, 1.0, 100.0),
    (
        Material::VeryDryGround,
        "very_dry_ground",
        3.0,
        0.0,
        0.00015,
        2.52,
        1.0,
        10.0,
    ),
    (
        Material::MediumDryGround,
        "medium_dry_ground",
        15.0,
        -0.1,
        0.035,
        1.63,
        1.0,
        10.0,
    ),
    (
        Material::WetGround,
        "wet_ground",
        30.0,
        -0.4,
        0.15,
        1.30,
        1.0,
        10.0,
    ),
];

impl Material {
    /// Every material, in table order.
    pub fn all() -> impl Iterator<Item = Material> {
        ITU_TABLE.iter().map(|row| row.0)
    }

    fn row(self) -> &'static ItuRow {
        ITU_TABLE
            .iter()
            .find(|row| row.0 == self)
            .expect("every Material has a table row")
    }

    /// The plain name (`"concrete"`); Sionna RT's name is `"itu_"` + this.
    pub fn name(self) -> &'static str {
        self.row().1
    }

    /// Looks a material up by plain (`"concrete"`) or Sionna RT (`"itu_concrete"`) name,
    /// case-insensitively.
    pub fn from_name(name: &str) -> Option<Material> {
        let lower = name.to_ascii_lowercase();
        let plain = lower.strip_prefix("itu_").unwrap_or(&lower);
        ITU_TABLE.iter().find(|row| row.1 == plain).map(|row| row.0)
    }

    /// Relative permittivity εr at `freq_hz`.
    pub fn relative_permittivity(self, freq_hz: f64) -> f64 {
        let (_, _, a, b, ..) = *self.row();
        a * (freq_hz * 1e-9).powf(b)
    }

    /// Conductivity σ in S/m at `freq_hz`.
    pub fn conductivity(self, freq_hz: f64) -> f64 {
        let (_, _, _, _, c, d, ..) = *self.row();
        c * (freq_hz * 1e-9).powf(d)
    }

    /// Complex relative permittivity `η = εr − j·σ/(ε0·ω)` at `freq_hz`.
    pub fn complex_permittivity(self, freq_hz: f64) -> Complex64 {
        let omega = 2.0 * std::f64::consts::PI * freq_hz;
        Complex64::new(
            self.relative_permittivity(freq_hz),
            -self.conductivity(freq_hz) / (EPSILON_0 * omega),
        )
    }

    /// The frequency range (GHz) over which ITU-R P.2040 states the fit is valid.
    pub fn valid_range_ghz(self) -> (f64, f64) {
        let row = self.row();
        (row.6, row.7)
    }
}

impl std::fmt::Display for Material {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn concrete_at_10_ghz_matches_itu_p2040() {
        let m = Material::Concrete;
        assert_eq!(m.relative_permittivity(10e9), 5.24);
        let sigma = m.conductivity(10e9);
        assert!((sigma - 0.0462 * 10f64.powf(0.7822)).abs() < 1e-12);
        // η'' = 17.98 σ / f_GHz
        let eta = m.complex_permittivity(10e9);
        assert!((eta.im + 17.975 * sigma / 10.0).abs() < 1e-3 * sigma);
    }

    #[test]
    fn marble_and_plywood_match_itu_p2040_table3() {
        // Table 3: marble εr = 7.074, σ = 0.0055·f^0.9262 (1–60 GHz); plywood εr = 2.71,
        // σ = 0.33 (1–40 GHz).
        let m = Material::from_name("itu_marble").unwrap();
        assert_eq!(m.relative_permittivity(10e9), 7.074);
        assert!((m.conductivity(10e9) - 0.0055 * 10f64.powf(0.9262)).abs() < 1e-15);
        assert_eq!(m.valid_range_ghz(), (1.0, 60.0));
        let p = Material::from_name("plywood").unwrap();
        assert_eq!(p.relative_permittivity(28e9), 2.71);
        assert_eq!(p.conductivity(28e9), 0.33);
    }

    #[test]
    fn names_round_trip_with_and_without_itu_prefix() {
        for m in Material::all() {
            assert_eq!(Material::from_name(m.name()), Some(m));
            assert_eq!(Material::from_name(&format!("itu_{}", m.name())), Some(m));
        }
        assert_eq!(
            Material::from_name("ITU_Concrete"),
            Some(Material::Concrete)
        );
        assert_eq!(Material::from_name("unobtainium"), None);
    }
}
