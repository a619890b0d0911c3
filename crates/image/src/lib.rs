#![doc = include_str!("../README.md")]

mod color;
mod components;
mod core;
mod draw;
mod error;
mod integral;
#[cfg(feature = "io")]
mod io;
mod morph;
mod ops;
mod sad;
pub mod simd;
mod warp;
mod warp_simd;

pub use crate::color::{
    Hsv, LUMA_WEIGHTS, Rgb, gray_level, gray_to_rgb, hsv_to_rgb, hue_distance, rgb_to_gray,
    rgb_to_gray_into, rgb_to_hsv, rgb_to_hsv_into, to_gray_unit, to_gray_unit_into,
};
pub use crate::components::{Blob, Components, Connectivity, label_components};
pub use crate::core::{Image, ImageView, ImageViewMut, Pixel, Rect};
pub use crate::draw::{BBox, draw_box};
pub use crate::error::{ImageError, Result};
pub use crate::integral::{AreaSampler, IntegralImage, gray_region_into};
#[cfg(feature = "io")]
pub use crate::io::{
    FramePool, decode_frame, list_frames, read_frame, read_frame_gray, read_frame_rgb,
    write_frame_with_boxes, write_png,
};
pub use crate::morph::{close, dilate, erode, open};
pub use crate::ops::{Mask, abs_diff, abs_diff_into, motion_mask, threshold, threshold_into};
pub use crate::sad::{SadTemplate, sad_u8, sad_u8_at};
pub use crate::simd::SimdLevel;
pub use crate::warp::{Affine2, Border, sample_bilinear, sample_bilinear_border, warp, warp_into};

/// Patch side used by paper 002 (36x36 patches).
pub const PATCH_SIDE_002: usize = 36;
