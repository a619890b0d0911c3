//! The one interface every tracker implements.

use bayestrack_image::{Affine2, BBox, ImageView};

use crate::error::{Result, TrackerError};

/// What a tracker reports for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The target box (OTB convention: 1-based corner, width, height).
    pub bbox: BBox,
    /// The affine pose, for trackers that estimate one (maps template
    /// coordinates centred on the template to 0-based image coordinates).
    pub pose: Option<Affine2>,
    /// Particles used in this frame (0 for deterministic trackers).
    pub particles: usize,
    /// Appearance-model evaluations in this frame (windows scored).
    pub evaluations: usize,
    /// Whether the tracker considers the target lost.
    pub lost: bool,
}

/// A single-target tracker: initialised from a box on a first frame, then
/// stepped frame by frame. Frames are 8-bit, gray (1 channel) or RGB (3).
///
/// The CLI, the OTB evaluation and the experiments drive every tracker
/// through this trait.
pub trait Tracker: Send {
    /// Short name, as listed by `bayestrack trackers`.
    fn name(&self) -> &'static str;

    /// Starts tracking `target` in `frame`.
    ///
    /// # Errors
    /// [`TrackerError::NonFiniteBox`], [`TrackerError::EmptyBox`],
    /// [`TrackerError::BoxOutsideFrame`], [`TrackerError::Channels`], and
    /// model errors.
    fn init(&mut self, frame: ImageView<'_, u8>, target: BBox) -> Result<()>;

    /// Tracks into the next frame.
    ///
    /// # Errors
    /// [`TrackerError::NotInitialised`], [`TrackerError::FrameSizeChanged`],
    /// and model errors.
    fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Estimate>;
}

/// Checks an initial box against a frame: finite, non-empty, and inside
/// it (OTB boxes are 1-based), since every tracker cuts its model from the
/// box. A box only partly inside is for the caller to clip first, as the
/// tracking loops of `bayestrack-otb` do (they refuse only a box wholly
/// outside the frame).
///
/// # Errors
/// [`TrackerError::NonFiniteBox`], [`TrackerError::EmptyBox`] or
/// [`TrackerError::BoxOutsideFrame`].
pub fn check_initial_box(bbox: BBox, width: usize, height: usize) -> Result<()> {
    let finite = [bbox.x, bbox.y, bbox.width, bbox.height]
        .iter()
        .all(|v| v.is_finite());
    if !finite {
        return Err(TrackerError::NonFiniteBox { bbox });
    }
    if bbox.width < 1.0 || bbox.height < 1.0 {
        return Err(TrackerError::EmptyBox { bbox });
    }
    let (x0, y0) = (bbox.x - 1.0, bbox.y - 1.0);
    if x0 < 0.0 || y0 < 0.0 || x0 + bbox.width > width as f64 || y0 + bbox.height > height as f64 {
        return Err(TrackerError::BoxOutsideFrame {
            bbox,
            width,
            height,
        });
    }
    Ok(())
}

/// Remembers the first frame's size and channel count, and refuses later
/// frames of another size or channel count (a gray frame after a colour
/// first frame, whatever the tracker: matching channels is the frame
/// source's job). [`crate::Shell`] keeps one for every tracker core.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameGuard {
    /// Width, height and channels of the first frame.
    first: Option<(usize, usize, usize)>,
    /// The tracker named in errors.
    tracker: &'static str,
}

impl FrameGuard {
    /// A guard whose errors name `tracker`.
    pub fn named(tracker: &'static str) -> Self {
        Self {
            first: None,
            tracker,
        }
    }

    /// Records the size and channels of the first frame.
    pub fn start(&mut self, frame: &ImageView<'_, u8>) {
        self.first = Some((frame.width(), frame.height(), frame.channels()));
    }

    /// Forgets the first frame (before a new `init`).
    pub fn reset(&mut self) {
        self.first = None;
    }

    /// Checks a later frame.
    ///
    /// # Errors
    /// [`TrackerError::NotInitialised`] before [`FrameGuard::start`],
    /// [`TrackerError::FrameSizeChanged`] for another size,
    /// [`TrackerError::Channels`] for another channel count.
    pub fn check(&self, frame: &ImageView<'_, u8>) -> Result<()> {
        let (width, height, channels) = self.first.ok_or(TrackerError::NotInitialised)?;
        if (frame.width(), frame.height()) != (width, height) {
            return Err(TrackerError::FrameSizeChanged {
                width,
                height,
                got_width: frame.width(),
                got_height: frame.height(),
            });
        }
        if frame.channels() != channels {
            return Err(TrackerError::Channels {
                tracker: if self.tracker.is_empty() {
                    "tracker"
                } else {
                    self.tracker
                },
                expected: if channels == 1 {
                    "1 (as the first frame)"
                } else {
                    "3 (as the first frame)"
                },
                got: frame.channels(),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::Image;

    #[test]
    fn initial_boxes_are_checked() {
        assert!(check_initial_box(BBox::new(1.0, 1.0, 10.0, 10.0), 10, 10).is_ok());
        assert!(matches!(
            check_initial_box(BBox::new(2.0, 1.0, 10.0, 10.0), 10, 10),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        assert!(matches!(
            check_initial_box(BBox::new(1.0, 1.0, 0.0, 10.0), 10, 10),
            Err(TrackerError::EmptyBox { .. })
        ));
        assert!(matches!(
            check_initial_box(BBox::new(f64::NAN, 1.0, 3.0, 3.0), 10, 10),
            Err(TrackerError::NonFiniteBox { .. })
        ));
    }

    #[test]
    fn frame_guard_rejects_size_changes() {
        let a = Image::new(8, 6, 1, 0u8).unwrap();
        let b = Image::new(8, 7, 1, 0u8).unwrap();
        let mut g = FrameGuard::default();
        assert!(matches!(
            g.check(&a.view()),
            Err(TrackerError::NotInitialised)
        ));
        g.start(&a.view());
        assert!(g.check(&a.view()).is_ok());
        assert!(matches!(
            g.check(&b.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        let rgb = Image::new(8, 6, 3, 0u8).unwrap();
        assert!(matches!(
            g.check(&rgb.view()),
            Err(TrackerError::Channels { got: 3, .. })
        ));
        g.reset();
        assert!(matches!(
            g.check(&a.view()),
            Err(TrackerError::NotInitialised)
        ));
    }
}
