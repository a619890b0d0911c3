//! The one error type of this crate.

use bayestrack_image::{ImageError, Rect};

/// Everything that can go wrong in `bayestrack-appearance`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AppearanceError {
    /// An error from `bayestrack-image` (bad geometry, channels, warp outside, ...).
    #[error(transparent)]
    Image(#[from] ImageError),
    /// A window that is not inside the frame.
    #[error("{operation}: window {window} is not inside the {width}x{height} frame")]
    WindowOutside {
        /// The operation that was given the window.
        operation: &'static str,
        /// The window (0-based pixels).
        window: Rect,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// A template larger than the region it must be searched in.
    #[error(
        "template {template_width}x{template_height} is larger than the search region {region}"
    )]
    TemplateLargerThanRegion {
        /// Template width.
        template_width: usize,
        /// Template height.
        template_height: usize,
        /// The search region.
        region: Rect,
    },
    /// A window whose size differs from the model's (template or patch).
    #[error(
        "{operation}: window is {got_width}x{got_height}, the model needs {want_width}x{want_height}"
    )]
    WindowSize {
        /// The operation.
        operation: &'static str,
        /// Window width given.
        got_width: usize,
        /// Window height given.
        got_height: usize,
        /// Width needed.
        want_width: usize,
        /// Height needed.
        want_height: usize,
    },
    /// A parameter out of its domain (sigma <= 0, zero bins, ...).
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value, printed.
        value: String,
        /// The valid domain.
        reason: &'static str,
    },
    /// A NaN or infinite input.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// What held the value.
        what: &'static str,
    },
    /// The [`Frame`](crate::Frame) lacks a plane a cue needs.
    #[error("cue {cue} needs the {plane} plane of the frame, which was not provided")]
    MissingPlane {
        /// The cue.
        cue: &'static str,
        /// The missing plane (`gray`, `rgb`, `hsv`, `ifd`).
        plane: &'static str,
    },
    /// Two histograms or models that cannot be compared.
    #[error("{operation}: incompatible operands ({detail})")]
    Incompatible {
        /// The operation.
        operation: &'static str,
        /// What differs.
        detail: String,
    },
    /// A template with no texture (constant), which normalised
    /// cross-correlation cannot match.
    #[error("the {width}x{height} template is flat (no texture to correlate)")]
    FlatTemplate {
        /// Template width.
        width: usize,
        /// Template height.
        height: usize,
    },
    /// Not enough samples to learn a distribution.
    #[error("{what}: need at least {needed} samples, got {got}")]
    TooFewSamples {
        /// What was being learnt.
        what: &'static str,
        /// Samples needed.
        needed: usize,
        /// Samples given.
        got: usize,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = AppearanceError> = std::result::Result<T, E>;

pub(crate) fn check_window(
    operation: &'static str,
    window: Rect,
    width: usize,
    height: usize,
) -> Result<()> {
    if window.fits_in(width, height) {
        Ok(())
    } else {
        Err(AppearanceError::WindowOutside {
            operation,
            window,
            width,
            height,
        })
    }
}

/// The smallest spread a Gaussian-shaped likelihood `-d / (2 sigma^2)`
/// accepts: below it `2 sigma^2` underflows, and a distance of 0 scored NaN
/// (0 / 0) and any other `-inf`, with `Ok`.
pub(crate) const MIN_SIGMA: f64 = 1e-100;

/// The smallest spread of a likelihood computed in `f32` (the skin model).
pub(crate) const MIN_SIGMA_F32: f64 = 1e-15;

/// A likelihood spread: finite and at least [`MIN_SIGMA`].
pub(crate) fn spread(name: &'static str, v: f64) -> Result<f64> {
    spread_at_least(name, v, MIN_SIGMA)
}

/// A likelihood spread: finite and at least `min`.
pub(crate) fn spread_at_least(name: &'static str, v: f64, min: f64) -> Result<f64> {
    if v.is_finite() && v >= min {
        Ok(v)
    } else {
        Err(AppearanceError::InvalidParameter {
            name,
            value: v.to_string(),
            reason: "must be finite and large enough that its square does not underflow (1e-100; 1e-15 in f32)",
        })
    }
}

pub(crate) fn positive(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(AppearanceError::InvalidParameter {
            name,
            value: v.to_string(),
            reason: "must be finite and > 0",
        })
    }
}
