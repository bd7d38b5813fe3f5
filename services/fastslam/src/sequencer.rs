//! Puts the inputs of any number of streams — odometry and the lidar (landmark
//! observations or raw scans) in the service — into one stamp order, so a run is
//! deterministic whatever the process scheduling.
//!
//! Each stream is a *lane*, keyed by its [`StreamId`] and registered in a fixed order.
//! Each lane's newest received stamp is its *watermark*: an input is released only when
//! no other lane can deliver anything older any more (its queue holds a later input, its
//! watermark has passed, or it has ended). On equal stamps the lane registered first goes
//! first: with odometry first, the filter predicts up to the scan's time, then updates.
//!
//! A lane marked *quiet* (its sensor missed its deadline) is not waited for; an input
//! that then arrives older than what was already released is refused as late. Queues are
//! bounded: beyond the limit the oldest input is dropped. With healthy sensors neither
//! happens, and the order is the deterministic one above. (As fast as possible, the
//! service never pushes into a full queue: it stops taking that stream instead, see
//! [`Sequencer::full`] and [`Sequencer::vouch`].)

use crate::per_stream::PerStream;
use fastslam_protocol::message::Owned;
use fastslam_protocol::{
    LaserScanHeader, Observation, ObservationsHeader, Odometry, StreamId, StreamStatus,
};
use std::collections::VecDeque;

/// One scan's observations, copied out of shared memory (`items`: the observations).
pub type Scan = Owned<ObservationsHeader>;

/// One raw scan, copied out of shared memory and validated (`items`: the ranges (m), one
/// per beam; intensities are not kept).
pub type RawScan = Owned<LaserScanHeader>;

/// An input released in stamp order: one variant per message type a lane carries.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// Odometry over the interval ending at its stamp.
    Odometry(Odometry),
    /// A scan's observations.
    Scan(Scan),
    /// A raw scan.
    RawScan(RawScan),
}

impl Input {
    /// The stream it arrives on.
    pub fn stream(&self) -> StreamId {
        match self {
            Self::Odometry(_) => StreamId::Odometry,
            Self::Scan(_) => StreamId::Observations,
            Self::RawScan(_) => StreamId::Scan,
        }
    }

    /// Its stamp (ns).
    pub fn stamp_ns(&self) -> u64 {
        match self {
            Self::Odometry(m) => m.header.stamp_ns,
            Self::Scan(s) => s.header.header.stamp_ns,
            Self::RawScan(s) => s.header.header.stamp_ns,
        }
    }
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

/// Where an input that has just arrived goes: see [`Sequencer::place`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// To the filter now, straight from shared memory, after the other lanes' inputs the
    /// order puts before it ([`Sequencer::before`]).
    Direct,
    /// It goes next, but only once every other lane has passed its stamp. Until then the
    /// caller may leave it in shared memory and offer it again, or queue it (a copy).
    AwaitOthers,
    /// Into the queue (a copy): an input waits before it on its lane, a lane is quiet, or
    /// it is late (the push then refuses it).
    Queue,
}

/// Default most inputs waiting per lane (`[input] max_queue`).
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

/// Merges the lanes' inputs into stamp order.
///
/// An input the queue would release at once goes to the filter straight from shared
/// memory ([`Sequencer::place`]); so can one that only waits for the other lanes, if the
/// caller holds its sample meanwhile. Any other is copied out once, into a buffer that
/// is handed back with [`Sequencer::recycle`] after the filter has used it: in steady
/// state no step allocates. (The copy releases the sample at once, so a publisher never
/// waits on the filter for it, and an input can wait here behind others or for a quiet
/// stream.)
#[derive(Debug, Clone)]
pub struct Sequencer {
    /// One lane per registered stream, each holding the [`Input`]s of its stream.
    lanes: PerStream<Lane<Input>>,
    /// Emptied observation buffers, ready for the next scan.
    spare_observations: Vec<Vec<Observation>>,
    /// Emptied range buffers, ready for the next raw scan.
    spare_ranges: Vec<Vec<f32>>,
    max_queue: usize,
}

impl Sequencer {
    /// A sequencer of `streams` (in tie-breaking order: the first goes first on equal
    /// stamps) holding at most `max_queue` inputs per stream.
    pub fn new(streams: &[StreamId], max_queue: usize) -> Self {
        Self {
            lanes: PerStream::new(streams, |_| Lane::default()),
            spare_observations: Vec::new(),
            spare_ranges: Vec::new(),
            max_queue: max_queue.max(1),
        }
    }

    /// Queues `input` on its stream's lane (stamps of one stream must not decrease; the
    /// caller validates that).
    ///
    /// # Panics
    /// When its stream is not registered.
    pub fn push(&mut self, input: Input) -> Pushed {
        let released = self.newest_released();
        let (stream, stamp) = (input.stream(), input.stamp_ns());
        self.lanes[stream].push(stamp, input, released, self.max_queue)
    }

    /// True when `stream`'s queue holds its limit of inputs: the next push drops its
    /// oldest.
    pub fn full(&self, stream: StreamId) -> bool {
        self.lanes[stream].queue.len() >= self.max_queue
    }

    /// Takes every other lane as having passed `stream`'s newest stamp, so `stream`'s
    /// queue can be released: what a publisher that sends its streams in stamp order
    /// (one thread) guarantees once the other streams have nothing waiting. An input of
    /// another stream older than that which arrives after all is refused as late.
    pub fn vouch(&mut self, stream: StreamId) {
        if let Some(stamp) = self.lanes[stream].watermark {
            for (_, lane) in self.lanes.iter_mut().filter(|(s, _)| *s != stream) {
                lane.saw(stamp);
            }
        }
    }

    /// Marks `stream` quiet (its sensor missed its deadline: the other streams stop
    /// waiting for it) or back.
    pub fn set_quiet(&mut self, stream: StreamId, quiet: bool) {
        self.lanes[stream].quiet = quiet;
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
                s.items.clear();
                self.spare_observations.push(s.items);
            }
            Input::RawScan(mut s) => {
                s.items.clear();
                self.spare_ranges.push(s.items);
            }
        }
    }

    /// `stream` has ended: nothing more will come on it.
    pub fn end(&mut self, stream: StreamId) {
        self.lanes[stream].ended = true;
    }

    /// Where an input of `stream` stamped `stamp` that has just arrived goes ([`Place`]).
    ///
    /// It is [`Place::Direct`] when the queue would release it right after the other
    /// lanes' inputs up to its stamp ([`Sequencer::before`]): nothing waits before it on
    /// its lane, it is not late, no lane is quiet, and every other lane has passed
    /// `stamp`. [`Sequencer::took_directly`] then books it. If all of that holds but a
    /// lane has not passed `stamp` yet, it is [`Place::AwaitOthers`].
    pub fn place(&self, stream: StreamId, stamp: u64) -> Place {
        let next = self.lanes[stream].queue.is_empty()
            && self.lanes.iter().all(|(_, lane)| !lane.quiet)
            && stamp >= self.newest_released();
        let others_passed = (self.lanes.iter())
            .filter(|(s, _)| *s != stream)
            .all(|(_, lane)| lane.passed(stamp));
        match (next, others_passed) {
            (true, true) => Place::Direct,
            (true, false) => Place::AwaitOthers,
            (false, _) => Place::Queue,
        }
    }

    /// The next queued input of another lane that the order puts before an input of
    /// `stream` stamped `stamp` (at or before it; on an equal stamp, from a lane
    /// registered earlier), to apply before that input when it is taken directly.
    pub fn before(&mut self, stream: StreamId, stamp: u64) -> Option<Input> {
        let rank = self.lanes.streams().position(|s| s == stream)?;
        let (k, head) = self.next_head(|s| s != stream)?;
        let first = head < stamp || (head == stamp && k < rank);
        first.then(|| self.pop_lane(k)).flatten()
    }

    /// Books an input of `stream` stamped `stamp` that went to the filter directly, as if
    /// it had been queued and released.
    pub fn took_directly(&mut self, stream: StreamId, stamp: u64) {
        let lane = &mut self.lanes[stream];
        lane.saw(stamp);
        lane.released = Some(stamp);
    }

    /// Newest stamp released on any lane (0 before the first): anything older that
    /// arrives now is late.
    fn newest_released(&self) -> u64 {
        (self.lanes.iter())
            .filter_map(|(_, lane)| lane.released)
            .max()
            .unwrap_or(0)
    }

    /// The lane (by registration rank) whose head goes first among the lanes `keep`
    /// admits, and that head's stamp: the oldest, the earliest registered on a tie.
    fn next_head(&self, keep: impl Fn(StreamId) -> bool) -> Option<(usize, u64)> {
        (self.lanes.iter().enumerate())
            .filter(|(_, (s, _))| keep(*s))
            .filter_map(|(k, (_, lane))| lane.head().map(|h| (k, h)))
            .min_by_key(|&(k, h)| (h, k))
    }

    /// Pops the head of the lane of rank `k`.
    fn pop_lane(&mut self, k: usize) -> Option<Input> {
        self.lanes
            .iter_mut()
            .nth(k)
            .and_then(|(_, lane)| lane.pop())
    }

    /// The next input in stamp order, if it can be released now: the oldest head, once
    /// every lane with nothing queued has passed its stamp.
    pub fn release(&mut self) -> Option<Input> {
        let (k, head) = self.next_head(|_| true)?;
        let waits =
            (self.lanes.iter()).any(|(_, lane)| lane.queue.is_empty() && !lane.passed(head));
        if waits { None } else { self.pop_lane(k) }
    }

    /// Each lane's state as the status reports it, in registration order.
    pub fn lanes(&self) -> impl Iterator<Item = StreamStatus> + '_ {
        self.lanes.iter().map(|(stream, lane)| StreamStatus {
            stream: stream as u32,
            queued: lane.queue.len() as u32,
            last_input_ns: lane.watermark.unwrap_or(0),
            quiet: u32::from(lane.quiet),
            reserved: 0,
        })
    }

    /// Stamp of the last input released per stream, 0 before the first.
    pub fn released(&self) -> PerStream<u64> {
        self.lanes.map(|lane| lane.released.unwrap_or(0))
    }

    /// True when every stream has ended and everything was released.
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
            items: Vec::new(),
        }
    }

    /// A raw scan of one beam.
    fn raw(t: u64) -> RawScan {
        let header = LaserScanHeader {
            header: Header {
                stamp_ns: t,
                seq: t,
            },
            ..Default::default()
        };
        RawScan {
            header,
            items: vec![1.0],
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

    /// The service's two lanes: odometry, then observations.
    fn two(max_queue: usize) -> Sequencer {
        Sequencer::new(&[ODO, OBS], max_queue)
    }

    const ODO: StreamId = StreamId::Odometry;
    const OBS: StreamId = StreamId::Observations;

    /// Released stamp per lane, in registration order.
    fn released(seq: &Sequencer) -> Vec<u64> {
        seq.released().iter().map(|(_, &t)| t).collect()
    }

    fn stamps(seq: &mut Sequencer) -> Vec<(char, u64)> {
        std::iter::from_fn(|| seq.release()).map(stamp).collect()
    }

    #[test]
    fn a_full_queue_vouched_for_releases_in_stamp_order_and_a_tie_is_not_late() {
        let mut seq = two(3);
        for t in [10, 20, 30] {
            assert_eq!(seq.push(Input::Odometry(odo(t))), Pushed::Queued);
        }
        assert!(seq.full(ODO));
        assert_eq!(stamps(&mut seq), [], "the lidar may still bring 15");
        seq.vouch(ODO);
        assert_eq!(stamps(&mut seq), [('o', 10), ('o', 20), ('o', 30)]);
        assert!(!seq.full(ODO));
        // A scan stamped as the newest odometry was sent after it (odometry first).
        assert_eq!(seq.push(Input::Scan(scan(30))), Pushed::Queued);
        assert_eq!(seq.push(Input::Scan(scan(25))), Pushed::Late);
    }

    #[test]
    fn a_scan_is_taken_directly_only_where_the_queue_would_release_it_next() {
        let mut seq = two(DEFAULT_MAX_QUEUE);
        seq.push(Input::Odometry(odo(10)));
        assert_eq!(
            seq.place(OBS, 20),
            Place::AwaitOthers,
            "odometry may still bring 15"
        );
        seq.push(Input::Odometry(odo(20)));
        seq.push(Input::Odometry(odo(30)));
        assert_eq!(seq.place(OBS, 20), Place::Direct);
        let through: Vec<(char, u64)> = std::iter::from_fn(|| seq.before(OBS, 20))
            .map(stamp)
            .collect();
        assert_eq!(
            through,
            [('o', 10), ('o', 20)],
            "odometry up to the scan's stamp, odometry first"
        );
        seq.took_directly(OBS, 20);
        assert_eq!(released(&seq), [20, 20]);
        assert_eq!(
            stamps(&mut seq),
            vec![],
            "odometry 30 waits for the next scan"
        );
        assert_eq!(seq.place(OBS, 15), Place::Queue, "late: 20 was released");
        seq.set_quiet(ODO, true);
        assert_eq!(
            seq.place(OBS, 40),
            Place::Queue,
            "nothing waits for a quiet stream"
        );
        seq.set_quiet(ODO, false);
        assert_eq!(seq.place(OBS, 40), Place::AwaitOthers);
        seq.push(Input::Scan(scan(40)));
        assert_eq!(seq.place(OBS, 50), Place::Queue, "a queued scan goes first");
    }

    #[test]
    fn a_scan_waits_for_odometry_up_to_its_stamp() {
        let mut seq = two(DEFAULT_MAX_QUEUE);
        seq.push(Input::Scan(scan(20)));
        seq.push(Input::Odometry(odo(10)));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 10)],
            "scan 20 must wait: odometry may still bring 15"
        );
        seq.push(Input::Odometry(odo(20)));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 20), ('s', 20)],
            "equal stamps: odometry first"
        );
        assert_eq!(released(&seq), [20, 20]);
    }

    #[test]
    fn odometry_waits_for_a_late_scan() {
        let mut seq = two(DEFAULT_MAX_QUEUE);
        seq.push(Input::Odometry(odo(10)));
        seq.push(Input::Odometry(odo(30)));
        seq.push(Input::Scan(scan(5)));
        assert_eq!(
            stamps(&mut seq),
            vec![('s', 5)],
            "odometry 10 waits: a scan at 8 may come"
        );
        seq.push(Input::Scan(scan(20)));
        assert_eq!(stamps(&mut seq), vec![('o', 10), ('s', 20)]);
        seq.end(OBS);
        assert_eq!(stamps(&mut seq), vec![('o', 30)]);
        assert!(!seq.finished());
        seq.end(ODO);
        assert!(seq.finished());
    }

    #[test]
    fn recycled_buffers_are_reused_for_later_scans() {
        let mut seq = two(DEFAULT_MAX_QUEUE);
        let obs = Observation {
            range: 5.0,
            ..Default::default()
        };
        let first = seq.copy_observations(&[obs; 3]);
        let storage = first.as_ptr();
        seq.push(Input::Scan(Scan {
            header: scan(10).header,
            items: first,
        }));
        seq.end(ODO);
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
    fn raw_scans_go_on_their_own_lane() {
        let mut seq = Sequencer::new(&[ODO, StreamId::Scan], DEFAULT_MAX_QUEUE);
        seq.push(Input::RawScan(raw(15)));
        seq.push(Input::Odometry(odo(10)));
        seq.push(Input::Odometry(odo(20)));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 10), ('r', 15)],
            "odometry 20 waits: a scan at 18 may come"
        );
        seq.end(StreamId::Scan);
        assert_eq!(stamps(&mut seq), vec![('o', 20)]);
    }

    #[test]
    fn a_quiet_lane_is_not_waited_for_and_late_inputs_are_refused() {
        let mut seq = two(DEFAULT_MAX_QUEUE);
        seq.push(Input::Scan(scan(5)));
        seq.push(Input::Odometry(odo(10)));
        seq.push(Input::Odometry(odo(20)));
        assert_eq!(stamps(&mut seq), vec![('s', 5)], "waits for the lidar");
        seq.set_quiet(OBS, true);
        assert_eq!(stamps(&mut seq), vec![('o', 10), ('o', 20)]);
        assert_eq!(seq.push(Input::Scan(scan(15))), Pushed::Late);
        seq.set_quiet(OBS, false);
        assert_eq!(seq.push(Input::Scan(scan(25))), Pushed::Queued);
        seq.set_quiet(ODO, true);
        assert_eq!(stamps(&mut seq), vec![('s', 25)], "no wait for odometry");
    }

    #[test]
    fn a_full_queue_drops_its_oldest_input() {
        let mut seq = two(2);
        assert_eq!(seq.push(Input::Odometry(odo(1))), Pushed::Queued);
        assert_eq!(seq.push(Input::Odometry(odo(2))), Pushed::Queued);
        assert_eq!(seq.push(Input::Odometry(odo(3))), Pushed::Overflowed);
        let queued: Vec<u32> = seq.lanes().map(|lane| lane.queued).collect();
        assert_eq!(queued, [2, 0]);
        seq.end(OBS);
        assert_eq!(stamps(&mut seq), vec![('o', 2), ('o', 3)]);
    }

    #[test]
    fn arrival_interleaving_does_not_change_the_output_order() {
        // Each stream arrives in its own order; only the interleaving of the two varies.
        let odos: Vec<Input> = (1..=12).map(|k| Input::Odometry(odo(k * 10))).collect();
        let scans: Vec<Input> = (1..=3).map(|k| Input::Scan(scan(k * 40))).collect();
        let run = |order: Vec<&Input>| {
            let mut seq = two(DEFAULT_MAX_QUEUE);
            let mut out = Vec::new();
            for input in order {
                assert_eq!(seq.push(input.clone()), Pushed::Queued);
                out.extend(stamps(&mut seq));
            }
            seq.end(ODO);
            seq.end(OBS);
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

    #[test]
    fn a_third_lane_is_merged_in_stamp_order_and_waited_for() {
        // A test-only third stream: a second laser publishing raw scans beside the
        // observations. Registration order breaks ties: odometry, observations, scans.
        let mut seq = Sequencer::new(&[ODO, OBS, StreamId::Scan], DEFAULT_MAX_QUEUE);
        seq.push(Input::RawScan(raw(20)));
        seq.push(Input::Scan(scan(20)));
        seq.push(Input::Odometry(odo(10)));
        assert_eq!(stamps(&mut seq), vec![('o', 10)], "odometry may bring 15");
        seq.push(Input::Odometry(odo(20)));
        seq.push(Input::Odometry(odo(30)));
        assert_eq!(
            stamps(&mut seq),
            vec![('o', 20), ('s', 20), ('r', 20)],
            "equal stamps in registration order"
        );
        seq.push(Input::Scan(scan(40)));
        assert_eq!(stamps(&mut seq), vec![], "the scan lane may bring 25");
        assert_eq!(
            seq.place(StreamId::Scan, 35),
            Place::AwaitOthers,
            "odometry may bring 32"
        );
        seq.push(Input::Odometry(odo(40)));
        assert_eq!(seq.place(StreamId::Scan, 35), Place::Direct);
        let before: Vec<_> = std::iter::from_fn(|| seq.before(StreamId::Scan, 35))
            .map(stamp)
            .collect();
        assert_eq!(
            before,
            [('o', 30)],
            "odometry and observations at 40 come after"
        );
        seq.took_directly(StreamId::Scan, 35);
        assert_eq!(stamps(&mut seq), vec![], "the scan lane may bring 38");
        seq.end(StreamId::Scan);
        assert_eq!(stamps(&mut seq), vec![('o', 40), ('s', 40)]);
        seq.end(ODO);
        seq.end(OBS);
        assert!(seq.finished());
        assert_eq!(released(&seq), [40, 40, 35]);
    }
}
