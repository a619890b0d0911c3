//! The `hikpf` experiment: paper 000 Table 1 (and van der Merwe et al. 2000,
//! Table 1) on the scalar model of the original unscented-particle-filter
//! demo,
//!
//! `x_t = 1 + sin(w pi t) + 0.5 x_{t-1} + v_{t-1}`, `v ~ Gamma(3, rate 2)`,
//! `y_t = x_t^2 / 5 + n` for `t <= 30`, `x_t / 2 - 2 + n` after,
//! `n ~ N(0, 1e-5)`, `x_1 = 1`, `t = 1..60`.
//!
//! Every ambiguity of the paper is a named option of [`HikpfConfig`]; the
//! defaults and the reasons for them are in docs/reproduction.md.

use std::fmt::Write as _;
use std::path::Path;

use bayestrack_kalman::{
    Dynamics, DynamicsJacobian, Ekf, Gaussian, HybridPrior, HybridUkfIekf, Iekf, Measurement,
    MeasurementJacobian, NoiseForm, Ukf,
};
use bayestrack_particle::{
    Bootstrap, Degenerate, KalmanParticle, KalmanProposal, LocalFilter, Model, ParticleError,
    ParticleFilter, ParticleSet, ResamplePolicy, Resampling, TransitionDensity, stream_rng,
};
use nalgebra::{Matrix1, SMatrix, SVector, Vector1};
use rand::Rng;
use rand_distr::{Distribution, Gamma, StandardNormal};

use crate::driver::Paper;
use crate::experiment::{ExperimentError, MAX_FRAMES, MAX_PARTICLES, MAX_RUNS, write_text};
use bayestrack_options::{Options, choice, options};
use bayestrack_otb::Table;
use bayestrack_otb::plot::{Series, line_chart};

/// The experiment's id.
const ID: &str = "hikpf";

/// Key of this experiment's random streams.
const KEY: u64 = 0x0068_696b_7066; // "hikpf" in ASCII

/// Gamma process noise: shape 3, rate 2 (scale 1/2): mean 1.5, variance 0.75.
const GAMMA_SHAPE: f64 = 3.0;
const GAMMA_RATE: f64 = 2.0;
/// Measurement noise variance.
const SIGMA: f64 = 1e-5;
/// Prior variance of the EKF/UKF and of each Kalman particle (the demo's P0).
const P0: f64 = 0.75;

mod options;
mod paper;
mod report;
mod score;
pub use options::*;
pub use paper::*;
pub use report::*;
pub use score::*;

/// `f(x, t) = 1 + sin(w pi t) + 0.5 x` (without noise).
#[inline]
fn drift(t: usize, w: f64) -> f64 {
    1.0 + (w * std::f64::consts::PI * t as f64).sin()
}

/// `h(x, t)` and its derivative.
#[inline]
fn observe(x: f64, t: usize) -> (f64, f64) {
    if t <= 30 {
        (0.2 * x * x, 0.4 * x)
    } else {
        (0.5 * x - 2.0, 0.5)
    }
}

/// The true model at time `t`, for the particle weights.
struct TrueModel {
    t: usize,
    drift: f64,
    prior: PriorDensity,
    floor: bool,
    gamma: Gamma<f64>,
}

impl TrueModel {
    fn new(t: usize, c: &HikpfConfig) -> Self {
        Self {
            t,
            drift: drift(t, c.sin_freq),
            prior: c.prior,
            floor: c.likelihood_floor,
            gamma: Gamma::new(GAMMA_SHAPE, 1.0 / GAMMA_RATE).expect("valid Gamma parameters"),
        }
    }
}

/// `ln Gamma(3) = ln 2`.
const LN_GAMMA_SHAPE: f64 = std::f64::consts::LN_2;

impl Model<1> for TrueModel {
    type Observation = SVector<f64, 1>;
    #[inline]
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 1>,
        rng: &mut R,
    ) -> SVector<f64, 1> {
        Vector1::new(self.drift + 0.5 * x[0] + self.gamma.sample(rng))
    }
    #[inline]
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 1>, z: &SVector<f64, 1>) -> f64 {
        let e = z[0] - observe(x[0], self.t).0;
        // the demo's unnormalised sigma^(-1/2) exp(-e^2 / (2 sigma))
        let ll = -0.5 * e * e / SIGMA - 0.5 * SIGMA.ln();
        if self.floor {
            let floor = 1e-99f64.ln();
            let m = ll.max(floor);
            m + ((ll - m).exp() + (floor - m).exp()).ln()
        } else {
            ll
        }
    }
}

impl TransitionDensity<1> for TrueModel {
    fn log_transition(&self, _k: usize, x_prev: &SVector<f64, 1>, x: &SVector<f64, 1>) -> f64 {
        match self.prior {
            PriorDensity::Transition => {
                let d = x[0] - (self.drift + 0.5 * x_prev[0]);
                if d <= 0.0 {
                    f64::NEG_INFINITY
                } else {
                    GAMMA_SHAPE * GAMMA_RATE.ln() + (GAMMA_SHAPE - 1.0) * d.ln()
                        - GAMMA_RATE * d
                        - LN_GAMMA_SHAPE
                }
            }
            PriorDensity::DemoIncrement => {
                let d = x[0] - x_prev[0];
                (GAMMA_SHAPE - 1.0) * d.abs().ln() - GAMMA_RATE * d
            }
        }
    }
}

/// The Gaussian model of the local filters at time `t`.
struct LocalModel {
    t: usize,
    drift: f64,
    noise_mean: f64,
    q: f64,
    r: f64,
}

impl Dynamics<1> for LocalModel {
    #[inline]
    fn propagate(&self, x: &SVector<f64, 1>) -> SVector<f64, 1> {
        Vector1::new(self.drift + 0.5 * x[0] + self.noise_mean)
    }
    #[inline]
    fn process_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(self.q)
    }
}

impl DynamicsJacobian<1> for LocalModel {
    #[inline]
    fn jacobian(&self, _: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        Matrix1::new(0.5)
    }
}

impl Measurement<1, 1> for LocalModel {
    #[inline]
    fn observe(&self, x: &SVector<f64, 1>) -> SVector<f64, 1> {
        Vector1::new(observe(x[0], self.t).0)
    }
    #[inline]
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(self.r)
    }
}

impl MeasurementJacobian<1, 1> for LocalModel {
    #[inline]
    fn jacobian(&self, x: &SVector<f64, 1>) -> SMatrix<f64, 1, 1> {
        Matrix1::new(observe(x[0], self.t).1)
    }
}

/// Local model of the standalone EKF/UKF (demo: zero-mean noise, Q = 0.75,
/// R = 1e-5) or of a proposal with the given demo `Q`.
fn local(t: usize, c: &HikpfConfig, demo_q: Option<f64>) -> LocalModel {
    let (noise_mean, q, r) = match (demo_q, c.proposal_noise) {
        (None, _) => (0.0, 0.75, SIGMA),
        (Some(q), ProposalNoise::Demo) => (0.0, q, 0.1),
        (Some(_), ProposalNoise::TrueMoments) => (1.5, 0.75, SIGMA),
    };
    LocalModel {
        t,
        drift: drift(t, c.sin_freq),
        noise_mean,
        q,
        r,
    }
}

/// One simulated run: states and measurements for `t = 1..T` (index 0 is
/// `t = 1`, whose measurement is never used).
fn simulate(c: &HikpfConfig, run: usize) -> (Vec<f64>, Vec<f64>) {
    let mut rng = stream_rng(&[KEY, c.seed, run as u64, 0]);
    let gamma = Gamma::new(GAMMA_SHAPE, 1.0 / GAMMA_RATE).expect("valid Gamma parameters");
    let mut x = vec![1.0];
    let mut y = vec![observe(1.0, 1).0];
    for t in 2..=c.steps {
        let xt = drift(t, c.sin_freq) + 0.5 * x[t - 2] + gamma.sample(&mut rng);
        let n: f64 = StandardNormal.sample(&mut rng);
        x.push(xt);
        y.push(observe(xt, t).0 + SIGMA.sqrt() * n);
    }
    (x, y)
}

/// The error of one run's estimates.
fn run_error(metric: ErrorMetric, est: &[f64], truth: &[f64]) -> f64 {
    let n = truth.len() as f64;
    match metric {
        ErrorMetric::Rmse => (est
            .iter()
            .zip(truth)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / n)
            .sqrt(),
        ErrorMetric::Eq11Literal => (est.iter().zip(truth).map(|(a, b)| a - b).sum::<f64>() / n)
            .abs()
            .sqrt(),
    }
}

/// The result of one filter on one run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunOutcome {
    /// Per-run error (the configured [`ErrorMetric`]).
    pub error: f64,
    /// The same run's error under the other [`ErrorMetric`] (for the
    /// sweep, which reads both from one run).
    pub other_error: f64,
    /// Steps at which every weight was zero (measurement ignored).
    pub degenerate: usize,
    /// Metropolis-Hastings moves accepted over the run (0 without MCMC).
    pub accepted: usize,
}

fn failed(kind: FilterKind, run: usize, t: usize, e: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Failed {
        id: "hikpf",
        message: format!("{} failed at run {run}, t = {t}: {e}", kind.name()),
    }
}

/// The particle filter configuration shared by every PF row: resampling at
/// every step (the demo), a step whose weights are all zero ignores its
/// measurement and is counted.
fn particle_filter(c: &HikpfConfig, mcmc: bool) -> ParticleFilter {
    ParticleFilter {
        resampling: c.resampling,
        policy: ResamplePolicy::Always,
        mcmc,
        chunk_size: 1024,
        degenerate: Degenerate::IgnoreMeasurement,
        ..ParticleFilter::default()
    }
}

/// One step of a particle filter at time `t`.
type PfStep<'a, T> = dyn Fn(
        &ParticleFilter,
        &mut ParticleSet<T>,
        usize,
        &SVector<f64, 1>,
        &[u64],
    ) -> Result<bayestrack_particle::StepReport<1>, ParticleError>
    + 'a;

/// Runs one particle filter over one run; the estimate is the mean of the
/// particles after resampling (and after the MCMC move), as in the demo.
fn run_particles<T: bayestrack_particle::Particle<1>>(
    c: &HikpfConfig,
    kind: FilterKind,
    run: usize,
    y: &[f64],
    initial: T,
    step: &PfStep<'_, T>,
) -> Result<(Vec<f64>, usize, usize), ExperimentError> {
    let mcmc = matches!(
        kind,
        FilterKind::PfMcmc | FilterKind::PfEkfMcmc | FilterKind::PfUkfMcmc
    );
    let pf = particle_filter(c, mcmc);
    let mut set =
        ParticleSet::new(vec![initial; c.particles]).map_err(|e| failed(kind, run, 1, e))?;
    let mut est = vec![1.0];
    let (mut degenerate, mut accepted) = (0, 0);
    for (t, &yt) in y.iter().enumerate().skip(1).map(|(i, v)| (i + 1, v)) {
        let key = [KEY, c.seed, run as u64, kind as u64 + 1, t as u64];
        let report =
            step(&pf, &mut set, t, &Vector1::new(yt), &key).map_err(|e| failed(kind, run, t, e))?;
        degenerate += usize::from(report.degenerate);
        accepted += report.accepted;
        est.push(set.mean()[0]);
    }
    Ok((est, degenerate, accepted))
}

/// A step with Kalman proposals from `filter` on the local model with the
/// demo's `demo_q`.
fn kalman_step<'a, F: LocalFilter<1, 1, LocalModel> + 'a>(
    c: &'a HikpfConfig,
    filter: F,
    demo_q: f64,
) -> Box<PfStep<'a, KalmanParticle<1>>> {
    Box::new(move |pf, set, t, z, key| {
        let model = TrueModel::new(t, c);
        let local = local(t, c, Some(demo_q));
        let proposal = KalmanProposal {
            model: &model,
            local: &local,
            filter: &filter,
        };
        pf.step(set, &proposal, z, key)
    })
}

/// The estimates of the standalone EKF or UKF (demo: Q = 0.75, R = 1e-5,
/// zero-mean process noise, P0 = 0.75).
fn run_kalman(
    c: &HikpfConfig,
    kind: FilterKind,
    run: usize,
    y: &[f64],
) -> Result<Vec<f64>, ExperimentError> {
    let ukf = Ukf::new(1.0, 0.0, 2.0)
        .expect("valid UT parameters")
        .with_noise_form(NoiseForm::Augmented);
    let ekf = Ekf::default();
    let mut belief =
        Gaussian::new(Vector1::new(1.0), Matrix1::new(P0)).map_err(|e| failed(kind, run, 1, e))?;
    let mut est = vec![1.0];
    for (t, &yt) in y.iter().enumerate().skip(1).map(|(i, v)| (i + 1, v)) {
        let m = local(t, c, None);
        let z = Vector1::new(yt);
        let next = match kind {
            FilterKind::Ekf => ekf
                .predict(&belief, &m)
                .and_then(|p| ekf.update(&p, &m, Some(&z)))
                .map(|u| u.posterior),
            _ => ukf
                .step(&belief, &m, &m, Some(&z))
                .map(|s| s.update.posterior),
        };
        belief = next.map_err(|e| failed(kind, run, t, e))?;
        est.push(belief.mean()[0]);
    }
    Ok(est)
}

/// Every filter on one run.
fn one_run(c: &HikpfConfig, run: usize) -> Result<Vec<RunOutcome>, ExperimentError> {
    let (x, y) = simulate(c, run);
    let ukf = Ukf::new(1.0, 0.0, 2.0)
        .expect("valid UT parameters")
        .with_noise_form(NoiseForm::Augmented);
    let iekf =
        Iekf::new(c.iekf_iterations, c.iekf_tolerance).map_err(|e| ExperimentError::Failed {
            id: "hikpf",
            message: e.to_string(),
        })?;
    let hybrid = HybridUkfIekf {
        ukf,
        iekf,
        prior: c.hybrid_prior,
    };
    let bootstrap: Box<PfStep<'_, SVector<f64, 1>>> = Box::new(|pf, set, t, z, key| {
        let model = TrueModel::new(t, c);
        pf.step(set, &Bootstrap(&model), z, key)
    });
    let kp = KalmanParticle {
        x: Vector1::new(1.0),
        cov: Matrix1::new(P0),
    };
    FilterKind::ALL
        .iter()
        .map(|&kind| {
            let (est, degenerate, accepted) = match kind {
                FilterKind::Ekf | FilterKind::Ukf => (run_kalman(c, kind, run, &y)?, 0, 0),
                FilterKind::Pf | FilterKind::PfMcmc => {
                    run_particles(c, kind, run, &y, Vector1::new(1.0), &*bootstrap)?
                }
                FilterKind::PfEkf | FilterKind::PfEkfMcmc => {
                    run_particles(c, kind, run, &y, kp, &*kalman_step(c, Ekf::default(), 7.5))?
                }
                FilterKind::PfUkf | FilterKind::PfUkfMcmc => {
                    run_particles(c, kind, run, &y, kp, &*kalman_step(c, ukf, 1.5))?
                }
                FilterKind::PfIekf => {
                    run_particles(c, kind, run, &y, kp, &*kalman_step(c, iekf, 7.5))?
                }
                FilterKind::Hikpf => {
                    run_particles(c, kind, run, &y, kp, &*kalman_step(c, hybrid, 1.5))?
                }
            };
            let other = match c.error {
                ErrorMetric::Rmse => ErrorMetric::Eq11Literal,
                ErrorMetric::Eq11Literal => ErrorMetric::Rmse,
            };
            Ok(RunOutcome {
                error: run_error(c.error, &est, &x),
                other_error: run_error(other, &est, &x),
                degenerate,
                accepted,
            })
        })
        .collect()
}

/// The registry entry: job `j` is run `j % runs` of the main table
/// (`j < runs`) or of sweep cell `j / runs - 1` ([`sweep`], when on).
pub struct HikpfExperiment;

impl Paper for HikpfExperiment {
    type Config = HikpfConfig;
    type Done = Vec<RunOutcome>;
    type Row = RunRow;
    type Shared = ();
    const ID: &'static str = ID;
    const SOURCE: &'static str = "paper 000 Table 1; van der Merwe et al. 2000 Table 1";
    const SUMMARY: &'static str =
        "EKF, UKF, PF, PF-EKF, PF-UKF, PF-IEKF, HIKPF (+MCMC) on the Gamma-noise model";
    const LOG: &'static str = "runs.csv";
    const JOBS: &'static str = "hikpf runs";

    fn quick() -> HikpfConfig {
        HikpfConfig::quick()
    }
    fn full() -> HikpfConfig {
        HikpfConfig::paper()
    }
    fn jobs(c: &HikpfConfig) -> usize {
        c.runs * if c.sweep { 1 + SWEEP_CELLS } else { 1 }
    }
    fn prepare(_: &HikpfConfig, _: &[usize]) -> Result<(), ExperimentError> {
        Ok(())
    }
    fn run_job(c: &HikpfConfig, _: &(), j: usize) -> Result<Vec<RunOutcome>, ExperimentError> {
        let (cell, r) = (j / c.runs, j % c.runs);
        if cell == 0 {
            one_run(c, r)
        } else {
            one_run(&sweep_config(c, cell - 1), r)
        }
    }
    fn rows(c: &HikpfConfig, j: usize, done: &Vec<RunOutcome>) -> Vec<RunRow> {
        if j < c.runs {
            run_rows(j, done)
        } else {
            Vec::new()
        }
    }
    fn report(
        config: &HikpfConfig,
        mut runs: Vec<Vec<RunOutcome>>,
        dir: &Path,
    ) -> Result<Vec<Table>, ExperimentError> {
        let swept = runs.split_off(config.runs.min(runs.len()));
        let result = HikpfResult {
            config: *config,
            runs,
        };
        write_outputs(&result, dir)?;
        let mut tables = vec![result.table()];
        if config.sweep {
            let t = sweep_table(&sweep_cells(config, swept), config.runs);
            write_text(&dir.join("sweep.csv"), &t.to_csv())?;
            tables.push(t);
        }
        Ok(tables)
    }

    fn golden() -> Result<Option<String>, ExperimentError> {
        let mut out = String::from("config,filter,mean,var,median,all_zero_steps\n");
        for (name, config) in golden_configs() {
            for s in run(&config, None, false)?.summary() {
                let _ = writeln!(
                    out,
                    "{name},{},{:.17e},{:.17e},{:.17e},{}",
                    s.kind.name(),
                    s.mean,
                    s.var,
                    s.median,
                    s.degenerate
                );
            }
        }
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_csv_is_replaced_whole_in_run_order() {
        let dir = std::env::temp_dir().join(format!("bayestrack-hikpf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("runs.csv");
        std::fs::write(&path, "previous\n").unwrap();
        let config = HikpfConfig {
            runs: 3,
            particles: 20,
            ..HikpfConfig::quick()
        };
        let result = run(&config, Some(&path), false).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let rows: Vec<RunRow> = (0..3).flat_map(|r| run_rows(r, &result.runs[r])).collect();
        assert_eq!(rows.len(), 3 * FilterKind::ALL.len());
        assert_eq!(text, bayestrack_otb::write::csv_text(&rows));
        assert!(text.starts_with("run,filter,error\n0,"), "{text}");
        // full precision: every error reads back to the same f64
        let first: f64 = text
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(2)
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(first, result.runs[0][0].error);
        assert!(!dir.join("runs.partial.csv").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn gamma_log_density_integrates_to_one() {
        let c = HikpfConfig::quick();
        let m = TrueModel::new(5, &c);
        let x0 = Vector1::new(0.3);
        let f = m.drift + 0.15;
        let h = 1e-3;
        let total: f64 = (1..20_000)
            .map(|i| {
                m.log_transition(0, &x0, &Vector1::new(f + i as f64 * h))
                    .exp()
                    * h
            })
            .sum();
        assert!((total - 1.0).abs() < 1e-3, "{total}");
        assert_eq!(
            m.log_transition(0, &x0, &Vector1::new(f - 0.1)),
            f64::NEG_INFINITY
        );
    }

    #[test]
    fn simulation_is_seeded_and_follows_the_model() {
        let c = HikpfConfig::quick();
        let (x, y) = simulate(&c, 3);
        assert_eq!((x.len(), y.len()), (60, 60));
        assert_eq!(simulate(&c, 3), (x.clone(), y.clone()));
        assert_ne!(simulate(&c, 4).0, x);
        for t in 2..=60 {
            let d = x[t - 1] - drift(t, c.sin_freq) - 0.5 * x[t - 2];
            assert!(d > 0.0, "Gamma noise is positive");
            assert!((y[t - 1] - observe(x[t - 1], t).0).abs() < 0.02);
        }
    }

    #[test]
    fn options_parse_and_reject() {
        let mut c = HikpfConfig::quick();
        c.apply("sin_freq", "0.4").unwrap();
        c.apply("prior", "demo").unwrap();
        c.apply("resampling", "systematic").unwrap();
        assert_eq!(
            (c.sin_freq, c.prior, c.resampling),
            (0.4, PriorDensity::DemoIncrement, Resampling::Systematic)
        );
        assert!(c.apply("prior", "nope").is_err());
        assert!(c.apply("bogus", "1").is_err());
        assert!(c.apply("runs", "0").is_err());
    }

    #[test]
    fn errors_are_computed_as_documented() {
        assert!(
            (run_error(ErrorMetric::Rmse, &[1.0, 3.0], &[1.0, 1.0]) - 2f64.sqrt()).abs() < 1e-15
        );
        assert!(
            (run_error(ErrorMetric::Eq11Literal, &[1.0, 3.0], &[1.0, 1.0]) - 1.0).abs() < 1e-15
        );
    }
}
