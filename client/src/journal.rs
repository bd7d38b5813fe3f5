//! The client's journal in the run folder: every message it took, written a few times a
//! second, so that a client started again after a crash (`client --resume`) takes them
//! again and asks the stack's publishers only for what came after ([`ClientNotice`]).
//!
//! `journal.bin` holds records `[u32 body length][u8 kind][u8 topic row][u16 0][body]`
//! (little-endian): a start record per client started on the run folder (its body: the
//! lidar stream and whether ground truth is taken, as the first client chose), and a
//! record per message of a stream (its body: the message's bytes, see
//! `Message::write_bytes`). Maps, grids and smoothed trajectories (where only the newest
//! counts) live in `journal.<row>.bin` instead, one record each, replaced when a newer one
//! is written. A record cut short by a kill is dropped when the journal is read. A client
//! that writes its run folder removes the journal.

use anyhow::{Context, bail, ensure};
use fastslam_protocol::ipc::{Ipc, Pub};
use fastslam_protocol::message::{
    Fixed, FixedMessage, Message, PayloadVisitor, Slice, SliceMessage,
};
use fastslam_protocol::topics::{self, TopicRow};
use fastslam_protocol::validate::Rejection;
use fastslam_protocol::{ClientNotice, Header, StreamId, client_notice::NOTICE_STREAMS};
use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The journal's file name in the run folder.
pub const FILE: &str = "journal.bin";

/// How often the journal is written and the publishers told what it holds.
const WRITE_EVERY: Duration = Duration::from_millis(100);

/// Bytes before a record's body.
const RECORD_HEAD: usize = 8;

/// Bytes of a start record's body.
const START_BYTES: usize = 2;

/// What a record holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
enum Kind {
    Start = 0,
    Message = 1,
}

/// What the first client recording a run chose; a resumed client takes the same topics
/// without waiting for their publishers (some may have finished).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Start {
    /// The lidar's stream: raw scans or observations.
    pub lidar: StreamId,
    /// Whether ground truth is taken.
    pub truth: bool,
}

/// Streams of which only the newest message counts: the publishers keep and send again
/// only the newest's successors, and the journal keeps only the newest.
pub fn snapshot(stream: StreamId) -> bool {
    matches!(
        stream,
        StreamId::Map
            | StreamId::Grid
            | StreamId::SmoothedTrajectory
            | StreamId::SmoothedMap
            | StreamId::Particles
    )
}

/// What the journal holds of each stream: every message below a sequence number, the
/// ones above it, and the ends.
#[derive(Debug, Default)]
struct Marks {
    next: [Option<u64>; NOTICE_STREAMS],
    ahead: [BTreeSet<u64>; NOTICE_STREAMS],
    ended: u64,
    newest_ns: u64,
}

impl Marks {
    /// Notes message `header` of `stream` (the first one seen of a stream starts it).
    fn note(&mut self, stream: StreamId, header: Header) {
        let i = stream as usize;
        self.newest_ns = self.newest_ns.max(header.stamp_ns);
        let next = self.next[i].get_or_insert(header.seq);
        if snapshot(stream) {
            *next = (*next).max(header.seq + 1);
            return;
        }
        if header.seq == *next {
            *next += 1;
            while self.ahead[i].remove(next) {
                *next += 1;
            }
        } else if header.seq > *next {
            self.ahead[i].insert(header.seq);
        }
    }

    /// Notes message `message` of `row`'s topic: its stream's message, or a stream's end.
    fn take(&mut self, row: &TopicRow, message: Message<'_>) {
        if let Message::EndOfStream(e) = message {
            self.ended |= 1 << e.stream.min(63);
        }
        if let Some(stream) = row.stream {
            self.note(stream, message.header());
        }
    }

    /// The notice saying what these marks hold.
    fn notice(&self, seq: u64, restarts: u64, finished: bool) -> ClientNotice {
        ClientNotice {
            header: Header {
                stamp_ns: self.newest_ns,
                seq,
            },
            restarts,
            recorded: self.next.map(|n| n.unwrap_or(0)),
            ended: self.ended,
            finished: u64::from(finished),
        }
    }
}

/// The journal being written, and the notices that tell the publishers what it holds.
pub struct Journal {
    dir: PathBuf,
    file: File,
    buffer: Vec<u8>,
    /// Newest message of each snapshot stream not yet written: its row and record.
    snapshots: Vec<(usize, Vec<u8>)>,
    marks: Marks,
    restarts: u64,
    notices: Pub<ClientNotice, ()>,
    sent: u64,
    written: Instant,
}

impl Journal {
    /// Starts a fresh journal in the run folder `dir` (an old one there is removed) and
    /// publishes its first notice.
    ///
    /// # Errors
    /// The journal cannot be written, or the notice sent.
    pub fn create(ipc: &Ipc, dir: &Path) -> anyhow::Result<Self> {
        remove_files(dir)?;
        Self::go_on(ipc, dir, Marks::default(), 0)
    }

    /// Takes the journal of a client that died in the run folder `dir`: gives its
    /// messages to `each` (with their topic's row and check), then goes on writing it and
    /// publishes its first notice, which asks the publishers for what they kept. Returns
    /// it with the start the journal records.
    ///
    /// # Errors
    /// No journal there, or one that cannot be read or written.
    pub fn resume(
        ipc: &Ipc,
        dir: &Path,
        each: impl FnMut(&'static TopicRow, Message<'_>, Result<(), Rejection>),
    ) -> anyhow::Result<(Self, Start)> {
        let (marks, restarts, start) = replay(dir, &dir.join(FILE), each)?;
        Ok((Self::go_on(ipc, dir, marks, restarts)?, start))
    }

    /// The journal of `dir` appended to, holding `marks`, for the client's `restarts`-th
    /// restart; its first notice published.
    fn go_on(ipc: &Ipc, dir: &Path, marks: Marks, restarts: u64) -> anyhow::Result<Self> {
        let path = dir.join(FILE);
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .with_context(|| format!("open {}", path.display()))?;
        let mut journal = Self {
            dir: dir.to_path_buf(),
            file,
            buffer: Vec::new(),
            snapshots: Vec::new(),
            marks,
            restarts,
            notices: ipc.newest_only_publisher(&topics::CLIENT_NOTICE)?,
            sent: 0,
            written: Instant::now(),
        };
        journal.tell(false)?;
        Ok(journal)
    }

    /// Records that a client started on this run folder with `start`'s choice (the
    /// first's, for a resumed one).
    pub fn started(&mut self, start: Start) {
        let body: [u8; START_BYTES] = [start.lidar as u32 as u8, u8::from(start.truth)];
        record(Kind::Start, 0, &body, &mut self.buffer);
    }

    /// Journals message `message` of `row`'s topic.
    pub fn add(&mut self, row: &'static TopicRow, message: Message<'_>) {
        let index = row_index(row);
        let write = |out: &mut Vec<u8>| message.write_bytes(out);
        match row.stream {
            Some(stream) if snapshot(stream) => {
                let mut rec = Vec::new();
                record_with(Kind::Message, index, &mut rec, write);
                self.snapshots.retain(|(r, _)| *r != index);
                self.snapshots.push((index, rec));
            }
            _ => record_with(Kind::Message, index, &mut self.buffer, write),
        }
        self.marks.take(row, message);
    }

    /// Writes what was journaled and tells the publishers, when [`WRITE_EVERY`] has
    /// passed since the last time.
    ///
    /// # Errors
    /// The journal cannot be written, or the notice sent.
    pub fn tend(&mut self) -> anyhow::Result<()> {
        if self.written.elapsed() >= WRITE_EVERY {
            self.write()?;
            self.tell(false)?;
        }
        Ok(())
    }

    /// Tells the publishers that the run folder is written (nothing more will be
    /// asked), and removes the journal.
    ///
    /// # Errors
    /// The notice cannot be sent.
    pub fn finish(mut self) -> anyhow::Result<()> {
        self.tell(true)?;
        if let Err(e) = remove_files(&self.dir) {
            tracing::warn!("the journal cannot be removed: {e}");
        }
        Ok(())
    }

    /// Writes the buffered records to `journal.bin` and the newest snapshots to their
    /// files (each written beside and renamed over the old one).
    fn write(&mut self) -> anyhow::Result<()> {
        self.file.write_all(&self.buffer)?;
        self.buffer.clear();
        for (row, rec) in self.snapshots.drain(..) {
            let path = self.dir.join(format!("journal.{row}.bin"));
            let part = path.with_extension("part");
            std::fs::write(&part, &rec)?;
            std::fs::rename(&part, &path)?;
        }
        self.written = Instant::now();
        Ok(())
    }

    /// Publishes what the journal holds.
    fn tell(&mut self, finished: bool) -> anyhow::Result<()> {
        let notice = self.marks.notice(self.sent, self.restarts, finished);
        self.notices.send(notice)?;
        self.sent += 1;
        Ok(())
    }
}

/// The start the journal in the run folder `dir` records: what a client started again
/// there subscribes to.
///
/// # Errors
/// No journal there, or one without a start record.
pub fn start_of(dir: &Path) -> anyhow::Result<Start> {
    let path = dir.join(FILE);
    let file = File::open(&path).with_context(|| {
        format!(
            "--resume: no journal of a client that died in {}",
            path.display()
        )
    })?;
    // The first record alone: a start record is short; the journal may be long.
    let mut bytes = Vec::new();
    file.take((RECORD_HEAD + START_BYTES) as u64)
        .read_to_end(&mut bytes)?;
    match split_record(&bytes)? {
        Some((record, _)) if record.kind == Kind::Start => read_start(record.body),
        _ => bail!(
            "{}: the journal does not begin with a start record",
            path.display()
        ),
    }
}

/// Reads the journal at `path` and the snapshot files beside it in `dir`, giving each
/// message to `each`; returns what they hold, the restarts so far (this one included)
/// and the first start record. A record cut short at the end is dropped from the file.
fn replay(
    dir: &Path,
    path: &Path,
    mut each: impl FnMut(&'static TopicRow, Message<'_>, Result<(), Rejection>),
) -> anyhow::Result<(Marks, u64, Start)> {
    let bytes = std::fs::read(path)?;
    let snapshots: Vec<Vec<u8>> = (0..topics::TABLE.len())
        .filter_map(|index| std::fs::read(dir.join(format!("journal.{index}.bin"))).ok())
        .collect();
    let mut records = Vec::new();
    let mut rest = bytes.as_slice();
    while let Some((record, next)) = split_record(rest)? {
        records.push(record);
        rest = next;
    }
    for b in &snapshots {
        if let Some((record, _)) = split_record(b)? {
            records.push(record);
        }
    }
    let (mut marks, mut starts, mut start) = (Marks::default(), 0, None);
    for Record { kind, row, body } in records {
        match kind {
            Kind::Start => {
                starts += 1;
                start.get_or_insert(read_start(body)?);
            }
            Kind::Message => {
                let row = topics::TABLE
                    .get(row)
                    .context("a journal record of no topic")?;
                row.payload.visit(Decode {
                    body,
                    each: &mut |m, checked| {
                        marks.take(row, m);
                        each(row, m, checked);
                    },
                })?;
            }
        }
    }
    if !rest.is_empty() {
        tracing::warn!(
            bytes = rest.len(),
            "the journal ends with a record cut short: dropped"
        );
        std::fs::write(path, &bytes[..bytes.len() - rest.len()])?;
    }
    let start = start.context("the journal has no start record")?;
    Ok((marks, starts, start))
}

/// Removes the journal's files from the run folder `dir`.
fn remove_files(dir: &Path) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        if name.is_some_and(|n| n.starts_with("journal.")) {
            std::fs::remove_file(&path)?;
        }
    }
    Ok(())
}

/// The index of `row` in the topic table.
fn row_index(row: &TopicRow) -> usize {
    (topics::TABLE.iter())
        .position(|r| r.topic == row.topic)
        .expect("a row of the table")
}

/// Appends a record of `kind` for topic row `row` with `body` to `out`.
fn record(kind: Kind, row: usize, body: &[u8], out: &mut Vec<u8>) {
    record_with(kind, row, out, |out| out.extend_from_slice(body));
}

/// Appends a record of `kind` for topic row `row` to `out`, its body written by `body`
/// straight after the head, whose length it then fills in.
fn record_with(kind: Kind, row: usize, out: &mut Vec<u8>, body: impl FnOnce(&mut Vec<u8>)) {
    let at = out.len();
    out.extend_from_slice(&[0, 0, 0, 0, kind as u8, row as u8, 0, 0]);
    body(out);
    let len = u32::try_from(out.len() - at - RECORD_HEAD).expect("a message under 4 GiB");
    out[at..at + 4].copy_from_slice(&len.to_le_bytes());
}

/// One record read back.
struct Record<'a> {
    kind: Kind,
    row: usize,
    body: &'a [u8],
}

/// The first whole record of `bytes` and what follows it; `None` when no whole record is
/// left.
///
/// # Errors
/// A record of an unknown kind.
fn split_record(bytes: &[u8]) -> anyhow::Result<Option<(Record<'_>, &[u8])>> {
    let Some(head) = bytes.get(..RECORD_HEAD) else {
        return Ok(None);
    };
    let len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let Some(body) = bytes.get(RECORD_HEAD..RECORD_HEAD + len) else {
        return Ok(None);
    };
    let kind = match head[4] {
        0 => Kind::Start,
        1 => Kind::Message,
        k => bail!("a journal record of unknown kind {k}"),
    };
    let record = Record {
        kind,
        row: head[5] as usize,
        body,
    };
    Ok(Some((record, &bytes[RECORD_HEAD + len..])))
}

/// The start a start record's body holds.
fn read_start(body: &[u8]) -> anyhow::Result<Start> {
    ensure!(
        body.len() == START_BYTES,
        "a start record of {} bytes",
        body.len()
    );
    let lidar = StreamId::from_u32(u32::from(body[0])).context("a start record's lidar stream")?;
    Ok(Start {
        lidar,
        truth: body[1] != 0,
    })
}

/// Reads one message's bytes back as its topic's payload type.
struct Decode<'a, 'f> {
    body: &'a [u8],
    each: &'f mut dyn FnMut(Message<'_>, Result<(), Rejection>),
}

impl PayloadVisitor for Decode<'_, '_> {
    type Output = anyhow::Result<()>;

    fn fixed<T: FixedMessage>(self, payload: &'static Fixed<T>) -> Self::Output {
        ensure!(
            self.body.len() == size_of::<T>(),
            "a journal record of the wrong size"
        );
        let m: T = bytemuck::pod_read_unaligned(self.body);
        let (message, checked) = payload.read(&m);
        (self.each)(message, checked);
        Ok(())
    }

    fn slice<H: SliceMessage>(self, payload: &'static Slice<H>) -> Self::Output {
        let (head, items) = (self.body)
            .split_at_checked(size_of::<H>())
            .context("a journal record shorter than its header")?;
        ensure!(
            items.len() % size_of::<H::Item>().max(1) == 0,
            "a journal record of the wrong size"
        );
        let h: H = bytemuck::pod_read_unaligned(head);
        let items: Vec<H::Item> = bytemuck::pod_collect_to_vec(items);
        let (message, checked) = payload.read(&h, &items);
        (self.each)(message, checked);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::{LandmarkMapHeader, MapLandmark, Odometry};

    fn at(seq: u64) -> Header {
        Header {
            stamp_ns: seq * 10,
            seq,
        }
    }

    #[test]
    fn the_marks_hold_every_message_below_the_first_gap_and_the_newest_snapshot() {
        let mut marks = Marks::default();
        for seq in [3, 4, 6, 7] {
            marks.note(StreamId::Odometry, at(seq));
        }
        assert_eq!(marks.next[StreamId::Odometry as usize], Some(5));
        marks.note(StreamId::Odometry, at(5));
        assert_eq!(marks.next[StreamId::Odometry as usize], Some(8));
        for seq in [2, 9, 4] {
            marks.note(StreamId::Map, at(seq));
        }
        assert_eq!(marks.next[StreamId::Map as usize], Some(10));
        let notice = marks.notice(0, 1, false);
        assert!(notice.records(StreamId::Odometry, 7) && !notice.records(StreamId::Odometry, 8));
        assert!(!notice.records(StreamId::Pose, 0));
    }

    #[test]
    fn a_journal_gives_back_its_messages_and_drops_a_record_cut_short() {
        let dir = std::env::temp_dir().join(format!("journal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let odometry = topics::row(topics::ODOMETRY.name).unwrap();
        let map = topics::row(topics::MAP.name).unwrap();
        let mut bytes = Vec::new();
        let start = Start {
            lidar: StreamId::Observations,
            truth: true,
        };
        record(Kind::Start, 0, &[start.lidar as u8, 1], &mut bytes);
        for seq in 0..3 {
            let m = Odometry {
                header: at(seq),
                ..Odometry::default()
            };
            let mut body = Vec::new();
            Message::Odometry(&m).write_bytes(&mut body);
            record(Kind::Message, row_index(odometry), &body, &mut bytes);
        }
        let whole = bytes.len();
        let cut = bytes[8..20].to_vec();
        bytes.extend_from_slice(&cut);
        std::fs::write(dir.join(FILE), &bytes).unwrap();
        let h = LandmarkMapHeader {
            header: at(7),
            count: 2,
            reserved: 0,
        };
        let mut body = Vec::new();
        Message::LandmarkMap(&h, &[MapLandmark::default(); 2]).write_bytes(&mut body);
        let mut rec = Vec::new();
        record(Kind::Message, row_index(map), &body, &mut rec);
        std::fs::write(dir.join(format!("journal.{}.bin", row_index(map))), rec).unwrap();

        let mut seen = Vec::new();
        let (marks, restarts, read) = replay(&dir, &dir.join(FILE), |row, m, checked| {
            assert!(checked.is_ok());
            seen.push((row.topic.name, m.header().seq));
        })
        .unwrap();
        assert_eq!(read, start);
        assert_eq!(restarts, 1);
        assert_eq!(
            seen,
            [
                ("odometry", 0),
                ("odometry", 1),
                ("odometry", 2),
                ("map", 7)
            ]
        );
        assert_eq!(marks.next[StreamId::Odometry as usize], Some(3));
        assert_eq!(marks.next[StreamId::Map as usize], Some(8));
        assert_eq!(
            std::fs::metadata(dir.join(FILE)).unwrap().len(),
            whole as u64
        );
        assert_eq!(start_of(&dir).unwrap(), start);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
