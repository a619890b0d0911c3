//! Paper 001's numbers: Tables 1-3 as printed.

use super::*;

/// One row of paper 001: Table 1 (fps, error, lost, found), Table 2 (lost
/// without / with noise), Table 3 (lost linear / non-linear).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperRow {
    /// Frames per second.
    pub fps: f64,
    /// Error (px).
    pub error: f64,
    /// Times the ball was lost.
    pub lost: f64,
    /// Time to find it again.
    pub found: f64,
    /// Table 2: lost without and with motion noise.
    pub noise: [f64; 2],
    /// Table 3: lost with linear and non-linear motion.
    pub motion: [f64; 2],
}

/// Paper 001's cells for a tracker (SPEC section 3 `ball`).
pub fn paper_row(filter: BallFilter) -> Option<PaperRow> {
    let row = |fps, error, lost, found, noise, motion| PaperRow {
        fps,
        error,
        lost,
        found,
        noise,
        motion,
    };
    match filter {
        BallFilter::Pf(10) => Some(row(15.81, 11.31, 1.25, 6.25, [1.5, 1.0], [1.0, 1.5])),
        BallFilter::Pf(30) => Some(row(10.71, 12.28, 11.75, 5.67, [11.5, 12.0], [12.5, 11.0])),
        BallFilter::Pf(70) => Some(row(7.24, 15.69, 18.25, 4.41, [20.5, 16.0], [20.0, 16.5])),
        BallFilter::Kf => Some(row(10.28, 8.57, 7.5, 8.02, [5.5, 9.5], [2.0, 13.0])),
        BallFilter::Ukf => Some(row(10.19, 8.52, 4.0, 8.87, [3.0, 5.0], [1.5, 6.5])),
        BallFilter::Pf(_) => None,
    }
}
