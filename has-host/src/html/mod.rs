//! `report.html`: one self-contained page per run — the report's Markdown as HTML
//! ([`markdown`]), an interactive 3D view of the run's clouds and meshes (a small WebGL viewer
//! kept in this crate, `viewer.js`; no library, no network) and the run's plots embedded as data
//! URIs, so that the file opens offline, mailed or moved on its own.
//!
//! The 3D layers are stored as 16-bit positions quantised over the scene's bounding box (a
//! millimetre over 65 m) and base64-encoded; point layers above [`MAX_POINTS`] keep every k-th
//! point, meshes above [`MAX_FACES`] are simplified by vertex clustering
//! ([`crate::mesh::cluster_vertices`]) and say so in the layer's note. Units: metres, world frame,
//! z up.

pub mod markdown;

use glam::Vec3;

use crate::mesh::TriMesh;

/// Most points one layer embeds.
pub const MAX_POINTS: usize = 200_000;
/// Most faces one mesh layer embeds.
pub const MAX_FACES: usize = 150_000;

const VIEWER_JS: &str = include_str!("viewer.js");

const STYLE: &str = "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;\
color:#222;background:#fafafa}main{max-width:1100px;margin:0 auto;padding:1em 1.5em 3em}\
table{border-collapse:collapse;margin:.8em 0;font-size:.92em}th,td{border:1px solid #ccc;\
padding:.25em .6em;text-align:left;vertical-align:top}th{background:#eee}code{background:#eee;\
padding:0 .2em;border-radius:3px}figure{margin:1em 0}figure img{max-width:100%;border:1px solid \
#ddd;background:#fff}figcaption{font-size:.9em;color:#555}#has-view{width:100%;max-width:1040px;\
border:1px solid #ccc;background:#fff;cursor:grab}#has-layers label{margin-right:1.2em;\
white-space:nowrap}.swatch{display:inline-block;width:.8em;height:.8em;margin-left:.3em;\
border:1px solid #888}.note{color:#555;font-size:.9em}";

/// Standard base64 (RFC 4648, padded).
pub fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                s.push(ABC[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// What a 3D layer holds.
#[derive(Clone, Debug)]
pub enum LayerData<'a> {
    /// Points drawn `point_px` pixels wide.
    Points {
        /// Positions, metres.
        points: &'a [Vec3],
        /// Screen size of a point, pixels.
        point_px: u32,
    },
    /// A triangle mesh, shaded by its face normals.
    Mesh(&'a TriMesh),
}

/// One layer of the 3D view: a name, an sRGB colour and its data.
#[derive(Clone, Debug)]
pub struct Layer<'a> {
    /// Shown beside the layer's checkbox.
    pub name: &'a str,
    /// sRGB colour.
    pub colour: [u8; 3],
    /// The geometry.
    pub data: LayerData<'a>,
}

/// The colour the reports give a reconstructed mesh or twin.
pub const MESH_COLOUR: [u8; 3] = [215, 120, 90];

impl<'a> Layer<'a> {
    /// A point layer drawn `point_px` pixels wide.
    pub fn points(name: &'a str, colour: [u8; 3], points: &'a [Vec3], point_px: u32) -> Self {
        Self {
            name,
            colour,
            data: LayerData::Points { points, point_px },
        }
    }

    /// A mesh layer.
    pub fn mesh(name: &'a str, colour: [u8; 3], mesh: &'a TriMesh) -> Self {
        Self {
            name,
            colour,
            data: LayerData::Mesh(mesh),
        }
    }
}

/// A report page under construction ([`Page::new`], the sections in order, [`Page::finish`]).
#[derive(Clone, Debug, Default)]
pub struct Page {
    title: String,
    body: String,
    has_view: bool,
}

impl Page {
    /// An empty page titled `title`.
    pub fn new(title: &str) -> Self {
        Self {
            title: title.to_string(),
            ..Self::default()
        }
    }

    /// Appends a report's Markdown, as HTML.
    pub fn markdown(&mut self, md: &str) -> &mut Self {
        self.body.push_str(&markdown::to_html(md));
        self
    }

    /// Appends a heading of level 2.
    pub fn heading(&mut self, text: &str) -> &mut Self {
        self.body
            .push_str(&format!("<h2>{}</h2>\n", markdown::escape(text)));
        self
    }

    /// Appends a figure: a PNG or SVG file's bytes (by `file_name`'s extension) as a data URI,
    /// captioned with `caption` and the file's name.
    pub fn figure(&mut self, file_name: &str, bytes: &[u8], caption: &str) -> &mut Self {
        let mime = if file_name.ends_with(".svg") {
            "image/svg+xml"
        } else {
            "image/png"
        };
        self.body.push_str(&format!(
            "<figure><img alt=\"{name}\" src=\"data:{mime};base64,{data}\">\
             <figcaption>{caption} (<code>{name}</code>)</figcaption></figure>\n",
            name = markdown::escape(file_name),
            data = base64(bytes),
            caption = markdown::escape(caption),
        ));
        self
    }

    /// Appends the interactive 3D view of `layers` (module docs). One view per page: a second
    /// call is ignored.
    pub fn view_3d(&mut self, layers: &[Layer<'_>]) -> &mut Self {
        if self.has_view {
            return self;
        }
        self.has_view = true;
        let json = scene_json(layers);
        self.body.push_str(
            "<h2>3D view</h2>\n<div id=\"has-layers\"></div>\n\
             <canvas id=\"has-view\" width=\"1040\" height=\"680\"></canvas>\n\
             <p class=\"note\" id=\"has-view-note\">Drag to turn, wheel to zoom; the boxes show \
             and hide the layers.</p>\n<script type=\"application/json\" id=\"has-scene\">",
        );
        // JSON inside <script>: no "</" may close the element early.
        self.body.push_str(&json.replace("</", "<\\/"));
        self.body.push_str("</script>\n");
        self
    }

    /// The whole page.
    pub fn finish(&self) -> String {
        let script = if self.has_view {
            format!("<script>\n{VIEWER_JS}</script>\n")
        } else {
            String::new()
        };
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{title}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<main>\n{body}\
             </main>\n{script}</body>\n</html>\n",
            title = markdown::escape(&self.title),
            body = self.body,
        )
    }
}

/// Every `k`-th point, `k` the smallest keeping at most [`MAX_POINTS`].
fn thinned(points: &[Vec3]) -> (Vec<Vec3>, usize) {
    let k = points.len().div_ceil(MAX_POINTS).max(1);
    (
        points
            .iter()
            .step_by(k)
            .copied()
            .filter(|p| p.is_finite())
            .collect(),
        k,
    )
}

/// A layer ready to embed: the layer, its (thinned or simplified) positions, its faces if a mesh,
/// and its note.
type Prepared<'a> = (&'a Layer<'a>, Vec<Vec3>, Option<Vec<[u32; 3]>>, String);

/// The scene's JSON (format in `viewer.js`).
fn scene_json(layers: &[Layer<'_>]) -> String {
    // Geometry first (thinned, simplified), then one bounding box over all of it.
    let prepared: Vec<Prepared<'_>> = layers
        .iter()
        .map(|l| match &l.data {
            LayerData::Points { points, .. } => {
                let (p, k) = thinned(points);
                let note = if k > 1 {
                    format!("1 in {k} of {} points", points.len())
                } else {
                    format!("{} points", points.len())
                };
                (l, p, None, note)
            }
            LayerData::Mesh(mesh) => {
                let (m, cell) = crate::mesh::simplified_to(mesh, MAX_FACES);
                let note = match cell {
                    Some(c) => format!(
                        "{} of {} faces, vertices clustered at {c:.2} m",
                        m.faces.len(),
                        mesh.faces.len()
                    ),
                    None => format!("{} faces", m.faces.len()),
                };
                (l, m.vertices, Some(m.faces), note)
            }
        })
        .collect();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (_, p, _, _) in &prepared {
        for v in p {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    if !lo.is_finite() {
        (lo, hi) = (Vec3::ZERO, Vec3::ONE);
    }
    let size = (hi - lo).max(Vec3::splat(1e-3));
    let quantise = |p: &[Vec3]| -> String {
        let mut b = Vec::with_capacity(p.len() * 6);
        for v in p {
            let q = ((*v - lo) / size * 65535.0)
                .round()
                .clamp(Vec3::ZERO, Vec3::splat(65535.0));
            for c in [q.x, q.y, q.z] {
                b.extend_from_slice(&(c as u16).to_le_bytes());
            }
        }
        base64(&b)
    };
    let mut entries = Vec::new();
    for (l, p, faces, note) in &prepared {
        let mut e = serde_json::json!({
            "name": l.name,
            "colour": l.colour,
            "note": note,
            "positions": quantise(p),
        });
        match (&l.data, faces) {
            (LayerData::Points { point_px, .. }, _) => {
                e["kind"] = "points".into();
                e["point_px"] = (*point_px).into();
            }
            (LayerData::Mesh(_), Some(f)) => {
                let mut b = Vec::with_capacity(f.len() * 12);
                for i in f.iter().flatten() {
                    b.extend_from_slice(&i.to_le_bytes());
                }
                e["kind"] = "mesh".into();
                e["indices"] = base64(&b).into();
            }
            (LayerData::Mesh(_), None) => unreachable!("a mesh layer keeps its faces"),
        }
        entries.push(e);
    }
    serde_json::json!({
        "min": [lo.x, lo.y, lo.z],
        "size": [size.x, size.y, size.z],
        "layers": entries,
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc_4648_s_test_vectors() {
        for (raw, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(raw.as_bytes()), enc);
        }
    }

    #[test]
    fn a_page_embeds_its_figures_and_scene_and_nothing_closes_its_script_early() {
        let pts = [Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)];
        let mesh = TriMesh {
            vertices: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            faces: vec![[0, 1, 2]],
        };
        let mut page = Page::new("run </script>");
        page.markdown("# t\n")
            .view_3d(&[
                Layer {
                    name: "cloud </script>",
                    colour: [1, 2, 3],
                    data: LayerData::Points {
                        points: &pts,
                        point_px: 2,
                    },
                },
                Layer {
                    name: "mesh",
                    colour: [4, 5, 6],
                    data: LayerData::Mesh(&mesh),
                },
            ])
            .figure("a.png", &[0x89, b'P', b'N', b'G'], "plot");
        let html = page.finish();
        assert!(html.contains("src=\"data:image/png;base64,iVBORw==\""));
        assert!(!VIEWER_JS.contains("</script"));
        assert_eq!(html.matches("</script>").count(), 2, "{html}");
        let start = html.find("id=\"has-scene\">").expect("scene") + 15;
        let end = start + html[start..].find("</script>").expect("end");
        let v: serde_json::Value =
            serde_json::from_str(&html[start..end].replace("<\\/", "</")).expect("json");
        assert_eq!(v["layers"][0]["kind"], "points");
        assert_eq!(v["layers"][1]["kind"], "mesh");
        assert_eq!(
            v["layers"][1]["indices"],
            base64(&[0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0])
        );
        // Two points, 6 bytes each: 16 base64 characters; the far corner quantises to 65535.
        assert_eq!(
            v["layers"][0]["positions"],
            base64(&[0, 0, 0, 0, 0, 0, 255, 255, 255, 255, 255, 255])
        );
    }

    #[test]
    fn a_large_cloud_is_thinned_to_the_budget_and_says_so() {
        let pts: Vec<Vec3> = (0..MAX_POINTS + 10)
            .map(|i| Vec3::splat(i as f32))
            .collect();
        let v: serde_json::Value = serde_json::from_str(&scene_json(&[Layer {
            name: "c",
            colour: [0; 3],
            data: LayerData::Points {
                points: &pts,
                point_px: 1,
            },
        }]))
        .expect("json");
        let n = v["layers"][0]["positions"].as_str().expect("b64").len() / 8;
        assert!((MAX_POINTS / 2..=MAX_POINTS).contains(&n), "{n}");
        assert!(v["layers"][0]["note"]
            .as_str()
            .expect("note")
            .contains("1 in 2 of"));
    }
}
