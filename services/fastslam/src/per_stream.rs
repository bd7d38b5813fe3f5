//! The service's input streams, keyed by the wire's [`StreamId`], and one value per
//! stream.
//!
//! Every per-stream piece of state — queues, watermarks, stream checks, deadlines, stream
//! ends, a checkpoint's processed stamps — is a [`PerStream`]: one value for each stream
//! the service registered, in registration order. The order matters once: on equal
//! stamps, the stream registered first goes first (odometry before the lidar, so the
//! filter predicts up to a scan's time before it updates).

use fastslam_protocol::StreamId;
use std::ops::{Index, IndexMut};

/// A value per registered input stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PerStream<T> {
    entries: Vec<(StreamId, T)>,
}

impl<T> PerStream<T> {
    /// The value `f` gives for each of `streams`, in that order.
    ///
    /// # Panics
    /// When a stream is listed twice.
    pub fn new(streams: &[StreamId], mut f: impl FnMut(StreamId) -> T) -> Self {
        for (k, s) in streams.iter().enumerate() {
            assert!(!streams[..k].contains(s), "stream {s:?} registered twice");
        }
        Self {
            entries: streams.iter().map(|&s| (s, f(s))).collect(),
        }
    }

    /// The value of `stream`, if it is registered.
    pub fn get(&self, stream: StreamId) -> Option<&T> {
        self.entries
            .iter()
            .find(|(s, _)| *s == stream)
            .map(|(_, v)| v)
    }

    /// The streams, in registration order.
    pub fn streams(&self) -> impl Iterator<Item = StreamId> + '_ {
        self.entries.iter().map(|(s, _)| *s)
    }

    /// Each stream with its value, in registration order.
    pub fn iter(&self) -> impl Iterator<Item = (StreamId, &T)> {
        self.entries.iter().map(|(s, v)| (*s, v))
    }

    /// Each stream with its value to change, in registration order.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (StreamId, &mut T)> {
        self.entries.iter_mut().map(|(s, v)| (*s, v))
    }

    /// Each value passed through `f`, for the same streams.
    pub fn map<U>(&self, mut f: impl FnMut(&T) -> U) -> PerStream<U> {
        PerStream {
            entries: self.entries.iter().map(|(s, v)| (*s, f(v))).collect(),
        }
    }

    /// Sets every value to `value`.
    pub fn fill(&mut self, value: T)
    where
        T: Clone,
    {
        self.entries
            .iter_mut()
            .for_each(|(_, v)| *v = value.clone());
    }
}

impl<T> Index<StreamId> for PerStream<T> {
    type Output = T;

    /// # Panics
    /// When `stream` is not registered: the service asks only about its own streams.
    fn index(&self, stream: StreamId) -> &T {
        self.get(stream)
            .unwrap_or_else(|| panic!("stream {stream:?} is not an input of this service"))
    }
}

impl<T> IndexMut<StreamId> for PerStream<T> {
    fn index_mut(&mut self, stream: StreamId) -> &mut T {
        (self.entries.iter_mut())
            .find(|(s, _)| *s == stream)
            .map(|(_, v)| v)
            .unwrap_or_else(|| panic!("stream {stream:?} is not an input of this service"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_reached_by_stream_and_listed_in_registration_order() {
        let streams = [StreamId::Odometry, StreamId::Scan, StreamId::Observations];
        let mut v = PerStream::new(&streams, |s| u32::from(s == StreamId::Scan));
        v[StreamId::Odometry] += 10;
        let listed: Vec<_> = v.iter().map(|(s, &x)| (s, x)).collect();
        assert_eq!(
            listed,
            [
                (StreamId::Odometry, 10),
                (StreamId::Scan, 1),
                (StreamId::Observations, 0)
            ]
        );
        assert_eq!(v.map(|&x| x * 2)[StreamId::Odometry], 20);
        assert_eq!(v.get(StreamId::Pose), None);
        v.fill(7);
        assert!(v.iter().all(|(_, &x)| x == 7));
    }

    #[test]
    #[should_panic(expected = "registered twice")]
    fn a_stream_registered_twice_is_refused() {
        PerStream::new(&[StreamId::Odometry, StreamId::Odometry], |_| 0);
    }
}
