//! The planar affine shape space of B-spline contours (Lee, Jo and Kang (paper 003) eq. 13-14;
//! Blake and Isard, "Active Contours", ch. 4).
//!
//! A contour's control points `Q = [Q_x; Q_y]` (reference, centred on the
//! origin) move to `Q' = W Y + Q` with the `2n x 6` shape matrix
//!
//! ```text
//! W = [ 1 0 Q_x  0   0   Q_y ]
//!     [ 0 1  0  Q_y Q_x  0   ]
//! ```
//!
//! and the shape-space vector `Y = [t_x, t_y, a11 - 1, a22 - 1, a21, a12]`
//! of an affine map `x' = A x + t`. For the rotation-and-scale particles of
//! paper 003 (`theta`, scale increment `alpha`, centroid `(x, y)`):
//! `Y = [x, y, s cos(theta) - 1, s cos(theta) - 1, s sin(theta), -s sin(theta)]`
//! with `s = 1 + alpha`. The paper prints `cos(theta) - 1 + alpha` (the first
//! order form of `s cos(theta) - 1`) and `+ sin(theta)` twice; a rotation
//! needs opposite signs on `a21` and `a12`, and the exact form keeps `Q'` a
//! rotated, scaled copy of `Q` for any angle.

use nalgebra::{SMatrix, SVector, Vector2};

use crate::error::{AffineError, Result};

/// The shape-space vector `Y` (6 components).
pub type ShapeVector = SVector<f64, 6>;

/// A reference contour and its shape matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeSpace {
    reference: Vec<Vector2<f64>>,
}

impl ShapeSpace {
    /// A shape space around reference control points (in contour
    /// coordinates, normally centred on the origin).
    ///
    /// # Errors
    /// [`AffineError::InvalidParameter`] for fewer than 3 points,
    /// [`AffineError::NonFinite`] for a NaN or infinite coordinate.
    pub fn new(reference: Vec<Vector2<f64>>) -> Result<Self> {
        if reference.len() < 3 {
            return Err(AffineError::InvalidParameter {
                name: "control points",
                value: reference.len() as f64,
                reason: "a contour needs at least 3 control points",
            });
        }
        if let Some(index) = reference
            .iter()
            .position(|p| !p.iter().all(|v| v.is_finite()))
        {
            return Err(AffineError::NonFinite {
                what: "reference control points",
                index,
            });
        }
        Ok(Self { reference })
    }

    /// The reference control points `Q`.
    pub fn reference(&self) -> &[Vector2<f64>] {
        &self.reference
    }

    /// `Y` for a particle at centroid `(x, y)` rotated by `theta` and scaled
    /// by `1 + alpha`.
    pub fn rotation_scale(x: f64, y: f64, theta: f64, alpha: f64) -> ShapeVector {
        let s = 1.0 + alpha;
        let (sin, cos) = theta.sin_cos();
        SVector::from([x, y, s * cos - 1.0, s * cos - 1.0, s * sin, -s * sin])
    }

    /// The two rows of `W` for control point `i`.
    pub fn w_rows(&self, i: usize) -> SMatrix<f64, 2, 6> {
        let q = self.reference[i];
        SMatrix::from_row_slice(&[
            1.0, 0.0, q.x, 0.0, 0.0, q.y, //
            0.0, 1.0, 0.0, q.y, q.x, 0.0,
        ])
    }

    /// `Q' = W Y + Q` (eq. 13-14) into `out` (resized to `n`).
    pub fn apply_into(&self, y: &ShapeVector, out: &mut Vec<Vector2<f64>>) {
        out.clear();
        out.extend(self.reference.iter().map(|q| {
            Vector2::new(
                q.x + y[0] + y[2] * q.x + y[5] * q.y,
                q.y + y[1] + y[3] * q.y + y[4] * q.x,
            )
        }));
    }

    /// `Q' = W Y + Q`.
    pub fn apply(&self, y: &ShapeVector) -> Vec<Vector2<f64>> {
        let mut out = Vec::with_capacity(self.reference.len());
        self.apply_into(y, &mut out);
        out
    }

    /// The least-squares shape vector `Y = (W^T W)^{-1} W^T (Q' - Q)` of
    /// observed control points: the affine map that best explains them.
    ///
    /// # Errors
    /// [`AffineError::DimensionMismatch`] when `points` has another length,
    /// [`AffineError::NonFinite`], and [`AffineError::Singular`] when the
    /// reference points are collinear (no unique affine fit).
    pub fn project(&self, points: &[Vector2<f64>]) -> Result<ShapeVector> {
        if points.len() != self.reference.len() {
            return Err(AffineError::DimensionMismatch {
                what: "control points",
                expected: self.reference.len(),
                got: points.len(),
            });
        }
        if let Some(index) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(AffineError::NonFinite {
                what: "control points",
                index,
            });
        }
        let mut wtw = SMatrix::<f64, 6, 6>::zeros();
        let mut wtd = ShapeVector::zeros();
        for (i, p) in points.iter().enumerate() {
            let w = self.w_rows(i);
            wtw += w.transpose() * w;
            wtd += w.transpose() * (p - self.reference[i]);
        }
        let chol = wtw.cholesky().ok_or(AffineError::Singular {
            op: "shape-space projection (collinear reference points)",
            det: wtw.determinant(),
        })?;
        Ok(chol.solve(&wtd))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contour() -> ShapeSpace {
        let pts = (0..12)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 12.0;
                Vector2::new(20.0 * a.cos(), 30.0 * a.sin() + 2.0 * (3.0 * a).cos())
            })
            .collect();
        ShapeSpace::new(pts).unwrap()
    }

    #[test]
    fn rotation_scale_moves_the_contour_rigidly() {
        let s = contour();
        let (x, y, theta, alpha) = (100.0, 50.0, 0.7, 0.2);
        let moved = s.apply(&ShapeSpace::rotation_scale(x, y, theta, alpha));
        let (sin, cos) = theta.sin_cos();
        for (q, p) in s.reference().iter().zip(&moved) {
            let expected = Vector2::new(
                x + 1.2 * (cos * q.x - sin * q.y),
                y + 1.2 * (sin * q.x + cos * q.y),
            );
            assert!((p - expected).norm() < 1e-12, "{p} vs {expected}");
        }
        // identity
        let same = s.apply(&ShapeSpace::rotation_scale(0.0, 0.0, 0.0, 0.0));
        assert_eq!(same, s.reference());
    }

    #[test]
    fn w_times_y_matches_apply_and_projection_inverts_it() {
        let s = contour();
        let y = ShapeVector::from([3.0, -2.0, 0.1, -0.05, 0.2, 0.15]);
        let moved = s.apply(&y);
        for (i, p) in moved.iter().enumerate() {
            assert!((s.w_rows(i) * y + s.reference()[i] - p).norm() < 1e-12);
        }
        let back = s.project(&moved).unwrap();
        assert!((back - y).amax() < 1e-10, "{back}");
    }

    #[test]
    fn bad_input_is_typed() {
        assert!(matches!(
            ShapeSpace::new(vec![Vector2::zeros(); 2]),
            Err(AffineError::InvalidParameter { .. })
        ));
        assert!(matches!(
            ShapeSpace::new(vec![
                Vector2::zeros(),
                Vector2::new(f64::NAN, 0.0),
                Vector2::zeros()
            ]),
            Err(AffineError::NonFinite { index: 1, .. })
        ));
        let line = ShapeSpace::new(
            (0..5)
                .map(|i| Vector2::new(i as f64, 2.0 * i as f64))
                .collect(),
        )
        .unwrap();
        let pts = line.reference().to_vec();
        assert!(matches!(
            line.project(&pts),
            Err(AffineError::Singular { .. })
        ));
        assert!(matches!(
            contour().project(&pts),
            Err(AffineError::DimensionMismatch { .. })
        ));
    }
}
