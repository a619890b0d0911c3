//! The synthetic scenes: deterministic per seed, different across seeds, and
//! ground truth that matches what is rendered.

use bayestrack_experiments::scenes::{
    AffineScene, BallMotion, BallScene, Car, JumpKind, RoadScene, Scene, SceneError, SceneStream,
    SkinShape, TEMPLATE_POINTS, Visibility, WebcamScene, otb_box,
};
use bayestrack_image::{Affine2, Border, Image, Rgb, warp};

fn assert_same(a: &Scene, b: &Scene) {
    assert_eq!(a.len(), b.len());
    assert_eq!(a.truth, b.truth);
    for (i, (x, y)) in a.frames.iter().zip(&b.frames).enumerate() {
        assert!(
            x == y,
            "frame {i} differs between two runs with the same seed"
        );
    }
}

fn assert_differs(a: &Scene, b: &Scene) {
    assert!(
        a.frames.iter().zip(&b.frames).any(|(x, y)| x != y),
        "two seeds gave the same frames"
    );
}

fn px(img: &Image<u8>, x: usize, y: usize) -> &[u8] {
    img.pixel(x, y).expect("pixel inside the frame")
}

#[test]
fn ball_is_deterministic_and_seed_dependent() {
    let p = BallScene {
        frames: 12,
        motion_noise: 0.3,
        ..BallScene::default()
    };
    let a = p.generate(11).unwrap();
    assert_same(&a, &p.generate(11).unwrap());
    assert_differs(&a, &p.generate(12).unwrap());
    assert_eq!(a.info.fps, 22.0);
    assert_eq!((a.frames[0].width(), a.frames[0].height()), (200, 160));
    assert_eq!(a.frames[0].channels(), 3);
}

#[test]
fn ball_pixels_are_dark_inside_its_box_and_bright_outside() {
    for motion in [BallMotion::Linear, BallMotion::Bouncing] {
        let p = BallScene {
            frames: 25,
            motion,
            ..BallScene::default()
        };
        let s = p.generate(3).unwrap();
        for (img, t) in s.frames.iter().zip(&s.truth) {
            let ball = t.target().unwrap();
            assert_eq!(ball.visibility(), Visibility::Full);
            let [cx, cy] = ball.center0();
            let r = ball.bbox.width / 2.0;
            assert_eq!(r, 10.0);
            // The box lies inside the frame.
            assert!(ball.bbox.x >= 1.0 && ball.bbox.y >= 1.0);
            assert!(ball.bbox.x + ball.bbox.width - 1.0 <= 200.0);
            assert!(ball.bbox.y + ball.bbox.height - 1.0 <= 160.0);
            let (mut dark, mut inside) = (0, 0);
            for y in 0..160 {
                for x in 0..200 {
                    let d = (x as f64 - cx).hypot(y as f64 - cy);
                    let v = px(img, x, y);
                    if d < r - 1.0 {
                        inside += 1;
                        if v.iter().all(|&c| c < 60) {
                            dark += 1;
                        }
                    } else if d > r + 1.0 {
                        assert!(
                            v.iter().all(|&c| c > 170),
                            "{motion:?} frame {}: bright screen expected at ({x}, {y}), got {v:?}",
                            t.index
                        );
                    }
                }
            }
            assert_eq!(
                dark, inside,
                "frame {}: every pixel inside the ball is dark",
                t.index
            );
        }
    }
}

#[test]
fn ball_motion_follows_its_model() {
    // Linear: constant velocity of 3 px/frame between bounces.
    let s = BallScene {
        frames: 60,
        sensor_noise: 0.0,
        ..BallScene::default()
    }
    .generate(5)
    .unwrap();
    let c: Vec<[f64; 2]> = s
        .truth
        .iter()
        .map(|t| t.target().unwrap().center0())
        .collect();
    let mut straight = 0;
    for k in 1..c.len() - 1 {
        let v1 = [c[k][0] - c[k - 1][0], c[k][1] - c[k - 1][1]];
        let v2 = [c[k + 1][0] - c[k][0], c[k + 1][1] - c[k][1]];
        if !s.truth[k].bounce && !s.truth[k + 1].bounce {
            assert!((v1[0].hypot(v1[1]) - 3.0).abs() < 1e-9);
            assert!((v1[0] - v2[0]).abs() < 1e-9 && (v1[1] - v2[1]).abs() < 1e-9);
            straight += 1;
        }
    }
    assert!(straight > 30);
    // Bouncing: the vertical velocity grows by the gravity every frame.
    let b = BallScene {
        frames: 60,
        ..BallScene::bouncing()
    }
    .generate(5)
    .unwrap();
    let y: Vec<f64> = b
        .truth
        .iter()
        .map(|t| t.target().unwrap().center0()[1])
        .collect();
    let mut checked = 0;
    for k in 1..y.len() - 1 {
        if !b.truth[k].bounce && !b.truth[k + 1].bounce {
            let acc = y[k + 1] - 2.0 * y[k] + y[k - 1];
            assert!((acc - 0.25).abs() < 1e-9, "frame {k}: {acc}");
            checked += 1;
        }
    }
    assert!(checked > 30);
    assert!(
        b.truth.iter().any(|t| t.bounce),
        "the ball bounces within 60 frames"
    );
}

#[test]
fn ball_illumination_drift_darkens_the_screen() {
    let p = BallScene {
        frames: 2,
        fps: 1.0,
        drift_period: 2.0, // frame 1 is at the darkest point
        illumination_drift: 0.3,
        sensor_noise: 0.0,
        ..BallScene::default()
    };
    let s = p.generate(1).unwrap();
    assert_eq!(s.truth[0].gain, 1.0);
    assert!((s.truth[1].gain - 0.7).abs() < 1e-12);
    // A screen pixel far from the ball.
    let corner = |k: usize| {
        let [cx, _] = s.truth[k].target().unwrap().center0();
        let x = if cx > 100.0 { 2 } else { 197 };
        px(&s.frames[k], x, 2)[0]
    };
    assert_eq!(corner(0), 245);
    assert!(corner(1).abs_diff(172) <= 1, "{}", corner(1));
}

#[test]
fn skipping_frames_does_not_change_the_others() {
    let p = BallScene {
        frames: 8,
        ..BallScene::default()
    };
    let all = p.generate(9).unwrap();
    let mut s = p.stream(9).unwrap();
    for k in 0..5 {
        assert_eq!(s.skip_frame().unwrap(), all.truth[k]);
    }
    let f = s.next_frame().unwrap();
    assert_eq!(f.truth, all.truth[5]);
    assert!(f.image == all.frames[5]);
    // Reusing a buffer of the wrong shape works too.
    let mut buf = Image::new(3, 3, 1, 0u8).unwrap();
    let t = s.next_into(&mut buf).unwrap();
    assert_eq!(t.index, 6);
    assert!(buf == all.frames[6]);
    assert!(s.next_into(&mut buf).is_some());
    assert!(s.next_into(&mut buf).is_none());
    assert!(s.skip_frame().is_none());
}

#[test]
fn road_billboard_hides_the_car_exactly_when_the_truth_says_so() {
    let p = RoadScene::default();
    let s = p.generate(4).unwrap();
    assert_eq!(s.len(), 28);
    assert_eq!(
        (s.info.width, s.info.height, s.info.channels),
        (320, 240, 1)
    );
    let vis: Vec<Visibility> = s
        .truth
        .iter()
        .map(|t| t.target().unwrap().visibility())
        .collect();
    for (k, v) in vis.iter().enumerate() {
        let want = match k {
            0..=3 | 21.. => Visibility::Full,
            10..=14 => Visibility::Hidden,
            _ => Visibility::Partial,
        };
        assert_eq!(*v, want, "frame {k}");
    }
    // Uniform linear motion: (2.56, 5) px per frame from (57, 85).
    for t in &s.truth {
        let [cx, cy] = t.target().unwrap().center0();
        assert!((cx - (57.0 + 2.56 * t.index as f64)).abs() < 1e-9);
        assert!((cy - (85.0 + 5.0 * t.index as f64)).abs() < 1e-9);
    }
    // The same scene with the car parked far outside the frame.
    let empty = RoadScene {
        cars: vec![Car {
            center: [-500.0, -500.0],
            velocity: [0.0, 0.0],
            ..p.cars[0]
        }],
        ..p.clone()
    }
    .generate(4)
    .unwrap();
    for (k, v) in vis.iter().enumerate() {
        let (with, without) = (&s.frames[k], &empty.frames[k]);
        match v {
            Visibility::Hidden => assert!(with == without, "frame {k}: a hidden car shows"),
            _ => {
                // Every changed pixel lies in the car's box, and the car shows.
                let b = s.truth[k].target().unwrap().bbox;
                let mut changed = 0;
                for y in 0..240 {
                    for x in 0..320 {
                        if with.get(x, y, 0) != without.get(x, y, 0) {
                            changed += 1;
                            let (fx, fy) = (x as f64 + 1.0, y as f64 + 1.0);
                            assert!(
                                fx >= b.x.floor()
                                    && fx <= (b.x + b.width).ceil()
                                    && fy >= b.y.floor()
                                    && fy <= (b.y + b.height).ceil(),
                                "frame {k}: pixel ({x}, {y}) changed outside the box {b:?}"
                            );
                        }
                    }
                }
                assert!(changed > 50, "frame {k}: only {changed} car pixels");
            }
        }
    }
}

#[test]
fn road_two_cars_stand_out_from_the_background() {
    let p = RoadScene::two_cars();
    let s = p.generate(8).unwrap();
    let bg = p.background(8).unwrap();
    assert_eq!(s.len(), 12);
    for (img, t) in s.frames.iter().zip(&s.truth) {
        assert_eq!(t.objects.len(), 2);
        let sizes: Vec<_> = t
            .objects
            .iter()
            .map(|o| (o.bbox.width, o.bbox.height))
            .collect();
        assert_eq!(sizes, [(34.0, 46.0), (29.0, 43.0)]);
        let mut fg_in_boxes = [0usize; 2];
        for y in 0..240 {
            for x in 0..320 {
                let d = img.get(x, y, 0).unwrap().abs_diff(bg.get(x, y, 0).unwrap());
                let (fx, fy) = (x as f64 + 1.0, y as f64 + 1.0);
                let inside = t.objects.iter().position(|o| {
                    let b = o.bbox;
                    fx >= b.x - 1.0
                        && fx <= b.x + b.width
                        && fy >= b.y - 1.0
                        && fy <= b.y + b.height
                });
                match inside {
                    Some(i) if d > 25 => fg_in_boxes[i] += 1,
                    Some(_) => {}
                    None => assert!(d <= 14, "frame {}: ({x}, {y}) differs by {d}", t.index),
                }
            }
        }
        for (i, n) in fg_in_boxes.iter().enumerate() {
            let b = t.objects[i].bbox;
            assert!(
                *n as f64 > 0.4 * b.width * b.height,
                "frame {}: car {i} has only {n} foreground pixels",
                t.index
            );
        }
    }
}

#[test]
fn road_is_deterministic_and_seed_dependent() {
    let p = RoadScene {
        frames: 4,
        ..RoadScene::default()
    };
    let a = p.generate(1).unwrap();
    assert_same(&a, &p.generate(1).unwrap());
    assert_differs(&a, &p.generate(2).unwrap());
}

fn is_skin(p: &[u8]) -> bool {
    let hsv = Rgb::new(p[0], p[1], p[2]).to_hsv();
    (0.02..0.12).contains(&hsv.h) && (0.25..0.6).contains(&hsv.s)
}

#[test]
fn webcam_target_is_skin_coloured_where_the_truth_puts_it() {
    let p = WebcamScene {
        frames: 20,
        ..WebcamScene::default()
    };
    let s = p.generate(21).unwrap();
    assert_same(&s, &p.generate(21).unwrap());
    assert_differs(&s, &p.generate(22).unwrap());
    for (img, t) in s.frames.iter().zip(&s.truth) {
        let face = t.target().unwrap();
        assert_eq!(face.label, "face");
        assert_eq!((face.bbox.width, face.bbox.height), (40.0, 52.0));
        assert_eq!(face.visibility(), Visibility::Full);
        let [cx, cy] = face.center0();
        // Plain skin between the eyes and the mouth, and on the cheeks.
        for (dx, dy) in [(0.0, 3.0), (-12.0, 4.0), (12.0, 4.0), (0.0, -18.0)] {
            let (x, y) = ((cx + dx).round() as usize, (cy + dy).round() as usize);
            assert!(
                is_skin(px(img, x, y)),
                "frame {} ({x}, {y}): {:?}",
                t.index,
                px(img, x, y)
            );
        }
    }
    // The face moves (IFD sees it) and the moving distractors are not skin.
    let c0 = s.truth[0].target().unwrap().center0();
    let c1 = s.truth[19].target().unwrap().center0();
    assert!((c0[0] - c1[0]).hypot(c0[1] - c1[1]) > 5.0);
}

#[test]
fn webcam_static_skin_distractors_exist_and_do_not_move() {
    let p = WebcamScene {
        frames: 6,
        moving_distractors: 0,
        sensor_noise: 0.0,
        ..WebcamScene::default()
    };
    let s = p.generate(5).unwrap();
    let (a, b) = (&s.frames[0], &s.frames[5]);
    let boxes: Vec<_> = [&s.truth[0], &s.truth[5]]
        .iter()
        .map(|t| t.target().unwrap().bbox)
        .collect();
    let near_face = |x: usize, y: usize| {
        boxes.iter().any(|b| {
            let (fx, fy) = (x as f64 + 1.0, y as f64 + 1.0);
            fx >= b.x - 2.0
                && fx <= b.x + b.width + 1.0
                && fy >= b.y - 2.0
                && fy <= b.y + b.height + 1.0
        })
    };
    let mut skin_elsewhere = 0;
    for y in 0..240 {
        for x in 0..320 {
            if near_face(x, y) {
                continue;
            }
            assert_eq!(
                px(a, x, y),
                px(b, x, y),
                "({x}, {y}) changed away from the face"
            );
            if is_skin(px(a, x, y)) {
                skin_elsewhere += 1;
            }
        }
    }
    assert!(
        skin_elsewhere > 300,
        "static skin distractors: {skin_elsewhere} px"
    );
}

#[test]
fn webcam_object_enters_through_the_border() {
    let p = WebcamScene::entering();
    let mut s = p.stream(2).unwrap();
    let truth: Vec<_> = std::iter::from_fn(|| s.skip_frame()).collect();
    assert_eq!(truth.len(), 120);
    for t in &truth {
        let hand = t.object(1).unwrap();
        assert_eq!(hand.label, "hand");
        match t.index {
            0..=30 => assert_eq!(hand.visibility(), Visibility::Hidden, "frame {}", t.index),
            31..=35 => assert_eq!(hand.visibility(), Visibility::Partial, "frame {}", t.index),
            60.. => assert!(hand.visible_fraction > 0.5, "frame {}", t.index),
            _ => {}
        }
    }
    // Rendering agrees: frame 31 shows the first skin pixels at the border.
    let full = WebcamScene { frames: 40, ..p }.generate(2).unwrap();
    let hand = full.truth[38].object(1).unwrap();
    let [hx, hy] = hand.center0();
    // The palm's centre is 2.5 px left of and 6.5 px below the box centre.
    let (x, y) = ((hx - 2.5).round() as usize, (hy + 6.5).round() as usize);
    assert!(
        is_skin(px(&full.frames[38], x, y)),
        "palm centre at ({x}, {y})"
    );
    // What groundtruth_rect.1.txt holds: unlabelled until the hand meets the frame.
    let boxes = full.boxes(1);
    assert!(boxes[..=30].iter().all(Option::is_none));
    assert!(boxes[31..].iter().all(Option::is_some));
    assert!(full.boxes(0).iter().all(Option::is_some));
}

#[test]
fn webcam_hand_target_is_skin_at_the_palm() {
    let p = WebcamScene {
        frames: 5,
        target: SkinShape::Hand,
        ..WebcamScene::default()
    };
    let s = p.generate(30).unwrap();
    for (img, t) in s.frames.iter().zip(&s.truth) {
        let hand = t.target().unwrap();
        assert_eq!(
            (hand.label, hand.bbox.width, hand.bbox.height),
            ("hand", 31.0, 43.0)
        );
        let [hx, hy] = hand.center0();
        for (dx, dy) in [(-2.5, 6.5), (-8.5, 10.0), (3.5, 12.0)] {
            let (x, y) = ((hx + dx).round() as usize, (hy + dy).round() as usize);
            assert!(is_skin(px(img, x, y)), "frame {} ({x}, {y})", t.index);
        }
    }
}

#[test]
fn webcam_crossing_objects_occlude_each_other() {
    let p = WebcamScene::crossing();
    let s = p.generate(6).unwrap();
    let mid = &s.truth[45];
    let (face, hand) = (mid.object(0).unwrap(), mid.object(1).unwrap());
    // Face centre and palm centre (2.5 px left of the hand's box centre) align.
    assert!((face.center0()[0] - (hand.center0()[0] - 2.5)).abs() < 1e-9);
    assert_eq!(face.visibility(), Visibility::Partial);
    assert_eq!(hand.visibility(), Visibility::Full, "the hand is in front");
    assert!(face.visible_fraction < 0.8);
    assert_eq!(s.truth[0].object(0).unwrap().visibility(), Visibility::Full);
    assert_eq!(
        s.truth[89].object(0).unwrap().visibility(),
        Visibility::Full
    );
    // Target moves right, the other left.
    let d0 =
        s.truth[10].object(0).unwrap().center0()[0] - s.truth[0].object(0).unwrap().center0()[0];
    let d1 =
        s.truth[10].object(1).unwrap().center0()[0] - s.truth[0].object(1).unwrap().center0()[0];
    assert!(d0 > 20.0 && d1 < -20.0);
}

#[test]
fn affine_points_are_the_pose_applied_to_the_template() {
    let p = AffineScene {
        frames: 45,
        ..AffineScene::default()
    };
    let s = p.generate(17).unwrap();
    assert_same(&s, &p.generate(17).unwrap());
    assert_differs(&s, &p.generate(18).unwrap());
    let tpl = p.template_points();
    for (i, t) in tpl.iter().enumerate() {
        assert_eq!(t[0], TEMPLATE_POINTS[i][0] * 48.0);
        assert_eq!(t[1], TEMPLATE_POINTS[i][1] * 56.0);
    }
    let mut jumps = Vec::new();
    for t in &s.truth {
        let a = t.affine.unwrap();
        let m = a.matrix;
        assert_eq!(m[2], [0.0, 0.0, 1.0]);
        for (q, p0) in a.points.points.iter().zip(&tpl) {
            let x = m[0][0] * p0[0] + m[0][1] * p0[1] + m[0][2];
            let y = m[1][0] * p0[0] + m[1][1] * p0[1] + m[1][2];
            assert!((q[0] - x).abs() < 1e-9 && (q[1] - y).abs() < 1e-9);
        }
        assert_eq!(a.points.center, [m[0][2], m[1][2]]);
        // The OTB box is centred on the pose's centre.
        let b = t.target().unwrap().center0();
        assert!((b[0] - m[0][2]).abs() < 1e-9 && (b[1] - m[1][2]).abs() < 1e-9);
        if a.jump {
            jumps.push(t.index);
            assert_eq!(a.blur, 10.0);
        }
    }
    assert_eq!(jumps, [20, 40]);
    // A jump moves the centre much further than the smooth drift.
    let step = |k: usize| {
        let (a, b) = (s.truth[k - 1].affine.unwrap(), s.truth[k].affine.unwrap());
        (a.points.center[0] - b.points.center[0]).hypot(a.points.center[1] - b.points.center[1])
    };
    assert!(
        step(20) > 15.0 && step(21) < 6.0,
        "{} {}",
        step(20),
        step(21)
    );
}

/// A shake offsets the view from the smooth path by at most `jump_size`
/// and is replaced, not accumulated; a teleport accumulates. Both blur in
/// proportion to the move.
#[test]
fn affine_shakes_stay_near_the_path_and_teleports_accumulate() {
    let base = AffineScene {
        frames: 60,
        jump_every: 0,
        ..AffineScene::default()
    };
    let with = |kind: JumpKind| AffineScene {
        jump_every: 1,
        jump_size: 12.0,
        jump_blur: 4.0,
        jump_kind: kind,
        ..base.clone()
    };
    let centres = |p: &AffineScene| -> Vec<[f64; 2]> {
        let s = p.generate(5).unwrap();
        s.truth
            .iter()
            .map(|t| t.affine.unwrap().points.center)
            .collect()
    };
    let path = centres(&base);
    let shake = with(JumpKind::Shake).generate(5).unwrap();
    let mut farthest = 0.0f64;
    for (k, t) in shake.truth.iter().enumerate() {
        let a = t.affine.unwrap();
        let off = (a.points.center[0] - path[k][0]).hypot(a.points.center[1] - path[k][1]);
        assert!(off <= 12.0 + 1e-9, "frame {k}: {off} px from the path");
        farthest = farthest.max(off);
        if k > 0 {
            let prev = shake.truth[k - 1].affine.unwrap().points.center;
            let own = (path[k][0] - path[k - 1][0]).hypot(path[k][1] - path[k - 1][1]);
            let moved = (a.points.center[0] - prev[0]).hypot(a.points.center[1] - prev[1]);
            assert!(a.jump, "frame {k} shakes");
            // the blur is 4/12 of the shake's own move (within the drift)
            assert!(
                (a.blur - moved / 3.0).abs() <= own / 3.0 + 1e-9,
                "frame {k}: blur {} for a {moved} px move",
                a.blur
            );
        }
    }
    assert!(farthest > 9.0, "offsets fill the disc: {farthest}");
    let tele = centres(&with(JumpKind::Teleport));
    let far = tele
        .iter()
        .zip(&path)
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
        .fold(0.0f64, f64::max);
    assert!(far > 24.0, "teleports accumulate: {far} px at most");
}

#[test]
fn affine_patch_warped_back_through_the_true_pose_is_stable() {
    let p = AffineScene {
        frames: 24,
        sensor_noise: 1.0,
        ..AffineScene::default()
    };
    let s = p.generate(3).unwrap();
    // Patch pixel (u, v) -> template coordinates -> image through M.
    let patch = |k: usize, shift: f64| -> Vec<f32> {
        let a = s.truth[k].affine.unwrap();
        let m = Affine2::from_matrix3(a.matrix).unwrap();
        let to_template = Affine2::patch_to_rect(36, 36, -23.5, -27.5, 48.0, 56.0).unwrap();
        let m = Affine2::translation(shift, 0.0).compose(&m.compose(&to_template));
        let img = warp(s.frames[k].view(), &m, 36, 36, Border::Replicate).unwrap();
        let g = s.truth[k].gain as f32;
        img.as_slice().iter().map(|v| v / g).collect()
    };
    let mad = |a: &[f32], b: &[f32]| {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>() / a.len() as f32
    };
    let p0 = patch(0, 0.0);
    for k in 1..24 {
        if s.truth[k].affine.unwrap().blur > 0.0 {
            continue;
        }
        let same = mad(&p0, &patch(k, 0.0));
        let off = mad(&p0, &patch(k, 5.0));
        assert!(same < 9.0, "frame {k}: MAD {same} at the true pose");
        assert!(off > 2.0 * same, "frame {k}: MAD {off} 5 px off vs {same}");
    }
}

#[test]
fn invalid_parameters_are_errors_not_panics() {
    let bad = |r: Result<Scene, SceneError>| {
        assert!(
            matches!(r, Err(SceneError::InvalidParameter { .. })),
            "{r:?}"
        );
    };
    bad(BallScene {
        width: 0,
        ..BallScene::default()
    }
    .generate(0));
    bad(BallScene {
        frames: 0,
        ..BallScene::default()
    }
    .generate(0));
    bad(BallScene {
        radius: 100.0,
        ..BallScene::default()
    }
    .generate(0));
    bad(BallScene {
        fps: f64::NAN,
        ..BallScene::default()
    }
    .generate(0));
    bad(BallScene {
        sensor_noise: -1.0,
        ..BallScene::default()
    }
    .generate(0));
    bad(RoadScene {
        cars: vec![],
        ..RoadScene::default()
    }
    .generate(0));
    bad(RoadScene {
        billboard: Some(bayestrack_image::Rect::new(300, 200, 50, 50)),
        ..RoadScene::default()
    }
    .generate(0));
    bad(WebcamScene {
        width: 50,
        ..WebcamScene::default()
    }
    .generate(0));
    bad(AffineScene {
        template_size: [300.0, 300.0],
        ..AffineScene::default()
    }
    .generate(0));
    bad(AffineScene {
        rotation_period: 0.0,
        ..AffineScene::default()
    }
    .generate(0));
    let e = BallScene {
        radius: -1.0,
        ..BallScene::default()
    }
    .generate(0)
    .unwrap_err();
    assert!(e.to_string().contains("radius"), "{e}");
    // The OTB box helper used by every scene.
    assert_eq!(
        otb_box(-0.5, -0.5, 4.0, 4.0),
        bayestrack_image::BBox::new(1.0, 1.0, 4.0, 4.0)
    );
}
