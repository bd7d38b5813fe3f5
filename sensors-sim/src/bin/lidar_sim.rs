//! The `lidar-sim` process on its own (the launcher starts the same code as `fastslam-stack lidar-sim`).

use fastslam_sensors_sim::processes::lidar;

fn main() -> std::process::ExitCode {
    fastslam_protocol::cli::main_of("lidar-sim", lidar::ABOUT, lidar::run)
}
