#![doc = include_str!("../README.md")]

mod color;
mod core;
mod error;
mod warp;

pub use crate::color::{
    Hsv, LUMA_WEIGHTS, Rgb, gray_to_rgb, hsv_to_rgb, hue_distance, rgb_to_gray, rgb_to_gray_into,
    rgb_to_hsv, rgb_to_hsv_into, to_gray_unit, to_gray_unit_into,
};
pub use crate::core::{Image, ImageView, ImageViewMut, Pixel, Rect};
pub use crate::error::{ImageError, Result};
pub use crate::warp::{Affine2, Border, sample_bilinear, sample_bilinear_border, warp, warp_into};

/// Patch side used by paper 002 (36x36 patches).
pub const PATCH_SIDE_002: usize = 36;
