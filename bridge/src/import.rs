//! Receiving: the topics a peer publishes, from Zenoh into shared memory.
//!
//! A topic gets a publisher here once a peer's token says it has one there, so that a
//! process here that waits for a publisher, or picks its input by which topic has one,
//! sees what it would on the peer's host. The bridge takes the topic from the peers only
//! once a process here subscribed to it, so nothing is published before anyone here can
//! receive it: meanwhile the peer's bridge holds the messages back. A message that finds
//! a subscriber's buffer full waits, and so, through Zenoh's blocking congestion control,
//! does the peer. The bridge is done receiving once each stream it received has ended
//! and its last message was published; it then tells the peers and waits for the
//! subscribers here to leave.

use crate::frame::{self, Kind, Refused};
use crate::link::{Delivered, Keys, Token, zenoh_error};
use crate::routes::{Incoming, Route, end_of_stream, header_of};
use anyhow::{Context as _, Result};
use fastslam_protocol::ipc::{Ipc, shutdown};
use fastslam_protocol::stream::{Repeats, StreamEnd};
use fastslam_protocol::{EndOfStream, StreamId};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, SyncSender, sync_channel};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;
use zenoh::Wait;
use zenoh::bytes::ZBytes;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::Queryable;
use zenoh::sample::{Locality, SampleKind};

/// How often the loop looks for new topics and subscribers when nothing arrives.
const LOOK_EVERY: Duration = Duration::from_millis(5);

/// Messages received from Zenoh and not yet published: beyond this Zenoh's receiving
/// thread waits, and so, once its buffers are full, does the sender.
const QUEUE: usize = 64;

/// One topic this host receives.
struct In {
    route: &'static Route,
    kind: Kind,
    port: Option<Box<dyn Incoming>>,
    subscriber: Option<Subscriber<()>>,
    end: StreamEnd,
    received: u64,
    /// Messages taken again and dropped: already published here (sent again after a
    /// bridge restarted).
    repeated: u64,
    /// Frames refused so far (the first is logged with its reason).
    refused: u64,
    /// The token telling the peers the stream arrived to its end.
    ended: Option<LivelinessToken>,
}

/// Receives `routes` (and the end of their streams) until each stream that got a
/// publisher here has ended, then waits for this host's subscribers to leave; or until a
/// signal arrives or `stop` is set (the sending side failed).
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
    let theirs: Vec<StreamId> = routes.iter().filter_map(|r| r.row.stream).collect();
    let mut ins: Vec<In> = routes
        .iter()
        .copied()
        .chain([end_of_stream()])
        .map(|route| In {
            route,
            kind: route.kind(),
            port: None,
            subscriber: None,
            end: StreamEnd::default(),
            received: 0,
            repeated: 0,
            refused: 0,
            ended: None,
        })
        .collect();
    let eos = ins.len() - 1;
    ins[eos].port = Some(ins[eos].route.incoming(ipc)?);
    let publishers = session
        .liveliness()
        .declare_subscriber(keys.tokens(Token::Publisher))
        .history(true)
        .wait()
        .map_err(zenoh_error)
        .context("follow the peers' publishers")?;
    let delivered = Arc::new(Mutex::new(Repeats::default()));
    let _answer = answer_delivered(session, keys, &theirs, &delivered)?;
    let (tx, rx) = sync_channel::<(usize, ZBytes)>(QUEUE);
    let stopped = || shutdown::requested() || stop.load(Ordering::Relaxed);
    while !stopped() {
        while let Some(token) = publishers.try_recv().map_err(zenoh_error)? {
            let topic = keys.topic_of(Token::Publisher, token.key_expr().as_str());
            if token.kind() == SampleKind::Put
                && let Some(i) = ins
                    .iter()
                    .position(|s| Some(s.route.row.topic.name) == topic)
                && ins[i].port.is_none()
            {
                ins[i].port = Some(ins[i].route.incoming(ipc)?);
                tracing::info!(topic = ins[i].route.row.topic.name, "a peer publishes it");
            }
        }
        for (i, s) in ins.iter_mut().enumerate() {
            if s.subscriber.is_none() && s.port.as_ref().is_some_and(|p| p.subscribers() > 0) {
                s.subscriber = Some(subscribe(session, keys, s.route, i, tx.clone())?);
            }
        }
        match rx.recv_timeout(LOOK_EVERY) {
            Ok(first) => {
                let mut delivered = delivered.lock().unwrap_or_else(PoisonError::into_inner);
                publish(&mut ins, eos, &theirs, &mut delivered, first)?;
                while let Ok(next) = rx.try_recv() {
                    publish(&mut ins, eos, &theirs, &mut delivered, next)?;
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => unreachable!("this loop holds a sender"),
        }
        for s in ins.iter_mut().filter(|s| s.route.row.stream.is_some()) {
            if s.ended.is_none() && s.port.is_some() && s.end.finished() {
                s.ended = Some(
                    session
                        .liveliness()
                        .declare_token(keys.token(Token::Ended, s.route.row.topic.name))
                        .wait()
                        .map_err(zenoh_error)?,
                );
            }
        }
        if done(&ins) {
            break;
        }
    }
    for s in &ins {
        if s.received > 0 || s.refused > 0 {
            tracing::info!(
                topic = s.route.row.topic.name,
                messages = s.received,
                repeated = s.repeated,
                refused = s.refused,
                "received"
            );
        }
    }
    if !stopped() {
        for port in ins.iter().filter_map(|s| s.port.as_ref()) {
            port.wait_until_unsubscribed(ipc)?;
        }
    }
    Ok(())
}

/// Takes `route` from the peers: each message goes, with the route's index `i`, into
/// the queue `tx` (Zenoh's thread waits while the queue is full).
fn subscribe(
    session: &zenoh::Session,
    keys: &Keys,
    route: &Route,
    i: usize,
    tx: SyncSender<(usize, ZBytes)>,
) -> Result<Subscriber<()>> {
    let name = route.row.topic.name;
    tracing::info!(topic = name, "receiving from the peers");
    session
        .declare_subscriber(keys.data(name))
        .allowed_origin(Locality::Remote)
        .callback(move |sample| {
            // Fails only once the bridge stops receiving.
            let _ = tx.send((i, sample.payload().clone()));
        })
        .wait()
        .map_err(zenoh_error)
        .with_context(|| format!("subscribe to {name} on Zenoh"))
}

/// Answers the peers' question what was published here last of each stream in
/// `theirs` (see [`Delivered`]), from `delivered`.
fn answer_delivered(
    session: &zenoh::Session,
    keys: &Keys,
    theirs: &[StreamId],
    delivered: &Arc<Mutex<Repeats>>,
) -> Result<Queryable<()>> {
    let (key, theirs, delivered) = (keys.delivered(), theirs.to_vec(), Arc::clone(delivered));
    session
        .declare_queryable(keys.delivered())
        .callback(move |query| {
            let seen = delivered.lock().unwrap_or_else(PoisonError::into_inner);
            let newest = theirs.iter().filter_map(|&id| Some((id, seen.newest(id)?)));
            let answer = Delivered(newest.collect()).encode();
            drop(seen);
            // A peer that went away meanwhile needs no answer.
            let _ = query.reply(key.clone(), answer).wait();
        })
        .wait()
        .map_err(zenoh_error)
        .context("answer what was delivered")
}

/// Publishes one received frame here, or counts it refused (logging the first refusal
/// of each topic with its reason) or repeated (already published: `delivered`). An end
/// of stream goes to the stream's progress.
fn publish(
    ins: &mut [In],
    eos: usize,
    theirs: &[StreamId],
    delivered: &mut Repeats,
    (i, payload): (usize, ZBytes),
) -> Result<()> {
    let bytes = payload.to_bytes();
    let s = &mut ins[i];
    let body = match frame::decode(&s.kind, &bytes) {
        Ok(body) => body,
        Err(refused) => {
            refuse(s, &refused);
            return Ok(());
        }
    };
    let port = s.port.as_ref().expect("subscribed only with a port");
    if i == eos {
        let end: EndOfStream = bytemuck::pod_read_unaligned(body);
        let Some(stream) = StreamId::from_u32(end.stream).filter(|s| theirs.contains(s)) else {
            return Ok(());
        };
        port.publish(body)?;
        s.received += 1;
        if let Some(carrier) = ins.iter_mut().find(|s| s.route.row.stream == Some(stream)) {
            carrier.end.announce(&end);
        }
        return Ok(());
    }
    let header = header_of(body);
    if let Some(stream) = s.route.row.stream
        && !delivered.fresh(stream, header)
    {
        s.repeated += 1;
        return Ok(());
    }
    port.publish(body)?;
    s.received += 1;
    s.end.saw(header.seq);
    Ok(())
}

/// Counts a refused frame; logs the first of its topic.
fn refuse(s: &mut In, refused: &Refused) {
    if s.refused == 0 {
        tracing::error!(
            topic = s.route.row.topic.name,
            "refused what a peer sends on this topic (and every further refusal is only counted): {refused}"
        );
    }
    s.refused += 1;
}

/// True once every stream that got a publisher here has ended and its last message was
/// published (and at least one did).
fn done(ins: &[In]) -> bool {
    let mut streams = ins
        .iter()
        .filter(|s| s.route.row.stream.is_some() && s.port.is_some())
        .peekable();
    streams.peek().is_some() && streams.all(|s| s.end.finished())
}
