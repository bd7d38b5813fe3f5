//! What a publisher keeps for the client ([`Pub::kept_for_client`]): every message it
//! sent until the client's notices ([`ClientNotice`]) say the client recorded it, sent
//! again on the topic's resend service when a client started again after a crash asks.
//!
//! A process subscribes to the notices once ([`Notices`], shared by its publishers), and
//! its publishers tend what they keep whenever one of them sends or waits at the end of
//! the run, so that a publisher that has stopped sending (the end-of-stream) still
//! answers a restarted client.

use super::{Ipc, Pub, Result, Sub, Wire};
use crate::client_notice::ClientNotice;
use crate::message::Message;
use crate::stream::StreamId;
use crate::topics::{self, Topic};
use iceoryx2::prelude::ZeroCopySend;
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::fmt::Debug;
use std::rc::{Rc, Weak};

/// The most a publisher keeps for the client, in bytes of payload (the oldest is
/// forgotten beyond it, with a warning): a client that records falls behind by a few
/// hundred milliseconds at most, so this bounds only a client that stopped confirming.
const KEEP_BOUND: usize = 256 << 20;

/// A process's subscription to the client's notices, and the publishers that keep
/// messages for the client.
pub(super) struct Notices {
    sub: Sub<ClientNotice, ()>,
    newest: Cell<Option<ClientNotice>>,
    kept: RefCell<Vec<Weak<dyn Tend>>>,
}

impl Notices {
    /// Subscribes to the client's notices (no publisher needed: the client may come
    /// later; its newest notice is in history).
    pub(super) fn open(ipc: &Ipc) -> Result<Self> {
        Ok(Self {
            sub: ipc.optional_subscriber::<ClientNotice>(&topics::CLIENT_NOTICE)?,
            newest: Cell::new(None),
            kept: RefCell::new(Vec::new()),
        })
    }

    /// The newest notice of the client, if one ever came.
    fn newest(&self) -> Result<Option<ClientNotice>> {
        self.sub.drain(|s| self.newest.set(Some(*s.payload())))?;
        Ok(self.newest.get())
    }

    /// Tends what every publisher of the process keeps; true while one of them keeps
    /// messages a client that died may still ask for (none has said it finished).
    pub(super) fn tend_all(&self) -> Result<bool> {
        match self.newest()? {
            Some(notice) => self.tend_each(&notice),
            None => Ok(false),
        }
    }

    /// Tends what every publisher of the process keeps after `notice`, the newest.
    fn tend_each(&self, notice: &ClientNotice) -> Result<bool> {
        let kept: Vec<Rc<dyn Tend>> = self
            .kept
            .borrow()
            .iter()
            .filter_map(Weak::upgrade)
            .collect();
        let mut waiting = false;
        for k in kept {
            waiting |= k.tend(notice)?;
        }
        Ok(waiting)
    }
}

/// What tending a publisher's kept messages does, whatever its payload type.
trait Tend {
    /// Forgets what `notice`, the client's newest, says it recorded, sends everything
    /// again to a client started again; true while messages remain that the client has
    /// not recorded.
    fn tend(&self, notice: &ClientNotice) -> Result<bool>;
}

/// Whether the client has recorded a message kept for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mark {
    /// Message `seq` of a stream.
    Message(StreamId, u64),
    /// A stream's end.
    End(StreamId),
    /// Not of a stream: kept until the client has finished.
    Unmarked,
}

impl Mark {
    /// The mark of `message` sent on a topic of `stream`.
    fn of(message: Message<'_>, stream: Option<StreamId>) -> Self {
        match (message, stream) {
            (Message::EndOfStream(e), _) => {
                StreamId::from_u32(e.stream).map_or(Self::Unmarked, Self::End)
            }
            (m, Some(s)) => Self::Message(s, m.header().seq),
            (_, None) => Self::Unmarked,
        }
    }

    /// True when `notice` says the client recorded it.
    fn recorded(self, notice: &ClientNotice) -> bool {
        match self {
            Self::Message(s, seq) => notice.records(s, seq),
            Self::End(s) => notice.records_end(s),
            Self::Unmarked => notice.finished != 0,
        }
    }
}

/// A message sent again with this.
type Resend<P, H> = Box<dyn Fn(&Pub<P, H>) -> Result<()>>;

/// One message kept.
struct Entry<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    mark: Mark,
    bytes: usize,
    resend: Resend<P, H>,
}

/// What one publisher keeps for the client.
pub(super) struct Kept<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    notices: Rc<Notices>,
    state: RefCell<KeptState<P, H>>,
}

/// The kept messages and the requests answered.
struct KeptState<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> {
    stream: Option<StreamId>,
    entries: VecDeque<Entry<P, H>>,
    bytes: usize,
    /// The publisher on the topic's resend service.
    resend: Pub<P, H>,
    /// The client's restarts answered with a resend.
    answered: u64,
    /// Messages forgotten beyond [`KEEP_BOUND`].
    forgotten: u64,
    /// The notice last applied (the client's restarts and its sequence number): what it
    /// says is forgotten once.
    applied: Option<(u64, u64)>,
}

impl<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> Kept<P, H> {
    /// Keeps for the client what is sent on `topic`, sending it again on `resend`; the
    /// process's notices are `ipc`'s.
    pub(super) fn open(ipc: &Ipc, topic: &Topic, resend: Pub<P, H>) -> Result<Rc<Self>> {
        let notices = ipc.client_notices()?;
        let kept = Rc::new(Self {
            state: RefCell::new(KeptState {
                stream: topics::row(topic.name).and_then(|r| r.stream),
                entries: VecDeque::new(),
                bytes: 0,
                resend,
                answered: 0,
                forgotten: 0,
                applied: None,
            }),
            notices: notices.clone(),
        });
        let weak: Weak<dyn Tend> = Rc::downgrade(&(kept.clone() as Rc<dyn Tend>));
        notices.kept.borrow_mut().push(weak);
        Ok(kept)
    }

    /// Keeps the message just sent (`message`, of `bytes`), to be sent again with
    /// `resend`, once a client has given notice (before that, there is none to keep
    /// for); then tends what is kept.
    pub(super) fn keep(
        &self,
        message: Message<'_>,
        bytes: usize,
        resend: impl Fn(&Pub<P, H>) -> Result<()> + 'static,
    ) -> Result<()> {
        let Some(notice) = self.notices.newest()? else {
            return Ok(());
        };
        {
            let mut state = self.state.borrow_mut();
            let mark = Mark::of(message, state.stream);
            state.bytes += bytes;
            state.entries.push_back(Entry {
                mark,
                bytes,
                resend: Box::new(resend),
            });
            while state.bytes > KEEP_BOUND
                && let Some(old) = state.entries.pop_front()
            {
                state.bytes -= old.bytes;
                state.forgotten += 1;
                if state.forgotten == 1 {
                    tracing::warn!(
                        topic = state.resend.topic,
                        "the client has not confirmed what it recorded for long: forgetting \
                         the oldest messages kept for it"
                    );
                }
            }
        }
        // Every publisher of the process answers a restarted client, also one that sends
        // rarely (a map, an end-of-stream).
        self.notices.tend_each(&notice).map(|_| ())
    }
}

impl<P: Wire + ?Sized, H: Debug + ZeroCopySend + 'static> Tend for Kept<P, H> {
    fn tend(&self, notice: &ClientNotice) -> Result<bool> {
        let mut state = self.state.borrow_mut();
        if notice.restarts > state.answered {
            state.answered = notice.restarts;
            for e in &state.entries {
                (e.resend)(&state.resend)?;
            }
            state.resend.flush()?;
            if !state.entries.is_empty() {
                tracing::info!(
                    topic = state.resend.topic,
                    messages = state.entries.len(),
                    "sent again to the client started again"
                );
            }
        }
        let key = (notice.restarts, notice.header.seq);
        if state.applied != Some(key) {
            state.applied = Some(key);
            let mut freed = 0;
            state.entries.retain(|e| {
                let recorded = e.mark.recorded(notice);
                freed += if recorded { e.bytes } else { 0 };
                !recorded
            });
            state.bytes -= freed;
        }
        Ok(!state.entries.is_empty() && notice.finished == 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ipc::testing::{TestStack, on_thread};
    use crate::{Header, PoseEstimate};

    /// A kept publisher keeps nothing before the client's first notice, forgets what a
    /// notice says was recorded, sends the rest again on the resend service when the
    /// client restarted, and forgets everything once it finished.
    #[test]
    fn a_kept_publisher_sends_again_only_what_the_client_has_not_recorded() {
        let test = TestStack::new("kept");
        let got = on_thread(test.config(), "a kept publisher hung", |ipc| {
            let out = (ipc.publisher::<PoseEstimate>(&topics::POSE)?).kept_for_client(ipc)?;
            let notices = ipc.newest_only_publisher::<ClientNotice>(&topics::CLIENT_NOTICE)?;
            let resent = ipc.optional_subscriber::<PoseEstimate>(&topics::resend(&topics::POSE))?;
            let pose = |seq| PoseEstimate {
                header: Header { stamp_ns: seq, seq },
                ..PoseEstimate::default()
            };
            out.send(pose(0))?;
            let mut notice = ClientNotice::default();
            notices.send(notice)?;
            for seq in 1..6 {
                out.send(pose(seq))?;
            }
            notice.header.seq = 1;
            notice.recorded[StreamId::Pose as usize] = 4;
            notices.send(notice)?;
            let keeping = ipc.tend_kept()?;
            notice.header.seq = 2;
            notice.restarts = 1;
            notices.send(notice)?;
            ipc.tend_kept()?;
            let mut seqs = Vec::new();
            resent.drain(|s| seqs.push(s.payload().header.seq))?;
            notice.header.seq = 3;
            notice.finished = 1;
            notices.send(notice)?;
            Ok((keeping, seqs, ipc.tend_kept()?))
        });
        assert_eq!(got, Ok((true, vec![4, 5], false)));
    }
}
