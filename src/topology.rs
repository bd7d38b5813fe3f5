//! The processes of a stack and who consumes what each of them publishes. A producer
//! starts publishing once its consumers have subscribed (`--wait-subscribers`), so a
//! consumer that starts late loses nothing; the counts come from this one table, for
//! `run` and `replay` alike, and the processes start in its order (consumers first).
//! With `--live` the live viewer ([`VIEWER`]) starts first and is one more consumer of
//! every producer.

/// One process of a stack and the processes that consume what it waits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Role {
    /// The process (its subcommand).
    pub name: &'static str,
    /// The processes whose subscriptions it waits for before it publishes.
    pub consumers: &'static [&'static str],
}

/// The live viewer (`--live`): it subscribes to every topic, so every producer waits for
/// its subscription too.
pub const VIEWER: &str = "viewer";

impl Role {
    /// Its `--wait-subscribers` count; with the live viewer (`live`), one more for a
    /// process that waits for anyone (a producer).
    pub fn wait_subscribers(&self, live: bool) -> usize {
        match self.consumers.len() {
            0 => 0,
            n => n + usize::from(live),
        }
    }

    /// `--wait-subscribers N` when it waits for anyone, else nothing.
    pub fn wait_flags(&self, live: bool) -> Vec<String> {
        match self.wait_subscribers(live) {
            0 => Vec::new(),
            n => vec!["--wait-subscribers".into(), n.to_string()],
        }
    }
}

/// A simulated stack (`run`): the truth feeds both sensors and the client; the
/// sensors feed the service and the client (which measures latency on the lidar); the
/// service feeds the client.
pub const SIMULATION: [Role; 5] = [
    Role {
        name: "client",
        consumers: &[],
    },
    Role {
        name: "service",
        consumers: &["client"],
    },
    Role {
        name: "odometry-sim",
        consumers: &["service", "client"],
    },
    Role {
        name: "lidar-sim",
        consumers: &["service", "client"],
    },
    Role {
        name: "truth-sim",
        consumers: &["odometry-sim", "lidar-sim", "client"],
    },
];

/// A replayed stack (`replay`): one replay process plays every stream to the service
/// and the client.
pub const REPLAY: [Role; 3] = [
    Role {
        name: "client",
        consumers: &[],
    },
    Role {
        name: "service",
        consumers: &["client"],
    },
    Role {
        name: "replay",
        consumers: &["service", "client"],
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_consumer_is_a_process_of_the_stack_that_starts_before_its_producer() {
        for stack in [&SIMULATION[..], &REPLAY[..]] {
            for (i, role) in stack.iter().enumerate() {
                for consumer in role.consumers {
                    let at = stack.iter().position(|r| r.name == *consumer);
                    assert!(at.is_some_and(|at| at < i), "{consumer} of {}", role.name);
                }
            }
        }
        assert_eq!(SIMULATION[4].wait_subscribers(false), 3);
        assert_eq!(SIMULATION[4].wait_subscribers(true), 4);
        assert_eq!(
            SIMULATION[0].wait_subscribers(true),
            0,
            "the client publishes nothing"
        );
    }
}
