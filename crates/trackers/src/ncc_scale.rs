//! A fast template tracker for real video that follows position and
//! scale: normalised cross-correlation (NCC) of a gray template searched
//! exhaustively in a window around a constant-velocity prediction, at three
//! scales, with a guarded template update. Not from the papers: Dong and Chen's (paper 004)
//! MAD tracker (translation, fixed template, [`crate::MadTracker`]) made
//! usable on real video (issue #7).
//!
//! # Model
//! - **Template.** The initial box, in gray (the luma of RGB frames), is
//!   resampled to at most [`NccScaleConfig::template_area`] pixels keeping
//!   its aspect ratio (never enlarged): `tw x th` template pixels, each
//!   covering `rx x ry` frame pixels at scale 1. The score is NCC with a
//!   separable centre-weighted profile ([`NccScaleConfig::border_weight`]),
//!   invariant to gain and offset of the intensities, which absorbs most
//!   illumination change.
//! - **State.** Centre `c` (0-based pixel coordinates), velocity `v`
//!   (px/frame), scale `s` relative to the initial box; the box is
//!   `s (w0, h0)` centred on `c`.
//! - **Search.** The prediction is `p = c + v`. For each scale
//!   `sigma in {1 / q, 1, q}` ([`NccScaleConfig::scale_step`] `q`) the frame
//!   around `p` is area-resampled ([`bayestrack_image::AreaSampler`]: each
//!   patch pixel is the mean of the frame over its cell, the same
//!   anti-aliasing at every scale) to a `(tw + 2m) x (th + 2m)` patch at
//!   `s sigma` cells per template pixel, `m` =
//!   [`NccScaleConfig::search_margin`] times the template's side
//!   `sqrt(tw th)`; the adaptive template is scored at all `(2m + 1)^2`
//!   offsets at the current scale and at the few offsets around that peak
//!   at the other two ([`bayestrack_appearance::NccSearch`]). The peak of
//!   each scale under a weak motion prior ([`NccScaleConfig::motion_penalty`])
//!   gives the position; the scales are compared by the initial template's NCC at
//!   their peaks ([`NccScaleConfig::anchor_weight`]), the two other scales'
//!   scores multiplied by [`NccScaleConfig::scale_penalty`]. A parabola
//!   through the neighbouring scores gives the sub-pixel offset.
//! - **Update.** `c` becomes the match of the best scale; `v` is smoothed,
//!   `v <- g (c_new - c_old) + (1 - g) v` ([`NccScaleConfig::velocity_gain`]);
//!   the log-scale moves by [`NccScaleConfig::scale_gain`] times the vertex
//!   of the parabola through the three scales' scores, kept within
//!   [`NccScaleConfig::min_scale`], [`NccScaleConfig::max_scale`]. When the
//!   best score reaches [`NccScaleConfig::update_threshold`] the adaptive
//!   template moves towards the matched window, `T <- (1 - a) T + a W`
//!   ([`NccScaleConfig::update_rate`]). Below
//!   [`NccScaleConfig::lost_threshold`] the tracker reports the target lost,
//!   keeps the prediction, zeroes the velocity and searches the next frame
//!   in the wide window ([`NccScaleConfig::wide_margin`]), which also
//!   serves a second look whenever a match is weak (the target may have
//!   jumped out of the window with an abrupt camera motion).
//!
//! Deterministic: no randomness.
//!
//! ```
//! use bayestrack_image::{BBox, Image};
//! use bayestrack_trackers::{NccScaleConfig, NccScaleTracker, Tracker};
//!
//! // A textured 16x16 square on a flat background, moving 2 px right per frame.
//! let frame = |x0: usize| {
//!     Image::from_fn(96, 64, |x, y| {
//!         if (x0..x0 + 16).contains(&x) && (20..36).contains(&y) {
//!             (40 + 20 * ((x - x0) % 7) + 15 * (y % 5)) as u8
//!         } else {
//!             120
//!         }
//!     })
//!     .unwrap()
//! };
//! let mut t = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
//! t.init(frame(20).view(), BBox::new(21.0, 21.0, 16.0, 16.0)).unwrap();
//! let mut est = None;
//! for k in 1..=10 {
//!     est = Some(t.step(frame(20 + 2 * k).view()).unwrap());
//! }
//! let b = est.unwrap().bbox;
//! assert!((b.x - 41.0).abs() < 1.0 && (b.width - 16.0).abs() < 1.0);
//! ```

use bayestrack_appearance::{NccSearch, NccTemplate};
use bayestrack_image::{AreaSampler, BBox, Image, ImageView, ImageViewMut, Rect, gray_region_into};
use bayestrack_options::options;

use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Needs, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

const NAME: &str = "ncc-scale";

options! {
    /// Every parameter of [`NccScaleTracker`], with defaults chosen from the
    /// literature and first principles (see each field); one set for every
    /// sequence.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct NccScaleConfig {
        /// Largest template, in template pixels (400, e.g. 20x20): the initial
        /// box is resampled down to this area. Template trackers work with
        /// patches of a few hundred pixels (KCF/DSST resample to about 50x50
        /// cells of 4 pixels; Xu, Gao and Yang 2015 (paper 002) uses 36x36); the search cost grows with
        /// this area times the number of offsets.
        pub template_area: usize = 400;
        /// Weight `f` of the template's edges relative to its centre (0.25):
        /// pixel `(u, v)` is weighted `k(x_u) k(y_v)`, `k(x) = f + (1 - f)(1 - x^2)`
        /// with `x` the normalised distance from the middle (a separable
        /// Epanechnikov profile, as in kernel-based tracking, Comaniciu et al.
        /// 2003, with a floor), so the box corners, usually background, count
        /// less; 1 gives plain NCC. The window's variance is weighted alike
        /// ([`bayestrack_appearance::NccTemplate::set_weighted`]).
        pub border_weight: f64 = 0.25;
        /// Search margin on each side of the prediction, as a fraction of the
        /// template side `sqrt(tw th)` (0.75): a search window of 2.5 target
        /// sizes, as in KCF's padding of 1.5.
        pub search_margin: f64 = 0.75;
        /// Ratio between neighbouring scales searched (1.03; DSST's scale step
        /// is 1.02 over 33 scales; with three scales and the parabola through
        /// their scores, a coarser step sees the change of a few frames).
        pub scale_step: f64 = 1.03;
        /// Fraction `k` of the estimated log-scale change applied per frame
        /// (0.5): `s <- s q^(k v)` with `v` the vertex of the parabola through
        /// the three scales' scores, in `[-1, 1]`. A first-order filter on the
        /// scale, which averages the noisy per-frame scale evidence.
        pub scale_gain: f64 = 0.5;
        /// Factor applied to the score of the two scales other than the
        /// current one (0.995): a scale change needs a clearer match than a
        /// translation (SAMF uses a similar scale weight).
        pub scale_penalty: f64 = 0.995;
        /// Smallest scale relative to the initial box (0.2).
        pub min_scale: f64 = 0.2;
        /// Largest scale relative to the initial box (5).
        pub max_scale: f64 = 5.0;
        /// Weight `b` of the motion prior: the score at offset `d` from the
        /// prediction (template pixels) is lowered by `b (d / m)^2`, `m` the
        /// search margin (0.1): breaks near-ties in favour of smooth motion.
        pub motion_penalty: f64 = 0.1;
        /// Gain `g` of the velocity estimate (0.5): the velocity is the
        /// displacement smoothed over about two frames.
        pub velocity_gain: f64 = 0.5;
        /// Template learning rate `a` (0.2, a time constant of 5 frames; MOSSE
        /// adapts its filter at 0.125 per frame). Raw-pixel templates need fast
        /// adaptation under pose and illumination change; the scale does not
        /// drift with them because it is measured against the initial template
        /// ([`NccScaleConfig::anchor_weight`]).
        pub update_rate: f64 = 0.2;
        /// Score the match needs for the template update (0.5): a weaker match
        /// may be an occluder or background, which would corrupt the template.
        pub update_threshold: f64 = 0.5;
        /// Weight `l` of the initial template when choosing among the scales
        /// (1): each scale's peak is scored `(1 - l) NCC_adaptive + l NCC_initial`.
        /// The initial template fixes what scale 1 means; an adapted template
        /// lets the scale drift (a template updated from slightly zoomed
        /// windows prefers zooming further).
        pub anchor_weight: f64 = 1.0;
        /// Score below which the target is reported lost (0.35).
        pub lost_threshold: f64 = 0.35;
        /// Factor on the search margin of the wide search (2): a match weaker
        /// than [`NccScaleConfig::update_threshold`] is searched for again in
        /// the wide window, as is every frame after a loss.
        pub wide_margin: f64 = 2.0;
    }
    check check_ncc_scale;
}

fn check_ncc_scale(c: &NccScaleConfig) -> std::result::Result<(), String> {
    c.validate().map_err(|e| e.to_string())
}

impl NccScaleConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value, reason| {
            Err(TrackerError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(4..=1 << 20).contains(&self.template_area) {
            return bad(
                "template_area",
                self.template_area as f64,
                "must be in 4..=2^20 pixels",
            );
        }
        if !(self.search_margin.is_finite()
            && self.search_margin > 0.0
            && self.search_margin <= 4.0)
        {
            return bad("search_margin", self.search_margin, "must be in (0, 4]");
        }
        if !(self.scale_step.is_finite() && self.scale_step >= 1.0 && self.scale_step <= 2.0) {
            return bad("scale_step", self.scale_step, "must be in [1, 2]");
        }
        for (name, v) in [
            ("scale_penalty", self.scale_penalty),
            ("scale_gain", self.scale_gain),
            ("border_weight", self.border_weight),
            ("motion_penalty", self.motion_penalty),
            ("anchor_weight", self.anchor_weight),
            ("velocity_gain", self.velocity_gain),
            ("update_rate", self.update_rate),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(name, v, "must be in [0, 1]");
            }
        }
        for (name, v) in [
            ("update_threshold", self.update_threshold),
            ("lost_threshold", self.lost_threshold),
        ] {
            if !(-1.0..=1.0).contains(&v) {
                return bad(name, v, "an NCC threshold must be in [-1, 1]");
            }
        }
        if !(self.min_scale.is_finite() && self.min_scale > 0.0 && self.min_scale <= 1.0) {
            return bad("min_scale", self.min_scale, "must be in (0, 1]");
        }
        if !(self.max_scale.is_finite() && self.max_scale >= 1.0) {
            return bad("max_scale", self.max_scale, "must be finite and >= 1");
        }
        if !(self.wide_margin.is_finite() && self.wide_margin >= 1.0 && self.wide_margin <= 4.0) {
            return bad("wide_margin", self.wide_margin, "must be in [1, 4]");
        }
        Ok(())
    }
}

/// The running state after `init`.
#[derive(Debug, Clone)]
struct State {
    /// Initial box size (frame pixels).
    w0: f64,
    h0: f64,
    /// Template size and frame pixels per template pixel at scale 1.
    tw: usize,
    th: usize,
    rx: f64,
    ry: f64,
    /// Centre (0-based), velocity, scale.
    cx: f64,
    cy: f64,
    vx: f64,
    vy: f64,
    scale: f64,
    /// The unnormalised template (gray levels) and its NCC form.
    raw: Image<f32>,
    template: NccTemplate,
    /// Template weights along x and y.
    kx: Vec<f32>,
    ky: Vec<f32>,
    /// The initial template, NCC form.
    anchor: NccTemplate,
    /// Whether the previous frame lost the target.
    lost: bool,
}

/// The fast NCC tracker with scale; see the module docs.
pub type NccScaleTracker = Shell<NccScaleCore>;

/// The model of [`NccScaleTracker`].
#[derive(Debug, Clone)]
pub struct NccScaleCore {
    config: NccScaleConfig,
    state: Option<State>,
    scratch: Scratch,
}

/// Buffers of the search: gray region, search patches, score maps.
#[derive(Debug, Clone)]
struct Scratch {
    region: Region,
    patch: Vec<f32>,
    best_patch: Vec<f32>,
    scores: Vec<f32>,
    best_scores: Vec<f32>,
    anchor_scores: Vec<f32>,
    /// The first search's best patch and scores during a second look.
    kept_patch: Vec<f32>,
    kept_scores: Vec<f32>,
    search: NccSearch,
}

/// The outcome of a search over the three scales.
#[derive(Debug, Clone, Copy)]
struct Found {
    /// Search margin `m` and patch size.
    m: usize,
    pw: usize,
    /// Best corner (in `best_patch`), its scale factor `sigma` and raw
    /// (adaptive template) score.
    bx: usize,
    by: usize,
    sigma: f64,
    score: f64,
    /// Sub-pixel offsets of the peak.
    dx: f64,
    dy: f64,
    /// Scale-selection scores at `1/q`, `1`, `q` (NaN if not searched).
    per_scale: [f64; 3],
    evaluations: usize,
}

impl Scratch {
    /// Searches the three scales around the prediction `(px, py)` with
    /// margin `m`; leaves the best scale's patch and scores in `best_*`.
    fn search(
        &mut self,
        s: &State,
        c: &NccScaleConfig,
        frame: &ImageView<'_, u8>,
        (px, py): (f64, f64),
        m: usize,
    ) -> Result<Found> {
        let (tw, th) = (s.tw, s.th);
        let (pw, ph) = (tw + 2 * m, th + 2 * m);
        let q = c.scale_step;
        let mut best = (f64::NEG_INFINITY, 0usize, 0usize, 1.0f64, 0.0f64);
        let mut per_scale = [f64::NAN; 3];
        let mut evaluations = 0;
        let big = s.scale * q;
        let (hw, hh) = (pw as f64 * s.rx * big / 2.0, ph as f64 * s.ry * big / 2.0);
        self.region.load(frame, px, py, hw, hh)?;
        let n = 2 * m + 1;
        let full = Rect::new(0, 0, n, n);
        let mut best_rect = full;
        // The current scale's peak, where the other scales look.
        let mut centre = (m, m);
        for sigma in [1.0, 1.0 / q, q] {
            let scale = s.scale * sigma;
            if sigma != 1.0 && !(c.min_scale..=c.max_scale).contains(&scale) {
                continue;
            }
            self.region
                .sample(px, py, s.rx * scale, s.ry * scale, pw, ph, &mut self.patch)?;
            let view = ImageView::from_slice(&self.patch, pw, ph, 1, pw)?;
            let corners = if sigma == 1.0 {
                full
            } else {
                // The same frame point at this sampling.
                let at = |v: usize| {
                    let d = (v as f64 - m as f64) / sigma;
                    (m as f64 + d).round().clamp(0.0, (n - 1) as f64) as usize
                };
                let (x, y) = (at(centre.0), at(centre.1));
                let (x0, y0) = (
                    x.saturating_sub(REFINE_RADIUS),
                    y.saturating_sub(REFINE_RADIUS),
                );
                let (x1, y1) = (
                    (x + REFINE_RADIUS).min(n - 1),
                    (y + REFINE_RADIUS).min(n - 1),
                );
                Rect::new(x0, y0, x1 - x0 + 1, y1 - y0 + 1)
            };
            self.search
                .map_into(view, &s.template, corners, &mut self.scores)?;
            evaluations += corners.area();
            let hit = prior_peak(&self.scores, corners, m, c.motion_penalty);
            if sigma == 1.0 {
                centre = (hit.1, hit.2);
            }
            let sigma_weight = if sigma == 1.0 { 1.0 } else { c.scale_penalty };
            let combined = if c.anchor_weight > 0.0 {
                let window = Rect::new(hit.1, hit.2, tw, th);
                let a = anchored(
                    &mut self.search,
                    view,
                    &s.anchor,
                    window,
                    &mut self.anchor_scores,
                )?;
                (1.0 - c.anchor_weight) * hit.0 + c.anchor_weight * a
            } else {
                hit.0
            };
            let weighted = combined * sigma_weight;
            per_scale[if sigma < 1.0 {
                0
            } else if sigma > 1.0 {
                2
            } else {
                1
            }] = weighted;
            if weighted > best.0 {
                best = (weighted, hit.1, hit.2, sigma, hit.3);
                best_rect = corners;
                std::mem::swap(&mut self.patch, &mut self.best_patch);
                std::mem::swap(&mut self.scores, &mut self.best_scores);
            }
        }
        let (_, bx, by, sigma, score) = best;
        let r = best_rect;
        let at = |x: usize, y: usize| f64::from(self.best_scores[(y - r.y) * r.width + (x - r.x)]);
        let dx = if bx > r.x && bx + 1 < r.right() {
            parabola(at(bx - 1, by), at(bx, by), at(bx + 1, by))
        } else {
            0.0
        };
        let dy = if by > r.y && by + 1 < r.bottom() {
            parabola(at(bx, by - 1), at(bx, by), at(bx, by + 1))
        } else {
            0.0
        };
        Ok(Found {
            m,
            pw,
            bx,
            by,
            sigma,
            score,
            dx,
            dy,
            per_scale,
            evaluations,
        })
    }
}

/// Frame pixels per template pixel for a box, and the template size.
fn template_geometry(w: f64, h: f64, area: usize) -> (usize, usize, f64, f64) {
    let r = (w * h / area as f64).sqrt().max(1.0);
    let tw = ((w / r).round() as usize).max(2);
    let th = ((h / r).round() as usize).max(2);
    (tw, th, w / tw as f64, h / th as f64)
}

/// The gray frame around one centre, ready for area resampling at any
/// scale (see [`bayestrack_image::AreaSampler`]): the luma of the frame
/// region within `(half_w, half_h)` of `(cx, cy)` (clipped to the frame)
/// and its summed-area table.
#[derive(Debug, Clone)]
struct Region {
    gray: Image<f32>,
    sampler: AreaSampler,
    x0: usize,
    y0: usize,
}

impl Region {
    fn new() -> Result<Self> {
        Ok(Self {
            gray: Image::new(1, 1, 1, 0.0)?,
            sampler: AreaSampler::default(),
            x0: 0,
            y0: 0,
        })
    }

    fn load(
        &mut self,
        frame: &ImageView<'_, u8>,
        cx: f64,
        cy: f64,
        half_w: f64,
        half_h: f64,
    ) -> Result<()> {
        let clip = |lo: f64, hi: f64, n: usize| -> (usize, usize) {
            let a = (lo - 1.0).floor().clamp(0.0, n as f64 - 1.0) as usize;
            let b = ((hi + 1.0).ceil().clamp(0.0, n as f64 - 1.0) as usize).max(a);
            (a, b + 1 - a)
        };
        let (x0, w) = clip(cx - half_w, cx + half_w, frame.width());
        let (y0, h) = clip(cy - half_h, cy + half_h, frame.height());
        gray_region_into(*frame, Rect::new(x0, y0, w, h), 1, &mut self.gray)?;
        self.sampler.compute(self.gray.view())?;
        self.x0 = x0;
        self.y0 = y0;
        Ok(())
    }

    /// Fills `out` (`pw x ph`): patch pixel `(u, v)` is the mean of the
    /// frame over the `rx x ry` cell centred on
    /// `(cx + (u - (pw - 1)/2) rx, cy + (v - (ph - 1)/2) ry)`.
    #[allow(clippy::too_many_arguments)]
    fn sample(
        &mut self,
        cx: f64,
        cy: f64,
        rx: f64,
        ry: f64,
        pw: usize,
        ph: usize,
        out: &mut Vec<f32>,
    ) -> Result<()> {
        // Area coordinates: pixel i covers [i, i + 1], its centre is i + 0.5.
        let ox = cx + 0.5 - self.x0 as f64 - pw as f64 / 2.0 * rx;
        let oy = cy + 0.5 - self.y0 as f64 - ph as f64 / 2.0 * ry;
        out.resize(pw * ph, 0.0);
        let mut view = ImageViewMut::from_slice(out, pw, ph, 1, pw)?;
        self.sampler.sample_into(ox, oy, rx, ry, &mut view)?;
        Ok(())
    }
}

/// The peak of a score map over the corners `rect` of a search whose
/// prediction sits at corner `(m, m)`, under the motion prior:
/// `(score - b (d / m)^2, x, y, score)` with `d` the distance from `(m, m)`
/// and `(x, y)` absolute corners.
fn prior_peak(scores: &[f32], rect: Rect, m: usize, b: f64) -> (f64, usize, usize, f64) {
    let mf = m.max(1) as f64;
    let k = b / (mf * mf);
    let mut best = (f64::NEG_INFINITY, rect.x, rect.y, 0.0);
    for (j, row) in scores.chunks_exact(rect.width).enumerate() {
        let dy = (rect.y + j) as f64 - m as f64;
        for (i, &v) in row.iter().enumerate() {
            let dx = (rect.x + i) as f64 - m as f64;
            let v = f64::from(v);
            let w = v - k * (dx * dx + dy * dy);
            if w > best.0 {
                best = (w, rect.x + i, rect.y + j, v);
            }
        }
    }
    best
}

/// Half-size, in template pixels, of the neighbourhood searched at the
/// two other scales around the current scale's peak (mapped to their
/// sampling): the peak moves by `d (1 - 1/q)` there, under a pixel for
/// any offset `d` of the search.
const REFINE_RADIUS: usize = 2;

/// One axis of the template weights: `f + (1 - f) (1 - x^2)`, `x` the
/// normalised distance of the pixel centre from the middle, in `(-1, 1)`.
fn kernel_profile(n: usize, floor: f64) -> Vec<f32> {
    let c = (n as f64 - 1.0) / 2.0;
    let half = n as f64 / 2.0;
    (0..n)
        .map(|u| {
            let x = (u as f64 - c) / half;
            (floor + (1.0 - floor) * (1.0 - x * x).max(0.0)) as f32
        })
        .collect()
}

/// NCC of `template` with the window of `patch` at `window`.
fn anchored(
    search: &mut NccSearch,
    patch: ImageView<'_, f32>,
    template: &NccTemplate,
    window: Rect,
    scratch: &mut Vec<f32>,
) -> Result<f64> {
    let at = Rect::new(window.x, window.y, 1, 1);
    Ok(search.map_into(patch, template, at, scratch)?.score)
}

/// Vertex offset of the parabola through `(-1, a)`, `(0, b)`, `(1, c)`,
/// clamped to `[-0.5, 0.5]`; 0 when `b` is not a strict peak.
fn parabola(a: f64, b: f64, c: f64) -> f64 {
    let den = a - 2.0 * b + c;
    if den < 0.0 {
        (0.5 * (a - c) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

impl NccScaleTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a bad configuration.
    pub fn new(config: NccScaleConfig) -> Result<Self> {
        Ok(Shell::wrap(NccScaleCore::new(config)?))
    }
}

impl NccScaleCore {
    /// The model of [`NccScaleTracker::new`].
    ///
    /// # Errors
    /// As [`NccScaleTracker::new`].
    pub fn new(config: NccScaleConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            config,
            state: None,
            scratch: Scratch {
                region: Region::new()?,
                patch: Vec::new(),
                best_patch: Vec::new(),
                scores: Vec::new(),
                best_scores: Vec::new(),
                anchor_scores: Vec::new(),
                kept_patch: Vec::new(),
                kept_scores: Vec::new(),
                search: NccSearch::new(),
            },
        })
    }

    /// The configuration.
    pub fn config(&self) -> &NccScaleConfig {
        &self.config
    }

    /// The current scale relative to the initial box (`None` before `init`).
    pub fn scale(&self) -> Option<f64> {
        self.state.as_ref().map(|s| s.scale)
    }

    /// The template size in template pixels (`None` before `init`).
    pub fn template_size(&self) -> Option<(usize, usize)> {
        self.state.as_ref().map(|s| (s.tw, s.th))
    }
}

fn bbox_of(s: &State) -> BBox {
    let (w, h) = (s.w0 * s.scale, s.h0 * s.scale);
    BBox::new(
        s.cx - (w - 1.0) / 2.0 + 1.0,
        s.cy - (h - 1.0) / 2.0 + 1.0,
        w,
        h,
    )
}

impl TrackerCore for NccScaleCore {
    fn name(&self) -> &'static str {
        NAME
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn needs(&self) -> Needs {
        Needs::INPUT
    }

    fn start(&mut self, planes: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (frame, target) = (planes.input(), target.bbox);
        let (w0, h0) = (target.width, target.height);
        let (tw, th, rx, ry) = template_geometry(w0, h0, self.config.template_area);
        let (cx, cy) = target.center();
        let (cx, cy) = (cx - 1.0, cy - 1.0);
        let (hw, hh) = (tw as f64 * rx / 2.0, th as f64 * ry / 2.0);
        let sc = &mut self.scratch;
        sc.region.load(&frame, cx, cy, hw, hh)?;
        sc.region.sample(cx, cy, rx, ry, tw, th, &mut sc.patch)?;
        let raw = Image::from_vec(tw, th, 1, sc.patch.clone())?;
        let kx = kernel_profile(tw, self.config.border_weight);
        let ky = kernel_profile(th, self.config.border_weight);
        let mut template = NccTemplate::default();
        template.set_weighted(raw.view(), &kx, &ky)?;
        self.state = Some(State {
            w0,
            h0,
            tw,
            th,
            rx,
            ry,
            cx,
            cy,
            vx: 0.0,
            vy: 0.0,
            scale: 1.0,
            raw,
            anchor: template.clone(),
            kx,
            ky,
            template,
            lost: false,
        });
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let frame = planes.input();
        let c = self.config;
        let Some(s) = self.state.as_mut() else {
            return Err(TrackerError::NotInitialised);
        };
        let (tw, th) = (s.tw, s.th);
        let margin = (c.search_margin * ((tw * th) as f64).sqrt()).ceil();
        let wide = ((margin * c.wide_margin).ceil() as usize).max(2);
        let m = if s.lost {
            wide
        } else {
            (margin as usize).max(2)
        };
        let (px, py) = (s.cx + s.vx, s.cy + s.vy);
        let mut found = self.scratch.search(s, &c, &frame, (px, py), m)?;
        // A weak match may mean the target jumped out of the window (an
        // abrupt camera motion): look again in the wide window and keep
        // whichever match is better.
        if found.score < c.update_threshold && m < wide {
            let sc = &mut self.scratch;
            std::mem::swap(&mut sc.best_patch, &mut sc.kept_patch);
            std::mem::swap(&mut sc.best_scores, &mut sc.kept_scores);
            let again = sc.search(s, &c, &frame, (px, py), wide)?;
            let evaluations = found.evaluations + again.evaluations;
            if again.score > found.score {
                found = again;
            } else {
                std::mem::swap(&mut sc.best_patch, &mut sc.kept_patch);
                std::mem::swap(&mut sc.best_scores, &mut sc.kept_scores);
            }
            found.evaluations = evaluations;
        }
        let Found {
            m,
            pw,
            bx,
            by,
            sigma,
            score,
            dx,
            dy,
            per_scale,
            evaluations,
            ..
        } = found;
        let q = c.scale_step;
        let lost = score.is_nan() || score < c.lost_threshold;
        let (ox, oy) = (s.cx, s.cy);
        if lost {
            s.cx = px;
            s.cy = py;
            s.vx = 0.0;
            s.vy = 0.0;
        } else {
            let scale = s.scale * sigma;
            s.cx = px + (bx as f64 + dx - m as f64) * s.rx * scale;
            s.cy = py + (by as f64 + dy - m as f64) * s.ry * scale;
            // Log-scale step: the vertex of the parabola through the three
            // scales' scores (in units of log q), or the best scale's when
            // the scores are not concave, times the gain.
            let [lo, mid, hi] = per_scale;
            let vertex = if lo.is_finite() && hi.is_finite() && lo - 2.0 * mid + hi < 0.0 {
                (0.5 * (lo - hi) / (lo - 2.0 * mid + hi)).clamp(-1.0, 1.0)
            } else {
                sigma.ln() / q.ln().max(f64::MIN_POSITIVE)
            };
            let vertex = if vertex.is_finite() { vertex } else { 0.0 };
            s.scale = (s.scale * q.powf(c.scale_gain * vertex)).clamp(c.min_scale, c.max_scale);
            let g = c.velocity_gain;
            s.vx = g * (s.cx - ox) + (1.0 - g) * s.vx;
            s.vy = g * (s.cy - oy) + (1.0 - g) * s.vy;
            if score >= c.update_threshold && c.update_rate > 0.0 {
                let a = c.update_rate as f32;
                for (r, raw_row) in s.raw.as_mut_slice().chunks_exact_mut(tw).enumerate() {
                    let src = &self.scratch.best_patch[(by + r) * pw + bx..(by + r) * pw + bx + tw];
                    for (t, &w) in raw_row.iter_mut().zip(src) {
                        *t = (1.0 - a) * *t + a * w;
                    }
                }
                // A template that went flat keeps its previous NCC form
                // (`set` changes nothing when it fails).
                let _flat = s.template.set_weighted(s.raw.view(), &s.kx, &s.ky).is_err();
            }
        }
        // Keep the centre on the frame (a target may leave it partly).
        s.cx = s.cx.clamp(0.0, (frame.width() - 1) as f64);
        s.cy = s.cy.clamp(0.0, (frame.height() - 1) as f64);
        s.lost = lost;
        Ok(Estimate {
            bbox: bbox_of(s),
            pose: None,
            particles: 0,
            evaluations,
            lost,
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::tracker::Tracker;
    use rand::{RngExt, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Smooth random texture: a sum of a few sinusoids with random
    /// frequencies and phases, in `0..=255`.
    pub(crate) fn texture(seed: u64) -> impl Fn(f64, f64) -> f64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let waves: Vec<(f64, f64, f64)> = (0..8)
            .map(|_| {
                (
                    rng.random_range(-0.6..0.6),
                    rng.random_range(-0.6..0.6),
                    rng.random_range(0.0..6.3),
                )
            })
            .collect();
        move |x, y| {
            let v: f64 = waves
                .iter()
                .map(|(a, b, p)| (a * x + b * y + p).sin())
                .sum();
            128.0 + 14.0 * v
        }
    }

    /// A synthetic sequence: a textured `w x h` target (its texture
    /// stretched with it) on a different textured background, centre and
    /// size per frame given by `path`; Gaussian pixel noise `noise`; gray
    /// or RGB. Returns the frames and the true boxes.
    pub(crate) fn scene(
        frames: usize,
        rgb: bool,
        noise: f64,
        path: impl Fn(usize) -> (f64, f64, f64, f64),
    ) -> (Vec<Image<u8>>, Vec<BBox>) {
        let (fw, fh) = (160usize, 120usize);
        let bg = texture(11);
        let fg = texture(23);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let mut out = Vec::new();
        let mut boxes = Vec::new();
        for k in 0..frames {
            let (cx, cy, w, h) = path(k);
            let mut data = Vec::with_capacity(fw * fh * 3);
            for y in 0..fh {
                for x in 0..fw {
                    let (xf, yf) = (x as f64, y as f64);
                    let (u, v) = ((xf - cx) / w, (yf - cy) / h);
                    let inside = u.abs() <= 0.5 && v.abs() <= 0.5;
                    // the target's texture lives in its own (normalised) frame
                    let g = if inside {
                        // a darker, contrasty target
                        0.6 * fg(u * 40.0, v * 40.0) + 30.0 * (u * 9.0).cos()
                    } else {
                        bg(xf, yf)
                    };
                    let z: f64 = StandardNormal.sample(&mut rng);
                    let g = (g + noise * z).clamp(0.0, 255.0);
                    if rgb {
                        // an orange target on a green-grey background
                        let p = if inside {
                            [(g * 1.3 + 40.0).min(255.0), g * 0.7, g * 0.4]
                        } else {
                            [g * 0.8, g, g * 0.85]
                        };
                        data.extend(p.map(|v| v as u8));
                    } else {
                        data.push(g as u8);
                    }
                }
            }
            let ch = if rgb { 3 } else { 1 };
            out.push(Image::from_vec(fw, fh, ch, data).unwrap());
            boxes.push(BBox::new(
                cx - (w - 1.0) / 2.0 + 1.0,
                cy - (h - 1.0) / 2.0 + 1.0,
                w,
                h,
            ));
        }
        (out, boxes)
    }

    /// Runs a tracker over a scene and returns the boxes (first = truth).
    pub(crate) fn run(t: &mut dyn Tracker, frames: &[Image<u8>], first: BBox) -> Vec<BBox> {
        t.init(frames[0].view(), first).unwrap();
        let mut boxes = vec![first];
        for f in &frames[1..] {
            boxes.push(t.step(f.view()).unwrap().bbox);
        }
        boxes
    }

    /// Worst centre error and worst relative width error.
    pub(crate) fn errors(got: &[BBox], truth: &[BBox]) -> (f64, f64) {
        got.iter()
            .zip(truth)
            .fold((0.0f64, 0.0f64), |(c, s), (g, t)| {
                let (gx, gy) = g.center();
                let (tx, ty) = t.center();
                (
                    c.max((gx - tx).hypot(gy - ty)),
                    s.max((g.width / t.width - 1.0).abs()),
                )
            })
    }

    /// A target moving on a curve while growing by 40 % (or shrinking).
    pub(crate) fn growing(k: usize, grow: f64) -> (f64, f64, f64, f64) {
        let t = k as f64;
        let s = grow.powf(t / 60.0);
        (
            50.0 + 0.9 * t,
            60.0 + 12.0 * (t / 15.0).sin(),
            24.0 * s,
            30.0 * s,
        )
    }

    #[test]
    fn follows_position_and_scale_of_a_growing_target() {
        for (rgb, grow) in [(false, 1.4), (true, 1.4), (false, 0.7)] {
            let (frames, truth) = scene(61, rgb, 3.0, |k| growing(k, grow));
            let mut t = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
            let got = run(&mut t, &frames, truth[0]);
            let (centre, size) = errors(&got, &truth);
            assert!(centre < 3.0, "rgb {rgb} grow {grow}: centre error {centre}");
            assert!(size < 0.12, "rgb {rgb} grow {grow}: size error {size}");
            let last = got.last().unwrap().width / truth[0].width;
            assert!(
                (last / grow - 1.0).abs() < 0.08,
                "grow {grow}: scale {last}"
            );
        }
    }

    #[test]
    fn keeps_the_scale_of_a_target_that_does_not_change_size() {
        let (frames, truth) = scene(80, false, 8.0, |k| growing(k, 1.0));
        let mut t = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
        let got = run(&mut t, &frames, truth[0]);
        let (centre, size) = errors(&got, &truth);
        assert!(centre < 3.0 && size < 0.08, "centre {centre}, size {size}");
    }

    #[test]
    fn finds_a_target_that_jumps_out_of_the_search_window() {
        // A 34 px jump at frame 10: beyond the normal margin (20 px here),
        // within the wide one.
        let path = |k: usize| {
            let x = 50.0 + k as f64 + if k >= 10 { 34.0 } else { 0.0 };
            (x, 60.0, 24.0, 30.0)
        };
        let (frames, truth) = scene(16, false, 3.0, path);
        let last_error = |wide_margin| {
            let config = NccScaleConfig {
                wide_margin,
                ..NccScaleConfig::default()
            };
            let mut t = NccScaleTracker::new(config).unwrap();
            let got = run(&mut t, &frames, truth[0]);
            errors(&got[10..], &truth[10..]).0
        };
        assert!(last_error(2.0) < 2.0, "{}", last_error(2.0));
        assert!(last_error(1.0) > 10.0, "{}", last_error(1.0));
    }

    #[test]
    fn deterministic() {
        let (frames, truth) = scene(20, true, 3.0, |k| growing(k, 1.2));
        let mut a = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
        let mut b = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
        assert_eq!(
            run(&mut a, &frames, truth[0]),
            run(&mut b, &frames, truth[0])
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        for bad in [
            NccScaleConfig {
                template_area: 1,
                ..NccScaleConfig::default()
            },
            NccScaleConfig {
                search_margin: 0.0,
                ..NccScaleConfig::default()
            },
            NccScaleConfig {
                scale_step: 0.9,
                ..NccScaleConfig::default()
            },
            NccScaleConfig {
                update_rate: f64::NAN,
                ..NccScaleConfig::default()
            },
            NccScaleConfig {
                lost_threshold: 2.0,
                ..NccScaleConfig::default()
            },
            NccScaleConfig {
                min_scale: 0.0,
                ..NccScaleConfig::default()
            },
        ] {
            assert!(matches!(
                NccScaleTracker::new(bad),
                Err(TrackerError::InvalidParameter { .. })
            ));
        }
        let mut t = NccScaleTracker::new(NccScaleConfig::default()).unwrap();
        let gray = Image::from_fn(40, 30, |x, y| ((x * 7 + y * 3) % 50) as u8).unwrap();
        assert!(matches!(
            t.step(gray.view()),
            Err(TrackerError::NotInitialised)
        ));
        let two = Image::new(40, 30, 2, 0u8).unwrap();
        assert!(matches!(
            t.init(two.view(), BBox::new(1.0, 1.0, 5.0, 5.0)),
            Err(TrackerError::Channels { .. })
        ));
        assert!(matches!(
            t.init(gray.view(), BBox::new(38.0, 1.0, 5.0, 5.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        let flat = Image::new(40, 30, 1, 7u8).unwrap();
        assert!(matches!(
            t.init(flat.view(), BBox::new(1.0, 1.0, 8.0, 8.0)),
            Err(TrackerError::Appearance(_))
        ));
        t.init(gray.view(), BBox::new(5.0, 5.0, 10.0, 8.0)).unwrap();
        let other = Image::new(41, 30, 1, 0u8).unwrap();
        assert!(matches!(
            t.step(other.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        assert!(matches!(
            t.step(two.view()),
            Err(TrackerError::FrameSizeChanged { .. }) | Err(TrackerError::Channels { .. })
        ));
    }
}
