//! `has-sim bench mesh`: prints [`has_host::bench::mesh`], the screened Poisson solver with
//! adaptive fine levels against full grids on the same noisy proxy building, all threads.

use has_host::bench::mesh::{self, PoissonInput};

/// Runs the benchmark at grid depth 8 (the quick variant: depth 7) and prints its table.
pub fn run(quick: bool) -> anyhow::Result<()> {
    let depth = mesh::depth(quick);
    let input = PoissonInput::new()?;
    println!(
        "has-sim bench mesh — screened Poisson, depth {depth}, {} points (proxy building, σ 0.3 m), {} threads\n",
        input.cloud.len(),
        rayon::current_num_threads()
    );
    println!(
        "{:<28} {:>9} {:>9} {:>16} {:>10} {:>12}",
        "solver", "seconds", "× plain", "finest unknowns", "vertices", "√CD to ref"
    );
    for r in mesh::poisson_rows(&input, depth)? {
        println!(
            "{:<28} {:>9.2} {:>9.2} {:>16} {:>10} {:>10.3} m",
            r.solver, r.seconds, r.speedup, r.finest_unknowns, r.vertices, r.sqrt_cd_to_reference_m
        );
    }
    Ok(())
}
