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
use crate::io::npy::write_npy;
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

/// Writes the paths of each receiver `rxs[r]` (`paths[r]`) into `dir` (module docs); with
/// `freqs_hz`, their frequency response too.
///
/// # Errors
/// [`MeshIoError::Io`] when a file cannot be written.
pub fn write_path_arrays(
    dir: &FsPath,
    rxs: &[DVec3],
    paths: &[Vec<Path>],
    freqs_hz: Option<&[f64]>,
) -> Result<(), MeshIoError> {
    let r = paths.len();
    let p = paths.iter().map(Vec::len).max().unwrap_or(0);
    let table = |f: &dyn Fn(&Path) -> f64| -> Vec<f64> {
        paths
            .iter()
            .flat_map(|ps| (0..p).map(move |i| ps.get(i).map_or(f64::NAN, f)))
            .collect()
    };
    let counts: Vec<i64> = paths.iter().map(|ps| ps.len() as i64).collect();
    write_npy(&dir.join("num_paths.npy"), &[r], &counts)?;
    let rx: Vec<f64> = rxs.iter().flat_map(|v| v.to_array()).collect();
    write_npy(&dir.join("rx.npy"), &[rxs.len(), 3], &rx)?;
    write_npy(&dir.join("tau.npy"), &[r, p], &table(&|q| q.delay_s))?;
    for (name, f) in [
        ("aod.npy", (|q: &Path| q.aod) as fn(&Path) -> f64),
        ("zod.npy", |q: &Path| q.zod),
        ("aoa.npy", |q: &Path| q.aoa),
        ("zoa.npy", |q: &Path| q.zoa),
    ] {
        write_npy(&dir.join(name), &[r, p], &table(&f))?;
    }
    let zero = Complex64::new(0.0, 0.0);
    let a: Vec<Complex64> = paths
        .iter()
        .flat_map(|ps| (0..p).map(move |i| ps.get(i).map_or(zero, |q| q.a)))
        .collect();
    write_npy(&dir.join("a.npy"), &[r, p], &a)?;
    let jones: Vec<Complex64> = paths
        .iter()
        .flat_map(|ps| {
            (0..p).flat_map(move |i| {
                let j = ps.get(i).map_or([[zero; 2]; 2], |q| q.jones);
                [j[0][0], j[0][1], j[1][0], j[1][1]]
            })
        })
        .collect();
    write_npy(&dir.join("jones.npy"), &[r, p, 2, 2], &jones)?;
    if let Some(freqs) = freqs_hz {
        let cfr: Vec<Complex64> = paths
            .iter()
            .flat_map(|ps| frequency_response_at(ps, freqs))
            .collect();
        write_npy(&dir.join("cfr.npy"), &[r, freqs.len()], &cfr)?;
        write_npy(&dir.join("freqs_hz.npy"), &[freqs.len()], freqs)?;
    }
    Ok(())
}
