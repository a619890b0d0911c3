//! The layout of every frame of a stress sequence: where the target, the
//! occluders and the distractors are, and how the scene is lit.
//!
//! Extents are `[x0, y0, x1, y1]` in 0-based continuous pixel coordinates
//! (pixel `i` covers `[i - 0.5, i + 0.5]`); frame `k` of `N` has the phase
//! `u = k / (N - 1)` in `[0, 1]`, so every stress spans the whole sequence
//! whatever its length.

use std::f64::consts::PI;

use rand::RngExt;

use super::{HEIGHT, KEY, Stress, TARGET_SIZE, WIDTH};
use crate::scenes::{scene_rng, streams};

/// A soft round shadow: the light is multiplied by `gain` inside
/// `radius`, rising smoothly to 1 at `radius + soft`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shadow {
    /// Centre, 0-based.
    pub center: [f64; 2],
    /// Radius of the full shadow, px.
    pub radius: f64,
    /// Width of the soft edge, px.
    pub soft: f64,
    /// Light gain inside the shadow.
    pub gain: f64,
}

impl Shadow {
    /// The light gain at `(x, y)`.
    #[inline]
    pub fn gain_at(&self, x: f64, y: f64) -> f64 {
        let r = (x - self.center[0]).hypot(y - self.center[1]);
        let t = ((r - self.radius) / self.soft).clamp(0.0, 1.0);
        let s = t * t * (3.0 - 2.0 * t);
        self.gain + (1.0 - self.gain) * s
    }
}

/// How the target's texture is laid over its box in a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Look {
    /// The texture as it is, scaled with the box.
    Rigid,
    /// Non-rigid: the texture displaced inside the box by two travelling
    /// waves (`amplitude` template pixels, at `phase`), the box's outline
    /// unchanged (its aspect is the plan's).
    Warp {
        /// Phase of the waves, radians.
        phase: f64,
        /// Largest displacement, template pixels.
        amplitude: f64,
    },
    /// A cylinder as wide as the box, turned `angle` radians about its
    /// vertical axis: its texture wraps round it, the side facing the
    /// camera is lit most.
    Turn {
        /// Turn from the first frame's pose, radians.
        angle: f64,
    },
}

/// The layout of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FramePlan {
    /// The target's extent.
    pub target: [f64; 4],
    /// The target's scale (the geometric mean of its width and height
    /// over [`TARGET_SIZE`]'s).
    pub scale: f64,
    /// How its texture is laid over its box.
    pub look: Look,
    /// Occluders in front of the target (never overlapping each other).
    pub occluders: Vec<[f64; 4]>,
    /// Distractors behind the target, each with the target's size at
    /// scale 1.
    pub distractors: Vec<[f64; 4]>,
    /// Global light gain.
    pub gain: f64,
    /// Global offset added after the gain, grey levels.
    pub offset: f64,
    /// A local shadow, if any.
    pub shadow: Option<Shadow>,
    /// Fraction of the target's area inside the frame and not behind an
    /// occluder.
    pub visible_fraction: f64,
}

/// Extent of a box of `size * scale` centred on `c`.
fn extent(c: [f64; 2], scale: f64) -> [f64; 4] {
    extent_aspect(c, scale, 1.0)
}

/// Extent of a box of `size * scale` centred on `c`, its width times
/// `aspect` and its height over it.
fn extent_aspect(c: [f64; 2], scale: f64, aspect: f64) -> [f64; 4] {
    let (w, h) = (
        TARGET_SIZE[0] * scale * aspect,
        TARGET_SIZE[1] * scale / aspect,
    );
    [
        c[0] - w / 2.0,
        c[1] - h / 2.0,
        c[0] + w / 2.0,
        c[1] + h / 2.0,
    ]
}

/// Area of the intersection of two extents.
pub(crate) fn overlap(a: [f64; 4], b: [f64; 4]) -> f64 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    w * h
}

/// The deformation's largest texture displacement, template pixels.
const WARP_AMPLITUDE: f64 = 3.0;

/// The out-of-plane turn's largest angle either way, radians (80 degrees:
/// at the extremes the side first seen is a sliver at the edge).
pub(crate) const TURN_ANGLE: f64 = 80.0 * PI / 180.0;

/// The frame's extent.
const FRAME: [f64; 4] = [-0.5, -0.5, WIDTH as f64 - 0.5, HEIGHT as f64 - 0.5];

/// Fraction of `e` inside the frame and behind none of `occluders`
/// (which do not overlap each other).
pub(crate) fn visible_fraction(e: [f64; 4], occluders: &[[f64; 4]]) -> f64 {
    let area = (e[2] - e[0]) * (e[3] - e[1]);
    let inside = [
        e[0].max(FRAME[0]),
        e[1].max(FRAME[1]),
        e[2].min(FRAME[2]),
        e[3].min(FRAME[3]),
    ];
    let mut seen = overlap(e, FRAME);
    if seen > 0.0 {
        for o in occluders {
            seen -= overlap(inside, *o);
        }
    }
    (seen / area).clamp(0.0, 1.0)
}

/// A full-height pole between `x0` and `x1`.
fn pole(x0: f64, x1: f64) -> [f64; 4] {
    [x0, FRAME[1], x1, FRAME[3]]
}

/// The layout of every frame of `stress`, `frames` long, under `seed`.
pub(crate) fn plan(stress: Stress, frames: usize, seed: u64) -> Vec<FramePlan> {
    let index = Stress::ALL.iter().position(|&s| s == stress).unwrap_or(0) as u64;
    let mut layout = scene_rng(seed, KEY, streams::LAYOUT, index);
    // phases of the smooth paths
    let ph: [f64; 4] = std::array::from_fn(|_| layout.random_range(0.0..2.0 * PI));
    let last = (frames.max(2) - 1) as f64;
    let fast = (stress == Stress::FastMotion).then(|| fast_path(frames, seed, index));
    (0..frames)
        .map(|k| {
            let u = k as f64 / last;
            let tau = 2.0 * PI * u;
            let mut p = FramePlan {
                target: [0.0; 4],
                scale: 1.0,
                look: Look::Rigid,
                occluders: Vec::new(),
                distractors: Vec::new(),
                gain: 1.0,
                offset: 0.0,
                shadow: None,
                visible_fraction: 1.0,
            };
            let mut aspect = 1.0;
            let centre = match stress {
                Stress::PartialOcclusion => {
                    p.occluders = vec![pole(118.0, 136.0), [200.0, 122.5, 300.0, FRAME[3]]];
                    [60.0 + 200.0 * u, 120.0 + 6.0 * (1.5 * tau + ph[0]).sin()]
                }
                Stress::FullOcclusion => {
                    p.occluders = vec![[130.0, 50.0, 210.0, 190.0]];
                    [50.0 + 220.0 * u, 118.0 + 8.0 * (tau + ph[0]).sin()]
                }
                Stress::Scale => {
                    p.scale = tau.sin().exp2();
                    [
                        160.0 + 25.0 * (0.7 * tau + ph[0]).sin(),
                        120.0 + 15.0 * (1.1 * tau + ph[1]).sin(),
                    ]
                }
                Stress::FastMotion => fast.as_ref().map_or([160.0, 120.0], |f| f[k]),
                Stress::Illumination => {
                    let c = [
                        160.0 + 90.0 * (tau + ph[0]).sin(),
                        120.0 + 40.0 * (2.0 * tau + ph[1]).sin(),
                    ];
                    p.gain = 1.0 - 0.5 * tau.sin();
                    p.offset = 10.0 * (PI * u).sin();
                    p.shadow = Some(Shadow {
                        center: [-70.0 + (WIDTH as f64 + 140.0) * u, c[1]],
                        radius: 55.0,
                        soft: 20.0,
                        gain: 0.35,
                    });
                    c
                }
                Stress::Clutter => {
                    let c = [
                        160.0 + 70.0 * (tau + ph[0]).sin(),
                        120.0 + 35.0 * (1.3 * tau + ph[1]).sin(),
                    ];
                    p.distractors = vec![
                        extent([20.0 + 280.0 * u, c[1] + 12.0], 1.0),
                        extent(lissajous([60.0, 55.0], tau, ph[2], 35.0, 20.0), 1.0),
                        extent(lissajous([262.0, 60.0], tau, ph[3], 35.0, 20.0), 1.0),
                        extent(lissajous([250.0, 190.0], tau, ph[0] + 1.0, 35.0, 20.0), 1.0),
                    ];
                    c
                }
                Stress::Mixed => {
                    p.scale = (0.5 * (1.2 * tau + ph[2]).sin()).exp2();
                    p.occluders = vec![pole(96.0, 114.0)];
                    p.gain = 1.0 - 0.4 * (PI * u).sin();
                    p.distractors = vec![
                        extent(lissajous([80.0, 60.0], tau, ph[3], 50.0, 30.0), 1.0),
                        extent(lissajous([240.0, 185.0], tau, ph[1] + 2.0, 50.0, 30.0), 1.0),
                    ];
                    [
                        160.0 + 100.0 * (1.5 * tau + ph[0]).sin(),
                        120.0 + 45.0 * (tau + ph[1]).sin(),
                    ]
                }
                Stress::Deformation => {
                    aspect = (0.4 * (3.0 * tau + ph[2]).sin()).exp2();
                    p.look = Look::Warp {
                        phase: 6.0 * tau + ph[3],
                        amplitude: WARP_AMPLITUDE,
                    };
                    [
                        160.0 + 80.0 * (tau + ph[0]).sin(),
                        120.0 + 35.0 * (1.4 * tau + ph[1]).sin(),
                    ]
                }
                Stress::OutOfPlane => {
                    p.look = Look::Turn {
                        angle: TURN_ANGLE * (1.5 * tau).sin(),
                    };
                    [
                        160.0 + 80.0 * (tau + ph[0]).sin(),
                        120.0 + 35.0 * (1.4 * tau + ph[1]).sin(),
                    ]
                }
            };
            p.target = extent_aspect(centre, p.scale, aspect);
            p.visible_fraction = visible_fraction(p.target, &p.occluders);
            p
        })
        .collect()
}

/// A slow Lissajous path about `c`.
fn lissajous(c: [f64; 2], tau: f64, phase: f64, ax: f64, ay: f64) -> [f64; 2] {
    [
        c[0] + ax * (tau + phase).sin(),
        c[1] + ay * (1.7 * tau + phase).cos(),
    ]
}

/// The fast-motion centres: straight segments of 6-14 frames at 12-24 px
/// per frame in a random direction, reflected at the margins (so the
/// target stays in the frame).
fn fast_path(frames: usize, seed: u64, index: u64) -> Vec<[f64; 2]> {
    let mut rng = scene_rng(seed, KEY, streams::MOTION, index);
    let (lo, hi) = (
        [TARGET_SIZE[0] / 2.0 + 4.0, TARGET_SIZE[1] / 2.0 + 4.0],
        [
            WIDTH as f64 - TARGET_SIZE[0] / 2.0 - 5.0,
            HEIGHT as f64 - TARGET_SIZE[1] / 2.0 - 5.0,
        ],
    );
    let mut c = [WIDTH as f64 / 2.0, HEIGHT as f64 / 2.0];
    let mut v = [0.0; 2];
    let mut left = 0usize;
    let mut out = Vec::with_capacity(frames);
    for k in 0..frames {
        if k > 0 {
            if left == 0 {
                let speed = rng.random_range(12.0..24.0);
                let angle: f64 = rng.random_range(0.0..2.0 * PI);
                v = [speed * angle.cos(), speed * angle.sin()];
                left = rng.random_range(6..=14);
            }
            left -= 1;
            for i in 0..2 {
                c[i] += v[i];
                if c[i] < lo[i] {
                    c[i] = 2.0 * lo[i] - c[i];
                    v[i] = -v[i];
                } else if c[i] > hi[i] {
                    c[i] = 2.0 * hi[i] - c[i];
                    v[i] = -v[i];
                }
                c[i] = c[i].clamp(lo[i], hi[i]);
            }
        }
        out.push(c);
    }
    out
}
