//! `fastslam-stack scenarios`: the built-in scenarios, one line each.

/// Prints each built-in scenario's name and the first line of its file.
pub fn run() {
    for (name, text) in fastslam_sensors_sim::scenario::BUILT_IN {
        let first = text
            .lines()
            .next()
            .unwrap_or_default()
            .trim_start_matches("# ");
        println!("{name:16} {first}");
    }
}
