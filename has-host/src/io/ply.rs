//! PLY (Stanford polygon format) meshes and point clouds: read ASCII, binary little- and
//! big-endian; write binary little-endian (default), big-endian or ASCII.
//!
//! Reading keeps the `vertex` element's `x`, `y`, `z` as positions and every other scalar vertex
//! property as an extra `f32` column (`intensity`, `nx`, `red`, ...) in header order; the `face`
//! element's `vertex_indices` (or `vertex_index`) list is fan-triangulated. Other elements and
//! list properties are read and skipped. Writing stores positions and extra columns as `float`
//! and faces as `list uchar int vertex_indices`; a [`PlyData`] without faces is a point cloud.
//! Coordinates in metres.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use glam::Vec3;

use super::{atomic_write, read_bytes, MeshIoError};

/// A triangle mesh or (without faces) a point cloud, with extra per-vertex `f32` properties.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyData {
    /// Vertex positions, metres.
    pub vertices: Vec<Vec3>,
    /// Extra per-vertex properties `(name, values)`; each `values.len() == vertices.len()`.
    pub properties: Vec<(String, Vec<f32>)>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

/// Encoding of a written PLY file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlyFormat {
    /// `binary_little_endian 1.0` (compact; the default).
    #[default]
    BinaryLittleEndian,
    /// `binary_big_endian 1.0`.
    BinaryBigEndian,
    /// `ascii 1.0` (readable, larger).
    Ascii,
}

impl PlyData {
    /// A point cloud with no extra properties.
    pub fn from_points(points: Vec<Vec3>) -> Self {
        PlyData {
            vertices: points,
            ..Default::default()
        }
    }

    /// Adds an extra per-vertex property column (builder style). The length is checked when
    /// writing.
    pub fn with_property(mut self, name: impl Into<String>, values: Vec<f32>) -> Self {
        self.properties.push((name.into(), values));
        self
    }

    /// The values of property `name`, if present.
    pub fn property(&self, name: &str) -> Option<&[f32]> {
        self.properties
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    /// The faces as triangles of positions.
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        self.faces
            .iter()
            .map(|f| f.map(|i| self.vertices[i as usize]))
            .collect()
    }

    /// Appends triangles, sharing vertices with bit-identical positions among the appended ones.
    /// Extra property columns are not extended.
    pub fn append_triangles(&mut self, tris: &[[Vec3; 3]]) {
        let mut index: HashMap<[u32; 3], u32> = HashMap::new();
        for t in tris {
            let f = t.map(|v| {
                *index
                    .entry([v.x.to_bits(), v.y.to_bits(), v.z.to_bits()])
                    .or_insert_with(|| {
                        self.vertices.push(v);
                        (self.vertices.len() - 1) as u32
                    })
            });
            self.faces.push(f);
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:literal) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => num!(i16, 2),
            Scalar::U16 => num!(u16, 2),
            Scalar::I32 => num!(i32, 4),
            Scalar::U32 => num!(u32, 4),
            Scalar::F32 => num!(f32, 4),
            Scalar::F64 => num!(f64, 8),
        }
    }
}

#[derive(Clone, Debug)]
enum Prop {
    Scalar(Scalar, String),
    List(Scalar, Scalar, String),
}

impl Prop {
    fn name(&self) -> &str {
        match self {
            Prop::Scalar(_, n) | Prop::List(_, _, n) => n,
        }
    }
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big: bool },
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    /// Byte offset of the body.
    body: usize,
    /// Number of header lines (the body's first line is `lines + 1`).
    lines: usize,
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, MeshIoError> {
    let perr = |line: usize, msg: String| MeshIoError::Parse {
        path: path.to_path_buf(),
        line,
        msg,
    };
    let mut pos = 0;
    let mut line_no = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let rest = &bytes[pos..];
        let Some(nl) = rest.iter().position(|&b| b == b'\n') else {
            return Err(perr(
                line_no + 1,
                "file ends inside the header (no 'end_header')".into(),
            ));
        };
        line_no += 1;
        let raw = &rest[..nl];
        pos += nl + 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| perr(line_no, "header line is not text".into()))?
            .trim_end_matches('\r')
            .trim();
        let toks: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line != "ply" {
                return Err(perr(1, format!("not a PLY file (first line '{line}')")));
            }
            continue;
        }
        match toks.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                encoding = Some(match toks.get(1).copied() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Binary { big: false },
                    Some("binary_big_endian") => Encoding::Binary { big: true },
                    other => {
                        return Err(perr(
                            line_no,
                            format!("unknown format '{}'", other.unwrap_or("")),
                        ))
                    }
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (toks.get(1), toks.get(2)) else {
                    return Err(perr(line_no, format!("malformed element line '{line}'")));
                };
                let count = count.parse::<usize>().map_err(|_| {
                    perr(
                        line_no,
                        format!("element '{name}': count '{count}' is not a number"),
                    )
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(perr(line_no, "property before any element".into()));
                };
                let ty = |s: Option<&&str>| -> Result<Scalar, MeshIoError> {
                    let s = s.copied().unwrap_or("");
                    Scalar::parse(s).ok_or_else(|| {
                        perr(line_no, format!("unknown property type '{s}' in '{line}'"))
                    })
                };
                let prop = if toks.get(1) == Some(&"list") {
                    let name = toks
                        .get(4)
                        .ok_or_else(|| perr(line_no, format!("malformed list '{line}'")))?;
                    Prop::List(ty(toks.get(2))?, ty(toks.get(3))?, name.to_string())
                } else {
                    let name = toks
                        .get(2)
                        .ok_or_else(|| perr(line_no, format!("malformed property '{line}'")))?;
                    Prop::Scalar(ty(toks.get(1))?, name.to_string())
                };
                el.props.push(prop);
            }
            Some("end_header") => break,
            Some(other) => return Err(perr(line_no, format!("unknown header keyword '{other}'"))),
        }
    }
    let encoding = encoding.ok_or_else(|| perr(line_no, "no 'format' line in header".into()))?;
    // An instance without a property takes no byte of a binary body, so no end of file stops
    // a count of 2⁶⁴ − 1 of them; such an element holds nothing and is refused.
    if let Some(el) = elements.iter().find(|e| e.count > 0 && e.props.is_empty()) {
        return Err(perr(
            line_no,
            format!(
                "element '{}' declares {} instances but no property",
                el.name, el.count
            ),
        ));
    }
    Ok(Header {
        encoding,
        elements,
        body: pos,
        lines: line_no,
    })
}

/// Reads element instances from the body, in either encoding.
enum Body<'a> {
    Binary {
        bytes: &'a [u8],
        pos: usize,
        big: bool,
    },
    Ascii {
        lines: std::str::Lines<'a>,
        line_no: usize,
    },
}

impl Body<'_> {
    /// Reads one instance of `el`: `values[k]` is scalar property `k` (the count for a list);
    /// the items of list property `keep_list` go to `list`.
    fn instance(
        &mut self,
        el: &Element,
        index: usize,
        keep_list: Option<usize>,
        values: &mut Vec<f64>,
        list: &mut Vec<f64>,
        path: &Path,
    ) -> Result<(), MeshIoError> {
        values.clear();
        list.clear();
        match self {
            Body::Binary { bytes, pos, big } => {
                let eof = || MeshIoError::Element {
                    path: path.to_path_buf(),
                    element: el.name.clone(),
                    index,
                    msg: format!("file ends inside the element ({} declared)", el.count),
                };
                let mut take = |ty: Scalar| -> Result<f64, MeshIoError> {
                    let n = ty.size();
                    let b = bytes.get(*pos..*pos + n).ok_or_else(eof)?;
                    *pos += n;
                    Ok(ty.decode(b, *big))
                };
                for (k, p) in el.props.iter().enumerate() {
                    match p {
                        Prop::Scalar(t, _) => values.push(take(*t)?),
                        Prop::List(ct, it, name) => {
                            let n = take(*ct)?;
                            if !(0.0..=1e6).contains(&n) {
                                return Err(MeshIoError::Element {
                                    path: path.to_path_buf(),
                                    element: el.name.clone(),
                                    index,
                                    msg: format!("list '{name}' has invalid length {n}"),
                                });
                            }
                            values.push(n);
                            for _ in 0..n as usize {
                                let v = take(*it)?;
                                if keep_list == Some(k) {
                                    list.push(v);
                                }
                            }
                        }
                    }
                }
            }
            Body::Ascii { lines, line_no } => {
                let line = loop {
                    *line_no += 1;
                    match lines.next() {
                        None => {
                            return Err(MeshIoError::Parse {
                                path: path.to_path_buf(),
                                line: *line_no,
                                msg: format!(
                                    "file ends at element '{}' #{index} ({} declared)",
                                    el.name, el.count
                                ),
                            })
                        }
                        Some(l) if l.trim().is_empty() => continue,
                        Some(l) => break l,
                    }
                };
                let ln = *line_no;
                let mut toks = line.split_whitespace();
                let mut take = |name: &str| -> Result<f64, MeshIoError> {
                    let t = toks.next().ok_or_else(|| MeshIoError::Parse {
                        path: path.to_path_buf(),
                        line: ln,
                        msg: format!(
                            "element '{}' #{index}: missing value for property '{name}'",
                            el.name
                        ),
                    })?;
                    t.parse::<f64>().map_err(|_| MeshIoError::Parse {
                        path: path.to_path_buf(),
                        line: ln,
                        msg: format!(
                            "element '{}' #{index}: property '{name}': '{t}' is not a number",
                            el.name
                        ),
                    })
                };
                for (k, p) in el.props.iter().enumerate() {
                    match p {
                        Prop::Scalar(_, name) => values.push(take(name)?),
                        Prop::List(_, _, name) => {
                            let n = take(name)?;
                            if !((0.0..=1e6).contains(&n) && n.fract() == 0.0) {
                                return Err(MeshIoError::Parse {
                                    path: path.to_path_buf(),
                                    line: ln,
                                    msg: format!(
                                        "element '{}' #{index}: list '{name}' has invalid length {n}",
                                        el.name
                                    ),
                                });
                            }
                            values.push(n);
                            for _ in 0..n as usize {
                                let v = take(name)?;
                                if keep_list == Some(k) {
                                    list.push(v);
                                }
                            }
                        }
                    }
                }
                if let Some(extra) = toks.next() {
                    return Err(MeshIoError::Parse {
                        path: path.to_path_buf(),
                        line: ln,
                        msg: format!(
                            "element '{}' #{index}: unexpected extra value '{extra}'",
                            el.name
                        ),
                    });
                }
            }
        }
        Ok(())
    }
}

/// Reads a PLY file (mesh or point cloud).
pub fn read_ply(path: &Path) -> Result<PlyData, MeshIoError> {
    let bytes = read_bytes(path)?;
    parse_ply(&bytes, path)
}

/// Parses PLY bytes; `path` only names the source in errors.
pub fn parse_ply(bytes: &[u8], path: &Path) -> Result<PlyData, MeshIoError> {
    let header = parse_header(bytes, path)?;
    let body_bytes = &bytes[header.body..];
    let mut body = match header.encoding {
        Encoding::Binary { big } => Body::Binary {
            bytes: body_bytes,
            pos: 0,
            big,
        },
        Encoding::Ascii => Body::Ascii {
            lines: std::str::from_utf8(body_bytes)
                .map_err(|e| MeshIoError::Parse {
                    path: path.to_path_buf(),
                    line: header.lines + 1,
                    msg: format!("ASCII body is not text: {e}"),
                })?
                .lines(),
            line_no: header.lines,
        },
    };
    let mut out = PlyData::default();
    let mut seen_vertex = false;
    let mut values = Vec::new();
    let mut list = Vec::new();
    for el in &header.elements {
        let el_err = |index: usize, msg: String| MeshIoError::Element {
            path: path.to_path_buf(),
            element: el.name.clone(),
            index,
            msg,
        };
        match el.name.as_str() {
            "vertex" => {
                seen_vertex = true;
                let find = |axis: &str| {
                    el.props
                        .iter()
                        .position(|p| matches!(p, Prop::Scalar(_, n) if n == axis))
                        .ok_or_else(|| el_err(0, format!("no scalar property '{axis}'")))
                };
                let (ix, iy, iz) = (find("x")?, find("y")?, find("z")?);
                let extra: Vec<usize> = (0..el.props.len())
                    .filter(|&k| {
                        k != ix && k != iy && k != iz && matches!(el.props[k], Prop::Scalar(..))
                    })
                    .collect();
                // Every instance takes at least one byte of the body: a header that declares
                // more (4·10⁹ vertices in a 150-byte file) reserves no more than the body can
                // hold, and the read stops with an error where the body ends.
                let cap = el.count.min(body_bytes.len());
                out.vertices.reserve(cap);
                let mut cols: Vec<Vec<f32>> = vec![Vec::with_capacity(cap); extra.len()];
                for i in 0..el.count {
                    body.instance(el, i, None, &mut values, &mut list, path)?;
                    for (k, axis) in [(ix, "x"), (iy, "y"), (iz, "z")] {
                        if !values[k].is_finite() {
                            return Err(MeshIoError::NonFinite {
                                path: path.to_path_buf(),
                                element: "vertex".into(),
                                index: i,
                                field: axis.into(),
                                value: values[k],
                            });
                        }
                    }
                    out.vertices.push(Vec3::new(
                        values[ix] as f32,
                        values[iy] as f32,
                        values[iz] as f32,
                    ));
                    for (c, &k) in cols.iter_mut().zip(&extra) {
                        c.push(values[k] as f32);
                    }
                }
                out.properties = extra
                    .iter()
                    .map(|&k| el.props[k].name().to_string())
                    .zip(cols)
                    .collect();
            }
            "face" => {
                if !seen_vertex {
                    return Err(el_err(0, "face element before the vertex element".into()));
                }
                let k = el
                    .props
                    .iter()
                    .position(|p| {
                        matches!(p, Prop::List(_, _, n) if n == "vertex_indices" || n == "vertex_index")
                    })
                    .ok_or_else(|| {
                        el_err(0, "no list property 'vertex_indices' or 'vertex_index'".into())
                    })?;
                let nv = out.vertices.len();
                out.faces.reserve(el.count.min(body_bytes.len()));
                for i in 0..el.count {
                    body.instance(el, i, Some(k), &mut values, &mut list, path)?;
                    if list.len() < 3 {
                        return Err(el_err(i, format!("face has {} vertices (< 3)", list.len())));
                    }
                    let mut idx = [0u32; 3];
                    let mut ids = Vec::with_capacity(list.len());
                    for &v in &list {
                        if !(v >= 0.0 && (v as usize) < nv && v.fract() == 0.0) {
                            return Err(el_err(
                                i,
                                format!("vertex index {v} out of range ({nv} vertices)"),
                            ));
                        }
                        ids.push(v as u32);
                    }
                    for j in 1..ids.len() - 1 {
                        idx[0] = ids[0];
                        idx[1] = ids[j];
                        idx[2] = ids[j + 1];
                        out.faces.push(idx);
                    }
                }
            }
            _ => {
                for i in 0..el.count {
                    body.instance(el, i, None, &mut values, &mut list, path)?;
                }
            }
        }
    }
    if !seen_vertex {
        return Err(MeshIoError::Parse {
            path: path.to_path_buf(),
            line: header.lines,
            msg: "header declares no 'vertex' element".into(),
        });
    }
    Ok(out)
}

fn check_writable(data: &PlyData, path: &Path) -> Result<(), MeshIoError> {
    let bad = |msg: String| MeshIoError::BadData {
        path: path.to_path_buf(),
        msg,
    };
    let n = data.vertices.len();
    for (i, (name, vals)) in data.properties.iter().enumerate() {
        if name.is_empty() || name.chars().any(|c| c.is_whitespace()) {
            return Err(bad(format!(
                "property name '{name}' is empty or has spaces"
            )));
        }
        if ["x", "y", "z"].contains(&name.as_str())
            || data.properties[..i].iter().any(|(m, _)| m == name)
        {
            return Err(bad(format!("property '{name}' is given twice")));
        }
        if vals.len() != n {
            return Err(bad(format!(
                "property '{name}' has {} values for {n} vertices",
                vals.len()
            )));
        }
    }
    for (i, f) in data.faces.iter().enumerate() {
        if let Some(v) = f.iter().find(|&&v| v as usize >= n) {
            return Err(bad(format!("face {i} refers to vertex {v} ({n} vertices)")));
        }
    }
    if n > i32::MAX as usize {
        return Err(bad(format!("{n} vertices exceed the int index range")));
    }
    Ok(())
}

/// Writes a PLY file atomically. Positions and extra properties are stored as `float`; faces
/// (if any) as `list uchar int vertex_indices`.
///
/// # Errors
/// [`MeshIoError::BadData`] if a property column's length differs from the vertex count, a
/// property name is empty, has spaces or repeats, or a face index is out of range;
/// [`MeshIoError::Io`] if the file cannot be written.
pub fn write_ply(path: &Path, data: &PlyData, format: PlyFormat) -> Result<(), MeshIoError> {
    check_writable(data, path)?;
    atomic_write(path, |w| {
        let fmt = match format {
            PlyFormat::BinaryLittleEndian => "binary_little_endian",
            PlyFormat::BinaryBigEndian => "binary_big_endian",
            PlyFormat::Ascii => "ascii",
        };
        writeln!(w, "ply\nformat {fmt} 1.0\ncomment written by has")?;
        writeln!(w, "element vertex {}", data.vertices.len())?;
        for axis in ["x", "y", "z"] {
            writeln!(w, "property float {axis}")?;
        }
        for (name, _) in &data.properties {
            writeln!(w, "property float {name}")?;
        }
        if !data.faces.is_empty() {
            writeln!(w, "element face {}", data.faces.len())?;
            writeln!(w, "property list uchar int vertex_indices")?;
        }
        writeln!(w, "end_header")?;
        let cols: Vec<&[f32]> = data.properties.iter().map(|(_, v)| v.as_slice()).collect();
        match format {
            PlyFormat::Ascii => {
                for (i, v) in data.vertices.iter().enumerate() {
                    write!(w, "{} {} {}", v.x, v.y, v.z)?;
                    for c in &cols {
                        write!(w, " {}", c[i])?;
                    }
                    writeln!(w)?;
                }
                for f in &data.faces {
                    writeln!(w, "3 {} {} {}", f[0], f[1], f[2])?;
                }
            }
            PlyFormat::BinaryLittleEndian | PlyFormat::BinaryBigEndian => {
                let big = format == PlyFormat::BinaryBigEndian;
                let f32b = |x: f32| {
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                };
                let i32b = |x: u32| {
                    let x = x as i32;
                    if big {
                        x.to_be_bytes()
                    } else {
                        x.to_le_bytes()
                    }
                };
                for (i, v) in data.vertices.iter().enumerate() {
                    w.write_all(&f32b(v.x))?;
                    w.write_all(&f32b(v.y))?;
                    w.write_all(&f32b(v.z))?;
                    for c in &cols {
                        w.write_all(&f32b(c[i]))?;
                    }
                }
                for f in &data.faces {
                    w.write_all(&[3])?;
                    for &k in f {
                        w.write_all(&i32b(k))?;
                    }
                }
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::testutil::tmp_dir;

    fn sample() -> PlyData {
        PlyData {
            vertices: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.5, 0.0, -2.25),
                Vec3::new(0.1, 0.7, 3.0e-7),
                Vec3::new(-1e4, 2.0, 0.333),
            ],
            properties: vec![
                ("intensity".into(), vec![1.0, 0.5, 0.25, 1e-9]),
                ("pair".into(), vec![0.0, 1.0, 2.0, 5.0]),
            ],
            faces: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn every_format_round_trips_exactly() {
        let d = tmp_dir("ply-rt");
        for fmt in [
            PlyFormat::BinaryLittleEndian,
            PlyFormat::BinaryBigEndian,
            PlyFormat::Ascii,
        ] {
            let p = d.join(format!("{fmt:?}.ply"));
            write_ply(&p, &sample(), fmt).unwrap();
            // f32 → shortest decimal → f32 is exact, and binary is bit-exact.
            assert_eq!(read_ply(&p).unwrap(), sample(), "{fmt:?}");
            // Point cloud: no face element at all (another file: the one just read is an
            // input of this process, which the writers refuse to overwrite).
            let mut cloud = sample();
            cloud.faces.clear();
            let c = d.join(format!("{fmt:?}-cloud.ply"));
            write_ply(&c, &cloud, fmt).unwrap();
            let text = std::fs::read(&c).unwrap();
            assert!(!String::from_utf8_lossy(&text).contains("element face"));
            let back = read_ply(&c).unwrap();
            assert_eq!(back, cloud);
            assert_eq!(back.property("intensity").unwrap()[1], 0.5);
        }
    }

    #[test]
    fn reads_foreign_layouts_quads_doubles_and_extra_elements() {
        // Hand-written ASCII file: double coordinates, normals, a uchar colour, a quad, the
        // `vertex_index` spelling, a uint count type, an extra element, comments, CRLF.
        let text = "ply\r\nformat ascii 1.0\r\ncomment hi\r\nelement vertex 4\r\n\
            property double x\r\nproperty double y\r\nproperty double z\r\n\
            property float nx\r\nproperty uchar red\r\n\
            element face 1\r\nproperty list uint int vertex_index\r\nproperty int flags\r\n\
            element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\n\
            end_header\r\n\
            0 0 0 0 255\r\n1 0 0 0 1\r\n1 1 0 0 2\r\n0 1 0 1 3\r\n4 0 1 2 3 7\r\n0 1\r\n";
        let d = parse_ply(text.as_bytes(), Path::new("q.ply")).unwrap();
        assert_eq!(d.faces, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(d.property("red").unwrap(), &[255.0, 1.0, 2.0, 3.0]);
        assert_eq!(d.property("nx").unwrap()[3], 1.0);
        // The same data in big-endian binary with short/ushort/char types.
        let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty short x\n\
            property ushort y\nproperty char z\nelement face 1\n\
            property list uchar ushort vertex_indices\nend_header\n"
            .to_vec();
        for (x, y, z) in [(-2i16, 3u16, -1i8), (4, 0, 0), (0, 9, 5)] {
            b.extend(x.to_be_bytes());
            b.extend(y.to_be_bytes());
            b.push(z as u8);
        }
        b.push(3);
        for i in [2u16, 1, 0] {
            b.extend(i.to_be_bytes());
        }
        let d = parse_ply(&b, Path::new("b.ply")).unwrap();
        assert_eq!(d.vertices[0], Vec3::new(-2.0, 3.0, -1.0));
        assert_eq!(d.faces, vec![[2, 1, 0]]);
    }

    #[test]
    fn malformed_files_are_errors_naming_line_element_and_value() {
        let p = Path::new("bad.ply");
        let hdr = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                   property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                   end_header\n";
        let cases: Vec<(String, &str)> = vec![
            ("plx\n".into(), "not a PLY"),
            ("ply\nformat ascii 1.0\nelement vertex 1\n".into(), "no 'end_header'"),
            ("ply\nformat zip 1.0\nend_header\n".into(), "unknown format 'zip'"),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty flt x\nend_header\n".into(),
                "unknown property type 'flt'",
            ),
            (format!("{hdr}0 0 0\n1 1 q\n3 0 1 1\n"), "bad.ply:11: element 'vertex' #1: property 'z': 'q'"),
            (format!("{hdr}0 0 0\n1 1 1\n3 0 1 2\n"), "vertex index 2 out of range"),
            (format!("{hdr}0 0 0\n1 1 1\n"), "file ends at element 'face' #0"),
            (format!("{hdr}0 0 0\n1 1 1\n2 0 1\n"), "face has 2 vertices"),
            (format!("{hdr}0 nan 0\n1 1 1\n3 0 1 1\n"), "vertex #0: field 'y' is not finite"),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float z\nend_header\n0 0\n".into(),
                "no scalar property 'y'",
            ),
        ];
        for (text, want) in cases {
            let e = parse_ply(text.as_bytes(), p).unwrap_err().to_string();
            assert!(e.contains(want), "expected '{want}' in '{e}'");
            assert!(e.contains("bad.ply"), "{e}");
        }
        // Truncated binary body.
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n\
            property float y\nproperty float z\nend_header\n"
            .to_vec();
        b.extend([0u8; 16]);
        let e = parse_ply(&b, p).unwrap_err().to_string();
        assert!(e.contains("element 'vertex' #1: file ends"), "{e}");
        // Missing file.
        let e = read_ply(Path::new("/nonexistent/x.ply"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/x.ply"), "{e}");
    }

    #[test]
    fn writer_rejects_inconsistent_data() {
        let d = tmp_dir("ply-bad");
        let p = d.join("x.ply");
        let mut s = sample();
        s.properties[0].1.pop();
        let e = write_ply(&p, &s, PlyFormat::Ascii).unwrap_err().to_string();
        assert!(e.contains("'intensity' has 3 values for 4 vertices"), "{e}");
        let mut s = sample();
        s.faces.push([0, 1, 9]);
        let e = write_ply(&p, &s, PlyFormat::Ascii).unwrap_err().to_string();
        assert!(e.contains("face 2 refers to vertex 9"), "{e}");
        let s = sample().with_property("x", vec![0.0; 4]);
        let e = write_ply(&p, &s, PlyFormat::Ascii).unwrap_err().to_string();
        assert!(e.contains("'x' is given twice"), "{e}");
        assert!(!p.exists());
    }

    #[test]
    fn a_header_declaring_more_elements_than_the_body_holds_is_an_error_not_an_allocation() {
        // 4·10⁹ vertices (48 GB as f32 triples) declared in a 150-byte file: before, the reader
        // reserved the declared count and the process aborted.
        let d = tmp_dir("ply-huge");
        for (fmt, body) in [
            ("binary_little_endian", &[0u8; 24][..]),
            ("ascii", &b"1 2 3\n4 5 6\n"[..]),
        ] {
            let p = d.join(format!("{fmt}.ply"));
            let mut bytes = format!(
                "ply\nformat {fmt} 1.0\nelement vertex 4000000000\nproperty float x\n\
                 property float y\nproperty float z\nend_header\n"
            )
            .into_bytes();
            bytes.extend_from_slice(body);
            std::fs::write(&p, bytes).unwrap();
            let e = read_ply(&p).unwrap_err().to_string();
            assert!(e.contains("vertex"), "{fmt}: {e}");
            assert_eq!(e.lines().count(), 1, "{fmt}: {e}");
        }
    }

    #[test]
    fn an_element_without_properties_is_refused_at_once() {
        // Its instances take no byte of a binary body: 2⁶⁴ − 1 of them in a 150-byte file kept
        // the reader looping without end.
        for fmt in ["binary_little_endian", "ascii"] {
            let mut bytes = format!(
                "ply\nformat {fmt} 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nelement junk 18446744073709551615\nend_header\n"
            )
            .into_bytes();
            bytes.extend_from_slice(if fmt == "ascii" {
                b"0 0 0\n"
            } else {
                &[0u8; 12]
            });
            let t0 = std::time::Instant::now();
            let e = parse_ply(&bytes, Path::new("junk.ply"))
                .unwrap_err()
                .to_string();
            assert!(t0.elapsed().as_secs_f64() < 1.0, "{fmt}");
            assert!(
                e.contains("junk.ply") && e.contains("element 'junk'") && e.contains("no property"),
                "{fmt}: {e}"
            );
        }
        // An empty element without properties is harmless.
        let ok = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                   property float z\nelement junk 0\nend_header\n1 2 3\n";
        assert_eq!(
            parse_ply(ok, Path::new("ok.ply")).unwrap().vertices.len(),
            1
        );
    }

    #[test]
    fn append_triangles_shares_identical_vertices() {
        let mut d = PlyData::default();
        let (a, b, c, e) = (Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE);
        d.append_triangles(&[[a, b, c], [b, e, c]]);
        assert_eq!(d.vertices.len(), 4);
        assert_eq!(d.triangles(), vec![[a, b, c], [b, e, c]]);
    }
}
