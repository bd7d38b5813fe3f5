//! Occupancy grid maps, shaped like ROS 2's `nav_msgs/OccupancyGrid`: a fixed header plus
//! one slice of `i8` cells, row-major from cell (0, 0) — the cell whose lower-left corner
//! is the origin — along +x first, then +y.

use crate::header::Header;
use bytemuck::{Pod, Zeroable};
use iceoryx2::prelude::*;

/// Cell value of a cell nothing was ever measured in.
pub const UNKNOWN: i8 = -1;

/// Header of a grid; the slice holds `width · height` cells, each [`UNKNOWN`] or an
/// occupancy probability in percent (0 free … 100 occupied).
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Pod, Zeroable)]
#[type_name("fastslam::OccupancyGridHeader")]
#[repr(C)]
pub struct OccupancyGridHeader {
    /// Stamp of the estimate the grid was built from, and sequence number.
    pub header: Header,
    /// Side of a square cell (m).
    pub resolution: f64,
    /// x of cell (0, 0)'s lower-left corner, frame `map` (m).
    pub origin_x: f64,
    /// y of cell (0, 0)'s lower-left corner (m).
    pub origin_y: f64,
    /// Rotation of the grid about its origin (rad); 0: rows along +x.
    pub origin_theta: f64,
    /// Cells per row (along +x).
    pub width: u32,
    /// Rows (along +y).
    pub height: u32,
}

impl OccupancyGridHeader {
    /// Number of cells the slice must hold (`None` on overflow).
    pub fn cells(&self) -> Option<usize> {
        (self.width as usize).checked_mul(self.height as usize)
    }
}
