//! Mitsuba 3 XML scenes as Sionna RT writes and reads them: `<shape>` elements referencing PLY
//! or OBJ meshes, with radio materials given by `<bsdf>` elements.
//!
//! Materials, both Sionna generations:
//! - Sionna ≥ 1.0: `<bsdf type="itu-radio-material" id="..."><string name="type"
//!   value="concrete"/>...</bsdf>` — the `type` string names the ITU material;
//! - Sionna 0.x (Blender exports): `<bsdf type="twosided" id="mat-itu_concrete">` with a visual
//!   `diffuse` inside — the material comes from the id (`mat-` and `itu_` prefixes optional).
//!
//! Thickness: each radio material reflects as a slab of its `<float name="thickness">` (metres;
//! `inf` for an infinitely thick material, the half-space), [`SIONNA_DEFAULT_THICKNESS_M`] when
//! it gives none or is a legacy material — what Sionna RT does with the same file
//! ([`crate::propagation::slab_coefficients`]).
//!
//! A custom `radio-material` (εr, σ given directly) is not one of the ITU materials and is
//! reported as unsupported. Shapes: `ply` and `obj` (filename relative to the XML file's
//! directory), `rectangle` (the square [−1, 1]² in z = 0, facing +z) and `cube` ([−1, 1]³), each
//! with an optional `<transform name="to_world">` of `translate`, `scale`, `rotate` (degrees) and
//! `matrix` steps applied in order, `flip_normals`, and the material as `<ref id="..."/>` or an
//! inline `<bsdf>`. Object names are the shape ids without a `mesh-` prefix (the file stem if
//! there is no id). Materials are resolved only for shapes that use them.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec3, Vec3};
use roxmltree::{Document, Node};

use super::obj::{material_from_tag, read_obj};
use super::ply::read_ply;
use super::{read_bytes, MeshIoError};
use crate::material::Material;
use crate::scene::Object;
use crate::shapes;

/// The thickness Sionna RT gives a radio material that states none (`sionna.rt.constants.
/// DEFAULT_THICKNESS`), metres.
pub const SIONNA_DEFAULT_THICKNESS_M: f64 = 0.1;

/// Reads a Mitsuba XML scene and the meshes it references.
pub fn read_mitsuba(path: &Path) -> Result<Vec<Object>, MeshIoError> {
    let bytes = read_bytes(path)?;
    let text = String::from_utf8(bytes).map_err(|e| MeshIoError::Xml {
        path: path.to_path_buf(),
        line: 1,
        msg: format!("not UTF-8 text: {e}"),
    })?;
    parse_mitsuba(&text, path)
}

struct Ctx<'a, 'input> {
    doc: &'a Document<'input>,
    path: &'a Path,
}

impl Ctx<'_, '_> {
    fn line(&self, n: Node) -> u32 {
        self.doc.text_pos_at(n.range().start).row
    }

    fn err(&self, n: Node, msg: String) -> MeshIoError {
        MeshIoError::Xml {
            path: self.path.to_path_buf(),
            line: self.line(n),
            msg,
        }
    }

    fn attr<'a>(&self, n: Node<'a, '_>, name: &str) -> Result<&'a str, MeshIoError> {
        n.attribute(name).ok_or_else(|| {
            self.err(
                n,
                format!("<{}> lacks attribute '{name}'", n.tag_name().name()),
            )
        })
    }

    fn num(&self, n: Node, attr: &str, s: &str) -> Result<f64, MeshIoError> {
        let v: f64 = s.trim().parse().map_err(|_| {
            self.err(
                n,
                format!("<{}> {attr}: '{s}' is not a number", n.tag_name().name()),
            )
        })?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(
                n,
                format!("<{}> {attr}: '{s}' is not finite", n.tag_name().name()),
            ))
        }
    }

    /// `value="a b c"` or `x=".." y=".." z=".."` (missing components default to `default`).
    fn vec3(&self, n: Node, default: f64) -> Result<DVec3, MeshIoError> {
        if let Some(v) = n.attribute("value") {
            let parts: Vec<&str> = v.split([' ', ',']).filter(|s| !s.is_empty()).collect();
            return match parts.len() {
                1 => Ok(DVec3::splat(self.num(n, "value", parts[0])?)),
                3 => Ok(DVec3::new(
                    self.num(n, "value", parts[0])?,
                    self.num(n, "value", parts[1])?,
                    self.num(n, "value", parts[2])?,
                )),
                _ => Err(self.err(n, format!("value '{v}' is not 1 or 3 numbers"))),
            };
        }
        let c = |a: &str| -> Result<f64, MeshIoError> {
            n.attribute(a)
                .map(|s| self.num(n, a, s))
                .unwrap_or(Ok(default))
        };
        Ok(DVec3::new(c("x")?, c("y")?, c("z")?))
    }

    fn transform(&self, t: Node) -> Result<DMat4, MeshIoError> {
        let mut m = DMat4::IDENTITY;
        for step in t.children().filter(Node::is_element) {
            let s = match step.tag_name().name() {
                "translate" => DMat4::from_translation(self.vec3(step, 0.0)?),
                "scale" => DMat4::from_scale(self.vec3(step, 1.0)?),
                "rotate" => {
                    let axis = self.vec3(step, 0.0)?;
                    let angle = self.num(step, "angle", self.attr(step, "angle")?)?;
                    if axis.length_squared() == 0.0 {
                        return Err(self.err(step, "<rotate> has a zero axis".into()));
                    }
                    DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.attr(step, "value")?;
                    let nums = v
                        .split([' ', ','])
                        .filter(|s| !s.is_empty())
                        .map(|s| self.num(step, "value", s))
                        .collect::<Result<Vec<_>, _>>()?;
                    if nums.len() != 16 {
                        return Err(self.err(
                            step,
                            format!("<matrix> has {} numbers, expected 16", nums.len()),
                        ));
                    }
                    // Mitsuba lists the matrix row by row.
                    let mut a = [0.0; 16];
                    a.copy_from_slice(&nums);
                    DMat4::from_cols_array(&a).transpose()
                }
                other => {
                    return Err(MeshIoError::Unsupported {
                        path: self.path.to_path_buf(),
                        what: format!("transform step <{other}> at line {}", self.line(step)),
                    })
                }
            };
            m = s * m;
        }
        Ok(m)
    }

    /// The named child property (`<string name=".." value=".."/>`, `<boolean ...>`).
    fn prop<'a>(&self, n: Node<'a, '_>, tag: &str, name: &str) -> Option<&'a str> {
        n.children()
            .find(|c| c.has_tag_name(tag) && c.attribute("name") == Some(name))
            .and_then(|c| c.attribute("value"))
    }

    /// A bsdf's material and thickness (metres; `None`: infinitely thick, the half-space).
    fn bsdf_material(
        &self,
        b: Node,
        id: Option<&str>,
    ) -> Result<(Material, Option<f64>), MeshIoError> {
        let ty = b.attribute("type").unwrap_or("");
        let id = b.attribute("id").or(id);
        let label = id.unwrap_or("(inline)");
        match ty {
            "itu-radio-material" => {
                let v = self.prop(b, "string", "type").ok_or_else(|| {
                    self.err(b, format!("bsdf '{label}' lacks <string name=\"type\">"))
                })?;
                let material = material_from_tag(v).ok_or_else(|| {
                    MeshIoError::unknown_material(
                        self.path,
                        v,
                        format!("bsdf '{label}', line {}", self.line(b)),
                    )
                })?;
                Ok((material, self.thickness(b, label)?))
            }
            "radio-material" => Err(MeshIoError::Unsupported {
                path: self.path.to_path_buf(),
                what: format!(
                    "custom radio-material '{label}' at line {} (only ITU materials are supported)",
                    self.line(b)
                ),
            }),
            _ => {
                if let Some(inner) = b.children().find(|c| {
                    c.has_tag_name("bsdf")
                        && matches!(
                            c.attribute("type"),
                            Some("itu-radio-material") | Some("radio-material")
                        )
                }) {
                    return self.bsdf_material(inner, id);
                }
                let Some(id) = id else {
                    return Err(self.err(
                        b,
                        format!("bsdf of type '{ty}' has no id naming a material"),
                    ));
                };
                let material = material_from_tag(id).ok_or_else(|| {
                    MeshIoError::unknown_material(
                        self.path,
                        id,
                        format!("bsdf id, line {}", self.line(b)),
                    )
                })?;
                // Sionna gives a legacy material its default thickness.
                Ok((material, Some(SIONNA_DEFAULT_THICKNESS_M)))
            }
        }
    }

    /// `<float name="thickness">` of an ITU radio material: positive metres, `inf` for the
    /// half-space; absent, Sionna's default.
    fn thickness(&self, b: Node, label: &str) -> Result<Option<f64>, MeshIoError> {
        let Some(t) = b
            .children()
            .find(|c| c.has_tag_name("float") && c.attribute("name") == Some("thickness"))
        else {
            return Ok(Some(SIONNA_DEFAULT_THICKNESS_M));
        };
        let text = self.attr(t, "value")?;
        match text.trim().parse::<f64>() {
            Ok(d) if d == f64::INFINITY => Ok(None),
            Ok(d) if d > 0.0 && d.is_finite() => Ok(Some(d)),
            _ => Err(self.err(
                t,
                format!(
                    "bsdf '{label}' thickness: '{text}' is not a positive number of metres \
                     (or inf for an infinitely thick material)"
                ),
            )),
        }
    }
}

/// Parses Mitsuba XML text; referenced files are resolved against `path`'s directory.
pub fn parse_mitsuba(text: &str, path: &Path) -> Result<Vec<Object>, MeshIoError> {
    let doc = Document::parse(text).map_err(|e| MeshIoError::Xml {
        path: path.to_path_buf(),
        line: e.pos().row,
        msg: e.to_string(),
    })?;
    let cx = Ctx { doc: &doc, path };
    let root = doc.root_element();
    if !root.has_tag_name("scene") {
        return Err(cx.err(
            root,
            format!(
                "root element is <{}>, expected <scene>",
                root.tag_name().name()
            ),
        ));
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    let bsdfs: HashMap<&str, Node> = root
        .children()
        .filter(|c| c.has_tag_name("bsdf"))
        .filter_map(|c| c.attribute("id").map(|id| (id, c)))
        .collect();
    let mut objects: Vec<Object> = Vec::new();
    for shape in root.children().filter(|c| c.has_tag_name("shape")) {
        let ty = cx.attr(shape, "type")?;
        let line = cx.line(shape);
        // Material: a reference or an inline bsdf.
        let (material, thickness_m) =
            if let Some(r) = shape.children().find(|c| c.has_tag_name("ref")) {
                let id = cx.attr(r, "id")?;
                let b = bsdfs
                    .get(id)
                    .ok_or_else(|| cx.err(r, format!("shape refers to undefined bsdf '{id}'")))?;
                cx.bsdf_material(*b, None)?
            } else if let Some(b) = shape.children().find(|c| c.has_tag_name("bsdf")) {
                cx.bsdf_material(b, None)?
            } else {
                return Err(cx.err(shape, "shape has no material (<ref> or <bsdf>)".into()));
            };
        let filename = cx.prop(shape, "string", "filename");
        let (default_name, mut tris) = match ty {
            "ply" | "obj" => {
                let f = filename.ok_or_else(|| {
                    cx.err(
                        shape,
                        format!("{ty} shape lacks <string name=\"filename\">"),
                    )
                })?;
                let file = dir.join(f);
                let read = || -> Result<Vec<[Vec3; 3]>, MeshIoError> {
                    Ok(if ty == "ply" {
                        read_ply(&file)?.triangles()
                    } else {
                        read_obj(&file, Some(material))?
                            .into_iter()
                            .flat_map(|o| o.triangles)
                            .collect()
                    })
                };
                // The XML file and the shape that names the mesh, with the mesh's own error.
                let tris = read().map_err(|e| {
                    let id = shape.attribute("id").unwrap_or("(no id)");
                    cx.err(shape, format!("shape '{id}': {e}"))
                })?;
                (super::file_stem(&file), tris)
            }
            "rectangle" => {
                let g = shapes::ground(
                    "rectangle",
                    material,
                    glam::Vec2::splat(-1.0),
                    glam::Vec2::splat(1.0),
                    0.0,
                    (1, 1),
                )
                .expect("unit square is valid");
                ("rectangle".to_string(), g.triangles)
            }
            "cube" => {
                let c = shapes::axis_box("cube", material, Vec3::splat(-1.0), Vec3::splat(1.0))
                    .expect("unit cube is valid");
                ("cube".to_string(), c.triangles)
            }
            other => {
                return Err(MeshIoError::Unsupported {
                    path: path.to_path_buf(),
                    what: format!("shape type '{other}' at line {line}"),
                })
            }
        };
        if let Some(t) = shape
            .children()
            .find(|c| c.has_tag_name("transform") && c.attribute("name") == Some("to_world"))
        {
            let m = cx.transform(t)?;
            let mirror = m.determinant() < 0.0;
            for tri in &mut tris {
                for v in tri.iter_mut() {
                    *v = m.transform_point3(v.as_dvec3()).as_vec3();
                }
                if mirror {
                    tri.swap(1, 2);
                }
            }
        }
        if let Some(v) = cx.prop(shape, "boolean", "flip_normals") {
            if v == "true" {
                for tri in &mut tris {
                    tri.swap(1, 2);
                }
            }
        }
        let base = shape
            .attribute("id")
            .map(|id| id.strip_prefix("mesh-").unwrap_or(id).to_string())
            .unwrap_or(default_name);
        let mut name = base.clone();
        let mut k = 1;
        while objects.iter().any(|o| o.name == name) {
            k += 1;
            name = format!("{base}#{k}");
        }
        objects.push(Object {
            thickness_m,
            name,
            material,
            triangles: tris,
        });
    }
    if objects.is_empty() {
        return Err(MeshIoError::Xml {
            path: path.to_path_buf(),
            line: cx.line(root),
            msg: "scene has no <shape>".into(),
        });
    }
    Ok(objects)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ply::{write_ply, PlyData, PlyFormat};
    use crate::io::testutil::tmp_dir;
    use crate::shapes::{signed_volume, surface_area};

    fn write_tri_ply(dir: &Path, name: &str) {
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        let mut d = PlyData::default();
        d.append_triangles(&[[Vec3::ZERO, Vec3::X, Vec3::Y]]);
        write_ply(
            &dir.join("meshes").join(name),
            &d,
            PlyFormat::BinaryLittleEndian,
        )
        .unwrap();
    }

    #[test]
    fn both_sionna_material_styles_and_transforms_load() {
        let d = tmp_dir("mitsuba-ok");
        write_tri_ply(&d, "a.ply");
        let xml = r#"<scene version="2.1.0">
  <bsdf type="twosided" id="mat-itu_brick"><bsdf type="diffuse"/></bsdf>
  <bsdf type="itu-radio-material" id="walls">
    <string name="type" value="concrete"/><float name="thickness" value="0.2"/>
  </bsdf>
  <shape type="ply" id="mesh-a">
    <string name="filename" value="meshes/a.ply"/>
    <boolean name="face_normals" value="true"/>
    <ref id="mat-itu_brick" name="bsdf"/>
  </shape>
  <shape type="ply" id="mesh-a">
    <string name="filename" value="meshes/a.ply"/>
    <ref id="walls"/>
    <transform name="to_world">
      <scale value="2"/><rotate z="1" angle="90"/><translate x="10" y="0" z="5"/>
    </transform>
  </shape>
  <shape type="cube">
    <bsdf type="itu-radio-material"><string name="type" value="itu_metal"/></bsdf>
    <transform name="to_world"><scale x="2" y="3" z="4"/></transform>
  </shape>
</scene>"#;
        let p = d.join("s.xml");
        std::fs::write(&p, xml).unwrap();
        let objs = read_mitsuba(&p).unwrap();
        assert_eq!(objs.len(), 3);
        assert_eq!(objs[0].name, "a");
        assert_eq!(objs[0].material, Material::Brick);
        assert_eq!(objs[1].name, "a#2");
        assert_eq!(objs[1].material, Material::Concrete);
        // (1,0,0) → scale 2 → (2,0,0) → rotate 90° about z → (0,2,0) → translate → (10,2,5).
        let v = objs[1].triangles[0][1];
        assert!((v - Vec3::new(10.0, 2.0, 5.0)).length() < 1e-5, "{v}");
        assert_eq!(objs[2].material, Material::Metal);
        // Thickness as given (0.2 m), else Sionna's default, legacy materials included.
        assert_eq!(objs[0].thickness_m, Some(SIONNA_DEFAULT_THICKNESS_M));
        assert_eq!(objs[1].thickness_m, Some(0.2));
        assert_eq!(objs[2].thickness_m, Some(SIONNA_DEFAULT_THICKNESS_M));
        // Cube [−1,1]³ scaled by (2,3,4): volume 8·24 = 192, still outward.
        let vol = signed_volume(&objs[2].triangles);
        assert!((vol - 192.0).abs() < 1e-3, "{vol}");
        assert!((surface_area(&objs[2].triangles) - 8.0 * (6.0 + 8.0 + 12.0)).abs() < 1e-3);
    }

    #[test]
    fn an_infinite_thickness_is_the_half_space() {
        let d = tmp_dir("mitsuba-inf");
        write_tri_ply(&d, "a.ply");
        let xml = r#"<scene><bsdf type="itu-radio-material" id="g"><string name="type" value="glass"/>
  <float name="thickness" value="inf"/></bsdf>
  <shape type="ply"><string name="filename" value="meshes/a.ply"/><ref id="g"/></shape></scene>"#;
        let p = d.join("s.xml");
        std::fs::write(&p, xml).unwrap();
        assert_eq!(read_mitsuba(&p).unwrap()[0].thickness_m, None);
    }

    #[test]
    fn bad_mitsuba_input_is_an_error_naming_what_and_where() {
        let d = tmp_dir("mitsuba-bad");
        write_tri_ply(&d, "a.ply");
        let shape = |mat: &str, file: &str| {
            format!("<shape type=\"ply\"><string name=\"filename\" value=\"{file}\"/>{mat}</shape>")
        };
        let cases = [
            ("<scene><shape".to_string(), "s.xml:1:"),
            ("<world/>".to_string(), "expected <scene>"),
            (
                format!(
                    "<scene>\n<bsdf type=\"itu-radio-material\" id=\"m\"><string name=\"type\" value=\"unobtainium\"/></bsdf>\n{}</scene>",
                    shape("<ref id=\"m\"/>", "meshes/a.ply")
                ),
                "unknown material 'unobtainium' (bsdf 'm', line 2)",
            ),
            (
                format!(
                    "<scene><bsdf type=\"twosided\" id=\"mat-itu_cheese\"/>{}</scene>",
                    shape("<ref id=\"mat-itu_cheese\"/>", "meshes/a.ply")
                ),
                "unknown material 'mat-itu_cheese'",
            ),
            (
                format!("<scene>{}</scene>", shape("<ref id=\"nope\"/>", "meshes/a.ply")),
                "undefined bsdf 'nope'",
            ),
            (
                format!(
                    "<scene><bsdf type=\"radio-material\" id=\"c\"/>{}</scene>",
                    shape("<ref id=\"c\"/>", "meshes/a.ply")
                ),
                "custom radio-material 'c'",
            ),
            (
                format!(
                    "<scene><bsdf type=\"twosided\" id=\"mat-itu_wood\"/>{}</scene>",
                    shape("<ref id=\"mat-itu_wood\"/>", "meshes/missing.ply")
                ),
                "meshes/missing.ply",
            ),
            (
                "<scene><shape type=\"sphere\"><bsdf type=\"twosided\" id=\"mat-itu_wood\"/></shape></scene>"
                    .to_string(),
                "shape type 'sphere'",
            ),
            ("<scene/>".to_string(), "no <shape>"),
            (
                format!(
                    "<scene><bsdf type=\"itu-radio-material\" id=\"w\"><string name=\"type\" value=\"wood\"/><float name=\"thickness\" value=\"-0.1\"/></bsdf>{}</scene>",
                    shape("<ref id=\"w\"/>", "meshes/a.ply")
                ),
                "bsdf 'w' thickness: '-0.1' is not a positive number of metres",
            ),
        ];
        for (xml, want) in cases {
            let p = d.join("s.xml");
            std::fs::write(&p, &xml).unwrap();
            let e = read_mitsuba(&p).unwrap_err().to_string();
            assert!(e.contains(want), "expected '{want}' in '{e}'");
        }
    }
}
