//! ROS 1 bags (format 2.0: one `.bag` file), read as a bag's storage file.
//!
//! A ROS 1 bag is a sequence of records, each a header of `name=value` fields (its `op`
//! says what it is) and a data block: the bag header, then chunks (uncompressed, `bz2` or
//! `lz4`) holding the connection records that name each topic and type and the messages,
//! then the index, which repeats the connections. The file is read from start to end in
//! one pass, a record at a time, and memory grows only with the bytes the file has:
//! - a bag cut short (inside a record, or between records before its index) keeps the
//!   messages of every chunk before the cut, with a warning;
//! - a recording that did not finish (no index; its last chunk still open, its header a
//!   placeholder followed by the chunk's records, compressed or not, up to where the
//!   recorder stopped) keeps every message up to there, with a warning;
//! - a bag cut before its first message, a record whose length runs past a whole file, a
//!   chunk that does not decompress to its stated size or holds other records than
//!   connections and messages, a record without its fields, and an encrypted bag are
//!   errors naming the file.
//!
//! Types are named the ROS 2 way (`sensor_msgs/LaserScan` becomes
//! `sensor_msgs/msg/LaserScan`, and tf's `tf/tfMessage` from before tf2 the
//! `tf2_msgs/msg/TFMessage` of the same fields) with the encoding [`ROS1_ENCODING`], so
//! the bag reader decodes them with ROS 1's serialisation.

use super::storage::Collector;
use crate::text::{DataError, Result};
use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

/// The first bytes of a ROS 1 bag (format 2.0).
pub const ROS1_MAGIC: &[u8] = b"#ROSBAG V2.0\n";
/// The encoding a ROS 1 bag's topics are registered with.
pub const ROS1_ENCODING: &str = "ros1";

/// A message (`op` 0x02).
const OP_MESSAGE: u8 = 0x02;
/// The bag header (`op` 0x03), the file's first record.
const OP_BAG_HEADER: u8 = 0x03;
/// A chunk of records (`op` 0x05).
const OP_CHUNK: u8 = 0x05;
/// A connection: a topic and its type (`op` 0x07).
const OP_CONNECTION: u8 = 0x07;
/// The longest header or data block accepted, against corrupt lengths.
const MAX_BLOCK: u32 = 1 << 31;

/// Why a bag cannot be read (the reason, for an error naming the file).
type Corrupt = std::result::Result<(), String>;

/// One record: its header's fields and its data.
struct Record {
    header: Vec<u8>,
    data: Vec<u8>,
}

impl Record {
    /// The value of the header's field `name`.
    fn field(&self, name: &str) -> Option<&[u8]> {
        fields(&self.header).find_map(|(n, v)| (n == name.as_bytes()).then_some(v))
    }

    /// The record's `op`.
    fn op(&self) -> std::result::Result<u8, String> {
        match self.field("op") {
            Some(&[op]) => Ok(op),
            _ => Err("a record without its op field".into()),
        }
    }

    /// The little-endian `N`-byte field `name`.
    fn bytes<const N: usize>(&self, name: &str) -> std::result::Result<[u8; N], String> {
        (self.field(name).and_then(|v| v.try_into().ok()))
            .ok_or_else(|| format!("a record without its {name} field"))
    }

    /// The `u32` field `name`.
    fn u32(&self, name: &str) -> std::result::Result<u32, String> {
        self.bytes(name).map(u32::from_le_bytes)
    }

    /// The `u64` field `name`.
    fn u64(&self, name: &str) -> std::result::Result<u64, String> {
        self.bytes(name).map(u64::from_le_bytes)
    }

    /// The `time` field (seconds and nanoseconds, each a `u32`) in nanoseconds.
    fn time_ns(&self) -> std::result::Result<u64, String> {
        let time: [u8; 8] = self.bytes("time")?;
        let (sec, nsec) = time.split_at(4);
        let word = |b: &[u8]| u64::from(u32::from_le_bytes(b.try_into().unwrap_or_default()));
        Ok(word(sec) * 1_000_000_000 + word(nsec))
    }

    /// True for the chunk a recording that stopped left open: its header a placeholder
    /// (size 0, no data), its records after it in the file.
    fn is_open_chunk(&self) -> bool {
        self.op() == Ok(OP_CHUNK) && self.data.is_empty() && self.u32("size") == Ok(0)
    }
}

/// The `name=value` fields of a record header or a connection's data block; the walk
/// stops at a field that runs past the end.
fn fields(block: &[u8]) -> impl Iterator<Item = (&[u8], &[u8])> {
    let mut rest = block;
    std::iter::from_fn(move || {
        let (len, tail) = rest.split_first_chunk::<4>()?;
        let len = u32::from_le_bytes(*len) as usize;
        let field = tail.get(..len)?;
        rest = &tail[len..];
        let eq = field.iter().position(|&b| b == b'=')?;
        Some((&field[..eq], &field[eq + 1..]))
    })
}

/// What the next record of a stream is.
enum Next {
    /// A whole record.
    Record(Record),
    /// The stream ended after a whole record.
    End,
    /// The stream ended inside a record.
    Cut,
}

/// The next record of `source`; `read` counts the bytes taken.
fn next_record(source: &mut impl Read, read: &mut u64) -> std::result::Result<Next, String> {
    let mut blocks = [Vec::new(), Vec::new()];
    for (k, block) in blocks.iter_mut().enumerate() {
        let len = take(source, 4, read)?;
        let Ok(len) = <[u8; 4]>::try_from(len.as_slice()) else {
            return Ok(if k == 0 && len.is_empty() {
                Next::End
            } else {
                Next::Cut
            });
        };
        let len = u32::from_le_bytes(len);
        if len > MAX_BLOCK {
            return Err(format!("a record block of {len} bytes at byte {read}"));
        }
        *block = take(source, u64::from(len), read)?;
        if block.len() < len as usize {
            return Ok(Next::Cut);
        }
    }
    let [header, data] = blocks;
    Ok(Next::Record(Record { header, data }))
}

/// Up to `n` bytes of `source`, fewer where it ends; `read` counts them.
fn take(source: &mut impl Read, n: u64, read: &mut u64) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    (source.take(n).read_to_end(&mut out)).map_err(|e| e.to_string())?;
    *read += out.len() as u64;
    Ok(out)
}

/// What the records read so far say.
#[derive(Default)]
struct State {
    /// Connection id → topic index in the collector.
    connections: HashMap<u32, usize>,
    /// Messages read.
    messages: u64,
    /// Where the bag header says the index starts (0: the bag was not closed).
    index_pos: u64,
}

impl State {
    /// Takes a record of the file's top level.
    fn top_level(&mut self, record: &Record, sink: &mut Collector) -> Corrupt {
        match record.op()? {
            OP_BAG_HEADER => {
                if let Some(encryptor) = record.field("encryptor") {
                    return Err(format!(
                        "the bag is encrypted ({}), which is not read",
                        String::from_utf8_lossy(encryptor)
                    ));
                }
                self.index_pos = record.u64("index_pos")?;
                Ok(())
            }
            OP_CHUNK => self.chunk(&decompress(record)?, sink),
            OP_CONNECTION | OP_MESSAGE => self.connection_or_message(record, sink),
            // Index data and chunk information: where things are, which one pass does not
            // need.
            _ => Ok(()),
        }
    }

    /// Takes the records of one decompressed chunk.
    fn chunk(&mut self, mut records: &[u8], sink: &mut Collector) -> Corrupt {
        let mut read = 0;
        loop {
            match next_record(&mut records, &mut read)? {
                Next::Record(record) => self.connection_or_message(&record, sink)?,
                Next::End => return Ok(()),
                Next::Cut => return Err("a chunk's last record runs past its end".into()),
            }
        }
    }

    /// Takes a connection or a message, and refuses any other record (a chunk holds only
    /// connections and messages).
    fn connection_or_message(&mut self, record: &Record, sink: &mut Collector) -> Corrupt {
        match record.op()? {
            OP_CONNECTION => {
                let id = record.u32("conn")?;
                // The topic in the bag is the header's; the data block's is the topic as
                // published, which a rewritten bag may have renamed.
                let topic = record
                    .field("topic")
                    .ok_or("a connection without its topic")?;
                let type_name = fields(&record.data)
                    .find_map(|(n, v)| (n == b"type").then(|| String::from_utf8_lossy(v)))
                    .map_or_else(String::new, |t| ros2_type_name(&t));
                let k = sink.topic(&String::from_utf8_lossy(topic), &type_name, ROS1_ENCODING);
                self.connections.entry(id).or_insert(k);
            }
            OP_MESSAGE => {
                let id = record.u32("conn")?;
                let topic = *self.connections.get(&id).ok_or_else(|| {
                    format!(
                        "a message on connection {id}, which no connection record names before it"
                    )
                })?;
                sink.message(topic, record.time_ns()?, &record.data);
                self.messages += 1;
            }
            op => return Err(format!("a chunk holds a record of op {op:#04x}")),
        }
        Ok(())
    }

    /// Reads the records of the chunk a recording left open, which run from `source`'s
    /// position to its end (compressed as `chunk` says), up to the last whole one.
    fn open_chunk(&mut self, chunk: &Record, source: impl Read, sink: &mut Collector) -> Corrupt {
        let mut stream = decoder(chunk.field("compression").unwrap_or(b"none"), source)?;
        let mut read = 0;
        // The stream ends where the recorder stopped: inside a record, or in the middle of
        // a compressed block, which does not decompress.
        while let Ok(Next::Record(record)) = next_record(&mut stream, &mut read) {
            self.connection_or_message(&record, sink)?;
        }
        Ok(())
    }
}

/// The records of a chunk compressed with `compression` (none, bz2 or lz4), read from
/// `source`.
fn decoder<'r>(
    compression: &[u8],
    source: impl Read + 'r,
) -> std::result::Result<Box<dyn Read + 'r>, String> {
    Ok(match compression {
        b"none" => Box::new(source),
        b"bz2" => Box::new(bzip2::read::BzDecoder::new(source)),
        b"lz4" => Box::new(lz4_flex::frame::FrameDecoder::new(source)),
        other => {
            return Err(format!(
                "a chunk compressed with `{}`, which is not none, bz2 or lz4",
                String::from_utf8_lossy(other)
            ));
        }
    })
}

/// A chunk's records, decompressed and checked against the chunk's stated size.
fn decompress(chunk: &Record) -> std::result::Result<Vec<u8>, String> {
    let size = chunk.u32("size")?;
    let compression = chunk.field("compression").unwrap_or(b"none");
    let decoder = decoder(compression, chunk.data.as_slice())?;
    let name = String::from_utf8_lossy(compression);
    // At most one byte more than stated: enough to tell, never more memory than that.
    let mut out = Vec::new();
    (decoder.take(u64::from(size) + 1).read_to_end(&mut out))
        .map_err(|e| format!("a {name} chunk does not decompress: {e}"))?;
    if out.len() != size as usize {
        return Err(format!(
            "a {name} chunk decompresses to {}{} bytes, not the {size} it states",
            if out.len() > size as usize {
                "over "
            } else {
                ""
            },
            out.len().min(size as usize)
        ));
    }
    Ok(out)
}

/// `pkg/Type` as ROS 2 names it, `pkg/msg/Type`; a name with more parts is kept. tf's
/// `tf/tfMessage`, from before tf2, is `tf2_msgs/msg/TFMessage`: the same fields.
fn ros2_type_name(ros1: &str) -> String {
    if ros1 == "tf/tfMessage" {
        return "tf2_msgs/msg/TFMessage".into();
    }
    match ros1.split_once('/') {
        Some((package, name)) if !name.contains('/') => format!("{package}/msg/{name}"),
        _ => ros1.to_string(),
    }
}

/// How the pass over a bag ended.
enum Ending {
    /// After a whole record.
    Whole,
    /// Inside the record that starts at this byte.
    Cut(u64),
    /// In the chunk a recording left open.
    OpenChunk,
}

/// Reads the ROS 1 bag `source` (the file `path`, from its first byte) into `sink`.
///
/// # Errors
/// [`DataError::Io`] naming the file when it is cut short before its first message,
/// corrupt or encrypted.
pub fn read(mut source: impl Read, path: &Path, sink: &mut Collector) -> Result<()> {
    let bad = |reason: String| DataError::Io {
        path: path.to_path_buf(),
        reason,
    };
    let mut offset = 0;
    if take(&mut source, ROS1_MAGIC.len() as u64, &mut offset).map_err(&bad)? != ROS1_MAGIC {
        return Err(bad("not a ROS 1 bag of format 2.0".into()));
    }
    let corrupt = |reason: String| bad(format!("corrupt ROS 1 bag: {reason}"));
    let mut state = State::default();
    let ending = loop {
        let start = offset;
        match next_record(&mut source, &mut offset).map_err(&bad)? {
            // An uncompressed open chunk's records read like the top level's.
            Next::Record(record)
                if record.is_open_chunk() && record.field("compression") != Some(b"none") =>
            {
                let open = state.open_chunk(&record, &mut source, sink);
                open.map_err(corrupt)?;
                break Ending::OpenChunk;
            }
            Next::Record(record) => state.top_level(&record, sink).map_err(corrupt)?,
            Next::End => break Ending::Whole,
            Next::Cut => break Ending::Cut(start),
        }
    };
    let (messages, index) = (state.messages, state.index_pos);
    let cut_before_index = index > 0 && offset < index;
    let warning = match ending {
        // The index (after every chunk) was read into: the file is whole, so the record
        // that runs past its end has a corrupt length.
        Ending::Cut(start) if start < index && offset >= index => {
            return Err(corrupt(format!(
                "the record at byte {start} runs past the end of the file"
            )));
        }
        // Ended early with nothing read.
        _ if messages == 0 && (cut_before_index || !matches!(ending, Ending::Whole)) => {
            return Err(bad(format!(
                "ROS 1 bag cut short before its first message ({offset} bytes read)"
            )));
        }
        Ending::Cut(_) => Some(format!("cut short inside a record ({offset} bytes read)")),
        Ending::Whole if cut_before_index => Some(format!(
            "cut short ({offset} bytes read, where its index starts at byte {index})"
        )),
        Ending::Whole if index == 0 => Some("no index (a recording that did not finish?)".into()),
        Ending::OpenChunk => {
            Some("a recording that did not finish (its last chunk still open, no index)".into())
        }
        Ending::Whole => None,
    };
    if let Some(what) = warning {
        sink.warn(format!(
            "{}: {what}: read the {messages} messages of the records whole before its end",
            path.display()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
