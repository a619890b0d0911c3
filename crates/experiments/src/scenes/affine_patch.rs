//! Paper 002's synthetic affine sequence: a textured face-like patch under a
//! known affine trajectory, with seven feature points (sec. 4, eq. 6).
//!
//! The paper evaluates on real videos ("Cock": abrupt, erratic motion and
//! blur; "Sylvester": illumination and pose change; "Dudek": a face with
//! seven hand-labelled points on the eyes and mouth). We make a sequence
//! whose pose is exact: a 48x56 face-like patch (face ellipse with brows,
//! eyes, nose and mouth, over a textured backdrop) is mapped into a
//! cluttered static background by
//!
//! `M_k = [R(theta_k) diag(s_k, s_k a_k) | c_k]`,
//!
//! with smooth sinusoidal rotation `theta_k`, scale `s_k` and aspect `a_k`,
//! a smooth drift of the centre `c_k` plus abrupt displacements every
//! `jump_every` frames ([`JumpKind`]: a teleport of `jump_size` px in a
//! random direction that the target keeps, or a camera shake that moves
//! the whole view by a random offset of up to `jump_size` px from the
//! smooth path, drawn anew at each shake), motion blur along the
//! displacement on those frames (`jump_blur` px for a `jump_size` move), a
//! global illumination gain, and sensor noise. `M_k` maps template coordinates (origin at the template centre)
//! to 0-based image coordinates, as `bayestrack-affine` poses do. The seven
//! feature points (eye corners, nose tip, mouth corners: [`TEMPLATE_POINTS`])
//! and the centre are mapped through `M_k`.

use bayestrack_image::{Affine2, Image, sample_bilinear};
use rand::RngExt;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::render::{ValueNoise, blend, clipped_span, ellipse_cov, rect_cov, to_u8};
use super::{
    AffineTruth, FrameTruth, ObjectTruth, Result, SceneError, SceneInfo, SceneStream,
    check_geometry, check_range, name_key, otb_box, scene_rng, streams,
};
use bayestrack_otb::metrics::FeaturePoints;

const NAME: &str = "affine";
const KEY: u64 = name_key(NAME);

/// The seven feature points as fractions of the template width and height,
/// relative to the template centre: left eye outer and inner corners, right
/// eye inner and outer corners, nose tip, left and right mouth corners.
pub const TEMPLATE_POINTS: [[f64; 2]; 7] = [
    [-0.29, -0.14],
    [-0.10, -0.14],
    [0.10, -0.14],
    [0.29, -0.14],
    [0.0, 0.07],
    [-0.19, 0.25],
    [0.19, 0.25],
];

/// How the scene's abrupt displacements move the target (paper 002 sec.
/// 3.2 describes "abrupt and erratic motion" and "severe camera vibration"
/// on Cock without saying more; the two readings differ in whether a
/// displacement stays).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JumpKind {
    /// Every `jump_every` frames the target jumps `jump_size` px in a
    /// random direction and stays there (its path is shifted for good).
    #[default]
    Teleport,
    /// Every `jump_every` frames the camera shakes: the view is offset from
    /// the smooth path by a new random offset, uniform in the disc of
    /// radius `jump_size` (so a frame-to-frame move of up to twice that),
    /// and the offset is replaced, not accumulated, at the next shake.
    Shake,
}

/// Parameters of the affine scene. `Default`: 320x240 gray, 30 fps, 120
/// frames, a 48x56 patch, jumps of 30 px every 20 frames with 10 px motion
/// blur, rotation up to 0.6 rad, scale 0.75-1.25, aspect 0.9-1.1,
/// illumination gain 0.65-1.35, sensor noise 2.
#[derive(Debug, Clone, PartialEq)]
pub struct AffineScene {
    /// Frame width (320).
    pub width: usize,
    /// Frame height (240).
    pub height: usize,
    /// Frames per second (30).
    pub fps: f64,
    /// Number of frames (120).
    pub frames: usize,
    /// Template width and height at scale 1 (48, 56).
    pub template_size: [f64; 2],
    /// Amplitude of the smooth drift of the centre, px per axis (50, 30).
    pub drift_amplitude: [f64; 2],
    /// Period of the drift in frames (90).
    pub drift_period: f64,
    /// Frames between abrupt displacements (20); 0 for none.
    pub jump_every: usize,
    /// What a displacement is ([`JumpKind::Teleport`]).
    pub jump_kind: JumpKind,
    /// Length of a jump in pixels (30).
    pub jump_size: f64,
    /// Length in pixels of the motion blur on a frame that moves by
    /// `jump_size` (10; 0: sharp); proportional to the move on a shake.
    pub jump_blur: f64,
    /// Rotation amplitude in radians (0.6).
    pub rotation_amplitude: f64,
    /// Rotation period in frames (100).
    pub rotation_period: f64,
    /// Relative scale amplitude (0.25: scale in 0.75..1.25).
    pub scale_amplitude: f64,
    /// Scale period in frames (70).
    pub scale_period: f64,
    /// Relative aspect amplitude (0.1).
    pub aspect_amplitude: f64,
    /// Aspect period in frames (50).
    pub aspect_period: f64,
    /// Relative illumination amplitude (0.35: gain in 0.65..1.35).
    pub illumination_amplitude: f64,
    /// Illumination period in frames (80).
    pub illumination_period: f64,
    /// Standard deviation of the sensor noise in grey levels (2).
    pub sensor_noise: f64,
}

impl Default for AffineScene {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            fps: 30.0,
            frames: 120,
            template_size: [48.0, 56.0],
            drift_amplitude: [50.0, 30.0],
            drift_period: 90.0,
            jump_every: 20,
            jump_kind: JumpKind::Teleport,
            jump_size: 30.0,
            jump_blur: 10.0,
            rotation_amplitude: 0.6,
            rotation_period: 100.0,
            scale_amplitude: 0.25,
            scale_period: 70.0,
            aspect_amplitude: 0.1,
            aspect_period: 50.0,
            illumination_amplitude: 0.35,
            illumination_period: 80.0,
            sensor_noise: 2.0,
        }
    }
}

impl AffineScene {
    /// The seven feature points in template coordinates (pixels from the
    /// template centre).
    pub fn template_points(&self) -> [[f64; 2]; 7] {
        let [w, h] = self.template_size;
        TEMPLATE_POINTS.map(|[u, v]| [u * w, v * h])
    }

    /// Half the side of the square the centre must stay out of the border:
    /// the largest template half-diagonal at the largest scale and aspect.
    fn margin(&self) -> f64 {
        let [w, h] = self.template_size;
        0.5 * w.hypot(h) * (1.0 + self.scale_amplitude) * (1.0 + self.aspect_amplitude) + 2.0
    }

    fn validate(&self) -> Result<()> {
        check_geometry(NAME, self.width, self.height, self.fps, self.frames)?;
        let [w, h] = self.template_size;
        check_range(NAME, "template width", w, 8.0, 1024.0)?;
        check_range(NAME, "template height", h, 8.0, 1024.0)?;
        check_range(NAME, "scale_amplitude", self.scale_amplitude, 0.0, 0.9)?;
        check_range(NAME, "aspect_amplitude", self.aspect_amplitude, 0.0, 0.9)?;
        let m = self.margin();
        if 2.0 * m >= self.width.min(self.height) as f64 {
            return Err(SceneError::InvalidParameter {
                scene: NAME,
                name: "template_size",
                reason: format!(
                    "a {w}x{h} template at scale {} does not fit a {}x{} frame",
                    1.0 + self.scale_amplitude,
                    self.width,
                    self.height
                ),
            });
        }
        let big = 1e6;
        for v in self.drift_amplitude {
            check_range(NAME, "drift_amplitude", v, 0.0, big)?;
        }
        check_range(NAME, "jump_size", self.jump_size, 0.0, big)?;
        check_range(NAME, "jump_blur", self.jump_blur, 0.0, 64.0)?;
        check_range(
            NAME,
            "rotation_amplitude",
            self.rotation_amplitude,
            0.0,
            10.0,
        )?;
        check_range(
            NAME,
            "illumination_amplitude",
            self.illumination_amplitude,
            0.0,
            0.95,
        )?;
        for (name, p) in [
            ("drift_period", self.drift_period),
            ("rotation_period", self.rotation_period),
            ("scale_period", self.scale_period),
            ("aspect_period", self.aspect_period),
            ("illumination_period", self.illumination_period),
        ] {
            check_range(NAME, name, p, 1.0, 1e9)?;
        }
        check_range(NAME, "sensor_noise", self.sensor_noise, 0.0, 255.0)
    }

    /// Size, rate and length.
    pub fn info(&self) -> SceneInfo {
        SceneInfo {
            name: NAME,
            width: self.width,
            height: self.height,
            channels: 1,
            fps: self.fps,
            frames: self.frames,
        }
    }

    /// A frame-by-frame stream for `seed`.
    ///
    /// # Errors
    /// [`SceneError::InvalidParameter`] for a parameter out of range (a
    /// template that does not fit the frame, non-positive periods, ...).
    pub fn stream(&self, seed: u64) -> Result<AffineStream> {
        self.validate()?;
        let mut layout = scene_rng(seed, KEY, streams::LAYOUT, 0);
        let mut motion = scene_rng(seed, KEY, streams::MOTION, 0);
        let background = self.render_background(&mut layout)?;
        let [tw, th] = self.template_size;
        let texture = ValueNoise::new(tw, th, 4.0, &mut layout);
        let tau = std::f64::consts::TAU;
        let phases = [(); 6].map(|_| motion.random_range(0.0..tau));
        let n = self.width * self.height;
        Ok(AffineStream {
            params: self.clone(),
            seed,
            motion,
            next: 0,
            phases,
            jumps: [0.0, 0.0],
            background,
            texture,
            sharp: vec![0.0; n],
            blurred: Image::new(self.width, self.height, 1, 0f32)?,
        })
    }

    /// Renders the whole scene in memory.
    ///
    /// # Errors
    /// As [`AffineScene::stream`].
    pub fn generate(&self, seed: u64) -> Result<super::Scene> {
        Ok(super::Scene::collect(&mut self.stream(seed)?))
    }

    fn render_background(&self, layout: &mut Xoshiro256PlusPlus) -> Result<Image<f32>> {
        let (w, h) = (self.width as f64, self.height as f64);
        let coarse = ValueNoise::new(w, h, 16.0, layout);
        let fine = ValueNoise::new(w, h, 3.0, layout);
        let rects: Vec<([f64; 4], f64)> = (0..16)
            .map(|_| {
                let (rw, rh) = (
                    layout.random_range(8.0..50.0),
                    layout.random_range(8.0..50.0),
                );
                let (x, y) = (layout.random_range(-10.0..w), layout.random_range(-10.0..h));
                ([x, y, x + rw, y + rh], layout.random_range(40.0..220.0))
            })
            .collect();
        Ok(Image::from_fn(self.width, self.height, |x, y| {
            let (fx, fy) = (x as f64, y as f64);
            let mut v = 128.0 + 30.0 * coarse.at(fx, fy);
            for (r, g) in &rects {
                v = blend(v, *g, rect_cov(fx, fy, r[0], r[1], r[2], r[3]));
            }
            (v + 8.0 * fine.at(fx, fy)) as f32
        })?)
    }
}

/// Grey level of the face-like template at normalised template coordinates
/// `(p, q)` (fractions of width and height from the centre), with texture
/// `t` in `[-1, 1]`.
fn face(p: f64, q: f64, t: f64) -> f64 {
    let rho2 = (p / 0.42).powi(2) + (q / 0.47).powi(2);
    if rho2 > 1.0 {
        return 60.0 + 25.0 * t;
    }
    let mut v = 175.0 + 10.0 * t - 25.0 * rho2;
    let (p100, q100) = (p * 100.0, q * 100.0);
    // Brows (units of 1/100 template size).
    let brow = rect_cov(p100, q100, 9.0, -24.5, 31.0, -21.5)
        .max(rect_cov(-p100, q100, 9.0, -24.5, 31.0, -21.5));
    v = blend(v, 70.0, brow);
    // Eyes with pupils: corners at p = +-0.10 and +-0.29, q = -0.14.
    for cx in [-19.5, 19.5] {
        v = blend(v, 45.0, ellipse_cov(p100 - cx, q100 + 14.0, 9.5, 3.5));
        v = blend(v, 15.0, ellipse_cov(p100 - cx, q100 + 14.0, 2.5, 2.5));
    }
    // Nose ridge and tip (0, 0.07).
    v = blend(v, 150.0, rect_cov(p100, q100, -2.0, -8.0, 2.0, 5.0));
    v = blend(v, 105.0, ellipse_cov(p100, q100 - 7.0, 4.0, 2.0));
    // Mouth: corners at p = +-0.19, q = 0.25.
    v = blend(v, 85.0, ellipse_cov(p100, q100 - 25.0, 19.0, 3.0));
    v
}

/// The affine scene frame by frame (see [`AffineScene::stream`]).
#[derive(Debug, Clone)]
pub struct AffineStream {
    params: AffineScene,
    seed: u64,
    motion: Xoshiro256PlusPlus,
    next: usize,
    /// Phases of drift x, drift y, rotation, scale, aspect, illumination.
    phases: [f64; 6],
    /// Sum of the jumps so far.
    jumps: [f64; 2],
    background: Image<f32>,
    texture: ValueNoise,
    sharp: Vec<f32>,
    blurred: Image<f32>,
}

impl AffineStream {
    fn wave(&self, i: usize, k: usize, period: f64) -> f64 {
        (std::f64::consts::TAU * k as f64 / period + self.phases[i]).sin()
    }

    /// Advances the motion: returns the pose, the blur length when the
    /// frame is displaced (`None` otherwise), the direction of the
    /// displacement, and the illumination gain.
    fn pose(&mut self, k: usize) -> (Affine2, Option<f64>, [f64; 2], f64) {
        let p = self.params.clone();
        let (w, h) = (p.width as f64, p.height as f64);
        let m = p.margin();
        let base = |s: &Self| {
            [
                w / 2.0 + p.drift_amplitude[0] * s.wave(0, k, p.drift_period) + s.jumps[0],
                h / 2.0 + p.drift_amplitude[1] * s.wave(1, k, p.drift_period) + s.jumps[1],
            ]
        };
        let mut jumped = None;
        let mut dir = [0.0, 0.0];
        let due = p.jump_every > 0 && k > 0 && k.is_multiple_of(p.jump_every) && p.jump_size > 0.0;
        if due && p.jump_kind == JumpKind::Teleport {
            let a = self.motion.random_range(0.0..std::f64::consts::TAU);
            let mut d = [p.jump_size * a.cos(), p.jump_size * a.sin()];
            let c = base(self);
            for (axis, lim) in [(0, w), (1, h)] {
                let t = c[axis] + d[axis];
                if t < m || t > lim - 1.0 - m {
                    d[axis] = -d[axis];
                }
            }
            self.jumps = [self.jumps[0] + d[0], self.jumps[1] + d[1]];
            jumped = Some(p.jump_blur);
            dir = [d[0] / p.jump_size, d[1] / p.jump_size];
        } else if due {
            // A shake: a new offset, uniform in the disc, replacing the old.
            let a = self.motion.random_range(0.0..std::f64::consts::TAU);
            let r = p.jump_size * self.motion.random_range(0.0..1.0f64).sqrt();
            let o = [r * a.cos(), r * a.sin()];
            let d = [o[0] - self.jumps[0], o[1] - self.jumps[1]];
            self.jumps = o;
            let len = d[0].hypot(d[1]);
            jumped = Some(p.jump_blur * len / p.jump_size);
            if len > 0.0 {
                dir = [d[0] / len, d[1] / len];
            }
        }
        let c = base(self);
        let cx = c[0].clamp(m, w - 1.0 - m);
        let cy = c[1].clamp(m, h - 1.0 - m);
        let theta = p.rotation_amplitude * self.wave(2, k, p.rotation_period);
        let s = 1.0 + p.scale_amplitude * self.wave(3, k, p.scale_period);
        let asp = 1.0 + p.aspect_amplitude * self.wave(4, k, p.aspect_period);
        let gain = 1.0 + p.illumination_amplitude * self.wave(5, k, p.illumination_period);
        let (sn, cs) = theta.sin_cos();
        let (sx, sy) = (s, s * asp);
        // R(theta) diag(sx, sy).
        let pose = Affine2::from_rows([[cs * sx, -sn * sy, cx], [sn * sx, cs * sy, cy]])
            .unwrap_or(Affine2::translation(cx, cy));
        (pose, jumped, dir, gain)
    }

    fn truth(&self, k: usize, pose: &Affine2, jumped: Option<f64>, gain: f64) -> FrameTruth {
        let p = &self.params;
        let [tw, th] = p.template_size;
        let corners = [
            [-tw / 2.0, -th / 2.0],
            [tw / 2.0, -th / 2.0],
            [tw / 2.0, th / 2.0],
            [-tw / 2.0, th / 2.0],
        ];
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for [u, v] in corners {
            let (x, y) = pose.apply(u, v);
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        let points = p.template_points().map(|[u, v]| {
            let (x, y) = pose.apply(u, v);
            [x, y]
        });
        let (cx, cy) = pose.apply(0.0, 0.0);
        FrameTruth {
            index: k,
            time: k as f64 / p.fps,
            objects: vec![ObjectTruth {
                id: 0,
                label: "patch",
                bbox: otb_box(lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]),
                visible_fraction: 1.0,
            }],
            gain,
            bounce: false,
            affine: Some(AffineTruth {
                matrix: pose.to_matrix3(),
                template_size: p.template_size,
                points: FeaturePoints {
                    points,
                    center: [cx, cy],
                },
                jump: jumped.is_some(),
                blur: jumped.unwrap_or(0.0),
            }),
        }
    }

    fn advance(&mut self) -> Option<(FrameTruth, Affine2, [f64; 2])> {
        if self.next >= self.params.frames {
            return None;
        }
        let k = self.next;
        self.next += 1;
        let (pose, jumped, dir, gain) = self.pose(k);
        Some((self.truth(k, &pose, jumped, gain), pose, dir))
    }

    fn render(&mut self, truth: &FrameTruth, pose: &Affine2, dir: [f64; 2], out: &mut Image<u8>) {
        let p = &self.params;
        let (w, h) = (p.width, p.height);
        let [tw, th] = p.template_size;
        self.sharp.copy_from_slice(self.background.as_slice());
        let inv = pose.inverse().unwrap_or_default();
        let [a, b, _, c, d, _] = pose.as_array();
        // Smaller singular value of the linear part: template px -> image px.
        let (s1, s2) = (a * a + b * b + c * c + d * d, (a * d - b * c).abs());
        let smin = (0.5 * (s1 - (s1 * s1 - 4.0 * s2 * s2).max(0.0).sqrt())).sqrt();
        let bb = truth.objects[0].bbox;
        let (x0, y0) = (bb.x - 1.5, bb.y - 1.5);
        for y in clipped_span(y0, y0 + bb.height, h) {
            for x in clipped_span(x0, x0 + bb.width, w) {
                let (u, v) = inv.apply(x as f64, y as f64);
                let inside = (tw / 2.0 - u.abs()).min(th / 2.0 - v.abs());
                let alpha = (inside * smin + 0.5).clamp(0.0, 1.0);
                if alpha <= 0.0 {
                    continue;
                }
                let t = self.texture.at(u + tw / 2.0, v + th / 2.0);
                let g = face(u / tw, v / th, t);
                let o = y * w + x;
                self.sharp[o] = blend(f64::from(self.sharp[o]), g, alpha) as f32;
            }
        }
        let gain = truth.gain as f32;
        let blur = truth.affine.map_or(0.0, |a| a.blur);
        let dst = out.as_mut_slice();
        if blur > 0.0 {
            // Motion blur: mean of samples along the jump direction.
            let n = blur.ceil() as usize + 1;
            self.blurred.as_mut_slice().copy_from_slice(&self.sharp);
            let view = self.blurred.view();
            let (wm, hm) = ((w - 1) as f64, (h - 1) as f64);
            for y in 0..h {
                for x in 0..w {
                    let mut acc = 0.0;
                    for i in 0..n {
                        let s = blur * (i as f64 / (n - 1) as f64 - 0.5);
                        let sx = (x as f64 + s * dir[0]).clamp(0.0, wm);
                        let sy = (y as f64 + s * dir[1]).clamp(0.0, hm);
                        acc += sample_bilinear(view, sx, sy, 0).unwrap_or_default();
                    }
                    dst[y * w + x] = to_u8(f64::from(gain * acc / n as f32));
                }
            }
        } else {
            for (o, v) in dst.iter_mut().zip(&self.sharp) {
                *o = to_u8(f64::from(gain * v));
            }
        }
        let mut noise = scene_rng(self.seed, KEY, streams::NOISE, truth.index as u64);
        super::render::add_noise(dst, p.sensor_noise, &mut noise);
    }
}

impl SceneStream for AffineStream {
    fn info(&self) -> SceneInfo {
        self.params.info()
    }

    fn skip_frame(&mut self) -> Option<FrameTruth> {
        self.advance().map(|(t, _, _)| t)
    }

    fn next_into(&mut self, frame: &mut Image<u8>) -> Option<FrameTruth> {
        let (truth, pose, dir) = self.advance()?;
        if (frame.width(), frame.height(), frame.channels())
            != (self.params.width, self.params.height, 1)
        {
            *frame = self.background.map(|v| v as u8);
        }
        self.render(&truth, &pose, dir, frame);
        Some(truth)
    }
}

impl Iterator for AffineStream {
    type Item = super::SceneFrame;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}
