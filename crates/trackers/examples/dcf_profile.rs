//! Runs a correlation-filter tracker over a real sequence with the frames
//! decoded first, so that a profiler sees the tracker alone:
//!
//! `valgrind --tool=callgrind --toggle-collect='*dcf_profile*run*' \
//!   target/release/examples/dcf_profile ../shared/data/sequences/Crossing dcf`
//!
//! Prints a hash of the boxes' bits and the tracker-only fps.

use std::hint::black_box;

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{
    DcfTracker, DcfTrackerConfig, StapleTracker, StapleTrackerConfig, Tracker,
};

fn load(dir: &std::path::Path) -> (Vec<Image<u8>>, BBox) {
    let gt = std::fs::read_to_string(dir.join("groundtruth_rect.txt")).expect("ground truth");
    let v: Vec<f64> = gt
        .lines()
        .next()
        .expect("a first box")
        .split([',', '\t', ' '])
        .filter(|s| !s.is_empty())
        .map(|s| s.trim().parse().expect("a number"))
        .collect();
    let frames = bayestrack_image::list_frames(dir)
        .expect("frames")
        .iter()
        .map(|p| bayestrack_image::read_frame(p).expect("a frame"))
        .collect();
    (frames, BBox::new(v[0], v[1], v[2], v[3]))
}

/// Init on frame 0, step through the rest `reps` times; returns a checksum
/// of the boxes.
#[inline(never)]
fn run(tracker: &mut dyn Tracker, frames: &[Image<u8>], first: BBox, reps: usize) -> u64 {
    // FNV-1a over the bits of every box
    let mut sum = 0xcbf2_9ce4_8422_2325u64;
    for _ in 0..reps {
        tracker.init(frames[0].view(), first).expect("init");
        for f in &frames[1..] {
            let e = tracker.step(black_box(f.view())).expect("step");
            let b = e.bbox;
            for v in [b.x, b.y, b.width, b.height] {
                sum = (sum ^ v.to_bits()).wrapping_mul(0x100_0000_01b3);
            }
        }
    }
    sum
}

fn main() {
    let mut args = std::env::args().skip(1);
    let dir = args
        .next()
        .unwrap_or_else(|| "../shared/data/sequences/Crossing".into());
    let name = args.next().unwrap_or_else(|| "dcf".into());
    let reps: usize = args.next().map_or(1, |s| s.parse().expect("reps"));
    let (frames, first) = load(std::path::Path::new(&dir));
    let mut tracker: Box<dyn Tracker> = match name.as_str() {
        "dcf" => Box::new(DcfTracker::new(DcfTrackerConfig::default()).expect("dcf")),
        "dcf-staple" => {
            Box::new(StapleTracker::new(StapleTrackerConfig::default()).expect("staple"))
        }
        // the same with the other scale filter than the default's
        "dcf-other-scale" => {
            let mut c = DcfTrackerConfig::default();
            c.fdsst = !c.fdsst;
            Box::new(DcfTracker::new(c).expect("dcf"))
        }
        "dcf-staple-other-scale" => {
            let mut c = StapleTrackerConfig::default();
            c.fdsst = !c.fdsst;
            Box::new(StapleTracker::new(c).expect("staple"))
        }
        other => panic!("unknown tracker {other}"),
    };
    let t = std::time::Instant::now();
    let sum = run(tracker.as_mut(), &frames, first, reps);
    let s = t.elapsed().as_secs_f64();
    let n = reps * (frames.len() - 1);
    println!(
        "{name}: {n} steps, box hash {sum:016x}, {:.0} fps (init included)",
        n as f64 / s
    );
}
