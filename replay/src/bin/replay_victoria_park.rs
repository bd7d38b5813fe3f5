//! The `replay-victoria-park` process on its own (the launcher starts the same code as `fastslam-stack replay-victoria-park`).

use fastslam_replay::processes::victoria_park;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of(
        "replay-victoria-park",
        victoria_park::ABOUT,
        victoria_park::run,
    )
}
