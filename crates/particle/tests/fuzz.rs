//! Property tests over the whole f64 range: log-weights, particle steps
//! with arbitrary log-likelihoods, and the resamplers. Nothing panics; what
//! comes back `Ok` is finite and normalised.

use bayestrack_particle::{
    Bootstrap, Degenerate, Model, ParticleFilter, ParticleSet, ResamplePolicy, Resampler,
    Resampling, TransitionDensity, log_sum_exp, stream_rng,
};
use nalgebra::{SVector, Vector1};
use proptest::prelude::*;
use rand::Rng;

use bayestrack_testkit::strategies::{cases, extreme_f64};

/// Any log-weight: ordinary, huge of either sign, minus infinity, NaN,
/// plus infinity, subnormal.
fn log_weight() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -50.0f64..5.0,
        4 => (-1.0f64..1.0, 0i32..308).prop_map(|(m, e)| m * 10f64.powi(e)),
        2 => any::<f64>(),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(-f64::MAX),
    ]
}

/// Particles that stay where they are (their state is their index) with
/// log-likelihoods read from a table.
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

fn normalised(set: &ParticleSet<SVector<f64, 1>>) -> Result<(), TestCaseError> {
    let w = set.weights();
    let sum: f64 = w.iter().sum();
    prop_assert!((sum - 1.0).abs() < 1e-9, "weights sum to {sum}");
    prop_assert!(w.iter().all(|v| v.is_finite() && *v >= 0.0));
    let ess = set.ess();
    prop_assert!(
        ess >= 1.0 - 1e-9 && ess <= set.len() as f64 * (1.0 + 1e-9),
        "ess {ess}"
    );
    let m = set.mean()[0];
    prop_assert!(
        m.is_finite() && m >= -1e-9 && m <= (set.len() - 1) as f64 * (1.0 + 1e-9),
        "mean {m}"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn log_weights_normalise_or_fail(lw in prop::collection::vec(log_weight(), 1..40)) {
        let n = lw.len();
        let lse = log_sum_exp(&lw);
        let set = ParticleSet::from_log_weights((0..n).map(|i| Vector1::new(i as f64)).collect(), lw.clone());
        prop_assert_eq!(lse.is_ok(), set.is_ok());
        if let Ok(set) = set {
            prop_assert!(!lse.unwrap().is_nan());
            normalised(&set)?;
        }
    }

    #[test]
    fn a_step_with_any_log_likelihoods_normalises_or_fails(
        table in prop::collection::vec(log_weight(), 1..40),
        scheme in prop::sample::select(Resampling::ALL.to_vec()),
        policy in prop::sample::select(vec![ResamplePolicy::Always, ResamplePolicy::Never, ResamplePolicy::Ess(0.5)]),
        chunk in 1usize..8,
        lenient in any::<bool>(),
    ) {
        let n = table.len();
        let pf = ParticleFilter {
            resampling: scheme,
            policy,
            chunk_size: chunk,
            degenerate: if lenient { Degenerate::IgnoreMeasurement } else { Degenerate::Error },
            ..ParticleFilter::default()
        };
        let mut set = ParticleSet::new((0..n).map(|i| Vector1::new(i as f64)).collect()).unwrap();
        let model = Table(table);
        for k in 0..2u64 {
            match pf.step(&mut set, &Bootstrap(&model), &Vector1::new(0.0), &[k]) {
                Ok(r) => {
                    prop_assert!(r.ess.is_finite() && r.ess >= 1.0 - 1e-9, "{r:?}");
                    prop_assert!(!r.log_evidence.is_nan(), "{r:?}");
                    normalised(&set)?;
                }
                Err(_) => break,
            }
        }
    }

    #[test]
    fn resamplers_take_any_weights(
        weights in prop::collection::vec(
            prop_oneof![4 => 0.0f64..1.0, 2 => 0.0f64..f64::MAX, 1 => Just(0.0), 1 => any::<f64>()],
            0..40,
        ),
        m in 0usize..64,
        seed in any::<u64>(),
    ) {
        let mut rng = stream_rng(&[seed]);
        let mut ancestors = vec![usize::MAX; m];
        for scheme in Resampling::ALL {
            if scheme.resample(&weights, &mut rng, &mut ancestors).is_ok() {
                for &a in &ancestors {
                    prop_assert!(a < weights.len() && weights[a] > 0.0, "{scheme:?}: {a} of {weights:?}");
                }
            }
        }
    }

    #[test]
    fn a_set_of_any_states_is_finite_or_refused(xs in prop::collection::vec(any::<f64>(), 0..20)) {
        let n = xs.len();
        match ParticleSet::new(xs.iter().map(|&x| Vector1::new(x)).collect()) {
            Ok(set) => {
                prop_assert!(xs.iter().all(|x| x.is_finite()));
                // finite even where the sum of the states overflows
                let m = set.mean()[0];
                let (lo, hi) = xs.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                // (within the weights' round-off of the states' range)
                let tol = 1e-12 * lo.abs().max(hi.abs());
                prop_assert!(m.is_finite() && m >= lo - tol && m <= hi + tol, "{m} outside [{lo}, {hi}]");
            }
            Err(_) => prop_assert!(n == 0 || xs.iter().any(|x| !x.is_finite())),
        }
    }

    /// Issue 28 (subnormal weights): systematic resampling gives particle
    /// `i` `floor(M w_i)` or `ceil(M w_i)` copies at every magnitude of the
    /// weights, subnormal (all points landed on particle 0) or overflowing
    /// their sum.
    #[test]
    fn systematic_copies_hold_at_every_weight_magnitude(
        base in prop::collection::vec(0.0f64..1.0, 1..12),
        e in prop_oneof![-325i32..-318, -318i32..310],
        m in 1usize..200,
        seed in any::<u64>(),
    ) {
        // 10^e in two factors (`powi(-323)` is `1 / 10^323 = 1 / inf = 0`)
        let f = 10f64.powi(e / 2) * 10f64.powi(e - e / 2);
        let weights: Vec<f64> = base.iter().map(|w| w * f).collect();
        let max = weights.iter().copied().fold(0.0, f64::max);
        if !(max > 0.0 && max.is_finite()) {
            return Ok(());
        }
        let ratios: Vec<f64> = weights.iter().map(|w| w / max).collect();
        let total: f64 = ratios.iter().sum();
        let mut rng = stream_rng(&[seed]);
        let mut ancestors = vec![usize::MAX; m];
        Resampling::Systematic.resample(&weights, &mut rng, &mut ancestors).unwrap();
        let mut counts = vec![0usize; weights.len()];
        ancestors.iter().for_each(|&a| counts[a] += 1);
        for (i, &c) in counts.iter().enumerate() {
            let expected = m as f64 * ratios[i] / total;
            prop_assert!(
                c as f64 >= expected.floor() - 1e-9 - 1.0 * f64::from(expected.fract() < 1e-9)
                    && c as f64 <= expected.ceil() + 1e-9 + 1.0 * f64::from(expected.fract() > 1.0 - 1e-9),
                "particle {i}: {c} copies, expected {expected} ({weights:?})"
            );
        }
    }

    /// Particles with any states enter by either constructor only when
    /// finite.
    #[test]
    fn from_log_weights_refuses_non_finite_states(
        xs in prop::collection::vec(extreme_f64(), 1..10),
    ) {
        let n = xs.len();
        let set = ParticleSet::from_log_weights(xs.iter().map(|&x| Vector1::new(x)).collect(), vec![0.0; n]);
        prop_assert_eq!(set.is_ok(), xs.iter().all(|x| x.is_finite()));
    }
}
