//! Mesh and point-cloud files: Wavefront OBJ ([`obj`]), PLY ([`ply`], ASCII and binary, meshes
//! and point clouds with extra per-point properties) and the Mitsuba XML scenes that Sionna RT
//! uses ([`mitsuba`]).
//!
//! Coordinates are read and written as given (metres, z up, as everywhere in `has`). Every write
//! is atomic: the file is written to a temporary file in the same directory and renamed over the
//! target, so a reader never sees half a file. Every error names the file and, where it applies,
//! the line, element, field and value ([`MeshIoError`]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::material::Material;
use crate::mesh::TriMesh;
use crate::scene::Object;

pub mod guard;
pub mod mitsuba;
pub mod npy;
pub mod obj;
pub mod ply;

pub use ply::{PlyData, PlyFormat};

/// Why a mesh, point-cloud or scene file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum MeshIoError {
    /// The operating system refused (missing file, permissions, disk full).
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A text line (OBJ, PLY header or ASCII body) could not be parsed.
    #[error("{path}:{line}: {msg}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was wrong, quoting the offending text.
        msg: String,
    },
    /// A PLY element instance (binary body, or a bad index) was malformed.
    #[error("{path}: element '{element}' #{index}: {msg}")]
    Element {
        /// The file.
        path: PathBuf,
        /// PLY element name (`vertex`, `face`, ...).
        element: String,
        /// 0-based instance index.
        index: usize,
        /// What was wrong.
        msg: String,
    },
    /// A vertex coordinate was NaN or infinite.
    #[error("{path}: {element} #{index}: field '{field}' is not finite ({value})")]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// `vertex` (PLY) or `v` (OBJ).
        element: String,
        /// 0-based vertex index.
        index: usize,
        /// `x`, `y` or `z`.
        field: String,
        /// The value read.
        value: f64,
    },
    /// A material name that is not one of the ITU-R P.2040 materials.
    #[error("{path}: unknown material '{name}' ({context}); known: {known}")]
    UnknownMaterial {
        /// The file.
        path: PathBuf,
        /// The name as written.
        name: String,
        /// Where it was used.
        context: String,
        /// The accepted names.
        known: String,
    },
    /// A mesh file with no faces: not a mesh (e.g. a TOML or PLY file read as OBJ, whose
    /// unknown lines a reader skips; a point cloud), or an empty one.
    #[error("{path}: no faces: not a mesh, or an empty one")]
    NoFaces {
        /// The file.
        path: PathBuf,
    },
    /// The file is valid but uses something this reader does not support.
    #[error("{path}: unsupported: {what}")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What, quoting the construct.
        what: String,
    },
    /// Malformed Mitsuba XML.
    #[error("{path}:{line}: {msg}")]
    Xml {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u32,
        /// What was wrong.
        msg: String,
    },
    /// Data handed to a writer was inconsistent.
    #[error("{path}: cannot write: {msg}")]
    BadData {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        msg: String,
    },
}

impl MeshIoError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        MeshIoError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn unknown_material(path: &Path, name: &str, context: impl Into<String>) -> Self {
        MeshIoError::UnknownMaterial {
            path: path.to_path_buf(),
            name: name.to_string(),
            context: context.into(),
            known: known_material_names(),
        }
    }
}

/// The material names accepted everywhere, comma-separated (`concrete, brick, ...`); the
/// Sionna spelling `itu_concrete` is accepted too.
pub fn known_material_names() -> String {
    Material::all()
        .map(Material::name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Reads a whole file, naming it in the error.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, MeshIoError> {
    guard::read_input(path).map_err(|e| MeshIoError::io(path, e))
}

/// Writes `path` atomically: `body` writes into a temporary file in the same directory, which is
/// flushed and renamed over `path`. On error the temporary file is removed.
///
/// # Errors
/// [`MeshIoError::BadData`] before anything is written when `path` exists and is not a regular
/// file, or is a file this run read ([`guard::check_output`]); [`MeshIoError::Io`] when writing
/// fails.
pub fn atomic_write(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), MeshIoError> {
    let tmp = write_temporary(path, body)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        MeshIoError::io(path, e)
    })
}

/// Writes several files, each `(path, bytes)`, all or none: every one goes to its temporary
/// file first, and only when all are written are they renamed into place.
///
/// # Errors
/// As [`atomic_write`]; then none of the files is left (a rename that fails part-way removes
/// the ones already renamed).
pub fn write_files(files: &[(PathBuf, Vec<u8>)]) -> Result<(), MeshIoError> {
    let mut tmps = Vec::with_capacity(files.len());
    for (path, bytes) in files {
        match write_temporary(path, |w| w.write_all(bytes)) {
            Ok(t) => tmps.push(t),
            Err(e) => {
                for t in &tmps {
                    let _ = std::fs::remove_file(t);
                }
                return Err(e);
            }
        }
    }
    for (k, (tmp, (path, _))) in tmps.iter().zip(files).enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            for t in &tmps[k..] {
                let _ = std::fs::remove_file(t);
            }
            for (p, _) in &files[..k] {
                let _ = std::fs::remove_file(p);
            }
            return Err(MeshIoError::io(path, e));
        }
    }
    Ok(())
}

/// The temporary file of [`atomic_write`] for `path`, written by `body` and synced; removed
/// again on error. Refuses a `path` [`guard::check_output`] refuses, before writing.
fn write_temporary(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<PathBuf, MeshIoError> {
    guard::check_output(path).map_err(|msg| MeshIoError::BadData {
        path: path.to_path_buf(),
        msg,
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| MeshIoError::BadData {
            path: path.to_path_buf(),
            msg: "path has no file name".into(),
        })?
        .to_string_lossy()
        .into_owned();
    // Unique per process and call, so concurrent writers never share a temporary file.
    static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let seq = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(".{file_name}.{}.{seq}.tmp", std::process::id()));
    let result = (|| -> std::io::Result<()> {
        let f = File::create(&tmp)?;
        let mut w = BufWriter::with_capacity(1 << 20, f);
        body(&mut w)?;
        w.flush()?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()
    })();
    match result {
        Ok(()) => Ok(tmp),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(MeshIoError::io(path, e))
        }
    }
}

/// Loads the objects of a mesh or scene file, by extension: `.obj` ([`obj::read_obj`]),
/// `.ply` ([`ply::read_ply`], one object named after the file stem) or `.xml` (Mitsuba,
/// [`mitsuba::read_mitsuba`]).
///
/// `material`, if given, overrides every object's material; otherwise materials come from the
/// file (OBJ `usemtl`, Mitsuba `bsdf`), and a PLY file, which has none, is an error.
pub fn load_objects(path: &Path, material: Option<Material>) -> Result<Vec<Object>, MeshIoError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let mut objects = match ext.as_str() {
        "obj" => obj::read_obj(path, material)?,
        "ply" => {
            let m = material.ok_or_else(|| MeshIoError::Unsupported {
                path: path.to_path_buf(),
                what: "a PLY file carries no material; give one (`--material`)".into(),
            })?;
            let data = ply::read_ply(path)?;
            vec![Object {
                thickness_m: None,
                name: file_stem(path),
                material: m,
                triangles: data.triangles(),
            }]
        }
        "xml" => mitsuba::read_mitsuba(path)?,
        _ => {
            return Err(MeshIoError::Unsupported {
                path: path.to_path_buf(),
                what: format!("file extension '{ext}' (expected obj, ply or xml)"),
            })
        }
    };
    if objects.iter().all(|o| o.triangles.is_empty()) {
        return Err(MeshIoError::NoFaces {
            path: path.to_path_buf(),
        });
    }
    if let Some(m) = material {
        for o in &mut objects {
            o.material = m;
        }
    }
    Ok(objects)
}

/// Writes objects for viewing, by extension: `.obj` (one `o` group per object with its
/// `usemtl itu_*` material) or `.ply` (binary little-endian, all triangles in one mesh with a
/// per-vertex `object` index property).
pub fn save_objects(path: &Path, objects: &[Object]) -> Result<(), MeshIoError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "obj" => obj::write_obj(path, objects),
        "ply" => {
            let mut data = PlyData::default();
            let mut object_ids = Vec::new();
            for (i, o) in objects.iter().enumerate() {
                let before = data.vertices.len();
                data.append_triangles(&o.triangles);
                object_ids.resize(object_ids.len() + data.vertices.len() - before, i as f32);
            }
            data.properties.push(("object".into(), object_ids));
            ply::write_ply(path, &data, PlyFormat::BinaryLittleEndian)
        }
        _ => Err(MeshIoError::Unsupported {
            path: path.to_path_buf(),
            what: format!("output extension '{ext}' (expected obj or ply)"),
        }),
    }
}

/// Writes a surface mesh for viewing and reuse: OBJ at `obj` (one object `mesh`, concrete, the
/// material a twin's surfaces get, with the area-weighted vertex normals of
/// [`TriMesh::vertex_normals`] as `vn`, [`obj::write_mesh`]) and, if `ply` is given, binary
/// little-endian PLY with the same normals (`nx`, `ny`, `nz`) and, if given, each vertex's
/// support `density`. Each file is complete or absent ([`atomic_write`]); the mesh is checked
/// before either is written.
///
/// # Errors
/// [`MeshIoError::BadData`] if a face indexes past the vertices, a vertex is not finite or
/// `density` has another length than the vertices; [`MeshIoError::Io`] if a file cannot be
/// written.
pub fn save_mesh(
    mesh: &TriMesh,
    obj: &Path,
    ply: Option<&Path>,
    density: Option<&[f32]>,
) -> Result<(), MeshIoError> {
    if let (Some(p), Some(d)) = (ply, density) {
        if d.len() != mesh.vertices.len() {
            return Err(MeshIoError::BadData {
                path: p.to_path_buf(),
                msg: format!("{} densities for {} vertices", d.len(), mesh.vertices.len()),
            });
        }
    }
    obj::check_mesh(obj, mesh)?;
    let normals = mesh.vertex_normals();
    obj::write_mesh(obj, mesh, "mesh", Material::Concrete, Some(&normals))?;
    if let Some(p) = ply {
        let mut data = PlyData {
            vertices: mesh.vertices.clone(),
            properties: Vec::new(),
            faces: mesh.faces.clone(),
        };
        for (k, name) in ["nx", "ny", "nz"].into_iter().enumerate() {
            data.properties
                .push((name.into(), normals.iter().map(|n| n[k]).collect()));
        }
        if let Some(d) = density {
            data.properties.push(("density".into(), d.to_vec()));
        }
        ply::write_ply(p, &data, PlyFormat::BinaryLittleEndian)?;
    }
    Ok(())
}

/// Writes a point cloud as binary little-endian PLY with extra per-point `f32` columns
/// `(name, values)`, atomically ([`ply::write_ply`]).
///
/// # Errors
/// As [`ply::write_ply`]: a column whose length differs from the points' or a bad column name is
/// [`MeshIoError::BadData`].
pub fn save_cloud(
    path: &Path,
    points: &[Vec3],
    properties: Vec<(&str, Vec<f32>)>,
) -> Result<(), MeshIoError> {
    let mut data = PlyData::from_points(points.to_vec());
    for (name, values) in properties {
        data = data.with_property(name, values);
    }
    ply::write_ply(path, &data, PlyFormat::BinaryLittleEndian)
}

pub(crate) fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into())
}

#[cfg(test)]
pub(crate) mod testutil {
    use std::path::{Path, PathBuf};

    /// A scratch directory, removed with everything in it when dropped.
    pub struct TempDir(PathBuf);

    impl std::ops::Deref for TempDir {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl AsRef<Path> for TempDir {
        fn as_ref(&self) -> &Path {
            &self.0
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// A fresh, empty directory under the system's temp dir, unique per test name and process.
    pub fn tmp_dir(name: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("has-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        TempDir(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn atomic_write_leaves_no_temp_file_and_replaces_target() {
        let d = testutil::tmp_dir("atomic");
        let p = d.join("a.txt");
        std::fs::write(&p, "old").unwrap();
        atomic_write(&p, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        // A failing body leaves the old file and no temp file.
        let e = atomic_write(&p, |_| Err(std::io::Error::other("boom"))).unwrap_err();
        assert!(e.to_string().contains("boom"), "{e}");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn write_files_writes_every_file_or_none() {
        let d = testutil::tmp_dir("write-files");
        let ok: Vec<_> = ["a.npy", "b.npy"]
            .iter()
            .map(|n| (d.join(n), n.as_bytes().to_vec()))
            .collect();
        write_files(&ok).unwrap();
        assert_eq!(std::fs::read(d.join("b.npy")).unwrap(), b"b.npy");
        // The third cannot be written (its directory is missing): none of the new ones is.
        let bad: Vec<_> = [d.join("c.npy"), d.join("e.npy"), d.join("missing/f.npy")]
            .into_iter()
            .map(|p| (p, b"x".to_vec()))
            .collect();
        write_files(&bad).unwrap_err();
        let mut left: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, ["a.npy", "b.npy"]);
    }

    #[test]
    fn a_file_without_faces_is_not_a_mesh() {
        let d = testutil::tmp_dir("no-faces");
        // A point cloud (vertices only) as PLY, and a scenario file named .obj.
        let ply = d.join("cloud.ply");
        std::fs::write(
            &ply,
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
             property float z\nend_header\n0 0 0\n1 0 0\n",
        )
        .unwrap();
        let obj = d.join("scenario.obj");
        std::fs::write(&obj, "[scene]\ndescription = \"factory\"\n").unwrap();
        for p in [&ply, &obj] {
            let e = load_objects(p, Some(Material::Concrete)).unwrap_err();
            assert!(matches!(e, MeshIoError::NoFaces { .. }), "{e}");
            assert!(e.to_string().contains("no faces"), "{e}");
        }
    }

    #[test]
    fn save_and_load_objects_round_trip_through_obj_and_ply() {
        let d = testutil::tmp_dir("roundtrip");
        let b = shapes::axis_box(
            "hall",
            Material::Brick,
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 2.0, 3.0),
        )
        .unwrap();
        let g = shapes::ground(
            "ground",
            Material::WetGround,
            glam::Vec2::splat(-5.0),
            glam::Vec2::splat(5.0),
            0.0,
            (2, 2),
        )
        .unwrap();
        let objs = vec![b, g];
        save_objects(&d.join("s.obj"), &objs).unwrap();
        let back = load_objects(&d.join("s.obj"), None).unwrap();
        assert_eq!(back.len(), 2);
        for (a, b) in objs.iter().zip(&back) {
            assert_eq!(a.name, b.name);
            assert_eq!(a.material, b.material);
            assert_eq!(a.triangles, b.triangles);
        }
        save_objects(&d.join("s.ply"), &objs).unwrap();
        let ply = load_objects(&d.join("s.ply"), Some(Material::Metal)).unwrap();
        assert_eq!(ply.len(), 1);
        let all: Vec<_> = objs.iter().flat_map(|o| o.triangles.clone()).collect();
        assert_eq!(ply[0].triangles, all);
        assert_eq!(ply[0].material, Material::Metal);
    }

    #[test]
    fn save_mesh_writes_obj_and_ply_that_read_back_or_nothing_when_the_mesh_is_bad() {
        let d = testutil::tmp_dir("save-mesh");
        let tet = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z],
            faces: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let (obj, ply) = (d.join("m.obj"), d.join("m.ply"));
        let density = [1.0, 2.0, 3.0, 4.0];
        save_mesh(&tet, &obj, Some(&ply), Some(&density)).unwrap();
        let back = load_objects(&obj, None).unwrap();
        assert_eq!(
            (back[0].name.as_str(), back[0].material),
            ("mesh", Material::Concrete)
        );
        let soup: Vec<_> = tet
            .faces
            .iter()
            .map(|f| f.map(|i| tet.vertices[i as usize]))
            .collect();
        assert_eq!(back[0].triangles, soup);
        assert!(std::fs::read_to_string(&obj)
            .unwrap()
            .contains("f 1//1 3//3 2//2\n"));
        let p = ply::read_ply(&ply).unwrap();
        assert_eq!(
            (p.vertices.clone(), p.faces.clone()),
            (tet.vertices.clone(), tet.faces.clone())
        );
        assert_eq!(p.property("density"), Some(&density[..]));
        for (k, n) in tet.vertex_normals().iter().enumerate() {
            assert_eq!(p.property("nx").unwrap()[k], n.x);
        }
        let bad_face = TriMesh {
            faces: vec![[0, 1, 4]],
            ..tet.clone()
        };
        let mut bad_vertex = tet.clone();
        bad_vertex.vertices[2].y = f32::NAN;
        for (m, dens, want) in [
            (&bad_face, None, "indexes past the 4 vertices"),
            (&bad_vertex, None, "vertex 2 is not finite"),
            (&tet, Some(&density[..3]), "3 densities for 4 vertices"),
        ] {
            let (o, p) = (d.join("bad.obj"), d.join("bad.ply"));
            let e = save_mesh(m, &o, Some(&p), dens).unwrap_err();
            assert!(
                matches!(e, MeshIoError::BadData { .. }) && e.to_string().contains(want),
                "{e}"
            );
            assert!(!o.exists() && !p.exists());
        }
    }

    #[test]
    fn load_objects_errors_name_the_file_and_problem() {
        let d = testutil::tmp_dir("loaderr");
        let missing = d.join("nope.obj");
        let e = load_objects(&missing, None).unwrap_err();
        assert!(e.to_string().contains("nope.obj"), "{e}");
        std::fs::write(d.join("x.stl"), "solid").unwrap();
        let e = load_objects(&d.join("x.stl"), None).unwrap_err();
        assert!(e.to_string().contains("'stl'"), "{e}");
        let data = PlyData {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            faces: vec![[0, 1, 2]],
            ..Default::default()
        };
        ply::write_ply(&d.join("t.ply"), &data, PlyFormat::Ascii).unwrap();
        let e = load_objects(&d.join("t.ply"), None).unwrap_err();
        assert!(e.to_string().contains("no material"), "{e}");
    }
}
