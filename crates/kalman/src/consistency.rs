//! Filter consistency: NEES, NIS and their chi-square bands.
//!
//! For a consistent filter the normalised estimation error squared
//! `NEES = (x - x_hat)^T P^{-1} (x - x_hat)` is chi-square with `n` degrees
//! of freedom, and the NIS of an update with `m`. Averaged over `R`
//! independent Monte Carlo runs, `R * mean` is chi-square with `R n` degrees,
//! which gives the two-sided band of [`ChiSquareBand::for_average`]
//! (Bar-Shalom, Li, Kirubarajan 2001, sec. 5.4).

use nalgebra::SVector;

use crate::error::{KalmanError, Result};
use crate::gaussian::Gaussian;

/// NEES of `truth` under the belief `estimate`.
///
/// # Errors
/// [`KalmanError::NotPositiveDefinite`] when the covariance is singular;
/// [`KalmanError::NonFinite`] for a non-finite `truth`.
pub fn nees<const N: usize>(truth: &SVector<f64, N>, estimate: &Gaussian<N>) -> Result<f64> {
    estimate.mahalanobis_sq(truth)
}

/// A two-sided acceptance interval for a chi-square statistic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChiSquareBand {
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
}

impl ChiSquareBand {
    /// The band that holds the average of `runs` independent chi-square
    /// statistics with `dof` degrees of freedom each, with probability
    /// `confidence` (0.95 for the usual 95% band).
    ///
    /// # Errors
    /// [`KalmanError::InvalidParameter`] for zero `dof` or `runs`, `dof * runs` above 1e10, or a
    /// confidence outside (0, 1).
    pub fn for_average(dof: usize, runs: usize, confidence: f64) -> Result<Self> {
        if dof == 0 || runs == 0 {
            return Err(KalmanError::InvalidParameter {
                name: if dof == 0 { "dof" } else { "runs" },
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        if !(confidence > 0.0 && confidence < 1.0) {
            return Err(KalmanError::InvalidParameter {
                name: "confidence",
                value: confidence,
                reason: "must lie in (0, 1)",
            });
        }
        let Some(k) = dof.checked_mul(runs).map(|k| k as f64) else {
            return Err(KalmanError::InvalidParameter {
                name: "runs",
                value: runs as f64,
                reason: "dof * runs overflows",
            });
        };
        let tail = 0.5 * (1.0 - confidence);
        Ok(Self {
            lower: chi_square_quantile(tail, k)? / runs as f64,
            upper: chi_square_quantile(1.0 - tail, k)? / runs as f64,
        })
    }

    /// Whether `x` lies inside the band.
    pub fn contains(&self, x: f64) -> bool {
        x >= self.lower && x <= self.upper
    }
}

/// `ln Gamma(x)` for `x > 0` (Lanczos, g = 7, 9 terms; relative error < 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // reflection
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised lower incomplete gamma `P(a, x)` (series for `x < a + 1`,
/// Lentz continued fraction otherwise).
fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_pre = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut n = a;
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (sum.ln() + ln_pre).exp().min(1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (1.0 - (ln_pre.exp() * h)).max(0.0)
    }
}

/// The chi-square CDF with `k` degrees of freedom: 0 for `x <= 0`, 1 for
/// `x = +inf`.
///
/// # Errors
/// [`KalmanError::InvalidParameter`] for a NaN `x` (it returned 0) or `k`
/// outside `(0, 1e10]` (a negative `k` returned 0.68, `k = 1e20` a CDF
/// of 0 at the median).
pub fn chi_square_cdf(x: f64, k: f64) -> Result<f64> {
    check_dof(k)?;
    if x.is_nan() {
        return Err(KalmanError::InvalidParameter {
            name: "x",
            value: x,
            reason: "the chi-square CDF needs a number",
        });
    }
    if x == f64::INFINITY {
        return Ok(1.0);
    }
    Ok(cdf(x, k))
}

/// [`chi_square_cdf`] of checked arguments.
fn cdf(x: f64, k: f64) -> f64 {
    gamma_p(0.5 * k, 0.5 * x)
}

/// The most degrees of freedom the CDF resolves: the series and continued
/// fraction of `gamma_p` lose accuracy beyond (at 1e12 the CDF is off by
/// 4e-5, at 1e15 by 0.15).
const MAX_DOF: f64 = 1e10;

/// Degrees of freedom must lie in `(0, 1e10]`.
fn check_dof(k: f64) -> Result<()> {
    if !(k > 0.0 && k <= MAX_DOF) {
        return Err(KalmanError::InvalidParameter {
            name: "k",
            value: k,
            reason: "degrees of freedom must lie in (0, 1e10] (beyond, the CDF loses its accuracy)",
        });
    }
    Ok(())
}

/// The `p`-quantile of the chi-square distribution with `k` degrees of
/// freedom (bisection on the CDF to 1e-12 relative precision).
///
/// # Errors
/// [`KalmanError::InvalidParameter`] for `p` outside (0, 1) or `k` outside `(0, 1e10]`.
pub fn chi_square_quantile(p: f64, k: f64) -> Result<f64> {
    if !(p > 0.0 && p < 1.0) {
        return Err(KalmanError::InvalidParameter {
            name: "p",
            value: p,
            reason: "must lie in (0, 1)",
        });
    }
    check_dof(k)?;
    let (mut lo, mut hi) = (0.0, k.max(1.0));
    while cdf(hi, k) < p {
        hi *= 2.0;
        if hi > f64::MAX {
            // the CDF never reached p before overflow (its NaN at infinity
            // reads as 0): the degrees of freedom are beyond its range
            return Err(KalmanError::InvalidParameter {
                name: "k",
                value: k,
                reason: "degrees of freedom too large for the chi-square quantile",
            });
        }
    }
    // up to 2,200 halvings: from 2^1024 down past the smallest subnormal
    // (a tiny p with a small k has a quantile such as 1e-3000, which
    // rounds to 0; 200 halvings stopped at 3e-61, whose CDF is 1.7e-6
    // for p = 2e-308)
    for _ in 0..2200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if cdf(mid, k) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    let mid = 0.5 * (lo + hi);
    if mid > lo && mid < hi {
        return Ok(mid);
    }
    // adjacent floats (the quantile is below the smallest subnormal, or
    // the CDF steps past p between neighbours): the one nearer in CDF
    if (cdf(lo, k) - p).abs() <= (cdf(hi, k) - p).abs() {
        Ok(lo)
    } else {
        Ok(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        // Values from standard chi-square tables (Abramowitz & Stegun 26.4).
        let cases = [
            (0.95, 1.0, 3.841_458_820_694_124),
            (0.975, 1.0, 5.023_886_187_314_888),
            (0.95, 2.0, 5.991_464_547_107_979),
            (0.025, 10.0, 3.246_972_780_236_841),
            (0.975, 10.0, 20.483_177_350_807_39),
            (0.025, 2000.0, 1_877.947_395_264_808),
            (0.975, 2000.0, 2_125.842_308_271_395),
        ];
        for (p, k, expected) in cases {
            let q = chi_square_quantile(p, k).unwrap();
            assert!((q - expected).abs() < 1e-6 * expected, "p={p} k={k}: {q}");
        }
    }

    #[test]
    fn band_for_average() {
        let band = ChiSquareBand::for_average(4, 500, 0.95).unwrap();
        assert!(
            // chi2(2000) quantiles 1877.95 and 2125.84 divided by 500 runs
            (band.lower - 3.7559).abs() < 1e-3 && (band.upper - 4.2517).abs() < 1e-3,
            "{band:?}"
        );
        assert!(band.contains(4.0) && !band.contains(4.26) && !band.contains(3.75));
        assert!(ChiSquareBand::for_average(0, 5, 0.95).is_err());
        assert!(ChiSquareBand::for_average(1, 5, 1.0).is_err());
    }

    #[test]
    fn cdf_of_bad_arguments_is_an_error_and_of_the_edges_exact() {
        // NaN returned 0, a negative dof 0.68
        assert!(matches!(
            chi_square_cdf(f64::NAN, 2.0),
            Err(KalmanError::InvalidParameter { name: "x", .. })
        ));
        for k in [-1.0, 0.0, f64::NAN, f64::INFINITY] {
            assert!(
                matches!(
                    chi_square_cdf(1.0, k),
                    Err(KalmanError::InvalidParameter { name: "k", .. })
                ),
                "{k}"
            );
        }
        assert_eq!(chi_square_cdf(f64::INFINITY, 2.0), Ok(1.0));
        assert_eq!(chi_square_cdf(f64::NEG_INFINITY, 2.0), Ok(0.0));
        assert_eq!(chi_square_cdf(-3.0, 2.0), Ok(0.0));
        assert_eq!(chi_square_cdf(f64::MAX, 2.0), Ok(1.0));
        // chi2(2) is exponential with mean 2
        let c = chi_square_cdf(2.0, 2.0).unwrap();
        assert!((c - (1.0 - (-1.0f64).exp())).abs() < 1e-14, "{c}");
    }

    #[test]
    fn ln_gamma_of_integers() {
        for n in 1..20u32 {
            let fact: f64 = (1..n).map(f64::from).product();
            assert!((ln_gamma(f64::from(n)) - fact.ln()).abs() < 1e-12);
        }
    }
}
