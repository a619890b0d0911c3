//! Particle filters against the Kalman filter, value stability and thread
//! independence, and errors.

use bayestrack_kalman::{
    Dynamics, DynamicsJacobian, Ekf, Gaussian, HybridUkfIekf, Iekf, Kf, LinearDynamics,
    LinearMeasurement, Measurement, MeasurementJacobian, NoiseForm, Ukf,
};
use bayestrack_particle::{
    Bootstrap, Degenerate, KalmanParticle, KalmanProposal, Model, ParticleError, ParticleFilter,
    ParticleSet, Proposal, ResamplePolicy, ResampleTiming, Resampling, TransitionDensity,
    stream_rng,
};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, SMatrix, SVector, Vector1, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// 1-D position/velocity random walk observed in position: linear-Gaussian.
#[derive(Clone)]
struct Lin {
    f: Matrix2<f64>,
    q: Matrix2<f64>,
    h: Matrix1x2<f64>,
    r: f64,
}

impl Lin {
    fn new() -> Self {
        Self {
            f: Matrix2::new(1.0, 0.5, 0.0, 0.9),
            q: Matrix2::new(0.05, 0.01, 0.01, 0.1),
            h: Matrix1x2::new(1.0, 0.0),
            r: 0.5,
        }
    }
}

impl Model<2> for Lin {
    type Observation = SVector<f64, 1>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 2>,
        rng: &mut R,
    ) -> SVector<f64, 2> {
        let l = self.q.cholesky().unwrap().l();
        let e = Vector2::new(StandardNormal.sample(rng), StandardNormal.sample(rng));
        self.f * x + l * e
    }
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 2>, z: &SVector<f64, 1>) -> f64 {
        let d = z[0] - (self.h * x)[0];
        -0.5 * (d * d / self.r + (2.0 * std::f64::consts::PI * self.r).ln())
    }
}

impl TransitionDensity<2> for Lin {
    fn log_transition(&self, _k: usize, x_prev: &SVector<f64, 2>, x: &SVector<f64, 2>) -> f64 {
        Gaussian::new(self.f * x_prev, self.q)
            .unwrap()
            .log_pdf(x)
            .unwrap()
    }
}

impl Dynamics<2> for Lin {
    fn propagate(&self, x: &SVector<f64, 2>) -> SVector<f64, 2> {
        self.f * x
    }
    fn process_noise(&self) -> SMatrix<f64, 2, 2> {
        self.q
    }
}
impl DynamicsJacobian<2> for Lin {
    fn jacobian(&self, _: &SVector<f64, 2>) -> SMatrix<f64, 2, 2> {
        self.f
    }
}
impl Measurement<2, 1> for Lin {
    fn observe(&self, x: &SVector<f64, 2>) -> SVector<f64, 1> {
        self.h * x
    }
    fn measurement_noise(&self) -> SMatrix<f64, 1, 1> {
        Matrix1::new(self.r)
    }
}
impl MeasurementJacobian<2, 1> for Lin {
    fn jacobian(&self, _: &SVector<f64, 2>) -> SMatrix<f64, 1, 2> {
        self.h
    }
}

fn data(model: &Lin, steps: usize) -> Vec<Vector1<f64>> {
    let mut rng = stream_rng(&[42]);
    let mut x = Vector2::new(0.0, 1.0);
    (0..steps)
        .map(|_| {
            x = model.sample_transition(0, &x, &mut rng);
            let e: f64 = StandardNormal.sample(&mut rng);
            Vector1::new(x[0] + model.r.sqrt() * e)
        })
        .collect()
}

fn kalman(model: &Lin, zs: &[Vector1<f64>], p0: &Gaussian<2>) -> Vec<Gaussian<2>> {
    let dyn_ = LinearDynamics::new(model.f, model.q).unwrap();
    let sensor = LinearMeasurement::new(model.h, Matrix1::new(model.r)).unwrap();
    let kf = Kf::default();
    let mut g = *p0;
    zs.iter()
        .map(|z| {
            let p = kf.predict(&g, &dyn_).unwrap();
            g = kf.update(&p, &sensor, Some(z)).unwrap().posterior;
            g
        })
        .collect()
}

fn initial_particles(p0: &Gaussian<2>, n: usize) -> Vec<SVector<f64, 2>> {
    let mut rng = stream_rng(&[7]);
    (0..n).map(|_| p0.sample(&mut rng).unwrap()).collect()
}

#[test]
fn bootstrap_filter_with_10000_particles_matches_the_kalman_filter() {
    let model = Lin::new();
    let zs = data(&model, 25);
    let p0 = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
    let truth = kalman(&model, &zs, &p0);
    let n = 10_000;
    let mut set = ParticleSet::new(initial_particles(&p0, n)).unwrap();
    let pf = ParticleFilter {
        policy: ResamplePolicy::Ess(0.5),
        ..ParticleFilter::default()
    };
    for (k, (z, kf)) in zs.iter().zip(&truth).enumerate() {
        pf.step(&mut set, &Bootstrap(&model), z, &[1, k as u64])
            .unwrap();
        assert_near_kalman(&set, kf, k);
    }
}

/// The weighted set's mean within 5 Monte Carlo sigma (`sqrt(var / ESS)`,
/// doubled) and its variances within 15 % of the Kalman filter's at step
/// `k`.
fn assert_near_kalman(set: &ParticleSet<SVector<f64, 2>>, kf: &Gaussian<2>, k: usize) {
    let n = set.len() as f64;
    let m = set.mean();
    let c = set.covariance();
    for i in 0..2 {
        let sd = kf.cov()[(i, i)].sqrt();
        let tol = 5.0 * sd / (set.ess().min(n) * 0.5).sqrt();
        assert!(
            (m[i] - kf.mean()[i]).abs() < tol,
            "step {k} mean {i}: {} vs {}",
            m[i],
            kf.mean()[i]
        );
        let rel = (c[(i, i)] / kf.cov()[(i, i)] - 1.0).abs();
        assert!(
            rel < 0.15,
            "step {k} var {i}: {} vs {}",
            c[(i, i)],
            kf.cov()[(i, i)]
        );
    }
}

fn run_kalman_pf<F: bayestrack_particle::LocalFilter<2, 1, Lin>>(
    filter: F,
    mcmc: bool,
) -> (f64, usize) {
    let model = Lin::new();
    let zs = data(&model, 20);
    let p0 = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
    let truth = kalman(&model, &zs, &p0);
    let n = 2000;
    let particles = initial_particles(&p0, n)
        .into_iter()
        .map(|x| KalmanParticle { x, cov: model.q })
        .collect();
    let mut set = ParticleSet::new(particles).unwrap();
    let pf = ParticleFilter {
        resampling: Resampling::Residual,
        mcmc,
        ..ParticleFilter::default()
    };
    let proposal = KalmanProposal {
        model: &model,
        local: &model,
        filter,
    };
    let mut worst = 0.0f64;
    let mut accepted = 0;
    for (k, (z, kf)) in zs.iter().zip(&truth).enumerate() {
        let r = pf.step(&mut set, &proposal, z, &[2, k as u64]).unwrap();
        accepted += r.accepted;
        let m = set.mean();
        // Monte Carlo standard error of the mean after weighting (ESS) and
        // resampling (N), in posterior standard deviations.
        let se = (1.0 / r.ess + 1.0 / n as f64).sqrt();
        for i in 0..2 {
            let z_score = (m[i] - kf.mean()[i]).abs() / kf.cov()[(i, i)].sqrt() / se;
            worst = worst.max(z_score);
        }
    }
    (worst, accepted)
}

#[test]
fn kalman_proposal_filters_match_the_kalman_filter() {
    // Worst z-score of the posterior mean over 20 steps and 2 components,
    // N = 2000: below 4.5 for a consistent filter.
    for (name, worst) in [
        ("ekf", run_kalman_pf(Ekf::default(), false).0),
        (
            "ukf",
            run_kalman_pf(
                Ukf::new(1.0, 0.0, 2.0)
                    .unwrap()
                    .with_noise_form(NoiseForm::Augmented),
                false,
            )
            .0,
        ),
        ("iekf", run_kalman_pf(Iekf::new(3, 1e-9).unwrap(), false).0),
        (
            "hikpf",
            run_kalman_pf(
                HybridUkfIekf::new(
                    Ukf::new(1.0, 0.0, 2.0).unwrap(),
                    Iekf::new(3, 1e-9).unwrap(),
                ),
                false,
            )
            .0,
        ),
    ] {
        assert!(worst < 4.5, "{name}: worst z-score of the mean {worst}");
    }
}

#[test]
fn mcmc_move_accepts_and_keeps_the_posterior() {
    let (worst, accepted) = run_kalman_pf(Ekf::default(), true);
    assert!(worst < 4.5, "worst z-score of the mean {worst}");
    // 20 steps x 2000 particles; the independence sampler accepts about
    // as often as the ESS fraction suggests (30-50% here)
    assert!(
        accepted > 20 * 2000 / 10 && accepted < 20 * 2000 * 9 / 10,
        "accepted {accepted}"
    );
}

fn trajectory(threads: usize, chunk: usize) -> Vec<f64> {
    trajectory_with(
        threads,
        chunk,
        Resampling::Systematic,
        ResamplePolicy::Always,
    )
}

fn trajectory_with(
    threads: usize,
    chunk: usize,
    resampling: Resampling,
    policy: ResamplePolicy,
) -> Vec<f64> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let model = Lin::new();
        let zs = data(&model, 10);
        let p0 = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
        let mut set = ParticleSet::new(initial_particles(&p0, 5000)).unwrap();
        let pf = ParticleFilter {
            resampling,
            policy,
            chunk_size: chunk,
            mcmc: true,
            ..ParticleFilter::default()
        };
        let mut out = vec![];
        for (k, z) in zs.iter().enumerate() {
            pf.step(&mut set, &Bootstrap(&model), z, &[3, k as u64])
                .unwrap();
            out.push(set.mean()[0]);
            out.push(set.particles()[1234][1]);
        }
        out
    })
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let one = trajectory(1, 256);
    let two = trajectory(2, 256);
    assert_eq!(one, two);
    // every scheme, and steps that keep their weights (ESS policy)
    for scheme in Resampling::ALL {
        let policy = ResamplePolicy::Ess(0.6);
        assert_eq!(
            trajectory_with(1, 300, scheme, policy),
            trajectory_with(2, 300, scheme, policy),
            "{scheme:?}"
        );
    }
}

#[test]
fn value_stability_of_a_seeded_run() {
    // Pinned: a change here means a change in the random streams or in the
    // arithmetic of the filter. Update deliberately, never to make CI pass.
    let t = trajectory(2, 256);
    let pinned = [t[0], t[1], t[18], t[19]];
    let expected: [f64; 4] = [PINNED_0, PINNED_1, PINNED_18, PINNED_19];
    for (a, b) in pinned.iter().zip(&expected) {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            "{pinned:?} vs {expected:?}"
        );
    }
}

const PINNED_0: f64 = -0.6090588216534392;
const PINNED_1: f64 = -0.4151795613575894;
const PINNED_18: f64 = 6.604258955447964;
const PINNED_19: f64 = 1.5164426129558723;

/// Particles that stay where they are (their state is their index) and
/// whose log-likelihood is read from a table: the step's weights can be
/// checked against a direct computation.
struct Table(Vec<f64>);

impl Model<1> for Table {
    type Observation = SVector<f64, 1>;
    fn sample_transition<R: Rng + ?Sized>(
        &self,
        _k: usize,
        x: &SVector<f64, 1>,
        _: &mut R,
    ) -> SVector<f64, 1> {
        *x
    }
    fn log_likelihood(&self, _k: usize, x: &SVector<f64, 1>, _: &SVector<f64, 1>) -> f64 {
        self.0[x[0] as usize]
    }
}

impl TransitionDensity<1> for Table {
    fn log_transition(&self, _k: usize, _: &SVector<f64, 1>, _: &SVector<f64, 1>) -> f64 {
        0.0
    }
}

#[test]
fn all_zero_weights_are_an_error_or_a_counted_fallback() {
    let mut set = ParticleSet::new(vec![Vector1::new(0.0), Vector1::new(1.0)]).unwrap();
    let z = Vector1::new(0.0);
    let blind = Table(vec![f64::NEG_INFINITY; 2]);
    let pf = ParticleFilter::default();
    assert_eq!(
        pf.step(&mut set, &Bootstrap(&blind), &z, &[0]),
        Err(ParticleError::AllWeightsZero { count: 2 })
    );
    let lenient = ParticleFilter {
        degenerate: Degenerate::IgnoreMeasurement,
        ..pf
    };
    let r = lenient
        .step(&mut set, &Bootstrap(&blind), &z, &[0])
        .unwrap();
    assert!(r.degenerate);
    assert!((set.weights()[0] - 0.5).abs() < 1e-12);
    let bad = ParticleFilter {
        chunk_size: 0,
        ..pf
    };
    assert!(matches!(
        bad.step(&mut set, &Bootstrap(&blind), &z, &[0]),
        Err(ParticleError::InvalidParameter { .. })
    ));
    let bad = ParticleFilter {
        policy: ResamplePolicy::Ess(2.0),
        ..pf
    };
    assert!(bad.validate().is_err());
}

#[test]
fn a_failing_local_filter_names_the_particle() {
    // a particle with an indefinite covariance cannot seed its Kalman filter
    let model = Lin::new();
    let good = KalmanParticle {
        x: Vector2::zeros(),
        cov: Matrix2::identity(),
    };
    let bad = KalmanParticle {
        x: Vector2::zeros(),
        cov: Matrix2::new(1.0, 2.0, 2.0, 1.0),
    };
    let mut set = ParticleSet::new(vec![good, good, bad]).unwrap();
    let proposal = KalmanProposal {
        model: &model,
        local: &model,
        filter: Ekf::default(),
    };
    let r = ParticleFilter::default().step(&mut set, &proposal, &Vector1::new(0.0), &[0]);
    assert!(
        matches!(r, Err(ParticleError::Proposal { index: 2, .. })),
        "{r:?}"
    );
    // the proposal's own error comes back with its type
    let Err(ParticleError::Proposal { source, .. }) = r else {
        unreachable!()
    };
    assert!(
        source
            .downcast_ref::<bayestrack_kalman::KalmanError>()
            .is_some(),
        "{source:?}"
    );
}

/// A proposal with an error type and a scratch of its own: it fails on
/// a negative parent, and counts in its per-chunk scratch the particles it
/// has proposed (so a test sees that the scratch is kept between steps).
struct Counting;

#[derive(Debug, PartialEq)]
struct Negative(f64);

impl std::fmt::Display for Negative {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "negative parent {}", self.0)
    }
}

impl std::error::Error for Negative {}

impl Proposal<SVector<f64, 1>, ()> for Counting {
    type Error = Negative;
    type Scratch = usize;
    fn propose<R: Rng + ?Sized>(
        &self,
        _k: usize,
        parent: &SVector<f64, 1>,
        _z: &(),
        scratch: &mut usize,
        _rng: &mut R,
    ) -> Result<(SVector<f64, 1>, f64), Negative> {
        *scratch += 1;
        if parent[0] < 0.0 {
            return Err(Negative(parent[0]));
        }
        Ok((*parent, 0.0))
    }
}

#[test]
fn proposals_bring_their_own_errors_and_keep_their_scratch() {
    let pf = ParticleFilter {
        chunk_size: 4,
        ..ParticleFilter::default()
    };
    let mut set = index_set(10);
    let mut scratch = Vec::new();
    for k in 1..=3 {
        pf.step_with(&mut set, &Counting, &(), &[k], &mut scratch)
            .unwrap();
    }
    // chunks of 4, 4 and 2 particles, three steps each
    assert_eq!(scratch, vec![12, 12, 6]);
    let mut bad = ParticleSet::new(vec![Vector1::new(1.0), Vector1::new(-2.0)]).unwrap();
    let r = pf.step(&mut bad, &Counting, &(), &[0]);
    let Err(ParticleError::Proposal { index, source }) = r else {
        panic!("{r:?}")
    };
    assert_eq!(index, 1);
    assert_eq!(source.downcast_ref::<Negative>(), Some(&Negative(-2.0)));
    assert!(
        source.to_string().contains("negative parent -2"),
        "{source}"
    );
}

#[test]
fn resampling_before_the_proposal_keeps_the_weighted_set() {
    let model = Lin::new();
    let zs = data(&model, 25);
    let p0 = Gaussian::new(Vector2::new(0.0, 1.0), Matrix2::identity()).unwrap();
    let truth = kalman(&model, &zs, &p0);
    let n = 10_000;
    let mut set = ParticleSet::new(initial_particles(&p0, n)).unwrap();
    let pf = ParticleFilter {
        timing: ResampleTiming::BeforeProposal,
        ..ParticleFilter::default()
    };
    for (k, (z, kf)) in zs.iter().zip(&truth).enumerate() {
        let report = pf
            .step(&mut set, &Bootstrap(&model), z, &[2, k as u64])
            .unwrap();
        // the first step has no weights to select by
        assert_eq!(report.resampled, k > 0, "step {k}");
        // the set keeps this step's weights: not uniform, and (resampled
        // before each step) not degenerate either
        assert!(set.ess() < 0.99 * n as f64, "step {k}: ess {}", set.ess());
        assert!(set.ess() > 0.02 * n as f64, "step {k}: ess {}", set.ess());
        assert!((set.ess() - report.ess).abs() < 1e-6 * n as f64);
        assert_near_kalman(&set, kf, k);
    }
    // MCMC moves follow a resampling after the weights
    let refused = ParticleFilter { mcmc: true, ..pf };
    assert!(matches!(
        refused.validate(),
        Err(ParticleError::InvalidParameter { name: "mcmc", .. })
    ));
}

/// Log-likelihoods whose chunks of 4 lie on very different scales: chunk
/// maxima 0, -1, none (all zero), -800 (flushed against the largest) and
/// -30, with spreads inside each chunk.
fn scaled_table() -> Table {
    let inf = f64::NEG_INFINITY;
    Table(vec![
        0.0, -0.5, inf, -2.0, // chunk 0
        -1.0, -1.0, -3.0, -1.7, // chunk 1
        inf, inf, inf, inf, // chunk 2
        -800.0, -801.0, -800.5, inf, // chunk 3
        -30.0, -30.2, -31.0, -29.5, // chunk 4
    ])
}

fn index_set(n: usize) -> ParticleSet<SVector<f64, 1>> {
    ParticleSet::new((0..n).map(|i| Vector1::new(i as f64)).collect()).unwrap()
}

#[test]
fn chunks_on_different_scales_give_the_direct_weights() {
    let table = scaled_table();
    let n = table.0.len();
    let pf = ParticleFilter {
        policy: ResamplePolicy::Never,
        chunk_size: 4,
        ..ParticleFilter::default()
    };
    let mut set = index_set(n);
    let report = pf
        .step(&mut set, &Bootstrap(&table), &Vector1::new(0.0), &[1])
        .unwrap();
    // direct: log w_i = -ln n + l_i, normalised over all particles at once
    let lse = bayestrack_particle::log_sum_exp(&table.0).unwrap();
    let w: Vec<f64> = table.0.iter().map(|l| (l - lse).exp()).collect();
    let ess = 1.0 / w.iter().map(|w| w * w).sum::<f64>();
    assert!((report.log_evidence - (lse - (n as f64).ln())).abs() < 1e-12);
    assert!(
        (report.ess - ess).abs() < 1e-12 * ess,
        "{} vs {ess}",
        report.ess
    );
    for (i, (&got, &l)) in set.log_weights().iter().zip(&table.0).enumerate() {
        if l == f64::NEG_INFINITY {
            assert_eq!(got, l, "particle {i}");
        } else {
            assert!((got - (l - lse)).abs() < 1e-12, "particle {i}: {got}");
        }
    }
}

#[test]
fn chunks_on_different_scales_resample_in_proportion_to_the_weights() {
    let table = scaled_table();
    let n = table.0.len();
    let lse = bayestrack_particle::log_sum_exp(&table.0).unwrap();
    let w: Vec<f64> = table.0.iter().map(|l| (l - lse).exp()).collect();
    let draws = 4000;
    for scheme in Resampling::ALL {
        let pf = ParticleFilter {
            resampling: scheme,
            chunk_size: 4,
            ..ParticleFilter::default()
        };
        let mut copies = vec![0usize; n];
        for k in 0..draws {
            let mut set = index_set(n);
            pf.step(&mut set, &Bootstrap(&table), &Vector1::new(0.0), &[2, k])
                .unwrap();
            for p in set.particles() {
                copies[p[0] as usize] += 1;
            }
        }
        for (i, (&c, &wi)) in copies.iter().zip(&w).enumerate() {
            let expected = (draws as usize * n) as f64 * wi;
            if wi < 1e-12 {
                assert_eq!(c, 0, "{scheme:?}: particle {i} of weight {wi:e} drawn");
            } else {
                // at most n draws a step: a generous 6 sigma of a binomial
                let sd = (expected * (1.0 - wi)).sqrt().max(1.0);
                assert!(
                    (c as f64 - expected).abs() < 6.0 * sd,
                    "{scheme:?}: particle {i}: {c} copies, expected {expected:.1}"
                );
            }
        }
    }
}

#[test]
fn a_step_normalises_at_every_magnitude() {
    // log-likelihoods all at or below about -1e15: the weights summed to N
    // and the ESS fell below 1 before the normalisation was shifted
    for m in [1.0, 1e10, 1e15, 1e16, 1e100, 1e300] {
        for policy in [ResamplePolicy::Never, ResamplePolicy::Ess(0.01)] {
            let pf = ParticleFilter {
                policy,
                chunk_size: 2,
                ..ParticleFilter::default()
            };
            let mut set = index_set(5);
            let table = Table(vec![-m, -m, -m, -m, f64::NEG_INFINITY]);
            let r = pf.step(&mut set, &Bootstrap(&table), &Vector1::new(0.0), &[1]);
            let r = r.unwrap();
            assert!(!r.resampled);
            let sum: f64 = set.weights().iter().sum();
            assert!((sum - 1.0).abs() < 1e-12, "m = {m:e}: {sum}");
            assert!((set.mean()[0] - 1.5).abs() < 1e-12, "m = {m:e}");
            assert!((set.ess() - 4.0).abs() < 1e-9, "m = {m:e}");
            assert!((r.ess - 4.0).abs() < 1e-9, "m = {m:e}");
        }
    }
}
