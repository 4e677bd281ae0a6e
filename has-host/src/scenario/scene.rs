//! Scene descriptions in TOML: the `[scene]` table of a scenario file, turned into a [`Scene`].
//!
//! The format is documented field by field in `docs/scenario.md`. In short, a scene is a list of
//! `[[scene.objects]]`, each with a `kind` (`building`, `box`, `ground`, `cylinder`, `mesh`), a
//! unique `name` and a `material` (ITU-R P.2040 name, `concrete` or `itu_concrete`). Lengths are
//! metres, angles degrees, positions in the scene frame (z up). Buildings are placed by their
//! footprint *centre* (`center = [x, y]`, `base_z`), sized `[along local x, along local y, eave
//! height]` and rotated by `yaw_deg` about their centre. Mesh paths are relative to the TOML
//! file's directory.
//!
//! [`SceneSpec`] is meant to be embedded as the `scene` field of a larger scenario struct; every
//! struct here denies unknown fields, so a typo is an error naming the field.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde::{Deserialize, Deserializer, Serialize};

use crate::io::{self, MeshIoError};
use crate::material::Material;
use crate::scene::{Object, Scene, SceneError};
use crate::shapes::{self, Axis, Building, Direction, Roof, ShapeError};

/// The `[scene]` table: the objects of the environment.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Free text shown in reports. Default: empty.
    #[serde(default)]
    pub description: String,
    /// The objects, in order.
    pub objects: Vec<ObjectSpec>,
    /// Directory that relative mesh paths are resolved against: the TOML file's directory for
    /// [`SceneSpec::load`], `.` otherwise (see [`SceneSpec::set_base_dir`]).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// One `[[scene.objects]]` entry, selected by `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ObjectSpec {
    /// A building: walls and a roof on a rectangular footprint, open at the bottom by default.
    Building(BuildingSpec),
    /// A box: a building with a flat roof (unless given) and, by default, a bottom face.
    Box(BuildingSpec),
    /// A horizontal ground rectangle facing up.
    Ground(GroundSpec),
    /// A vertical cylinder (a target), closed by default.
    Cylinder(CylinderSpec),
    /// Objects loaded from an OBJ, PLY or Mitsuba XML file.
    Mesh(MeshSpec),
}

/// Fields of `kind = "building"` and `kind = "box"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BuildingSpec {
    /// Object name, unique in the scene.
    pub name: String,
    /// Radio material (ITU-R P.2040 name).
    #[serde(deserialize_with = "de_material", serialize_with = "ser_material")]
    pub material: Material,
    /// Footprint centre `[x, y]`, metres.
    pub center: [f32; 2],
    /// Height of the base, metres. Default 0.
    #[serde(default)]
    pub base_z: f32,
    /// `[length along local x, width along local y, eave (wall) height]`, metres, all > 0.
    pub size: [f32; 3],
    /// Rotation about the vertical through `center`, degrees, counter-clockwise from above.
    /// Default 0.
    #[serde(default)]
    pub yaw_deg: f32,
    /// Roof above the eaves. Default flat.
    #[serde(default)]
    pub roof: RoofSpec,
    /// Whether to close the bottom. Default false for `building`, true for `box`.
    #[serde(default)]
    pub bottom: Option<bool>,
}

/// `roof = { kind = ..., ... }`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum RoofSpec {
    /// Flat roof at the eaves.
    #[default]
    Flat,
    /// Gable roof.
    Pitched {
        /// Axis the ridge runs along, local `"x"` or `"y"`.
        ridge: AxisName,
        /// Ridge height above the eaves, metres (> 0).
        height: f32,
    },
    /// Sawtooth (north-light) roof.
    Sawtooth {
        /// Number of teeth (≥ 1).
        teeth: u32,
        /// Tooth height above the eaves, metres (> 0).
        height: f32,
        /// Local direction the vertical faces look: `"+x"`, `"-x"`, `"+y"`, `"-y"`.
        facing: DirectionName,
    },
}

/// A local horizontal axis name: `"x"` or `"y"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum AxisName {
    /// Local x.
    #[serde(rename = "x")]
    X,
    /// Local y.
    #[serde(rename = "y")]
    Y,
}

/// A local horizontal direction name: `"+x"`, `"-x"`, `"+y"`, `"-y"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DirectionName {
    /// +x.
    #[serde(rename = "+x")]
    PosX,
    /// −x.
    #[serde(rename = "-x")]
    NegX,
    /// +y.
    #[serde(rename = "+y")]
    PosY,
    /// −y.
    #[serde(rename = "-y")]
    NegY,
}

/// Fields of `kind = "ground"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Object name, unique in the scene.
    pub name: String,
    /// Radio material.
    #[serde(deserialize_with = "de_material", serialize_with = "ser_material")]
    pub material: Material,
    /// Corner `[x, y]` with the smallest coordinates, metres.
    pub min: [f32; 2],
    /// Corner `[x, y]` with the largest coordinates, metres.
    pub max: [f32; 2],
    /// Height, metres. Default 0.
    #[serde(default)]
    pub z: f32,
    /// Cells `[along x, along y]` (two triangles each). Default `[1, 1]`.
    #[serde(default = "default_cells")]
    pub cells: [u32; 2],
}

/// Fields of `kind = "cylinder"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSpec {
    /// Object name, unique in the scene.
    pub name: String,
    /// Radio material.
    #[serde(deserialize_with = "de_material", serialize_with = "ser_material")]
    pub material: Material,
    /// Axis position `[x, y]`, metres.
    pub center: [f32; 2],
    /// Height of the bottom, metres. Default 0.
    #[serde(default)]
    pub base_z: f32,
    /// Radius, metres (> 0).
    pub radius: f32,
    /// Height, metres (> 0).
    pub height: f32,
    /// Sides of the prism approximating the circle (≥ 3). Default 32.
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Whether to close top and bottom. Default true.
    #[serde(default = "default_true")]
    pub caps: bool,
}

/// Fields of `kind = "mesh"`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSpec {
    /// Name for the loaded objects: the object's name if the file holds one, otherwise a prefix
    /// (`name/object`). Default: the names in the file.
    #[serde(default)]
    pub name: Option<String>,
    /// File: `.obj`, `.ply` or `.xml` (Mitsuba / Sionna RT), relative to the TOML file.
    pub path: PathBuf,
    /// Material for every loaded object, overriding the file's. Required for PLY. Default: the
    /// file's materials (OBJ `usemtl`, Mitsuba `bsdf`).
    #[serde(
        default,
        deserialize_with = "de_material_opt",
        serialize_with = "ser_material_opt"
    )]
    pub material: Option<Material>,
    /// Translation `[x, y, z]` applied to the loaded vertices (after `yaw_deg`), metres. Default
    /// `[0, 0, 0]`.
    #[serde(default)]
    pub offset: [f32; 3],
    /// Rotation of the loaded vertices about the file's vertical axis (x = y = 0), degrees
    /// counter-clockwise seen from above, applied before `offset`. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub yaw_deg: f32,
}

impl MeshSpec {
    /// [`SceneSpecError::NotFinite`] naming `offset` or `yaw_deg` of object `index` when not
    /// finite.
    pub fn check_placement(&self, index: usize) -> Result<(), SceneSpecError> {
        let bad = |field, value| SceneSpecError::NotFinite {
            index,
            field,
            value,
        };
        if !self.offset.iter().all(|v| v.is_finite()) {
            return Err(bad("offset", format!("{:?}", self.offset)));
        }
        if !self.yaw_deg.is_finite() {
            return Err(bad("yaw_deg", format!("{}", self.yaw_deg)));
        }
        Ok(())
    }
}

fn is_zero(v: &f32) -> bool {
    *v == 0.0
}

fn default_cells() -> [u32; 2] {
    [1, 1]
}

fn default_segments() -> u32 {
    32
}

fn default_true() -> bool {
    true
}

fn de_material<'de, D: Deserializer<'de>>(d: D) -> Result<Material, D::Error> {
    let s = String::deserialize(d)?;
    Material::from_name(&s).ok_or_else(|| {
        serde::de::Error::custom(format!(
            "unknown material '{s}' (known: {})",
            io::known_material_names()
        ))
    })
}

fn de_material_opt<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Material>, D::Error> {
    de_material(d).map(Some)
}

fn ser_material<S: serde::Serializer>(m: &Material, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(m.name())
}

fn ser_material_opt<S: serde::Serializer>(m: &Option<Material>, s: S) -> Result<S::Ok, S::Error> {
    match m {
        Some(m) => s.serialize_str(m.name()),
        None => s.serialize_none(),
    }
}

/// Why a scene description could not be loaded or built.
#[derive(Debug, thiserror::Error)]
pub enum SceneSpecError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The TOML is malformed or does not match the format (unknown / missing field, wrong
    /// type, unknown material); the message names the field, value and line.
    #[error("{path}: {msg}")]
    Toml {
        /// The file (`<string>` for [`SceneSpec::from_toml_str`]).
        path: PathBuf,
        /// The parser's message.
        msg: String,
    },
    /// An object's parameters are invalid (negative size, NaN, too few segments, ...).
    #[error("scene.objects[{index}]: {source}")]
    Shape {
        /// Index in `scene.objects`.
        index: usize,
        /// The problem, naming object, field and value.
        source: ShapeError,
    },
    /// An object's name is empty or cannot be part of a file name.
    #[error("scene.objects[{index}].name: {name:?} ({expected})")]
    BadName {
        /// Index in `scene.objects`.
        index: usize,
        /// The name.
        name: String,
        /// What a name must be ([`crate::io::guard::check_name_component`]).
        expected: &'static str,
    },
    /// A mesh object's placement is not finite.
    #[error("scene.objects[{index}].{field}: {value} is not finite")]
    NotFinite {
        /// Index in `scene.objects`.
        index: usize,
        /// `offset` or `yaw_deg`.
        field: &'static str,
        /// The value as written.
        value: String,
    },
    /// A mesh file could not be loaded.
    #[error("scene.objects[{index}] (mesh): {source}")]
    Mesh {
        /// Index in `scene.objects`.
        index: usize,
        /// The problem, naming the file.
        source: MeshIoError,
    },
    /// Two objects have the same name.
    #[error("scene.objects[{index}]: name '{name}' is used twice")]
    DuplicateName {
        /// Index of the second use.
        index: usize,
        /// The name.
        name: String,
    },
    /// A mesh or Mitsuba file given directly as the scene could not be loaded.
    #[error(transparent)]
    MeshFile(#[from] MeshIoError),
    /// The scene could not be built (no triangles, non-finite vertex).
    #[error(transparent)]
    Scene(#[from] SceneError),
}

/// Loads the objects of a scene file of any supported kind: a TOML scenario (its `[scene]`
/// table, see [`SceneSpec`]), a Mitsuba XML scene, an OBJ file with `usemtl` materials, or a
/// PLY mesh. `material`, for a mesh file, replaces every object's material (a PLY file has none
/// and needs it); a TOML scene names its own, and is refused with one.
pub fn load_scene_objects(
    path: &Path,
    material: Option<Material>,
) -> Result<Vec<Object>, SceneSpecError> {
    let is_toml = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if is_toml {
        if material.is_some() {
            return Err(SceneSpecError::MeshFile(MeshIoError::Unsupported {
                path: path.to_path_buf(),
                what: "a material for a TOML scene, whose objects name their own".into(),
            }));
        }
        SceneSpec::load(path)?.build_objects()
    } else {
        Ok(io::load_objects(path, material)?)
    }
}

/// [`load_scene_objects`] and build the BVH.
pub fn load_scene(path: &Path, material: Option<Material>) -> Result<Scene, SceneSpecError> {
    Ok(Scene::new(load_scene_objects(path, material)?)?)
}

#[derive(Deserialize)]
struct SceneFile {
    scene: SceneSpec,
}

impl SceneSpec {
    /// Reads the `[scene]` table of a TOML file (other top-level tables, which belong to the
    /// full scenario, are ignored here). Relative mesh paths resolve against the file's directory.
    pub fn load(path: &Path) -> Result<SceneSpec, SceneSpecError> {
        let text = crate::io::guard::read_input_string(path).map_err(|e| SceneSpecError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        let mut spec = Self::parse(&text, path)?;
        spec.base_dir = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        Ok(spec)
    }

    /// Parses TOML text holding a `[scene]` table; mesh paths resolve against `.`.
    pub fn from_toml_str(text: &str) -> Result<SceneSpec, SceneSpecError> {
        let mut spec = Self::parse(text, Path::new("<string>"))?;
        spec.base_dir = PathBuf::from(".");
        Ok(spec)
    }

    fn parse(text: &str, path: &Path) -> Result<SceneSpec, SceneSpecError> {
        toml::from_str::<SceneFile>(text)
            .map(|f| f.scene)
            .map_err(|e| SceneSpecError::Toml {
                path: path.to_path_buf(),
                msg: super::error::one_line_toml_error(text, &e),
            })
    }

    /// Sets the directory relative mesh paths resolve against (for a `SceneSpec` deserialized
    /// as part of a larger file).
    pub fn set_base_dir(&mut self, dir: impl Into<PathBuf>) {
        self.base_dir = dir.into();
    }

    /// Generates (and loads) every object, in order, checking names are unique.
    pub fn build_objects(&self) -> Result<Vec<Object>, SceneSpecError> {
        let mut out: Vec<Object> = Vec::new();
        for (index, spec) in self.objects.iter().enumerate() {
            let given = match spec {
                ObjectSpec::Building(b) | ObjectSpec::Box(b) => Some(&b.name),
                ObjectSpec::Ground(g) => Some(&g.name),
                ObjectSpec::Cylinder(c) => Some(&c.name),
                ObjectSpec::Mesh(m) => m.name.as_ref(),
            };
            if let Some(name) = given {
                crate::io::guard::check_name_component(name).map_err(|expected| {
                    SceneSpecError::BadName {
                        index,
                        name: name.clone(),
                        expected,
                    }
                })?;
            }
            let shape_err = |source| SceneSpecError::Shape { index, source };
            let new: Vec<Object> = match spec {
                ObjectSpec::Building(b) => vec![build_building(b, false).map_err(shape_err)?],
                ObjectSpec::Box(b) => vec![build_building(b, true).map_err(shape_err)?],
                ObjectSpec::Ground(g) => vec![shapes::ground(
                    g.name.clone(),
                    g.material,
                    Vec2::from_array(g.min),
                    Vec2::from_array(g.max),
                    g.z,
                    (g.cells[0], g.cells[1]),
                )
                .map_err(shape_err)?],
                ObjectSpec::Cylinder(c) => vec![shapes::cylinder(
                    c.name.clone(),
                    c.material,
                    Vec3::new(c.center[0], c.center[1], c.base_z),
                    c.radius,
                    c.height,
                    c.segments,
                    c.caps,
                )
                .map_err(shape_err)?],
                ObjectSpec::Mesh(m) => {
                    let mesh_err = |source| SceneSpecError::Mesh { index, source };
                    m.check_placement(index)?;
                    let offset = Vec3::from_array(m.offset);
                    let path = self.base_dir.join(&m.path);
                    let mut objs = io::load_objects(&path, m.material).map_err(mesh_err)?;
                    let single = objs.len() == 1;
                    for o in &mut objs {
                        if m.yaw_deg != 0.0 {
                            shapes::rotate_z(o, (m.yaw_deg as f64).to_radians());
                        }
                        shapes::translate(o, offset);
                        if let Some(n) = &m.name {
                            o.name = if single {
                                n.clone()
                            } else {
                                format!("{n}/{}", o.name)
                            };
                        }
                    }
                    objs
                }
            };
            for o in new {
                if out.iter().any(|p| p.name == o.name) {
                    return Err(SceneSpecError::DuplicateName {
                        index,
                        name: o.name,
                    });
                }
                out.push(o);
            }
        }
        Ok(out)
    }

    /// Builds the scene (objects and BVH).
    pub fn build(&self) -> Result<Scene, SceneSpecError> {
        Ok(Scene::new(self.build_objects()?)?)
    }
}

fn build_building(b: &BuildingSpec, is_box: bool) -> Result<Object, ShapeError> {
    let roof = match b.roof {
        RoofSpec::Flat => Roof::Flat,
        RoofSpec::Pitched { ridge, height } => Roof::Pitched {
            ridge: match ridge {
                AxisName::X => Axis::X,
                AxisName::Y => Axis::Y,
            },
            height,
        },
        RoofSpec::Sawtooth {
            teeth,
            height,
            facing,
        } => Roof::Sawtooth {
            teeth,
            height,
            facing: match facing {
                DirectionName::PosX => Direction::PosX,
                DirectionName::NegX => Direction::NegX,
                DirectionName::PosY => Direction::PosY,
                DirectionName::NegY => Direction::NegY,
            },
        },
    };
    shapes::building(
        b.name.clone(),
        b.material,
        &Building {
            base_center: Vec3::new(b.center[0], b.center[1], b.base_z),
            size: Vec3::from_array(b.size),
            yaw_rad: b.yaw_deg.to_radians(),
            roof,
            bottom: b.bottom.unwrap_or(is_box),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::signed_volume;

    const GOOD: &str = r#"
[scene]
description = "test"

[[scene.objects]]
kind = "ground"
name = "ground"
material = "medium_dry_ground"
min = [-50.0, -50.0]
max = [50.0, 50.0]

[[scene.objects]]
kind = "building"
name = "hall"
material = "itu_concrete"
center = [0.0, 0.0]
size = [20.0, 10.0, 6.0]
yaw_deg = 30.0
roof = { kind = "sawtooth", teeth = 4, height = 2.0, facing = "-y" }

[[scene.objects]]
kind = "box"
name = "crate"
material = "wood"
center = [30.0, 0.0]
size = [2.0, 2.0, 2.0]

[[scene.objects]]
kind = "cylinder"
name = "target"
material = "metal"
center = [-20.0, 10.0]
radius = 3.0
height = 3.0
"#;

    #[test]
    fn toml_scene_builds_with_the_documented_defaults() {
        let spec = SceneSpec::from_toml_str(GOOD).unwrap();
        assert_eq!(spec.objects.len(), 4);
        let objs = spec.build_objects().unwrap();
        let names: Vec<_> = objs.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["ground", "hall", "crate", "target"]);
        assert_eq!(objs[1].material, Material::Concrete);
        // Box defaults to closed: volume 8 m³; cylinder defaults to 32 segments with caps.
        assert!((signed_volume(&objs[2].triangles) - 8.0).abs() < 1e-4);
        assert_eq!(objs[3].triangles.len(), 4 * 32);
        // Building defaults to open bottom: no face lies entirely at z = 0.
        assert!(objs[1]
            .triangles
            .iter()
            .all(|t| t.iter().any(|v| v.z > 0.0)));
        let scene = spec.build().unwrap();
        assert!(scene.triangle_count() > 100);
        // Round trip through serialization keeps the spec.
        let text = toml::to_string(&SceneFileOut { scene: &spec }).unwrap();
        let back = SceneSpec::from_toml_str(&text).unwrap();
        assert_eq!(back, spec);
    }

    #[derive(Serialize)]
    struct SceneFileOut<'a> {
        scene: &'a SceneSpec,
    }

    #[test]
    fn bad_scene_input_is_an_error_naming_field_and_value() {
        let one = |body: &str| format!("[scene]\n[[scene.objects]]\n{body}\n");
        let bld =
            "kind = \"building\"\nname = \"b\"\nmaterial = \"concrete\"\ncenter = [0.0, 0.0]\n";
        let cases: Vec<(String, &str)> = vec![
            (one(&format!("{bld}size = [1.0, 1.0, 1.0]\ncolour = 3")), "unknown field `colour`"),
            (one("kind = \"building\"\nname = \"b\"\nmaterial = \"concrete\"\nsize = [1.0, 1.0, 1.0]"), "missing field `center`"),
            (one(&format!("{bld}size = [1.0, -4.0, 1.0]")), "size.y must be positive and finite, got -4"),
            (one(&format!("{bld}size = [1.0, nan, 1.0]")), "size.y must be positive and finite, got NaN"),
            (one("kind = \"building\"\nname = \"b\"\nmaterial = \"cheese\"\ncenter = [0.0, 0.0]\nsize = [1.0, 1.0, 1.0]"), "unknown material 'cheese'"),
            (one(&format!("{bld}size = [1.0, 1.0, 1.0]\nroof = {{ kind = \"dome\" }}")), "dome"),
            (one(&format!("{bld}size = [1.0, 1.0, 1.0]\nroof = {{ kind = \"pitched\", ridge = \"z\", height = 1.0 }}")), "z"),
            (one(&format!("{bld}size = [1.0, 1.0, 1.0]\nroof = {{ kind = \"pitched\", ridge = \"x\", height = 1.0, pitch = 3 }}")), "pitch"),
            (one("kind = \"sphere\"\nname = \"s\""), "sphere"),
            (one("kind = \"mesh\"\npath = \"does/not/exist.obj\""), "does/not/exist.obj"),
            (one("kind = \"cylinder\"\nname = \"c\"\nmaterial = \"metal\"\ncenter = [0.0, 0.0]\nradius = 1.0\nheight = 2.0\nsegments = 2"), "segments must be at least 3, got 2"),
            (format!("{}{}", one(&format!("{bld}size = [1.0, 1.0, 1.0]")), one(&format!("{bld}size = [1.0, 1.0, 1.0]")).replace("[scene]\n", "")), "name 'b' is used twice"),
            ("[scene]\nobjects = []\n".to_string(), "scene has no triangles"),
            ("[scen]\n".to_string(), "missing field `scene`"),
        ];
        for (text, want) in cases {
            let e = SceneSpec::from_toml_str(&text)
                .and_then(|s| s.build().map(|_| ()))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want), "expected '{want}' in '{e}'\n{text}");
        }
        let e = SceneSpec::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
        assert!(e.to_string().contains("/nonexistent/scene.toml"), "{e}");
    }
}
