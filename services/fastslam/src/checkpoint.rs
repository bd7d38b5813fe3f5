//! Checkpoints: the service's state written to a file every so many steps, so a service
//! that was killed continues with `--resume` where the last checkpoint left it.
//!
//! # File format
//! ```text
//! offset  size  field
//! 0       8     magic "FSLMCKPT"
//! 8       4     format version, u32 little-endian (FORMAT_VERSION)
//! 12      8     payload length in bytes, u64 little-endian
//! 20      8     FNV-1a 64 hash of the payload, u64 little-endian
//! 28      n     payload: a [`Checkpoint`], bincode 2 (standard config, serde)
//! ```
//! The file is written atomically: a temporary file in the same folder, flushed to disk,
//! then renamed over the old checkpoint, so a crash while writing leaves the previous
//! checkpoint intact. A file that is not a checkpoint, of another version, truncated or
//! corrupt is refused with a [`CheckpointError`] that says which.

use crate::per_stream::PerStream;
pub use crate::state::EstimatorState;
use fastslam_estimation::Pose2;
use fastslam_estimation::fastslam::NisWindow;
use fastslam_estimation::graph::Feed;
use fastslam_protocol::status::REJECTION_KINDS;
use fastslam_protocol::{Header, StreamId};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The first bytes of every checkpoint file.
pub const MAGIC: [u8; 8] = *b"FSLMCKPT";
/// The payload layout written by this build; bumped whenever [`Checkpoint`] changes.
pub const FORMAT_VERSION: u32 = 13;
/// Bytes before the payload: magic, version, length, hash.
const HEADER_LEN: usize = 28;

/// Why a checkpoint could not be written or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckpointError {
    /// The file could not be read, written or renamed.
    #[error("checkpoint {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason (in the message, not a separate cause, so the
        /// error reads as one line).
        error: std::io::Error,
    },
    /// The file does not start with [`MAGIC`].
    #[error("checkpoint {path}: not a FastSLAM checkpoint (bad magic bytes)")]
    NotACheckpoint {
        /// The file.
        path: PathBuf,
    },
    /// The file was written by a build with another [`FORMAT_VERSION`].
    #[error("checkpoint {path}: format version {found}, this build reads version {expected}")]
    Version {
        /// The file.
        path: PathBuf,
        /// The version in the file.
        found: u32,
        /// [`FORMAT_VERSION`].
        expected: u32,
    },
    /// The file is shorter than its header says.
    #[error("checkpoint {path}: truncated ({found} bytes, expected {expected})")]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Bytes in the file.
        found: usize,
        /// Bytes the header announces.
        expected: usize,
    },
    /// The payload does not match its hash or does not decode.
    #[error("checkpoint {path}: corrupt ({reason})")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What did not match.
        reason: String,
    },
}

/// Everything the service needs to continue a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The filter's seed (a resumed run must use the same one to be reproducible).
    pub seed: u64,
    /// Particles, weights, maps and the step counter (the random state).
    pub filter: EstimatorState,
    /// Stamp of the last odometry the filter predicted to (ns), if any.
    pub last_odometry_ns: Option<u64>,
    /// Pose of that odometry in the odometry frame (the increment model's start).
    pub last_odometry_pose: Option<Pose2>,
    /// Stamp of the last input processed per stream (ns), as (wire stream id, stamp).
    /// Older inputs after a resume are skipped.
    pub processed_ns: Vec<(u32, u64)>,
    /// Observation steps taken.
    pub steps: u64,
    /// Resamplings done.
    pub resamplings: u64,
    /// Sequence numbers last published: pose, map, grid, status, smoothed trajectory and
    /// map, particle cloud (so they continue).
    pub last_seq: [Option<u64>; 6],
    /// What the smoothing back-end was fed (empty without one): a resumed service feeds
    /// it again and so rebuilds the same graph.
    pub smoother_feed: Vec<Feed>,
    /// The noise check's window, and whether its warning was logged.
    pub noise_check: (NisWindow, bool),
    /// Inputs rejected so far, by [`fastslam_protocol::status::RejectionKind`].
    pub rejections: [u64; REJECTION_KINDS],
}

/// FNV-1a, 64 bits: a cheap hash that catches flipped or lost bytes.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Checkpoint {
    /// Stamp of the last input of `stream` processed (ns; 0 when the checkpoint has no
    /// input of it).
    pub fn processed(&self, stream: StreamId) -> u64 {
        (self.processed_ns.iter())
            .find(|(s, _)| *s == stream as u32)
            .map_or(0, |&(_, t)| t)
    }

    /// The processed stamps of the streams this build knows, as a checkpoint notice
    /// lists them.
    pub fn covered(&self) -> impl Iterator<Item = (StreamId, u64)> + '_ {
        (self.processed_ns.iter()).filter_map(|&(s, t)| StreamId::from_u32(s).map(|s| (s, t)))
    }

    /// The file contents: header and payload.
    ///
    /// # Panics
    /// Never in practice: encoding plain data into a `Vec` cannot fail.
    pub fn encode(&self) -> Vec<u8> {
        let payload = bincode::serde::encode_to_vec(self, bincode::config::standard())
            .expect("encoding plain data into memory");
        let mut bytes = Vec::with_capacity(HEADER_LEN + payload.len());
        bytes.extend_from_slice(&MAGIC);
        bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&fnv1a(&payload).to_le_bytes());
        bytes.extend_from_slice(&payload);
        bytes
    }

    /// Decodes file contents; `path` only names the file in errors.
    ///
    /// # Errors
    /// [`CheckpointError::NotACheckpoint`], [`CheckpointError::Version`],
    /// [`CheckpointError::Truncated`] or [`CheckpointError::Corrupt`].
    pub fn decode(bytes: &[u8], path: &Path) -> Result<Self, CheckpointError> {
        let path = path.to_path_buf();
        if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
            return Err(CheckpointError::NotACheckpoint { path });
        }
        let truncated = |expected| CheckpointError::Truncated {
            path: path.clone(),
            found: bytes.len(),
            expected,
        };
        if bytes.len() < HEADER_LEN {
            return Err(truncated(HEADER_LEN));
        }
        let word = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != FORMAT_VERSION {
            return Err(CheckpointError::Version {
                path,
                found: version,
                expected: FORMAT_VERSION,
            });
        }
        let expected = usize::try_from(word(12))
            .unwrap_or(usize::MAX)
            .saturating_add(HEADER_LEN);
        if bytes.len() < expected {
            return Err(truncated(expected));
        }
        let corrupt = |reason: String| CheckpointError::Corrupt {
            path: path.clone(),
            reason,
        };
        let payload = &bytes[HEADER_LEN..];
        if payload.len() + HEADER_LEN != expected {
            return Err(corrupt(format!(
                "{} bytes after the announced end",
                bytes.len() - expected
            )));
        }
        if fnv1a(payload) != word(20) {
            return Err(corrupt("payload hash mismatch".into()));
        }
        let (checkpoint, _) =
            bincode::serde::decode_from_slice(payload, bincode::config::standard())
                .map_err(|e| corrupt(e.to_string()))?;
        Ok(checkpoint)
    }

    /// Writes the checkpoint to `path` atomically (temporary file in the same folder,
    /// `fsync`, rename, `fsync` of the folder).
    ///
    /// # Errors
    /// [`CheckpointError::Io`] when a step fails; the previous file is then untouched.
    pub fn write(&self, path: &Path) -> Result<(), CheckpointError> {
        write_atomically(path, &self.encode()).map_err(|error| CheckpointError::Io {
            path: path.to_path_buf(),
            error,
        })
    }

    /// Reads and decodes the checkpoint at `path`.
    ///
    /// # Errors
    /// As [`decode`](Self::decode), and [`CheckpointError::Io`] when it cannot be read.
    pub fn read(path: &Path) -> Result<Self, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|error| CheckpointError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        Self::decode(&bytes, path)
    }
}

/// Replaces `path` by `bytes` so that a reader sees the old or the new contents, never a
/// mixture: write a temporary sibling, flush it to disk, rename it over `path`, flush the
/// folder (the rename itself).
///
/// # Errors
/// The first failing file operation; the temporary file is removed then.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file")
    })?;
    let temporary = folder.join(format!(
        ".{}.{}.tmp",
        name.to_string_lossy(),
        std::process::id()
    ));
    let written = (|| {
        let mut file = std::fs::File::create(&temporary)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        std::fs::rename(&temporary, path)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    written?;
    std::fs::File::open(folder)?.sync_all()
}

/// What the [`ResumeFloor`] makes of an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Floor {
    /// Not processed yet: take it. `lost` inputs are missing between it and the last
    /// one the checkpoint holds: its sensor no longer had them to send again.
    New {
        /// Inputs missing before it.
        lost: u64,
    },
    /// The checkpoint holds it: skip it.
    Covered {
        /// It began its stream's resend (the last input the checkpoint holds, sent again
        /// by design). Any other covered input came from sensors that started over: the
        /// run that wrote the checkpoint processed it, not this one.
        mark: bool,
    },
    /// Sent before its sensor's resend began: skip it, it comes again (so it does not
    /// count towards its stream's end yet).
    ComesAgain,
}

/// Skips inputs a resumed run has already processed: those stamped at or before the
/// checkpoint's [`Checkpoint::processed_ns`] on their stream. They are counted, not
/// treated as errors.
///
/// A resumed service asks the sensors to send again what they sent after the checkpoint
/// (the `checkpoint` topic), and they start with the last input the checkpoint holds. A
/// sensor that had not noticed the crash may have sent newer inputs first: until a
/// stream's resend begins (an input at or before the floor, or one numbered before the
/// first seen), its inputs are skipped too; they come again in the resend.
#[derive(Debug, Clone)]
pub struct ResumeFloor {
    floor: Option<PerStream<u64>>,
    /// Per stream: the first sequence number seen while its resend had not begun.
    awaiting: PerStream<Option<Option<u64>>>,
    /// Per stream: the sequence number of the last input taken as covered since the last
    /// new one (the resend's mark), to count what is missing after it.
    covered_seq: PerStream<Option<u64>>,
    skipped: u64,
}

impl ResumeFloor {
    /// The floor of a run over `streams` resumed from `checkpoint` (none for a fresh
    /// run).
    pub fn of(checkpoint: Option<&Checkpoint>, streams: &[StreamId]) -> Self {
        let resumed = checkpoint.is_some();
        Self {
            floor: checkpoint.map(|c| PerStream::new(streams, |s| c.processed(s))),
            awaiting: PerStream::new(streams, |_| resumed.then_some(None)),
            covered_seq: PerStream::new(streams, |_| None),
            skipped: 0,
        }
    }

    /// Whether the input `h` on `stream` is new ([`Floor::New`]); counts it as skipped
    /// otherwise.
    pub fn admits(&mut self, stream: StreamId, h: Header) -> Floor {
        let Some(floor) = &self.floor else {
            return Floor::New { lost: 0 };
        };
        let floor = floor[stream];
        let mut mark = false;
        if let Some(first) = self.awaiting[stream] {
            let begun = h.stamp_ns <= floor || first.is_some_and(|f| h.seq < f);
            if begun {
                mark = true;
                self.awaiting[stream] = None;
            } else {
                self.awaiting[stream] = Some(first.or(Some(h.seq)));
                self.skipped += 1;
                return Floor::ComesAgain;
            }
        }
        if h.stamp_ns <= floor {
            self.skipped += 1;
            self.covered_seq[stream] = Some(h.seq);
            Floor::Covered { mark }
        } else {
            let lost = (self.covered_seq[stream].take()).map_or(0, |c| h.seq.saturating_sub(c + 1));
            Floor::New { lost }
        }
    }

    /// True when the checkpoint holds the input stamped `stamp_ns` on `stream`.
    pub fn covers(&self, stream: StreamId, stamp_ns: u64) -> bool {
        self.floor.as_ref().is_some_and(|f| stamp_ns <= f[stream])
    }

    /// Inputs skipped so far.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_estimation::Pose2;
    use fastslam_estimation::fastslam::{FastSlam, FastSlamConfig};

    fn checkpoint() -> Checkpoint {
        let config = FastSlamConfig {
            particles: 5,
            ..FastSlamConfig::default()
        };
        let observation = fastslam_estimation::observation::Observation {
            range: 5.0,
            bearing: 0.1,
            id: None,
        };
        let mut slam = FastSlam::new(config, Pose2::default()).unwrap();
        slam.update(&[observation]).unwrap();
        Checkpoint {
            seed: 7,
            filter: EstimatorState::Landmarks(Box::new(slam.state())),
            last_odometry_ns: Some(900),
            last_odometry_pose: Some(Pose2::new(1.0, 2.0, 0.5)),
            processed_ns: vec![
                (StreamId::Odometry as u32, 900),
                (StreamId::Observations as u32, 1000),
            ],
            steps: 1,
            resamplings: 0,
            last_seq: [Some(0), Some(0), None, Some(0), None, None],
            smoother_feed: Vec::new(),
            noise_check: (NisWindow::new(10), true),
            rejections: [3; REJECTION_KINDS],
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("fastslam-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn a_checkpoint_survives_the_file_round_trip() {
        let path = scratch("roundtrip.ckpt");
        let c = checkpoint();
        assert_eq!(c.filter.landmarks().unwrap().maps[0].landmarks.len(), 1);
        c.write(&path).unwrap();
        assert_eq!(Checkpoint::read(&path).unwrap(), c);
        let mut later = c.clone();
        later.steps = 2;
        later.write(&path).unwrap();
        assert_eq!(Checkpoint::read(&path).unwrap().steps, 2, "replaced");
        let leftover = std::fs::read_dir(path.parent().unwrap())
            .unwrap()
            .any(|e| e.unwrap().file_name().to_string_lossy().ends_with(".tmp"));
        assert!(!leftover, "no temporary file left behind");
        std::fs::remove_file(&path).unwrap();
    }

    #[test]
    fn truncated_or_flipped_files_are_refused_with_their_reason() {
        let bytes = checkpoint().encode();
        let path = Path::new("x.ckpt");
        for cut in [4, 20, bytes.len() - 1] {
            let err = Checkpoint::decode(&bytes[..cut], path).unwrap_err();
            let expected = if cut < MAGIC.len() {
                matches!(err, CheckpointError::NotACheckpoint { .. })
            } else {
                matches!(err, CheckpointError::Truncated { .. })
            };
            assert!(expected, "cut at {cut}: {err}");
        }
        let mut flipped = bytes.clone();
        let last = flipped.len() - 3;
        flipped[last] ^= 0x40;
        let err = Checkpoint::decode(&flipped, path).unwrap_err();
        assert!(err.to_string().contains("corrupt"), "{err}");
        let err = Checkpoint::decode(b"id,x,y\n1,2,3\n", path).unwrap_err();
        assert!(
            matches!(err, CheckpointError::NotACheckpoint { .. }),
            "{err}"
        );
    }

    #[test]
    fn another_format_version_is_refused() {
        let mut bytes = checkpoint().encode();
        bytes[8..12].copy_from_slice(&(FORMAT_VERSION + 1).to_le_bytes());
        let err = Checkpoint::decode(&bytes, Path::new("old.ckpt")).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "checkpoint old.ckpt: format version {}, this build reads version {FORMAT_VERSION}",
                FORMAT_VERSION + 1
            )
        );
    }

    #[test]
    fn the_resume_floor_skips_and_counts_processed_inputs() {
        let h = |seq, stamp_ns| Header { stamp_ns, seq };
        let c = checkpoint();
        let streams = [StreamId::Odometry, StreamId::Observations];
        let mut floor = ResumeFloor::of(Some(&c), &streams);
        let mut admits = |stream, seq, stamp| floor.admits(stream, h(seq, stamp));
        assert_eq!(
            admits(StreamId::Odometry, 12, 1200),
            Floor::ComesAgain,
            "sent before the resend"
        );
        assert_eq!(
            admits(StreamId::Odometry, 9, 900),
            Floor::Covered { mark: true },
            "the resend begins"
        );
        assert_eq!(admits(StreamId::Odometry, 10, 1000), Floor::New { lost: 0 });
        assert_eq!(
            admits(StreamId::Observations, 5, 900),
            Floor::Covered { mark: true }
        );
        assert_eq!(
            admits(StreamId::Observations, 5, 1000),
            Floor::Covered { mark: false },
            "a sensor that started over sends what the checkpoint holds"
        );
        assert_eq!(
            admits(StreamId::Observations, 9, 1400),
            Floor::New { lost: 3 },
            "6, 7 and 8 are missing after the mark"
        );
        assert_eq!(
            admits(StreamId::Observations, 11, 1600),
            Floor::New { lost: 0 }
        );
        assert_eq!(floor.skipped(), 4);
        assert!(
            floor.covers(StreamId::Observations, 1000)
                && !floor.covers(StreamId::Observations, 1001)
        );
        let mut fresh = ResumeFloor::of(None, &streams);
        assert_eq!(
            fresh.admits(StreamId::Odometry, h(0, 0)),
            Floor::New { lost: 0 }
        );
        assert_eq!(fresh.skipped(), 0);
    }
}
