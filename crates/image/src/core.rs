//! `Image<T>`, borrowed views, rectangles and the [`Pixel`] trait.

use std::fmt;

use crate::{ImageError, Result};

/// A scalar channel value: `u8`, `u16` or `f32`.
///
/// `FULL_SCALE` is the nominal white level (255 for `u8`, 65535 for `u16`,
/// 1.0 for `f32`); it lets code written for one scalar work on another.
pub trait Pixel: Copy + Default + PartialOrd + Send + Sync + fmt::Debug + 'static {
    /// Nominal white level.
    const FULL_SCALE: f32;
    /// The value as `f32`, in the scalar's own units.
    fn to_f32(self) -> f32;
    /// From `f32`, rounding and saturating for integer types.
    fn from_f32(v: f32) -> Self;
    /// `|self - other|` without overflow.
    fn abs_diff(self, other: Self) -> Self;
}

impl Pixel for u8 {
    const FULL_SCALE: f32 = 255.0;
    #[inline]
    fn to_f32(self) -> f32 {
        f32::from(self)
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        // `as` saturates and maps NaN to 0.
        v.round() as u8
    }
    #[inline]
    fn abs_diff(self, other: Self) -> Self {
        u8::abs_diff(self, other)
    }
}

impl Pixel for u16 {
    const FULL_SCALE: f32 = 65535.0;
    #[inline]
    fn to_f32(self) -> f32 {
        f32::from(self)
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        v.round() as u16
    }
    #[inline]
    fn abs_diff(self, other: Self) -> Self {
        u16::abs_diff(self, other)
    }
}

impl Pixel for f32 {
    const FULL_SCALE: f32 = 1.0;
    #[inline]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline]
    fn from_f32(v: f32) -> Self {
        v
    }
    #[inline]
    fn abs_diff(self, other: Self) -> Self {
        (self - other).abs()
    }
}

/// An axis-aligned pixel rectangle, 0-based, `x..x + width` by `y..y + height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Rect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

impl Rect {
    /// A rectangle from its top-left corner and size.
    pub const fn new(x: usize, y: usize, width: usize, height: usize) -> Self {
        Self {
            x,
            y,
            width,
            height,
        }
    }

    /// One past the right-most column (`usize::MAX` when that overflows:
    /// such a rectangle fits in no frame).
    pub const fn right(&self) -> usize {
        self.x.saturating_add(self.width)
    }

    /// One past the bottom row (`usize::MAX` when that overflows).
    pub const fn bottom(&self) -> usize {
        self.y.saturating_add(self.height)
    }

    /// Number of pixels (`usize::MAX` when that overflows).
    pub const fn area(&self) -> usize {
        self.width.saturating_mul(self.height)
    }

    /// Whether the rectangle is non-empty and lies inside a `width x height` frame.
    pub fn fits_in(&self, width: usize, height: usize) -> bool {
        self.width > 0
            && self.height > 0
            && self.x.checked_add(self.width).is_some_and(|r| r <= width)
            && self.y.checked_add(self.height).is_some_and(|b| b <= height)
    }

    /// Centre in pixel coordinates (pixel centres at integers).
    pub fn center(&self) -> (f64, f64) {
        (
            self.x as f64 + (self.width as f64 - 1.0) / 2.0,
            self.y as f64 + (self.height as f64 - 1.0) / 2.0,
        )
    }
}

impl fmt::Display for Rect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "[x {}, y {}, {}x{}]",
            self.x, self.y, self.width, self.height
        )
    }
}

/// Checks a geometry and returns the minimal buffer length it needs.
/// [`check_geometry`] with an empty buffer: keeps its
/// [`ImageError::ZeroSize`] and drops the buffer-size error it must give
/// (the caller allocates the buffer).
fn zero_size_only(e: ImageError) -> Result<()> {
    match e {
        ImageError::ZeroSize { .. } => Err(e),
        _ => Ok(()),
    }
}

/// Element count of a packed `width x height x channels` image.
fn element_count(width: usize, height: usize, channels: usize) -> Result<usize> {
    width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or(ImageError::TooLarge {
            width,
            height,
            channels,
        })
}

/// Above this many elements a buffer is reserved fallibly first, so that
/// a size the allocator refuses is [`ImageError::TooLarge`] instead of an
/// abort; below it `vec!` keeps its zeroed-allocation fast path.
const FALLIBLE_ALLOCATION: usize = 1 << 24;

/// `len` copies of `fill`, or [`ImageError::TooLarge`] when they cannot be
/// allocated.
fn filled<T: Copy>(
    len: usize,
    fill: T,
    width: usize,
    height: usize,
    channels: usize,
) -> Result<Vec<T>> {
    if len <= FALLIBLE_ALLOCATION {
        return Ok(vec![fill; len]);
    }
    let mut data = Vec::new();
    data.try_reserve_exact(len)
        .map_err(|_| ImageError::TooLarge {
            width,
            height,
            channels,
        })?;
    data.resize(len, fill);
    Ok(data)
}

fn check_geometry(
    len: usize,
    width: usize,
    height: usize,
    channels: usize,
    stride: usize,
) -> Result<()> {
    if width == 0 || height == 0 || channels == 0 {
        return Err(ImageError::ZeroSize {
            width,
            height,
            channels,
        });
    }
    let row = width.checked_mul(channels);
    let need = row.and_then(|row| {
        stride
            .checked_mul(height - 1)
            .and_then(|s| s.checked_add(row))
    });
    match (row, need) {
        (Some(row), Some(need)) if stride >= row && len >= need => Ok(()),
        _ => Err(ImageError::BufferSize {
            len,
            width,
            height,
            channels,
            stride,
        }),
    }
}

/// An owned, row-major image of `T` with interleaved channels.
///
/// The element at column `x`, row `y`, channel `c` is
/// `data[y * stride + x * channels + c]`. Width, height and channels are
/// never zero: constructors refuse empty images.
#[derive(Clone, PartialEq)]
pub struct Image<T> {
    data: Vec<T>,
    width: usize,
    height: usize,
    channels: usize,
    stride: usize,
}

impl<T: fmt::Debug> fmt::Debug for Image<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Image")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("channels", &self.channels)
            .field("stride", &self.stride)
            .finish_non_exhaustive()
    }
}

impl<T: Copy> Image<T> {
    /// A `width x height` image with `channels` channels, every element `fill`.
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`] if any dimension is zero;
    /// [`ImageError::TooLarge`] when `width * height * channels` overflows
    /// or cannot be allocated.
    pub fn new(width: usize, height: usize, channels: usize, fill: T) -> Result<Self> {
        let stride = width.saturating_mul(channels);
        check_geometry(0, width, height, channels, stride).or_else(zero_size_only)?;
        let len = element_count(width, height, channels)?;
        Ok(Self {
            data: filled(len, fill, width, height, channels)?,
            width,
            height,
            channels,
            stride,
        })
    }

    /// Wraps a packed buffer (stride = `width * channels`).
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`], or [`ImageError::BufferSize`] unless
    /// `data.len() == width * height * channels`.
    pub fn from_vec(width: usize, height: usize, channels: usize, data: Vec<T>) -> Result<Self> {
        let stride = width.saturating_mul(channels);
        check_geometry(data.len(), width, height, channels, stride)?;
        if data.len() != stride * height {
            return Err(ImageError::BufferSize {
                len: data.len(),
                width,
                height,
                channels,
                stride,
            });
        }
        Ok(Self {
            data,
            width,
            height,
            channels,
            stride,
        })
    }

    /// A single-channel image with `f(x, y)` at each pixel.
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`] if `width` or `height` is zero;
    /// [`ImageError::TooLarge`] when `width * height` overflows or cannot
    /// be allocated.
    pub fn from_fn(
        width: usize,
        height: usize,
        mut f: impl FnMut(usize, usize) -> T,
    ) -> Result<Self> {
        check_geometry(0, width, height, 1, width).or_else(zero_size_only)?;
        let len = element_count(width, height, 1)?;
        let mut data = Vec::new();
        data.try_reserve_exact(len)
            .map_err(|_| ImageError::TooLarge {
                width,
                height,
                channels: 1,
            })?;
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Ok(Self {
            data,
            width,
            height,
            channels: 1,
            stride: width,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Row stride in elements (`width * channels` for owned images).
    pub fn stride(&self) -> usize {
        self.stride
    }
    /// The whole buffer, row-major.
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }
    /// The whole buffer, mutable.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }
    /// The buffer, consuming the image.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }
    /// Sets every element to `value`.
    pub fn fill(&mut self, value: T) {
        self.data.fill(value);
    }

    /// Borrowed view of the whole image.
    pub fn view(&self) -> ImageView<'_, T> {
        ImageView {
            data: &self.data,
            width: self.width,
            height: self.height,
            channels: self.channels,
            stride: self.stride,
        }
    }

    /// Mutable view of the whole image.
    pub fn view_mut(&mut self) -> ImageViewMut<'_, T> {
        ImageViewMut {
            data: &mut self.data,
            width: self.width,
            height: self.height,
            channels: self.channels,
            stride: self.stride,
        }
    }

    /// Borrowed view of `rect`.
    ///
    /// # Errors
    /// [`ImageError::WindowOutside`] unless `rect` is non-empty and inside.
    pub fn crop(&self, rect: Rect) -> Result<ImageView<'_, T>> {
        self.view().crop(rect)
    }

    /// Elements of row `y` (`width * channels` of them).
    ///
    /// # Panics
    /// If `y >= height`.
    pub fn row(&self, y: usize) -> &[T] {
        let s = y * self.stride;
        &self.data[s..s + self.width * self.channels]
    }

    /// Mutable elements of row `y`.
    ///
    /// # Panics
    /// If `y >= height`.
    pub fn row_mut(&mut self, y: usize) -> &mut [T] {
        let s = y * self.stride;
        let n = self.width * self.channels;
        &mut self.data[s..s + n]
    }

    /// Channel values of pixel `(x, y)`, or `None` outside.
    pub fn pixel(&self, x: usize, y: usize) -> Option<&[T]> {
        self.view().pixel(x, y)
    }

    /// Channel `c` of pixel `(x, y)`, or `None` outside.
    pub fn get(&self, x: usize, y: usize, c: usize) -> Option<T> {
        self.view().get(x, y, c)
    }

    /// Sets channel `c` of pixel `(x, y)`.
    ///
    /// # Panics
    /// If the pixel or channel is out of range.
    pub fn set(&mut self, x: usize, y: usize, c: usize, value: T) {
        assert!(x < self.width && y < self.height && c < self.channels);
        self.data[y * self.stride + x * self.channels + c] = value;
    }

    /// Changes the geometry, reusing the allocation. If the geometry changes,
    /// every element becomes `fill`; if not, the contents are kept. Either
    /// way, treat the contents as unspecified.
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`] if any dimension is zero;
    /// [`ImageError::TooLarge`] when the new size overflows or cannot be
    /// allocated (the image is then unchanged).
    pub fn reshape(&mut self, width: usize, height: usize, channels: usize, fill: T) -> Result<()> {
        check_geometry(0, width, height, channels, width.saturating_mul(channels))
            .or_else(zero_size_only)?;
        let len = element_count(width, height, channels)?;
        if self.width != width || self.height != height || self.channels != channels {
            if len > self.data.len() {
                self.data
                    .try_reserve_exact(len - self.data.len())
                    .map_err(|_| ImageError::TooLarge {
                        width,
                        height,
                        channels,
                    })?;
            }
            self.data.clear();
            self.data.resize(len, fill);
            self.width = width;
            self.height = height;
            self.channels = channels;
            self.stride = width * channels;
        }
        Ok(())
    }

    /// Maps every element through `f`, keeping the geometry.
    pub fn map<U: Copy>(&self, f: impl FnMut(T) -> U) -> Image<U> {
        self.view().map(f)
    }
}

impl Image<u8> {
    /// Converts to `f32` in `[0, 1]` (value / 255).
    pub fn to_unit_f32(&self) -> Image<f32> {
        self.map(|v| f32::from(v) / 255.0)
    }
}

/// A borrowed, possibly strided, read-only view into an image.
#[derive(Clone, Copy)]
pub struct ImageView<'a, T> {
    data: &'a [T],
    width: usize,
    height: usize,
    channels: usize,
    stride: usize,
}

impl<T> fmt::Debug for ImageView<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ImageView")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("channels", &self.channels)
            .field("stride", &self.stride)
            .finish_non_exhaustive()
    }
}

impl<'a, T: Copy> ImageView<'a, T> {
    /// Wraps a borrowed buffer with a given stride (in elements).
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`] or [`ImageError::BufferSize`].
    pub fn from_slice(
        data: &'a [T],
        width: usize,
        height: usize,
        channels: usize,
        stride: usize,
    ) -> Result<Self> {
        check_geometry(data.len(), width, height, channels, stride)?;
        Ok(Self {
            data,
            width,
            height,
            channels,
            stride,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Row stride in elements.
    pub fn stride(&self) -> usize {
        self.stride
    }
    /// The underlying buffer, starting at the first element of the view.
    pub fn as_slice(&self) -> &'a [T] {
        self.data
    }

    /// Elements of row `y`.
    ///
    /// # Panics
    /// If `y >= height`.
    #[inline]
    pub fn row(&self, y: usize) -> &'a [T] {
        let s = y * self.stride;
        &self.data[s..s + self.width * self.channels]
    }

    /// Channel values of pixel `(x, y)`, or `None` outside.
    pub fn pixel(&self, x: usize, y: usize) -> Option<&'a [T]> {
        (x < self.width && y < self.height).then(|| {
            let s = y * self.stride + x * self.channels;
            &self.data[s..s + self.channels]
        })
    }

    /// Channel `c` of pixel `(x, y)`, or `None` outside.
    #[inline]
    pub fn get(&self, x: usize, y: usize, c: usize) -> Option<T> {
        (x < self.width && y < self.height && c < self.channels)
            .then(|| self.data[y * self.stride + x * self.channels + c])
    }

    /// The sub-view `rect` (no copy).
    ///
    /// # Errors
    /// [`ImageError::WindowOutside`] unless `rect` is non-empty and inside the view.
    pub fn crop(&self, rect: Rect) -> Result<ImageView<'a, T>> {
        if !rect.fits_in(self.width, self.height) {
            return Err(ImageError::WindowOutside {
                window: rect,
                width: self.width,
                height: self.height,
            });
        }
        let start = rect.y * self.stride + rect.x * self.channels;
        let end = (rect.bottom() - 1) * self.stride + rect.right() * self.channels;
        Ok(ImageView {
            data: &self.data[start..end],
            width: rect.width,
            height: rect.height,
            channels: self.channels,
            stride: self.stride,
        })
    }

    /// Whether two views have the same width, height and channels.
    pub fn same_shape<U>(&self, other: &ImageView<'_, U>) -> bool {
        self.width == other.width && self.height == other.height && self.channels == other.channels
    }

    /// Copies the view into a packed owned image.
    pub fn to_image(&self) -> Image<T> {
        self.map(|v| v)
    }

    /// Maps every element through `f` into a packed owned image.
    pub fn map<U: Copy>(&self, mut f: impl FnMut(T) -> U) -> Image<U> {
        let mut data = Vec::with_capacity(self.width * self.height * self.channels);
        for y in 0..self.height {
            data.extend(self.row(y).iter().map(|&v| f(v)));
        }
        Image {
            data,
            width: self.width,
            height: self.height,
            channels: self.channels,
            stride: self.width * self.channels,
        }
    }

    /// Fails with [`ImageError::Channels`] unless the view has `expected` channels.
    ///
    /// # Errors
    /// As described.
    pub fn expect_channels(&self, operation: &'static str, expected: usize) -> Result<()> {
        if self.channels == expected {
            Ok(())
        } else {
            Err(ImageError::Channels {
                operation,
                expected,
                got: self.channels,
            })
        }
    }

    /// Fails with [`ImageError::SizeMismatch`] unless `other` has the same shape.
    ///
    /// # Errors
    /// As described.
    pub fn expect_same_shape<U>(
        &self,
        operation: &'static str,
        other: &ImageView<'_, U>,
    ) -> Result<()> {
        if self.same_shape(other) {
            Ok(())
        } else {
            Err(ImageError::SizeMismatch {
                operation,
                a_width: self.width,
                a_height: self.height,
                a_channels: self.channels,
                b_width: other.width,
                b_height: other.height,
                b_channels: other.channels,
            })
        }
    }
}

/// A borrowed, possibly strided, mutable view into an image.
pub struct ImageViewMut<'a, T> {
    data: &'a mut [T],
    width: usize,
    height: usize,
    channels: usize,
    stride: usize,
}

impl<T> fmt::Debug for ImageViewMut<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ImageViewMut")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("channels", &self.channels)
            .field("stride", &self.stride)
            .finish_non_exhaustive()
    }
}

impl<'a, T: Copy> ImageViewMut<'a, T> {
    /// Wraps a mutable buffer, for example a fixed `[f32; 36 * 36]` patch.
    ///
    /// # Errors
    /// [`ImageError::ZeroSize`] or [`ImageError::BufferSize`].
    pub fn from_slice(
        data: &'a mut [T],
        width: usize,
        height: usize,
        channels: usize,
        stride: usize,
    ) -> Result<Self> {
        check_geometry(data.len(), width, height, channels, stride)?;
        Ok(Self {
            data,
            width,
            height,
            channels,
            stride,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Row stride in elements.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Read-only view of the same pixels.
    pub fn as_view(&self) -> ImageView<'_, T> {
        ImageView {
            data: self.data,
            width: self.width,
            height: self.height,
            channels: self.channels,
            stride: self.stride,
        }
    }

    /// Mutable elements of row `y`.
    ///
    /// # Panics
    /// If `y >= height`.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [T] {
        let s = y * self.stride;
        let n = self.width * self.channels;
        &mut self.data[s..s + n]
    }

    /// Sets channel `c` of pixel `(x, y)`; returns `false` (and does nothing) outside.
    pub fn set(&mut self, x: usize, y: usize, c: usize, value: T) -> bool {
        if x < self.width && y < self.height && c < self.channels {
            self.data[y * self.stride + x * self.channels + c] = value;
            true
        } else {
            false
        }
    }

    /// Sets every element of the view to `value`.
    pub fn fill(&mut self, value: T) {
        for y in 0..self.height {
            self.row_mut(y).fill(value);
        }
    }

    /// The mutable sub-view `rect` (no copy).
    ///
    /// # Errors
    /// [`ImageError::WindowOutside`] unless `rect` is non-empty and inside.
    pub fn crop_mut(&mut self, rect: Rect) -> Result<ImageViewMut<'_, T>> {
        if !rect.fits_in(self.width, self.height) {
            return Err(ImageError::WindowOutside {
                window: rect,
                width: self.width,
                height: self.height,
            });
        }
        let start = rect.y * self.stride + rect.x * self.channels;
        let end = (rect.bottom() - 1) * self.stride + rect.right() * self.channels;
        Ok(ImageViewMut {
            data: &mut self.data[start..end],
            width: rect.width,
            height: rect.height,
            channels: self.channels,
            stride: self.stride,
        })
    }
}

impl<'a, T: Copy> From<&'a Image<T>> for ImageView<'a, T> {
    fn from(img: &'a Image<T>) -> Self {
        img.view()
    }
}

impl<'a, T: Copy> From<&'a mut Image<T>> for ImageViewMut<'a, T> {
    fn from(img: &'a mut Image<T>) -> Self {
        img.view_mut()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_size_is_an_error() {
        assert!(matches!(
            Image::new(0, 3, 1, 0u8),
            Err(ImageError::ZeroSize { width: 0, .. })
        ));
        assert!(matches!(
            Image::new(3, 3, 0, 0u8),
            Err(ImageError::ZeroSize { channels: 0, .. })
        ));
        assert!(Image::<u8>::from_vec(2, 2, 1, vec![0; 3]).is_err());
        assert!(Image::from_fn(0, 2, |_, _| 0u8).is_err());
    }

    #[test]
    fn crops_are_views_with_the_parent_stride() {
        let img = Image::from_fn(6, 5, |x, y| (10 * y + x) as u8).unwrap();
        let c = img.crop(Rect::new(2, 1, 3, 2)).unwrap();
        assert_eq!(c.stride(), 6);
        assert_eq!(c.row(0), &[12, 13, 14]);
        assert_eq!(c.row(1), &[22, 23, 24]);
        let cc = c.crop(Rect::new(1, 1, 2, 1)).unwrap();
        assert_eq!(cc.row(0), &[23, 24]);
        assert_eq!(cc.to_image().as_slice(), &[23, 24]);
        assert!(matches!(
            img.crop(Rect::new(4, 0, 3, 1)),
            Err(ImageError::WindowOutside { .. })
        ));
        assert!(img.crop(Rect::new(0, 0, 0, 1)).is_err());
        assert!(img.crop(Rect::new(usize::MAX, 0, 2, 1)).is_err());
    }

    #[test]
    fn mutable_crop_writes_through() {
        let mut img = Image::new(4, 4, 2, 0u8).unwrap();
        {
            let mut v = img.view_mut();
            let mut c = v.crop_mut(Rect::new(1, 2, 2, 1)).unwrap();
            c.fill(7);
        }
        assert_eq!(img.get(1, 2, 1), Some(7));
        assert_eq!(img.get(2, 2, 0), Some(7));
        assert_eq!(img.get(3, 2, 0), Some(0));
        assert_eq!(img.get(1, 1, 0), Some(0));
    }

    #[test]
    fn strided_slice_view() {
        let buf = [1u8, 2, 99, 3, 4, 99];
        let v = ImageView::from_slice(&buf, 2, 2, 1, 3).unwrap();
        assert_eq!(v.row(1), &[3, 4]);
        assert!(ImageView::from_slice(&buf, 2, 3, 1, 3).is_err());
        assert!(ImageView::from_slice(&buf, 4, 1, 1, 3).is_err());
    }
}
