//! `has-sim turn`: writes a scenario turned about a vertical axis
//! ([`has_host::scenario::turn`]), to check that a site's results do not depend on which way it
//! faces: run `reconstruct` (or `suite --suite-dir`) on both files and compare.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use glam::Vec2;
use has_host::io::atomic_write;
use has_host::scenario::ObjectSpec;

use crate::reconstruct_cmd::load_scenario;

/// Arguments of `has-sim turn`.
#[derive(clap::Args, Debug)]
pub struct TurnArgs {
    /// Scenario file to turn (TOML, see docs/scenario.md). Default: the bundled
    /// fixtures/factory.toml.
    pub scenario: Option<PathBuf>,
    /// Angle in degrees, counter-clockwise seen from above.
    #[arg(long, allow_hyphen_values = true)]
    pub deg: f64,
    /// The vertical axis's ground position `X,Y` in metres. Default: the origin.
    #[arg(long, value_delimiter = ',', num_args = 1, allow_hyphen_values = true)]
    pub about: Option<Vec<f64>>,
    /// Where to write the turned scenario (TOML; comments are not carried over).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs the command.
pub fn run(args: TurnArgs) -> Result<()> {
    let about = match args.about.as_deref() {
        None => Vec2::ZERO,
        Some(&[x, y]) => Vec2::new(x as f32, y as f32),
        Some(v) => bail!("--about: {v:?} is not two numbers X,Y"),
    };
    let (sc, name) = load_scenario(args.scenario.as_deref())?;
    let turned = sc
        .turned(args.deg, about)
        .with_context(|| format!("turning {name}"))?;
    // Mesh files are named relative to the scenario read; the turned file may live elsewhere.
    let mut turned = turned;
    let base = turned.scene.base_dir.clone();
    for o in &mut turned.scene.objects {
        if let ObjectSpec::Mesh(m) = o {
            let p = base.join(&m.path);
            if !p.is_file() {
                bail!("scene mesh {}: not a file", p.display());
            }
            m.path =
                std::fs::canonicalize(&p).with_context(|| format!("scene mesh {}", p.display()))?;
        }
    }
    let text = format!(
        "# {name} turned by {}° counter-clockwise about ({}, {}) m by `has-sim turn`\n\n{}",
        args.deg,
        about.x,
        about.y,
        turned.to_toml_string()?
    );
    // The scenario read is an input of the run: `has_host::io::guard` refuses to write over it.
    atomic_write(&args.out, |w| std::io::Write::write_all(w, text.as_bytes())).context("--out")?;
    println!(
        "{} written: {name} turned by {}° about ({}, {}) m",
        args.out.display(),
        args.deg,
        about.x,
        about.y
    );
    Ok(())
}
