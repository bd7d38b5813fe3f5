//! The `odometry-sim` process on its own (the launcher starts the same code as `fastslam-stack odometry-sim`).

use fastslam_sensors_sim::processes::odometry;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("odometry-sim", odometry::ABOUT, odometry::run)
}
