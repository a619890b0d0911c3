//! Criterion benchmarks of the colour and motion cues' kernels (single
//! thread): RGB histograms (3x256, 3x16) on a noise frame and on a smooth
//! frame (runs of equal pixels, where increments of one counter serialise),
//! their L2 and Bhattacharyya distances, the HSV skin map of eq. 8 (Lee, Jo
//! and Kang (paper 003)), the interframe difference of eq. 7, and the HSV bin
//! map with a kernel histogram and a ring (on the smooth frame and on
//! Couple's first frame, hist-pf-scale's case), and the exhaustive L2
//! `histogram_search` of the ball trackers (tall and wide windows).
//!
//! `CUES_COUNT=<iterations> cargo bench --bench cues -- <substring>` skips
//! criterion and runs each kernel whose name contains the substring that
//! many times, for instruction counts under
//! `valgrind --tool=cachegrind` (run twice with different counts and
//! divide the difference by the difference of the counts).

use std::hint::black_box;

use bayestrack_appearance::{
    BinMap, HistogramDistance, HsvBinning, KernelHistogram, RgbHistogram, SkinModel,
    histogram_search, interframe_difference_into,
};
use bayestrack_image::{Image, Rect, rgb_to_gray};
use criterion::{Criterion, Throughput};

use bayestrack_testkit::noise;

/// A smooth 320x240 RGB frame: slow colour ramps with a little noise, so
/// neighbouring pixels often share a bin (as in real video).
fn smooth(seed: u32) -> Image<u8> {
    let n = noise(320, 240, 3, seed);
    let mut img = Image::new(320, 240, 3, 0u8).unwrap();
    for y in 0..240 {
        for x in 0..320 {
            for c in 0..3 {
                let base = 60.0 + 0.3 * x as f32 + 30.0 * ((y as f32 * 0.05) + c as f32).sin();
                let v = base + f32::from(n.get(x, y, c).unwrap() % 4);
                img.set(x, y, c, v.clamp(0.0, 255.0) as u8);
            }
        }
    }
    img
}

type Kernel<'a> = (String, u64, Box<dyn FnMut() + 'a>);

/// Every benchmarked kernel: name, elements per call (pixels or bins) and
/// the call.
fn kernels<'a>(data: &'a Data) -> Vec<Kernel<'a>> {
    let mut v: Vec<Kernel<'a>> = Vec::new();
    let window = Rect::new(100, 80, 40, 40);
    for (frame, label) in [(&data.noise, "noise"), (&data.smooth, "smooth")] {
        for bins in [256, 16] {
            let mut h = RgbHistogram::new(bins).unwrap();
            v.push((
                format!("RgbHistogram 3x{bins} of a 40x40 window ({label})"),
                1600,
                Box::new(move || h.compute(black_box(frame.view()), window).unwrap()),
            ));
        }
    }
    for bins in [256, 16] {
        let a = RgbHistogram::from_window(data.noise.view(), window, bins).unwrap();
        let b =
            RgbHistogram::from_window(data.noise.view(), Rect::new(10, 10, 40, 40), bins).unwrap();
        let (a2, b2) = (a.clone(), b.clone());
        v.push((
            format!("L2 distance 3x{bins}"),
            3 * bins as u64,
            Box::new(move || {
                black_box(black_box(&a).l2_distance(&b).unwrap());
            }),
        ));
        v.push((
            format!("Bhattacharyya distance 3x{bins}"),
            3 * bins as u64,
            Box::new(move || {
                black_box(black_box(&a2).bhattacharyya_distance(&b2).unwrap());
            }),
        ));
    }
    let model = SkinModel::new(0.05, 0.4, SkinModel::PAPER_SIGMA).unwrap();
    for (frame, label) in [(&data.noise, "noise"), (&data.smooth, "smooth")] {
        let mut out = Image::new(320, 240, 1, 0f32).unwrap();
        v.push((
            format!("skin map 320x240 RGB ({label})"),
            320 * 240,
            Box::new(move || {
                model
                    .map_rgb_into(black_box(frame.view()), &mut out.view_mut())
                    .unwrap()
            }),
        ));
    }
    v.push((
        "skin window_mean 40x40 (noise)".to_string(),
        1600,
        Box::new(move || {
            black_box(
                model
                    .window_mean(black_box(data.noise.view()), window)
                    .unwrap(),
            );
        }),
    ));
    let mut out = Image::new(320, 240, 1, 0f32).unwrap();
    v.push((
        "IFD 320x240 gray u8".to_string(),
        320 * 240,
        Box::new(move || {
            interframe_difference_into(
                black_box(data.gray1.view()),
                data.gray0.view(),
                &mut out.view_mut(),
            )
            .unwrap()
        }),
    ));
    let mut out = Image::new(320, 240, 1, 0f32).unwrap();
    v.push((
        "IFD 320x240 RGB u8 (luma)".to_string(),
        320 * 240,
        Box::new(move || {
            interframe_difference_into(
                black_box(data.noise.view()),
                data.prev.view(),
                &mut out.view_mut(),
            )
            .unwrap()
        }),
    ));
    let mut out = Image::new(320, 240, 1, 0f32).unwrap();
    v.push((
        "IFD 320x240 gray f32".to_string(),
        320 * 240,
        Box::new(move || {
            interframe_difference_into(
                black_box(data.unit1.view()),
                data.unit0.view(),
                &mut out.view_mut(),
            )
            .unwrap()
        }),
    ));
    let binning = HsvBinning::perez();
    let mut map = BinMap::new();
    let b2 = binning.clone();
    v.push((
        "HSV bin map 320x240 (Perez binning)".to_string(),
        320 * 240,
        Box::new(move || {
            b2.bin_map_into(
                black_box(data.smooth.view()),
                Rect::new(0, 0, 320, 240),
                &mut map,
            )
            .unwrap()
        }),
    ));
    let mut map = BinMap::new();
    binning
        .bin_map_into(data.smooth.view(), Rect::new(0, 0, 320, 240), &mut map)
        .unwrap();
    let ring_map = map.clone();
    let mut h = KernelHistogram::new(binning.len());
    let mut reference = KernelHistogram::new(binning.len());
    reference
        .ellipse(&map, 150.0, 100.0, 20.0, 30.0, 1)
        .unwrap();
    v.push((
        "KernelHistogram ellipse 40x60 + Bhattacharyya (110 bins)".to_string(),
        40 * 60,
        Box::new(move || {
            h.ellipse(&map, black_box(152.0), 101.0, 20.0, 30.0, 1)
                .unwrap();
            black_box(h.bhattacharyya(&reference).unwrap());
        }),
    ));
    // hist-pf-scale's background: the ring between a 40x60 box and the
    // box grown 1.5 times (its default), every pixel.
    let mut ring = KernelHistogram::new(binning.len());
    v.push((
        "KernelHistogram ring 40x60 x1.5 (110 bins)".to_string(),
        60 * 90 - 40 * 60,
        Box::new(move || {
            ring.ring(&ring_map, black_box(152.0), 101.0, 20.0, 30.0, 1.5, 1)
                .unwrap();
            black_box(ring.total());
        }),
    ));
    // hist-pf-scale's case on real video: Couple's first frame binned, the
    // first box (25 x 62, centre (62, 76.5) 0-based) at 16 positions a few
    // pixels apart, one per call (as particles): its ellipse and
    // Bhattacharyya, and its ring (x1.5). Skipped without the data folder.
    let couple = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/sequences/Couple/img/0001.jpg");
    if let Ok(frame) = bayestrack_image::read_frame_rgb(couple) {
        let mut map = BinMap::new();
        binning
            .bin_map_into(frame.view(), Rect::new(0, 0, 320, 240), &mut map)
            .unwrap();
        let ring_map = map.clone();
        let mut reference = KernelHistogram::new(binning.len());
        reference.ellipse(&map, 62.0, 76.5, 12.5, 31.0, 1).unwrap();
        let at = |k: usize| (60.0 + (k % 4) as f64 * 1.3, 74.0 + (k / 4 % 4) as f64 * 1.7);
        let (mut h, mut k) = (KernelHistogram::new(binning.len()), 0);
        v.push((
            "KernelHistogram ellipse 25x62 + Bhattacharyya (Couple frame 1)".to_string(),
            25 * 62,
            Box::new(move || {
                k += 1;
                let (cx, cy) = at(k);
                h.ellipse(&map, black_box(cx), cy, 12.5, 31.0, 1).unwrap();
                black_box(h.bhattacharyya(&reference).unwrap());
            }),
        ));
        let (mut ring, mut k) = (KernelHistogram::new(binning.len()), 0);
        v.push((
            "KernelHistogram ring 25x62 x1.5 (Couple frame 1)".to_string(),
            38 * 93 - 25 * 62,
            Box::new(move || {
                k += 1;
                let (cx, cy) = at(k);
                ring.ring(&ring_map, black_box(cx), cy, 12.5, 31.0, 1.5, 1)
                    .unwrap();
                black_box(ring.total());
            }),
        ));
    }
    // The ball trackers' exhaustive search: a tall 20x48 window (as on
    // Crossing) over a region with 41x41 positions, and a wide 48x20 one.
    for (w, h, label) in [(20, 48, "tall"), (48, 20, "wide")] {
        let frame = &data.smooth;
        let reference =
            RgbHistogram::from_window(frame.view(), Rect::new(150, 90, w, h), 256).unwrap();
        let region = Rect::new(130, 70, w + 40, h + 40);
        v.push((
            format!("histogram_search L2 {w}x{h} ({label}), 41x41 positions, 3x256 (smooth)"),
            41 * 41,
            Box::new(move || {
                black_box(
                    histogram_search(
                        black_box(frame.view()),
                        &reference,
                        w,
                        h,
                        region,
                        HistogramDistance::L2,
                    )
                    .unwrap(),
                );
            }),
        ));
    }
    v
}

struct Data {
    noise: Image<u8>,
    prev: Image<u8>,
    smooth: Image<u8>,
    gray0: Image<u8>,
    gray1: Image<u8>,
    unit0: Image<f32>,
    unit1: Image<f32>,
}

impl Data {
    fn new() -> Self {
        let noise = noise(320, 240, 3, 4);
        let prev = self::noise(320, 240, 3, 5);
        let gray1 = rgb_to_gray(noise.view()).unwrap();
        let gray0 = rgb_to_gray(prev.view()).unwrap();
        Self {
            smooth: smooth(6),
            unit0: gray0.to_unit_f32(),
            unit1: gray1.to_unit_f32(),
            noise,
            prev,
            gray0,
            gray1,
        }
    }
}

fn main() {
    let data = Data::new();
    let filter: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let selected = |name: &str| filter.is_empty() || filter.iter().any(|f| name.contains(f));
    if let Some(count) = std::env::var("CUES_COUNT")
        .ok()
        .and_then(|s| s.parse::<u64>().ok())
    {
        for (name, _, mut run) in kernels(&data) {
            if selected(&name) {
                for _ in 0..count {
                    run();
                }
                println!("ran {count} x {name}");
            }
        }
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    for (name, elements, mut run) in kernels(&data) {
        let mut group = c.benchmark_group("cues");
        group.throughput(Throughput::Elements(elements));
        group.bench_function(&name, |b| b.iter(&mut run));
        group.finish();
    }
    c.final_summary();
}
