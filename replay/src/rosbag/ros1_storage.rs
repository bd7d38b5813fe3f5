//! ROS 1 bags (format 2.0: one `.bag` file), read as a bag's storage file.
//!
//! A ROS 1 bag is a sequence of records, each a header of `name=value` fields (its `op`
//! says what it is) and a data block. Messages sit in chunks (uncompressed, `bz2` or
//! `lz4`), each beside the connection records that name their topic and type; the index
//! after the chunks repeats the connections. The file is read from start to end in one
//! pass, a record at a time, so a bag that was not closed (no index: a recording that
//! stopped) and a bag cut short inside a record keep the messages of every chunk before
//! the cut, with a warning. A bag cut before its first message, a chunk that does not
//! decompress to its stated size or a record without its fields is an error naming the
//! file.
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

    /// The little-endian `u32` field `name`.
    fn u32(&self, name: &str) -> std::result::Result<u32, String> {
        let value = self.field(name).and_then(|v| v.try_into().ok());
        value
            .map(u32::from_le_bytes)
            .ok_or_else(|| format!("a record without its {name} field"))
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

/// Where a stream of records ended.
enum End {
    /// After a whole record.
    Clean,
    /// Inside a record.
    Cut,
}

/// The next record of `source`, or where the stream ended; `read` counts the bytes.
fn next_record(
    source: &mut impl Read,
    read: &mut u64,
) -> std::result::Result<std::result::Result<Record, End>, String> {
    let mut blocks = [Vec::new(), Vec::new()];
    for (k, block) in blocks.iter_mut().enumerate() {
        let mut len = [0u8; 4];
        let n = read_up_to(source, &mut len)?;
        *read += n as u64;
        if n < 4 {
            return Ok(Err(if k == 0 && n == 0 {
                End::Clean
            } else {
                End::Cut
            }));
        }
        let len = u32::from_le_bytes(len);
        if len > MAX_BLOCK {
            return Err(format!("a record block of {len} bytes at byte {read}"));
        }
        block.resize(len as usize, 0);
        let n = read_up_to(source, block)?;
        *read += n as u64;
        if n < block.len() {
            return Ok(Err(End::Cut));
        }
    }
    let [header, data] = blocks;
    Ok(Ok(Record { header, data }))
}

/// Fills `buf` as far as `source` goes; the bytes read.
fn read_up_to(source: &mut impl Read, buf: &mut [u8]) -> std::result::Result<usize, String> {
    let mut filled = 0;
    while filled < buf.len() {
        match source.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.to_string()),
        }
    }
    Ok(filled)
}

/// What the records read so far say.
#[derive(Default)]
struct State {
    /// Connection id → topic index in the collector.
    connections: HashMap<u32, usize>,
    /// Messages read.
    messages: u64,
    /// Whether the bag header says the bag has its index (it was closed).
    indexed: bool,
}

impl State {
    /// Takes one record found at the top level or inside a chunk.
    fn record(&mut self, record: &Record, sink: &mut Collector) -> std::result::Result<(), String> {
        match record.op()? {
            OP_BAG_HEADER => {
                let index = record.field("index_pos").and_then(|v| v.try_into().ok());
                self.indexed = index.is_some_and(|v| u64::from_le_bytes(v) > 0);
            }
            OP_CHUNK => {
                let chunk = decompress(record)?;
                let mut source = chunk.as_slice();
                let mut read = 0;
                loop {
                    match next_record(&mut source, &mut read)? {
                        Ok(inner) => self.record(&inner, sink)?,
                        Err(End::Clean) => break,
                        Err(End::Cut) => {
                            return Err("a chunk's last record runs past its end".into());
                        }
                    }
                }
            }
            OP_CONNECTION => {
                let id = record.u32("conn")?;
                let field = |name: &str| {
                    fields(&record.data).find_map(|(n, v)| {
                        (n == name.as_bytes()).then(|| String::from_utf8_lossy(v))
                    })
                };
                let topic = field("topic")
                    .or_else(|| record.field("topic").map(String::from_utf8_lossy))
                    .ok_or("a connection without its topic")?;
                let type_name = field("type").map_or_else(String::new, |t| ros2_type_name(&t));
                let k = sink.topic(&topic, &type_name, ROS1_ENCODING);
                self.connections.entry(id).or_insert(k);
            }
            OP_MESSAGE => {
                let id = record.u32("conn")?;
                let topic = *self.connections.get(&id).ok_or_else(|| {
                    format!(
                        "a message on connection {id}, which no connection record names before it"
                    )
                })?;
                let time = record
                    .field("time")
                    .and_then(|v| <[u8; 8]>::try_from(v).ok());
                let time = time.ok_or("a message without its time field")?;
                let (sec, nsec) = (
                    u32::from_le_bytes(time[..4].try_into().unwrap_or_default()),
                    u32::from_le_bytes(time[4..].try_into().unwrap_or_default()),
                );
                sink.message(
                    topic,
                    u64::from(sec) * 1_000_000_000 + u64::from(nsec),
                    &record.data,
                );
                self.messages += 1;
            }
            // Index data and chunk information: where things are, which one pass does not
            // need.
            _ => {}
        }
        Ok(())
    }
}

/// A chunk's records, decompressed and checked against the chunk's stated size.
fn decompress(chunk: &Record) -> std::result::Result<Vec<u8>, String> {
    let size = chunk.u32("size")? as usize;
    let compression = chunk.field("compression").unwrap_or(b"none");
    // The stated size is checked after, not trusted for the allocation.
    let mut out = Vec::with_capacity(size.min(1 << 26));
    let result = match compression {
        b"none" => {
            out.extend_from_slice(&chunk.data);
            Ok(())
        }
        b"bz2" => bzip2::read::BzDecoder::new(chunk.data.as_slice())
            .read_to_end(&mut out)
            .map(|_| ()),
        b"lz4" => lz4_flex::frame::FrameDecoder::new(chunk.data.as_slice())
            .read_to_end(&mut out)
            .map(|_| ()),
        other => {
            return Err(format!(
                "a chunk compressed with `{}`, which is not none, bz2 or lz4",
                String::from_utf8_lossy(other)
            ));
        }
    };
    let name = String::from_utf8_lossy(compression);
    result.map_err(|e| format!("a {name} chunk does not decompress: {e}"))?;
    if out.len() != size {
        return Err(format!(
            "a {name} chunk decompresses to {} bytes, not the {size} it states",
            out.len()
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

/// Reads the ROS 1 bag `source` (the file `path`, after its first line was checked) into
/// `sink`.
///
/// # Errors
/// [`DataError::Io`] naming the file when it is cut short before its first message or
/// corrupt.
pub fn read(mut source: impl Read, path: &Path, sink: &mut Collector) -> Result<()> {
    let bad = |reason: String| DataError::Io {
        path: path.to_path_buf(),
        reason,
    };
    let mut magic = [0u8; ROS1_MAGIC.len()];
    let mut offset = read_up_to(&mut source, &mut magic).map_err(&bad)? as u64;
    if magic != ROS1_MAGIC {
        return Err(bad("not a ROS 1 bag of format 2.0".into()));
    }
    let mut state = State::default();
    let cut = loop {
        match next_record(&mut source, &mut offset).map_err(&bad)? {
            Ok(record) => state
                .record(&record, sink)
                .map_err(|reason| bad(format!("corrupt ROS 1 bag: {reason}")))?,
            Err(End::Clean) => break false,
            Err(End::Cut) => break true,
        }
    };
    let messages = state.messages;
    if cut && messages == 0 {
        return Err(bad(format!(
            "ROS 1 bag cut short before its first message ({offset} bytes read)"
        )));
    }
    if cut {
        sink.warn(format!(
            "{}: cut short inside a record ({offset} bytes read): read the {messages} messages \
             of the chunks whole before the cut (a chunk cut short is lost whole)",
            path.display()
        ));
    } else if !state.indexed {
        sink.warn(format!(
            "{}: no index (a recording that did not finish?): read the {messages} messages \
             it holds",
            path.display()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record header or connection block of `fields`.
    fn block(fields: &[(&str, &[u8])]) -> Vec<u8> {
        let mut out = Vec::new();
        for (name, value) in fields {
            out.extend_from_slice(&((name.len() + 1 + value.len()) as u32).to_le_bytes());
            out.extend_from_slice(name.as_bytes());
            out.push(b'=');
            out.extend_from_slice(value);
        }
        out
    }

    #[test]
    fn types_are_named_the_ros2_way() {
        assert_eq!(
            ros2_type_name("sensor_msgs/LaserScan"),
            "sensor_msgs/msg/LaserScan"
        );
        assert_eq!(
            ros2_type_name("tf2_msgs/msg/TFMessage"),
            "tf2_msgs/msg/TFMessage"
        );
        assert_eq!(ros2_type_name("Untyped"), "Untyped");
        assert_eq!(ros2_type_name("tf/tfMessage"), "tf2_msgs/msg/TFMessage");
    }

    #[test]
    fn fields_split_at_the_first_equals_sign_and_stop_at_a_short_one() {
        let mut header = block(&[("op", &[OP_CHUNK]), ("topic", b"/a=b")]);
        let found: Vec<_> = fields(&header).collect();
        assert_eq!(
            found,
            [(&b"op"[..], &[OP_CHUNK][..]), (&b"topic"[..], &b"/a=b"[..])]
        );
        header.extend_from_slice(&100u32.to_le_bytes());
        header.extend_from_slice(b"size=1");
        assert_eq!(fields(&header).count(), 2, "a field that runs past the end");
    }

    #[test]
    fn a_chunk_is_checked_against_its_compression_and_size() {
        let chunk = |compression: &[u8], size: u32, data: &[u8]| Record {
            header: block(&[
                ("op", &[OP_CHUNK]),
                ("compression", compression),
                ("size", &size.to_le_bytes()),
            ]),
            data: data.to_vec(),
        };
        assert_eq!(decompress(&chunk(b"none", 3, b"abc")).unwrap(), b"abc");
        let err = decompress(&chunk(b"none", 4, b"abc")).unwrap_err();
        assert!(err.contains("decompresses to 3 bytes, not the 4"), "{err}");
        let err = decompress(&chunk(b"zstd", 3, b"abc")).unwrap_err();
        assert!(
            err.contains("`zstd`, which is not none, bz2 or lz4"),
            "{err}"
        );
        let err = decompress(&chunk(b"bz2", 3, b"abc")).unwrap_err();
        assert!(err.starts_with("a bz2 chunk does not decompress"), "{err}");
    }

    #[test]
    fn a_message_before_its_connection_is_corrupt() {
        let message = Record {
            header: block(&[("op", &[OP_MESSAGE]), ("conn", &3u32.to_le_bytes())]),
            data: Vec::new(),
        };
        let keep = |_: &str, _: &str| true;
        let mut sink = Collector::new(&keep);
        let err = State::default().record(&message, &mut sink).unwrap_err();
        assert!(
            err.contains("connection 3, which no connection record names"),
            "{err}"
        );
    }
}
