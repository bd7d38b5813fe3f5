//! The bridge between hosts: carries chosen topics of one host's stack to another host's
//! over Zenoh, so the sensors can run on the robot and the estimator on another computer.
//!
//! Each host runs its stack on its own iceoryx2 shared memory and one bridge. A bridge
//! subscribes to the topics it exports and publishes the topics it imports, as any other
//! process of the stack does; between the bridges, each message travels as the bytes of
//! its `#[repr(C)]` type behind a small header with the type's name and the contract
//! version ([`frame`]), so a peer of another release is refused with the reason instead
//! of misread. Delivery is lossless as on one host: a message leaves only once a peer
//! takes its topic, Zenoh runs reliable with blocking congestion control, and a full
//! subscriber buffer on the receiving host makes the sender wait.
//!
//! One file per concern:
//! - [`frame`]: the bytes of one message on the wire;
//! - [`routes`]: the topics a bridge carries and their types;
//! - [`link`]: the Zenoh session and the keys;
//! - [`export`]: from shared memory to the peers;
//! - [`import`]: from the peers into shared memory.

// Messages travel as the bytes they are in memory, and the contract is little-endian.
#[cfg(target_endian = "big")]
compile_error!(
    "the bridge sends messages as they lie in memory: big-endian hosts are not supported"
);

pub mod export;
pub mod frame;
pub mod import;
pub mod link;
pub mod routes;

use anyhow::{Result, bail};
use fastslam_protocol::cli;
use fastslam_protocol::ipc::Ipc;
use fastslam_protocol::topics::{self, Publisher};
use routes::Route;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Which end of the link a host is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Side {
    /// The host with the sensors (and the client): sends odometry, observations and scans;
    /// receives poses, maps, grids, smoothed trajectories, particles, status and
    /// checkpoints.
    Sensors,
    /// The host with the FastSLAM service: the reverse.
    Service,
}

/// Flags of the bridge.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// The stack on this host.
    #[command(flatten)]
    pub stack: cli::StackArgs,
    /// Which end of the link this host is; it chooses what is sent and received.
    #[arg(long, value_enum)]
    pub side: Option<Side>,
    /// Topics to send to the peers, comma-separated (instead of --side's): odometry,
    /// observations, scan, ground_truth, pose, map, grid, smoothed/trajectory,
    /// smoothed/map, particles, status, checkpoint.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "TOPIC",
        conflicts_with = "side"
    )]
    pub export: Vec<String>,
    /// Topics to receive from the peers, comma-separated (instead of --side's); the same
    /// names as --export.
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "TOPIC",
        conflicts_with = "side"
    )]
    pub import: Vec<String>,
    /// The peers and the key.
    #[command(flatten)]
    pub zenoh: link::ZenohArgs,
    /// Give up waiting (for a peer to answer at --connect, for a subscriber here to leave,
    /// for the stack's services) after this many seconds.
    #[arg(long, default_value_t = 60.0)]
    pub wait_timeout_s: f64,
}

impl Args {
    /// The routes to send and to receive.
    ///
    /// # Errors
    /// An unknown topic, a topic both sent and received, or nothing to carry.
    pub fn routes(&self) -> Result<(Vec<&'static Route>, Vec<&'static Route>)> {
        let (export, import): (Vec<String>, Vec<String>) = match self.side {
            Some(Side::Sensors) => (names(Publisher::Sensor), names(Publisher::Service)),
            Some(Side::Service) => (names(Publisher::Service), names(Publisher::Sensor)),
            None => (self.export.clone(), self.import.clone()),
        };
        if export.is_empty() && import.is_empty() {
            bail!("nothing to carry: give --side sensors|service, or --export and --import");
        }
        if let Some(both) = export.iter().find(|t| import.contains(t)) {
            bail!("{both} is both sent and received: a topic travels one way");
        }
        Ok((lookup(&export)?, lookup(&import)?))
    }
}

/// The names of the topics `publisher` publishes: what its host sends.
fn names(publisher: Publisher) -> Vec<String> {
    (topics::TABLE.iter())
        .filter(|row| row.publisher == publisher)
        .map(|row| row.topic.name.to_string())
        .collect()
}

/// The routes of `topics`.
fn lookup(topics: &[String]) -> Result<Vec<&'static Route>> {
    topics
        .iter()
        .map(|t| match routes::by_name(t) {
            Some(route) if !std::ptr::eq(route, routes::end_of_stream()) => Ok(route),
            _ => {
                let known: Vec<&str> = routes::ROUTES
                    .iter()
                    .filter(|r| !std::ptr::eq(*r, routes::end_of_stream()))
                    .map(|r| r.row.topic.name)
                    .collect();
                bail!(
                    "a bridge cannot carry {t:?}; it carries {} (end_of_stream always goes both ways)",
                    known.join(", ")
                )
            }
        })
        .collect()
}

/// Runs the bridge until every stream it carried has ended (or a signal arrives).
///
/// # Errors
/// Bad flags, a Zenoh session that cannot be opened, no peer answering at `--connect`
/// within `--wait-timeout-s`, IPC failures.
pub fn run(args: Args) -> Result<()> {
    let (export, import) = args.routes()?;
    let timeout = Duration::from_secs_f64(args.wait_timeout_s);
    let Some(session) = args.zenoh.connect(timeout)? else {
        return Ok(()); // a signal while connecting
    };
    let keys = link::Keys::new(&args.zenoh.key);
    let stack = args.stack.stack();
    tracing::info!(
        key = %args.zenoh.key,
        sends = ?export.iter().map(|r| r.row.topic.name).collect::<Vec<_>>(),
        receives = ?import.iter().map(|r| r.row.topic.name).collect::<Vec<_>>(),
        "bridge up"
    );
    // Set when one direction fails, so that the other stops too.
    let failed = AtomicBool::new(false);
    // iceoryx2 ports stay on the thread that made them: one connection per direction.
    let result = std::thread::scope(|scope| {
        let side = |name: &'static str, routes: Vec<&'static Route>, run: Direction| {
            let (stack, session, keys, failed) = (&stack, &session, &keys, &failed);
            std::thread::Builder::new()
                .name(name.into())
                .spawn_scoped(scope, move || {
                    let result = cli::in_process_span("bridge", || {
                        let ipc = Ipc::open(stack, "bridge", timeout)?;
                        run(&ipc, session, keys, &routes, failed)
                    });
                    if result.is_err() {
                        failed.store(true, Ordering::Relaxed);
                    }
                    result
                })
        };
        let sending = side("bridge-send", export, export::run)?;
        let receiving = side("bridge-receive", import, import::run)?;
        let joined = |h: std::thread::ScopedJoinHandle<'_, Result<()>>| {
            h.join()
                .unwrap_or_else(|_| bail!("a bridge thread panicked"))
        };
        let (sent, received) = (joined(sending), joined(receiving));
        sent.and(received)
    });
    // What was sent was received (the peers said so): nothing is left to flush.
    let _ = zenoh::Wait::wait(session.close());
    result
}

/// One direction of the bridge: it stops early, without an error of its own, once the
/// flag says the other direction failed.
type Direction =
    fn(&Ipc, &zenoh::Session, &link::Keys, &[&'static Route], &AtomicBool) -> Result<()>;

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn parse(flags: &[&str]) -> Result<Args, clap::Error> {
        Cli::try_parse_from(std::iter::once("bridge").chain(flags.iter().copied())).map(|c| c.args)
    }

    fn topic_names(routes: &[&Route]) -> Vec<&'static str> {
        routes.iter().map(|r| r.row.topic.name).collect()
    }

    #[test]
    fn the_two_sides_mirror_each_other() {
        let sensors = parse(&["--side", "sensors", "--listen", "tcp/127.0.0.1:7447"]).unwrap();
        let service = parse(&["--side", "service", "--connect", "tcp/127.0.0.1:7447"]).unwrap();
        let (out, back) = sensors.routes().unwrap();
        let (service_out, service_back) = service.routes().unwrap();
        assert_eq!(topic_names(&out), topic_names(&service_back));
        assert_eq!(topic_names(&back), topic_names(&service_out));
        assert_eq!(topic_names(&out), ["odometry", "observations", "scan"]);
    }

    #[test]
    fn unknown_topics_and_topics_both_ways_are_refused_with_the_reason() {
        let e = parse(&["--export", "odometry,odometri"])
            .unwrap()
            .routes()
            .unwrap_err();
        assert!(
            e.to_string().contains("\"odometri\"") && e.to_string().contains("pose"),
            "{e}"
        );
        let e = parse(&["--export", "pose", "--import", "pose"])
            .unwrap()
            .routes()
            .unwrap_err();
        assert!(e.to_string().contains("one way"), "{e}");
        let e = parse(&["--export", "end_of_stream"])
            .unwrap()
            .routes()
            .unwrap_err();
        assert!(e.to_string().contains("both ways"), "{e}");
        assert!(parse(&[]).unwrap().routes().is_err());
        assert!(parse(&["--side", "sensors", "--export", "pose"]).is_err());
    }
}
