//! `fastslam-stack solve FILE.g2o`: a 2D pose graph in the g2o format (plain or gzipped)
//! solved by the project's sparse Levenberg–Marquardt, the first pose anchored; prints one
//! line — sizes, χ² before and after (over the edges, the anchor excluded), iterations and
//! the solve's wall time — and with `--out` writes the solution as g2o.

use anyhow::Context;
use fastslam_estimation::graph::{SolveOptions, g2o};
use std::path::PathBuf;

/// Flags of `solve`.
#[derive(Debug, Clone, clap::Args)]
pub struct SolveArgs {
    /// The g2o file (2D records; gzipped or not).
    pub file: PathBuf,
    /// Write the solution here as g2o (gzipped when the name ends in `.gz`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Most Levenberg–Marquardt iterations (accepted and rejected steps).
    #[arg(long, default_value_t = SolveOptions::default().max_iterations)]
    pub max_iterations: usize,
}

/// Runs `solve`.
///
/// # Errors
/// A file that cannot be read or parsed (naming the file and the line), a graph the
/// solver cannot factorise, an output that cannot be written.
pub fn run(args: &SolveArgs) -> anyhow::Result<()> {
    let file = args.file.display();
    let mut problem = g2o::read(&args.file).with_context(|| file.to_string())?;
    let chi2_initial = problem.graph.chi2_measurements();
    let options = SolveOptions {
        max_iterations: args.max_iterations,
        ..SolveOptions::pose_graph()
    };
    let report = (problem.graph.solve(&options)).with_context(|| file.to_string())?;
    println!(
        "poses {} landmarks {} edges {} chi2_initial {:.6} chi2_final {:.6} iterations {} solve_s {:.4}",
        problem.graph.poses.len(),
        problem.graph.landmarks.len(),
        problem.edges(),
        chi2_initial,
        problem.graph.chi2_measurements(),
        report.iterations,
        report.seconds
    );
    if !report.converged {
        eprintln!(
            "{file}: not converged after {} iterations",
            report.iterations
        );
    }
    if let Some(out) = &args.out {
        (problem.save(out)).with_context(|| format!("cannot write {}", out.display()))?;
    }
    Ok(())
}
