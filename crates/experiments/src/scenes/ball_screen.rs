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
//!
//! # Webcam effects
//! The paper filmed a screen with a 200x160 webcam; five effects of such a
//! camera are modelled, each off in `Default` (the clean scene) and set by
//! the `ball` experiment's options:
//! - [`BallScene::exposure`]: motion blur. The shutter is open for this
//!   fraction of the frame interval, centred on the capture time; the ball
//!   is rendered as the mean of its coverage along that stretch of its path
//!   (one sample per pixel of travel), and the ground truth is the centre of
//!   the stretch.
//! - [`BallScene::flicker`]: the light (screen refresh and room light beating
//!   against the camera's rate) scales each frame by an i.i.d. factor
//!   `1 + flicker z`, `z ~ N(0, 1)` (clamped to `[0.5, 1.5]`).
//! - [`BallScene::auto_exposure`]: the camera's auto-exposure, a gain `e`
//!   that meters the previous frame and moves towards cancelling its light
//!   with time constant `tau` s: `e_k = e_{k-1} + a (1 / g_{k-1} - e_{k-1})`,
//!   `a = 1 - exp(-1 / (tau fps))`, `g` the light (drift times flicker); the
//!   frame is rendered at `g_k e_k`. It removes slow drift and lags behind
//!   fast changes.
//! - [`BallScene::frame_jitter`]: frame `k` is captured at `k / fps + d`,
//!   `d ~ N(0, jitter)` (clamped to half a frame interval): the ball is
//!   rendered, and its ground truth taken, where it is at that instant
//!   (its position moved by velocity times `d`).
//! - [`BallScene::jpeg_quality`]: every frame goes through a JPEG encoder
//!   and decoder at this quality (the `image` crate's baseline encoder,
//!   4:2:0 chroma), as a webcam streaming MJPEG delivers it.

use bayestrack_image::{Image, Rgb};
use image::ImageEncoder;
use image::codecs::jpeg::{JpegDecoder, JpegEncoder};
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
/// Stream ids of the webcam effects (beyond [`streams`]' shared ids, so the
/// clean scene's streams are unchanged).
const FLICKER: u64 = 101;
const JITTER: u64 = 102;

/// How the ball moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
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
    /// Motion blur: fraction of the frame interval the shutter is open, in
    /// `[0, 1]` (0: instantaneous).
    pub exposure: f64,
    /// Relative standard deviation of the per-frame light factor, in
    /// `[0, 0.5]` (0: no flicker).
    pub flicker: f64,
    /// Auto-exposure time constant in seconds (0: no auto-exposure).
    pub auto_exposure: f64,
    /// Standard deviation of the capture-time jitter in milliseconds
    /// (0: frames exactly `1 / fps` apart).
    pub frame_jitter: f64,
    /// JPEG quality `1..=100` each frame is compressed at (0: none).
    pub jpeg_quality: u8,
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
            exposure: 0.0,
            flicker: 0.0,
            auto_exposure: 0.0,
            frame_jitter: 0.0,
            jpeg_quality: 0,
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
        check_range(NAME, "exposure", self.exposure, 0.0, 1.0)?;
        check_range(NAME, "flicker", self.flicker, 0.0, 0.5)?;
        check_range(NAME, "auto_exposure", self.auto_exposure, 0.0, 1e6)?;
        check_range(NAME, "frame_jitter", self.frame_jitter, 0.0, 1e3)?;
        if self.jpeg_quality > 100 {
            return Err(super::SceneError::InvalidParameter {
                scene: NAME,
                name: "jpeg_quality",
                reason: format!("{} is not in 0..=100", self.jpeg_quality),
            });
        }
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
        let mut jpeg = Vec::new();
        if self.jpeg_quality > 0 {
            // Round-trip a blank frame once, so that a codec that cannot
            // handle this size is an error here and not a silent raw frame.
            let mut probe = blank.clone();
            jpeg_round_trip(&mut probe, self.jpeg_quality, &mut jpeg).map_err(|reason| {
                super::SceneError::InvalidParameter {
                    scene: NAME,
                    name: "jpeg_quality",
                    reason,
                }
            })?;
        }
        Ok(BallStream {
            params: self.clone(),
            seed,
            motion,
            next: 0,
            pos: [x, y],
            vel: [vx, vy],
            shown: [x, y],
            exposure_gain: 1.0,
            light: 1.0,
            blank,
            jpeg,
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
    /// Where the camera sees the ball in the current frame (`pos` moved to
    /// the jittered capture time).
    shown: [f64; 2],
    /// Auto-exposure gain `e` of the current frame.
    exposure_gain: f64,
    /// Light `g` (drift times flicker) of the current frame.
    light: f64,
    blank: Image<u8>,
    /// Scratch buffer of the JPEG codec.
    jpeg: Vec<u8>,
}

/// Compresses `frame` (RGB, packed rows) to JPEG at `quality` and decodes it
/// back in place.
fn jpeg_round_trip(frame: &mut Image<u8>, quality: u8, buf: &mut Vec<u8>) -> Result<(), String> {
    let (w, h) = (frame.width(), frame.height());
    let (w32, h32) = (
        u32::try_from(w).map_err(|e| e.to_string())?,
        u32::try_from(h).map_err(|e| e.to_string())?,
    );
    buf.clear();
    JpegEncoder::new_with_quality(&mut *buf, quality)
        .write_image(frame.as_slice(), w32, h32, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("JPEG encoding failed: {e}"))?;
    let decoder = JpegDecoder::new(std::io::Cursor::new(&buf[..]))
        .map_err(|e| format!("JPEG decoding failed: {e}"))?;
    let out = frame.as_mut_slice();
    if image::ImageDecoder::total_bytes(&decoder) != out.len() as u64 {
        return Err(format!(
            "JPEG decoder returned another size than {w}x{h} RGB"
        ));
    }
    image::ImageDecoder::read_image(decoder, out).map_err(|e| format!("JPEG decoding failed: {e}"))
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

    /// The illumination drift's gain at frame `index`.
    fn drift(&self, index: usize) -> f64 {
        let p = &self.params;
        let t = index as f64 / p.fps;
        1.0 - p.illumination_drift
            * 0.5
            * (1.0 - (std::f64::consts::TAU * t / p.drift_period).cos())
    }

    /// Light and auto-exposure of frame `index` (after those of `index - 1`).
    fn expose(&mut self, index: usize) {
        let p = &self.params;
        let flicker = if p.flicker > 0.0 {
            let mut rng = scene_rng(self.seed, KEY, FLICKER, index as u64);
            let z: f64 = StandardNormal.sample(&mut rng);
            (1.0 + p.flicker * z).clamp(0.5, 1.5)
        } else {
            1.0
        };
        if p.auto_exposure > 0.0 && index > 0 {
            // Meter the previous frame's light, move a towards cancelling it.
            let a = 1.0 - (-1.0 / (p.auto_exposure * p.fps)).exp();
            self.exposure_gain += a * (1.0 / self.light - self.exposure_gain);
        }
        self.light = self.drift(index) * flicker;
    }

    /// Where the camera sees the ball: `pos` moved to the jittered capture
    /// time of frame `index`.
    fn capture(&mut self, index: usize) {
        let p = &self.params;
        self.shown = self.pos;
        if p.frame_jitter <= 0.0 {
            return;
        }
        let mut rng = scene_rng(self.seed, KEY, JITTER, index as u64);
        let z: f64 = StandardNormal.sample(&mut rng);
        // Offset in frame intervals, at most half a frame either way.
        let d = (z * p.frame_jitter * 1e-3 * p.fps).clamp(-0.5, 0.5);
        let g = if p.motion == BallMotion::Bouncing {
            p.gravity
        } else {
            0.0
        };
        let (lo_x, hi_x, lo_y, hi_y) = p.bounds();
        self.shown = [
            (self.pos[0] + self.vel[0] * d).clamp(lo_x, hi_x),
            (self.pos[1] + self.vel[1] * d + 0.5 * g * d * d).clamp(lo_y, hi_y),
        ];
    }

    fn advance(&mut self) -> Option<FrameTruth> {
        let p = &self.params;
        if self.next >= p.frames {
            return None;
        }
        let index = self.next;
        let bounce = index > 0 && self.step();
        self.expose(index);
        self.capture(index);
        self.next += 1;
        let r = self.params.radius;
        Some(FrameTruth {
            index,
            time: index as f64 / self.params.fps,
            objects: vec![ObjectTruth {
                id: 0,
                label: "ball",
                bbox: otb_box(self.shown[0] - r, self.shown[1] - r, 2.0 * r, 2.0 * r),
                visible_fraction: 1.0,
            }],
            gain: self.light * self.exposure_gain,
            bounce,
            affine: None,
        })
    }

    fn render(&mut self, index: usize, gain: f64, out: &mut Image<u8>) {
        let p = &self.params;
        let bg = p.screen_color.to_array().map(|c| f64::from(c) * gain);
        let fg = p.ball_color.to_array().map(|c| f64::from(c) * gain);
        let bg8 = bg.map(super::render::to_u8);
        for px in out.as_mut_slice().chunks_exact_mut(3) {
            px.copy_from_slice(&bg8);
        }
        let r = p.radius;
        let [cx, cy] = self.shown;
        // Motion blur: the path during the exposure, centred on the capture.
        let half = [
            0.5 * p.exposure * self.vel[0],
            0.5 * p.exposure * self.vel[1],
        ];
        let travel = 2.0 * half[0].hypot(half[1]);
        let samples = if travel > 0.0 {
            (travel.ceil() as usize + 1).min(64)
        } else {
            1
        };
        let offset = |j: usize| {
            if samples == 1 {
                0.0
            } else {
                2.0 * j as f64 / (samples - 1) as f64 - 1.0
            }
        };
        let (bx, by) = (half[0].abs(), half[1].abs());
        let stride = out.stride();
        let buf = out.as_mut_slice();
        for y in clipped_span(cy - r - by, cy + r + by, p.height) {
            for x in clipped_span(cx - r - bx, cx + r + bx, p.width) {
                let c = (0..samples)
                    .map(|j| {
                        let u = offset(j);
                        ellipse_cov(
                            x as f64 - cx - u * half[0],
                            y as f64 - cy - u * half[1],
                            r,
                            r,
                        )
                    })
                    .sum::<f64>()
                    / samples as f64;
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
        if p.jpeg_quality > 0 {
            // The size was checked by the round trip in `stream`, and the
            // encoder writes into a `Vec`: with the same size it has no way
            // left to fail (a failure would leave the raw frame).
            let _ = jpeg_round_trip(out, p.jpeg_quality, &mut self.jpeg);
        }
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
