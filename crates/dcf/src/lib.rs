//! Discriminative correlation filters for visual tracking.
//!
//! The kernels of the classical correlation-filter trackers, each a
//! module of its own, and the [`Dcf`] and [`Staple`] models that the
//! trackers of `bayestrack-trackers` drive:
//!
//! - [`fft`]: cached real 2-D FFT plans (`realfft` rows, `rustfft`
//!   columns) and 2,3,5-smooth sizes;
//! - [`features`]: Felzenszwalb's HOG as in Dollár's toolbox (31
//!   channels, 4-pixel cells) and a gray channel;
//! - [`kcf`]: cosine window, Gaussian labels, linear and Gaussian kernel
//!   correlation, KCF's closed-form training and detection (Henriques et
//!   al. 2015);
//! - [`scale`]: DSST's 1-D scale filter (Danelljan et al. 2014);
//! - [`confidence`]: PSR (Bolme et al. 2010) and APCE with LMCF's update
//!   gate (Wang et al. 2017);
//! - [`colour`]: Staple's colour-histogram model and its merge with the
//!   correlation response (Bertinetto et al. 2016).
//!
//! Everything is `f32`, deterministic (no randomness, no threads: the same
//! bits for a given input and build) and allocation-free per frame once a
//! model is initialised.

pub mod colour;
pub mod confidence;
mod error;
pub mod features;
pub mod fft;
pub mod kcf;
pub mod sample;
pub mod scale;
mod tracker;

pub use error::{DcfError, Result};
pub use tracker::{
    ColourMerge, Dcf, DcfConfig, Padding, Response, SharedFeatures, SharedGrid, Staple,
    StapleConfig, Step,
};
