//! The `truth-sim` process on its own (the launcher starts the same code as `fastslam-stack truth-sim`).

use fastslam_sensors_sim::processes::truth;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("truth-sim", truth::ABOUT, truth::run)
}
