//! `pf-dcf` (issue 26): the correlation filter's response as the
//! likelihood of a particle filter over position, velocity and log-scale,
//! with re-detection when the response's confidence falls.
//!
//! # State and dynamics
//! `x = [cx, cy, vx, vy, ln s]`: centre (0-based pixels), velocity
//! (px/frame) and log-scale relative to the initial box. Constant
//! velocity with Gaussian noise relative to the current size
//! `z = s sqrt(w0 h0)`: `c' = c + v + n_p z`, `v' = v + n_v z`,
//! `ln s' = ln s + n_s` ([`PfDcfConfig::position_noise`],
//! [`PfDcfConfig::velocity_noise`], [`PfDcfConfig::scale_noise`]), or
//! with probability `e` ([`PfDcfConfig::jump_fraction`]) a jump
//! `c' = c + n_j z`, `v' = 0` ([`PfDcfConfig::jump_spread`]), a valid
//! transition density (so the bootstrap weights stay `p(y | x)`) whose
//! particles find a target that moved abruptly; the centre is kept on the
//! frame and the scale within the filter's bounds.
//!
//! # Likelihood
//! Before the particles move, the KCF filter of `bayestrack-dcf` (the
//! `dcf` tracker's: Gaussian kernel on fHOG, Henriques et al. 2015)
//! computes its response in the window centred on the predicted centre
//! `E[c + v]`, at the predicted log-scale `E[ln s]` (the default,
//! [`PfDcfConfig::tracking_levels`] 1) or at three scales `E[ln s] +
//! {-1, 0, 1} ln a` (SiamFC's three-scale pyramid, `a = 1.0375`,
//! Bertinetto et al. 2016). A particle reads the response at its own
//! displacement from the window's centre (bilinear between cells,
//! [`bayestrack_dcf::Response::at`]'s rule), with three scales at each of
//! the two that bracket its `ln s`, linearly interpolated in `ln s`
//! (beyond the outer scales, the outer scale's value). With
//! `R(x)` that value and `R_bar` the mean peak of the responses learnt so
//! far,
//!
//! `ln p(y | x) = lambda R(x) / R_bar`.
//!
//! This is the reading of the correlation particle filters (Zhang, Xu and
//! Yang, "Multi-task correlation particle filter", CVPR 2017; Zhang et al.,
//! "Robust structural sparse tracking"/"correlation particle filter"
//! family), which weigh each particle by the filter's response at its
//! state, written as a Gibbs likelihood `exp(lambda R)`: it stays positive
//! and finite for the negative and zero responses a kernel filter gives
//! away from the target (the weights are log-domain, no floor needed),
//! and `lambda` sets how peaked the weights are. Dividing by `R_bar`
//! makes `lambda` independent of the response's absolute level, which
//! varies from target to target. The response is computed once per scale
//! and frame, so a particle costs a bilinear look-up: the particle count
//! is nearly free next to the filter's FFTs.
//!
//! Three responses barely tell scales a few per cent apart. With
//! [`PfDcfConfig::scale_likelihood`] `lambda_s > 0` (the default, 20) a
//! second factor measures the scale: fDSST's scale filter
//! ([`bayestrack_dcf::scale::ScaleFilter`], Danelljan et al. 2017, its
//! published parameters), the filter the `dcf` tracker uses, computes its
//! response `S` over its 33 interpolated scales (`1.02^e` times the
//! predicted scale `exp(E[ln s])`, `e = -16 ... 16`;
//! [`ScaleFilter::respond`]) at the peak of the window's middle-scale
//! response, once a tracked frame before the particles move, and
//! `ln p(y | x) = lambda R(x) / R_bar + lambda_s S(ln s) / S_bar`, `S(ln
//! s)` linear between the two interpolated scales that bracket the
//! particle's log-scale (the outer value beyond them), `S_bar` the mean of
//! the scale peaks learnt (the first frame's own peak before any). The
//! peak, not the frame's estimate: the likelihood must be fixed before the
//! particles are weighed, and the scale filter samples the target alone
//! (no padding), which the predicted centre's error after a turn would
//! blur; the peak is this frame's translation measurement, where fDSST
//! itself measures scale. `lambda_s = lambda`: both responses are divided
//! by their mean learnt peak, so one `lambda` weighs them alike. While
//! lost there is no scale factor (the grid's search). With
//! [`PfDcfConfig::tracking_levels`] 1 (the default) the translation
//! response is computed at the predicted log-scale only (every particle
//! reads it) and the log-scale is measured by the scale factor alone.
//!
//! `R` is by default Staple's merge (Bertinetto et al. 2016) of the
//! correlation response with a colour score, `R = (1 - w) R_cf + w P`
//! ([`PfDcfConfig::colour_merge`] `w`, Staple's 0.3): `P` at a
//! displacement is the mean, over the target's box placed there, of each
//! pixel's object likelihood under foreground and background colour
//! histograms ([`bayestrack_dcf::ColourMerge`]; a gray-level histogram on
//! gray video), and `R_bar` is the mean of the merged peaks. The lost
//! grid reads `R_cf` alone. The colour score is what keeps a target whose
//! texture changes (deformation, out-of-plane turns): chosen on the
//! stress set, docs/results.md.
//!
//! # Proposal
//! With [`PfDcfConfig::peak_fraction`] `beta = 0` the particles are
//! drawn from the dynamics (the bootstrap filter, weight `p(y | x)`). With
//! `beta > 0` (the default, 0.2), while tracking (not while lost: the
//! grid's own search), each particle is drawn with probability `beta`
//! from a component `g` at the response's peak instead, the mixture
//! `q(x | x', y) = (1 - beta) p(x | x') + beta g(x | x', y)` of Isard and
//! Blake's ICONDENSATION (ECCV 1998), and weighed exactly,
//!
//! `ln w = ln p(y | x) + ln p(x | x') - ln q(x | x', y)`,
//!
//! so the posterior is the bootstrap filter's and only the particles that
//! find it change. `g` draws the centre from `N(mu, tau^2 I)`, `mu` the
//! peak (sub-cell) of the highest of the window's three responses and
//! `tau` [`PfDcfConfig::peak_spread`] times the target size at its
//! scale; then the branch from its posterior given that centre,
//! `P(jump | c) = e N_j(c) / p_c(c)` with
//! `p_c(c) = (1 - e) N(c; c' + v', sigma_p^2 z^2) + e N(c; c', sigma_j^2 z^2)`
//! the centre's marginal transition density; then the velocity as that
//! branch gives it (`v' + n_v z`, independent of the centre, or 0), and
//! the log-scale as the jump gives it (`ln s'`) or, on the
//! constant-velocity branch, from `N(ls*, tau_s^2)`, `ls*` the highest
//! response's log-scale and `tau_s` [`PfDcfConfig::peak_scale_spread`]
//! times `ln a` (with the scale likelihood, `ls*` is the scale filter's
//! estimate instead, within the filter's bounds). Velocity and a jump's log-scale come from the
//! transition's own conditional in both components and cancel, so
//!
//! - a jump (velocity and log-scale kept exactly, an atom no continuous
//!   draw hits): `p / q = p_c / ((1 - beta) p_c + beta g_c)`;
//! - a constant-velocity draw: `p / q = p_c p_s / ((1 - beta) p_c p_s +
//!   beta g_c g_s)`, `p_s = N(ln s; ln s', sigma_s^2)`, `g_s = N(ln s; ls*,
//!   tau_s^2)` (with `sigma_s = 0` both drop out: the log-scale is kept),
//!
//! in logs (no underflow far from the peak). The frame clamp of the
//! centre and the bounds of the log-scale put atoms at the edges; the
//! ratio is taken at the draw before them, which is exact for the clamped
//! filter: the weights are those of importance sampling on the unclamped
//! draw, whose target `p(y | clamp(x)) p(x | x')` carries the clamped
//! posterior, and the next frame sees only the clamped state. A
//! non-zero `beta` needs `sigma_p > 0` (and `sigma_j > 0` with `e > 0`):
//! the centre's transition must have a density.
//!
//! # Update and re-detection
//! The estimate is the weighted mean of the particles. The confidence of
//! the frame is the peak and APCE of the middle scale's response, the
//! merged one by default ([`PfDcfConfig::gate_response`]; Wang et al.
//! 2017's LMCF gate: both at least `beta_1 = 0.7`, `beta_2 = 0.45` of
//! their means over the frames learnt): a target whose texture changed
//! keeps its colour and passes, a hidden one loses both and is refused.
//! A frame that passes is learnt at
//! the estimate (the filter's published learning rate; the scale filter,
//! when there is one, at the same estimate with fDSST's learning rate
//! 0.025), by default from the features of the response level nearest
//! the estimate's log-scale, moved in the Fourier domain so that the
//! estimate is at the window's centre (ECO's reuse of the detection's
//! features, [`PfDcfConfig::update_features`]) rather than from a window
//! sampled again, and the scale filter from its frame's measurement
//! ([`PfDcfConfig::update_scale`]), and the colour histograms from the
//! merge's patch ([`PfDcfConfig::update_colour`]); a frame that fails is
//! **lost**: the model, the scale filter and the histograms are frozen,
//! and while lost
//! ([`PfDcfConfig::redetect`]) the particles spread
//! [`PfDcfConfig::redetect_spread`] times wider in position and velocity
//! and [`PfDcfConfig::redetect_scale_spread`] times wider in log-scale,
//! and the response is computed in a grid of `g x g` windows
//! ([`PfDcfConfig::redetect_grid`]) half a window apart around the last
//! learnt estimate, at the last learnt scale (the default,
//! [`PfDcfConfig::redetect_levels`] 1), their features cut out of one
//! fHOG of the whole grid ([`PfDcfConfig::redetect_features`] `shared`);
//! with three levels, the two outer scales too, at the window whose
//! middle-scale peak is highest or at every window
//! ([`PfDcfConfig::redetect_outer`]; a window the frame's edge moves onto
//! another's centre is computed once), each particle reading the window
//! nearest to it (a window without outer scales its middle one at every
//! log-scale); the particles then diffuse without velocity. The
//! target is re-acquired on the first frame whose best window passes the
//! gate again: a second look, a window centred on the grid's best peak at
//! the last learnt log-scale, where the particles restart when the gate
//! admits it, at the scale filter's estimate there (measured from the
//! last learnt scale; [`PfDcfConfig::redetect_scale`], the default with
//! the scale filter; [`PfDcfConfig::redetect_scale_at`] `every-look`
//! measures it before each look and takes the look at that scale); while
//! the gate refuses, up to
//! [`PfDcfConfig::redetect_looks`] looks in all (3), the next ones at the
//! other windows' middle-scale peaks, highest first (a target between two
//! windows sits near their edges, where the cosine window weakens its
//! peak). [`PfDcfCore::diagnostics`] counts lost frames and
//! re-acquisitions.
//!
//! # Cost
//! A frame loads (and of an RGB frame converts to gray) only the union of
//! the windows it scores, then what the second look or the update lacks
//! ([`Dcf::load_windows`], [`Dcf::ensure_loaded`]): the same numbers as a
//! whole-frame load. The scale filter keeps its own sampler, loaded with
//! the region its 17 samples read (about 1.36 target sizes across).
//!
//! # Randomness
//! The engine (`bayestrack-particle`'s `Smc`, systematic resampling
//! before each proposal, [`crate::select_predict_measure`]) is seeded
//! `stream_seed([KEY, seed])`; frame `k` draws from its streams keyed
//! `[seed, k]`: one seed gives one run on every machine and thread count.
//! The first particles all sit on the initial box, at rest or (with
//! [`PfDcfConfig::initial_velocity_spread`]) with velocities drawn from
//! `stream_seed([KEY, seed, 1])`.

use std::convert::Infallible;

use bayestrack_dcf::confidence::ApceGate;
use bayestrack_dcf::fft::C32;
use bayestrack_dcf::sample::{PatchSampler, Region};
use bayestrack_dcf::scale::{ScaleConfig, ScaleFilter, ScaleResponse};
use bayestrack_dcf::{ColourMerge, Dcf, DcfConfig, Response, SharedFeatures, SharedGrid};
use bayestrack_image::{BBox, ImageView};
use bayestrack_options::{choice, options};
use bayestrack_particle::{ParticleSet, Proposal, Resampling, Smc, stream_rng, stream_seed};
use nalgebra::SVector;
use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};

use crate::dcf::{GateOptions, GateResponse, KcfOptions};
use crate::engine::select_predict_measure;
use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, InitialBox, Needs, Planes, Shell, TrackerCore};
use crate::tracker::Estimate;

const NAME: &str = "pf-dcf";
/// Key of the random streams ("pfdcf" in ASCII).
const KEY: u64 = 0x70_6664_6366;

type State = SVector<f64, 5>;

/// The scale filter of [`PfDcfConfig::scale_likelihood`]: fDSST's
/// published parameters (17 scales interpolated to 33, step 1.02,
/// learning rate 0.025).
fn scale_config() -> ScaleConfig {
    ScaleConfig::fdsst()
}

/// The region of a `w x h` frame that `f` reads at `at`, `scale` (the
/// whole frame where it has none).
fn scale_region(f: &ScaleFilter, w: usize, h: usize, at: (f64, f64), scale: f64) -> Region {
    f.region(w, h, at.0, at.1, scale)
        .unwrap_or(Region::whole(w, h))
}

options! {
    /// Every parameter of [`PfDcfTracker`]. The correlation filter's are
    /// KCF's published HOG values (Henriques et al. 2015, sec. 6.1), the
    /// gate's LMCF's (Wang et al. 2017), the scale pyramid SiamFC's
    /// (Bertinetto et al. 2016); the particle parameters have no published
    /// value for this filter and were set on the synthetic stress set
    /// (`cargo xtask stress`), never on the real sequences.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct PfDcfConfig {
        /// Number of particles (200; the likelihood is a look-up, so the
        /// count costs little).
        pub particles: usize = 200;
        /// `lambda` of the likelihood `exp(lambda R / R_bar)` (20; chosen on
        /// the stress set).
        pub likelihood: f64 = 20.0;
        /// Position noise `sigma_p` per frame, fraction of the target size
        /// (0.05).
        pub position_noise: f64 = 0.05;
        /// Velocity noise `sigma_v` per frame, fraction of the target size
        /// (0.05).
        pub velocity_noise: f64 = 0.05;
        /// Log-scale noise `sigma_s` per frame; 0 keeps the first size. The
        /// default, 0.03, is the stress set's choice with the scale filter
        /// among 0.02 (the choice before it), 0.03 and 0.04: over twelve
        /// pairs of set and tracker seeds its mean SR@0.5 was 0.043 above
        /// 0.02's (standard error 0.007, above it in every pair), AUC
        /// +0.044 (docs/results.md).
        pub scale_noise: f64 = 0.03;
        /// Fraction `e` of particles that jump instead of moving at
        /// constant velocity (0.1, as `hist-pf-scale`): they find a target
        /// that moved abruptly within the window.
        pub jump_fraction: f64 = 0.1;
        /// Jump spread `sigma_j`, fraction of the target size (0.5, as
        /// `hist-pf-scale`).
        pub jump_spread: f64 = 0.5;
        /// Ratio between the three response scales (SiamFC-3s: 1.0375).
        pub scale_step: f64 = 1.0375;
        /// Search wider while lost (false: the frozen model searches one
        /// window with the usual spread).
        pub redetect: bool = true;
        /// Position and velocity noise multiplier while lost (3).
        pub redetect_spread: f64 = 3.0;
        /// Log-scale noise multiplier while lost (2; 0: the log-scale
        /// held while lost, where nothing measures it).
        pub redetect_scale_spread: f64 = 2.0;
        /// Windows per side of the search grid while lost (3: 3 x 3
        /// windows half a window apart, about 3.75 target sizes across).
        pub redetect_grid: usize = 3;
        /// Scales while lost: 1 (the last learnt scale; the second looks
        /// take theirs from the scale filter, [`PfDcfConfig::redetect_scale`])
        /// or 3 (the three of tracking, the outer two where
        /// [`PfDcfConfig::redetect_outer`] says). The default, 1, is the
        /// stress set's choice (with `shared` features, below): before the
        /// scale filter one scale scored 0.006 lower mean SR@0.5 over
        /// twelve pairs of set and tracker seeds; with it, 0.0008 lower
        /// (standard error 0.0006; AUC -0.0003), within the 0.005 a
        /// cheaper search may lose (docs/results.md, "a cheaper lost
        /// search with the scale filter").
        pub redetect_levels: usize = 1;
        /// How a lost frame computes its grid's features:
        /// `per-window` (each window sampled and its fHOG computed on its
        /// own, clamped to the frame one by one) or `shared` (one patch
        /// and fHOG per scale covering the whole grid, each window's cells
        /// cut out of it, the window centres rounded to whole cells: about
        /// 4/9 of the features' cost for the 3 x 3 grid; border cells see
        /// the pixels beyond their window, so not the same numbers). The
        /// default, `shared`, is the stress set's choice: before the scale
        /// filter it scored 0.008 lower mean SR@0.5 over twelve pairs of
        /// set and tracker seeds (0.012 with one scale); with it and one
        /// scale, 0.0005 lower (standard error 0.0012; AUC +0.0003), within
        /// the 0.005 a cheaper search may lose, and the fewest
        /// instructions a frame on Couple of the variants that passed
        /// (docs/results.md, "a cheaper lost search with the scale
        /// filter").
        pub redetect_features: RedetectFeatures = RedetectFeatures::Shared;
        /// Where a lost frame with three scales and per-window features
        /// computes the outer two (`shared` features: at every window):
        /// `best-window` (the middle scale at every grid window first, the
        /// outer two at the window whose middle-scale peak is highest; the
        /// other windows' particles read their middle scale at every
        /// log-scale: 12 responses a lost frame instead of 28) or
        /// `every-window`. The default, `best-window`, is the stress set's
        /// choice: over twelve pairs of set and tracker seeds its mean
        /// SR@0.5 was 0.0003 below `every-window`'s (standard error
        /// 0.0014), its AUC 0.0001 below, within the 0.005 a cheaper search
        /// may lose (docs/results.md).
        pub redetect_outer: OuterScales = OuterScales::BestWindow;
        /// Fraction `beta` of the particles drawn around the response's
        /// peak rather than from the motion model while tracking (the
        /// mixture proposal of Isard and Blake's ICONDENSATION; weighed
        /// exactly, module docs "Proposal"); 0 (the bootstrap filter, the
        /// earlier boxes bit for bit) to 1. Not used while lost (the
        /// grid's own search). The default, 0.2, is the stress set's
        /// choice among 0, 0.1, 0.2 and 0.3: over twelve pairs of set and
        /// tracker seeds its mean SR@0.5 was 0.058 above the bootstrap's
        /// (standard error 0.009; AUC +0.041), the best of the three that
        /// passed (docs/results.md, "a proposal at the response peak").
        pub peak_fraction: f64 = 0.2;
        /// Spread `tau` of the peak component's centre, fraction of the
        /// target size at the peak's scale (0.1: KCF's
        /// `output_sigma_factor`, the width of the Gaussian peak the
        /// filter is trained to give, so the proposal is as wide as the
        /// peak it is drawn around).
        pub peak_spread: f64 = 0.1;
        /// Spread `tau_s` of the peak component's log-scale, fraction of
        /// the pyramid's step `ln a` (0.5: the best of the three scales is
        /// within half a step of the best scale between them).
        pub peak_scale_spread: f64 = 0.5;
        /// `lambda_s` of the scale likelihood `exp(lambda_s S(ln s) /
        /// S_bar)` (module docs, "Likelihood"): the response of fDSST's
        /// scale filter (Danelljan et al. 2017, its published parameters,
        /// [`ScaleConfig::fdsst`]) over its 33 interpolated scales, at the
        /// window's response peak, read at each particle's log-scale; 0
        /// computes no scale filter (the boxes of before the option, bit
        /// for bit). The default, 20, is the translation term's
        /// [`PfDcfConfig::likelihood`] (both responses are divided by their
        /// mean learnt peak, so one `lambda` weighs them alike), not swept;
        /// on the stress set it passed against 0: over twelve pairs of set
        /// and tracker seeds mean SR@0.5 +0.041 (standard error 0.013),
        /// AUC +0.067 (docs/results.md, "fDSST's scale filter as a scale
        /// likelihood").
        pub scale_likelihood: f64 = 20.0;
        /// Scales of the translation response while tracking: 3 (SiamFC's
        /// pyramid, [`PfDcfConfig::scale_step`] apart) or 1 (the predicted
        /// log-scale only: two responses a frame fewer; the log-scale then
        /// comes from the scale likelihood alone, so 1 needs
        /// [`PfDcfConfig::scale_likelihood`] > 0). The lost search keeps
        /// its own ([`PfDcfConfig::redetect_levels`]). The default, 1, is
        /// the stress set's choice: in session 25 one scale scored 0.020
        /// lower mean SR@0.5 over twelve pairs of set and tracker seeds
        /// (0.016 with [`PfDcfConfig::redetect_scale`]) and was refused;
        /// with session 26's defaults (both filters learning from their
        /// detections, the lost search at one scale) 0.0013 lower
        /// (standard error 0.0008; AUC -0.0014), within the 0.005 a
        /// cheaper variant may lose (docs/results.md, "one translation
        /// scale while tracking, measured again").
        pub tracking_levels: usize = 1;
        /// While lost, measure the scale filter (from the last learnt
        /// scale) at the second look and restart the particles at its
        /// estimate when the gate admits the look (where it is measured:
        /// [`PfDcfConfig::redetect_scale_at`]; false: the particles restart
        /// at the last learnt scale). Without the scale filter
        /// ([`PfDcfConfig::scale_likelihood`] 0) it does nothing, so that
        /// `scale_likelihood=0` alone gives the boxes of before the scale
        /// filter. The default, true, is the
        /// stress set's choice: over twelve pairs of set and tracker seeds
        /// its mean SR@0.5 was 0.011 above `scale_likelihood` alone's
        /// (standard error 0.004), AUC +0.014 (docs/results.md).
        pub redetect_scale: bool = true;
        /// Second looks a lost frame may take: the first at the grid's best
        /// peak, then, while the gate refuses, at the other windows'
        /// middle-scale peaks, highest first (1: the best peak only; at
        /// most one a window).
        /// The grid's windows are half a window apart, so a target between
        /// two of them sits near a window's edge, where the cosine window
        /// weakens its peak below the background's at the last learnt
        /// place (docs/results.md). The default, 3, is the stress set's
        /// choice among 1, 2 and 3: over twelve pairs of set and tracker
        /// seeds its mean SR@0.5 was 0.0030 above one look's (standard
        /// error 0.0008, never below it), AUC +0.0024 (two looks: +0.0018,
        /// s.e. 0.0006).
        pub redetect_looks: usize = 3;
        /// Where [`PfDcfConfig::redetect_scale`] measures the scale filter:
        /// `every-look` (before each second look, which is then taken at
        /// its estimate) or `admitted` (each look taken at the last learnt
        /// scale; the scale filter measured only at a look the gate
        /// admits, where the particles restart at its estimate).
        /// The default, `admitted`, is the stress set's choice: over twelve
        /// pairs of set and tracker seeds its mean SR@0.5 was 0.0007 above
        /// `every-look`'s (standard error 0.0008; AUC +0.0013), within the
        /// 0.005 a cheaper variant may lose (docs/results.md, "the second
        /// looks' scale measured only where one is admitted").
        pub redetect_scale_at: LookScale = LookScale::Admitted;
        /// What a tracked frame the gate admits learns from: `extracted`
        /// (a window sampled at the particles' mean and scale, its fHOG
        /// and FFT computed) or `detection` (the features of the
        /// response level nearest the mean's log-scale, already
        /// transformed, moved in the Fourier domain so that the mean is
        /// at the window's centre: ECO's reuse of the detection's
        /// features, Danelljan et al. 2017; a mean outside the window's
        /// central half, and a re-acquiring frame, extract). The default,
        /// `detection`, is the stress set's choice: over twelve pairs of
        /// set and tracker seeds its mean SR@0.5 was 0.0004 below
        /// `extracted`'s (standard error 0.0009; AUC +0.0008), within the
        /// 0.005 a cheaper variant may lose (docs/results.md, "learning
        /// from the detection's features").
        pub update_features: UpdateFeatures = UpdateFeatures::Detection;
        /// What the scale filter learns from on a tracked frame the gate
        /// admits: `extracted` (its 17 samples taken again at the
        /// particles' mean and scale, as fDSST does) or `detection` (the
        /// samples of the frame's scale measurement, each scale's features
        /// interpolated between the two sampled scales around its own
        /// log-scale plus the mean's offset from the predicted one, at the
        /// measurement's position: [`ScaleFilter::train_detected`]). The
        /// default, `detection`, is the stress set's choice: over twelve
        /// pairs of set and tracker seeds its mean SR@0.5 was 0.0002
        /// above `extracted`'s (standard error 0.0013; AUC +0.0009), within
        /// the 0.005 a cheaper variant may lose (docs/results.md, "the
        /// scale filter learning from its detection").
        pub update_scale: UpdateFeatures = UpdateFeatures::Detection;
        /// Weight of Staple's colour score in the tracking response, in
        /// `[0, 1]` (0: none; Staple's published merge factor is 0.3):
        /// the particles read `(1 - w) cf + w colour`, where `colour` is
        /// the mean object likelihood of the colour histograms (learnt
        /// as Staple learns them, at `colour_rate`, from the target's box
        /// shrunk by `inner_padding`) over the target's box at each
        /// displacement ([`bayestrack_dcf::ColourMerge`]). What the gate
        /// reads is [`PfDcfConfig::gate_response`]; the lost search's grid
        /// reads the correlation response alone. The default,
        /// 0.3 (with [`PfDcfConfig::gate_response`] `merged`), is the
        /// stress set's choice: over twelve pairs of set and tracker
        /// seeds its mean SR@0.5 was 0.037 above no colour's (standard
        /// error 0.007, every pair above; AUC +0.031), where 0.3 with the
        /// gate on the correlation response had been refused (-0.006)
        /// (docs/results.md, "the gate reading the colour-merged
        /// response").
        pub colour_merge: f64 = 0.3;
        /// Learning rate of the colour histograms (Staple: 0.04).
        pub colour_rate: f64 = 0.04;
        /// Foreground shrink per mean side of the colour histograms'
        /// target box (Staple's inner padding: 0.2).
        pub inner_padding: f64 = 0.2;
        /// What the update gate reads with [`PfDcfConfig::colour_merge`]
        /// above 0: `correlation` (the correlation response alone, as
        /// Staple's gate) or `merged` (the peak and APCE of the merged
        /// map the particles read, its running means too; a lost frame's
        /// second looks are then merged as well, and restart the
        /// particles at the merged peak). Without colour both are the
        /// correlation response. The default, `merged`, is the stress
        /// set's choice with `colour_merge` 0.3 (above).
        pub gate_response: GateResponse = GateResponse::Merged;
        /// What the colour histograms learn from on a tracked frame the
        /// gate admits: `extracted` (a patch sampled again at the
        /// particles' mean and scale, as Staple does) or `detection` (the
        /// patch the frame's merge sampled, the target's box moved to the
        /// mean in whole model pixels and sized by its scale:
        /// [`ColourMerge::learn_detected`]; a patch sampled again where
        /// that box would leave it). A frame re-acquired by a second look
        /// samples again either way. The default, `detection`, is the
        /// stress set's choice: over twelve pairs of set and tracker
        /// seeds its mean SR@0.5 was 0.0011 below `extracted`'s (standard
        /// error 0.0062; AUC -0.0013), within the 0.005 a cheaper variant
        /// may lose (docs/results.md, "the colour histograms learning from
        /// the merge's patch").
        pub update_colour: UpdateFeatures = UpdateFeatures::Detection;
        /// Standard deviation of the first particles' velocities, in
        /// target sizes `sqrt(w0 h0)` per frame (0: every particle starts
        /// at rest). Drawn from a stream of their own, keyed by the seed.
        /// The default, 0.5, is the jump's spread ([`PfDcfConfig::jump_spread`]'s
        /// default, the motion model's spread for an unexplained move),
        /// the stress set's choice against 0: over twelve pairs of set and
        /// tracker seeds its mean SR@0.5 was 0.025 higher (standard error
        /// 0.013; AUC +0.022; `fast-motion` 0.74 -> 0.99) (docs/results.md,
        /// "the first frame's velocity unknown").
        pub initial_velocity_spread: f64 = 0.5;
    }
    groups {
        /// The correlation filter (KCF's published values).
        pub kcf: KcfOptions = KcfOptions::default();
        /// The update gate (LMCF's).
        pub gate: GateOptions = GateOptions::default();
    }
    check check_pf_dcf;
}

/// How a lost frame computes the features of its grid of windows
/// ([`PfDcfConfig::redetect_features`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RedetectFeatures {
    /// Each window sampled and its fHOG computed on its own
    /// ([`Dcf::detect`]).
    PerWindow,
    /// One patch per scale covering the grid, each window cut out of its
    /// fHOG ([`Dcf::extract_shared`], [`Dcf::detect_cut`]).
    Shared,
}

choice! {
    RedetectFeatures { PerWindow = "per-window", Shared = "shared" }
}

/// Where a lost frame's second looks measure the scale filter
/// ([`PfDcfConfig::redetect_scale_at`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LookScale {
    /// Before every look.
    EveryLook,
    /// Only at a look the gate admits.
    Admitted,
}

choice! {
    LookScale { EveryLook = "every-look", Admitted = "admitted" }
}

/// What a tracked frame learns from ([`PfDcfConfig::update_features`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpdateFeatures {
    /// A window sampled at the estimate ([`Dcf::update`]).
    Extracted,
    /// The detection's features, moved to the estimate
    /// ([`Dcf::update_detected`]).
    Detection,
}

choice! {
    UpdateFeatures { Extracted = "extracted", Detection = "detection" }
}

/// Where a lost frame computes its outer two scales
/// ([`PfDcfConfig::redetect_outer`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OuterScales {
    /// At every window of the grid.
    EveryWindow,
    /// At the window whose middle-scale peak is highest.
    BestWindow,
}

choice! {
    OuterScales { EveryWindow = "every-window", BestWindow = "best-window" }
}

fn check_pf_dcf(c: &PfDcfConfig) -> std::result::Result<(), String> {
    c.validate().map_err(|e| e.to_string())
}

impl PfDcfConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] naming the first bad one;
    /// [`TrackerError::Dcf`] for a bad filter parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value, reason| {
            Err(TrackerError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if self.particles == 0 || self.particles > 1 << 20 {
            return bad("particles", self.particles as f64, "must be in 1..=2^20");
        }
        let nonneg = [
            ("likelihood", self.likelihood),
            ("initial_velocity_spread", self.initial_velocity_spread),
            ("position_noise", self.position_noise),
            ("velocity_noise", self.velocity_noise),
            ("scale_noise", self.scale_noise),
            ("jump_spread", self.jump_spread),
        ];
        for (name, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return bad(name, v, "must be finite and >= 0");
            }
        }
        if !(0.0..=1.0).contains(&self.jump_fraction) {
            return bad("jump_fraction", self.jump_fraction, "must be in [0, 1]");
        }
        for (name, v) in [
            ("peak_fraction", self.peak_fraction),
            ("colour_merge", self.colour_merge),
            ("colour_rate", self.colour_rate),
            ("inner_padding", self.inner_padding),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(name, v, "must be in [0, 1]");
            }
        }
        for (name, v) in [
            ("peak_spread", self.peak_spread),
            ("peak_scale_spread", self.peak_scale_spread),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 10.0) {
                return bad(name, v, "must be in (0, 10]");
            }
        }
        // the peak component's weights need the centre's transition to be
        // a density: no zero spread where a branch can be taken
        if self.peak_fraction > 0.0 {
            if self.position_noise == 0.0 {
                return bad(
                    "position_noise",
                    0.0,
                    "must be > 0 with peak_fraction > 0 (the weights need its density)",
                );
            }
            if self.jump_fraction > 0.0 && self.jump_spread == 0.0 {
                return bad(
                    "jump_spread",
                    0.0,
                    "must be > 0 with peak_fraction and jump_fraction > 0 (the weights need its density)",
                );
            }
        }
        if !(self.scale_step.is_finite() && self.scale_step > 1.0 && self.scale_step <= 2.0) {
            return bad("scale_step", self.scale_step, "must be in (1, 2]");
        }
        if !(self.redetect_spread.is_finite() && (1.0..=100.0).contains(&self.redetect_spread)) {
            return bad(
                "redetect_spread",
                self.redetect_spread,
                "must be in [1, 100]",
            );
        }
        let rs = self.redetect_scale_spread;
        if !(rs.is_finite() && (rs == 0.0 || (1.0..=100.0).contains(&rs))) {
            return bad("redetect_scale_spread", rs, "must be 0 or in [1, 100]");
        }
        if !(self.scale_likelihood.is_finite() && (0.0..=1000.0).contains(&self.scale_likelihood)) {
            return bad(
                "scale_likelihood",
                self.scale_likelihood,
                "must be in [0, 1000]",
            );
        }
        if !matches!(self.tracking_levels, 1 | 3) {
            return bad(
                "tracking_levels",
                self.tracking_levels as f64,
                "must be 1 or 3",
            );
        }
        if self.tracking_levels == 1 && self.scale_likelihood == 0.0 {
            return bad(
                "tracking_levels",
                1.0,
                "1 needs scale_likelihood > 0 (the log-scale would have no measurement)",
            );
        }
        if !matches!(self.redetect_levels, 1 | 3) {
            return bad(
                "redetect_levels",
                self.redetect_levels as f64,
                "must be 1 or 3",
            );
        }
        // (a grid with fewer windows takes as many looks as it has)
        if self.redetect_looks == 0 || self.redetect_looks > 81 {
            return bad(
                "redetect_looks",
                self.redetect_looks as f64,
                "must be 1 to 81",
            );
        }
        if self.redetect_grid == 0 || self.redetect_grid.is_multiple_of(2) || self.redetect_grid > 9
        {
            return bad(
                "redetect_grid",
                self.redetect_grid as f64,
                "must be odd, 1 to 9",
            );
        }
        self.to_dcf().validate()?;
        Ok(())
    }

    /// The correlation filter's configuration (no scale filter: the
    /// particles carry the scale; no gate: the tracker keeps its own).
    pub fn to_dcf(&self) -> DcfConfig {
        self.kcf.to_dcf()
    }
}

/// What [`PfDcfTracker`] has done so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PfDcfDiagnostics {
    /// Frames tracked (after the first).
    pub frames: usize,
    /// Frames the gate refused (model frozen, reported lost).
    pub lost_frames: usize,
    /// Lost spells ended by a frame the gate passed again.
    pub reacquisitions: usize,
    /// Responses computed (windows times scales).
    pub responses: usize,
}

/// One response map: where its window is, its cells, frame pixels per
/// cell.
#[derive(Debug, Clone, Default)]
struct Map {
    centre: (f64, f64),
    w: usize,
    h: usize,
    px: (f64, f64),
    data: Vec<f32>,
    /// The peak's value and position (frame pixels, sub-cell).
    peak: f32,
    at: (f64, f64),
}

impl Map {
    /// The response at `(dx, dy)` frame pixels from the window's centre,
    /// bilinear between cells as `Response::at`, `None` beyond half the
    /// window (where the map would wrap round).
    #[inline]
    fn at(&self, dx: f64, dy: f64) -> Option<f32> {
        let (u, v) = (dx / self.px.0, dy / self.px.1);
        let (w, h) = (self.w as f64, self.h as f64);
        if !(u.abs() <= w / 2.0 && v.abs() <= h / 2.0) {
            return None;
        }
        // `rem_euclid` and `floor` without their library calls: for
        // `|u| <= w / 2`, `u % w` is `u`, so `u.rem_euclid(w)` is `u + w`
        // below 0 and `u` otherwise (-0 included), and on the result
        // (>= 0) truncation is the floor: the same bits
        let wrap = |u: f64, w: f64| if u < 0.0 { u + w } else { u };
        let (u, v) = (wrap(u, w), wrap(v, h));
        let (fu, fv) = (u as usize, v as usize);
        let (i0, j0) = (fu % self.w, fv % self.h);
        let (i1, j1) = ((i0 + 1) % self.w, (j0 + 1) % self.h);
        let (fx, fy) = ((u - fu as f64) as f32, (v - fv as f64) as f32);
        let g = |i: usize, j: usize| self.data[j * self.w + i];
        let top = g(i0, j0) + fx * (g(i1, j0) - g(i0, j0));
        let bot = g(i0, j1) + fx * (g(i1, j1) - g(i0, j1));
        Some(top + fy * (bot - top))
    }
}

/// The frame's responses: `windows` centres times `levels` log-scales,
/// map `w * levels.len() + l`.
#[derive(Debug, Clone, Default)]
struct Responses {
    levels: Vec<f64>,
    windows: usize,
    maps: Vec<Map>,
    /// Spacing of the window grid, frame pixels (0 for one window).
    stride: (f64, f64),
    /// `lambda / R_bar`.
    gain: f64,
    /// The scale filter's response (`None`: no scale term this frame).
    scale: Option<ScaleTerm>,
}

/// The scale likelihood's response over log-scales (module docs,
/// "Likelihood").
#[derive(Debug, Clone, Default)]
struct ScaleTerm {
    /// Log-scale of the first value, and the spacing of the values.
    first: f64,
    step: f64,
    values: Vec<f64>,
    /// `lambda_s / S_bar`.
    gain: f64,
}

impl ScaleTerm {
    /// `lambda_s S(ls) / S_bar`: linear between the two values that
    /// bracket `ls`, the outer value beyond them.
    #[inline]
    fn log_likelihood(&self, ls: f64) -> f64 {
        let n = self.values.len();
        let u = ((ls - self.first) / self.step).clamp(0.0, (n - 1) as f64);
        let i = (u as usize).min(n.saturating_sub(2));
        let t = u - i as f64;
        let v = if n < 2 {
            self.values[0]
        } else {
            (1.0 - t) * self.values[i] + t * self.values[i + 1]
        };
        self.gain * v
    }
}

impl Responses {
    /// `ln p(y | x)` of a particle.
    #[inline]
    fn log_likelihood(&self, x: &State) -> f64 {
        let nl = self.levels.len();
        // the nearest window (grid distance in strides)
        let mut best = 0;
        if self.windows > 1 {
            let mut d = f64::INFINITY;
            for k in 0..self.windows {
                let c = self.maps[k * nl].centre;
                let e =
                    ((x[0] - c.0) / self.stride.0).powi(2) + ((x[1] - c.1) / self.stride.1).powi(2);
                if e < d {
                    d = e;
                    best = k;
                }
            }
        }
        let maps = &self.maps[best * nl..(best + 1) * nl];
        let read = |m: &Map| m.at(x[0] - m.centre.0, x[1] - m.centre.1).unwrap_or(0.0) as f64;
        let ls = x[4];
        let r = if nl == 1 || ls <= self.levels[0] {
            read(&maps[0])
        } else if ls >= self.levels[nl - 1] {
            read(&maps[nl - 1])
        } else {
            let l = self.levels.partition_point(|&v| v <= ls).clamp(1, nl - 1);
            let (a, b) = (self.levels[l - 1], self.levels[l]);
            let t = (ls - a) / (b - a);
            (1.0 - t) * read(&maps[l - 1]) + t * read(&maps[l])
        };
        match &self.scale {
            Some(st) => self.gain * r + st.log_likelihood(ls),
            None => self.gain * r,
        }
    }
}

/// The peak component `g` of the mixture proposal: where the frame's best
/// response peaks (module docs, "Proposal").
#[derive(Debug, Clone, Copy)]
struct Peak {
    /// `beta`.
    fraction: f64,
    /// `ln beta`, `ln (1 - beta)`.
    ln_beta: (f64, f64),
    /// The peak's centre (frame pixels) and log-scale.
    at: (f64, f64),
    ls: f64,
    /// `tau` (pixels) and `tau_s`.
    spread: f64,
    scale_spread: f64,
}

impl Peak {
    fn new(fraction: f64, at: (f64, f64), ls: f64, spread: f64, scale_spread: f64) -> Self {
        Self {
            fraction,
            ln_beta: (fraction.ln(), (1.0 - fraction).ln()),
            at,
            ls,
            spread,
            scale_spread,
        }
    }
}

/// `ln N(d; 0, sigma^2 I_2)` without the `-ln 2 pi` every term of a
/// ratio shares.
#[inline]
fn ln_normal2(dx: f64, dy: f64, sigma: f64) -> f64 {
    -0.5 * (dx * dx + dy * dy) / (sigma * sigma) - 2.0 * sigma.ln()
}

/// `ln N(d; 0, sigma^2)` without the `-ln 2 pi / 2` every term of a ratio
/// shares.
#[inline]
fn ln_normal1(d: f64, sigma: f64) -> f64 {
    -0.5 * d * d / (sigma * sigma) - sigma.ln()
}

/// `ln (e^a + e^b)`, minus infinity when both are.
#[inline]
fn ln_add(a: f64, b: f64) -> f64 {
    let (hi, lo) = if a >= b { (a, b) } else { (b, a) };
    if hi == f64::NEG_INFINITY {
        hi
    } else {
        hi + (lo - hi).exp().ln_1p()
    }
}

/// The proposal: constant-velocity motion (the bootstrap), or with
/// probability `beta` the peak component, and the response likelihood.
struct PfDcfProposal<'a> {
    config: &'a PfDcfConfig,
    responses: &'a Responses,
    /// `sqrt(w0 h0)`.
    z0: f64,
    /// Noise multipliers (position and velocity, log-scale).
    spread: (f64, f64),
    /// Searching while lost: no velocity drift (diffusion only).
    searching: bool,
    frame: (f64, f64),
    scale_bounds: (f64, f64),
    /// The peak component (`None`: the bootstrap filter).
    peak: Option<Peak>,
}

impl PfDcfProposal<'_> {
    /// A draw from the transition before the clamps, and whether it
    /// jumped.
    #[inline]
    fn predict_raw<R: Rng + ?Sized>(&self, x: &State, rng: &mut R) -> (State, bool) {
        let c = self.config;
        let z = self.z0 * x[4].exp();
        let (sp, ss) = (self.spread.0 * z, self.spread.1);
        let jump = c.jump_fraction > 0.0 && rng.random::<f64>() < c.jump_fraction;
        let mut n = || -> f64 { StandardNormal.sample(rng) };
        let mut y = *x;
        if jump {
            y[0] += c.jump_spread * sp * n();
            y[1] += c.jump_spread * sp * n();
            y[2] = 0.0;
            y[3] = 0.0;
        } else if self.searching {
            y[0] += c.position_noise * sp * n();
            y[1] += c.position_noise * sp * n();
            y[2] = 0.0;
            y[3] = 0.0;
            y[4] += c.scale_noise * ss * n();
        } else {
            y[0] += x[2] + c.position_noise * sp * n();
            y[1] += x[3] + c.position_noise * sp * n();
            y[2] += c.velocity_noise * sp * n();
            y[3] += c.velocity_noise * sp * n();
            y[4] += c.scale_noise * ss * n();
        }
        (y, jump)
    }

    /// `y` with its centre on the frame and its log-scale within bounds.
    #[inline]
    fn clamp(&self, mut y: State) -> State {
        y[0] = y[0].clamp(0.0, self.frame.0 - 1.0);
        y[1] = y[1].clamp(0.0, self.frame.1 - 1.0);
        y[4] = y[4].clamp(self.scale_bounds.0, self.scale_bounds.1);
        y
    }

    #[inline]
    fn predict<R: Rng + ?Sized>(&self, x: &State, rng: &mut R) -> State {
        self.clamp(self.predict_raw(x, rng).0)
    }

    /// `ln (1 - e) N_cv(c)` and `ln e N_j(c)`: the centre's transition
    /// density from `x` by branch (tracking, not searching).
    #[inline]
    fn ln_centre(&self, x: &State, cx: f64, cy: f64) -> (f64, f64) {
        let c = self.config;
        let z = self.z0 * x[4].exp();
        let e = c.jump_fraction;
        let cv =
            (1.0 - e).ln() + ln_normal2(cx - x[0] - x[2], cy - x[1] - x[3], c.position_noise * z);
        let jump = if e > 0.0 {
            e.ln() + ln_normal2(cx - x[0], cy - x[1], c.jump_spread * z)
        } else {
            f64::NEG_INFINITY
        };
        (cv, jump)
    }

    /// A draw from the peak component: the centre from `N(mu, tau^2 I)`,
    /// the branch from its posterior given that centre, then the velocity
    /// and log-scale as that branch gives them, except that the constant
    /// velocity branch's log-scale is drawn from `N(ls*, tau_s^2)`.
    /// Before the clamps; with whether it jumped.
    #[inline]
    fn draw_at_peak<R: Rng + ?Sized>(&self, pk: &Peak, x: &State, rng: &mut R) -> (State, bool) {
        let c = self.config;
        let z = self.z0 * x[4].exp();
        let mut y = *x;
        let n: f64 = StandardNormal.sample(rng);
        y[0] = pk.at.0 + pk.spread * n;
        let n: f64 = StandardNormal.sample(rng);
        y[1] = pk.at.1 + pk.spread * n;
        let (cv, jp) = self.ln_centre(x, y[0], y[1]);
        // P(jump | c) = 1 / (1 + e^(cv - jp))
        let jump = rng.random::<f64>() * (1.0 + (cv - jp).exp()) < 1.0;
        if jump {
            y[2] = 0.0;
            y[3] = 0.0;
        } else {
            let sv = c.velocity_noise * z;
            let n: f64 = StandardNormal.sample(rng);
            y[2] += sv * n;
            let n: f64 = StandardNormal.sample(rng);
            y[3] += sv * n;
            if c.scale_noise > 0.0 {
                let n: f64 = StandardNormal.sample(rng);
                y[4] = pk.ls + pk.scale_spread * n;
            }
        }
        (y, jump)
    }

    /// `ln p(x | x') - ln q(x | x', y)` of `y` (before the clamps) drawn
    /// from `x` by either component: velocity (and a jump's log-scale)
    /// come from the transition's conditional in both, so only the
    /// centre's marginal (and a constant-velocity draw's log-scale) are
    /// left in the ratio.
    #[inline]
    fn ln_ratio(&self, pk: &Peak, x: &State, y: &State, jump: bool) -> f64 {
        let c = self.config;
        let (cv, jp) = self.ln_centre(x, y[0], y[1]);
        let mut p = ln_add(cv, jp);
        let mut g = ln_normal2(y[0] - pk.at.0, y[1] - pk.at.1, pk.spread);
        if !jump && c.scale_noise > 0.0 {
            p += ln_normal1(y[4] - x[4], c.scale_noise);
            g += ln_normal1(y[4] - pk.ls, pk.scale_spread);
        }
        p - ln_add(pk.ln_beta.1 + p, pk.ln_beta.0 + g)
    }
}

impl Proposal<State, ()> for PfDcfProposal<'_> {
    type Error = Infallible;
    type Scratch = ();

    fn propose<R: Rng + ?Sized>(
        &self,
        _k: usize,
        parent: &State,
        _z: &(),
        _scratch: &mut (),
        rng: &mut R,
    ) -> std::result::Result<(State, f64), Infallible> {
        let Some(pk) = &self.peak else {
            let x = self.predict(parent, rng);
            return Ok((x, self.responses.log_likelihood(&x)));
        };
        let (y, jump) = if rng.random::<f64>() < pk.fraction {
            self.draw_at_peak(pk, parent, rng)
        } else {
            self.predict_raw(parent, rng)
        };
        let x = self.clamp(y);
        Ok((
            x,
            self.responses.log_likelihood(&x) + self.ln_ratio(pk, parent, &y, jump),
        ))
    }
}

/// The particle filter on the correlation response; see the module docs.
pub type PfDcfTracker = Shell<PfDcfCore>;

/// The model of [`PfDcfTracker`].
#[derive(Debug, Clone)]
pub struct PfDcfCore {
    config: PfDcfConfig,
    seed: u64,
    dcf: Dcf,
    gate: ApceGate,
    /// Sum and count of the learnt peaks (`R_bar`).
    peaks: (f64, u64),
    size0: (f64, f64),
    frame: (f64, f64),
    scale_bounds: (f64, f64),
    smc: Option<Smc<State>>,
    chunks: Vec<()>,
    responses: Responses,
    /// The shared grid's features and each window's offset (cells) per
    /// scale, `offsets[l * windows + k]` (scratch of a lost frame).
    shared: SharedFeatures,
    offsets: Vec<(isize, isize)>,
    lost: bool,
    /// The last learnt estimate `(cx, cy, ln s)`: where a lost search is
    /// centred.
    anchor: (f64, f64, f64),
    /// fDSST's scale filter, with the gray levels it reads (`None` with
    /// [`PfDcfConfig::scale_likelihood`] 0).
    scale: Option<ScaleFilter>,
    scale_sampler: PatchSampler,
    scale_response: ScaleResponse,
    /// Sum and count of the learnt scale peaks (`S_bar`).
    scale_peaks: (f64, u64),
    /// The spectra of each tracking level's features
    /// ([`PfDcfConfig::update_features`] `detection`).
    kept: Vec<Vec<C32>>,
    /// Staple's colour score ([`PfDcfConfig::colour_merge`] above 0).
    colour: Option<ColourMerge>,
    diagnostics: PfDcfDiagnostics,
}

impl PfDcfTracker {
    /// A tracker with `config`, its random streams keyed by `seed`.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] or [`TrackerError::Dcf`] for a
    /// bad parameter.
    pub fn new(config: PfDcfConfig, seed: u64) -> Result<Self> {
        Ok(Shell::wrap(PfDcfCore::new(config, seed)?))
    }
}

impl PfDcfCore {
    /// The model of [`PfDcfTracker::new`].
    ///
    /// # Errors
    /// As [`PfDcfTracker::new`].
    pub fn new(config: PfDcfConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        Ok(Self {
            dcf: Dcf::new(config.to_dcf())?,
            gate: ApceGate::new(config.gate.gate_peak, config.gate.gate_apce),
            config,
            seed,
            peaks: (0.0, 0),
            size0: (0.0, 0.0),
            frame: (0.0, 0.0),
            scale_bounds: (0.0, 0.0),
            smc: None,
            chunks: Vec::new(),
            responses: Responses::default(),
            shared: SharedFeatures::new(),
            offsets: Vec::new(),
            lost: false,
            anchor: (0.0, 0.0, 0.0),
            scale: None,
            scale_sampler: PatchSampler::new(),
            scale_response: ScaleResponse::default(),
            scale_peaks: (0.0, 0),
            kept: Vec::new(),
            colour: None,
            diagnostics: PfDcfDiagnostics::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PfDcfConfig {
        &self.config
    }

    /// Lost frames, re-acquisitions and responses so far.
    pub fn diagnostics(&self) -> PfDcfDiagnostics {
        self.diagnostics
    }

    /// Whether the last frame was lost (the next one searches wider).
    pub fn is_lost(&self) -> bool {
        self.lost
    }

    /// The particles `[cx, cy, vx, vy, ln s]` (`None` before `init`).
    pub fn particles(&self) -> Option<&[SVector<f64, 5>]> {
        self.smc.as_ref().map(|s| s.set.particles())
    }

    /// The correlation filter.
    pub fn filter(&self) -> &Dcf {
        &self.dcf
    }

    fn bbox(&self, x: &State) -> BBox {
        let s = x[4].exp();
        let (w, h) = (self.size0.0 * s, self.size0.1 * s);
        BBox::new(
            x[0] - (w - 1.0) / 2.0 + 1.0,
            x[1] - (h - 1.0) / 2.0 + 1.0,
            w,
            h,
        )
    }

    /// Computes the frame's responses around `centre` at log-scale `ls`:
    /// one window, or the re-detection grid while lost. Returns the peak
    /// and APCE of the best middle-scale response and where its peak is
    /// (frame pixels).
    fn respond(
        &mut self,
        frame: ImageView<'_, u8>,
        centre: (f64, f64),
        ls: f64,
        wide: bool,
    ) -> Result<Best> {
        let c = self.config;
        let r = &mut self.responses;
        r.levels.clear();
        let g = if wide { c.redetect_grid } else { 1 };
        let three = if wide {
            c.redetect_levels == 3
        } else {
            c.tracking_levels == 3
        };
        if c.scale_noise > 0.0 && three {
            let d = c.scale_step.ln();
            r.levels.extend([ls - d, ls, ls + d]);
        } else {
            r.levels.push(ls);
        }
        for v in r.levels.iter_mut() {
            *v = v.clamp(self.scale_bounds.0, self.scale_bounds.1);
        }
        let s = ls.exp();
        // half a window apart
        let stride = (
            self.size0.0 * s * (1.0 + c.kcf.padding) / 2.0,
            self.size0.1 * s * (1.0 + c.kcf.padding) / 2.0,
        );
        r.stride = stride;
        r.windows = g * g;
        let nl = r.levels.len();
        r.maps.resize_with(g * g * nl, Map::default);
        let half = (g / 2) as f64;
        let fsize = self.frame;
        let window = |i: usize, j: usize| {
            in_frame(
                (
                    centre.0 + (i as f64 - half) * stride.0,
                    centre.1 + (j as f64 - half) * stride.1,
                ),
                fsize,
            )
        };
        if wide && c.redetect_features == RedetectFeatures::Shared {
            return self.respond_shared(frame, centre, g);
        }
        // the frame's gray levels where the windows read, once
        let levels = &r.levels;
        self.dcf.load_windows(
            frame,
            (0..g * g).flat_map(|k| {
                let wc = window(k % g, k / g);
                levels.iter().map(move |&l| (wc, l.exp()))
            }),
        )?;
        let mut best = Best {
            peak: f64::NEG_INFINITY,
            at: centre,
            gate: (0.0, 0.0),
        };
        // the colour score's pixels: the one window at its largest scale
        let merge = !wide && self.colour.is_some();
        if let Some(m) = self.colour.as_mut().filter(|_| merge) {
            let top = levels.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            m.load(frame, &self.dcf, window(0, 0), top.exp(), 0)?;
        }
        // with `OuterScales::BestWindow`, the middle scale at every window
        // first and the outer two at the best one after
        let cascade = wide && nl == 3 && c.redetect_outer == OuterScales::BestWindow;
        // a tracked frame keeps each level's features for the update
        let keep_features = !wide && c.update_features == UpdateFeatures::Detection;
        if keep_features {
            self.kept.resize_with(nl, Vec::new);
        }
        let first = if cascade { 1..2 } else { 0..nl };
        let mut best_k = 0;
        for j in 0..g {
            for i in 0..g {
                let wc = window(i, j);
                // a window clamped onto the frame's edge can fall where an
                // earlier one did: its maps are copied, not computed again
                let k = j * g + i;
                if let Some(e) = (0..k).find(|&e| r.maps[e * nl + nl / 2].centre == wc) {
                    for l in first.clone() {
                        let (done, rest) = r.maps.split_at_mut(k * nl);
                        rest[l].clone_from(&done[e * nl + l]);
                    }
                    continue;
                }
                for l in first.clone() {
                    let ls = r.levels[l].exp();
                    let resp = self.dcf.detect(wc, ls)?;
                    let cf = (resp.max as f64, resp.apce);
                    let resp = match self.colour.as_mut().filter(|_| merge) {
                        Some(m) => m.merge(&self.dcf, wc, ls)?,
                        None => self.dcf.response(),
                    };
                    if keep(&mut r.maps[k * nl + l], &mut best, wc, resp, l == nl / 2) {
                        best_k = k;
                        if c.gate_response == GateResponse::Correlation {
                            best.gate = cf;
                        }
                    }
                    self.diagnostics.responses += 1;
                    if keep_features {
                        self.dcf.keep_detected(&mut self.kept[l])?;
                    }
                }
            }
        }
        if cascade {
            // the best window's outer scales; a window the frame's edge
            // moved onto its centre shares them, every other window's
            // particles read its middle scale at every log-scale
            let wc = r.maps[best_k * nl + 1].centre;
            for l in [0, 2] {
                let resp = self.dcf.detect(wc, r.levels[l].exp())?;
                keep(&mut r.maps[best_k * nl + l], &mut best, wc, resp, false);
                self.diagnostics.responses += 1;
            }
            let (head, tail) = r.maps.split_at_mut(best_k * nl);
            let (at_best, tail) = tail.split_at_mut(nl);
            for m in head.chunks_exact_mut(nl).chain(tail.chunks_exact_mut(nl)) {
                let [m0, m1, m2] = m else { unreachable!() };
                if m1.centre == wc {
                    m0.clone_from(&at_best[0]);
                    m2.clone_from(&at_best[2]);
                } else {
                    m0.clone_from(m1);
                    m2.clone_from(m1);
                }
            }
        }
        self.set_gain(best.peak);
        Ok(best)
    }

    /// With [`PfDcfConfig::update_features`] `detection`, the tracking
    /// level whose features the estimate `mean` learns from: the one
    /// nearest its log-scale (the first of equals), if `mean` lies in
    /// its window's central half.
    fn detected_level(&self, mean: &State) -> Option<usize> {
        if self.config.update_features != UpdateFeatures::Detection {
            return None;
        }
        let r = &self.responses;
        let l = (0..r.levels.len()).min_by(|&a, &b| {
            (r.levels[a] - mean[4])
                .abs()
                .total_cmp(&(r.levels[b] - mean[4]).abs())
        })?;
        let m = r.maps.get(l)?;
        let inside = (mean[0] - m.centre.0).abs() <= m.w as f64 * m.px.0 / 4.0
            && (mean[1] - m.centre.1).abs() <= m.h as f64 * m.px.1 / 4.0;
        (inside && self.kept.get(l).is_some_and(|k| !k.is_empty())).then_some(l)
    }

    /// `lambda / R_bar` of the frame's responses (the best peak standing
    /// for `R_bar` before any is learnt).
    fn set_gain(&mut self, peak: f64) {
        let mean_peak = if self.peaks.1 > 0 {
            self.peaks.0 / self.peaks.1 as f64
        } else {
            peak
        };
        self.responses.gain = self.config.likelihood / mean_peak.max(1e-3);
    }

    /// [`PfDcfCore::respond`]'s lost search with shared features
    /// ([`RedetectFeatures::Shared`]): the `g x g` grid's windows half a
    /// window apart around `centre`, in whole cells of each scale (a
    /// window the frame's edge moves at the cell nearest its moved
    /// centre); one patch per scale covers them all, and each distinct
    /// window is cut out of it.
    fn respond_shared(
        &mut self,
        frame: ImageView<'_, u8>,
        centre: (f64, f64),
        g: usize,
    ) -> Result<Best> {
        let r = &mut self.responses;
        let nl = r.levels.len();
        let half = (g / 2) as isize;
        let n = g * g;
        // half a window is `cells / 2` cells at the anchor's scale (`ls`,
        // the middle level), `cells / 2 * exp(ls - l)` at level `l`: the
        // stride is that rounded to whole cells, halves away from the
        // centre (the grid reaches at least half a window); a window the
        // frame's edge moves is rounded to the cell nearest its moved
        // centre
        let (nx, ny) = self.dcf.cells();
        let ls = r.levels[nl / 2];
        self.offsets.clear();
        for &l in &r.levels {
            let cp = self.dcf.cell_pixels(l.exp());
            let f = (ls - l).exp();
            let kx = (nx as f64 / 2.0 * f + 0.5).floor() as isize;
            let ky = (ny as f64 / 2.0 * f + 0.5).floor() as isize;
            for k in 0..n {
                let (i, j) = ((k % g) as isize - half, (k / g) as isize - half);
                let axis = |o: isize, c: f64, p: f64, size: f64| {
                    let x = c + o as f64 * p;
                    if (0.0..=size - 1.0).contains(&x) {
                        o
                    } else {
                        ((x.clamp(0.0, size - 1.0) - c) / p).round() as isize
                    }
                };
                self.offsets.push((
                    axis(i * kx, centre.0, cp.0, self.frame.0),
                    axis(j * ky, centre.1, cp.1, self.frame.1),
                ));
            }
        }
        let grid = |l: usize, offsets: &[(isize, isize)], levels: &[f64]| {
            let o = &offsets[l * n..(l + 1) * n];
            SharedGrid {
                centre,
                scale: levels[l].exp(),
                lo: (
                    o.iter().map(|p| p.0).min().unwrap_or(0),
                    o.iter().map(|p| p.1).min().unwrap_or(0),
                ),
                hi: (
                    o.iter().map(|p| p.0).max().unwrap_or(0),
                    o.iter().map(|p| p.1).max().unwrap_or(0),
                ),
            }
        };
        let (offsets, levels) = (&self.offsets, &r.levels);
        self.dcf
            .load_shared(frame, (0..nl).map(|l| grid(l, offsets, levels)))?;
        let mut best = Best {
            peak: f64::NEG_INFINITY,
            at: centre,
            gate: (0.0, 0.0),
        };
        for l in 0..nl {
            let sg = grid(l, &self.offsets, &r.levels);
            self.dcf.extract_shared(&mut self.shared, sg)?;
            let cp = self.dcf.cell_pixels(sg.scale);
            for k in 0..n {
                let off = self.offsets[l * n + k];
                // windows the frame's edge moved onto the same cell are
                // computed once
                if let Some(e) = (0..k).find(|&e| self.offsets[l * n + e] == off) {
                    let (done, rest) = r.maps.split_at_mut(k * nl);
                    rest[l].clone_from(&done[e * nl + l]);
                    continue;
                }
                let resp = self.dcf.detect_cut(&self.shared, off)?;
                let wc = (
                    centre.0 + off.0 as f64 * cp.0,
                    centre.1 + off.1 as f64 * cp.1,
                );
                keep(&mut r.maps[k * nl + l], &mut best, wc, resp, l == nl / 2);
                self.diagnostics.responses += 1;
            }
        }
        self.set_gain(best.peak);
        Ok(best)
    }

    /// The next place of a lost frame's second looks after the grid's
    /// best peak `best`: the highest middle-scale peak of the windows not
    /// yet `tried` (a bit per window; a window the frame's edge moved onto
    /// another's centre is marked with it), `None` when none is left.
    fn next_look(&self, best: (f64, f64), tried: &mut u128) -> Option<(f64, f64)> {
        let r = &self.responses;
        let nl = r.levels.len();
        let mid = |k: usize| &r.maps[k * nl + nl / 2];
        let mut pick: Option<usize> = None;
        for k in 0..r.windows {
            let m = mid(k);
            if (*tried >> k) & 1 == 1 || m.at == best {
                continue;
            }
            // equal peaks: the first in grid order
            if pick.is_none_or(|p| m.peak > mid(p).peak) {
                pick = Some(k);
            }
        }
        let centre = mid(pick?).centre;
        for k in 0..r.windows {
            if mid(k).centre == centre {
                *tried |= 1 << k;
            }
        }
        pick.map(|p| mid(p).at)
    }

    /// Re-detection's second look: the response of a window centred on the
    /// best peak of the lost search, at log-scale `ls`. Off-centre, the
    /// cosine window damps a returning target's peak (by half at a quarter
    /// window), so the grid's own peaks rarely pass the gate; centred, the
    /// peak is what tracking would see. Returns the peak, APCE and the
    /// refined position.
    /// The scale filter's log-scale estimate at `at` measured from the
    /// log-scale `pl`, within the bounds (`pl` without a scale filter).
    fn look_scale(&mut self, frame: ImageView<'_, u8>, at: (f64, f64), pl: f64) -> Result<f64> {
        let Some(f) = self.scale.as_mut() else {
            return Ok(pl);
        };
        let at = in_frame(at, self.frame);
        let r = scale_region(f, frame.width(), frame.height(), at, pl.exp());
        self.scale_sampler.load_gray_region(frame, r)?;
        let (factor, _) = f.detect(&mut self.scale_sampler, at.0, at.1, pl.exp())?;
        Ok((pl + factor.ln()).clamp(self.scale_bounds.0, self.scale_bounds.1))
    }

    fn second_look(&mut self, frame: ImageView<'_, u8>, at: (f64, f64), ls: f64) -> Result<Best> {
        let at = in_frame(at, self.frame);
        let s = ls.exp();
        self.dcf.ensure_loaded(frame, at, s)?;
        self.dcf.detect(at, s)?;
        self.diagnostics.responses += 1;
        // with the gate on the merged response, the look is merged too
        let merged = self.config.gate_response == GateResponse::Merged;
        let resp = match self.colour.as_mut().filter(|_| merged) {
            Some(m) => {
                m.load(frame, &self.dcf, at, s, 0)?;
                m.merge(&self.dcf, at, s)?
            }
            None => self.dcf.response(),
        };
        Ok(Best {
            peak: resp.max as f64,
            at: (at.0 + resp.dx, at.1 + resp.dy),
            gate: (resp.max as f64, resp.apce),
        })
    }
}

/// Keeps a window's response (centred at `wc`) in `m` and, at the middle
/// scale, in `best` when its peak is the highest so far; returns whether
/// it was.
fn keep(m: &mut Map, best: &mut Best, wc: (f64, f64), resp: &Response, middle: bool) -> bool {
    m.centre = wc;
    m.w = resp.width();
    m.h = resp.height();
    m.px = resp.pixels_per_cell();
    m.data.clear();
    m.data.extend_from_slice(resp.data());
    m.peak = resp.max;
    m.at = (wc.0 + resp.dx, wc.1 + resp.dy);
    let highest = middle && (resp.max as f64) > best.peak;
    if highest {
        *best = Best {
            peak: resp.max as f64,
            at: (wc.0 + resp.dx, wc.1 + resp.dy),
            gate: (resp.max as f64, resp.apce),
        };
    }
    highest
}

/// `p` moved into a frame of `(width, height)` pixels (0-based centres).
fn in_frame(p: (f64, f64), frame: (f64, f64)) -> (f64, f64) {
    (p.0.clamp(0.0, frame.0 - 1.0), p.1.clamp(0.0, frame.1 - 1.0))
}

/// The strongest middle-scale response of a frame.
#[derive(Debug, Clone, Copy)]
struct Best {
    /// Peak of the map the particles read.
    peak: f64,
    /// Where its peak is, frame pixels (0-based).
    at: (f64, f64),
    /// Peak and APCE the gate reads: the correlation response's (the
    /// same map without the colour score).
    gate: (f64, f64),
}

impl TrackerCore for PfDcfCore {
    fn name(&self) -> &'static str {
        NAME
    }

    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::GrayOrRgb
    }

    /// The input as given: the filter converts an RGB frame to gray only
    /// in the regions its windows read.
    fn needs(&self) -> Needs {
        Needs::INPUT
    }

    fn start(&mut self, planes: &Planes<'_>, target: InitialBox) -> Result<()> {
        let gray = planes.input();
        let (cx, cy) = target.bbox.center();
        let (cx, cy) = (cx - 1.0, cy - 1.0);
        let (w, h) = (target.bbox.width, target.bbox.height);
        let c = self.config;
        self.dcf.init(gray, (cx, cy), (w, h))?;
        self.size0 = (w, h);
        self.frame = (gray.width() as f64, gray.height() as f64);
        // the filter's bounds (DSST's): the window at least 5 pixels, the
        // target at most the frame
        let (ww, wh) = (w * (1.0 + c.kcf.padding), h * (1.0 + c.kcf.padding));
        let min_scale = (5.0 / ww.min(wh)).min(1.0);
        let max_scale = (self.frame.0 / w).min(self.frame.1 / h).max(1.0);
        self.scale_bounds = (min_scale.ln(), max_scale.ln());
        self.gate.reset();
        // R_bar starts from the first frame's own response peak (merged
        // with the colour score where the particles read one)
        let mut peak0 = self.dcf.detect((cx, cy), 1.0)?.max as f64;
        self.colour = None;
        if c.colour_merge > 0.0 {
            let mut m = ColourMerge::new(c.colour_merge, c.colour_rate, c.inner_padding)?;
            m.init(gray, &self.dcf)?;
            peak0 = m.merge(&self.dcf, (cx, cy), 1.0)?.max as f64;
            self.colour = Some(m);
        }
        self.peaks = (peak0, 1);
        // the scale filter learns the first frame whole; S_bar starts from
        // its own peak there, as R_bar
        self.scale = None;
        self.scale_peaks = (0.0, 0);
        self.responses.scale = None;
        if c.scale_likelihood > 0.0 {
            let mut f = ScaleFilter::new(scale_config(), w, h)?;
            let r = scale_region(&f, gray.width(), gray.height(), (cx, cy), 1.0);
            self.scale_sampler.load_gray_region(gray, r)?;
            f.train(&mut self.scale_sampler, cx, cy, 1.0, 1.0)?;
            let (_, p0) = f.detect(&mut self.scale_sampler, cx, cy, 1.0)?;
            self.scale_peaks = (f64::from(p0), 1);
            self.scale = Some(f);
        }
        self.lost = false;
        self.anchor = (cx, cy, 0.0);
        self.diagnostics = PfDcfDiagnostics::default();
        let mut particles = vec![State::new(cx, cy, 0.0, 0.0, 0.0); c.particles];
        if c.initial_velocity_spread > 0.0 {
            let sd = c.initial_velocity_spread * (w * h).sqrt();
            let mut rng = stream_rng(&[KEY, self.seed, 1]);
            for p in &mut particles {
                let (nx, ny): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                (p[2], p[3]) = (sd * nx, sd * ny);
            }
        }
        self.smc = Some(Smc::new(
            select_predict_measure(Resampling::Systematic),
            ParticleSet::new(particles)?,
            stream_seed(&[KEY, self.seed]),
        )?);
        Ok(())
    }

    fn track(&mut self, planes: &Planes<'_>) -> Result<Estimate> {
        let frame = planes.input();
        let c = self.config;
        let prior: State = self
            .smc
            .as_ref()
            .ok_or(TrackerError::NotInitialised)?
            .set
            .mean();
        // E[c + v] and E[ln s] of the particles the step will select from
        let predicted = [prior[0] + prior[2], prior[1] + prior[3], prior[4]];
        let wide = self.lost && c.redetect;
        // a lost search stays where the target was last learnt (the
        // particle mean would follow the clutter's response)
        let (px, py, pl) = if wide {
            self.anchor
        } else {
            (predicted[0], predicted[1], predicted[2])
        };
        let centre = in_frame((px, py), self.frame);
        let best = self.respond(frame, centre, pl, wide)?;
        // the scale filter's response while tracking, at the window's
        // response peak (fDSST's order: translation, then scale there)
        let (fw, fh) = (frame.width(), frame.height());
        let mut scale_peak = None;
        match self.scale.as_mut() {
            Some(f) if !wide => {
                let at = in_frame(best.at, self.frame);
                let s = pl.exp();
                let r = scale_region(f, fw, fh, at, s);
                self.scale_sampler.load_gray_region(frame, r)?;
                let sr = &mut self.scale_response;
                f.respond(&mut self.scale_sampler, at.0, at.1, s, sr)?;
                let mean_peak = if self.scale_peaks.1 > 0 {
                    self.scale_peaks.0 / self.scale_peaks.1 as f64
                } else {
                    f64::from(sr.peak)
                };
                let mut term = self.responses.scale.take().unwrap_or_default();
                term.first = pl + sr.log_factors[0];
                term.step = scale_config().step.ln();
                term.values.clone_from(&sr.values);
                term.gain = c.scale_likelihood / mean_peak.max(1e-3);
                self.responses.scale = Some(term);
                scale_peak = Some(f64::from(sr.peak));
            }
            _ => self.responses.scale = None,
        }
        // while lost, a centred second look at the grid's best peak (then
        // at the next highest windows' peaks) decides re-acquisition: when
        // the gate would learn it, the particles restart there
        let found = if wide {
            let (mut found, mut tried, mut at) = (None, 0u128, best.at);
            // with `redetect_scale`, each look at the scale filter's
            // estimate there (or, `admitted`, at the last learnt scale, the
            // estimate measured only where the look is admitted)
            let after = c.redetect_scale_at == LookScale::Admitted;
            for look in 0..c.redetect_looks {
                if look > 0 {
                    match self.next_look(best.at, &mut tried) {
                        Some(next) => at = next,
                        None => break,
                    }
                }
                let mut ls = pl;
                if c.redetect_scale && !after {
                    ls = self.look_scale(frame, at, pl)?;
                }
                let look = self.second_look(frame, at, ls)?;
                if self.gate.would_admit(look.gate.0, look.gate.1) {
                    if c.redetect_scale && after {
                        ls = self.look_scale(frame, look.at, pl)?;
                    }
                    found = Some((look, ls));
                    break;
                }
            }
            found
        } else {
            None
        };
        let spread = if wide {
            (c.redetect_spread, c.redetect_scale_spread)
        } else {
            (1.0, 1.0)
        };
        let z0 = (self.size0.0 * self.size0.1).sqrt();
        // the peak component while tracking: the highest of the window's
        // scales, its peak and log-scale
        let peak = (!wide && c.peak_fraction > 0.0).then(|| {
            let r = &self.responses;
            let l = (0..r.levels.len())
                .rev()
                .max_by(|&a, &b| r.maps[a].peak.total_cmp(&r.maps[b].peak))
                .unwrap_or(0);
            // with the scale likelihood, the scale filter's estimate
            let ls = match &r.scale {
                Some(_) => (pl + self.scale_response.factor.ln())
                    .clamp(self.scale_bounds.0, self.scale_bounds.1),
                None => r.levels[l],
            };
            let tau_s = c.peak_scale_spread * c.scale_step.ln();
            Peak::new(
                c.peak_fraction,
                r.maps[l].at,
                ls,
                c.peak_spread * z0 * ls.exp(),
                tau_s,
            )
        });
        let proposal = PfDcfProposal {
            config: &c,
            responses: &self.responses,
            z0,
            spread,
            searching: wide,
            frame: self.frame,
            scale_bounds: self.scale_bounds,
            peak,
        };
        let smc = self.smc.as_mut().ok_or(TrackerError::NotInitialised)?;
        let (peak, gate) = match found {
            Some((look, ls)) => {
                let particles = vec![State::new(look.at.0, look.at.1, 0.0, 0.0, ls); c.particles];
                smc.set = ParticleSet::new(particles)?;
                (look.peak, look.gate)
            }
            None => {
                smc.step_with(&proposal, &(), &mut self.chunks)?;
                (best.peak, best.gate)
            }
        };
        let mean: State = smc.set.mean();
        let n = smc.set.len();
        let admitted = !c.gate.gate || self.gate.admit(gate.0, gate.1);
        self.diagnostics.frames += 1;
        if admitted {
            if self.lost {
                self.diagnostics.reacquisitions += 1;
            }
            let (at, scale) = ((mean[0], mean[1]), mean[4].exp());
            match self.detected_level(&mean) {
                Some(l) if !wide => {
                    let r = &self.responses;
                    let (wc, ws) = (r.maps[l].centre, r.levels[l].exp());
                    self.dcf.update_detected(&self.kept[l], wc, ws, at, 1.0)?;
                }
                _ => {
                    self.dcf.ensure_loaded(frame, at, scale)?;
                    self.dcf.update(at, scale, 1.0)?;
                }
            }
            if let Some(m) = self.colour.as_mut() {
                let reused = !wide
                    && c.update_colour == UpdateFeatures::Detection
                    && m.learn_detected(&self.dcf, at, scale, 1.0)?;
                if !reused {
                    m.learn(frame, &self.dcf, at, scale, 1.0)?;
                }
            }
            self.anchor = (mean[0], mean[1], mean[4]);
            self.peaks.0 += peak;
            self.peaks.1 += 1;
            // the scale filter learns where the model does, at fDSST's rate
            if let Some(f) = self.scale.as_mut() {
                let rate = scale_config().learning_rate;
                if scale_peak.is_some() && c.update_scale == UpdateFeatures::Detection {
                    // the measurement was at the predicted log-scale `pl`
                    f.train_detected(mean[4] - pl, rate)?;
                } else {
                    let r = scale_region(f, fw, fh, at, scale);
                    // a frame without a scale response loaded nothing yet
                    if scale_peak.is_none() || !self.scale_sampler.holds(&r) {
                        self.scale_sampler.load_gray_region(frame, r)?;
                    }
                    f.train(&mut self.scale_sampler, at.0, at.1, scale, rate)?;
                }
                if let Some(p) = scale_peak {
                    self.scale_peaks.0 += p;
                    self.scale_peaks.1 += 1;
                }
            }
        } else {
            self.diagnostics.lost_frames += 1;
        }
        self.lost = !admitted;
        Ok(Estimate {
            bbox: self.bbox(&mean),
            pose: None,
            particles: n,
            evaluations: n + self.responses.maps.len(),
            lost: !admitted,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ncc_scale::tests::{errors, growing, run, scene, texture};
    use crate::tracker::Tracker;
    use bayestrack_image::Image;

    fn pf(config: PfDcfConfig, seed: u64) -> PfDcfTracker {
        PfDcfTracker::new(config, seed).unwrap()
    }

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

    /// `Map::at` as first written (`rem_euclid` and `floor`): the same
    /// bits at every offset within half the window, the edges, -0 and
    /// values a rounding away from 0 and from the edges included.
    #[test]
    fn map_reads_as_rem_euclid_and_floor() {
        let (w, h) = (16usize, 40usize);
        let m = Map {
            centre: (0.0, 0.0),
            w,
            h,
            px: (3.7, 2.3),
            data: (0..w * h).map(|i| ((i * 37 % 101) as f32).sin()).collect(),
            ..Map::default()
        };
        let reference = |dx: f64, dy: f64| -> Option<f32> {
            let (u, v) = (dx / m.px.0, dy / m.px.1);
            let (wf, hf) = (w as f64, h as f64);
            if !(u.abs() <= wf / 2.0 && v.abs() <= hf / 2.0) {
                return None;
            }
            let (u, v) = (u.rem_euclid(wf), v.rem_euclid(hf));
            let (i0, j0) = (u.floor() as usize % w, v.floor() as usize % h);
            let (i1, j1) = ((i0 + 1) % w, (j0 + 1) % h);
            let (fx, fy) = ((u - u.floor()) as f32, (v - v.floor()) as f32);
            let g = |i: usize, j: usize| m.data[j * w + i];
            let top = g(i0, j0) + fx * (g(i1, j0) - g(i0, j0));
            let bot = g(i0, j1) + fx * (g(i1, j1) - g(i0, j1));
            Some(top + fy * (bot - top))
        };
        let mut xs: Vec<f64> = (-700..=700).map(|k| k as f64 * 0.0437).collect();
        let edges = [w as f64 / 2.0 * m.px.0, h as f64 / 2.0 * m.px.1];
        for e in edges {
            for v in [e, -e, e * (1.0 + 1e-16), -e * (1.0 - 1e-16)] {
                xs.extend([v, v.next_up(), v.next_down()]);
            }
        }
        xs.extend([0.0, -0.0, 1e-300, -1e-300, 5e-324, -5e-324, f64::NAN]);
        let bits = |r: Option<f32>| r.map(f32::to_bits);
        for &dx in &xs {
            for &dy in xs.iter().step_by(7).chain(&xs[xs.len() - 30..]) {
                assert_eq!(
                    bits(m.at(dx, dy)),
                    bits(reference(dx, dy)),
                    "({dx:e}, {dy:e})"
                );
            }
        }
    }

    /// A target moving on a curve while it grows by 40 % or shrinks by 30 %
    /// over 60 frames, gray and RGB, two seeds. Measured without the scale
    /// filter: mean IoU 0.811 to 0.902, worst centre error 1.84 to 2.16
    /// px, final size within 19 % of the truth (the scale lags a growing
    /// target: ratio 0.81 to 0.88 at 1.4x); with it (the default, this
    /// build): IoU 0.882 to 0.919, centre 1.71 to 3.27 px, final size
    /// within 6.6 %. Bounds: IoU 0.78, centre 3.5 px, size 20 %.
    #[test]
    fn holds_growing_and_shrinking_targets() {
        for (rgb, grow) in [(false, 1.4), (true, 1.4), (false, 0.7), (true, 1.0)] {
            let (frames, truth) = scene(61, rgb, 3.0, |k| growing(k, grow));
            for seed in [1, 2] {
                let mut t = pf(PfDcfConfig::default(), seed);
                let got = run(&mut t, &frames, truth[0]);
                let (centre, _) = errors(&got, &truth);
                let iou = mean_iou(&got, &truth);
                let last = got.last().unwrap().width / truth.last().unwrap().width;
                eprintln!(
                    "rgb {rgb} grow {grow} seed {seed}: IoU {iou:.3}, centre {centre:.2}, size ratio {last:.3}, {:?}",
                    t.diagnostics()
                );
                let case = format!("rgb {rgb} grow {grow} seed {seed}");
                assert!(iou >= 0.78, "{case}: mean IoU {iou:.3}");
                assert!(centre < 3.5, "{case}: centre error {centre:.2}");
                assert!((last - 1.0).abs() < 0.2, "{case}: size ratio {last:.3}");
            }
        }
    }

    /// Largest area error `|w h / (w' h') - 1|` over the frames.
    fn area_error(got: &[BBox], truth: &[BBox]) -> f64 {
        got.iter()
            .zip(truth)
            .map(|(g, t)| (g.width * g.height / (t.width * t.height) - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// The default without the scale filter (`redetect_scale` then does
    /// nothing: `no_scale_likelihood_gives_the_earlier_boxes` checks both
    /// of its values), with one second look a lost frame and the log-scale
    /// noise of before (the tracker before all three).
    /// The default without the colour score (the gate on the correlation
    /// response) and with the first particles at rest: what the tests of
    /// the lost search's looks were measured with.
    fn without_colour() -> PfDcfConfig {
        PfDcfConfig {
            colour_merge: 0.0,
            gate_response: GateResponse::Correlation,
            initial_velocity_spread: 0.0,
            ..PfDcfConfig::default()
        }
    }

    fn without_scale_filter() -> PfDcfConfig {
        PfDcfConfig {
            scale_likelihood: 0.0,
            redetect_looks: 1,
            scale_noise: 0.02,
            redetect_levels: 3,
            redetect_features: RedetectFeatures::PerWindow,
            update_features: UpdateFeatures::Extracted,
            update_scale: UpdateFeatures::Extracted,
            redetect_scale_at: LookScale::EveryLook,
            tracking_levels: 3,
            ..without_colour()
        }
    }

    /// The scale filter sizes a target growing by 40 % or shrinking to
    /// 0.55x over 60 frames (gray and RGB, seeds 1-3): the area error is
    /// at most 17 % on every frame of every run with the default, and more
    /// than that somewhere in every run without the scale filter (today's
    /// default before it). Measured (this build): 0.046 to 0.107 with it,
    /// 0.179 to 0.344 without.
    #[test]
    fn the_scale_filter_sizes_growing_and_shrinking_targets() {
        const BOUND: f64 = 0.17;
        for (rgb, grow) in [(false, 1.4), (true, 1.4), (false, 0.7), (true, 0.55)] {
            let (frames, truth) = scene(61, rgb, 3.0, |k| growing(k, grow));
            for seed in [1, 2, 3] {
                let case = format!("rgb {rgb} grow {grow} seed {seed}");
                let got = run(&mut pf(PfDcfConfig::default(), seed), &frames, truth[0]);
                let with = area_error(&got, &truth);
                let got = run(&mut pf(without_scale_filter(), seed), &frames, truth[0]);
                let without = area_error(&got, &truth);
                eprintln!(
                    "{case}: area error {with:.3} with the scale filter, {without:.3} without"
                );
                assert!(with <= BOUND, "{case}: {with:.3} with the scale filter");
                assert!(without > BOUND, "{case}: {without:.3} without it");
            }
        }
    }

    /// `tracking_levels = 1`: one translation response a frame after a
    /// tracked one, and the scale filter still sizes the growing target
    /// (area error within the bound above; measured 0.151, seed 1, with
    /// no frame lost; 0.107 with one lost frame since the scale filter
    /// learns from its detection).
    #[test]
    fn one_tracking_level_computes_one_response_a_frame() {
        let (frames, truth) = scene(61, false, 3.0, |k| growing(k, 1.4));
        let config = PfDcfConfig {
            tracking_levels: 1,
            ..PfDcfConfig::default()
        };
        let mut t = pf(config, 1);
        t.init(frames[0].view(), truth[0]).unwrap();
        let mut got = vec![truth[0]];
        for f in &frames[1..] {
            let (searching, before) = (t.is_lost(), t.diagnostics().responses);
            got.push(t.step(f.view()).unwrap().bbox);
            if !searching {
                assert_eq!(t.diagnostics().responses - before, 1);
            }
        }
        let d = t.diagnostics();
        assert!(d.lost_frames <= 2, "{d:?}");
        let e = area_error(&got, &truth);
        assert!(e <= 0.17, "{e:.3}");
    }

    /// With the log-scale noise 0 the particles keep the first size: the
    /// size bound above fails on the growing target.
    #[test]
    fn without_log_scale_noise_the_size_is_lost() {
        let (frames, truth) = scene(61, false, 3.0, |k| growing(k, 1.4));
        let mut t = pf(
            PfDcfConfig {
                scale_noise: 0.0,
                ..PfDcfConfig::default()
            },
            1,
        );
        let got = run(&mut t, &frames, truth[0]);
        let last = got.last().unwrap().width / truth.last().unwrap().width;
        assert!((last - 1.0 / 1.4).abs() < 1e-9, "{last}");
    }

    /// A target that moves 40 px while the scene is blanked (frames 15 to
    /// 24: a flat grey band over the whole track), farther than the half
    /// window (30 px) the normal search covers. Returns frames and truth.
    fn jump_scene() -> (Vec<Image<u8>>, Vec<BBox>) {
        let path = |k: usize| {
            let jump = if k >= 20 { 40.0 } else { 0.0 };
            (45.0 + 0.5 * k as f64 + jump, 60.0, 24.0, 30.0)
        };
        let (mut frames, truth) = scene(50, false, 3.0, path);
        for f in &mut frames[15..25] {
            for y in 30..90 {
                for x in 20..150 {
                    f.set(x, y, 0, 128);
                }
            }
        }
        (frames, truth)
    }

    /// A run of `config` on `frames` from `first`: the boxes and lost flags
    /// (the first frame's given) and the diagnostics.
    fn track_run(
        config: PfDcfConfig,
        seed: u64,
        frames: &[Image<u8>],
        first: BBox,
    ) -> (Vec<BBox>, Vec<bool>, PfDcfDiagnostics) {
        let mut t = pf(config, seed);
        t.init(frames[0].view(), first).unwrap();
        let (mut boxes, mut lost) = (vec![first], vec![false]);
        for f in &frames[1..] {
            let e = t.step(f.view()).unwrap();
            boxes.push(e.bbox);
            lost.push(e.lost);
        }
        (boxes, lost, t.diagnostics())
    }

    fn lost_run(config: PfDcfConfig, seed: u64) -> (Vec<BBox>, Vec<bool>, PfDcfDiagnostics) {
        let (frames, truth) = jump_scene();
        track_run(config, seed, &frames, truth[0])
    }

    /// Re-detection: the blanked frames are refused (lost, model frozen),
    /// and when the target comes back 45 px from where it was last learnt
    /// (beyond the normal window's reach) the wide search's centred second
    /// look re-acquires it. Measured (seeds 1-3): 10-12 lost frames, one or
    /// two re-acquisitions, centre error 1.58-1.83 px over frames 35-49;
    /// seed 2 also refuses frame 12 (a weak response before the blank),
    /// hence "at most one" early loss. Without the second look (the grid's
    /// off-centre peaks only, this tracker's first version) no seed
    /// re-acquires (centre error 64 px); with `redetect = false` neither.
    #[test]
    fn re_detects_a_target_that_moved_while_hidden() {
        let (_, truth) = jump_scene();
        for seed in [1, 2, 3] {
            let (boxes, lost, d) = lost_run(bootstrap(), seed);
            let (centre, _) = errors(&boxes[35..], &truth[35..]);
            eprintln!("seed {seed}: {d:?}, centre error after {centre:.2}, lost {lost:?}");
            let early = lost[..15].iter().filter(|&&l| l).count();
            assert!(early <= 1, "seed {seed}: {lost:?}");
            assert!(lost[15..25].iter().all(|&l| l), "seed {seed}: {lost:?}");
            assert!(lost[30..].iter().all(|l| !l), "seed {seed}: {lost:?}");
            assert!(d.reacquisitions >= 1, "seed {seed}: {d:?}");
            assert!(
                centre < 3.0,
                "seed {seed}: centre error {centre:.2} after re-detection"
            );
        }
    }

    /// The bootstrap filter (`peak_fraction` 0) without the scale filter
    /// (`scale_likelihood` 0), one second look a lost frame: the jump
    /// scene's tests below were measured with it and test the lost
    /// search's mechanics. With one look, the scale filter or the peak
    /// proposal made the jump scene's re-acquisition luck (one seed in
    /// three): the target sits between two grid windows, near an edge
    /// where the cosine window weakens its peak to the background's at
    /// the last learnt place, and the one second look went to whichever
    /// was higher (docs/results.md, "second looks").
    fn bootstrap() -> PfDcfConfig {
        PfDcfConfig {
            peak_fraction: 0.0,
            ..without_scale_filter()
        }
    }

    /// The default holds the jump scene's target until the blank, loses
    /// it over the blank and re-acquires it after with every seed (seeds
    /// 1-3, measured: worst centre error 1.0-1.8 px before, 1.3-1.8 px
    /// over frames 35-49). At the log-scale noise, scale measurement and
    /// gate the extra second looks were chosen with (0.02, before every
    /// look, no colour),
    /// three looks re-acquire with every seed
    /// (1.4-1.5 px after) and one (`redetect_looks` 1, the mutation) leaves
    /// seeds 1 and 3 lost: its look goes to the background where the
    /// target was last learnt, not to the target between two grid windows.
    #[test]
    fn the_default_re_detects_the_jump_scene() {
        let (_, truth) = jump_scene();
        let mut one_look_found = 0;
        for seed in [1, 2, 3] {
            let (boxes, lost, d) = lost_run(PfDcfConfig::default(), seed);
            let (before, _) = errors(&boxes[..15], &truth[..15]);
            let (after, _) = errors(&boxes[35..], &truth[35..]);
            eprintln!("seed {seed}: before {before:.2}, after {after:.2}, {d:?}");
            assert!(before < 3.0, "seed {seed}: {before:.2} px");
            assert!(lost[15..25].iter().all(|&l| l), "seed {seed}: {lost:?}");
            assert!(after < 3.0, "seed {seed}: {after:.2} px after");
            // the looks at the log-scale noise, scale measurement and
            // gate of when they were chosen (0.02, before every look, the
            // correlation response without colour): three re-acquire
            // with every seed, one not
            let three = PfDcfConfig {
                scale_noise: 0.02,
                redetect_scale_at: LookScale::EveryLook,
                ..without_colour()
            };
            let (boxes, _, _) = lost_run(three, seed);
            let (after, _) = errors(&boxes[35..], &truth[35..]);
            assert!(after < 3.0, "seed {seed}, three looks: {after:.2} px after");
            let one = PfDcfConfig {
                redetect_looks: 1,
                ..three
            };
            let (boxes, _, _) = lost_run(one, seed);
            one_look_found += usize::from(errors(&boxes[35..], &truth[35..]).0 < 3.0);
        }
        assert!(one_look_found < 3, "one look re-acquired with every seed");
    }

    /// A target that comes back from behind the blank 40 px on and 1.15
    /// times larger (1.32 times the area) is re-acquired at its new size.
    /// Measured without colour, as the looks' scale was chosen: over the
    /// first five frames after it, the largest area error is at most 0.18
    /// (seeds 1-3; measured 0.125-0.146), at most 0.22 measuring the
    /// scale before every look (0.159-0.184), and above 0.18 with every
    /// seed with `redetect_scale = false` (the mutation: the looks at the
    /// last learnt scale, the particles restarting there; 0.217-0.244).
    /// With the default's colour (on this gray scene, a gray-level
    /// histogram) at most 0.22 (0.152-0.199; without the looks' scale
    /// 0.236-0.258).
    #[test]
    fn re_acquires_a_target_that_grew_while_hidden_at_its_size() {
        let path = |k: usize| {
            let (jump, z) = if k >= 20 { (40.0, 1.15) } else { (0.0, 1.0) };
            (45.0 + 0.5 * k as f64 + jump, 60.0, 24.0 * z, 30.0 * z)
        };
        let (mut frames, truth) = scene(40, false, 3.0, path);
        for f in &mut frames[15..25] {
            for y in 30..100 {
                for x in 20..160 {
                    f.set(x, y, 0, 128);
                }
            }
        }
        let every_look = PfDcfConfig {
            redetect_scale_at: LookScale::EveryLook,
            ..without_colour()
        };
        let no_scale = PfDcfConfig {
            redetect_scale: false,
            ..without_colour()
        };
        for seed in [1, 2, 3] {
            let error = |config: PfDcfConfig| {
                let (boxes, lost, d) = track_run(config, seed, &frames, truth[0]);
                let back = (25..35).find(|&k| !lost[k]);
                let back = back.unwrap_or_else(|| panic!("seed {seed}: not re-acquired, {d:?}"));
                area_error(&boxes[back..back + 5], &truth[back..back + 5])
            };
            let (a, e, n) = (error(without_colour()), error(every_look), error(no_scale));
            let coloured = error(PfDcfConfig::default());
            eprintln!("seed {seed}: area error {a:.3} / {e:.3} / {n:.3}, colour {coloured:.3}");
            assert!(a <= 0.18, "seed {seed}: {a:.3}");
            assert!(coloured <= 0.22, "seed {seed}, colour: {coloured:.3}");
            assert!(e <= 0.22, "seed {seed}, every look: {e:.3}");
            assert!(n > 0.18, "seed {seed}, no scale: {n:.3}");
        }
    }

    /// The scale filter learns the frames the gate admits and only those:
    /// on the jump scene (seed 1), its response on a fixed probe (the
    /// first frame at the first box) changes over every admitted frame
    /// and over no refused one (the blank). Skipping its training (the
    /// mutation) fails the first, training it on refused frames the
    /// second.
    #[test]
    fn the_scale_filter_learns_the_admitted_frames_only() {
        let (frames, truth) = jump_scene();
        let mut t = pf(PfDcfConfig::default(), 1);
        t.init(frames[0].view(), truth[0]).unwrap();
        let mut probe = PatchSampler::new();
        let whole = Region::whole(frames[0].width(), frames[0].height());
        probe.load_gray_region(frames[0].view(), whole).unwrap();
        let (cx, cy) = truth[0].center();
        let mut state = |t: &PfDcfTracker| -> Vec<u64> {
            let mut f = t.core().scale.clone().expect("a scale filter");
            let mut out = ScaleResponse::default();
            f.respond(&mut probe, cx - 1.0, cy - 1.0, 1.0, &mut out)
                .unwrap();
            out.values.iter().map(|v| v.to_bits()).collect()
        };
        let (mut admitted, mut refused) = (0, 0);
        for (k, f) in frames.iter().enumerate().skip(1) {
            let before = state(&t);
            let lost = t.step(f.view()).unwrap().lost;
            let after = state(&t);
            if lost {
                assert_eq!(before, after, "frame {k}: refused, yet learnt");
                refused += 1;
            } else {
                assert_ne!(before, after, "frame {k}: admitted, not learnt");
                admitted += 1;
            }
        }
        assert!(admitted >= 10 && refused >= 10, "{admitted} {refused}");
    }

    /// Responses of a run: three a tracked frame; a frame after a lost one
    /// searches the 3 x 3 grid and takes a second look, `per_lost` in all.
    fn responses_of(lost: &[bool], per_lost: usize) -> usize {
        lost.windows(2)
            .map(|w| if w[0] { per_lost } else { 3 })
            .sum()
    }

    /// Every lost search costs what it should (the outer scales at the
    /// best window: 9 + 2 + 1 responses; at every window 9 x 3 + 1; one
    /// scale 9 + 1), and the hidden target is still re-acquired (seeds
    /// 1-3: centre error under 3 px after). Computing the outer scales at
    /// every window (the mutation) fails the cost of the default.
    #[test]
    fn every_lost_search_re_detects_at_its_cost() {
        let (_, truth) = jump_scene();
        for seed in [1, 2, 3] {
            for (levels, outer, cost) in [
                (3, OuterScales::BestWindow, 12),
                (3, OuterScales::EveryWindow, 28),
                (1, OuterScales::BestWindow, 10),
            ] {
                let config = PfDcfConfig {
                    redetect_levels: levels,
                    redetect_outer: outer,
                    ..bootstrap()
                };
                let (boxes, lost, d) = lost_run(config, seed);
                let case = format!("seed {seed}, levels {levels}, {outer:?}");
                assert_eq!(d.responses, responses_of(&lost, cost), "{case}: {d:?}");
                assert!(
                    d.lost_frames >= 10 && d.reacquisitions >= 1,
                    "{case}: {d:?}"
                );
                let (centre, _) = errors(&boxes[35..], &truth[35..]);
                assert!(centre < 3.0, "{case}: {centre:.2} px");
            }
        }
    }

    /// While lost, the outer scales are computed at the window whose
    /// middle-scale map peaks highest; every other window's outer maps are
    /// its middle one. Checked on every lost frame of the jump scene whose
    /// best middle map is not flat (the blanked frames' are; 11 frames
    /// checked with seed 1, at least 5 required); with the
    /// outer scales always at the first window (the mutation) it fails.
    #[test]
    fn a_lost_frame_computes_the_outer_scales_at_the_best_window() {
        let (frames, truth) = jump_scene();
        let config = PfDcfConfig {
            redetect_levels: 3,
            redetect_features: RedetectFeatures::PerWindow,
            tracking_levels: 3,
            ..PfDcfConfig::default()
        };
        let mut t = pf(config, 1);
        t.init(frames[0].view(), truth[0]).unwrap();
        let peak = |m: &Map| m.data.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b));
        let mut checked = 0;
        for f in &frames[1..] {
            let searching = t.is_lost();
            t.step(f.view()).unwrap();
            let r = &t.core().responses;
            if !searching {
                assert_eq!(r.maps.len(), 3);
                continue;
            }
            assert_eq!(r.maps.len(), 27);
            let best = (0..9)
                .rev()
                .max_by(|&a, &b| peak(&r.maps[a * 3 + 1]).total_cmp(&peak(&r.maps[b * 3 + 1])))
                .unwrap();
            let m = &r.maps[best * 3..best * 3 + 3];
            let flat = m[1].data.iter().all(|&v| v == m[1].data[0]);
            if flat {
                continue;
            }
            assert!(m[0].data != m[1].data && m[2].data != m[1].data);
            for k in (0..9).filter(|&k| r.maps[k * 3 + 1].centre != m[1].centre) {
                let o = &r.maps[k * 3..k * 3 + 3];
                assert!(
                    o[0].data == o[1].data && o[2].data == o[1].data,
                    "window {k}"
                );
            }
            checked += 1;
        }
        assert!(checked >= 5, "{checked} lost frames with a response");
    }

    /// The shared-feature grid ([`RedetectFeatures::Shared`]) at one and
    /// three scales: a lost frame costs the same responses as the
    /// per-window grid (9 L + 1), and the target that moved 45 px while
    /// hidden is re-acquired (seeds 1-3: centre error under 3 px over
    /// frames 35-49, every frame from 30 on tracked).
    #[test]
    fn the_shared_feature_grid_re_detects() {
        let (_, truth) = jump_scene();
        for seed in [1, 2, 3] {
            for levels in [1, 3] {
                let config = PfDcfConfig {
                    redetect_levels: levels,
                    redetect_features: RedetectFeatures::Shared,
                    ..bootstrap()
                };
                let (boxes, lost, d) = lost_run(config, seed);
                let (centre, _) = errors(&boxes[35..], &truth[35..]);
                eprintln!("seed {seed} levels {levels}: {d:?}, centre error after {centre:.2}");
                assert_eq!(d.responses, responses_of(&lost, 9 * levels + 1), "{d:?}");
                assert!(lost[15..25].iter().all(|&l| l), "seed {seed}: {lost:?}");
                let late = lost[30..].iter().filter(|&&l| l).count();
                assert!(late <= 1, "seed {seed}: {lost:?}");
                assert!(d.reacquisitions >= 1, "{d:?}");
                assert!(centre < 3.0, "seed {seed}, levels {levels}: {centre:.2} px");
            }
        }
    }

    /// Near the frame's left edge a 5 x 5 grid clamps its two left columns
    /// of windows onto `x = 0`: 20 distinct windows, each computed once (a
    /// lost frame costs 20 + 2 + 1 responses with the outer scales at the
    /// best window, 20 x 3 + 1 at every window, not 25 ...), and the target
    /// hidden there for ten frames is still re-acquired; the same with
    /// the shared-feature grid (the clamped windows round to the same
    /// cells).
    #[test]
    fn grid_windows_clamped_together_are_computed_once() {
        let (mut frames, truth) = scene(40, false, 3.0, |_| (25.0, 60.0, 24.0, 30.0));
        for f in &mut frames[15..25] {
            for y in 30..90 {
                for x in 0..60 {
                    f.set(x, y, 0, 128);
                }
            }
        }
        // per-window features with the outer scales at the best window
        // (20 + 2 + 1 a lost frame) or at every one (20 x 3 + 1), shared
        // features (20 x 3 + 1)
        for (features, outer, cost) in [
            (RedetectFeatures::PerWindow, OuterScales::BestWindow, 23),
            (RedetectFeatures::PerWindow, OuterScales::EveryWindow, 61),
            (RedetectFeatures::Shared, OuterScales::BestWindow, 61),
        ] {
            // one second look a lost frame: the cost is fixed
            let config = PfDcfConfig {
                redetect_grid: 5,
                redetect_features: features,
                redetect_outer: outer,
                redetect_looks: 1,
                redetect_levels: 3,
                tracking_levels: 3,
                ..PfDcfConfig::default()
            };
            let (boxes, lost, d) = track_run(config, 1, &frames, truth[0]);
            assert!(
                d.lost_frames >= 10 && d.reacquisitions >= 1,
                "{features:?}: {d:?} {lost:?}"
            );
            let counted = responses_of(&lost, cost);
            assert_eq!(d.responses, counted, "{features:?}: {d:?} {lost:?}");
            let (centre, _) = errors(&boxes[30..], &truth[30..]);
            assert!(
                centre < 3.0,
                "{features:?}: centre error {centre:.2} px after re-detection"
            );
        }
    }

    /// What holds today: the gate refuses every blanked frame (the model
    /// is frozen through them) and none of the 14 frames before; with the
    /// gate off (the mutation) no frame is refused and the model learns
    /// the blank band.
    #[test]
    fn the_gate_freezes_the_model_on_blanked_frames() {
        let (_, lost, d) = lost_run(bootstrap(), 1);
        assert!(lost[..15].iter().all(|l| !l), "{lost:?}");
        assert!(lost[15..25].iter().all(|&l| l), "{lost:?}");
        assert!(d.lost_frames >= 10, "{d:?}");
        let (_, lost, d) = lost_run(
            PfDcfConfig {
                gate: GateOptions {
                    gate: false,
                    ..GateOptions::default()
                },
                ..bootstrap()
            },
            1,
        );
        assert!(lost.iter().all(|l| !l) && d.lost_frames == 0, "{d:?}");
    }

    /// FNV-1a over the boxes' bits.
    fn digest(boxes: &[BBox]) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for b in boxes {
            for v in [b.x, b.y, b.width, b.height] {
                for byte in v.to_bits().to_le_bytes() {
                    h = (h ^ byte as u64).wrapping_mul(0x100_0000_01b3);
                }
            }
        }
        h
    }

    /// `peak_fraction = 0` is the bootstrap filter of before the option:
    /// the boxes of a growing RGB target and of the jump scene (lost
    /// frames, the grid) hash as they did before the peak proposal was
    /// written (digests recorded then, seed 1).
    #[test]
    fn no_peak_fraction_gives_the_earlier_boxes() {
        let (frames, truth) = scene(61, true, 3.0, |k| growing(k, 1.4));
        let config = PfDcfConfig {
            peak_fraction: 0.0,
            ..without_scale_filter()
        };
        let got = run(&mut pf(config, 1), &frames, truth[0]);
        let (jumped, _, _) = lost_run(config, 1);
        assert_eq!(
            (digest(&got), digest(&jumped)),
            (GROWING_DIGEST, JUMP_DIGEST),
            "{:x} {:x}",
            digest(&got),
            digest(&jumped)
        );
    }

    const GROWING_DIGEST: u64 = 0x2111_583b_c12a_16ef;

    /// `scale_likelihood = 0` (with either `redetect_scale`) is the tracker
    /// of before the scale filter (`peak_fraction` 0.2): the boxes of a
    /// growing RGB target and of the jump scene hash as they did (digests
    /// recorded with this configuration, whose Couple and Crossing digests
    /// are main's before the scale filter, f84e1024f1af80a6 and
    /// 9302a3437c42334c; seed 1).
    #[test]
    fn no_scale_likelihood_gives_the_earlier_boxes() {
        let (frames, truth) = scene(61, true, 3.0, |k| growing(k, 1.4));
        for redetect_scale in [true, false] {
            let config = PfDcfConfig {
                redetect_scale,
                ..without_scale_filter()
            };
            let got = run(&mut pf(config, 1), &frames, truth[0]);
            let (jumped, _, _) = lost_run(config, 1);
            assert_eq!(
                (digest(&got), digest(&jumped)),
                (PEAK_GROWING_DIGEST, PEAK_JUMP_DIGEST),
                "redetect_scale {redetect_scale}: {:x} {:x}",
                digest(&got),
                digest(&jumped)
            );
        }
    }

    const PEAK_GROWING_DIGEST: u64 = 0xbfb9_1182_4826_cab0;
    const PEAK_JUMP_DIGEST: u64 = 0x0e8a_84c3_2d60_dbbe;
    const JUMP_DIGEST: u64 = 0xd501_20b8_27ec_7f55;

    /// A single window's responses at three scales, a Gaussian bump of
    /// `sigma` 4 px at `bump` (frame pixels) whose height grows with the
    /// scale (0.8, 0.9, 1.0), `ln p(y | x) = 6 R`.
    fn synthetic_responses(bump: (f64, f64), step: f64) -> Responses {
        let centre = (80.0, 60.0);
        let (w, h, px) = (32usize, 32usize, 2.0);
        let d = step.ln();
        let maps = [0.8f32, 0.9, 1.0]
            .iter()
            .map(|&height| {
                let data = (0..w * h)
                    .map(|i| {
                        // cell (i, j) is the wrapped displacement
                        let wrap = |k: usize, n: usize| {
                            if k < n / 2 {
                                k as f64
                            } else {
                                k as f64 - n as f64
                            }
                        };
                        let (dx, dy) = (wrap(i % w, w) * px, wrap(i / w, h) * px);
                        let (ex, ey) = (centre.0 + dx - bump.0, centre.1 + dy - bump.1);
                        height * (-(ex * ex + ey * ey) as f32 / 32.0).exp()
                    })
                    .collect();
                Map {
                    centre,
                    w,
                    h,
                    px: (px, px),
                    data,
                    peak: height,
                    at: bump,
                }
            })
            .collect();
        Responses {
            levels: vec![-d, 0.0, d],
            windows: 1,
            maps,
            stride: (0.0, 0.0),
            gain: 6.0,
            scale: None,
        }
    }

    /// The posterior `p(x | x', y) ~ p(y | x) p(x | x')` of one parent
    /// estimated by self-normalised importance sampling from `proposal`:
    /// the mean of `[cx, cy, vx, vy, ln s, jumped]`, and each one's
    /// standard error (the delta method's, `sum w^2 (f - mean)^2 /
    /// (sum w)^2`).
    fn posterior(
        proposal: &PfDcfProposal<'_>,
        parent: &State,
        n: usize,
        seed: u64,
    ) -> [(f64, f64); 6] {
        use rand::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let draws: Vec<(State, f64)> = (0..n)
            .map(|_| proposal.propose(0, parent, &(), &mut (), &mut rng).unwrap())
            .collect();
        let max = draws.iter().map(|d| d.1).fold(f64::NEG_INFINITY, f64::max);
        let w: Vec<f64> = draws.iter().map(|d| (d.1 - max).exp()).collect();
        let sw: f64 = w.iter().sum();
        let f = |x: &State, k: usize| {
            if k < 5 {
                x[k]
            } else if x[2] == 0.0 && x[3] == 0.0 {
                1.0
            } else {
                0.0
            }
        };
        std::array::from_fn(|k| {
            let mean = draws
                .iter()
                .zip(&w)
                .map(|(d, w)| w * f(&d.0, k))
                .sum::<f64>()
                / sw;
            let var = draws
                .iter()
                .zip(&w)
                .map(|(d, w)| (w * (f(&d.0, k) - mean)).powi(2))
                .sum::<f64>()
                / (sw * sw);
            (mean, var.sqrt())
        })
    }

    /// The peak proposal's weights are exact: on a fixed response, the
    /// posterior of one parent estimated from the mixture proposal
    /// (`beta` 0.5, 0.9) agrees with the bootstrap's (200,000 draws each)
    /// within 5 standard errors (plus 1e-4) in every state component and
    /// the jump probability, with the bump where only a jump reaches it
    /// (12 px from the predicted centre, about 12 position-noise sigmas)
    /// and where the constant-velocity branch does (2 px: the log-scale's
    /// factor of the weight at work). Weighing the mixture's particles by
    /// the likelihood alone (the correction term dropped) or leaving out
    /// the log-scale factor fails it.
    #[test]
    fn the_peak_proposal_weighs_exactly() {
        let config = PfDcfConfig::default();
        let parent = State::new(80.0, 60.0, 2.0, 0.0, 0.0);
        for (case, bump) in [("far", (91.0, 54.0)), ("near", (83.0, 61.5))] {
            let responses = synthetic_responses(bump, config.scale_step);
            let make = |peak| PfDcfProposal {
                config: &config,
                responses: &responses,
                z0: 20.0,
                spread: (1.0, 1.0),
                searching: false,
                frame: (160.0, 120.0),
                scale_bounds: (-1.0, 1.0),
                peak,
            };
            let d = config.scale_step.ln();
            let reference = posterior(&make(None), &parent, 200_000, 1);
            for beta in [0.5, 0.9] {
                let peak = Peak::new(beta, bump, d, 0.1 * 20.0 * d.exp(), 0.5 * d);
                let got = posterior(&make(Some(peak)), &parent, 200_000, 2);
                for (k, (a, b)) in reference.iter().zip(&got).enumerate() {
                    let bound = 5.0 * a.1.hypot(b.1) + 1e-4;
                    eprintln!(
                        "{case} beta {beta} [{k}]: bootstrap {:.5} ({:.5}), peak {:.5} ({:.5})",
                        a.0, a.1, b.0, b.1
                    );
                    assert!(
                        (a.0 - b.0).abs() < bound,
                        "{case}, beta {beta}, component {k}: {:.5} against {:.5} (bound {bound:.5})",
                        b.0,
                        a.0
                    );
                }
            }
        }
    }

    /// A target that turns abruptly at about 20 px a frame: a 72 x 40 px
    /// rectangle run round clockwise (right 4 frames at 18 px, down 2 at
    /// 20, left 4, up 2), four laps.
    fn turning(k: usize) -> (f64, f64, f64, f64) {
        let t = k % 16;
        let (x, y) = match t {
            0..=5 => (60.0 + 20.0 * t as f64, 50.0),
            6..=8 => (160.0, 50.0 + 20.0 * (t - 5) as f64),
            9..=13 => (160.0 - 20.0 * (t - 8) as f64, 110.0),
            _ => (60.0, 110.0 - 20.0 * (t - 13) as f64),
        };
        (x, y, 40.0, 48.0)
    }

    /// 49 gray frames of 160 x 120 of [`turning`]: a textured target on a
    /// plain background with a little pixel noise (a textured background
    /// that stays put outweighs a target that moves 18 px in the filter's
    /// window, and even `dcf` stays with it), truth boxes.
    fn turning_scene() -> (Vec<Image<u8>>, Vec<BBox>) {
        let mut frames = Vec::new();
        let mut truth = Vec::new();
        for k in 0..49 {
            let (cx, cy, w, h) = turning(k);
            frames.push(
                Image::from_fn(240, 180, |x, y| {
                    let (u, v) = ((x as f64 - cx) / w, (y as f64 - cy) / h);
                    let noise = ((x * 7919 + y * 104_729 + k * 31_337) % 13) as f64 - 6.0;
                    let g = if u.abs() <= 0.5 && v.abs() <= 0.5 {
                        110.0
                            + 60.0 * (u * 13.0).sin() * (v * 9.0 + 1.0).cos()
                            + 30.0 * (u * 5.0 - v * 7.0).cos()
                    } else {
                        120.0
                    };
                    (g + noise).clamp(0.0, 255.0) as u8
                })
                .unwrap(),
            );
            truth.push(BBox::new(cx - w / 2.0 + 1.0, cy - h / 2.0 + 1.0, w, h));
        }
        (frames, truth)
    }

    /// With the default fifth of the particles drawn at the response's
    /// peak, a target that turns abruptly at 20 px a frame is held. The
    /// bootstrap filter (`peak_fraction` 0, the mutation) fails the
    /// bound.
    #[test]
    fn the_peak_proposal_follows_abrupt_turns() {
        let (frames, truth) = turning_scene();
        for (beta, holds) in [(PfDcfConfig::default().peak_fraction, true), (0.0, false)] {
            for seed in [1, 2, 3] {
                let config = PfDcfConfig {
                    peak_fraction: beta,
                    ..PfDcfConfig::default()
                };
                let (got, lost, _) = track_run(config, seed, &frames, truth[0]);
                let iou = mean_iou(&got, &truth);
                let (centre, _) = errors(&got, &truth);
                let lost = lost.iter().filter(|&&l| l).count();
                eprintln!("beta {beta} seed {seed}: IoU {iou:.3}, centre {centre:.2}, {lost} lost");
                if holds {
                    assert!(iou >= 0.85, "seed {seed}: IoU {iou:.3}");
                } else {
                    assert!(iou < 0.85, "seed {seed}: IoU {iou:.3}");
                }
            }
        }
    }

    #[test]
    fn deterministic_for_a_seed() {
        let (frames, truth) = scene(20, true, 3.0, |k| growing(k, 1.2));
        let a = run(&mut pf(PfDcfConfig::default(), 4), &frames, truth[0]);
        let b = run(&mut pf(PfDcfConfig::default(), 4), &frames, truth[0]);
        let c = run(&mut pf(PfDcfConfig::default(), 5), &frames, truth[0]);
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn bad_input_is_an_error() {
        for bad in [
            PfDcfConfig {
                particles: 0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                likelihood: f64::NAN,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                scale_step: 1.0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_grid: 2,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_looks: 0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_looks: 82,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_spread: 0.5,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_scale_spread: 0.5,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                redetect_levels: 2,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                peak_fraction: 1.5,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                peak_fraction: f64::NAN,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                colour_merge: 1.5,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                initial_velocity_spread: -0.5,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                colour_rate: f64::NAN,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                inner_padding: -0.1,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                peak_spread: 0.0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                peak_scale_spread: f64::INFINITY,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                peak_fraction: 0.2,
                position_noise: 0.0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                scale_likelihood: f64::NAN,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                scale_likelihood: -1.0,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                scale_likelihood: 1e4,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                tracking_levels: 2,
                ..PfDcfConfig::default()
            },
            PfDcfConfig {
                tracking_levels: 1,
                ..without_scale_filter()
            },
        ] {
            assert!(matches!(
                PfDcfTracker::new(bad, 0),
                Err(TrackerError::InvalidParameter { .. })
            ));
        }
        assert!(matches!(
            PfDcfTracker::new(
                PfDcfConfig {
                    kcf: KcfOptions {
                        cell: 0,
                        ..KcfOptions::default()
                    },
                    ..PfDcfConfig::default()
                },
                0
            ),
            Err(TrackerError::Dcf(_))
        ));
        let gray = Image::from_fn(40, 30, |x, y| ((x * 7 + y * 3) % 50) as u8).unwrap();
        let two = Image::new(40, 30, 2, 0u8).unwrap();
        let mut t = pf(PfDcfConfig::default(), 0);
        assert!(matches!(
            t.step(gray.view()),
            Err(TrackerError::NotInitialised)
        ));
        assert!(matches!(
            t.init(two.view(), BBox::new(1.0, 1.0, 5.0, 5.0)),
            Err(TrackerError::Channels { .. })
        ));
        // a flat frame: a zero response, equal weights; tracked, not NaN
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

    /// An orange target whose texture two travelling waves warp further
    /// every frame (its look keeps changing, its colour does not),
    /// walking 1.2 px a frame across a static green-gray texture: the
    /// stress set's `deformation` in small.
    fn warping(frames: usize) -> (Vec<Image<u8>>, Vec<BBox>) {
        let (fw, fh) = (160usize, 120usize);
        let (bg, fg) = (texture(11), texture(23));
        let mut out = Vec::new();
        let mut boxes = Vec::new();
        for k in 0..frames {
            let t = k as f64;
            let (cx, cy, w, h) = (40.0 + 1.2 * t, 60.0 + 10.0 * (t / 12.0).sin(), 24.0, 30.0);
            let phase = 0.35 * t;
            let mut data = Vec::with_capacity(fw * fh * 3);
            for y in 0..fh {
                for x in 0..fw {
                    let (xf, yf) = (x as f64, y as f64);
                    let (u, v) = ((xf - cx) / w, (yf - cy) / h);
                    let p = if u.abs() <= 0.5 && v.abs() <= 0.5 {
                        let a = u * 40.0 + 6.0 * (v * 12.0 + phase).sin();
                        let b = v * 40.0 + 6.0 * (u * 10.0 + 1.3 * phase).sin();
                        let g = 0.6 * fg(a, b) + 30.0 * (a * 0.25).cos();
                        [(g * 1.3 + 40.0).min(255.0), g * 0.7, g * 0.4]
                    } else {
                        let g = bg(xf, yf);
                        [g * 0.8, g, g * 0.85]
                    };
                    data.extend(p.map(|c| c as u8));
                }
            }
            out.push(Image::from_vec(fw, fh, 3, data).unwrap());
            boxes.push(BBox::new(
                cx - (w - 1.0) / 2.0 + 1.0,
                cy - (h - 1.0) / 2.0 + 1.0,
                w,
                h,
            ));
        }
        (out, boxes)
    }

    /// With Staple's colour score and the gate reading the merged
    /// response, pf-dcf holds a target whose texture keeps warping (worst
    /// centre error 9.5-10.9 px on a 24 x 30 target, mean 3.8-4.3, 1-2
    /// frames lost, tracker seeds 0-2); with the gate on the correlation
    /// response, with or without colour, the gate refuses the changed
    /// target, the model freezes, and the search loses it (worst errors
    /// 35-94 px, 45-77 frames lost): the bounds fail.
    #[test]
    fn colour_and_a_gate_on_the_merged_response_hold_a_target_whose_look_changes() {
        let (frames, truth) = warping(80);
        for (colour, gate) in [
            (0.3, GateResponse::Merged),
            (0.0, GateResponse::Correlation),
            (0.3, GateResponse::Correlation),
        ] {
            let mut worst = 0.0f64;
            for seed in 0..3 {
                let config = PfDcfConfig {
                    colour_merge: colour,
                    gate_response: gate,
                    ..PfDcfConfig::default()
                };
                let mut t = pf(config, seed);
                let got = run(&mut t, &frames, truth[0]);
                let (centre, _) = errors(&got, &truth);
                let mean = got
                    .iter()
                    .zip(&truth)
                    .map(|(g, t)| {
                        let (a, b) = (g.center(), t.center());
                        (a.0 - b.0).hypot(a.1 - b.1)
                    })
                    .sum::<f64>()
                    / got.len() as f64;
                let lost = t.core().diagnostics().lost_frames;
                if gate == GateResponse::Merged {
                    assert!(
                        centre <= 13.0 && mean <= 5.0 && lost <= 5,
                        "seed {seed}: worst {centre:.2}, mean {mean:.2}, lost {lost}"
                    );
                }
                worst = worst.max(centre);
            }
            if gate == GateResponse::Correlation {
                assert!(
                    worst > 30.0,
                    "colour {colour}: worst centre error {worst:.2}"
                );
            }
        }
    }

    /// A target that starts moving at once, 0.6 of its size a frame
    /// (16 px on a 24 x 30 target, 7 frames): with the first particles'
    /// velocities drawn at the jump's spread (the default) the mean centre
    /// error over frames 1-6 stays at most 8 px (seeds 0-2; measured
    /// 1.5-7.2), with every particle at rest it is at least 10 (12.4-12.7:
    /// the first move is refused and found again only by the lost search,
    /// every third frame).
    #[test]
    fn a_target_that_moves_fast_from_the_first_frame_is_followed() {
        let path = |k: usize| (30.0 + 16.0 * k as f64, 60.0, 24.0, 30.0);
        let (frames, truth) = scene(7, true, 3.0, path);
        for (spread, bound) in [(0.5, 8.0), (0.0, 10.0)] {
            for seed in 0..3 {
                let config = PfDcfConfig {
                    initial_velocity_spread: spread,
                    ..PfDcfConfig::default()
                };
                let got = run(&mut pf(config, seed), &frames, truth[0]);
                let mean = got[1..]
                    .iter()
                    .zip(&truth[1..])
                    .map(|(g, t)| {
                        let (a, b) = (g.center(), t.center());
                        (a.0 - b.0).hypot(a.1 - b.1)
                    })
                    .sum::<f64>()
                    / 6.0;
                if spread > 0.0 {
                    assert!(mean <= bound, "seed {seed}: {mean:.2} px");
                } else {
                    assert!(mean >= bound, "at rest, seed {seed}: {mean:.2} px");
                }
            }
        }
    }

    /// A target hidden for 40 frames behind a flat patch, the textured
    /// background around it still in view: with the log-scale held while
    /// lost (`redetect_scale_spread` 0) the box's area stays within 10 %
    /// of the last tracked frame's (seeds 0-2; measured at most 2-4 %);
    /// with the default's walk (2) it drifts by more than e^1 (measured
    /// e^1.6-e^1.7 smaller: small particles stay on the background's narrow
    /// peaks and survive). The set did not choose 0 (docs/results.md, "the
    /// log-scale held while lost"): a lost box is scored off the target
    /// whatever its size.
    #[test]
    fn the_box_keeps_its_size_while_lost_only_with_the_scale_held() {
        let path = |k: usize| (60.0 + 0.3 * k as f64, 60.0, 24.0, 30.0);
        let (mut frames, truth) = scene(50, false, 3.0, path);
        for f in &mut frames[10..] {
            for y in 35..85 {
                for x in 40..100 {
                    f.set(x, y, 0, 128);
                }
            }
        }
        for spread in [0.0, 2.0] {
            for seed in 0..3 {
                let config = PfDcfConfig {
                    redetect_scale_spread: spread,
                    ..PfDcfConfig::default()
                };
                let (boxes, lost, _) = track_run(config, seed, &frames, truth[0]);
                assert!(lost[10..].iter().all(|&l| l), "seed {seed}: {lost:?}");
                let a0 = boxes[9].width * boxes[9].height;
                let worst = boxes[10..]
                    .iter()
                    .map(|b| (b.width * b.height / a0).ln().abs())
                    .fold(0.0f64, f64::max);
                if spread == 0.0 {
                    assert!(worst <= 0.1, "held, seed {seed}: {worst:.3}");
                } else {
                    assert!(worst > 1.0, "walking, seed {seed}: {worst:.3}");
                }
            }
        }
    }
}
