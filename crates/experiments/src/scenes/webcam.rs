//! Paper 003's webcam: a skin-coloured face or hand moving in clutter.
//!
//! The paper (sec. 3-5) tracks "a human moving in clutter" with a static
//! webcam, using interframe difference (IFD) and HSV skin colour; it
//! re-initialises when a new object enters through the image border stripes
//! (c-AVQ) and tracks two objects that cross with a priority-subtracted IFD.
//! The frame size and rate are not given; ours are 320x240 RGB at 30 fps.
//!
//! The scene holds, back to front: a static low-saturation wall with
//! shelves and a window; static skin-coloured distractors (they defeat the
//! skin cue alone, never move, so IFD ignores them); moving non-skin
//! distractors (saturated blue and green boxes: they defeat IFD alone); the
//! target (object 0, a face or a hand) wandering smoothly; and optionally a
//! second skin object (object 1, in front of the target) that either
//! enters through the left or right border or crosses the target.
//!
//! Skin colour: RGB (224, 172, 138), HSV hue 0.066 turns (24 deg),
//! saturation 0.38; shading scales RGB, which keeps hue and saturation.

use bayestrack_image::{Image, Rgb};
use rand::RngExt;
use rand_xoshiro::Xoshiro256PlusPlus;

use super::render::{
    ValueNoise, add_noise, blend, clipped_span, ellipse_cov, pixel_span, rect_cov, to_u8,
};
use super::{
    FrameTruth, ObjectTruth, Outline, Result, SceneError, SceneInfo, SceneStream, check_geometry,
    check_range, name_key, otb_box, scene_rng, streams,
};

const NAME: &str = "webcam";
const KEY: u64 = name_key(NAME);

/// Skin tone of the face and hand (HSV hue 0.066, saturation 0.38).
pub const SKIN: Rgb = Rgb::new(224, 172, 138);

/// Skin-like colours of the static distractors (wood, a poster).
const SKIN_DISTRACTORS: [Rgb; 2] = [Rgb::new(205, 150, 110), Rgb::new(232, 178, 146)];

/// Saturated non-skin colours of the moving distractors.
const NON_SKIN: [Rgb; 3] = [
    Rgb::new(40, 70, 200),
    Rgb::new(50, 160, 80),
    Rgb::new(120, 60, 170),
];

/// Which skin-coloured object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SkinShape {
    /// An elliptic face (40x52) with darker eyes and mouth.
    #[default]
    Face,
    /// A palm with four fingers and a thumb (31x43).
    Hand,
}

impl SkinShape {
    fn label(self) -> &'static str {
        match self {
            Self::Face => "face",
            Self::Hand => "hand",
        }
    }

    fn other(self) -> Self {
        match self {
            Self::Face => Self::Hand,
            Self::Hand => Self::Face,
        }
    }
}

/// A second skin-coloured object besides the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SecondObject {
    /// The target alone.
    #[default]
    None,
    /// The other shape waits outside the left or right border (side drawn
    /// from the seed), touches the border at frame `frame` and moves in at
    /// 3 px/frame to a resting point a quarter of the width inside.
    Entering {
        /// Frame (0-based) at which it reaches the border.
        frame: usize,
    },
    /// The target moves right and the other shape moves left, 2.5 px/frame
    /// each, 12 px apart vertically; the face centre and the palm centre
    /// share the same x at frame `frame`.
    Crossing {
        /// Frame (0-based) at which the two objects are aligned.
        frame: usize,
    },
}

/// Parameters of the webcam scene. `Default` is paper 003's basic setting:
/// a face moving in clutter (two static skin-coloured and two moving
/// non-skin distractors), 150 frames.
#[derive(Debug, Clone, PartialEq)]
pub struct WebcamScene {
    /// Frame width (320).
    pub width: usize,
    /// Frame height (240).
    pub height: usize,
    /// Frames per second (30).
    pub fps: f64,
    /// Number of frames (150).
    pub frames: usize,
    /// The target's shape.
    pub target: SkinShape,
    /// Scale of the target's wandering frequencies (1: peak speed about
    /// 4 px/frame).
    pub target_speed: f64,
    /// Number of static skin-coloured distractors (2).
    pub static_skin_distractors: usize,
    /// Number of moving non-skin distractors (2).
    pub moving_distractors: usize,
    /// An entering or crossing second object.
    pub second: SecondObject,
    /// Standard deviation of the sensor noise in grey levels (3).
    pub sensor_noise: f64,
    /// Size of the target (object 0) relative to its shape's 40x52 face
    /// or 31x43 hand (1).
    pub target_size: f64,
    /// Amplitude in degrees of the target's in-plane rotation about its
    /// centre, `theta(t) = A sin(omega t + phi)` with a period of 4 s
    /// (x [`WebcamScene::target_speed`]) and a phase drawn from the seed
    /// (0: the target never rotates).
    pub rotation_deg: f64,
    /// Relative amplitude of the target's change of scale,
    /// `s(t) = target_size (1 + A sin(omega t + phi))` with a period of
    /// 5 s and its own phase (0: the size never changes).
    pub scale_change: f64,
}

impl Default for WebcamScene {
    fn default() -> Self {
        Self {
            width: 320,
            height: 240,
            fps: 30.0,
            frames: 150,
            target: SkinShape::Face,
            target_speed: 1.0,
            static_skin_distractors: 2,
            moving_distractors: 2,
            second: SecondObject::None,
            sensor_noise: 3.0,
            target_size: 1.0,
            rotation_deg: 0.0,
            scale_change: 0.0,
        }
    }
}

impl WebcamScene {
    /// A hand entering through the border at frame 30 while the face
    /// wanders (c-AVQ re-initialisation), 120 frames.
    pub fn entering() -> Self {
        Self {
            frames: 120,
            second: SecondObject::Entering { frame: 30 },
            ..Self::default()
        }
    }

    /// A face and a hand crossing at frame 45 (priority IFD), 90 frames.
    pub fn crossing() -> Self {
        Self {
            frames: 90,
            second: SecondObject::Crossing { frame: 45 },
            ..Self::default()
        }
    }

    fn validate(&self) -> Result<()> {
        check_geometry(NAME, self.width, self.height, self.fps, self.frames)?;
        if self.width < 120 || self.height < 100 {
            return Err(SceneError::InvalidParameter {
                scene: NAME,
                name: "size",
                reason: format!(
                    "{}x{} is too small for 40x52 objects (need 120x100)",
                    self.width, self.height
                ),
            });
        }
        check_range(NAME, "target_speed", self.target_speed, 0.0, 10.0)?;
        check_range(
            NAME,
            "static_skin_distractors",
            self.static_skin_distractors as f64,
            0.0,
            16.0,
        )?;
        check_range(
            NAME,
            "moving_distractors",
            self.moving_distractors as f64,
            0.0,
            16.0,
        )?;
        check_range(NAME, "target_size", self.target_size, 0.25, 4.0)?;
        check_range(NAME, "rotation_deg", self.rotation_deg, 0.0, 90.0)?;
        check_range(NAME, "scale_change", self.scale_change, 0.0, 0.5)?;
        check_range(NAME, "sensor_noise", self.sensor_noise, 0.0, 255.0)
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
    /// [`SceneError::InvalidParameter`] for a parameter out of range.
    pub fn stream(&self, seed: u64) -> Result<WebcamStream> {
        self.validate()?;
        let mut layout = scene_rng(seed, KEY, streams::LAYOUT, 0);
        let mut motion = scene_rng(seed, KEY, streams::MOTION, 0);
        let (w, h) = (self.width as f64, self.height as f64);

        let target_path = match self.second {
            SecondObject::Crossing { frame } => Path::Linear {
                start: [w / 2.0 - 2.5 * frame as f64, h / 2.0 + 6.0],
                velocity: [2.5, 0.0],
            },
            _ => Path::wander(
                &mut motion,
                [w / 2.0, h / 2.0],
                [w / 2.0 - 35.0, h / 2.0 - 40.0],
                self.target_speed,
            ),
        };
        // Phases of the target's rotation and scale from their own stream,
        // so that a scene without them draws exactly what it drew before.
        let mut turn = scene_rng(seed, KEY, streams::MOTION, 1);
        let tau = std::f64::consts::TAU;
        let target_pose = Pose {
            size: self.target_size,
            rotation: self.rotation_deg.to_radians(),
            rotation_omega: self.target_speed * tau / 4.0,
            rotation_phase: turn.random_range(0.0..tau),
            scale: self.scale_change,
            scale_omega: self.target_speed * tau / 5.0,
            scale_phase: turn.random_range(0.0..tau),
        };
        let mut people = vec![Person {
            shape: self.target.shape(),
            label: self.target.label(),
            path: target_path,
            pose: target_pose,
        }];
        let other = self.target.other();
        match self.second {
            SecondObject::None => {}
            SecondObject::Crossing { frame } => people.push(Person {
                shape: other.shape(),
                label: other.label(),
                pose: Pose::FIXED,
                path: Path::Linear {
                    start: [w / 2.0 + 2.5 * frame as f64, h / 2.0 - 6.0],
                    velocity: [-2.5, 0.0],
                },
            }),
            SecondObject::Entering { frame } => {
                let shape = other.shape();
                let [ex0, _, ex1, _] = shape.extent;
                let from_left = motion.random_bool(0.5);
                let y = motion.random_range(0.3 * h..=0.7 * h);
                // At `frame` the inner edge touches the border from outside.
                let (border_x, rest_x, dir) = if from_left {
                    (-0.5 - ex1, 0.25 * w, 1.0)
                } else {
                    (w - 0.5 - ex0, 0.75 * w, -1.0)
                };
                people.push(Person {
                    shape,
                    label: other.label(),
                    pose: Pose::FIXED,
                    path: Path::Enter {
                        frame,
                        start: [border_x, y],
                        rest_x,
                        dir,
                        speed: 3.0,
                    },
                });
            }
        }

        // Static skin-coloured distractors, away from the target's start.
        let start = people[0].path.at(0, self.fps);
        let mut statics = Vec::new();
        for i in 0..self.static_skin_distractors {
            let (a, b) = (
                layout.random_range(12.0..24.0),
                layout.random_range(12.0..24.0),
            );
            let mut c = [w / 2.0, h / 2.0];
            for _ in 0..100 {
                c = [layout.random_range(a..w - a), layout.random_range(b..h - b)];
                if (c[0] - start[0]).hypot(c[1] - start[1]) > 70.0 {
                    break;
                }
            }
            statics.push(Blob {
                center: c,
                half: [a, b],
                ellipse: i % 2 == 0,
                color: SKIN_DISTRACTORS[i % SKIN_DISTRACTORS.len()],
            });
        }
        let movers = (0..self.moving_distractors)
            .map(|i| {
                let half = [
                    layout.random_range(12.0..20.0),
                    layout.random_range(15.0..25.0),
                ];
                let center = [
                    layout.random_range(half[0]..w - half[0]),
                    layout.random_range(half[1]..h - half[1]),
                ];
                let speed = layout.random_range(1.5..4.0);
                let angle = layout.random_range(0.0..std::f64::consts::TAU);
                Mover {
                    blob: Blob {
                        center,
                        half,
                        ellipse: false,
                        color: NON_SKIN[i % NON_SKIN.len()],
                    },
                    velocity: [speed * angle.cos(), speed * angle.sin()],
                }
            })
            .collect();
        let background = self.render_background(&mut layout, &statics)?;
        Ok(WebcamStream {
            params: self.clone(),
            seed,
            next: 0,
            people,
            movers,
            background,
        })
    }

    /// Renders the whole scene in memory.
    ///
    /// # Errors
    /// As [`WebcamScene::stream`].
    pub fn generate(&self, seed: u64) -> Result<super::Scene> {
        Ok(super::Scene::collect(&mut self.stream(seed)?))
    }

    fn render_background(
        &self,
        layout: &mut Xoshiro256PlusPlus,
        statics: &[Blob],
    ) -> Result<Image<u8>> {
        let (w, h) = (self.width as f64, self.height as f64);
        let tex = ValueNoise::new(w, h, 12.0, layout);
        // A shelf and a window.
        let shelf = [
            layout.random_range(0.05 * w..0.5 * w),
            layout.random_range(0.55 * h..0.8 * h),
        ];
        let window = [
            layout.random_range(0.55 * w..0.8 * w),
            layout.random_range(0.05 * h..0.2 * h),
        ];
        let mut img = Image::new(self.width, self.height, 3, 0u8)?;
        let stride = img.stride();
        let buf = img.as_mut_slice();
        for y in 0..self.height {
            for x in 0..self.width {
                let (fx, fy) = (x as f64, y as f64);
                let base = 175.0 + 20.0 * (fy / h) + 6.0 * tex.at(fx, fy);
                let mut c = [base, base + 2.0, base + 8.0];
                let s = rect_cov(
                    fx,
                    fy,
                    shelf[0],
                    shelf[1],
                    shelf[0] + 0.4 * w,
                    shelf[1] + 8.0,
                );
                let win = rect_cov(
                    fx,
                    fy,
                    window[0],
                    window[1],
                    window[0] + 0.18 * w,
                    window[1] + 0.3 * h,
                );
                for (k, v) in c.iter_mut().enumerate() {
                    *v = blend(*v, [95.0, 92.0, 90.0][k], s);
                    *v = blend(*v, [238.0, 242.0, 248.0][k], win);
                }
                for b in statics {
                    let a = b.coverage(fx, fy);
                    if a > 0.0 {
                        let col = b.color.to_array();
                        for (k, v) in c.iter_mut().enumerate() {
                            *v = blend(*v, f64::from(col[k]), a);
                        }
                    }
                }
                let o = y * stride + 3 * x;
                for k in 0..3 {
                    buf[o + k] = to_u8(c[k]);
                }
            }
        }
        Ok(img)
    }
}

/// A plain ellipse or rectangle of one colour.
#[derive(Debug, Clone, Copy)]
struct Blob {
    center: [f64; 2],
    half: [f64; 2],
    ellipse: bool,
    color: Rgb,
}

impl Blob {
    fn coverage(&self, x: f64, y: f64) -> f64 {
        let [cx, cy] = self.center;
        let [a, b] = self.half;
        if self.ellipse {
            ellipse_cov(x - cx, y - cy, a, b)
        } else {
            rect_cov(x, y, cx - a, cy - b, cx + a, cy + b)
        }
    }
}

/// A non-skin box bouncing inside the frame.
#[derive(Debug, Clone, Copy)]
struct Mover {
    blob: Blob,
    velocity: [f64; 2],
}

/// Position in `[lo, hi]` of a point moving at constant velocity and
/// reflected at both ends (a triangle wave).
fn reflect(p: f64, lo: f64, hi: f64) -> f64 {
    let span = hi - lo;
    if span <= 0.0 {
        return lo;
    }
    let t = (p - lo).rem_euclid(2.0 * span);
    lo + if t > span { 2.0 * span - t } else { t }
}

impl Mover {
    fn at(&self, k: usize, w: f64, h: f64) -> Blob {
        let [a, b] = self.blob.half;
        let kf = k as f64;
        Blob {
            center: [
                reflect(
                    self.blob.center[0] + kf * self.velocity[0],
                    a - 0.5,
                    w - 0.5 - a,
                ),
                reflect(
                    self.blob.center[1] + kf * self.velocity[1],
                    b - 0.5,
                    h - 0.5 - b,
                ),
            ],
            ..self.blob
        }
    }
}

/// One primitive of a skin object, in object coordinates.
#[derive(Debug, Clone, Copy)]
enum Prim {
    /// Centre and semi-axes.
    Ellipse([f64; 4]),
    /// `[x0, y0, x1, y1]`.
    Rect([f64; 4]),
}

impl Prim {
    fn coverage(&self, dx: f64, dy: f64) -> f64 {
        match *self {
            Prim::Ellipse([cx, cy, a, b]) => ellipse_cov(dx - cx, dy - cy, a, b),
            Prim::Rect([x0, y0, x1, y1]) => rect_cov(dx, dy, x0, y0, x1, y1),
        }
    }

    fn extent(&self) -> [f64; 4] {
        match *self {
            Prim::Ellipse([cx, cy, a, b]) => [cx - a, cy - b, cx + a, cy + b],
            Prim::Rect(r) => r,
        }
    }

    /// Points along the primitive's boundary (where its coverage is one
    /// half), at most `step` apart, in order; a closed loop (first point
    /// repeated last).
    fn boundary(&self, step: f64) -> Vec<[f64; 2]> {
        match *self {
            Prim::Ellipse([cx, cy, a, b]) => {
                // Ramanujan's perimeter bounds the arc between samples.
                let h = ((a - b) / (a + b)).powi(2);
                let perimeter = std::f64::consts::PI
                    * (a + b)
                    * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
                let n = (perimeter / step).ceil().max(8.0) as usize;
                (0..=n)
                    .map(|i| {
                        let t = std::f64::consts::TAU * (i % n) as f64 / n as f64;
                        [cx + a * t.cos(), cy + b * t.sin()]
                    })
                    .collect()
            }
            Prim::Rect([x0, y0, x1, y1]) => {
                let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]];
                let mut out = vec![corners[0]];
                for w in corners.windows(2) {
                    let len = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
                    let n = (len / step).ceil().max(1.0) as usize;
                    for i in 1..=n {
                        let t = i as f64 / n as f64;
                        out.push([
                            w[0][0] + t * (w[1][0] - w[0][0]),
                            w[0][1] + t * (w[1][1] - w[0][1]),
                        ]);
                    }
                }
                out
            }
        }
    }

    /// Whether `(x, y)` is inside the primitive, more than `margin` from
    /// its boundary (approximately, for the ellipse).
    fn strictly_contains(&self, x: f64, y: f64, margin: f64) -> bool {
        match *self {
            Prim::Ellipse([cx, cy, a, b]) => {
                ((x - cx) / (a - margin)).powi(2) + ((y - cy) / (b - margin)).powi(2) < 1.0
            }
            Prim::Rect([x0, y0, x1, y1]) => {
                x > x0 + margin && x < x1 - margin && y > y0 + margin && y < y1 - margin
            }
        }
    }
}

/// A skin object: a silhouette (union of primitives) in skin colour with
/// darker details drawn inside it.
#[derive(Debug, Clone)]
struct Shape {
    silhouette: Vec<Prim>,
    details: Vec<(Prim, Rgb)>,
    /// Shading ellipse semi-axes (brightness falls off towards its edge).
    shade: [f64; 2],
    /// Silhouette extent `[x0, y0, x1, y1]` in object coordinates.
    extent: [f64; 4],
}

impl SkinShape {
    fn shape(self) -> Shape {
        let (silhouette, details, shade) = match self {
            SkinShape::Face => (
                vec![Prim::Ellipse([0.0, 0.0, 20.0, 26.0])],
                vec![
                    (Prim::Ellipse([-7.0, -6.0, 3.6, 2.4]), Rgb::new(60, 40, 35)),
                    (Prim::Ellipse([7.0, -6.0, 3.6, 2.4]), Rgb::new(60, 40, 35)),
                    (Prim::Rect([-9.5, -11.5, -3.5, -10.0]), Rgb::new(90, 60, 45)),
                    (Prim::Rect([3.5, -11.5, 9.5, -10.0]), Rgb::new(90, 60, 45)),
                    (Prim::Ellipse([0.0, 12.0, 7.0, 1.8]), Rgb::new(150, 70, 70)),
                ],
                [20.0, 26.0],
            ),
            SkinShape::Hand => {
                let mut s = vec![Prim::Ellipse([0.0, 6.0, 13.0, 15.0])];
                for (x, top) in [(-8.5, -20.0), (-3.0, -22.0), (2.5, -21.0), (8.0, -17.0)] {
                    s.push(Prim::Rect([x - 2.5, top, x + 2.5, -4.0]));
                }
                s.push(Prim::Rect([10.0, -1.0, 18.0, 5.0]));
                (s, Vec::new(), [16.0, 22.0])
            }
        };
        let extent = silhouette.iter().map(Prim::extent).fold(
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
            |a, e| {
                [
                    a[0].min(e[0]),
                    a[1].min(e[1]),
                    a[2].max(e[2]),
                    a[3].max(e[3]),
                ]
            },
        );
        Shape {
            silhouette,
            details,
            shade,
            extent,
        }
    }
}

impl Shape {
    /// The silhouette's boundary in object coordinates: each primitive's
    /// boundary (samples 0.25 px apart) without the parts inside another
    /// primitive.
    fn outline(&self) -> Outline {
        const STEP: f64 = 0.25;
        const MARGIN: f64 = 1e-9;
        let mut polylines = Vec::new();
        for (i, p) in self.silhouette.iter().enumerate() {
            let mut line: Vec<[f64; 2]> = Vec::new();
            for q in p.boundary(STEP) {
                let covered = self
                    .silhouette
                    .iter()
                    .enumerate()
                    .any(|(j, o)| j != i && o.strictly_contains(q[0], q[1], MARGIN));
                if covered {
                    if !line.is_empty() {
                        polylines.push(std::mem::take(&mut line));
                    }
                } else {
                    line.push(q);
                }
            }
            if !line.is_empty() {
                polylines.push(line);
            }
        }
        Outline { polylines }
    }

    fn coverage(&self, dx: f64, dy: f64) -> f64 {
        self.silhouette
            .iter()
            .map(|p| p.coverage(dx, dy))
            .fold(0.0, f64::max)
    }

    /// Colour at object coordinates `(dx, dy)` (ignoring the silhouette).
    fn color(&self, dx: f64, dy: f64) -> [f64; 3] {
        let rho2 = (dx / self.shade[0]).powi(2) + (dy / self.shade[1]).powi(2);
        let f = 1.0 - 0.15 * rho2.min(1.0);
        let mut c = SKIN.to_array().map(|v| f64::from(v) * f);
        for (p, col) in &self.details {
            let a = p.coverage(dx, dy);
            if a > 0.0 {
                for (k, v) in c.iter_mut().enumerate() {
                    *v = blend(*v, f64::from(col.to_array()[k]), a);
                }
            }
        }
        c
    }
}

/// How a skin object moves.
#[derive(Debug, Clone, Copy)]
enum Path {
    /// `center + sum_j amp_j * sin(omega_j t + phase_j)` per axis (t in s).
    Wander {
        center: [f64; 2],
        amp: [[f64; 2]; 3],
        omega: [[f64; 2]; 3],
        phase: [[f64; 2]; 3],
    },
    /// Constant velocity per frame.
    Linear { start: [f64; 2], velocity: [f64; 2] },
    /// Waits at `start` until `frame`, then moves along x by `dir * speed`
    /// per frame until `rest_x`.
    Enter {
        frame: usize,
        start: [f64; 2],
        rest_x: f64,
        dir: f64,
        speed: f64,
    },
}

impl Path {
    fn wander(
        rng: &mut Xoshiro256PlusPlus,
        center: [f64; 2],
        max_amp: [f64; 2],
        speed: f64,
    ) -> Self {
        let share = [0.55, 0.3, 0.15];
        let base = [0.6, 1.1, 1.9];
        let mut amp = [[0.0; 2]; 3];
        let mut omega = [[0.0; 2]; 3];
        let mut phase = [[0.0; 2]; 3];
        for j in 0..3 {
            for a in 0..2 {
                amp[j][a] = share[j] * max_amp[a];
                omega[j][a] = speed * base[j] * rng.random_range(0.8..1.2);
                phase[j][a] = rng.random_range(0.0..std::f64::consts::TAU);
            }
        }
        Path::Wander {
            center,
            amp,
            omega,
            phase,
        }
    }

    fn at(&self, k: usize, fps: f64) -> [f64; 2] {
        match *self {
            Path::Wander {
                center,
                amp,
                omega,
                phase,
            } => {
                let t = k as f64 / fps;
                let mut p = center;
                for j in 0..3 {
                    for a in 0..2 {
                        p[a] += amp[j][a] * (omega[j][a] * t + phase[j][a]).sin();
                    }
                }
                p
            }
            Path::Linear { start, velocity } => [
                start[0] + k as f64 * velocity[0],
                start[1] + k as f64 * velocity[1],
            ],
            Path::Enter {
                frame,
                start,
                rest_x,
                dir,
                speed,
            } => {
                let moved = k.saturating_sub(frame) as f64 * speed;
                let limit = (rest_x - start[0]).abs();
                [start[0] + dir * moved.min(limit), start[1]]
            }
        }
    }
}

/// How a skin object turns and changes size about its centre.
#[derive(Debug, Clone, Copy)]
struct Pose {
    size: f64,
    rotation: f64,
    rotation_omega: f64,
    rotation_phase: f64,
    scale: f64,
    scale_omega: f64,
    scale_phase: f64,
}

impl Pose {
    /// Upright at its shape's size, always.
    const FIXED: Pose = Pose {
        size: 1.0,
        rotation: 0.0,
        rotation_omega: 0.0,
        rotation_phase: 0.0,
        scale: 0.0,
        scale_omega: 0.0,
        scale_phase: 0.0,
    };

    /// (rotation in radians, scale) at frame `k`.
    fn at(&self, k: usize, fps: f64) -> (f64, f64) {
        let t = k as f64 / fps;
        let theta = if self.rotation == 0.0 {
            0.0
        } else {
            self.rotation * (self.rotation_omega * t + self.rotation_phase).sin()
        };
        let s = if self.scale == 0.0 {
            self.size
        } else {
            self.size * (1.0 + self.scale * (self.scale_omega * t + self.scale_phase).sin())
        };
        (theta, s)
    }
}

/// Where an object stands in frame k: centre, rotation and scale.
#[derive(Debug, Clone, Copy)]
struct Placed {
    c: [f64; 2],
    cos: f64,
    sin: f64,
    s: f64,
}

impl Placed {
    fn new(c: [f64; 2], (theta, s): (f64, f64)) -> Self {
        let (sin, cos) = if theta == 0.0 {
            (0.0, 1.0)
        } else {
            theta.sin_cos()
        };
        Self { c, cos, sin, s }
    }

    /// Object coordinates of image point (x, y) (exactly x - cx, y - cy
    /// for an upright object of size 1).
    fn local(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (x - self.c[0], y - self.c[1]);
        (
            (self.cos * dx + self.sin * dy) / self.s,
            (self.cos * dy - self.sin * dx) / self.s,
        )
    }

    /// Image point of object coordinates (u, v).
    fn image(&self, u: f64, v: f64) -> [f64; 2] {
        [
            self.c[0] + self.s * (self.cos * u - self.sin * v),
            self.c[1] + self.s * (self.sin * u + self.cos * v),
        ]
    }

    /// The image box [x0, y0, x1, y1] of the object's extent rectangle
    /// (the extent itself, moved, for an upright object of size 1).
    fn extent(&self, e: [f64; 4]) -> [f64; 4] {
        let corners = [[e[0], e[1]], [e[2], e[1]], [e[2], e[3]], [e[0], e[3]]];
        corners.iter().fold(
            [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ],
            |a, &[u, v]| {
                let [x, y] = self.image(u, v);
                [a[0].min(x), a[1].min(y), a[2].max(x), a[3].max(y)]
            },
        )
    }
}

#[derive(Debug, Clone)]
struct Person {
    shape: Shape,
    label: &'static str,
    path: Path,
    pose: Pose,
}

/// The webcam scene frame by frame (see [`WebcamScene::stream`]).
#[derive(Debug, Clone)]
pub struct WebcamStream {
    params: WebcamScene,
    seed: u64,
    next: usize,
    people: Vec<Person>,
    movers: Vec<Mover>,
    background: Image<u8>,
}

impl WebcamStream {
    /// The true outline of every object in frame `k` (0-based), in the
    /// order of [`FrameTruth::objects`]: the silhouette's boundary (face
    /// ellipse; palm, fingers and thumb of the hand) at the object's
    /// position, in 0-based pixels, also where it is hidden or outside the
    /// frame. The positions are a function of `k` alone, so this does not
    /// depend on how far the stream has advanced.
    pub fn outlines(&self, k: usize) -> Vec<Outline> {
        self.people
            .iter()
            .zip(self.placed(k))
            .map(|(p, at)| {
                let o = p.shape.outline();
                if at.sin == 0.0 && at.s == 1.0 {
                    o.translated(at.c[0], at.c[1])
                } else {
                    Outline {
                        polylines: o
                            .polylines
                            .iter()
                            .map(|l| l.iter().map(|q| at.image(q[0], q[1])).collect())
                            .collect(),
                    }
                }
            })
            .collect()
    }

    fn visible_fraction(&self, i: usize, placed: &[Placed]) -> f64 {
        let (w, h) = (self.params.width as i64, self.params.height as i64);
        let person = &self.people[i];
        let at = placed[i];
        let [x0, y0, x1, y1] = at.extent(person.shape.extent);
        let (mut total, mut seen) = (0.0, 0.0);
        for y in pixel_span(y0, y1) {
            for x in pixel_span(x0, x1) {
                let (fx, fy) = (x as f64, y as f64);
                let (u, v) = at.local(fx, fy);
                let c = person.shape.coverage(u, v);
                total += c;
                if c <= 0.0 || x < 0 || y < 0 || x >= w || y >= h {
                    continue;
                }
                let hidden = (i + 1..self.people.len())
                    .map(|j| {
                        let (u, v) = placed[j].local(fx, fy);
                        self.people[j].shape.coverage(u, v)
                    })
                    .fold(0.0, f64::max);
                seen += c * (1.0 - hidden);
            }
        }
        if total > 0.0 { seen / total } else { 0.0 }
    }

    fn placed(&self, k: usize) -> Vec<Placed> {
        let fps = self.params.fps;
        self.people
            .iter()
            .map(|p| Placed::new(p.path.at(k, fps), p.pose.at(k, fps)))
            .collect()
    }

    fn advance(&mut self) -> Option<FrameTruth> {
        if self.next >= self.params.frames {
            return None;
        }
        let k = self.next;
        self.next += 1;
        let placed = self.placed(k);
        let objects = self
            .people
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let at = placed[i];
                let [x0, y0, x1, y1] = p.shape.extent;
                let bbox = if at.sin == 0.0 && at.s == 1.0 {
                    otb_box(at.c[0] + x0, at.c[1] + y0, x1 - x0, y1 - y0)
                } else {
                    let [x0, y0, x1, y1] = at.extent(p.shape.extent);
                    otb_box(x0, y0, x1 - x0, y1 - y0)
                };
                ObjectTruth {
                    id: i,
                    label: p.label,
                    bbox,
                    visible_fraction: self.visible_fraction(i, &placed),
                }
            })
            .collect();
        Some(FrameTruth {
            index: k,
            time: k as f64 / self.params.fps,
            objects,
            gain: 1.0,
            bounce: false,
            affine: None,
        })
    }

    fn render(&self, k: usize, out: &mut Image<u8>) {
        let p = &self.params;
        let (w, h) = (p.width as f64, p.height as f64);
        out.as_mut_slice()
            .copy_from_slice(self.background.as_slice());
        let stride = out.stride();
        let buf = out.as_mut_slice();
        let mut paint = |x: usize, y: usize, col: [f64; 3], a: f64| {
            let o = y * stride + 3 * x;
            for c in 0..3 {
                buf[o + c] = to_u8(blend(f64::from(buf[o + c]), col[c], a));
            }
        };
        for m in &self.movers {
            let b = m.at(k, w, h);
            let col = b.color.to_array().map(f64::from);
            let [cx, cy] = b.center;
            let [a, bb] = b.half;
            for y in clipped_span(cy - bb, cy + bb, p.height) {
                for x in clipped_span(cx - a, cx + a, p.width) {
                    let c = b.coverage(x as f64, y as f64);
                    if c > 0.0 {
                        paint(x, y, col, c);
                    }
                }
            }
        }
        for (person, at) in self.people.iter().zip(self.placed(k)) {
            let [x0, y0, x1, y1] = at.extent(person.shape.extent);
            for y in clipped_span(y0, y1, p.height) {
                for x in clipped_span(x0, x1, p.width) {
                    let (dx, dy) = at.local(x as f64, y as f64);
                    let c = person.shape.coverage(dx, dy);
                    if c > 0.0 {
                        paint(x, y, person.shape.color(dx, dy), c);
                    }
                }
            }
        }
        let mut noise = scene_rng(self.seed, KEY, streams::NOISE, k as u64);
        add_noise(buf, p.sensor_noise, &mut noise);
    }
}

impl SceneStream for WebcamStream {
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
            *frame = self.background.clone();
        }
        self.render(truth.index, frame);
        Some(truth)
    }
}

impl Iterator for WebcamStream {
    type Item = super::SceneFrame;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_frame()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skin_colours_are_skin_and_distractors_are_not() {
        for c in [SKIN, SKIN_DISTRACTORS[0], SKIN_DISTRACTORS[1]] {
            let hsv = c.to_hsv();
            assert!((0.02..0.12).contains(&hsv.h), "{c:?} hue {}", hsv.h);
            assert!((0.25..0.6).contains(&hsv.s), "{c:?} saturation {}", hsv.s);
        }
        for c in NON_SKIN {
            let hsv = c.to_hsv();
            assert!(hsv.h > 0.2 && hsv.h < 0.95, "{c:?} hue {}", hsv.h);
        }
        // The wall is nearly grey.
        assert!(Rgb::new(175, 177, 183).to_hsv().s < 0.1);
    }

    #[test]
    fn reflect_is_a_triangle_wave() {
        assert_eq!(reflect(5.0, 0.0, 10.0), 5.0);
        assert_eq!(reflect(12.0, 0.0, 10.0), 8.0);
        assert_eq!(reflect(-3.0, 0.0, 10.0), 3.0);
        assert_eq!(reflect(23.0, 0.0, 10.0), 3.0);
    }

    #[test]
    fn outlines_lie_where_the_coverage_is_one_half() {
        for shape in [SkinShape::Face, SkinShape::Hand] {
            let s = shape.shape();
            let o = s.outline();
            assert!(o.len() > 400, "{shape:?}: {} points", o.len());
            let mut ext = [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ];
            for [x, y] in o.points() {
                // On an edge 1/2, at a rectangle's corner 1/4.
                let c = s.coverage(x, y);
                assert!((0.24..=0.76).contains(&c), "{shape:?} ({x}, {y}): {c}");
                ext = [ext[0].min(x), ext[1].min(y), ext[2].max(x), ext[3].max(y)];
            }
            for (a, b) in ext.iter().zip(s.extent) {
                assert!((a - b).abs() < 0.01, "{shape:?}: {ext:?} vs {:?}", s.extent);
            }
            // Nothing of the palm's arc under the fingers is kept.
            assert!(o.distance([0.0, -4.0]) > 1.0 || shape == SkinShape::Face);
        }
        // The face is one closed ellipse.
        let face = SkinShape::Face.shape().outline();
        assert_eq!(face.polylines.len(), 1);
        assert!((face.distance([0.0, 0.0]) - 20.0).abs() < 1e-3);
    }

    #[test]
    fn a_turning_target_is_drawn_where_its_outline_and_box_say() {
        let p = WebcamScene {
            frames: 90,
            target_size: 1.2,
            rotation_deg: 15.0,
            scale_change: 0.15,
            static_skin_distractors: 0,
            moving_distractors: 0,
            ..WebcamScene::default()
        };
        let mut stream = p.stream(3).unwrap();
        let (mut min_w, mut max_w) = (f64::INFINITY, 0.0_f64);
        let mut tilted = 0;
        while let Some(f) = stream.next_frame() {
            let k = f.truth.index;
            let b = f.truth.objects[0].bbox;
            let (x0, y0) = (b.x - 1.5, b.y - 1.5);
            let o = &stream.outlines(k)[0];
            let pts: Vec<[f64; 2]> = o.points().collect();
            let c = pts
                .iter()
                .fold([0.0, 0.0], |a, q| [a[0] + q[0], a[1] + q[1]]);
            let c = [c[0] / pts.len() as f64, c[1] / pts.len() as f64];
            // The box holds the outline.
            for &[x, y] in &pts {
                assert!(
                    x >= x0 - 1e-9 && x <= x0 + b.width + 1e-9,
                    "frame {k}: x {x}"
                );
                assert!(
                    y >= y0 - 1e-9 && y <= y0 + b.height + 1e-9,
                    "frame {k}: y {y}"
                );
            }
            // 3 px inside the outline is skin (R - B about 70 and more), 3
            // px outside is the near-grey wall (R - B about -8).
            let img = &f.image;
            let px = |x: f64, y: f64| {
                let (x, y) = (x.round() as usize, y.round() as usize);
                let o = y * img.stride() + 3 * x;
                let d = img.as_slice();
                f64::from(d[o]) - f64::from(d[o + 2])
            };
            for q in pts.iter().step_by(40) {
                let (dx, dy) = (c[0] - q[0], c[1] - q[1]);
                let n = dx.hypot(dy);
                let (ux, uy) = (dx / n, dy / n);
                let (ox, oy) = (q[0] - 3.0 * ux, q[1] - 3.0 * uy);
                if ox < 0.0 || oy < 0.0 || ox > 318.0 || oy > 238.0 {
                    continue;
                }
                let inside = px(q[0] + 3.0 * ux, q[1] + 3.0 * uy);
                let outside = px(q[0] - 3.0 * ux, q[1] - 3.0 * uy);
                assert!(inside > 40.0, "frame {k}: {inside} inside at {q:?}");
                assert!(outside < 20.0, "frame {k}: {outside} outside at {q:?}");
            }
            // The ellipse's widest point: not on the horizontal axis when it
            // is tilted.
            let right = pts
                .iter()
                .fold(pts[0], |a, &q| if q[0] > a[0] { q } else { a });
            if (right[1] - c[1]).abs() > 2.0 {
                tilted += 1;
            }
            min_w = min_w.min(b.width);
            max_w = max_w.max(b.width);
        }
        // Size 1.2 x (1 +- 0.15) of the 40 px wide face (wider when tilted).
        assert!(min_w >= 1.2 * 0.85 * 40.0 - 1.0, "{min_w}");
        assert!(max_w - min_w > 6.0, "{min_w} - {max_w}");
        assert!(tilted > 30, "{tilted} of 90 frames tilted");
    }

    #[test]
    fn shapes_have_the_documented_extent() {
        assert_eq!(SkinShape::Face.shape().extent, [-20.0, -26.0, 20.0, 26.0]);
        assert_eq!(SkinShape::Hand.shape().extent, [-13.0, -22.0, 18.0, 21.0]);
    }
}
