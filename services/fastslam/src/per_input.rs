//! The service's two inputs, odometry and the lidar, and one value of a type per input.
//!
//! Every per-input piece of state — queues, watermarks, stream checks, deadlines, stream
//! ends, a checkpoint's processed stamps — is a [`PerInput`], indexed by [`Stream`]. The
//! protocol's `StreamId` names streams on the wire (and tells observations from raw
//! scans); the service maps it to a [`Stream`] where an end-of-stream arrives.

use serde::{Deserialize, Serialize};
use std::ops::{Index, IndexMut};

/// One of the service's input streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Odometry.
    Odometry,
    /// The lidar (landmark observations or raw scans).
    Lidar,
}

impl Stream {
    /// Both streams, odometry first (the order of [`PerInput`]'s fields and iteration).
    pub const ALL: [Self; 2] = [Self::Odometry, Self::Lidar];

    /// The other stream.
    pub fn other(self) -> Self {
        match self {
            Self::Odometry => Self::Lidar,
            Self::Lidar => Self::Odometry,
        }
    }
}

/// A value per input stream: one type for what would otherwise be `odo_x`/`lidar_x`
/// pairs or two-element arrays indexed by 0 and 1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct PerInput<T> {
    /// The odometry's.
    pub odometry: T,
    /// The lidar's.
    pub lidar: T,
}

impl<T> PerInput<T> {
    /// The value `f` gives for each stream.
    pub fn from_fn(mut f: impl FnMut(Stream) -> T) -> Self {
        Self {
            odometry: f(Stream::Odometry),
            lidar: f(Stream::Lidar),
        }
    }

    /// Each value passed through `f`.
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> PerInput<U> {
        PerInput {
            odometry: f(self.odometry),
            lidar: f(self.lidar),
        }
    }

    /// References to both values.
    pub fn as_ref(&self) -> PerInput<&T> {
        PerInput {
            odometry: &self.odometry,
            lidar: &self.lidar,
        }
    }

    /// Both values with their stream, odometry first.
    pub fn iter(&self) -> impl Iterator<Item = (Stream, &T)> {
        Stream::ALL
            .into_iter()
            .map(|stream| (stream, &self[stream]))
    }
}

impl<T> Index<Stream> for PerInput<T> {
    type Output = T;

    fn index(&self, stream: Stream) -> &T {
        match stream {
            Stream::Odometry => &self.odometry,
            Stream::Lidar => &self.lidar,
        }
    }
}

impl<T> IndexMut<Stream> for PerInput<T> {
    fn index_mut(&mut self, stream: Stream) -> &mut T {
        match stream {
            Stream::Odometry => &mut self.odometry,
            Stream::Lidar => &mut self.lidar,
        }
    }
}

/// The wire's two-element arrays (the status message's): odometry, then lidar.
impl<T> From<PerInput<T>> for [T; 2] {
    fn from(values: PerInput<T>) -> Self {
        [values.odometry, values.lidar]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_reached_by_stream_and_listed_odometry_first() {
        let mut v = PerInput::from_fn(|s| u32::from(s == Stream::Lidar));
        v[Stream::Odometry] += 10;
        assert_eq!((v.odometry, v.lidar), (10, 1));
        assert_eq!(v[Stream::Lidar.other()], 10);
        let listed: Vec<_> = v.iter().map(|(s, &x)| (s, x)).collect();
        assert_eq!(listed, [(Stream::Odometry, 10), (Stream::Lidar, 1)]);
        assert_eq!(<[u32; 2]>::from(v.as_ref().map(|&x| x * 2)), [20, 2]);
    }
}
