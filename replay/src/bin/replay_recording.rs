//! The `replay-recording` process on its own (the launcher starts the same code as `fastslam-stack replay-recording`).

use fastslam_replay::processes::recording;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("replay-recording", recording::ABOUT, recording::run)
}
