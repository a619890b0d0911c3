//! Resampling is unbiased, and the low-variance schemes are what they claim.

use bayestrack_kalman::chi_square_quantile;
use bayestrack_particle::{Resampler, Resampling, stream_rng};

fn weights() -> Vec<f64> {
    // uneven weights, some tiny, some zero, not normalised
    let raw = [0.3, 2.2, 0.0, 0.05, 1.7, 0.9, 0.001, 3.1, 0.45, 1.3];
    raw.to_vec()
}

fn copies(scheme: Resampling, w: &[f64], m: usize, seed: u64) -> Vec<usize> {
    let mut rng = stream_rng(&[0xa11ce, seed]);
    let mut anc = vec![0; m];
    scheme.resample(w, &mut rng, &mut anc).unwrap();
    let mut c = vec![0; w.len()];
    for a in anc {
        c[a] += 1;
    }
    c
}

#[test]
fn expected_copies_equal_m_w_for_every_scheme() {
    // Over R seeds the mean copy count of particle i estimates M w_i; the
    // standardised squared errors summed over particles are chi-square with
    // (number of particles with w > 0) degrees of freedom when each count's
    // variance is estimated from the draws.
    let w = weights();
    let total: f64 = w.iter().sum();
    let m = 10;
    let runs = 4000;
    for scheme in Resampling::ALL {
        let mut sum = vec![0.0; w.len()];
        let mut sum2 = vec![0.0; w.len()];
        for r in 0..runs {
            for (i, c) in copies(scheme, &w, m, r).into_iter().enumerate() {
                sum[i] += c as f64;
                sum2[i] += (c * c) as f64;
            }
        }
        let mut stat = 0.0;
        let mut dof = 0;
        for i in 0..w.len() {
            let expected = m as f64 * w[i] / total;
            let mean = sum[i] / runs as f64;
            let var = sum2[i] / runs as f64 - mean * mean;
            if w[i] == 0.0 {
                assert_eq!(sum[i], 0.0, "{scheme:?} copied a zero-weight particle");
                continue;
            }
            if var < 1e-12 {
                // deterministic count (floor = ceil)
                assert!((mean - expected).abs() < 1e-9, "{scheme:?} particle {i}");
                continue;
            }
            stat += (mean - expected).powi(2) / (var / runs as f64);
            dof += 1;
        }
        let bound = chi_square_quantile(0.999, dof as f64).unwrap();
        assert!(
            stat < bound,
            "{scheme:?}: chi-square {stat} > {bound} with {dof} dof"
        );
    }
}

#[test]
fn systematic_and_residual_give_floor_or_ceil_copies() {
    let w = weights();
    let total: f64 = w.iter().sum();
    for m in [7, 10, 33, 100] {
        for seed in 0..300 {
            for scheme in [Resampling::Systematic, Resampling::Residual] {
                let c = copies(scheme, &w, m, seed);
                assert_eq!(c.iter().sum::<usize>(), m);
                for (i, &ci) in c.iter().enumerate() {
                    let e = m as f64 * w[i] / total;
                    if scheme == Resampling::Systematic {
                        assert!(
                            ci as f64 >= e.floor() && ci as f64 <= e.ceil(),
                            "{scheme:?} m={m} i={i}: {ci} copies for {e}"
                        );
                    } else {
                        // residual: at least the integer part
                        assert!(ci as f64 >= e.floor(), "residual m={m} i={i}");
                    }
                }
            }
        }
    }
}

#[test]
fn stratified_and_systematic_have_lower_variance_than_multinomial() {
    let w = weights();
    let m = 50;
    let runs = 2000;
    let variance = |scheme| {
        let mut total_var = 0.0;
        let mut sum = vec![0.0; w.len()];
        let mut sum2 = vec![0.0; w.len()];
        for r in 0..runs {
            for (i, c) in copies(scheme, &w, m, r).into_iter().enumerate() {
                sum[i] += c as f64;
                sum2[i] += (c * c) as f64;
            }
        }
        for i in 0..w.len() {
            let mean = sum[i] / runs as f64;
            total_var += sum2[i] / runs as f64 - mean * mean;
        }
        total_var
    };
    let multi = variance(Resampling::Multinomial);
    let strat = variance(Resampling::Stratified);
    let sys = variance(Resampling::Systematic);
    let res = variance(Resampling::Residual);
    assert!(
        strat < 0.8 * multi,
        "stratified {strat} vs multinomial {multi}"
    );
    assert!(sys < 0.5 * multi, "systematic {sys} vs multinomial {multi}");
    assert!(res < multi, "residual {res} vs multinomial {multi}");
}
