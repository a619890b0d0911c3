#![doc = include_str!("../README.md")]

mod cue;
mod error;
mod histogram;
mod ifd;
mod kernel_histogram;
mod mad;
mod moments;
mod ncc_search;
mod similarity;
mod skin;

pub use crate::cue::{
    Candidate, Cue, DEFAULT_FLOOR, Frame, Fusion, FusionRule, HistogramCue, IfdCue, MadCue,
    Scratch, SimilarityCue, SkinCue,
};
pub use crate::error::{AppearanceError, Result};
pub use crate::histogram::{HistogramDistance, HistogramMatch, RgbHistogram, histogram_search};
pub use crate::ifd::{PriorityIfd, Suppression, interframe_difference, interframe_difference_into};
pub use crate::kernel_histogram::{BinMap, HsvBinning, KernelHistogram};
pub use crate::mad::{
    MadLikelihood, MadMatch, MadPixel, MadSearch, SAD_CHUNK, mad, mad_map_into, mad_search,
};
pub use crate::moments::{Moments, centroid_in, moments};
pub use crate::ncc_search::{NccMatch, NccSearch, NccTemplate};
pub use crate::similarity::{OnlineGaussian, TargetModel, ncc};
pub use crate::skin::SkinModel;
