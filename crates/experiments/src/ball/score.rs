//! Lost / found / error scoring of one tracker's estimates, and what one run gives.

use super::*;

/// Lost / found / error bookkeeping of one tracker under one scoring (see
/// the module docs).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Score {
    /// Sum of the centre errors over the processed frames (px).
    pub error_sum: f64,
    /// Losses.
    pub losses: usize,
    /// Time from each re-found loss to its re-finding (s).
    pub found_times: Vec<f64>,
    /// Losses not re-found before the end of the run.
    pub unresolved: usize,
    /// When the current loss began (s), `None` while the ball is held.
    lost_since: Option<f64>,
}

impl Score {
    /// Scores one estimate whose centre error is `err` at time `time` (s).
    pub(super) fn record(&mut self, time: f64, err: f64, lost_radius: f64, found_radius: f64) {
        self.error_sum += err;
        match self.lost_since {
            None if err > lost_radius => {
                self.losses += 1;
                self.lost_since = Some(time);
            }
            Some(since) if err <= found_radius => {
                self.found_times.push(time - since);
                self.lost_since = None;
            }
            _ => {}
        }
    }

    /// Closes the run: a loss still open is unresolved.
    pub(super) fn finish(&mut self) {
        self.unresolved = usize::from(self.lost_since.take().is_some());
    }
}

/// What one tracker did in one run, in one mode.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackOutcome {
    /// Which tracker.
    #[serde(with = "ball_filter")]
    pub filter: BallFilter,
    /// Its evaluation budget (windows per frame) for a budgeted KF/UKF,
    /// `None` for the exhaustive search and the PFs.
    pub budget: Option<usize>,
    /// Offline or real time.
    pub mode: FrameMode,
    /// Frames processed (after the initial one).
    pub frames: usize,
    /// Histogram evaluations over the processed frames.
    pub evaluations: usize,
    /// Scored against the ball in the processed frame.
    pub score: Score,
    /// Real time only: scored against where the ball is when the estimate
    /// becomes available (the frame's capture time plus `1 / fps_paper`).
    pub delayed: Option<Score>,
    /// Processed frames in which the tracker reported itself lost.
    pub self_lost: usize,
    /// Wall-clock seconds spent in `step` (not deterministic; never pinned).
    pub wall: f64,
    /// `(time, centre error)` of every processed frame (first run of a
    /// condition only, for the figure).
    pub trace: Vec<(f64, f64)>,
}

impl TrackOutcome {
    /// The row label: `PF10`, `KF`, or `KF@37` for a budgeted KF.
    pub fn label(&self) -> String {
        label(self.filter, self.budget)
    }
}

/// A [`BallFilter`] as `(kind, particles)`: `("pf", n)`, `("kf", 0)`,
/// `("ukf", 0)`.
pub(super) mod ball_filter {
    use bayestrack_trackers::BallFilter;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(f: &BallFilter, s: S) -> Result<S::Ok, S::Error> {
        #[allow(unreachable_patterns)]
        let pair = match *f {
            BallFilter::Pf(n) => ("pf", n),
            BallFilter::Kf => ("kf", 0),
            BallFilter::Ukf => ("ukf", 0),
            _ => return Err(serde::ser::Error::custom("unknown ball filter")),
        };
        pair.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<BallFilter, D::Error> {
        match <(String, usize)>::deserialize(d)? {
            (k, n) if k == "pf" => Ok(BallFilter::Pf(n)),
            (k, _) if k == "kf" => Ok(BallFilter::Kf),
            (k, _) if k == "ukf" => Ok(BallFilter::Ukf),
            (k, _) => Err(serde::de::Error::custom(format!(
                "unknown ball filter `{k}`"
            ))),
        }
    }
}

/// Row label of a tracker with an optional budget (`KF@37`).
pub(super) fn label(filter: BallFilter, budget: Option<usize>) -> String {
    match budget {
        Some(b) => format!("{}@{b}", filter.label()),
        None => filter.label(),
    }
}

/// Every outcome of one run of one condition.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    /// The condition.
    pub condition: Condition,
    /// Run index within the condition.
    pub run: usize,
    /// Seconds of video.
    pub seconds: f64,
    /// One outcome per tracker and mode: `BallFilter::PAPER` x
    /// `FrameMode::ALL`, then the budgeted KF and UKF in both modes.
    pub outcomes: Vec<TrackOutcome>,
}

/// How the estimates are scored, and whether the KF/UKF are on the budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct View {
    /// Which frames are processed.
    pub mode: FrameMode,
    /// Real time only: score against where the ball is when the estimate
    /// becomes available.
    pub delayed: bool,
    /// KF and UKF on the evaluation budget (the PFs are the same either way).
    pub budgeted: bool,
}

impl View {
    /// Every frame, scored on it, exhaustive KF/UKF.
    pub const OFFLINE: View = View {
        mode: FrameMode::Offline,
        delayed: false,
        budgeted: false,
    };
    /// Real time, scored on the processed frame, exhaustive KF/UKF.
    pub const REALTIME: View = View {
        mode: FrameMode::RealTime,
        delayed: false,
        budgeted: false,
    };

    /// The views of the findings table: offline, real time, real time
    /// scored when available; each without and then with the budget.
    pub const ALL: [View; 6] = [
        View::OFFLINE,
        View::REALTIME,
        View::REALTIME.scored_late(),
        View::OFFLINE.on_budget(),
        View::REALTIME.on_budget(),
        View::REALTIME.scored_late().on_budget(),
    ];

    /// This view with the KF/UKF on the budget.
    pub const fn on_budget(self) -> View {
        View {
            budgeted: true,
            ..self
        }
    }

    /// This view scored when the estimate becomes available.
    pub const fn scored_late(self) -> View {
        View {
            delayed: true,
            ..self
        }
    }

    /// Short name (`offline`, `realtime`, `realtime+delay`, with `@budget`).
    pub fn name(self) -> String {
        format!(
            "{}{}{}",
            self.mode.name(),
            if self.delayed { "+delay" } else { "" },
            if self.budgeted { "@budget" } else { "" }
        )
    }
}
