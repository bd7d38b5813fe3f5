//! `run.mcap`: what the client receives, as it receives it, written with the Foxglove SDK
//! through the run's channels ([`RunLog`]: topics and schemas listed there, the live
//! view's as well), stamped with the messages' own stamps; the metrics end it as one JSON
//! message on `/metrics`. Foxglove, `mcap` and the MCAP libraries open it.
//!
//! A kill cannot leave the file unreadable for long: each chunk is assembled in memory
//! and written whole (no chunk is ever left with a placeholder length), and a file whose
//! writer died before its footer is closed by [`close_unfinished`]: every whole record is
//! kept, a record cut short at the end is dropped, and a footer without summary ends it
//! (readers then read it from the start). A client that finds such a file in its run
//! folder closes it and keeps it as `run.<n>.mcap` before it starts its own.

use crate::Metrics;
use crate::foxglove_log::RunLog;
use foxglove::{Context, McapWriteOptions, McapWriterHandle, PartialMetadata, RawChannel};
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::ops::{Deref, DerefMut};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Bytes of messages a chunk holds before it is written: what a kill can lose at most.
const CHUNK_BYTES: u64 = 32 << 10;

/// The MCAP file of a run being recorded: the run's channels ([`RunLog`], which it
/// dereferences to) with the file as their one sink.
pub struct RunMcap {
    /// Keeps the channels' context (and so the writer's sink) alive.
    _context: Arc<Context>,
    writer: McapWriterHandle<File>,
    log: RunLog,
    metrics: Arc<RawChannel>,
}

impl RunMcap {
    /// Starts the file at `path`. A finished file there is replaced; an unfinished one
    /// (its writer was killed) is closed ([`close_unfinished`]) and kept beside it
    /// ([`kept_name`]).
    ///
    /// # Errors
    /// When the file cannot be created, or an unfinished one cannot be kept.
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        match close_unfinished(path) {
            Ok(Closed::Finished) => std::fs::remove_file(path)?,
            Ok(Closed::Absent) => {}
            outcome => {
                let kept = kept_name(path);
                std::fs::rename(path, &kept)?;
                match outcome {
                    Ok(closed) => tracing::warn!(
                        kept = %kept.display(),
                        ?closed,
                        "the previous client's recording was unfinished: closed and kept"
                    ),
                    Err(e) => tracing::warn!(
                        kept = %kept.display(),
                        "the previous client's recording cannot be closed ({e}): kept as it is"
                    ),
                }
            }
        }
        let context = Context::new();
        // Buffered chunks: each is written whole, as one record, once full (no message
        // indexes after it: the summary's chunk indexes serve readers).
        let options = McapWriteOptions::new()
            .disable_seeking(true)
            .emit_message_indexes(false)
            .chunk_size(Some(CHUNK_BYTES));
        let writer = (context.mcap_writer_with_options(options)).create(File::create_new(path)?)?;
        Ok(Self {
            log: RunLog::new(&context),
            metrics: (context.channel_builder("/metrics"))
                .message_encoding("json")
                .build_raw()?,
            writer,
            _context: context,
        })
    }

    /// Logs the metrics on `/metrics` at the newest stamp and closes the file.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn finish(self, metrics: &Metrics) -> anyhow::Result<()> {
        let json = serde_json::to_vec(metrics)?;
        self.metrics
            .log_with_meta(&json, PartialMetadata::with_log_time(self.log.last_ns()));
        self.writer.close()?.sync_all()?;
        Ok(())
    }
}

impl Deref for RunMcap {
    type Target = RunLog;

    fn deref(&self) -> &RunLog {
        &self.log
    }
}

impl DerefMut for RunMcap {
    fn deref_mut(&mut self) -> &mut RunLog {
        &mut self.log
    }
}

/// The name an unfinished `run.mcap` is kept under: `run.<n>.mcap` beside it, with the
/// first `n` from 1 not taken.
pub fn kept_name(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or("run".into(), |s| s.to_string_lossy());
    (1..)
        .map(|n| path.with_file_name(format!("{stem}.{n}.mcap")))
        .find(|p| !p.exists())
        .unwrap_or_else(|| path.with_extension("kept.mcap"))
}

/// What [`close_unfinished`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Closed {
    /// No file there.
    Absent,
    /// The file ends with its footer: nothing to do.
    Finished,
    /// The file was unfinished and is closed now.
    Recovered {
        /// Bytes of whole records kept (magic included).
        kept: u64,
        /// Bytes of a record cut short, or of an unfinished summary, dropped.
        dropped: u64,
    },
}

/// The MCAP magic, at both ends of a file.
const MAGIC: [u8; 8] = *b"\x89MCAP0\r\n";
/// Record opcodes (MCAP specification).
const OP_HEADER: u8 = 0x01;
const OP_FOOTER: u8 = 0x02;
const OP_DATA_END: u8 = 0x0F;
/// A record's opcode and length.
const RECORD_HEAD: u64 = 9;
/// The footer's fields: summary start, summary offset start, summary CRC.
const FOOTER_LEN: u64 = 20;

/// Closes the MCAP file at `path` if its writer did not finish it: keeps every whole
/// record of its data section, drops what follows the last one (a chunk or index cut
/// short, an unfinished summary), then writes a data end and a footer without summary
/// (summary start 0, no CRCs) and the closing magic, and syncs it. A finished file is left
/// as it is.
///
/// # Errors
/// When the file cannot be read or written, or is not an MCAP file (no magic and header).
pub fn close_unfinished(path: &Path) -> io::Result<Closed> {
    let mut file = match OpenOptions::new().read(true).write(true).open(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Closed::Absent),
        other => other?,
    };
    let len = file.metadata()?.len();
    let not_mcap = || io::Error::new(io::ErrorKind::InvalidData, "not an MCAP file");
    let footer_at = len.checked_sub(MAGIC.len() as u64 + RECORD_HEAD + FOOTER_LEN);
    if let Some(at) = footer_at.filter(|&at| at >= MAGIC.len() as u64) {
        let (op, length) = record_head(&mut file, at)?;
        let mut end = [0; 8];
        file.seek(SeekFrom::End(-8))?;
        file.read_exact(&mut end)?;
        if (op, length, end) == (OP_FOOTER, FOOTER_LEN, MAGIC) {
            return Ok(Closed::Finished);
        }
    }
    let mut magic = [0; 8];
    file.seek(SeekFrom::Start(0))?;
    file.read_exact(&mut magic).map_err(|_| not_mcap())?;
    let mut kept = MAGIC.len() as u64;
    while kept + RECORD_HEAD <= len {
        let (op, length) = record_head(&mut file, kept)?;
        let end = (kept + RECORD_HEAD).checked_add(length);
        match end {
            _ if kept == MAGIC.len() as u64 && op != OP_HEADER => break,
            Some(end) if end <= len && !matches!(op, OP_DATA_END | OP_FOOTER) => kept = end,
            _ => break,
        }
    }
    if magic != MAGIC || kept == MAGIC.len() as u64 {
        return Err(not_mcap());
    }
    file.set_len(kept)?;
    file.seek(SeekFrom::Start(kept))?;
    let mut tail = Vec::with_capacity(64);
    tail.push(OP_DATA_END);
    tail.extend(4u64.to_le_bytes());
    tail.extend(0u32.to_le_bytes());
    tail.push(OP_FOOTER);
    tail.extend(FOOTER_LEN.to_le_bytes());
    tail.extend([0; FOOTER_LEN as usize]);
    tail.extend(MAGIC);
    file.write_all(&tail)?;
    file.sync_all()?;
    Ok(Closed::Recovered {
        kept,
        dropped: len - kept,
    })
}

/// The opcode and length of the record at `at`.
fn record_head(file: &mut File, at: u64) -> io::Result<(u8, u64)> {
    let mut head = [0; RECORD_HEAD as usize];
    file.seek(SeekFrom::Start(at))?;
    file.read_exact(&mut head)?;
    let mut length = [0; 8];
    length.copy_from_slice(&head[1..]);
    Ok((head[0], u64::from_le_bytes(length)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::message::Message;
    use fastslam_protocol::{GroundTruth, Header, topics};

    /// A run folder of its own for a test.
    fn folder(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("mcap-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Records `n` ground-truth samples into `path` and leaves the file as a killed
    /// writer would: what was written stays, nothing is closed.
    fn killed_after(path: &Path, n: u64) {
        let mut mcap = RunMcap::create(path).unwrap();
        for seq in 0..n {
            let gt = GroundTruth {
                header: Header {
                    stamp_ns: seq * 1_000_000,
                    seq,
                },
                x: seq as f64,
                ..GroundTruth::default()
            };
            mcap.message(topics::GROUND_TRUTH, Message::GroundTruth(&gt));
        }
        std::mem::forget(mcap);
    }

    /// The messages an MCAP reader reads in the file at `path`, in order of their log
    /// time; an error when it refuses the file.
    fn read(path: &Path) -> Result<Vec<u64>, mcap::McapError> {
        let bytes = std::fs::read(path).unwrap();
        mcap::MessageStream::new(&bytes)?
            .map(|m| m.map(|m| m.log_time))
            .collect()
    }

    #[test]
    fn a_killed_writer_leaves_whole_chunks_that_close_into_a_readable_file() {
        let dir = folder("killed");
        let path = dir.join("run.mcap");
        killed_after(&path, 20_000);
        let whole = std::fs::read(&path).unwrap();
        assert!(read(&path).is_err(), "an unfinished file reads as finished");
        // As killed between chunks; in the middle of a chunk's write (cut short); with a
        // chunk whose length was never filled in.
        let mut placeholder = whole.clone();
        placeholder.extend([0x06].into_iter().chain(u64::MAX.to_le_bytes()));
        placeholder.extend([7; 300]);
        let variants = [
            whole.clone(),
            whole[..whole.len() - 50].to_vec(),
            placeholder,
        ];
        let mut counts = Vec::new();
        for bytes in variants {
            std::fs::write(&path, &bytes).unwrap();
            let closed = close_unfinished(&path).unwrap();
            assert!(matches!(closed, Closed::Recovered { .. }), "{closed:?}");
            let stamps = read(&path).unwrap();
            assert!(stamps.len() > 1000, "{} messages kept", stamps.len());
            assert!(stamps.windows(2).all(|w| w[0] < w[1]), "out of order");
            assert_eq!(stamps[0], 0);
            assert_eq!(close_unfinished(&path).unwrap(), Closed::Finished);
            counts.push(stamps.len());
        }
        assert!(counts[1] < counts[0], "a cut chunk is dropped: {counts:?}");
        assert_eq!(counts[2], counts[0], "{counts:?}");
    }

    #[test]
    fn a_new_recording_keeps_an_unfinished_one_and_replaces_a_finished_one() {
        let dir = folder("keep");
        let path = dir.join("run.mcap");
        killed_after(&path, 5000);
        killed_after(&path, 5000);
        let kept = dir.join("run.1.mcap");
        assert!(read(&kept).is_ok_and(|m| m.len() > 1000));
        assert_eq!(close_unfinished(&kept).unwrap(), Closed::Finished);
        // Dropped, a recording is closed.
        drop(RunMcap::create(&path).unwrap());
        assert!(read(&path).is_ok_and(|m| m.is_empty()));
        drop(RunMcap::create(&path).unwrap());
        assert!(dir.join("run.2.mcap").exists());
        assert!(!dir.join("run.3.mcap").exists());
        std::fs::write(&path, b"garbage").unwrap();
        assert!(close_unfinished(&path).is_err());
        drop(RunMcap::create(&path).unwrap());
        assert_eq!(std::fs::read(dir.join("run.3.mcap")).unwrap(), b"garbage");
    }
}
