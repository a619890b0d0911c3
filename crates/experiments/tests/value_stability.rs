//! Value stability: a fixed seed gives fixed ground truth and frames. A
//! change here changes every experiment built on the scenes: if it is
//! intended, update the numbers and say so in the commit.

use bayestrack_experiments::scenes::{AffineScene, BallScene, RoadScene, Scene, WebcamScene};
use bayestrack_image::BBox;

fn pixel_sum(s: &Scene, k: usize) -> u64 {
    s.frames[k].as_slice().iter().map(|&v| u64::from(v)).sum()
}

fn check(s: &Scene, boxes: &[[f64; 4]], sum: u64) {
    let got: Vec<BBox> = s.truth[2].objects.iter().map(|o| o.bbox).collect();
    assert_eq!(got.len(), boxes.len(), "{}", s.info.name);
    for (g, w) in got.iter().zip(boxes) {
        for (a, b) in [g.x, g.y, g.width, g.height].iter().zip(w) {
            assert!((a - b).abs() < 1e-9, "{}: {g:?} vs {w:?}", s.info.name);
        }
    }
    // Pixel sums allow for last-bit differences of sin/cos across platforms.
    let have = pixel_sum(s, 2) as f64;
    assert!(
        (have - sum as f64).abs() <= 1e-4 * sum as f64,
        "{}: pixel sum {have} vs {sum}",
        s.info.name
    );
}

#[test]
fn fixed_seed_gives_fixed_scenes() {
    let ball = BallScene {
        frames: 3,
        ..BallScene::default()
    };
    check(
        &ball.generate(42).unwrap(),
        &[[143.90500520881398, 49.51167591996116, 20.0, 20.0]],
        23150936,
    );
    let bouncing = BallScene {
        frames: 3,
        ..BallScene::bouncing()
    };
    check(
        &bouncing.generate(42).unwrap(),
        &[[132.20064124933884, 26.935922877856484, 20.0, 20.0]],
        23150970,
    );
    let road = RoadScene {
        frames: 3,
        ..RoadScene::default()
    };
    check(
        &road.generate(42).unwrap(),
        &[[51.62, 80.5, 24.0, 32.0]],
        10466758,
    );
    let webcam = WebcamScene {
        frames: 3,
        ..WebcamScene::entering()
    };
    check(
        &webcam.generate(42).unwrap(),
        &[
            [218.51906970672525, 54.04119430046191, 40.0, 52.0],
            [321.0, 115.39451107606789, 31.0, 43.0],
        ],
        42717219,
    );
    let affine = AffineScene {
        frames: 3,
        ..AffineScene::default()
    };
    let a = affine.generate(42).unwrap();
    check(
        &a,
        &[[
            131.49755435010775,
            85.00811511580568,
            63.51254140237853,
            66.1071056760104,
        ]],
        7000858,
    );
    let p = a.truth[2].affine.unwrap().points.points[0];
    assert!((p[0] - 146.72442940410227).abs() < 1e-9 && (p[1] - 115.94615502090869).abs() < 1e-9);
}
