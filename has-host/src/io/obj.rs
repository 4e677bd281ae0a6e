//! Wavefront OBJ meshes: `v` vertices, `f` faces (any polygon, fan-triangulated; `i`, `i/t`,
//! `i//n`, `i/t/n` and negative relative indices), `o` / `g` names and `usemtl` materials.
//! Other statements (`vn`, `vt`, `s`, `mtllib`, ...) are ignored.
//!
//! Faces are grouped into one [`Object`] per (name, material) pair, in order of first use; the
//! name is the latest `o` or `g` (the file stem before any), suffixed `.<material>` when one name
//! carries several materials. A `usemtl` name is a material if [`Material::from_name`] accepts it
//! with or without a `mat-` prefix (`concrete`, `itu_concrete`, `mat-itu_concrete`). Written files
//! use `o <name>` and `usemtl itu_<material>` per object and 1-based indices; an indexed mesh
//! ([`write_mesh`]) may carry per-vertex normals (`vn`, faces `f a//a b//b c//c`).

use std::io::Write;
use std::path::Path;

use glam::Vec3;

use super::{atomic_write, file_stem, read_bytes, MeshIoError};
use crate::material::Material;
use crate::mesh::TriMesh;
use crate::scene::Object;

/// A material from an OBJ `usemtl` or Mitsuba id: `concrete`, `itu_concrete`,
/// `mat-itu_concrete` (case-insensitive).
pub fn material_from_tag(tag: &str) -> Option<Material> {
    Material::from_name(tag).or_else(|| {
        let lower = tag.to_ascii_lowercase();
        lower.strip_prefix("mat-").and_then(Material::from_name)
    })
}

/// Reads an OBJ file. `material`, if given, is every object's material and `usemtl` names are
/// only used for grouping; otherwise each group's `usemtl` must name a known material.
pub fn read_obj(path: &Path, material: Option<Material>) -> Result<Vec<Object>, MeshIoError> {
    let bytes = read_bytes(path)?;
    let text = String::from_utf8_lossy(&bytes);
    parse_obj(&text, path, material)
}

/// Parses OBJ text; `path` names the source in errors and gives the default object name.
pub fn parse_obj(
    text: &str,
    path: &Path,
    material: Option<Material>,
) -> Result<Vec<Object>, MeshIoError> {
    struct Group {
        name: String,
        mtl: Option<String>,
        line: usize,
        tris: Vec<[Vec3; 3]>,
    }
    let mut verts: Vec<Vec3> = Vec::new();
    let mut groups: Vec<Group> = Vec::new();
    let mut name = file_stem(path);
    let mut mtl: Option<String> = None;
    let mut current: Option<usize> = None;
    let perr = |line: usize, msg: String| MeshIoError::Parse {
        path: path.to_path_buf(),
        line,
        msg,
    };
    let mut poly: Vec<u32> = Vec::new();
    for (li, raw) in text.lines().enumerate() {
        let line_no = li + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut toks = line.split_whitespace();
        let Some(kw) = toks.next() else { continue };
        match kw {
            "v" => {
                let mut c = [0f32; 3];
                for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
                    let t = toks
                        .next()
                        .ok_or_else(|| perr(line_no, format!("vertex lacks '{axis}': '{line}'")))?;
                    let v: f64 = t.parse().map_err(|_| {
                        perr(line_no, format!("vertex '{axis}': '{t}' is not a number"))
                    })?;
                    if !v.is_finite() {
                        return Err(MeshIoError::NonFinite {
                            path: path.to_path_buf(),
                            element: format!("v (line {line_no})"),
                            index: verts.len(),
                            field: axis.into(),
                            value: v,
                        });
                    }
                    c[k] = v as f32;
                }
                verts.push(Vec3::from_array(c));
            }
            "o" | "g" => {
                let rest = line[kw.len()..].trim();
                if !rest.is_empty() {
                    name = rest.to_string();
                }
                current = None;
            }
            "usemtl" => {
                mtl = Some(line[kw.len()..].trim().to_string());
                current = None;
            }
            "f" => {
                poly.clear();
                for t in toks {
                    let idx = t.split('/').next().unwrap_or("");
                    let i: i64 = idx.parse().map_err(|_| {
                        perr(line_no, format!("face index '{t}' is not an integer"))
                    })?;
                    let n = verts.len() as i64;
                    let abs = if i < 0 { n + i } else { i - 1 };
                    if i == 0 || abs < 0 || abs >= n {
                        return Err(perr(
                            line_no,
                            format!("face index {i} out of range ({n} vertices defined so far)"),
                        ));
                    }
                    poly.push(abs as u32);
                }
                if poly.len() < 3 {
                    return Err(perr(
                        line_no,
                        format!("face has {} vertices (< 3)", poly.len()),
                    ));
                }
                let gi = match current {
                    Some(g) => g,
                    None => {
                        let g = groups
                            .iter()
                            .position(|g| g.name == name && g.mtl == mtl)
                            .unwrap_or_else(|| {
                                groups.push(Group {
                                    name: name.clone(),
                                    mtl: mtl.clone(),
                                    line: line_no,
                                    tris: Vec::new(),
                                });
                                groups.len() - 1
                            });
                        current = Some(g);
                        g
                    }
                };
                let p = |k: usize| verts[poly[k] as usize];
                for k in 1..poly.len() - 1 {
                    groups[gi].tris.push([p(0), p(k), p(k + 1)]);
                }
            }
            _ => {}
        }
    }
    if groups.iter().all(|g| g.tris.is_empty()) {
        return Err(MeshIoError::NoFaces {
            path: path.to_path_buf(),
        });
    }
    let mut objects = Vec::with_capacity(groups.len());
    for g in &groups {
        let m = match material {
            Some(m) => m,
            None => match &g.mtl {
                Some(tag) => material_from_tag(tag).ok_or_else(|| {
                    MeshIoError::unknown_material(
                        path,
                        tag,
                        format!("usemtl of object '{}', line {}", g.name, g.line),
                    )
                })?,
                None => {
                    return Err(MeshIoError::unknown_material(
                        path,
                        "",
                        format!(
                            "object '{}' (line {}) has no usemtl and no material was given",
                            g.name, g.line
                        ),
                    ))
                }
            },
        };
        let shared = groups.iter().filter(|h| h.name == g.name).count() > 1;
        let name = match (&g.mtl, shared) {
            (Some(t), true) => format!("{}.{t}", g.name),
            _ => g.name.clone(),
        };
        objects.push(Object {
            thickness_m: None,
            name,
            material: m,
            triangles: g.tris.clone(),
        });
    }
    Ok(objects)
}

/// The first line of every OBJ file has writes.
const HEADER: &str = "# written by has: metres, z up";

/// Writes objects as OBJ atomically (one `o` and `usemtl itu_<material>` per object; vertices
/// shared within an object where bit-identical).
pub fn write_obj(path: &Path, objects: &[Object]) -> Result<(), MeshIoError> {
    atomic_write(path, |w| {
        writeln!(w, "{HEADER}")?;
        let mut base = 1usize;
        for o in objects {
            let mut data = super::PlyData::default();
            data.append_triangles(&o.triangles);
            write_object(
                w,
                &o.name,
                o.material,
                &data.vertices,
                None,
                &data.faces,
                base,
            )?;
            base += data.vertices.len();
        }
        Ok(())
    })
}

/// Writes an indexed mesh as OBJ atomically: one object `name` of `material`, written straight
/// from its indices (no triangle-soup copy), with per-vertex `normals` as `vn` lines and faces as
/// `f a//a b//b c//c` when given.
///
/// # Errors
/// [`MeshIoError::BadData`] (nothing written) if a face indexes past the vertices, a vertex is
/// not finite or `normals` has another length than the vertices; [`MeshIoError::Io`] if the
/// file cannot be written.
pub fn write_mesh(
    path: &Path,
    mesh: &TriMesh,
    name: &str,
    material: Material,
    normals: Option<&[Vec3]>,
) -> Result<(), MeshIoError> {
    check_mesh(path, mesh)?;
    if let Some(m) = normals.filter(|m| m.len() != mesh.vertices.len()) {
        return Err(MeshIoError::BadData {
            path: path.to_path_buf(),
            msg: format!("{} normals for {} vertices", m.len(), mesh.vertices.len()),
        });
    }
    atomic_write(path, |w| {
        writeln!(w, "{HEADER}")?;
        write_object(w, name, material, &mesh.vertices, normals, &mesh.faces, 1)
    })
}

/// Checks that every face of `mesh` indexes one of its vertices and every vertex is finite;
/// the error names `path`, the file that was to be written.
pub(crate) fn check_mesh(path: &Path, mesh: &TriMesh) -> Result<(), MeshIoError> {
    let bad = |msg: String| MeshIoError::BadData {
        path: path.to_path_buf(),
        msg,
    };
    let n = mesh.vertices.len();
    if let Some((i, f)) = mesh
        .faces
        .iter()
        .enumerate()
        .find(|(_, f)| f.iter().any(|&v| v as usize >= n))
    {
        return Err(bad(format!(
            "mesh face {i} {f:?} indexes past the {n} vertices"
        )));
    }
    if let Some(i) = mesh.vertices.iter().position(|v| !v.is_finite()) {
        return Err(bad(format!(
            "mesh vertex {i} is not finite: {:?}",
            mesh.vertices[i]
        )));
    }
    Ok(())
}

/// One object: `o <name>` (control characters replaced, trimmed), `usemtl itu_<material>`, `v`
/// lines, `vn` lines if `normals` are given, and faces with 1-based indices offset by `base`, the
/// number of vertices written before plus one (`f a b c`, or `f a//a b//b c//c` with normals,
/// which assumes every object of the file has normals).
fn write_object(
    w: &mut impl Write,
    name: &str,
    material: Material,
    vertices: &[Vec3],
    normals: Option<&[Vec3]>,
    faces: &[[u32; 3]],
    base: usize,
) -> std::io::Result<()> {
    let name: String = name
        .chars()
        .map(|c| if c.is_control() { '_' } else { c })
        .collect();
    writeln!(w, "o {}", name.trim())?;
    writeln!(w, "usemtl itu_{}", material.name())?;
    for v in vertices {
        writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
    }
    for n in normals.unwrap_or_default() {
        writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    for f in faces {
        let [a, b, c] = f.map(|i| i as usize + base);
        if normals.is_some() {
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        } else {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_by_name_and_material_and_fans_polygons() {
        let text = "mtllib x.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n# comment\n\
                    o wall\nusemtl itu_brick\nf 1/1/1 2/2/2 3/3/3 4/4/4\n\
                    usemtl mat-itu_glass\nf -4//1 -2//1 -1//1\n\
                    o roof\nusemtl Concrete\nf 1 2 3\n";
        let objs = parse_obj(text, Path::new("m.obj"), None).unwrap();
        let names: Vec<_> = objs.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["wall.itu_brick", "wall.mat-itu_glass", "roof"]);
        assert_eq!(objs[0].material, Material::Brick);
        assert_eq!(objs[1].material, Material::Glass);
        assert_eq!(objs[2].material, Material::Concrete);
        // Quad 1-2-3-4 fans into (1,2,3), (1,3,4).
        assert_eq!(objs[0].triangles.len(), 2);
        assert_eq!(objs[0].triangles[1][2], Vec3::new(0.0, 1.0, 0.0));
        // Negative indices: -4 → v1, -2 → v3, -1 → v4.
        assert_eq!(
            objs[1].triangles[0],
            [
                Vec3::ZERO,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0)
            ]
        );
        // An override replaces materials, grouping stays.
        let objs = parse_obj(text, Path::new("m.obj"), Some(Material::Metal)).unwrap();
        assert!(objs.iter().all(|o| o.material == Material::Metal));
    }

    #[test]
    fn bad_obj_input_is_an_error_naming_line_and_value() {
        let p = Path::new("bad.obj");
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nf 1 2 3\n",
                None,
                "bad.obj:3: face index 3 out of range",
            ),
            ("v 0 0\n", None, "bad.obj:1: vertex lacks 'z'"),
            ("v 0 x 0\n", None, "'x' is not a number"),
            ("v 0 0 nan\n", None, "field 'z' is not finite"),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", None, "face has 2 vertices"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl Material.001\nf 1 2 3\n",
                None,
                "unknown material 'Material.001'",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", None, "no usemtl"),
            // A scenario file or a PLY read as OBJ: every line is skipped, nothing is a mesh.
            (
                "description = \"factory\"\n[scene]\n",
                Some(Material::Concrete),
                "bad.obj: no faces",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n0 0 0\n",
                Some(Material::Concrete),
                "no faces",
            ),
            ("", Some(Material::Concrete), "no faces"),
        ];
        for (text, m, want) in cases {
            let e = parse_obj(text, p, m).unwrap_err().to_string();
            assert!(e.contains(want), "expected '{want}' in '{e}'");
        }
    }
}
