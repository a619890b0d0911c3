//! The correlation-filter trackers of issue 26 (`bayestrack-dcf`):
//!
//! - [`DcfTracker`] (`dcf`): KCF's Gaussian-kernel correlation filter on
//!   fHOG (Henriques et al. 2015) with fDSST's scale filter (Danelljan
//!   et al. 2017: 17 scales interpolated to 33; DSST's 33-scale filter of
//!   2014 with `fdsst=false`); the model learns only when the response
//!   passes LMCF's APCE gate (Wang et al. 2017).
//! - [`StapleTracker`] (`dcf-staple`): Staple (Bertinetto et al. 2016): a
//!   linear HOG correlation filter and a colour-histogram response merged
//!   0.7 / 0.3, fDSST's scale filter (DSST's with `fdsst=false`), the
//!   same gate.
//!
//! Both work on gray and RGB video: the correlation filter reads gray
//! levels (of an RGB frame, converted only in the region around the
//! target that a frame's samples read: no whole-frame gray plane); Staple's
//! colour model reads the frame as given (joint RGB
//! histograms of 32^3 bins, or 32 gray bins). Deterministic: no
//! randomness. Every default is the paper's published value (see each
//! option); none was tuned on the evaluation sequences.
//!
//! An [`Estimate`] is `lost` when the gate refused the frame's response
//! (a weak or multi-modal peak: occlusion, fast appearance change).

use bayestrack_dcf::kcf::Kernel;
use bayestrack_dcf::scale::{ScaleConfig, ScaleMethod};
use bayestrack_dcf::{Dcf, DcfConfig, Padding, Staple, StapleConfig, Step};
use bayestrack_image::BBox;
use bayestrack_options::{choice, options};

use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

options! {
    /// KCF's translation filter on fHOG, with KCF's published HOG values
    /// (Henriques et al. 2015, sec. 6.1): the options `dcf` and `pf-dcf`
    /// share.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct KcfOptions {
        /// Search window `(1 + padding)` times the target (KCF: 1.5).
        pub padding: f64 = 1.5;
        /// Ridge regularisation lambda (KCF: 1e-4).
        pub lambda: f64 = 1e-4;
        /// Label standard deviation per `sqrt(w h)` of the target (KCF: 0.1).
        pub output_sigma_factor: f64 = 0.1;
        /// Gaussian kernel bandwidth (KCF with HOG: 0.5); 0 selects the
        /// linear kernel.
        pub kernel_sigma: f64 = 0.5;
        /// Translation model learning rate (KCF with HOG: 0.02).
        pub learning_rate: f64 = 0.02;
        /// fHOG cell, pixels (KCF: 4).
        pub cell: usize = 4;
        /// Largest area of the search window, model pixels (Staple's fixed
        /// area, 150^2): larger windows are shrunk to it, smaller ones stay at
        /// the frame's resolution (KCF); bounds the cost per frame.
        pub model_area: f64 = 22500.0;
    }
}

impl KcfOptions {
    /// The filter's configuration, without scale filter or gate.
    pub fn to_dcf(&self) -> DcfConfig {
        DcfConfig {
            padding: Padding::Relative(self.padding),
            lambda: self.lambda,
            output_sigma_factor: self.output_sigma_factor,
            kernel: if self.kernel_sigma == 0.0 {
                Kernel::Linear
            } else {
                Kernel::Gaussian {
                    sigma: self.kernel_sigma,
                }
            },
            learning_rate: self.learning_rate,
            cell: self.cell,
            model_area: self.model_area,
            scale: None,
            gate: None,
        }
    }
}

options! {
    /// DSST's scale filter (Danelljan et al. 2014, sec. 4), or fDSST's
    /// (Danelljan et al. 2017): the options `dcf` and `dcf-staple` share
    /// (Staple's regularisation is 1e-3, DSST's 1e-2).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct ScaleOptions {
        /// Estimate the scale (DSST's or fDSST's filter; false: translation only).
        pub scale: bool = true;
        /// Number of scales (DSST: 33).
        pub scales: usize = 33;
        /// Ratio between neighbouring scales (DSST: 1.02).
        pub scale_step: f64 = 1.02;
        /// Scale label width per sqrt(scales) (DSST: 1/4).
        pub scale_sigma_factor: f64 = 0.25;
        /// Scale filter regularisation (DSST: 1e-2; Staple: 1e-3).
        pub scale_lambda: f64 = 1e-2;
        /// Scale model learning rate (DSST: 0.025).
        pub scale_learning_rate: f64 = 0.025;
        /// Largest area of the scale samples, pixels (DSST: 512; Staple:
        /// 32 x 16 = 512).
        pub scale_model_max_area: f64 = 512.0;
        /// fDSST's scale filter (Danelljan et al. 2017): 17 scales
        /// interpolated to 33, label factor 1/16, features compressed on the
        /// learnt samples' basis, instead of DSST's 33 (`scales` and
        /// `scale_sigma_factor` then unused, but still checked); the step,
        /// lambda, rate and area above still apply. False here (DSST's
        /// values above); `dcf` and `dcf-staple` default to true (see their
        /// configurations).
        pub fdsst: bool = false;
    }
}

impl ScaleOptions {
    /// The scale filter's configuration for HOG cells of `cell` pixels, or
    /// `None` without scale estimation.
    pub fn to_scale(&self, cell: usize) -> Option<ScaleConfig> {
        self.scale
            .then_some(scale_config(self.fdsst, self.dsst(cell)))
    }

    /// DSST's configuration as the options give it (what `fdsst=false`
    /// runs).
    fn dsst(&self, cell: usize) -> ScaleConfig {
        ScaleConfig {
            scales: self.scales,
            step: self.scale_step,
            sigma_factor: self.scale_sigma_factor,
            lambda: self.scale_lambda,
            learning_rate: self.scale_learning_rate,
            model_max_area: self.scale_model_max_area,
            cell,
            method: ScaleMethod::Dsst,
        }
    }

    /// Checks every option, also those fDSST leaves unused (`scales`,
    /// `scale_sigma_factor`): a bad value is an error whichever filter
    /// runs, not ignored.
    ///
    /// # Errors
    /// [`bayestrack_dcf::DcfError::InvalidParameter`] naming the first bad
    /// one.
    pub fn validate(&self, cell: usize) -> bayestrack_dcf::Result<()> {
        if self.scale {
            self.dsst(cell).validate()?;
        }
        Ok(())
    }
}

options! {
    /// LMCF's update gate (Wang et al. 2017, sec. 3.3): a response is learnt
    /// only when its peak and APCE reach fractions of their means.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct GateOptions {
        /// Gate the model update on the response (LMCF's rule); without the
        /// gate every frame is learnt and none is lost.
        pub gate: bool = true;
        /// Fraction of the mean peak a learnt response needs (LMCF beta_1: 0.7).
        pub gate_peak: f64 = 0.7;
        /// Fraction of the mean APCE a learnt response needs (LMCF beta_2: 0.45).
        pub gate_apce: f64 = 0.45;
    }
}

impl GateOptions {
    /// `(peak, APCE)` fractions, or `None` without the gate.
    pub fn to_gate(&self) -> Option<(f64, f64)> {
        self.gate.then_some((self.gate_peak, self.gate_apce))
    }
}

/// What the update gate reads where a colour score is merged into the
/// correlation response (`dcf-staple`'s and `pf-dcf`'s `gate_response`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GateResponse {
    /// The correlation response alone.
    Correlation,
    /// The response merged with the colour score.
    Merged,
}

choice! {
    GateResponse { Correlation = "correlation", Merged = "merged" }
}

options! {
    /// Every parameter of [`DcfTracker`]: KCF's published HOG parameters
    /// (Henriques et al. 2015, sec. 6.1), fDSST's scale filter (Danelljan
    /// et al. 2017, sec. 4.3), LMCF's update gate (Wang et al. 2017, sec. 3.3).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct DcfTrackerConfig {}
    groups {
        /// The translation filter.
        pub kcf: KcfOptions = KcfOptions::default();
        /// The scale filter: fDSST's (`fdsst=true`), chosen over DSST's on
        /// the synthetic stress set by the rule "fDSST when its mean SR@0.5
        /// and AUC are at most 0.005 below DSST's on stress seeds 1 and 2,
        /// the faster breaking the tie" (`cargo xtask stress --trackers dcf
        /// --sweep fdsst=false,true`, 2026-12-03: SR@0.5 0.793 / 0.790 and
        /// 0.907 / 0.907, AUC 0.749 / 0.749 and 0.858 / 0.859, DSST /
        /// fDSST; the real sequences were not consulted).
        pub scale: ScaleOptions = ScaleOptions {
            fdsst: true,
            ..ScaleOptions::default()
        };
        /// The update gate.
        pub gate: GateOptions = GateOptions::default();
    }
    check check_dcf;
}

fn check_dcf(c: &DcfTrackerConfig) -> std::result::Result<(), String> {
    c.scale
        .validate(c.kcf.cell)
        .and_then(|()| c.to_dcf().validate())
        .map_err(|e| e.to_string())
}

impl DcfTrackerConfig {
    /// The model's configuration.
    pub fn to_dcf(&self) -> DcfConfig {
        DcfConfig {
            scale: self.scale.to_scale(self.kcf.cell),
            gate: self.gate.to_gate(),
            ..self.kcf.to_dcf()
        }
    }
}

options! {
    /// Every parameter of [`StapleTracker`]: Staple's published values
    /// (Bertinetto et al. 2016, sec. 5 and its code's defaults), fDSST's scale
    /// filter (with Staple's regularisation), LMCF's update gate.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct StapleTrackerConfig {
        /// Context added to each side of the window, in mean sides
        /// `(w + h) / 2` (Staple: 1, the window is the target plus its mean side).
        pub padding: f64 = 1.0;
        /// Ridge regularisation lambda (Staple: 1e-3).
        pub lambda: f64 = 1e-3;
        /// Label standard deviation per `sqrt(w h)` of the target (Staple: 1/16).
        pub output_sigma_factor: f64 = 0.0625;
        /// Correlation filter learning rate (Staple: 0.01).
        pub learning_rate: f64 = 0.01;
        /// fHOG cell, pixels (Staple: 4).
        pub cell: usize = 4;
        /// Largest area of the search window, model pixels (Staple's fixed
        /// area 150^2; smaller windows stay at the frame's resolution).
        pub model_area: f64 = 22500.0;
        /// Weight of the colour response in the merge (Staple: 0.3).
        pub merge_factor: f64 = 0.3;
        /// Colour histogram learning rate (Staple: 0.04).
        pub colour_rate: f64 = 0.04;
        /// Foreground shrink per mean side (Staple's inner padding: 0.2).
        pub inner_padding: f64 = 0.2;
        /// What the update gate reads: `correlation` (the correlation
        /// response alone) or `merged` (the merged map's peak and APCE, as
        /// pf-dcf's gate). The stress set kept `correlation`: over its
        /// four set seeds `merged` gained 0.0032 mean SR@0.5, below the
        /// 0.005 a change of the same cost has to gain (docs/results.md,
        /// "dcf-staple: the gate reading the merged response").
        pub gate_response: GateResponse = GateResponse::Correlation;
    }
    groups {
        /// The scale filter: Staple's regularisation 1e-3, and fDSST's
        /// filter (`fdsst=true`), chosen over DSST's on the synthetic stress
        /// set by the rule "fDSST when its mean SR@0.5 and AUC are at most
        /// 0.005 below DSST's on stress seeds 1 and 2, the faster breaking
        /// the tie" (`cargo xtask stress --trackers dcf-staple --sweep
        /// fdsst=false,true`, 2026-12-03: SR@0.5 0.807 / 0.808 and 0.843 /
        /// 0.875, AUC 0.763 / 0.762 and 0.800 / 0.830, DSST / fDSST; the
        /// real sequences were not consulted).
        pub scale: ScaleOptions = ScaleOptions {
            scale_lambda: 1e-3,
            fdsst: true,
            ..ScaleOptions::default()
        };
        /// The update gate (on the correlation response).
        pub gate: GateOptions = GateOptions::default();
    }
    check check_staple;
}

fn check_staple(c: &StapleTrackerConfig) -> std::result::Result<(), String> {
    c.scale
        .validate(c.cell)
        .and_then(|()| c.to_staple().validate())
        .map_err(|e| e.to_string())
}

impl StapleTrackerConfig {
    /// The model's configuration.
    pub fn to_staple(&self) -> StapleConfig {
        StapleConfig {
            dcf: DcfConfig {
                padding: Padding::MeanSide(self.padding),
                lambda: self.lambda,
                output_sigma_factor: self.output_sigma_factor,
                kernel: Kernel::Linear,
                learning_rate: self.learning_rate,
                cell: self.cell,
                model_area: self.model_area,
                scale: self.scale.to_scale(self.cell),
                gate: self.gate.to_gate(),
            },
            merge_factor: self.merge_factor,
            colour_rate: self.colour_rate,
            inner_padding: self.inner_padding,
            gate_merged: self.gate_response == GateResponse::Merged,
        }
    }
}

/// The scale filter's configuration: `dsst` as given, or fDSST's
/// published scales, label and method with `dsst`'s step, lambda, rate,
/// area and cell.
fn scale_config(fdsst: bool, dsst: ScaleConfig) -> ScaleConfig {
    if fdsst {
        ScaleConfig {
            step: dsst.step,
            lambda: dsst.lambda,
            learning_rate: dsst.learning_rate,
            model_max_area: dsst.model_max_area,
            cell: dsst.cell,
            ..ScaleConfig::fdsst()
        }
    } else {
        dsst
    }
}

/// The OTB box of a centre (0-based) and size.
fn bbox_of((cx, cy): (f64, f64), (w, h): (f64, f64)) -> BBox {
    BBox::new(cx - (w - 1.0) / 2.0 + 1.0, cy - (h - 1.0) / 2.0 + 1.0, w, h)
}

/// The 0-based centre and size of the initial box.
fn start_of(target: &InitialBox) -> ((f64, f64), (f64, f64)) {
    let (cx, cy) = target.bbox.center();
    (
        (cx - 1.0, cy - 1.0),
        (target.bbox.width, target.bbox.height),
    )
}

fn estimate(step: Step) -> Estimate {
    Estimate {
        bbox: bbox_of(step.centre, step.size),
        pose: None,
        particles: 0,
        evaluations: 1,
        lost: !step.updated,
    }
}

/// KCF + fDSST with LMCF's gate; see the module docs.
pub type DcfTracker = Shell<DcfCore>;

/// The model of [`DcfTracker`].
#[derive(Debug, Clone)]
pub struct DcfCore {
    config: DcfTrackerConfig,
    dcf: Dcf,
    started: bool,
}

impl DcfTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::Dcf`] for a bad parameter.
    pub fn new(config: DcfTrackerConfig) -> Result<Self> {
        Ok(Shell::wrap(DcfCore::new(config)?))
    }
}

impl DcfCore {
    /// A model with `config`.
    ///
    /// # Errors
    /// [`TrackerError::Dcf`] for a bad parameter.
    pub fn new(config: DcfTrackerConfig) -> Result<Self> {
        config.scale.validate(config.kcf.cell)?;
        Ok(Self {
            dcf: Dcf::new(config.to_dcf())?,
            config,
            started: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &DcfTrackerConfig {
        &self.config
    }

    /// The correlation filter (its last response, scale, ...).
    pub fn filter(&self) -> &Dcf {
        &self.dcf
    }
}

impl TrackerCore for DcfCore {
    fn name(&self) -> &'static str {
        "dcf"
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (centre, size) = start_of(&target);
        self.dcf.init(frame.input(), centre, size)?;
        self.started = true;
        Ok(())
    }

    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate> {
        if !self.started {
            return Err(TrackerError::NotInitialised);
        }
        Ok(estimate(self.dcf.step(frame.input())?))
    }
}

/// Staple with fDSST's scale filter and LMCF's gate; see the module docs.
pub type StapleTracker = Shell<StapleCore>;

/// The model of [`StapleTracker`].
#[derive(Debug, Clone)]
pub struct StapleCore {
    config: StapleTrackerConfig,
    staple: Staple,
    started: bool,
}

impl StapleTracker {
    /// A tracker with `config`.
    ///
    /// # Errors
    /// [`TrackerError::Dcf`] for a bad parameter.
    pub fn new(config: StapleTrackerConfig) -> Result<Self> {
        Ok(Shell::wrap(StapleCore::new(config)?))
    }
}

impl StapleCore {
    /// A model with `config`.
    ///
    /// # Errors
    /// [`TrackerError::Dcf`] for a bad parameter.
    pub fn new(config: StapleTrackerConfig) -> Result<Self> {
        config.scale.validate(config.cell)?;
        Ok(Self {
            staple: Staple::new(config.to_staple())?,
            config,
            started: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &StapleTrackerConfig {
        &self.config
    }

    /// The model (its correlation filter, last merged response, ...).
    pub fn model(&self) -> &Staple {
        &self.staple
    }
}

impl TrackerCore for StapleCore {
    fn name(&self) -> &'static str {
        "dcf-staple"
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
        let (centre, size) = start_of(&target);
        self.staple.init(frame.input(), centre, size)?;
        self.started = true;
        Ok(())
    }

    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate> {
        if !self.started {
            return Err(TrackerError::NotInitialised);
        }
        Ok(estimate(self.staple.step(frame.input())?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ncc_scale::tests::{errors, growing, run, scene};
    use crate::tracker::Tracker;
    use bayestrack_image::Image;

    /// Mean IoU of two box lists.
    fn mean_iou(got: &[BBox], truth: &[BBox]) -> f64 {
        let iou = |a: &BBox, b: &BBox| {
            let iw = (a.x + a.width).min(b.x + b.width) - a.x.max(b.x);
            let ih = (a.y + a.height).min(b.y + b.height) - a.y.max(b.y);
            let inter = iw.max(0.0) * ih.max(0.0);
            inter / (a.width * a.height + b.width * b.height - inter)
        };
        got.iter().zip(truth).map(|(a, b)| iou(a, b)).sum::<f64>() / got.len() as f64
    }

    fn dcf(config: DcfTrackerConfig) -> Box<dyn Tracker> {
        Box::new(DcfTracker::new(config).unwrap())
    }

    fn staple(config: StapleTrackerConfig) -> Box<dyn Tracker> {
        Box::new(StapleTracker::new(config).unwrap())
    }

    /// Both trackers on a textured target moving on a curve while it
    /// grows by 40 % or shrinks by 30 % over 60 frames, gray and RGB, on a
    /// textured background. Measured (this build): mean IoU 0.940 to 0.951,
    /// worst centre error 0.72 to 0.86 px, final size within 3.1 % of the
    /// truth. The bounds leave room: IoU 0.9, centre 2 px, size 5 %.
    #[test]
    fn hold_growing_and_shrinking_targets() {
        for (rgb, grow) in [(false, 1.4), (true, 1.4), (false, 0.7), (true, 1.0)] {
            let (frames, truth) = scene(61, rgb, 3.0, |k| growing(k, grow));
            for (name, mut t) in [
                ("dcf", dcf(DcfTrackerConfig::default())),
                ("dcf-staple", staple(StapleTrackerConfig::default())),
            ] {
                let got = run(t.as_mut(), &frames, truth[0]);
                let (centre, _) = errors(&got, &truth);
                let iou = mean_iou(&got, &truth);
                let last = got.last().unwrap().width / truth.last().unwrap().width;
                eprintln!(
                    "{name} rgb {rgb} grow {grow}: IoU {iou:.3}, centre {centre:.2}, size ratio {last:.3}"
                );
                assert!(
                    iou >= 0.9,
                    "{name} rgb {rgb} grow {grow}: mean IoU {iou:.3}"
                );
                assert!(
                    centre < 2.0,
                    "{name} rgb {rgb} grow {grow}: centre error {centre:.2}"
                );
                assert!(
                    (last - 1.0).abs() < 0.05,
                    "{name} rgb {rgb} grow {grow}: final size ratio {last:.3}"
                );
            }
        }
    }

    /// Without the scale filter the box keeps its first size and the bounds
    /// above fail on the growing target: the scale filter is what follows
    /// the size.
    #[test]
    fn without_the_scale_filter_the_size_is_lost() {
        let (frames, truth) = scene(61, false, 3.0, |k| growing(k, 1.4));
        for (name, mut t) in [
            (
                "dcf",
                dcf(DcfTrackerConfig {
                    scale: ScaleOptions {
                        scale: false,
                        ..ScaleOptions::default()
                    },
                    ..DcfTrackerConfig::default()
                }),
            ),
            (
                "dcf-staple",
                staple(StapleTrackerConfig {
                    scale: ScaleOptions {
                        scale: false,
                        ..ScaleOptions::default()
                    },
                    ..StapleTrackerConfig::default()
                }),
            ),
        ] {
            let got = run(t.as_mut(), &frames, truth[0]);
            let last = got.last().unwrap().width / truth.last().unwrap().width;
            assert!((last - 1.0 / 1.4).abs() < 1e-9, "{name}: {last}");
            assert!(mean_iou(&got, &truth) < 0.9, "{name}");
        }
    }

    /// A target hidden behind a flat occluder for 10 frames: the response
    /// collapses, the gate refuses those frames (reported lost), and the
    /// uncorrupted model finds the target when it comes back. Measured:
    /// every occluded frame refused, none of the 15 frames before;
    /// worst centre error after the occlusion 0.79 px (dcf), 0.47 px
    /// (dcf-staple).
    #[test]
    fn the_gate_refuses_an_occluded_target_and_finds_it_again() {
        let path = |k: usize| (60.0 + 0.5 * k as f64, 60.0, 24.0, 30.0);
        let (mut frames, truth) = scene(40, false, 3.0, path);
        for f in &mut frames[15..25] {
            for y in 35..85 {
                for x in 55..100 {
                    f.set(x, y, 0, 128);
                }
            }
        }
        for (name, mut t) in [
            ("dcf", dcf(DcfTrackerConfig::default())),
            ("dcf-staple", staple(StapleTrackerConfig::default())),
        ] {
            t.init(frames[0].view(), truth[0]).unwrap();
            let mut lost = Vec::new();
            let mut boxes = vec![truth[0]];
            for f in &frames[1..] {
                let e = t.step(f.view()).unwrap();
                lost.push(e.lost);
                boxes.push(e.bbox);
            }
            assert!(lost[..14].iter().all(|l| !l), "{name}: {lost:?}");
            assert!(lost[14..24].iter().all(|&l| l), "{name}: {lost:?}");
            let (centre, _) = errors(&boxes[30..], &truth[30..]);
            eprintln!("{name}: centre error after the occlusion {centre:.2} px");
            assert!(
                centre < 2.0,
                "{name}: centre error {centre:.2} after the occlusion"
            );
        }
    }

    /// A target whose texture cross-fades into an unrelated one over 80
    /// frames while it moves (the appearance change a model must follow),
    /// on a background of the first texture, gray. Returns frames and true boxes.
    fn changing_scene() -> (Vec<Image<u8>>, Vec<BBox>) {
        let n = 81;
        let wave = |a: f64, b: f64, p: f64| move |x: f64, y: f64| (a * x + b * y + p).sin();
        let (a1, a2) = (wave(0.9, 0.2, 0.0), wave(-0.3, 0.8, 1.0));
        let (b1, b2) = (wave(0.15, -0.95, 2.0), wave(0.7, 0.6, 0.5));
        let (w, h) = (28.0, 32.0);
        let mut frames = Vec::new();
        let mut boxes = Vec::new();
        for k in 0..n {
            let t = k as f64 / (n - 1) as f64;
            let (cx, cy) = (50.0 + 0.8 * k as f64, 60.0 + 10.0 * (k as f64 / 20.0).sin());
            let img = Image::from_fn(160, 120, |x, y| {
                let (xf, yf) = (x as f64, y as f64);
                let (u, v) = (xf - cx, yf - cy);
                let g = if u.abs() <= w / 2.0 && v.abs() <= h / 2.0 {
                    let a = a1(u, v) + a2(u, v);
                    let b = b1(u, v) + b2(u, v);
                    128.0 + 45.0 * ((1.0 - t) * a + t * b)
                } else {
                    // the background looks like the first texture: a
                    // distractor for a model that never learns
                    128.0 + 25.0 * (a1(xf, yf) + a2(xf, yf))
                };
                g.clamp(0.0, 255.0) as u8
            })
            .unwrap();
            frames.push(img);
            boxes.push(BBox::new(
                cx - (w - 1.0) / 2.0 + 1.0,
                cy - (h - 1.0) / 2.0 + 1.0,
                w,
                h,
            ));
        }
        (frames, boxes)
    }

    /// The model update is what follows the cross-fading target: with the
    /// published learning rates both trackers hold it (measured mean IoU
    /// over the last 20 frames: dcf 0.813, dcf-staple 0.901; bound 0.7);
    /// with the correlation filter's learning rates 0 (the first frame's
    /// model kept) dcf follows the distractor (IoU 0.036). Staple's gray
    /// histogram alone still separates this target, so it is not frozen
    /// here.
    #[test]
    fn the_model_update_follows_a_changing_appearance() {
        let (frames, truth) = changing_scene();
        let cases: Vec<(&str, bool, Box<dyn Tracker>)> = vec![
            ("dcf", true, dcf(DcfTrackerConfig::default())),
            ("dcf-staple", true, staple(StapleTrackerConfig::default())),
            (
                "dcf frozen",
                false,
                dcf({
                    let mut c = DcfTrackerConfig::default();
                    c.kcf.learning_rate = 0.0;
                    c.scale.scale_learning_rate = 0.0;
                    c
                }),
            ),
        ];
        for (name, learns, mut t) in cases {
            let got = run(t.as_mut(), &frames, truth[0]);
            let iou = mean_iou(&got[60..], &truth[60..]);
            eprintln!("{name}: mean IoU over the last 20 frames {iou:.3}");
            if learns {
                assert!(iou >= 0.7, "{name}: {iou:.3}");
            } else {
                assert!(iou < 0.7, "{name}: {iou:.3}");
            }
        }
    }

    #[test]
    fn deterministic() {
        let (frames, truth) = scene(20, true, 3.0, |k| growing(k, 1.2));
        for make in [
            || dcf(DcfTrackerConfig::default()),
            || staple(StapleTrackerConfig::default()),
        ] {
            let (mut a, mut b) = (make(), make());
            assert_eq!(
                run(a.as_mut(), &frames, truth[0]),
                run(b.as_mut(), &frames, truth[0])
            );
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let edits: [fn(&mut DcfTrackerConfig); 6] = [
            |c| c.kcf.padding = f64::NAN,
            |c| c.kcf.cell = 0,
            // DSST's scale count: an error with fDSST too (which does
            // not use it)
            |c| c.scale.scales = 0,
            |c| {
                c.scale.fdsst = false;
                c.scale.scales = 0;
            },
            |c| c.scale.scale_step = 1.0,
            |c| c.kcf.learning_rate = 2.0,
        ];
        for bad in edits.map(|edit| {
            let mut c = DcfTrackerConfig::default();
            edit(&mut c);
            c
        }) {
            assert!(matches!(DcfTracker::new(bad), Err(TrackerError::Dcf(_))));
        }
        assert!(
            StapleTracker::new(StapleTrackerConfig {
                merge_factor: -0.1,
                ..StapleTrackerConfig::default()
            })
            .is_err()
        );
        let mut c = StapleTrackerConfig::default();
        c.scale.scale_sigma_factor = 0.0;
        assert!(matches!(StapleTracker::new(c), Err(TrackerError::Dcf(_))));
        let gray = Image::from_fn(40, 30, |x, y| ((x * 7 + y * 3) % 50) as u8).unwrap();
        let two = Image::new(40, 30, 2, 0u8).unwrap();
        for mut t in [
            dcf(DcfTrackerConfig::default()),
            staple(StapleTrackerConfig::default()),
        ] {
            assert!(matches!(
                t.step(gray.view()),
                Err(TrackerError::NotInitialised)
            ));
            assert!(matches!(
                t.init(two.view(), BBox::new(1.0, 1.0, 5.0, 5.0)),
                Err(TrackerError::Channels { .. })
            ));
            assert!(matches!(
                t.init(gray.view(), BBox::new(38.0, 1.0, 5.0, 5.0)),
                Err(TrackerError::BoxOutsideFrame { .. })
            ));
            // a flat frame: no gradient, a zero response; tracked, not NaN
            let flat = Image::new(40, 30, 1, 7u8).unwrap();
            t.init(flat.view(), BBox::new(10.0, 10.0, 8.0, 8.0))
                .unwrap();
            let e = t.step(flat.view()).unwrap();
            assert!(e.bbox.x.is_finite() && e.bbox.width.is_finite());
            let other = Image::new(41, 30, 1, 0u8).unwrap();
            assert!(matches!(
                t.step(other.view()),
                Err(TrackerError::FrameSizeChanged { .. })
            ));
        }
    }
}
