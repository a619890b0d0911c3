//! The stress set renders what it says: determinism, ground truth that
//! matches the pixels, and each stress present.

use bayestrack_image::Image;

use super::plan::overlap;
use super::*;

fn frames(scene: &StressScene, seed: u64, hide: bool) -> Vec<(Image<u8>, FrameTruth)> {
    let mut s = scene.stream(seed).unwrap();
    s.hide_target = hide;
    std::iter::from_fn(|| s.next_frame().map(|f| (f.image, f.truth))).collect()
}

fn short(stress: Stress, colour: bool) -> StressScene {
    StressScene {
        frames: 40,
        ..StressScene::new(stress, colour)
    }
}

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    for stress in Stress::ALL {
        let scene = short(stress, true);
        let a = frames(&scene, 3, false);
        let b = frames(&scene, 3, false);
        let c = frames(&scene, 4, false);
        assert_eq!(a.len(), 40);
        for ((fa, ta), (fb, tb)) in a.iter().zip(&b) {
            assert_eq!(fa.as_slice(), fb.as_slice(), "{}", scene.name());
            assert_eq!(ta, tb);
        }
        assert!(
            a.iter()
                .zip(&c)
                .all(|(x, y)| x.0.as_slice() != y.0.as_slice()),
            "{}: seeds 3 and 4 render a frame alike",
            scene.name()
        );
    }
}

#[test]
fn the_gray_variant_is_the_colour_frame_converted() {
    for stress in [Stress::Mixed, Stress::Illumination] {
        let quiet = |colour| StressScene {
            noise_sigma: 0.0,
            ..short(stress, colour)
        };
        let rgb = frames(&quiet(true), 9, false);
        let gray = frames(&quiet(false), 9, false);
        for ((c, tc), (g, tg)) in rgb.iter().zip(&gray) {
            assert_eq!((g.channels(), c.channels()), (1, 3));
            let converted = bayestrack_image::rgb_to_gray(c.view()).unwrap();
            assert_eq!(converted.as_slice(), g.as_slice());
            assert_eq!(tc, tg);
        }
    }
}

/// Bounding box (0-based inclusive pixels) of the pixels that differ
/// between two frames, if any.
fn changed(a: &Image<u8>, b: &Image<u8>) -> Option<[usize; 4]> {
    let ch = a.channels();
    let mut bb: Option<[usize; 4]> = None;
    for (i, (x, y)) in a.as_slice().iter().zip(b.as_slice()).enumerate() {
        if x != y {
            let (px, py) = ((i / ch) % WIDTH, (i / ch) / WIDTH);
            bb = Some(match bb {
                None => [px, py, px, py],
                Some(r) => [r[0].min(px), r[1].min(py), r[2].max(px), r[3].max(py)],
            });
        }
    }
    bb
}

/// Every pixel that the target changes lies inside its ground-truth box
/// (OTB box: 1-based inclusive pixels `x ..= x + w - 1`, widened by the
/// one partly covered pixel on each side), and where the target is fully
/// visible the changed pixels span the box to within 2 px: the box is
/// where the target is drawn.
#[test]
fn the_ground_truth_box_is_where_the_target_is_drawn() {
    for stress in Stress::ALL {
        for colour in [true, false] {
            let scene = short(stress, colour);
            let with = frames(&scene, 5, false);
            let without = frames(&scene, 5, true);
            for ((f, t), (g, _)) in with.iter().zip(&without) {
                let target = t.target().unwrap();
                let b = target.bbox;
                // 0-based continuous extent of the box
                let (x0, y0) = (b.x - 1.5, b.y - 1.5);
                let (x1, y1) = (x0 + b.width, y0 + b.height);
                match changed(f, g) {
                    None => assert!(
                        target.visible_fraction < 0.01,
                        "{} frame {}: nothing drawn, visible {}",
                        scene.name(),
                        t.index,
                        target.visible_fraction
                    ),
                    Some(r) => {
                        let name = scene.name();
                        let k = t.index;
                        assert!(
                            r[0] as f64 >= x0 - 0.5
                                && r[1] as f64 >= y0 - 0.5
                                && r[2] as f64 <= x1 + 0.5
                                && r[3] as f64 <= y1 + 0.5,
                            "{name} frame {k}: changed {r:?} outside [{x0}, {y0}, {x1}, {y1}]"
                        );
                        if target.visible_fraction > 0.999 {
                            let tight = (r[0] as f64 - (x0 + 0.5)).abs().max(
                                (r[1] as f64 - (y0 + 0.5))
                                    .abs()
                                    .max((r[2] as f64 - (x1 - 0.5)).abs())
                                    .max((r[3] as f64 - (y1 - 0.5)).abs()),
                            );
                            assert!(
                                tight <= 2.0,
                                "{name} frame {k}: changed {r:?}, box [{x0}, {y0}, {x1}, {y1}]"
                            );
                        }
                    }
                }
            }
        }
    }
}

fn full_plan(stress: Stress) -> Vec<FramePlan> {
    StressScene::new(stress, true).plan(1).unwrap()
}

#[test]
fn full_occlusion_hides_the_target_then_it_reappears() {
    let plan = full_plan(Stress::FullOcclusion);
    let hidden: Vec<usize> = (0..plan.len())
        .filter(|&k| plan[k].visible_fraction == 0.0)
        .collect();
    // one run of hidden frames, about 25 of 120, in the middle
    assert!((20..=30).contains(&hidden.len()), "{hidden:?}");
    assert_eq!(hidden.last().unwrap() - hidden[0] + 1, hidden.len());
    assert!(hidden[0] > 30 && *hidden.last().unwrap() < 90, "{hidden:?}");
    assert_eq!(plan[0].visible_fraction, 1.0);
    assert_eq!(plan[plan.len() - 1].visible_fraction, 1.0);
    // and the pixels agree: in a hidden frame the target changes nothing
    let scene = StressScene::new(Stress::FullOcclusion, true);
    let k = hidden[hidden.len() / 2];
    let mut with = scene.stream(1).unwrap();
    let mut without = scene.stream(1).unwrap();
    without.hide_target = true;
    for _ in 0..k {
        with.skip_frame();
        without.skip_frame();
    }
    let (a, b) = (with.next_frame().unwrap(), without.next_frame().unwrap());
    assert_eq!(a.truth.index, k);
    assert!(a.truth.target().unwrap().is_hidden());
    assert_eq!(a.image.as_slice(), b.image.as_slice());
}

#[test]
fn partial_occlusion_covers_up_to_about_half_never_all() {
    let plan = full_plan(Stress::PartialOcclusion);
    let vis: Vec<f64> = plan.iter().map(|p| p.visible_fraction).collect();
    let min = vis.iter().copied().fold(1.0, f64::min);
    assert!((0.35..=0.6).contains(&min), "least visible {min}");
    let partial = vis.iter().filter(|&&v| v < 0.95).count();
    assert!(partial >= 30, "{partial} partly hidden frames");
    assert_eq!(vis[0], 1.0);
}

#[test]
fn scale_reaches_half_and_double_smoothly() {
    let plan = full_plan(Stress::Scale);
    let s: Vec<f64> = plan.iter().map(|p| p.scale).collect();
    let (lo, hi) = (
        s.iter().copied().fold(f64::INFINITY, f64::min),
        s.iter().copied().fold(0.0, f64::max),
    );
    assert!((0.5..=0.501).contains(&lo), "{lo}");
    assert!((1.998..=2.0).contains(&hi), "{hi}");
    assert_eq!(s[0], 1.0);
    let step = s
        .windows(2)
        .map(|w| (w[1] / w[0]).ln().abs())
        .fold(0.0, f64::max);
    assert!(step < 0.04, "largest change per frame {step}");
    // the box follows the scale
    for p in &plan {
        let w = p.target[2] - p.target[0];
        assert!((w - TARGET_SIZE[0] * p.scale).abs() < 1e-9);
    }
}

#[test]
fn fast_motion_moves_12_to_24_px_a_frame_inside_the_frame() {
    let plan = full_plan(Stress::FastMotion);
    let centre = |p: &FramePlan| {
        [
            (p.target[0] + p.target[2]) / 2.0,
            (p.target[1] + p.target[3]) / 2.0,
        ]
    };
    let d: Vec<f64> = plan
        .windows(2)
        .map(|w| {
            let (a, b) = (centre(&w[0]), centre(&w[1]));
            (a[0] - b[0]).hypot(a[1] - b[1])
        })
        .collect();
    let mut sorted = d.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(median >= 10.0, "median step {median}");
    assert!(sorted[sorted.len() - 1] <= 24.0 + 1e-9);
    assert!(sorted[sorted.len() - 1] >= 20.0);
    assert!(plan.iter().all(|p| p.visible_fraction == 1.0));
}

#[test]
fn illumination_ramps_and_the_shadow_crosses_the_target() {
    let plan = full_plan(Stress::Illumination);
    let gains: Vec<f64> = plan.iter().map(|p| p.gain).collect();
    let lo = gains.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = gains.iter().copied().fold(0.0, f64::max);
    assert!(lo <= 0.51 && hi >= 1.49, "{lo} {hi}");
    let shaded = plan
        .iter()
        .filter(|p| {
            let s = p.shadow.unwrap();
            let c = [
                (p.target[0] + p.target[2]) / 2.0,
                (p.target[1] + p.target[3]) / 2.0,
            ];
            s.gain_at(c[0], c[1]) <= 0.36
        })
        .count();
    assert!(
        shaded >= 5,
        "{shaded} frames with the target's centre in full shadow"
    );
}

#[test]
fn clutter_distractors_share_the_colour_and_one_passes_the_target() {
    let plan = full_plan(Stress::Clutter);
    assert!(plan.iter().all(|p| p.distractors.len() == 4));
    let near = plan
        .iter()
        .filter(|p| overlap(p.target, p.distractors[0]) > 0.25 * 36.0 * 44.0)
        .count();
    assert!(
        near >= 3,
        "{near} frames where distractor 0 overlaps the target"
    );
    // mean colour of each distractor's pixels against the target's (no
    // noise, no occlusion: the texture's own statistics)
    let scene = StressScene {
        noise_sigma: 0.0,
        ..StressScene::new(Stress::Clutter, true)
    };
    let f = scene.stream(2).unwrap().next_frame().unwrap();
    let mean = |id: usize| {
        let b = f.truth.object(id).unwrap().bbox;
        let (x0, y0) = ((b.x + 1.0) as usize - 1, (b.y + 1.0) as usize - 1);
        let mut sum = [0.0; 3];
        let mut n = 0.0;
        for y in y0..y0 + 40 {
            for x in x0..x0 + 32 {
                if let Some(px) = f.image.pixel(x, y) {
                    for c in 0..3 {
                        sum[c] += f64::from(px[c]);
                    }
                    n += 1.0;
                }
            }
        }
        sum.map(|s| s / n)
    };
    let t = mean(0);
    for id in 2..=4 {
        let d = mean(id);
        for c in 0..3 {
            assert!(
                (t[c] - d[c]).abs() < 25.0,
                "distractor {id}: {d:?} vs target {t:?}"
            );
        }
    }
}

#[test]
fn mixed_has_scale_occlusion_light_and_distractors() {
    let plan = full_plan(Stress::Mixed);
    let s = plan.iter().map(|p| p.scale);
    let (lo, hi) = s.fold((f64::INFINITY, 0.0_f64), |(a, b), v| (a.min(v), b.max(v)));
    assert!(lo < 0.75 && hi > 1.35, "{lo} {hi}");
    assert!(plan.iter().any(|p| p.visible_fraction < 0.8));
    assert!(plan.iter().any(|p| p.gain < 0.65));
    assert!(plan.iter().all(|p| p.distractors.len() == 2));
}

/// The target's look in its own box: the mean gray level of each cell of
/// a 6x7 grid over the box (the pixels whose centre falls in the cell),
/// noise-free.
fn appearance(stress: Stress, seed: u64) -> Vec<Vec<f64>> {
    let scene = StressScene {
        noise_sigma: 0.0,
        ..StressScene::new(stress, false)
    };
    frames(&scene, seed, false)
        .iter()
        .map(|(f, t)| {
            let b = t.target().unwrap().bbox;
            let (x0, y0) = (b.x - 1.5, b.y - 1.5);
            let mut sum = vec![0.0; 42];
            let mut n = vec![0.0; 42];
            for y in (y0.ceil() as usize)..=((y0 + b.height).floor() as usize) {
                for x in (x0.ceil() as usize)..=((x0 + b.width).floor() as usize) {
                    let i = ((x as f64 - x0) / b.width * 6.0) as usize;
                    let j = ((y as f64 - y0) / b.height * 7.0) as usize;
                    if let (true, true, Some(px)) = (i < 6, j < 7, f.pixel(x, y)) {
                        sum[j * 6 + i] += f64::from(px[0]);
                        n[j * 6 + i] += 1.0;
                    }
                }
            }
            sum.iter().zip(&n).map(|(s, n)| s / n).collect()
        })
        .collect()
}

/// Normalised cross-correlation of two samples.
fn ncc(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    ab / (aa * bb).sqrt()
}

/// The two appearance stresses change what the target looks like in its
/// own box (its first frame's look correlates below 0.6 with some later
/// frame's; seeds 1 and 2 measured 0.33 and 0.49 for deformation, 0.34
/// and 0.11 out of plane), where a rigid target that only moves and
/// scales keeps it (above 0.85 in every frame of `scale`, between 0.5x
/// and 2x: 0.93 and 0.90).
#[test]
fn deformation_and_out_of_plane_change_the_targets_look_rigid_stresses_do_not() {
    for seed in [1, 2] {
        let least = |stress| {
            let look = appearance(stress, seed);
            look.iter().map(|v| ncc(&look[0], v)).fold(1.0, f64::min)
        };
        let rigid = least(Stress::Scale);
        assert!(rigid > 0.85, "scale, seed {seed}: {rigid}");
        for stress in [Stress::Deformation, Stress::OutOfPlane] {
            let changed = least(stress);
            assert!(changed < 0.6, "{}, seed {seed}: {changed}", stress.name());
        }
    }
}

#[test]
fn deformation_swings_the_aspect_and_warps_inside_the_box() {
    let plan = full_plan(Stress::Deformation);
    let aspect: Vec<f64> = plan
        .iter()
        .map(|p| {
            let (w, h) = (p.target[2] - p.target[0], p.target[3] - p.target[1]);
            ((w / h) / (TARGET_SIZE[0] / TARGET_SIZE[1])).sqrt()
        })
        .collect();
    let (lo, hi) = aspect
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(lo < 0.77 && hi > 1.31, "aspect {lo} .. {hi}");
    let step = aspect
        .windows(2)
        .map(|w| (w[1] / w[0]).ln().abs())
        .fold(0.0, f64::max);
    assert!(step < 0.05, "largest change of the aspect per frame {step}");
    for p in &plan {
        // the area is kept: the box is the target's at scale 1
        let area = (p.target[2] - p.target[0]) * (p.target[3] - p.target[1]);
        assert!((area - TARGET_SIZE[0] * TARGET_SIZE[1]).abs() < 1e-9);
        assert!(matches!(p.look, Look::Warp { amplitude, .. } if amplitude == 3.0));
        assert_eq!(p.visible_fraction, 1.0);
    }
}

#[test]
fn out_of_plane_turns_80_degrees_either_way_in_a_fixed_box() {
    let plan = full_plan(Stress::OutOfPlane);
    let angle: Vec<f64> = plan
        .iter()
        .map(|p| match p.look {
            Look::Turn { angle } => angle.to_degrees(),
            _ => panic!("not turning"),
        })
        .collect();
    let (lo, hi) = angle
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    assert!(lo < -79.9 && hi > 79.9, "{lo} .. {hi}");
    assert_eq!(angle[0], 0.0);
    let step = angle
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0, f64::max);
    assert!(step < 7.0, "largest turn per frame {step} degrees");
    for p in &plan {
        assert!((p.target[2] - p.target[0] - TARGET_SIZE[0]).abs() < 1e-9);
        assert!((p.target[3] - p.target[1] - TARGET_SIZE[1]).abs() < 1e-9);
        assert_eq!(p.visible_fraction, 1.0);
    }
}

#[test]
fn bad_parameters_are_errors() {
    let bad = StressScene {
        frames: 5,
        ..StressScene::new(Stress::Scale, true)
    };
    assert!(matches!(
        bad.stream(1),
        Err(SceneError::InvalidParameter { name: "frames", .. })
    ));
    let bad = StressScene {
        noise_sigma: f64::NAN,
        ..StressScene::new(Stress::Scale, true)
    };
    assert!(bad.plan(1).is_err());
}

#[test]
fn names_round_trip() {
    for s in Stress::ALL {
        assert_eq!(Stress::of_sequence(s.sequence_name(true)), Some((s, true)));
        assert_eq!(
            Stress::of_sequence(s.sequence_name(false)),
            Some((s, false))
        );
    }
    assert_eq!(default_set(None).len(), 18);
}

#[test]
fn the_set_is_written_once_rewritten_when_changed_and_foreign_folders_refused() {
    let dir = std::env::temp_dir().join(format!("bayestrack-stress-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let set = vec![
        StressScene {
            frames: 12,
            ..StressScene::new(Stress::Scale, true)
        },
        StressScene {
            frames: 12,
            ..StressScene::new(Stress::Clutter, false)
        },
    ];
    let first = write_set(&set, 1, &dir).unwrap();
    assert_eq!(first.written, ["scale", "clutter-gray"]);
    let seq = bayestrack_otb::Sequence::open(dir.join("scale")).unwrap();
    assert_eq!(seq.len(), 12);
    let again = write_set(&set, 1, &dir).unwrap();
    assert_eq!(again.kept, ["scale", "clutter-gray"]);
    // an edited ground truth is put back
    let gt = dir.join("scale/groundtruth_rect.txt");
    let original = std::fs::read(&gt).unwrap();
    std::fs::write(&gt, "1,1,1,1\n").unwrap();
    let fixed = write_set(&set, 1, &dir).unwrap();
    assert_eq!(fixed.rewritten, ["scale"]);
    assert_eq!(fixed.kept, ["clutter-gray"]);
    assert_eq!(std::fs::read(&gt).unwrap(), original);
    // another seed rewrites both; a smaller set removes the other folder
    let other = write_set(&set[..1], 2, &dir).unwrap();
    assert_eq!(other.rewritten, ["scale"]);
    assert_eq!(other.removed, ["clutter-gray"]);
    assert!(!dir.join("clutter-gray").exists());
    // a sequence folder the set did not write is refused, and kept
    std::fs::create_dir_all(dir.join("mine/img")).unwrap();
    let err = write_set(&set, 1, &dir).unwrap_err().to_string();
    assert!(
        err.contains("did not write") && err.contains("mine"),
        "{err}"
    );
    assert!(dir.join("mine/img").is_dir());
    std::fs::remove_dir_all(&dir).unwrap();
}
