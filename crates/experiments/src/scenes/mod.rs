//! Seeded synthetic sequences with exact ground truth.
//!
//! Four generators, one per paper scene, each a struct of parameters whose
//! `Default` is the paper's setting:
//!
//! | generator | paper | frame | what moves |
//! |---|---|---|---|
//! | [`BallScene`] | 001 sec. 3 | 200x160 RGB, 22 fps | a black ball on a white screen, linear or bouncing, optional motion noise, illumination drift, sensor noise |
//! | [`RoadScene`] | 004 sec. 2-4 | 320x240 gray, 25 fps | one or two cars in uniform linear motion on a road, a billboard that hides them |
//! | [`WebcamScene`] | 003 sec. 3-5 | 320x240 RGB, 30 fps | a skin-coloured face or hand in clutter, static skin-coloured distractors, moving non-skin distractors, an object entering through the border, two objects crossing |
//! | [`AffineScene`] | 002 sec. 4 | 320x240 gray, 30 fps | a textured face-like patch under a known affine trajectory (jumps, blur, rotation, scale, illumination), seven feature points |
//!
//! Every generator has `stream(&self, seed)`, a frame-by-frame
//! [`SceneStream`] that never holds more than one frame (a 10-minute run of
//! paper 001 has 13,200 frames), and `generate(&self, seed)`, which collects
//! the whole [`Scene`] in memory (for short scenes and tests).
//!
//! # Conventions
//! - Scene parameters and the exact geometry (feature points, affine matrices,
//!   centres) are in **0-based continuous pixel coordinates** with pixel
//!   centres at integers (the convention of `bayestrack-image`): pixel `i`
//!   covers `[i - 0.5, i + 0.5]`.
//! - Ground-truth boxes ([`ObjectTruth::bbox`]) are **OTB boxes**: 1-based
//!   top-left pixel plus size. An object covering `[x0, x0 + w]` in 0-based
//!   continuous coordinates has the OTB box `(x0 + 1.5, y0 + 1.5, w, h)`;
//!   its OTB centre `(x + (w - 1) / 2, y + (h - 1) / 2)` is its 0-based
//!   centre plus one.
//! - A box is the object's full extent, also while it is hidden or partly
//!   outside the frame; [`ObjectTruth::visible_fraction`] says how much of it
//!   can be seen (computed from the same coverage the renderer uses).
//!
//! # Randomness
//! All randomness comes from `Xoshiro256PlusPlus` generators seeded by
//! [`scene_rng`] from `(seed, scene key, stream, index)`: the motion stream is
//! drawn once per frame in order; the sensor noise of frame `k` has its own
//! generator keyed by `k`, so skipping the rendering of some frames
//! ([`SceneStream::skip_frame`]) does not change the others. Rendering is
//! deterministic: the same parameters and seed give the same bytes.
//!
//! ```
//! use bayestrack_experiments::scenes::BallScene;
//!
//! let scene = BallScene { frames: 3, ..BallScene::default() }.generate(7).unwrap();
//! let ball = scene.truth[0].objects[0].bbox;
//! assert_eq!((ball.width, ball.height), (20.0, 20.0));
//! assert_eq!(scene.frames[0].width(), 200);
//! ```

mod affine_patch;
mod ball_screen;
mod registry;
pub(crate) mod render;
mod road;
mod webcam;
mod write;

use std::path::PathBuf;

use bayestrack_image::{BBox, Image, ImageError};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

use bayestrack_otb::metrics::FeaturePoints;

pub use affine_patch::{AffineScene, AffineStream, JumpKind, TEMPLATE_POINTS};
pub use ball_screen::{BallMotion, BallScene, BallStream};
pub use registry::{BALL_PREVIEW_FRAMES, NamedScene, SCENES, named_stream};
pub use road::{Car, RoadGeometry, RoadScene, RoadStream};
pub use webcam::{SKIN, SecondObject, SkinShape, WebcamScene, WebcamStream};
pub use write::{MAX_SCENE_FRAMES, WriteSummary, write_named_scene, write_scene};

/// What can go wrong when building or writing a scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// A parameter out of its valid range.
    #[error("{scene} scene: invalid {name}: {reason}")]
    InvalidParameter {
        /// Scene generator.
        scene: &'static str,
        /// Parameter name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// A scene name that [`named_stream`] does not know.
    #[error("unknown scene `{name}` (known: {known})")]
    UnknownScene {
        /// The name asked for.
        name: String,
        /// The known names, comma separated.
        known: String,
    },
    /// Creating a folder or writing a text file failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// An image operation (allocation, PNG encoding) failed.
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// Shorthand for results of the scene generators.
pub type Result<T, E = SceneError> = std::result::Result<T, E>;

/// Size, rate and length of a scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneInfo {
    /// Short name (`ball`, `road`, `webcam`, `affine`).
    pub name: &'static str,
    /// Frame width in pixels.
    pub width: usize,
    /// Frame height in pixels.
    pub height: usize,
    /// Channels per pixel: 1 (gray) or 3 (RGB).
    pub channels: usize,
    /// Frames per second.
    pub fps: f64,
    /// Number of frames.
    pub frames: usize,
}

/// How much of an object can be seen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Visibility {
    /// Entirely visible (visible fraction 1).
    Full,
    /// Partly hidden or partly outside the frame.
    Partial,
    /// Not visible at all (fully hidden or outside the frame).
    Hidden,
}

/// Ground truth of one object in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectTruth {
    /// Stable identity across frames (0 is the tracking target).
    pub id: usize,
    /// What it is (`ball`, `car`, `face`, `hand`, `patch`).
    pub label: &'static str,
    /// OTB box of the object's full extent (also when hidden or outside).
    pub bbox: BBox,
    /// Fraction of the object's rendered area that is visible: inside the
    /// frame and not covered by anything in front of it, in `[0, 1]`.
    pub visible_fraction: f64,
}

impl ObjectTruth {
    /// Full, partial or hidden (thresholds 1e-9 from 1 and 0).
    pub fn visibility(&self) -> Visibility {
        if self.visible_fraction >= 1.0 - 1e-9 {
            Visibility::Full
        } else if self.visible_fraction <= 1e-9 {
            Visibility::Hidden
        } else {
            Visibility::Partial
        }
    }

    /// Whether nothing of the object can be seen.
    pub fn is_hidden(&self) -> bool {
        self.visibility() == Visibility::Hidden
    }

    /// The 0-based continuous centre of the object's box.
    pub fn center0(&self) -> [f64; 2] {
        let (cx, cy) = self.bbox.center();
        [cx - 1.0, cy - 1.0]
    }
}

/// The true outline of an object: the boundary of its rendered silhouette
/// as polylines in 0-based continuous pixel coordinates (consecutive points
/// joined by segments, at most 0.25 px apart). The boundary is where the
/// renderer's anti-aliased coverage is one half: on an ellipse
/// `((x - cx) / a)^2 + ((y - cy) / b)^2 = 1`, on a rectangle's edges. A
/// silhouette made of several primitives (the hand: palm, fingers, thumb)
/// keeps only the parts of their boundaries that no other primitive covers,
/// so it may be several polylines.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Outline {
    /// The boundary pieces; a closed piece repeats its first point last.
    pub polylines: Vec<Vec<[f64; 2]>>,
}

impl Outline {
    /// Every vertex of every polyline.
    pub fn points(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.polylines.iter().flatten().copied()
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.polylines.iter().map(Vec::len).sum()
    }

    /// Whether the outline has no vertex.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Euclidean distance from `p` to the nearest segment (or lone vertex);
    /// infinite for an empty outline.
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        let mut best = f64::INFINITY;
        for line in &self.polylines {
            if let [only] = line.as_slice() {
                best = best.min((p[0] - only[0]).hypot(p[1] - only[1]));
            }
            for w in line.windows(2) {
                best = best.min(segment_distance(p, w[0], w[1]));
            }
        }
        best
    }

    /// The outline moved by `(dx, dy)`.
    pub fn translated(&self, dx: f64, dy: f64) -> Self {
        Self {
            polylines: self
                .polylines
                .iter()
                .map(|l| l.iter().map(|q| [q[0] + dx, q[1] + dy]).collect())
                .collect(),
        }
    }
}

/// Distance from `p` to the segment `[a, b]`.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ux, uy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = ux * ux + uy * uy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * ux + (p[1] - a[1]) * uy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * ux).hypot(p[1] - a[1] - t * uy)
}

/// Exact pose of paper 002's patch in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineTruth {
    /// 3x3 homogeneous matrix (rows) mapping template coordinates (origin
    /// at the template centre, x right, y down, template pixels) to 0-based
    /// image coordinates; the pose convention of `bayestrack-affine`.
    pub matrix: [[f64; 3]; 3],
    /// Template width and height (template pixels) at scale 1.
    pub template_size: [f64; 2],
    /// The seven feature points (eyes and mouth corners, nose tip) and the
    /// centre, mapped through `matrix`, in 0-based image coordinates.
    pub points: FeaturePoints,
    /// Whether an abrupt jump happened between the previous frame and this one.
    pub jump: bool,
    /// Length in pixels of the motion blur applied to this frame (0: sharp).
    pub blur: f64,
}

/// Ground truth of one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTruth {
    /// 0-based frame index.
    pub index: usize,
    /// Time of the frame in seconds (`index / fps`).
    pub time: f64,
    /// Every object of the scene (present even when hidden), target first.
    pub objects: Vec<ObjectTruth>,
    /// Global illumination gain applied to the frame (1 = nominal).
    pub gain: f64,
    /// Whether the target bounced off a wall or the floor since the
    /// previous frame (ball scene).
    pub bounce: bool,
    /// The patch pose and feature points (affine scene only).
    pub affine: Option<AffineTruth>,
}

impl FrameTruth {
    /// The tracking target (object 0).
    pub fn target(&self) -> Option<&ObjectTruth> {
        self.objects.first()
    }

    /// The object with identity `id`.
    pub fn object(&self, id: usize) -> Option<&ObjectTruth> {
        self.objects.iter().find(|o| o.id == id)
    }
}

/// One rendered frame and its ground truth.
#[derive(Debug, Clone)]
pub struct SceneFrame {
    /// The image (`info.channels` channels, 8 bits).
    pub image: Image<u8>,
    /// Its exact ground truth.
    pub truth: FrameTruth,
}

/// A frame-by-frame scene: advances the motion, renders on request.
pub trait SceneStream {
    /// Size, rate and length.
    fn info(&self) -> SceneInfo;

    /// Advances to the next frame without rendering it and returns its
    /// ground truth; `None` after the last frame. The next rendered frame is
    /// the same as if this one had been rendered.
    fn skip_frame(&mut self) -> Option<FrameTruth>;

    /// Advances to the next frame, renders it into `frame` (replaced by a
    /// new image if its shape differs from the scene's) and returns its
    /// ground truth; `None` after the last frame.
    fn next_into(&mut self, frame: &mut Image<u8>) -> Option<FrameTruth>;

    /// Advances and renders into a new image.
    fn next_frame(&mut self) -> Option<SceneFrame> {
        let info = self.info();
        let mut image = Image::new(info.width, info.height, info.channels, 0u8).ok()?;
        let truth = self.next_into(&mut image)?;
        Some(SceneFrame { image, truth })
    }
}

/// A whole scene in memory.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Size, rate and length.
    pub info: SceneInfo,
    /// The frames in order.
    pub frames: Vec<Image<u8>>,
    /// Ground truth of each frame.
    pub truth: Vec<FrameTruth>,
}

impl Scene {
    /// Renders every frame of a stream.
    pub fn collect<S: SceneStream + ?Sized>(stream: &mut S) -> Self {
        let info = stream.info();
        let mut frames = Vec::with_capacity(info.frames);
        let mut truth = Vec::with_capacity(info.frames);
        while let Some(f) = stream.next_frame() {
            frames.push(f.image);
            truth.push(f.truth);
        }
        Self {
            info,
            frames,
            truth,
        }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether the scene has no frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// OTB boxes of object `id` per frame, `None` where it is absent or
    /// entirely outside the frame (what `groundtruth_rect.txt` holds).
    pub fn boxes(&self, id: usize) -> Vec<Option<BBox>> {
        self.truth
            .iter()
            .map(|t| {
                t.object(id)
                    .filter(|o| box_meets_frame(&o.bbox, self.info.width, self.info.height))
                    .map(|o| o.bbox)
            })
            .collect()
    }
}

/// Whether an OTB box shares some area with a `width x height` frame.
pub(crate) fn box_meets_frame(b: &BBox, width: usize, height: usize) -> bool {
    let (x0, y0) = (b.x - 1.5, b.y - 1.5);
    x0 < width as f64 - 0.5
        && y0 < height as f64 - 0.5
        && x0 + b.width > -0.5
        && y0 + b.height > -0.5
        && b.width > 0.0
        && b.height > 0.0
}

/// The OTB box of the 0-based continuous extent `[x0, x0 + w] x [y0, y0 + h]`.
pub fn otb_box(x0: f64, y0: f64, w: f64, h: f64) -> BBox {
    BBox::new(x0 + 1.5, y0 + 1.5, w, h)
}

/// SplitMix64 finaliser: a bijective 64-bit mixer.
const fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A key from a name (FNV-1a), for scene keys.
pub const fn name_key(name: &str) -> u64 {
    let bytes = name.as_bytes();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
        i += 1;
    }
    h
}

/// Mixes a user seed with a key path into one 64-bit seed.
pub fn mix_seed(seed: u64, key: &[u64]) -> u64 {
    key.iter()
        .fold(splitmix(seed), |acc, &k| splitmix(acc ^ splitmix(k)))
}

/// The generator of stream `stream`, item `index`, of scene `scene_key`
/// under user seed `seed`.
pub fn scene_rng(seed: u64, scene_key: u64, stream: u64, index: u64) -> Xoshiro256PlusPlus {
    Xoshiro256PlusPlus::seed_from_u64(mix_seed(seed, &[scene_key, stream, index]))
}

/// Stream ids used with [`scene_rng`].
pub(crate) mod streams {
    /// Motion, drawn once per frame in order.
    pub const MOTION: u64 = 1;
    /// Sensor noise, one generator per frame.
    pub const NOISE: u64 = 2;
    /// Static content (background texture, distractor layout), drawn once.
    pub const LAYOUT: u64 = 3;
}

/// Checks that a parameter is finite and within `[lo, hi]`.
pub(crate) fn check_range(
    scene: &'static str,
    name: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
) -> Result<()> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(SceneError::InvalidParameter {
            scene,
            name,
            reason: format!("{v} is not in [{lo}, {hi}]"),
        })
    }
}

/// Checks a frame geometry (non-zero size, at most 8192 pixels a side,
/// positive finite fps, at least one frame).
pub(crate) fn check_geometry(
    scene: &'static str,
    width: usize,
    height: usize,
    fps: f64,
    frames: usize,
) -> Result<()> {
    let bad = |name, reason: String| SceneError::InvalidParameter {
        scene,
        name,
        reason,
    };
    if width == 0 || height == 0 || width > 8192 || height > 8192 {
        return Err(bad(
            "size",
            format!("{width}x{height} (each side must be 1..=8192)"),
        ));
    }
    if frames == 0 {
        return Err(bad("frames", "need at least one frame".to_string()));
    }
    if !(fps.is_finite() && fps > 0.0) {
        return Err(bad("fps", format!("{fps} is not a positive number")));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn seeds_mix_every_key() {
        let a = mix_seed(1, &[2, 3, 4]);
        assert_ne!(a, mix_seed(1, &[2, 3, 5]));
        assert_ne!(a, mix_seed(1, &[3, 2, 4]));
        assert_ne!(a, mix_seed(2, &[2, 3, 4]));
        assert_eq!(a, mix_seed(1, &[2, 3, 4]));
        assert_ne!(name_key("ball"), name_key("road"));
        let mut r = scene_rng(5, name_key("ball"), streams::MOTION, 0);
        let mut s = scene_rng(5, name_key("ball"), streams::MOTION, 0);
        assert_eq!(r.next_u64(), s.next_u64());
    }

    #[test]
    fn otb_box_convention() {
        // The 0-based extent [-0.5, 9.5] covers pixels 0..=9: OTB x = 1, w = 10.
        let b = otb_box(-0.5, -0.5, 10.0, 10.0);
        assert_eq!(b, BBox::new(1.0, 1.0, 10.0, 10.0));
        assert_eq!(b.center(), (5.5, 5.5)); // 0-based centre 4.5, plus one.
        assert!(box_meets_frame(&b, 5, 5));
        assert!(!box_meets_frame(&otb_box(5.5, 0.0, 3.0, 3.0), 6, 6));
        assert!(!box_meets_frame(&otb_box(-3.5, 0.0, 3.0, 3.0), 6, 6));
        assert!(box_meets_frame(&otb_box(-3.4, 0.0, 3.0, 3.0), 6, 6));
    }
}
