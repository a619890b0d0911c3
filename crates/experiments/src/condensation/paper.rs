//! Paper 003's grid: representations, cues, particle counts, side trackers.

use super::*;

/// The particle counts of the grid: the paper's 50 (sec. 3.1, 3.3), 100
/// (sec. 3.3) and 200 (sec. 3.2).
pub const PARTICLES: [usize; 3] = [50, 100, 200];

/// Which cues weight the particles (sec. 2.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Cue {
    /// Interframe difference alone (eq. 7; eq. 9 with `lambda = 0`).
    Ifd,
    /// HSV skin colour alone (eq. 8).
    Skin,
    /// OR fusion, eq. 9, `lambda = 1/N`.
    Or,
    /// AND fusion, eq. 11, `lambda = 1/N`.
    And,
}

impl Cue {
    /// Every cue, in column order.
    pub const ALL: [Cue; 4] = [Cue::Ifd, Cue::Skin, Cue::Or, Cue::And];

    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            Cue::Ifd => "IFD",
            Cue::Skin => "skin",
            Cue::Or => "OR",
            Cue::And => "AND",
        }
    }

    /// The tracker's cue set for `n` particles (`lambda = 1/N`, sec. 3.1
    /// and 3.3).
    pub fn cue_set(self, n: usize) -> CueSet {
        let lambda = 1.0 / n.max(1) as f64;
        match self {
            Cue::Ifd => CueSet::Ifd,
            Cue::Skin => CueSet::Skin,
            Cue::Or => CueSet::Or { lambda },
            Cue::And => CueSet::And { lambda },
        }
    }
}

/// How eq. 9's OR weighs a point (see
/// [`CondensationConfig::or_weighting`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrWeighting {
    /// `IFD + lambda skin` over the whole window.
    Raw,
    /// The same over the window's subtracted pixels only.
    Subtracted,
    /// Each cue's window mean divided by its mean over the particle set
    /// before the sum ([`CueSet::OrNormalised`]).
    Normalised,
}

bayestrack_options::choice! { OrWeighting { Raw = "raw", Subtracted = "subtracted", Normalised = "normalised" } }

/// How the contours' rotation and scale move (see
/// [`CondensationConfig::contour_dynamics`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContourMotion {
    /// Eq. 10's damped velocity, no preferred rotation or scale.
    Velocity,
    /// Blake and Isard's AR(2) model around the template mean.
    Ar2,
}

bayestrack_options::choice! { ContourMotion { Velocity = "velocity", Ar2 = "ar2" } }

/// Point cloud or contour particles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Representation {
    /// Sec. 3.1: `[x, y, x_prev, y_prev]`, 30 px diffusion.
    Points,
    /// Sec. 3.3: the face's B-spline contour, 21 control points.
    Contour,
}

impl Representation {
    /// Both, in row order.
    pub const ALL: [Representation; 2] = [Representation::Points, Representation::Contour];

    /// Label.
    pub fn name(self) -> &'static str {
        match self {
            Representation::Points => "points",
            Representation::Contour => "contour",
        }
    }
}

/// One cell of the tracking grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct GridKey {
    /// Point cloud or contour.
    pub representation: Representation,
    /// The cues.
    pub cue: Cue,
    /// `N`.
    pub particles: usize,
}

impl GridKey {
    /// Every cell, in table order (representation, `N`, cue).
    pub fn all() -> Vec<GridKey> {
        let mut v = Vec::new();
        for representation in Representation::ALL {
            for particles in PARTICLES {
                for cue in Cue::ALL {
                    v.push(GridKey {
                        representation,
                        cue,
                        particles,
                    });
                }
            }
        }
        v
    }

    /// `points OR N=50`.
    pub fn label(&self) -> String {
        format!(
            "{} {} N={}",
            self.representation.name(),
            self.cue.name(),
            self.particles
        )
    }
}

/// The trackers of the re-initialisation and crossing runs: the point
/// cloud of sec. 3.1 (OR, `N = 50`), the same with AND (the cue that tracks
/// in our clutter), and the contour of sec. 3.3 (AND, `N = 100`).
pub const SIDE_TRACKERS: [GridKey; 3] = [
    GridKey {
        representation: Representation::Points,
        cue: Cue::Or,
        particles: 50,
    },
    GridKey {
        representation: Representation::Points,
        cue: Cue::And,
        particles: 50,
    },
    GridKey {
        representation: Representation::Contour,
        cue: Cue::And,
        particles: 100,
    },
];
