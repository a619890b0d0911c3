//! Several objects by the priority-subtracted IFD (Lee, Jo and Kang 2005,
//! sec. 5, eq. 15).
//!
//! One particle set per object, stepped one after another in priority order
//! (the order the objects were added). The paper regards the IFD as a
//! potential field and subtracts, in priority order, what each object has
//! claimed, "like subtractive clustering". Eq. 15 is garbled in the text
//! (`V^0 = dP`, `V^k = dP . V^{k-1}`); our reading, the one of
//! `bayestrack_appearance::PriorityIfd`:
//!
//! ```text
//! V^0 = dP,      V^{k+1} = V^k (1 - K_k),
//! ```
//!
//! with `K_k` the indicator of object `k`'s *support*: its estimated box
//! (after its own step) scaled about its centre by
//! [`MultiConfig::claim_scale`]. Object `k` is weighted on `V^k`, so a
//! later object cannot lock onto the motion an earlier one explains, and
//! two objects that cross keep their identities. The skin cue is not
//! subtracted (the paper subtracts the IFD only).
//!
//! The API has the shape of paper 004's Kalman `MultiTargetTracker`:
//! `new(config, ..)`, then `step(frame)` returns the objects of the frame
//! with stable identities; objects are added with
//! [`MultiCondensation::add_object`] rather than born from blobs.

use bayestrack_appearance::{PriorityIfd, Suppression};
use bayestrack_image::{BBox, ImageView};
use bayestrack_particle::{stream_rng, stream_seed};

use super::common::{CueSet, NEEDS, Object, ObjectStep, channel_policy};
use super::contour::ContourConfig;
use super::contour::ContourModel;
use super::points::PointCloudConfig;
use super::points::PointModel;
use crate::error::{Result, TrackerError};
use crate::shell::PlaneBuffers;
use crate::tracker::{FrameGuard, check_initial_box};

/// Key of the random streams ("c-multi" in ASCII).
const KEY: u64 = 0x0063_2d6d_756c_7469;

/// The representation every object is tracked with.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ObjectConfig {
    /// Point clouds (sec. 3.1; the paper's fig. 6).
    Points(PointCloudConfig),
    /// B-spline contours (sec. 3.2-3.3), ellipse templates.
    Contour(ContourConfig),
}

impl ObjectConfig {
    fn cues(&self) -> CueSet {
        match self {
            ObjectConfig::Points(c) => c.cues,
            ObjectConfig::Contour(c) => c.cues,
        }
    }

    fn validate(&self) -> Result<()> {
        match self {
            ObjectConfig::Points(c) => c.validate(),
            ObjectConfig::Contour(c) => c.validate(),
        }
    }
}

/// Settings of [`MultiCondensation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiConfig {
    /// How each object is tracked (sec. 3.1 point clouds by default).
    pub object: ObjectConfig,
    /// Whether later objects measure on the priority-subtracted field `V^k`
    /// (true) or all on the raw IFD `dP` (false: no priority).
    pub priority: bool,
    /// An object claims its estimated box scaled by this about its centre
    /// (1.0).
    pub claim_scale: f64,
}

impl Default for MultiConfig {
    fn default() -> Self {
        Self {
            object: ObjectConfig::Points(PointCloudConfig::default()),
            priority: true,
            claim_scale: 1.0,
        }
    }
}

/// One object as reported for a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectEstimate {
    /// Identity, stable across frames, in order of addition from 0.
    pub id: u64,
    /// Priority: the object's place in the order of measurement (0 first).
    pub priority: usize,
    /// The weighted-mean centre (eq. 4), 0-based pixels.
    pub centre: (f64, f64),
    /// The box (OTB convention).
    pub bbox: BBox,
    /// Particles in its set.
    pub particles: usize,
    /// Likelihood evaluations this frame.
    pub evaluations: usize,
    /// Whether its set saw no evidence this frame.
    pub lost: bool,
}

/// Lee, Jo and Kang (2005) sec. 5: several objects, one CONDENSATION set
/// each (Isard and Blake 1998), measured in priority order on the
/// priority-subtracted IFD potential field (eq. 15).
#[derive(Debug)]
pub struct MultiCondensation {
    config: MultiConfig,
    seed: u64,
    k: u64,
    guard: FrameGuard,
    planes: PlaneBuffers,
    field: Option<PriorityIfd>,
    objects: Vec<(u64, ObjectFilter)>,
    next_id: u64,
}

impl MultiCondensation {
    /// No objects yet; random streams keyed by `seed`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: MultiConfig, seed: u64) -> Result<Self> {
        config.object.validate()?;
        if !(config.claim_scale.is_finite() && config.claim_scale >= 0.0) {
            return Err(TrackerError::InvalidParameter {
                name: "claim_scale",
                value: config.claim_scale,
                reason: "must be finite and >= 0",
            });
        }
        Ok(Self {
            config,
            seed,
            k: 0,
            guard: FrameGuard::named("condensation-multi"),
            planes: PlaneBuffers::default(),
            field: None,
            objects: Vec::new(),
            next_id: 0,
        })
    }

    /// The settings.
    pub fn config(&self) -> &MultiConfig {
        &self.config
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether no object has been added.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Adds an object at `target` in `frame`, with the lowest priority so
    /// far; returns its identity. The first object's frame starts the
    /// sequence (the IFD of the next `step` is taken against it); later
    /// objects must come with a frame of the same size (normally the frame
    /// last stepped).
    ///
    /// # Errors
    /// [`TrackerError::EmptyBox`], [`TrackerError::BoxOutsideFrame`],
    /// [`TrackerError::Channels`], [`TrackerError::FrameSizeChanged`], and
    /// model errors (a box with no skin hue to learn).
    pub fn add_object(&mut self, frame: ImageView<'_, u8>, target: BBox) -> Result<u64> {
        channel_policy(self.config.object.cues()).check("condensation-multi", frame.channels())?;
        check_initial_box(target, frame.width(), frame.height())?;
        let first = self.objects.is_empty() && self.k == 0;
        if !first {
            self.guard.check(&frame)?;
        }
        let id = self.next_id;
        let mut rng = stream_rng(&[KEY, self.seed, id, u64::MAX]);
        // one filter, and so one family of random streams, per object
        let seed = stream_seed(&[KEY, self.seed, id]);
        let object = match &self.config.object {
            ObjectConfig::Points(c) => {
                ObjectFilter::Points(PointModel::object(c, frame, target, &mut rng, seed)?)
            }
            ObjectConfig::Contour(c) => ObjectFilter::Contour(ContourModel::object(
                c, frame, target, None, &mut rng, seed,
            )?),
        };
        if first {
            self.planes.build(NEEDS, frame, 0)?;
            self.guard.start(&frame);
        }
        self.objects.push((id, object));
        self.next_id += 1;
        Ok(id)
    }

    /// Removes the object `id`; returns whether it existed. The others keep
    /// their order.
    pub fn remove_object(&mut self, id: u64) -> bool {
        let before = self.objects.len();
        self.objects.retain(|(i, _)| *i != id);
        self.objects.len() != before
    }

    /// Tracks every object into `frame`, in priority order, each on its
    /// field `V^k` (eq. 15); returns them in that order.
    ///
    /// # Errors
    /// [`TrackerError::NotInitialised`] before the first object,
    /// [`TrackerError::FrameSizeChanged`], [`TrackerError::Channels`], and
    /// model errors.
    pub fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Vec<ObjectEstimate>> {
        self.guard.check(&frame)?;
        self.k += 1;
        let planes = self.planes.build(NEEDS, frame, self.k)?;
        let ifd = planes.ifd()?;
        let field = match &mut self.field {
            Some(f) => {
                f.reset(ifd)?;
                f
            }
            None => self.field.insert(PriorityIfd::new(ifd)?),
        };
        let mut out = Vec::with_capacity(self.objects.len());
        for (priority, (id, object)) in self.objects.iter_mut().enumerate() {
            let ifd = if self.config.priority {
                field.field()
            } else {
                ifd
            };
            let s = object.step(&planes.cues().with_ifd(ifd))?;
            if self.config.priority {
                let c = self.config.claim_scale;
                let (w, h) = (s.bbox.width * c, s.bbox.height * c);
                let (cx, cy) = s.centre;
                let claim = BBox::new(cx + 1.0 - (w - 1.0) / 2.0, cy + 1.0 - (h - 1.0) / 2.0, w, h);
                if let Some(r) = claim.to_rect(frame.width(), frame.height()) {
                    field.subtract(Suppression::Window(r))?;
                }
            }
            out.push(ObjectEstimate {
                id: *id,
                priority,
                centre: s.centre,
                bbox: s.bbox,
                particles: object.len(),
                evaluations: s.report.evaluations,
                lost: s.report.lost(),
            });
        }
        Ok(out)
    }
}

/// One tracked object in either representation.
#[derive(Debug)]
enum ObjectFilter {
    Points(Box<Object<PointModel, 4>>),
    Contour(Box<Object<ContourModel, 8>>),
}

impl ObjectFilter {
    fn step(&mut self, frame: &bayestrack_appearance::Frame<'_>) -> Result<ObjectStep> {
        match self {
            ObjectFilter::Points(o) => {
                let report = o.step(frame)?;
                Ok(o.model.estimate(&o.mean(), report))
            }
            ObjectFilter::Contour(o) => {
                let report = o.step(frame)?;
                o.model.estimate(&o.mean(), report)
            }
        }
    }

    fn len(&self) -> usize {
        match self {
            ObjectFilter::Points(o) => o.len(),
            ObjectFilter::Contour(o) => o.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn bad_input_is_typed() {
        assert!(
            MultiCondensation::new(
                MultiConfig {
                    claim_scale: f64::NAN,
                    ..Default::default()
                },
                0
            )
            .is_err()
        );
        let mut m = MultiCondensation::new(MultiConfig::default(), 0).unwrap();
        assert!(m.is_empty());
        let rgb = Image::new(40, 30, 3, 0u8).unwrap();
        assert!(matches!(
            m.step(rgb.view()),
            Err(TrackerError::NotInitialised)
        ));
        let gray = Image::new(40, 30, 1, 0u8).unwrap();
        assert!(matches!(
            m.add_object(gray.view(), BBox::new(1.0, 1.0, 5.0, 5.0)),
            Err(TrackerError::Channels { .. })
        ));
        let mut ifd = MultiCondensation::new(
            MultiConfig {
                object: ObjectConfig::Points(PointCloudConfig {
                    cues: CueSet::Ifd,
                    ..Default::default()
                }),
                ..Default::default()
            },
            0,
        )
        .unwrap();
        assert_eq!(
            ifd.add_object(gray.view(), BBox::new(1.0, 1.0, 5.0, 5.0))
                .unwrap(),
            0
        );
        assert_eq!(
            ifd.add_object(gray.view(), BBox::new(10.0, 10.0, 5.0, 5.0))
                .unwrap(),
            1
        );
        let small = Image::new(20, 30, 1, 0u8).unwrap();
        assert!(matches!(
            ifd.add_object(small.view(), BBox::new(1.0, 1.0, 5.0, 5.0)),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        let out = ifd.step(gray.view()).unwrap();
        assert_eq!(out.len(), 2);
        assert_eq!((out[0].id, out[1].id, out[1].priority), (0, 1, 1));
        assert!(ifd.remove_object(0));
        assert!(!ifd.remove_object(0));
        assert_eq!(ifd.step(gray.view()).unwrap()[0].id, 1);
    }
}
