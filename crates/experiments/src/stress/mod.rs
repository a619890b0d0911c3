//! Synthetic stress sequences with exact ground truth, scored by the OTB
//! metrics: the set on which a tracker parameter is chosen (never on the
//! three real sequences, which only report it).
//!
//! Nine stresses, each rendered in colour and as a gray variant (the
//! colour frame converted with BT.601 before the sensor noise), 320x240 at
//! 30 fps, 120 frames by default:
//!
//! | sequence | what stresses the tracker |
//! |---|---|
//! | `partial-occlusion` | a pole, then a low wall, cover up to about half of the target |
//! | `full-occlusion` | the target passes behind a board wider than itself: hidden for about 25 frames, then reappears on the other side |
//! | `scale` | the target's size follows `2^sin(2 pi k / (N - 1))`: it grows to 2x, shrinks back through 1x to 0.5x, and returns (about 3.7 % per frame at most) |
//! | `fast-motion` | 12-24 px per frame in straight segments, turning at random and at the walls |
//! | `illumination` | a global gain ramp 1 -> 0.5 -> 1 -> 1.5 -> 1 with an offset, and a soft moving shadow (gain 0.35) that crosses the target |
//! | `clutter` | four distractors of the target's colour and texture family (same base colour, same texture statistics, another texture), one crossing just behind the target |
//! | `mixed` | moderate motion, scale 0.7x-1.4x, a pole, a gain ramp down to 0.6, two distractors |
//! | `deformation` | non-rigid: the aspect swings 0.76x-1.32x in width (height inversely, three times) while two travelling waves displace the texture by up to 3 px inside the box |
//! | `out-of-plane` | the target is a lit cylinder turning up to 80 degrees either way about its vertical axis (one and a half swings): the side first seen shrinks to a sliver, texture never seen turns into view |
//!
//! The gray variants are named `<sequence>-gray`. Every sequence is a
//! [`StressScene`] (a [`SceneStream`] like the paper scenes), so
//! [`crate::scenes::write_scene`] writes it in OTB layout and
//! `bayestrack_otb::suite::run_suite` scores it exactly as a real
//! sequence; [`write_set`] writes the whole set, and rewrites a sequence only
//! when it is missing or differs from what the seed renders.
//!
//! # The target and the scene
//! The target is a textured rectangle (36x44 px at scale 1): a reddish base
//! colour modulated by value noise (a shared luminance field with cells of
//! 7 px and one field per channel with cells of 4 px, in the target's own
//! coordinates, so the texture scales with it), on a static greenish
//! value-noise background. Distractors are drawn behind the target,
//! occluders (blue-gray striped boards) in front. Sensor noise is Gaussian,
//! sigma 2 grey levels, drawn per frame from its own generator.
//!
//! # Ground truth and occlusion
//! `groundtruth_rect.txt` holds the target's full extent as an OTB box
//! (1-based top-left plus size, see [`crate::scenes`]) in **every** frame,
//! also while it is partly or fully hidden: the OTB suite scores every
//! frame, so a tracker is scored during a full occlusion against the box
//! where the hidden target is (a tracker that waits where the target
//! vanished, or coasts along its motion, keeps part of its overlap; one
//! that jumps to the clutter loses it). `truth.csv` gives the visible
//! fraction of every frame (0 while hidden), so a reader can score the
//! visible frames alone.
//!
//! ```
//! use bayestrack_experiments::stress::{Stress, StressScene};
//! use bayestrack_experiments::scenes::SceneStream;
//!
//! let scene = StressScene { frames: 10, ..StressScene::new(Stress::Scale, true) };
//! let mut stream = scene.stream(1).unwrap();
//! let frame = stream.next_frame().unwrap();
//! assert_eq!((frame.image.width(), frame.image.channels()), (320, 3));
//! assert_eq!(frame.truth.target().unwrap().bbox.width, 36.0);
//! ```

mod plan;
mod render;
mod report;
#[cfg(test)]
mod tests;
mod write;

use bayestrack_image::{Image, rgb_to_gray_into};

use crate::scenes::render::add_noise;
use crate::scenes::{
    FrameTruth, ObjectTruth, Result, SceneError, SceneInfo, SceneStream, check_range, otb_box,
    scene_rng, streams,
};

pub use plan::{FramePlan, Look};
pub use report::{SweepRow, stress_table, sweep_table};
pub use write::{MANIFEST_FILE, SetSummary, write_set};

/// Frames of every stress sequence by default.
pub const DEFAULT_FRAMES: usize = 120;

/// Most frames a stress sequence may have (the plan is held in memory).
pub const MAX_FRAMES: usize = 3000;

/// One kind of stress.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stress {
    /// A pole and a low wall cover up to about half of the target.
    PartialOcclusion,
    /// The target is hidden behind a board for about 25 frames.
    FullOcclusion,
    /// Scale 1 -> 2 -> 1 -> 0.5 -> 1, smoothly.
    Scale,
    /// 12-24 px per frame.
    FastMotion,
    /// Global gain and offset ramps and a moving shadow.
    Illumination,
    /// Distractors of the target's colour and texture family.
    Clutter,
    /// Several stresses at once, milder.
    Mixed,
    /// Non-rigid: the texture warps inside a box whose aspect changes.
    Deformation,
    /// The target is a cylinder that turns about its vertical axis.
    OutOfPlane,
}

impl Stress {
    /// Every stress, in the set's order.
    pub const ALL: [Stress; 9] = [
        Stress::PartialOcclusion,
        Stress::FullOcclusion,
        Stress::Scale,
        Stress::FastMotion,
        Stress::Illumination,
        Stress::Clutter,
        Stress::Mixed,
        Stress::Deformation,
        Stress::OutOfPlane,
    ];

    /// The colour sequence's name (`partial-occlusion`, ...).
    pub fn name(self) -> &'static str {
        self.names()[0]
    }

    /// The sequence name of the colour (`colour = true`) or gray variant.
    pub fn sequence_name(self, colour: bool) -> &'static str {
        self.names()[usize::from(!colour)]
    }

    fn names(self) -> [&'static str; 2] {
        match self {
            Stress::PartialOcclusion => ["partial-occlusion", "partial-occlusion-gray"],
            Stress::FullOcclusion => ["full-occlusion", "full-occlusion-gray"],
            Stress::Scale => ["scale", "scale-gray"],
            Stress::FastMotion => ["fast-motion", "fast-motion-gray"],
            Stress::Illumination => ["illumination", "illumination-gray"],
            Stress::Clutter => ["clutter", "clutter-gray"],
            Stress::Mixed => ["mixed", "mixed-gray"],
            Stress::Deformation => ["deformation", "deformation-gray"],
            Stress::OutOfPlane => ["out-of-plane", "out-of-plane-gray"],
        }
    }

    /// The stress of a sequence name (colour or gray variant).
    pub fn of_sequence(name: &str) -> Option<(Stress, bool)> {
        Stress::ALL.into_iter().find_map(|s| {
            if s.sequence_name(true) == name {
                Some((s, true))
            } else if s.sequence_name(false) == name {
                Some((s, false))
            } else {
                None
            }
        })
    }
}

/// One stress sequence: what it stresses, its size and length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StressScene {
    /// The stress.
    pub stress: Stress,
    /// Colour (3 channels) or the gray variant (1 channel).
    pub colour: bool,
    /// Number of frames (the stresses are laid out over them: fewer frames
    /// make every motion faster).
    pub frames: usize,
    /// Standard deviation of the sensor noise, grey levels.
    pub noise_sigma: f64,
}

/// Frame width of every stress sequence.
pub const WIDTH: usize = 320;
/// Frame height of every stress sequence.
pub const HEIGHT: usize = 240;
/// Frames per second written to `scene.txt`.
pub const FPS: f64 = 30.0;
/// Target width and height at scale 1, px.
pub const TARGET_SIZE: [f64; 2] = [36.0, 44.0];

impl StressScene {
    /// The default sequence of `stress`, colour or gray.
    pub fn new(stress: Stress, colour: bool) -> Self {
        Self {
            stress,
            colour,
            frames: DEFAULT_FRAMES,
            noise_sigma: 2.0,
        }
    }

    /// Its sequence name.
    pub fn name(&self) -> &'static str {
        self.stress.sequence_name(self.colour)
    }

    /// Size, rate and length.
    pub fn info(&self) -> SceneInfo {
        SceneInfo {
            name: self.name(),
            width: WIDTH,
            height: HEIGHT,
            channels: if self.colour { 3 } else { 1 },
            fps: FPS,
            frames: self.frames,
        }
    }

    fn validate(&self) -> Result<()> {
        if !(10..=MAX_FRAMES).contains(&self.frames) {
            return Err(SceneError::InvalidParameter {
                scene: "stress",
                name: "frames",
                reason: format!("{} is not in 10..={MAX_FRAMES}", self.frames),
            });
        }
        check_range("stress", "noise_sigma", self.noise_sigma, 0.0, 50.0)
    }

    /// The per-frame layout (target, occluders, distractors, light) under
    /// `seed`: what [`StressScene::stream`] renders.
    ///
    /// # Errors
    /// [`SceneError::InvalidParameter`] for frames outside `10..=`
    /// [`MAX_FRAMES`] or a noise sigma outside `[0, 50]`.
    pub fn plan(&self, seed: u64) -> Result<Vec<FramePlan>> {
        self.validate()?;
        Ok(plan::plan(self.stress, self.frames, seed))
    }

    /// The sequence as a frame-by-frame stream under `seed`. The colour and
    /// gray variants of a stress share the seed's layout and texture: the
    /// gray frame is the colour frame converted, then noised.
    ///
    /// # Errors
    /// As [`StressScene::plan`].
    pub fn stream(&self, seed: u64) -> Result<StressStream> {
        let plan = self.plan(seed)?;
        let textures = render::Textures::new(seed, self.stress);
        Ok(StressStream {
            scene: *self,
            seed,
            plan,
            textures,
            next: 0,
            hide_target: false,
            rgb: Image::new(WIDTH, HEIGHT, 3, 0u8)?,
        })
    }
}

/// The default set: every stress, colour then gray, in [`Stress::ALL`]
/// order, with `frames` frames each (`None`: [`DEFAULT_FRAMES`]).
pub fn default_set(frames: Option<usize>) -> Vec<StressScene> {
    let mut set = Vec::new();
    for colour in [true, false] {
        for s in Stress::ALL {
            set.push(StressScene {
                frames: frames.unwrap_or(DEFAULT_FRAMES),
                ..StressScene::new(s, colour)
            });
        }
    }
    set
}

/// A stress sequence being rendered frame by frame.
#[derive(Debug, Clone)]
pub struct StressStream {
    scene: StressScene,
    seed: u64,
    plan: Vec<FramePlan>,
    textures: render::Textures,
    next: usize,
    /// Render without the target (tests: what the target changes).
    hide_target: bool,
    /// The colour frame before the gray conversion.
    rgb: Image<u8>,
}

/// Key of the stress scenes' random streams.
const KEY: u64 = crate::scenes::name_key("stress");

impl StressStream {
    /// The layout of every frame.
    pub fn plan(&self) -> &[FramePlan] {
        &self.plan
    }

    fn truth(&self, k: usize) -> FrameTruth {
        let p = &self.plan[k];
        let t = p.target;
        let mut objects = vec![ObjectTruth {
            id: 0,
            label: "target",
            bbox: otb_box(t[0], t[1], t[2] - t[0], t[3] - t[1]),
            visible_fraction: p.visible_fraction,
        }];
        for (i, d) in p.distractors.iter().enumerate() {
            objects.push(ObjectTruth {
                id: i + 1,
                label: "distractor",
                bbox: otb_box(d[0], d[1], d[2] - d[0], d[3] - d[1]),
                visible_fraction: plan::visible_fraction(*d, &p.occluders),
            });
        }
        FrameTruth {
            index: k,
            time: k as f64 / FPS,
            objects,
            gain: p.gain,
            bounce: false,
            affine: None,
        }
    }
}

impl SceneStream for StressStream {
    fn info(&self) -> SceneInfo {
        self.scene.info()
    }

    fn skip_frame(&mut self) -> Option<FrameTruth> {
        let k = self.next;
        if k >= self.plan.len() {
            return None;
        }
        self.next += 1;
        Some(self.truth(k))
    }

    fn next_into(&mut self, frame: &mut Image<u8>) -> Option<FrameTruth> {
        let k = self.next;
        if k >= self.plan.len() {
            return None;
        }
        self.next += 1;
        let channels = if self.scene.colour { 3 } else { 1 };
        if (frame.width(), frame.height(), frame.channels()) != (WIDTH, HEIGHT, channels) {
            *frame = Image::new(WIDTH, HEIGHT, channels, 0u8).ok()?;
        }
        let p = &self.plan[k];
        if self.scene.colour {
            render::render(&self.textures, p, self.hide_target, frame);
        } else {
            render::render(&self.textures, p, self.hide_target, &mut self.rgb);
            rgb_to_gray_into(self.rgb.view(), &mut frame.view_mut()).ok()?;
        }
        let mut rng = scene_rng(self.seed, KEY, streams::NOISE, k as u64);
        add_noise(frame.as_mut_slice(), self.scene.noise_sigma, &mut rng);
        Some(self.truth(k))
    }
}
