//! The FastSLAM service on its own (the launcher starts the same code as `fastslam-stack service`).

use fastslam_service::process;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("service", process::ABOUT, process::run)
}
