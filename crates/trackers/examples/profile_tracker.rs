//! Tracker-only time and a box digest of one registered tracker on a shared
//! real sequence, for profiling (callgrind: `--toggle-collect=*run_tracker*`
//! counts the tracker calls only, not the JPEG decoding).
//!
//! `cargo run --release -p bayestrack-trackers --example profile_tracker -- Crossing hkpf [repeats] [key=value ...]`
//! (options as `--set` takes them, e.g. `dcf 1 fdsst=true`).
//! `BAYESTRACK_SIMD=avx2` (or `scalar`, `sse2`) caps the kernels' level, to
//! time the AVX2 paths on a machine with AVX-512 (the boxes are the same).

use bayestrack_image::{BBox, Image};
use bayestrack_trackers::{Tracker, tracker_info};
use std::hint::black_box;
use std::time::Instant;

fn frames(name: &str) -> (Vec<Image<u8>>, BBox) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/sequences")
        .join(name);
    let gt = std::fs::read_to_string(dir.join("groundtruth_rect.txt")).expect("ground truth");
    let v: Vec<f64> = gt
        .lines()
        .next()
        .expect("a first line")
        .split([',', '\t', ' '])
        .filter(|s| !s.is_empty())
        .map(|s| s.trim().parse().expect("a number"))
        .collect();
    let frames = bayestrack_image::list_frames(&dir)
        .expect("frames")
        .iter()
        .map(|p| bayestrack_image::read_frame(p).expect("a frame"))
        .collect();
    (frames, BBox::new(v[0], v[1], v[2], v[3]))
}

/// Every tracker call of one pass; returns an FNV digest of the boxes' bits
/// and pushes the boxes to `boxes`.
#[inline(never)]
fn run_tracker(
    tracker: &mut dyn Tracker,
    frames: &[Image<u8>],
    first: BBox,
    boxes: &mut Vec<BBox>,
    lost: &mut usize,
) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325_u64;
    let mut mix = |x: f64| {
        for b in x.to_bits().to_le_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
    };
    tracker.init(frames[0].view(), first).expect("init");
    for f in &frames[1..] {
        let e = tracker.step(black_box(f.view())).expect("step");
        let b = e.bbox;
        *lost += usize::from(e.lost);
        boxes.push(b);
        mix(b.x);
        mix(b.y);
        mix(b.width);
        mix(b.height);
    }
    h
}

fn main() {
    if let Some(level) = bayestrack_image::simd::cap_from_env().expect("BAYESTRACK_SIMD") {
        eprintln!("kernels capped at {level:?}");
    }
    let mut args = std::env::args().skip(1);
    let seq = args.next().unwrap_or_else(|| "Crossing".into());
    let name = args.next().unwrap_or_else(|| "hkpf".into());
    let repeats: usize = args.next().map_or(1, |s| s.parse().expect("repeats"));
    let set: Vec<(String, String)> = args
        .map(|kv| {
            let (k, v) = kv.split_once('=').expect("options as key=value");
            (k.to_string(), v.to_string())
        })
        .collect();
    let info = tracker_info(&name).expect("a registered tracker");
    let (frames, first) = frames(&seq);
    let mut best = f64::INFINITY;
    let mut digest = 0;
    let mut boxes = Vec::with_capacity(frames.len());
    let mut lost = 0;
    for _ in 0..repeats {
        boxes.clear();
        lost = 0;
        let mut tracker = info.build_with(0, &set).expect("tracker options");
        let t0 = Instant::now();
        digest = run_tracker(tracker.as_mut(), &frames, first, &mut boxes, &mut lost);
        best = best.min(t0.elapsed().as_secs_f64());
    }
    // PROFILE_BOXES=FILE: the boxes, one `x,y,width,height` line a frame
    // (Rust's shortest round-trip decimal), to compare two builds.
    if let Ok(path) = std::env::var("PROFILE_BOXES") {
        let text: String = boxes
            .iter()
            .map(|b| format!("{:?},{:?},{:?},{:?}\n", b.x, b.y, b.width, b.height))
            .collect();
        std::fs::write(path, text).expect("write the boxes");
    }
    println!(
        "{name} on {seq}: {} frames, digest {digest:016x}, best {:.0} fps, {lost} reported lost",
        frames.len(),
        (frames.len() - 1) as f64 / best
    );
}
