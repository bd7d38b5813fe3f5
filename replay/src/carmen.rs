//! CARMEN logs (`.clf`, `.log`; plain or gzipped, told apart by the gzip magic bytes): the
//! format of the Freiburg 2D-lidar SLAM benchmark (Kümmerle et al., Autonomous Robots
//! 2009), read into a [`DataSet`] of raw scans and odometry poses.
//!
//! How the lines map onto the stack's messages (one message per line, fields separated by
//! white space, `#` lines are comments, blank lines are ignored):
//! - `FLASER n r1…rn x y θ odom_x odom_y odom_θ ipc_timestamp hostname logger_timestamp`:
//!   a scan of `n` ranges spread evenly from −90° to +90° (`angle_min` −π/2, increment
//!   π/(n−1)); the odometry pose (`odom_x odom_y odom_θ`) is the robot's pose at the scan
//!   and `x y θ` the laser's, so the laser's mount is `odom⁻¹ ⊕ laser`. When that mount
//!   varies over a log of FLASER lines beyond [`MOUNT_TOLERANCE_M`] or
//!   [`MOUNT_TOLERANCE_RAD`], the laser poses are another trajectory (a corrected one,
//!   say), not a mount: the laser is taken at the robot's origin and the log's
//!   [`CarmenLog::warnings`] say so.
//! - `ROBOTLASER1 laser_type start_angle fov angular_res max_range accuracy remission_mode
//!   n r1…rn m rem1…remm laser_x laser_y laser_θ robot_x robot_y robot_θ tv rv
//!   forward_safety side_safety turn_axis ipc_timestamp hostname logger_timestamp`: beam `i`
//!   points at `start_angle + i·angular_res`; the laser's mount is `robot⁻¹ ⊕ laser`, which
//!   must stay within [`MOUNT_TOLERANCE_M`] and [`MOUNT_TOLERANCE_RAD`] of the first laser
//!   line's over the whole log (else the log is refused).
//! - `ODOM x y θ tv rv accel ipc_timestamp hostname logger_timestamp`: an odometry pose.
//! - Every other message type (`PARAM`, `SYNC`, `RAWLASER1`, `TRUEPOS`, …) is counted by
//!   name and skipped.
//!
//! **Lines that cannot be read** — a first field that is not an upper-case message name,
//! missing or extra fields, a field that is not a number, a non-finite pose or time, a
//! beam count that does not match — are skipped and counted, and the log's
//! [`CarmenLog::warnings`] give how many and the first few with file, line and reason: one
//! corrupt line does not cost the whole recording. A file that ends early (a gzip stream
//! cut short, a read error after the first line) keeps the lines before, with a warning.
//! A log in which no laser line can be read is refused, with the first reasons.
//!
//! **Time** is `ipc_timestamp` (s on the log's clock, Unix time in most logs); stamp 0 is
//! the earliest time of a laser or odometry line ([`DataSet::epoch_s`]).
//!
//! **Odometry as poses.** Every laser line's robot pose becomes one [`Odometry`] message
//! carrying the raw odometry pose as recorded (not re-integrated), `v` = tv and `omega` =
//! rv where the line has them (0 for FLASER), `steering` 0, as GMapping reads these logs.
//! `ODOM` lines are read and counted but not published: the laser lines' poses are copies
//! of them stamped at the scan (0.1–1 s apart in the Freiburg logs), so both together
//! would step the pose back and forth.
//!
//! **Strictly increasing stamps** within each stream. Records are sorted by time, keeping
//! file order among equal times. A record whose stamp is not later than the previous kept
//! one is dropped when it repeats it (the same pose; for a scan, the same beams), and is
//! otherwise moved to 1 ns after it. Both are counted ([`StampRepairs`]).
//!
//! **No return.** FLASER lines do not carry the laser's maximum range, so it is taken as
//! the largest reading of all FLASER lines of the log (these logs write a fixed value for
//! "no return": 81.83 or 81.91 m, 50 m on ACES). For ROBOTLASER1 it is the line's
//! `max_range`. A reading from that maximum minus [`NO_RETURN_MARGIN_M`] on becomes `+∞`
//! (REP-117 no return) and the header's `range_max` is the maximum minus the margin; a
//! reading ≤ 0 or not finite becomes NaN (invalid). A log whose longest FLASER reading is
//! a real echo loses that one reading to "no return".

use crate::dataset::{Clock, DataSet, RawScan};
use crate::text::{self, DataError, Result, Skipped};
use fastslam_estimation::{Pose2, wrap_angle};
use fastslam_protocol::validate::MAX_SCAN_BEAMS;
use fastslam_protocol::{Header, LaserScanHeader, Odometry};
use flate2::read::MultiGzDecoder;
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

/// Readings this close to the laser's maximum range (or beyond) are "no return" (m).
pub const NO_RETURN_MARGIN_M: f64 = 0.01;
/// Largest change of the laser's mount position over a log (m).
pub const MOUNT_TOLERANCE_M: f64 = 1e-3;
/// Largest change of the laser's mount heading over a log (rad): 0.1°.
pub const MOUNT_TOLERANCE_RAD: f64 = 0.1 * PI / 180.0;

/// How many records of a stream had their stamp repaired to keep stamps strictly
/// increasing (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StampRepairs {
    /// Records moved to 1 ns after the previous one.
    pub nudged: usize,
    /// Records dropped as repeats of the previous one.
    pub dropped: usize,
}

/// What the log held, line by line.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MessageCounts {
    /// `FLASER` lines.
    pub flaser: usize,
    /// `ROBOTLASER1` lines.
    pub robotlaser1: usize,
    /// `ODOM` lines.
    pub odom: usize,
    /// Lines of every other message type, by type name.
    pub skipped: BTreeMap<String, usize>,
    /// Lines that could not be read (module doc), skipped.
    pub malformed: usize,
}

/// A CARMEN log read into messages, with what was read, skipped and repaired.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenLog {
    /// The file read.
    pub path: PathBuf,
    /// The messages: raw scans and odometry poses; no truth, landmarks or observations.
    pub data: DataSet,
    /// The lines read, by type.
    pub messages: MessageCounts,
    /// Stamp repairs in the odometry stream.
    pub odometry_repairs: StampRepairs,
    /// Stamp repairs in the scan stream.
    pub scan_repairs: StampRepairs,
    /// The FLASER lines' maximum range, their largest reading (m); `None` without FLASER.
    pub flaser_max_range_m: Option<f64>,
    /// From the first to the last time of the log's laser and odometry lines (s).
    pub duration_s: f64,
    /// What the reader noticed and the user should know: lines skipped as malformed, a
    /// file that ends early, a FLASER mount that varies.
    pub warnings: Vec<String>,
}

impl fmt::Display for CarmenLog {
    /// One line: the file, its messages, duration, repairs and skipped types.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (m, o, s) = (&self.messages, self.odometry_repairs, self.scan_repairs);
        let (scans, poses) = (self.data.raw_scans.len(), self.data.odometry.len());
        let (path, duration) = (self.path.display(), self.duration_s);
        write!(f, "{path}: {scans} scans ({} FLASER, ", m.flaser)?;
        write!(f, "{} ROBOTLASER1), {poses} odometry poses ", m.robotlaser1)?;
        write!(f, "({} ODOM lines) over {duration:.1} s; ", m.odom)?;
        write!(
            f,
            "nudged/dropped stamps: odometry {}/{}, ",
            o.nudged, o.dropped
        )?;
        write!(f, "scans {}/{}", s.nudged, s.dropped)?;
        if let Some(max) = self.flaser_max_range_m {
            write!(
                f,
                "; FLASER no return from {:.2} m",
                max - NO_RETURN_MARGIN_M
            )?;
        }
        let skipped: Vec<String> = ((m.malformed > 0)
            .then(|| format!("malformed {}", m.malformed)))
        .into_iter()
        .chain(m.skipped.iter().map(|(k, n)| format!("{k} {n}")))
        .collect();
        match skipped.is_empty() {
            true => write!(f, "; nothing skipped"),
            false => write!(f, "; skipped {}", skipped.join(", ")),
        }
    }
}

/// Reads the CARMEN log at `path`, plain or gzipped (see the module doc); lines that
/// cannot be read, and the end of a file cut short, are skipped with a warning.
///
/// # Errors
/// [`DataError::Io`] naming the file when it cannot be opened or its first line read;
/// [`DataError::Unusable`] for a log without a readable laser line (with the first
/// malformed lines' reasons), whose laser mount varies (beyond FLASER laser poses taken
/// as another trajectory, see the module doc), or whose FLASER lines have no valid
/// reading.
pub fn load(path: &Path) -> Result<CarmenLog> {
    let io = |e: std::io::Error| DataError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut file = BufReader::new(File::open(path).map_err(io)?);
    let gzipped = file.fill_buf().map_err(io)?.starts_with(&[0x1f, 0x8b]);
    let reader: Box<dyn BufRead> = match gzipped {
        true => Box::new(BufReader::new(MultiGzDecoder::new(file))),
        false => Box::new(file),
    };
    let mut records = Records::default();
    let early = text::each_line(reader, |number, text| {
        let fields = text.split_ascii_whitespace().collect();
        let line = Line {
            path,
            number,
            fields,
        };
        if let Err(e) = records.add(&line) {
            records.malformed.add(&e);
        }
    })
    .map_err(io)?;
    let warnings = (early.into_iter())
        .map(|end| format!("{}: {end}; the lines before are replayed", path.display()))
        .collect();
    build(path, records, warnings)
}

/// A laser line, before its stamp is known.
#[derive(Debug, Clone, PartialEq)]
struct LaserRecord {
    t_s: f64,
    line: usize,
    /// A FLASER line: its laser pose may be another trajectory's rather than a mount.
    flaser: bool,
    mount: Pose2,
    /// The line's maximum range; `None` for FLASER (the log's largest reading).
    max_range: Option<f64>,
    /// The scan before the no-return rule (invalid readings already NaN).
    scan: RawScan,
}

/// A pose-carrying line, before its stamp is known.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PoseRecord {
    t_s: f64,
    odometry: Odometry,
}

/// A pose record at `t_s`: the raw pose `x y θ`, speed and yaw rate `v ω`.
fn pose(t_s: f64, [x, y, theta]: [f64; 3], [v, omega]: [f64; 2]) -> PoseRecord {
    let (header, steering) = (Header::default(), 0.0);
    let odometry = Odometry {
        header,
        v,
        omega,
        steering,
        x,
        y,
        theta,
    };
    PoseRecord { t_s, odometry }
}

/// Everything read so far.
#[derive(Debug, Default)]
struct Records {
    lasers: Vec<LaserRecord>,
    poses: Vec<PoseRecord>,
    messages: MessageCounts,
    /// The lines that could not be read.
    malformed: Skipped,
}

impl Records {
    /// Takes in one line of the log.
    fn add(&mut self, line: &Line) -> Result<()> {
        let (laser, pose) = match line.fields.first() {
            None => return Ok(()),
            Some(kind) if kind.starts_with('#') => return Ok(()),
            Some(&"FLASER") => flaser(line)?,
            Some(&"ROBOTLASER1") => robotlaser1(line)?,
            Some(&"ODOM") => {
                // Read for its errors; its pose is a laser line's too (module doc).
                odom(line)?;
                self.messages.odom += 1;
                return Ok(());
            }
            Some(kind) if is_message_name(kind) => {
                *self.messages.skipped.entry(kind.to_string()).or_default() += 1;
                return Ok(());
            }
            Some(kind) => return Err(line.malformed(format!("`{kind}` is not a message type"))),
        };
        match laser.max_range {
            None => self.messages.flaser += 1,
            Some(_) => self.messages.robotlaser1 += 1,
        }
        self.lasers.push(laser);
        self.poses.push(pose);
        Ok(())
    }
}

/// An upper-case name such as `PARAM` or `RAWLASER1`.
fn is_message_name(kind: &str) -> bool {
    kind.starts_with(|c: char| c.is_ascii_uppercase())
        && (kind.chars()).all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
}

/// One line's fields, with where it is for error messages.
struct Line<'a> {
    path: &'a Path,
    number: usize,
    fields: Vec<&'a str>,
}

impl Line<'_> {
    /// A [`DataError::Malformed`] about this line.
    fn malformed(&self, reason: impl Into<String>) -> DataError {
        let (path, line, reason) = (self.path.to_path_buf(), self.number, reason.into());
        DataError::Malformed { path, line, reason }
    }

    /// Field `i` (from 0, the type's) as text.
    fn text(&self, i: usize) -> Result<&str> {
        let only = || self.malformed(format!("only {} fields", self.fields.len()));
        self.fields.get(i).copied().ok_or_else(only)
    }

    /// Field `i` as any number (NaN and infinities allowed: readings).
    fn reading(&self, i: usize) -> Result<f64> {
        let text = self.text(i)?;
        let bad = |_| self.malformed(format!("field {} is not a number: `{text}`", i + 1));
        text.parse::<f64>().map_err(bad)
    }

    /// The `N` fields from `start` on as finite numbers, named `names` for errors.
    fn numbers<const N: usize>(&self, start: usize, names: [&str; N]) -> Result<[f64; N]> {
        let mut values = [0.0; N];
        for (k, (value, name)) in values.iter_mut().zip(names).enumerate() {
            *value = self.reading(start + k)?;
            if !value.is_finite() {
                return Err(self.malformed(format!("{name} is not finite: {value}")));
            }
        }
        Ok(values)
    }

    /// Field `i` as a count from `min` to `max`.
    fn count(&self, i: usize, name: &str, min: usize, max: usize) -> Result<usize> {
        let text = self.text(i)?;
        let bad = || self.malformed(format!("{name} is not from {min} to {max}: `{text}`"));
        (text.parse().ok())
            .filter(|n| (min..=max).contains(n))
            .ok_or_else(bad)
    }

    /// Checks the line has exactly `expected` fields.
    fn expect_fields(&self, expected: usize, shape: &str) -> Result<()> {
        let found = self.fields.len();
        if found == expected {
            return Ok(());
        }
        let reason = format!("{shape}: expected {expected} fields, found {found}");
        Err(self.malformed(reason))
    }

    /// The `n` readings from field `start` on as ranges: NaN where ≤ 0 or not finite.
    fn ranges(&self, start: usize, n: usize) -> Result<Vec<f32>> {
        let valid = |r: f64| (r.is_finite() && r > 0.0).then_some(r as f32);
        (start..start + n)
            .map(|i| Ok(valid(self.reading(i)?).unwrap_or(f32::NAN)))
            .collect()
    }

    /// A laser record of this line, its scan laid out from `angles` (first, step).
    fn laser(&self, t_s: f64, angles: [f64; 2], ranges: Vec<f32>) -> LaserRecord {
        let header = LaserScanHeader {
            angle_min: angles[0] as f32,
            angle_increment: angles[1] as f32,
            ranges: ranges.len() as u32,
            ..LaserScanHeader::default()
        };
        let (line, mount, max_range) = (self.number, Pose2::default(), None);
        let scan = RawScan {
            header,
            items: ranges,
        };
        LaserRecord {
            t_s,
            line,
            flaser: false,
            mount,
            max_range,
            scan,
        }
    }
}

/// A FLASER line's scan and robot pose.
fn flaser(line: &Line) -> Result<(LaserRecord, PoseRecord)> {
    let n = line.count(1, "the beam count", 2, MAX_SCAN_BEAMS)?;
    line.expect_fields(n + 11, &format!("FLASER with {n} beams"))?;
    let ranges = line.ranges(2, n)?;
    let [lx, ly, lt] = line.numbers(2 + n, ["laser x", "laser y", "laser θ"])?;
    let odometry = line.numbers(5 + n, ["odom_x", "odom_y", "odom_θ"])?;
    let [t_s] = line.numbers(8 + n, ["ipc_timestamp"])?;
    line.numbers(10 + n, ["logger_timestamp"])?;
    let mut laser = line.laser(t_s, [-FRAC_PI_2, PI / (n - 1) as f64], ranges);
    laser.mount = mount_on(odometry, [lx, ly, lt]);
    laser.flaser = true;
    Ok((laser, pose(t_s, odometry, [0.0; 2])))
}

/// A ROBOTLASER1 line's scan and robot pose.
fn robotlaser1(line: &Line) -> Result<(LaserRecord, PoseRecord)> {
    let [start, _, step, max_range] =
        line.numbers(2, ["start_angle", "fov", "angular_res", "max_range"])?;
    let n = line.count(8, "the beam count", 1, MAX_SCAN_BEAMS)?;
    let m = line.count(9 + n, "the remission count", 0, line.fields.len())?;
    let tail = 10 + n + m;
    let shape = format!("ROBOTLASER1 with {n} beams, {m} remissions");
    line.expect_fields(tail + 14, &shape)?;
    if step <= 0.0 || step * (n - 1) as f64 > TAU + 1e-4 {
        let sweep = format!("angular_res {step} must be > 0, {n} beams sweeping at most 2π");
        return Err(line.malformed(sweep));
    }
    if max_range <= NO_RETURN_MARGIN_M {
        return Err(line.malformed(format!("max_range {max_range} must exceed 0.01 m")));
    }
    let ranges = line.ranges(9, n)?;
    line.ranges(10 + n, m)?;
    let [lx, ly, lt] = line.numbers(tail, ["laser_x", "laser_y", "laser_θ"])?;
    let [x, y, theta] = line.numbers(tail + 3, ["robot_x", "robot_y", "robot_θ"])?;
    let rates = line.numbers(tail + 6, ["tv", "rv"])?;
    let [t_s] = line.numbers(tail + 11, ["ipc_timestamp"])?;
    line.numbers(tail + 13, ["logger_timestamp"])?;
    let mut laser = line.laser(t_s, [start, step], ranges);
    laser.mount = mount_on([x, y, theta], [lx, ly, lt]);
    laser.max_range = Some(max_range);
    Ok((laser, pose(t_s, [x, y, theta], rates)))
}

/// The laser's pose `laser` on the robot at `robot` (both as written): `robot⁻¹ ⊕ laser`,
/// exactly the identity where the line writes the same pose twice.
fn mount_on(robot: [f64; 3], laser: [f64; 3]) -> Pose2 {
    if robot == laser {
        return Pose2::default();
    }
    let pose = |[x, y, theta]: [f64; 3]| Pose2::new(x, y, theta);
    pose(robot).inverse().compose(&pose(laser))
}

/// An ODOM line's pose and velocities.
fn odom(line: &Line) -> Result<PoseRecord> {
    line.expect_fields(10, "ODOM")?;
    let [x, y, theta, tv, rv, _, t_s] =
        line.numbers(1, ["x", "y", "θ", "tv", "rv", "accel", "ipc_timestamp"])?;
    line.numbers(9, ["logger_timestamp"])?;
    Ok(pose(t_s, [x, y, theta], [tv, rv]))
}

/// The laser's mount: the first laser line's, checked against every other line's. FLASER
/// lines whose laser poses are no fixed mount are first taken at the identity, with a
/// warning (see the module doc); a mount that varies after that refuses the log.
fn mount(path: &Path, lasers: &mut [LaserRecord]) -> Result<(Pose2, Option<String>)> {
    let path = path.display();
    let line_mount = |l: &LaserRecord| (l.line, l.mount);
    let flaser: Vec<(usize, Pose2)> = lasers.iter().filter(|l| l.flaser).map(line_mount).collect();
    let warning = varying(&flaser).map(|how| {
        format!(
            "{path}: the FLASER lines' laser poses are not the odometry poses moved by one \
             mount ({how}): taken as another trajectory, the laser at the robot's origin"
        )
    });
    if warning.is_some() {
        for l in lasers.iter_mut().filter(|l| l.flaser) {
            l.mount = Pose2::default();
        }
    }
    let mounts: Vec<(usize, Pose2)> = lasers.iter().map(line_mount).collect();
    if let Some(how) = varying(&mounts) {
        return Err(DataError::Unusable(format!(
            "{path}: the laser's mount on the robot varies ({how}), so no fixed mount \
             describes it"
        )));
    }
    let first = mounts.first().map_or_else(Pose2::default, |m| m.1);
    Ok((first, warning))
}

/// How `mounts` (line, mount) vary: the first against the first that differs from it by
/// more than [`MOUNT_TOLERANCE_M`] or [`MOUNT_TOLERANCE_RAD`], and how many do; `None`
/// when none does.
fn varying(mounts: &[(usize, Pose2)]) -> Option<String> {
    let &(_, a) = mounts.first()?;
    let differs = |(_, b): &&(usize, Pose2)| {
        (a.x - b.x).hypot(a.y - b.y) > MOUNT_TOLERANCE_M
            || wrap_angle(a.theta - b.theta).abs() > MOUNT_TOLERANCE_RAD
    };
    let count = mounts.iter().filter(differs).count();
    let other = mounts.iter().find(differs)?;
    let show = |(line, m): &(usize, Pose2)| {
        let (x, y, deg) = (m.x, m.y, m.theta.to_degrees());
        format!("line {line}: ({x:.3}, {y:.3}) m, {deg:.2}°")
    };
    let (mm, deg) = (MOUNT_TOLERANCE_M * 1e3, MOUNT_TOLERANCE_RAD.to_degrees());
    Some(format!(
        "{} vs {}; {count} lines differ from the first by more than {mm} mm or {deg:.1}°",
        show(&mounts[0]),
        show(other)
    ))
}

/// Stamps strictly increasing over records sorted by stamp: a record not later than the
/// previous kept one is dropped when `absorb` takes it into that one (a repeat), and is
/// otherwise moved to 1 ns after it.
fn strictly_increasing<T>(
    records: impl IntoIterator<Item = (u64, T)>,
    mut absorb: impl FnMut(&mut T, &T) -> bool,
) -> (Vec<(u64, T)>, StampRepairs) {
    let mut kept: Vec<(u64, T)> = Vec::new();
    let mut repairs = StampRepairs::default();
    for (mut stamp_ns, record) in records {
        if let Some((last_ns, last)) = kept.last_mut()
            && stamp_ns <= *last_ns
        {
            if absorb(last, &record) {
                repairs.dropped += 1;
                continue;
            }
            stamp_ns = last_ns.saturating_add(1);
            repairs.nudged += 1;
        }
        kept.push((stamp_ns, record));
    }
    (kept, repairs)
}

/// Applies the no-return rule of the module doc to `scan` for the laser's `max_range`.
fn no_return(scan: &mut RawScan, max_range: f64) {
    let limit = max_range - NO_RETURN_MARGIN_M;
    scan.header.range_max = limit as f32;
    for r in scan.items.iter_mut().filter(|r| f64::from(**r) >= limit) {
        *r = f32::INFINITY;
    }
}

/// The messages from the records read.
fn build(path: &Path, records: Records, mut warnings: Vec<String>) -> Result<CarmenLog> {
    let malformed = records.malformed.phrase("malformed lines skipped");
    let (mut lasers, mut poses) = (records.lasers, records.poses);
    let messages = MessageCounts {
        malformed: records.malformed.count(),
        ..records.messages
    };
    let unusable = |why: &str| Err(DataError::Unusable(format!("{}: {why}", path.display())));
    if lasers.is_empty() {
        // What was skipped, and where the file ended early.
        let why: String = (malformed.into_iter().chain(warnings))
            .map(|w| format!("; {w}"))
            .collect();
        return unusable(&format!(
            "no laser line (FLASER or ROBOTLASER1) in the log{why}"
        ));
    }
    if let Some(m) = malformed {
        warnings.insert(0, format!("{}: {m}", path.display()));
    }
    let (laser_mount, mount_warning) = mount(path, &mut lasers)?;
    warnings.extend(mount_warning);
    let flaser_max_range_m = (lasers.iter().filter(|l| l.flaser))
        .flat_map(|l| l.scan.items.iter().copied().filter(|r| !r.is_nan()))
        .map(f64::from)
        .reduce(f64::max);
    if messages.flaser > 0 && flaser_max_range_m.is_none_or(|m| m <= NO_RETURN_MARGIN_M) {
        return unusable("the FLASER lines have no reading over 0.01 m: no maximum range");
    }
    let times = || (poses.iter().map(|p| p.t_s)).chain(lasers.iter().map(|l| l.t_s));
    let clock = Clock::starting_at(times())?;
    let duration_s = times().fold(clock.epoch_s(), f64::max) - clock.epoch_s();
    // `sort_by` is stable: file order among equal times.
    poses.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    lasers.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    let scan_time = match (lasers.first(), lasers.last()) {
        (Some(first), Some(last)) if lasers.len() > 1 => {
            ((last.t_s - first.t_s) / (lasers.len() - 1) as f64) as f32
        }
        _ => 0.0,
    };
    for l in &mut lasers {
        l.scan.header.scan_time = scan_time;
        let max_range = l.max_range.or(flaser_max_range_m);
        no_return(&mut l.scan, max_range.unwrap_or(f64::MAX));
    }
    let (poses, odometry_repairs) = strictly_increasing(
        poses.into_iter().map(|p| (clock.stamp(p.t_s), p)),
        |last, p| {
            let at = |o: &Odometry| [o.x, o.y, o.theta];
            at(&last.odometry) == at(&p.odometry)
        },
    );
    let bits = |s: &RawScan| s.items.iter().map(|r| r.to_bits()).collect::<Vec<u32>>();
    let (lasers, scan_repairs) = strictly_increasing(
        lasers.into_iter().map(|l| (clock.stamp(l.t_s), l.scan)),
        |last, s| last.header == s.header && bits(last) == bits(s),
    );
    let stamped = |seq: usize, stamp_ns: u64| Header {
        stamp_ns,
        seq: seq as u64,
    };
    let odometry = (poses.iter().enumerate())
        .map(|(seq, &(stamp_ns, p))| Odometry {
            header: stamped(seq, stamp_ns),
            ..p.odometry
        })
        .collect();
    let raw_scans = (lasers.into_iter().enumerate())
        .map(|(seq, (stamp_ns, mut scan))| {
            scan.header.header = stamped(seq, stamp_ns);
            scan
        })
        .collect();
    let data = DataSet {
        odometry,
        raw_scans,
        laser_mount,
        epoch_s: clock.epoch_s(),
        ..DataSet::default()
    };
    let log = CarmenLog {
        path: path.to_path_buf(),
        data,
        messages,
        odometry_repairs,
        scan_repairs,
        flaser_max_range_m,
        duration_s,
        warnings,
    };
    tracing::info!(summary = %log, "CARMEN log read");
    Ok(log)
}

#[cfg(test)]
mod tests;
