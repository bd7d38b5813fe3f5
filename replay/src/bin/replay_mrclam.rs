//! The `replay-mrclam` process on its own (the launcher starts the same code as `fastslam-stack replay-mrclam`).

use fastslam_replay::processes::mrclam;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("replay-mrclam", mrclam::ABOUT, mrclam::run)
}
