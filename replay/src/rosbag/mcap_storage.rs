//! MCAP storage files (rosbag2's default storage since ROS 2 Iron).
//!
//! The file is read from start to end in one pass, a bounded buffer at a time: schemas
//! give the message types, channels the topics, chunks are decompressed (none, `zstd` or
//! `lz4`, checked against their CRC) and the messages inside them collected. When the file
//! ends with its summary, the summary's per-channel message counts must match what the
//! data section held; a file without summary (a recording that stopped without closing
//! the file) is read as far as it is whole, with a warning, and so is a file cut inside a
//! record after its first message (a copy that stopped early): the messages before the
//! cut are read. A file cut before any message, a chunk that does not decompress or a
//! record that does not parse is an error naming the file.

use super::storage::Collector;
use crate::text::{DataError, Result};
use mcap::records::{ChunkHeader, Record, Statistics, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::Path;

/// The most bytes asked of the file at once.
const READ_SIZE: usize = 1 << 20;
/// The longest record accepted (a chunk or a message), against corrupt lengths.
const MAX_RECORD: usize = 1 << 32;

/// What the records read so far say.
#[derive(Default)]
struct State {
    /// Schema id → message type.
    schemas: HashMap<u16, String>,
    /// Channel id → topic index in the collector.
    channels: HashMap<u16, usize>,
    /// Messages read per channel id.
    counts: BTreeMap<u16, u64>,
    /// The summary's statistics, when the file has them.
    statistics: Option<Statistics>,
    /// Whether the footer (the file's last record) was read.
    footer: bool,
}

/// What the bytes an MCAP stream is read from are: the file's own, or the file's
/// decompressed content (rosbag2's file compression). Messages about where a file ends
/// count its bytes in these.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// The file is the MCAP stream.
    File,
    /// The MCAP stream is the file's decompressed content.
    Decompressed,
}

impl Stream {
    /// How `n` bytes of this stream read in a message: "N bytes" or "N bytes after
    /// decompression".
    fn bytes(self, n: u64) -> String {
        match self {
            Self::File => format!("{n} bytes"),
            Self::Decompressed => format!("{n} bytes after decompression"),
        }
    }
}

/// Reads the MCAP stream `source` (the file `path`, or its decompressed content as
/// `stream` says) into `sink`.
///
/// # Errors
/// [`DataError::Io`] naming the file when it is cut short before its first message,
/// corrupt, or contradicts its own summary.
pub fn read(
    mut source: impl Read,
    stream: Stream,
    path: &Path,
    sink: &mut Collector,
) -> Result<()> {
    let bad = |reason: String| DataError::Io {
        path: path.to_path_buf(),
        reason,
    };
    let options = LinearReaderOptions::default()
        .with_emit_chunks(true)
        .with_skip_end_magic(true)
        .with_record_length_limit(MAX_RECORD);
    let mut reader = LinearReader::new_with_options(options);
    let mut state = State::default();
    let (mut offset, mut cut) = (0u64, false);
    // The stream's last bytes: a file that ends with the magic was not cut short.
    let mut tail = Vec::with_capacity(2 * mcap::MAGIC.len());
    while let Some(event) = reader.next_event() {
        match event {
            Err(mcap::McapError::UnexpectedEof) => {
                if tail.ends_with(mcap::MAGIC) {
                    return Err(bad(format!(
                        "corrupt MCAP file: a record runs past the end of the whole file \
                         ({})",
                        stream.bytes(offset)
                    )));
                }
                if state.counts.is_empty() {
                    return Err(bad(format!(
                        "MCAP file cut short: its last record is incomplete ({} read)",
                        stream.bytes(offset)
                    )));
                }
                cut = true;
                break;
            }
            Err(e) => return Err(bad(format!("corrupt MCAP file: {e}"))),
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let buf = reader.insert(need.clamp(1, READ_SIZE));
                let n = read_some(&mut source, buf).map_err(|e| bad(e.to_string()))?;
                tail.extend_from_slice(&buf[n.saturating_sub(mcap::MAGIC.len())..n]);
                tail.drain(..tail.len().saturating_sub(mcap::MAGIC.len()));
                reader.notify_read(n);
                offset += n as u64;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                state
                    .record(opcode, data, sink, false)
                    .map_err(|Corrupt(reason)| bad(reason))?;
            }
        }
    }
    state.check_summary().map_err(bad)?;
    let total: u64 = state.counts.values().sum();
    if cut {
        sink.warn(format!(
            "{}: cut short inside a record ({} read): read the {total} messages of the \
             records whole before the cut (a chunk cut short is lost whole)",
            path.display(),
            stream.bytes(offset)
        ));
    } else if !state.footer {
        sink.warn(format!(
            "{}: no summary at the end (a recording that did not finish?): read the {total} \
             messages it holds",
            path.display()
        ));
    }
    Ok(())
}

/// Reads into `buf`, retrying when interrupted; 0 at the end of the stream.
fn read_some(source: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match source.read(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            other => return other,
        }
    }
}

/// Why a record could not be taken: the file is corrupt (the reason).
struct Corrupt(String);

impl From<mcap::McapError> for Corrupt {
    fn from(e: mcap::McapError) -> Self {
        Self(format!("corrupt MCAP record: {e}"))
    }
}

impl State {
    /// Takes one record (`in_chunk` when it comes out of a chunk).
    fn record(
        &mut self,
        opcode: u8,
        body: &[u8],
        sink: &mut Collector,
        in_chunk: bool,
    ) -> std::result::Result<(), Corrupt> {
        // Only the records the reader needs are parsed.
        let wanted = [
            op::SCHEMA,
            op::CHANNEL,
            op::MESSAGE,
            op::CHUNK,
            op::STATISTICS,
            op::FOOTER,
        ];
        if !wanted.contains(&opcode) {
            return Ok(());
        }
        match mcap::parse_record(opcode, body)? {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(channel) => {
                let type_name = match channel.schema_id {
                    0 => String::new(),
                    id => self.schemas.get(&id).cloned().ok_or_else(|| {
                        Corrupt(format!(
                            "channel {} (`{}`) refers to schema {id}, which is not defined",
                            channel.id, channel.topic
                        ))
                    })?,
                };
                let topic = sink.topic(&channel.topic, &type_name, &channel.message_encoding);
                self.channels.insert(channel.id, topic);
            }
            Record::Message { header, data } => {
                let Some(&topic) = self.channels.get(&header.channel_id) else {
                    return Err(Corrupt(format!(
                        "a message refers to channel {}, which is not defined",
                        header.channel_id
                    )));
                };
                *self.counts.entry(header.channel_id).or_default() += 1;
                sink.message(topic, header.log_time, &data);
            }
            Record::Chunk { header, data } if !in_chunk => {
                let records = decompress(&header, &data).map_err(Corrupt)?;
                let mut rest: &[u8] = &records;
                while !rest.is_empty() {
                    let Some((&[opcode], tail)) = rest.split_first_chunk::<1>() else {
                        break;
                    };
                    let Some((len, tail)) = tail.split_first_chunk::<8>() else {
                        return Err(Corrupt("a chunk ends inside a record".into()));
                    };
                    let len = usize::try_from(u64::from_le_bytes(*len)).unwrap_or(usize::MAX);
                    if len > tail.len() {
                        return Err(Corrupt("a chunk ends inside a record".into()));
                    }
                    let (body, tail) = tail.split_at(len);
                    self.record(opcode, body, sink, true)?;
                    rest = tail;
                }
            }
            Record::Chunk { .. } => {
                return Err(Corrupt("a chunk inside a chunk".into()));
            }
            Record::Statistics(statistics) => self.statistics = Some(statistics),
            Record::Footer(_) => self.footer = true,
            _ => {}
        }
        Ok(())
    }

    /// Checks the messages read against the summary's statistics, when there are some.
    fn check_summary(&self) -> std::result::Result<(), String> {
        let Some(stats) = &self.statistics else {
            return Ok(());
        };
        let total: u64 = self.counts.values().sum();
        if stats.message_count != total {
            return Err(format!(
                "its summary counts {} messages, its data section holds {total}",
                stats.message_count
            ));
        }
        if stats.channel_message_counts.is_empty() {
            return Ok(());
        }
        let ids = (self.counts.keys()).chain(stats.channel_message_counts.keys());
        for id in ids {
            let (read, said) = (
                self.counts.get(id).copied().unwrap_or(0),
                (stats.channel_message_counts.get(id).copied()).unwrap_or(0),
            );
            if read != said {
                return Err(format!(
                    "its summary counts {said} messages on channel {id}, its data section holds \
                     {read}"
                ));
            }
        }
        Ok(())
    }
}

/// The records of a chunk, decompressed and checked against the chunk's size and CRC.
fn decompress<'a>(
    header: &ChunkHeader,
    data: &'a [u8],
) -> std::result::Result<Cow<'a, [u8]>, String> {
    let size = header.uncompressed_size;
    let records: Cow<[u8]> = match header.compression.as_str() {
        "" => Cow::Borrowed(data),
        "zstd" => Cow::Owned(inflate(
            super::storage::ZstdFrames::new(data),
            size,
            "zstd",
        )?),
        "lz4" => Cow::Owned(inflate(
            lz4_flex::frame::FrameDecoder::new(data),
            size,
            "lz4",
        )?),
        other => {
            return Err(format!(
                "a chunk uses compression `{other}`, not none, zstd or lz4"
            ));
        }
    };
    if records.len() as u64 != size {
        return Err(format!(
            "a chunk holds {} bytes of records, its header says {size}",
            records.len()
        ));
    }
    if header.uncompressed_crc != 0 && crc32fast::hash(&records) != header.uncompressed_crc {
        return Err("a chunk's CRC does not match its records".into());
    }
    Ok(records)
}

/// Up to one byte more than `size` read from the decompressor `inner`.
fn inflate(inner: impl Read, size: u64, kind: &str) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    (inner.take(size.saturating_add(1)))
        .read_to_end(&mut out)
        .map_err(|e| format!("a {kind} chunk does not decompress: {e}"))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn header(compression: &str, records: &[u8], compressed: &[u8]) -> ChunkHeader {
        ChunkHeader {
            message_start_time: 0,
            message_end_time: 0,
            uncompressed_size: records.len() as u64,
            uncompressed_crc: crc32fast::hash(records),
            compression: compression.into(),
            compressed_size: compressed.len() as u64,
        }
    }

    #[test]
    fn lz4_chunks_decompress_and_are_checked_against_size_and_crc() {
        let records = b"the records of one chunk, again and again; ".repeat(40);
        let mut encoder = lz4_flex::frame::FrameEncoder::new(Vec::new());
        encoder.write_all(&records).unwrap();
        let lz4 = encoder.finish().unwrap();
        assert!(lz4.len() < records.len());
        let h = header("lz4", &records, &lz4);
        assert_eq!(decompress(&h, &lz4).unwrap(), &records[..]);
        let bad_crc = ChunkHeader {
            uncompressed_crc: h.uncompressed_crc ^ 1,
            ..h.clone()
        };
        assert!(decompress(&bad_crc, &lz4).unwrap_err().contains("CRC"));
        let short = ChunkHeader {
            uncompressed_size: 10,
            ..h.clone()
        };
        assert!(
            decompress(&short, &lz4)
                .unwrap_err()
                .contains("header says 10")
        );
        assert!(decompress(&h, &lz4[..lz4.len() / 2]).is_err());
        let bz2 = header("bz2", &records, &records);
        assert!(decompress(&bz2, &records).unwrap_err().contains("`bz2`"));
        let plain = header("", &records, &records);
        assert_eq!(decompress(&plain, &records).unwrap(), &records[..]);
    }
}
