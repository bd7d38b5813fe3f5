//! Landmark observations (sensor → service) and landmark maps (service → clients, and the
//! simulator's true map). Both are a fixed user header plus a slice.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Header of one scan's landmark observations; the slice holds [`Observation`]s.
///
/// The sensor's range and field of view tell the filter which landmarks it *could* have
/// seen (negative evidence).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::ObservationsHeader")]
#[repr(C)]
pub struct ObservationsHeader {
    /// Stamp of the scan, and sequence number.
    pub header: Header,
    /// Number of observations in the slice (must equal the slice length).
    pub count: u32,
    /// Reserved, must be 0.
    pub reserved: u32,
    /// Maximum range of the sensor (m).
    pub max_range: f64,
    /// Smallest bearing the sensor covers (rad, 0 = forward, counter-clockwise positive).
    pub min_bearing: f64,
    /// Largest bearing the sensor covers (rad).
    pub max_bearing: f64,
}

/// One range–bearing observation of a point landmark (a pole, a tree trunk), in the
/// vehicle frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::Observation")]
#[repr(C)]
pub struct Observation {
    /// Range to the landmark's centre (m).
    pub range: f64,
    /// Bearing to the landmark's centre (rad, 0 = forward, counter-clockwise positive).
    pub bearing: f64,
    /// Diameter of the landmark if the sensor measures it (m), 0 when unknown.
    pub diameter: f64,
    /// Landmark id when the sensor knows it (known association), −1 when unknown.
    pub id: i64,
}

impl Observation {
    /// The id when the sensor knows it.
    pub fn known_id(&self) -> Option<u64> {
        u64::try_from(self.id).ok()
    }
}

/// Header of a landmark map; the slice holds [`MapLandmark`]s.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::LandmarkMapHeader")]
#[repr(C)]
pub struct LandmarkMapHeader {
    /// Stamp of the estimate the map belongs to, and sequence number.
    pub header: Header,
    /// Number of landmarks in the slice (must equal the slice length).
    pub count: u32,
    /// Reserved, must be 0.
    pub reserved: u32,
}

/// One landmark of a map (frame `map`): mean and 2×2 covariance.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::MapLandmark")]
#[repr(C)]
pub struct MapLandmark {
    /// Stable id of the landmark within its map.
    pub id: u64,
    /// Mean x (m).
    pub x: f64,
    /// Mean y (m).
    pub y: f64,
    /// Covariance xx (m²).
    pub cov_xx: f64,
    /// Covariance xy (m²).
    pub cov_xy: f64,
    /// Covariance yy (m²).
    pub cov_yy: f64,
    /// How many times the landmark was observed (0 for a true map).
    pub observations: u64,
}

/// A request for the current map, sent to the `map/get` request–response service; the
/// response is a [`LandmarkMapHeader`] plus a slice of [`MapLandmark`]s, as on `map`.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::MapRequest")]
#[repr(C)]
pub struct MapRequest {
    /// Reserved, must be 0.
    pub reserved: u64,
}

/// The header row of a landmark map as CSV (the run folder's `map.csv`, saved maps).
pub const MAP_CSV_HEADER: &str = "id,x,y,cov_xx,cov_xy,cov_yy,observations";

/// `map` as CSV: [`MAP_CSV_HEADER`], then one landmark per line. Numbers are written in
/// Rust's shortest exact form, so parsing them back gives the same bits.
pub fn map_csv(map: &[MapLandmark]) -> String {
    use std::fmt::Write;
    let mut text = format!("{MAP_CSV_HEADER}\n");
    for l in map {
        let _ = writeln!(
            text,
            "{},{},{},{},{},{},{}",
            l.id, l.x, l.y, l.cov_xx, l.cov_xy, l.cov_yy, l.observations
        );
    }
    text
}
