//! Point-cloud particles (Lee, Jo and Kang 2005, sec. 2.4 and 3.1).
//!
//! A particle is a point with its previous position,
//! `X = [x, y, x_prev, y_prev]`, moved by the second-order dynamics of
//! eq. 10 (see the module docs of `condensation` for `A` and `B`) with
//! `sigma_x = sigma_y` = [`PointCloudConfig::sigma`].
//!
//! **Support.** Eq. 9 sums the cues over "the particle's points"
//! `(x_P, y_P) in dP_i`, which the paper does not define further. We take
//! the `(2r + 1) x (2r + 1)` window of pixels centred on the particle's
//! rounded position, `r` = [`PointCloudConfig::support_radius`], clipped
//! to the frame: the pixels the particle stands for. The weight is
//! `mean_S dP + lambda mean_S C` (the window's mean, which is eq. 9's sum
//! divided by the constant `|S|` away from the border), through the
//! `IfdCue` and `SkinCue` windows and the OR `Fusion` of
//! `bayestrack-appearance`. A particle whose centre leaves the frame gets
//! zero weight (sec. 2.3).

use bayestrack_appearance::{Candidate, IfdCue, SkinCue, SkinModel};
use bayestrack_image::{BBox, ImageView, Rect};
use bayestrack_particle::{stream_rng, stream_seed};
use nalgebra::{SVector, Vector4};
use rand::{Rng, RngExt};

use super::avq::{CAvq, CAvqConfig};
use super::common::{
    Condensation, CondensationReport, CueSet, FLOOR, Flat, NEEDS, NormalisedOr, Object, ObjectStep,
    SubtractedOr, channel_policy, check_damping, check_particles, check_positive, second_order,
};
use crate::engine::StateModel;
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Needs, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

/// Key of the random streams ("c-points" in ASCII).
const KEY: u64 = 0x632d_706f_696e_7473;

/// Settings of [`PointCloudTracker`]; `Default` is sec. 3.1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointCloudConfig {
    /// `N`, particles (50).
    pub particles: usize,
    /// The cues and their fusion (OR, eq. 9, `lambda = 1/N`).
    pub cues: CueSet,
    /// `sigma_x = sigma_y`, the diffusion in pixels per frame (30).
    pub sigma: f64,
    /// `rho` of eq. 10 (1/2; see the `condensation` module docs).
    pub velocity_damping: f64,
    /// `r`: a particle's support is the `(2r + 1)^2` window around it (4).
    pub support_radius: usize,
    /// `sigma_hs` of the skin model, eq. 8 (0.05).
    pub sigma_hs: f64,
    /// Selection (roulette wheel when `sum pi^2 > 2/N`).
    pub condensation: Condensation,
    /// c-AVQ re-initialisation from the border stripes (sec. 4); off by
    /// default (a single-target tracker would otherwise jump to anything
    /// that enters the frame).
    pub avq: Option<CAvqConfig>,
}

impl Default for PointCloudConfig {
    fn default() -> Self {
        Self::paper(50)
    }
}

impl PointCloudConfig {
    /// Sec. 3.1 with `n` particles: OR fusion with `lambda = 1/n`,
    /// `sigma_x = sigma_y = 30`, `sigma_hs = 0.05`, selection threshold
    /// `2/n`.
    pub fn paper(n: usize) -> Self {
        Self {
            particles: n,
            cues: CueSet::Or {
                lambda: 1.0 / n.max(1) as f64,
            },
            sigma: 30.0,
            velocity_damping: 0.5,
            support_radius: 4,
            sigma_hs: 0.05,
            condensation: Condensation::POINT_CLOUD,
            avq: None,
        }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the bad field.
    pub fn validate(&self) -> Result<()> {
        check_particles(self.particles)?;
        self.cues.check()?;
        check_positive("sigma", self.sigma)?;
        check_positive("sigma_hs", self.sigma_hs)?;
        check_damping(self.velocity_damping)?;
        self.condensation.validate()?;
        if let Some(a) = &self.avq {
            a.validate()?;
        }
        Ok(())
    }
}

/// The point-cloud model of one object.
#[derive(Debug, Clone, Copy)]
pub(super) struct PointModel {
    sigma: f64,
    rho: f64,
    radius: usize,
    frame: (usize, usize),
    size: (f64, f64),
}

impl PointModel {
    /// Particles uniform over `target` (drawn from `rng`), at rest, with
    /// the cue of `config`; the filter's random streams keyed by `seed`.
    pub(super) fn object<R: Rng + ?Sized>(
        config: &PointCloudConfig,
        frame: ImageView<'_, u8>,
        target: BBox,
        rng: &mut R,
        seed: u64,
    ) -> Result<Box<Object<PointModel, 4>>> {
        let rect =
            target
                .to_rect(frame.width(), frame.height())
                .ok_or(TrackerError::BoxOutsideFrame {
                    bbox: target,
                    width: frame.width(),
                    height: frame.height(),
                })?;
        let skin = if config.cues.uses_skin() {
            let model = SkinModel::from_window(frame, rect, config.sigma_hs)?;
            Some(SkinCue::new(model, FLOOR, 1)?)
        } else {
            None
        };
        let mut normalised = None;
        let cue: Box<dyn bayestrack_appearance::Cue + Send + Sync> = match config.cues {
            CueSet::OrSubtracted { lambda, threshold } => Box::new(SubtractedOr {
                skin: SkinModel::from_window(frame, rect, config.sigma_hs)?,
                lambda,
                threshold: threshold as f32,
            }),
            CueSet::OrNormalised { lambda } => {
                normalised = Some(NormalisedOr {
                    ifd: IfdCue::new(FLOOR, 1)?,
                    skin: SkinCue::new(
                        SkinModel::from_window(frame, rect, config.sigma_hs)?,
                        FLOOR,
                        1,
                    )?,
                    lambda,
                });
                Box::new(Flat)
            }
            cues => cues.build(IfdCue::new(FLOOR, 1)?, skin)?,
        };
        let (x0, y0) = (target.x - 1.0, target.y - 1.0);
        let particles = (0..config.particles)
            .map(|_| {
                let x = x0 + target.width * rng.random::<f64>() - 0.5;
                let y = y0 + target.height * rng.random::<f64>() - 0.5;
                Vector4::new(x, y, x, y)
            })
            .collect();
        let model = PointModel {
            sigma: config.sigma,
            rho: config.velocity_damping,
            radius: config.support_radius,
            frame: (frame.width(), frame.height()),
            size: (target.width, target.height),
        };
        let mut object = Box::new(Object::new(
            model,
            cue,
            &config.condensation,
            particles,
            seed,
        )?);
        object.normalised = normalised;
        Ok(object)
    }

    /// The support window of a particle, `None` when its centre is off the
    /// frame.
    #[inline]
    fn support(&self, s: &SVector<f64, 4>) -> Option<Candidate> {
        let (w, h) = self.frame;
        let (cx, cy) = (s[0].round(), s[1].round());
        if !(cx >= 0.0 && cy >= 0.0 && cx < w as f64 && cy < h as f64) {
            return None;
        }
        let (cx, cy, r) = (cx as usize, cy as usize, self.radius);
        let (x0, y0) = (cx.saturating_sub(r), cy.saturating_sub(r));
        let (x1, y1) = ((cx + r + 1).min(w), (cy + r + 1).min(h));
        Some(Candidate::Window(Rect::new(x0, y0, x1 - x0, y1 - y0)))
    }

    /// The frame's estimate from the weighted-mean state `m` (eq. 4).
    pub(super) fn estimate(&self, m: &SVector<f64, 4>, report: CondensationReport) -> ObjectStep {
        let (w, h) = self.size;
        ObjectStep {
            centre: (m[0], m[1]),
            // OTB centre = 0-based centre + 1.
            bbox: BBox::new(
                m[0] + 1.0 - (w - 1.0) / 2.0,
                m[1] + 1.0 - (h - 1.0) / 2.0,
                w,
                h,
            ),
            pose: None,
            report,
        }
    }
}

impl StateModel<4> for PointModel {
    /// Eq. 10 on `(x, y)`.
    #[inline]
    fn predict<R: Rng + ?Sized>(
        &self,
        _k: usize,
        p: &SVector<f64, 4>,
        rng: &mut R,
    ) -> SVector<f64, 4> {
        let (x, xp) = second_order(p[0], p[2], self.rho, self.sigma, rng);
        let (y, yp) = second_order(p[1], p[3], self.rho, self.sigma, rng);
        Vector4::new(x, y, xp, yp)
    }

    #[inline]
    fn candidate(&self, s: &SVector<f64, 4>) -> Option<Candidate> {
        self.support(s)
    }
}

/// Lee, Jo and Kang (2005) sec. 3.1: CONDENSATION (Isard and Blake 1998)
/// with point-cloud particles weighted by IFD OR skin colour (eq. 9).
/// Position only: the box keeps the initial size.
///
/// Frames: RGB, or gray with [`CueSet::Ifd`] (a skin cue on a gray frame is
/// [`TrackerError::Channels`]).
pub type PointCloudTracker = Shell<PointCloudCore>;

/// The model of [`PointCloudTracker`].
#[derive(Debug)]
pub struct PointCloudCore {
    config: PointCloudConfig,
    seed: u64,
    object: Option<Box<Object<PointModel, 4>>>,
    avq: Option<CAvq>,
    reinitialised: bool,
}

impl PointCloudTracker {
    /// A tracker with `config`, its random streams keyed by `seed`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: PointCloudConfig, seed: u64) -> Result<Self> {
        Ok(Shell::wrap(PointCloudCore::new(config, seed)?))
    }
}

impl PointCloudCore {
    /// The model of [`PointCloudTracker::new`].
    ///
    /// # Errors
    /// As [`PointCloudTracker::new`].
    pub fn new(config: PointCloudConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            seed,
            object: None,
            avq: config.avq.map(CAvq::new).transpose()?,
            reinitialised: false,
        })
    }

    /// The settings.
    pub fn config(&self) -> &PointCloudConfig {
        &self.config
    }

    /// The particles `[x, y, x_prev, y_prev]` (0-based pixels), once
    /// initialised.
    pub fn particles(&self) -> Option<&[Vector4<f64>]> {
        self.object.as_ref().map(|o| o.filter.set().particles())
    }

    /// The normalised weights `pi_i`, once initialised.
    pub fn weights(&self) -> Option<Vec<f64>> {
        self.object.as_ref().map(|o| o.filter.set().weights())
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

impl TrackerCore for PointCloudCore {
    fn name(&self) -> &'static str {
        "condensation-points"
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
        self.object = Some(PointModel::object(
            &self.config,
            frame,
            target,
            &mut rng,
            stream_seed(&[KEY, self.seed]),
        )?);
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let object = self.object.as_mut().ok_or(TrackerError::NotInitialised)?;
        self.reinitialised = object.reinitialise(self.avq.as_mut(), planes.ifd()?);
        let report = object.step(planes.cues())?;
        let s = object.model.estimate(&object.mean(), report);
        Ok(s.estimate(object.len()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::Tracker;
    use bayestrack_image::Image;

    #[test]
    fn support_is_the_clipped_window_and_off_frame_is_impossible() {
        let m = PointModel {
            sigma: 1.0,
            rho: 0.5,
            radius: 2,
            frame: (20, 10),
            size: (5.0, 5.0),
        };
        let at = |x, y| m.support(&Vector4::new(x, y, x, y));
        assert_eq!(
            at(10.0, 5.0),
            Some(Candidate::Window(Rect::new(8, 3, 5, 5)))
        );
        assert_eq!(at(0.2, 0.4), Some(Candidate::Window(Rect::new(0, 0, 3, 3))));
        assert_eq!(
            at(19.4, 9.0),
            Some(Candidate::Window(Rect::new(17, 7, 3, 3)))
        );
        assert_eq!(at(-0.6, 5.0), None);
        assert_eq!(at(19.6, 5.0), None);
        assert_eq!(at(f64::NAN, 5.0), None);
    }

    #[test]
    fn bad_configs_and_frames_are_typed_errors() {
        for bad in [
            PointCloudConfig {
                particles: 0,
                ..Default::default()
            },
            PointCloudConfig {
                sigma: -1.0,
                ..Default::default()
            },
            PointCloudConfig {
                cues: CueSet::Or { lambda: 0.0 },
                ..Default::default()
            },
            PointCloudConfig {
                velocity_damping: 2.0,
                ..Default::default()
            },
        ] {
            assert!(matches!(
                PointCloudTracker::new(bad, 0),
                Err(TrackerError::InvalidParameter { .. })
            ));
        }
        let mut t = PointCloudTracker::new(PointCloudConfig::default(), 0).unwrap();
        let gray = Image::new(40, 30, 1, 0u8).unwrap();
        assert!(matches!(
            t.step(gray.view()),
            Err(TrackerError::NotInitialised)
        ));
        // A skin cue on a gray frame is a typed error, not a panic.
        assert!(matches!(
            t.init(gray.view(), BBox::new(5.0, 5.0, 10.0, 10.0)),
            Err(TrackerError::Channels { got: 1, .. })
        ));
        // IFD alone works on gray frames.
        let mut ifd = PointCloudTracker::new(
            PointCloudConfig {
                cues: CueSet::Ifd,
                ..Default::default()
            },
            0,
        )
        .unwrap();
        ifd.init(gray.view(), BBox::new(5.0, 5.0, 10.0, 10.0))
            .unwrap();
        let e = ifd.step(gray.view()).unwrap();
        assert!(e.lost, "no motion, no evidence");
        assert!(e.bbox.x.is_finite());
        let other = Image::new(41, 30, 1, 0u8).unwrap();
        assert!(matches!(
            ifd.step(other.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        let rgb = Image::new(40, 30, 3, 128u8).unwrap();
        // A gray box has no skin hue to learn.
        assert!(t.init(rgb.view(), BBox::new(5.0, 5.0, 10.0, 10.0)).is_err());
        assert!(matches!(
            t.init(rgb.view(), BBox::new(35.0, 5.0, 10.0, 10.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
    }
}
