//! Closed uniform B-spline curves, the contours that move through the planar
//! affine shape space (Lee, Jo and Kang 2005, sec. 2.4 and eq. 13-14;
//! Blake and Isard 1998, "Active Contours", ch. 3-4).
//!
//! A closed curve of degree `d` with `n` control points `Q_0 .. Q_{n-1}`
//! (indices modulo `n`) has `n` spans; on span `k` with local parameter
//! `u` in `[0, 1)`
//!
//! ```text
//! r(k + u) = sum_{j=0..d} b_j(u) Q_{k+j}
//! ```
//!
//! with the uniform basis functions of that degree (quadratic:
//! `b_0 = (1-u)^2 / 2`, `b_1 = (-2u^2 + 2u + 1) / 2`, `b_2 = u^2 / 2`).
//! The weights sum to one, so the curve is **affine invariant**: the curve
//! of the moved control points `Q' = W Y + Q` of eq. 13 is the same affine
//! map applied to the curve of `Q`. Trackers therefore sample the template
//! curve once and move the samples with [`shape_affine`], never
//! re-evaluating the spline per particle.

use bayestrack_image::Affine2;
use nalgebra::Vector2;

use crate::error::{AffineError, Result};
use crate::shape_space::ShapeVector;

/// The degree of a uniform B-spline (a closed choice).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BSplineDegree {
    /// Degree 2 (order 3): the default of Blake and Isard's contour trackers;
    /// tangent-continuous, each point depends on 3 control points.
    #[default]
    Quadratic,
    /// Degree 3 (order 4): curvature-continuous, 4 control points per point.
    Cubic,
}

impl BSplineDegree {
    /// The polynomial degree `d`.
    pub fn degree(self) -> usize {
        match self {
            Self::Quadratic => 2,
            Self::Cubic => 3,
        }
    }

    /// The `d + 1` basis weights at local parameter `u` in `[0, 1]`.
    #[inline]
    fn weights(self, u: f64) -> [f64; 4] {
        match self {
            Self::Quadratic => [
                0.5 * (1.0 - u) * (1.0 - u),
                0.5 * (-2.0 * u * u + 2.0 * u + 1.0),
                0.5 * u * u,
                0.0,
            ],
            Self::Cubic => {
                let (u2, u3) = (u * u, u * u * u);
                let v = 1.0 - u;
                [
                    v * v * v / 6.0,
                    (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
                    (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
                    u3 / 6.0,
                ]
            }
        }
    }

    /// The derivatives `d b_j / du` at `u`.
    #[inline]
    fn derivatives(self, u: f64) -> [f64; 4] {
        match self {
            Self::Quadratic => [u - 1.0, 1.0 - 2.0 * u, u, 0.0],
            Self::Cubic => {
                let v = 1.0 - u;
                [
                    -0.5 * v * v,
                    1.5 * u * u - 2.0 * u,
                    -1.5 * u * u + u + 0.5,
                    0.5 * u * u,
                ]
            }
        }
    }
}

/// A closed uniform B-spline curve.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedBSpline {
    control: Vec<Vector2<f64>>,
    degree: BSplineDegree,
}

impl ClosedBSpline {
    /// A closed curve through `control` points (at least `degree + 2`, all
    /// finite).
    ///
    /// # Errors
    /// [`AffineError::InvalidParameter`] for too few points,
    /// [`AffineError::NonFinite`] for a NaN or infinite coordinate.
    pub fn new(control: Vec<Vector2<f64>>, degree: BSplineDegree) -> Result<Self> {
        if control.len() < degree.degree() + 2 {
            return Err(AffineError::InvalidParameter {
                name: "control points",
                value: control.len() as f64,
                reason: "a closed B-spline needs at least degree + 2 control points",
            });
        }
        if let Some(index) = control
            .iter()
            .position(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(AffineError::NonFinite {
                what: "B-spline control points",
                index,
            });
        }
        Ok(Self { control, degree })
    }

    /// `n` control points on the ellipse with semi-axes `(a, b)` centred on
    /// the origin, equally spaced in angle from the `+x` axis, pushed out by
    /// the factor that puts the curve's mean normalised radius on the
    /// ellipse (a spline runs inside its control polygon).
    ///
    /// # Errors
    /// [`AffineError::InvalidParameter`] for too few points or a
    /// non-positive (or non-finite) semi-axis.
    pub fn ellipse(n: usize, a: f64, b: f64, degree: BSplineDegree) -> Result<Self> {
        for (name, v) in [("semi-axis a", a), ("semi-axis b", b)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(AffineError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and positive",
                });
            }
        }
        let on = |k: usize| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            Vector2::new(a * t.cos(), b * t.sin())
        };
        let unit = Self::new((0..n).map(on).collect(), degree)?;
        let samples = unit.sample(16);
        let mean: f64 = samples
            .iter()
            .map(|p| (p.x / a).hypot(p.y / b))
            .sum::<f64>()
            / samples.len() as f64;
        Self::new((0..n).map(|k| on(k) / mean).collect(), degree)
    }

    /// The control points.
    pub fn control_points(&self) -> &[Vector2<f64>] {
        &self.control
    }

    /// The degree.
    pub fn degree(&self) -> BSplineDegree {
        self.degree
    }

    /// Number of spans (= number of control points).
    pub fn spans(&self) -> usize {
        self.control.len()
    }

    fn combine(&self, s: f64, basis: [f64; 4]) -> Vector2<f64> {
        let n = self.control.len();
        let k = s.floor().rem_euclid(n as f64) as usize % n;
        let mut p = Vector2::zeros();
        for (j, &b) in basis.iter().take(self.degree.degree() + 1).enumerate() {
            p += self.control[(k + j) % n] * b;
        }
        p
    }

    /// The curve point at parameter `s` (periodic with period `n`; span
    /// `floor(s)`, local parameter `s - floor(s)`).
    pub fn point(&self, s: f64) -> Vector2<f64> {
        self.combine(s, self.degree.weights(s - s.floor()))
    }

    /// The tangent `dr/ds` at `s`.
    pub fn tangent(&self, s: f64) -> Vector2<f64> {
        self.combine(s, self.degree.derivatives(s - s.floor()))
    }

    /// `per_span` points per span, at `s = k + i / per_span`, into `out`
    /// (cleared first): `n * per_span` points in curve order.
    pub fn sample_into(&self, per_span: usize, out: &mut Vec<Vector2<f64>>) {
        out.clear();
        let m = self.control.len() * per_span;
        out.extend((0..m).map(|i| self.point(i as f64 / per_span.max(1) as f64)));
    }

    /// `per_span` points per span (see [`ClosedBSpline::sample_into`]).
    pub fn sample(&self, per_span: usize) -> Vec<Vector2<f64>> {
        let mut out = Vec::new();
        self.sample_into(per_span, &mut out);
        out
    }

    /// Unit normals pointing into the region the curve encloses, at the
    /// parameters of [`ClosedBSpline::sample`] (the tangent turned by 90
    /// degrees towards the inside, the side given by the sign of the
    /// control polygon's area).
    pub fn inward_normals(&self, per_span: usize) -> Vec<Vector2<f64>> {
        let n = self.control.len();
        let area2: f64 = (0..n)
            .map(|i| {
                let (p, q) = (self.control[i], self.control[(i + 1) % n]);
                p.x * q.y - q.x * p.y
            })
            .sum();
        // Counter-clockwise (positive area, y up): the inside is to the left.
        let left = if area2 >= 0.0 { 1.0 } else { -1.0 };
        let m = n * per_span;
        (0..m)
            .map(|i| {
                let t = self.tangent(i as f64 / per_span.max(1) as f64);
                let v = Vector2::new(-t.y, t.x) * left;
                let norm = v.norm();
                if norm > 0.0 { v / norm } else { v }
            })
            .collect()
    }
}

/// The affine map `x' = A x + t` that the shape-space vector `Y` of eq. 13
/// applies to every point (`a11 = 1 + Y_3`, `a12 = Y_6`, `a21 = Y_5`,
/// `a22 = 1 + Y_4`, `t = (Y_1, Y_2)`, 1-based as in the paper), so that
/// `shape_affine(Y)` of a control point equals its row of `W Y + Q`.
///
/// # Errors
/// [`AffineError::NonFinite`] for a NaN or infinite component.
pub fn shape_affine(y: &ShapeVector) -> Result<Affine2> {
    if let Some(index) = y.iter().position(|v| !v.is_finite()) {
        return Err(AffineError::NonFinite {
            what: "shape-space vector",
            index,
        });
    }
    Affine2::from_rows([[1.0 + y[2], y[5], y[0]], [y[4], 1.0 + y[3], y[1]]]).map_err(|_| {
        AffineError::NonFinite {
            what: "shape-space vector",
            index: 0,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ShapeSpace;

    fn blob(degree: BSplineDegree) -> ClosedBSpline {
        let pts = (0..21)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 21.0;
                Vector2::new(
                    20.0 * a.cos() + 3.0 * (2.0 * a).sin(),
                    26.0 * a.sin() + 2.0 * (3.0 * a).cos(),
                )
            })
            .collect();
        ClosedBSpline::new(pts, degree).unwrap()
    }

    #[test]
    fn basis_is_a_partition_of_unity_and_curve_is_continuous() {
        for degree in [BSplineDegree::Quadratic, BSplineDegree::Cubic] {
            for i in 0..=20 {
                let u = i as f64 / 20.0;
                let w = degree.weights(u);
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
                assert!(degree.derivatives(u).iter().sum::<f64>().abs() < 1e-12);
            }
            let c = blob(degree);
            // Continuous across span joins and around the closure.
            for k in 0..=c.spans() {
                let s = k as f64;
                let (a, b) = (c.point(s - 1e-9), c.point(s + 1e-9));
                assert!((a - b).norm() < 1e-6, "{degree:?} {k}");
                let (ta, tb) = (c.tangent(s - 1e-9), c.tangent(s + 1e-9));
                assert!((ta - tb).norm() < 1e-6, "{degree:?} tangent {k}");
            }
            // Tangent = numerical derivative.
            let s = 3.3;
            let num = (c.point(s + 1e-6) - c.point(s - 1e-6)) / 2e-6;
            assert!((num - c.tangent(s)).norm() < 1e-5);
        }
        // Quadratic hand values: the span start is the midpoint of Q_0, Q_1.
        let c = blob(BSplineDegree::Quadratic);
        let q = c.control_points();
        assert!((c.point(0.0) - (q[0] + q[1]) / 2.0).norm() < 1e-12);
        assert!((c.point(0.5) - (q[0] + 6.0 * q[1] + q[2]) / 8.0).norm() < 1e-12);
    }

    #[test]
    fn curve_through_the_shape_space_is_the_affine_map_of_the_template_curve() {
        for degree in [BSplineDegree::Quadratic, BSplineDegree::Cubic] {
            let c = blob(degree);
            let space = ShapeSpace::new(c.control_points().to_vec()).unwrap();
            // W = identity parameters (Y = 0) reproduce the template.
            let y0 = ShapeSpace::rotation_scale(0.0, 0.0, 0.0, 0.0);
            let same = ClosedBSpline::new(space.apply(&y0), degree).unwrap();
            assert_eq!(same.sample(4), c.sample(4));
            let id = shape_affine(&y0).unwrap();
            assert_eq!(id, Affine2::IDENTITY);
            // A rotated, scaled, shifted contour: the spline of W Y + Q is
            // the map of the template spline.
            let y = ShapeSpace::rotation_scale(120.0, 80.0, 0.4, -0.15);
            let moved = ClosedBSpline::new(space.apply(&y), degree).unwrap();
            let m = shape_affine(&y).unwrap();
            for (p, q) in moved.sample(5).iter().zip(c.sample(5)) {
                let (x, yy) = m.apply(q.x, q.y);
                assert!((p - Vector2::new(x, yy)).norm() < 1e-10);
            }
            // And for a general shape vector.
            let g = ShapeVector::from([3.0, -2.0, 0.1, -0.05, 0.2, 0.15]);
            let moved = ClosedBSpline::new(space.apply(&g), degree).unwrap();
            let m = shape_affine(&g).unwrap();
            for (p, q) in moved.sample(3).iter().zip(c.sample(3)) {
                let (x, yy) = m.apply(q.x, q.y);
                assert!((p - Vector2::new(x, yy)).norm() < 1e-10);
            }
        }
        let mut bad = ShapeVector::zeros();
        bad[3] = f64::NAN;
        assert!(matches!(
            shape_affine(&bad),
            Err(AffineError::NonFinite { index: 3, .. })
        ));
    }

    #[test]
    fn ellipse_curve_lies_on_the_ellipse_and_normals_point_in() {
        for degree in [BSplineDegree::Quadratic, BSplineDegree::Cubic] {
            for n in [21, 45] {
                let c = ClosedBSpline::ellipse(n, 20.0, 26.0, degree).unwrap();
                let pts = c.sample(4);
                assert_eq!(pts.len(), 4 * n);
                for p in &pts {
                    let r = (p.x / 20.0).hypot(p.y / 26.0);
                    assert!((r - 1.0).abs() < 2e-3, "{degree:?} n={n} r={r}");
                }
                for (p, nrm) in pts.iter().zip(c.inward_normals(4)) {
                    assert!((nrm.norm() - 1.0).abs() < 1e-12);
                    assert!(p.dot(&nrm) < 0.0, "normal must point to the centre");
                }
                // A clockwise template (reversed) still gets inward normals.
                let mut rev = c.control_points().to_vec();
                rev.reverse();
                let r = ClosedBSpline::new(rev, degree).unwrap();
                for (p, nrm) in r.sample(2).iter().zip(r.inward_normals(2)) {
                    assert!(p.dot(&nrm) < 0.0);
                }
            }
        }
    }

    #[test]
    fn bad_input_is_typed() {
        assert!(matches!(
            ClosedBSpline::new(vec![Vector2::zeros(); 3], BSplineDegree::Quadratic),
            Err(AffineError::InvalidParameter { .. })
        ));
        assert!(matches!(
            ClosedBSpline::new(
                vec![
                    Vector2::zeros(),
                    Vector2::new(1.0, 0.0),
                    Vector2::new(0.0, f64::INFINITY),
                    Vector2::new(1.0, 1.0),
                ],
                BSplineDegree::Quadratic
            ),
            Err(AffineError::NonFinite { index: 2, .. })
        ));
        assert!(ClosedBSpline::ellipse(21, 0.0, 1.0, BSplineDegree::Cubic).is_err());
        assert!(ClosedBSpline::ellipse(21, 1.0, f64::NAN, BSplineDegree::Cubic).is_err());
        assert!(ClosedBSpline::ellipse(3, 1.0, 1.0, BSplineDegree::Quadratic).is_err());
    }
}
