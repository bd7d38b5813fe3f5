//! Puts the inputs of two streams — odometry and the lidar (landmark observations or raw
//! scans) — into one stamp order, so a run is deterministic whatever the process
//! scheduling.
//!
//! Each stream's newest received stamp is its *watermark*: an input is released only
//! when the other stream cannot deliver anything older any more (its queue holds a later
//! input, its watermark has passed, or it has ended). On equal stamps odometry goes
//! first: the filter predicts up to the scan's time, then updates.
//!
//! A stream marked *quiet* (its sensor missed its deadline) is not waited for; an input
//! that then arrives older than what was already released is refused as late. Queues are
//! bounded: beyond the limit the oldest input is dropped. With healthy sensors neither
//! happens, and the order is the deterministic one above. (As fast as possible, the
//! service never pushes into a full queue: it stops taking that stream instead, see
//! [`Sequencer::full`] and [`Sequencer::vouch`].)

use crate::per_input::{PerInput, Stream};
use fastslam_protocol::{LaserScanHeader, Observation, ObservationsHeader, Odometry};
use std::collections::VecDeque;

/// One scan's observations, copied out of shared memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// The message header (stamp, sensor range and field of view).
    pub header: ObservationsHeader,
    /// The observations.
    pub observations: Vec<Observation>,
}

/// One raw scan, copied out of shared memory (validated: the counts match).
#[derive(Debug, Clone, PartialEq)]
pub struct RawScan {
    /// The message header (stamp, beam layout, range limits).
    pub header: LaserScanHeader,
    /// The ranges (m), one per beam; intensities are not kept.
    pub ranges: Vec<f32>,
}

/// An input released in stamp order.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// Odometry over the interval ending at its stamp.
    Odometry(Odometry),
    /// A scan's observations.
    Scan(Scan),
    /// A raw scan (the lidar lane carries observations or raw scans).
    RawScan(RawScan),
}

/// What became of a pushed input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// Queued.
    Queued,
    /// Queued, and the lane's oldest input was dropped to keep it within its limit.
    Overflowed,
    /// Refused: older than inputs already released (possible only after a quiet stream
    /// stopped being waited for).
    Late,
}

/// Where a scan that has just arrived goes: see [`Sequencer::place_scan`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanPlace {
    /// To the filter now, straight from shared memory, after the odometry up to its stamp.
    Direct,
    /// It goes next, but only once odometry has passed its stamp. Until then the caller
    /// may leave it in shared memory and offer it again, or queue it (a copy).
    AwaitOdometry,
    /// Into the queue (a copy): a scan waits before it, a stream is quiet, or it is late
    /// (the push then refuses it).
    Queue,
}

/// Default most inputs waiting per lane.
pub const DEFAULT_MAX_QUEUE: usize = 4096;

/// One stream: waiting inputs, newest stamp seen, and whether it has ended or is quiet.
#[derive(Debug, Clone)]
struct Lane<T> {
    queue: VecDeque<(u64, T)>,
    watermark: Option<u64>,
    released: Option<u64>,
    ended: bool,
    quiet: bool,
}

impl<T> Default for Lane<T> {
    fn default() -> Self {
        Self {
            queue: VecDeque::new(),
            watermark: None,
            released: None,
            ended: false,
            quiet: false,
        }
    }
}

impl<T> Lane<T> {
    fn push(&mut self, stamp: u64, item: T, released: u64, max_queue: usize) -> Pushed {
        if stamp < released {
            return Pushed::Late;
        }
        self.saw(stamp);
        self.queue.push_back((stamp, item));
        if self.queue.len() > max_queue {
            self.queue.pop_front();
            Pushed::Overflowed
        } else {
            Pushed::Queued
        }
    }

    /// Raises the watermark to `stamp`.
    fn saw(&mut self, stamp: u64) {
        self.watermark = Some(self.watermark.map_or(stamp, |w| w.max(stamp)));
    }

    fn head(&self) -> Option<u64> {
        self.queue.front().map(|(t, _)| *t)
    }

    /// True when nothing stamped before `stamp` can still arrive on this stream.
    fn passed(&self, stamp: u64) -> bool {
        self.ended || self.quiet || self.watermark.is_some_and(|w| w >= stamp)
    }

    fn pop(&mut self) -> Option<T> {
        let (stamp, item) = self.queue.pop_front()?;
        self.released = Some(stamp);
        Some(item)
    }
}

/// Merges odometry and scans into stamp order.
///
/// A scan the queue would release at once goes to the filter straight from shared memory
/// ([`Sequencer::place_scan`]); so can a scan that only waits for odometry, if the caller
/// holds its sample meanwhile. Any other is copied out once, into a buffer that is handed
/// back with [`Sequencer::recycle`] after the filter has used it: in steady state no step
/// allocates. (The copy releases the sample at once, so a publisher never waits on the
/// filter for it, and a scan can wait here behind others or for a quiet stream.)
#[derive(Debug, Clone)]
pub struct Sequencer {
    /// The odometry lane holds [`Input::Odometry`]; the lidar lane [`Input::Scan`] or
    /// [`Input::RawScan`].
    lanes: PerInput<Lane<Input>>,
    /// Emptied observation buffers, ready for the next scan.
    spare_observations: Vec<Vec<Observation>>,
    /// Emptied range buffers, ready for the next raw scan.
    spare_ranges: Vec<Vec<f32>>,
    max_queue: usize,
}

impl Default for Sequencer {
    fn default() -> Self {
        Self::new(DEFAULT_MAX_QUEUE)
    }
}

impl Sequencer {
    /// A sequencer holding at most `max_queue` inputs per stream.
    pub fn new(max_queue: usize) -> Self {
        Self {
            lanes: PerInput::default(),
            spare_observations: Vec::new(),
            spare_ranges: Vec::new(),
            max_queue: max_queue.max(1),
        }
    }

    /// Queues an odometry message (stamps of one stream must not decrease; the caller
    /// validates that).
    pub fn push_odometry(&mut self, m: Odometry) -> Pushed {
        self.push(Stream::Odometry, m.header.stamp_ns, Input::Odometry(m))
    }

    /// Queues a scan's observations.
    pub fn push_scan(&mut self, s: Scan) -> Pushed {
        self.push(Stream::Lidar, s.header.header.stamp_ns, Input::Scan(s))
    }

    /// Queues a raw scan (on the same lane as observations: one lidar stream).
    pub fn push_raw_scan(&mut self, s: RawScan) -> Pushed {
        self.push(Stream::Lidar, s.header.header.stamp_ns, Input::RawScan(s))
    }

    fn push(&mut self, stream: Stream, stamp: u64, input: Input) -> Pushed {
        let released = self.newest_released();
        self.lanes[stream].push(stamp, input, released, self.max_queue)
    }

    /// True when `stream`'s queue holds its limit of inputs: the next push drops its
    /// oldest.
    pub fn full(&self, stream: Stream) -> bool {
        self.lanes[stream].queue.len() >= self.max_queue
    }

    /// Takes the other stream as having passed `stream`'s newest stamp, so `stream`'s
    /// queue can be released: what a publisher that sends both streams in stamp order
    /// (one thread) guarantees once the other stream has nothing waiting. An input of the
    /// other stream older than that which arrives after all is refused as late.
    pub fn vouch(&mut self, stream: Stream) {
        if let Some(stamp) = self.lanes[stream].watermark {
            self.lanes[stream.other()].saw(stamp);
        }
    }

    /// Marks `stream` quiet (its sensor missed its deadline: the other stream stops
    /// waiting for it) or back.
    pub fn set_quiet(&mut self, stream: Stream, quiet: bool) {
        self.lanes[stream].quiet = quiet;
    }

    /// Whether each stream is quiet.
    pub fn quiet(&self) -> PerInput<bool> {
        self.lanes.as_ref().map(|lane| lane.quiet)
    }

    /// A copy of `observations` in a recycled buffer (allocates only when none is spare).
    pub fn copy_observations(&mut self, observations: &[Observation]) -> Vec<Observation> {
        let mut buffer = self.spare_observations.pop().unwrap_or_default();
        buffer.extend_from_slice(observations);
        buffer
    }

    /// A copy of `ranges` in a recycled buffer (allocates only when none is spare).
    pub fn copy_ranges(&mut self, ranges: &[f32]) -> Vec<f32> {
        let mut buffer = self.spare_ranges.pop().unwrap_or_default();
        buffer.extend_from_slice(ranges);
        buffer
    }

    /// Takes back a released input's buffer for a later scan.
    pub fn recycle(&mut self, input: Input) {
        match input {
            Input::Odometry(_) => {}
            Input::Scan(mut s) => {
                s.observations.clear();
                self.spare_observations.push(s.observations);
            }
            Input::RawScan(mut s) => {
                s.ranges.clear();
                self.spare_ranges.push(s.ranges);
            }
        }
    }

    /// The odometry stream has ended: nothing more will come.
    pub fn end_odometry(&mut self) {
        self.lanes.odometry.ended = true;
    }

    /// The lidar stream has ended.
    pub fn end_scans(&mut self) {
        self.lanes.lidar.ended = true;
    }

    /// Where a scan stamped `stamp` that has just arrived goes ([`ScanPlace`]).
    ///
    /// It is [`ScanPlace::Direct`] when the queue would release it right after the
    /// odometry up to its stamp ([`Sequencer::odometry_through`]): no scan waits before
    /// it, it is not late, neither stream is quiet, and odometry has passed `stamp`.
    /// [`Sequencer::took_directly`] then books it. If all of that holds but odometry has
    /// not passed `stamp` yet, it is [`ScanPlace::AwaitOdometry`].
    pub fn place_scan(&self, stamp: u64) -> ScanPlace {
        let PerInput { odometry, lidar } = &self.lanes;
        let next = lidar.queue.is_empty()
            && !lidar.quiet
            && !odometry.quiet
            && stamp >= self.newest_released();
        match (next, odometry.passed(stamp)) {
            (true, true) => ScanPlace::Direct,
            (true, false) => ScanPlace::AwaitOdometry,
            (false, _) => ScanPlace::Queue,
        }
    }

    /// The next odometry ([`Input::Odometry`]) stamped at or before `stamp`, to apply
    /// before a scan taken directly.
    pub fn odometry_through(&mut self, stamp: u64) -> Option<Input> {
        let odometry = &mut self.lanes.odometry;
        odometry
            .head()
            .is_some_and(|o| o <= stamp)
            .then(|| odometry.pop())
            .flatten()
    }

    /// Books a scan stamped `stamp` that went to the filter directly, as if it had been
    /// queued and released.
    pub fn took_directly(&mut self, stamp: u64) {
        self.lanes.lidar.saw(stamp);
        self.lanes.lidar.released = Some(stamp);
    }

    /// Newest stamp released on either stream (0 before the first): anything older that
    /// arrives now is late.
    fn newest_released(&self) -> u64 {
        let PerInput { odometry, lidar } = &self.lanes;
        odometry.released.max(lidar.released).unwrap_or(0)
    }

    /// The next input in stamp order, if it can be released now.
    pub fn release(&mut self) -> Option<Input> {
        let PerInput { odometry, lidar } = &self.lanes;
        let next = match (odometry.head(), lidar.head()) {
            (Some(o), Some(s)) if o <= s => Stream::Odometry,
            (Some(_), Some(_)) => Stream::Lidar,
            (Some(o), None) if lidar.passed(o) => Stream::Odometry,
            (None, Some(s)) if odometry.passed(s) => Stream::Lidar,
            _ => return None,
        };
        self.lanes[next].pop()
    }

    /// Inputs waiting per stream.
    pub fn queued(&self) -> PerInput<u32> {
        self.lanes.as_ref().map(|lane| lane.queue.len() as u32)
    }

    /// Newest stamp received per stream, 0 before the first.
    pub fn watermarks(&self) -> PerInput<u64> {
        self.lanes.as_ref().map(|lane| lane.watermark.unwrap_or(0))
    }

    /// Stamp of the last input released per stream, 0 before the first.
    pub fn released(&self) -> PerInput<u64> {
        self.lanes.as_ref().map(|lane| lane.released.unwrap_or(0))
    }

    /// True when both streams have ended and everything was released.
    pub fn finished(&self) -> bool {
        self.lanes
            .iter()
            .all(|(_, lane)| lane.ended && lane.queue.is_empty())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fastslam_protocol::Header;

    fn odo(t: u64) -> Odometry {
        Odometry {
            header: Header {
                stamp_ns: t,
                seq: t,
            },
            ..Default::default()
        }
    }

    fn scan(t: u64) -> Scan {
        let header = ObservationsHeader {
            header: Header {
                stamp_ns: t,
                seq: t,
            },
            ..Default::default()
        };
        Scan {
            header,
            observations: Vec::new(),
        }
    }

    /// The kind and stamp of an input.
    fn stamp(input: Input) -> (char, u64) {
        match input {
            Input::Odometry(o) => ('o', o.header.stamp_ns),
            Input::Scan(s) => ('s', s.header.header.stamp_ns),
            Input::RawScan(s) => ('r', s.header.header.stamp_ns),
        }
    }

    fn stamps(seq: &mut Sequencer) -> Vec<(char, u64)> {
        std::iter::from_fn(|| seq.release()).map(stamp).collect()
    }

    #[test]
    fn a_full_queue_vouched_for_releases_in_stamp_order_and_a_tie_is_not_late() {
        let mut seq = Sequencer::new(3);
        for t in [10, 20, 30] {
            assert_eq!(seq.push_odometry(odo(t)), Pushed::Queued);
        }
        assert!(seq.full(Stream::Odometry));
        assert_eq!(stamps(&mut seq), [], "the lidar may still bring 15");
        seq.vouch(Stream::Odometry);
        assert_eq!(stamps(&mut seq), [('o', 10), ('o', 20), ('o', 30)]);
        assert!(!seq.full(Stream::Odometry));
        // A scan stamped as the newest odometry was sent after it (odometry first).
        assert_eq!(seq.push_scan(scan(30)), Pushed::Queued);
        assert_eq!(seq.push_scan(scan(25)), Pushed::Late);
    }

    #[test]
    fn a_scan_is_taken_directly_only_where_the_queue_would_release_it_next() {
        let mut seq = Sequencer::default();
        seq.push_odometry(odo(10));
        assert_eq!(
            seq.place_scan(20),
            ScanPlace::AwaitOdometry,
            "odometry may still bring 15"
        );
        seq.push_odometry(odo(20));
        seq.push_odometry(odo(30));
        assert_eq!(seq.place_scan(20), ScanPlace::Direct);
        let through: Vec<(char, u64)> = std::iter::from_fn(|| seq.odometry_through(20))
            .map(stamp)
            .collect();
        assert_eq!(
            through,
            [('o', 10), ('o', 20)],
            "odometry up to the scan's stamp, odometry first"
        );
        seq.took_directly(20);
        assert_eq!(
            seq.released(),
            PerInput {
                odometry: 20,
                lidar: 20
            }
        );
        assert_eq!(
            stamps(&mut seq),
            vec![],
            "odometry 30 waits for the next scan"
        );
        assert_eq!(
            seq.place_scan(15),
            ScanPlace::Queue,
            "late: 20 was released"
        );
        seq.set_quiet(Stream::Odometry, true);
        assert_eq!(
            seq.place_scan(40),
            ScanPlace::Queue,
            "nothing waits for a quiet stream"
        );
        seq.set_quiet(Stream::Odometry, false);
        assert_eq!(seq.place_scan(40), ScanPlace::AwaitOdometry);
        seq.push_scan(scan(40));
        assert_eq!(
            seq.place_scan(50),
            ScanPlace::Queue,
            "a queued scan goes first"
        );
    }

    #[test]
    fn a_scan_waits_for_odometry_up_to_its_stamp() {
        let mut seq = Sequencer::default();
        seq.push_scan(scan(20));
        seq.push_odometry(odo(10));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 10)],
            "scan 20 must wait: odometry may still bring 15"
        );
        seq.push_odometry(odo(20));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 20), ('s', 20)],
            "equal stamps: odometry first"
        );
        assert_eq!(
            seq.released(),
            PerInput {
                odometry: 20,
                lidar: 20
            }
        );
    }

    #[test]
    fn odometry_waits_for_a_late_scan() {
        let mut seq = Sequencer::default();
        seq.push_odometry(odo(10));
        seq.push_odometry(odo(30));
        seq.push_scan(scan(5));
        assert_eq!(
            stamps(&mut seq),
            vec![('s', 5)],
            "odometry 10 waits: a scan at 8 may come"
        );
        seq.push_scan(scan(20));
        assert_eq!(stamps(&mut seq), vec![('o', 10), ('s', 20)]);
        seq.end_scans();
        assert_eq!(stamps(&mut seq), vec![('o', 30)]);
        assert!(!seq.finished());
        seq.end_odometry();
        assert!(seq.finished());
    }

    #[test]
    fn recycled_buffers_are_reused_for_later_scans() {
        let mut seq = Sequencer::default();
        let obs = Observation {
            range: 5.0,
            ..Default::default()
        };
        let first = seq.copy_observations(&[obs; 3]);
        let storage = first.as_ptr();
        seq.push_scan(Scan {
            header: scan(10).header,
            observations: first,
        });
        seq.end_odometry();
        let input = seq.release().unwrap();
        seq.recycle(input);
        let second = seq.copy_observations(&[obs]);
        assert_eq!(second, vec![obs]);
        assert_eq!(
            second.as_ptr(),
            storage,
            "the same buffer, no new allocation"
        );
        let ranges = seq.copy_ranges(&[1.0, 2.0]);
        assert_eq!(ranges, vec![1.0, 2.0]);
    }

    #[test]
    fn raw_scans_share_the_lidar_lane() {
        let mut seq = Sequencer::default();
        let raw = |t: u64| RawScan {
            header: LaserScanHeader {
                header: Header {
                    stamp_ns: t,
                    seq: t,
                },
                ..Default::default()
            },
            ranges: vec![1.0],
        };
        seq.push_raw_scan(raw(15));
        seq.push_odometry(odo(10));
        seq.push_odometry(odo(20));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 10), ('r', 15)],
            "odometry 20 waits: a scan at 18 may come"
        );
        seq.end_scans();
        assert_eq!(stamps(&mut seq), vec![('o', 20)]);
    }

    #[test]
    fn a_quiet_lane_is_not_waited_for_and_late_inputs_are_refused() {
        let mut seq = Sequencer::default();
        seq.push_scan(scan(5));
        seq.push_odometry(odo(10));
        seq.push_odometry(odo(20));
        assert_eq!(stamps(&mut seq), vec![('s', 5)], "waits for the lidar");
        seq.set_quiet(Stream::Lidar, true);
        assert_eq!(stamps(&mut seq), vec![('o', 10), ('o', 20)]);
        assert_eq!(seq.push_scan(scan(15)), Pushed::Late);
        seq.set_quiet(Stream::Lidar, false);
        assert_eq!(seq.push_scan(scan(25)), Pushed::Queued);
        seq.set_quiet(Stream::Odometry, true);
        assert_eq!(stamps(&mut seq), vec![('s', 25)], "no wait for odometry");
    }

    #[test]
    fn a_full_queue_drops_its_oldest_input() {
        let mut seq = Sequencer::new(2);
        assert_eq!(seq.push_odometry(odo(1)), Pushed::Queued);
        assert_eq!(seq.push_odometry(odo(2)), Pushed::Queued);
        assert_eq!(seq.push_odometry(odo(3)), Pushed::Overflowed);
        assert_eq!(
            seq.queued(),
            PerInput {
                odometry: 2,
                lidar: 0
            }
        );
        seq.end_scans();
        assert_eq!(stamps(&mut seq), vec![('o', 2), ('o', 3)]);
    }

    #[test]
    fn arrival_interleaving_does_not_change_the_output_order() {
        // Each stream arrives in its own order; only the interleaving of the two varies.
        let odos: Vec<Input> = (1..=12).map(|k| Input::Odometry(odo(k * 10))).collect();
        let scans: Vec<Input> = (1..=3).map(|k| Input::Scan(scan(k * 40))).collect();
        let run = |order: Vec<&Input>| {
            let mut seq = Sequencer::default();
            let mut out = Vec::new();
            for input in order {
                let pushed = match input.clone() {
                    Input::Odometry(o) => seq.push_odometry(o),
                    Input::Scan(s) => seq.push_scan(s),
                    Input::RawScan(s) => seq.push_raw_scan(s),
                };
                assert_eq!(pushed, Pushed::Queued);
                out.extend(stamps(&mut seq));
            }
            seq.end_odometry();
            seq.end_scans();
            out.extend(stamps(&mut seq));
            out
        };
        let odo_first = run(odos.iter().chain(&scans).collect());
        let scans_first = run(scans.iter().chain(&odos).collect());
        let alternating = run(odos
            .iter()
            .zip(&scans)
            .flat_map(|(a, b)| [a, b])
            .chain(odos.iter().skip(3))
            .collect());
        assert_eq!(scans_first, odo_first);
        assert_eq!(alternating, odo_first);
        assert_eq!(odo_first.len(), 15);
        let times: Vec<u64> = odo_first.iter().map(|(_, t)| *t).collect();
        assert!(times.windows(2).all(|w| w[0] <= w[1]), "{odo_first:?}");
        let scan_40 = odo_first.iter().position(|&e| e == ('s', 40)).unwrap();
        assert_eq!(
            odo_first[scan_40 - 1],
            ('o', 40),
            "odometry at the scan's stamp comes first"
        );
    }
}
