//! The ROS messages the bag reader needs, decoded from their CDR bytes (ROS 2) or their
//! ROS 1 bytes: `sensor_msgs/msg/LaserScan` (and `MultiEchoLaserScan`),
//! `nav_msgs/msg/Odometry` and `tf2_msgs/msg/TFMessage`; `sensor_msgs/msg/PointCloud2`
//! is read through this module's cursor by [`super::cloud`].
//!
//! ROS 2 serialises messages as plain CDR (XCDR1): a 4-byte encapsulation header (`00 01`
//! little-endian, `00 00` big-endian, then two option bytes), then the fields in order,
//! each primitive aligned to its own size counted from the end of that header. A string is
//! a `u32` length that counts its terminating NUL, then the bytes; a sequence is a `u32`
//! count, then the elements; a fixed array (the covariances) has no count. The plain XCDR2
//! encapsulations (`00 06`, `00 07`) differ only in aligning 8-byte values to 4, and are
//! read too.
//!
//! ROS 1 serialises the same fields little-endian with no header and no alignment; its
//! strings count no NUL, its `Header` starts with a `uint32 seq` (skipped here), and its
//! `time` is two `uint32`, seconds and nanoseconds. Its frame ids lose a leading slash
//! (bags recorded before tf2 have `/base_link`), as tf2 reads them.
//!
//! Every read is bounds-checked: a short or inconsistent message is an error saying where
//! it ends, never a panic.

/// What is wrong with a message's bytes.
pub type DecodeResult<T> = std::result::Result<T, String>;

/// How a message's bytes are serialised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Serialization {
    /// ROS 2's CDR, with its encapsulation header (a storage file's `cdr` encoding).
    Cdr,
    /// ROS 1's serialisation (a ROS 1 bag's messages).
    Ros1,
}

/// A cursor over one serialised message (CDR or ROS 1).
pub struct Cdr<'a> {
    /// The bytes after the encapsulation header.
    body: &'a [u8],
    /// Read position in `body`.
    pos: usize,
    /// Little-endian (else big-endian).
    little: bool,
    /// Largest alignment: 8 in XCDR1, 4 in XCDR2, 1 (none) in ROS 1.
    max_align: usize,
    /// ROS 1 (headers start with a sequence number, times are unsigned, frames may
    /// carry tf's leading slash) or CDR.
    serialization: Serialization,
}

impl<'a> Cdr<'a> {
    /// A cursor at the first field of `bytes`, serialised as `serialization` says.
    ///
    /// # Errors
    /// For CDR, when `bytes` is shorter than the header or the encapsulation is not plain
    /// CDR.
    pub fn new(bytes: &'a [u8], serialization: Serialization) -> DecodeResult<Self> {
        if serialization == Serialization::Ros1 {
            return Ok(Self {
                body: bytes,
                pos: 0,
                little: true,
                max_align: 1,
                serialization,
            });
        }
        let Some((header, body)) = bytes.split_first_chunk::<4>() else {
            return Err(format!(
                "{} bytes: shorter than the 4-byte CDR header",
                bytes.len()
            ));
        };
        let (little, max_align) = match (header[0], header[1]) {
            (0, 0) => (false, 8),
            (0, 1) => (true, 8),
            (0, 6) => (false, 4),
            (0, 7) => (true, 4),
            (a, b) => {
                return Err(format!(
                    "encapsulation {a:02x} {b:02x} is not plain CDR (00 00, 00 01, 00 06 or 00 07)"
                ));
            }
        };
        Ok(Self {
            body,
            pos: 0,
            little,
            max_align,
            serialization,
        })
    }

    /// The next `n` bytes.
    fn take(&mut self, n: usize) -> DecodeResult<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.body.len());
        let Some(end) = end else {
            return Err(format!(
                "the message's fields end after {} bytes, {n} more needed at byte {}",
                self.body.len(),
                self.pos
            ));
        };
        let out = &self.body[self.pos..end];
        self.pos = end;
        Ok(out)
    }

    /// Skips the padding before a primitive of `size` bytes.
    fn align(&mut self, size: usize) -> DecodeResult<()> {
        let a = size.min(self.max_align);
        let pad = (a - self.pos % a) % a;
        self.take(pad).map(|_| ())
    }

    /// The next `N`-byte primitive, aligned, in the message's byte order.
    fn primitive<const N: usize>(&mut self) -> DecodeResult<[u8; N]> {
        self.align(N)?;
        let mut raw: [u8; N] = self.take(N)?.try_into().map_err(|_| "short read")?;
        if !self.little {
            raw.reverse();
        }
        Ok(raw)
    }

    /// A `uint32`.
    pub fn u32(&mut self) -> DecodeResult<u32> {
        self.primitive().map(u32::from_le_bytes)
    }

    /// An `int32`.
    pub fn i32(&mut self) -> DecodeResult<i32> {
        self.primitive().map(i32::from_le_bytes)
    }

    /// A `uint8` (or a `bool`, which is one byte).
    pub fn u8(&mut self) -> DecodeResult<u8> {
        self.primitive().map(u8::from_le_bytes)
    }

    /// A `uint8[]` sequence, borrowed from the message.
    pub fn byte_seq(&mut self) -> DecodeResult<&'a [u8]> {
        let n = self.count(1)?;
        self.take(n)
    }

    /// A `float32`.
    pub fn f32(&mut self) -> DecodeResult<f32> {
        self.primitive().map(f32::from_le_bytes)
    }

    /// A `float64`.
    pub fn f64(&mut self) -> DecodeResult<f64> {
        self.primitive().map(f64::from_le_bytes)
    }

    /// `N` consecutive `float64` (a fixed array or a small struct of them).
    pub fn f64s<const N: usize>(&mut self) -> DecodeResult<[f64; N]> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64()?;
        }
        Ok(out)
    }

    /// A sequence's element count, checked against the bytes left (`size` per element).
    fn count(&mut self, size: usize) -> DecodeResult<usize> {
        let n = self.u32()? as usize;
        let left = self.body.len() - self.pos;
        if n.saturating_mul(size) > left {
            return Err(format!(
                "a sequence of {n} elements at byte {} does not fit in the {left} bytes left",
                self.pos
            ));
        }
        Ok(n)
    }

    /// A string (UTF-8, its NUL terminator dropped).
    pub fn string(&mut self) -> DecodeResult<String> {
        let n = self.count(1)?;
        let raw = self.take(n)?;
        let text = raw.strip_suffix(&[0]).unwrap_or(raw);
        String::from_utf8(text.to_vec()).map_err(|_| "a string is not UTF-8".to_string())
    }

    /// A frame id: a string, in ROS 1 without the leading slash frames had before tf2
    /// (`/base_link` is `base_link`, as tf2 reads it).
    pub fn frame(&mut self) -> DecodeResult<String> {
        let frame = self.string()?;
        Ok(match frame.strip_prefix('/') {
            Some(stripped) if self.serialization == Serialization::Ros1 => stripped.to_string(),
            _ => frame,
        })
    }

    /// A `float32[]` sequence.
    pub fn f32_seq(&mut self) -> DecodeResult<Vec<f32>> {
        self.align(4)?;
        let n = self.count(4)?;
        (0..n).map(|_| self.f32()).collect()
    }

    /// Skips a `float32[]` sequence.
    pub fn skip_f32_seq(&mut self) -> DecodeResult<()> {
        let n = self.count(4)?;
        self.take(n * 4).map(|_| ())
    }
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, added to `sec`.
    pub nanosec: u32,
}

impl Time {
    /// The time in nanoseconds; `None` for the zero time (no stamp).
    ///
    /// # Errors
    /// For a negative time.
    pub fn ns(&self) -> DecodeResult<Option<u64>> {
        let total = i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec);
        match u64::try_from(total) {
            Ok(0) => Ok(None),
            Ok(ns) => Ok(Some(ns)),
            Err(_) => Err(format!(
                "stamp {}.{:09} s is negative",
                self.sec, self.nanosec
            )),
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// The stamp.
    pub stamp: Time,
    /// The frame the data is expressed in.
    pub frame_id: String,
}

/// Decodes a `std_msgs/msg/Header` (ROS 1: its sequence number skipped).
pub(crate) fn header(c: &mut Cdr) -> DecodeResult<Header> {
    let sec = if c.serialization == Serialization::Ros1 {
        c.u32()?; // seq
        let sec = c.u32()?;
        i32::try_from(sec).map_err(|_| format!("stamp {sec} s is past 2038"))?
    } else {
        c.i32()?
    };
    let stamp = Time {
        sec,
        nanosec: c.u32()?,
    };
    Ok(Header {
        stamp,
        frame_id: c.frame()?,
    })
}

/// `sensor_msgs/msg/LaserScan`, without its intensities.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LaserScan {
    /// Stamp (first beam) and the laser's frame.
    pub header: Header,
    /// Angle of the first beam (rad).
    pub angle_min: f32,
    /// Angle of the last beam (rad), as the message states it.
    pub angle_max: f32,
    /// Angle between beams (rad); negative for a clockwise scanner.
    pub angle_increment: f32,
    /// Time between beams (s).
    pub time_increment: f32,
    /// Time between scans (s).
    pub scan_time: f32,
    /// Shortest valid range (m).
    pub range_min: f32,
    /// Longest valid range (m).
    pub range_max: f32,
    /// The ranges (m).
    pub ranges: Vec<f32>,
}

/// Decodes a `sensor_msgs/msg/LaserScan`.
///
/// # Errors
/// When the bytes do not hold one (short, bad header, intensities cut off).
pub fn laser_scan(bytes: &[u8], serialization: Serialization) -> DecodeResult<LaserScan> {
    scan_with(bytes, serialization, |c| {
        let ranges = c.f32_seq()?;
        c.skip_f32_seq()?;
        Ok(ranges)
    })
}

/// Decodes a `sensor_msgs/msg/MultiEchoLaserScan` as the [`LaserScan`] of each beam's
/// first echo, the one Cartographer reads too (a beam without an echo reads NaN: no
/// reading, REP-117).
///
/// # Errors
/// When the bytes do not hold one (short, bad header, echoes or intensities cut off).
pub fn multi_echo_laser_scan(
    bytes: &[u8],
    serialization: Serialization,
) -> DecodeResult<LaserScan> {
    scan_with(bytes, serialization, |c| {
        let beams = c.count(4)?;
        let ranges = (0..beams)
            .map(|_| Ok(c.f32_seq()?.first().copied().unwrap_or(f32::NAN)))
            .collect::<DecodeResult<Vec<f32>>>()?;
        let intensities = c.count(4)?;
        for _ in 0..intensities {
            c.skip_f32_seq()?;
        }
        Ok(ranges)
    })
}

/// `scan`'s bytes in `serialization` (little-endian CDR for ROS 2), without intensities:
/// what [`laser_scan`] reads back.
pub fn encode_laser_scan(scan: &LaserScan, serialization: Serialization) -> Vec<u8> {
    let ros1 = serialization == Serialization::Ros1;
    // CDR counts alignment from after its 4-byte encapsulation header.
    let mut out: Vec<u8> = if ros1 { Vec::new() } else { vec![0, 1, 0, 0] };
    let start = out.len();
    let align = |out: &mut Vec<u8>| {
        while !ros1 && !(out.len() - start).is_multiple_of(4) {
            out.push(0);
        }
    };
    let stamp = scan.header.stamp;
    if ros1 {
        out.extend(0u32.to_le_bytes()); // seq
    }
    out.extend(stamp.sec.to_le_bytes());
    out.extend(stamp.nanosec.to_le_bytes());
    let frame = scan.header.frame_id.as_bytes();
    let terminator = usize::from(!ros1);
    out.extend(((frame.len() + terminator) as u32).to_le_bytes());
    out.extend(frame);
    out.extend(std::iter::repeat_n(0, terminator));
    align(&mut out);
    for v in [
        scan.angle_min,
        scan.angle_max,
        scan.angle_increment,
        scan.time_increment,
        scan.scan_time,
        scan.range_min,
        scan.range_max,
    ] {
        out.extend(v.to_le_bytes());
    }
    out.extend((scan.ranges.len() as u32).to_le_bytes());
    scan.ranges.iter().for_each(|r| out.extend(r.to_le_bytes()));
    out.extend(0u32.to_le_bytes()); // no intensities
    out
}

/// A scan message: the header and the seven numbers both scan types begin with, then
/// the ranges as `ranges` reads them.
fn scan_with(
    bytes: &[u8],
    serialization: Serialization,
    ranges: impl FnOnce(&mut Cdr) -> DecodeResult<Vec<f32>>,
) -> DecodeResult<LaserScan> {
    let mut c = Cdr::new(bytes, serialization)?;
    let header = header(&mut c)?;
    let mut f = [0f32; 7];
    for v in &mut f {
        *v = c.f32()?;
    }
    let [
        angle_min,
        angle_max,
        angle_increment,
        time_increment,
        scan_time,
        range_min,
        range_max,
    ] = f;
    let ranges = ranges(&mut c)?;
    Ok(LaserScan {
        header,
        angle_min,
        angle_max,
        angle_increment,
        time_increment,
        scan_time,
        range_min,
        range_max,
        ranges,
    })
}

/// `nav_msgs/msg/Odometry`, without its covariances.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Odometry {
    /// Stamp and the odometry frame (`odom`).
    pub header: Header,
    /// The frame whose pose this is (`base_link`…).
    pub child_frame_id: String,
    /// Position (m) in the odometry frame.
    pub position: [f64; 3],
    /// Orientation quaternion `[x, y, z, w]` in the odometry frame.
    pub orientation: [f64; 4],
    /// Linear velocity (m/s) in the child frame.
    pub linear: [f64; 3],
    /// Angular velocity (rad/s) in the child frame.
    pub angular: [f64; 3],
}

/// Decodes a `nav_msgs/msg/Odometry`.
///
/// # Errors
/// When the bytes do not hold one.
pub fn odometry(bytes: &[u8], serialization: Serialization) -> DecodeResult<Odometry> {
    let mut c = Cdr::new(bytes, serialization)?;
    let header = header(&mut c)?;
    let child_frame_id = c.frame()?;
    let position = c.f64s::<3>()?;
    let orientation = c.f64s::<4>()?;
    c.f64s::<36>()?;
    let linear = c.f64s::<3>()?;
    let angular = c.f64s::<3>()?;
    c.f64s::<36>()?;
    Ok(Odometry {
        header,
        child_frame_id,
        position,
        orientation,
        linear,
        angular,
    })
}

/// One `geometry_msgs/msg/TransformStamped`: the child frame's pose in the parent frame
/// (`header.frame_id`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TransformStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Translation (m).
    pub translation: [f64; 3],
    /// Rotation quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

/// Decodes a `tf2_msgs/msg/TFMessage` into its transforms.
///
/// # Errors
/// When the bytes do not hold one.
pub fn tf_message(
    bytes: &[u8],
    serialization: Serialization,
) -> DecodeResult<Vec<TransformStamped>> {
    let mut c = Cdr::new(bytes, serialization)?;
    // A transform takes at least 8 (stamp) + 2 × 4 (empty strings) + 7 × 8 bytes.
    let n = c.count(72)?;
    (0..n)
        .map(|_| {
            Ok(TransformStamped {
                header: header(&mut c)?,
                child_frame_id: c.frame()?,
                translation: c.f64s::<3>()?,
                rotation: c.f64s::<4>()?,
            })
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A CDR writer for building test messages by hand, in either byte order.
    pub(crate) struct Writer {
        pub(crate) bytes: Vec<u8>,
        little: bool,
    }

    impl Writer {
        pub(crate) fn new(little: bool) -> Self {
            Self {
                bytes: vec![0, u8::from(little), 0, 0],
                little,
            }
        }
        fn put<const N: usize>(&mut self, le: [u8; N]) -> &mut Self {
            while !(self.bytes.len() - 4).is_multiple_of(N) {
                self.bytes.push(0);
            }
            let mut raw = le;
            if !self.little {
                raw.reverse();
            }
            self.bytes.extend_from_slice(&raw);
            self
        }
        pub(crate) fn u8(&mut self, v: u8) -> &mut Self {
            self.put([v])
        }
        pub(crate) fn u32(&mut self, v: u32) -> &mut Self {
            self.put(v.to_le_bytes())
        }
        pub(crate) fn i32(&mut self, v: i32) -> &mut Self {
            self.put(v.to_le_bytes())
        }
        pub(crate) fn f32(&mut self, v: f32) -> &mut Self {
            self.put(v.to_le_bytes())
        }
        pub(crate) fn f64(&mut self, v: f64) -> &mut Self {
            self.put(v.to_le_bytes())
        }
        pub(crate) fn string(&mut self, s: &str) -> &mut Self {
            self.u32(s.len() as u32 + 1);
            self.bytes.extend_from_slice(s.as_bytes());
            self.bytes.push(0);
            self
        }
        pub(crate) fn header(&mut self, sec: i32, nanosec: u32, frame: &str) -> &mut Self {
            self.i32(sec).u32(nanosec).string(frame)
        }
    }

    /// A LaserScan message's bytes.
    pub(crate) fn scan_bytes(
        little: bool,
        frame: &str,
        fields: [f32; 7],
        ranges: &[f32],
    ) -> Vec<u8> {
        let mut w = Writer::new(little);
        w.header(12, 500, frame);
        for v in fields {
            w.f32(v);
        }
        w.u32(ranges.len() as u32);
        for &r in ranges {
            w.f32(r);
        }
        w.u32(2).f32(7.0).f32(8.0);
        w.bytes
    }

    #[test]
    fn a_laser_scan_decodes_in_both_byte_orders() {
        let fields = [-1.5, 1.5, 0.5, 0.001, 0.1, 0.2, 30.0];
        for little in [true, false] {
            let bytes = scan_bytes(little, "laser", fields, &[1.0, f32::INFINITY, 3.0]);
            let scan = laser_scan(&bytes, Serialization::Cdr).unwrap();
            assert_eq!(scan.header.frame_id, "laser");
            assert_eq!(
                scan.header.stamp,
                Time {
                    sec: 12,
                    nanosec: 500
                }
            );
            assert_eq!(scan.angle_min, -1.5);
            assert_eq!(scan.angle_increment, 0.5);
            assert_eq!(scan.range_max, 30.0);
            assert_eq!(scan.ranges, [1.0, f32::INFINITY, 3.0]);
        }
    }

    #[test]
    fn an_encoded_scan_reads_back_in_both_serialisations() {
        let scan = LaserScan {
            header: Header {
                stamp: Time { sec: 7, nanosec: 9 },
                frame_id: "lidar".into(),
            },
            angle_min: -1.0,
            angle_max: 1.0,
            angle_increment: 1.0,
            range_min: 0.2,
            range_max: 30.0,
            ranges: vec![1.0, f32::NAN, 2.0],
            ..LaserScan::default()
        };
        for serialization in [Serialization::Cdr, Serialization::Ros1] {
            let back = laser_scan(&encode_laser_scan(&scan, serialization), serialization);
            assert_eq!(
                format!("{back:?}"),
                format!("{:?}", Ok::<_, String>(scan.clone()))
            );
        }
    }

    #[test]
    fn a_multi_echo_scan_reads_each_beam_s_first_echo() {
        let fields = [-1.5, 1.5, 1.5, 0.0, 0.1, 0.2, 30.0];
        for little in [true, false] {
            let mut w = Writer::new(little);
            w.header(12, 500, "horizontal_laser_link");
            for v in fields {
                w.f32(v);
            }
            // Three beams: two echoes, none, one; then intensities for the first beam only.
            w.u32(3).u32(2).f32(1.0).f32(2.5).u32(0).u32(1).f32(3.0);
            w.u32(1).u32(2).f32(7.0).f32(8.0);
            let scan = multi_echo_laser_scan(&w.bytes, Serialization::Cdr).unwrap();
            assert_eq!(scan.header.frame_id, "horizontal_laser_link");
            assert_eq!((scan.angle_min, scan.angle_increment), (-1.5, 1.5));
            assert_eq!(scan.ranges.len(), 3);
            assert_eq!((scan.ranges[0], scan.ranges[2]), (1.0, 3.0));
            assert!(scan.ranges[1].is_nan());
            let cut = &w.bytes[..w.bytes.len() - 4];
            assert!(multi_echo_laser_scan(cut, Serialization::Cdr).is_err());
        }
    }

    #[test]
    fn an_odometry_decodes_with_its_eight_byte_alignment() {
        for little in [true, false] {
            let mut w = Writer::new(little);
            // A 3-character frame leaves the string ending off an 8-byte boundary.
            w.header(1, 2, "odo").string("base_footprint");
            for v in [1.0, 2.0, 3.0, 0.0, 0.0, 0.6, 0.8] {
                w.f64(v);
            }
            for _ in 0..36 {
                w.f64(9.0);
            }
            for v in [0.5, 0.0, 0.0, 0.0, 0.0, 0.25] {
                w.f64(v);
            }
            for _ in 0..36 {
                w.f64(9.0);
            }
            let odo = odometry(&w.bytes, Serialization::Cdr).unwrap();
            assert_eq!(odo.header.frame_id, "odo");
            assert_eq!(odo.child_frame_id, "base_footprint");
            assert_eq!(odo.position, [1.0, 2.0, 3.0]);
            assert_eq!(odo.orientation, [0.0, 0.0, 0.6, 0.8]);
            assert_eq!((odo.linear[0], odo.angular[2]), (0.5, 0.25));
        }
    }

    #[test]
    fn a_tf_message_decodes_every_transform() {
        let mut w = Writer::new(true);
        w.u32(2);
        for (child, x) in [("base_footprint", 1.5), ("base_link", 0.0)] {
            w.header(5, 0, "odom").string(child);
            for v in [x, 0.0, 0.1, 0.0, 0.0, 0.0, 1.0] {
                w.f64(v);
            }
        }
        let tf = tf_message(&w.bytes, Serialization::Cdr).unwrap();
        assert_eq!(tf.len(), 2);
        assert_eq!(tf[0].child_frame_id, "base_footprint");
        assert_eq!(tf[0].translation, [1.5, 0.0, 0.1]);
        assert_eq!(tf[1].header.frame_id, "odom");
        assert_eq!(tf[1].rotation, [0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn short_or_foreign_bytes_are_errors_not_panics() {
        let bytes = scan_bytes(
            true,
            "laser",
            [0.0, 1.0, 0.5, 0.0, 0.0, 0.1, 10.0],
            &[1.0; 3],
        );
        for cut in 0..bytes.len() {
            assert!(
                laser_scan(&bytes[..cut], Serialization::Cdr).is_err(),
                "cut at {cut}"
            );
        }
        assert!(odometry(&bytes, Serialization::Cdr).is_err());
        let err = laser_scan(&[1, 0, 0, 0, 0], Serialization::Cdr).unwrap_err();
        assert!(err.contains("not plain CDR"), "{err}");
        // A sequence count far beyond the message.
        let mut w = Writer::new(true);
        w.u32(u32::MAX);
        assert!(
            tf_message(&w.bytes, Serialization::Cdr)
                .unwrap_err()
                .contains("does not fit")
        );
        let negative = Time {
            sec: -1,
            nanosec: 0,
        };
        assert!(negative.ns().is_err());
        assert_eq!(Time::default().ns(), Ok(None));
    }

    #[test]
    fn ros1_bytes_have_no_header_no_alignment_a_sequence_number_and_bare_frames() {
        // A TFMessage of one transform, ROS 1: seq, stamp (u32, u32), frame ids without
        // NUL, the leading slash of tf's days.
        let mut b = Vec::new();
        let string = |b: &mut Vec<u8>, s: &str| {
            b.extend_from_slice(&(s.len() as u32).to_le_bytes());
            b.extend_from_slice(s.as_bytes());
        };
        b.extend_from_slice(&1u32.to_le_bytes());
        b.extend_from_slice(&7u32.to_le_bytes()); // seq
        b.extend_from_slice(&12u32.to_le_bytes());
        b.extend_from_slice(&500u32.to_le_bytes());
        string(&mut b, "/odom");
        string(&mut b, "/base_link");
        for v in [1.0f64, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let tf = tf_message(&b, Serialization::Ros1).unwrap();
        assert_eq!(tf.len(), 1);
        assert_eq!(
            tf[0].header.stamp,
            Time {
                sec: 12,
                nanosec: 500
            }
        );
        assert_eq!(tf[0].header.frame_id, "odom");
        assert_eq!(tf[0].child_frame_id, "base_link");
        assert_eq!(tf[0].translation, [1.0, 2.0, 0.0]);
        assert_eq!(tf[0].rotation, [0.0, 0.0, 0.0, 1.0]);
        // Cut anywhere: an error, never a panic.
        for cut in 0..b.len() {
            assert!(
                tf_message(&b[..cut], Serialization::Ros1).is_err(),
                "cut at {cut}"
            );
        }
        // A ROS 2 frame keeps what it says.
        let mut w = Writer::new(true);
        w.u32(1).header(12, 500, "/odom").string("/base_link");
        for v in [1.0f64, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            w.f64(v);
        }
        let tf = tf_message(&w.bytes, Serialization::Cdr).unwrap();
        assert_eq!(tf[0].header.frame_id, "/odom");
    }
}
