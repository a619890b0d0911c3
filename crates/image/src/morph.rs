//! Binary morphology with square structuring elements.
//!
//! Erosion and dilation by a `(2r+1) x (2r+1)` square are separable: a
//! horizontal pass then a vertical pass, each a running count, so the cost
//! does not grow with `r`. Pixels outside the image have no effect (they
//! neither erode nor dilate), as with OpenCV's default border.

use crate::{ImageView, Mask, Result};

#[derive(Clone, Copy)]
enum Op {
    Erode,
    Dilate,
}

/// One 1-D pass over `len` samples read by `get` and written by `set`.
/// For erosion a pixel stays set if all in-range neighbours are set; for
/// dilation it becomes set if any in-range neighbour is set.
fn pass_1d(
    len: usize,
    r: usize,
    op: Op,
    get: impl Fn(usize) -> bool,
    mut set: impl FnMut(usize, bool),
) {
    // Count set pixels in the window [i - r, i + r] clipped to [0, len).
    // A radius of `len` or more covers the whole line, as `len` does (and
    // `i + r` cannot overflow).
    let r = r.min(len);
    let mut count = 0usize;
    for j in 0..r.min(len) {
        count += usize::from(get(j));
    }
    for i in 0..len {
        if i + r < len {
            count += usize::from(get(i + r));
        }
        if i > r {
            count -= usize::from(get(i - r - 1));
        }
        let lo = i.saturating_sub(r);
        let hi = (i + r).min(len - 1);
        let n = hi - lo + 1;
        set(
            i,
            match op {
                Op::Erode => count == n,
                Op::Dilate => count > 0,
            },
        );
    }
}

fn morph(src: ImageView<'_, bool>, r: usize, op: Op) -> Result<Mask> {
    src.expect_channels("morphology", 1)?;
    let (w, h) = (src.width(), src.height());
    let mut tmp = Mask::new(w, h, 1, false)?;
    for y in 0..h {
        let row = src.row(y);
        let out = tmp.row_mut(y);
        pass_1d(w, r, op, |i| row[i], |i, v| out[i] = v);
    }
    let mut out = Mask::new(w, h, 1, false)?;
    let t = tmp.as_slice();
    let o = out.as_mut_slice();
    for x in 0..w {
        pass_1d(h, r, op, |j| t[j * w + x], |j, v| o[j * w + x] = v);
    }
    Ok(out)
}

/// Erosion by a `(2r+1)`-square.
///
/// # Errors
/// [`ImageError::Channels`](crate::ImageError::Channels) unless the mask has 1 channel.
pub fn erode(src: ImageView<'_, bool>, radius: usize) -> Result<Mask> {
    morph(src, radius, Op::Erode)
}

/// Dilation by a `(2r+1)`-square.
///
/// # Errors
/// [`ImageError::Channels`](crate::ImageError::Channels) unless the mask has 1 channel.
pub fn dilate(src: ImageView<'_, bool>, radius: usize) -> Result<Mask> {
    morph(src, radius, Op::Dilate)
}

/// Opening (erode, then dilate): removes specks smaller than the square.
///
/// # Errors
/// [`ImageError::Channels`](crate::ImageError::Channels) unless the mask has 1 channel.
pub fn open(src: ImageView<'_, bool>, radius: usize) -> Result<Mask> {
    let e = erode(src, radius)?;
    dilate(e.view(), radius)
}

/// Closing (dilate, then erode): fills holes smaller than the square.
///
/// # Errors
/// [`ImageError::Channels`](crate::ImageError::Channels) unless the mask has 1 channel.
pub fn close(src: ImageView<'_, bool>, radius: usize) -> Result<Mask> {
    let d = dilate(src, radius)?;
    erode(d.view(), radius)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Image;

    fn mask(rows: &[&str]) -> Mask {
        let h = rows.len();
        let w = rows[0].len();
        Image::from_fn(w, h, |x, y| rows[y].as_bytes()[x] == b'#').unwrap()
    }

    fn show(m: &Mask) -> Vec<String> {
        (0..m.height())
            .map(|y| {
                m.row(y)
                    .iter()
                    .map(|&b| if b { '#' } else { '.' })
                    .collect()
            })
            .collect()
    }

    /// Brute-force reference with the same border convention.
    fn reference(m: &Mask, r: usize, erode: bool) -> Mask {
        let (w, h) = (m.width(), m.height());
        Image::from_fn(w, h, |x, y| {
            let mut all = true;
            let mut any = false;
            for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                    let v = m.get(xx, yy, 0).unwrap();
                    all &= v;
                    any |= v;
                }
            }
            if erode { all } else { any }
        })
        .unwrap()
    }

    #[test]
    fn erode_and_dilate_known_masks() {
        let m = mask(&[".....", ".###.", ".###.", ".###.", "....#"]);
        assert_eq!(
            show(&erode(m.view(), 1).unwrap()),
            [".....", ".....", "..#..", ".....", "....."]
        );
        assert_eq!(
            show(&open(m.view(), 1).unwrap()),
            [".....", ".###.", ".###.", ".###.", "....."]
        );
        let d = dilate(mask(&["....", "..#.", "....", "...."]).view(), 1).unwrap();
        assert_eq!(show(&d), [".###", ".###", ".###", "...."]);
        let holed = mask(&["#####", "##.##", "#####"]);
        assert_eq!(show(&close(holed.view(), 1).unwrap()), ["#####"; 3]);
    }

    #[test]
    fn separable_passes_match_brute_force() {
        let mut next = bayestrack_testkit::ansi_c_lcg(7);
        let m = Image::from_fn(23, 17, |_, _| !(next() >> 16).is_multiple_of(3)).unwrap();
        for r in 0..4 {
            assert_eq!(
                erode(m.view(), r).unwrap(),
                reference(&m, r, true),
                "erode r={r}"
            );
            assert_eq!(
                dilate(m.view(), r).unwrap(),
                reference(&m, r, false),
                "dilate r={r}"
            );
        }
    }
}
