//! Builds every input message type from a stream of random words, the way a publisher
//! with arbitrary bytes would: any bit pattern is a valid value of these `#[repr(C)]`
//! types, so a word per field covers them all. Numbers lean towards the interesting:
//! NaN, ±∞, 0, small values of either sign, and raw bit patterns. Shared by the proptest
//! suite and the `validate_fuzz` bench.

#![allow(dead_code)] // each user takes a subset

use fastslam_protocol::{
    GroundTruth, Header, LandmarkMapHeader, LaserScanHeader, MapLandmark, Observation,
    ObservationsHeader, Odometry,
};

/// A source of random words.
pub struct Words<'a>(pub &'a mut dyn FnMut() -> u64);

impl Words<'_> {
    /// The next raw word.
    pub fn word(&mut self) -> u64 {
        (self.0)()
    }

    /// A number, leaning towards edge cases.
    pub fn f64(&mut self) -> f64 {
        let w = self.word();
        match w % 8 {
            0 => f64::NAN,
            1 => f64::INFINITY * if w & 8 == 0 { 1.0 } else { -1.0 },
            2 => 0.0,
            3..=5 => ((w >> 8) % 200_000) as f64 / 1000.0 - 100.0,
            _ => f64::from_bits(w),
        }
    }

    /// A 32-bit number, leaning towards edge cases.
    pub fn f32(&mut self) -> f32 {
        self.f64() as f32
    }

    /// A count: mostly small, sometimes anything.
    pub fn count(&mut self) -> u32 {
        let w = self.word();
        if w.is_multiple_of(4) {
            (w >> 32) as u32
        } else {
            ((w >> 8) % 40) as u32
        }
    }

    /// A header with a small stamp and seq (or anything).
    pub fn header(&mut self) -> Header {
        let w = self.word();
        Header {
            stamp_ns: if w.is_multiple_of(5) {
                self.word()
            } else {
                (w >> 8) % 20_000_000_000
            },
            seq: if w.is_multiple_of(7) {
                self.word()
            } else {
                (w >> 16) % 100
            },
        }
    }
}

/// Odometry with every field drawn.
pub fn odometry(w: &mut Words) -> Odometry {
    Odometry {
        header: w.header(),
        v: w.f64(),
        omega: w.f64(),
        steering: w.f64(),
        x: w.f64(),
        y: w.f64(),
        theta: w.f64(),
    }
}

/// Ground truth with every field drawn.
pub fn ground_truth(w: &mut Words) -> GroundTruth {
    GroundTruth {
        header: w.header(),
        x: w.f64(),
        y: w.f64(),
        theta: w.f64(),
        v: w.f64(),
        omega: w.f64(),
        steering: w.f64(),
    }
}

/// An observations header and a slice whose length may disagree with its count.
pub fn observations(w: &mut Words) -> (ObservationsHeader, Vec<Observation>) {
    let len = (w.word() % 24) as usize;
    let items = (0..len)
        .map(|_| Observation {
            range: w.f64(),
            bearing: w.f64(),
            diameter: w.f64(),
            id: w.word() as i64,
        })
        .collect();
    let count = if w.word().is_multiple_of(3) {
        w.count()
    } else {
        len as u32
    };
    let h = ObservationsHeader {
        header: w.header(),
        count,
        reserved: w.word() as u32,
        max_range: w.f64(),
        min_bearing: w.f64(),
        max_bearing: w.f64(),
    };
    (h, items)
}

/// A laser scan header and a data slice whose length may disagree with its counts.
pub fn laser_scan(w: &mut Words) -> (LaserScanHeader, Vec<f32>) {
    let len = (w.word() % 64) as usize;
    let data = (0..len).map(|_| w.f32()).collect();
    let (ranges, intensities) = match w.word() % 3 {
        0 => (w.count(), w.count()),
        1 => (len as u32, 0),
        _ => ((len / 2) as u32, (len - len / 2) as u32),
    };
    let h = LaserScanHeader {
        header: w.header(),
        angle_min: w.f32(),
        angle_increment: w.f32() / 100.0,
        time_increment: w.f32(),
        scan_time: w.f32(),
        range_min: w.f32() / 10.0,
        range_max: w.f32().abs(),
        ranges,
        intensities,
    };
    (h, data)
}

/// A landmark map header and a slice whose length may disagree with its count.
pub fn landmark_map(w: &mut Words) -> (LandmarkMapHeader, Vec<MapLandmark>) {
    let len = (w.word() % 24) as usize;
    let items = (0..len)
        .map(|_| MapLandmark {
            id: w.word(),
            x: w.f64(),
            y: w.f64(),
            cov_xx: w.f64(),
            cov_xy: w.f64(),
            cov_yy: w.f64(),
            observations: w.word(),
        })
        .collect();
    let count = if w.word().is_multiple_of(3) {
        w.count()
    } else {
        len as u32
    };
    let h = LandmarkMapHeader {
        header: w.header(),
        count,
        reserved: 0,
    };
    (h, items)
}
