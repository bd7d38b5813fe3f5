//! The ROS 1 reader on bags built here record by record: the layouts of a bag a
//! recorder closed, cut or left open, and corrupt ones. (`tests/rosbag_written_by_rosbags.rs`
//! reads bags an independent library wrote.)

use super::*;
use crate::rosbag::storage::{Contents, Keep};
use std::io::Write;

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

/// A record's bytes: its header of `fields`, then `data`.
fn record(fields: &[(&str, &[u8])], data: &[u8]) -> Vec<u8> {
    let header = block(fields);
    let mut out = Vec::new();
    out.extend_from_slice(&(header.len() as u32).to_le_bytes());
    out.extend_from_slice(&header);
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// A connection record: id `conn`, `topic` in the header, `published` in its data.
fn connection(conn: u32, topic: &str, published: &str) -> Vec<u8> {
    let data = block(&[
        ("topic", published.as_bytes()),
        ("type", b"std_msgs/String"),
    ]);
    record(
        &[
            ("op", &[OP_CONNECTION]),
            ("conn", &conn.to_le_bytes()),
            ("topic", topic.as_bytes()),
        ],
        &data,
    )
}

/// Message `k` on connection `conn`, at `k` seconds and 5 ns.
fn message(conn: u32, k: u32) -> Vec<u8> {
    let time = [k.to_le_bytes(), 5u32.to_le_bytes()].concat();
    let fields: [(&str, &[u8]); 3] = [
        ("op", &[OP_MESSAGE]),
        ("conn", &conn.to_le_bytes()),
        ("time", &time),
    ];
    record(&fields, &k.to_le_bytes())
}

/// A chunk of `records`, compressed as `compression` says.
fn chunk(compression: &str, records: &[u8]) -> Vec<u8> {
    let data = compress(compression, records);
    record(
        &[
            ("op", &[OP_CHUNK]),
            ("compression", compression.as_bytes()),
            ("size", &(records.len() as u32).to_le_bytes()),
        ],
        &data,
    )
}

/// `bytes` compressed with `compression` (none, bz2 or lz4).
fn compress(compression: &str, bytes: &[u8]) -> Vec<u8> {
    match compression {
        "none" => bytes.to_vec(),
        "bz2" => {
            let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::fast());
            e.write_all(bytes).unwrap();
            e.finish().unwrap()
        }
        _ => {
            let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
            e.write_all(bytes).unwrap();
            e.finish().unwrap()
        }
    }
}

/// A bag: the magic, the bag header with `index_pos`, then `records`.
fn bag(index_pos: u64, records: &[Vec<u8>]) -> Vec<u8> {
    let fields: [(&str, &[u8]); 2] = [
        ("op", &[OP_BAG_HEADER]),
        ("index_pos", &index_pos.to_le_bytes()),
    ];
    let mut out = ROS1_MAGIC.to_vec();
    out.extend(record(&fields, &[b' '; 64]));
    records.iter().for_each(|r| out.extend_from_slice(r));
    out
}

/// A closed bag of two chunks (messages 0–2, then 3–5 on `/chatter`) compressed as
/// `compression`, and its index: a connection and a chunk-information record.
fn closed_bag(compression: &str) -> Vec<u8> {
    let first = [connection(0, "/chatter", "/chatter"), message(0, 0)].concat();
    let first = [first, message(0, 1), message(0, 2)].concat();
    let second = [message(0, 3), message(0, 4), message(0, 5)].concat();
    let chunks = [chunk(compression, &first), chunk(compression, &second)].concat();
    let index = [
        connection(0, "/chatter", "/chatter"),
        record(&[("op", &[0x06])], &[]),
    ];
    let head = bag(0, &[]).len() as u64;
    let mut out = bag(head + chunks.len() as u64, &[chunks]);
    index.iter().for_each(|r| out.extend_from_slice(r));
    out
}

/// What `bytes` read as: the contents, or the error's text.
fn read_bag(bytes: &[u8]) -> std::result::Result<Contents, String> {
    let keep = |_: &str, _: &str| Keep::Bytes;
    let mut sink = Collector::new(&keep);
    sink.start_file(Path::new("t.bag"));
    read(bytes, Path::new("t.bag"), &mut sink).map_err(|e| e.to_string())?;
    Ok(sink.into_contents())
}

/// The payloads (message numbers) of `contents`.
fn numbers(contents: &Contents) -> Vec<u32> {
    (contents.messages.iter())
        .map(|m| u32::from_le_bytes(m.bytes().unwrap().try_into().unwrap()))
        .collect()
}

#[test]
fn a_closed_bag_reads_whole_in_every_compression() {
    for compression in ["none", "bz2", "lz4"] {
        let contents = read_bag(&closed_bag(compression)).unwrap();
        assert_eq!(numbers(&contents), [0, 1, 2, 3, 4, 5], "{compression}");
        assert!(contents.warnings.is_empty(), "{:?}", contents.warnings);
        assert_eq!(contents.topics.len(), 1);
        assert_eq!(contents.topics[0].name, "/chatter");
        assert_eq!(contents.topics[0].type_name, "std_msgs/msg/String");
        assert_eq!(contents.topics[0].encoding, ROS1_ENCODING);
        assert_eq!(contents.messages[4].receive_ns, 4_000_000_005);
    }
}

#[test]
fn the_topic_is_the_one_in_the_bag_not_the_one_published() {
    let records = [connection(0, "/renamed", "/original"), message(0, 7)].concat();
    let contents = read_bag(&bag(0, &[chunk("none", &records)])).unwrap();
    assert_eq!(contents.topics[0].name, "/renamed");
}

#[test]
fn a_bag_cut_between_or_inside_records_keeps_the_chunks_before_with_a_warning() {
    let whole = closed_bag("lz4");
    // Between the two chunks: exactly after the first (its size recomputed).
    let first = [connection(0, "/chatter", "/chatter"), message(0, 0)].concat();
    let first = [first, message(0, 1), message(0, 2)].concat();
    let between = bag(0, &[]).len() + chunk("lz4", &first).len();
    let contents = read_bag(&whole[..between]).unwrap();
    assert_eq!(numbers(&contents), [0, 1, 2]);
    let [warning] = &contents.warnings[..] else {
        panic!("{:?}", contents.warnings);
    };
    assert!(warning.starts_with("t.bag: cut short ("), "{warning}");
    assert!(
        warning.contains("where its index starts at byte"),
        "{warning}"
    );
    // Inside the second chunk.
    let contents = read_bag(&whole[..between + 20]).unwrap();
    assert_eq!(numbers(&contents), [0, 1, 2]);
    assert!(contents.warnings[0].contains("cut short inside a record"));
    // Inside the first: nothing read, refused.
    let err = read_bag(&whole[..between - 3]).unwrap_err();
    assert!(
        err.contains("ROS 1 bag cut short before its first message"),
        "{err}"
    );
    // Anywhere: refused naming the file, or read with a warning (without one only when
    // the cut is in the index, after every message); never a panic.
    for end in 0..whole.len() {
        match read_bag(&whole[..end]) {
            Err(e) => assert!(e.contains("t.bag"), "cut at {end}: {e}"),
            Ok(c) => assert!(
                !c.warnings.is_empty() || numbers(&c).len() == 6,
                "cut at {end} without warning"
            ),
        }
    }
}

#[test]
fn a_recording_left_open_keeps_every_message_up_to_where_it_stopped() {
    // The recorder's open chunk: a placeholder header (size 0, no data), its records
    // after it, compressed or not, cut where the recorder stopped.
    let records = [connection(0, "/chatter", "/chatter"), message(0, 0)].concat();
    let records = [records, message(0, 1), message(0, 2), message(0, 3)].concat();
    for compression in ["none", "bz2", "lz4"] {
        let placeholder = record(
            &[
                ("op", &[OP_CHUNK]),
                ("compression", compression.as_bytes()),
                ("size", &0u32.to_le_bytes()),
            ],
            &[],
        );
        let stream = compress(compression, &records);
        let mut open = bag(0, &[placeholder]);
        open.extend_from_slice(&stream);
        let contents = read_bag(&open).unwrap();
        assert_eq!(numbers(&contents), [0, 1, 2, 3], "{compression}");
        let [warning] = &contents.warnings[..] else {
            panic!("{compression}: {:?}", contents.warnings);
        };
        assert!(warning.contains("did not finish"), "{warning}");
        // Stopped anywhere: the whole messages before (uncompressed: all but the one
        // cut; compressed: those of the whole blocks), or refused naming the file.
        for end in 0..open.len() {
            match read_bag(&open[..end]) {
                Ok(c) => assert!(!c.warnings.is_empty(), "{compression} cut at {end}"),
                Err(e) => assert!(e.contains("t.bag"), "{compression} cut at {end}: {e}"),
            }
        }
        if compression == "none" {
            let kept = numbers(&read_bag(&open[..open.len() - 2]).unwrap());
            assert_eq!(kept, [0, 1, 2]);
        }
    }
}

#[test]
fn corrupt_bags_are_refused_with_their_reason() {
    let refused = |bytes: &[u8], reason: &str| {
        let err = read_bag(bytes).unwrap_err();
        assert!(err.contains("t.bag: corrupt ROS 1 bag: "), "{err}");
        assert!(err.contains(reason), "{err}");
    };
    let conn = connection(0, "/chatter", "/chatter");
    // A chunk holding a bag header, or a chunk.
    let inner = [conn.clone(), bag(0, &[])[ROS1_MAGIC.len()..].to_vec()].concat();
    refused(
        &bag(0, &[chunk("none", &inner)]),
        "a chunk holds a record of op 0x03",
    );
    let nested = chunk("none", &chunk("none", &message(0, 1)));
    refused(&bag(0, &[nested]), "a chunk holds a record of op 0x05");
    // A chunk that decompresses to more than it states, or less.
    let size_at = |r: &[u8]| r.windows(5).position(|w| w == b"size=").unwrap() + 5;
    let mut long = chunk("lz4", &[conn.clone(), message(0, 1)].concat());
    let size = size_at(&long);
    long[size..size + 4].copy_from_slice(&3u32.to_le_bytes());
    refused(
        &bag(0, &[long]),
        "decompresses to over 3 bytes, not the 3 it states",
    );
    let mut short = chunk("none", &[conn.clone(), message(0, 1)].concat());
    let size = size_at(&short);
    short[size..size + 4].copy_from_slice(&4000u32.to_le_bytes());
    refused(&bag(0, &[short]), "decompresses to");
    // A message before its connection; an unknown compression.
    refused(&bag(0, &[chunk("none", &message(3, 1))]), "connection 3");
    refused(
        &bag(0, &[chunk("zstd", &conn)]),
        "`zstd`, which is not none, bz2 or lz4",
    );
    // A whole, closed bag whose record claims more bytes than the file has.
    let mut whole = closed_bag("none");
    let first = bag(0, &[]).len();
    whole[first..first + 4].copy_from_slice(&(1u32 << 30).to_le_bytes());
    refused(&whole, "runs past the end of the file");
}

#[test]
fn an_encrypted_bag_or_another_format_is_refused_in_one_line() {
    let fields: [(&str, &[u8]); 3] = [
        ("op", &[OP_BAG_HEADER]),
        ("index_pos", &0u64.to_le_bytes()),
        ("encryptor", b"rosbag/AesCbcEncryptor"),
    ];
    let encrypted = [ROS1_MAGIC, &record(&fields, &[])].concat();
    let err = read_bag(&encrypted).unwrap_err();
    assert!(err.contains("encrypted (rosbag/AesCbcEncryptor)"), "{err}");
    let err = read_bag(b"#ROSRECORD V1.2\n").unwrap_err();
    assert!(err.contains("not a ROS 1 bag of format 2.0"), "{err}");
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
    assert_eq!(ros2_type_name("tf/tfMessage"), "tf2_msgs/msg/TFMessage");
    assert_eq!(ros2_type_name("Untyped"), "Untyped");
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
