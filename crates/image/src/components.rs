//! Connected-component labelling of binary masks, with per-blob statistics.

use crate::{Image, ImageView, Rect, Result};

/// Which neighbours touch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Connectivity {
    /// Left, right, up, down.
    Four,
    /// The four plus the diagonals.
    #[default]
    Eight,
}

/// One connected blob of set pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    /// Its label in [`Components::labels`] (1-based; 0 is background).
    pub label: u32,
    /// Number of pixels.
    pub area: usize,
    /// Mean pixel position `(x, y)` (0-based pixel centres): the binary
    /// image moments `m10 / m00`, `m01 / m00`.
    pub centroid: (f64, f64),
    /// Tightest enclosing rectangle.
    pub bbox: Rect,
}

/// The result of [`label_components`].
#[derive(Clone, Debug)]
pub struct Components {
    /// Label per pixel: 0 for background, `k` for the pixels of `blobs[k - 1]`.
    pub labels: Image<u32>,
    /// Blobs in raster order of their first (top-most, then left-most) pixel.
    pub blobs: Vec<Blob>,
}

impl Components {
    /// Blobs with at least `min_area` pixels, largest first.
    pub fn largest(&self, min_area: usize) -> Vec<Blob> {
        let mut v: Vec<Blob> = self
            .blobs
            .iter()
            .filter(|b| b.area >= min_area)
            .copied()
            .collect();
        v.sort_by(|a, b| b.area.cmp(&a.area).then(a.label.cmp(&b.label)));
        v
    }
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let p = parent[x as usize];
        parent[x as usize] = parent[p as usize];
        x = p;
    }
    x
}

fn union(parent: &mut [u32], a: u32, b: u32) -> u32 {
    let ra = find(parent, a);
    let rb = find(parent, b);
    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
    parent[hi as usize] = lo;
    lo
}

/// Labels the connected components of a 1-channel mask (two-pass union-find)
/// and measures each blob's area, centroid and bounding box.
///
/// # Errors
/// [`ImageError::Channels`](crate::ImageError::Channels) unless the mask has 1 channel.
pub fn label_components(
    mask: ImageView<'_, bool>,
    connectivity: Connectivity,
) -> Result<Components> {
    mask.expect_channels("label_components", 1)?;
    let (w, h) = (mask.width(), mask.height());
    let mut labels = Image::new(w, h, 1, 0u32)?;
    let mut parent: Vec<u32> = vec![0];
    {
        let lab = labels.as_mut_slice();
        for y in 0..h {
            let row = mask.row(y);
            for x in 0..w {
                if !row[x] {
                    continue;
                }
                let mut l = 0u32;
                let merge = |l: &mut u32, n: u32, parent: &mut Vec<u32>| {
                    if n != 0 {
                        *l = if *l == 0 {
                            find(parent, n)
                        } else {
                            union(parent, *l, n)
                        };
                    }
                };
                if x > 0 {
                    merge(&mut l, lab[y * w + x - 1], &mut parent);
                }
                if y > 0 {
                    let up = (y - 1) * w;
                    merge(&mut l, lab[up + x], &mut parent);
                    if connectivity == Connectivity::Eight {
                        if x > 0 {
                            merge(&mut l, lab[up + x - 1], &mut parent);
                        }
                        if x + 1 < w {
                            merge(&mut l, lab[up + x + 1], &mut parent);
                        }
                    }
                }
                if l == 0 {
                    l = parent.len() as u32;
                    parent.push(l);
                }
                lab[y * w + x] = l;
            }
        }
    }
    // Second pass: compact labels in raster order of first appearance and
    // accumulate moments.
    let mut compact = vec![0u32; parent.len()];
    let mut acc: Vec<(usize, f64, f64, usize, usize, usize, usize)> = Vec::new();
    let lab = labels.as_mut_slice();
    for y in 0..h {
        for x in 0..w {
            let l = lab[y * w + x];
            if l == 0 {
                continue;
            }
            let root = find(&mut parent, l) as usize;
            if compact[root] == 0 {
                acc.push((0, 0.0, 0.0, x, y, x, y));
                compact[root] = acc.len() as u32;
            }
            let k = compact[root];
            lab[y * w + x] = k;
            let a = &mut acc[k as usize - 1];
            a.0 += 1;
            a.1 += x as f64;
            a.2 += y as f64;
            a.3 = a.3.min(x);
            a.4 = a.4.min(y);
            a.5 = a.5.max(x);
            a.6 = a.6.max(y);
        }
    }
    let blobs = acc
        .iter()
        .enumerate()
        .map(|(i, &(n, sx, sy, x0, y0, x1, y1))| Blob {
            label: i as u32 + 1,
            area: n,
            centroid: (sx / n as f64, sy / n as f64),
            bbox: Rect::new(x0, y0, x1 - x0 + 1, y1 - y0 + 1),
        })
        .collect();
    Ok(Components { labels, blobs })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(rows: &[&str]) -> Image<bool> {
        Image::from_fn(rows[0].len(), rows.len(), |x, y| {
            rows[y].as_bytes()[x] == b'#'
        })
        .unwrap()
    }

    #[test]
    fn known_mask_eight_and_four() {
        let m = mask(&[
            "##....#", //
            "##...#.", //
            "......#", //
            ".###...", //
            ".#.#..#",
        ]);
        let c = label_components(m.view(), Connectivity::Eight).unwrap();
        assert_eq!(c.blobs.len(), 4);
        let b = c.blobs[0];
        assert_eq!(
            (b.area, b.centroid, b.bbox),
            (4, (0.5, 0.5), Rect::new(0, 0, 2, 2))
        );
        let diag = c.blobs[1];
        assert_eq!(diag.area, 3);
        assert_eq!(diag.bbox, Rect::new(5, 0, 2, 3));
        assert!((diag.centroid.0 - 17.0 / 3.0).abs() < 1e-12);
        assert_eq!(diag.centroid.1, 1.0);
        let u = c.blobs[2];
        assert_eq!((u.area, u.bbox), (5, Rect::new(1, 3, 3, 2)));
        assert_eq!(u.centroid, (2.0, 3.4));
        assert_eq!(c.blobs[3].area, 1);
        assert_eq!(c.labels.get(6, 4, 0), Some(4));
        assert_eq!(c.labels.get(2, 4, 0), Some(0));
        // With 4-connectivity the diagonal chain splits into three.
        let c4 = label_components(m.view(), Connectivity::Four).unwrap();
        assert_eq!(c4.blobs.len(), 6);
        assert_eq!(
            c.largest(2).iter().map(|b| b.area).collect::<Vec<_>>(),
            [5, 4, 3]
        );
    }

    #[test]
    fn u_shape_merges_late() {
        // Two arms that only meet at the bottom: needs the union step.
        let m = mask(&["#.#.#", "#.#.#", "#####"]);
        let c = label_components(m.view(), Connectivity::Four).unwrap();
        assert_eq!(c.blobs.len(), 1);
        assert_eq!(c.blobs[0].area, 11);
        assert!(c.labels.as_slice().iter().all(|&l| l <= 1));
        let empty = Image::new(3, 3, 1, false).unwrap();
        assert!(
            label_components(empty.view(), Connectivity::Eight)
                .unwrap()
                .blobs
                .is_empty()
        );
    }
}
