//! ROS bags (rosbag2, and ROS 1's `.bag`): a robot's laser scans and odometry as a
//! [`DataSet`], so a recording a ROS user brings replays like the data sets the stack
//! ships.
//!
//! [`load`] reads a rosbag2 folder (`metadata.yaml` and its MCAP or SQLite storage files),
//! one `.mcap` / `.db3` file, or a ROS 1 `.bag` file or a folder of them
//! (`ros1_storage`), through [`storage`]; decodes the CDR or ROS 1 messages it needs
//! ([`cdr`]) and turns them into the stack's messages:
//! - **Scans**: the one `sensor_msgs/msg/LaserScan` or `sensor_msgs/msg/MultiEchoLaserScan`
//!   topic (or the one named) becomes [`DataSet::raw_scans`], ranges after REP-117 and
//!   beams counter-clockwise ([`streams`]); a multi-echo beam reads its first echo
//!   ([`cdr::multi_echo_laser_scan`]); intensities are dropped; a scan without beams is
//!   skipped. A `sensor_msgs/msg/PointCloud2` topic named by `--scan-topic` (a 3D lidar)
//!   is cut to a scan ([`cloud`]) as it is read, so a long 3D-lidar recording is never
//!   held whole; without the flag clouds are not read (a depth camera's would be no
//!   lidar), and a bag without a 2D scan names them in its refusal.
//! - **Odometry**: the one `nav_msgs/msg/Odometry` topic (or the one named) becomes one
//!   [`Odometry`] per message: `x`, `y`, `theta` the 2D pose in the odometry frame (yaw
//!   from the quaternion), `v` = `twist.linear.x`, `omega` = `twist.angular.z`, steering
//!   0. A bag without an Odometry topic (or with `--odom-topic /tf`) takes the pose of the
//!   base frame in the odometry frame from `/tf` instead ([`frames`]), chained through any
//!   frames between them, with `v` and `omega` 0.
//! - **Laser mounting**: the scan frame's pose in the base frame, from `/tf_static` (or
//!   `/tf` when the static transforms lack it), projected to x, y, yaw, goes into
//!   [`DataSet::laser_mount`]. Without one the laser is taken to sit at the base's
//!   origin, with a warning. A laser mounted upside down has its scans mirrored (its
//!   beams turn clockwise in the robot's frame).
//! - **Stamps**: each message's `header.stamp` (the bag's receive time when that is
//!   zero), as nanoseconds since the earliest scan or odometry stamp, which is
//!   [`DataSet::epoch_s`] (Unix seconds for a live recording). Each stream is put in
//!   strictly increasing stamp order ([`StampRepairs`]).
//!
//! The base frame is the Odometry messages' `child_frame_id`, or for tf `base_link` when
//! the odometry frame reaches it, else the odometry frame's only child; the odometry
//! frame for tf is `odom`. [`TopicChoice`] overrides each. Every other topic is counted
//! and skipped. Ground truth, landmarks and observations stay empty.
//!
//! A problem with the bag as a whole is an error naming the file, never a panic: a missing
//! or unknown storage file, a file cut short before its first message or corrupt, no scan
//! topic or several without a choice (listing them). A message that does not decode, or
//! holds a pose, twist or scan no sensor reports, is skipped and counted, and a warning
//! names the first few by file, topic and index. An MCAP file or a ROS 1 bag that stopped
//! early is read up to where it is whole, with a warning (`mcap_storage`,
//! `ros1_storage`).

mod bag;
pub mod cdr;
pub mod cloud;
pub mod frames;
mod mcap_storage;
mod ros1_storage;
mod sqlite_storage;
pub mod storage;
pub mod streams;
#[cfg(test)]
mod tests;

use crate::dataset::{Clock, DataSet, RawScan};
use crate::laser_odometry::OdometryChoice;
use crate::text::{DataError, Result, Skipped};
pub use bag::{Bag, OdometrySource, TopicCount};
use cdr::Serialization;
use fastslam_estimation::Pose2;
use fastslam_protocol::{Header, Odometry};
use frames::{TfTree, Transform};
use std::collections::BTreeSet;
use std::path::Path;
use storage::{Contents, Keep, RawMessage, Topic};
pub use streams::StampRepairs;

/// The laser scan message type.
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
/// The multi-echo laser scan message type (Cartographer's backpack bags).
pub const MULTI_ECHO_LASER_SCAN: &str = "sensor_msgs/msg/MultiEchoLaserScan";
/// The message types read as scans.
pub const SCAN_TYPES: &[&str] = &[LASER_SCAN, MULTI_ECHO_LASER_SCAN];
/// The point cloud message type, read as a scan when `--scan-topic` names it.
pub const POINT_CLOUD: &str = "sensor_msgs/msg/PointCloud2";
/// The odometry message type.
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";
/// The tf message type.
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
/// The topic of moving transforms.
pub const TF_TOPIC: &str = "/tf";
/// The topic of fixed transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// The flag that picks the odometry topic, as error messages name it.
const ODOM_FLAG: &str = "--odom-topic (or --odom-topic /tf for odometry from tf)";
/// Tilt of the laser from level beyond which the bag warns (rad, 5°).
const TILT_WARNING_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;

/// Which topics and frames to use where the bag leaves a choice; `None` picks the one
/// there is (see the module doc).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TopicChoice {
    /// The scan topic, of one of the [`SCAN_TYPES`] (`--scan-topic`).
    pub scan_topic: Option<String>,
    /// The `nav_msgs/msg/Odometry` topic, or `/tf` for odometry from tf (`--odom-topic`).
    pub odom_topic: Option<String>,
    /// The odometry frame, for odometry from tf (`--odom-frame`, default `odom`).
    pub odom_frame: Option<String>,
    /// The robot's frame: whose pose the odometry is and where the laser mounting is
    /// measured from (`--base-frame`).
    pub base_frame: Option<String>,
    /// Whether the bag's odometry is read (`--odometry`).
    pub odometry: OdometryChoice,
}

/// Reads the bag at `path` (a rosbag2 folder, one `.mcap` / `.db3` file or a ROS 1 `.bag`
/// file) with the topics and frames of `topics` (see the module doc); a message that does
/// not decode is skipped with a warning. With `topics.odometry` [`OdometryChoice::Laser`]
/// the bag's odometry is not read (the data set has none; the base frame is
/// `topics.base_frame`, else `base_link`).
///
/// # Errors
/// [`DataError`] naming the file: a missing, unknown, truncated or corrupt storage file;
/// no scan topic, no odometry, or several candidates without a choice
/// ([`DataError::Unusable`], listing them and the flag that picks one).
pub fn load(path: &Path, topics: &TopicChoice) -> Result<Bag> {
    let keep = |name: &str, type_name: &str| keep(topics, name, type_name);
    let contents = storage::read(path, &keep)?;
    // A ROS 1 bag's frames lose tf's leading slash (`cdr`); so do the flags naming them.
    let ros1 = (contents.topics.iter()).any(|t| t.serialization() == Some(Serialization::Ros1));
    let unslashed = |frame: &Option<String>| {
        frame.as_deref().map(|f| {
            f.strip_prefix('/')
                .filter(|_| ros1)
                .unwrap_or(f)
                .to_string()
        })
    };
    let topics = &TopicChoice {
        odom_frame: unslashed(&topics.odom_frame),
        base_frame: unslashed(&topics.base_frame),
        ..topics.clone()
    };
    let bag = Reader {
        path,
        contents: &contents,
        warnings: contents.warnings.clone(),
        used: BTreeSet::new(),
        rejected: BTreeSet::new(),
        skipped_messages: Skipped::default(),
    };
    bag.build(topics)
}

/// What [`load`] keeps of topic `name` of type `type_name` with the choices `topics`:
/// the scans (only the topic `--scan-topic` names, when it names one; a point cloud cut to
/// its scan as it is read, and only when named), the odometry unless it is made from the
/// laser, and tf.
fn keep(topics: &TopicChoice, name: &str, type_name: &str) -> Keep {
    let named = topics.scan_topic.as_deref() == Some(name);
    if type_name == POINT_CLOUD {
        return if named {
            Keep::Reduced(cloud::cut)
        } else {
            Keep::Nothing
        };
    }
    let wanted = ((named || topics.scan_topic.is_none()) && SCAN_TYPES.contains(&type_name))
        || (topics.odometry == OdometryChoice::Recorded && type_name == ODOMETRY)
        || (type_name == TF_MESSAGE && (name == TF_TOPIC || name == TF_STATIC_TOPIC));
    if wanted { Keep::Bytes } else { Keep::Nothing }
}

/// One load in progress.
struct Reader<'a> {
    path: &'a Path,
    contents: &'a Contents,
    warnings: Vec<String>,
    /// Topics read (by index), so the rest are reported as skipped.
    used: BTreeSet<usize>,
    /// Messages skipped as undecodable or holding values no sensor reports, by (file,
    /// topic, index): each is counted once, however often its topic is read.
    rejected: BTreeSet<(usize, usize, usize)>,
    /// Those messages' count and first errors.
    skipped_messages: Skipped,
}

/// One odometry sample: the base's pose in the odometry frame and the measured speeds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sample {
    pose: Pose2,
    v: f64,
    omega: f64,
}

/// Odometry samples with their absolute stamps (ns).
type Samples = Vec<(u64, Sample)>;

impl<'a> Reader<'a> {
    /// The bag as a data set, with the topics and frames of `choice`; a refusal names the
    /// messages skipped on the way.
    fn build(mut self, choice: &TopicChoice) -> Result<Bag> {
        let built = self.assemble(choice);
        match (built, self.rejected_messages()) {
            (Err(DataError::Unusable(why)), Some(r)) => {
                Err(DataError::Unusable(format!("{why}; {r}")))
            }
            (built, _) => built,
        }
    }

    /// [`Reader::build`]'s work.
    fn assemble(&mut self, choice: &TopicChoice) -> Result<Bag> {
        let recorded_odometry = choice.odometry == OdometryChoice::Recorded;
        let scan_topic = self.scan_topic(choice.scan_topic.as_deref())?;
        let odom_topic = match choice.odom_topic.as_deref() {
            _ if !recorded_odometry => None,
            Some(TF_TOPIC) => None,
            wanted => {
                let none_is_fine = wanted.is_none() && self.candidates(&[ODOMETRY]).is_empty();
                if none_is_fine {
                    None
                } else {
                    Some(self.choose(&[ODOMETRY], wanted, ODOM_FLAG)?)
                }
            }
        };
        let scans = if self.contents.topics[scan_topic].type_name == MULTI_ECHO_LASER_SCAN {
            self.decode(scan_topic, cdr::multi_echo_laser_scan)
        } else {
            // A LaserScan, or a cloud cut to its scan as it was read (`cloud::cut`).
            self.decode(scan_topic, cdr::laser_scan)
        };
        let laser_frame = (scans.first())
            .map(|(_, s, _)| s.header.frame_id.clone())
            .unwrap_or_default();
        if scans
            .iter()
            .any(|(_, s, _)| s.header.frame_id != laser_frame)
        {
            self.warnings.push(format!(
                "scans name more than one frame: the mounting is that of `{laser_frame}`, the \
                 first scan's"
            ));
        }
        let mut full_tf = None;
        let (odometry_source, base_frame, samples) = if recorded_odometry {
            self.odometry(choice, odom_topic, &mut full_tf)?
        } else {
            let base = (choice.base_frame.clone()).unwrap_or_else(|| "base_link".into());
            (OdometrySource::Laser, base, Samples::new())
        };
        let first_scan_ns = scans.iter().map(|(t, _, _)| *t).min().unwrap_or(0);
        let mount = self.find_mount(&base_frame, &laser_frame, first_scan_ns, full_tf)?;
        let (mount_pose, mirrored) = self.mount(mount, &base_frame, &laser_frame);
        let raw_scans = self.scans(scan_topic, scans, mirrored);
        let (raw_scans, scan_stamps) = streams::order(raw_scans, same_scan);
        let (samples, odometry_stamps) = streams::order(samples, |a, b| a == b);
        let path = self.path.display();
        // Without the recorded odometry the scans alone set the epoch.
        let first_sample_ns = match samples.first() {
            Some((t, _)) => Some(*t),
            None if !recorded_odometry => raw_scans.first().map(|(t, _)| *t),
            None => None,
        };
        let (Some(first_scan), Some(first_sample_ns)) = (raw_scans.first(), first_sample_ns) else {
            let what = if raw_scans.is_empty() {
                format!(
                    "no scan with beams on {}",
                    self.contents.topics[scan_topic].name
                )
            } else {
                format!(
                    "no odometry from {odometry_source} (without wheel odometry, --odometry \
                     laser makes it from the scans)"
                )
            };
            return Err(DataError::Unusable(format!("{path}: {what}")));
        };
        let rejected = self.rejected_messages();
        self.warnings
            .extend(rejected.map(|r| format!("{path}: {r}")));
        let epoch_ns = first_scan.0.min(first_sample_ns);
        let clock = Clock::starting_at([epoch_ns as f64 * 1e-9])?;
        let data = DataSet {
            odometry: (samples.iter().enumerate())
                .map(|(seq, (t, s))| Odometry {
                    header: header(*t - epoch_ns, seq),
                    v: s.v,
                    omega: s.omega,
                    steering: 0.0,
                    x: s.pose.x,
                    y: s.pose.y,
                    theta: s.pose.theta,
                })
                .collect(),
            raw_scans: (raw_scans.into_iter().enumerate())
                .map(|(seq, (t, mut scan))| {
                    scan.header.header = header(t - epoch_ns, seq);
                    scan
                })
                .collect(),
            laser_mount: mount_pose,
            epoch_s: clock.epoch_s(),
            ..DataSet::default()
        };
        let skipped = (self.contents.topics.iter().enumerate())
            .filter(|(k, _)| !self.used.contains(k))
            .map(|(_, t)| TopicCount {
                name: t.name.clone(),
                type_name: t.type_name.clone(),
                count: t.count,
            })
            .collect();
        Ok(Bag {
            data,
            files: self.contents.files.clone(),
            scan_topic: self.contents.topics[scan_topic].name.clone(),
            scan_type: self.contents.topics[scan_topic].type_name.clone(),
            odometry: odometry_source,
            laser_frame,
            base_frame,
            mount_from_tf: mount.is_some(),
            skipped,
            scan_stamps,
            odometry_stamps,
            warnings: std::mem::take(&mut self.warnings),
        })
    }

    /// The odometry's source, base frame and samples: from the chosen Odometry topic, or
    /// from tf (the tree then left in `full_tf`).
    fn odometry(
        &mut self,
        choice: &TopicChoice,
        odom_topic: Option<usize>,
        full_tf: &mut Option<TfTree>,
    ) -> Result<(OdometrySource, String, Samples)> {
        if let Some(topic) = odom_topic {
            let messages = self.decode(topic, cdr::odometry);
            let child = (messages.iter())
                .map(|(_, m, _)| m.child_frame_id.as_str())
                .find(|c| !c.is_empty());
            let base = (choice.base_frame.clone())
                .or(child.map(str::to_string))
                .unwrap_or_else(|| "base_link".into());
            let samples = self.odometry_samples(messages);
            let name = self.contents.topics[topic].name.clone();
            return Ok((OdometrySource::Topic(name), base, samples));
        }
        let tf = full_tf.insert(self.tf(&[TF_STATIC_TOPIC, TF_TOPIC])?);
        let odom = choice.odom_frame.clone().unwrap_or_else(|| "odom".into());
        let base = self.tf_base(tf, &odom, choice.base_frame.as_deref())?;
        let samples = self.tf_samples(tf, &odom, &base)?;
        let source = OdometrySource::Tf {
            odom_frame: odom,
            base_frame: base.clone(),
        };
        Ok((source, base, samples))
    }

    /// The laser's pose in the base frame: from `/tf_static`, else from all of tf (the
    /// tree `full_tf` when already read) at the first scan; `None` when tf lacks it or the
    /// laser is the base.
    fn find_mount(
        &mut self,
        base: &str,
        laser: &str,
        first_scan_ns: u64,
        full_tf: Option<TfTree>,
    ) -> Result<Option<Transform>> {
        if laser.is_empty() || laser == base {
            return Ok(None);
        }
        if let Some(mount) = self
            .tf(&[TF_STATIC_TOPIC])?
            .lookup(base, laser, first_scan_ns)
        {
            return Ok(Some(mount));
        }
        let tf = match full_tf {
            Some(tf) => tf,
            None => self.tf(&[TF_STATIC_TOPIC, TF_TOPIC])?,
        };
        let mount = tf.lookup(base, laser, first_scan_ns);
        if mount.is_some() && !tf.is_fixed(base, laser) {
            self.warnings.push(format!(
                "the laser mounting {base}→{laser} moves on {TF_TOPIC}: taken at the first scan"
            ));
        }
        Ok(mount)
    }

    /// The scan topic: the point cloud topic `wanted` names, else the one of the
    /// [`SCAN_TYPES`] `wanted` names or the only one; a refusal for a bag without a 2D
    /// scan names its point cloud topics.
    fn scan_topic(&mut self, wanted: Option<&str>) -> Result<usize> {
        let clouds = self.candidates(&[POINT_CLOUD]);
        let topics = &self.contents.topics;
        if let Some(k) = clouds
            .iter()
            .copied()
            .find(|&k| Some(topics[k].name.as_str()) == wanted)
        {
            self.used.insert(k);
            return Ok(k);
        }
        let flag = if clouds.is_empty() {
            "--scan-topic".to_string()
        } else {
            format!(
                "--scan-topic (a {POINT_CLOUD} topic named there is cut to a scan: {})",
                (clouds.iter().map(|&k| topics[k].name.as_str()))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        self.choose(SCAN_TYPES, wanted, &flag)
    }

    /// The topics of one of the types `types` in a serialisation the decoders read.
    fn candidates(&self, types: &[&str]) -> Vec<usize> {
        (self.contents.topics.iter().enumerate())
            .filter(|(_, t)| types.contains(&t.type_name.as_str()) && t.serialization().is_some())
            .map(|(k, _)| k)
            .collect()
    }

    /// The topic of one of the types `types`: the one named `wanted`, else the only one.
    fn choose(&mut self, types: &[&str], wanted: Option<&str>, flag: &str) -> Result<usize> {
        let candidates = self.candidates(types);
        let type_name = types.join(" or ");
        let topics = &self.contents.topics;
        let list = |ks: &[usize]| listing(ks.iter().map(|&k| &topics[k]));
        let all: Vec<usize> = (0..topics.len()).collect();
        let found = match wanted {
            Some(name) => candidates.iter().copied().find(|&k| topics[k].name == name),
            None if candidates.len() == 1 => Some(candidates[0]),
            None => None,
        };
        if let Some(k) = found {
            self.used.insert(k);
            return Ok(k);
        }
        let problem = match (wanted, candidates.len()) {
            (Some(name), 0) => format!(
                "no {type_name} topic `{name}`: the bag has no {type_name} topic; its topics: {}",
                list(&all)
            ),
            (Some(name), _) => format!(
                "no {type_name} topic `{name}`; the {type_name} topics: {}",
                list(&candidates)
            ),
            (None, 0) => format!("no {type_name} topic; the bag's topics: {}", list(&all)),
            (None, n) => format!("{n} {type_name} topics: {}", list(&candidates)),
        };
        Err(DataError::Unusable(format!(
            "{}: {problem}; pick one with {flag}",
            self.path.display()
        )))
    }

    /// The messages of `topic` decoded by `decode`, each with its stamp (header stamp, or
    /// receive time when that is zero).
    fn decode<M: Stamped>(
        &mut self,
        topic: usize,
        decode: fn(&[u8], Serialization) -> cdr::DecodeResult<M>,
    ) -> Vec<(u64, M, &'a RawMessage)> {
        let serialization = self.serialization(topic);
        let mut out = Vec::new();
        for m in self.messages(topic) {
            let decoded = (m.bytes())
                .and_then(|bytes| decode(bytes, serialization))
                .and_then(|msg| Ok((msg.stamp().ns()?, msg)));
            match decoded {
                Ok((stamp, msg)) => out.push((stamp.unwrap_or(m.receive_ns), msg, m)),
                Err(reason) => self.reject(m, reason),
            }
        }
        out
    }

    /// How `topic`'s messages are serialised (CDR unless the storage says ROS 1).
    fn serialization(&self, topic: usize) -> Serialization {
        self.contents.topics[topic]
            .serialization()
            .unwrap_or(Serialization::Cdr)
    }

    /// The kept messages of `topic`, in storage order.
    fn messages(&self, topic: usize) -> impl Iterator<Item = &'a RawMessage> + use<'a> {
        (self.contents.messages.iter()).filter(move |m| m.topic == topic)
    }

    /// Skips message `m`, which does not decode or holds values no sensor reports, for
    /// `reason`: counted, and among the first few named in a warning.
    fn reject(&mut self, m: &RawMessage, reason: String) {
        if !self.rejected.insert((m.file, m.topic, m.index)) {
            return; // read again (tf is read once per question asked of it)
        }
        self.skipped_messages.add(&DataError::Message {
            path: self.contents.files[m.file].clone(),
            topic: self.contents.topics[m.topic].name.clone(),
            index: m.index,
            reason,
        });
    }

    /// The skipped messages in one phrase: how many, and the first few; `None` without.
    fn rejected_messages(&self) -> Option<String> {
        (self.skipped_messages)
            .phrase("messages skipped that do not decode or hold values no sensor reports")
    }

    /// The transforms on the tf topics `names` (the first static), as one tree.
    fn tf(&mut self, names: &[&str]) -> Result<TfTree> {
        let mut tree = TfTree::default();
        for (k, topic) in self.contents.topics.iter().enumerate() {
            let Some(n) = names.iter().position(|n| *n == topic.name) else {
                continue;
            };
            if topic.type_name != TF_MESSAGE {
                continue;
            }
            self.used.insert(k);
            let serialization = self.serialization(k);
            for m in self.messages(k) {
                let transforms = match (m.bytes()).and_then(|b| cdr::tf_message(b, serialization)) {
                    Ok(transforms) => transforms,
                    Err(reason) => {
                        self.reject(m, reason);
                        continue;
                    }
                };
                // A bad transform costs only itself: a static publisher sends every mount
                // in one message.
                for t in transforms {
                    let (parent, child) = (&t.header.frame_id, &t.child_frame_id);
                    let stamp = t.header.stamp.ns().map(|s| s.unwrap_or(m.receive_ns));
                    match stamp.and_then(|s| Ok((s, Transform::new(t.translation, t.rotation)?))) {
                        Ok((stamp, transform)) => tree.add(parent, child, stamp, transform, n == 0),
                        Err(reason) => self.reject(m, format!("{parent} → {child}: {reason}")),
                    }
                }
            }
        }
        tree.finish();
        for w in &tree.warnings {
            if !self.warnings.contains(w) {
                self.warnings.push(w.clone());
            }
        }
        Ok(tree)
    }

    /// Odometry messages as samples.
    fn odometry_samples(&mut self, messages: Vec<(u64, cdr::Odometry, &RawMessage)>) -> Samples {
        let mut samples = Vec::with_capacity(messages.len());
        for (t, m, raw) in messages {
            let pose = Transform::new(m.position, m.orientation).map_err(|e| format!("pose: {e}"));
            let (v, omega) = (m.linear[0], m.angular[2]);
            match pose {
                Err(reason) => self.reject(raw, reason),
                Ok(_) if !(v.is_finite() && omega.is_finite()) => {
                    self.reject(raw, format!("twist {v} m/s, {omega} rad/s is not finite"));
                }
                Ok(pose) => samples.push((
                    t,
                    Sample {
                        pose: pose.pose2(),
                        v,
                        omega,
                    },
                )),
            }
        }
        samples
    }

    /// The base frame for odometry from tf (see the module doc).
    fn tf_base(&self, tf: &TfTree, odom: &str, wanted: Option<&str>) -> Result<String> {
        if let Some(base) = wanted {
            return Ok(base.to_string());
        }
        if tf.lookup(odom, "base_link", 0).is_some() {
            return Ok("base_link".into());
        }
        match tf.children(odom)[..] {
            [only] => Ok(only.to_string()),
            _ => Err(self.no_tf_odometry(tf, odom, "base_link")),
        }
    }

    /// The base's pose in the odometry frame over time, from tf.
    fn tf_samples(&self, tf: &TfTree, odom: &str, base: &str) -> Result<Samples> {
        let track = tf
            .track(odom, base)
            .ok_or_else(|| self.no_tf_odometry(tf, odom, base))?;
        Ok((track.into_iter())
            .map(|(t, pose)| {
                let sample = Sample {
                    pose: pose.pose2(),
                    v: 0.0,
                    omega: 0.0,
                };
                (t, sample)
            })
            .collect())
    }

    /// The error for odometry missing from tf, listing what tf holds.
    fn no_tf_odometry(&self, tf: &TfTree, odom: &str, base: &str) -> DataError {
        let seen = if tf.is_empty() {
            "the bag has no tf".to_string()
        } else {
            format!("tf holds {}", tf.listing())
        };
        DataError::Unusable(format!(
            "{}: no odometry: no {ODOMETRY} topic, and no moving transform {odom}→{base} on \
             {TF_TOPIC} ({seen}); name the frames with --odom-frame and --base-frame, or a \
             topic with --odom-topic; without wheel odometry, --odometry laser makes it from \
             the scans",
            self.path.display()
        ))
    }

    /// The planar mounting and whether scans are mirrored (laser upside down), with
    /// warnings for what is missing or odd.
    fn mount(&mut self, mount: Option<Transform>, base: &str, laser: &str) -> (Pose2, bool) {
        let Some(mount) = mount else {
            if laser.is_empty() {
                self.warnings.push(
                    "the scans name no frame: the laser is taken to sit at the base's origin"
                        .into(),
                );
            } else if laser != base {
                self.warnings.push(format!(
                    "no transform {base}→{laser} on {TF_STATIC_TOPIC} or {TF_TOPIC}: the laser \
                     is taken to sit at the base's origin (name the base frame with \
                     --base-frame)"
                ));
            }
            return (Pose2::default(), false);
        };
        let mirrored = mount.up() < 0.0;
        let upright = if mirrored { mount.flipped() } else { mount };
        if mirrored {
            self.warnings.push(format!(
                "the laser `{laser}` is mounted upside down: its scans are mirrored"
            ));
        }
        if upright.up() < TILT_WARNING_RAD.cos() {
            self.warnings.push(format!(
                "the laser `{laser}` is tilted {:.1}° from level: its ranges are used as if level",
                upright.up().clamp(-1.0, 1.0).acos().to_degrees()
            ));
        }
        (upright.pose2(), mirrored)
    }

    /// The decoded scans as wire scans, stamped with their absolute stamps.
    fn scans(
        &mut self,
        topic: usize,
        scans: Vec<(u64, cdr::LaserScan, &RawMessage)>,
        mirrored: bool,
    ) -> Vec<(u64, RawScan)> {
        let (mut empty, mut reversed, mut timing) = (0, 0, 0);
        let mut out = Vec::with_capacity(scans.len());
        for (t, msg, raw) in scans {
            let scan = match streams::scan(&msg, mirrored) {
                Ok(scan) => scan,
                Err(reason) => {
                    self.reject(raw, reason);
                    continue;
                }
            };
            let Some((header, ranges, fixes)) = scan else {
                empty += 1;
                continue;
            };
            reversed += usize::from(fixes.reversed);
            timing += usize::from(fixes.timing_zeroed);
            out.push((
                t,
                RawScan {
                    header,
                    items: ranges,
                },
            ));
        }
        let name = &self.contents.topics[topic].name;
        for (n, what) in [
            (empty, "had no beams and were skipped"),
            (
                reversed,
                "were reversed to sweep counter-clockwise (per-beam timing dropped)",
            ),
            (
                timing,
                "had a negative or non-finite time_increment or scan_time, set to 0",
            ),
        ] {
            if n > 0 {
                self.warnings.push(format!("{n} scans on {name} {what}"));
            }
        }
        out
    }
}

/// Messages with a header stamp.
trait Stamped {
    /// The header stamp.
    fn stamp(&self) -> cdr::Time;
}

impl Stamped for cdr::LaserScan {
    fn stamp(&self) -> cdr::Time {
        self.header.stamp
    }
}

impl Stamped for cdr::Odometry {
    fn stamp(&self) -> cdr::Time {
        self.header.stamp
    }
}

/// A wire header.
fn header(stamp_ns: u64, seq: usize) -> Header {
    Header {
        stamp_ns,
        seq: seq as u64,
    }
}

/// Whether two scans are the same (ranges compared bit for bit, so NaN equals NaN).
fn same_scan(a: &RawScan, b: &RawScan) -> bool {
    a.header == b.header
        && a.items.len() == b.items.len()
        && a.items
            .iter()
            .zip(&b.items)
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Topics as `name (type, N messages)`, joined.
fn listing<'a>(topics: impl Iterator<Item = &'a Topic>) -> String {
    let items: Vec<String> = topics
        .map(|t| {
            let encoding = if t.serialization().is_some() {
                String::new()
            } else {
                format!(", {} encoding", t.encoding)
            };
            let type_name = if t.type_name.is_empty() {
                "no type"
            } else {
                &t.type_name
            };
            format!("{} ({type_name}{encoding}, {} messages)", t.name, t.count)
        })
        .collect();
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}
