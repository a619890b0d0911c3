//! The experiment's declared options.

use super::*;
use bayestrack_trackers::ResamplingCodec;

/// How the per-run error is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorMetric {
    /// `sqrt(mean_t (x_hat - x)^2)`: what the demo code computes.
    Rmse,
    /// Paper 000 eq. 11 as printed, `(mean_t (x_hat - x))^(1/2)`, with the
    /// absolute value taken so that a negative mean error stays real.
    Eq11Literal,
}
choice! { ErrorMetric { Rmse = "rmse", Eq11Literal = "eq11" } }

/// The transition density `p(x_t | x_{t-1})` in the importance weights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PriorDensity {
    /// Gamma density of `x_t - f(x_{t-1})`, zero outside its support (the
    /// model's true density; ReBEL's version of the demo).
    Transition,
    /// The demo's expression `d^2 exp(-2 d)` with `d = x_t - x_{t-1}`
    /// (unnormalised, no support check): likely a bug, kept to compare.
    DemoIncrement,
}
choice! { PriorDensity { Transition = "transition", DemoIncrement = "demo" } }

/// The Gaussian model of the local Kalman filters inside the proposals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProposalNoise {
    /// The demo's tuning: zero-mean process noise with `Q = 7.5` for the
    /// EKF and IEKF proposals, `Q = 1.5` for the UKF and hybrid ones,
    /// `R = 0.1`.
    Demo,
    /// The true moments: process-noise mean 1.5, `Q = 0.75`, `R = 1e-5`.
    TrueMoments,
}
choice! { ProposalNoise { Demo = "demo", TrueMoments = "moments" } }

choice! {
    /// Reads [`HybridPrior`] by name.
    pub codec HybridPriorName for HybridPrior {
        UkfPredicted = "predicted",
        UkfPosterior = "posterior",
    }
}

options! {
    /// Every choice of the experiment, at paper scale by default (100 runs
    /// of 60 steps with 200 particles); the reasons for the defaults are in
    /// docs/reproduction.md.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct HikpfConfig {
        /// Monte Carlo runs (paper 000 sec. 4: 100).
        pub runs: usize = 100, in 1..=MAX_RUNS;
        /// Particles per filter (paper 000 sec. 4: 200).
        pub particles: usize = 200, in 1..=MAX_PARTICLES;
        /// Time steps `T`, the state starting at `t = 1` (the demo's 60).
        pub steps: usize = 60, in 2..=MAX_FRAMES;
        /// Seed of the whole experiment.
        pub seed: u64 = 1;
        /// Frequency `w` of `sin(w pi t)`: 0.04 in the original demo, 0.4 as
        /// paper 000 prints it.
        pub sin_freq: f64 = 0.04;
        /// Paper 000's `c`: IEKF iterations of PF-IEKF and HIKPF (unstated;
        /// 10, swept by `sweep`).
        pub iekf_iterations: usize = 10, in 1..=10_000;
        /// IEKF early-stopping tolerance.
        pub iekf_tolerance: f64 = 1e-10;
        /// Per-run error: `rmse` as the demo computes it, or `eq11` as
        /// paper 000 prints it.
        pub error: ErrorMetric = ErrorMetric::Rmse;
        /// Transition density in the weights (`transition`: the model's own;
        /// `demo`: the demo's expression).
        pub prior: PriorDensity = PriorDensity::Transition;
        /// Local-filter model of the Kalman proposals (`demo` tuning or the
        /// true `moments`).
        pub proposal_noise: ProposalNoise = ProposalNoise::Demo;
        /// Prior of the IEKF refinement inside HIKPF (`predicted`: the
        /// measurement used once).
        pub hybrid_prior: HybridPrior = HybridPrior::UkfPredicted, via HybridPriorName;
        /// Add the demo's `1e-99` to every likelihood (a linear-domain floor).
        pub likelihood_floor: bool = false;
        /// Also run the sweep of [`sweep`] (error formula x likelihood floor
        /// x IEKF iterations) and print it after the main table: on in full
        /// mode, off in quick mode (`--set sweep=true` turns it on there: 10
        /// more runs of the table).
        pub sweep: bool = true;
        /// Resampling scheme, every step (the demo's residual resampling).
        pub resampling: Resampling = Resampling::Residual, via ResamplingCodec;
    }
    check check;
}

/// Most particle steps a run of the experiment may ask for in all (runs x
/// steps x particles x the filters, sweep included): 1e11, about a thousand
/// times the paper's scale. More is a typo (`runs=100000 steps=1000000
/// particles=1000000`, 1e19, would run for millennia), refused before
/// anything runs.
pub const MAX_PARTICLE_STEPS: f64 = 1e11;

/// The cross-option rules, checked before the run starts: a tolerance the
/// IEKF accepts, and a bounded amount of work.
pub(super) fn check(c: &HikpfConfig) -> Result<(), String> {
    if !(c.iekf_tolerance.is_finite() && c.iekf_tolerance >= 0.0) {
        return Err(format!(
            "iekf_tolerance must be a finite number >= 0 (it is {})",
            bayestrack_otb::ground_truth::short_number(c.iekf_tolerance)
        ));
    }
    let cells = if c.sweep { 1 + SWEEP_CELLS } else { 1 };
    let work = c.runs as f64
        * c.steps as f64
        * c.particles as f64
        * (FilterKind::ALL.len() * cells) as f64;
    if work > MAX_PARTICLE_STEPS {
        return Err(format!(
            "runs x steps x particles x {} filter runs = {work:.1e} particle steps, more than \
             the {MAX_PARTICLE_STEPS:.0e} a run may ask for; lower runs, steps or particles",
            FilterKind::ALL.len() * cells
        ));
    }
    Ok(())
}

impl HikpfConfig {
    /// Paper scale: 100 runs of 60 steps with 200 particles, with the sweep.
    pub fn paper() -> Self {
        Self::default()
    }

    /// The CI scale: 20 runs, no sweep.
    pub fn quick() -> Self {
        Self {
            runs: 20,
            sweep: false,
            ..Self::paper()
        }
    }

    /// Applies a `key=value` override (see [`Options::set`]).
    ///
    /// # Errors
    /// [`ExperimentError::BadOption`] for an unknown key or value, listing
    /// every key with its domain; the options are then unchanged.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), ExperimentError> {
        crate::driver::apply(ID, self, key, value)
    }

    /// Every option as `key=value`, for the table footer.
    pub fn describe(&self) -> String {
        Options::describe(self)
    }
}
