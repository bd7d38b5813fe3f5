//! The Zenoh side of a bridge: how the session is opened ([`ZenohArgs`]) and the keys a
//! bridge uses below its `--key` ([`Keys`]).
//!
//! Besides the messages (`<key>/data/<topic>`), bridges tell each other two things with
//! liveliness tokens: which topics have a publisher on their host
//! (`<key>/publishers/<topic>`: the peer then opens a publisher of its own, so a process
//! there that picks its input by which topic has a publisher picks the same as on one
//! host), and which streams they have received to the end (`<key>/ended/<topic>`: the
//! sender may then leave, knowing nothing was still on its way).

use anyhow::{Context as _, Result, bail};
use fastslam_protocol::ipc::shutdown;
use fastslam_protocol::{Header, StreamId};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::{Duration, Instant};
use zenoh::{Session, Wait};

/// How often a connecting bridge looks for a peer, a signal and its timeout.
const CONNECT_POLL: Duration = Duration::from_millis(50);

/// The Zenoh key bridges use unless told otherwise.
pub const DEFAULT_KEY: &str = "fastslam";

/// How a bridge reaches its peers.
#[derive(Debug, Clone, clap::Args)]
pub struct ZenohArgs {
    /// Zenoh endpoints to listen on, comma-separated (`tcp/0.0.0.0:7447`): the other
    /// host's bridge connects to one of them.
    #[arg(long, value_delimiter = ',', value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Zenoh endpoints to connect to, comma-separated (`tcp/192.168.1.20:7447`); the
    /// bridge retries until the peer listens.
    #[arg(long, value_delimiter = ',', value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// The Zenoh key below which this stack's topics travel: bridges with the same key
    /// exchange topics, bridges of other stacks on the same network use other keys.
    #[arg(long, default_value = DEFAULT_KEY)]
    pub key: String,
    /// Also find peers by UDP multicast on the local network (off: only the peers given by
    /// `--listen` and `--connect`).
    #[arg(long)]
    pub multicast: bool,
}

impl ZenohArgs {
    /// Checks that the flags name a way to the peers and a valid key.
    ///
    /// # Errors
    /// No endpoint and no multicast, or a key Zenoh refuses.
    pub fn check(&self) -> Result<()> {
        if self.listen.is_empty() && self.connect.is_empty() && !self.multicast {
            bail!(
                "the bridge has no peer to reach: give --listen (e.g. tcp/0.0.0.0:7447) on one \
                 host and --connect (e.g. tcp/<that host>:7447) on the other, or --multicast"
            );
        }
        zenoh::key_expr::KeyExpr::try_from(self.key.as_str()).map_err(|e| {
            zenoh_error(e).context(format!("--key {:?} is not a Zenoh key", self.key))
        })?;
        for (flag, endpoints) in [("--listen", &self.listen), ("--connect", &self.connect)] {
            for endpoint in endpoints {
                endpoint.parse::<zenoh::config::EndPoint>().map_err(|e| {
                    zenoh_error(e).context(format!("{flag} {endpoint:?} is not an endpoint"))
                })?;
            }
        }
        Ok(())
    }

    /// The same flags, for a bridge process.
    pub fn flags(&self) -> Vec<String> {
        let mut flags = vec!["--key".to_string(), self.key.clone()];
        if !self.listen.is_empty() {
            flags.extend(["--listen".into(), self.listen.join(",")]);
        }
        if !self.connect.is_empty() {
            flags.extend(["--connect".into(), self.connect.join(",")]);
        }
        if self.multicast {
            flags.push("--multicast".into());
        }
        flags
    }

    /// Opens the Zenoh session ([`ZenohArgs::open`]) and, with `--connect`, waits until a
    /// peer answers. Returns `None` once SIGINT or SIGTERM arrived. The session opens and
    /// waits on a thread of its own, which is abandoned at a signal or at `timeout`, so
    /// that neither a session that blocks while it opens nor an endpoint that never
    /// answers holds the bridge past either.
    ///
    /// # Errors
    /// As [`ZenohArgs::open`], and no peer answering within `timeout`.
    pub fn connect(&self, timeout: Duration) -> Result<Option<Session>> {
        shutdown::install();
        tracing::info!(
            listen = ?self.listen,
            connect = ?self.connect,
            "opening the Zenoh session"
        );
        let started = Instant::now();
        let (sender, receiver) = mpsc::channel();
        let abandoned = Arc::new(AtomicBool::new(false));
        let (args, given_up) = (self.clone(), Arc::clone(&abandoned));
        let span = tracing::Span::current();
        std::thread::Builder::new()
            .name("zenoh-connect".into())
            .spawn(move || {
                let _in_span = span.enter();
                let session = args.open().inspect(|s| {
                    while !args.connect.is_empty()
                        && !given_up.load(Ordering::Relaxed)
                        && !has_peers(s)
                    {
                        std::thread::sleep(CONNECT_POLL);
                    }
                });
                // Gave up: the session closes here, however long that takes.
                let _ = sender.send(session);
            })
            .context("start the thread that opens the Zenoh session")?;
        loop {
            match receiver.recv_timeout(CONNECT_POLL) {
                Ok(session) => return session.map(Some),
                Err(RecvTimeoutError::Disconnected) => bail!("opening the Zenoh session panicked"),
                Err(RecvTimeoutError::Timeout) => {}
            }
            let stop = shutdown::requested();
            if stop || started.elapsed() > timeout {
                abandoned.store(true, Ordering::Relaxed);
                if stop {
                    return Ok(None);
                }
                bail!(
                    "no peer answered at {} within {} s (--wait-timeout-s): is the other \
                     host's bridge running and listening there, and the port open?",
                    self.connect.join(", "),
                    timeout.as_secs_f64()
                );
            }
        }
    }

    /// Opens the Zenoh session: a peer that listens and connects where it was told.
    ///
    /// # Errors
    /// No endpoint and no multicast, a key or endpoint Zenoh refuses, or a port that
    /// cannot be bound.
    pub fn open(&self) -> Result<Session> {
        self.check()?;
        let mut config = zenoh::Config::default();
        let mut set = |path: &str, value: String| {
            config
                .insert_json5(path, &value)
                .map_err(|e| zenoh_error(e).context(format!("{path} = {value}")))
        };
        set("mode", "\"peer\"".into())?;
        set("listen/endpoints", json_list(&self.listen))?;
        set("connect/endpoints", json_list(&self.connect))?;
        set(
            "connect/retry",
            "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}".into(),
        )?;
        set("scouting/multicast/enabled", self.multicast.to_string())?;
        zenoh::open(config)
            .wait()
            .map_err(zenoh_error)
            .context("open the Zenoh session")
    }
}

/// A Zenoh error as an `anyhow` error (Zenoh's boxed errors do not convert by `?`),
/// without the source locations Zenoh writes into its messages: they name files on the
/// machine that built the binary, nothing a user can act on.
pub(crate) fn zenoh_error(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!(without_source_locations(&e.to_string()))
}

/// `text` without the ` at <file>.rs:<line>.` Zenoh appends to each of its errors
/// (nested ones included).
fn without_source_locations(text: &str) -> String {
    let is_location = |word: &str| {
        let word = word.strip_suffix('.').unwrap_or(word);
        word.rsplit_once(':').is_some_and(|(file, line)| {
            file.ends_with(".rs") && !line.is_empty() && line.bytes().all(|b| b.is_ascii_digit())
        })
    };
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(" at ") {
        let after = &rest[at + " at ".len()..];
        let end = after
            .find(|c: char| c.is_whitespace() || "]\"),".contains(c))
            .unwrap_or(after.len());
        if is_location(&after[..end]) {
            out.push_str(&rest[..at]);
        } else {
            out.push_str(&rest[..at + " at ".len()]);
            out.push_str(&after[..end]);
        }
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// True when the session is connected to a peer.
fn has_peers(session: &Session) -> bool {
    session.info().peers_zid().wait().next().is_some()
}

/// A JSON list of strings.
fn json_list(items: &[String]) -> String {
    let quoted: Vec<String> = items.iter().map(|i| format!("{i:?}")).collect();
    format!("[{}]", quoted.join(","))
}

/// What a liveliness token says about a topic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Token {
    /// The topic has a publisher on the host that declares it.
    Publisher,
    /// The host that declares it received the topic's stream to its end.
    Ended,
}

impl Token {
    /// Its chunk in the key.
    fn chunk(self) -> &'static str {
        match self {
            Self::Publisher => "publishers",
            Self::Ended => "ended",
        }
    }
}

/// The keys of one stack's bridges.
#[derive(Debug, Clone)]
pub struct Keys {
    key: String,
}

impl Keys {
    /// The keys below `key`.
    pub fn new(key: &str) -> Self {
        Self {
            key: key.to_string(),
        }
    }

    /// Where the messages of `topic` travel.
    pub fn data(&self, topic: &str) -> String {
        format!("{}/data/{topic}", self.key)
    }

    /// The query a bridge answers with the newest message it published of each stream
    /// it receives ([`Delivered`]).
    pub fn delivered(&self) -> String {
        format!("{}/delivered", self.key)
    }

    /// The token `what` of `topic`.
    pub fn token(&self, what: Token, topic: &str) -> String {
        format!("{}/{}/{topic}", self.key, what.chunk())
    }

    /// Every token `what`, as a key expression.
    pub fn tokens(&self, what: Token) -> String {
        self.token(what, "**")
    }

    /// The topic a token `what` names.
    pub fn topic_of<'a>(&self, what: Token, token: &'a str) -> Option<&'a str> {
        token.strip_prefix(&self.token(what, ""))
    }
}

/// The newest message a bridge published on its host of each stream it receives: what
/// a restarted peer needs to ask its sensors for again. On the wire, one line per stream:
/// `<stream id> <stamp_ns> <seq>`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Delivered(pub Vec<(StreamId, Header)>);

impl Delivered {
    /// The answer's text.
    pub fn encode(&self) -> String {
        self.0
            .iter()
            .map(|(id, h)| format!("{} {} {}\n", *id as u32, h.stamp_ns, h.seq))
            .collect()
    }

    /// Reads an answer; lines it cannot read are left out.
    pub fn decode(text: &str) -> Self {
        let line = |l: &str| {
            let mut words = l.split_whitespace().map(str::parse::<u64>);
            let id = StreamId::from_u32(u32::try_from(words.next()?.ok()?).ok()?)?;
            let stamp_ns = words.next()?.ok()?;
            let seq = words.next()?.ok()?;
            Some((id, Header { stamp_ns, seq }))
        };
        Self(text.lines().filter_map(line).collect())
    }

    /// The newest message of stream `id`.
    pub fn of(&self, id: StreamId) -> Option<Header> {
        self.0.iter().find(|(s, _)| *s == id).map(|(_, h)| *h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_give_back_their_topic() {
        let keys = Keys::new("fastslam/robot1");
        assert_eq!(
            keys.data("smoothed/map"),
            "fastslam/robot1/data/smoothed/map"
        );
        let token = keys.token(Token::Publisher, "smoothed/map");
        assert_eq!(
            keys.topic_of(Token::Publisher, &token),
            Some("smoothed/map")
        );
        let ended = keys.token(Token::Ended, "pose");
        assert_eq!(keys.topic_of(Token::Ended, &ended), Some("pose"));
        assert_eq!(keys.topic_of(Token::Ended, &token), None);
        assert_eq!(keys.tokens(Token::Ended), "fastslam/robot1/ended/**");
    }

    #[test]
    fn what_was_delivered_reads_back() {
        let delivered = Delivered(vec![
            (
                StreamId::Odometry,
                Header {
                    stamp_ns: 1_500_000_000,
                    seq: 7,
                },
            ),
            (
                StreamId::Scan,
                Header {
                    stamp_ns: 2,
                    seq: 0,
                },
            ),
        ]);
        assert_eq!(Delivered::decode(&delivered.encode()), delivered);
        assert_eq!(delivered.of(StreamId::Scan).map(|h| h.seq), Some(0));
        assert_eq!(Delivered::decode("2 x 1\n99 1 1\n\n3 5").0, vec![]);
    }

    #[test]
    fn a_bridge_without_a_peer_is_refused_with_what_to_give() {
        let args = ZenohArgs {
            listen: vec![],
            connect: vec![],
            key: "fastslam".into(),
            multicast: false,
        };
        let e = args.open().unwrap_err().to_string();
        assert!(e.contains("--listen") && e.contains("--connect"), "{e}");
    }

    #[test]
    fn a_bad_endpoint_is_named_without_the_build_machines_paths() {
        let args = ZenohArgs {
            listen: vec![],
            connect: vec!["tcp/127.0.0.1:7447".into(), "nonsense".into()],
            key: "fastslam".into(),
            multicast: false,
        };
        let e = format!("{:#}", args.check().unwrap_err());
        assert!(
            e.starts_with("--connect \"nonsense\" is not an endpoint: "),
            "{e}"
        );
        assert!(!e.contains(".rs:") && !e.contains("/src/"), "{e}");
    }

    #[test]
    fn source_locations_leave_zenohs_messages_and_nothing_else() {
        let zenoh = "Can not create a new TCP listener bound to tcp/1.2.3.4:7447: [1.2.3.4:7447: \
             Cannot assign requested address (os error 99) at /root/.cargo/registry/src/\
             index.crates.io-1949cf8c6b5b557f/zenoh-link-commons-1.10.2/src/tcp.rs:61.] at \
             /root/.cargo/registry/src/x/zenoh-link-tcp-1.10.2/src/unicast.rs:338.";
        assert_eq!(
            without_source_locations(zenoh),
            "Can not create a new TCP listener bound to tcp/1.2.3.4:7447: [1.2.3.4:7447: \
             Cannot assign requested address (os error 99)]"
        );
        let plain = "a peer at tcp/10.0.0.2:7447 left at 12:30.";
        assert_eq!(without_source_locations(plain), plain);
    }
}
