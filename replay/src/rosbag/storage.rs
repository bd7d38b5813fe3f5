//! A bag's storage files and their raw messages: topic, type, receive time and bytes.
//!
//! A rosbag2 bag is a folder with `metadata.yaml` and one or more storage files; the
//! storage files name their topics and types themselves (MCAP channels and schemas, the
//! SQLite `topics` table), so `metadata.yaml` only says which files make the bag and in
//! which order (`relative_file_paths`). A folder without it is read file by file in
//! name order (numbers compared as numbers: `bag_2` before `bag_10`).
//!
//! Each file's format comes from its first bytes, not its name: MCAP, SQLite, either
//! compressed whole with zstd (rosbag2's `file` compression mode), or a ROS 1 bag. A
//! message whose bytes are a zstd frame (the `message` compression mode) is decompressed on
//! the way in. A folder without `metadata.yaml` may instead hold ROS 1 bags: the files of
//! one recording split by size or time, read in name order.

use super::cdr::{DecodeResult, Serialization};
use super::mcap_storage::{self, Stream};
use super::ros1_storage::{self, ROS1_ENCODING, ROS1_MAGIC};
use super::sqlite_storage;
use crate::text::{DataError, Result};
use ruzstd::decoding::errors::{FrameDecoderError, ReadFrameHeaderError};
use ruzstd::decoding::{BlockDecodingStrategy, FrameDecoder};
use serde::Deserialize;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// The first bytes of an MCAP file.
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
/// The first bytes of an SQLite database.
const SQLITE_MAGIC: &[u8] = b"SQLite format 3\0";
/// The first bytes of a zstd frame.
const ZSTD_MAGIC: &[u8] = &[0x28, 0xb5, 0x2f, 0xfd];
/// The most bytes one decompressed message may take.
const MAX_MESSAGE_BYTES: u64 = 1 << 30;

/// One topic of the bag (a name with one type).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// The topic name (`/scan`).
    pub name: String,
    /// The message type (`sensor_msgs/msg/LaserScan`); empty when the file does not say.
    pub type_name: String,
    /// The serialisation (`cdr` for ROS 2, `ros1` for a ROS 1 bag).
    pub encoding: String,
    /// How many messages the bag holds on it.
    pub count: usize,
}

impl Topic {
    /// The serialisation of its messages, when the decoders read it.
    pub fn serialization(&self) -> Option<Serialization> {
        match self.encoding.as_str() {
            "cdr" => Some(Serialization::Cdr),
            ROS1_ENCODING => Some(Serialization::Ros1),
            _ => None,
        }
    }
}

/// One message kept for decoding.
#[derive(Debug, Clone)]
pub struct RawMessage {
    /// Index into [`Contents::topics`].
    pub topic: usize,
    /// Index into [`Contents::files`].
    pub file: usize,
    /// Position on its topic, from 0, in storage order.
    pub index: usize,
    /// When the recorder received it (ns, the bag's clock).
    pub receive_ns: u64,
    /// The serialised message (for a [`Keep::Reduced`] topic, what the reduction made of
    /// it), or why its bytes cannot be read (a zstd frame that does not decompress, a
    /// message the reduction refused).
    pub data: std::result::Result<Vec<u8>, String>,
}

impl RawMessage {
    /// The serialised message, or why its bytes cannot be read, for a decoder.
    pub fn bytes(&self) -> std::result::Result<&[u8], String> {
        self.data.as_deref().map_err(String::clone)
    }
}

/// What a bag holds: its files, every topic with its count, and the messages of the
/// topics that were asked for.
#[derive(Debug, Clone, Default)]
pub struct Contents {
    /// The storage files read, in order.
    pub files: Vec<PathBuf>,
    /// Every topic seen.
    pub topics: Vec<Topic>,
    /// The kept topics' messages, in storage order.
    pub messages: Vec<RawMessage>,
    /// Things worth telling (a file without summary).
    pub warnings: Vec<String>,
}

/// What the reader keeps of a topic's messages.
#[derive(Debug, Clone, Copy)]
pub enum Keep {
    /// Nothing: the messages are only counted.
    Nothing,
    /// Their bytes.
    Bytes,
    /// What the function makes of each message's bytes (in its topic's serialisation), so
    /// that a large message read for a small part of it is never held whole; an error
    /// takes the bytes' place.
    Reduced(fn(&[u8], Serialization) -> DecodeResult<Vec<u8>>),
}

/// Collects topics and messages as the storage readers find them.
pub struct Collector<'k> {
    keep: &'k dyn Fn(&str, &str) -> Keep,
    contents: Contents,
    by_key: HashMap<(String, String), usize>,
    kept: Vec<Keep>,
}

impl<'k> Collector<'k> {
    /// An empty collector keeping of each topic's messages what `keep(name, type)` says.
    pub fn new(keep: &'k dyn Fn(&str, &str) -> Keep) -> Self {
        Self {
            keep,
            contents: Contents::default(),
            by_key: HashMap::new(),
            kept: Vec::new(),
        }
    }

    /// Starts reading the storage file `path`: the messages that follow are its.
    pub fn start_file(&mut self, path: &Path) {
        self.contents.files.push(path.to_path_buf());
    }

    /// What was collected.
    #[cfg(test)]
    pub fn into_contents(self) -> Contents {
        self.contents
    }

    /// The index of topic `name` of type `type_name`, registered on first sight.
    pub fn topic(&mut self, name: &str, type_name: &str, encoding: &str) -> usize {
        let key = (name.to_string(), type_name.to_string());
        if let Some(&k) = self.by_key.get(&key) {
            return k;
        }
        let k = self.contents.topics.len();
        self.contents.topics.push(Topic {
            name: name.into(),
            type_name: type_name.into(),
            encoding: encoding.into(),
            count: 0,
        });
        self.kept.push((self.keep)(name, type_name));
        self.by_key.insert(key, k);
        k
    }

    /// Counts a message of `topic` received at `receive_ns`, and keeps what the topic's
    /// [`Keep`] says of its bytes: a zstd frame decompressed first, or why it does not
    /// decompress.
    pub fn message(&mut self, topic: usize, receive_ns: u64, data: &[u8]) {
        let t = &mut self.contents.topics[topic];
        let index = t.count;
        t.count += 1;
        let serialization = t.serialization();
        let reduce = match self.kept[topic] {
            Keep::Nothing => return,
            Keep::Bytes => None,
            Keep::Reduced(reduce) => Some(reduce),
        };
        let file = self.contents.files.len() - 1;
        // What is kept of the (decompressed) bytes: a copy, or their reduction read in place.
        let kept = |bytes: &[u8]| match (reduce, serialization) {
            (None, _) => Ok(bytes.to_vec()),
            (Some(reduce), Some(serialization)) => reduce(bytes, serialization),
            (Some(_), None) => Err("a serialisation the decoders do not read".to_string()),
        };
        let data = if data.starts_with(ZSTD_MAGIC) {
            let mut out = Vec::new();
            let mut frames = ZstdFrames::new(data);
            let read = (&mut frames).take(MAX_MESSAGE_BYTES).read_to_end(&mut out);
            let whole = read.and_then(|_| match frames.cut_short() {
                true => Err(std::io::ErrorKind::UnexpectedEof.into()),
                false => Ok(()),
            });
            (whole.map_err(|e| format!("zstd-compressed message does not decompress: {e}")))
                .and_then(|()| {
                    if reduce.is_some() {
                        kept(&out)
                    } else {
                        Ok(out)
                    }
                })
        } else {
            kept(data)
        };
        self.contents.messages.push(RawMessage {
            topic,
            file,
            index,
            receive_ns,
            data,
        });
    }

    /// Adds a warning about the file being read.
    pub fn warn(&mut self, text: String) {
        self.contents.warnings.push(text);
    }
}

/// Reads the bag at `path` (a rosbag2 folder, one `.mcap` / `.db3` file, or a ROS 1 `.bag`
/// file or folder of them), keeping of each topic's messages what `keep(name, type)` says.
///
/// # Errors
/// [`DataError`] naming the file: a missing or unknown storage file, a bad
/// `metadata.yaml`, a truncated or corrupt file.
pub fn read(path: &Path, keep: &dyn Fn(&str, &str) -> Keep) -> Result<Contents> {
    let files = storage_files(path)?;
    let mut sink = Collector::new(keep);
    for file in files {
        sink.start_file(&file);
        read_file(&file, &mut sink)?;
    }
    Ok(sink.contents)
}

/// The storage files of the bag at `path`, in order.
fn storage_files(path: &Path) -> Result<Vec<PathBuf>> {
    if path.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    if !path.is_dir() {
        return Err(DataError::Missing {
            path: path.to_path_buf(),
        });
    }
    let metadata = path.join("metadata.yaml");
    if metadata.is_file() {
        let files = relative_file_paths(&metadata)?;
        for file in &files {
            if !file.is_file() {
                return Err(DataError::Unusable(format!(
                    "{}: lists {}, which does not exist",
                    metadata.display(),
                    file.display()
                )));
            }
        }
        return Ok(files);
    }
    let io = |e: std::io::Error| DataError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    // rosbag2 storage files, and ROS 1 bags (one recording split by `rosbag record
    // --split`): one kind or the other.
    let (mut rosbag2, mut ros1) = (Vec::new(), Vec::new());
    for entry in std::fs::read_dir(path).map_err(io)? {
        let file = entry.map_err(io)?.path();
        let name = file.file_name().unwrap_or_default().to_string_lossy();
        let storage = [".mcap", ".db3", ".mcap.zstd", ".db3.zstd"];
        if file.is_file() && storage.iter().any(|s| name.ends_with(s)) {
            rosbag2.push(file);
        } else if file.is_file() && name.ends_with(".bag") {
            ros1.push(file);
        }
    }
    for files in [&mut rosbag2, &mut ros1] {
        files.sort_by_cached_key(|f| {
            natural_key(&f.file_name().unwrap_or_default().to_string_lossy())
        });
    }
    let name = |files: &[PathBuf]| {
        files[0]
            .file_name()
            .unwrap_or_default()
            .display()
            .to_string()
    };
    let files = match (rosbag2.is_empty(), ros1.is_empty()) {
        (true, true) => {
            return Err(DataError::Unusable(format!(
                "{}: not a bag: no metadata.yaml and no .mcap, .db3 or .bag file",
                path.display()
            )));
        }
        (false, false) => {
            return Err(DataError::Unusable(format!(
                "{}: holds both rosbag2 storage files ({}…) and ROS 1 bags ({}…): give the \
                 one file, or a folder of one kind",
                path.display(),
                name(&rosbag2),
                name(&ros1)
            )));
        }
        (false, true) => rosbag2,
        (true, false) => ros1,
    };
    Ok(files)
}

/// A sort key comparing runs of digits as numbers.
fn natural_key(name: &str) -> Vec<(String, u128)> {
    let mut key = Vec::new();
    let mut rest = name;
    while !rest.is_empty() {
        let text_len = rest
            .find(|c: char| c.is_ascii_digit())
            .unwrap_or(rest.len());
        let (text, tail) = rest.split_at(text_len);
        let digits_len = tail
            .find(|c: char| !c.is_ascii_digit())
            .unwrap_or(tail.len());
        let (digits, tail) = tail.split_at(digits_len);
        key.push((text.to_string(), digits.parse().unwrap_or(u128::MAX)));
        rest = tail;
    }
    key
}

/// The part of `metadata.yaml` the reader uses.
#[derive(Debug, Deserialize)]
struct Metadata {
    rosbag2_bagfile_information: BagInfo,
}

/// `rosbag2_bagfile_information`: the storage files, relative to the folder.
#[derive(Debug, Deserialize)]
struct BagInfo {
    #[serde(default)]
    relative_file_paths: Vec<String>,
}

/// The storage files `metadata.yaml` lists, as paths.
fn relative_file_paths(metadata: &Path) -> Result<Vec<PathBuf>> {
    let bad = |reason: String| DataError::Io {
        path: metadata.to_path_buf(),
        reason,
    };
    let text = std::fs::read_to_string(metadata).map_err(|e| bad(e.to_string()))?;
    let parsed: Metadata = serde_yaml_ng::from_str(&text)
        .map_err(|e| bad(format!("not a rosbag2 metadata file: {e}")))?;
    let names = parsed.rosbag2_bagfile_information.relative_file_paths;
    if names.is_empty() {
        return Err(bad("lists no storage file (relative_file_paths)".into()));
    }
    let dir = metadata.parent().unwrap_or(Path::new("."));
    Ok(names.iter().map(|n| dir.join(n)).collect())
}

/// Reads one storage file into `sink`, by its format.
fn read_file(path: &Path, sink: &mut Collector) -> Result<()> {
    let io = |e: std::io::Error| DataError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut reader = BufReader::new(File::open(path).map_err(io)?);
    let head = reader.fill_buf().map_err(io)?.to_vec();
    if head.starts_with(MCAP_MAGIC) {
        mcap_storage::read(reader, Stream::File, path, sink)
    } else if head.starts_with(ROS1_MAGIC) {
        ros1_storage::read(reader, path, sink)
    } else if head.starts_with(SQLITE_MAGIC) {
        sqlite_storage::read(path, path, sink)
    } else if head.starts_with(ZSTD_MAGIC) {
        let mut inner = BufReader::new(ZstdFrames::new(reader));
        let head = inner.fill_buf().map_err(io)?.to_vec();
        if head.is_empty() && inner.get_ref().cut_short() {
            return Err(DataError::Unusable(format!(
                "{}: the zstd-compressed file is cut short before its first whole block",
                path.display()
            )));
        }
        if head.starts_with(MCAP_MAGIC) {
            // A cut in the compressed file is a cut in the MCAP stream, which the MCAP
            // reader reads up to and warns about.
            mcap_storage::read(inner, Stream::Decompressed, path, sink)
        } else if head.starts_with(SQLITE_MAGIC) {
            let copy = TempFile::copy_of(&mut inner, path)?;
            if inner.get_ref().cut_short() {
                return Err(DataError::Unusable(format!(
                    "{}: the zstd-compressed database is cut short; SQLite needs the \
                     whole file",
                    path.display()
                )));
            }
            sqlite_storage::read(&copy.0, path, sink)
        } else {
            Err(unknown_storage(path, &head))
        }
    } else {
        Err(unknown_storage(path, &head))
    }
}

/// The error for a file that is neither MCAP, SQLite nor a ROS 1 bag, showing its first
/// bytes.
fn unknown_storage(path: &Path, head: &[u8]) -> DataError {
    if head.starts_with(b"#ROS") {
        let line = head.split(|&b| b == b'\n').next().unwrap_or_default();
        return DataError::Unusable(format!(
            "{}: a ROS 1 bag of another format than 2.0 (`{}`); ROS 1's `rosbag filter \
             IN OUT True` rewrites it as 2.0",
            path.display(),
            String::from_utf8_lossy(line)
        ));
    }
    let shown: Vec<String> = head.iter().take(8).map(|b| format!("{b:02x}")).collect();
    DataError::Unusable(format!(
        "{}: unknown storage: neither MCAP, SQLite (nor either compressed with zstd) nor a \
         ROS 1 bag; it starts with {}",
        path.display(),
        if shown.is_empty() {
            "nothing (empty file)".to_string()
        } else {
            shown.join(" ")
        }
    ))
}

/// A decompressed copy of a database, removed when dropped (SQLite reads files only).
struct TempFile(PathBuf);

impl TempFile {
    /// A temporary file holding all of `source`; errors name `shown`.
    fn copy_of(source: &mut impl Read, shown: &Path) -> Result<Self> {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let name = format!(
            "fastslam-rosbag-{}-{}.db3",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        );
        let copy = Self(std::env::temp_dir().join(name));
        let written = File::create(&copy.0).and_then(|mut f| std::io::copy(source, &mut f));
        written.map_err(|e| DataError::Io {
            path: shown.to_path_buf(),
            reason: format!("decompressing into {}: {e}", copy.0.display()),
        })?;
        Ok(copy)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// zstd-compressed bytes as a reader of the decompressed bytes: any number of frames one
/// after another (skippable frames skipped), each frame's checksum checked. Compressed
/// bytes that end inside a frame (a file cut short) end the stream after the frame's last
/// whole block, and [`ZstdFrames::cut_short`] says so.
pub struct ZstdFrames<R: Read> {
    source: BufReader<R>,
    decoder: FrameDecoder,
    in_frame: bool,
    cut: bool,
    /// The next block's compressed bytes, read whole before the decoder sees them.
    block: Vec<u8>,
}

/// An empty raw block marked last, and room for a checksum: ends a frame that was cut,
/// so that the decoder gives up the bytes it holds back for its window.
const LAST_EMPTY_BLOCK: [u8; 7] = [1, 0, 0, 0, 0, 0, 0];

impl<R: Read> ZstdFrames<R> {
    /// A reader decompressing `source`.
    pub fn new(source: R) -> Self {
        Self {
            source: BufReader::new(source),
            decoder: FrameDecoder::new(),
            in_frame: false,
            cut: false,
            block: Vec::new(),
        }
    }

    /// True once the compressed bytes have ended inside a frame: what was read is what
    /// decompressed before the cut.
    pub fn cut_short(&self) -> bool {
        self.cut
    }

    /// Whether a failed frame header is the compressed bytes running out (a cut), not
    /// corrupt data: the source has nothing left.
    fn ran_out(&mut self) -> std::io::Result<bool> {
        if self.source.fill_buf()?.is_empty() {
            self.cut = true;
        }
        Ok(self.cut)
    }

    /// Reads the next block (its 3-byte header and its content) into `self.block`;
    /// false when the source ends before the block does.
    fn next_block(&mut self) -> std::io::Result<bool> {
        self.block.clear();
        let mut source = (&mut self.source).take(3);
        if source.read_to_end(&mut self.block)? < 3 {
            return Ok(false);
        }
        let header = u32::from_le_bytes([self.block[0], self.block[1], self.block[2], 0]);
        let rle = (header >> 1) & 3 == 1;
        let content = if rle { 1 } else { u64::from(header >> 3) };
        let read = (&mut self.source)
            .take(content)
            .read_to_end(&mut self.block)?;
        Ok(read as u64 == content)
    }
}

impl<R: Read> Read for ZstdFrames<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let bad = |e: FrameDecoderError| std::io::Error::new(std::io::ErrorKind::InvalidData, e);
        loop {
            if !self.in_frame {
                if self.cut || self.source.fill_buf()?.is_empty() {
                    return Ok(0);
                }
                match self.decoder.reset(&mut self.source) {
                    Ok(()) => self.in_frame = true,
                    Err(FrameDecoderError::ReadFrameHeaderError(
                        ReadFrameHeaderError::SkipFrame { length, .. },
                    )) => {
                        let skipped = std::io::copy(
                            &mut (&mut self.source).take(length.into()),
                            &mut std::io::sink(),
                        )?;
                        self.cut = skipped < length.into();
                    }
                    Err(_) if self.ran_out()? => {}
                    Err(e) => return Err(bad(e)),
                }
                continue;
            }
            while self.decoder.can_collect() == 0 && !self.decoder.is_finished() {
                let strategy = BlockDecodingStrategy::UptoBlocks(1);
                if !self.next_block()? {
                    self.cut = true;
                    self.decoder
                        .decode_blocks(&LAST_EMPTY_BLOCK[..], strategy)
                        .map_err(bad)?;
                    continue;
                }
                let block = (&self.block[..]).chain(&mut self.source);
                match self.decoder.decode_blocks(block, strategy) {
                    Ok(_) => {}
                    // The last block whole and its checksum cut.
                    Err(FrameDecoderError::FailedToReadChecksum(_)) => self.cut = true,
                    Err(e) => return Err(bad(e)),
                }
            }
            let n = self.decoder.read(buf)?;
            if n > 0 || buf.is_empty() {
                return Ok(n);
            }
            if let (false, Some(saved), Some(computed)) = (
                self.cut,
                self.decoder.get_checksum_from_data(),
                self.decoder.get_calculated_checksum(),
            ) && saved != computed
            {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    "zstd frame checksum mismatch",
                ));
            }
            self.in_frame = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_files_sort_by_their_numbers() {
        let mut names = ["bag_10.mcap", "bag_2.mcap", "bag_0.mcap", "bag_1.mcap"];
        names.sort_by_key(|n| natural_key(n));
        assert_eq!(
            names,
            ["bag_0.mcap", "bag_1.mcap", "bag_2.mcap", "bag_10.mcap"]
        );
    }

    /// A zstd frame of `text` in one raw (uncompressed) block.
    fn frame(text: &[u8]) -> Vec<u8> {
        let mut f = vec![0x28, 0xb5, 0x2f, 0xfd, 0x20, text.len() as u8];
        let block_header = ((text.len() as u32) << 3) | 1; // last block, raw
        f.extend_from_slice(&block_header.to_le_bytes()[..3]);
        f.extend_from_slice(text);
        f
    }

    #[test]
    fn a_compressed_message_cut_short_is_kept_with_why_it_does_not_decompress() {
        let keep = |_: &str, _: &str| Keep::Bytes;
        let mut sink = Collector::new(&keep);
        sink.start_file(Path::new("bag.mcap"));
        let topic = sink.topic("/scan", "sensor_msgs/msg/LaserScan", "cdr");
        let whole = frame(b"hello");
        sink.message(topic, 0, &whole);
        sink.message(topic, 1, &whole[..whole.len() - 1]);
        let messages = &sink.contents.messages;
        assert_eq!(messages[0].data.as_deref(), Ok(&b"hello"[..]));
        let err = messages[1].data.as_ref().unwrap_err();
        assert!(err.contains("does not decompress"), "{err}");
    }

    #[test]
    fn zstd_frames_decompress_one_after_another() {
        // Two frames of raw (uncompressed) blocks, a skippable frame between them.
        let mut bytes = frame(b"hello ");
        bytes.extend_from_slice(&[0x50, 0x2a, 0x4d, 0x18, 2, 0, 0, 0, 9, 9]);
        bytes.extend(frame(b"world"));
        let mut out = String::new();
        ZstdFrames::new(&bytes[..])
            .read_to_string(&mut out)
            .unwrap();
        assert_eq!(out, "hello world");
        // Cut inside the second frame: the first frame, and the cut is told.
        let mut cut = ZstdFrames::new(&bytes[..bytes.len() - 2]);
        let mut out = String::new();
        cut.read_to_string(&mut out).unwrap();
        assert_eq!((out.as_str(), cut.cut_short()), ("hello ", true));
        // A reserved block type before the end is corrupt, not a cut.
        let mut corrupt = frame(b"hello ");
        corrupt[6] |= 0b110;
        corrupt.extend(frame(b"world"));
        let mut out = Vec::new();
        assert!(ZstdFrames::new(&corrupt[..]).read_to_end(&mut out).is_err());
    }

    #[test]
    fn a_path_that_is_no_bag_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("rosbag-none-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let err = read(&dir, &|_, _| Keep::Bytes).unwrap_err().to_string();
        assert!(err.contains("not a bag: no metadata.yaml"), "{err}");
        let file = dir.join("notes.mcap");
        std::fs::write(&file, b"hello").unwrap();
        let err = read(&file, &|_, _| Keep::Bytes).unwrap_err().to_string();
        assert!(err.contains("notes.mcap: unknown storage"), "{err}");
        assert!(err.contains("68 65 6c 6c 6f"), "{err}");
        std::fs::remove_dir_all(dir).unwrap();
        assert!(matches!(
            read(Path::new("/no/such/bag"), &|_, _| Keep::Bytes),
            Err(DataError::Missing { .. })
        ));
    }
}
