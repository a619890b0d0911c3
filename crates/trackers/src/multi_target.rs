//! Dong and Chen (paper 004) sec. 4: Kalman multi-target tracking by background subtraction.
//!
//! Each frame: the foreground `|F - B| > tau` (cleaned by a morphological
//! opening and closing) is split into blobs by connected components; each
//! blob gives a measurement `z = (x, y, Lx, Ly)` (eq. 19): its centroid
//! `x = m10 / m00`, `y = m01 / m00` (eq. 14-15, with `f` the blob's
//! foreground indicator) and the size of its tracking window. Each track
//! keeps the 8-D state of eq. 18,
//!
//! `s = (x, y, x', y', Lx, Ly, Lx', Ly')`,
//!
//! with the constant-velocity transition `A` of sec. 4.2.2 (`dt = 0.04` s)
//! and the measurement matrix `C` that selects `(x, y, Lx, Ly)`: the text
//! (eq. 19) measures centroid and window size, while the `C` printed in the
//! paper selects `(x, y, x', y')`; we build the one the text describes.
//!
//! Tracks are matched to blobs by the similarity of eq. 20-22,
//! `Delta(i, j) = gamma D(i, j) + zeta A(i, j)`, between the predicted
//! track `i` and blob `j` (see [`Association`]); a pair is matched when
//! `Delta <= T_Delta`. An unmatched blob starts a track (birth); a track
//! unmatched for more than `max_missed` frames ends (death).

use bayestrack_image::{
    BBox, Connectivity, Image, ImageView, Rect, abs_diff_into, close, label_components, open,
    threshold_into,
};
use bayestrack_kalman::{Gaussian, Kf, LinearDynamics, LinearMeasurement};
use nalgebra::{SMatrix, SVector, Vector4};

use crate::error::{Result, TrackerError};
use crate::shell::{ChannelPolicy, Needs, PlaneBuffers};

/// The name in error messages.
const NAME: &str = "multi-target";

/// Centroid and window size of a target: the measurement of eq. 19 and
/// what eq. 20-21 compare.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feature {
    /// Centroid `(x, y)`, 0-based pixel coordinates.
    pub centroid: (f64, f64),
    /// Window size `(Lx, Ly)` in pixels.
    pub size: (f64, f64),
}

impl Feature {
    /// Window area `Lx Ly`.
    pub fn area(&self) -> f64 {
        self.size.0 * self.size.1
    }

    fn distance(&self, other: &Feature) -> f64 {
        (self.centroid.0 - other.centroid.0).hypot(self.centroid.1 - other.centroid.1)
    }
}

/// A foreground blob of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Its centroid (eq. 14-15) and tracking-window size.
    pub feature: Feature,
    /// The tracking window: the tightest rectangle around the blob (0-based).
    pub window: Rect,
    /// Foreground pixels in the blob.
    pub area: usize,
}

/// The matching rule of eq. 20-22.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Association {
    /// `gamma`, the weight of the centroid distance (0.7).
    pub gamma: f64,
    /// `zeta`, the weight of the area difference (0.3).
    pub zeta: f64,
    /// `T_Delta`: pairs with `Delta` above it are not the same target (0.6).
    pub threshold: f64,
    /// Floors on the normalisers of eq. 20-21 (see [`Association::delta`]).
    pub floored: bool,
}

impl Default for Association {
    /// The paper's `gamma = 0.7`, `zeta = 0.3`, `T_Delta = 0.6`, floored
    /// normalisers.
    fn default() -> Self {
        Self {
            gamma: 0.7,
            zeta: 0.3,
            threshold: 0.6,
            floored: true,
        }
    }
}

impl Association {
    fn check(&self) -> Result<()> {
        let bad = |name, value, reason| {
            Err(TrackerError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if !(self.gamma >= 0.0
            && self.zeta >= 0.0
            && self.gamma.is_finite()
            && self.zeta.is_finite())
        {
            return bad(
                "gamma",
                self.gamma,
                "gamma and zeta must be finite and >= 0",
            );
        }
        if !self.threshold.is_finite() {
            return bad("threshold", self.threshold, "must be finite");
        }
        Ok(())
    }

    /// The similarity `Delta(i, j) = gamma D(i, j) + zeta A(i, j)` (eq. 22)
    /// of every track feature `i` with every detection feature `j`, as rows
    /// per track:
    ///
    /// - `D(i, j) = |c_i c_j| / max_* |c_i c_*|` (eq. 20),
    /// - `A(i, j) = |a_i - a_j| / max_* |a_i - a_*|` (eq. 21), `a = Lx Ly`,
    ///
    /// the maxima over the detections of the frame (`0 / 0 = 0`). As printed,
    /// a track with one candidate gets `D = A = 1` and `Delta = 1 > T_Delta`
    /// whatever the distance, so a lone target could never be followed; with
    /// `floored` the normalisers are at least the track window's diagonal
    /// (for `D`) and its area (for `A`), which changes nothing when the
    /// candidates are farther apart than that.
    pub fn delta(&self, tracks: &[Feature], detections: &[Feature]) -> Vec<Vec<f64>> {
        tracks
            .iter()
            .map(|t| {
                let dist: Vec<f64> = detections.iter().map(|d| t.distance(d)).collect();
                let area: Vec<f64> = detections
                    .iter()
                    .map(|d| (t.area() - d.area()).abs())
                    .collect();
                let mut dmax = dist.iter().copied().fold(0.0, f64::max);
                let mut amax = area.iter().copied().fold(0.0, f64::max);
                if self.floored {
                    dmax = dmax.max(t.size.0.hypot(t.size.1));
                    amax = amax.max(t.area());
                }
                let ratio = |v: f64, m: f64| if m > 0.0 { v / m } else { 0.0 };
                dist.iter()
                    .zip(&area)
                    .map(|(&d, &a)| self.gamma * ratio(d, dmax) + self.zeta * ratio(a, amax))
                    .collect()
            })
            .collect()
    }

    /// Matches tracks to detections: repeatedly the pair of smallest `Delta`
    /// among the unmatched (first track, then first detection, on ties),
    /// while it is at most the threshold. Returns `(track, detection)` pairs.
    pub fn associate(&self, tracks: &[Feature], detections: &[Feature]) -> Vec<(usize, usize)> {
        let delta = self.delta(tracks, detections);
        let mut pairs: Vec<(f64, usize, usize)> = delta
            .iter()
            .enumerate()
            .flat_map(|(i, row)| row.iter().enumerate().map(move |(j, &v)| (v, i, j)))
            .filter(|(v, _, _)| *v <= self.threshold)
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut track_used = vec![false; tracks.len()];
        let mut det_used = vec![false; detections.len()];
        let mut out = Vec::new();
        for (_, i, j) in pairs {
            if !track_used[i] && !det_used[j] {
                track_used[i] = true;
                det_used[j] = true;
                out.push((i, j));
            }
        }
        out
    }
}

/// Settings of [`MultiTargetTracker`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiTargetConfig {
    /// Sampling time in seconds (0.04: 25 fps).
    pub dt: f64,
    /// Association rule (eq. 20-22).
    pub association: Association,
    /// Foreground threshold `tau` on `|F - B|` in gray levels.
    pub foreground_threshold: u8,
    /// Radius of the opening that removes isolated foreground pixels.
    pub open_radius: usize,
    /// Radius of the closing that fills small holes in a blob.
    pub close_radius: usize,
    /// Blobs with fewer pixels are ignored.
    pub min_area: usize,
    /// A track unmatched for more frames than this ends.
    pub max_missed: usize,
    /// Spectral density of the white acceleration of the centroid,
    /// (px/s^2)^2 s.
    pub centroid_accel: f64,
    /// Spectral density of the white rate-of-change noise of the window
    /// size, (px/s^2)^2 s.
    pub size_accel: f64,
    /// Standard deviation of the centroid measurement (px).
    pub centroid_std: f64,
    /// Standard deviation of the window-size measurement (px).
    pub size_std: f64,
    /// Prior standard deviation of a new track's velocities (px/s).
    pub velocity_std: f64,
}

impl Default for MultiTargetConfig {
    /// `dt = 0.04`, the paper's association, `tau = 20`, opening radius 1,
    /// closing radius 2, blobs of at least 100 pixels, death after 5 missed
    /// frames; accelerations 1000 (centroid) and 100 (size) (px/s^2)^2 s;
    /// measurement std 1 px (centroid) and 2 px (size); new tracks'
    /// velocity std 250 px/s (10 px a frame).
    fn default() -> Self {
        Self {
            dt: 0.04,
            association: Association::default(),
            foreground_threshold: 20,
            open_radius: 1,
            close_radius: 2,
            min_area: 100,
            max_missed: 5,
            centroid_accel: 1000.0,
            size_accel: 100.0,
            centroid_std: 1.0,
            size_std: 2.0,
            velocity_std: 250.0,
        }
    }
}

/// One tracked target as reported for a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Track {
    /// Identity, stable across frames, in order of birth from 0.
    pub id: u64,
    /// Filtered centroid and window size (eq. 18's `x, y, Lx, Ly`).
    pub feature: Feature,
    /// Filtered centroid velocity in px/s (`x', y'`).
    pub velocity: (f64, f64),
    /// The window as an OTB box (centred on the centroid).
    pub bbox: BBox,
    /// The blob matched in this frame, `None` when the track coasted.
    pub detection: Option<Detection>,
    /// Frames in which the track was matched (1 at birth).
    pub hits: usize,
    /// Consecutive frames without a match.
    pub missed: usize,
}

#[derive(Debug, Clone)]
struct TrackState {
    id: u64,
    belief: Gaussian<8>,
    hits: usize,
    missed: usize,
    detection: Option<Detection>,
}

impl TrackState {
    fn feature(&self) -> Feature {
        let m = self.belief.mean();
        Feature {
            centroid: (m[0], m[1]),
            size: (m[4], m[5]),
        }
    }

    fn report(&self) -> Track {
        let f = self.feature();
        let m = self.belief.mean();
        let (lx, ly) = (f.size.0.max(0.0), f.size.1.max(0.0));
        Track {
            id: self.id,
            feature: f,
            velocity: (m[2], m[3]),
            // OTB centre = 0-based centre + 1.
            bbox: BBox::new(
                f.centroid.0 + 1.0 - (lx - 1.0) / 2.0,
                f.centroid.1 + 1.0 - (ly - 1.0) / 2.0,
                lx,
                ly,
            ),
            detection: self.detection,
            hits: self.hits,
            missed: self.missed,
        }
    }
}

/// Dong and Chen (paper 004) sec. 4: several targets, each with its own Kalman filter on
/// the 8-D state of eq. 18, found by subtracting a known background.
#[derive(Debug, Clone)]
pub struct MultiTargetTracker {
    config: MultiTargetConfig,
    kf: Kf,
    dynamics: LinearDynamics<8>,
    sensor: LinearMeasurement<8, 4>,
    background: Image<u8>,
    planes: PlaneBuffers,
    diff: Image<u8>,
    mask: Image<bool>,
    tracks: Vec<TrackState>,
    next_id: u64,
}

/// `A` of sec. 4.2.2: constant velocity for centroid and window size.
pub fn transition_matrix(dt: f64) -> SMatrix<f64, 8, 8> {
    let mut a = SMatrix::<f64, 8, 8>::identity();
    for (p, v) in [(0, 2), (1, 3), (4, 6), (5, 7)] {
        a[(p, v)] = dt;
    }
    a
}

/// The measurement matrix of eq. 17 as the text describes it (eq. 19):
/// `z = (x, y, Lx, Ly)`, state indices 0, 1, 4, 5. (The paper prints a `C`
/// that selects indices 0-3, i.e. `(x, y, x', y')`.)
pub fn measurement_matrix() -> SMatrix<f64, 4, 8> {
    let mut c = SMatrix::<f64, 4, 8>::zeros();
    for (row, col) in [(0, 0), (1, 1), (2, 4), (3, 5)] {
        c[(row, col)] = 1.0;
    }
    c
}

fn positive(name: &'static str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(TrackerError::InvalidParameter {
            name,
            value: v,
            reason: "must be finite and positive",
        })
    }
}

impl MultiTargetTracker {
    /// A tracker that subtracts `background` (gray or RGB, 8 bits); every
    /// frame must have its size.
    ///
    /// # Errors
    /// [`TrackerError::InvalidParameter`] for a non-positive `dt`, noise or
    /// std, or a bad association; [`TrackerError::Channels`] unless the
    /// background has 1 or 3 channels.
    pub fn new(config: MultiTargetConfig, background: ImageView<'_, u8>) -> Result<Self> {
        let dt = positive("dt", config.dt)?;
        positive("centroid_accel", config.centroid_accel)?;
        positive("size_accel", config.size_accel)?;
        positive("centroid_std", config.centroid_std)?;
        positive("size_std", config.size_std)?;
        positive("velocity_std", config.velocity_std)?;
        config.association.check()?;
        let mut q = SMatrix::<f64, 8, 8>::zeros();
        for (p, v, s) in [
            (0, 2, config.centroid_accel),
            (1, 3, config.centroid_accel),
            (4, 6, config.size_accel),
            (5, 7, config.size_accel),
        ] {
            q[(p, p)] = s * dt.powi(3) / 3.0;
            q[(p, v)] = s * dt.powi(2) / 2.0;
            q[(v, p)] = s * dt.powi(2) / 2.0;
            q[(v, v)] = s * dt;
        }
        let dynamics = LinearDynamics::new(transition_matrix(dt), q)?;
        let (cs, ss) = (config.centroid_std.powi(2), config.size_std.powi(2));
        let r = SMatrix::<f64, 4, 4>::from_diagonal(&Vector4::new(cs, cs, ss, ss));
        let sensor = LinearMeasurement::new(measurement_matrix(), r)?;
        ChannelPolicy::GrayOrRgb.check(NAME, background.channels())?;
        let mut planes = PlaneBuffers::default();
        let bg = planes.build(Needs::GRAY, background, 0)?.gray()?.to_image();
        let (w, h) = (background.width(), background.height());
        Ok(Self {
            config,
            kf: Kf::default(),
            dynamics,
            sensor,
            background: bg,
            planes,
            diff: Image::new(w, h, 1, 0)?,
            mask: Image::new(w, h, 1, false)?,
            tracks: Vec::new(),
            next_id: 0,
        })
    }

    /// The settings.
    pub fn config(&self) -> &MultiTargetConfig {
        &self.config
    }

    /// The foreground blobs of `frame`, largest first.
    ///
    /// # Errors
    /// [`TrackerError::FrameSizeChanged`], [`TrackerError::Channels`].
    pub fn detect(&mut self, frame: ImageView<'_, u8>) -> Result<Vec<Detection>> {
        // Frames are compared with the background, gray, in either
        // channel count: only the size must match.
        let (width, height) = (self.background.width(), self.background.height());
        if (frame.width(), frame.height()) != (width, height) {
            return Err(TrackerError::FrameSizeChanged {
                width,
                height,
                got_width: frame.width(),
                got_height: frame.height(),
            });
        }
        ChannelPolicy::GrayOrRgb.check(NAME, frame.channels())?;
        let gray = self.planes.build(Needs::GRAY, frame, 0)?.gray()?;
        abs_diff_into(gray, self.background.view(), &mut self.diff.view_mut())?;
        threshold_into(
            self.diff.view(),
            self.config.foreground_threshold,
            &mut self.mask.view_mut(),
        )?;
        let mut mask = open(self.mask.view(), self.config.open_radius)?;
        if self.config.close_radius > 0 {
            mask = close(mask.view(), self.config.close_radius)?;
        }
        let comps = label_components(mask.view(), Connectivity::Eight)?;
        Ok(comps
            .largest(self.config.min_area.max(1))
            .into_iter()
            .map(|b| Detection {
                feature: Feature {
                    centroid: b.centroid,
                    size: (b.bbox.width as f64, b.bbox.height as f64),
                },
                window: b.bbox,
                area: b.area,
            })
            .collect())
    }

    fn birth(&mut self, d: Detection) -> Result<()> {
        let c = &self.config;
        let (x, y) = d.feature.centroid;
        let (lx, ly) = d.feature.size;
        let mean = SVector::<f64, 8>::from_column_slice(&[x, y, 0.0, 0.0, lx, ly, 0.0, 0.0]);
        let (cs, ss, vs) = (
            c.centroid_std.powi(2),
            c.size_std.powi(2),
            c.velocity_std.powi(2),
        );
        let var =
            SVector::<f64, 8>::from_column_slice(&[cs, cs, vs, vs, ss, ss, vs / 4.0, vs / 4.0]);
        self.tracks.push(TrackState {
            id: self.next_id,
            belief: Gaussian::diagonal(mean, var)?,
            hits: 1,
            missed: 0,
            detection: Some(d),
        });
        self.next_id += 1;
        Ok(())
    }

    /// Tracks into `frame`: predict every track, detect, associate (eq.
    /// 20-22), update the matched tracks with their blob, start a track
    /// for every unmatched blob, end the tracks unmatched for more than
    /// `max_missed` frames. Returns the live tracks in order of birth
    /// (coasting ones included, with `detection: None`).
    ///
    /// # Errors
    /// [`TrackerError::FrameSizeChanged`], [`TrackerError::Channels`],
    /// [`TrackerError::Kalman`] for a failed filter step.
    pub fn step(&mut self, frame: ImageView<'_, u8>) -> Result<Vec<Track>> {
        let detections = self.detect(frame)?;
        for t in &mut self.tracks {
            t.belief = self.kf.predict(&t.belief, &self.dynamics)?;
            t.detection = None;
        }
        let predicted: Vec<Feature> = self.tracks.iter().map(TrackState::feature).collect();
        let features: Vec<Feature> = detections.iter().map(|d| d.feature).collect();
        let pairs = self.config.association.associate(&predicted, &features);
        let mut det_used = vec![false; detections.len()];
        let mut matched = vec![false; self.tracks.len()];
        for &(i, j) in &pairs {
            let d = detections[j];
            let z = Vector4::new(
                d.feature.centroid.0,
                d.feature.centroid.1,
                d.feature.size.0,
                d.feature.size.1,
            );
            let t = &mut self.tracks[i];
            t.belief = self.kf.update(&t.belief, &self.sensor, Some(&z))?.posterior;
            t.detection = Some(d);
            t.hits += 1;
            t.missed = 0;
            matched[i] = true;
            det_used[j] = true;
        }
        for (t, m) in self.tracks.iter_mut().zip(&matched) {
            if !m {
                t.missed += 1;
            }
        }
        let max_missed = self.config.max_missed;
        self.tracks.retain(|t| t.missed <= max_missed);
        for (d, used) in detections.into_iter().zip(det_used) {
            if !used {
                self.birth(d)?;
            }
        }
        Ok(self.tracks.iter().map(TrackState::report).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feature(x: f64, y: f64, lx: f64, ly: f64) -> Feature {
        Feature {
            centroid: (x, y),
            size: (lx, ly),
        }
    }

    #[test]
    fn association_matches_hand_computed_numbers() {
        // Track at (0, 0), 10x10 (area 100, diagonal 14.14).
        // Candidate 0 at (3, 4), 10x12: distance 5, area difference 20.
        // Candidate 1 at (30, 40), 10x13: distance 50, area difference 30.
        let tracks = [feature(0.0, 0.0, 10.0, 10.0)];
        let dets = [
            feature(3.0, 4.0, 10.0, 12.0),
            feature(30.0, 40.0, 10.0, 13.0),
        ];
        let paper = Association {
            floored: false,
            ..Association::default()
        };
        // D = (5/50, 50/50) = (0.1, 1); A = (20/30, 30/30).
        // Delta = (0.7 * 0.1 + 0.3 * 2/3, 0.7 + 0.3) = (0.27, 1.0).
        let d = paper.delta(&tracks, &dets);
        assert!((d[0][0] - 0.27).abs() < 1e-12, "{d:?}");
        assert!((d[0][1] - 1.0).abs() < 1e-12);
        assert_eq!(paper.associate(&tracks, &dets), vec![(0, 0)]);
        // Floored: the area normaliser becomes max(30, 100) = 100:
        // Delta = (0.07 + 0.3 * 0.2, 0.7 + 0.3 * 0.3) = (0.13, 0.79).
        let d = Association::default().delta(&tracks, &dets);
        assert!((d[0][0] - 0.13).abs() < 1e-12, "{d:?}");
        assert!((d[0][1] - 0.79).abs() < 1e-12);
        // A lone candidate: as printed Delta = 1 > 0.6 wherever it is;
        // floored, a blob 5 px away matches (0.7 * 5 / 14.14 + 0.3 * 0.2).
        let lone = [dets[0]];
        assert_eq!(paper.delta(&tracks, &lone), vec![vec![1.0]]);
        assert!(paper.associate(&tracks, &lone).is_empty());
        let d = Association::default().delta(&tracks, &lone)[0][0];
        assert!((d - (0.7 * 5.0 / 200f64.sqrt() + 0.06)).abs() < 1e-12);
        assert_eq!(
            Association::default().associate(&tracks, &lone),
            vec![(0, 0)]
        );
        // Two tracks competing: the smaller Delta wins, each used once.
        let two = [feature(3.0, 4.0, 10.0, 12.0), feature(0.0, 0.0, 10.0, 10.0)];
        let pairs = Association::default().associate(&two, &dets);
        assert_eq!(pairs, vec![(0, 0)]);
    }

    #[test]
    fn matrices_follow_the_text() {
        let a = transition_matrix(0.04);
        let s =
            SVector::<f64, 8>::from_column_slice(&[1.0, 2.0, 100.0, 50.0, 30.0, 40.0, 25.0, -25.0]);
        let n = a * s;
        assert_eq!(
            n.as_slice(),
            &[5.0, 4.0, 100.0, 50.0, 31.0, 39.0, 25.0, -25.0]
        );
        assert_eq!(
            (measurement_matrix() * s).as_slice(),
            &[1.0, 2.0, 30.0, 40.0]
        );
    }

    /// Two textured rectangles moving right on a flat background.
    fn two_cars(k: usize) -> Image<u8> {
        let mut f = Image::new(200, 120, 1, 100u8).unwrap();
        for (x0, y0, w, h, v) in [
            (10 + 4 * k, 20 + k, 20, 30, 30u8),
            (10 + 4 * k, 70 + k, 24, 28, 200u8),
        ] {
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    f.set(x, y, 0, v + ((x + y) % 3) as u8);
                }
            }
        }
        f
    }

    #[test]
    fn two_separated_cars_keep_two_stable_tracks() {
        let bg = Image::new(200, 120, 1, 100u8).unwrap();
        let mut tr = MultiTargetTracker::new(MultiTargetConfig::default(), bg.view()).unwrap();
        let first = tr.step(two_cars(0).view()).unwrap();
        assert_eq!(first.len(), 2);
        let ids: Vec<u64> = first.iter().map(|t| t.id).collect();
        let y_of =
            |ts: &[Track], id: u64| ts.iter().find(|t| t.id == id).unwrap().feature.centroid.1;
        let upper = if y_of(&first, ids[0]) < y_of(&first, ids[1]) {
            ids[0]
        } else {
            ids[1]
        };
        for k in 1..20 {
            let ts = tr.step(two_cars(k).view()).unwrap();
            assert_eq!(ts.len(), 2, "frame {k}");
            let mut now: Vec<u64> = ts.iter().map(|t| t.id).collect();
            now.sort();
            assert_eq!(now, vec![0, 1]);
            // The upper car keeps its id; the centroid is exact (eq. 14-15).
            let t = ts.iter().find(|t| t.id == upper).unwrap();
            assert!(
                (t.detection.unwrap().feature.centroid.0 - (10.0 + 4.0 * k as f64 + 9.5)).abs()
                    < 1e-9
            );
            assert!(
                (t.feature.centroid.1 - (20.0 + k as f64 + 14.5)).abs() < 0.5,
                "{t:?}"
            );
            assert_eq!(t.feature.size.0.round(), 20.0);
            assert!(ts.iter().all(|t| t.missed == 0));
        }
        // The filter learnt the velocity: 4 px a frame = 100 px/s.
        let ts = tr.step(two_cars(20).view()).unwrap();
        let t = ts.iter().find(|t| t.id == upper).unwrap();
        assert!((t.velocity.0 - 100.0).abs() < 5.0, "{:?}", t.velocity);
    }

    #[test]
    fn tracks_die_after_max_missed_and_new_ones_are_born() {
        let bg = Image::new(200, 120, 1, 100u8).unwrap();
        let config = MultiTargetConfig {
            max_missed: 2,
            ..MultiTargetConfig::default()
        };
        let mut tr = MultiTargetTracker::new(config, bg.view()).unwrap();
        assert_eq!(tr.step(two_cars(0).view()).unwrap().len(), 2);
        // Empty frames: tracks coast for 2 frames, then end.
        assert_eq!(tr.step(bg.view()).unwrap().len(), 2);
        let coast = tr.step(bg.view()).unwrap();
        assert!(coast.iter().all(|t| t.missed == 2 && t.detection.is_none()));
        assert!(tr.step(bg.view()).unwrap().is_empty());
        // The cars reappear: two new identities.
        let ts = tr.step(two_cars(3).view()).unwrap();
        let mut ids: Vec<u64> = ts.iter().map(|t| t.id).collect();
        ids.sort();
        assert_eq!(ids, vec![2, 3]);
    }

    #[test]
    fn bad_input_is_an_error() {
        let bg = Image::new(50, 40, 1, 0u8).unwrap();
        for c in [
            MultiTargetConfig {
                dt: 0.0,
                ..MultiTargetConfig::default()
            },
            MultiTargetConfig {
                centroid_std: f64::NAN,
                ..MultiTargetConfig::default()
            },
            MultiTargetConfig {
                association: Association {
                    gamma: -1.0,
                    ..Association::default()
                },
                ..MultiTargetConfig::default()
            },
        ] {
            assert!(matches!(
                MultiTargetTracker::new(c, bg.view()),
                Err(TrackerError::InvalidParameter { .. })
            ));
        }
        let two = Image::new(50, 40, 2, 0u8).unwrap();
        assert!(matches!(
            MultiTargetTracker::new(MultiTargetConfig::default(), two.view()),
            Err(TrackerError::Channels { .. })
        ));
        let mut tr = MultiTargetTracker::new(MultiTargetConfig::default(), bg.view()).unwrap();
        let other = Image::new(50, 41, 1, 0u8).unwrap();
        assert!(matches!(
            tr.step(other.view()),
            Err(TrackerError::FrameSizeChanged { .. })
        ));
        // RGB frames of the right size are fine.
        let rgb = Image::new(50, 40, 3, 0u8).unwrap();
        assert!(tr.step(rgb.view()).unwrap().is_empty());
    }
}
