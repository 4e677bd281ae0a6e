//! The paths of one transmitter to one or many receivers as typed, serialisable reports, and the
//! text inputs that name the ends: a point `"X,Y,Z"` ([`parse_point`]) and a receivers file, one
//! point per line ([`parse_receivers`], [`read_receivers`]). `has-sim paths` parses its
//! `--tx`/`--rx`/`--rx-file` with these and prints [`PathsReport`] (one receiver) or
//! [`ReceiversReport`] (a receivers file) as its `--json`.
//!
//! Units: positions in metres in the scene's frame (z up); each path as its [`PathRecord`]
//! (delay ns, gain dB, phase rad, angles in degrees with the conventions of [`crate::paths`]).
//! Receivers keep the order of their file; paths are by delay, as the tracer returns them.

use std::path::{Path as FsPath, PathBuf};

use glam::DVec3;
use serde::Serialize;

use super::{Path, PathRecord};

/// A point that is not `"X,Y,Z"`; prints the text it was given.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("'{text}' is not X,Y,Z (three finite numbers, metres)")]
pub struct PointError {
    /// The text, as given.
    pub text: String,
}

/// Parses `"X,Y,Z"`: three finite numbers separated by commas, spaces around each allowed
/// (metres).
///
/// # Errors
/// [`PointError`] for anything else (two or four numbers, a non-number, NaN or an infinity).
pub fn parse_point(s: &str) -> Result<DVec3, PointError> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || PointError {
        text: s.to_string(),
    };
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut v = [0.0f64; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse::<f64>().map_err(|_| bad())?;
        if !slot.is_finite() {
            return Err(bad());
        }
    }
    Ok(DVec3::from_array(v))
}

/// Why a receivers file gave no receivers. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReceiversError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A line is not `"X,Y,Z"`.
    #[error("{} line {line}: {source}", path.display())]
    BadLine {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The line's text (trimmed) and why it is not a point.
        source: PointError,
    },
    /// Only blank lines and comments.
    #[error("{}: no receivers", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
}

/// The receivers in `text`, the content of the file `path` (named in errors only): one
/// `"X,Y,Z"` ([`parse_point`]) per line, blank lines and lines starting with `#` (after leading
/// spaces) skipped.
///
/// # Errors
/// [`ReceiversError::BadLine`] for the first line that is not a point, with its number and
/// text; [`ReceiversError::Empty`] when no line is a receiver.
pub fn parse_receivers(text: &str, path: &FsPath) -> Result<Vec<DVec3>, ReceiversError> {
    let mut out = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        out.push(parse_point(l).map_err(|source| ReceiversError::BadLine {
            path: path.to_path_buf(),
            line: n + 1,
            source,
        })?);
    }
    if out.is_empty() {
        return Err(ReceiversError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(out)
}

/// The receivers of the file at `path` ([`parse_receivers`]).
///
/// # Errors
/// [`ReceiversError::Read`], or as [`parse_receivers`].
pub fn read_receivers(path: &FsPath) -> Result<Vec<DVec3>, ReceiversError> {
    let text =
        crate::io::guard::read_input_string(path).map_err(|source| ReceiversError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    parse_receivers(&text, path)
}

/// The records of `paths` ([`Path::record`]); `objects` names the scene's objects.
fn records<'a>(paths: &[Path], objects: &'a [String]) -> Vec<PathRecord<'a>> {
    paths.iter().map(|p| p.record(objects)).collect()
}

/// How a transmitter's candidate facet sequences were found (`"search"` of the reports).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Search {
    /// Shoot-and-bounce rays launched from the transmitter; `None` for the exhaustive
    /// enumeration.
    pub rays: Option<usize>,
    /// Candidate facet sequences found (each traced to every receiver).
    pub candidate_sequences: usize,
}

/// The paths to one receiver, serialised as `{"paths":[…], "search":{…}}`: each path a
/// [`PathRecord`] (keys in its documented order: `delay_ns, gain_db, phase_rad, a, jones,
/// aod_deg, zod_deg, aoa_deg, zoa_deg, interactions, objects, points`; per interaction its kind,
/// the name of the object it meets and its point `[x, y, z]` in metres, `null` for line of
/// sight), and the [`Search`] when given.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathsReport<'a> {
    /// The paths, by delay.
    pub paths: Vec<PathRecord<'a>>,
    /// How the candidates were found.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search: Option<Search>,
}

impl<'a> PathsReport<'a> {
    /// The report of `paths`; `objects` names the scene's objects.
    pub fn new(paths: &[Path], objects: &'a [String]) -> Self {
        PathsReport {
            paths: records(paths, objects),
            search: None,
        }
    }

    /// The report with how its candidates were found.
    pub fn with_search(mut self, search: Search) -> Self {
        self.search = Some(search);
        self
    }
}

/// One receiver of a [`ReceiversReport`]: its position and its paths.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReceiverPaths<'a> {
    /// The receiver, metres.
    pub rx: [f64; 3],
    /// Its paths, by delay.
    pub paths: Vec<PathRecord<'a>>,
}

/// The paths to many receivers, serialised as
/// `{"receivers":[{"rx":[x,y,z],"paths":[…]}, …], "search":{…}}`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReceiversReport<'a> {
    /// Per receiver, in the given order.
    pub receivers: Vec<ReceiverPaths<'a>>,
    /// How the candidates were found (once, for every receiver).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search: Option<Search>,
}

impl<'a> ReceiversReport<'a> {
    /// The report of receivers `rxs` with their paths `paths` (`paths[i]` those of `rxs[i]`, as
    /// [`super::Tracer::trace_many`] returns them); `objects` names the scene's objects.
    pub fn new(rxs: &[DVec3], paths: &[Vec<Path>], objects: &'a [String]) -> Self {
        ReceiversReport {
            receivers: rxs
                .iter()
                .zip(paths)
                .map(|(rx, paths)| ReceiverPaths {
                    rx: rx.to_array(),
                    paths: records(paths, objects),
                })
                .collect(),
            search: None,
        }
    }

    /// The report with how its candidates were found.
    pub fn with_search(mut self, search: Search) -> Self {
        self.search = Some(search);
        self
    }
}

#[cfg(test)]
mod tests {
    use num_complex::Complex64;

    use super::super::Interaction;
    use super::*;

    #[test]
    fn parse_point_accepts_three_numbers_and_quotes_anything_else() {
        assert_eq!(
            parse_point("1, -2.5,3e1").unwrap(),
            DVec3::new(1.0, -2.5, 30.0)
        );
        for bad in ["1,2", "1,2,3,4", "a,b,c", "NaN,0,0", "1,inf,0", ""] {
            let e = parse_point(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("'{bad}' is not X,Y,Z")), "{e}");
        }
    }

    #[test]
    fn receivers_skip_blanks_and_comments_and_a_bad_line_is_named_with_its_text() {
        let file = FsPath::new("rx.csv");
        let rx = parse_receivers("# x, y, z\n0,-40,10\n\n  # more\n 5, -45, 3 \n", file).unwrap();
        assert_eq!(
            rx,
            [DVec3::new(0.0, -40.0, 10.0), DVec3::new(5.0, -45.0, 3.0)]
        );
        let e = parse_receivers("0,-40,10\n\n1,2\n", file).unwrap_err();
        assert!(
            matches!(&e, ReceiversError::BadLine { line: 3, source, .. } if source.text == "1,2"),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "rx.csv line 3: '1,2' is not X,Y,Z (three finite numbers, metres)"
        );
        let e = parse_receivers("# none\n\n", file).unwrap_err();
        assert_eq!(e.to_string(), "rx.csv: no receivers");
        let missing = FsPath::new("/nonexistent/has-rx.csv");
        let e = read_receivers(missing).unwrap_err();
        assert!(matches!(e, ReceiversError::Read { .. }), "{e:?}");
        assert!(
            e.to_string().starts_with("/nonexistent/has-rx.csv: "),
            "{e}"
        );
    }

    #[test]
    fn json_has_documented_keys_in_order_and_parses() {
        let p = crate::paths::example_los_path();
        let wall = Path {
            interactions: vec![Interaction::Reflection {
                object: 1,
                facet: 0,
                point: DVec3::new(1.0, -2.5, 3.0),
            }],
            ..p.clone()
        };
        // A zero amplitude has no finite gain: written as null.
        let silent = Path {
            a: Complex64::new(0.0, 0.0),
            ..p.clone()
        };
        let names = ["ground".to_string(), "wall \"A\"".to_string()];
        let s =
            serde_json::to_string(&PathsReport::new(&[p.clone(), wall, silent], &names)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&s).unwrap();
        let o = &v["paths"][0];
        assert!((o["delay_ns"].as_f64().unwrap() - 100.0).abs() < 1e-9);
        assert!((o["gain_db"].as_f64().unwrap() + 60.0).abs() < 1e-9);
        assert!((o["phase_rad"].as_f64().unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(o["interactions"][0], "los");
        assert!(o["objects"][0].is_null() && o["points"][0].is_null());
        let r = &v["paths"][1];
        assert_eq!(r["interactions"][0], "reflection");
        assert_eq!(r["objects"][0], "wall \"A\"");
        let point: Vec<f64> = r["points"][0]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(point, [1.0, -2.5, 3.0]);
        assert!(v["paths"][2]["gain_db"].is_null(), "{s}");
        let keys = [
            "delay_ns",
            "gain_db",
            "phase_rad",
            "aod_deg",
            "zod_deg",
            "aoa_deg",
            "zoa_deg",
            "interactions",
            "objects",
            "points",
        ];
        let pos: Vec<usize> = keys
            .iter()
            .map(|k| s.find(&format!("\"{k}\"")).unwrap())
            .collect();
        assert!(pos.windows(2).all(|w| w[0] < w[1]), "{s}");
        // Many receivers: one entry per receiver, in order, each with its own paths.
        let rxs = [DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO];
        let many = ReceiversReport::new(&rxs, &[vec![p], vec![]], &names);
        let v = serde_json::to_value(&many).unwrap();
        assert_eq!(v["receivers"][0]["rx"], serde_json::json!([1.0, 2.0, 3.0]));
        assert_eq!(v["receivers"][0]["paths"][0]["interactions"][0], "los");
        assert_eq!(v["receivers"][1]["paths"], serde_json::json!([]));
    }
}
