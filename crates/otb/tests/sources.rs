//! Frame sources and OTB conventions: OTB-100 folders load by the
//! benchmark's table (Football1, David, Board, BlurCar1, Tiger1, Jogging),
//! Y4M streams decode, selections pick frames without decoding the others,
//! and the tracking loop pulls one frame at a time.

#![cfg(feature = "track")]

use std::cell::Cell;
use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use bayestrack_image::{BBox, Image, write_png};
use bayestrack_otb::OtbError;
use bayestrack_otb::Sequence;
use bayestrack_otb::metrics::score_otb;
use bayestrack_otb::y4m::rgb_to_yuv;
use bayestrack_otb::{Frame, FrameSelection, FrameSource, Select, Y4mSource};
use bayestrack_otb::{OnBadFrame, clip_initial_box, track_source};
use bayestrack_trackers::{Estimate, Result as TrackerResult, Tracker};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("bayestrack-src-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

/// A frame whose every pixel is `value` (so a decoded frame says which
/// file it came from).
fn flat(value: u8) -> Image<u8> {
    Image::new(8, 6, 1, value).unwrap()
}

/// Writes an OTB-layout folder `root/name` with frames `numbers` named
/// with `digits` digits in `img/`, each filled with its number mod 256, and
/// ground-truth files `(name, rows)`.
fn otb_folder(
    root: &Path,
    name: &str,
    numbers: std::ops::RangeInclusive<usize>,
    digits: usize,
    gts: &[(&str, usize)],
) -> PathBuf {
    let d = root.join(name);
    fs::create_dir_all(d.join("img")).unwrap();
    for n in numbers {
        // PNG bytes under a .jpg name decode by content.
        let path = d.join(format!("img/{n:0digits$}.jpg"));
        write_png(&path, flat((n % 256) as u8).view()).unwrap();
    }
    for (file, rows) in gts {
        let text: String = (1..=*rows).map(|r| format!("{r},1,2,2\n")).collect();
        fs::write(d.join(file), text).unwrap();
    }
    d
}

#[test]
fn football1_as_shipped_runs_its_74_labelled_frames() {
    let root = tmpdir("football");
    // 81 images, 74 ground-truth rows, as OTB ships Football1.
    let d = otb_folder(
        &root,
        "Football1",
        1..=81,
        4,
        &[("groundtruth_rect.txt", 74)],
    );
    let s = Sequence::open(&d).unwrap();
    assert_eq!(s.name, "Football1");
    assert_eq!((s.len(), s.labelled(), s.ground_truth_rows), (74, 74, 74));
    assert_eq!(s.frame_name(73), "0074.jpg");
    assert!(s.otb.is_some());
    // Scored as the benchmark scores it: 74 frames.
    let boxes: Vec<BBox> = s.ground_truth.iter().map(|b| b.unwrap()).collect();
    assert_eq!(
        score_otb(&boxes, &s.ground_truth).unwrap().frames_scored,
        74
    );
    // The same folder under another name is a plain folder: all 81 frames
    // are tracked, the last 7 are not scored, and the loader says so.
    let plain = root.join("MyFootball");
    fs::rename(&d, &plain).unwrap();
    let s = Sequence::open(&plain).unwrap();
    assert_eq!((s.len(), s.labelled(), s.ground_truth_rows), (81, 74, 74));
    assert!(s.otb.is_none());
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("frames 75-81 have no ground-truth row")),
        "{:?}",
        s.notes
    );
    let _ = fs::remove_dir_all(&root);
}

#[test]
fn otb_folders_use_the_benchmarks_frames_and_files() {
    let root = tmpdir("otb");
    // David: frames 300-770 of its folder; the ground truth's row 1 is frame 300.
    let d = otb_folder(&root, "David", 1..=770, 4, &[("groundtruth_rect.txt", 471)]);
    let s = Sequence::open(&d).unwrap();
    assert_eq!(s.len(), 471);
    assert_eq!(s.frame_name(0), "0300.jpg");
    assert_eq!(
        s.frame(0).unwrap().pixel(0, 0).unwrap(),
        &[(300 % 256) as u8]
    );
    assert_eq!(s.initial_box(), Some(BBox::new(1.0, 1.0, 2.0, 2.0)));
    // Board: five digits.
    let d = otb_folder(&root, "Board", 1..=698, 5, &[("groundtruth_rect.txt", 698)]);
    let s = Sequence::open(&d).unwrap();
    assert_eq!((s.len(), s.frame_name(0).as_str()), (698, "00001.jpg"));
    // BlurCar1 starts at 247.
    let d = otb_folder(
        &root,
        "BlurCar1",
        247..=988,
        4,
        &[("groundtruth_rect.txt", 742)],
    );
    let s = Sequence::open(&d).unwrap();
    assert_eq!((s.len(), s.frame_name(0).as_str()), (742, "0247.jpg"));
    // Tiger1 leaves out its first 5 frames and their rows.
    let d = otb_folder(
        &root,
        "Tiger1",
        1..=354,
        4,
        &[("groundtruth_rect.txt", 354)],
    );
    let s = Sequence::open(&d).unwrap();
    assert_eq!((s.len(), s.frame_name(0).as_str()), (349, "0006.jpg"));
    assert_eq!(s.initial_box(), Some(BBox::new(6.0, 1.0, 2.0, 2.0)));
    // A frame the table lists that is missing is named.
    fs::remove_file(root.join("Tiger1/img/0100.jpg")).unwrap();
    match Sequence::open(root.join("Tiger1")) {
        Err(e @ OtbError::MissingFrame { .. }) => {
            assert!(e.to_string().contains("0100.jpg"), "{e}");
        }
        other => panic!("expected MissingFrame, got {other:?}"),
    }
    let _ = fs::remove_dir_all(&root);
}

#[test]
fn a_folder_with_two_targets_says_which_it_tracks_and_takes_another() {
    let root = tmpdir("jogging");
    let d = otb_folder(
        &root,
        "Jogging",
        1..=307,
        4,
        &[
            ("groundtruth_rect.1.txt", 307),
            ("groundtruth_rect.2.txt", 307),
        ],
    );
    // Different second target.
    let second: String = (1..=307).map(|r| format!("{r},3,5,5\n")).collect();
    fs::write(d.join("groundtruth_rect.2.txt"), second).unwrap();
    let s = Sequence::open(&d).unwrap();
    assert_eq!(s.name, "Jogging_1");
    assert!(
        s.notes
            .iter()
            .any(|n| n.contains("2 OTB-100 targets") && n.contains("--groundtruth")),
        "{:?}",
        s.notes
    );
    let two = Sequence::open_with_ground_truth(&d, d.join("groundtruth_rect.2.txt")).unwrap();
    assert_eq!(two.name, "Jogging_2");
    assert_eq!(two.initial_box(), Some(BBox::new(1.0, 3.0, 5.0, 5.0)));
    assert!(two.notes.is_empty(), "{:?}", two.notes);
    // The target's name as a path picks its file too.
    let by_name = Sequence::open(root.join("Jogging_2")).unwrap();
    assert_eq!(by_name.ground_truth, two.ground_truth);
    // A plain folder with two *_gt.txt files says which it read.
    let plain = tmpdir("twogt");
    write_png(plain.join("0001.png"), flat(1).view()).unwrap();
    fs::write(plain.join("a_gt.txt"), "1,1,2,2\n").unwrap();
    fs::write(plain.join("b_gt.txt"), "2,2,2,2\n").unwrap();
    let s = Sequence::open(&plain).unwrap();
    assert!(
        s.notes.iter().any(|n| n.contains("b_gt.txt")),
        "{:?}",
        s.notes
    );
    let _ = fs::remove_dir_all(&root);
    let _ = fs::remove_dir_all(&plain);
}

#[test]
fn a_folder_named_like_an_otb_sequence_without_its_layout_is_a_plain_folder() {
    // The MIL copy of David (`img/img00001.png`, `david_gt.txt`) is not
    // OTB's David (frames 300-770 of `img/0001.jpg ...`).
    let root = tmpdir("mildavid");
    let d = root.join("David");
    fs::create_dir_all(d.join("img")).unwrap();
    for n in 1..=4 {
        write_png(d.join(format!("img/img{n:05}.png")), flat(n as u8).view()).unwrap();
    }
    fs::write(
        d.join("david_gt.txt"),
        "1,1,2,2\n0,0,0,0\n1,1,2,2\n0,0,0,0\n",
    )
    .unwrap();
    let s = Sequence::open(&d).unwrap();
    assert_eq!((s.len(), s.labelled()), (4, 2));
    assert!(s.otb.is_none());
    assert!(
        s.notes.iter().any(|n| n.contains("has not its layout")),
        "{:?}",
        s.notes
    );
    let _ = fs::remove_dir_all(&root);
}

/// The real OTB sequences, when someone has put them at
/// `../shared/data/otb/<name>` (the repository ships only the table).
#[test]
fn real_otb_sequences_when_present() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/otb");
    let mut checked = 0;
    for (name, frames) in [
        ("Football1", 74),
        ("David", 471),
        ("BlurCar1", 742),
        ("Board", 698),
    ] {
        let d = root.join(name);
        if !d.join("img").is_dir() {
            eprintln!(
                "SKIPPED: no OTB images at {} (the shared data holds only the OTB-100 table); \
                 {name} not checked on real data",
                d.display()
            );
            continue;
        }
        let s = Sequence::open(&d).unwrap();
        assert_eq!(s.len(), frames, "{name}");
        s.frame(0).unwrap();
        checked += 1;
    }
    eprintln!("{checked} real OTB sequences checked");
}

/// Y4M bytes: `frames` frames of `w x h`, colour space `c`; frame `k`'s
/// pixel `(x, y)` has RGB `pattern(k, x, y)`.
fn y4m(
    w: usize,
    h: usize,
    c: &str,
    frames: usize,
    pattern: impl Fn(usize, usize, usize) -> [u8; 3],
) -> Vec<u8> {
    let mut out = format!("YUV4MPEG2 W{w} H{h} F25:1 Ip A1:1 C{c} XYSCSS=TEST\n").into_bytes();
    for k in 0..frames {
        out.extend(b"FRAME\n");
        let yuv = |x: usize, y: usize| rgb_to_yuv(pattern(k, x, y));
        let (cw, ch) = match c {
            "mono" => (0, 0),
            "444" => (w, h),
            "422" => (w.div_ceil(2), h),
            _ => (w.div_ceil(2), h.div_ceil(2)),
        };
        for y in 0..h {
            for x in 0..w {
                out.push(if c == "mono" {
                    pattern(k, x, y)[0]
                } else {
                    yuv(x, y)[0]
                });
            }
        }
        for plane in [1, 2] {
            for cy in 0..ch {
                for cx in 0..cw {
                    out.push(yuv(cx * w / cw.max(1), cy * h / ch.max(1))[plane]);
                }
            }
        }
    }
    out
}

#[test]
fn y4m_streams_decode_in_every_colour_space() {
    // Colour blocks of 2x2 (so 4:2:0 chroma is exact), changing per frame.
    let pattern = |k: usize, x: usize, y: usize| {
        let v = ((x / 2 * 60 + y / 2 * 90 + k * 40) % 200) as u8 + 20;
        [v, 255 - v, v / 2]
    };
    for c in ["420jpeg", "420paldv", "420mpeg2", "420", "422", "444"] {
        let bytes = y4m(6, 4, c, 3, pattern);
        let src = Y4mSource::new(&bytes[..], "test.y4m").unwrap();
        let frames: Vec<Frame> = src.map(Result::unwrap).collect();
        assert_eq!(frames.len(), 3, "{c}");
        for (k, f) in frames.iter().enumerate() {
            assert_eq!(
                (f.number, f.name.as_str()),
                (k + 1, format!("frame {}", k + 1).as_str())
            );
            assert_eq!(
                (f.image.width(), f.image.height(), f.image.channels()),
                (6, 4, 3)
            );
            for y in 0..4 {
                for x in 0..6 {
                    let want = pattern(k, x, y);
                    let got = f.image.pixel(x, y).unwrap();
                    for ch in 0..3 {
                        assert!(
                            (i32::from(got[ch]) - i32::from(want[ch])).abs() <= 3,
                            "{c} frame {k} ({x},{y}): {got:?} vs {want:?}"
                        );
                    }
                }
            }
        }
    }
    // Mono is gray, exactly; odd sizes round the chroma planes up.
    let bytes = y4m(5, 3, "mono", 2, |k, x, y| [(k * 50 + x * 7 + y) as u8; 3]);
    let frames: Vec<Frame> = Y4mSource::new(&bytes[..], "m")
        .unwrap()
        .map(Result::unwrap)
        .collect();
    assert_eq!(frames[1].image.channels(), 1);
    assert_eq!(frames[1].image.pixel(4, 2).unwrap(), &[50 + 28 + 2]);
    let odd = y4m(5, 3, "420jpeg", 2, |_, _, _| [200, 40, 90]);
    assert_eq!(Y4mSource::new(&odd[..], "o").unwrap().count(), 2);
}

#[test]
fn a_cut_or_malformed_y4m_stream_names_the_frame() {
    let bytes = y4m(4, 4, "420jpeg", 3, |_, _, _| [10, 20, 30]);
    let cut = &bytes[..bytes.len() - 5];
    let got: Vec<_> = Y4mSource::new(cut, "stdin").unwrap().collect();
    assert_eq!(got.len(), 3);
    let e = got[2].as_ref().unwrap_err().to_string();
    assert!(
        e.contains("stdin") && e.contains("Y4M frame 3") && e.contains("cut short"),
        "{e}"
    );
    let mut bad = bytes.clone();
    let second = 4 * 4 * 3 / 2 + 6 + bad.iter().position(|&b| b == b'\n').unwrap() + 1;
    bad[second..second + 5].copy_from_slice(b"FRAMX");
    // One bad FRAME line: its frame is an error, and the stream goes on
    // (numbered as before) so `--on-bad-frame skip` reaches frame 3.
    let got: Vec<_> = Y4mSource::new(&bad[..], "stdin").unwrap().collect();
    assert_eq!(got.len(), 3);
    let e = got[1].as_ref().unwrap_err().to_string();
    assert!(e.contains("Y4M frame 2") && e.contains("FRAMX"), "{e}");
    assert_eq!(got[2].as_ref().unwrap().number, 3);
    // Two in a row: the data is not frames of the header's size; the
    // stream ends with an error naming the colour space.
    let third = second + 4 * 4 * 3 / 2 + 6;
    bad[third..third + 5].copy_from_slice(b"FRAMY");
    let got: Vec<_> = Y4mSource::new(&bad[..], "stdin").unwrap().collect();
    assert_eq!(got.len(), 3);
    let e = got[2].as_ref().unwrap_err().to_string();
    assert!(
        e.contains("Y4M frame 3") && e.contains("colour space"),
        "{e}"
    );
    for (input, says) in [
        (&b""[..], "empty"),
        (&b"P6 4 4 255\n"[..], "not a YUV4MPEG2"),
        (&b"YUV4MPEG2 W4 H4 C420p10\n"[..], "more than 8 bits"),
        (&b"YUV4MPEG2 W4 H4"[..], "ends inside a header line"),
    ] {
        let e = Y4mSource::new(input, "stdin").unwrap_err().to_string();
        assert!(e.contains("stdin: Y4M header") && e.contains(says), "{e}");
    }
}

/// A reader of an endless Y4M stream that counts the bytes read.
struct Endless {
    header: Vec<u8>,
    frame: Vec<u8>,
    at: usize,
    read: Rc<Cell<usize>>,
}

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let total = self.header.len() + self.frame.len();
        let mut n = 0;
        while n < buf.len() {
            let pos = if self.at < self.header.len() {
                self.header[self.at]
            } else {
                let k = (self.at - self.header.len()) % (total - self.header.len());
                self.frame[k]
            };
            buf[n] = pos;
            n += 1;
            self.at += 1;
        }
        self.read.set(self.read.get() + n);
        Ok(n)
    }
}

#[test]
fn a_stream_is_read_as_far_as_the_frames_asked_for() {
    let read = Rc::new(Cell::new(0));
    let frame_bytes = 64 * 48 * 3 / 2;
    let mut frame = b"FRAME\n".to_vec();
    frame.extend(vec![90u8; frame_bytes]);
    let endless = Endless {
        header: b"YUV4MPEG2 W64 H48 C420jpeg\n".to_vec(),
        frame,
        at: 0,
        read: read.clone(),
    };
    // Frames 3..5 of an endless stream: the selection ends the run, and
    // no more than a read buffer (64 KiB) past frame 5 is read.
    let sel = FrameSelection::parse(Some("3..5"), 1).unwrap();
    let got: Vec<usize> = Select::new(Y4mSource::new(endless, "endless").unwrap(), sel)
        .map(|f| f.unwrap().number)
        .collect();
    assert_eq!(got, [3, 4, 5]);
    assert!(
        read.get() < 5 * (frame_bytes + 6) + (1 << 16) + 100,
        "{} bytes read",
        read.get()
    );
}

#[test]
fn selections_pick_frames_without_decoding_the_others() {
    let d = tmpdir("select");
    for n in 1..=12 {
        write_png(d.join(format!("{n:04}.png")), flat(n as u8).view()).unwrap();
    }
    // Frame 4 does not decode: it is passed over unread when not selected.
    fs::write(d.join("0004.png"), "not a PNG").unwrap();
    let s = Sequence::open_frames(&d).unwrap();
    let pick = |range: Option<&str>, every: usize| -> Vec<usize> {
        let sel = FrameSelection::parse(range, every).unwrap();
        Select::new(s.source(), sel)
            .map(|f| {
                let f = f.unwrap();
                assert_eq!(f.image.pixel(0, 0).unwrap(), &[f.number as u8]);
                f.number
            })
            .collect()
    };
    assert_eq!(pick(Some("5..9"), 1), [5, 6, 7, 8, 9]);
    assert_eq!(pick(Some("1..12"), 4), [1, 5, 9]);
    assert_eq!(pick(Some("10.."), 1), [10, 11, 12]);
    assert_eq!(pick(Some("7"), 1), [7]);
    assert_eq!(pick(Some("2..=3"), 1), [2, 3]);
    let sel = FrameSelection::parse(Some("2..11"), 3).unwrap();
    let src = Select::new(s.source(), sel);
    assert_eq!(src.remaining(), Some(4)); // 2, 5, 8, 11
    for (text, every) in [("0..3", 1), ("5..2", 1), ("a..b", 1), ("1..3", 0)] {
        assert!(
            FrameSelection::parse(Some(text), every).is_err(),
            "{text} every {every}"
        );
    }
    let _ = fs::remove_dir_all(&d);
}

/// Records what it is given; steps keep the box.
struct Recorder {
    bbox: BBox,
    channels: Vec<usize>,
}

impl Tracker for Recorder {
    fn name(&self) -> &'static str {
        "recorder"
    }
    fn init(
        &mut self,
        frame: bayestrack_image::ImageView<'_, u8>,
        target: BBox,
    ) -> TrackerResult<()> {
        self.bbox = target;
        self.channels.push(frame.channels());
        Ok(())
    }
    fn step(&mut self, frame: bayestrack_image::ImageView<'_, u8>) -> TrackerResult<Estimate> {
        self.channels.push(frame.channels());
        Ok(Estimate {
            bbox: self.bbox,
            pose: None,
            particles: 0,
            evaluations: 1,
            lost: false,
        })
    }
}

/// Generates frames on demand and counts how many it has handed out.
struct Counting {
    made: Rc<Cell<usize>>,
    len: usize,
    gray_at: usize,
}

impl Iterator for Counting {
    type Item = Result<Frame, OtbError>;
    fn next(&mut self) -> Option<Self::Item> {
        let k = self.made.get();
        if k == self.len {
            return None;
        }
        self.made.set(k + 1);
        let channels = if k + 1 == self.gray_at { 1 } else { 3 };
        Some(Ok(Frame {
            number: k + 1,
            name: format!("frame {}", k + 1),
            image: Image::new(16, 12, channels, 100).unwrap(),
        }))
    }
}

impl FrameSource for Counting {
    fn describe(&self) -> String {
        "generated".into()
    }
    fn remaining(&self) -> Option<usize> {
        Some(self.len - self.made.get())
    }
}

#[test]
fn the_loop_pulls_one_frame_at_a_time_and_keeps_channels_consistent() {
    let made = Rc::new(Cell::new(0));
    let mut source = Counting {
        made: made.clone(),
        len: 500,
        gray_at: 7,
    };
    let mut tracker = Recorder {
        bbox: BBox::new(0.0, 0.0, 1.0, 1.0),
        channels: Vec::new(),
    };
    let mut seen = 0;
    let run = track_source(
        &mut tracker,
        &mut source,
        BBox::new(3.0, 3.0, 4.0, 4.0),
        OnBadFrame::Stop,
        |f| {
            // When frame k reaches the sink, exactly k frames were made:
            // nothing is read ahead or collected first.
            assert_eq!(made.get(), f.index + 1);
            assert_eq!(f.number, f.index + 1);
            seen += 1;
            Ok(())
        },
    )
    .unwrap();
    assert_eq!((seen, run.boxes.len(), run.numbers.len()), (500, 500, 500));
    // The gray frame 7 of a colour run reaches the tracker as RGB.
    assert_eq!(run.converted, [7]);
    assert!(tracker.channels.iter().all(|&c| c == 3));
}

#[test]
fn an_initial_box_partly_outside_is_clipped_and_one_wholly_outside_is_not() {
    let inside = BBox::new(2.0, 3.0, 5.0, 5.0);
    assert_eq!(clip_initial_box(inside, 20, 10), Some(inside));
    assert_eq!(
        clip_initial_box(BBox::new(-5.0, 10.0, 20.0, 20.0), 40, 20),
        Some(BBox::new(1.0, 10.0, 14.0, 11.0))
    );
    assert_eq!(
        clip_initial_box(BBox::new(15.0, 1.0, 10.0, 4.0), 20, 10),
        Some(BBox::new(15.0, 1.0, 6.0, 4.0))
    );
    assert_eq!(
        clip_initial_box(BBox::new(30.0, 1.0, 5.0, 5.0), 20, 10),
        None
    );
    assert_eq!(
        clip_initial_box(BBox::new(-9.0, 1.0, 9.5, 5.0), 20, 10),
        None
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 256, ..Default::default() })]

    /// Arbitrary bytes after a Y4M header (and arbitrary headers): frames or
    /// errors naming the stream, never a panic, and frames of the header's size.
    #[test]
    fn any_y4m_bytes_give_frames_or_errors(
        header in proptest::sample::select(vec![
            "YUV4MPEG2 W3 H2 C420jpeg\n", "YUV4MPEG2 W4 H3 Cmono\n", "YUV4MPEG2 W2 H2 C444alpha\n",
            "YUV4MPEG2 W5 H1 C422 XCOLORRANGE=FULL\n", "YUV4MPEG2 W32768 H32768\n",
        ]),
        body in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..200),
        frames in 0usize..3,
    ) {
        let mut bytes = header.as_bytes().to_vec();
        for _ in 0..frames {
            bytes.extend(b"FRAME\n");
            bytes.extend(&body);
        }
        bytes.extend(&body);
        if let Ok(src) = Y4mSource::new(&bytes[..], "fuzz") {
            let (w, h) = (src.header().width, src.header().height);
            for f in src.take(10) {
                match f {
                    Ok(f) => proptest::prop_assert_eq!((f.image.width(), f.image.height()), (w, h)),
                    Err(e) => proptest::prop_assert!(e.to_string().contains("fuzz"), "{}", e),
                }
            }
        }
    }
}
