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
    assert!(err.contains("particles (1..=1000000)"), "{err}");
    assert_eq!(fs::read_to_string(&out).unwrap(), "previous run\n");
    let o = bayestrack(&["trackers", "--options", "ball-pf70"]);
    let listing = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(o.status.success());
    assert!(
        listing.starts_with("particles: usize (1..=1000000) = 70"),
        "{listing}"
    );
}
