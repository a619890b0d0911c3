//! The `bayestrack` command line on synthetic folders: it tracks and scores,
//! and every kind of bad input gets a clear message, a non-zero exit status
//! and keeps the boxes written before the failure.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use bayestrack::image::{Image, write_png};
use bayestrack::trackers::REGISTRY;

fn bayestrack(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bayestrack"))
        .args(args)
        .output()
        .expect("the bayestrack binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bayestrack-cli-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(d.join("img")).unwrap();
    d
}

/// A `w x h` gray frame: smooth background, a 12x12 checkerboard target
/// with its top-left corner at 0-based `(x, y)`.
fn frame(w: usize, h: usize, x: usize, y: usize) -> Image<u8> {
    let data = (0..w * h)
        .map(|i| {
            let (u, v) = (i % w, i / w);
            if (x..x + 12).contains(&u) && (y..y + 12).contains(&v) {
                if ((u - x) / 3 + (v - y) / 3).is_multiple_of(2) {
                    20
                } else {
                    235
                }
            } else {
                (100 + (u * 3 + v * 5) % 40) as u8
            }
        })
        .collect();
    Image::from_vec(w, h, 1, data).unwrap()
}

/// Writes `n` frames of a target moving 2 px right per frame, and a ground
/// truth file with `gt_rows` rows (OTB boxes).
fn write_sequence(dir: &Path, n: usize, gt_rows: usize) {
    let mut gt = String::new();
    for k in 0..n {
        let (x, y) = (10 + 2 * k, 20);
        write_png(
            dir.join(format!("img/{:04}.png", k + 1)),
            frame(80, 60, x, y).view(),
        )
        .unwrap();
        if k < gt_rows {
            gt.push_str(&format!("{},{},12,12\n", x + 1, y + 1));
        }
    }
    fs::write(dir.join("groundtruth_rect.txt"), gt).unwrap();
}

fn lines(path: &Path) -> usize {
    fs::read_to_string(path).unwrap().lines().count()
}

#[test]
fn trackers_lists_every_registered_tracker() {
    let o = bayestrack(&["trackers"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    for t in REGISTRY {
        assert!(out.contains(t.name), "{} missing from:\n{out}", t.name);
    }
    assert_eq!(out.lines().count(), REGISTRY.len());
}

#[test]
fn tracks_a_synthetic_sequence_and_scores_it() {
    let dir = tmpdir("ok");
    write_sequence(&dir, 8, 8);
    let out = dir.join("boxes.txt");
    let draw = dir.join("drawn");
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--tracker",
        "mad",
        "--out",
        out.to_str().unwrap(),
        "--draw",
        draw.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let boxes = fs::read_to_string(&out).unwrap();
    assert_eq!(boxes.lines().count(), 8);
    assert_eq!(boxes.lines().last().unwrap(), "25,21,12,12");
    assert!(err.contains("success AUC 0.952"), "{err}");
    assert!(err.contains("precision@20px 1.000"), "{err}");
    assert_eq!(fs::read_dir(&draw).unwrap().count(), 8);
}

#[test]
fn a_folder_without_frames_is_refused() {
    let dir = tmpdir("empty");
    let o = bayestrack(&["track", "--seq", dir.to_str().unwrap(), "--init", "1,1,5,5"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no PNG/JPEG frames"), "{}", stderr(&o));
}

#[test]
fn a_frame_that_does_not_decode_stops_or_is_skipped() {
    let dir = tmpdir("corrupt");
    write_sequence(&dir, 6, 6);
    fs::write(dir.join("img/0004.png"), b"not a png at all").unwrap();
    let out = dir.join("boxes.txt");
    let seq = dir.to_str().unwrap();
    let o = bayestrack(&["track", "--seq", seq, "--out", out.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("0004.png"), "{err}");
    assert!(err.contains("the 3 boxes before it are in"), "{err}");
    assert_eq!(lines(&out), 3);

    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--out",
        out.to_str().unwrap(),
        "--on-bad-frame",
        "skip",
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("skipped frame 4"), "{err}");
    assert_eq!(lines(&out), 6);
}

#[test]
fn frames_of_changing_size_are_refused_keeping_the_boxes() {
    let dir = tmpdir("resize");
    write_sequence(&dir, 5, 5);
    write_png(dir.join("img/0003.png"), frame(90, 60, 14, 20).view()).unwrap();
    let out = dir.join("boxes.txt");
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("frame 3") && err.contains("0003.png"), "{err}");
    assert!(err.contains("90x60"), "{err}");
    assert_eq!(lines(&out), 2);
}

#[test]
fn an_initial_box_outside_the_frame_is_refused() {
    let dir = tmpdir("outside");
    write_sequence(&dir, 3, 3);
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--init",
        "75,10,12,12",
        "--out",
        dir.join("b.txt").to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("box 75,10,12,12 (x,y,width,height) is outside the 80x60 frame"),
        "{err}"
    );
}

#[test]
fn ground_truth_with_too_few_rows_is_refused() {
    let dir = tmpdir("short-gt");
    write_sequence(&dir, 4, 3);
    let o = bayestrack(&["track", "--seq", dir.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("groundtruth_rect.txt") && err.contains("3 ground-truth rows for 4 frames"),
        "{err}"
    );
}

#[test]
fn bad_arguments_are_explained() {
    let dir = tmpdir("args");
    write_sequence(&dir, 2, 2);
    let seq = dir.to_str().unwrap();
    let o = bayestrack(&["track", "--seq", seq, "--tracker", "csrt"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("no tracker called 'csrt'"),
        "{}",
        stderr(&o)
    );
    let o = bayestrack(&["track", "--seq", seq, "--init", "1,2,3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("expected"), "{}", stderr(&o));
    let o = bayestrack(&["track", "--seq", dir.join("nope").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("does not exist"), "{}", stderr(&o));
}
