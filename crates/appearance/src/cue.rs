//! One trait for every appearance cue, and OR / AND fusion (Lee, Jo and Kang (paper 003),
//! eq. 9 and eq. 11).
//!
//! A [`Cue`] turns a [`Frame`] and a [`Candidate`] state (an axis-aligned
//! window, or an affine pose) into a log-likelihood, so trackers can swap
//! cues. Cues read the planes of the frame they need (gray, RGB, HSV, IFD);
//! a tracker computes those once per frame.
//!
//! Cues that are non-negative scores (IFD, skin, similarity) return
//! `ln(score + floor)`. Fusion then works in the log domain:
//! OR (eq. 9, `w = sum_i lambda_i w_i`) is a weighted log-sum-exp, AND
//! (eq. 11, `w = prod_i lambda_i w_i`) a sum of logs.

use std::any::Any;

use bayestrack_image::{
    Affine2, Border, ImageError, ImageView, ImageViewMut, Rect, Rgb, warp_into,
};

use crate::error::{check_window, positive};
use crate::{
    AppearanceError, HistogramDistance, MadLikelihood, Result, RgbHistogram, SkinModel,
    TargetModel, mad,
};

/// A candidate state to score.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Candidate {
    /// An axis-aligned window (0-based pixels).
    Window(Rect),
    /// An affine pose mapping the cue's patch coordinates to image
    /// coordinates (see `bayestrack_image::warp_into`). Build it from a 3x3
    /// matrix with `Affine2::from_matrix3` or `Affine2::from_column_major`.
    Pose(Affine2),
}

/// The planes of one frame that cues may read. Absent planes are `None`;
/// a cue that needs one fails with [`AppearanceError::MissingPlane`].
///
/// A cue of your own that reads a plane of its own (gradients, a
/// probability map) finds it by name among [`Frame::planes`], set with
/// [`Frame::with_planes`]: no change to this type needed.
#[derive(Clone, Copy, Debug, Default)]
pub struct Frame<'a> {
    /// 1-channel 8-bit gray.
    pub gray: Option<ImageView<'a, u8>>,
    /// 3-channel 8-bit RGB.
    pub rgb: Option<ImageView<'a, u8>>,
    /// 3-channel HSV (`bayestrack_image::rgb_to_hsv`).
    pub hsv: Option<ImageView<'a, f32>>,
    /// 1-channel interframe difference in `[0, 1]` (or a priority field).
    pub ifd: Option<ImageView<'a, f32>>,
    /// Further planes by name, for cues beyond this crate's.
    pub planes: &'a [(&'static str, ImageView<'a, f32>)],
}

impl<'a> Frame<'a> {
    /// A frame with no planes.
    pub fn new() -> Self {
        Self::default()
    }
    /// Sets the gray plane.
    pub fn with_gray(mut self, v: ImageView<'a, u8>) -> Self {
        self.gray = Some(v);
        self
    }
    /// Sets the RGB plane.
    pub fn with_rgb(mut self, v: ImageView<'a, u8>) -> Self {
        self.rgb = Some(v);
        self
    }
    /// Sets the HSV plane.
    pub fn with_hsv(mut self, v: ImageView<'a, f32>) -> Self {
        self.hsv = Some(v);
        self
    }
    /// Sets the IFD plane.
    pub fn with_ifd(mut self, v: ImageView<'a, f32>) -> Self {
        self.ifd = Some(v);
        self
    }
    /// Sets the named planes.
    pub fn with_planes(mut self, planes: &'a [(&'static str, ImageView<'a, f32>)]) -> Self {
        self.planes = planes;
        self
    }

    /// The named plane `name`.
    ///
    /// # Errors
    /// [`AppearanceError::MissingPlane`] naming `cue` and the plane.
    pub fn plane(&self, cue: &'static str, name: &'static str) -> Result<ImageView<'a, f32>> {
        let found = self.planes.iter().find(|(n, _)| *n == name);
        plane(found.map(|(_, v)| *v), cue, name)
    }
}

/// Reusable buffers for cue evaluation: keep one per worker so that
/// scoring a particle allocates nothing after the first call.
///
/// A cue of your own keeps its buffers here too, by type
/// ([`Scratch::get`]): no change to this type needed.
#[derive(Default)]
pub struct Scratch {
    patch: Vec<f32>,
    hist: Option<RgbHistogram>,
    others: Vec<Box<dyn Any + Send>>,
}

impl Clone for Scratch {
    /// Buffers carry no state between calls: a clone starts with the
    /// built-in buffers' contents and without the others.
    fn clone(&self) -> Self {
        Self {
            patch: self.patch.clone(),
            hist: self.hist.clone(),
            others: Vec::new(),
        }
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scratch")
            .field("patch", &self.patch.len())
            .field("others", &self.others.len())
            .finish()
    }
}

impl Scratch {
    /// Empty buffers (they grow on first use).
    pub fn new() -> Self {
        Self::default()
    }

    /// The buffer of type `T`, created by `T::default()` on first use.
    pub fn get<T: Default + Send + 'static>(&mut self) -> &mut T {
        let i = match self.others.iter().position(|b| b.is::<T>()) {
            Some(i) => i,
            None => {
                self.others.push(Box::new(T::default()));
                self.others.len() - 1
            }
        };
        match self.others[i].downcast_mut::<T>() {
            Some(t) => t,
            None => unreachable!("position() found a T"),
        }
    }

    fn patch(&mut self, w: usize, h: usize, ch: usize) -> Result<ImageViewMut<'_, f32>> {
        let n = w * h * ch;
        if self.patch.len() < n {
            self.patch.resize(n, 0.0);
        }
        Ok(ImageViewMut::from_slice(
            &mut self.patch[..n],
            w,
            h,
            ch,
            w * ch,
        )?)
    }
}

fn plane<'a, T>(
    p: Option<ImageView<'a, T>>,
    cue: &'static str,
    plane: &'static str,
) -> Result<ImageView<'a, T>> {
    p.ok_or(AppearanceError::MissingPlane { cue, plane })
}

/// An appearance model that scores candidate states.
pub trait Cue {
    /// A short name for error messages.
    fn name(&self) -> &'static str;

    /// `ln p(frame | candidate)` up to a constant shared by all candidates.
    ///
    /// # Errors
    /// [`AppearanceError::MissingPlane`]; [`AppearanceError::WindowOutside`]
    /// or `ImageError::PatchOutside` when the candidate leaves the frame;
    /// cue-specific errors.
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64>;

    /// As [`Cue::log_likelihood`], but a candidate that leaves the frame
    /// scores `-inf` (zero likelihood, as Lee, Jo and Kang (paper 003) gives to impossible
    /// configurations) instead of failing. Other errors still fail.
    ///
    /// # Errors
    /// Those of [`Cue::log_likelihood`] other than leaving the frame.
    fn log_likelihood_or_zero(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        match self.log_likelihood(frame, candidate, scratch) {
            Err(AppearanceError::WindowOutside { .. })
            | Err(AppearanceError::Image(ImageError::PatchOutside { .. })) => Ok(f64::NEG_INFINITY),
            other => other,
        }
    }
}

fn ln_floor(score: f64, floor: f64) -> f64 {
    (score + floor).ln()
}

fn check_floor(floor: f64) -> Result<f64> {
    if floor.is_finite() && floor >= 0.0 {
        Ok(floor)
    } else {
        Err(AppearanceError::InvalidParameter {
            name: "floor",
            value: floor.to_string(),
            reason: "must be finite and >= 0",
        })
    }
}

/// Checks the side of a cue's pose patch.
fn check_patch_side(patch_side: usize) -> Result<()> {
    if patch_side == 0 {
        return Err(AppearanceError::InvalidParameter {
            name: "patch_side",
            value: "0".to_string(),
            reason: "must be > 0",
        });
    }
    Ok(())
}

/// Default floor added to scores before the log (keeps `ln 0` finite).
pub const DEFAULT_FLOOR: f64 = 1e-12;

fn mean_patch(p: &ImageViewMut<'_, f32>) -> f64 {
    let v = p.as_view();
    let s: f64 = (0..v.height())
        .map(|y| v.row(y).iter().map(|&x| f64::from(x)).sum::<f64>())
        .sum();
    s / (v.width() * v.height() * v.channels()) as f64
}

/// MAD template cue (Dong and Chen (paper 004), eq. 1 and 7) on the gray plane:
/// `ln p = -MAD / (2 sigma^2)`. A window must have the template's size; a
/// pose warps the frame into a template-size patch.
#[derive(Clone, Debug)]
pub struct MadCue {
    template: bayestrack_image::Image<u8>,
    template_f32: bayestrack_image::Image<f32>,
    likelihood: MadLikelihood,
}

impl MadCue {
    /// From a 1-channel template and the likelihood's sigma (gray levels).
    ///
    /// # Errors
    /// [`ImageError::Channels`]; [`AppearanceError::InvalidParameter`].
    pub fn new(template: bayestrack_image::Image<u8>, sigma: f64) -> Result<Self> {
        template.view().expect_channels("MadCue", 1)?;
        Ok(Self {
            template_f32: template.map(f32::from),
            template,
            likelihood: MadLikelihood::new(sigma)?,
        })
    }
}

impl Cue for MadCue {
    fn name(&self) -> &'static str {
        "mad"
    }
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        let gray = plane(frame.gray, "mad", "gray")?;
        let (tw, th) = (self.template.width(), self.template.height());
        let m = match candidate {
            Candidate::Window(r) => {
                if (r.width, r.height) != (tw, th) {
                    return Err(AppearanceError::WindowSize {
                        operation: "MadCue",
                        got_width: r.width,
                        got_height: r.height,
                        want_width: tw,
                        want_height: th,
                    });
                }
                mad(gray, self.template.view(), r.x, r.y)?
            }
            Candidate::Pose(pose) => {
                let mut p = scratch.patch(tw, th, 1)?;
                warp_into(gray, pose, Border::Error, &mut p)?;
                mad(p.as_view(), self.template_f32.view(), 0, 0)?
            }
        };
        self.likelihood.log_likelihood(m)
    }
}

/// RGB histogram cue (Bócsi and Csató (paper 001)): `ln p = -d^2 / (2 sigma^2)` with `d` the
/// chosen histogram distance to the reference. A pose is observed through a
/// `patch_side x patch_side` warped patch.
#[derive(Clone, Debug)]
pub struct HistogramCue {
    reference: RgbHistogram,
    kind: HistogramDistance,
    sigma: f64,
    patch_side: usize,
}

impl HistogramCue {
    /// From a reference histogram, a distance, the spread sigma and the
    /// patch side used for poses.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] for sigma below 1e-100 (its
    /// square underflows) or a zero patch side;
    /// [`AppearanceError::Incompatible`] for an empty reference.
    pub fn new(
        reference: RgbHistogram,
        kind: HistogramDistance,
        sigma: f64,
        patch_side: usize,
    ) -> Result<Self> {
        if reference.pixels() == 0 {
            return Err(AppearanceError::Incompatible {
                operation: "HistogramCue",
                detail: "empty reference histogram".to_string(),
            });
        }
        check_patch_side(patch_side)?;
        Ok(Self {
            reference,
            kind,
            sigma: crate::error::spread("sigma", sigma)?,
            patch_side,
        })
    }
}

impl Cue for HistogramCue {
    fn name(&self) -> &'static str {
        "histogram"
    }
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        let rgb = plane(frame.rgb, "histogram", "rgb")?;
        let bins = self.reference.bins();
        let mut hist = match scratch.hist.take() {
            Some(h) if h.bins() == bins => h,
            _ => RgbHistogram::new(bins)?,
        };
        let filled = match candidate {
            Candidate::Window(r) => hist.compute(rgb, *r),
            Candidate::Pose(pose) => {
                let s = self.patch_side;
                scratch.patch(s, s, 3).and_then(|mut p| {
                    warp_into(rgb, pose, Border::Error, &mut p)?;
                    hist.compute_f32(p.as_view())
                })
            }
        };
        let d = filled.and_then(|()| hist.distance(&self.reference, self.kind));
        scratch.hist = Some(hist);
        let d = d?;
        Ok(-d * d / (2.0 * self.sigma * self.sigma))
    }
}

/// HSV skin cue (Lee, Jo and Kang (paper 003), eq. 8): `ln(mean C + floor)` over the window or
/// the warped patch. Uses the HSV plane for windows when present, else RGB.
#[derive(Clone, Copy, Debug)]
pub struct SkinCue {
    model: SkinModel,
    floor: f64,
    patch_side: usize,
}

impl SkinCue {
    /// From a skin model, the log floor and the patch side used for poses.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`].
    pub fn new(model: SkinModel, floor: f64, patch_side: usize) -> Result<Self> {
        check_patch_side(patch_side)?;
        Ok(Self {
            model,
            floor: check_floor(floor)?,
            patch_side,
        })
    }
}

impl Cue for SkinCue {
    fn name(&self) -> &'static str {
        "skin"
    }
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        let mean = match candidate {
            Candidate::Window(r) => {
                if let Some(hsv) = frame.hsv {
                    hsv.expect_channels("SkinCue", 3)?;
                    check_window("skin", *r, hsv.width(), hsv.height())?;
                    let mut s = 0f64;
                    for y in r.y..r.bottom() {
                        for p in hsv.row(y)[r.x * 3..r.right() * 3].chunks_exact(3) {
                            s += f64::from(self.model.score_hsv(p[0], p[1]));
                        }
                    }
                    s / r.area() as f64
                } else {
                    self.model
                        .window_mean(plane(frame.rgb, "skin", "rgb")?, *r)?
                }
            }
            Candidate::Pose(pose) => {
                // Warp RGB, not HSV: interpolating hue breaks at the wrap.
                let rgb = plane(frame.rgb, "skin", "rgb")?;
                let s = self.patch_side;
                let mut p = scratch.patch(s, s, 3)?;
                warp_into(rgb, pose, Border::Error, &mut p)?;
                let v = p.as_view();
                let q = |x: f32| x.round().clamp(0.0, 255.0) as u8;
                let mut acc = 0f64;
                for y in 0..s {
                    for px in v.row(y).chunks_exact(3) {
                        acc +=
                            f64::from(self.model.score_rgb(Rgb::new(q(px[0]), q(px[1]), q(px[2]))));
                    }
                }
                acc / (s * s) as f64
            }
        };
        Ok(ln_floor(mean, self.floor))
    }
}

/// Interframe-difference cue (Lee, Jo and Kang (paper 003), eq. 7): `ln(mean dP + floor)` over
/// the window or warped patch of the IFD plane (which may be a priority
/// field `V^k`, eq. 15).
#[derive(Clone, Copy, Debug)]
pub struct IfdCue {
    floor: f64,
    patch_side: usize,
}

impl IfdCue {
    /// With the log floor and the patch side used for poses.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`].
    pub fn new(floor: f64, patch_side: usize) -> Result<Self> {
        check_patch_side(patch_side)?;
        Ok(Self {
            floor: check_floor(floor)?,
            patch_side,
        })
    }
}

impl Cue for IfdCue {
    fn name(&self) -> &'static str {
        "ifd"
    }
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        let ifd = plane(frame.ifd, "ifd", "ifd")?;
        ifd.expect_channels("IfdCue", 1)?;
        let mean = match candidate {
            Candidate::Window(r) => {
                check_window("ifd", *r, ifd.width(), ifd.height())?;
                let s: f64 = (r.y..r.bottom())
                    .map(|y| {
                        ifd.row(y)[r.x..r.right()]
                            .iter()
                            .map(|&v| f64::from(v))
                            .sum::<f64>()
                    })
                    .sum();
                s / r.area() as f64
            }
            Candidate::Pose(pose) => {
                let s = self.patch_side;
                let mut p = scratch.patch(s, s, 1)?;
                warp_into(ifd, pose, Border::Error, &mut p)?;
                mean_patch(&p)
            }
        };
        if !mean.is_finite() {
            return Err(AppearanceError::NonFinite { what: "IFD plane" });
        }
        Ok(ln_floor(mean.max(0.0), self.floor))
    }
}

/// The Xu, Gao and Yang 2015 (paper 002) similarity as a cue: `ln(S + floor)`, `S = max(0, NCC)`
/// between the warped gray patch (template size) and the template. A window
/// is resampled onto the template grid.
#[derive(Clone, Debug)]
pub struct SimilarityCue {
    model: TargetModel,
    floor: f64,
}

impl SimilarityCue {
    /// From a target model and the log floor.
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] for a bad floor.
    pub fn new(model: TargetModel, floor: f64) -> Result<Self> {
        Ok(Self {
            model,
            floor: check_floor(floor)?,
        })
    }
    /// The model (to update it between frames).
    pub fn model_mut(&mut self) -> &mut TargetModel {
        &mut self.model
    }
    /// The model.
    pub fn model(&self) -> &TargetModel {
        &self.model
    }
}

impl Cue for SimilarityCue {
    fn name(&self) -> &'static str {
        "similarity"
    }
    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        let gray = plane(frame.gray, "similarity", "gray")?;
        let t = self.model.template();
        let (tw, th) = (t.width(), t.height());
        let pose = match candidate {
            Candidate::Pose(p) => *p,
            Candidate::Window(r) => {
                check_window("similarity", *r, gray.width(), gray.height())?;
                Affine2::patch_to_rect(
                    tw,
                    th,
                    r.x as f64,
                    r.y as f64,
                    r.width as f64,
                    r.height as f64,
                )?
            }
        };
        // A window is resampled with its half-pixel margin clamped; a pose
        // must stay inside the frame.
        let border = match candidate {
            Candidate::Pose(_) => Border::Error,
            Candidate::Window(_) => Border::Replicate,
        };
        let mut p = scratch.patch(tw, th, 1)?;
        warp_into(gray, &pose, border, &mut p)?;
        let s = self.model.similarity(p.as_view())?;
        Ok(ln_floor(s, self.floor))
    }
}

/// How fused cues combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum FusionRule {
    /// Disjunctive, eq. 9: `w = sum_i lambda_i w_i`.
    Or,
    /// Conjunctive, eq. 11: `w = prod_i lambda_i w_i`.
    And,
}

/// Several cues combined by OR or AND, itself a [`Cue`].
pub struct Fusion {
    rule: FusionRule,
    terms: Vec<(f64, Box<dyn Cue + Send + Sync>)>,
}

impl std::fmt::Debug for Fusion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<(f64, &str)> = self.terms.iter().map(|(l, c)| (*l, c.name())).collect();
        f.debug_struct("Fusion")
            .field("rule", &self.rule)
            .field("terms", &names)
            .finish()
    }
}

impl Fusion {
    /// An empty fusion with a rule; add cues with [`Fusion::with`].
    pub fn new(rule: FusionRule) -> Self {
        Self {
            rule,
            terms: Vec::new(),
        }
    }

    /// Adds a cue with balancing weight `lambda > 0` (the paper's lambda).
    ///
    /// # Errors
    /// [`AppearanceError::InvalidParameter`] unless lambda is finite and > 0.
    pub fn with(mut self, lambda: f64, cue: impl Cue + Send + Sync + 'static) -> Result<Self> {
        positive("lambda", lambda)?;
        self.terms.push((lambda, Box::new(cue)));
        Ok(self)
    }

    /// Number of cues.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// Whether there are no cues.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

impl Cue for Fusion {
    fn name(&self) -> &'static str {
        match self.rule {
            FusionRule::Or => "fusion-or",
            FusionRule::And => "fusion-and",
        }
    }

    fn log_likelihood(
        &self,
        frame: &Frame<'_>,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Result<f64> {
        if self.terms.is_empty() {
            return Err(AppearanceError::InvalidParameter {
                name: "cues",
                value: "0".to_string(),
                reason: "a fusion needs at least one cue",
            });
        }
        match self.rule {
            FusionRule::And => {
                let mut s = 0.0;
                for (lambda, cue) in &self.terms {
                    s += lambda.ln() + cue.log_likelihood(frame, candidate, scratch)?;
                }
                Ok(s)
            }
            FusionRule::Or => {
                // Max-shifted log-sum-exp of ln(lambda_i) + l_i.
                let mut logs = [0f64; 8];
                let mut heap = Vec::new();
                let vals: &mut [f64] = if self.terms.len() <= logs.len() {
                    &mut logs[..self.terms.len()]
                } else {
                    heap.resize(self.terms.len(), 0.0);
                    &mut heap
                };
                for (v, (lambda, cue)) in vals.iter_mut().zip(&self.terms) {
                    *v = lambda.ln() + cue.log_likelihood(frame, candidate, scratch)?;
                }
                let m = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                if m == f64::NEG_INFINITY {
                    return Ok(m);
                }
                Ok(m + vals.iter().map(|v| (v - m).exp()).sum::<f64>().ln())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::OnlineGaussian;
    use bayestrack_image::Image;

    /// A cue with a fixed log-likelihood, to check fusion arithmetic.
    struct Fixed(f64);
    impl Cue for Fixed {
        fn name(&self) -> &'static str {
            "fixed"
        }
        fn log_likelihood(&self, _: &Frame<'_>, _: &Candidate, _: &mut Scratch) -> Result<f64> {
            Ok(self.0)
        }
    }

    fn w(x: usize, y: usize) -> Candidate {
        Candidate::Window(Rect::new(x, y, 4, 4))
    }

    /// A cue of its own: the mean of a named plane over the window, with a
    /// buffer of its own in the scratch.
    struct MeanOf(&'static str);

    impl Cue for MeanOf {
        fn name(&self) -> &'static str {
            "mean-of"
        }
        fn log_likelihood(&self, f: &Frame<'_>, c: &Candidate, s: &mut Scratch) -> Result<f64> {
            let Candidate::Window(r) = *c else {
                return Ok(f64::NEG_INFINITY);
            };
            let p = f.plane(self.name(), self.0)?;
            let calls: &mut usize = s.get();
            *calls += 1;
            let row = |y: usize| p.row(y)[r.x..r.right()].iter().sum::<f32>();
            let sum: f32 = (r.y..r.bottom()).map(row).sum();
            Ok((sum / (r.width * r.height) as f32).into())
        }
    }

    #[test]
    fn a_new_cue_reads_its_own_plane_and_keeps_its_own_buffers() {
        let img = bayestrack_image::Image::from_fn(4, 3, |x, _| x as f32).unwrap();
        let planes = [("ramp", img.view())];
        let f = Frame::new().with_planes(&planes);
        let mut s = Scratch::new();
        let window = Candidate::Window(Rect::new(1, 0, 3, 3));
        let v = MeanOf("ramp").log_likelihood(&f, &window, &mut s).unwrap();
        assert_eq!(v, 2.0); // columns 1, 2, 3
        MeanOf("ramp").log_likelihood(&f, &window, &mut s).unwrap();
        assert_eq!(*s.get::<usize>(), 2);
        assert!(matches!(
            MeanOf("edges").log_likelihood(&f, &w(0, 0), &mut s),
            Err(AppearanceError::MissingPlane { plane: "edges", .. })
        ));
        assert_eq!(*s.clone().get::<usize>(), 0, "clones start afresh");
    }

    #[test]
    fn fusion_rules_match_eq_9_and_11() {
        let f = Frame::new();
        let mut s = Scratch::new();
        // w1 = 0.2, w2 = 0.5, lambda = (1, 0.1):
        // OR: 0.2 + 0.05 = 0.25; AND: 0.2 * 0.05 = 0.01.
        let or = Fusion::new(FusionRule::Or)
            .with(1.0, Fixed(0.2f64.ln()))
            .unwrap()
            .with(0.1, Fixed(0.5f64.ln()))
            .unwrap();
        let and = Fusion::new(FusionRule::And)
            .with(1.0, Fixed(0.2f64.ln()))
            .unwrap()
            .with(0.1, Fixed(0.5f64.ln()))
            .unwrap();
        assert!((or.log_likelihood(&f, &w(0, 0), &mut s).unwrap() - 0.25f64.ln()).abs() < 1e-12);
        assert!((and.log_likelihood(&f, &w(0, 0), &mut s).unwrap() - 0.01f64.ln()).abs() < 1e-12);
        // Log domain: terms that underflow exp() still fuse.
        let tiny = Fusion::new(FusionRule::Or)
            .with(1.0, Fixed(-2000.0))
            .unwrap()
            .with(1.0, Fixed(-2000.0))
            .unwrap();
        let v = tiny.log_likelihood(&f, &w(0, 0), &mut s).unwrap();
        assert!((v - (-2000.0 + 2f64.ln())).abs() < 1e-9);
        let dead = Fusion::new(FusionRule::Or)
            .with(1.0, Fixed(f64::NEG_INFINITY))
            .unwrap();
        assert_eq!(
            dead.log_likelihood(&f, &w(0, 0), &mut s).unwrap(),
            f64::NEG_INFINITY
        );
        assert!(
            Fusion::new(FusionRule::And)
                .log_likelihood(&f, &w(0, 0), &mut s)
                .is_err()
        );
        assert!(Fusion::new(FusionRule::Or).with(0.0, Fixed(0.0)).is_err());
        // More than eight terms take the heap path.
        let mut many = Fusion::new(FusionRule::Or);
        for _ in 0..10 {
            many = many.with(1.0, Fixed(0.0)).unwrap();
        }
        assert!((many.log_likelihood(&f, &w(0, 0), &mut s).unwrap() - 10f64.ln()).abs() < 1e-12);
    }

    #[test]
    fn ifd_and_skin_cues_hand_values() {
        // IFD plane: 0.5 on a 2x2 block at (2, 2), else 0.
        let ifd = Image::from_fn(8, 8, |x, y| {
            if (2..4).contains(&x) && (2..4).contains(&y) {
                0.5f32
            } else {
                0.0
            }
        })
        .unwrap();
        let frame = Frame::new().with_ifd(ifd.view());
        let cue = IfdCue::new(0.0, 4).unwrap();
        let mut s = Scratch::new();
        // Window (2, 2, 4, 4) holds 4 of its 16 pixels at 0.5: mean 0.125.
        let l = cue.log_likelihood(&frame, &w(2, 2), &mut s).unwrap();
        assert!((l - 0.125f64.ln()).abs() < 1e-9);
        // The same window as a pose (identity scale, 4x4 patch).
        let pose = Candidate::Pose(Affine2::translation(2.0, 2.0));
        let lp = cue.log_likelihood(&frame, &pose, &mut s).unwrap();
        assert!((lp - l).abs() < 1e-9);
        assert!(matches!(
            cue.log_likelihood(&frame, &w(6, 6), &mut s),
            Err(AppearanceError::WindowOutside { .. })
        ));
        assert_eq!(
            cue.log_likelihood_or_zero(&frame, &w(6, 6), &mut s)
                .unwrap(),
            f64::NEG_INFINITY
        );
        let far = Candidate::Pose(Affine2::translation(6.0, 0.0));
        assert_eq!(
            cue.log_likelihood_or_zero(&frame, &far, &mut s).unwrap(),
            f64::NEG_INFINITY
        );
        assert!(matches!(
            cue.log_likelihood(&Frame::new(), &w(0, 0), &mut s),
            Err(AppearanceError::MissingPlane { plane: "ifd", .. })
        ));
        // Skin: a frame at exactly the reference colour scores ln(1) = 0,
        // through RGB or HSV planes, windows or poses.
        let skin_rgb = Rgb::new(220, 160, 130);
        let hsv = skin_rgb.to_hsv();
        let model = SkinModel::new(f64::from(hsv.h), f64::from(hsv.s), 0.05).unwrap();
        let mut img = Image::new(8, 8, 3, 0u8).unwrap();
        for px in img.as_mut_slice().chunks_exact_mut(3) {
            px.copy_from_slice(&skin_rgb.to_array());
        }
        let hsv_img = bayestrack_image::rgb_to_hsv(img.view()).unwrap();
        let skin = SkinCue::new(model, 0.0, 4).unwrap();
        let f_rgb = Frame::new().with_rgb(img.view());
        let f_hsv = Frame::new().with_rgb(img.view()).with_hsv(hsv_img.view());
        for (f, c) in [(&f_rgb, w(1, 1)), (&f_hsv, w(1, 1)), (&f_rgb, pose)] {
            assert!(skin.log_likelihood(f, &c, &mut s).unwrap().abs() < 1e-6);
        }
        // A mislabelled plane is an error, not a panic.
        let wrong = Frame::new().with_hsv(ifd.view());
        assert!(matches!(
            skin.log_likelihood(&wrong, &w(1, 1), &mut s),
            Err(AppearanceError::Image(ImageError::Channels { .. }))
        ));
        assert!(matches!(
            skin.log_likelihood(&Frame::new(), &w(1, 1), &mut s),
            Err(AppearanceError::MissingPlane { .. })
        ));
    }

    #[test]
    fn mad_histogram_similarity_cues() {
        let frame = bayestrack_testkit::noise(40, 30, 1, 5);
        let tpl = frame.crop(Rect::new(10, 8, 6, 5)).unwrap().to_image();
        let cue = MadCue::new(tpl.clone(), 2.0).unwrap();
        let planes = Frame::new().with_gray(frame.view());
        let mut s = Scratch::new();
        let at = |x, y| Candidate::Window(Rect::new(x, y, 6, 5));
        assert_eq!(
            cue.log_likelihood(&planes, &at(10, 8), &mut s).unwrap(),
            0.0
        );
        let m = mad(frame.view(), tpl.view(), 11, 8).unwrap();
        let l = cue.log_likelihood(&planes, &at(11, 8), &mut s).unwrap();
        assert!((l - (-m / 8.0)).abs() < 1e-12);
        // The same through a pose (pure translation: no interpolation).
        let lp = cue
            .log_likelihood(
                &planes,
                &Candidate::Pose(Affine2::translation(11.0, 8.0)),
                &mut s,
            )
            .unwrap();
        assert!((lp - l).abs() < 1e-9);
        assert!(matches!(
            cue.log_likelihood(&planes, &Candidate::Window(Rect::new(0, 0, 5, 5)), &mut s),
            Err(AppearanceError::WindowSize { .. })
        ));
        assert!(matches!(
            cue.log_likelihood(
                &planes,
                &Candidate::Pose(Affine2::translation(36.0, 0.0)),
                &mut s
            ),
            Err(AppearanceError::Image(ImageError::PatchOutside { .. }))
        ));
        // Histogram cue on an RGB version.
        let rgb = bayestrack_image::gray_to_rgb(frame.view()).unwrap();
        let reference = RgbHistogram::from_window(rgb.view(), Rect::new(10, 8, 6, 5), 16).unwrap();
        let hc = HistogramCue::new(reference.clone(), HistogramDistance::L2, 0.1, 6).unwrap();
        let rgb_planes = Frame::new().with_rgb(rgb.view());
        assert_eq!(
            hc.log_likelihood(&rgb_planes, &at(10, 8), &mut s).unwrap(),
            0.0
        );
        let other = RgbHistogram::from_window(rgb.view(), Rect::new(20, 20, 6, 5), 16).unwrap();
        let d = other.l2_distance(&reference).unwrap();
        let l = hc.log_likelihood(&rgb_planes, &at(20, 20), &mut s).unwrap();
        assert!((l - (-d * d / 0.02)).abs() < 1e-9);
        // Similarity cue: the template window scores ln(1) = 0.
        let tf = tpl.map(f32::from);
        let model = TargetModel::new(
            tf,
            OnlineGaussian::new(0.9, 0.05, 0.1).unwrap(),
            OnlineGaussian::new(0.2, 0.1, 0.1).unwrap(),
            0.1,
        )
        .unwrap();
        let sc = SimilarityCue::new(model, 1e-12).unwrap();
        assert!(
            sc.log_likelihood(&planes, &at(10, 8), &mut s)
                .unwrap()
                .abs()
                < 1e-6
        );
        assert!(sc.log_likelihood(&planes, &at(25, 20), &mut s).unwrap() < -0.5);
        assert!(
            sc.log_likelihood(
                &planes,
                &Candidate::Pose(Affine2::translation(10.0, 8.0)),
                &mut s
            )
            .unwrap()
            .abs()
                < 1e-6
        );
    }
}
