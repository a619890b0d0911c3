//! Criterion benchmarks for bayestrack-image.

use std::hint::black_box;

use bayestrack_image::{
    Affine2, Border, Connectivity, Image, ImageViewMut, label_components, open, rgb_to_gray_into,
    rgb_to_hsv_into, warp_into,
};
use criterion::{Criterion, criterion_group, criterion_main};

fn frame_rgb(w: usize, h: usize) -> Image<u8> {
    bayestrack_testkit::noise(w, h, 3, 12345)
}

fn bench_warp(c: &mut Criterion) {
    let pose = Affine2::from_rows([[1.1, 0.2, 120.0], [-0.15, 0.95, 80.0]]).unwrap();
    let gray_f32 = Image::from_fn(320, 240, |x, y| ((x * 7 + y * 13) % 256) as f32).unwrap();
    let rgb_u8 = frame_rgb(320, 240);
    let gray_u8 = Image::from_fn(320, 240, |x, y| ((x * 7 + y * 13) % 256) as u8).unwrap();
    let mut buf = vec![0f32; 36 * 36 * 3];
    c.bench_function("warp_into 36x36 affine patch (gray f32 320x240)", |b| {
        b.iter(|| {
            let mut patch = ImageViewMut::from_slice(&mut buf, 36, 36, 1, 36).unwrap();
            warp_into(gray_f32.view(), black_box(&pose), Border::Error, &mut patch).unwrap();
            black_box(buf[0])
        })
    });
    c.bench_function("warp_into 36x36 affine patch (gray u8 320x240)", |b| {
        b.iter(|| {
            let mut patch = ImageViewMut::from_slice(&mut buf, 36, 36, 1, 36).unwrap();
            warp_into(gray_u8.view(), black_box(&pose), Border::Error, &mut patch).unwrap();
            black_box(buf[0])
        })
    });
    c.bench_function("warp_into 36x36 affine patch (RGB u8 320x240)", |b| {
        b.iter(|| {
            let mut patch = ImageViewMut::from_slice(&mut buf, 36, 36, 3, 108).unwrap();
            warp_into(rgb_u8.view(), black_box(&pose), Border::Error, &mut patch).unwrap();
            black_box(buf[0])
        })
    });
}

fn bench_hsv(c: &mut Criterion) {
    let frame = frame_rgb(320, 240);
    let mut out = Image::new(320, 240, 3, 0f32).unwrap();
    c.bench_function("rgb_to_hsv_into 320x240", |b| {
        b.iter(|| rgb_to_hsv_into(black_box(frame.view()), &mut out.view_mut()).unwrap())
    });
    let mut gray = Image::new(320, 240, 1, 0u8).unwrap();
    c.bench_function("rgb_to_gray_into 320x240", |b| {
        b.iter(|| rgb_to_gray_into(black_box(frame.view()), &mut gray.view_mut()).unwrap())
    });
}

fn bench_blobs(c: &mut Criterion) {
    // Sparse blobs: about 6% of pixels set, in small clusters.
    let noise = frame_rgb(320, 240);
    let mask = Image::from_fn(320, 240, |x, y| noise.get(x / 4, y / 4, 0).unwrap() > 240).unwrap();
    c.bench_function("label_components 320x240 (8-connectivity)", |b| {
        b.iter(|| label_components(black_box(mask.view()), Connectivity::Eight).unwrap())
    });
    c.bench_function("open r=1 320x240", |b| {
        b.iter(|| open(black_box(mask.view()), 1).unwrap())
    });
}

criterion_group!(benches, bench_warp, bench_hsv, bench_blobs);
criterion_main!(benches);
