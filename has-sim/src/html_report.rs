//! `report.html` of a run (has_host::html): the report's Markdown, the 3D view of the run's
//! geometry and the plots the run wrote into its directory, read back and embedded, so that the
//! page opens on its own, offline.

use std::path::Path;

use anyhow::{Context, Result};
use has_host::html::{Layer, Page};

/// Writes `DIR/report.html`: `title`, the Markdown `md`, the 3D view of `layers` and the plots
/// `plots` (file name in `out`, or `prefix*suffix` for every matching file in name order; and a
/// caption), atomically.
pub fn write(
    out: &Path,
    title: &str,
    md: &str,
    layers: &[Layer<'_>],
    plots: &[(&str, &str)],
) -> Result<()> {
    // The headline figures, then the 3D view, then the report's sections and the plots.
    let (head, sections) = md.split_at(md.find("\n## ").unwrap_or(md.len()));
    let mut page = Page::new(title);
    page.markdown(head);
    if !layers.is_empty() {
        page.view_3d(layers);
    }
    page.markdown(sections);
    let mut heading = false;
    for (pattern, caption) in plots {
        for name in matching(out, pattern)? {
            let bytes = std::fs::read(out.join(&name))
                .with_context(|| format!("reading {}", out.join(&name).display()))?;
            if !heading {
                page.heading("Plots");
                heading = true;
            }
            page.figure(&name, &bytes, caption);
        }
    }
    let html = page.finish();
    let path = out.join("report.html");
    has_host::io::atomic_write(&path, |w| std::io::Write::write_all(w, html.as_bytes()))
        .with_context(|| format!("writing {}", path.display()))
}

/// The files of `dir` that `pattern` names: itself if it exists (a run without a mesh has no
/// mesh plots), or with one `*`, every name with that prefix and suffix, sorted.
fn matching(dir: &Path, pattern: &str) -> Result<Vec<String>> {
    let Some((pre, suf)) = pattern.split_once('*') else {
        let exists = dir.join(pattern).is_file();
        return Ok(exists.then(|| pattern.to_string()).into_iter().collect());
    };
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with(pre) && n.ends_with(suf) && n.len() >= pre.len() + suf.len())
        .collect();
    names.sort();
    Ok(names)
}
