//! A 3D lidar's `sensor_msgs/msg/PointCloud2` as a 2D scan, much as ROS's
//! `pointcloud_to_laserscan` makes one: the points within [`BAND_M`] of the sensor's
//! horizontal plane (`|z|` in the cloud's frame), binned by bearing into [`BEAMS`] beams
//! over the full turn (each beam's angle the middle of its bin), the nearest point per
//! beam. A beam no point falls in reads NaN, where `pointcloud_to_laserscan` would say
//! +∞ (no reading: a sparse ring leaves gaps that are not free space); points nearer than
//! [`RANGE_MIN_M`] (the robot itself) are dropped. The cloud's `x`, `y` and `z` fields
//! are read whatever else it holds (float32 or float64, either byte order); a point
//! with a non-finite coordinate is skipped.
//!
//! The band is taken in the cloud's own frame, so the sensor is taken to be mounted level
//! (the bag reader warns about a tilted mounting).

use super::cdr::{self, Cdr, DecodeResult, LaserScan, Serialization};

/// Half the height of the band of points kept (m): a 16-ring lidar's rings at ±1° stay
/// in it out to 11 m, the floor under a sensor 0.3 m up stays out of it.
pub const BAND_M: f64 = 0.2;
/// Beams over the full turn (0.5° apart).
pub const BEAMS: usize = 720;
/// Points nearer than this are dropped (m).
pub const RANGE_MIN_M: f32 = 0.2;
/// The scan's `range_max` (m): every point of the band is a return.
pub const RANGE_MAX_M: f32 = 1000.0;

/// `PointField` datatype of a `float32`.
const FLOAT32: u8 = 7;
/// `PointField` datatype of a `float64`.
const FLOAT64: u8 = 8;

/// One coordinate's place in a point: byte offset and whether it is a `float64`.
#[derive(Debug, Clone, Copy)]
struct Field {
    offset: usize,
    wide: bool,
}

impl Field {
    /// Its size in bytes.
    fn size(self) -> usize {
        if self.wide { 8 } else { 4 }
    }
}

/// Decodes a `sensor_msgs/msg/PointCloud2` and cuts it to a scan (see the module doc).
///
/// # Errors
/// When the bytes do not hold one, it lacks a float `x`, `y` or `z` field, or its data is
/// shorter than its points.
pub fn cloud_scan(bytes: &[u8], serialization: Serialization) -> DecodeResult<LaserScan> {
    let mut c = Cdr::new(bytes, serialization)?;
    let header = cdr::header(&mut c)?;
    let height = c.u32()? as usize;
    let width = c.u32()? as usize;
    let fields = c.u32()?;
    let (mut x, mut y, mut z) = (None, None, None);
    for _ in 0..fields {
        let name = c.string()?;
        let offset = c.u32()? as usize;
        let datatype = c.u8()?;
        c.u32()?; // count: 1 for a coordinate
        let field = match datatype {
            FLOAT32 => Some(Field {
                offset,
                wide: false,
            }),
            FLOAT64 => Some(Field { offset, wide: true }),
            _ => None,
        };
        match name.as_str() {
            "x" => x = field,
            "y" => y = field,
            "z" => z = field,
            _ => {}
        }
    }
    let (Some(x), Some(y), Some(z)) = (x, y, z) else {
        return Err("the cloud has no float32 or float64 x, y and z fields".into());
    };
    let big_endian = c.u8()? != 0;
    let point_step = c.u32()? as usize;
    let row_step = c.u32()? as usize;
    let data = c.byte_seq()?;
    let increment = std::f64::consts::TAU / BEAMS as f64;
    let mut ranges = vec![f32::NAN; BEAMS];
    if !fits(height, width, point_step, row_step, data.len()) {
        return Err(format!(
            "the cloud's {height} rows of {width} points, {point_step} bytes each, do not fit \
             rows of {row_step} bytes in its {} bytes of data",
            data.len()
        ));
    }
    let outside = [x, y, z]
        .into_iter()
        .find(|f| f.offset + f.size() > point_step);
    if let Some(f) = outside.filter(|_| width > 0 && height > 0) {
        return Err(format!(
            "a coordinate at byte {} of a point lies past its {point_step} bytes",
            f.offset
        ));
    }
    let rows = if width == 0 { 0 } else { height };
    for row in 0..rows {
        for column in 0..width {
            let start = row * row_step + column * point_step;
            let read = |f: Field| coordinate(data, start + f.offset, f.size(), big_endian);
            let (px, py, pz) = (read(x)?, read(y)?, read(z)?);
            if !(px.is_finite() && py.is_finite() && pz.is_finite()) || pz.abs() > BAND_M {
                continue;
            }
            let range = px.hypot(py) as f32;
            if range < RANGE_MIN_M {
                continue;
            }
            let bearing = py.atan2(px) + std::f64::consts::PI;
            let beam = ((bearing / increment) as usize).min(BEAMS - 1);
            if ranges[beam].is_nan() || range < ranges[beam] {
                ranges[beam] = range;
            }
        }
    }
    let angle_min = -std::f64::consts::PI + 0.5 * increment;
    Ok(LaserScan {
        header,
        angle_min: angle_min as f32,
        angle_max: (angle_min + (BEAMS - 1) as f64 * increment) as f32,
        angle_increment: increment as f32,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: RANGE_MIN_M,
        range_max: RANGE_MAX_M,
        ranges,
    })
}

/// The cloud's bytes cut to the bytes of its scan ([`cloud_scan`], encoded by
/// [`cdr::encode_laser_scan`] in the same serialisation): how the bag reader keeps a
/// cloud topic, so that a long 3D-lidar recording is never held whole.
///
/// # Errors
/// As [`cloud_scan`].
pub fn cut(bytes: &[u8], serialization: Serialization) -> DecodeResult<Vec<u8>> {
    let scan = cloud_scan(bytes, serialization)?;
    Ok(cdr::encode_laser_scan(&scan, serialization))
}

/// Whether `height` rows of `width` points of `point_step` bytes, rows `row_step` bytes
/// apart, lie within `data_len` bytes (so that the points, each read once, are bounded
/// by the message's size).
fn fits(height: usize, width: usize, point_step: usize, row_step: usize, data_len: usize) -> bool {
    if height == 0 || width == 0 {
        return true;
    }
    let row = width.checked_mul(point_step);
    let last_row = (height - 1).checked_mul(row_step);
    let end = row
        .zip(last_row)
        .and_then(|(row, last)| last.checked_add(row));
    point_step > 0
        && row.is_some_and(|row| height == 1 || row <= row_step)
        && end.is_some_and(|end| end <= data_len)
}

/// The float of `size` bytes (4 or 8) at byte `at` of `data`.
fn coordinate(data: &[u8], at: usize, size: usize, big_endian: bool) -> DecodeResult<f64> {
    let Some(raw) = data.get(at..at + size) else {
        return Err(format!(
            "the cloud's data ends after {} bytes, a point's coordinate is at byte {at}",
            data.len()
        ));
    };
    let mut buffer = [0u8; 8];
    buffer[..size].copy_from_slice(raw);
    if big_endian {
        buffer[..size].reverse();
    }
    let [a, b, c, d, ..] = buffer;
    Ok(if size == 8 {
        f64::from_le_bytes(buffer)
    } else {
        f64::from(f32::from_le_bytes([a, b, c, d]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rosbag::cdr::tests::Writer;

    /// How a test cloud is written: the message's serialisation and byte order (CDR), the
    /// points' byte order and whether their coordinates are `float64`.
    #[derive(Debug, Clone, Copy)]
    struct Layout {
        ros1: bool,
        little_message: bool,
        big_data: bool,
        wide: bool,
    }

    /// A cloud of `points` (x, y, z) laid out as `layout` says, each point x, an
    /// intensity, y, z.
    fn cloud_bytes(layout: Layout, points: &[[f64; 3]]) -> Vec<u8> {
        let size = if layout.wide { 8 } else { 4 };
        let datatype = if layout.wide { FLOAT64 } else { FLOAT32 };
        let point_step = 4 * size;
        let mut data = Vec::new();
        for p in points {
            for v in [p[0], 9.0, p[1], p[2]] {
                let mut raw = match layout.wide {
                    true => v.to_le_bytes().to_vec(),
                    false => (v as f32).to_le_bytes().to_vec(),
                };
                if layout.big_data {
                    raw.reverse();
                }
                data.extend(raw);
            }
        }
        let fields = ["x", "intensity", "y", "z"];
        let n = points.len() as u32;
        if layout.ros1 {
            // No encapsulation, no alignment, a sequence number, strings without NUL.
            let mut out = Vec::new();
            let string = |out: &mut Vec<u8>, s: &str| {
                out.extend((s.len() as u32).to_le_bytes());
                out.extend(s.as_bytes());
            };
            [0u32, 3, 0]
                .iter()
                .for_each(|v| out.extend(v.to_le_bytes()));
            string(&mut out, "velodyne");
            [1, n, 4].iter().for_each(|v| out.extend(v.to_le_bytes()));
            for (k, name) in fields.iter().enumerate() {
                string(&mut out, name);
                out.extend((k as u32 * size).to_le_bytes());
                out.push(datatype);
                out.extend(1u32.to_le_bytes());
            }
            out.push(u8::from(layout.big_data));
            [point_step, point_step * n, data.len() as u32]
                .iter()
                .for_each(|v| out.extend(v.to_le_bytes()));
            out.extend(data);
            out.push(1);
            return out;
        }
        let mut w = Writer::new(layout.little_message);
        w.header(3, 0, "velodyne").u32(1).u32(n).u32(4);
        for (k, name) in fields.iter().enumerate() {
            w.string(name).u32(k as u32 * size).u8(datatype).u32(1);
        }
        w.u8(u8::from(layout.big_data))
            .u32(point_step)
            .u32(point_step * n);
        w.u32(data.len() as u32);
        w.bytes.extend(data);
        w.u8(1);
        w.bytes
    }

    /// A point at `range` in the middle of beam `beam`, `z` above the sensor's plane.
    fn on_beam(beam: usize, range: f64, z: f64) -> [f64; 3] {
        let bearing = -std::f64::consts::PI + (beam as f64 + 0.5) * std::f64::consts::TAU / 720.0;
        [range * bearing.cos(), range * bearing.sin(), z]
    }

    #[test]
    fn a_cloud_keeps_the_nearest_point_of_the_band_per_beam() {
        let points = [
            on_beam(360, 2.0, 0.0),   // just left of straight ahead
            on_beam(360, 3.0, 0.1),   // behind it, in the band
            on_beam(360, 1.0, 0.5),   // nearer, above the band
            on_beam(360, 1.0, -0.3),  // nearer, below the band (the floor)
            on_beam(180, 4.0, -0.15), // to the right
            on_beam(719, 5.0, 0.0),   // behind the sensor
            on_beam(360, 0.1, 0.0),   // the robot itself
            [f64::NAN, 1.0, 0.0],     // no point
        ];
        for ros1 in [false, true] {
            for little_message in [true, false] {
                for big_data in [false, true] {
                    for wide in [false, true] {
                        let layout = Layout {
                            ros1,
                            little_message,
                            big_data,
                            wide,
                        };
                        let serialization = match ros1 {
                            true => Serialization::Ros1,
                            false => Serialization::Cdr,
                        };
                        let bytes = cloud_bytes(layout, &points);
                        let scan = cloud_scan(&bytes, serialization).unwrap();
                        assert_eq!(scan.header.frame_id, "velodyne");
                        assert_eq!(scan.ranges.len(), BEAMS);
                        let angle = |k: usize| {
                            f64::from(scan.angle_min) + k as f64 * f64::from(scan.angle_increment)
                        };
                        assert!((angle(360) - 0.25f64.to_radians()).abs() < 1e-6);
                        let r = |k: usize| f64::from(scan.ranges[k]);
                        assert!((r(360) - 2.0).abs() < 1e-6, "{layout:?}: {}", r(360));
                        assert!((r(180) - 4.0).abs() < 1e-6, "{layout:?}: {}", r(180));
                        assert!((r(719) - 5.0).abs() < 1e-6, "{layout:?}: {}", r(719));
                        let returns = scan.ranges.iter().filter(|r| !r.is_nan()).count();
                        assert_eq!(returns, 3, "{layout:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn malformed_clouds_are_errors() {
        let layout = Layout {
            ros1: false,
            little_message: true,
            big_data: false,
            wide: false,
        };
        let bytes = cloud_bytes(layout, &[[1.0, 0.0, 0.0]]);
        let cut = &bytes[..bytes.len() - 6];
        assert!(cloud_scan(cut, Serialization::Cdr).is_err());
        let mut w = Writer::new(true);
        w.header(3, 0, "velodyne").u32(1).u32(1).u32(1);
        w.string("x").u32(0).u8(FLOAT32).u32(1);
        w.u8(0).u32(4).u32(4).u32(4).f32(1.0).u8(1);
        let err = cloud_scan(&w.bytes, Serialization::Cdr).unwrap_err();
        assert!(err.contains("x, y and z"), "{err}");
        // Points that claim no bytes (or more than the data holds) are refused, not read
        // over and over; so is a coordinate past its point.
        let cloud = |points: u32, point_step: u32, z_offset: u32| {
            let mut w = Writer::new(true);
            w.header(3, 0, "velodyne").u32(points).u32(points).u32(3);
            for (name, offset) in [("x", 0), ("y", 4), ("z", z_offset)] {
                w.string(name).u32(offset).u8(FLOAT32).u32(1);
            }
            w.u8(0)
                .u32(point_step)
                .u32(0)
                .u32(12)
                .f32(1.0)
                .f32(0.0)
                .f32(0.0)
                .u8(1);
            cloud_scan(&w.bytes, Serialization::Cdr).unwrap_err()
        };
        assert!(cloud(u32::MAX, 0, 8).contains("do not fit"));
        assert!(cloud(1, 12, 10).contains("past its 12 bytes"));
        assert!(!fits(1, 2, 12, 24, 23) && fits(1, 2, 12, 24, 24) && !fits(2, 2, 12, 12, 48));
    }
}
