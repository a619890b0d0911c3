//! OTB boxes and drawing them on frames.

use crate::{ImageError, ImageViewMut, Rect, Result, Rgb};

/// An axis-aligned box: the one box type of the workspace (trackers'
/// estimates, ground truth, metrics, drawing, affine poses' bounding boxes).
///
/// The numbers are OTB's: 1-based top-left corner `(x, y)` plus width and
/// height, in (possibly fractional) pixels; pixel `(i, j)` (1-based) covers
/// `[i, i + 1) x [j, j + 1)`. Code that works in 0-based pixel-centre
/// coordinates (warps, affine poses: pixel `i` 0-based has its centre at
/// `i` and covers `[i - 0.5, i + 0.5)`) converts with [`BBox::from_edges`]
/// and [`BBox::edges`]; integer pixel regions are [`Rect`]s.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct BBox {
    /// 1-based left edge.
    pub x: f64,
    /// 1-based top edge.
    pub y: f64,
    /// Width.
    pub width: f64,
    /// Height.
    pub height: f64,
}

/// `x,y,width,height`, the numbers of an OTB ground-truth row (and of the
/// CLI's `--init`).
impl std::fmt::Display for BBox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{},{},{}", self.x, self.y, self.width, self.height)
    }
}

impl BBox {
    /// A box from OTB numbers.
    pub const fn new(x: f64, y: f64, width: f64, height: f64) -> Self {
        Self {
            x,
            y,
            width,
            height,
        }
    }

    /// The box whose edges are at `left..right` and `top..bottom` in 0-based
    /// pixel-centre coordinates (those of [`warp_into`](crate::warp_into) and of
    /// affine poses): `x = left + 1.5`, `width = right - left`.
    pub fn from_edges(left: f64, top: f64, right: f64, bottom: f64) -> Self {
        Self::new(left + 1.5, top + 1.5, right - left, bottom - top)
    }

    /// The edges `(left, top, right, bottom)` in 0-based pixel-centre
    /// coordinates (inverse of [`BBox::from_edges`]).
    pub fn edges(&self) -> (f64, f64, f64, f64) {
        let (left, top) = (self.x - 1.5, self.y - 1.5);
        (left, top, left + self.width, top + self.height)
    }

    /// Centre in OTB convention: `(x + (w - 1) / 2, y + (h - 1) / 2)`, 1-based.
    pub fn center(&self) -> (f64, f64) {
        (
            self.x + (self.width - 1.0) / 2.0,
            self.y + (self.height - 1.0) / 2.0,
        )
    }

    /// Whether every number is finite and the size non-negative.
    pub fn is_valid(&self) -> bool {
        [self.x, self.y, self.width, self.height]
            .iter()
            .all(|v| v.is_finite())
            && self.width >= 0.0
            && self.height >= 0.0
    }

    /// The 0-based pixel rectangle covered by the box (rounded to whole
    /// pixels), clipped to a `width x height` frame; `None` if nothing of it
    /// is inside or the box is invalid.
    pub fn to_rect(&self, width: usize, height: usize) -> Option<Rect> {
        if !self.is_valid() {
            return None;
        }
        let x0 = (self.x - 1.0).round().max(0.0);
        let y0 = (self.y - 1.0).round().max(0.0);
        let x1 = (self.x - 1.0 + self.width).round().min(width as f64);
        let y1 = (self.y - 1.0 + self.height).round().min(height as f64);
        (x1 > x0 && y1 > y0).then(|| {
            Rect::new(
                x0 as usize,
                y0 as usize,
                (x1 - x0) as usize,
                (y1 - y0) as usize,
            )
        })
    }

    /// The OTB box of a 0-based pixel rectangle.
    pub fn from_rect(r: Rect) -> Self {
        Self::new(
            r.x as f64 + 1.0,
            r.y as f64 + 1.0,
            r.width as f64,
            r.height as f64,
        )
    }
}

/// Draws the outline of an OTB box, `thickness` pixels wide inwards,
/// clipped to the frame (a box fully outside draws nothing). On a
/// 1-channel image the colour's luma is used.
///
/// # Errors
/// [`ImageError::Channels`] unless the image has 1 or 3 channels.
pub fn draw_box(
    img: &mut ImageViewMut<'_, u8>,
    bbox: &BBox,
    color: Rgb,
    thickness: usize,
) -> Result<()> {
    let value: &[u8] = match img.channels() {
        3 => &color.to_array(),
        1 => &[color.luma()],
        got => {
            return Err(ImageError::Channels {
                operation: "draw_box",
                expected: 3,
                got,
            });
        }
    };
    let value = value.to_vec();
    let Some(r) = bbox.to_rect(img.width(), img.height()) else {
        return Ok(());
    };
    let t = thickness.max(1);
    let mut put = |x: usize, y: usize| {
        for (c, &v) in value.iter().enumerate() {
            img.set(x, y, c, v);
        }
    };
    for y in r.y..r.bottom() {
        for x in r.x..r.right() {
            let edge = x < r.x + t || x + t >= r.right() || y < r.y + t || y + t >= r.bottom();
            if edge {
                put(x, y);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Image;

    #[test]
    fn boxes_and_rects() {
        let b = BBox::new(2.0, 3.0, 4.0, 2.0);
        assert_eq!(b.center(), (3.5, 3.5));
        // 0-based pixel-centre edges: the centre of the box is at
        // center() - 1 there
        assert_eq!(b.edges(), (0.5, 1.5, 4.5, 3.5));
        assert_eq!(BBox::from_edges(0.5, 1.5, 4.5, 3.5), b);
        let (l, t, r, bt) = b.edges();
        assert_eq!(((l + r) / 2.0 + 1.0, (t + bt) / 2.0 + 1.0), b.center());
        assert_eq!(b.to_rect(100, 100), Some(Rect::new(1, 2, 4, 2)));
        assert_eq!(BBox::from_rect(Rect::new(1, 2, 4, 2)), b);
        assert_eq!(b.to_rect(3, 100), Some(Rect::new(1, 2, 2, 2)));
        assert_eq!(BBox::new(200.0, 3.0, 4.0, 2.0).to_rect(100, 100), None);
        assert_eq!(BBox::new(f64::NAN, 3.0, 4.0, 2.0).to_rect(100, 100), None);
    }

    #[test]
    fn draw_outline() {
        let mut img = Image::new(6, 5, 3, 0u8).unwrap();
        draw_box(
            &mut img.view_mut(),
            &BBox::new(2.0, 2.0, 4.0, 3.0),
            Rgb::new(255, 0, 0),
            1,
        )
        .unwrap();
        let red: Vec<bool> = (0..5)
            .flat_map(|y| (0..6).map(move |x| (x, y)))
            .map(|(x, y)| img.get(x, y, 0) == Some(255))
            .collect();
        let want = [
            "......", //
            ".####.", //
            ".#..#.", //
            ".####.", //
            "......",
        ];
        let want: Vec<bool> = want
            .iter()
            .flat_map(|r| r.bytes().map(|b| b == b'#'))
            .collect();
        assert_eq!(red, want);
        let mut gray = Image::new(6, 5, 1, 0u8).unwrap();
        draw_box(
            &mut gray.view_mut(),
            &BBox::new(1.0, 1.0, 2.0, 2.0),
            Rgb::new(255, 255, 255),
            3,
        )
        .unwrap();
        assert_eq!(gray.get(1, 1, 0), Some(255));
        let mut two = Image::new(2, 2, 2, 0u8).unwrap();
        assert!(
            draw_box(
                &mut two.view_mut(),
                &BBox::new(1.0, 1.0, 1.0, 1.0),
                Rgb::default(),
                1
            )
            .is_err()
        );
    }
}
