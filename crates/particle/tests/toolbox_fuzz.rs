//! Issue 28's class "library calls that return Ok with NaN, inf or a
//! negative variance", over the particle toolbox: the auxiliary filter,
//! the Rao-Blackwellised proposal, `ffbs`, `path_means`, `FixedLag`,
//! `Pmmh` / `Chain`, `ScalarModel` and `Smc::log_evidence`, with extreme
//! numbers (1e308, 1e-300, subnormals, NaN, inf) and counts (zero
//! particles, `usize::MAX` trajectories or iterations). Each call returns
//! a typed error or a finite, valid result, and a huge count is refused
//! before it allocates.

use bayestrack_kalman::{Gaussian, LinearDynamics, LinearMeasurement};
use bayestrack_particle::{
    Auxiliary, AuxiliaryFilter, Bootstrap, ConditionallyLinear, FixedLag, ParticleError,
    ParticleFilter, ParticleSet, Pmmh, RaoBlackwellised, RbParticle, ResamplePolicy, ScalarModel,
    ScalarTransitionDensity, Smc, ffbs, path_means,
};
use nalgebra::{Matrix1, SVector, Vector1, Vector2};
use proptest::prelude::*;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use bayestrack_testkit::strategies::{cases, extreme_f64};

/// `x_k = a x + s v`, `z = x + n`, `n ~ N(0, r)`, on `f64`, with any
/// numbers for `a`, `s`, `r`.
#[derive(Clone, Copy, Debug)]
struct Extreme {
    a: f64,
    s: f64,
    r: f64,
}

impl ScalarModel for Extreme {
    type Observation = f64;
    fn sample_transition<R: Rng + ?Sized>(&self, _k: usize, x: f64, rng: &mut R) -> f64 {
        let v: f64 = StandardNormal.sample(rng);
        self.a * x + self.s * v
    }
    fn log_likelihood(&self, _k: usize, x: f64, z: &f64) -> f64 {
        -0.5 * ((z - x).powi(2) / self.r + self.r.ln())
    }
}

impl ScalarTransitionDensity for Extreme {
    fn log_transition(&self, _k: usize, x_prev: f64, x: f64) -> f64 {
        -0.5 * ((x - self.a * x_prev).powi(2) / (self.s * self.s) + 2.0 * self.s.abs().ln())
    }
}

impl Auxiliary<1> for Extreme {
    fn point(&self, _k: usize, x_prev: &Vector1<f64>) -> Vector1<f64> {
        x_prev * self.a
    }
}

/// A set of the finite values among `xs`, or `None` when the set refuses
/// them.
fn set_of(xs: &[f64]) -> Option<ParticleSet<Vector1<f64>>> {
    ParticleSet::new(xs.iter().map(|&x| Vector1::new(x)).collect()).ok()
}

/// A set after a step: finite particles, normalised finite weights.
fn valid_set<const N: usize>(set: &ParticleSet<SVector<f64, N>>) -> Result<(), TestCaseError> {
    prop_assert!(
        set.particles()
            .iter()
            .all(|x| x.iter().all(|v| v.is_finite()))
    );
    let w = set.weights();
    prop_assert!(w.iter().all(|v| v.is_finite() && *v >= 0.0));
    let sum: f64 = w.iter().sum();
    prop_assert!((sum - 1.0).abs() < 1e-9, "weights sum to {sum}");
    Ok(())
}

fn policy() -> impl Strategy<Value = ResamplePolicy> {
    prop_oneof![
        Just(ResamplePolicy::Always),
        Just(ResamplePolicy::Never),
        extreme_f64().prop_map(ResamplePolicy::Ess),
        (0.0f64..=1.0).prop_map(ResamplePolicy::Ess),
    ]
}

/// A mixed model whose every number is drawn: `xn_k = fa xn + an xl +
/// wn`, `xl_k = al xl + wl`, `z = xn + xl + e`, `cov(wl, wn) = qln`.
#[derive(Debug)]
struct Mixed {
    fa: f64,
    nonlinear: LinearMeasurement<1, 1>,
    linear: LinearDynamics<1>,
    sensor: LinearMeasurement<1, 1>,
    qln: f64,
}

impl ConditionallyLinear<1, 1, 1> for Mixed {
    fn nonlinear(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (xn * self.fa, self.nonlinear)
    }
    fn linear(&self, _k: usize, _xn: &Vector1<f64>) -> (Vector1<f64>, LinearDynamics<1>) {
        (Vector1::zeros(), self.linear)
    }
    fn measurement(&self, _k: usize, xn: &Vector1<f64>) -> (Vector1<f64>, LinearMeasurement<1, 1>) {
        (*xn, self.sensor)
    }
    fn cross_covariance(&self, _k: usize, _xn: &Vector1<f64>) -> Option<Matrix1<f64>> {
        Some(Matrix1::new(self.qln))
    }
}

/// Huge or small counts.
fn count() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 0usize..6,
        1 => Just(usize::MAX),
        1 => Just(usize::MAX / 2 + 1),
        1 => Just(1usize << 40),
        1 => Just(1usize << 24),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn the_auxiliary_filter_is_finite_or_refuses(
        xs in prop::collection::vec(extreme_f64(), 0..12),
        (a, s, r, z) in (extreme_f64(), extreme_f64(), extreme_f64(), extreme_f64()),
        policy in policy(),
        chunk_size in prop_oneof![Just(0usize), 1usize..5, Just(1024usize)],
        steps in 1usize..4,
    ) {
        let Some(mut set) = set_of(&xs) else { return Ok(()) };
        let m = Extreme { a, s, r };
        let apf = AuxiliaryFilter { policy, chunk_size, ..AuxiliaryFilter::default() };
        for k in 0..steps {
            let before = set.clone();
            match apf.step(&mut set, &m, &z, &[1, k as u64]) {
                Ok(rep) => {
                    valid_set(&set)?;
                    prop_assert!(rep.mean.iter().all(|v| v.is_finite()), "{rep:?}");
                    prop_assert!(
                        rep.log_evidence.is_finite(),
                        "log evidence {} ({m:?}, z {z})", rep.log_evidence
                    );
                    let n = set.len() as f64;
                    prop_assert!(rep.ess >= 1.0 - 1e-9 && rep.ess <= n * (1.0 + 1e-9), "{rep:?}");
                }
                Err(_) => {
                    prop_assert_eq!(set, before);
                    break;
                }
            }
        }
    }

    #[test]
    fn a_scalar_model_in_smc_keeps_a_finite_or_zero_evidence(
        xs in prop::collection::vec(extreme_f64(), 0..12),
        (a, s, r) in (extreme_f64(), extreme_f64(), extreme_f64()),
        zs in prop::collection::vec(extreme_f64(), 1..4),
        policy in policy(),
    ) {
        let Some(set) = set_of(&xs) else { return Ok(()) };
        let m = Extreme { a, s, r };
        let pf = ParticleFilter { policy, ..ParticleFilter::default() };
        let Ok(mut smc) = Smc::new(pf, set, 3) else { return Ok(()) };
        for z in &zs {
            if smc.step(&Bootstrap(&m), z).is_err() {
                break;
            }
            valid_set(&smc.set)?;
            let le = smc.log_evidence();
            prop_assert!(!le.is_nan() && le < f64::INFINITY, "log evidence {le}");
        }
    }

    #[test]
    fn the_rao_blackwellised_proposal_is_finite_or_refuses(
        (fa, an, qn, al, ql, r) in (
            extreme_f64(), extreme_f64(), extreme_f64(),
            extreme_f64(), extreme_f64(), extreme_f64(),
        ),
        qln in extreme_f64(),
        (xn, ml, pl, z) in (extreme_f64(), extreme_f64(), extreme_f64(), extreme_f64()),
        n in 1usize..6,
    ) {
        let (Ok(nonlinear), Ok(linear), Ok(sensor), Ok(xl)) = (
            LinearMeasurement::new(Matrix1::new(an), Matrix1::new(qn)),
            LinearDynamics::new(Matrix1::new(al), Matrix1::new(ql)),
            LinearMeasurement::new(Matrix1::new(1.0), Matrix1::new(r)),
            Gaussian::new(Vector1::new(ml), Matrix1::new(pl)),
        ) else {
            return Ok(());
        };
        let m = Mixed { fa, nonlinear, linear, sensor, qln };
        let p = RbParticle { xn: Vector1::new(xn), xl };
        let Ok(mut set) = ParticleSet::new(vec![p; n]) else { return Ok(()) };
        let pf = ParticleFilter { policy: ResamplePolicy::Never, ..ParticleFilter::default() };
        for k in 0..3u64 {
            match pf.step(&mut set, &RaoBlackwellised::new(&m), &Vector1::new(z), &[4, k]) {
                Ok(rep) => {
                    prop_assert!(rep.mean.iter().all(|v| v.is_finite()));
                    prop_assert!(rep.log_evidence < f64::INFINITY && !rep.log_evidence.is_nan());
                    for p in set.particles() {
                        prop_assert!(p.xn[0].is_finite() && p.xl.mean()[0].is_finite());
                        let v = p.xl.cov()[(0, 0)];
                        prop_assert!(v.is_finite() && v >= 0.0, "variance {v} ({m:?})");
                    }
                }
                Err(_) => break,
            }
        }
    }

    #[test]
    fn ffbs_and_path_means_are_finite_or_refuse(
        sets in prop::collection::vec(prop::collection::vec(extreme_f64(), 0..6), 0..4),
        (a, s) in (extreme_f64(), extreme_f64()),
        trajectories in prop_oneof![
            4 => 0usize..6,
            1 => Just(usize::MAX),
            1 => Just(1usize << 40),
            // 2 GiB of paths at one step: refused before it allocates
            1 => Just(1usize << 28),
        ],
        chunk_size in prop_oneof![Just(0usize), 1usize..4],
    ) {
        let history: Vec<_> = sets.iter().filter_map(|xs| set_of(xs)).collect();
        let m = Extreme { a, s, r: 1.0 };
        if let Ok(paths) = ffbs(&history, &m, trajectories, chunk_size, &[5]) {
            prop_assert_eq!(paths.len(), trajectories);
            prop_assert!(paths.iter().all(|p| p.len() == history.len()
                && p.iter().all(|x| x[0].is_finite())));
            let means = path_means(&paths).unwrap();
            prop_assert!(means.iter().all(|x| x[0].is_finite()));
        }
    }

    #[test]
    fn path_means_of_any_paths_are_finite_or_refused(
        paths in prop::collection::vec(prop::collection::vec(extreme_f64(), 0..4), 0..5),
    ) {
        let paths: Vec<Vec<Vector1<f64>>> = paths
            .iter()
            .map(|p| p.iter().map(|&x| Vector1::new(x)).collect())
            .collect();
        if let Ok(means) = path_means(&paths) {
            prop_assert_eq!(means.len(), paths[0].len());
            for (t, m) in means.iter().enumerate() {
                prop_assert!(m[0].is_finite());
                let lo = paths.iter().map(|p| p[t][0]).fold(f64::INFINITY, f64::min);
                let hi = paths.iter().map(|p| p[t][0]).fold(f64::NEG_INFINITY, f64::max);
                // within the range of the paths, up to the rounding of x / n
                prop_assert!(m[0] >= lo - lo.abs() * 1e-12 && m[0] <= hi + hi.abs() * 1e-12,
                    "mean {} outside [{lo}, {hi}]", m[0]);
            }
        }
    }

    #[test]
    fn fixed_lag_is_finite_or_refuses(
        xs in prop::collection::vec(extreme_f64(), 0..8),
        ys in prop::collection::vec(extreme_f64(), 0..8),
        lag in prop_oneof![0usize..3, Just(usize::MAX)],
        (a, s, z) in (extreme_f64(), extreme_f64(), extreme_f64()),
    ) {
        let (Some(mut set), Some(mut other)) = (set_of(&xs), set_of(&ys)) else { return Ok(()) };
        let m = Extreme { a, s, r: 1.0 };
        let mut smoother = FixedLag::new(lag);
        smoother.record(&set, None).unwrap();
        let pf = ParticleFilter::default();
        let calm = Extreme { a: 1.0, s: 1.0, r: 1.0 };
        for k in 0..3u64 {
            // a report of another set's step that resampled, while this
            // set holds no ancestors (it has not stepped yet): refused,
            // not a panic on its empty ancestor list
            let Ok(rep) = pf.step(&mut other, &Bootstrap(&calm), &0.0, &[6, k]) else { break };
            let foreign = smoother.record(&set, Some(&rep));
            if k == 0 {
                prop_assert!(foreign.is_err());
            }
            let Ok(rep) = pf.step(&mut set, &Bootstrap(&m), &z, &[7, k]) else { break };
            if smoother.record(&set, Some(&rep)).is_err() {
                break;
            }
            if let Some(e) = smoother.estimate(&set) {
                prop_assert!(e[0].is_finite());
            }
        }
    }

    #[test]
    fn pmmh_is_finite_or_refuses(
        iterations in count(),
        (s0, s1) in (extreme_f64(), extreme_f64()),
        (t0, t1) in (extreme_f64(), extreme_f64()),
        (p, l) in (
            prop_oneof![extreme_f64(), Just(1e308), Just(-1e308)],
            prop_oneof![extreme_f64(), Just(1e308), Just(-1e308)],
        ),
        seed in any::<u64>(),
        (burn_in, i, level) in (count(), 0usize..3, extreme_f64()),
    ) {
        let pmmh = Pmmh { iterations, step: Vector2::new(s0, s1), seed };
        // log densities from the drawn numbers, scaled by theta
        let prior = |t: &Vector2<f64>| p * (1.0 + t[0].abs().min(1.0));
        // (l = 1e308 overflows to +inf away from theta0 = 0)
        let like = |t: &Vector2<f64>, _seed: u64| -> Result<f64, ParticleError> {
            Ok(l * (1.0 + t[1].abs().min(1.0)))
        };
        let Ok(chain) = pmmh.run(Vector2::new(t0, t1), prior, like) else { return Ok(()) };
        prop_assert!(iterations < Pmmh::<2>::MAX_SAMPLES);
        prop_assert_eq!(chain.samples.len(), iterations + 1);
        prop_assert!(chain.samples.iter().all(|s| s.iter().all(|v| v.is_finite())));
        prop_assert!(chain.log_likelihoods.iter().all(|v| v.is_finite()));
        let rate = chain.acceptance_rate();
        prop_assert!((0.0..=1.0).contains(&rate));
        if let Some(mean) = chain.mean(burn_in) {
            prop_assert!(mean.iter().all(|v| v.is_finite()), "{mean:?}");
        } else {
            prop_assert!(burn_in >= chain.samples.len());
        }
        if let Some((lo, hi)) = chain.credible_interval(i, level, burn_in) {
            prop_assert!(i < 2 && lo.is_finite() && hi.is_finite() && lo <= hi);
        }
    }
}

/// Stays put; log-likelihood and first-stage weight from a rule.
struct Rule {
    log_likelihood: fn(f64) -> f64,
}

impl ScalarModel for Rule {
    type Observation = f64;
    fn sample_transition<R: Rng + ?Sized>(&self, _k: usize, x: f64, _rng: &mut R) -> f64 {
        x
    }
    fn log_likelihood(&self, _k: usize, x: f64, _z: &f64) -> f64 {
        (self.log_likelihood)(x)
    }
}

impl Auxiliary<1> for Rule {
    fn point(&self, _k: usize, x_prev: &Vector1<f64>) -> Vector1<f64> {
        *x_prev
    }
}

#[test]
fn an_apf_parent_of_zero_first_stage_weight_leaves_a_child_of_weight_zero() {
    // without resampling the parent at -1 stays in place; its child's
    // weight w g p / g is zero, not the NaN of (-inf) - (-inf)
    let m = Rule {
        log_likelihood: |x| if x < 0.0 { f64::NEG_INFINITY } else { -x },
    };
    let mut set = set_of(&[-1.0, 1.0, 2.0]).unwrap();
    let apf = AuxiliaryFilter {
        policy: ResamplePolicy::Never,
        ..AuxiliaryFilter::default()
    };
    let r = apf.step(&mut set, &m, &0.0, &[1]).unwrap();
    assert!(!r.resampled);
    let w = set.weights();
    assert_eq!(w[0], 0.0);
    // w g p / g = p: weights e^-1 and e^-2, normalised
    let e = (-1.0f64).exp();
    assert!((w[1] - 1.0 / (1.0 + e)).abs() < 1e-12, "{w:?}");
    assert!((r.mean[0] - (1.0 + 2.0 * e) / (1.0 + e)).abs() < 1e-12);
}

#[test]
fn smc_refuses_a_log_evidence_past_the_largest_f64() {
    let m = Rule {
        log_likelihood: |_| 1e308,
    };
    let mut smc = Smc::new(ParticleFilter::default(), set_of(&[0.0, 1.0]).unwrap(), 1).unwrap();
    smc.step(&Bootstrap(&m), &0.0).unwrap();
    assert_eq!(smc.log_evidence(), 1e308);
    assert!(matches!(
        smc.step(&Bootstrap(&m), &0.0),
        Err(ParticleError::InvalidParameter {
            name: "log evidence",
            ..
        })
    ));
    assert_eq!(smc.log_evidence(), 1e308);
}

#[test]
fn huge_counts_are_refused_before_they_allocate() {
    let history = vec![set_of(&[0.0, 1.0]).unwrap(); 3];
    let m = Extreme {
        a: 1.0,
        s: 1.0,
        r: 1.0,
    };
    for n in [usize::MAX, 1 << 40, 1 << 26] {
        assert!(matches!(
            ffbs(&history, &m, n, 64, &[1]),
            Err(ParticleError::TooLarge { .. })
        ));
    }
    let pmmh = Pmmh {
        iterations: usize::MAX,
        step: Vector1::new(0.1),
        seed: 1,
    };
    assert!(matches!(
        pmmh.run(Vector1::new(0.0), |_| 0.0, |_, _| Ok(0.0)),
        Err(ParticleError::TooLarge { .. })
    ));
}

#[test]
fn a_credible_interval_at_a_tiny_level_is_ordered() {
    let chain = bayestrack_particle::Chain {
        samples: (0..5).map(|i| Vector1::new(f64::from(i))).collect(),
        log_likelihoods: vec![0.0; 5],
        accepted: 0,
    };
    for level in [8.4e-18, 1e-300, 5e-324, 0.5, 1.0] {
        let (lo, hi) = chain.credible_interval(0, level, 1).unwrap();
        assert!(lo <= hi, "level {level}: [{lo}, {hi}]");
    }
    for level in [0.0, -0.5, 1.5, f64::NAN] {
        assert_eq!(chain.credible_interval(0, level, 1), None);
    }
    assert_eq!(chain.credible_interval(1, 0.9, 1), None);
    assert_eq!(chain.mean(5), None);
    assert_eq!(chain.mean(4), Some(Vector1::new(4.0)));
}
