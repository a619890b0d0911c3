//! The models a tracker drives: [`Dcf`] (KCF translation filter on fHOG
//! plus DSST's scale filter, updates gated by LMCF's APCE rule) and
//! [`Staple`] (the same with Staple's colour model merged in).

use bayestrack_image::ImageView;
use bayestrack_image::simd::{Kernel as SimdKernel, Token, dispatch};

use crate::colour::ColourModel;
use crate::confidence::{ApceGate, PSR_EXCLUDE, apce, psr};
use crate::error::{DcfError, Result, check_rate};
use crate::features::{Fhog, HOG_CHANNELS};
use crate::fft::{C32, next_smooth};
use crate::kcf::{KcfModel, Kernel, cosine_window, subcell_peak};
use crate::sample::{PatchSampler, Region};
use crate::scale::{ScaleConfig, ScaleFilter};

/// How much context the search window adds around the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Padding {
    /// KCF: the window is `(1 + p)` times the target in each dimension
    /// (KCF: `p = 1.5`).
    Relative(f64),
    /// Staple: the window adds `p (w + h) / 2` to each dimension (Staple:
    /// `p = 1`).
    MeanSide(f64),
}

/// Every parameter of [`Dcf`]; the defaults are KCF's published HOG
/// parameters (Henriques et al. 2015, table 2 and sec. 6.1) with DSST's
/// scale filter (Danelljan et al. 2014) and LMCF's update gate (Wang et
/// al. 2017).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcfConfig {
    /// Search window around the target (KCF: relative 1.5).
    pub padding: Padding,
    /// Ridge regularisation (KCF: 1e-4).
    pub lambda: f64,
    /// Label standard deviation as a fraction of `sqrt(w h)` of the target
    /// (KCF: 0.1), divided by the cell.
    pub output_sigma_factor: f64,
    /// Kernel (KCF with HOG: Gaussian, sigma 0.5).
    pub kernel: Kernel,
    /// Learning rate of the translation model (KCF with HOG: 0.02).
    pub learning_rate: f64,
    /// fHOG cell, pixels (KCF: 4).
    pub cell: usize,
    /// Largest area of the search window, model pixels (Staple's fixed
    /// area, 150^2): a larger window is resampled down to it, a smaller one
    /// stays at the frame's resolution as in KCF (which also works at the
    /// frame's resolution and halves large targets). Bounds the cost per
    /// frame.
    pub model_area: f64,
    /// The scale filter (DSST's parameters); `None` tracks translation only.
    pub scale: Option<ScaleConfig>,
    /// LMCF's update gate `(beta_1, beta_2)` on the peak and the APCE
    /// (0.7, 0.45); `None` learns every frame (KCF, DSST).
    pub gate: Option<(f64, f64)>,
}

impl Default for DcfConfig {
    fn default() -> Self {
        Self {
            padding: Padding::Relative(1.5),
            lambda: 1e-4,
            output_sigma_factor: 0.1,
            kernel: Kernel::Gaussian { sigma: 0.5 },
            learning_rate: 0.02,
            cell: 4,
            model_area: 150.0 * 150.0,
            scale: Some(ScaleConfig::default()),
            gate: Some((0.7, 0.45)),
        }
    }
}

impl DcfConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f64, reason| {
            Err(DcfError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        let p = match self.padding {
            Padding::Relative(p) | Padding::MeanSide(p) => p,
        };
        if !(p.is_finite() && (0.0..=10.0).contains(&p)) {
            return bad("padding", p, "must be in [0, 10]");
        }
        if !(self.lambda.is_finite() && self.lambda > 0.0) {
            return bad("lambda", self.lambda, "must be positive");
        }
        if !(self.output_sigma_factor.is_finite() && self.output_sigma_factor > 0.0) {
            return bad(
                "output_sigma_factor",
                self.output_sigma_factor,
                "must be positive",
            );
        }
        if let Kernel::Gaussian { sigma } = self.kernel
            && !(sigma.is_finite() && sigma > 0.0)
        {
            return bad("kernel_sigma", sigma, "must be positive");
        }
        if !(0.0..=1.0).contains(&self.learning_rate) {
            return bad("learning_rate", self.learning_rate, "must be in [0, 1]");
        }
        if !(1..=16).contains(&self.cell) {
            return bad("cell", self.cell as f64, "must be in 1..=16");
        }
        if !(self.model_area.is_finite() && (256.0..=1e6).contains(&self.model_area)) {
            return bad("model_area", self.model_area, "must be in [256, 1e6]");
        }
        if let Some(s) = &self.scale {
            s.validate()?;
        }
        if let Some((a, b)) = self.gate
            && !((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b))
        {
            return bad("gate", a.max(b), "ratios must be in [0, 1]");
        }
        Ok(())
    }
}

/// A correlation response over the search window, in cells, and what it
/// says: the peak's displacement (frame pixels), value and confidence.
#[derive(Debug, Clone, Default)]
pub struct Response {
    w: usize,
    h: usize,
    data: Vec<f32>,
    px: (f64, f64),
    /// Peak value.
    pub max: f32,
    /// Displacement of the peak from the window's centre, frame pixels
    /// (sub-cell by parabolas).
    pub dx: f64,
    /// Vertical displacement of the peak, frame pixels.
    pub dy: f64,
    /// Average peak-to-correlation energy.
    pub apce: f64,
}

impl Response {
    /// Cells across.
    pub fn width(&self) -> usize {
        self.w
    }

    /// Cells down.
    pub fn height(&self) -> usize {
        self.h
    }

    /// The map, row-major; cell `(i, j)` is the displacement
    /// `(wrapped(i), wrapped(j))` cells (index 0 = no displacement).
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Frame pixels per cell along x and y.
    pub fn pixels_per_cell(&self) -> (f64, f64) {
        self.px
    }

    /// Peak-to-sidelobe ratio (MOSSE's 11x11 exclusion), computed when
    /// asked (a search that weighs many windows by their peak and APCE,
    /// as pf-dcf's, never needs it).
    pub fn psr(&self) -> f64 {
        psr(&self.data, self.w, self.h, PSR_EXCLUDE)
    }

    /// The response at a displacement `(dx, dy)` frame pixels from the
    /// window's centre, bilinear between cells (cyclic). A cheap score for
    /// any candidate centre once the response of a frame is computed (the
    /// particle filter's likelihood). 0 for an empty response or a
    /// non-finite displacement.
    pub fn at(&self, dx: f64, dy: f64) -> f32 {
        if self.data.is_empty() || !dx.is_finite() || !dy.is_finite() {
            return 0.0;
        }
        let (u, v) = (dx / self.px.0, dy / self.px.1);
        let (w, h) = (self.w as f64, self.h as f64);
        let (u, v) = (u.rem_euclid(w), v.rem_euclid(h));
        let (i0, j0) = (u.floor() as usize % self.w, v.floor() as usize % self.h);
        let (i1, j1) = ((i0 + 1) % self.w, (j0 + 1) % self.h);
        let (fx, fy) = ((u - u.floor()) as f32, (v - v.floor()) as f32);
        let g = |i: usize, j: usize| self.data[j * self.w + i];
        let top = g(i0, j0) + fx * (g(i1, j0) - g(i0, j0));
        let bot = g(i0, j1) + fx * (g(i1, j1) - g(i0, j1));
        top + fy * (bot - top)
    }

    fn finish(&mut self) -> Result<()> {
        let (max, dx, dy) = subcell_peak(&self.data, self.w, self.h);
        if !max.is_finite() {
            return Err(DcfError::NonFinite { what: "response" });
        }
        self.max = max;
        self.dx = dx * self.px.0;
        self.dy = dy * self.px.1;
        self.apce = apce(&self.data);
        Ok(())
    }
}

/// One tracked frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// New centre (0-based pixel coordinates).
    pub centre: (f64, f64),
    /// New scale relative to the initial box.
    pub scale: f64,
    /// Box size, frame pixels.
    pub size: (f64, f64),
    /// Peak of the response that placed it.
    pub peak: f32,
    /// Its PSR.
    pub psr: f64,
    /// Its APCE.
    pub apce: f64,
    /// Whether the model learnt from this frame.
    pub updated: bool,
}

/// The geometry fixed at `init`.
#[derive(Debug, Clone, Copy)]
struct Geometry {
    /// Target size at scale 1, frame pixels.
    base: (f64, f64),
    /// Cells of the window.
    nx: usize,
    ny: usize,
    /// Model pixels of the window.
    pw: usize,
    ph: usize,
    /// Frame pixels per model pixel at scale 1.
    rx: f64,
    ry: f64,
    /// Scale bounds.
    min_scale: f64,
    max_scale: f64,
}

impl Geometry {
    /// The window's sampling origin and steps at `centre`, `scale`.
    fn origin(&self, centre: (f64, f64), scale: f64) -> (f64, f64, f64, f64) {
        let (sx, sy) = (self.rx * scale, self.ry * scale);
        let x0 = centre.0 + 0.5 - self.pw as f64 * sx / 2.0;
        let y0 = centre.1 + 0.5 - self.ph as f64 * sy / 2.0;
        (x0, y0, sx, sy)
    }

    /// The pixels of a `w x h` frame the window at `centre`, `scale`
    /// reads (`None`: nothing to load, for an empty frame or a non-finite
    /// centre).
    fn region(&self, w: usize, h: usize, centre: (f64, f64), scale: f64) -> Option<Region> {
        let (x0, y0, sx, sy) = self.origin(centre, scale);
        Region::of_sample(w, h, x0, y0, sx, sy, self.pw, self.ph)
    }
}

/// The error of a sample that reads outside the loaded region (a frame
/// not loaded where the filter looks).
fn outside() -> DcfError {
    DcfError::InvalidParameter {
        name: "sample region",
        value: 0.0,
        reason: "reads outside the region of the frame loaded",
    }
}

/// Loads `region` of `frame`'s gray levels into `sampler` unless it holds
/// it already (`None`: the whole frame, where it reports bad frames).
fn ensure_gray(
    sampler: &mut PatchSampler,
    frame: ImageView<'_, u8>,
    region: Option<Region>,
) -> Result<()> {
    let r = region.unwrap_or(Region::whole(frame.width(), frame.height()));
    if sampler.holds(&r) {
        return Ok(());
    }
    sampler.load_gray_region(frame, r)
}

/// A grid of windows for [`Dcf::extract_shared`]: the windows centred
/// `(i, j)` cells from `centre` at `scale`, `i` in `lo.0..=hi.0`, `j` in
/// `lo.1..=hi.1` (cells of [`Dcf::cell_pixels`]`(scale)`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SharedGrid {
    /// Centre of the window at offset `(0, 0)`, frame pixels (0-based).
    pub centre: (f64, f64),
    /// Scale relative to the initial box.
    pub scale: f64,
    /// Smallest offsets, cells.
    pub lo: (isize, isize),
    /// Largest offsets, cells.
    pub hi: (isize, isize),
}

/// The fHOG of one patch shared by a grid of windows
/// ([`Dcf::extract_shared`]) and its scratch (no allocation once its
/// sizes have been seen).
#[derive(Debug, Clone, Default)]
pub struct SharedFeatures {
    /// fHOG of the patch sizes seen last.
    hogs: Vec<((usize, usize), Fhog)>,
    patch: Vec<f32>,
    features: Vec<f32>,
    /// Cells of the patch.
    cells: (usize, usize),
    grid: Option<SharedGrid>,
}

impl SharedFeatures {
    /// Empty (fill it with [`Dcf::extract_shared`]).
    pub fn new() -> Self {
        Self::default()
    }
}

/// KCF translation filter on fHOG with DSST's scale filter; see
/// [`DcfConfig`]. Feed it gray or RGB frames (the filter reads gray
/// levels; of an RGB frame it converts only the region it reads).
#[derive(Debug, Clone)]
pub struct Dcf {
    config: DcfConfig,
    sampler: PatchSampler,
    geometry: Option<Geometry>,
    model: Option<KcfModel>,
    scale_filter: Option<ScaleFilter>,
    hog: Option<Fhog>,
    window: Vec<f32>,
    patch: Vec<f32>,
    features: Vec<f32>,
    response: Response,
    gate: ApceGate,
    centre: (f64, f64),
    scale: f64,
    /// The last frame's displacement (largest of x and y), pixels: the
    /// margin of the next frame's first load.
    motion: f64,
}

impl Dcf {
    /// A filter with `config`.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a bad parameter.
    pub fn new(config: DcfConfig) -> Result<Self> {
        config.validate()?;
        let (a, b) = config.gate.unwrap_or((0.0, 0.0));
        Ok(Self {
            config,
            sampler: PatchSampler::new(),
            geometry: None,
            model: None,
            scale_filter: None,
            hog: None,
            window: Vec::new(),
            patch: Vec::new(),
            features: Vec::new(),
            response: Response::default(),
            gate: ApceGate::new(a, b),
            centre: (0.0, 0.0),
            scale: 1.0,
            motion: 0.0,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DcfConfig {
        &self.config
    }

    /// Current centre (0-based pixels).
    pub fn centre(&self) -> (f64, f64) {
        self.centre
    }

    /// Current scale relative to the initial box.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Current box size, frame pixels (0 before `init`).
    pub fn size(&self) -> (f64, f64) {
        self.geometry
            .map(|g| (g.base.0 * self.scale, g.base.1 * self.scale))
            .unwrap_or((0.0, 0.0))
    }

    /// Cells of the search window (0 before `init`).
    pub fn cells(&self) -> (usize, usize) {
        self.geometry.map(|g| (g.nx, g.ny)).unwrap_or((0, 0))
    }

    /// The last response computed.
    pub fn response(&self) -> &Response {
        &self.response
    }

    /// Starts on a gray frame with a target of `size` frame pixels centred
    /// at `centre` (0-based pixel coordinates).
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a non-finite or empty target or a
    /// frame that is not 1-channel.
    pub fn init(
        &mut self,
        frame: ImageView<'_, u8>,
        centre: (f64, f64),
        size: (f64, f64),
    ) -> Result<()> {
        let (w, h) = size;
        let finite = centre.0.is_finite() && centre.1.is_finite();
        if !(finite && w.is_finite() && h.is_finite() && w >= 1.0 && h >= 1.0) {
            return Err(DcfError::InvalidParameter {
                name: "target",
                value: w.min(h),
                reason: "must be finite, at least 1x1 pixel",
            });
        }
        let c = self.config;
        let (ww, wh) = match c.padding {
            Padding::Relative(p) => (w * (1.0 + p), h * (1.0 + p)),
            Padding::MeanSide(p) => (w + p * (w + h) / 2.0, h + p * (w + h) / 2.0),
        };
        // larger windows are shrunk to the model area, smaller ones kept at
        // the frame's resolution (KCF), which bounds the cost per frame
        let k = (c.model_area / (ww * wh)).sqrt().min(1.0);
        let cell = c.cell;
        let nx = next_smooth(((ww * k / cell as f64).round() as usize).max(4));
        let ny = next_smooth(((wh * k / cell as f64).round() as usize).max(4));
        let (pw, ph) = (nx * cell, ny * cell);
        let (rx, ry) = (ww / pw as f64, wh / ph as f64);
        // target in model pixels, label width in cells (KCF)
        let sigma = (w / rx * h / ry).sqrt() * c.output_sigma_factor / cell as f64;
        let model = KcfModel::new(nx, ny, HOG_CHANNELS, sigma, c.kernel, c.lambda)?;
        let hog = Fhog::new(pw, ph, cell)?;
        let (fw, fh) = (frame.width() as f64, frame.height() as f64);
        // DSST's bounds: the window at least 5 pixels, the target at most
        // the frame
        let min_scale = (5.0 / ww.min(wh)).min(1.0);
        let max_scale = (fw / w).min(fh / h).max(1.0);
        self.geometry = Some(Geometry {
            base: (w, h),
            nx,
            ny,
            pw,
            ph,
            rx,
            ry,
            min_scale,
            max_scale,
        });
        self.window = cosine_window(nx, ny);
        self.patch = vec![0.0; pw * ph];
        self.features = vec![0.0; HOG_CHANNELS * nx * ny];
        self.response = Response {
            w: nx,
            h: ny,
            data: vec![0.0; nx * ny],
            ..Response::default()
        };
        self.model = Some(model);
        self.hog = Some(hog);
        self.scale_filter = match c.scale {
            Some(sc) => Some(ScaleFilter::new(sc, w, h)?),
            None => None,
        };
        self.gate.reset();
        self.centre = centre;
        self.scale = 1.0;
        self.motion = 0.0;
        self.load(frame)?;
        self.update(centre, 1.0, 1.0)
    }

    /// Loads the gray levels of a frame (gray, or RGB converted as
    /// `bayestrack_image::rgb_to_gray_into` does), the whole of it, for the
    /// following `detect`, `scale_change` and `update` calls.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a frame that is not 1- or
    /// 3-channel or is empty.
    pub fn load(&mut self, frame: ImageView<'_, u8>) -> Result<()> {
        let whole = Region::whole(frame.width(), frame.height());
        self.sampler.load_gray_region(frame, whole)
    }

    /// Loads the gray levels of only the part of `frame` that
    /// [`Dcf::detect`] and [`Dcf::update`] read at each of `windows`
    /// (`(centre, scale)`: their union; the whole frame before
    /// [`Dcf::init`] or for a window with no region), replacing what was
    /// loaded. Those calls then give the same numbers as after
    /// [`Dcf::load`]; a call elsewhere is an error until
    /// [`Dcf::ensure_loaded`] loads its region.
    ///
    /// # Errors
    /// As [`Dcf::load`].
    pub fn load_windows(
        &mut self,
        frame: ImageView<'_, u8>,
        windows: impl IntoIterator<Item = ((f64, f64), f64)>,
    ) -> Result<()> {
        let (w, h) = (frame.width(), frame.height());
        let mut region: Option<Region> = None;
        for (centre, scale) in windows {
            let Some(r) = self.needs(w, h, centre, scale) else {
                region = Some(Region::whole(w, h));
                break;
            };
            region = Some(region.map_or(r, |u| u.union(&r)));
        }
        self.sampler
            .load_gray_region(frame, region.unwrap_or(Region::whole(w, h)))
    }

    /// Loads what [`Dcf::detect`] and [`Dcf::update`] at `centre`,
    /// `scale` read of `frame` when the loaded region lacks it (replacing
    /// the loaded region); nothing otherwise.
    ///
    /// # Errors
    /// As [`Dcf::load`].
    pub fn ensure_loaded(
        &mut self,
        frame: ImageView<'_, u8>,
        centre: (f64, f64),
        scale: f64,
    ) -> Result<()> {
        let need = self.needs(frame.width(), frame.height(), centre, scale);
        ensure_gray(&mut self.sampler, frame, need)
    }

    /// The pixels of a `w x h` frame that the frame's translation window at
    /// `centre`, `scale` and the scale samples there read.
    fn needs(&self, w: usize, h: usize, centre: (f64, f64), scale: f64) -> Option<Region> {
        let window = self.geometry?.region(w, h, centre, scale)?;
        Some(match &self.scale_filter {
            Some(f) => window.union(&f.region(w, h, centre.0, centre.1, scale)?),
            None => window,
        })
    }

    /// The scale factor a frame's scale estimate changes the scale by in
    /// planning what to load: one scale step (larger changes load again).
    fn plan_growth(&self) -> f64 {
        self.config.scale.map_or(1.0, |s| s.step)
    }

    /// The region of a `w x h` frame to load before a frame's detection
    /// from `centre`, `scale`: what detection, the scale estimate and the
    /// update read if the target moves as far as last frame, plus four
    /// pixels, and grows by at most one scale step. Wherever the target
    /// goes, the later steps load what they lack ([`ensure_gray`]): the
    /// plan changes the cost, never the result.
    fn plan(&self, w: usize, h: usize, centre: (f64, f64), scale: f64) -> Option<Region> {
        let r = self.needs(w, h, centre, scale * self.plan_growth())?;
        Some(r.grown(self.motion.ceil() as usize + 4, w, h))
    }

    /// The windowed fHOG of the loaded frame around `centre` at `scale`.
    fn extract(&mut self, centre: (f64, f64), scale: f64) -> Result<Geometry> {
        let g = self.geometry.ok_or(DcfError::NotInitialised)?;
        let hog = self.hog.as_mut().ok_or(DcfError::NotInitialised)?;
        let (x0, y0, sx, sy) = g.origin(centre, scale);
        let (w, h) = (self.sampler.width(), self.sampler.height());
        if let Some(r) = g.region(w, h, centre, scale)
            && !self.sampler.holds(&r)
        {
            return Err(outside());
        }
        // gray levels to [0, 1] in the sampler's output pass
        self.sampler
            .sample_scaled(0, x0, y0, sx, sy, &mut self.patch, g.pw, g.ph, 1.0 / 255.0)?;
        hog.compute(&self.patch, &mut self.features)?;
        dispatch(Windowed {
            features: &mut self.features,
            window: &self.window,
        });
        Ok(g)
    }

    /// The translation response of the loaded frame in the window centred
    /// at `centre`, at `scale`.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; [`DcfError::NonFinite`] for a NaN
    /// response.
    pub fn detect(&mut self, centre: (f64, f64), scale: f64) -> Result<&Response> {
        self.extract(centre, scale)?;
        self.respond(scale)
    }

    /// The response of the windowed features in `self.features` (a window
    /// at `scale`): [`Dcf::detect`]'s and [`Dcf::detect_cut`]'s last step.
    fn respond(&mut self, scale: f64) -> Result<&Response> {
        let px = self.cell_pixels(scale);
        let model = self.model.as_mut().ok_or(DcfError::NotInitialised)?;
        model.detect(&self.features, &mut self.response.data)?;
        self.response.px = px;
        self.response.finish()?;
        Ok(&self.response)
    }

    /// Frame pixels per fHOG cell at `scale` (along x and y): the step of
    /// the grid on which [`Dcf::extract_shared`] cuts windows, and of a
    /// response's cells. `(0, 0)` before [`Dcf::init`].
    pub fn cell_pixels(&self, scale: f64) -> (f64, f64) {
        self.geometry.map_or((0.0, 0.0), |g| {
            let k = g.pw as f64 / g.nx as f64;
            (k * g.rx * scale, k * g.ry * scale)
        })
    }

    /// The sampling of the shared patch of the windows centred
    /// `(i, j)` cells from `centre` at `scale`, `i` in `lo.0..=hi.0`, `j`
    /// in `lo.1..=hi.1`: origin, steps and size in model pixels.
    fn shared_origin(
        &self,
        centre: (f64, f64),
        scale: f64,
        lo: (isize, isize),
        hi: (isize, isize),
    ) -> Result<(f64, f64, f64, f64, usize, usize)> {
        let g = self.geometry.ok_or(DcfError::NotInitialised)?;
        if lo.0 > hi.0 || lo.1 > hi.1 || hi.0 - lo.0 > 1024 || hi.1 - lo.1 > 1024 {
            return Err(DcfError::InvalidParameter {
                name: "shared grid",
                value: (hi.0 - lo.0).min(hi.1 - lo.1) as f64,
                reason: "needs lo <= hi, at most 1024 cells apart",
            });
        }
        let (x0, y0, sx, sy) = g.origin(centre, scale);
        let cell = self.config.cell;
        let step = (cell as f64 * sx, cell as f64 * sy);
        let cols = g.nx + (hi.0 - lo.0) as usize;
        let rows = g.ny + (hi.1 - lo.1) as usize;
        Ok((
            x0 + lo.0 as f64 * step.0,
            y0 + lo.1 as f64 * step.1,
            sx,
            sy,
            cols * cell,
            rows * cell,
        ))
    }

    /// Loads the gray levels of only the part of `frame` that the shared
    /// patches `(centre, scale, lo, hi)` of [`Dcf::extract_shared`] read
    /// (their union; the whole frame before [`Dcf::init`] or for a patch
    /// with no region), replacing what was loaded.
    ///
    /// # Errors
    /// As [`Dcf::load`]; [`DcfError::InvalidParameter`] for a bad grid.
    pub fn load_shared(
        &mut self,
        frame: ImageView<'_, u8>,
        patches: impl IntoIterator<Item = SharedGrid>,
    ) -> Result<()> {
        let (w, h) = (frame.width(), frame.height());
        let mut region: Option<Region> = None;
        for p in patches {
            let r = if self.geometry.is_some() {
                let (x0, y0, sx, sy, pw, ph) = self.shared_origin(p.centre, p.scale, p.lo, p.hi)?;
                Region::of_sample(w, h, x0, y0, sx, sy, pw, ph)
            } else {
                None
            };
            let Some(r) = r else {
                region = Some(Region::whole(w, h));
                break;
            };
            region = Some(region.map_or(r, |u| u.union(&r)));
        }
        self.sampler
            .load_gray_region(frame, region.unwrap_or(Region::whole(w, h)))
    }

    /// Samples and computes the fHOG of one patch covering the windows
    /// centred `(i, j)` cells (of [`Dcf::cell_pixels`]) from `centre` at
    /// `scale`, `i` in `grid.lo.0..=grid.hi.0` and `j` in
    /// `grid.lo.1..=grid.hi.1`, into `shared`; [`Dcf::detect_cut`] then
    /// cuts each window's cells out of it. Not the numbers of
    /// [`Dcf::detect`] at those centres: a window's border cells see the
    /// pixels beyond it (gradients, cell shares, block normalisation), and
    /// windows past the frame's edge read the edge replicated as one
    /// patch; cells two or more from a window's border match up to the
    /// sampler's rounding. A 3 x 3 grid half a window apart costs the
    /// features of about 4 windows instead of 9.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; [`DcfError::InvalidParameter`] for a
    /// bad grid or a patch outside the loaded region; sampler errors.
    pub fn extract_shared(&mut self, shared: &mut SharedFeatures, grid: SharedGrid) -> Result<()> {
        let SharedGrid {
            centre,
            scale,
            lo,
            hi,
        } = grid;
        let (x0, y0, sx, sy, pw, ph) = self.shared_origin(centre, scale, lo, hi)?;
        let (w, h) = (self.sampler.width(), self.sampler.height());
        if let Some(r) = Region::of_sample(w, h, x0, y0, sx, sy, pw, ph)
            && !self.sampler.holds(&r)
        {
            return Err(outside());
        }
        let k = match shared.hogs.iter().position(|f| f.0 == (pw, ph)) {
            Some(k) => k,
            None => {
                // a few sizes recur (the grid clamped at an edge, other
                // scales): keep the last four
                if shared.hogs.len() >= 4 {
                    shared.hogs.remove(0);
                }
                shared
                    .hogs
                    .push(((pw, ph), Fhog::new(pw, ph, self.config.cell)?));
                shared.hogs.len() - 1
            }
        };
        shared.patch.resize(pw * ph, 0.0);
        self.sampler
            .sample_scaled(0, x0, y0, sx, sy, &mut shared.patch, pw, ph, 1.0 / 255.0)?;
        let hog = &mut shared.hogs[k].1;
        shared.features.resize(hog.len(), 0.0);
        hog.compute(&shared.patch, &mut shared.features)?;
        shared.cells = (hog.cells_x(), hog.cells_y());
        shared.grid = Some(grid);
        Ok(())
    }

    /// The translation response of the window centred `offset` cells from
    /// the centre of the patch in `shared` ([`Dcf::extract_shared`]): its
    /// cells cut out of the shared fHOG, the cosine window applied, then
    /// detection as [`Dcf::detect`]. The window's centre is
    /// `centre + offset * cell_pixels(scale)`.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] (also for an empty `shared`);
    /// [`DcfError::InvalidParameter`] for an offset outside the grid;
    /// [`DcfError::NonFinite`] for a NaN response.
    pub fn detect_cut(
        &mut self,
        shared: &SharedFeatures,
        offset: (isize, isize),
    ) -> Result<&Response> {
        let g = self.geometry.ok_or(DcfError::NotInitialised)?;
        let grid = shared.grid.ok_or(DcfError::NotInitialised)?;
        let inside = |o: isize, lo: isize, hi: isize| (lo..=hi).contains(&o);
        if !(inside(offset.0, grid.lo.0, grid.hi.0) && inside(offset.1, grid.lo.1, grid.hi.1)) {
            return Err(DcfError::InvalidParameter {
                name: "cut offset",
                value: offset.0.max(offset.1) as f64,
                reason: "outside the shared grid",
            });
        }
        let (cw, ch) = shared.cells;
        let (ox, oy) = (
            (offset.0 - grid.lo.0) as usize,
            (offset.1 - grid.lo.1) as usize,
        );
        let (nx, ny) = (g.nx, g.ny);
        let plane = cw * ch;
        for (c, dst) in self.features.chunks_exact_mut(nx * ny).enumerate() {
            let src = &shared.features[c * plane..(c + 1) * plane];
            for (j, (row, win)) in dst
                .chunks_exact_mut(nx)
                .zip(self.window.chunks_exact(nx))
                .enumerate()
            {
                let s = (oy + j) * cw + ox;
                for ((v, &f), &w) in row.iter_mut().zip(&src[s..s + nx]).zip(win) {
                    *v = f * w;
                }
            }
        }
        self.respond(grid.scale)
    }

    /// DSST's estimate of the scale at `centre` in the loaded frame, from
    /// `scale`: the new scale (clamped to the frame), or `scale` when the
    /// filter has no scale model.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; sampler errors.
    pub fn scale_change(&mut self, centre: (f64, f64), scale: f64) -> Result<f64> {
        let g = self.geometry.ok_or(DcfError::NotInitialised)?;
        let Some(f) = self.scale_filter.as_mut() else {
            return Ok(scale);
        };
        let (factor, _) = f.detect(&mut self.sampler, centre.0, centre.1, scale)?;
        Ok((scale * factor).clamp(g.min_scale, g.max_scale))
    }

    /// Learns the loaded frame's target at `centre` and `scale`, the
    /// learning rates times `rate` (1: the configured rates).
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; [`DcfError::InvalidParameter`] for a
    /// rate outside `[0, 1]`.
    pub fn update(&mut self, centre: (f64, f64), scale: f64, rate: f64) -> Result<()> {
        check_rate("rate", rate)?;
        self.extract(centre, scale)?;
        let lr = self.config.learning_rate * rate;
        self.model
            .as_mut()
            .ok_or(DcfError::NotInitialised)?
            .train(&self.features, lr)?;
        self.learn_scale(centre, scale, rate)
    }

    /// The last response's features ([`Dcf::detect`], [`Dcf::detect_cut`])
    /// as their spectra, copied into `into` for [`Dcf::update_detected`].
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] before [`Dcf::init`].
    pub fn keep_detected(&self, into: &mut Vec<C32>) -> Result<()> {
        let model = self.model.as_ref().ok_or(DcfError::NotInitialised)?;
        into.clear();
        into.extend_from_slice(model.detected());
        Ok(())
    }

    /// [`Dcf::update`] from features already computed: `kept`
    /// ([`Dcf::keep_detected`]) of a window centred at `window` at `scale`,
    /// moved so that `centre` is learnt at the window's centre
    /// ([`KcfModel::train_moved`]: ECO's reuse of the detection's
    /// features). A scale filter, if any, learns at `centre` and `scale`
    /// from the loaded frame as in [`Dcf::update`].
    ///
    /// # Errors
    /// As [`Dcf::update`]; [`DcfError::Size`] for kept spectra of another
    /// size.
    pub fn update_detected(
        &mut self,
        kept: &[C32],
        window: (f64, f64),
        scale: f64,
        centre: (f64, f64),
        rate: f64,
    ) -> Result<()> {
        check_rate("rate", rate)?;
        let (px, py) = self.cell_pixels(scale);
        let moved = ((centre.0 - window.0) / px, (centre.1 - window.1) / py);
        let lr = self.config.learning_rate * rate;
        self.model
            .as_mut()
            .ok_or(DcfError::NotInitialised)?
            .train_moved(kept, moved, lr)?;
        self.learn_scale(centre, scale, rate)
    }

    /// The scale filter's share of an update (nothing without one).
    fn learn_scale(&mut self, centre: (f64, f64), scale: f64, rate: f64) -> Result<()> {
        if let (Some(f), Some(sc)) = (self.scale_filter.as_mut(), self.config.scale) {
            f.train(
                &mut self.sampler,
                centre.0,
                centre.1,
                scale,
                sc.learning_rate * rate,
            )?;
        }
        Ok(())
    }

    /// Whether the update gate admits a response (recording it when it
    /// does); always true without a gate.
    pub fn admit(&mut self, peak: f64, apce: f64) -> bool {
        self.config.gate.is_none() || self.gate.admit(peak, apce)
    }

    /// Moves the tracker's state to `centre`, `scale` (after an external
    /// estimate, e.g. a particle filter's).
    pub fn set_state(&mut self, centre: (f64, f64), scale: f64) {
        self.centre = centre;
        if let Some(g) = self.geometry {
            self.scale = scale.clamp(g.min_scale, g.max_scale);
        }
    }

    /// One frame of the classical tracker: translation at the current
    /// scale, then scale at the new centre, then a gated update. Reads
    /// only the region of `frame` around the target that these need (the
    /// same numbers as loading all of it).
    ///
    /// # Errors
    /// As [`Dcf::load`], [`Dcf::detect`], [`Dcf::update`].
    pub fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Step> {
        let (c, s) = (self.centre, self.scale);
        let (fw, fh) = (frame.width(), frame.height());
        let first = self.plan(fw, fh, c, s);
        // the first load of the frame (the sampler holds the last frame)
        self.sampler
            .load_gray_region(frame, first.unwrap_or(Region::whole(fw, fh)))?;
        let r = self.detect(c, s)?;
        let (peak, dx, dy, p, a) = (r.max, r.dx, r.dy, r.psr(), r.apce);
        let centre = self.clamp_centre((c.0 + dx, c.1 + dy));
        if let Some(f) = &self.scale_filter
            && f.region(fw, fh, centre.0, centre.1, s)
                .is_some_and(|r| !self.sampler.holds(&r))
        {
            let later = self.needs(fw, fh, centre, s * self.plan_growth());
            ensure_gray(&mut self.sampler, frame, later)?;
        }
        let scale = self.scale_change(centre, s)?;
        let updated = self.admit(peak as f64, a);
        if updated {
            let update = self.needs(fw, fh, centre, scale);
            ensure_gray(&mut self.sampler, frame, update)?;
            self.update(centre, scale, 1.0)?;
        }
        self.motion = (centre.0 - c.0).abs().max((centre.1 - c.1).abs());
        self.centre = centre;
        self.scale = scale;
        Ok(Step {
            centre,
            scale,
            size: self.size(),
            peak,
            psr: p,
            apce: a,
            updated,
        })
    }

    fn clamp_centre(&self, (x, y): (f64, f64)) -> (f64, f64) {
        let (w, h) = (self.sampler.width(), self.sampler.height());
        (
            x.clamp(0.0, w.saturating_sub(1) as f64),
            y.clamp(0.0, h.saturating_sub(1) as f64),
        )
    }
}

/// Every parameter of [`Staple`]: its correlation filter (Staple's HOG
/// DCF: window of the target plus its mean side, linear kernel, lambda
/// 1e-3, label sigma factor 1/16, learning rate 0.01, DSST's scale filter)
/// and its colour model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StapleConfig {
    /// The correlation filter.
    pub dcf: DcfConfig,
    /// Weight of the colour response in the merge (Staple: 0.3).
    pub merge_factor: f64,
    /// Learning rate of the colour histograms (Staple: 0.04).
    pub colour_rate: f64,
    /// Foreground shrink as a fraction of the mean side (Staple: 0.2).
    pub inner_padding: f64,
    /// Whether the update gate reads the merged response's peak and APCE
    /// (`false`: the correlation response's).
    pub gate_merged: bool,
}

impl Default for StapleConfig {
    fn default() -> Self {
        Self {
            dcf: DcfConfig {
                padding: Padding::MeanSide(1.0),
                lambda: 1e-3,
                output_sigma_factor: 1.0 / 16.0,
                kernel: Kernel::Linear,
                learning_rate: 0.01,
                cell: 4,
                model_area: 150.0 * 150.0,
                scale: Some(ScaleConfig {
                    lambda: 1e-3,
                    ..ScaleConfig::default()
                }),
                gate: Some((0.7, 0.45)),
            },
            merge_factor: 0.3,
            colour_rate: 0.04,
            inner_padding: 0.2,
            gate_merged: false,
        }
    }
}

impl StapleConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        self.dcf.validate()?;
        check_colour(self.merge_factor, self.colour_rate, self.inner_padding)
    }
}

/// The pixels of `frame` that the window of `dcf` at `centre`, `scale`
/// reads (`None`: nothing to load, as [`Geometry::region`]).
fn window(
    dcf: &Dcf,
    frame: ImageView<'_, u8>,
    centre: (f64, f64),
    scale: f64,
) -> Result<Option<Region>> {
    let g = dcf.geometry.ok_or(DcfError::NotInitialised)?;
    Ok(g.region(frame.width(), frame.height(), centre, scale))
}

/// The colour half's parameters, each in `[0, 1]`.
fn check_colour(merge_factor: f64, colour_rate: f64, inner_padding: f64) -> Result<()> {
    for (name, v) in [
        ("merge_factor", merge_factor),
        ("colour_rate", colour_rate),
        ("inner_padding", inner_padding),
    ] {
        if !(0.0..=1.0).contains(&v) {
            return Err(DcfError::InvalidParameter {
                name,
                value: v,
                reason: "must be in [0, 1]",
            });
        }
    }
    Ok(())
}

/// Staple's colour half (Bertinetto et al. 2016), for any [`Dcf`]:
/// foreground and background colour histograms learnt over the filter's
/// window, each pixel's object likelihood, its mean over the target's box
/// at every cell displacement of the correlation response, and the two
/// merged, `(1 - merge) cf + merge colour`. [`Staple`] drives one; so can
/// any tracker that reads a [`Dcf`]'s responses.
#[derive(Debug, Clone)]
pub struct ColourMerge {
    merge_factor: f64,
    colour_rate: f64,
    inner_padding: f64,
    colour: Option<ColourModel>,
    sampler: PatchSampler,
    planes: Vec<f32>,
    map: Vec<f32>,
    scores: Vec<f32>,
    merged: Response,
    /// The window of the patch in `planes` (the last one sampled whole).
    sampled: Option<((f64, f64), f64)>,
}

impl ColourMerge {
    /// The colour half with Staple's three parameters: the colour
    /// response's weight in the merge (Staple: 0.3), the histograms'
    /// learning rate (0.04) and the foreground's shrink as a fraction of
    /// the target's mean side (0.2).
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a parameter outside `[0, 1]`.
    pub fn new(merge_factor: f64, colour_rate: f64, inner_padding: f64) -> Result<Self> {
        check_colour(merge_factor, colour_rate, inner_padding)?;
        Ok(Self {
            merge_factor,
            colour_rate,
            inner_padding,
            colour: None,
            sampler: PatchSampler::new(),
            planes: Vec::new(),
            map: Vec::new(),
            scores: Vec::new(),
            merged: Response::default(),
            sampled: None,
        })
    }

    /// The last merged response.
    pub fn response(&self) -> &Response {
        &self.merged
    }

    /// Starts with `dcf` (already started on `frame`, gray or RGB: the
    /// histograms read it as given): learns the histograms at the target.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] for a `dcf` not started; a frame of
    /// another channel count than 1 or 3.
    pub fn init(&mut self, frame: ImageView<'_, u8>, dcf: &Dcf) -> Result<()> {
        self.colour = Some(ColourModel::new(frame.channels())?);
        let g = dcf.geometry.ok_or(DcfError::NotInitialised)?;
        self.planes = vec![0.0; frame.channels() * g.pw * g.ph];
        self.map = vec![0.0; g.pw * g.ph];
        self.scores = vec![0.0; g.nx * g.ny];
        self.merged = Response {
            w: g.nx,
            h: g.ny,
            data: vec![0.0; g.nx * g.ny],
            ..Response::default()
        };
        self.sampler.load(frame)?;
        self.learn_at(dcf, dcf.centre(), 1.0, 1.0)
    }

    /// Loads the pixels of `frame` that the window of `dcf` at `centre`,
    /// `scale` reads, grown by `margin` pixels (the whole frame where the
    /// window reads nothing).
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; a frame of another channel count.
    pub fn load(
        &mut self,
        frame: ImageView<'_, u8>,
        dcf: &Dcf,
        centre: (f64, f64),
        scale: f64,
        margin: usize,
    ) -> Result<()> {
        let (fw, fh) = (frame.width(), frame.height());
        let r = window(dcf, frame, centre, scale)?
            .map_or(Region::whole(fw, fh), |r| r.grown(margin, fw, fh));
        self.sampler.load_region(frame, r)
    }

    /// Samples the colour patch of `dcf`'s window at `centre`, `scale`.
    fn patch(&mut self, dcf: &Dcf, centre: (f64, f64), scale: f64) -> Result<Geometry> {
        let g = dcf.geometry.ok_or(DcfError::NotInitialised)?;
        let (x0, y0, sx, sy) = g.origin(centre, scale);
        let (w, h) = (self.sampler.width(), self.sampler.height());
        if let Some(r) = g.region(w, h, centre, scale)
            && !self.sampler.holds(&r)
        {
            return Err(outside());
        }
        let n = g.pw * g.ph;
        self.sampled = None;
        for (ch, plane) in self.planes.chunks_exact_mut(n).enumerate() {
            self.sampler.sample(ch, x0, y0, sx, sy, plane, g.pw, g.ph)?;
        }
        self.sampled = Some((centre, scale));
        Ok(g)
    }

    /// The target box in model pixels, `k` times its size in the patch.
    fn target_box(g: &Geometry, k: f64) -> (usize, usize) {
        (
            ((g.base.0 / g.rx * k).round() as usize).clamp(1, g.pw),
            ((g.base.1 / g.ry * k).round() as usize).clamp(1, g.ph),
        )
    }

    fn learn_at(&mut self, dcf: &Dcf, centre: (f64, f64), scale: f64, rate: f64) -> Result<()> {
        let g = self.patch(dcf, centre, scale)?;
        let (bw, bh) = Self::target_box(&g, 1.0);
        let (x0, y0) = ((g.pw - bw) / 2, (g.ph - bh) / 2);
        self.learn_box(&g, (x0, y0, x0 + bw, y0 + bh), rate)
    }

    /// The histograms learn the box `(x0, y0, x1, y1)` (model pixels) of
    /// the patch in `planes`, its foreground shrunk by the inner padding.
    fn learn_box(
        &mut self,
        g: &Geometry,
        (x0, y0, x1, y1): (usize, usize, usize, usize),
        rate: f64,
    ) -> Result<()> {
        let (bw, bh) = (x1 - x0, y1 - y0);
        let shrink = (self.inner_padding * (bw + bh) as f64 / 2.0).round() as usize;
        let colour = self.colour.as_mut().ok_or(DcfError::NotInitialised)?;
        colour.learn(
            &self.planes,
            g.pw,
            g.ph,
            (x0, y0, x1, y1),
            shrink.min(bw.min(bh).saturating_sub(1) / 2),
            self.colour_rate * rate,
        )
    }

    /// The histograms learn the target at `centre`, `scale` from the
    /// patch the last [`ColourMerge::merge`] sampled, without sampling
    /// again: the target's box moved there in whole model pixels and
    /// sized by `scale` over the patch's scale (ECO's reuse of the
    /// detection's samples, for the colour model). Returns `false`, and
    /// learns nothing, when that box would leave the patch (learn from a
    /// patch sampled there, [`ColourMerge::learn`], instead).
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`] before any merge.
    pub fn learn_detected(
        &mut self,
        dcf: &Dcf,
        centre: (f64, f64),
        scale: f64,
        rate: f64,
    ) -> Result<bool> {
        let g = dcf.geometry.ok_or(DcfError::NotInitialised)?;
        let (c, s) = self.sampled.ok_or(DcfError::NotInitialised)?;
        let (bw, bh) = Self::target_box(&g, scale / s);
        // the box's top-left in model pixels of the sampled patch: where
        // the patch's own box is, moved by the offset rounded
        let moved = |n: usize, b: usize, d: f64| ((n - b) / 2) as f64 + d.round();
        let left = moved(g.pw, bw, (centre.0 - c.0) / (g.rx * s));
        let top = moved(g.ph, bh, (centre.1 - c.1) / (g.ry * s));
        if !(left >= 0.0
            && top >= 0.0
            && left + bw as f64 <= g.pw as f64
            && top + bh as f64 <= g.ph as f64)
        {
            return Ok(false);
        }
        let (x0, y0) = (left as usize, top as usize);
        self.learn_box(&g, (x0, y0, x0 + bw, y0 + bh), rate)?;
        Ok(true)
    }

    /// The histograms learn the target at `centre`, `scale` (at `rate`
    /// times their learning rate), loading the pixels they read unless
    /// loaded.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`].
    pub fn learn(
        &mut self,
        frame: ImageView<'_, u8>,
        dcf: &Dcf,
        centre: (f64, f64),
        scale: f64,
        rate: f64,
    ) -> Result<()> {
        let r = window(dcf, frame, centre, scale)?
            .unwrap_or(Region::whole(frame.width(), frame.height()));
        if !self.sampler.holds(&r) {
            self.sampler.load_region(frame, r)?;
        }
        self.learn_at(dcf, centre, scale, rate)
    }

    /// The response `dcf` computed last (its window at `centre`, `scale`)
    /// merged with the colour score of the same displacements: peak,
    /// displacement and APCE of the merge.
    ///
    /// # Errors
    /// [`DcfError::NotInitialised`]; the window reads outside the loaded
    /// region ([`ColourMerge::load`]); a non-finite merge.
    pub fn merge(&mut self, dcf: &Dcf, centre: (f64, f64), scale: f64) -> Result<&Response> {
        let g = self.patch(dcf, centre, scale)?;
        let colour = self.colour.as_mut().ok_or(DcfError::NotInitialised)?;
        colour.likelihood(&self.planes[..], g.pw, g.ph, &mut self.map)?;
        let (bw, bh) = Self::target_box(&g, 1.0);
        colour.box_scores(
            &self.map,
            g.pw,
            g.ph,
            (bw, bh),
            (g.nx, g.ny, dcf.config.cell),
            &mut self.scores,
        )?;
        let m = self.merge_factor as f32;
        for ((o, &cf), &p) in self
            .merged
            .data
            .iter_mut()
            .zip(&dcf.response.data)
            .zip(&self.scores)
        {
            *o = (1.0 - m) * cf + m * p;
        }
        self.merged.px = dcf.response.px;
        self.merged.finish()?;
        Ok(&self.merged)
    }
}

/// Staple (Bertinetto et al. 2016): [`Dcf`] with a colour-histogram
/// response merged into the correlation response ([`ColourMerge`]).
#[derive(Debug, Clone)]
pub struct Staple {
    dcf: Dcf,
    colour: ColourMerge,
    gate_merged: bool,
}

impl Staple {
    /// A tracker model with `config`.
    ///
    /// # Errors
    /// [`DcfError::InvalidParameter`] for a bad parameter.
    pub fn new(config: StapleConfig) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            dcf: Dcf::new(config.dcf)?,
            colour: ColourMerge::new(
                config.merge_factor,
                config.colour_rate,
                config.inner_padding,
            )?,
            gate_merged: config.gate_merged,
        })
    }

    /// The correlation filter.
    pub fn dcf(&self) -> &Dcf {
        &self.dcf
    }

    /// The last merged response.
    pub fn response(&self) -> &Response {
        self.colour.response()
    }

    /// Starts on `frame` (gray or RGB: the colour model reads it as given,
    /// the correlation filter its gray levels).
    ///
    /// # Errors
    /// As [`Dcf::init`]; a frame of another channel count than 1 or 3.
    pub fn init(
        &mut self,
        frame: ImageView<'_, u8>,
        centre: (f64, f64),
        size: (f64, f64),
    ) -> Result<()> {
        self.dcf.init(frame, centre, size)?;
        self.colour.init(frame, &self.dcf)
    }

    /// One frame: the merged response gives the centre, DSST the scale;
    /// both models learn when the correlation response passes the gate.
    /// Reads only the region of `frame` around the target that these need
    /// (as [`Dcf::step`]).
    ///
    /// # Errors
    /// As [`Staple::init`].
    pub fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Step> {
        let (c, s) = (self.dcf.centre, self.dcf.scale);
        let (fw, fh) = (frame.width(), frame.height());
        let whole = Region::whole(fw, fh);
        let first = self.dcf.plan(fw, fh, c, s);
        self.dcf
            .sampler
            .load_gray_region(frame, first.unwrap_or(whole))?;
        // the colour patches: the window now and after the update
        let growth = self.dcf.plan_growth();
        let margin = self.dcf.motion.ceil() as usize + 4;
        self.colour.load(frame, &self.dcf, c, s * growth, margin)?;
        let r = self.dcf.detect(c, s)?;
        let (cf_peak, cf_apce) = (r.max as f64, r.apce);
        let merged = self.colour.merge(&self.dcf, c, s)?;
        let (dx, dy, peak, psr, apce) =
            (merged.dx, merged.dy, merged.max, merged.psr(), merged.apce);
        let centre = self.dcf.clamp_centre((c.0 + dx, c.1 + dy));
        if let Some(f) = &self.dcf.scale_filter
            && f.region(fw, fh, centre.0, centre.1, s)
                .is_some_and(|r| !self.dcf.sampler.holds(&r))
        {
            let later = self.dcf.needs(fw, fh, centre, s * growth);
            ensure_gray(&mut self.dcf.sampler, frame, later)?;
        }
        let scale = self.dcf.scale_change(centre, s)?;
        let updated = if self.gate_merged {
            self.dcf.admit(f64::from(peak), apce)
        } else {
            self.dcf.admit(cf_peak, cf_apce)
        };
        if updated {
            let update = self.dcf.needs(fw, fh, centre, scale);
            ensure_gray(&mut self.dcf.sampler, frame, update)?;
            self.dcf.update(centre, scale, 1.0)?;
            self.colour.learn(frame, &self.dcf, centre, scale, 1.0)?;
        }
        self.dcf.motion = (centre.0 - c.0).abs().max((centre.1 - c.1).abs());
        self.dcf.centre = centre;
        self.dcf.scale = scale;
        Ok(Step {
            centre,
            scale,
            size: self.dcf.size(),
            peak,
            psr,
            apce,
            updated,
        })
    }
}

/// Every channel of `features` (planes of `window.len()` values) times
/// the cosine window, value by value (compiled for the machine's vector
/// width: the same products at every level).
struct Windowed<'a> {
    features: &'a mut [f32],
    window: &'a [f32],
}

impl SimdKernel for Windowed<'_> {
    type Output = ();
    #[inline(always)]
    fn run<T: Token>(self, _: T) {
        for ch in self.features.chunks_exact_mut(self.window.len()) {
            for (v, w) in ch.iter_mut().zip(self.window) {
                *v *= w;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bayestrack_image::{Image, rgb_to_gray};

    /// The windowing kernel against the scalar products, bit for bit, at
    /// every level: odd and vector-wide planes, one or many channels,
    /// signed zeros and subnormals among the values.
    #[test]
    fn windowing_is_the_scalar_product_at_every_level() {
        use bayestrack_image::simd::SimdLevel;
        for (w, h, c) in [
            (1, 1, 1),
            (3, 5, 2),
            (8, 1, 31),
            (7, 9, 3),
            (16, 40, 31),
            (13, 11, 31),
        ] {
            let window = cosine_window(w, h);
            let mut s = (w * 31 + h * 7 + c) as u32;
            let features: Vec<f32> = (0..w * h * c)
                .map(|i| match i % 7 {
                    0 => -0.0,
                    1 => 1e-39,
                    _ => {
                        s ^= s << 13;
                        s ^= s >> 17;
                        s ^= s << 5;
                        s as f32 / u32::MAX as f32 - 0.3
                    }
                })
                .collect();
            let want: Vec<f32> = features
                .chunks_exact(w * h)
                .flat_map(|ch| ch.iter().zip(&window).map(|(v, w)| v * w))
                .collect();
            for level in SimdLevel::ALL {
                let mut got = features.clone();
                level.run(Windowed {
                    features: &mut got,
                    window: &window,
                });
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "{w}x{h}x{c} {level:?}");
            }
        }
    }

    /// An RGB frame: a textured 24 x 30 target centred at `(cx, cy)` on a
    /// textured background.
    fn frame(cx: f64, cy: f64) -> Image<u8> {
        let (w, h) = (160, 120);
        let mut data = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let (u, v) = (x as f64 - cx, y as f64 - cy);
                for ch in 0..3 {
                    let t = if u.abs() < 12.0 && v.abs() < 15.0 {
                        128.0 + 70.0 * (0.6 * u + ch as f64).sin() * (0.5 * v).cos()
                    } else {
                        90.0 + 30.0 * (0.31 * x as f64 + ch as f64).sin()
                            + 25.0 * (0.17 * y as f64).cos()
                    };
                    data.push(t.clamp(0.0, 255.0) as u8);
                }
            }
        }
        Image::from_vec(w, h, 3, data).unwrap()
    }

    /// `step` reads only regions of the frame, of an RGB frame converts
    /// only them: the same steps, bit for bit, as loading the whole gray
    /// frame and detecting, estimating the scale and updating, through a
    /// slow drift, a jump the first load does not cover, and the edge.
    #[test]
    fn a_step_on_regions_is_a_step_on_the_whole_frame() {
        let path = |k: usize| match k {
            0..=9 => (60.0 + k as f64, 50.0 + 0.5 * k as f64),
            10..=14 => (80.0, 62.0),
            _ => (150.0, 100.0 + k as f64),
        };
        // no gate: every frame learns, the jump's too (a load the plan
        // missed)
        let config = DcfConfig {
            gate: None,
            ..DcfConfig::default()
        };
        let mut fast = Dcf::new(config).unwrap();
        let mut slow = Dcf::new(config).unwrap();
        let first = frame(path(0).0, path(0).1);
        fast.init(first.view(), path(0), (24.0, 30.0)).unwrap();
        slow.init(
            rgb_to_gray(first.view()).unwrap().view(),
            path(0),
            (24.0, 30.0),
        )
        .unwrap();
        for k in 1..20 {
            let f = frame(path(k).0, path(k).1);
            let got = fast.step(f.view()).unwrap();
            // the same step on the whole gray frame
            slow.load(rgb_to_gray(f.view()).unwrap().view()).unwrap();
            let (c, s) = (slow.centre, slow.scale);
            let r = slow.detect(c, s).unwrap();
            let (peak, dx, dy, apce) = (r.max, r.dx, r.dy, r.apce);
            let centre = slow.clamp_centre((c.0 + dx, c.1 + dy));
            let scale = slow.scale_change(centre, s).unwrap();
            let updated = slow.admit(peak as f64, apce);
            if updated {
                slow.update(centre, scale, 1.0).unwrap();
            }
            slow.set_state(centre, scale);
            let bits = |v: (f64, f64)| (v.0.to_bits(), v.1.to_bits());
            assert_eq!(bits(got.centre), bits(centre), "frame {k}");
            assert_eq!(got.scale.to_bits(), scale.to_bits(), "frame {k}");
            assert_eq!((got.peak, got.updated), (peak, updated), "frame {k}");
        }
        // a sample outside the region loaded is an error, not stale data
        let r = fast.sampler.region();
        assert!(r != Region::whole(160, 120), "{r:?}");
        let far = if r.x0 > 40 {
            (5.0, 5.0)
        } else {
            (150.0, 110.0)
        };
        assert!(matches!(
            fast.detect(far, 1.0),
            Err(DcfError::InvalidParameter {
                name: "sample region",
                ..
            })
        ));
    }

    /// The shared grid's responses ([`Dcf::extract_shared`],
    /// [`Dcf::detect_cut`]) against each window's own ([`Dcf::detect`] at
    /// the same centre): a 3 x 3 grid half a window apart, one window past
    /// the frame's left edge, at three scales. The windowed features of
    /// cells two or more from a window's border are the same up to the
    /// sampler's rounding (max abs difference 1e-4 of the largest), the
    /// responses differ by at most 2 % of the peak (the border cells, which
    /// the cosine window nearly zeroes, see past their window) and peak
    /// at the same cell.
    #[test]
    fn a_cut_of_the_shared_features_is_the_window_away_from_its_border() {
        let config = DcfConfig {
            gate: None,
            scale: None,
            ..DcfConfig::default()
        };
        let mut a = Dcf::new(config).unwrap();
        let first = frame(60.0, 55.0);
        a.init(first.view(), (60.0, 55.0), (24.0, 30.0)).unwrap();
        let f = frame(70.0, 60.0);
        a.load(f.view()).unwrap();
        let (nx, ny) = a.cells();
        let mut shared = SharedFeatures::new();
        let mut worst = (0.0f32, 0.0f32);
        for scale in [0.96, 1.0, 1.04] {
            let cp = a.cell_pixels(scale);
            let (kx, ky) = ((nx / 2) as isize, (ny / 2) as isize);
            // the left column moved 20 cells: past the frame's left edge
            let (lo, hi) = ((-kx - 20, -ky), (kx, ky));
            let centre = (60.0, 55.0);
            let grid = SharedGrid {
                centre,
                scale,
                lo,
                hi,
            };
            a.extract_shared(&mut shared, grid).unwrap();
            for oy in [-ky, 0, ky] {
                for ox in [-kx - 20, 0, kx] {
                    let wc = (centre.0 + ox as f64 * cp.0, centre.1 + oy as f64 * cp.1);
                    let own = a.detect(wc, scale).unwrap().clone();
                    let own_features = a.features.clone();
                    let cut = a.detect_cut(&shared, (ox, oy)).unwrap().clone();
                    let big = own_features.iter().fold(0.0f32, |m, v| m.max(v.abs()));
                    let plane = nx * ny;
                    for c in 0..HOG_CHANNELS {
                        for j in 2..ny - 2 {
                            for i in 2..nx - 2 {
                                let k = c * plane + j * nx + i;
                                let d = (own_features[k] - a.features[k]).abs() / big;
                                worst.0 = worst.0.max(d);
                            }
                        }
                    }
                    let d = own
                        .data()
                        .iter()
                        .zip(cut.data())
                        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
                    worst.1 = worst.1.max(d / own.max.abs());
                    let argmax = |r: &Response| {
                        (0..r.data().len())
                            .max_by(|&i, &j| r.data()[i].total_cmp(&r.data()[j]))
                            .unwrap()
                    };
                    assert_eq!(argmax(&own), argmax(&cut), "{ox} {oy} {scale}");
                    assert_eq!(own.pixels_per_cell(), cut.pixels_per_cell());
                }
            }
        }
        eprintln!("worst interior feature, response differences: {worst:?}");
        assert!(worst.0 < 1e-4, "{worst:?}");
        assert!(worst.1 < 0.02, "{worst:?}");
        // an offset outside the grid is an error
        assert!(a.detect_cut(&shared, (100, 0)).is_err());
    }

    /// `load_windows` loads the union of the windows' regions only (of an
    /// RGB frame, converts only it): detection there and an update
    /// `ensure_loaded` prepares give the numbers of a whole-frame load, bit
    /// for bit; a window outside the loaded region is an error until
    /// `ensure_loaded` loads it.
    #[test]
    fn loading_the_windows_is_loading_the_frame() {
        let config = DcfConfig {
            gate: None,
            ..DcfConfig::default()
        };
        let mut part = Dcf::new(config).unwrap();
        let mut whole = Dcf::new(config).unwrap();
        let first = frame(50.0, 45.0);
        part.init(first.view(), (50.0, 45.0), (24.0, 30.0)).unwrap();
        whole
            .init(first.view(), (50.0, 45.0), (24.0, 30.0))
            .unwrap();
        let f = frame(54.0, 47.0);
        let windows = [
            ((50.0, 45.0), 1.0),
            ((40.0, 38.0), 0.96),
            ((62.0, 50.0), 1.04),
        ];
        part.load_windows(f.view(), windows).unwrap();
        whole.load(f.view()).unwrap();
        assert!(part.sampler.region() != Region::whole(160, 120));
        let bits = |d: &Dcf| {
            d.response()
                .data()
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>()
        };
        for (c, s) in windows {
            part.detect(c, s).unwrap();
            whole.detect(c, s).unwrap();
            assert_eq!(bits(&part), bits(&whole), "window at {c:?}, scale {s}");
        }
        let far = (150.0, 110.0);
        assert!(matches!(
            part.detect(far, 1.0),
            Err(DcfError::InvalidParameter {
                name: "sample region",
                ..
            })
        ));
        part.ensure_loaded(f.view(), far, 1.0).unwrap();
        part.detect(far, 1.0).unwrap();
        whole.detect(far, 1.0).unwrap();
        assert_eq!(bits(&part), bits(&whole), "far window");
        // an update where the loaded region lacks it, then detection
        let at = (53.0, 46.5);
        part.ensure_loaded(f.view(), at, 1.02).unwrap();
        part.update(at, 1.02, 1.0).unwrap();
        whole.update(at, 1.02, 1.0).unwrap();
        part.detect(at, 1.02).unwrap();
        whole.detect(at, 1.02).unwrap();
        assert_eq!(bits(&part), bits(&whole), "after the update");
    }

    /// An RGB frame: a red 24 x 30 box centred at `(cx, cy)` on a green
    /// background, both under a gray-level texture fixed to the frame.
    fn red_on_green(cx: f64, cy: f64) -> Image<u8> {
        let (w, h) = (160, 120);
        let mut data = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let (u, v) = (x as f64 - cx, y as f64 - cy);
                let t = 30.0 * (0.7 * x as f64).sin() * (0.4 * y as f64).cos();
                let px = if u.abs() < 12.0 && v.abs() < 15.0 {
                    [200.0 + t, 40.0 + t, 40.0 + t]
                } else {
                    [60.0 + t, 140.0 + t, 70.0 + t]
                };
                data.extend(px.map(|c: f64| c.clamp(0.0, 255.0) as u8));
            }
        }
        Image::from_vec(w, h, 3, data).unwrap()
    }

    /// The colour half: with weight 0 the merge is the correlation
    /// response bit for bit; with weight 1 it is the colour score alone,
    /// which peaks where the red box went (8 px right, 3 px up of the
    /// window's centre) within half a cell, where the correlation
    /// response, held by the texture fixed to the frame, stays within a
    /// pixel of the centre (seen by merging the correlation response in
    /// place of the colour score); a window outside the loaded region and
    /// parameters outside `[0, 1]` are errors.
    #[test]
    fn the_colour_merge_is_the_correlation_at_0_and_the_colour_at_1() {
        let (f0, f1) = (red_on_green(80.0, 60.0), red_on_green(88.0, 57.0));
        let mut dcf = Dcf::new(DcfConfig::default()).unwrap();
        dcf.init(f0.view(), (80.0, 60.0), (24.0, 30.0)).unwrap();
        let mut merges = [0.0, 1.0].map(|w| ColourMerge::new(w, 0.04, 0.2).unwrap());
        for m in &mut merges {
            m.init(f0.view(), &dcf).unwrap();
        }
        dcf.load(f1.view()).unwrap();
        let cf: Vec<u32> = dcf
            .detect((80.0, 60.0), 1.0)
            .unwrap()
            .data()
            .iter()
            .map(|v| v.to_bits())
            .collect();
        let [zero, one] = &mut merges;
        zero.load(f1.view(), &dcf, (80.0, 60.0), 1.0, 0).unwrap();
        let z = zero.merge(&dcf, (80.0, 60.0), 1.0).unwrap();
        assert_eq!(z.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>(), cf);
        one.load(f1.view(), &dcf, (80.0, 60.0), 1.0, 0).unwrap();
        let o = one.merge(&dcf, (80.0, 60.0), 1.0).unwrap();
        assert!(
            (o.dx - 8.0).abs() <= 2.0 && (o.dy + 3.0).abs() <= 2.0,
            "colour peak at {:.2}, {:.2}",
            o.dx,
            o.dy
        );
        // a window the loaded region does not hold
        assert!(one.merge(&dcf, (20.0, 60.0), 1.0).is_err());
        for bad in [-0.1, 1.5, f64::NAN] {
            assert!(ColourMerge::new(bad, 0.04, 0.2).is_err());
            assert!(ColourMerge::new(0.3, bad, 0.2).is_err());
            assert!(ColourMerge::new(0.3, 0.04, bad).is_err());
        }
    }

    /// Learning from the merge's patch: with no move it learns what a
    /// patch sampled again learns (the next merges agree bit for bit);
    /// moved by the red box's own move (8 px right, 3 px up) it learns the
    /// box where it went (at learning rate 1, the histograms replaced),
    /// so the next merge's colour score peaks on it within half a cell
    /// (the move's sign flipped, the peak goes to -13.1, 0.8); a box moved
    /// out of the patch learns nothing and says so.
    #[test]
    fn the_colour_model_learns_from_the_merge_patch_as_from_a_new_one() {
        let (f0, f1) = (red_on_green(80.0, 60.0), red_on_green(88.0, 57.0));
        let mut dcf = Dcf::new(DcfConfig::default()).unwrap();
        dcf.init(f0.view(), (80.0, 60.0), (24.0, 30.0)).unwrap();
        let mut fresh = ColourMerge::new(1.0, 1.0, 0.2).unwrap();
        fresh.init(f0.view(), &dcf).unwrap();
        let mut reused = fresh.clone();
        dcf.load(f1.view()).unwrap();
        dcf.detect((80.0, 60.0), 1.0).unwrap();
        let bits = |r: &Response| r.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for m in [&mut fresh, &mut reused] {
            m.load(f1.view(), &dcf, (80.0, 60.0), 1.0, 0).unwrap();
            m.merge(&dcf, (80.0, 60.0), 1.0).unwrap();
        }
        fresh
            .learn(f1.view(), &dcf, (80.0, 60.0), 1.0, 1.0)
            .unwrap();
        assert!(reused.learn_detected(&dcf, (80.0, 60.0), 1.0, 1.0).unwrap());
        let a = bits(fresh.merge(&dcf, (80.0, 60.0), 1.0).unwrap());
        let b = bits(reused.merge(&dcf, (80.0, 60.0), 1.0).unwrap());
        assert_eq!(a, b);
        // moved with the box: the histograms keep the red box
        assert!(reused.learn_detected(&dcf, (88.0, 57.0), 1.0, 1.0).unwrap());
        let o = reused.merge(&dcf, (80.0, 60.0), 1.0).unwrap();
        assert!(
            (o.dx - 8.0).abs() <= 2.0 && (o.dy + 3.0).abs() <= 2.0,
            "colour peak at {:.2}, {:.2}",
            o.dx,
            o.dy
        );
        // out of the patch
        assert!(
            !reused
                .learn_detected(&dcf, (160.0, 60.0), 1.0, 1.0)
                .unwrap()
        );
    }

    /// An RGB frame: a 24 x 30 box of `base` colour under a texture that
    /// moves with it, centred at `(cx, cy)` on a green background with a
    /// texture fixed to the frame.
    fn tinted(cx: f64, cy: f64, base: [f64; 3]) -> Image<u8> {
        let (w, h) = (160, 120);
        let mut data = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let (u, v) = (x as f64 - cx, y as f64 - cy);
                let px = if u.abs() < 12.0 && v.abs() < 15.0 {
                    let t = 45.0 * (0.9 * u).sin() * (0.6 * v).cos();
                    base.map(|c| c + t)
                } else {
                    let t = 30.0 * (0.7 * x as f64).sin() * (0.4 * y as f64).cos();
                    [60.0 + t, 140.0 + t, 70.0 + t]
                };
                data.extend(px.map(|c: f64| c.clamp(0.0, 255.0) as u8));
            }
        }
        Image::from_vec(w, h, 3, data).unwrap()
    }

    /// A red target turns green-gray (the background's hue) at frame 10
    /// with its gray levels kept (BT.601: 0.299 r + 0.587 g + 0.114 b is
    /// 88 either way): the correlation response, which reads gray levels,
    /// hardly moves and Staple's default gate keeps learning it; the gate
    /// on the merged response sees the colour score fall and refuses
    /// (measured: 10 of the 10 frames after the change learnt, and 0).
    #[test]
    fn the_gate_on_the_merged_response_reads_the_colour_score() {
        let learnt = |gate_merged: bool| {
            let mut t = Staple::new(StapleConfig {
                gate_merged,
                ..StapleConfig::default()
            })
            .unwrap();
            let red = [200.0, 40.0, 40.0];
            t.init(tinted(60.0, 60.0, red).view(), (60.0, 60.0), (24.0, 30.0))
                .unwrap();
            (1..20usize)
                .filter(|&k| {
                    let base = if k < 10 { red } else { [40.0, 122.0, 40.0] };
                    let f = tinted(60.0 + k as f64, 60.0, base);
                    t.step(f.view()).unwrap().updated && k >= 10
                })
                .count()
        };
        let (cf, merged) = (learnt(false), learnt(true));
        assert!(
            cf >= 8 && merged <= 2,
            "learnt after the change: {cf} with the correlation gate, {merged} with the merged one"
        );
    }
}
