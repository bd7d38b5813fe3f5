//! Sending: the topics this host publishes, from shared memory to the peers.
//!
//! A topic is subscribed to once it has a publisher here; its publisher token then tells
//! the peers. A message leaves only once a peer takes the topic (Zenoh matches a
//! subscriber); until then it stays in shared memory and its publisher waits once the
//! buffer is full, as it would for a slow subscriber on one host, so a stack that starts
//! before its peer loses nothing. The bridge is done sending once each stream it carried
//! has ended, it sent the last message, and the peer says it received the stream to its
//! end.
//!
//! Two things make a restart of a bridge lose nothing. A bridge that starts while its
//! peer already published some of its streams (it restarted mid-run) asks its sensors to
//! send again everything after what the peer published last (the request a resumed
//! service makes, on the checkpoint topic); the peer drops what it already has. And a
//! bridge whose peer went away and came back sends the last messages it sent again
//! ([`WINDOW_BYTES`]), which may have been on their way when the peer died; the peer, and
//! the client after it, skip those they already have.

use crate::frame::{self, Kind};
use crate::link::{Delivered, Keys, Token, zenoh_error};
use crate::routes::{Outgoing, Route, end_of_stream};
use anyhow::{Context as _, Result};
use fastslam_protocol::ipc::{Ended, Flow, Ipc, Pub, WakeSource};
use fastslam_protocol::stream::StreamEnd;
use fastslam_protocol::{Checkpointed, EndOfStream, Header, StreamId, topics};
use std::collections::{HashSet, VecDeque};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Publisher;
use zenoh::qos::CongestionControl;
use zenoh::sample::{Locality, SampleKind};

/// How often the loop looks for new publishers here and for peers.
const LOOK_EVERY: Duration = Duration::from_millis(5);

/// The last messages of each topic kept to send again to a peer that comes back, in
/// bytes (at least the last message is kept).
const WINDOW_BYTES: usize = 4 << 20;

/// How long messages may wait for a peer before the bridge says so (once).
const PEERLESS_WARNING: Duration = Duration::from_secs(10);

/// How long a starting bridge waits for its peers to say what they published.
const ASK_TIMEOUT: Duration = Duration::from_secs(2);

/// A topic being sent: the subscriber here, the publisher to the peers, and the token
/// that tells them the topic has a publisher.
struct Open {
    name: &'static str,
    port: Box<dyn Outgoing>,
    publisher: Publisher<'static>,
    _token: LivelinessToken,
}

/// How far a topic's stream got.
#[derive(Default)]
struct Progress {
    end: StreamEnd,
    /// A peer takes the topic (as last looked).
    matched: bool,
    /// A peer took the topic and went away: what it may have missed goes again when one
    /// comes back.
    peer_left: bool,
    /// Since when no peer has taken the topic.
    unmatched_since: Option<Instant>,
    sent: u64,
    /// The last frames sent, at most [`WINDOW_BYTES`] but the newest.
    window: VecDeque<Vec<u8>>,
    window_bytes: usize,
}

impl Progress {
    /// Keeps `frame`, forgetting the oldest beyond [`WINDOW_BYTES`].
    fn keep(&mut self, frame: Vec<u8>) {
        self.window_bytes += frame.len();
        self.window.push_back(frame);
        while self.window_bytes > WINDOW_BYTES
            && self.window.len() > 1
            && let Some(old) = self.window.pop_front()
        {
            self.window_bytes -= old.len();
        }
    }

    /// Records whether a peer takes the topic now; true when one came back after a peer
    /// went away.
    fn look(&mut self, matched: bool) -> bool {
        self.unmatched_since = if matched {
            None
        } else {
            Some(self.unmatched_since.unwrap_or_else(Instant::now))
        };
        let came_back = matched && self.peer_left;
        if self.matched && !matched {
            self.peer_left = true;
        }
        if came_back {
            self.peer_left = false;
        }
        self.matched = matched;
        came_back
    }
}

impl Open {
    /// Subscribes to `route` here and declares it to the peers.
    fn new(
        ipc: &Ipc,
        session: &zenoh::Session,
        keys: &Keys,
        route: &'static Route,
    ) -> Result<Self> {
        let name = route.row.topic.name;
        let port = route.outgoing(ipc)?;
        let publisher = session
            .declare_publisher(keys.data(name))
            .congestion_control(CongestionControl::Block)
            .express(true)
            .allowed_destination(Locality::Remote)
            .wait()
            .map_err(zenoh_error)
            .with_context(|| format!("declare the Zenoh publisher of {name}"))?;
        let token = session
            .liveliness()
            .declare_token(keys.token(Token::Publisher, name))
            .wait()
            .map_err(zenoh_error)
            .with_context(|| format!("announce {name} to the peers"))?;
        tracing::info!(topic = name, "sending to the peers once one takes it");
        Ok(Self {
            name,
            port,
            publisher,
            _token: token,
        })
    }

    /// Sends one frame to the peers.
    fn put(&self, frame: Vec<u8>) -> Result<()> {
        self.publisher
            .put(frame)
            .wait()
            .map_err(zenoh_error)
            .with_context(|| format!("send {}", self.name))
    }

    /// True when a peer takes the topic.
    fn matched(&self) -> Result<bool> {
        let status = self
            .publisher
            .matching_status()
            .wait()
            .map_err(zenoh_error)?;
        Ok(status.matching())
    }
}

/// Sends `routes` (and the end of their streams) until each has ended and a peer
/// received it, a signal arrives, or `stop` is set (the receiving side failed).
///
/// # Errors
/// IPC or Zenoh failures.
pub fn run(
    ipc: &Ipc,
    session: &zenoh::Session,
    keys: &Keys,
    routes: &[&'static Route],
    stop: &AtomicBool,
) -> Result<()> {
    if routes.is_empty() {
        return Ok(());
    }
    let all: Vec<&'static Route> = routes.iter().copied().chain([end_of_stream()]).collect();
    let kinds: Vec<Kind> = all.iter().map(|r| r.kind()).collect();
    let ours: Vec<StreamId> = routes.iter().filter_map(|r| r.row.stream).collect();
    let probes = all
        .iter()
        .map(|r| r.publishers(ipc))
        .collect::<Result<Vec<_>>>()?;
    let mut opens: Vec<Option<Open>> = all.iter().map(|_| None).collect();
    let mut progress: Vec<Progress> = all.iter().map(|_| Progress::default()).collect();
    let ends = session
        .liveliness()
        .declare_subscriber(keys.tokens(Token::Ended))
        .history(true)
        .wait()
        .map_err(zenoh_error)
        .context("follow what the peers received")?;
    let mut peer_ended: HashSet<String> = HashSet::new();
    let mut restart = Restart::default();
    let mut warned = false;
    loop {
        for (i, route) in all.iter().enumerate() {
            if opens[i].is_none() && probes[i]() > 0 {
                opens[i] = Some(Open::new(ipc, session, keys, route)?);
            }
        }
        let sources: Vec<&dyn WakeSource> =
            opens.iter().flatten().map(|o| o.port.source()).collect();
        let mut finished = false;
        let mut last_look: Option<Instant> = None;
        let ended = ipc.wake_loop(&sources, Some(LOOK_EVERY), || -> Result<Flow> {
            if stop.load(Ordering::Relaxed) {
                finished = true;
                return Ok(Flow::Stop);
            }
            let look = last_look.is_none_or(|t| t.elapsed() >= LOOK_EVERY);
            if look {
                last_look = Some(Instant::now());
                for (open, p) in opens.iter().zip(&mut progress) {
                    if let Some(open) = open
                        && p.look(open.matched()?)
                    {
                        send_again(open, p)?;
                    }
                }
                let streams: Vec<_> = open_streams(&all, &opens, &progress).collect();
                restart.check(ipc, session, keys, &ours, &streams)?;
                if !warned {
                    warned = warn_if_peerless(&streams);
                }
                while let Some(token) = ends.try_recv().map_err(zenoh_error)? {
                    if token.kind() == SampleKind::Put
                        && let Some(topic) = keys.topic_of(Token::Ended, token.key_expr().as_str())
                    {
                        peer_ended.insert(topic.to_string());
                    }
                }
            }
            let mut frame = Vec::new();
            for (i, open) in opens.iter().enumerate() {
                if let Some(open) = open {
                    let send = |body: &[u8]| -> Result<Vec<u8>> {
                        frame::encode(&kinds[i], body, &mut frame);
                        open.put(frame.clone())?;
                        Ok(std::mem::take(&mut frame))
                    };
                    send_pending(i, open.port.as_ref(), &all, &ours, &mut progress, send)?;
                }
            }
            if done(open_streams(&all, &opens, &progress), &peer_ended) {
                finished = true;
                return Ok(Flow::Stop);
            }
            let new_publisher = || (0..all.len()).any(|i| opens[i].is_none() && probes[i]() > 0);
            Ok(if look && new_publisher() {
                Flow::Stop
            } else {
                Flow::Continue
            })
        })?;
        if finished || ended == Ended::Signal {
            break;
        }
    }
    for (route, p) in all.iter().zip(&progress) {
        if p.sent > 0 {
            tracing::info!(topic = route.row.topic.name, messages = p.sent, "sent");
        }
    }
    Ok(())
}

/// Sends what waits on route `i` while a peer takes it: a message of a stream this side
/// carries is counted in that stream's progress; an end of another stream (one this host
/// received from a peer) is not sent back.
fn send_pending(
    i: usize,
    port: &dyn Outgoing,
    all: &[&'static Route],
    ours: &[StreamId],
    progress: &mut [Progress],
    mut send: impl FnMut(&[u8]) -> Result<Vec<u8>>,
) -> Result<()> {
    let mut failed = None;
    let ends_streams = std::ptr::eq(all[i], end_of_stream());
    port.drain(&mut |header, body| {
        let stream = if ends_streams {
            let eos: EndOfStream = bytemuck::pod_read_unaligned(body);
            match StreamId::from_u32(eos.stream).filter(|s| ours.contains(s)) {
                Some(stream) => Some((stream, eos)),
                None => return true,
            }
        } else {
            None
        };
        if !progress[i].matched {
            return false;
        }
        match send(body) {
            Ok(frame) => progress[i].keep(frame),
            Err(e) => {
                failed = Some(e);
                return false;
            }
        }
        progress[i].sent += 1;
        match stream {
            Some((stream, eos)) => {
                if let Some(j) = all.iter().position(|r| r.row.stream == Some(stream)) {
                    progress[j].end.announce(&eos);
                }
            }
            None => progress[i].end.saw(header.seq),
        }
        true
    })?;
    failed.map_or(Ok(()), Err)
}

/// Sends the frames kept of a topic again, to a peer that came back.
fn send_again(open: &Open, p: &Progress) -> Result<()> {
    for frame in &p.window {
        open.put(frame.clone())?;
    }
    tracing::info!(
        topic = open.name,
        messages = p.window.len(),
        "a peer came back: sent the last messages again"
    );
    Ok(())
}

/// A bridge that starts while its peer already published some of the streams it sends
/// (it restarted mid-run): once a peer takes every stream open here, it asks the peer
/// what it published last and, if anything, asks the sensors here for everything after
/// that, as a resumed service does.
#[derive(Default)]
struct Restart {
    /// Looked already.
    checked: bool,
    /// The publisher of the request, kept until the bridge ends (a sample lives in its
    /// publisher's memory).
    request: Option<Pub<Checkpointed, ()>>,
}

impl Restart {
    /// Asks, once a peer takes every stream open here (`streams`, of `ours`).
    fn check(
        &mut self,
        ipc: &Ipc,
        session: &zenoh::Session,
        keys: &Keys,
        ours: &[StreamId],
        streams: &[(&'static Route, &Progress)],
    ) -> Result<()> {
        if self.checked || streams.is_empty() || !streams.iter().all(|(_, p)| p.matched) {
            return Ok(());
        }
        self.checked = true;
        let delivered = ask_delivered(session, keys)?;
        let covered: Vec<(StreamId, u64)> = (topics::TABLE.iter())
            .filter(|row| row.publisher == topics::Publisher::Sensor)
            .filter_map(|row| row.stream)
            .filter(|id| ours.contains(id))
            .filter_map(|id| delivered.of(id).map(|h| (id, h.stamp_ns)))
            .collect();
        if covered.is_empty() {
            return Ok(());
        }
        tracing::warn!(
            ?covered,
            "the peer already published part of the sensor streams (this bridge restarted): \
             asking the sensors for everything after it"
        );
        let request = ipc.newest_only_publisher::<Checkpointed>(&topics::CHECKPOINT)?;
        request.send(Checkpointed::new(Header::default(), covered, true))?;
        self.request = Some(request);
        Ok(())
    }
}

/// What the peers published last of each stream they receive.
fn ask_delivered(session: &zenoh::Session, keys: &Keys) -> Result<Delivered> {
    let replies = session
        .get(keys.delivered())
        .allowed_destination(Locality::Remote)
        .timeout(ASK_TIMEOUT)
        .wait()
        .map_err(zenoh_error)
        .context("ask the peers what they published")?;
    let mut delivered = Delivered::default();
    while let Ok(reply) = replies.recv() {
        if let Ok(sample) = reply.result() {
            let text = sample.payload().try_to_string().unwrap_or_default();
            delivered.0.extend(Delivered::decode(&text).0);
        }
    }
    Ok(delivered)
}

/// Warns once messages of `streams` waited [`PEERLESS_WARNING`] for a peer; true when it
/// did.
fn warn_if_peerless(streams: &[(&'static Route, &Progress)]) -> bool {
    let waiting: Vec<&str> = streams
        .iter()
        .filter(|(_, p)| {
            p.unmatched_since
                .is_some_and(|t| t.elapsed() >= PEERLESS_WARNING)
        })
        .map(|(route, _)| route.row.topic.name)
        .collect();
    if waiting.is_empty() {
        return false;
    }
    tracing::warn!(
        topics = ?waiting,
        "no peer has taken these for {} s: is the other host's bridge running, on the other \
         --side, with the same --key, and reachable (--listen on one host, --connect to it on \
         the other)?",
        PEERLESS_WARNING.as_secs()
    );
    true
}

/// The streams being sent: each open route that carries a stream, with its progress.
fn open_streams<'a>(
    all: &'a [&'static Route],
    opens: &'a [Option<Open>],
    progress: &'a [Progress],
) -> impl Iterator<Item = (&'static Route, &'a Progress)> + Clone {
    all.iter()
        .zip(opens)
        .zip(progress)
        .filter(|((route, open), _)| route.row.stream.is_some() && open.is_some())
        .map(|((route, _), p)| (*route, p))
}

/// True once every stream sent (`streams`) has ended, its last message left, and a peer
/// received it to the end (and at least one stream was sent).
fn done<'a>(
    mut streams: impl Iterator<Item = (&'static Route, &'a Progress)> + Clone,
    peer_ended: &HashSet<String>,
) -> bool {
    streams.clone().next().is_some()
        && streams.all(|(route, p)| p.end.finished() && peer_ended.contains(route.row.topic.name))
}
