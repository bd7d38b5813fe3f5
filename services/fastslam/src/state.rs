//! The estimator's state as a checkpoint holds it: the landmark filter's, or grid
//! FastSLAM's with what its loop-closing back-end was handed.

use crate::loop_closing::BackEndState;
use fastslam_estimation::fastslam::FilterState;
use fastslam_estimation::gridslam::GridFilterState;
use serde::{Deserialize, Serialize};

/// The estimator's state, by map kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum EstimatorState {
    /// `[map] kind = "landmarks"`.
    Landmarks(Box<FilterState>),
    /// `[map] kind = "grid"`.
    Grid(Box<GridState>),
}

impl EstimatorState {
    /// The landmark filter's state (`None` for grid FastSLAM's).
    pub fn landmarks(&self) -> Option<&FilterState> {
        match self {
            Self::Landmarks(state) => Some(state),
            Self::Grid(_) => None,
        }
    }
}

/// Grid FastSLAM's part of a checkpoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridState {
    /// The filter: particles, weights, grids (tiles once), the keyframe counter.
    pub filter: GridFilterState,
    /// What the loop-closing back-end was handed (`None` without one).
    pub back_end: Option<BackEndState>,
}
