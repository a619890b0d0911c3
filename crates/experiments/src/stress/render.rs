//! Rendering a stress frame from its [`FramePlan`]: background, distractors,
//! target, occluders, then the light (gain, shadow, offset). Anti-aliased
//! by area coverage, as the paper scenes are.

use bayestrack_image::Image;

use std::f64::consts::PI;

use super::plan::{FramePlan, Look};
use super::{HEIGHT, KEY, Stress, TARGET_SIZE, WIDTH};
use crate::scenes::render::{ValueNoise, blend, clipped_span, rect_cov, to_u8};
use crate::scenes::{scene_rng, streams};

/// Base colour of the target and of the distractors (RGB).
pub(crate) const TARGET_BASE: [f64; 3] = [190.0, 80.0, 60.0];
/// Base colour of the background (RGB).
const BACKGROUND_BASE: [f64; 3] = [70.0, 95.0, 80.0];
/// The occluders' two stripe colours.
const OCCLUDER: [[f64; 3]; 2] = [[70.0, 80.0, 130.0], [95.0, 105.0, 150.0]];

/// The texture of the target or of a distractor, in its own coordinates
/// (template pixels at scale 1, origin at its top-left corner).
#[derive(Debug, Clone)]
pub(crate) struct ObjectTexture {
    luminance: ValueNoise,
    chroma: [ValueNoise; 3],
}

/// Radius of the turning cylinder at scale 1, template pixels.
const TURN_RADIUS: f64 = TARGET_SIZE[0] / 2.0;

impl ObjectTexture {
    /// The texture of object `index`, `w` template pixels wide (its box's
    /// width, or a turning cylinder's circumference).
    fn new(seed: u64, index: u64, w: f64) -> Self {
        let mut rng = scene_rng(seed, KEY, streams::LAYOUT, 1000 + index);
        let h = TARGET_SIZE[1];
        Self {
            luminance: ValueNoise::new(w, h, 7.0, &mut rng),
            chroma: std::array::from_fn(|_| ValueNoise::new(w, h, 4.0, &mut rng)),
        }
    }

    /// The darker rim 1.5 px wide along the box's outline: the light
    /// factor at `(u, v)`.
    #[inline]
    fn rim(u: f64, v: f64) -> f64 {
        let [w, h] = TARGET_SIZE;
        if u < 1.5 || v < 1.5 || u > w - 1.5 || v > h - 1.5 {
            0.6
        } else {
            1.0
        }
    }

    /// The texture at `(u, v)` times `light`, without the rim.
    #[inline]
    fn shaded(&self, u: f64, v: f64, light: f64) -> [f64; 3] {
        let l = 50.0 * self.luminance.at(u, v);
        std::array::from_fn(|c| (TARGET_BASE[c] + l + 30.0 * self.chroma[c].at(u, v)) * light)
    }

    /// The colour at `(u, v)` of the box under `look`: the base, a shared
    /// luminance field (so the gray variant keeps the texture), a field per
    /// channel, and a darker rim that stays on the box's outline while the
    /// texture under it warps or turns.
    #[inline]
    fn looked(&self, u: f64, v: f64, look: Look) -> [f64; 3] {
        match look {
            Look::Rigid => self.shaded(u, v, Self::rim(u, v)),
            Look::Warp { phase, amplitude } => {
                let du = amplitude * (2.0 * PI * v / 22.0 + phase).sin();
                let dv = amplitude * (2.0 * PI * u / 18.0 + 1.3 * phase).sin();
                self.shaded(u + du, v + dv, Self::rim(u, v))
            }
            Look::Turn { angle } => {
                // the column's point on the cylinder, seen from the front
                let s = ((u - TURN_RADIUS) / TURN_RADIUS).clamp(-1.0, 1.0);
                let around = TURN_RADIUS * (s.asin() + angle + PI);
                let lit = 0.45 + 0.55 * (1.0 - s * s).sqrt();
                let h = TARGET_SIZE[1];
                let rim = if v < 1.5 || v > h - 1.5 { 0.6 } else { 1.0 };
                self.shaded(around, v, lit * rim)
            }
        }
    }
}

/// Everything a sequence draws that does not move: the background and the
/// objects' textures.
#[derive(Debug, Clone)]
pub(crate) struct Textures {
    /// RGB background, row-major.
    background: Vec<f32>,
    /// The target's texture.
    pub(crate) target: ObjectTexture,
    /// The distractors' textures (as many as any plan uses).
    distractors: Vec<ObjectTexture>,
}

impl Textures {
    /// The textures of `stress` under `seed` (shared by the colour and
    /// gray variants).
    pub(crate) fn new(seed: u64, stress: Stress) -> Self {
        let index = Stress::ALL.iter().position(|&s| s == stress).unwrap_or(0) as u64;
        let key = 16 * index;
        let mut rng = scene_rng(seed, KEY, streams::LAYOUT, 2000 + index);
        let (w, h) = (WIDTH as f64, HEIGHT as f64);
        let lum = ValueNoise::new(w, h, 14.0, &mut rng);
        let chroma: [ValueNoise; 3] =
            std::array::from_fn(|_| ValueNoise::new(w, h, 30.0, &mut rng));
        let mut background = Vec::with_capacity(WIDTH * HEIGHT * 3);
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let (xf, yf) = (x as f64, y as f64);
                let l = 40.0 * lum.at(xf, yf);
                for c in 0..3 {
                    background.push((BACKGROUND_BASE[c] + l + 15.0 * chroma[c].at(xf, yf)) as f32);
                }
            }
        }
        let width = if stress == Stress::OutOfPlane {
            2.0 * PI * TURN_RADIUS
        } else {
            TARGET_SIZE[0]
        };
        Self {
            background,
            target: ObjectTexture::new(seed, key, width),
            distractors: (1..=4)
                .map(|i| ObjectTexture::new(seed, key + i, TARGET_SIZE[0]))
                .collect(),
        }
    }
}

/// Paints `tex` over the extent `e` (scaled to it) under `look` into the
/// RGB buffer.
fn paint(buf: &mut [f32], e: [f64; 4], tex: &ObjectTexture, look: Look) {
    let scale = (e[2] - e[0]) / TARGET_SIZE[0];
    // a rigid box keeps its aspect: one scale for both axes
    let scale_y = match look {
        Look::Rigid => scale,
        _ => (e[3] - e[1]) / TARGET_SIZE[1],
    };
    for y in clipped_span(e[1], e[3], HEIGHT) {
        let yf = y as f64;
        for x in clipped_span(e[0], e[2], WIDTH) {
            let xf = x as f64;
            let cov = rect_cov(xf, yf, e[0], e[1], e[2], e[3]);
            if cov <= 0.0 {
                continue;
            }
            let col = tex.looked((xf - e[0]) / scale, (yf - e[1]) / scale_y, look);
            let px = &mut buf[(y * WIDTH + x) * 3..][..3];
            for (d, s) in px.iter_mut().zip(col) {
                *d = blend(f64::from(*d), s, cov) as f32;
            }
        }
    }
}

/// Paints an occluder (vertical stripes 6 px wide) over `e`.
fn paint_occluder(buf: &mut [f32], e: [f64; 4]) {
    for y in clipped_span(e[1], e[3], HEIGHT) {
        let yf = y as f64;
        for x in clipped_span(e[0], e[2], WIDTH) {
            let xf = x as f64;
            let cov = rect_cov(xf, yf, e[0], e[1], e[2], e[3]);
            if cov <= 0.0 {
                continue;
            }
            let stripe = ((xf - e[0]) / 6.0).floor().rem_euclid(2.0) as usize;
            let px = &mut buf[(y * WIDTH + x) * 3..][..3];
            for (d, s) in px.iter_mut().zip(OCCLUDER[stripe]) {
                *d = blend(f64::from(*d), s, cov) as f32;
            }
        }
    }
}

/// Renders frame `p` into the RGB image `out` (320x240x3), without noise;
/// without the target when `hide_target`.
pub(crate) fn render(tex: &Textures, p: &FramePlan, hide_target: bool, out: &mut Image<u8>) {
    let mut buf = tex.background.clone();
    for (e, t) in p.distractors.iter().zip(&tex.distractors) {
        paint(&mut buf, *e, t, Look::Rigid);
    }
    if !hide_target {
        paint(&mut buf, p.target, &tex.target, p.look);
    }
    for o in &p.occluders {
        paint_occluder(&mut buf, *o);
    }
    let dst = out.as_mut_slice();
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let light = p.gain * p.shadow.map_or(1.0, |s| s.gain_at(x as f64, y as f64));
            let i = (y * WIDTH + x) * 3;
            for c in 0..3 {
                dst[i + c] = to_u8(f64::from(buf[i + c]) * light + p.offset);
            }
        }
    }
}
