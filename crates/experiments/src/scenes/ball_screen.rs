//! Paper 001's screen: a black ball on white at 22 fps (sec. 3).
//!
//! The paper's camera (200x160, 22 fps) watched a computer screen on which a
//! ball moved "linearly" or with "bouncing dynamics, meaning that the movement
//! was always nonlinear" (footnote 4), with optional additive motion noise,
//! under changing room illumination. Our reading:
//! - [`BallMotion::Linear`]: constant speed in a straight line, reflected
//!   elastically at the edges of the screen (piecewise linear);
//! - [`BallMotion::Bouncing`]: a ball under gravity bouncing elastically on
//!   the floor and the walls (parabolic arcs: never linear);
//! - motion noise: each frame the velocity receives an i.i.d. Gaussian kick
//!   of `motion_noise` px/frame per axis (for linear motion the speed is then
//!   restored, so only the heading wanders);
//! - illumination drift: a global gain `1 - drift (1 - cos(2 pi t / T)) / 2`;
//! - sensor noise: i.i.d. Gaussian per pixel and channel.
//!
//! The ball's radius and speed are not in the paper; the defaults (10 px,
//! 3 px/frame) are ours.

use bayestrack_image::{Image, Rgb};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

use super::render::{add_noise, clipped_span, ellipse_cov};
use super::{
    FrameTruth, ObjectTruth, Result, SceneInfo, SceneStream, check_geometry, check_range, name_key,
    otb_box, scene_rng, streams,
};

const NAME: &str = "ball";
const KEY: u64 = name_key(NAME);

/// How the ball moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BallMotion {
    /// Straight lines at constant speed, reflected at the screen edges.
    #[default]
    Linear,
    /// Under gravity, bouncing on the floor and walls (always non-linear).
    Bouncing,
}

/// Parameters of the ball scene. `Default` is paper 001's setting: a
/// 200x160 RGB camera at 22 fps watching for 10 minutes (13,200 frames).
#[derive(Debug, Clone, PartialEq)]
pub struct BallScene {
    /// Frame width (200).
    pub width: usize,
    /// Frame height (160).
    pub height: usize,
    /// Frames per second (22).
    pub fps: f64,
    /// Number of frames (13,200 = 10 minutes at 22 fps).
    pub frames: usize,
    /// Ball radius in pixels (10).
    pub radius: f64,
    /// Linear or bouncing motion.
    pub motion: BallMotion,
    /// Speed in px/frame (3): the constant speed of linear motion, the
    /// horizontal speed of bouncing motion.
    pub speed: f64,
    /// Gravity of bouncing motion in px/frame^2 (0.25).
    pub gravity: f64,
    /// Standard deviation of the per-frame velocity kick, px/frame per
    /// axis (0: no motion noise).
    pub motion_noise: f64,
    /// Relative depth of the illumination drift, in `[0, 1)` (0.15).
    pub illumination_drift: f64,
    /// Period of the illumination drift in seconds (60).
    pub drift_period: f64,
    /// Standard deviation of the sensor noise in grey levels (3).
    pub sensor_noise: f64,
    /// Ball colour under nominal light.
    pub ball_color: Rgb,
    /// Screen colour under nominal light.
    pub screen_color: Rgb,
}

impl Default for BallScene {
    fn default() -> Self {
        Self {
            width: 200,
            height: 160,
            fps: 22.0,
            frames: 22 * 600,
            radius: 10.0,
            motion: BallMotion::Linear,
            speed: 3.0,
            gravity: 0.25,
            motion_noise: 0.0,
            illumination_drift: 0.15,
            drift_period: 60.0,
            sensor_noise: 3.0,
            ball_color: Rgb::new(20, 20, 24),
            screen_color: Rgb::new(245, 245, 240),
        }
    }
}

impl BallScene {
    /// The bouncing variant of the default scene.
    pub fn bouncing() -> Self {
        Self {
            motion: BallMotion::Bouncing,
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<()> {
        check_geometry(NAME, self.width, self.height, self.fps, self.frames)?;
        let half = self.width.min(self.height) as f64 / 2.0;
        check_range(NAME, "radius", self.radius, 0.5, half - 1.0)?;
        check_range(NAME, "speed", self.speed, 0.0, 4.0 * self.radius)?;
        check_range(NAME, "gravity", self.gravity, 0.0, self.radius)?;
        check_range(NAME, "motion_noise", self.motion_noise, 0.0, self.radius)?;
        check_range(
            NAME,
            "illumination_drift",
            self.illumination_drift,
            0.0,
            0.99,
        )?;
        check_range(NAME, "drift_period", self.drift_period, 1e-3, 1e9)?;
        check_range(NAME, "sensor_noise", self.sensor_noise, 0.0, 255.0)?;
        Ok(())
    }

    /// Size, rate and length.
    pub fn info(&self) -> SceneInfo {
        SceneInfo {
            name: NAME,
            width: self.width,
            height: self.height,
            channels: 3,
            fps: self.fps,
            frames: self.frames,
        }
    }

    /// A frame-by-frame stream for `seed`.
    ///
    /// # Errors
    /// [`super::SceneError::InvalidParameter`] for a parameter out of range
    /// (zero size, a ball that does not fit, negative noise, ...).
    pub fn stream(&self, seed: u64) -> Result<BallStream> {
        self.validate()?;
        let mut motion = scene_rng(seed, KEY, streams::MOTION, 0);
        let (lo_x, hi_x, lo_y, hi_y) = self.bounds();
        let x = motion.random_range(lo_x..=hi_x);
        let (y, vx, vy) = match self.motion {
            BallMotion::Linear => {
                let y = motion.random_range(lo_y..=hi_y);
                // Keep away from the axes so the ball visits the whole screen.
                let quarter = std::f64::consts::FRAC_PI_2;
                let a = motion.random_range(0.2..quarter - 0.2)
                    + quarter * f64::from(motion.random_range(0..4u8));
                (y, self.speed * a.cos(), self.speed * a.sin())
            }
            BallMotion::Bouncing => {
                // Drop from the upper half with a horizontal speed.
                let y = motion.random_range(lo_y..=lo_y + 0.5 * (hi_y - lo_y));
                let dir = if motion.random_bool(0.5) { 1.0 } else { -1.0 };
                (y, dir * self.speed, 0.0)
            }
        };
        let blank = Image::new(self.width, self.height, 3, 0u8)?;
        Ok(BallStream {
            params: self.clone(),
            seed,
            motion,
            next: 0,
            pos: [x, y],
            vel: [vx, vy],
            blank,
        })
    }

    /// Renders the whole scene in memory (13,200 RGB frames of 96 kB for the
    /// default: prefer [`BallScene::stream`] for long runs).
    ///
    /// # Errors
    /// As [`BallScene::stream`].
    pub fn generate(&self, seed: u64) -> Result<super::Scene> {
        Ok(super::Scene::collect(&mut self.stream(seed)?))
    }

    /// Range of the ball centre: `[lo_x, hi_x] x [lo_y, hi_y]`.
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let r = self.radius;
        (
            r - 0.5,
            self.width as f64 - 0.5 - r,
            r - 0.5,
            self.height as f64 - 0.5 - r,
        )
    }
}

/// The ball scene frame by frame (see [`BallScene::stream`]).
#[derive(Debug, Clone)]
pub struct BallStream {
    params: BallScene,
    seed: u64,
    motion: Xoshiro256PlusPlus,
    next: usize,
    pos: [f64; 2],
    vel: [f64; 2],
    blank: Image<u8>,
}

impl BallStream {
    /// Moves the ball from frame `next - 1` to frame `next`; returns whether
    /// it bounced.
    fn step(&mut self) -> bool {
        let p = &self.params;
        if p.motion_noise > 0.0 {
            for v in &mut self.vel {
                let z: f64 = StandardNormal.sample(&mut self.motion);
                *v += p.motion_noise * z;
            }
            if p.motion == BallMotion::Linear {
                let s = self.vel[0].hypot(self.vel[1]);
                if s > 1e-12 {
                    self.vel = [self.vel[0] * p.speed / s, self.vel[1] * p.speed / s];
                }
            } else {
                // Keep the energy bounded: no faster than a fall from the top.
                let cap = p.speed + (2.0 * p.gravity * p.height as f64).sqrt() + p.radius;
                let s = self.vel[0].hypot(self.vel[1]);
                if s > cap {
                    self.vel = [self.vel[0] * cap / s, self.vel[1] * cap / s];
                }
            }
        }
        if p.motion == BallMotion::Bouncing {
            self.vel[1] += p.gravity;
        }
        let (lo_x, hi_x, lo_y, hi_y) = p.bounds();
        let mut bounced = false;
        for (axis, (lo, hi)) in [(lo_x, hi_x), (lo_y, hi_y)].into_iter().enumerate() {
            let mut x = self.pos[axis] + self.vel[axis];
            // Reflect (several times if a kick were huge; bounded by validation).
            for _ in 0..4 {
                if x < lo {
                    x = 2.0 * lo - x;
                    self.vel[axis] = self.vel[axis].abs();
                    bounced = true;
                } else if x > hi {
                    x = 2.0 * hi - x;
                    self.vel[axis] = -self.vel[axis].abs();
                    bounced = true;
                } else {
                    break;
                }
            }
            self.pos[axis] = x.clamp(lo, hi);
        }
        bounced
    }

    fn gain(&self, index: usize) -> f64 {
        let p = &self.params;
        let t = index as f64 / p.fps;
        1.0 - p.illumination_drift
            * 0.5
            * (1.0 - (std::f64::consts::TAU * t / p.drift_period).cos())
    }

    fn advance(&mut self) -> Option<FrameTruth> {
        let p = &self.params;
        if self.next >= p.frames {
            return None;
        }
        let index = self.next;
        let bounce = index > 0 && self.step();
        self.next += 1;
        let r = self.params.radius;
        Some(FrameTruth {
            index,
            time: index as f64 / self.params.fps,
            objects: vec![ObjectTruth {
                id: 0,
                label: "ball",
                bbox: otb_box(self.pos[0] - r, self.pos[1] - r, 2.0 * r, 2.0 * r),
                visible_fraction: 1.0,
            }],
            gain: self.gain(index),
            bounce,
            affine: None,
        })
    }

    fn render(&self, index: usize, gain: f64, out: &mut Image<u8>) {
        let p = &self.params;
        let bg = p.screen_color.to_array().map(|c| f64::from(c) * gain);
        let fg = p.ball_color.to_array().map(|c| f64::from(c) * gain);
        let bg8 = bg.map(super::render::to_u8);
        for px in out.as_mut_slice().chunks_exact_mut(3) {
            px.copy_from_slice(&bg8);
        }
        let r = p.radius;
        let [cx, cy] = self.pos;
        let stride = out.stride();
        let buf = out.as_mut_slice();
        for y in clipped_span(cy - r, cy + r, p.height) {
            for x in clipped_span(cx - r, cx + r, p.width) {
                let c = ellipse_cov(x as f64 - cx, y as f64 - cy, r, r);
                if c > 0.0 {
                    let o = y * stride + 3 * x;
                    for k in 0..3 {
                        buf[o + k] = super::render::to_u8(super::render::blend(bg[k], fg[k], c));
                    }
                }
            }
        }
        let mut noise = scene_rng(self.seed, KEY, streams::NOISE, index as u64);
        add_noise(buf, p.sensor_noise, &mut noise);
    }
}

impl SceneStream for BallStream {
    fn info(&self) -> SceneInfo {
        self.params.info()
    }

    fn skip_frame(&mut self) -> Option<FrameTruth> {
        self.advance()
    }

    fn next_into(&mut self, frame: &mut Image<u8>) -> Option<FrameTruth> {
        let truth = self.advance()?;
        if (frame.width(), frame.height(), frame.channels())
            != (self.params.width, self.params.height, 3)
        {
            *frame = self.blank.clone();
        }
        self.render(truth.index, truth.gain, frame);
        Some(truth)
    }
}

impl Iterator for BallStream {
    type Item = super::SceneFrame;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}
