//! The tracker shell: what every tracker does around its model, in one
//! place.
//!
//! A tracker is a [`TrackerCore`] (its model: what it cuts from the first
//! frame, how it moves from frame to frame) inside a [`Shell`], which
//! implements [`Tracker`]. The shell
//!
//! - applies the core's declared [`ChannelPolicy`] to the first frame, and
//!   holds every later frame to the first frame's size and channel count
//!   (a gray frame after a colour first frame is refused, whatever the
//!   tracker: matching channels is the frame source's job);
//! - checks the initial box (finite, non-empty, inside the frame) and
//!   hands the core both its OTB form and its 0-based pixel rectangle;
//! - builds, once per frame, the planes the core declared in [`Needs`]
//!   (gray, HSV) and gives them to the core as a cue [`Frame`];
//! - counts frames: [`Planes::index`] is 0 at `init` and 1, 2, ... after,
//!   the key of a core's random streams.
//!
//! A new tracker writes only its core: see `examples/custom_tracker.rs`.

use std::ops::Deref;

use bayestrack_appearance::{Frame, interframe_difference_into};
use bayestrack_image::{BBox, Image, ImageView, Rect, rgb_to_gray_into, rgb_to_hsv_into};

use crate::error::{Result, TrackerError};
use crate::tracker::{Estimate, FrameGuard, Tracker, check_initial_box};

/// Which first frames a tracker accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChannelPolicy {
    /// 1-channel gray or 3-channel RGB.
    GrayOrRgb,
    /// 3-channel RGB only: the tracker's model is colour, which a gray
    /// frame (or gray replicated into three channels) does not have. The
    /// text says what needs colour and what to use on gray video, as the
    /// error's `expected` (`"3 (RGB: ...)"`).
    Rgb(&'static str),
}

impl ChannelPolicy {
    pub(crate) fn check(self, tracker: &'static str, channels: usize) -> Result<()> {
        let (ok, expected) = match self {
            Self::GrayOrRgb => (channels == 1 || channels == 3, "1 or 3"),
            Self::Rgb(why) => (channels == 3, why),
        };
        if ok {
            Ok(())
        } else {
            Err(TrackerError::Channels {
                tracker,
                expected,
                got: channels,
            })
        }
    }
}

/// The planes a core reads besides the input frame, built by the shell
/// once per frame. The input itself is always there (as the cue frame's
/// `rgb` plane when it has three channels).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Needs {
    /// 1-channel gray: the input itself when it is gray, else converted
    /// (`bayestrack_image::rgb_to_gray`).
    pub gray: bool,
    /// 3-channel HSV (`bayestrack_image::rgb_to_hsv`), from RGB inputs only.
    pub hsv: bool,
    /// The interframe difference `|I_t - I_{t-1}|` of the 8-bit gray planes
    /// in `[0, 1]` (`bayestrack_appearance::interframe_difference`), zero
    /// on the first frame; implies `gray`.
    pub ifd: bool,
}

impl Needs {
    /// Nothing but the input.
    pub const INPUT: Self = Self {
        gray: false,
        hsv: false,
        ifd: false,
    };
    /// The gray plane.
    pub const GRAY: Self = Self {
        gray: true,
        hsv: false,
        ifd: false,
    };
}

/// One frame as a core sees it: the input, the planes it declared, and
/// the frame's index.
#[derive(Debug, Clone, Copy)]
pub struct Planes<'a> {
    input: ImageView<'a, u8>,
    cues: Frame<'a>,
    index: u64,
}

impl<'a> Planes<'a> {
    /// The frame as given to the tracker (1 or 3 channels).
    pub fn input(&self) -> ImageView<'a, u8> {
        self.input
    }

    /// The planes as a cue frame (`rgb` is the input when it has three
    /// channels; `gray` and `hsv` as declared in [`Needs`]).
    pub fn cues(&self) -> &Frame<'a> {
        &self.cues
    }

    /// The gray plane.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] when the core did not declare
    /// [`Needs::gray`] (a bug in the core, reported rather than panicking).
    pub fn gray(&self) -> Result<ImageView<'a, u8>> {
        self.cues.gray.ok_or(undeclared("gray"))
    }

    /// The interframe difference (zero on the first frame).
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] when the core did not declare
    /// [`Needs::ifd`].
    pub fn ifd(&self) -> Result<ImageView<'a, f32>> {
        self.cues.ifd.ok_or(undeclared("ifd"))
    }

    /// Frame width.
    pub fn width(&self) -> usize {
        self.input.width()
    }

    /// Frame height.
    pub fn height(&self) -> usize {
        self.input.height()
    }

    /// 0 for the frame given to `init`, then 1, 2, ... for each step.
    pub fn index(&self) -> u64 {
        self.index
    }
}

fn undeclared(plane: &'static str) -> TrackerError {
    TrackerError::InvalidParameter {
        name: plane,
        value: 0.0,
        reason: "plane not declared in the tracker's Needs",
    }
}

/// The initial target, checked: inside the frame, finite, at least one
/// pixel wide and high.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitialBox {
    /// As given (OTB convention: 1-based corner, width, height).
    pub bbox: BBox,
    /// The 0-based pixel rectangle it covers.
    pub rect: Rect,
}

/// A tracker's model: everything but the frame handling, which its
/// [`Shell`] does.
pub trait TrackerCore: Send {
    /// Short name, as listed by `bayestrack trackers`.
    fn name(&self) -> &'static str;

    /// The first frames this tracker accepts.
    fn channels(&self) -> ChannelPolicy;

    /// The planes it reads besides the input (none by default).
    fn needs(&self) -> Needs {
        Needs::INPUT
    }

    /// Starts tracking `target` in the first frame.
    ///
    /// # Errors
    /// Model errors (a flat template, an empty histogram, ...).
    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()>;

    /// Tracks into the next frame (same size and channels as the first).
    ///
    /// # Errors
    /// Model errors.
    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate>;
}

/// A [`TrackerCore`] made a [`Tracker`]; reads through to the core
/// ([`Deref`]), so a core's accessors are the tracker's.
#[derive(Debug, Clone)]
pub struct Shell<C> {
    core: C,
    guard: FrameGuard,
    index: u64,
    buffers: PlaneBuffers,
}

impl<C: TrackerCore> Shell<C> {
    /// A shell around `core`.
    pub fn wrap(core: C) -> Self {
        Self {
            guard: FrameGuard::named(core.name()),
            core,
            index: 0,
            buffers: PlaneBuffers::default(),
        }
    }

    /// The core.
    pub fn core(&self) -> &C {
        &self.core
    }

    /// The core, mutably (changing its model between frames).
    pub fn core_mut(&mut self) -> &mut C {
        &mut self.core
    }

    /// Checks a later frame against the first and runs `track` on its
    /// planes: [`Tracker::step`] with the core's own stepping (a time step,
    /// say).
    ///
    /// # Errors
    /// [`TrackerError::NotInitialised`], [`TrackerError::FrameSizeChanged`],
    /// [`TrackerError::Channels`] for another channel count than the first
    /// frame's, and those of `track`.
    pub fn step_with<T>(
        &mut self,
        frame: ImageView<'_, u8>,
        track: impl FnOnce(&mut C, &Planes<'_>) -> Result<T>,
    ) -> Result<T> {
        self.guard.check(&frame)?;
        let index = self.index + 1;
        let planes = self.buffers.build(self.core.needs(), frame, index)?;
        let out = track(&mut self.core, &planes)?;
        self.index = index;
        Ok(out)
    }
}

/// The buffers behind [`Planes`], kept from frame to frame (the previous
/// gray plane for the interframe difference). [`Shell`] keeps one; a
/// multi-object tracker outside the shell keeps its own.
#[derive(Debug, Clone, Default)]
pub struct PlaneBuffers {
    gray: Option<Image<u8>>,
    previous: Option<Image<u8>>,
    hsv: Option<Image<f32>>,
    ifd: Option<Image<f32>>,
}

impl PlaneBuffers {
    /// The planes of `frame` that `needs` asks for; `index` 0 starts a
    /// sequence (a zero interframe difference), later ones difference
    /// against the frame built before.
    ///
    /// # Errors
    /// Image errors (a frame of 2 or 4 channels, or a size that cannot be
    /// allocated).
    pub fn build<'a>(
        &'a mut self,
        needs: Needs,
        frame: ImageView<'a, u8>,
        index: u64,
    ) -> Result<Planes<'a>> {
        let (w, h) = (frame.width(), frame.height());
        let rgb = frame.channels() == 3;
        if !rgb {
            frame.expect_channels("tracker shell", 1)?;
        }
        let mut cues = Frame::new();
        if rgb {
            cues = cues.with_rgb(frame);
        }
        if needs.hsv && rgb {
            let hsv = reshaped(&mut self.hsv, w, h, 3, 0.0)?;
            rgb_to_hsv_into(frame, &mut hsv.view_mut())?;
        }
        // The 8-bit gray plane of an RGB frame, in `gray`.
        if (needs.gray || needs.ifd) && rgb {
            let gray = reshaped(&mut self.gray, w, h, 1, 0)?;
            rgb_to_gray_into(frame, &mut gray.view_mut())?;
        }
        if needs.ifd {
            let ifd = reshaped(&mut self.ifd, w, h, 1, 0.0)?;
            let current = if rgb {
                self.gray.as_ref().map(|g| g.view())
            } else {
                Some(frame)
            };
            let current = current.ok_or(undeclared("gray"))?;
            let previous = reshaped(&mut self.previous, w, h, 1, 0)?;
            if index == 0 {
                ifd.fill(0.0);
            } else {
                interframe_difference_into(current, previous.view(), &mut ifd.view_mut())?;
            }
            if rgb {
                // the current gray plane becomes the previous one
                std::mem::swap(&mut self.gray, &mut self.previous);
            } else {
                for y in 0..h {
                    previous.row_mut(y).copy_from_slice(&frame.row(y)[..w]);
                }
            }
        }
        if needs.gray || needs.ifd {
            let gray = match (rgb, needs.ifd) {
                (false, _) => Some(frame),
                // after the swap, the current gray plane is `previous`
                (true, true) => self.previous.as_ref().map(|g| g.view()),
                (true, false) => self.gray.as_ref().map(|g| g.view()),
            };
            cues = cues.with_gray(gray.ok_or(undeclared("gray"))?);
        }
        if needs.hsv && rgb {
            cues = cues.with_hsv(
                self.hsv
                    .as_ref()
                    .map(|p| p.view())
                    .ok_or(undeclared("hsv"))?,
            );
        }
        if needs.ifd {
            cues = cues.with_ifd(
                self.ifd
                    .as_ref()
                    .map(|p| p.view())
                    .ok_or(undeclared("ifd"))?,
            );
        }
        Ok(Planes {
            input: frame,
            cues,
            index,
        })
    }
}

/// The buffer in `slot`, created or reshaped to `w x h x channels`.
fn reshaped<T: Copy + Default>(
    slot: &mut Option<Image<T>>,
    w: usize,
    h: usize,
    channels: usize,
    fill: T,
) -> Result<&mut Image<T>> {
    let b = match slot.take() {
        Some(mut b) => {
            if (b.width(), b.height(), b.channels()) != (w, h, channels) {
                b.reshape(w, h, channels, fill)?;
            }
            b
        }
        None => Image::new(w, h, channels, fill)?,
    };
    Ok(slot.insert(b))
}

impl<C> Deref for Shell<C> {
    type Target = C;

    fn deref(&self) -> &C {
        &self.core
    }
}

impl<C: TrackerCore> Tracker for Shell<C> {
    fn name(&self) -> &'static str {
        self.core.name()
    }

    fn init(&mut self, frame: ImageView<'_, u8>, target: BBox) -> Result<()> {
        let name = self.core.name();
        self.core.channels().check(name, frame.channels())?;
        let (w, h) = (frame.width(), frame.height());
        check_initial_box(target, w, h)?;
        let rect = target.to_rect(w, h).filter(|r| r.fits_in(w, h)).ok_or(
            TrackerError::BoxOutsideFrame {
                bbox: target,
                width: w,
                height: h,
            },
        )?;
        self.guard.reset();
        let planes = self.buffers.build(self.core.needs(), frame, 0)?;
        self.core
            .start(&planes, InitialBox { bbox: target, rect })?;
        self.guard.start(&frame);
        self.index = 0;
        Ok(())
    }

    fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Estimate> {
        self.step_with(frame, |core, planes| core.track(planes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records what it was given.
    #[derive(Debug, Default)]
    struct Probe {
        policy: Option<ChannelPolicy>,
        seen: Vec<(u64, bool, bool, bool)>,
        started: Option<InitialBox>,
    }

    impl TrackerCore for Probe {
        fn name(&self) -> &'static str {
            "probe"
        }
        fn channels(&self) -> ChannelPolicy {
            self.policy.unwrap_or(ChannelPolicy::GrayOrRgb)
        }
        fn needs(&self) -> Needs {
            Needs {
                gray: true,
                hsv: true,
                ifd: true,
            }
        }
        fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
            self.started = Some(target);
            self.track(frame).map(|_| ())
        }
        fn track(&mut self, f: &Planes<'_>) -> Result<Estimate> {
            let c = f.cues();
            self.seen.push((
                f.index(),
                c.gray.is_some(),
                c.rgb.is_some(),
                c.hsv.is_some(),
            ));
            let g = f.gray()?;
            assert_eq!((g.width(), g.height(), g.channels()), (8, 6, 1));
            Ok(Estimate {
                bbox: BBox::new(1.0, 1.0, 2.0, 2.0),
                pose: None,
                particles: 0,
                evaluations: 0,
                lost: false,
            })
        }
    }

    fn frame(channels: usize, height: usize) -> Image<u8> {
        Image::new(8, height, channels, 100).unwrap()
    }

    #[test]
    fn builds_declared_planes_and_counts_frames() {
        let mut t = Shell::wrap(Probe::default());
        let rgb = frame(3, 6);
        t.init(rgb.view(), BBox::new(2.0, 3.0, 4.0, 2.0)).unwrap();
        assert_eq!(t.started.unwrap().rect, Rect::new(1, 2, 4, 2));
        t.step(rgb.view()).unwrap();
        t.step(rgb.view()).unwrap();
        assert_eq!(
            t.seen,
            vec![
                (0, true, true, true),
                (1, true, true, true),
                (2, true, true, true)
            ]
        );
        // a gray sequence: the input is the gray plane, no colour planes
        let mut g = Shell::wrap(Probe::default());
        g.init(frame(1, 6).view(), BBox::new(1.0, 1.0, 8.0, 6.0))
            .unwrap();
        assert_eq!(g.seen, vec![(0, true, false, false)]);
    }

    #[test]
    fn the_interframe_difference_is_of_consecutive_frames() {
        use bayestrack_image::rgb_to_gray;
        let needs = Needs {
            ifd: true,
            ..Needs::INPUT
        };
        for channels in [1, 3] {
            let frame = |k: usize| {
                let data = (0..8 * 6 * channels)
                    .map(|i| ((i * 37 + k * k * 11 + i / 5 * k) % 251) as u8)
                    .collect();
                Image::from_vec(8, 6, channels, data).unwrap()
            };
            let gray = |k: usize| match channels {
                1 => frame(k),
                _ => rgb_to_gray(frame(k).view()).unwrap(),
            };
            let mut b = PlaneBuffers::default();
            for k in 0..4 {
                let f = frame(k);
                let p = b.build(needs, f.view(), k as u64).unwrap();
                let got = p.cues().ifd.unwrap().to_image();
                assert_eq!(p.gray().unwrap().to_image(), gray(k), "{channels} {k}");
                let want = if k == 0 {
                    Image::new(8, 6, 1, 0.0).unwrap()
                } else {
                    bayestrack_appearance::interframe_difference(gray(k).view(), gray(k - 1).view())
                        .unwrap()
                };
                assert_eq!(got, want, "{channels} channels, frame {k}");
            }
        }
    }

    #[test]
    fn refuses_frames_unlike_the_first() {
        let mut t = Shell::wrap(Probe::default());
        assert!(matches!(
            t.step(frame(3, 6).view()),
            Err(TrackerError::NotInitialised)
        ));
        t.init(frame(3, 6).view(), BBox::new(1.0, 1.0, 2.0, 2.0))
            .unwrap();
        assert!(matches!(
            t.step(frame(1, 6).view()),
            Err(TrackerError::Channels { got: 1, .. })
        ));
        assert!(matches!(
            t.step(frame(3, 7).view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        // a refused frame does not count
        t.step(frame(3, 6).view()).unwrap();
        assert_eq!(t.seen.last().unwrap().0, 1);
    }

    #[test]
    fn applies_the_channel_policy_and_checks_the_box() {
        let mut t = Shell::wrap(Probe {
            policy: Some(ChannelPolicy::Rgb("3 (RGB: the probe is colour)")),
            ..Probe::default()
        });
        assert!(matches!(
            t.init(frame(1, 6).view(), BBox::new(1.0, 1.0, 2.0, 2.0)),
            Err(TrackerError::Channels { got: 1, .. })
        ));
        assert!(matches!(
            t.init(frame(2, 6).view(), BBox::new(1.0, 1.0, 2.0, 2.0)),
            Err(TrackerError::Channels { got: 2, .. })
        ));
        assert!(matches!(
            t.init(frame(3, 6).view(), BBox::new(1.0, 1.0, 9.0, 2.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        assert!(matches!(
            t.init(frame(3, 6).view(), BBox::new(1.0, 1.0, f64::NAN, 2.0)),
            Err(TrackerError::NonFiniteBox { .. })
        ));
        assert!(t.started.is_none());
    }
}
