//! Dong and Chen's (paper 004) correlation trackers: the MAD template tracker (sec. 2) and
//! the particle-filter correlation tracker (sec. 3).
//!
//! Both take the gray template inside the initial box and compare it with
//! frame windows by the mean absolute difference (eq. 1)
//!
//! `MAD(i, j) = 1/(M N) sum_m sum_n |T(m, n) - F(m + i, n + j)|`
//!
//! under a translation model (eq. 2). [`MadTracker`] keeps the window of
//! smallest MAD of an exhaustive search (the "peak"); [`PfCorrelationTracker`]
//! keeps `Ns` particles `T^i = (TX^i, TY^i)` (eq. 3), spread uniformly around
//! the initial centre (eq. 4), moved by a first-order ARP (eq. 5-6), weighted
//! by `p(z | x^i) = exp(-MAD^i / (2 sigma^2))` (eq. 7), reports the weighted
//! mean (eq. 8) and resamples.

use bayestrack_appearance::{AppearanceError, MadLikelihood, MadSearch, mad};
use bayestrack_image::{BBox, Image, ImageView, Rect};
use bayestrack_options::{Codec, above, choice, options};
use bayestrack_particle::{
    Degenerate, ParticleFilter, ParticleSet, Proposal, ResampleTiming, Resampling, stream_rng,
};
use nalgebra::Vector2;
use rand::{Rng, RngExt};

use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Needs, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

/// Where [`MadTracker`] searches for the template.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SearchArea {
    /// The whole frame: the `M x N` parameter space `E(i, j)` of sec. 2 (4).
    Frame,
    /// The previous match grown by `margin` pixels on every side, clipped
    /// to the frame.
    Window {
        /// Pixels added on each side of the previous window.
        margin: usize,
    },
    /// A fixed region of the frame (0-based pixels); it must hold the
    /// template.
    Region(Rect),
}

options! {
    /// Settings of [`MadTracker`], each an option of `bayestrack track
    /// --tracker mad --set key=value`.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct MadTrackerConfig {
        /// Where to search: `frame` (the whole frame, the `M x N` parameter
        /// space `E(i, j)` of sec. 2 (4)), `window:M` (the previous match
        /// grown by `M` px on every side; 16, about three frames of the road
        /// scene's motion) or `region:X,Y,W,H` (a fixed 0-based region).
        pub search: SearchArea = SearchArea::Window { margin: 16 }, via SearchAreaCodec;
        /// The tracker reports the target lost when the best MAD (gray
        /// levels) exceeds this (20).
        pub lost_mad: f64 = 20.0, in 0.0..=255.0;
    }
}

/// Reads a [`SearchArea`]: `frame`, `window:M` or `region:X,Y,W,H`.
#[derive(Debug, Clone, Copy)]
pub struct SearchAreaCodec;

impl Codec<SearchArea> for SearchAreaCodec {
    fn type_name() -> &'static str {
        "search"
    }
    fn parse(s: &str) -> Option<SearchArea> {
        let s = s.trim();
        if s == "frame" {
            return Some(SearchArea::Frame);
        }
        if let Some(m) = s.strip_prefix("window:") {
            return Some(SearchArea::Window {
                margin: m.trim().parse().ok()?,
            });
        }
        let [x, y, w, h] = numbers::<usize, 4>(s.strip_prefix("region:")?)?;
        (w > 0 && h > 0).then_some(SearchArea::Region(Rect::new(x, y, w, h)))
    }
    fn format(v: &SearchArea) -> String {
        match v {
            SearchArea::Frame => "frame".into(),
            SearchArea::Window { margin } => format!("window:{margin}"),
            SearchArea::Region(r) => format!("region:{},{},{},{}", r.x, r.y, r.width, r.height),
        }
    }
    fn domain() -> String {
        "frame|window:M|region:X,Y,W,H (pixels, 0-based)".into()
    }
}

/// `N` comma-separated numbers.
fn numbers<T: std::str::FromStr, const N: usize>(s: &str) -> Option<[T; N]> {
    let v: Vec<T> = s
        .split(',')
        .map(|p| p.trim().parse().ok())
        .collect::<Option<_>>()?;
    v.try_into().ok()
}

/// Dong and Chen (paper 004) sec. 2: exhaustive MAD template matching under a translation
/// model. The template is the gray content of the initial box and is never
/// updated; each frame the window of smallest MAD (first in raster order on
/// ties) becomes the estimate.
pub type MadTracker = Shell<MadCore>;

/// The model of [`MadTracker`].
#[derive(Debug, Clone)]
pub struct MadCore {
    config: MadTrackerConfig,
    template: Image<u8>,
    /// Frame size.
    size: (usize, usize),
    search: MadSearch,
    window: Option<Rect>,
    last_mad: f64,
}

impl MadTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a NaN or negative `lost_mad`.
    pub fn new(config: MadTrackerConfig) -> Result<Self> {
        Ok(Shell::wrap(MadCore::new(config)?))
    }
}

impl MadCore {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a NaN or negative `lost_mad`.
    pub fn new(config: MadTrackerConfig) -> Result<Self> {
        if config.lost_mad.is_nan() || config.lost_mad < 0.0 {
            return Err(TrackerError::InvalidParameter {
                name: "lost_mad",
                value: config.lost_mad,
                reason: "must be a non-negative number",
            });
        }
        Ok(Self {
            config,
            template: Image::new(1, 1, 1, 0)?,
            size: (0, 0),
            search: MadSearch::new(),
            window: None,
            last_mad: 0.0,
        })
    }

    /// The settings.
    pub fn config(&self) -> &MadTrackerConfig {
        &self.config
    }

    /// The current window (0-based), `None` before `init`.
    pub fn window(&self) -> Option<Rect> {
        self.window
    }

    /// The MAD of the latest match (0 right after `init`).
    pub fn last_mad(&self) -> f64 {
        self.last_mad
    }

    fn region(&self, window: Rect) -> Rect {
        let (w, h) = self.size;
        match self.config.search {
            SearchArea::Frame => Rect::new(0, 0, w, h),
            SearchArea::Region(r) => r,
            SearchArea::Window { margin } => {
                let x0 = window.x.saturating_sub(margin);
                let y0 = window.y.saturating_sub(margin);
                let x1 = window.right().saturating_add(margin).min(w);
                let y1 = window.bottom().saturating_add(margin).min(h);
                Rect::new(x0, y0, x1 - x0, y1 - y0)
            }
        }
    }
}

impl TrackerCore for MadCore {
    fn name(&self) -> &'static str {
        "mad"
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn needs(&self) -> Needs {
        Needs::GRAY
    }

    /// # Errors
    /// [`AppearanceError::WindowOutside`] for a [`SearchArea::Region`]
    /// outside the frame and [`AppearanceError::TemplateLargerThanRegion`]
    /// when the template does not fit in it.
    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (w, h) = (frame.width(), frame.height());
        let rect = target.rect;
        if let SearchArea::Region(r) = self.config.search {
            if !r.fits_in(w, h) {
                return Err(AppearanceError::WindowOutside {
                    operation: "MadTracker search region",
                    window: r,
                    width: w,
                    height: h,
                }
                .into());
            }
            if rect.width > r.width || rect.height > r.height {
                return Err(AppearanceError::TemplateLargerThanRegion {
                    template_width: rect.width,
                    template_height: rect.height,
                    region: r,
                }
                .into());
            }
        }
        self.template = frame.gray()?.crop(rect)?.to_image();
        self.size = (w, h);
        self.window = Some(rect);
        self.last_mad = 0.0;
        Ok(())
    }

    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate> {
        let window = self.window.ok_or(TrackerError::NotInitialised)?;
        let region = self.region(window);
        let m = self
            .search
            .search(frame.gray()?, self.template.view(), region)?;
        let (tw, th) = (self.template.width(), self.template.height());
        let found = m.window(tw, th);
        self.window = Some(found);
        self.last_mad = m.mad;
        Ok(Estimate {
            bbox: BBox::from_rect(found),
            pose: None,
            particles: 0,
            evaluations: (region.width - tw + 1) * (region.height - th + 1),
            lost: m.mad > self.config.lost_mad,
        })
    }
}

/// The first-order ARP of eq. 5-6 that moves each particle.
///
/// `w` is drawn uniformly in `[-1, 1]`, independently per coordinate and
/// per particle (the paper writes one `w_{t-1}` for both coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArpMotion {
    /// Eq. 6 as printed: `TX_t = A1 TX_{t-1} + B1 w`, `TY_t = A2 TY_{t-1} + B2 w`.
    /// With `A = (1, 1)` a random walk: the particles do not move with the
    /// target unless the likelihood pulls them.
    Position {
        /// `(A1, A2)`.
        a: [f64; 2],
        /// `(B1, B2)` in pixels.
        b: [f64; 2],
    },
    /// Eq. 6 on the displacement: `T_t = T_{t-1} + v_{t-1} + B w`, where
    /// `v` follows the outputs (eq. 8): `v_t = v_{t-1} + g (T^opt_t -
    /// T^opt_{t-1} - v_{t-1})`, zero in the first frame. The uniform motion
    /// the paper assumes for the car ("pixel distance ... approximately
    /// equal") then moves the particles even where the likelihood is flat.
    Drift {
        /// `(B1, B2)` in pixels.
        b: [f64; 2],
        /// `g` in `[0, 1]`: 1 takes the last output displacement as it is,
        /// smaller values average it over about `1 / g` frames.
        gain: f64,
    },
    /// Sec. 3.2 read with a constant drift: `T_t = T_{t-1} + c + B w`. In
    /// frame 2 the tracker is the MAD tracker of sec. 2 (an exhaustive
    /// search of the template within `margin` pixels of the initial
    /// window); its match is frame 2's output and `c` is the displacement
    /// from the initial centre to it, kept for the rest of the sequence.
    /// The particles (spread by eq. 4 in frame 1) move by `c` in frame 2;
    /// "at the third frame" the particle filter takes over.
    ConstantDrift {
        /// `(B1, B2)` in pixels.
        b: [f64; 2],
        /// Pixels added on every side of the initial window for the frame-2
        /// MAD search.
        margin: usize,
    },
}

impl ArpMotion {
    fn check(&self) -> Result<()> {
        let (a, b) = match *self {
            ArpMotion::Position { a, b } => (a, b),
            ArpMotion::Drift { b, gain } => {
                if !(0.0..=1.0).contains(&gain) {
                    return Err(TrackerError::InvalidParameter {
                        name: "gain",
                        value: gain,
                        reason: "must be in [0, 1]",
                    });
                }
                ([1.0, 1.0], b)
            }
            ArpMotion::ConstantDrift { b, .. } => ([1.0, 1.0], b),
        };
        for (name, v) in [("A1", a[0]), ("A2", a[1])] {
            if !v.is_finite() {
                return Err(TrackerError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite",
                });
            }
        }
        for (name, v) in [("B1", b[0]), ("B2", b[1])] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(TrackerError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and non-negative",
                });
            }
        }
        Ok(())
    }
}

options! {
    /// Settings of [`PfCorrelationTracker`], each an option of `bayestrack
    /// track --tracker pf-correlation --set key=value` (the registry sets
    /// `seed` from `--seed`; `--set seed=S` overrides it).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct PfCorrelationConfig {
        /// `Ns`, the number of particles (15 in Dong and Chen (paper 004) sec. 3.3).
        pub particles: usize = 15, in 1..=1_000_000;
        /// `(b1, b2)` of eq. 4: the half-widths in pixels of the uniform
        /// initial spread around the initial centre (5, 5).
        pub spread: [f64; 2] = [5.0, 5.0], via PairCodec;
        /// The dynamics of eq. 5-6: `position:A1,A2,B1,B2`, `drift:B1,B2,G`
        /// (the default, `B = 4` px and gain 0.5) or
        /// `constant-drift:B1,B2,MARGIN` (see [`ArpMotion`]).
        pub motion: ArpMotion = ArpMotion::Drift { b: [4.0, 4.0], gain: 0.5 }, via ArpCodec;
        /// `sigma` of eq. 7 in gray levels: `p = exp(-MAD / (2 sigma^2))` (1.5).
        pub sigma: f64 = 1.5, in above(0.0);
        /// Resampling scheme, applied after the output of every frame
        /// (systematic).
        pub resampling: Resampling = Resampling::Systematic, via ResamplingCodec;
        /// Seed of every random stream of the tracker (0).
        pub seed: u64 = 0;
        /// The tracker reports the target lost when the MAD at its output
        /// exceeds this (gray levels; 20).
        pub lost_mad: f64 = 20.0, in 0.0..=255.0;
        /// Not in the paper: a cap on the MAD inside eq. 7,
        /// `p = exp(-min(MAD, cap) / (2 sigma^2))`. Windows worse than the cap
        /// are equally unlikely, so where no particle sees the target (an
        /// occlusion) the weights are flat and the particles coast with the
        /// ARP. `none` (the default) is eq. 7 as printed.
        pub mad_cap: Option<f64> = None;
    }
    check check_pf_correlation;
}

fn check_pf_correlation(c: &PfCorrelationConfig) -> std::result::Result<(), String> {
    c.check().map_err(|e| e.to_string())
}

choice! {
    /// Reads a [`Resampling`] scheme by its name.
    pub codec ResamplingCodec for Resampling {
        Multinomial = "multinomial",
        Residual = "residual",
        Systematic = "systematic",
        Stratified = "stratified",
    }
}

/// Reads `[f64; 2]` as `A,B` (finite).
#[derive(Debug, Clone, Copy)]
pub struct PairCodec;

impl Codec<[f64; 2]> for PairCodec {
    fn type_name() -> &'static str {
        "pair"
    }
    fn parse(s: &str) -> Option<[f64; 2]> {
        numbers::<f64, 2>(s).filter(|v| v.iter().all(|x| x.is_finite()))
    }
    fn format(v: &[f64; 2]) -> String {
        format!("{},{}", v[0], v[1])
    }
    fn domain() -> String {
        "A,B (two finite numbers)".into()
    }
}

/// Reads an [`ArpMotion`]: `position:A1,A2,B1,B2`, `drift:B1,B2,G` or
/// `constant-drift:B1,B2,MARGIN`.
#[derive(Debug, Clone, Copy)]
pub struct ArpCodec;

impl Codec<ArpMotion> for ArpCodec {
    fn type_name() -> &'static str {
        "arp"
    }
    fn parse(s: &str) -> Option<ArpMotion> {
        let s = s.trim();
        let m = if let Some(r) = s.strip_prefix("position:") {
            let [a1, a2, b1, b2] = numbers::<f64, 4>(r)?;
            ArpMotion::Position {
                a: [a1, a2],
                b: [b1, b2],
            }
        } else if let Some(r) = s.strip_prefix("drift:") {
            let [b1, b2, gain] = numbers::<f64, 3>(r)?;
            ArpMotion::Drift { b: [b1, b2], gain }
        } else {
            let (b, margin) = s.strip_prefix("constant-drift:")?.rsplit_once(',')?;
            ArpMotion::ConstantDrift {
                b: numbers::<f64, 2>(b)?,
                margin: margin.trim().parse().ok()?,
            }
        };
        m.check().is_ok().then_some(m)
    }
    fn format(v: &ArpMotion) -> String {
        match v {
            ArpMotion::Position { a, b } => format!("position:{},{},{},{}", a[0], a[1], b[0], b[1]),
            ArpMotion::Drift { b, gain } => format!("drift:{},{},{gain}", b[0], b[1]),
            ArpMotion::ConstantDrift { b, margin } => {
                format!("constant-drift:{},{},{margin}", b[0], b[1])
            }
        }
    }
    fn domain() -> String {
        "position:A1,A2,B1,B2|drift:B1,B2,G (G in [0, 1])|constant-drift:B1,B2,MARGIN (B >= 0 px)"
            .into()
    }
}

impl PfCorrelationConfig {
    fn check(&self) -> Result<()> {
        if self.particles == 0 {
            return Err(TrackerError::InvalidParameter {
                name: "particles",
                value: 0.0,
                reason: "need at least one particle",
            });
        }
        for (name, v) in [("b1", self.spread[0]), ("b2", self.spread[1])] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(TrackerError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and non-negative",
                });
            }
        }
        if self.lost_mad.is_nan() || self.lost_mad < 0.0 {
            return Err(TrackerError::InvalidParameter {
                name: "lost_mad",
                value: self.lost_mad,
                reason: "must be a non-negative number",
            });
        }
        if let Some(cap) = self.mad_cap
            && (cap.is_nan() || cap < 0.0)
        {
            return Err(TrackerError::InvalidParameter {
                name: "mad_cap",
                value: cap,
                reason: "must be a non-negative number",
            });
        }
        MadLikelihood::new(self.sigma)?;
        self.motion.check()
    }
}

/// What a particle is weighed against in one frame.
struct Observation<'a> {
    frame: ImageView<'a, u8>,
    template: ImageView<'a, u8>,
    likelihood: MadLikelihood,
    motion: ArpMotion,
    drift: Vector2<f64>,
    cap: f64,
}

/// Centre limits that keep a `tw x th` window inside a `w x h` frame.
fn clamp_centre(c: Vector2<f64>, tw: usize, th: usize, w: usize, h: usize) -> Vector2<f64> {
    let (hx, hy) = ((tw as f64 - 1.0) / 2.0, (th as f64 - 1.0) / 2.0);
    Vector2::new(
        c.x.clamp(hx, w as f64 - 1.0 - hx),
        c.y.clamp(hy, h as f64 - 1.0 - hy),
    )
}

impl Observation<'_> {
    /// Top-left of the template window centred (rounded) at `c`, inside
    /// the frame.
    fn corner(&self, c: &Vector2<f64>) -> (usize, usize) {
        let (tw, th) = (self.template.width(), self.template.height());
        let max_x = (self.frame.width() - tw) as f64;
        let max_y = (self.frame.height() - th) as f64;
        let x = (c.x - (tw as f64 - 1.0) / 2.0).round().clamp(0.0, max_x);
        let y = (c.y - (th as f64 - 1.0) / 2.0).round().clamp(0.0, max_y);
        (x as usize, y as usize)
    }

    fn mad_at(&self, c: &Vector2<f64>) -> std::result::Result<f64, AppearanceError> {
        let (x, y) = self.corner(c);
        mad(self.frame, self.template, x, y)
    }
}

/// Eq. 5-6 proposal with the eq. 7 weight (a bootstrap step).
struct ArpProposal;

impl<'a> Proposal<Vector2<f64>, Observation<'a>> for ArpProposal {
    /// The window is clamped inside the frame, so the MAD fails only if the
    /// template and frame disagree (channels): an error, not a zero weight.
    type Error = AppearanceError;
    type Scratch = ();
    fn propose<R: Rng + ?Sized>(
        &self,
        _k: usize,
        parent: &Vector2<f64>,
        z: &Observation<'a>,
        _scratch: &mut (),
        rng: &mut R,
    ) -> std::result::Result<(Vector2<f64>, f64), AppearanceError> {
        let w = Vector2::new(rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0));
        let moved = match z.motion {
            ArpMotion::Position { a, b } => {
                Vector2::new(a[0] * parent.x + b[0] * w.x, a[1] * parent.y + b[1] * w.y)
            }
            ArpMotion::Drift { b, .. } | ArpMotion::ConstantDrift { b, .. } => {
                parent + z.drift + Vector2::new(b[0] * w.x, b[1] * w.y)
            }
        };
        let (tw, th) = (z.template.width(), z.template.height());
        let x = clamp_centre(moved, tw, th, z.frame.width(), z.frame.height());
        let lw = z.likelihood.log_likelihood(z.mad_at(&x)?.min(z.cap))?;
        Ok((x, lw))
    }
}

/// Dong and Chen (paper 004) sec. 3: correlation tracking with a particle filter on the
/// window centre `(TX, TY)` (0-based pixel coordinates), built on
/// [`bayestrack_particle::ParticleFilter`].
///
/// Per frame, one step of the particle engine with
/// [`ResampleTiming::BeforeProposal`]: the previous frame's weighted set is
/// resampled, every particle moves by the ARP (eq. 6) and is weighted by
/// the MAD likelihood of its window (eq. 7, log domain); the output is the
/// weighted mean of the particles (eq. 8). The random streams are keyed by
/// `(seed, frame)`.
pub type PfCorrelationTracker = Shell<PfCorrelationCore>;

/// The model of [`PfCorrelationTracker`].
#[derive(Debug, Clone)]
pub struct PfCorrelationCore {
    config: PfCorrelationConfig,
    filter: ParticleFilter,
    likelihood: MadLikelihood,
    template: Image<u8>,
    set: Option<ParticleSet<Vector2<f64>>>,
    output: Vector2<f64>,
    drift: Vector2<f64>,
    window: Rect,
    search: MadSearch,
}

/// Stream ids of the tracker's random streams.
const INIT_STREAM: u64 = 0x0000_696e_6974;
const STEP_STREAM: u64 = 0x0000_7374_6570;

impl PfCorrelationTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for zero particles, a negative or
    /// non-finite spread, `B` or `lost_mad`, a non-finite `A`;
    /// [`TrackerError::Appearance`] for a `sigma` that is not positive.
    pub fn new(config: PfCorrelationConfig) -> Result<Self> {
        Ok(Shell::wrap(PfCorrelationCore::new(config)?))
    }
}

impl PfCorrelationCore {
    /// The model of a tracker with `config`.
    ///
    /// # Errors
    /// As [`PfCorrelationTracker::new`].
    pub fn new(config: PfCorrelationConfig) -> Result<Self> {
        config.check()?;
        Ok(Self {
            filter: ParticleFilter {
                resampling: config.resampling,
                timing: ResampleTiming::BeforeProposal,
                degenerate: Degenerate::IgnoreMeasurement,
                ..ParticleFilter::default()
            },
            likelihood: MadLikelihood::new(config.sigma)?,
            config,
            template: Image::new(1, 1, 1, 0)?,
            set: None,
            output: Vector2::zeros(),
            drift: Vector2::zeros(),
            window: Rect::new(0, 0, 1, 1),
            search: MadSearch::new(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &PfCorrelationConfig {
        &self.config
    }

    /// The particles (centres, 0-based) after the latest resampling.
    pub fn particles(&self) -> &[Vector2<f64>] {
        self.set.as_ref().map_or(&[], |s| s.particles())
    }

    /// The latest output centre (eq. 8), 0-based pixel coordinates.
    pub fn centre(&self) -> (f64, f64) {
        (self.output.x, self.output.y)
    }

    /// Frame 2 of [`ArpMotion::ConstantDrift`]: the MAD match within
    /// `margin` of the initial window gives the output and the drift `c`;
    /// every particle moves by `c`.
    fn measure_drift(&mut self, gray: ImageView<'_, u8>, margin: usize) -> Result<Estimate> {
        let (w, h) = (gray.width(), gray.height());
        let r = self.window;
        let x0 = r.x.saturating_sub(margin);
        let y0 = r.y.saturating_sub(margin);
        let x1 = r.right().saturating_add(margin).min(w);
        let y1 = r.bottom().saturating_add(margin).min(h);
        let region = Rect::new(x0, y0, x1 - x0, y1 - y0);
        let m = self.search.search(gray, self.template.view(), region)?;
        let (tw, th) = (self.template.width(), self.template.height());
        let (cx, cy) = m.window(tw, th).center();
        let out = Vector2::new(cx, cy);
        self.drift = out - self.output;
        let set = self.set.as_mut().ok_or(TrackerError::NotInitialised)?;
        for p in set.parts_mut().0 {
            *p = clamp_centre(*p + self.drift, tw, th, w, h);
        }
        self.output = out;
        Ok(Estimate {
            bbox: self.bbox_at(out),
            pose: None,
            particles: self.config.particles,
            evaluations: (region.width - tw + 1) * (region.height - th + 1),
            lost: m.mad > self.config.lost_mad,
        })
    }

    fn bbox_at(&self, c: Vector2<f64>) -> BBox {
        let (tw, th) = (self.template.width() as f64, self.template.height() as f64);
        // OTB centre = 0-based centre + 1.
        BBox::new(
            c.x + 1.0 - (tw - 1.0) / 2.0,
            c.y + 1.0 - (th - 1.0) / 2.0,
            tw,
            th,
        )
    }
}

impl TrackerCore for PfCorrelationCore {
    fn name(&self) -> &'static str {
        "pf-correlation"
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn needs(&self) -> Needs {
        Needs::GRAY
    }

    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (w, h) = (frame.width(), frame.height());
        let rect = target.rect;
        self.template = frame.gray()?.crop(rect)?.to_image();
        let (cx, cy) = rect.center();
        let centre = Vector2::new(cx, cy);
        let mut rng = stream_rng(&[self.config.seed, INIT_STREAM]);
        let [b1, b2] = self.config.spread;
        let particles = (0..self.config.particles)
            .map(|_| {
                let p = centre
                    + Vector2::new(
                        b1 * rng.random_range(-1.0..=1.0),
                        b2 * rng.random_range(-1.0..=1.0),
                    );
                clamp_centre(p, rect.width, rect.height, w, h)
            })
            .collect();
        self.set = Some(ParticleSet::new(particles)?);
        self.output = centre;
        self.drift = Vector2::zeros();
        self.window = rect;
        Ok(())
    }

    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate> {
        let gray = frame.gray()?;
        if let (ArpMotion::ConstantDrift { margin, .. }, 1) = (self.config.motion, frame.index()) {
            return self.measure_drift(gray, margin);
        }
        let set = self.set.as_mut().ok_or(TrackerError::NotInitialised)?;
        let z = Observation {
            frame: gray,
            template: self.template.view(),
            likelihood: self.likelihood,
            motion: self.config.motion,
            drift: self.drift,
            cap: self.config.mad_cap.unwrap_or(f64::INFINITY),
        };
        let key = [self.config.seed, STEP_STREAM, frame.index()];
        // resample last frame's weighted set, move, weigh (eq. 5-7)
        self.filter.step(set, &ArpProposal, &z, &key)?;
        // Eq. 8: the weighted mean
        let out = set.mean();
        let mad_out = z.mad_at(&out)?;
        if let ArpMotion::Drift { gain, .. } = self.config.motion {
            self.drift += gain * (out - self.output - self.drift);
        }
        self.output = out;
        Ok(Estimate {
            bbox: self.bbox_at(out),
            pose: None,
            particles: self.config.particles,
            evaluations: self.config.particles,
            lost: mad_out > self.config.lost_mad,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::Tracker;

    /// A textured 8-bit frame (LCG noise).
    fn texture(w: usize, h: usize, seed: u32) -> Image<u8> {
        let mut s = seed;
        Image::from_fn(w, h, |_, _| {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 24) as u8 / 4 + 80
        })
        .unwrap()
    }

    /// `background` with `patch` pasted at top-left `(x, y)`.
    fn paste(background: &Image<u8>, patch: &Image<u8>, x: usize, y: usize) -> Image<u8> {
        let mut f = background.clone();
        for v in 0..patch.height() {
            for u in 0..patch.width() {
                f.set(x + u, y + v, 0, patch.get(u, v, 0).unwrap());
            }
        }
        f
    }

    fn target() -> Image<u8> {
        Image::from_fn(16, 12, |u, v| ((u * 37 + v * 91) % 200) as u8 + 20).unwrap()
    }

    /// A road-like scene: a flat, lightly textured background.
    fn road(w: usize, h: usize) -> Image<u8> {
        let mut s = 7u32;
        Image::from_fn(w, h, |_, _| {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            95 + (s >> 29) as u8
        })
        .unwrap()
    }

    /// A 24x32 target of 4x4 flat blocks (6x8 px) of different grey
    /// levels: structure in both directions, as a textured car roof has.
    fn car() -> Image<u8> {
        Image::from_fn(24, 32, |u, v| {
            let block = (u / 6) * 4 + v / 8;
            [
                40u8, 200, 90, 150, 220, 30, 170, 60, 120, 240, 20, 180, 70, 140, 210, 50,
            ][block]
        })
        .unwrap()
    }

    #[test]
    fn mad_tracker_follows_a_translating_template_exactly() {
        let bg = texture(120, 90, 3);
        let t = target();
        for search in [SearchArea::Frame, SearchArea::Window { margin: 6 }] {
            let mut tr = MadTracker::new(MadTrackerConfig {
                search,
                ..Default::default()
            })
            .unwrap();
            let f0 = paste(&bg, &t, 10, 8);
            tr.init(f0.view(), BBox::from_rect(Rect::new(10, 8, 16, 12)))
                .unwrap();
            for k in 1..15 {
                let (x, y) = (10 + 4 * k, 8 + 3 * k);
                let e = tr.step(paste(&bg, &t, x, y).view()).unwrap();
                assert_eq!(
                    e.bbox,
                    BBox::from_rect(Rect::new(x, y, 16, 12)),
                    "{search:?}"
                );
                assert_eq!(tr.last_mad(), 0.0);
            }
        }
    }

    #[test]
    fn mad_tracker_rejects_bad_input() {
        let f = texture(40, 30, 1);
        let mut tr = MadTracker::new(MadTrackerConfig::default()).unwrap();
        assert!(matches!(
            tr.step(f.view()),
            Err(TrackerError::NotInitialised)
        ));
        assert!(matches!(
            tr.init(f.view(), BBox::new(35.0, 1.0, 10.0, 10.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        assert!(matches!(
            tr.init(f.view(), BBox::new(5.0, 5.0, 0.0, 10.0)),
            Err(TrackerError::EmptyBox { .. })
        ));
        let two = Image::new(40, 30, 2, 0u8).unwrap();
        assert!(matches!(
            tr.init(two.view(), BBox::new(5.0, 5.0, 8.0, 8.0)),
            Err(TrackerError::Channels { got: 2, .. })
        ));
        tr.init(f.view(), BBox::new(5.0, 5.0, 8.0, 8.0)).unwrap();
        let other = texture(41, 30, 1);
        assert!(matches!(
            tr.step(other.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        let mut small = MadTracker::new(MadTrackerConfig {
            search: SearchArea::Region(Rect::new(0, 0, 6, 20)),
            ..Default::default()
        })
        .unwrap();
        assert!(matches!(
            small.init(f.view(), BBox::new(5.0, 5.0, 8.0, 8.0)),
            Err(TrackerError::Appearance(
                AppearanceError::TemplateLargerThanRegion { .. }
            ))
        ));
        let mut outside = MadTracker::new(MadTrackerConfig {
            search: SearchArea::Region(Rect::new(30, 0, 20, 20)),
            ..Default::default()
        })
        .unwrap();
        assert!(matches!(
            outside.init(f.view(), BBox::new(5.0, 5.0, 8.0, 8.0)),
            Err(TrackerError::Appearance(
                AppearanceError::WindowOutside { .. }
            ))
        ));
        assert!(
            MadTracker::new(MadTrackerConfig {
                lost_mad: f64::NAN,
                ..Default::default()
            })
            .is_err()
        );
    }

    #[test]
    fn mad_tracker_accepts_rgb_frames() {
        let g = paste(&texture(60, 40, 2), &target(), 20, 10);
        let rgb = Image::from_vec(
            60,
            40,
            3,
            g.as_slice().iter().flat_map(|&v| [v, v, v]).collect(),
        )
        .unwrap();
        let mut tr = MadTracker::new(MadTrackerConfig::default()).unwrap();
        tr.init(rgb.view(), BBox::from_rect(Rect::new(20, 10, 16, 12)))
            .unwrap();
        let e = tr.step(rgb.view()).unwrap();
        assert_eq!(e.bbox, BBox::from_rect(Rect::new(20, 10, 16, 12)));
    }

    #[test]
    fn pf_tracker_follows_a_translating_template() {
        // 3 px right, 2 px down per frame for 30 frames.
        let bg = road(200, 160);
        let t = car();
        let run = |seed| {
            let config = PfCorrelationConfig {
                seed,
                ..PfCorrelationConfig::default()
            };
            let mut tr = PfCorrelationTracker::new(config).unwrap();
            let init = BBox::from_rect(Rect::new(10, 10, 24, 32));
            tr.init(paste(&bg, &t, 10, 10).view(), init).unwrap();
            let (mut worst, mut sum) = (0f64, 0.0);
            for k in 1..30 {
                let (x, y) = (10 + 3 * k, 10 + 2 * k);
                let e = tr.step(paste(&bg, &t, x, y).view()).unwrap();
                let (cx, cy) = e.bbox.center();
                let (tx, ty) = Rect::new(x, y, 24, 32).center();
                let err = (cx - 1.0 - tx).hypot(cy - 1.0 - ty);
                worst = worst.max(err);
                sum += err;
                assert_eq!((e.particles, e.evaluations), (15, 15));
            }
            (worst, sum / 29.0, tr.centre())
        };
        // Measured: 18 of 20 seeds keep the mean error near 1 px; with so
        // few particles a frame where none lands near the peak can lose the
        // target even on a clean scene.
        let means: Vec<f64> = (0..20).map(|seed| run(seed).1).collect();
        let good = means.iter().filter(|&&m| m < 3.0).count();
        assert!(good >= 16, "{means:?}");
        let (worst, mean, end) = run(0);
        assert!(mean < 2.0 && worst < 5.0, "mean {mean}, worst {worst}");
        // Same seed, same bits.
        assert_eq!(run(0).2, end);
    }

    #[test]
    fn constant_drift_is_measured_in_frame_2_and_coasts_through_a_hidden_stretch() {
        // 3 px right, 2 px down per frame; hidden (background only) in
        // frames 10-14.
        let bg = road(260, 200);
        let t = car();
        let motion = ArpMotion::ConstantDrift {
            b: [2.0, 2.0],
            margin: 8,
        };
        let run = |seed, motion| {
            let mut tr = PfCorrelationTracker::new(PfCorrelationConfig {
                seed,
                motion,
                ..PfCorrelationConfig::default()
            })
            .unwrap();
            tr.init(
                paste(&bg, &t, 10, 10).view(),
                BBox::from_rect(Rect::new(10, 10, 24, 32)),
            )
            .unwrap();
            let mut errs = vec![];
            for k in 1..30 {
                let (x, y) = (10 + 3 * k, 10 + 2 * k);
                let frame = if (10..15).contains(&k) {
                    bg.clone()
                } else {
                    paste(&bg, &t, x, y)
                };
                let e = tr.step(frame.view()).unwrap();
                if k == 1 {
                    // frame 2: the exact MAD match, the drift measured by it
                    assert_eq!(e.bbox, BBox::from_rect(Rect::new(13, 12, 24, 32)));
                    assert_eq!(tr.drift, Vector2::new(3.0, 2.0));
                    assert!(e.evaluations > 15, "the frame-2 MAD search");
                }
                let (cx, cy) = e.bbox.center();
                let (tx, ty) = Rect::new(x, y, 24, 32).center();
                errs.push((cx - 1.0 - tx).hypot(cy - 1.0 - ty));
            }
            errs
        };
        for seed in 0..5 {
            let errs = run(seed, motion);
            let after = errs[15..].iter().sum::<f64>() / 14.0;
            assert!(after < 3.0, "seed {seed}: {errs:?}");
        }
        // The drift stays what frame 2 measured.
        let mut tr = PfCorrelationTracker::new(PfCorrelationConfig {
            motion,
            ..PfCorrelationConfig::default()
        })
        .unwrap();
        tr.init(
            paste(&bg, &t, 10, 10).view(),
            BBox::from_rect(Rect::new(10, 10, 24, 32)),
        )
        .unwrap();
        for k in 1..6 {
            tr.step(paste(&bg, &t, 10 + 3 * k, 10 + 2 * k).view())
                .unwrap();
            assert_eq!(tr.drift, Vector2::new(3.0, 2.0));
        }
    }

    #[test]
    fn pf_tracker_rejects_bad_input() {
        let f = texture(40, 30, 1);
        for bad in [
            PfCorrelationConfig {
                particles: 0,
                ..Default::default()
            },
            PfCorrelationConfig {
                mad_cap: Some(f64::NAN),
                ..Default::default()
            },
            PfCorrelationConfig {
                sigma: 0.0,
                ..Default::default()
            },
            PfCorrelationConfig {
                spread: [f64::NAN, 1.0],
                ..Default::default()
            },
            PfCorrelationConfig {
                motion: ArpMotion::Position {
                    a: [1.0, f64::INFINITY],
                    b: [1.0, 1.0],
                },
                ..Default::default()
            },
            PfCorrelationConfig {
                motion: ArpMotion::Drift {
                    b: [-1.0, 1.0],
                    gain: 0.5,
                },
                ..Default::default()
            },
        ] {
            assert!(PfCorrelationTracker::new(bad).is_err(), "{bad:?}");
        }
        let mut tr = PfCorrelationTracker::new(PfCorrelationConfig::default()).unwrap();
        assert!(matches!(
            tr.step(f.view()),
            Err(TrackerError::NotInitialised)
        ));
        assert!(matches!(
            tr.init(f.view(), BBox::new(-3.0, 1.0, 10.0, 10.0)),
            Err(TrackerError::BoxOutsideFrame { .. })
        ));
        assert!(matches!(
            tr.init(f.view(), BBox::new(1.0, 1.0, 10.0, 0.5)),
            Err(TrackerError::EmptyBox { .. })
        ));
        tr.init(f.view(), BBox::new(1.0, 1.0, 40.0, 30.0)).unwrap();
        // The template fills the frame: every particle sits at the one
        // position, nothing panics.
        let e = tr.step(f.view()).unwrap();
        assert!((e.bbox.x - 1.0).abs() < 1e-9 && (e.bbox.y - 1.0).abs() < 1e-9);
        assert!(matches!(
            tr.step(texture(40, 31, 1).view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
    }
}
