//! The webcam scene's true outlines (`WebcamStream::outlines`) sit on the
//! boundary of what is rendered: skin just inside, wall just outside.

use bayestrack_experiments::scenes::{SceneStream, WebcamScene};
use bayestrack_image::Rgb;

fn is_skin(p: &[u8]) -> bool {
    let hsv = Rgb::new(p[0], p[1], p[2]).to_hsv();
    (0.02..0.12).contains(&hsv.h) && (0.25..0.6).contains(&hsv.s)
}

#[test]
fn the_face_outline_separates_skin_from_the_wall() {
    let p = WebcamScene {
        frames: 12,
        static_skin_distractors: 0,
        moving_distractors: 0,
        sensor_noise: 0.0,
        ..WebcamScene::default()
    };
    let mut stream = p.stream(5).unwrap();
    let mut checked = 0;
    while let Some(f) = stream.next_frame() {
        let outlines = stream.outlines(f.truth.index);
        assert_eq!(outlines.len(), f.truth.objects.len());
        let face = &f.truth.objects[0];
        let [cx, cy] = face.center0();
        let o = &outlines[0];
        // The polygon spans exactly the truth box.
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in o.points() {
            for a in 0..2 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        assert!((hi[0] - lo[0] - face.bbox.width).abs() < 0.01);
        assert!((hi[1] - lo[1] - face.bbox.height).abs() < 0.01);
        assert!(o.distance([cx, cy]) > 19.0);
        for (i, q) in o.points().enumerate().step_by(7) {
            let (dx, dy) = (q[0] - cx, q[1] - cy);
            let r = dx.hypot(dy);
            let at = |s: f64| {
                let (x, y) = (q[0] + s * dx / r, q[1] + s * dy / r);
                f.image
                    .pixel(x.round() as usize, y.round() as usize)
                    .unwrap()
                    .to_vec()
            };
            assert!(is_skin(&at(-2.0)), "frame {} point {i}", f.truth.index);
            assert!(!is_skin(&at(2.0)), "frame {} point {i}", f.truth.index);
            checked += 1;
        }
    }
    assert!(checked > 500);
}

#[test]
fn outlines_follow_the_objects_of_the_crossing_scene() {
    let p = WebcamScene::crossing();
    let mut stream = p.stream(3).unwrap();
    let first = stream.skip_frame().unwrap();
    let outlines = stream.outlines(0);
    assert_eq!(outlines.len(), 2);
    for (o, t) in outlines.iter().zip(&first.objects) {
        // Every vertex inside the object's box (0-based extent).
        let (x0, y0) = (t.bbox.x - 1.5, t.bbox.y - 1.5);
        for q in o.points() {
            assert!(q[0] >= x0 - 1e-9 && q[0] <= x0 + t.bbox.width + 1e-9);
            assert!(q[1] >= y0 - 1e-9 && q[1] <= y0 + t.bbox.height + 1e-9);
        }
    }
    // The hand (object 1) is several pieces: palm arcs, fingers, thumb.
    assert!(outlines[1].polylines.len() > 3);
    // Later frames move the outline by the same amount as the box.
    let later = stream.outlines(10);
    let t10 = std::iter::from_fn(|| stream.skip_frame())
        .find(|t| t.index == 10)
        .unwrap();
    let shift = t10.objects[0].bbox.x - first.objects[0].bbox.x;
    let a = outlines[0].points().next().unwrap();
    let b = later[0].points().next().unwrap();
    assert!((b[0] - a[0] - shift).abs() < 1e-9);
}
