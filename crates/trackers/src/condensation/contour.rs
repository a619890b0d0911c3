//! Deformable B-spline contour particles (Lee, Jo and Kang 2005, sec. 2.4,
//! 3.2 and 3.3; Blake and Isard 1998).
//!
//! A particle is `X = [x, y, theta, alpha, x_prev, y_prev, theta_prev,
//! alpha_prev]`: the centroid of the control points, the rotation and the
//! scale increment, and their previous values, moved by the second-order
//! dynamics of eq. 10 (`rho` as for the point cloud) with diffusion
//! `(sigma_xy, sigma_xy, sigma_theta, sigma_alpha)`. Its contour is the
//! template's closed B-spline moved through the planar affine shape space
//! `Q' = W Y + Q` of eq. 13-14 with
//! `Y = ShapeSpace::rotation_scale(x, y, theta, alpha)`.
//!
//! **Spline and sampling (our choices).** A closed uniform *quadratic*
//! B-spline (Blake and Isard's usual contour; cubic is available through
//! [`ContourConfig::degree`]) with `n` control points (21 for the face, 45
//! for the hand), sampled at [`ContourConfig::samples_per_span`] = 4 points
//! per span, equally spaced in the parameter: `4 n` measurement points. The
//! template is sampled once; because B-splines are affine invariant, a
//! particle's samples are the template's samples through the affine map of
//! `Y` (`bayestrack_affine::shape_affine`), so a particle costs one 2x3
//! map per sample and no allocation.
//!
//! **Measurement.** The IFD (eq. 7) is read at the curve's samples (nearest
//! pixel; samples off the frame read 0) and averaged. The skin colour (eq. 8)
//! is read at the same samples moved [`ContourConfig::skin_inset`] pixels
//! (at template scale) along the inward normal: exactly on the outline half
//! the pixels are background, which would pull the contour inside the
//! object; an inset of 0 is the paper's literal "skin at the control
//! points". They are fused by AND (eq. 11, sec. 3.3), or the IFD is used
//! alone (sec. 3.2: eq. 9 with `lambda = 0`). A contour whose centroid
//! leaves the frame, or whose scale leaves
//! [`ContourConfig::alpha_range`], has zero weight.

use bayestrack_affine::{BSplineDegree, ClosedBSpline, ShapeSpace, shape_affine};
use bayestrack_appearance::{AppearanceError, Candidate, Cue, Frame, Scratch, SkinModel};
use bayestrack_image::{Affine2, BBox, ImageView, Rgb};
use bayestrack_particle::{stream_rng, stream_seed};
use nalgebra::{SVector, Vector2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::avq::{CAvq, CAvqConfig};
use super::common::{
    Condensation, CondensationReport, CueSet, FLOOR, NEEDS, Object, ObjectStep, channel_policy,
    check_damping, check_particles, check_positive, second_order,
};
use crate::engine::StateModel;
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Needs, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

/// Key of the random streams ("c-contour" in ASCII, truncated).
const KEY: u64 = 0x632d_636f_6e74_6f75;

/// Settings of [`ContourTracker`]; `Default` is sec. 3.3 with `N = 100`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContourConfig {
    /// `N`, particles (contours).
    pub particles: usize,
    /// `n`, control points of the B-spline (21 face, 45 hand).
    pub control_points: usize,
    /// The spline's degree (quadratic).
    pub degree: BSplineDegree,
    /// Measurement points per span (4).
    pub samples_per_span: usize,
    /// `sigma_x = sigma_y`, centroid diffusion in pixels per frame (5).
    pub sigma_xy: f64,
    /// `sigma_theta` in degrees per frame (1 face, 3 hand).
    pub sigma_theta_deg: f64,
    /// `sigma_alpha`, scale-increment diffusion per frame (0.01 face, 0.05
    /// hand).
    pub sigma_alpha: f64,
    /// `rho` of eq. 10 (1/2; see the `condensation` module docs).
    pub velocity_damping: f64,
    /// How rotation and scale move between frames: eq. 10's damped
    /// velocity (the default of these presets) or Blake and Isard's
    /// second-order auto-regressive model around the template.
    pub dynamics: ContourDynamics,
    /// The cues (AND, eq. 11, `lambda = 1/N` face; IFD only hand).
    pub cues: CueSet,
    /// `sigma_hs` of the skin model, eq. 8 (0.05).
    pub sigma_hs: f64,
    /// Where the skin is read: this many pixels inside the curve along its
    /// normal, at template scale (2; 0 reads on the curve).
    pub skin_inset: f64,
    /// Allowed scale increments `alpha` (a contour outside has zero weight):
    /// `(-0.5, 1.0)`, i.e. half to twice the template.
    pub alpha_range: (f64, f64),
    /// Selection (roulette wheel when `sum pi^2 > 1.5/N`).
    pub condensation: Condensation,
    /// c-AVQ re-initialisation (sec. 4); off by default.
    pub avq: Option<CAvqConfig>,
}

impl Default for ContourConfig {
    fn default() -> Self {
        Self::face(100)
    }
}

impl ContourConfig {
    /// Sec. 3.3, the face: `n = 21` control points, AND fusion (eq. 11) with
    /// `lambda = 1/N`, `sigma_xy = 5` px, `sigma_theta = 1` degree,
    /// `sigma_alpha = 0.01`, `sigma_hs = 0.05`, selection at `1.5/N`; the
    /// paper runs `N = 50` and `N = 100`.
    pub fn face(particles: usize) -> Self {
        Self {
            particles,
            control_points: 21,
            degree: BSplineDegree::Quadratic,
            samples_per_span: 4,
            sigma_xy: 5.0,
            sigma_theta_deg: 1.0,
            sigma_alpha: 0.01,
            velocity_damping: 0.5,
            dynamics: ContourDynamics::DampedVelocity,
            cues: CueSet::And {
                lambda: 1.0 / particles.max(1) as f64,
            },
            sigma_hs: 0.05,
            skin_inset: 2.0,
            alpha_range: (-0.5, 1.0),
            condensation: Condensation::CONTOURS,
            avq: None,
        }
    }

    /// Sec. 3.2, the hand: `N = 200`, `n = 45`, IFD only (`lambda = 0`),
    /// `sigma_xy = 5` px, `sigma_theta = 3` degrees, `sigma_alpha = 0.05`,
    /// selection at `1.5/N`.
    pub fn hand() -> Self {
        Self {
            particles: 200,
            control_points: 45,
            sigma_theta_deg: 3.0,
            sigma_alpha: 0.05,
            cues: CueSet::Ifd,
            ..Self::face(200)
        }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<()> {
        check_particles(self.particles)?;
        self.cues.check()?;
        if self.control_points < self.degree.degree() + 2 {
            return Err(TrackerError::InvalidParameter {
                name: "control_points",
                value: self.control_points as f64,
                reason: "a closed B-spline needs at least degree + 2 control points",
            });
        }
        if self.samples_per_span == 0 {
            return Err(TrackerError::InvalidParameter {
                name: "samples_per_span",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        check_positive("sigma_xy", self.sigma_xy)?;
        check_positive("sigma_theta_deg", self.sigma_theta_deg)?;
        check_positive("sigma_alpha", self.sigma_alpha)?;
        check_positive("sigma_hs", self.sigma_hs)?;
        check_damping(self.velocity_damping)?;
        self.coefficients()?;
        if !(self.skin_inset.is_finite() && self.skin_inset >= 0.0) {
            return Err(TrackerError::InvalidParameter {
                name: "skin_inset",
                value: self.skin_inset,
                reason: "must be finite and >= 0",
            });
        }
        let (lo, hi) = self.alpha_range;
        if !(lo.is_finite() && hi.is_finite() && lo > -1.0 && lo <= 0.0 && hi >= 0.0) {
            return Err(TrackerError::InvalidParameter {
                name: "alpha_range",
                value: lo,
                reason: "must satisfy -1 < low <= 0 <= high (finite)",
            });
        }
        self.condensation.validate()?;
        if let Some(a) = &self.avq {
            a.validate()?;
        }
        Ok(())
    }
}

/// How a contour's rotation `theta` and scale increment `alpha` move from
/// frame to frame (the `A` of eq. 10 for those two components; the
/// centroid always follows eq. 10's damped velocity, because the object
/// may wander anywhere in the frame).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ContourDynamics {
    /// Eq. 10 as for the point cloud, `q_t = q_{t-1} + rho (q_{t-1} -
    /// q_{t-2}) + sigma v_t`: `theta` and `alpha` wander with no preferred
    /// value (between selections their spread grows without bound).
    DampedVelocity,
    /// Blake and Isard (1998, ch. 9, the paper's ref. \[5\]): a
    /// second-order auto-regressive process around the template's mean
    /// shape (`theta = alpha = 0`), `q_t = (r + rho) q_{t-1} - r rho
    /// q_{t-2} + sigma v_t`, whose characteristic roots are `rho` (the
    /// velocity's damping, as in eq. 10) and `r < 1` (the return to the
    /// template). `r` is solved so that the process's stationary
    /// root-mean-square displacement is `rms_theta_deg` (`rms_alpha`),
    /// Blake and Isard's parametrisation by an rms displacement; `sigma`
    /// stays the paper's per-frame diffusion. `r = 1` would be
    /// [`ContourDynamics::DampedVelocity`].
    Ar2 {
        /// Stationary rms of the rotation about the template, degrees.
        rms_theta_deg: f64,
        /// Stationary rms of the scale increment about the template.
        rms_alpha: f64,
    },
}

/// Stationary variance of `q_t = a1 q_{t-1} + a2 q_{t-2} + v_t` with unit
/// innovation variance (infinite when not stationary).
fn ar2_variance(a1: f64, a2: f64) -> f64 {
    let d = (1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1);
    if d > 0.0 && a2.abs() < 1.0 {
        (1.0 - a2) / d
    } else {
        f64::INFINITY
    }
}

/// The `(a1, a2)` of the AR(2) process with roots `r` and `rho` whose
/// stationary rms under diffusion `sigma` is `rms`: bisection on `r` in
/// `[0, 1)` (the variance grows with `r`).
fn ar2_coefficients(name: &'static str, rho: f64, sigma: f64, rms: f64) -> Result<(f64, f64)> {
    check_positive(name, rms)?;
    if rho >= 1.0 {
        return Err(TrackerError::InvalidParameter {
            name: "velocity_damping",
            value: rho,
            reason: "the AR(2) contour dynamics needs velocity_damping < 1 (a stationary process)",
        });
    }
    let target = (rms / sigma).powi(2);
    let var = |r: f64| ar2_variance(r + rho, -r * rho);
    if var(0.0) >= target {
        return Err(TrackerError::InvalidParameter {
            name,
            value: rms,
            reason: "must exceed the spread of one damped step, sigma / sqrt(1 - rho^2)",
        });
    }
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if var(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let r = 0.5 * (lo + hi);
    Ok((r + rho, -r * rho))
}

impl ContourConfig {
    /// The AR(2) coefficients `(a1, a2)` of `theta` and `alpha` under
    /// [`ContourDynamics::Ar2`], `None` under damped velocity.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for an rms that is not finite and
    /// positive or not above one step's spread, or `velocity_damping = 1`.
    pub fn coefficients(&self) -> Result<Option<[(f64, f64); 2]>> {
        match self.dynamics {
            ContourDynamics::DampedVelocity => Ok(None),
            ContourDynamics::Ar2 {
                rms_theta_deg,
                rms_alpha,
            } => Ok(Some([
                ar2_coefficients(
                    "rms_theta_deg",
                    self.velocity_damping,
                    self.sigma_theta_deg,
                    rms_theta_deg,
                )?,
                ar2_coefficients(
                    "rms_alpha",
                    self.velocity_damping,
                    self.sigma_alpha,
                    rms_alpha,
                )?,
            ])),
        }
    }
}

/// What a [`CurveCue`] reads along the curve.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum CurveCueKind {
    /// The IFD plane (eq. 7, or a priority field of eq. 15).
    Ifd,
    /// Skin colour (eq. 8) of the RGB plane.
    Skin(SkinModel),
}

/// A cue read at points of a curve: `ln(mean value + floor)` over the
/// points, each moved into the image by the candidate's pose (template
/// coordinates to 0-based pixels) and read at the nearest pixel; points
/// off the frame read 0 (Lee, Jo and Kang 2005, eq. 11 up to the constant
/// number of points). Only [`Candidate::Pose`] is accepted.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveCue {
    kind: CurveCueKind,
    points: Vec<[f64; 2]>,
}

impl CurveCue {
    /// A cue over `points` (template coordinates).
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for no points or a non-finite one.
    pub fn new(kind: CurveCueKind, points: &[Vector2<f64>]) -> Result<Self> {
        if points.is_empty() || points.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(TrackerError::InvalidParameter {
                name: "curve points",
                value: points.len() as f64,
                reason: "need at least one point, all finite",
            });
        }
        Ok(Self {
            kind,
            points: points.iter().map(|p| [p.x, p.y]).collect(),
        })
    }

    /// The points (template coordinates).
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Sum of `value(x, y)` over the mapped points inside a `w x h` frame.
    #[inline]
    fn sum(
        &self,
        pose: &Affine2,
        w: usize,
        h: usize,
        mut value: impl FnMut(usize, usize) -> f32,
    ) -> f64 {
        let m = pose.as_array();
        let (wf, hf) = (w as f64 - 0.5, h as f64 - 0.5);
        let mut s = 0f32;
        for &[u, v] in &self.points {
            let x = m[0] * u + m[1] * v + m[2];
            let y = m[3] * u + m[4] * v + m[5];
            if x >= -0.5 && y >= -0.5 && x < wf && y < hf {
                s += value((x + 0.5) as usize, (y + 0.5) as usize);
            }
        }
        f64::from(s)
    }
}

impl Cue for CurveCue {
    fn name(&self) -> &'static str {
        match self.kind {
            CurveCueKind::Ifd => "curve-ifd",
            CurveCueKind::Skin(_) => "curve-skin",
        }
    }

    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        _scratch: &mut Scratch,
    ) -> bayestrack_appearance::Result<f64> {
        let Candidate::Pose(pose) = candidate else {
            return Err(AppearanceError::InvalidParameter {
                name: "candidate",
                value: "window".to_string(),
                reason: "a curve cue scores affine poses",
            });
        };
        let sum = match self.kind {
            CurveCueKind::Ifd => {
                let ifd = frame.ifd.ok_or(AppearanceError::MissingPlane {
                    cue: "curve-ifd",
                    plane: "ifd",
                })?;
                ifd.expect_channels("curve-ifd", 1)?;
                let (data, stride) = (ifd.as_slice(), ifd.stride());
                self.sum(pose, ifd.width(), ifd.height(), |x, y| data[y * stride + x])
            }
            CurveCueKind::Skin(model) => {
                let rgb = frame.rgb.ok_or(AppearanceError::MissingPlane {
                    cue: "curve-skin",
                    plane: "rgb",
                })?;
                rgb.expect_channels("curve-skin", 3)?;
                let (data, stride) = (rgb.as_slice(), rgb.stride());
                self.sum(pose, rgb.width(), rgb.height(), |x, y| {
                    let o = y * stride + 3 * x;
                    model.score_rgb(Rgb::new(data[o], data[o + 1], data[o + 2]))
                })
            }
        };
        Ok((sum / self.points.len() as f64 + FLOOR).ln())
    }
}

/// The contour model of one object.
#[derive(Debug, Clone)]
pub(super) struct ContourModel {
    sigma: [f64; 4],
    rho: f64,
    /// `(a1, a2)` of `theta` and `alpha` under the AR(2) dynamics.
    ar2: Option<[(f64, f64); 2]>,
    alpha_range: (f64, f64),
    frame: (usize, usize),
    /// The template curve's samples (template coordinates, centred on the
    /// control points' centroid).
    samples: Vec<Vector2<f64>>,
}

/// `Y` of eq. 13 for a contour state.
#[inline]
fn pose_of(s: &SVector<f64, 8>) -> Option<Affine2> {
    shape_affine(&ShapeSpace::rotation_scale(s[0], s[1], s[2], s[3])).ok()
}

impl ContourModel {
    /// The template B-spline for `target`: `outline` control points in
    /// box units (`[-0.5, 0.5]^2` spans the box) or, by default, the
    /// ellipse inscribed in the box; centred on the control points'
    /// centroid.
    fn template(
        config: &ContourConfig,
        target: BBox,
        outline: Option<&[Vector2<f64>]>,
    ) -> Result<ClosedBSpline> {
        let spline = match outline {
            Some(pts) => ClosedBSpline::new(
                pts.iter()
                    .map(|p| Vector2::new(p.x * target.width, p.y * target.height))
                    .collect(),
                config.degree,
            )?,
            None => ClosedBSpline::ellipse(
                config.control_points,
                target.width / 2.0,
                target.height / 2.0,
                config.degree,
            )?,
        };
        let q = spline.control_points();
        let c = q.iter().sum::<Vector2<f64>>() / q.len() as f64;
        Ok(ClosedBSpline::new(
            q.iter().map(|p| p - c).collect(),
            config.degree,
        )?)
    }

    /// Contours around `target`'s centre (each component drawn from `rng`
    /// with its diffusion deviation), at rest, with the cue of `config`;
    /// the filter's random streams keyed by `seed`.
    pub(super) fn object<R: Rng + ?Sized>(
        config: &ContourConfig,
        frame: ImageView<'_, u8>,
        target: BBox,
        outline: Option<&[Vector2<f64>]>,
        rng: &mut R,
        seed: u64,
    ) -> Result<Box<Object<ContourModel, 8>>> {
        let rect =
            target
                .to_rect(frame.width(), frame.height())
                .ok_or(TrackerError::BoxOutsideFrame {
                    bbox: target,
                    width: frame.width(),
                    height: frame.height(),
                })?;
        let spline = Self::template(config, target, outline)?;
        let samples = spline.sample(config.samples_per_span);
        let skin = if config.cues.uses_skin() {
            let model = SkinModel::from_window(frame, rect, config.sigma_hs)?;
            let inner: Vec<Vector2<f64>> = samples
                .iter()
                .zip(spline.inward_normals(config.samples_per_span))
                .map(|(p, n)| p + n * config.skin_inset)
                .collect();
            Some(CurveCue::new(CurveCueKind::Skin(model), &inner)?)
        } else {
            None
        };
        let cue = config
            .cues
            .build(CurveCue::new(CurveCueKind::Ifd, &samples)?, skin)?;
        // The template's centroid in the image: the box centre moved by the
        // offset of the control points' centroid from the box centre (zero
        // for the ellipse).
        let (cx, cy) = (
            target.x - 1.0 + (target.width - 1.0) / 2.0,
            target.y - 1.0 + (target.height - 1.0) / 2.0,
        );
        let offset = match outline {
            Some(pts) => {
                let c = pts.iter().sum::<Vector2<f64>>() / pts.len() as f64;
                Vector2::new(c.x * target.width, c.y * target.height)
            }
            None => Vector2::zeros(),
        };
        let sigma = [
            config.sigma_xy,
            config.sigma_xy,
            config.sigma_theta_deg.to_radians(),
            config.sigma_alpha,
        ];
        let centre = [cx + offset.x, cy + offset.y, 0.0, 0.0];
        let particles = (0..config.particles)
            .map(|_| {
                let mut s = SVector::<f64, 8>::zeros();
                for i in 0..4 {
                    let v: f64 = StandardNormal.sample(rng);
                    s[i] = centre[i] + sigma[i] * v;
                    s[i + 4] = s[i];
                }
                s
            })
            .collect();
        let model = ContourModel {
            sigma,
            rho: config.velocity_damping,
            ar2: config.coefficients()?,
            alpha_range: config.alpha_range,
            frame: (frame.width(), frame.height()),
            samples,
        };
        Ok(Box::new(Object::new(
            model,
            cue,
            &config.condensation,
            particles,
            seed,
        )?))
    }

    /// The pose a state is scored as, `None` when impossible.
    #[inline]
    fn pose(&self, s: &SVector<f64, 8>) -> Option<Candidate> {
        let (w, h) = self.frame;
        let inside = s[0] >= -0.5 && s[1] >= -0.5 && s[0] < w as f64 - 0.5 && s[1] < h as f64 - 0.5;
        let (lo, hi) = self.alpha_range;
        if !inside || !(lo..=hi).contains(&s[3]) {
            return None;
        }
        pose_of(s).map(Candidate::Pose)
    }

    /// The curve samples of state `s` in the image.
    pub(super) fn curve(&self, s: &SVector<f64, 8>) -> Vec<Vector2<f64>> {
        let Some(m) = pose_of(s) else {
            return Vec::new();
        };
        self.samples
            .iter()
            .map(|q| {
                let (x, y) = m.apply(q.x, q.y);
                Vector2::new(x, y)
            })
            .collect()
    }

    /// The frame's estimate from the weighted-mean state `m` (eq. 4).
    pub(super) fn estimate(
        &self,
        m: &SVector<f64, 8>,
        report: CondensationReport,
    ) -> Result<ObjectStep> {
        let pose = pose_of(m).ok_or(TrackerError::InvalidParameter {
            name: "mean contour",
            value: f64::NAN,
            reason: "the weighted mean state is not finite",
        })?;
        let (mut x0, mut y0, mut x1, mut y1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for q in &self.samples {
            let (x, y) = pose.apply(q.x, q.y);
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x);
            y1 = y1.max(y);
        }
        Ok(ObjectStep {
            centre: (m[0], m[1]),
            // The samples' extent as pixel areas, OTB 1-based.
            bbox: BBox::new(x0 + 0.5, y0 + 0.5, x1 - x0 + 1.0, y1 - y0 + 1.0),
            pose: Some(pose),
            report,
        })
    }
}

impl StateModel<8> for ContourModel {
    /// Eq. 10 on `(x, y, theta, alpha)`; `theta` and `alpha` by the AR(2)
    /// model around the template under [`ContourDynamics::Ar2`].
    #[inline]
    fn predict<R: Rng + ?Sized>(
        &self,
        _k: usize,
        p: &SVector<f64, 8>,
        rng: &mut R,
    ) -> SVector<f64, 8> {
        let mut x = *p;
        for i in 0..4 {
            let (q, qp) = match (i, &self.ar2) {
                (2 | 3, Some(c)) => {
                    let (a1, a2) = c[i - 2];
                    let v: f64 = StandardNormal.sample(rng);
                    (a1 * p[i] + a2 * p[i + 4] + self.sigma[i] * v, p[i])
                }
                _ => second_order(p[i], p[i + 4], self.rho, self.sigma[i], rng),
            };
            x[i] = q;
            x[i + 4] = qp;
        }
        x
    }

    #[inline]
    fn candidate(&self, s: &SVector<f64, 8>) -> Option<Candidate> {
        self.pose(s)
    }
}

/// Lee, Jo and Kang (2005) sec. 3.2-3.3: CONDENSATION (Isard and Blake
/// 1998) with deformable B-spline contour particles in the planar affine
/// shape space (eq. 13), weighted by IFD AND skin colour along the curve
/// (eq. 11) or by IFD alone. Estimates position, rotation and scale: the
/// box is the extent of the mean contour, the pose maps template
/// coordinates (centred on the control points' centroid) to 0-based pixels.
///
/// Frames: RGB, or gray with [`CueSet::Ifd`] (a skin cue on a gray frame is
/// [`TrackerError::Channels`]).
pub type ContourTracker = Shell<ContourCore>;

/// The model of [`ContourTracker`].
#[derive(Debug)]
pub struct ContourCore {
    config: ContourConfig,
    outline: Option<Vec<Vector2<f64>>>,
    seed: u64,
    object: Option<Box<Object<ContourModel, 8>>>,
    avq: Option<CAvq>,
    reinitialised: bool,
}

impl ContourTracker {
    /// A tracker whose template is the ellipse inscribed in the initial
    /// box, with `config.control_points` control points.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: ContourConfig, seed: u64) -> Result<Self> {
        Ok(Shell::wrap(ContourCore::new(config, seed)?))
    }

    /// A tracker with its own template: closed B-spline control points in
    /// box units (`(-0.5, -0.5)` is the initial box's top-left corner,
    /// `(0.5, 0.5)` its bottom-right), e.g. a hand's outline;
    /// `config.control_points` is ignored.
    ///
    /// # Errors
    /// As [`ContourTracker::new`], and [`TrackerError::Affine`] for too few
    /// or non-finite points.
    pub fn with_outline(
        config: ContourConfig,
        outline: Vec<Vector2<f64>>,
        seed: u64,
    ) -> Result<Self> {
        Ok(Shell::wrap(ContourCore::with_outline(
            config, outline, seed,
        )?))
    }
}

impl ContourCore {
    /// The model of [`ContourTracker::new`].
    ///
    /// # Errors
    /// As [`ContourTracker::new`].
    pub fn new(config: ContourConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            outline: None,
            seed,
            object: None,
            avq: config.avq.map(CAvq::new).transpose()?,
            reinitialised: false,
        })
    }

    /// A tracker with its own template: closed B-spline control points in
    /// box units (`(-0.5, -0.5)` is the initial box's top-left corner,
    /// `(0.5, 0.5)` its bottom-right), e.g. a hand's outline;
    /// `config.control_points` is ignored.
    ///
    /// # Errors
    /// As [`ContourTracker::new`], and [`TrackerError::Affine`] for too few
    /// or non-finite points.
    pub fn with_outline(
        config: ContourConfig,
        outline: Vec<Vector2<f64>>,
        seed: u64,
    ) -> Result<Self> {
        ClosedBSpline::new(outline.clone(), config.degree)?;
        let mut t = Self::new(config, seed)?;
        t.outline = Some(outline);
        Ok(t)
    }

    /// The settings.
    pub fn config(&self) -> &ContourConfig {
        &self.config
    }

    /// The particles `[x, y, theta, alpha, x_prev, y_prev, theta_prev,
    /// alpha_prev]`, once initialised.
    pub fn particles(&self) -> Option<&[SVector<f64, 8>]> {
        self.object.as_ref().map(|o| o.filter.set().particles())
    }

    /// The normalised weights `pi_i`, once initialised.
    pub fn weights(&self) -> Option<Vec<f64>> {
        self.object.as_ref().map(|o| o.filter.set().weights())
    }

    /// The measurement points of a state's curve, in 0-based pixels (to
    /// draw particles or score the mean contour); empty before `init`.
    pub fn curve(&self, state: &SVector<f64, 8>) -> Vec<Vector2<f64>> {
        self.object
            .as_ref()
            .map_or(Vec::new(), |o| o.model.curve(state))
    }

    /// The weighted-mean state (eq. 4), once initialised.
    pub fn mean_state(&self) -> Option<SVector<f64, 8>> {
        self.object.as_ref().map(|o| o.mean())
    }

    /// Whether c-AVQ moved the set in the last step.
    pub fn reinitialised(&self) -> bool {
        self.reinitialised
    }

    /// The c-AVQ state (its last stripe share and winner), when enabled.
    pub fn avq(&self) -> Option<&CAvq> {
        self.avq.as_ref()
    }
}

impl TrackerCore for ContourCore {
    fn name(&self) -> &'static str {
        "condensation-contour"
    }

    fn channels(&self) -> ChannelPolicy {
        channel_policy(self.config.cues)
    }

    fn needs(&self) -> Needs {
        NEEDS
    }

    fn start(&mut self, planes: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (frame, target) = (planes.input(), target.bbox);
        let mut rng = stream_rng(&[KEY, self.seed, u64::MAX]);
        self.object = Some(ContourModel::object(
            &self.config,
            frame,
            target,
            self.outline.as_deref(),
            &mut rng,
            stream_seed(&[KEY, self.seed]),
        )?);
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let object = self.object.as_mut().ok_or(TrackerError::NotInitialised)?;
        self.reinitialised = object.reinitialise(self.avq.as_mut(), planes.ifd()?);
        let report = object.step(planes.cues())?;
        let s = object.model.estimate(&object.mean(), report)?;
        Ok(s.estimate(object.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn curve_cue_reads_the_mapped_points() {
        // IFD plane: 1 on column 10, else 0.
        let ifd = Image::from_fn(20, 20, |x, _| if x == 10 { 1.0f32 } else { 0.0 }).unwrap();
        let pts = [
            Vector2::new(0.0, 0.0),
            Vector2::new(0.0, 3.0),
            Vector2::new(5.0, 0.0),
            Vector2::new(40.0, 0.0),
        ];
        let cue = CurveCue::new(CurveCueKind::Ifd, &pts).unwrap();
        let frame = Frame::new().with_ifd(ifd.view());
        let mut s = Scratch::new();
        // Shifted by (10, 5): two points on the column, one off it, one off
        // the frame: mean 2/4.
        let pose = Candidate::Pose(Affine2::translation(10.0, 5.0));
        let l = cue.log_likelihood(&frame, &pose, &mut s).unwrap();
        assert!((l - (0.5 + FLOOR).ln()).abs() < 1e-9);
        // Scaled by 2 about the origin, shifted down 5: only (5, 0) lands on
        // the column, at (10, 5): mean 1/4.
        let scaled =
            Candidate::Pose(Affine2::from_rows([[2.0, 0.0, 0.0], [0.0, 2.0, 5.0]]).unwrap());
        let ls = cue.log_likelihood(&frame, &scaled, &mut s).unwrap();
        assert!((ls - (0.25 + FLOOR).ln()).abs() < 1e-9);
        // Rounded to the nearest pixel.
        let pose = Candidate::Pose(Affine2::translation(10.4, 5.0));
        assert!((cue.log_likelihood(&frame, &pose, &mut s).unwrap() - l).abs() < 1e-9);
        let pose = Candidate::Pose(Affine2::translation(10.6, 5.0));
        assert!(cue.log_likelihood(&frame, &pose, &mut s).unwrap() < -20.0);
        assert!(
            cue.log_likelihood(
                &frame,
                &Candidate::Window(bayestrack_image::Rect::new(0, 0, 2, 2)),
                &mut s
            )
            .is_err()
        );
        assert!(matches!(
            cue.log_likelihood(&Frame::new(), &pose, &mut s),
            Err(AppearanceError::MissingPlane { .. })
        ));
        assert!(CurveCue::new(CurveCueKind::Ifd, &[]).is_err());
    }

    #[test]
    fn template_reproduces_the_box_ellipse() {
        let c = ContourConfig::face(10);
        let t = ContourModel::template(&c, BBox::new(11.0, 21.0, 40.0, 52.0), None).unwrap();
        for p in t.sample(4) {
            let r = (p.x / 20.0).hypot(p.y / 26.0);
            assert!((r - 1.0).abs() < 3e-3, "{r}");
        }
    }

    #[test]
    fn bad_configs_are_typed_errors() {
        for bad in [
            ContourConfig {
                control_points: 3,
                ..ContourConfig::face(10)
            },
            ContourConfig {
                samples_per_span: 0,
                ..ContourConfig::face(10)
            },
            ContourConfig {
                alpha_range: (-1.0, 1.0),
                ..ContourConfig::face(10)
            },
            ContourConfig {
                sigma_alpha: f64::NAN,
                ..ContourConfig::hand()
            },
            ContourConfig {
                skin_inset: -1.0,
                ..ContourConfig::hand()
            },
        ] {
            assert!(ContourTracker::new(bad, 0).is_err());
        }
        assert!(
            ContourTracker::with_outline(ContourConfig::hand(), vec![Vector2::zeros(); 2], 0)
                .is_err()
        );
    }
}

#[cfg(test)]
mod dynamics_tests {
    use super::*;

    fn model(config: &ContourConfig) -> ContourModel {
        ContourModel {
            sigma: [
                config.sigma_xy,
                config.sigma_xy,
                config.sigma_theta_deg.to_radians(),
                config.sigma_alpha,
            ],
            rho: config.velocity_damping,
            ar2: config.coefficients().unwrap(),
            alpha_range: config.alpha_range,
            frame: (320, 240),
            samples: Vec::new(),
        }
    }

    /// Spread of theta (degrees) and alpha after `steps` predictions from
    /// rest, over many independent chains.
    fn spread(config: &ContourConfig, steps: usize) -> (f64, f64) {
        let m = model(config);
        let mut rng = stream_rng(&[KEY, 99]);
        let chains = 4000;
        let (mut st, mut sa) = (0.0, 0.0);
        for _ in 0..chains {
            let mut s = SVector::<f64, 8>::zeros();
            for k in 0..steps {
                s = m.predict(k, &s, &mut rng);
            }
            st += s[2].to_degrees().powi(2);
            sa += s[3].powi(2);
        }
        ((st / chains as f64).sqrt(), (sa / chains as f64).sqrt())
    }

    #[test]
    fn ar2_holds_theta_and_alpha_at_the_stated_rms_around_the_template() {
        let ar2 = ContourConfig {
            dynamics: ContourDynamics::Ar2 {
                rms_theta_deg: 10.0,
                rms_alpha: 0.1,
            },
            ..ContourConfig::face(100)
        };
        let [(a1, a2), _] = ar2.coefficients().unwrap().unwrap();
        // Roots rho = 1/2 and r in (0, 1).
        let r = a1 - 0.5;
        assert!(
            r > 0.0 && r < 1.0 && (a2 + 0.5 * r).abs() < 1e-12,
            "{a1} {a2}"
        );
        // Long after the start the spread is the stated rms (4000 chains:
        // 2.2 % standard error of an rms), and it stays there.
        for steps in [400, 800] {
            let (t, a) = spread(&ar2, steps);
            assert!((t - 10.0).abs() < 0.8, "{steps}: theta rms {t}");
            assert!((a - 0.1).abs() < 0.008, "{steps}: alpha rms {a}");
        }
        // Eq. 10's damped velocity has no mean to return to: its spread
        // grows as the square root of the steps (1.15 sigma sqrt(k)... far
        // above the AR(2)'s after 400 steps).
        let free = ContourConfig::face(100);
        let (t, a) = spread(&free, 400);
        assert!(t > 30.0 && a > 0.3, "damped velocity: {t} deg, {a}");
    }

    #[test]
    fn ar2_rejects_an_rms_below_one_step_and_a_unit_velocity_root() {
        let bad = |rms_theta_deg: f64, rms_alpha: f64, rho: f64| ContourConfig {
            dynamics: ContourDynamics::Ar2 {
                rms_theta_deg,
                rms_alpha,
            },
            velocity_damping: rho,
            ..ContourConfig::face(100)
        };
        assert!(bad(10.0, 0.1, 0.5).validate().is_ok());
        // One damped step already spreads sigma / sqrt(1 - rho^2) = 1.15 deg.
        assert!(bad(1.1, 0.1, 0.5).validate().is_err());
        assert!(bad(10.0, f64::NAN, 0.5).validate().is_err());
        assert!(bad(-1.0, 0.1, 0.5).validate().is_err());
        assert!(bad(10.0, 0.1, 1.0).validate().is_err());
    }
}
