//! The scene writer, read back through the OTB sequence loader.

use std::fs;
use std::path::PathBuf;

use bayestrack_experiments::scenes::{
    BallScene, RoadScene, SCENES, SceneError, named_stream, write_named_scene, write_scene,
};
use bayestrack_otb::Sequence;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "bayestrack-experiments-{name}-{}",
        std::process::id()
    ));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn written_scene_reads_back_as_an_otb_sequence() {
    let d = tmpdir("written");
    let p = RoadScene {
        frames: 5,
        ..RoadScene::two_cars()
    };
    let scene = p.generate(7).unwrap();
    let summary = write_scene(&mut p.stream(7).unwrap(), &d).unwrap();
    assert_eq!(summary.frames_written, 5);
    assert_eq!(summary.ground_truth_files.len(), 2);
    assert!(d.join("groundtruth_rect.1.txt").is_file());
    assert!(d.join("truth.csv").is_file() && d.join("scene.txt").is_file());
    let seq = Sequence::open(&d).unwrap();
    assert_eq!(seq.len(), 5);
    for k in 0..5 {
        assert!(
            seq.frame(k).unwrap() == scene.frames[k],
            "frame {k}: PNG is lossless"
        );
        let want = scene.truth[k].target().unwrap().bbox;
        let got = seq.ground_truth[k].unwrap();
        for (a, b) in [
            (got.x, want.x),
            (got.y, want.y),
            (got.width, want.width),
            (got.height, want.height),
        ] {
            assert!((a - b).abs() < 1e-4, "frame {k}: {got:?} vs {want:?}");
        }
    }
    let csv = fs::read_to_string(d.join("truth.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 5 * 2);
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn named_scenes_write_and_unknown_names_fail() {
    for name in SCENES.iter().map(|s| s.name) {
        let s = named_stream(name, 1, Some(2)).unwrap();
        assert_eq!(s.info().frames, 2, "{name}");
    }
    assert_eq!(named_stream("ball", 1, None).unwrap().info().frames, 220);
    assert!(matches!(
        named_stream("nope", 1, None),
        Err(SceneError::UnknownScene { .. })
    ));
    assert!(matches!(
        named_stream("road", 1, Some(0)),
        Err(SceneError::InvalidParameter { .. })
    ));
    let d = tmpdir("named");
    let w = write_named_scene("affine", 3, Some(2), &d).unwrap();
    assert_eq!(w.frames_written, 2);
    let affine = fs::read_to_string(d.join("affine.csv")).unwrap();
    assert_eq!(affine.lines().count(), 3);
    assert_eq!(
        affine.lines().next().unwrap().split(',').count(),
        1 + 6 + 14 + 2 + 2
    );
    // The ball scene's writer keeps the 1-based OTB file names.
    let b = tmpdir("named-ball");
    write_scene(
        &mut BallScene {
            frames: 3,
            ..BallScene::default()
        }
        .stream(0)
        .unwrap(),
        &b,
    )
    .unwrap();
    assert!(b.join("img/0001.png").is_file() && b.join("img/0003.png").is_file());
    let _ = fs::remove_dir_all(&d);
    let _ = fs::remove_dir_all(&b);
}

#[test]
fn a_scene_replaces_the_previous_one_whole_and_is_bounded() {
    let d = tmpdir("replace");
    let out = d.join("road");
    write_named_scene("road", 1, Some(3), &out).unwrap();
    fs::write(out.join("img/0009.png"), b"from an older, longer scene").unwrap();
    // A run that fails part-way (here: before its first frame, the
    // staging folder cannot be created) leaves the previous scene whole.
    let before = fs::read(out.join("groundtruth_rect.txt")).unwrap();
    fs::write(
        d.join("road.partial"),
        b"a file where the staging folder goes",
    )
    .unwrap();
    assert!(write_named_scene("road", 2, Some(2), &out).is_err());
    assert_eq!(fs::read(out.join("groundtruth_rect.txt")).unwrap(), before);
    fs::remove_file(d.join("road.partial")).unwrap();
    // A finished run replaces the whole folder: no frame of the old one.
    let w = write_named_scene("road", 2, Some(2), &out).unwrap();
    assert_eq!(w.dir, out);
    assert!(!out.join("img/0009.png").exists());
    assert!(!out.join("img/0003.png").exists());
    assert!(!out.join("PARTIAL.txt").exists());
    assert!(!d.join("road.partial").exists());
    assert!(w.ground_truth_files[0].starts_with(&out));
    match write_named_scene("road", 1, Some(100_000_000), &d.join("huge")) {
        Err(e @ SceneError::InvalidParameter { .. }) => {
            assert!(e.to_string().contains("100000"), "{e}")
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert!(!d.join("huge").exists() && !d.join("huge.partial").exists());
    let _ = fs::remove_dir_all(&d);
}

#[test]
fn unwritable_output_names_the_path() {
    let d = tmpdir("unwritable");
    let file = d.join("a-file");
    fs::write(&file, "x").unwrap();
    // A folder cannot be created below a file.
    match write_named_scene("road", 1, Some(1), &file.join("out")) {
        Err(e @ SceneError::Io { .. }) => assert!(e.to_string().contains("a-file"), "{e}"),
        other => panic!("expected an Io error, got {other:?}"),
    }
    let _ = fs::remove_dir_all(&d);
}
