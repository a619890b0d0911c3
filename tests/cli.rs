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
fn an_initial_box_wholly_outside_the_frame_is_refused() {
    let dir = tmpdir("outside");
    write_sequence(&dir, 3, 3);
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--init",
        "95,10,12,12",
        "--out",
        dir.join("b.txt").to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("box 95,10,12,12 (x,y,width,height) is outside the 80x60 frame"),
        "{err}"
    );
}

#[test]
fn an_initial_box_partly_outside_is_clipped_and_negative_numbers_parse() {
    let dir = tmpdir("partly");
    write_sequence(&dir, 4, 4);
    let out = dir.join("b.txt");
    // Written as a separate argument, a leading minus is a number, not a flag.
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--tracker",
        "mad",
        "--init",
        "-5,20,20,12",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("clipped to 1,20,14,12"), "{err}");
    let boxes = fs::read_to_string(&out).unwrap();
    assert_eq!(boxes.lines().next(), Some("1,20,14,12"));
    // Partly outside on the far side too.
    let seq = dir.to_str().unwrap();
    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--tracker",
        "mad",
        "--init",
        "75,10,12,12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("clipped to 75,10,6,12"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn frames_past_the_last_ground_truth_row_are_tracked_not_scored() {
    // Football1 as shipped: 81 images, 74 rows. Under its own name the
    // OTB-100 table runs frames 1-74; under another name every frame runs
    // and the 7 without a row are not scored.
    let root = std::env::temp_dir().join(format!("bayestrack-cli-fb-{}", std::process::id()));
    let _ = fs::remove_dir_all(&root);
    let dir = root.join("Football1");
    fs::create_dir_all(dir.join("img")).unwrap();
    write_sequence(&dir, 30, 30);
    // The table's names are .jpg: PNG bytes decode by their content.
    for k in 1..=30 {
        fs::rename(
            dir.join(format!("img/{k:04}.png")),
            dir.join(format!("img/{k:04}.jpg")),
        )
        .unwrap();
    }
    for k in 31..=81 {
        fs::copy(
            dir.join("img/0030.jpg"),
            dir.join(format!("img/{k:04}.jpg")),
        )
        .unwrap();
    }
    let gt = fs::read_to_string(dir.join("groundtruth_rect.txt")).unwrap();
    let last = gt.lines().last().unwrap().to_string();
    let rows: String = gt
        .lines()
        .chain(std::iter::repeat_n(last.as_str(), 44))
        .map(|l| format!("{l}\n"))
        .collect();
    fs::write(dir.join("groundtruth_rect.txt"), rows).unwrap();
    let out = root.join("boxes.txt");
    let run = |seq: &Path| {
        let (seq, out) = (seq.to_str().unwrap(), out.to_str().unwrap());
        bayestrack(&["track", "--seq", seq, "--tracker", "mad", "--out", out])
    };
    let o = run(&dir);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(lines(&out), 74);
    assert!(err.contains("Football1: mad on 74 frames"), "{err}");
    assert!(err.contains("over 74 labelled frames"), "{err}");
    let plain = root.join("MyFootball");
    fs::rename(&dir, &plain).unwrap();
    let o = run(&plain);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(lines(&out), 81);
    assert!(
        err.contains("frames 75-81 have no ground-truth row"),
        "{err}"
    );
    assert!(
        err.contains("7 of the 81 frames run have no ground-truth row"),
        "{err}"
    );
    assert!(err.contains("over 74 labelled frames"), "{err}");
    let _ = fs::remove_dir_all(&root);
}

#[test]
fn out_naming_an_input_is_refused_before_anything_is_written() {
    let dir = tmpdir("out-input");
    write_sequence(&dir, 3, 3);
    let frame = dir.join("img/0002.png");
    let before = fs::read(&frame).unwrap();
    let seq = dir.to_str().unwrap();
    for target in [
        frame.clone(),
        dir.join("groundtruth_rect.txt"),
        dir.join("img/../img/0002.png"),
    ] {
        let o = bayestrack(&["track", "--seq", seq, "--out", target.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("is an input of this run"), "{err}");
    }
    assert_eq!(fs::read(&frame).unwrap(), before);
    let img = dir.join("img");
    let o = bayestrack(&["track", "--seq", seq, "--draw", img.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("folder of the input frames"),
        "{}",
        stderr(&o)
    );
    assert_eq!(fs::read(&frame).unwrap(), before);
}

#[test]
fn a_full_disk_is_an_error_naming_the_file() {
    if !Path::new("/dev/full").exists() {
        eprintln!("SKIPPED: no /dev/full on this system; the disk-full case is not checked");
        return;
    }
    let dir = tmpdir("full");
    write_sequence(&dir, 3, 3);
    let seq = dir.to_str().unwrap();
    let o = bayestrack(&["track", "--seq", seq, "--out", "/dev/full"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot write /dev/full"), "{err}");
}

#[test]
fn frames_and_every_pick_the_frames_run_and_scored() {
    let dir = tmpdir("select");
    write_sequence(&dir, 10, 10);
    let out = dir.join("boxes.txt");
    let draw = dir.join("drawn");
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--tracker",
        "mad",
        "--frames",
        "3..8",
        "--every",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--draw",
        draw.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    // Frames 3, 5 and 7; frame 3's ground truth is the initial box.
    let boxes = fs::read_to_string(&out).unwrap();
    assert_eq!(boxes.lines().next(), Some("15,21,12,12"));
    assert_eq!(boxes.lines().count(), 3);
    assert!(err.contains("over 3 labelled frames"), "{err}");
    let mut drawn: Vec<String> = fs::read_dir(&draw)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    drawn.sort();
    assert_eq!(drawn, ["0003.png", "0005.png", "0007.png"]);
    let seq = dir.to_str().unwrap();
    for (frames, every) in [("0..3", "1"), ("4..2", "1"), ("1..3", "0")] {
        let o = bayestrack(&["track", "--seq", seq, "--frames", frames, "--every", every]);
        assert_eq!(o.status.code(), Some(1), "{frames} {every}");
    }
}

/// The synthetic sequence of [`write_sequence`] as a 4:2:0 Y4M stream
/// (gray frames: Y is the gray level, full range, chroma neutral).
fn y4m_sequence(n: usize) -> Vec<u8> {
    let (w, h) = (80, 60);
    let mut out = b"YUV4MPEG2 W80 H60 F25:1 Ip A1:1 C420jpeg XCOLORRANGE=FULL\n".to_vec();
    for k in 0..n {
        out.extend(b"FRAME\n");
        out.extend(frame(w, h, 10 + 2 * k, 20).as_slice());
        out.extend(vec![128u8; 2 * (w / 2) * (h / 2)]);
    }
    out
}

fn bayestrack_stdin(args: &[&str], input: &[u8], env: &[(&str, &str)]) -> Output {
    use std::io::Write;
    let mut child = Command::new(env!("CARGO_BIN_EXE_bayestrack"))
        .args(args)
        .envs(env.iter().copied())
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let out = child.wait_with_output().unwrap();
    writer.join().unwrap();
    out
}

#[test]
fn y4m_on_standard_input_tracks() {
    let dir = tmpdir("y4m");
    write_sequence(&dir, 8, 8);
    let gt = dir.join("groundtruth_rect.txt");
    let args = [
        "track",
        "--seq",
        "-",
        "--tracker",
        "mad",
        "--init",
        "11,21,12,12",
        "--groundtruth",
        gt.to_str().unwrap(),
    ];
    let o = bayestrack_stdin(&args, &y4m_sequence(8), &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let boxes = String::from_utf8_lossy(&o.stdout);
    assert_eq!(boxes.lines().count(), 8);
    assert_eq!(boxes.lines().last(), Some("25,21,12,12"));
    assert!(err.contains("precision@20px 1.000"), "{err}");
    // A stream cut inside frame 6 keeps the 5 boxes before it.
    let bytes = y4m_sequence(8);
    let o = bayestrack_stdin(&args[..7], &bytes[..bytes.len() * 5 / 8 + 100], &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("stdin: Y4M frame 6: cut short"), "{err}");
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 5);
}

#[test]
fn a_video_file_without_ffmpeg_says_how_to_get_it() {
    let dir = tmpdir("noffmpeg");
    let clip = dir.join("clip.mp4");
    fs::write(&clip, b"not really a video").unwrap();
    let o = bayestrack_stdin(
        &[
            "track",
            "--seq",
            clip.to_str().unwrap(),
            "--init",
            "1,1,5,5",
        ],
        b"",
        &[("BAYESTRACK_FFMPEG", "/nonexistent/ffmpeg")],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("clip.mp4") && err.contains("install it"),
        "{err}"
    );
    assert!(
        err.contains("yuv4mpegpipe - | bayestrack track --seq -"),
        "{err}"
    );
}

/// A stand-in for ffmpeg: a script that writes a prepared Y4M file, or
/// fails as ffmpeg does on a file it cannot read.
#[cfg(unix)]
fn fake_ffmpeg(dir: &Path, name: &str, body: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let script = dir.join(name);
    fs::write(&script, format!("#!/bin/sh\n{body}\n")).unwrap();
    fs::set_permissions(&script, fs::Permissions::from_mode(0o755)).unwrap();
    script
}

#[cfg(unix)]
#[test]
fn a_video_file_is_decoded_through_ffmpeg() {
    let dir = tmpdir("fakeffmpeg");
    write_sequence(&dir, 8, 8);
    let stream = dir.join("stream.y4m");
    fs::write(&stream, y4m_sequence(8)).unwrap();
    let ok = fake_ffmpeg(&dir, "ok.sh", &format!("cat '{}'", stream.display()));
    let clip = dir.join("clip.mp4");
    fs::write(&clip, b"stand-in").unwrap();
    let clip = clip.to_str().unwrap();
    let args = [
        "track",
        "--seq",
        clip,
        "--tracker",
        "mad",
        "--init",
        "11,21,12,12",
    ];
    let o = bayestrack_stdin(&args, b"", &[("BAYESTRACK_FFMPEG", ok.to_str().unwrap())]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().last(), Some("25,21,12,12"));
    // A .y4m file is read directly, without ffmpeg.
    let mut direct = args;
    direct[2] = stream.to_str().unwrap();
    let o = bayestrack_stdin(
        &direct,
        b"",
        &[("BAYESTRACK_FFMPEG", "/nonexistent/ffmpeg")],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // ffmpeg's own message when it cannot decode.
    let bad = fake_ffmpeg(
        &dir,
        "bad.sh",
        "echo 'clip.mp4: Invalid data found when processing input' >&2; exit 1",
    );
    let o = bayestrack_stdin(&args, b"", &[("BAYESTRACK_FFMPEG", bad.to_str().unwrap())]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("Invalid data found when processing input"),
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

/// A real mp4, encoded and decoded by the ffmpeg on PATH (skipped, saying
/// so, where there is none): H.264 loses detail, so the check is that the
/// tracker follows the target (every centre within 20 px), not exact boxes.
#[test]
fn an_mp4_file_tracks_when_ffmpeg_is_installed() {
    let has_ffmpeg = Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_ffmpeg {
        eprintln!(
            "SKIPPED: no ffmpeg on PATH; the mp4 test needs one to encode and decode the clip \
             (the Y4M and stand-in ffmpeg tests still ran)"
        );
        return;
    }
    let dir = tmpdir("mp4");
    write_sequence(&dir, 12, 12);
    let y4m = dir.join("clip.y4m");
    fs::write(&y4m, y4m_sequence(12)).unwrap();
    let clip = dir.join("clip.mp4");
    let enc = Command::new("ffmpeg")
        .args(["-hide_banner", "-loglevel", "error", "-y", "-i"])
        .arg(&y4m)
        .args(["-pix_fmt", "yuv420p", "-crf", "10"])
        .arg(&clip)
        .output()
        .unwrap();
    if !enc.status.success() {
        // An ffmpeg without an H.264 encoder: MPEG-4 part 2 is built in.
        let enc = Command::new("ffmpeg")
            .args(["-hide_banner", "-loglevel", "error", "-y", "-i"])
            .arg(&y4m)
            .args(["-c:v", "mpeg4", "-q:v", "2"])
            .arg(&clip)
            .output()
            .unwrap();
        assert!(
            enc.status.success(),
            "{}",
            String::from_utf8_lossy(&enc.stderr)
        );
    }
    let gt = dir.join("groundtruth_rect.txt");
    let o = bayestrack(&[
        "track",
        "--seq",
        clip.to_str().unwrap(),
        "--tracker",
        "mad",
        "--groundtruth",
        gt.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 12);
    assert!(err.contains("precision@20px 1.000"), "{err}");
    assert!(err.contains("over 12 labelled frames"), "{err}");
}

/// Every tracker on a gray and on a colour sequence: it tracks, or it
/// refuses the gray one with a message naming itself and the channels it
/// needs (colour cues: the ball's colour, the skin model), never a panic
/// or a silent run on the wrong kind of frame.
#[test]
fn every_tracker_runs_on_gray_and_colour_or_says_why_not() {
    let gray = tmpdir("all-gray");
    write_sequence(&gray, 4, 4);
    let colour = tmpdir("all-colour");
    fs::create_dir_all(colour.join("img")).unwrap();
    for k in 1..=4 {
        // A skin-coloured target on a bluish background.
        let g = frame(80, 60, 10 + 2 * (k - 1), 20);
        let data = (0..80 * 60)
            .flat_map(|i| {
                let (u, v) = (i % 80, i / 80);
                let value = f64::from(g.as_slice()[i]);
                let inside =
                    (10 + 2 * (k - 1)..22 + 2 * (k - 1)).contains(&u) && (20..32).contains(&v);
                let tint = if inside {
                    [1.0, 0.7, 0.55]
                } else {
                    [0.6, 0.8, 1.0]
                };
                tint.map(|t| (value * t) as u8)
            })
            .collect();
        let rgb = Image::from_vec(80, 60, 3, data).unwrap();
        write_png(colour.join(format!("img/{k:04}.png")), rgb.view()).unwrap();
    }
    fs::copy(
        gray.join("groundtruth_rect.txt"),
        colour.join("groundtruth_rect.txt"),
    )
    .unwrap();
    for t in REGISTRY {
        let run = |dir: &Path| {
            bayestrack(&["track", "--seq", dir.to_str().unwrap(), "--tracker", t.name])
        };
        let o = run(&colour);
        assert!(o.status.success(), "{} on colour: {}", t.name, stderr(&o));
        assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 4);
        let o = run(&gray);
        if !o.status.success() {
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{}: {err}", t.name);
            assert!(
                err.contains(t.name) && err.contains("needs 3") && err.contains("0001.png"),
                "{}: {err}",
                t.name
            );
        }
    }
}

#[test]
fn tracker_options_reach_the_tracker_and_bad_ones_write_nothing() {
    let dir = tmpdir("options");
    write_sequence(&dir, 4, 4);
    let seq = dir.to_str().unwrap();
    let out = dir.join("boxes.txt");
    fs::write(&out, "previous run\n").unwrap();
    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--tracker",
        "ball-pf",
        "--set",
        "particles=0",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("bad value `0` for `particles`: expected 1..=1000000"),
        "{err}"
    );
    assert_eq!(fs::read_to_string(&out).unwrap(), "previous run\n");
    let o = bayestrack(&["trackers", "--options", "ball-pf70"]);
    let listing = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success());
    assert!(
        listing.starts_with("particles: usize (1..=1000000) = 70"),
        "{listing}"
    );
}

// ---- issue 28: never destroy an input, never score against the wrong
// truth, bounded memory, errors that name the cause ----

/// Runs the binary with `stdin` from a file.
fn bayestrack_with_stdin_file(args: &[&str], stdin: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bayestrack"))
        .args(args)
        .stdin(fs::File::open(stdin).unwrap())
        .output()
        .unwrap()
}

#[test]
fn out_that_is_standard_input_is_refused_and_the_stream_kept() {
    let dir = tmpdir("out-stdin");
    let clip = dir.join("clip.y4m");
    let bytes = y4m_sequence(4);
    fs::write(&clip, &bytes).unwrap();
    let o = bayestrack_with_stdin_file(
        &[
            "track",
            "--seq",
            "-",
            "--init",
            "11,21,12,12",
            "--out",
            clip.to_str().unwrap(),
        ],
        &clip,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("is an input of this run"), "{err}");
    assert!(err.contains("standard input"), "{err}");
    assert_eq!(fs::read(&clip).unwrap(), bytes);
}

#[cfg(unix)]
#[test]
fn out_that_is_a_hard_link_or_a_symlink_target_of_an_input_is_refused() {
    let dir = tmpdir("out-links");
    write_sequence(&dir, 3, 3);
    let seq = dir.to_str().unwrap();
    // A hard link to frame 2.
    let frame = dir.join("img/0002.png");
    let before = fs::read(&frame).unwrap();
    // Ground truth and frame 3 that are symlinks to files elsewhere.
    let elsewhere = dir.join("elsewhere");
    fs::create_dir_all(&elsewhere).unwrap();
    let link = elsewhere.join("hard.png");
    fs::hard_link(&frame, &link).unwrap();
    let gt_real = elsewhere.join("truth.txt");
    fs::rename(dir.join("groundtruth_rect.txt"), &gt_real).unwrap();
    std::os::unix::fs::symlink(&gt_real, dir.join("groundtruth_rect.txt")).unwrap();
    let gt_before = fs::read(&gt_real).unwrap();
    let f3_real = elsewhere.join("third.png");
    fs::rename(dir.join("img/0003.png"), &f3_real).unwrap();
    std::os::unix::fs::symlink(&f3_real, dir.join("img/0003.png")).unwrap();
    let f3_before = fs::read(&f3_real).unwrap();
    for target in [&link, &gt_real, &f3_real] {
        let o = bayestrack(&["track", "--seq", seq, "--out", target.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{}: {err}", target.display());
        assert!(err.contains("is an input of this run"), "{err}");
    }
    // --groundtruth given as a symlink whose target is --out.
    let gt_link = dir.join("gt-link.txt");
    std::os::unix::fs::symlink(&gt_real, &gt_link).unwrap();
    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--groundtruth",
        gt_link.to_str().unwrap(),
        "--out",
        gt_real.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(fs::read(&frame).unwrap(), before);
    assert_eq!(fs::read(&gt_real).unwrap(), gt_before);
    assert_eq!(fs::read(&f3_real).unwrap(), f3_before);
}

#[test]
fn a_run_that_fails_before_its_first_box_keeps_the_previous_out() {
    let dir = tmpdir("keep-out");
    write_sequence(&dir, 3, 3);
    let out = dir.join("boxes.txt");
    let seq = dir.to_str().unwrap();
    fs::write(&out, "previous\n").unwrap();
    // A box wholly outside the frame.
    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--init",
        "95,10,12,12",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(fs::read_to_string(&out).unwrap(), "previous\n");
    // A first frame that does not decode.
    fs::write(dir.join("img/0001.png"), b"\x89PNG\r\n\x1a\n cut").unwrap();
    let o = bayestrack(&["track", "--seq", seq, "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(fs::read_to_string(&out).unwrap(), "previous\n");
}

#[test]
fn out_inside_the_draw_folder_is_refused() {
    let dir = tmpdir("out-draw");
    write_sequence(&dir, 4, 4);
    let dd = dir.join("dd");
    fs::create_dir_all(&dd).unwrap();
    let out = dd.join("0003.png");
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--draw",
        dd.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("--draw"), "{err}");
    assert!(!out.exists());
    // a box file of another kind beside the drawn frames is fine
    let txt = dd.join("boxes.txt");
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--out",
        txt.to_str().unwrap(),
        "--draw",
        dd.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(lines(&txt), 4);
}

#[cfg(unix)]
#[test]
fn a_closed_standard_output_is_an_error() {
    let dir = tmpdir("closed-stdout");
    write_sequence(&dir, 3, 3);
    let o = Command::new("sh")
        .arg("-c")
        .arg("exec \"$0\" track --seq \"$1\" >&-")
        .arg(env!("CARGO_BIN_EXE_bayestrack"))
        .arg(&dir)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("standard output"), "{err}");
    assert!(!err.contains("write -:"), "{err}");
}

#[test]
fn a_standard_output_that_stops_reading_is_named_so() {
    let dir = tmpdir("broken-pipe");
    write_sequence(&dir, 3, 3);
    // A pipe whose reader is gone before the first row: every write fails.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = Command::new(env!("CARGO_BIN_EXE_bayestrack"))
        .args(["track", "--seq", dir.to_str().unwrap(), "--tracker", "mad"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot write standard output"), "{err}");
    assert!(!err.contains("write -:"), "{err}");
}

#[test]
fn frame_folders_with_a_gap_a_duplicate_or_an_odd_name_are_refused() {
    let gap = tmpdir("gap");
    write_sequence(&gap, 5, 5);
    fs::remove_file(gap.join("img/0003.png")).unwrap();
    let dup = tmpdir("dup");
    write_sequence(&dup, 4, 4);
    fs::copy(dup.join("img/0002.png"), dup.join("img/002.png")).unwrap();
    for (dir, says) in [(&gap, "frame 3 is missing"), (&dup, "002.png")] {
        let o = bayestrack(&["track", "--seq", dir.to_str().unwrap(), "--tracker", "mad"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(says), "{err}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let odd = tmpdir("odd-name");
        write_sequence(&odd, 3, 3);
        let name = std::ffi::OsStr::from_bytes(b"\xff0002.png");
        fs::rename(odd.join("img/0002.png"), odd.join("img").join(name)).unwrap();
        let o = bayestrack(&["track", "--seq", odd.to_str().unwrap(), "--tracker", "mad"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("UTF-8"), "{err}");
    }
}

/// Found by the frame-folder fuzz target: a multi-byte character before
/// the number (`ť1.png`) panicked the frame listing (exit 101).
#[test]
fn frame_names_with_a_multibyte_character_before_the_number_run() {
    let dir = tmpdir("multibyte");
    write_sequence(&dir, 3, 3);
    for k in 1..=3 {
        fs::rename(
            dir.join(format!("img/{k:04}.png")),
            dir.join(format!("img/\u{165}{k}.png")),
        )
        .unwrap();
    }
    fs::remove_file(dir.join("groundtruth_rect.txt")).unwrap();
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--tracker",
        "mad",
        "--init",
        "11,21,12,12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 3);
}

/// A gray 4:2:0 stream of `n` frames whose frame `bad` (1-based) has a
/// broken FRAME marker.
fn y4m_with_bad_marker(n: usize, bad: usize) -> Vec<u8> {
    let good = y4m_sequence(n);
    let header_end = good.iter().position(|&b| b == b'\n').unwrap() + 1;
    let frame_len = (good.len() - header_end) / n;
    let mut out = good.clone();
    let at = header_end + (bad - 1) * frame_len;
    out[at..at + 5].copy_from_slice(b"FRAMX");
    out
}

#[test]
fn skip_continues_past_a_bad_y4m_frame_marker() {
    let args = [
        "track",
        "--seq",
        "-",
        "--tracker",
        "mad",
        "--init",
        "11,21,12,12",
        "--on-bad-frame",
        "skip",
    ];
    let o = bayestrack_stdin(&args, &y4m_with_bad_marker(10, 3), &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("skipped frame 3"), "{err}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), 10, "{out}");
    assert_eq!(out.lines().last(), Some("29,21,12,12"));
}

#[test]
fn a_named_otb_target_without_the_otb_layout_is_refused() {
    let root = std::env::temp_dir().join(format!("bayestrack-cli-otbname-{}", std::process::id()));
    let _ = fs::remove_dir_all(&root);
    let dir = root.join("Jogging");
    fs::create_dir_all(dir.join("img")).unwrap();
    write_sequence(&dir, 4, 4);
    let o = bayestrack(&[
        "track",
        "--seq",
        root.join("Jogging_2").to_str().unwrap(),
        "--tracker",
        "mad",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("Jogging_2") && err.contains("layout"), "{err}");
    assert!(!err.contains("success AUC"), "{err}");
}

#[test]
fn ground_truth_rows_the_init_option_refuses_are_refused() {
    for (row, says) in [
        ("1e308,1e308,1e308,1e308", "finite"),
        ("20,13,0,12", "width"),
    ] {
        let dir = tmpdir("gt-rows");
        write_sequence(&dir, 4, 4);
        let gt = dir.join("groundtruth_rect.txt");
        let text = fs::read_to_string(&gt).unwrap();
        let mut rows: Vec<&str> = text.lines().collect();
        rows[2] = row;
        fs::write(&gt, rows.join("\n") + "\n").unwrap();
        let o = bayestrack(&["track", "--seq", dir.to_str().unwrap(), "--tracker", "mad"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{row}: {err}");
        assert!(err.contains("groundtruth_rect.txt:3"), "{row}: {err}");
        assert!(err.contains(says), "{row}: {err}");
        // the --init option refuses it too
        let o = bayestrack(&["track", "--seq", dir.to_str().unwrap(), "--init", row]);
        assert_eq!(o.status.code(), Some(2), "{row}: {}", stderr(&o));
    }
}

#[test]
fn a_huge_y4m_header_is_refused_naming_the_override() {
    let mut input = b"YUV4MPEG2 W32768 H32768 C444\nFRAME\n".to_vec();
    input.extend(vec![16u8; 1 << 20]);
    let args = ["track", "--seq", "-", "--init", "1,1,5,5"];
    let o = bayestrack_stdin(&args, &input, &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("W32768 H32768"), "{err}");
    assert!(err.contains("BAYESTRACK_Y4M_MAX_PIXELS"), "{err}");
}

#[cfg(unix)]
#[test]
fn ground_truth_from_an_endless_file_is_refused() {
    let dir = tmpdir("gt-zero");
    write_sequence(&dir, 3, 3);
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--groundtruth",
        "/dev/zero",
        "--init",
        "11,21,12,12",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("/dev/zero"), "{err}");
}

#[test]
fn y4m_with_crlf_header_and_wrong_colour_space_say_what_is_wrong() {
    let args = [
        "track",
        "--seq",
        "-",
        "--tracker",
        "mad",
        "--init",
        "11,21,12,12",
    ];
    // A CRLF header line is read (the CR is not part of the last field).
    let crlf = {
        let s = y4m_sequence(3);
        let nl = s.iter().position(|&b| b == b'\n').unwrap();
        let mut out = s[..nl].to_vec();
        out.extend(b" C444\r");
        let mut rest = Vec::new();
        // the frames as 4:4:4: Y then two full-size neutral chroma planes
        for k in 0..3 {
            rest.extend(b"FRAME\n");
            rest.extend(frame(80, 60, 10 + 2 * k, 20).as_slice());
            rest.extend(vec![128u8; 2 * 80 * 60]);
        }
        out.push(b'\n');
        // drop the original C420jpeg field
        let text = String::from_utf8(out).unwrap().replace(" C420jpeg", "");
        let mut out = text.into_bytes();
        out.extend(rest);
        out
    };
    let o = bayestrack_stdin(&args, &crlf, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 3);
    // 4:4:4 data under a 4:2:0 header.
    let mut mislabelled = b"YUV4MPEG2 W80 H60 C420jpeg\n".to_vec();
    for k in 0..3 {
        mislabelled.extend(b"FRAME\n");
        mislabelled.extend(frame(80, 60, 10 + 2 * k, 20).as_slice());
        mislabelled.extend(vec![128u8; 2 * 80 * 60]);
    }
    let o = bayestrack_stdin(&args, &mislabelled, &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("colour space"), "{err}");
    assert!(!err.contains("longer than 4096"), "{err}");
}

#[test]
fn unclear_errors_name_the_real_cause() {
    let dir = tmpdir("unclear");
    write_sequence(&dir, 10, 10);
    let seq = dir.to_str().unwrap();
    // --frames past the end
    let o = bayestrack(&["track", "--seq", seq, "--frames", "11.."]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("10 frames"), "{err}");
    // a range that ends past the last frame runs to the end and says so
    let o = bayestrack(&[
        "track",
        "--seq",
        seq,
        "--tracker",
        "mad",
        "--frames",
        "9..15",
    ]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 2);
    assert!(
        err.contains("frames 11-15 do not exist; running frames 9-10"),
        "{err}"
    );
    // a missing video file
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.join("clip.mp4").to_str().unwrap(),
        "--init",
        "1,1,5,5",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("no such file"), "{err}");
    assert!(!err.contains("folder"), "{err}");
    // a text file named .png
    fs::write(dir.join("img/0004.png"), b"just some text\n").unwrap();
    let o = bayestrack(&["track", "--seq", seq, "--tracker", "mad"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("0004.png") && err.contains("not a PNG"),
        "{err}"
    );
    assert!(!err.contains("truncated"), "{err}");
    // a huge box is printed in short form
    let dir = tmpdir("unclear-huge");
    write_sequence(&dir, 3, 3);
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--tracker",
        "mad",
        "--init",
        "1,1,1e300,5",
    ]);
    let err = stderr(&o);
    assert!(!err.contains("0000000000"), "{err}");
    // a box far outside the frame: the tracker's refusal prints it short
    let o = bayestrack(&[
        "track",
        "--seq",
        dir.to_str().unwrap(),
        "--init",
        "1e300,1,5,5",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("1e300"), "{err}");
    assert!(!err.contains("0000000000"), "{err}");
}

/// `--decode-ahead` and `--decode-threads` pairs a run must not depend on:
/// in turn, one thread ahead, several threads.
const DECODE_SETTINGS: [(&str, &str); 7] = [
    ("0", "1"),
    ("1", "1"),
    ("4", "1"),
    ("64", "1"),
    ("1", "2"),
    ("4", "2"),
    ("4", "3"),
];

#[test]
fn decoding_ahead_or_in_turn_writes_the_same_boxes() {
    let dir = tmpdir("ahead");
    write_sequence(&dir, 24, 24);
    fs::write(dir.join("img/0009.png"), b"not a png at all").unwrap();
    let seq = dir.to_str().unwrap();
    for tracker in ["mad", "ncc-scale", "pf-correlation"] {
        let mut first: Option<(String, String)> = None;
        for (depth, threads) in DECODE_SETTINGS {
            let out = dir.join(format!("{tracker}-{depth}-{threads}.txt"));
            let o = bayestrack(&[
                "track",
                "--seq",
                seq,
                "--tracker",
                tracker,
                "--seed",
                "7",
                "--on-bad-frame",
                "skip",
                "--decode-ahead",
                depth,
                "--decode-threads",
                threads,
                "--out",
                out.to_str().unwrap(),
            ]);
            let err = stderr(&o);
            assert!(o.status.success(), "{tracker} {depth} {threads}: {err}");
            assert!(err.contains("skipped frame 9"), "{err}");
            assert!(err.contains("fps whole run"), "{err}");
            let boxes = fs::read_to_string(&out).unwrap();
            assert_eq!(boxes.lines().count(), 24);
            // the summary without its fps figures
            let score = err
                .lines()
                .filter(|l| !l.contains("fps"))
                .collect::<Vec<_>>()
                .join("\n");
            match &first {
                None => first = Some((boxes, score)),
                Some((b, s)) => {
                    let with = format!("--decode-ahead {depth} --decode-threads {threads}");
                    assert_eq!(&boxes, b, "{tracker}: boxes with {with}");
                    assert_eq!(&score, s, "{tracker}: messages with {with}");
                }
            }
        }
    }
    for threads in ["0", "65", "two"] {
        let o = bayestrack(&["track", "--seq", seq, "--decode-threads", threads]);
        assert_eq!(o.status.code(), Some(2), "--decode-threads {threads}");
        assert!(stderr(&o).contains("--decode-threads"), "{}", stderr(&o));
    }
}

#[test]
fn a_bad_frame_stops_at_the_same_box_whether_decoded_ahead_or_not() {
    let dir = tmpdir("ahead-bad");
    write_sequence(&dir, 40, 40);
    fs::write(dir.join("img/0017.png"), b"not a png at all").unwrap();
    let seq = dir.to_str().unwrap();
    for (depth, threads) in DECODE_SETTINGS {
        let out = dir.join(format!("boxes-{depth}-{threads}.txt"));
        let o = bayestrack(&[
            "track",
            "--seq",
            seq,
            "--decode-ahead",
            depth,
            "--decode-threads",
            threads,
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("0017.png"), "{err}");
        assert!(err.contains("the 16 boxes before it are in"), "{err}");
        assert_eq!(
            lines(&out),
            16,
            "--decode-ahead {depth} --decode-threads {threads}"
        );
    }
}

#[test]
fn a_tracker_that_fails_early_ends_the_run_while_frames_are_decoded_ahead() {
    // The tracker refuses frame 3 (another size); 400 frames follow, which
    // the decoding thread must not go on decoding, nor hang on.
    let dir = tmpdir("ahead-fail");
    write_sequence(&dir, 3, 3);
    write_png(dir.join("img/0003.png"), frame(90, 60, 14, 20).view()).unwrap();
    let later = frame(80, 60, 30, 20);
    for k in 4..=403 {
        write_png(dir.join(format!("img/{k:04}.png")), later.view()).unwrap();
    }
    let out = dir.join("boxes.txt");
    for (depth, threads) in [("1", "1"), ("4", "1"), ("1", "2"), ("4", "3")] {
        let o = bayestrack(&[
            "track",
            "--seq",
            dir.to_str().unwrap(),
            "--init",
            "11,21,12,12",
            "--decode-ahead",
            depth,
            "--decode-threads",
            threads,
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("frame 3") && err.contains("90x60"), "{err}");
        assert_eq!(lines(&out), 2);
    }
}
