//! The live viewer on its own (the launcher starts the same code as `fastslam-stack viewer`).

use fastslam_client::viewer;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("viewer", viewer::ABOUT, viewer::run)
}
