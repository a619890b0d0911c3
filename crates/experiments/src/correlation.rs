//! The `correlation` experiment: paper 004 Tables 1-3 on the synthetic road
//! of [`RoadScene`].
//!
//! - Table 1: the MAD correlation tracker (sec. 2), window centre every
//!   third frame; the paper's stalls at (76, 113) from frame 13, behind the
//!   billboard.
//! - Table 2: the PF correlation tracker (sec. 3, `Ns = 15`); the paper's
//!   keeps moving about (2.6, 5) px a frame from (57, 85) to (126, 220).
//! - Table 3: the Kalman multi-target tracker (sec. 4) on two cars,
//!   centroid and window size per frame (the paper's frames 42-53).
//!
//! Paper frame `n` (1-based) is our frame index `n - 1` for Tables 1-2, and
//! index `n - 42` of [`RoadScene::two_cars`] for Table 3. Positions are
//! 0-based pixel centres (the scene's convention). Run `r` renders the scene
//! with seed `scene_seed + r` and seeds the particle filters with `r`; the
//! per-frame tables show run 0, the summary averages over runs. Every choice
//! is a named option ([`CorrelationConfig::apply`]); the reasons are in
//! docs/reproduction.md.

use std::fmt::Write as _;
use std::path::Path;

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    ArpMotion, MadTracker, MadTrackerConfig, MultiTargetConfig, MultiTargetTracker,
    PfCorrelationConfig, PfCorrelationTracker, SearchArea, Tracker,
};

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_PARTICLES, MAX_RUNS, write_text};
use bayestrack_options::{Options, options};

/// The experiment's id.
const ID: &str = "correlation";
use crate::scenes::{FrameTruth, RoadScene};
use bayestrack_otb::Table;
use bayestrack_otb::plot::{Series, line_chart};

/// Paper 004 Table 1 (MAD tracker): `(frame, x, y)`.
pub const PAPER_TABLE1: [(usize, f64, f64); 10] = [
    (1, 58.0, 83.0),
    (4, 64.0, 93.0),
    (7, 69.0, 102.0),
    (10, 75.0, 112.0),
    (13, 76.0, 112.0),
    (16, 76.0, 113.0),
    (19, 76.0, 113.0),
    (22, 76.0, 113.0),
    (25, 76.0, 113.0),
    (28, 76.0, 112.0),
];

/// Paper 004 Table 2 (PF tracker): `(frame, x, y)`.
pub const PAPER_TABLE2: [(usize, f64, f64); 10] = [
    (1, 57.0, 85.0),
    (4, 65.0, 100.0),
    (7, 72.0, 115.0),
    (10, 80.0, 130.0),
    (13, 88.0, 145.0),
    (16, 95.0, 160.0),
    (19, 103.0, 175.0),
    (22, 111.0, 190.0),
    (25, 119.0, 205.0),
    (28, 126.0, 220.0),
];

/// Paper 004 Table 3: `(frame, [x, y, Lx, Ly] of target 1, of target 2)`.
pub const PAPER_TABLE3: [(usize, [f64; 4], [f64; 4]); 8] = [
    (42, [146.0, 159.0, 34.0, 46.0], [186.0, 141.0, 29.0, 43.0]),
    (45, [159.0, 165.0, 33.0, 48.0], [198.0, 147.0, 30.0, 44.0]),
    (46, [163.0, 168.0, 33.0, 47.0], [201.0, 149.0, 30.0, 44.0]),
    (49, [173.0, 173.0, 35.0, 51.0], [214.0, 155.0, 32.0, 47.0]),
    (50, [177.0, 175.0, 36.0, 51.0], [219.0, 157.0, 32.0, 46.0]),
    (51, [181.0, 177.0, 37.0, 52.0], [224.0, 159.0, 33.0, 48.0]),
    (52, [186.0, 178.0, 38.0, 53.0], [228.0, 160.0, 35.0, 48.0]),
    (53, [189.0, 181.0, 39.0, 54.0], [232.0, 163.0, 35.0, 50.0]),
];

/// The single-target trackers compared in Tables 1-2, in column order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// MAD tracker searching a window around its last match.
    MadWindow,
    /// MAD tracker searching the whole frame.
    MadFrame,
    /// PF with eq. 6 as printed (`A = 1`: a random walk).
    PfPrinted,
    /// PF with the ARP on the displacement ([`ArpMotion::Drift`]).
    PfDrift,
    /// PF with the displacement ARP and a capped MAD in eq. 7 (not in the paper).
    PfDriftCap,
    /// PF with a constant drift measured by the MAD match between frames 1
    /// and 2, the particle filter from frame 3 on (sec. 3.2;
    /// [`ArpMotion::ConstantDrift`]), eq. 7 as printed.
    PfConstDrift,
}

impl Variant {
    /// Every variant, in column order.
    pub const ALL: [Variant; 6] = [
        Variant::MadWindow,
        Variant::MadFrame,
        Variant::PfPrinted,
        Variant::PfDrift,
        Variant::PfDriftCap,
        Variant::PfConstDrift,
    ];

    /// Column label.
    pub fn name(self) -> &'static str {
        match self {
            Variant::MadWindow => "MAD window",
            Variant::MadFrame => "MAD frame",
            Variant::PfPrinted => "PF eq.6 printed",
            Variant::PfDrift => "PF drift",
            Variant::PfDriftCap => "PF drift+cap",
            Variant::PfConstDrift => "PF const drift",
        }
    }

    /// Whether it is one of the particle filters.
    pub fn is_pf(self) -> bool {
        !matches!(self, Variant::MadWindow | Variant::MadFrame)
    }
}

/// Widest MAD search margin an option may ask for, px (wider than any
/// frame).
pub const MAX_MAD_MARGIN: usize = 4096;

/// The cross-option rule: the PF trackers' settings must be ones they
/// accept.
fn check(c: &CorrelationConfig) -> Result<(), String> {
    PfCorrelationTracker::new(c.pf()).map_err(|e| e.to_string())?;
    for v in Variant::ALL.into_iter().filter(|v| v.is_pf()) {
        c.tracker(v, 0).map_err(|e| e.to_string())?;
    }
    Ok(())
}

options! {
    /// Every choice of the experiment, at paper scale by default (50 runs).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CorrelationConfig {
        /// Runs (scene noise and particle seeds; 50 at paper scale).
        pub runs: usize = 50, in 1..=MAX_RUNS;
        /// Scene seed of run 0.
        pub scene_seed: u64 = 1;
        /// Margin of the MAD tracker's search window, px (16).
        pub mad_margin: usize = 16, in 0..=MAX_MAD_MARGIN;
        /// Particles of the PF trackers (paper 004 sec. 3: `Ns = 15`).
        pub particles: usize = 15, in 1..=MAX_PARTICLES;
        /// Likelihood width of the PF trackers, gray levels (1.5; the
        /// tracker checks its range).
        pub sigma: f64 = 1.5;
        /// Initial spread of the particles, px per axis (5).
        pub spread: f64 = 5.0;
        /// `B` of the drift model's random walk, px (4).
        pub b: f64 = 4.0;
        /// Gain of the drift model (0.5).
        pub gain: f64 = 0.5;
        /// `B` of the printed eq. 6 random walk, px (8).
        pub printed_b: f64 = 8.0;
        /// MAD cap of the `PF drift+cap` row, gray levels (40).
        pub cap: f64 = 40.0;
        /// `B` (px) of the `PF const drift` row: the constant drift carries
        /// the motion, `B w` only absorbs the error of `c`, which the
        /// integer-pixel MAD match measures to +-0.5 px per axis; 1 px
        /// covers it.
        pub const_b: f64 = 1.0;
    }
    check check;
}

impl CorrelationConfig {
    /// Paper scale: 50 runs.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: 8 runs.
    pub fn quick() -> Self {
        Self {
            runs: 8,
            ..Self::paper()
        }
    }

    /// Applies a `key=value` override (see [`Options::set`]).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or value, listing
    /// every key with its domain; a refused option leaves the configuration
    /// as it was.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        crate::driver::apply(ID, self, key, value)
    }

    /// Every option as `key=value`, for the table footer.
    pub fn describe(&self) -> String {
        Options::describe(self)
    }

    /// The PF tracker's settings (seed replaced per run) for the drift rows.
    pub fn pf(&self) -> PfCorrelationConfig {
        PfCorrelationConfig {
            particles: self.particles,
            spread: [self.spread; 2],
            motion: ArpMotion::Drift {
                b: [self.b; 2],
                gain: self.gain,
            },
            sigma: self.sigma,
            ..PfCorrelationConfig::default()
        }
    }

    fn tracker(&self, v: Variant, run: usize) -> Result<Box<dyn Tracker>, ExperimentError> {
        let pf = |c: PfCorrelationConfig| -> Result<Box<dyn Tracker>, ExperimentError> {
            Ok(Box::new(
                PfCorrelationTracker::new(PfCorrelationConfig {
                    seed: run as u64,
                    ..c
                })
                .map_err(|e| failed(v.name(), e))?,
            ))
        };
        let mad = |search| -> Result<Box<dyn Tracker>, ExperimentError> {
            Ok(Box::new(
                MadTracker::new(MadTrackerConfig {
                    search,
                    ..MadTrackerConfig::default()
                })
                .map_err(|e| failed(v.name(), e))?,
            ))
        };
        match v {
            Variant::MadWindow => mad(SearchArea::Window {
                margin: self.mad_margin,
            }),
            Variant::MadFrame => mad(SearchArea::Frame),
            Variant::PfPrinted => pf(PfCorrelationConfig {
                motion: ArpMotion::Position {
                    a: [1.0, 1.0],
                    b: [self.printed_b; 2],
                },
                ..self.pf()
            }),
            Variant::PfDrift => pf(self.pf()),
            Variant::PfDriftCap => pf(PfCorrelationConfig {
                mad_cap: Some(self.cap),
                ..self.pf()
            }),
            Variant::PfConstDrift => pf(PfCorrelationConfig {
                motion: ArpMotion::ConstantDrift {
                    b: [self.const_b; 2],
                    margin: self.mad_margin,
                },
                ..self.pf()
            }),
        }
    }
}

fn failed(what: &str, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: "correlation",
        message: format!("{what}: {e}"),
    }
}

/// One tracker's run on the single-car scene.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrackRun {
    /// Window centre per frame (0-based); frame 0 is the initial box.
    pub centres: Vec<[f64; 2]>,
    /// Whether the tracker reported the target lost, per frame.
    pub lost: Vec<bool>,
}

/// The phases of the single-car scene, by visibility of the car.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseErrors {
    /// Mean error (px) while the car is fully visible before the billboard.
    pub before: f64,
    /// Mean error while it is partly or fully hidden.
    pub during: f64,
    /// Mean error once it is fully visible again.
    pub after: f64,
}

/// Everything one run produced.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    /// Ground truth centres per frame.
    pub truth: Vec<[f64; 2]>,
    /// Visible fraction of the car per frame.
    pub visible: Vec<f64>,
    /// One run per [`Variant::ALL`].
    pub tracks: Vec<TrackRun>,
}

impl RunResult {
    /// Errors of variant `v` per frame.
    pub fn errors(&self, v: Variant) -> Vec<f64> {
        let i = Variant::ALL.iter().position(|&x| x == v).unwrap_or(0);
        self.tracks[i]
            .centres
            .iter()
            .zip(&self.truth)
            .map(|(c, t)| (c[0] - t[0]).hypot(c[1] - t[1]))
            .collect()
    }

    /// Mean errors of variant `v` before, during and after the occlusion
    /// (frame 0, the initial box, left out).
    pub fn phases(&self, v: Variant) -> PhaseErrors {
        let e = self.errors(v);
        let first_hidden = self
            .visible
            .iter()
            .position(|&f| f < 1.0 - 1e-9)
            .unwrap_or(self.visible.len());
        let last_hidden = self
            .visible
            .iter()
            .rposition(|&f| f < 1.0 - 1e-9)
            .unwrap_or(first_hidden);
        let mean = |a: usize, b: usize| {
            let s = &e[a.min(b)..b];
            if s.is_empty() {
                f64::NAN
            } else {
                s.iter().sum::<f64>() / s.len() as f64
            }
        };
        PhaseErrors {
            before: mean(1, first_hidden),
            during: mean(first_hidden, last_hidden + 1),
            after: mean(last_hidden + 1, e.len()),
        }
    }
}

/// The multi-target run (Table 3).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MultiResult {
    /// Per frame, per car (truth order): `[x, y, Lx, Ly]` of the track that
    /// follows it, `None` when no track does.
    pub tracks: Vec<[Option<[f64; 4]>; 2]>,
    /// Per frame, the truth `[x, y, w, h]` of the two cars.
    pub truth: Vec<[[f64; 4]; 2]>,
    /// Per frame, the ids of the live tracks.
    pub ids: Vec<Vec<u64>>,
}

/// The whole result.
#[derive(Debug, Clone, PartialEq)]
pub struct CorrelationResult {
    /// The configuration that produced it.
    pub config: CorrelationConfig,
    /// Runs on the single-car scene.
    pub runs: Vec<RunResult>,
    /// Run 0 of the two-car scene.
    pub multi: MultiResult,
}

fn car_truth(t: &FrameTruth) -> ([f64; 2], f64) {
    t.target()
        .map_or(([f64::NAN; 2], 0.0), |o| (o.center0(), o.visible_fraction))
}

/// The initial box: a template of whole pixels centred on the car's centre
/// (rounded), one pixel larger than the car so that its anti-aliased edges
/// are inside.
fn initial_box(t: &FrameTruth) -> Result<BBox, ExperimentError> {
    let o = t
        .target()
        .ok_or_else(|| failed("scene", "the road scene has no car"))?;
    let [cx, cy] = o.center0();
    let (w, h) = (o.bbox.width.round() + 1.0, o.bbox.height.round() + 1.0);
    // 0-based top-left of a w x h window centred at (cx, cy), OTB = + 1.
    Ok(BBox::new(
        (cx - (w - 1.0) / 2.0).round() + 1.0,
        (cy - (h - 1.0) / 2.0).round() + 1.0,
        w,
        h,
    ))
}

fn one_run(c: &CorrelationConfig, run: usize) -> Result<RunResult, ExperimentError> {
    let scene = RoadScene::default()
        .generate(c.scene_seed + run as u64)
        .map_err(|e| failed("scene", e))?;
    let (truth, visible): (Vec<[f64; 2]>, Vec<f64>) = scene.truth.iter().map(car_truth).unzip();
    let init = initial_box(&scene.truth[0])?;
    let tracks = Variant::ALL
        .iter()
        .map(|&v| {
            let mut t = c.tracker(v, run)?;
            let first = scene
                .frames
                .first()
                .ok_or_else(|| failed("scene", "no frame"))?;
            t.init(first.view(), init)
                .map_err(|e| failed(v.name(), e))?;
            let (cx, cy) = init.center();
            let mut centres = vec![[cx - 1.0, cy - 1.0]];
            let mut lost = vec![false];
            for (k, f) in scene.frames.iter().enumerate().skip(1) {
                let e = t
                    .step(f.view())
                    .map_err(|e| failed(v.name(), format!("run {run} frame {k}: {e}")))?;
                let (x, y) = e.bbox.center();
                centres.push([x - 1.0, y - 1.0]);
                lost.push(e.lost);
            }
            Ok(TrackRun { centres, lost })
        })
        .collect::<Result<_, ExperimentError>>()?;
    Ok(RunResult {
        truth,
        visible,
        tracks,
    })
}

fn multi_run(c: &CorrelationConfig) -> Result<MultiResult, ExperimentError> {
    let params = RoadScene::two_cars();
    let bg: Image<u8> = params
        .background(c.scene_seed)
        .map_err(|e| failed("scene", e))?;
    let scene = params
        .generate(c.scene_seed)
        .map_err(|e| failed("scene", e))?;
    let mut tracker = MultiTargetTracker::new(MultiTargetConfig::default(), bg.view())
        .map_err(|e| failed("multi-target", e))?;
    let mut owner: [Option<u64>; 2] = [None, None];
    let mut out = MultiResult {
        tracks: vec![],
        truth: vec![],
        ids: vec![],
    };
    for (k, (f, t)) in scene.frames.iter().zip(&scene.truth).enumerate() {
        let tracks = tracker
            .step(f.view())
            .map_err(|e| failed("multi-target", format!("frame {k}: {e}")))?;
        let mut truth = [[f64::NAN; 4]; 2];
        for (i, slot) in truth.iter_mut().enumerate() {
            if let Some(o) = t.object(i) {
                let [x, y] = o.center0();
                *slot = [x, y, o.bbox.width, o.bbox.height];
            }
        }
        // Each car is followed by the track nearest to it when first seen;
        // the identity is then kept (a swap shows as a large error).
        for (i, own) in owner.iter_mut().enumerate() {
            if own.is_none() {
                *own = tracks
                    .iter()
                    .min_by(|a, b| {
                        let d = |tr: &bayestrack_trackers::Track| {
                            (tr.feature.centroid.0 - truth[i][0])
                                .hypot(tr.feature.centroid.1 - truth[i][1])
                        };
                        d(a).total_cmp(&d(b))
                    })
                    .map(|tr| tr.id);
            }
        }
        let follow = |i: usize| {
            owner[i]
                .and_then(|id| tracks.iter().find(|tr| tr.id == id))
                .map(|tr| {
                    [
                        tr.feature.centroid.0,
                        tr.feature.centroid.1,
                        tr.feature.size.0,
                        tr.feature.size.1,
                    ]
                })
        };
        out.tracks.push([follow(0), follow(1)]);
        out.truth.push(truth);
        out.ids.push(tracks.iter().map(|tr| tr.id).collect());
    }
    Ok(out)
}

/// Runs the experiment (runs in parallel; each has its own seeds, so the
/// result does not depend on the thread count).
///
/// # Errors
/// [`ExperimentError::Failed`] naming the tracker, run and frame.
pub fn run(config: &CorrelationConfig) -> Result<CorrelationResult, ExperimentError> {
    let done = crate::driver::run_all::<CorrelationExperiment>(config, None, false)?;
    assemble(config, done)
}

/// What one job gives: a run on the single-car scene, or the two-car run.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub enum Done {
    /// Run `r` of the single-car scene (job `r`).
    Run(RunResult),
    /// The two-car run (the last job).
    Multi(MultiResult),
}

/// The result from every job's, in job order.
fn assemble(
    config: &CorrelationConfig,
    done: Vec<Done>,
) -> Result<CorrelationResult, ExperimentError> {
    let mut runs = Vec::new();
    let mut multi = None;
    for d in done {
        match d {
            Done::Run(r) => runs.push(r),
            Done::Multi(m) => multi = Some(m),
        }
    }
    Ok(CorrelationResult {
        config: *config,
        runs,
        multi: multi.ok_or_else(|| failed("multi-target", "no two-car run"))?,
    })
}

/// Summary of one variant over runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariantSummary {
    /// The tracker.
    pub variant: Variant,
    /// Mean over runs of the phase errors.
    pub phases: PhaseErrors,
    /// Fraction of runs whose mean error after the occlusion is under 5 px
    /// (the car re-acquired).
    pub recovered: f64,
}

fn xy(c: [f64; 2]) -> String {
    format!("({:.1}, {:.1})", c[0], c[1])
}

impl CorrelationResult {
    /// Per-variant summaries in [`Variant::ALL`] order.
    pub fn summary(&self) -> Vec<VariantSummary> {
        let n = self.runs.len() as f64;
        Variant::ALL
            .iter()
            .map(|&v| {
                let ph: Vec<PhaseErrors> = self.runs.iter().map(|r| r.phases(v)).collect();
                let avg = |f: fn(&PhaseErrors) -> f64| ph.iter().map(f).sum::<f64>() / n;
                VariantSummary {
                    variant: v,
                    phases: PhaseErrors {
                        before: avg(|p| p.before),
                        during: avg(|p| p.during),
                        after: avg(|p| p.after),
                    },
                    recovered: ph.iter().filter(|p| p.after < 5.0).count() as f64 / n,
                }
            })
            .collect()
    }

    fn per_frame_table(&self, title: &str, paper: &[(usize, f64, f64)], cols: &[Variant]) -> Table {
        let mut header = vec!["frame", "truth", "visible", "paper"];
        header.extend(cols.iter().map(|v| v.name()));
        let mut t = Table::new(title, &header);
        let r0 = &self.runs[0];
        for &(frame, px, py) in paper {
            let k = frame - 1;
            if k >= r0.truth.len() {
                continue;
            }
            let mut row = vec![
                frame.to_string(),
                xy(r0.truth[k]),
                format!("{:.2}", r0.visible[k]),
                xy([px, py]),
            ];
            for v in cols {
                let i = Variant::ALL.iter().position(|x| x == v).unwrap_or(0);
                let lost = if r0.tracks[i].lost[k] { " lost" } else { "" };
                row.push(format!("{}{lost}", xy(r0.tracks[i].centres[k])));
            }
            t.push(row);
        }
        t
    }

    /// Table 1: the MAD tracker, every third frame (run 0).
    pub fn table1(&self) -> Table {
        self.per_frame_table(
            "correlation: paper 004 Table 1, MAD tracker centre (0-based px), run 0",
            &PAPER_TABLE1,
            &[Variant::MadWindow, Variant::MadFrame],
        )
    }

    /// Table 2: the PF tracker, every third frame (run 0).
    pub fn table2(&self) -> Table {
        self.per_frame_table(
            "correlation: paper 004 Table 2, PF tracker (Ns = 15) centre (0-based px), run 0",
            &PAPER_TABLE2,
            &[
                Variant::PfPrinted,
                Variant::PfDrift,
                Variant::PfDriftCap,
                Variant::PfConstDrift,
            ],
        )
    }

    /// Mean errors before, during and after the occlusion, over runs.
    pub fn summary_table(&self) -> Table {
        let mut t = Table::new(
            format!(
                "correlation: mean centre error (px) by phase over {} runs; recovered = after < 5 px",
                self.runs.len()
            ),
            &["tracker", "before", "during", "after", "recovered"],
        );
        for s in self.summary() {
            t.push(vec![
                s.variant.name().to_string(),
                format!("{:.2}", s.phases.before),
                format!("{:.2}", s.phases.during),
                format!("{:.2}", s.phases.after),
                format!("{:.0}%", 100.0 * s.recovered),
            ]);
        }
        t
    }

    /// Table 3: the multi-target tracker (our frame 0 = paper frame 42).
    pub fn table3(&self) -> Table {
        let mut t = Table::new(
            "correlation: paper 004 Table 3, Kalman multi-target tracker, centroid x, y and window Lx x Ly",
            &[
                "frame", "paper 1", "ours 1", "truth 1", "paper 2", "ours 2", "truth 2", "tracks",
            ],
        );
        let fmt = |v: [f64; 4]| format!("{:.1} {:.1} {:.1}x{:.1}", v[0], v[1], v[2], v[3]);
        let paper = |v: [f64; 4]| format!("{:.0} {:.0} {:.0}x{:.0}", v[0], v[1], v[2], v[3]);
        for &(frame, p1, p2) in &PAPER_TABLE3 {
            let k = frame - 42;
            if k >= self.multi.tracks.len() {
                continue;
            }
            let ours = |i: usize| self.multi.tracks[k][i].map_or("-".to_string(), fmt);
            let ids: Vec<String> = self.multi.ids[k].iter().map(|i| i.to_string()).collect();
            t.push(vec![
                frame.to_string(),
                paper(p1),
                ours(0),
                fmt(self.multi.truth[k][0]),
                paper(p2),
                ours(1),
                fmt(self.multi.truth[k][1]),
                ids.join(" "),
            ]);
        }
        t
    }

    /// Every table, in print order.
    pub fn tables(&self) -> Vec<Table> {
        vec![
            self.table1(),
            self.table2(),
            self.summary_table(),
            self.table3(),
        ]
    }
}

/// One row of `frames.csv`: one tracker on one frame of one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameRow {
    /// Run index (0-based).
    pub run: usize,
    /// Frame number (1-based).
    pub frame: usize,
    /// True centre, x (px).
    pub truth_x: f64,
    /// True centre, y (px).
    pub truth_y: f64,
    /// Visible share of the car.
    pub visible: f64,
    /// [`Variant::name`].
    pub tracker: &'static str,
    /// Estimated centre, x (px).
    pub x: f64,
    /// Estimated centre, y (px).
    pub y: f64,
    /// Whether the tracker reported itself lost.
    pub lost: bool,
}

/// The `frames.csv` rows of run `r`: every frame of every tracker.
fn frame_rows(r: usize, run: &RunResult) -> Vec<FrameRow> {
    let mut rows = Vec::new();
    for k in 0..run.truth.len() {
        for (v, tr) in Variant::ALL.iter().zip(&run.tracks) {
            rows.push(FrameRow {
                run: r,
                frame: k + 1,
                truth_x: run.truth[k][0],
                truth_y: run.truth[k][1],
                visible: run.visible[k],
                tracker: v.name(),
                x: tr.centres[k][0],
                y: tr.centres[k][1],
                lost: tr.lost[k],
            });
        }
    }
    rows
}

/// Writes the CSV files (all but `frames.csv`, which the run writes as it
/// goes) and the figures under `dir`.
fn write_outputs(result: &CorrelationResult, dir: &Path) -> Result<(), ExperimentError> {
    for (name, table) in [
        ("table1_mad.csv", result.table1()),
        ("table2_pf.csv", result.table2()),
        ("summary.csv", result.summary_table()),
        ("table3_multi.csv", result.table3()),
    ] {
        let path = dir.join(name);
        write_text(&path, &table.to_csv())?;
    }
    // Trajectories (run 0) with the paper's, and error over time.
    let r0 = &result.runs[0];
    let mut traj = vec![
        Series {
            name: "truth".into(),
            points: r0.truth.iter().map(|c| (c[0], c[1])).collect(),
        },
        Series {
            name: "paper MAD (Table 1)".into(),
            points: PAPER_TABLE1.iter().map(|&(_, x, y)| (x, y)).collect(),
        },
        Series {
            name: "paper PF (Table 2)".into(),
            points: PAPER_TABLE2.iter().map(|&(_, x, y)| (x, y)).collect(),
        },
    ];
    for (v, tr) in Variant::ALL.iter().zip(&r0.tracks) {
        traj.push(Series {
            name: format!("ours {}", v.name()),
            points: tr.centres.iter().map(|c| (c[0], c[1])).collect(),
        });
    }
    line_chart(
        &dir.join("trajectories.svg"),
        "correlation: window centre, run 0 (x right, y down the image)",
        "x (px)",
        "y (px)",
        &traj,
    )?;
    let err: Vec<Series> = Variant::ALL
        .iter()
        .map(|&v| Series {
            name: v.name().to_string(),
            points: r0
                .errors(v)
                .iter()
                .enumerate()
                .map(|(k, &e)| ((k + 1) as f64, e))
                .collect(),
        })
        .collect();
    line_chart(
        &dir.join("errors.svg"),
        "correlation: centre error per frame, run 0 (billboard: frames 5-21)",
        "frame",
        "error (px)",
        &err,
    )?;
    Ok(())
}

/// The registry entry: job `r < runs` is run `r` of the single-car scene,
/// job `runs` the two-car run.
pub struct CorrelationExperiment;

impl Paper for CorrelationExperiment {
    type Config = CorrelationConfig;
    type Done = Done;
    type Row = FrameRow;
    type Shared = ();
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 004 Tables 1-3";
    const SUMMARY: &'static str =
        "MAD vs PF correlation tracker through an occlusion; Kalman multi-target";
    const LOG: &'static str = "frames.csv";
    const JOBS: &'static str = "correlation runs";

    fn quick() -> CorrelationConfig {
        CorrelationConfig::quick()
    }
    fn full() -> CorrelationConfig {
        CorrelationConfig::paper()
    }
    fn jobs(c: &CorrelationConfig) -> usize {
        c.runs + 1
    }
    fn prepare(_: &CorrelationConfig, _: &[usize]) -> Result<(), ExperimentError> {
        Ok(())
    }
    fn run_job(c: &CorrelationConfig, _: &(), j: usize) -> Result<Done, ExperimentError> {
        if j < c.runs {
            one_run(c, j).map(Done::Run)
        } else {
            multi_run(c).map(Done::Multi)
        }
    }
    fn rows(_: &CorrelationConfig, j: usize, done: &Done) -> Vec<FrameRow> {
        match done {
            Done::Run(r) => frame_rows(j, r),
            Done::Multi(_) => Vec::new(),
        }
    }
    fn report(
        config: &CorrelationConfig,
        done: Vec<Done>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let result = assemble(config, done)?;
        write_outputs(&result, dir)?;
        Ok(result.tables())
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let r = run(&CorrelationConfig::quick())?;
        let mut out = String::from("table,row,column,value\n");
        for s in r.summary() {
            let name = s.variant.name();
            for (col, v) in [
                ("before", s.phases.before),
                ("during", s.phases.during),
                ("after", s.phases.after),
                ("recovered", s.recovered),
            ] {
                let _ = writeln!(out, "summary,{name},{col},{v:.17e}");
            }
        }
        for (v, tr) in Variant::ALL.iter().zip(&r.runs[0].tracks) {
            for (k, c) in tr.centres.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "run0,{} frame {},xy,{:.17e} {:.17e}",
                    v.name(),
                    k + 1,
                    c[0],
                    c[1]
                );
            }
        }
        for (k, cars) in r.multi.tracks.iter().enumerate() {
            for (i, t) in cars.iter().enumerate() {
                let cell = t.map_or("-".to_string(), |v| {
                    format!("{:.17e} {:.17e} {:.17e} {:.17e}", v[0], v[1], v[2], v[3])
                });
                let _ = writeln!(out, "multi,frame {} car {},x y Lx Ly,{cell}", k + 42, i + 1);
            }
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject() {
        let mut c = CorrelationConfig::quick();
        c.apply("sigma", "2").unwrap();
        c.apply("b", "5").unwrap();
        c.apply("gain", "1").unwrap();
        assert_eq!(c.sigma, 2.0);
        assert_eq!(
            c.pf().motion,
            ArpMotion::Drift {
                b: [5.0, 5.0],
                gain: 1.0
            }
        );
        assert!(c.apply("gain", "2").is_err());
        assert_eq!(
            c.pf().motion,
            ArpMotion::Drift {
                b: [5.0, 5.0],
                gain: 1.0
            }
        );
        assert!(c.apply("runs", "0").is_err());
        assert!(c.apply("bogus", "1").is_err());
        assert!(c.apply("sigma", "nan").is_err());
        c.apply("const_b", "2").unwrap();
        assert_eq!(c.const_b, 2.0);
        assert!(c.apply("const_b", "-1").is_err());
        assert!(c.apply("cap", "-1").is_err());
    }

    #[test]
    fn the_initial_box_is_centred_on_the_car() {
        let scene = RoadScene::default().generate(1).unwrap();
        let b = initial_box(&scene.truth[0]).unwrap();
        let (cx, cy) = b.center();
        assert_eq!((cx - 1.0, cy - 1.0), (57.0, 85.0));
        assert_eq!((b.width, b.height), (25.0, 33.0));
    }
}
