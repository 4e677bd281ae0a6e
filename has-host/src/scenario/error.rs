//! Why a scenario file could not be used, and the one set of field validators every table of
//! the file shares: each error names the field as written in the file (`imaging.voxel_m`,
//! `channel.ues`, `base_stations[2].position`) and the value given.

use std::path::PathBuf;

/// Why a scenario could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("{path}: cannot read the file")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Malformed TOML or a field that does not match the format (the message names it).
    #[error("{path}: {msg}")]
    Toml {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        msg: String,
    },
    /// A field with a bad value.
    #[error("{field}: {value} ({expected})")]
    Invalid {
        /// The field, e.g. `imaging.voxel_m` or `base_stations[2].position`.
        field: String,
        /// The value given.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// A position too far from the origin for coherent imaging in f32 ([`super::coherent_extent_m`]).
    #[error(
        "{field}: {value} lies {distance_m:.0} m from the origin; coherent imaging at λ = \
         {wavelength_m:.4} m needs coordinates within ±{limit_m:.0} m (f32 rounds a coordinate x by \
         up to |x|·2⁻²⁴, a phase error of 2π/64 at that limit): give positions in a local site frame"
    )]
    FarFromOrigin {
        /// The field.
        field: String,
        /// The position given.
        value: String,
        /// Its largest coordinate magnitude, metres.
        distance_m: f64,
        /// [`super::coherent_extent_m`] at the scenario's wavelength.
        limit_m: f64,
        /// The wavelength, metres.
        wavelength_m: f64,
    },
    /// A size that would not fit in memory ([`crate::memory::check_size`]).
    #[error(transparent)]
    TooLarge(#[from] crate::memory::TooLarge),
    /// Range profiles too short for the region: an OFDM profile's bins wrap after `n·c/B` of
    /// path, so an echo from farther would fold onto a nearer path.
    #[error(
        "radar.subcarriers: {subcarriers} (the unambiguous path n·c/B, {unambiguous_m:.1} m, is \
         shorter than the longest bistatic path through the imaging region, {longest_m:.1} m, \
         {via}: at least {needed} subcarriers at this bandwidth)"
    )]
    Ambiguous {
        /// `radar.subcarriers`.
        subcarriers: usize,
        /// `n·c/B`, metres of path.
        unambiguous_m: f64,
        /// The longest bistatic path from a base station via a corner of the region's box to a
        /// terminal position, metres.
        longest_m: f64,
        /// Which base station and terminal.
        via: String,
        /// The smallest power of two of subcarriers that holds it.
        needed: usize,
    },
}

/// The validators of one table of the scenario file: each error names `<table>.<field>` (the
/// bare field for the top level, `TableFields::new("")`).
#[derive(Clone, Copy, Debug)]
pub struct TableFields(&'static str);

impl TableFields {
    /// The fields of table `table` (`""`: the top level).
    pub const fn new(table: &'static str) -> TableFields {
        TableFields(table)
    }

    /// The field's full name.
    fn name(&self, field: impl std::fmt::Display) -> String {
        if self.0.is_empty() {
            field.to_string()
        } else {
            format!("{}.{field}", self.0)
        }
    }

    /// [`ScenarioError::Invalid`] for `field` holding `value`, `expected` saying what is allowed.
    pub fn invalid(
        &self,
        field: impl std::fmt::Display,
        value: impl std::fmt::Debug,
        expected: &'static str,
    ) -> ScenarioError {
        ScenarioError::Invalid {
            field: self.name(field),
            value: format!("{value:?}"),
            expected,
        }
    }

    /// `v` is finite and > 0.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming the field.
    pub fn positive(&self, field: impl std::fmt::Display, v: f64) -> Result<(), ScenarioError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(self.invalid(field, v, "finite and > 0"))
        }
    }

    /// `v` can be part of a file name ([`crate::io::guard::check_name_component`]): outputs
    /// such as `pair_<bs>-<aperture>.ply` are named after it.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming the field.
    pub fn name_component(
        &self,
        field: impl std::fmt::Display,
        v: &str,
    ) -> Result<(), ScenarioError> {
        crate::io::guard::check_name_component(v)
            .map_err(|expected| self.invalid(field, v, expected))
    }

    /// `field` = `value`, which implies `need_bytes`, fits in memory
    /// ([`crate::memory::check_size`]).
    ///
    /// # Errors
    /// [`ScenarioError::TooLarge`] naming the field.
    pub fn size(
        &self,
        field: impl std::fmt::Display,
        value: impl std::fmt::Debug,
        need_bytes: f64,
    ) -> Result<(), ScenarioError> {
        Ok(crate::memory::check_size(
            self.name(field),
            format!("{value:?}"),
            need_bytes,
        )?)
    }

    /// Every coordinate of `v` is finite.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming the field.
    pub fn finite<T: Copy + Into<f64> + std::fmt::Debug, const N: usize>(
        &self,
        field: impl std::fmt::Display,
        v: [T; N],
    ) -> Result<(), ScenarioError> {
        if v.iter().all(|&x| x.into().is_finite()) {
            Ok(())
        } else {
            Err(self.invalid(field, v, "finite coordinates"))
        }
    }

    /// `v` is a power of two within `lo ..= hi`.
    ///
    /// # Errors
    /// [`ScenarioError::Invalid`] naming the field.
    pub fn pow2_in(
        &self,
        field: impl std::fmt::Display,
        v: usize,
        lo: usize,
        hi: usize,
    ) -> Result<(), ScenarioError> {
        if v.is_power_of_two() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.invalid(field, v, "a power of two in the documented range"))
        }
    }
}

/// A TOML error as one line: `line N (its text): message`, the line's text naming the field and
/// the value (the parser's own text spans several lines).
pub(crate) fn one_line_toml_error(text: &str, e: &toml::de::Error) -> String {
    /// Longest quoted line, characters.
    const SHOWN: usize = 80;
    let msg = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
    match e.span() {
        Some(span) => {
            let start = span.start.min(text.len());
            let line = text.get(..start).map_or(0, |t| t.matches('\n').count()) + 1;
            let shown = text
                .lines()
                .nth(line - 1)
                .map(str::trim)
                .unwrap_or_default();
            if shown.is_empty() {
                format!("line {line}: {msg}")
            } else if shown.chars().count() > SHOWN {
                let cut: String = shown.chars().take(SHOWN).collect();
                format!("line {line} ({cut}…): {msg}")
            } else {
                format!("line {line} ({shown}): {msg}")
            }
        }
        None => msg,
    }
}
