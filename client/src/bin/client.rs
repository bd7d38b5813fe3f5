//! The metrics client on its own (the launcher starts the same code as `fastslam-stack client`).

use fastslam_client::process;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("client", process::ABOUT, process::run)
}
