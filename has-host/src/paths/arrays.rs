//! Paths as NumPy arrays (`has-sim paths --npy DIR`), shaped as a Sionna RT user reads them: one
//! row per receiver, one column per path, padded to the largest path count. Per receiver `r` and
//! path `p`:
//!
//! - `num_paths.npy` `int64 [R]`; `rx.npy` `float64 [R, 3]` (metres);
//! - `tau.npy` `float64 [R, P]`, seconds (NaN past a receiver's paths);
//! - `a.npy` `complex128 [R, P]`, the amplitude for the configured polarisation, equal to Sionna
//!   RT's `cir(normalize_delays=False)` `a` (0 past a receiver's paths);
//! - `jones.npy` `complex128 [R, P, 2, 2]`, `[.., rx, tx]`, index 0 = θ̂, 1 = φ̂ (0 padded);
//! - `aod.npy`, `zod.npy`, `aoa.npy`, `zoa.npy` `float64 [R, P]`, radians (NaN padded);
//! - with a frequency grid: `cfr.npy` `complex128 [R, N]`, `H(f) = Σ a·e^{−j2πfτ}` at the
//!   baseband offsets of `freqs_hz.npy` `float64 [N]` ([`crate::channel::frequency_response_at`]).

use std::path::Path as FsPath;

use glam::DVec3;
use num_complex::Complex64;

use super::Path;
use crate::channel::frequency_response_at;
use crate::io::npy::npy_bytes;
use crate::io::MeshIoError;

/// The files [`write_path_arrays`] writes (module docs), `cfr.npy` and `freqs_hz.npy` only with
/// a frequency grid.
pub const FILES: [&str; 11] = [
    "num_paths.npy",
    "rx.npy",
    "tau.npy",
    "a.npy",
    "jones.npy",
    "aod.npy",
    "zod.npy",
    "aoa.npy",
    "zoa.npy",
    "cfr.npy",
    "freqs_hz.npy",
];

/// Bytes [`write_path_arrays`] holds at once for `receivers`, `paths` per receiver and
/// `subcarriers`: every array as values and as file bytes.
pub fn arrays_bytes(receivers: usize, paths: usize, subcarriers: usize) -> f64 {
    let (r, p, n) = (receivers as f64, paths as f64, subcarriers as f64);
    // Per path: tau and four angles (f64), a and four Jones terms (complex128); per receiver:
    // its position and count; per subcarrier: the response, and the grid once.
    2.0 * (r * (p * (5.0 * 8.0 + 5.0 * 16.0) + 4.0 * 8.0 + n * 16.0) + n * 8.0)
}

/// Refuses arrays that would not fit in memory ([`crate::memory::check_size`]), naming
/// `subcarriers × receivers`.
///
/// # Errors
/// [`crate::memory::TooLarge`].
pub fn check_arrays_size(
    receivers: usize,
    paths: usize,
    subcarriers: usize,
) -> Result<(), crate::memory::TooLarge> {
    crate::memory::check_size(
        "subcarriers × receivers",
        format!("{subcarriers} × {receivers}"),
        arrays_bytes(receivers, paths, subcarriers),
    )
}

/// Writes the paths of each receiver `rxs[r]` (`paths[r]`) into `dir` (module docs); with
/// `freqs_hz`, their frequency response too. Every file is written or none
/// ([`crate::io::write_files`]).
///
/// # Errors
/// [`MeshIoError::BadData`] for arrays that would not fit in memory ([`check_arrays_size`]);
/// [`MeshIoError::Io`] when a file cannot be written.
pub fn write_path_arrays(
    dir: &FsPath,
    rxs: &[DVec3],
    paths: &[Vec<Path>],
    freqs_hz: Option<&[f64]>,
) -> Result<(), MeshIoError> {
    let r = paths.len();
    let p = paths.iter().map(Vec::len).max().unwrap_or(0);
    check_arrays_size(r, p, freqs_hz.map_or(0, <[f64]>::len)).map_err(|e| {
        MeshIoError::BadData {
            path: dir.to_path_buf(),
            msg: e.to_string(),
        }
    })?;
    let table = |f: &dyn Fn(&Path) -> f64| -> Vec<f64> {
        paths
            .iter()
            .flat_map(|ps| (0..p).map(move |i| ps.get(i).map_or(f64::NAN, f)))
            .collect()
    };
    let mut files: Vec<(&str, Vec<u8>)> = Vec::new();
    let counts: Vec<i64> = paths.iter().map(|ps| ps.len() as i64).collect();
    files.push(("num_paths.npy", npy_bytes(&[r], &counts)));
    let rx: Vec<f64> = rxs.iter().flat_map(|v| v.to_array()).collect();
    files.push(("rx.npy", npy_bytes(&[rxs.len(), 3], &rx)));
    files.push(("tau.npy", npy_bytes(&[r, p], &table(&|q| q.delay_s))));
    for (name, f) in [
        ("aod.npy", (|q: &Path| q.aod) as fn(&Path) -> f64),
        ("zod.npy", |q: &Path| q.zod),
        ("aoa.npy", |q: &Path| q.aoa),
        ("zoa.npy", |q: &Path| q.zoa),
    ] {
        files.push((name, npy_bytes(&[r, p], &table(&f))));
    }
    let zero = Complex64::new(0.0, 0.0);
    let a: Vec<Complex64> = paths
        .iter()
        .flat_map(|ps| (0..p).map(move |i| ps.get(i).map_or(zero, |q| q.a)))
        .collect();
    files.push(("a.npy", npy_bytes(&[r, p], &a)));
    let jones: Vec<Complex64> = paths
        .iter()
        .flat_map(|ps| {
            (0..p).flat_map(move |i| {
                let j = ps.get(i).map_or([[zero; 2]; 2], |q| q.jones);
                [j[0][0], j[0][1], j[1][0], j[1][1]]
            })
        })
        .collect();
    files.push(("jones.npy", npy_bytes(&[r, p, 2, 2], &jones)));
    if let Some(freqs) = freqs_hz {
        let cfr: Vec<Complex64> = paths
            .iter()
            .flat_map(|ps| frequency_response_at(ps, freqs))
            .collect();
        files.push(("cfr.npy", npy_bytes(&[r, freqs.len()], &cfr)));
        files.push(("freqs_hz.npy", npy_bytes(&[freqs.len()], freqs)));
    }
    let files: Vec<_> = files
        .into_iter()
        .map(|(name, bytes)| (dir.join(name), bytes))
        .collect();
    crate::io::write_files(&files)
}
