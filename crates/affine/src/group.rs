//! The affine group Aff(2) as 3x3 matrices, its Lie algebra in the basis
//! A1..A6 of Xu, Gao and Yang 2015 (paper 002) eq. 3, and exp / log.
//!
//! The elements are [`Affine2`]s, the affine map type of
//! `bayestrack-image` (one type for warps, poses and trackers' estimates);
//! the group structure is the extension trait [`AffineGroup`].
//!
//! Basis (Xu, Gao and Yang 2015 (paper 002) eq. 3):
//!
//! ```text
//! A1 = [1 0 0; 0 1 0; 0 0 0]  scale       A2 = [1 0 0; 0 -1 0; 0 0 0]  aspect
//! A3 = [0 -1 0; 1 0 0; 0 0 0] rotation    A4 = [0 1 0; 1 0 0; 0 0 0]   skew
//! A5 = [0 0 1; 0 0 0; 0 0 0]  x-shift     A6 = [0 0 0; 0 0 1; 0 0 0]   y-shift
//! ```
//!
//! A group element maps template coordinates (u, v), centred on the template
//! (u in [-w/2, w/2], v in [-h/2, h/2]), to image coordinates:
//! (x, y, 1)^T = M (u, v, 1)^T. The translation of M is the target centre.

use bayestrack_image::{Affine2, BBox};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector6};

use crate::error::{AffineError, Result, check_finite};

/// Coordinates of a Lie-algebra element in the basis A1..A6.
pub type AlgebraVector = Vector6<f64>;

/// The six basis elements A1..A6 of Xu, Gao and Yang 2015 (paper 002) eq. 3, in order.
pub fn basis() -> [Matrix3<f64>; 6] {
    [
        Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0),
        Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0),
        Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        Matrix3::new(0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0),
    ]
}

/// The algebra element `sum_i w_i A_i` as a 3x3 matrix.
pub fn hat(w: &AlgebraVector) -> Matrix3<f64> {
    Matrix3::new(
        w[0] + w[1],
        w[3] - w[2],
        w[4],
        w[2] + w[3],
        w[0] - w[1],
        w[5],
        0.0,
        0.0,
        0.0,
    )
}

/// Coordinates of a 3x3 algebra element in the basis A1..A6 (inverse of
/// [`hat`]). Fails when the bottom row is not zero or a value is not finite.
pub fn vee(x: &Matrix3<f64>) -> Result<AlgebraVector> {
    check_finite("algebra element", x.as_slice())?;
    if x[(2, 0)] != 0.0 || x[(2, 1)] != 0.0 || x[(2, 2)] != 0.0 {
        return Err(AffineError::NotAffine {
            kind: "algebra element",
            r0: x[(2, 0)],
            r1: x[(2, 1)],
            r2: x[(2, 2)],
        });
    }
    Ok(vee_unchecked(x))
}

fn vee_unchecked(x: &Matrix3<f64>) -> AlgebraVector {
    let (a, b, c, d) = (x[(0, 0)], x[(0, 1)], x[(1, 0)], x[(1, 1)]);
    Vector6::new(
        0.5 * (a + d),
        0.5 * (a - d),
        0.5 * (c - b),
        0.5 * (b + c),
        x[(0, 2)],
        x[(1, 2)],
    )
}

/// Pose parameters (dx, dy, theta, scale, aspect, skew) of an affine map.
///
/// The linear part is `A = R(theta) R(-skew) diag(scale, scale * aspect) R(skew)`
/// (the convention of Ross et al.'s IVT tracker, which ISPF and Xu, Gao and Yang 2015 (paper 002)
/// follow) and the translation is `(dx, dy)`, the image position of the
/// template centre. [`Affine2::params`] returns the canonical parameters:
/// `scale > 0`, `0 < aspect <= 1`, `skew` in `(-pi/2, pi/2]` (0 when
/// `aspect == 1`), `theta` in `(-pi, pi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineParams {
    /// Horizontal translation (image x of the template centre).
    pub dx: f64,
    /// Vertical translation (image y of the template centre).
    pub dy: f64,
    /// Rotation angle in radians.
    pub theta: f64,
    /// Scale (the larger singular value of the linear part).
    pub scale: f64,
    /// Aspect ratio (smaller over larger singular value).
    pub aspect: f64,
    /// Skew direction in radians: before the rotation, the larger stretch
    /// acts along the axis at angle `-skew`.
    pub skew: f64,
}

impl AffineParams {
    /// The identity pose centred at (dx, dy).
    pub fn at(dx: f64, dy: f64) -> Self {
        Self {
            dx,
            dy,
            theta: 0.0,
            scale: 1.0,
            aspect: 1.0,
            skew: 0.0,
        }
    }
}

/// The group structure of Aff(2) on [`Affine2`], the workspace's one
/// affine map type (owned by `bayestrack-image`, which warps through it).
///
/// An element is the 3x3 matrix `[A b; 0 0 1]` with finite entries; the
/// linear part may be singular ([`AffineGroup::try_inverse`] and
/// [`AffineGroup::log`] report it). Group product and plain inverse are
/// `Affine2`'s own ([`Affine2::compose`] or `*`, [`Affine2::inverse`]);
/// this trait adds the nalgebra views, exp / log in the basis A1..A6, pose
/// parameters and the bounding box of a centred template. Bring it into
/// scope with `use bayestrack_affine::AffineGroup;`.
pub trait AffineGroup: Sized + sealed::Sealed {
    /// Wraps a 3x3 matrix; fails if a value is not finite or the bottom row is
    /// not exactly (0, 0, 1).
    fn from_matrix(m: Matrix3<f64>) -> Result<Self>;
    /// Builds `[a b; 0 1]` from a linear part and a translation.
    fn from_parts(a: Matrix2<f64>, b: Vector2<f64>) -> Result<Self>;
    /// The 3x3 matrix.
    fn matrix(&self) -> Matrix3<f64>;
    /// The 2x2 linear part A.
    fn linear(&self) -> Matrix2<f64>;
    /// The translation b (image position of the template centre).
    fn offset(&self) -> Vector2<f64>;
    /// Maps a template point to image coordinates ([`Affine2::apply`] on
    /// nalgebra vectors).
    fn map_point(&self, p: Vector2<f64>) -> Vector2<f64>;
    /// Group inverse; fails with [`AffineError::Singular`] where
    /// [`Affine2::inverse`] gives `None` (a linear part singular relative to
    /// the size of its entries, or an inverse that overflows).
    fn try_inverse(&self) -> Result<Self>;
    /// The group exponential `exp(sum_i w_i A_i)`.
    ///
    /// Scaling and squaring with a [6/6] Pade approximant (backward error
    /// below 1e-16 after scaling to 1-norm <= 1/2). Fails on non-finite input
    /// or when the result overflows.
    fn exp(w: &AlgebraVector) -> Result<Self>;
    /// The exponential of a 3x3 algebra element (bottom row zero).
    fn exp_matrix(x: &Matrix3<f64>) -> Result<Self>;
    /// The principal logarithm, in basis coordinates. Fails when the linear
    /// part has non-positive determinant or a (double) eigenvalue on the
    /// negative real axis, where no principal real logarithm exists.
    fn log(&self) -> Result<AlgebraVector>;
    /// The principal logarithm as a 3x3 algebra matrix.
    fn log_matrix(&self) -> Result<Matrix3<f64>>;
    /// Builds the matrix of pose parameters
    /// `A = R(theta) R(-skew) diag(scale, scale*aspect) R(skew)`, `b = (dx, dy)`.
    /// Fails on non-finite values or non-positive scale or aspect.
    fn from_params(p: &AffineParams) -> Result<Self>;
    /// Canonical pose parameters (see [`AffineParams`]). Fails when the linear
    /// part is singular or reflects (det <= 0).
    fn params(&self) -> Result<AffineParams>;
    /// The axis-aligned box of the four corners of a `w x h` template
    /// (centred on the template origin) mapped through this element: the
    /// corners are pixel edges in 0-based pixel-centre image coordinates,
    /// returned as the workspace's [`BBox`] ([`BBox::from_edges`]).
    fn bounding_box(&self, w: f64, h: f64) -> Result<BBox>;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for super::Affine2 {}
}

impl AffineGroup for Affine2 {
    fn from_matrix(m: Matrix3<f64>) -> Result<Self> {
        check_finite("affine matrix", m.as_slice())?;
        if m[(2, 0)] != 0.0 || m[(2, 1)] != 0.0 || m[(2, 2)] != 1.0 {
            return Err(AffineError::NotAffine {
                kind: "group element",
                r0: m[(2, 0)],
                r1: m[(2, 1)],
                r2: m[(2, 2)],
            });
        }
        Ok(Affine2::from_rows([
            [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
            [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        ])?)
    }

    fn from_parts(a: Matrix2<f64>, b: Vector2<f64>) -> Result<Self> {
        let m = Matrix3::new(
            a[(0, 0)],
            a[(0, 1)],
            b[0],
            a[(1, 0)],
            a[(1, 1)],
            b[1],
            0.0,
            0.0,
            1.0,
        );
        Self::from_matrix(m)
    }

    fn matrix(&self) -> Matrix3<f64> {
        let [a, b, tx, c, d, ty] = self.as_array();
        Matrix3::new(a, b, tx, c, d, ty, 0.0, 0.0, 1.0)
    }

    fn linear(&self) -> Matrix2<f64> {
        let [a, b, _, c, d, _] = self.as_array();
        Matrix2::new(a, b, c, d)
    }

    fn offset(&self) -> Vector2<f64> {
        let [_, _, tx, _, _, ty] = self.as_array();
        Vector2::new(tx, ty)
    }

    fn map_point(&self, p: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = self.apply(p[0], p[1]);
        Vector2::new(x, y)
    }

    fn try_inverse(&self) -> Result<Self> {
        self.inverse().ok_or(AffineError::Singular {
            op: "inverse",
            det: self.det(),
        })
    }

    fn exp(w: &AlgebraVector) -> Result<Self> {
        check_finite("algebra vector", w.as_slice())?;
        let x = hat(w);
        let out_of_range = || AffineError::InvalidParameter {
            name: "algebra vector norm",
            value: w.norm(),
            reason: "exp leaves the range of f64 (overflow, or a linear part that underflows to singular)",
        };
        let g = Self::from_matrix(expm3(&x)).map_err(|_| out_of_range())?;
        // det exp(X) = e^{tr X} > 0: a determinant that underflowed to zero
        // (or lost its digits to the squarings) is not the exponential
        // (to the round-off of the determinant's two products)
        let expected = (x[(0, 0)] + x[(1, 1)]).exp();
        let det = g.det();
        let m = g.matrix();
        let terms = (m[(0, 0)] * m[(1, 1)]).abs() + (m[(0, 1)] * m[(1, 0)]).abs();
        let agrees =
            det.is_finite() && expected.is_normal() && (det - expected).abs() <= 1e-6 * terms;
        if !agrees {
            return Err(out_of_range());
        }
        Ok(g)
    }

    fn exp_matrix(x: &Matrix3<f64>) -> Result<Self> {
        Self::exp(&vee(x)?)
    }

    fn log(&self) -> Result<AlgebraVector> {
        let a = self.linear();
        let det = self.det();
        let tr = a.trace();
        if det <= 0.0 {
            return Err(AffineError::NoRealLog {
                reason: "non-positive determinant",
                det,
                trace: tr,
            });
        }
        let sigma = 0.5 * tr;
        // Traceless part K, K^2 = kappa I.
        let k = a - Matrix2::identity() * sigma;
        let kappa = -(k[(0, 0)] * k[(1, 1)] - k[(0, 1)] * k[(1, 0)]);
        let s = 0.5 * det.ln();
        let es = s.exp();
        let c = sigma / es;
        let x = kappa.abs().sqrt() / es;
        // log A = s I + g K with g = e^{-s} f(x).
        let f = if kappa >= 0.0 {
            // Real eigenvalues sigma +- sqrt(kappa), both must be positive.
            if sigma <= 0.0 {
                return Err(AffineError::NoRealLog {
                    reason: "real negative eigenvalues",
                    det,
                    trace: tr,
                });
            }
            if x < 1e-8 { 1.0 } else { x.asinh() / x }
        } else {
            let omega = x.atan2(c);
            if x < 1e-8 {
                if c <= 0.0 {
                    return Err(AffineError::NoRealLog {
                        reason: "eigenvalues on the negative real axis",
                        det,
                        trace: tr,
                    });
                }
                1.0
            } else {
                omega / x
            }
        };
        let g = f / es;
        let l = Matrix2::identity() * s + k * g;
        // Translation: exp([L v; 0 0]) has translation V(L) v; V(L) from two
        // exponentials, then solve V v = b.
        let mut x1 = Matrix3::zeros();
        x1.fixed_view_mut::<2, 2>(0, 0).copy_from(&l);
        x1[(0, 2)] = 1.0;
        let mut x2 = x1;
        x2[(0, 2)] = 0.0;
        x2[(1, 2)] = 1.0;
        let e1 = expm3(&x1);
        let e2 = expm3(&x2);
        let v = Matrix2::new(e1[(0, 2)], e2[(0, 2)], e1[(1, 2)], e2[(1, 2)]);
        let vdet = v[(0, 0)] * v[(1, 1)] - v[(0, 1)] * v[(1, 0)];
        if !(vdet.is_finite() && vdet.abs() > 1e-300) {
            return Err(AffineError::NoRealLog {
                reason: "translation Jacobian V(L) is singular",
                det,
                trace: tr,
            });
        }
        let b = self.offset();
        let tv = Vector2::new(
            (v[(1, 1)] * b[0] - v[(0, 1)] * b[1]) / vdet,
            (-v[(1, 0)] * b[0] + v[(0, 0)] * b[1]) / vdet,
        );
        let mut xm = Matrix3::zeros();
        xm.fixed_view_mut::<2, 2>(0, 0).copy_from(&l);
        xm[(0, 2)] = tv[0];
        xm[(1, 2)] = tv[1];
        let out = vee_unchecked(&xm);
        check_finite("logarithm", out.as_slice())?;
        Ok(out)
    }

    fn log_matrix(&self) -> Result<Matrix3<f64>> {
        Ok(hat(&self.log()?))
    }

    fn from_params(p: &AffineParams) -> Result<Self> {
        check_finite(
            "affine parameters",
            &[p.dx, p.dy, p.theta, p.scale, p.aspect, p.skew],
        )?;
        if p.scale <= 0.0 {
            return Err(AffineError::InvalidParameter {
                name: "scale",
                value: p.scale,
                reason: "must be > 0",
            });
        }
        if p.aspect <= 0.0 {
            return Err(AffineError::InvalidParameter {
                name: "aspect",
                value: p.aspect,
                reason: "must be > 0",
            });
        }
        let d = Matrix2::new(p.scale, 0.0, 0.0, p.scale * p.aspect);
        let a = rot(p.theta - p.skew) * d * rot(p.skew);
        Self::from_parts(a, Vector2::new(p.dx, p.dy))
    }

    fn params(&self) -> Result<AffineParams> {
        let a = self.linear();
        let det = self.det();
        let scale_ref = a.amax().max(f64::MIN_POSITIVE);
        if det <= 0.0 || det / (scale_ref * scale_ref) < 1e-14 {
            return Err(AffineError::Singular { op: "params", det });
        }
        // Closed-form 2x2 SVD: A = R(alpha) diag(s1, s2) R(beta) with
        // s1 >= s2 > 0 (det > 0, so no reflection).
        let e = 0.5 * (a[(0, 0)] + a[(1, 1)]);
        let f = 0.5 * (a[(0, 0)] - a[(1, 1)]);
        let g = 0.5 * (a[(1, 0)] + a[(0, 1)]);
        let h = 0.5 * (a[(1, 0)] - a[(0, 1)]);
        let q = (e * e + h * h).sqrt();
        let r = (f * f + g * g).sqrt();
        let s1 = q + r;
        let s2 = q - r;
        let a1 = g.atan2(f);
        let a2 = h.atan2(e);
        // A = R(phi_u) diag(s1, s2) R(phi_v) with phi_u = (a2 + a1)/2,
        // phi_v = (a2 - a1)/2. Here phi_v = skew, phi_u = theta - skew.
        let mut skew = 0.5 * (a2 - a1);
        let mut theta = a2; // phi_u + phi_v
        let aspect = s2 / s1;
        if r <= 1e-15 * q {
            skew = 0.0;
        } else {
            // Bring skew into (-pi/2, pi/2]: R(skew + pi) gives the same
            // symmetric part (diag commutes with -I).
            while skew <= -std::f64::consts::FRAC_PI_2 {
                skew += std::f64::consts::PI;
            }
            while skew > std::f64::consts::FRAC_PI_2 {
                skew -= std::f64::consts::PI;
            }
        }
        theta = wrap_angle(theta);
        Ok(AffineParams {
            dx: self.offset()[0],
            dy: self.offset()[1],
            theta,
            scale: s1,
            aspect,
            skew,
        })
    }

    fn bounding_box(&self, w: f64, h: f64) -> Result<BBox> {
        check_finite("template size", &[w, h])?;
        if w <= 0.0 || h <= 0.0 {
            return Err(AffineError::InvalidParameter {
                name: "template size",
                value: w.min(h),
                reason: "width and height must be > 0",
            });
        }
        let (hw, hh) = (0.5 * w, 0.5 * h);
        let corners = [
            Vector2::new(-hw, -hh),
            Vector2::new(hw, -hh),
            Vector2::new(hw, hh),
            Vector2::new(-hw, hh),
        ];
        let mut lo = Vector2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Vector2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for c in corners {
            let p = self.map_point(c);
            lo = lo.inf(&p);
            hi = hi.sup(&p);
        }
        // a pose at scale 1e308 maps the corners (or their spread) beyond f64
        let b = BBox::from_edges(lo[0], lo[1], hi[0], hi[1]);
        check_finite("bounding box", &[b.x, b.y, b.width, b.height])?;
        Ok(b)
    }
}

fn rot(t: f64) -> Matrix2<f64> {
    let (s, c) = t.sin_cos();
    Matrix2::new(c, -s, s, c)
}

/// Wraps an angle to (-pi, pi].
pub(crate) fn wrap_angle(t: f64) -> f64 {
    let pi = std::f64::consts::PI;
    let mut t = t % (2.0 * pi);
    if t <= -pi {
        t += 2.0 * pi;
    } else if t > pi {
        t -= 2.0 * pi;
    }
    t
}

/// Matrix exponential of a 3x3 matrix by scaling and squaring with a [6/6]
/// Pade approximant. The caller checks the result for overflow.
pub(crate) fn expm3(x: &Matrix3<f64>) -> Matrix3<f64> {
    // Pade [6/6] coefficients c_k = (2m-k)! m! / ((2m)! k! (m-k)!), m = 6.
    const C: [f64; 7] = [
        1.0,
        0.5,
        5.0 / 44.0,
        1.0 / 66.0,
        1.0 / 792.0,
        1.0 / 15840.0,
        1.0 / 665280.0,
    ];
    let norm = x.column_iter().map(|c| c.abs().sum()).fold(0.0, f64::max);
    let mut s = 0i32;
    let mut scaled = norm;
    while scaled > 0.5 && s < 1100 {
        scaled *= 0.5;
        s += 1;
    }
    let y = x * 0.5f64.powi(s);
    let y2 = y * y;
    let y4 = y2 * y2;
    let y6 = y4 * y2;
    let i = Matrix3::identity();
    let even = i * C[0] + y2 * C[2] + y4 * C[4] + y6 * C[6];
    let odd = y * C[1] + y * y2 * C[3] + y * y4 * C[5];
    let num = even + odd;
    let den = even - odd;
    // den is close to I (||y|| <= 1/2), so the inverse exists.
    let mut r = match den.try_inverse() {
        Some(inv) => inv * num,
        None => Matrix3::from_element(f64::NAN),
    };
    for _ in 0..s {
        r = r * r;
    }
    // The bottom row of a group element is exactly (0, 0, 1).
    r[(2, 0)] = 0.0;
    r[(2, 1)] = 0.0;
    r[(2, 2)] = 1.0;
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn close(a: Matrix3<f64>, b: Matrix3<f64>, tol: f64) -> bool {
        (a - b).amax() <= tol * (1.0 + b.amax())
    }

    #[test]
    fn pade_coefficients_are_right() {
        // c_k = (12-k)! 6! / (12! k! (6-k)!)
        let fact = |n: u64| (1..=n).product::<u64>() as f64;
        let c: Vec<f64> = (0..=6)
            .map(|k| fact(12 - k) * fact(6) / (fact(12) * fact(k) * fact(6 - k)))
            .collect();
        let exp = [
            1.0,
            0.5,
            5.0 / 44.0,
            1.0 / 66.0,
            1.0 / 792.0,
            1.0 / 15840.0,
            1.0 / 665280.0,
        ];
        for (a, b) in c.iter().zip(exp) {
            assert!((a - b).abs() < 1e-15 * b, "{a} vs {b}");
        }
    }

    #[test]
    fn exp_of_a_huge_element_is_an_error_not_a_singular_matrix() {
        // a scale of e^-400 squares to a determinant of 0: a singular
        // "group element" came back with Ok
        for s in [-400.0, -1e3, -1e10, 800.0, 1e300] {
            let w = Vector6::new(s, 0.0, 0.0, 0.0, 0.0, 0.0);
            assert!(
                matches!(
                    Affine2::exp(&w),
                    Err(AffineError::InvalidParameter {
                        name: "algebra vector norm",
                        ..
                    })
                ),
                "s = {s:e}: {:?}",
                Affine2::exp(&w)
            );
        }
        // large but representable elements keep their exponential: scale
        // e^-150 (det e^-300), a boost of e^30 (cancelling det 1), and
        // 1e3 radians of rotation
        for w in [
            Vector6::new(-150.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            Vector6::new(0.0, 0.0, 0.0, 30.0, 1.0, 2.0),
            Vector6::new(0.0, 0.0, 1e3, 0.0, 5.0, 0.0),
        ] {
            let g = Affine2::exp(&w).unwrap_or_else(|e| panic!("{w:?}: {e}"));
            assert!(g.matrix().iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn exp_agrees_with_nalgebra_and_series() {
        let w = Vector6::new(0.3, -0.2, 1.1, 0.4, 2.0, -3.0);
        let e = Affine2::exp(&w).unwrap();
        let x = hat(&w);
        let reference = x.exp();
        assert!(close(e.matrix(), reference, 1e-12));
        // Taylor series for a small element.
        let w = Vector6::new(1e-3, 2e-3, -1e-3, 5e-4, 0.01, 0.02);
        let x = hat(&w);
        let mut term = Matrix3::identity();
        let mut sum = Matrix3::identity();
        for k in 1..20 {
            term = term * x / k as f64;
            sum += term;
        }
        assert!(close(Affine2::exp(&w).unwrap().matrix(), sum, 1e-15));
    }

    #[test]
    fn basis_reproduces_pose_parameters() {
        let t = 0.3;
        let e = |i: usize| {
            let mut w = Vector6::zeros();
            w[i] = t;
            Affine2::exp(&w).unwrap()
        };
        // A1: isotropic scale e^t.
        let p = e(0).params().unwrap();
        assert!((p.scale - t.exp()).abs() < 1e-14 && (p.aspect - 1.0).abs() < 1e-14);
        assert!(p.theta.abs() < 1e-14);
        // A2: diag(e^t, e^-t): scale e^t, aspect e^{-2t}, skew 0.
        let p = e(1).params().unwrap();
        assert!((p.scale - t.exp()).abs() < 1e-14);
        assert!((p.aspect - (-2.0 * t).exp()).abs() < 1e-14);
        assert!(p.skew.abs() < 1e-14 && p.theta.abs() < 1e-14);
        // A3: rotation by t.
        let p = e(2).params().unwrap();
        assert!((p.theta - t).abs() < 1e-14 && (p.scale - 1.0).abs() < 1e-14);
        assert!((p.aspect - 1.0).abs() < 1e-14);
        let r = e(2).linear();
        assert!((r - rot(t)).amax() < 1e-15);
        // A4: symmetric stretch along the diagonal: skew pi/4, no rotation.
        let p = e(3).params().unwrap();
        assert!((p.scale - t.exp()).abs() < 1e-14);
        assert!((p.aspect - (-2.0 * t).exp()).abs() < 1e-14);
        assert!((p.skew + PI / 4.0).abs() < 1e-14 && p.theta.abs() < 1e-14);
        // A5, A6: translations.
        let p = e(4).params().unwrap();
        assert!((p.dx - t).abs() < 1e-15 && p.dy == 0.0 && (p.scale - 1.0).abs() < 1e-15);
        let p = e(5).params().unwrap();
        assert!((p.dy - t).abs() < 1e-15 && p.dx == 0.0);
        // A5 and A6 commute: exp(a A5 + b A6) is a pure translation.
        let m = Affine2::exp(&Vector6::new(0.0, 0.0, 0.0, 0.0, 3.0, -4.0)).unwrap();
        assert_eq!(m, Affine2::translation(3.0, -4.0));
    }

    #[test]
    fn params_round_trip_and_box() {
        let p = AffineParams {
            dx: 10.0,
            dy: -5.0,
            theta: 0.7,
            scale: 1.5,
            aspect: 0.6,
            skew: -0.4,
        };
        let m = Affine2::from_params(&p).unwrap();
        let q = m.params().unwrap();
        for (a, b) in [
            (p.dx, q.dx),
            (p.dy, q.dy),
            (p.theta, q.theta),
            (p.scale, q.scale),
            (p.aspect, q.aspect),
            (p.skew, q.skew),
        ] {
            assert!((a - b).abs() < 1e-12, "{p:?} vs {q:?}");
        }
        let bx = Affine2::from_params(&AffineParams::at(50.0, 40.0))
            .unwrap()
            .bounding_box(20.0, 10.0)
            .unwrap();
        assert_eq!(
            bx,
            // edges 40..60 x 35..45 in 0-based pixel-centre coordinates
            BBox::new(41.5, 36.5, 20.0, 10.0)
        );
        // A 90 degree rotation swaps width and height.
        let mut p = AffineParams::at(0.0, 0.0);
        p.theta = PI / 2.0;
        let bx = Affine2::from_params(&p)
            .unwrap()
            .bounding_box(20.0, 10.0)
            .unwrap();
        assert!((bx.width - 10.0).abs() < 1e-12 && (bx.height - 20.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input_gives_typed_errors() {
        let sing = Affine2::from_parts(Matrix2::new(1.0, 2.0, 2.0, 4.0), Vector2::zeros()).unwrap();
        assert!(matches!(
            sing.try_inverse(),
            Err(AffineError::Singular { .. })
        ));
        assert!(matches!(sing.log(), Err(AffineError::NoRealLog { .. })));
        let refl =
            Affine2::from_parts(Matrix2::new(1.0, 0.0, 0.0, -1.0), Vector2::zeros()).unwrap();
        assert!(matches!(refl.log(), Err(AffineError::NoRealLog { .. })));
        // -2 I: double negative eigenvalue, no principal logarithm.
        let neg = Affine2::from_parts(Matrix2::identity() * -2.0, Vector2::zeros()).unwrap();
        assert!(matches!(neg.log(), Err(AffineError::NoRealLog { .. })));
        // Two distinct negative eigenvalues.
        let neg2 =
            Affine2::from_parts(Matrix2::new(-1.0, 0.0, 0.0, -3.0), Vector2::zeros()).unwrap();
        assert!(matches!(neg2.log(), Err(AffineError::NoRealLog { .. })));
        let mut bad = Matrix3::identity();
        bad[(2, 0)] = 1.0;
        assert!(matches!(
            Affine2::from_matrix(bad),
            Err(AffineError::NotAffine { .. })
        ));
        bad[(2, 0)] = 0.0;
        bad[(0, 1)] = f64::NAN;
        assert!(matches!(
            Affine2::from_matrix(bad),
            Err(AffineError::NonFinite { .. })
        ));
        assert!(matches!(
            Affine2::exp(&Vector6::new(f64::INFINITY, 0.0, 0.0, 0.0, 0.0, 0.0)),
            Err(AffineError::NonFinite { .. })
        ));
        assert!(Affine2::exp(&Vector6::new(800.0, 0.0, 0.0, 0.0, 0.0, 0.0)).is_err());
        let mut p = AffineParams::at(0.0, 0.0);
        p.scale = -1.0;
        assert!(Affine2::from_params(&p).is_err());
    }

    #[test]
    fn log_of_rotation_near_pi_and_large_elements() {
        // Rotation by 3 rad: principal log is 3 A3.
        let w = Vector6::new(0.2, 0.0, 3.0, 0.0, 1.0, 2.0);
        let m = Affine2::exp(&w).unwrap();
        let l = m.log().unwrap();
        assert!((l - w).amax() < 1e-10, "{l:?}");
        // Strong anisotropic stretch.
        let w = Vector6::new(-0.5, 2.0, 0.3, -1.5, -7.0, 4.0);
        let l = Affine2::exp(&w).unwrap().log().unwrap();
        assert!((l - w).amax() < 1e-10, "{l:?}");
    }

    fn small_algebra() -> impl Strategy<Value = Vector6<f64>> {
        prop::array::uniform6(-0.5f64..0.5).prop_map(Vector6::from)
    }

    proptest! {
        #[test]
        fn log_exp_is_identity_near_zero(w in small_algebra()) {
            let m = Affine2::exp(&w).unwrap();
            let l = m.log().unwrap();
            prop_assert!((l - w).amax() < 1e-12, "w={w:?} l={l:?}");
        }

        #[test]
        fn exp_log_is_identity_near_identity(
            a in prop::array::uniform6(-0.3f64..0.3)
        ) {
            let mut mm = Matrix3::identity();
            mm[(0, 0)] += a[0];
            mm[(0, 1)] += a[1];
            mm[(1, 0)] += a[2];
            mm[(1, 1)] += a[3];
            mm[(0, 2)] = 10.0 * a[4];
            mm[(1, 2)] = 10.0 * a[5];
            let m = Affine2::from_matrix(mm).unwrap();
            let back = Affine2::exp(&m.log().unwrap()).unwrap();
            prop_assert!(close(back.matrix(), m.matrix(), 1e-12));
        }

        #[test]
        fn inverse_and_compose(w in small_algebra(), v in small_algebra()) {
            let a = Affine2::exp(&w).unwrap();
            let b = Affine2::exp(&v).unwrap();
            let ai = a.try_inverse().unwrap();
            prop_assert!(close((a * ai).matrix(), Matrix3::identity(), 1e-13));
            // exp(-w) is the inverse of exp(w).
            let an = Affine2::exp(&(-w)).unwrap();
            prop_assert!(close(an.matrix(), ai.matrix(), 1e-12));
            // Associativity of compose with the matrix product.
            prop_assert!(close((a * b).matrix(), a.matrix() * b.matrix(), 1e-14));
            // bit for bit (the product Affine2 had before it moved to
            // bayestrack-image was nalgebra's; -0 and +0 compare equal)
            let mut p = a.matrix() * b.matrix();
            p[(2, 0)] = 0.0;
            p[(2, 1)] = 0.0;
            p[(2, 2)] = 1.0;
            prop_assert_eq!((a * b).matrix(), p);
            let (x, y) = a.apply(v[4], v[5]);
            let q = a.matrix() * nalgebra::Vector3::new(v[4], v[5], 1.0);
            prop_assert_eq!((x, y), (q[0], q[1]));
        }

        #[test]
        fn params_round_trip(
            dx in -100.0f64..100.0, dy in -100.0f64..100.0,
            theta in -3.1f64..3.1, scale in 0.1f64..5.0,
            aspect in 0.1f64..0.99, skew in -1.5f64..1.5,
        ) {
            let p = AffineParams { dx, dy, theta, scale, aspect, skew };
            let m = Affine2::from_params(&p).unwrap();
            let q = m.params().unwrap();
            let m2 = Affine2::from_params(&q).unwrap();
            prop_assert!(close(m.matrix(), m2.matrix(), 1e-12));
            prop_assert!((q.scale - scale).abs() < 1e-10 * scale);
            prop_assert!((q.aspect - aspect).abs() < 1e-9);
            prop_assert!((wrap_angle(q.theta - theta)).abs() < 1e-9);
            prop_assert!((q.skew - skew).abs() < 1e-8);
        }
    }
}
