//! Every named scene preset: what `cargo xtask scenes` lists and writes. A
//! preset added to [`SCENES`] joins both.

use super::webcam::SecondObject;
use super::{AffineScene, BallScene, Result, RoadScene, SceneError, SceneStream, WebcamScene};

/// Frames of the `ball*` named scenes when no count is given: 10 s at
/// 22 fps (the paper-scale default, 13,200 frames, is too many to look at).
pub const BALL_PREVIEW_FRAMES: usize = 220;

/// One named scene preset.
#[derive(Debug, Clone, Copy)]
pub struct NamedScene {
    /// The name given to `cargo xtask scenes`.
    pub name: &'static str,
    /// One line: what it shows.
    pub summary: &'static str,
    stream: fn(u64, Option<usize>) -> Result<Box<dyn SceneStream>>,
}

impl NamedScene {
    /// The preset as a stream seeded with `seed`; `frames` overrides its
    /// length (`None` keeps the preset's, except the `ball*` scenes, which
    /// then have [`BALL_PREVIEW_FRAMES`]).
    ///
    /// # Errors
    /// [`SceneError::InvalidParameter`] for `Some(0)` frames.
    pub fn stream(&self, seed: u64, frames: Option<usize>) -> Result<Box<dyn SceneStream>> {
        (self.stream)(seed, frames)
    }
}

fn ball(mut s: BallScene, seed: u64, frames: Option<usize>) -> Result<Box<dyn SceneStream>> {
    s.frames = frames.unwrap_or(BALL_PREVIEW_FRAMES);
    Ok(Box::new(s.stream(seed)?))
}

fn road(mut s: RoadScene, seed: u64, frames: Option<usize>) -> Result<Box<dyn SceneStream>> {
    s.frames = frames.unwrap_or(s.frames);
    Ok(Box::new(s.stream(seed)?))
}

fn webcam(mut s: WebcamScene, seed: u64, frames: Option<usize>) -> Result<Box<dyn SceneStream>> {
    s.frames = frames.unwrap_or(s.frames);
    Ok(Box::new(s.stream(seed)?))
}

/// Every named scene, in the order `cargo xtask scenes list` prints them.
pub const SCENES: &[NamedScene] = &[
    NamedScene {
        name: "ball",
        summary: "paper 001: a black ball on a white screen, linear motion",
        stream: |seed, frames| ball(BallScene::default(), seed, frames),
    },
    NamedScene {
        name: "ball-bouncing",
        summary: "paper 001: the ball bouncing off the screen's edges",
        stream: |seed, frames| ball(BallScene::bouncing(), seed, frames),
    },
    NamedScene {
        name: "ball-noisy",
        summary: "paper 001: linear motion with 0.5 px/frame motion noise",
        stream: |seed, frames| {
            let s = BallScene {
                motion_noise: 0.5,
                ..BallScene::default()
            };
            ball(s, seed, frames)
        },
    },
    NamedScene {
        name: "road",
        summary: "paper 004: one car in uniform linear motion behind a billboard",
        stream: |seed, frames| road(RoadScene::default(), seed, frames),
    },
    NamedScene {
        name: "road-two-cars",
        summary: "paper 004: two cars for the Kalman multi-target tracker",
        stream: |seed, frames| road(RoadScene::two_cars(), seed, frames),
    },
    NamedScene {
        name: "webcam",
        summary: "paper 003: a skin-coloured face in clutter",
        stream: |seed, frames| webcam(WebcamScene::default(), seed, frames),
    },
    NamedScene {
        name: "webcam-entering",
        summary: "paper 003: a second object entering through the border",
        stream: |seed, frames| webcam(WebcamScene::entering(), seed, frames),
    },
    NamedScene {
        name: "webcam-crossing",
        summary: "paper 003: two objects crossing",
        stream: |seed, frames| {
            let s = WebcamScene {
                second: match WebcamScene::crossing().second {
                    // Keep the crossing in the middle of a shortened scene.
                    SecondObject::Crossing { frame } => SecondObject::Crossing {
                        frame: frames.map_or(frame, |n| n / 2),
                    },
                    other => other,
                },
                ..WebcamScene::crossing()
            };
            webcam(s, seed, frames)
        },
    },
    NamedScene {
        name: "affine",
        summary: "paper 002: a textured face-like patch under a known affine trajectory",
        stream: |seed, frames| {
            let mut s = AffineScene::default();
            s.frames = frames.unwrap_or(s.frames);
            Ok(Box::new(s.stream(seed)?))
        },
    },
];

/// The named scene `name` as a stream (see [`NamedScene::stream`]).
///
/// # Errors
/// [`SceneError::UnknownScene`] for a name not in [`SCENES`];
/// [`SceneError::InvalidParameter`] for `Some(0)` frames.
pub fn named_stream(name: &str, seed: u64, frames: Option<usize>) -> Result<Box<dyn SceneStream>> {
    SCENES
        .iter()
        .find(|s| s.name == name)
        .ok_or_else(|| SceneError::UnknownScene {
            name: name.to_string(),
            known: SCENES.iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
        })?
        .stream(seed, frames)
}
