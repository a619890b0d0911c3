//! PNG/JPEG frame folders and PNG output (feature `io`). The OTB layout
//! (ground truth, sequence tables) is `bayestrack-otb`'s.

use std::fs;
use std::path::{Path, PathBuf};

use crate::{BBox, Image, ImageError, ImageView, Result, Rgb, draw_box, gray_to_rgb};

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> ImageError + '_ {
    move |source| ImageError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn is_frame_file(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg"))
}

/// The number formed by the last run of digits in a file stem
/// (`0001` -> 1, `img00042` -> 42).
fn frame_number(p: &Path) -> Option<u64> {
    let stem = p.file_stem()?.to_str()?;
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    // just past the last character that is not a digit (which may take
    // more than one byte: `ť8.png`)
    let start = stem[..end]
        .char_indices()
        .rev()
        .find(|(_, c)| !c.is_ascii_digit())
        .map_or(0, |(i, c)| i + c.len_utf8());
    stem[start..end].parse().ok()
}

/// Lists the PNG/JPEG frames of a folder in numeric order.
///
/// Accepts either the frame folder itself or a sequence folder with an
/// `img/` sub-folder (OTB layout: `img/0001.jpg`, `img/img00001.png`). Files
/// are ordered by the last number in their name, then by name, so
/// `2.png` comes before `10.png`.
///
/// # Errors
/// [`ImageError::Io`] if the folder cannot be read; [`ImageError::NoFrames`]
/// if it holds no PNG/JPEG file.
pub fn list_frames(dir: impl AsRef<Path>) -> Result<Vec<PathBuf>> {
    let dir = dir.as_ref();
    let mut frames = frames_in(dir)?;
    if frames.is_empty() && dir.join("img").is_dir() {
        frames = frames_in(&dir.join("img"))?;
    }
    if frames.is_empty() {
        return Err(ImageError::NoFrames {
            path: dir.to_path_buf(),
        });
    }
    frames.sort_by(|a, b| {
        let ka = frame_number(a).unwrap_or(u64::MAX);
        let kb = frame_number(b).unwrap_or(u64::MAX);
        ka.cmp(&kb).then_with(|| a.cmp(b))
    });
    Ok(frames)
}

fn frames_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).map_err(io_err(dir))? {
        let p = entry.map_err(io_err(dir))?.path();
        if p.is_file() && is_frame_file(&p) {
            out.push(p);
        }
    }
    Ok(out)
}

/// Whether the file holds the format's whole stream, wherever it ends.
///
/// The JPEG decoder fills a truncated scan with gray instead of failing,
/// so truncation is caught here: the JPEG markers are walked from the
/// start of image (segments by their lengths, entropy-coded data up to the
/// next marker) until the end-of-image marker (`FF D9`), and the PNG chunks
/// by their lengths until `IEND`. Bytes after that end are ignored: cameras
/// and editors append data (thumbnails, maker notes) after the image, and
/// decoders stop at its end.
fn has_end_marker(bytes: &[u8], format: image::ImageFormat) -> bool {
    match format {
        image::ImageFormat::Jpeg => jpeg_end(bytes).is_some(),
        image::ImageFormat::Png => png_end(bytes).is_some(),
        _ => true,
    }
}

/// The offset just past a JPEG's end-of-image marker, walking its
/// structure from the start-of-image marker; `None` when the stream ends
/// first (a file cut short) or is not a JPEG.
fn jpeg_end(bytes: &[u8]) -> Option<usize> {
    if bytes.get(..2)? != [0xFF, 0xD8] {
        return None;
    }
    let mut at = 2;
    loop {
        // A marker: 0xFF, optional fill bytes 0xFF, then the code.
        if *bytes.get(at)? != 0xFF {
            return None;
        }
        while *bytes.get(at)? == 0xFF {
            at += 1;
        }
        let code = *bytes.get(at)?;
        at += 1;
        match code {
            0xD9 => return Some(at),
            // Markers without a length: TEM, RSTn, a stray SOI.
            0x01 | 0xD0..=0xD8 => continue,
            _ => {}
        }
        let len = usize::from(u16::from_be_bytes([*bytes.get(at)?, *bytes.get(at + 1)?]));
        if len < 2 {
            return None;
        }
        at += len;
        if code == 0xDA {
            // Entropy-coded data after a start of scan: it ends at the first
            // 0xFF that is not a stuffed 0x00, a fill 0xFF or a restart marker.
            loop {
                let ff = at + bytes.get(at..)?.iter().position(|&b| b == 0xFF)?;
                match *bytes.get(ff + 1)? {
                    0x00 | 0xD0..=0xD7 => at = ff + 2,
                    0xFF => at = ff + 1,
                    _ => {
                        at = ff;
                        break;
                    }
                }
            }
        }
    }
}

/// The offset just past a PNG's `IEND` chunk, walking the chunks by their
/// lengths; `None` when the file ends first.
fn png_end(bytes: &[u8]) -> Option<usize> {
    const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    if bytes.get(..8)? != SIGNATURE {
        return None;
    }
    let mut at = 8usize;
    loop {
        let head = bytes.get(at..at + 8)?;
        let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
        let end = at.checked_add(12)?.checked_add(len)?;
        if end > bytes.len() {
            return None;
        }
        if &head[4..8] == b"IEND" {
            return Some(end);
        }
        at = end;
    }
}

/// Decodes the file at `path`; a JPEG's pixels go into `buffer`'s memory
/// ([`decode_bytes`]).
fn decode(path: &Path, buffer: Vec<u8>) -> Result<image::DynamicImage> {
    let bytes = fs::read(path).map_err(io_err(path))?;
    decode_bytes(&bytes, path, buffer)
}

/// Decodes a PNG/JPEG file's `bytes`; `path` names it in errors (and
/// gives the format when the bytes do not). A JPEG is decoded into
/// `buffer` (resized, its memory kept), a PNG into new memory.
fn decode_bytes(bytes: &[u8], path: &Path, buffer: Vec<u8>) -> Result<image::DynamicImage> {
    let format = match image::guess_format(bytes) {
        Ok(format) => format,
        Err(guess) => {
            // The bytes start with no image signature: a file named .png
            // that is not one (text, another format) is not "truncated".
            let source = match image::ImageFormat::from_path(path) {
                Ok(named) => {
                    let ext = path
                        .extension()
                        .map_or(String::new(), |e| e.to_string_lossy().into_owned());
                    let kind = match named {
                        image::ImageFormat::Jpeg => "JPEG",
                        image::ImageFormat::Png => "PNG",
                        _ => "image",
                    };
                    image::ImageError::Decoding(image::error::DecodingError::new(
                        image::error::ImageFormatHint::Exact(named),
                        format!(
                            "not a {kind} file: its bytes do not start with the {kind} \
                             signature (another format, or text, named .{ext})"
                        ),
                    ))
                }
                Err(_) => guess,
            };
            return Err(ImageError::Decode {
                path: path.to_path_buf(),
                source,
            });
        }
    };
    if !has_end_marker(bytes, format) {
        return Err(ImageError::Truncated {
            path: path.to_path_buf(),
            format: format!("{format:?}"),
        });
    }
    let decoded = match format {
        image::ImageFormat::Jpeg => decode_jpeg(bytes, buffer),
        _ => None,
    };
    decoded
        .unwrap_or_else(|| image::load_from_memory_with_format(bytes, format))
        .map_err(|source| ImageError::Decode {
            path: path.to_path_buf(),
            source,
        })
}

/// The image crate's largest output by default (`image::Limits`'s
/// `max_alloc`, 512 MiB): a JPEG header may claim up to 65,535 x 65,535
/// pixels, and no buffer is allocated for more than this.
const MAX_JPEG_BYTES: usize = 512 * 1024 * 1024;

/// A JPEG decoded as `image::load_from_memory_with_format` decodes it,
/// into `data`'s memory, without its second pass over the headers and its
/// copy of the bytes:
/// the same decoder (zune-jpeg) with the same options (lenient, no size
/// limit of its own), the same output colours (gray stays gray, every
/// other colour space becomes RGB), the same 512 MiB limit on the output
/// and the same errors; tested pixel for pixel against it. `None` for the
/// kinds with alpha, which are left to the image crate.
fn decode_jpeg(bytes: &[u8], mut data: Vec<u8>) -> Option<image::ImageResult<image::DynamicImage>> {
    use zune_core::colorspace::ColorSpace;
    // The image crate reads the headers with the default output (RGB),
    // then decodes again with the output it chose: RGB where the input
    // is not gray, so the one decoder here is configured alike.
    let options = zune_core::options::DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(
        zune_core::bytestream::ZCursor::new(bytes),
        options,
    );
    if let Err(e) = decoder.decode_headers() {
        return Some(Err(jpeg_error(e)));
    }
    let (w, h) = decoder.dimensions()?;
    let out = match decoder.input_colorspace()? {
        ColorSpace::Luma => ColorSpace::Luma,
        ColorSpace::RGBA | ColorSpace::LumaA => return None,
        _ => ColorSpace::RGB,
    };
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(out));
    let size = decoder.output_buffer_size()?;
    if size > MAX_JPEG_BYTES {
        return Some(Err(image::ImageError::Limits(
            image::error::LimitError::from_kind(image::error::LimitErrorKind::InsufficientMemory),
        )));
    }
    // every byte is written by the decoder: a reused buffer's old pixels
    // need no clearing
    data.resize(size, 0);
    if let Err(e) = decoder.decode_into(&mut data) {
        return Some(Err(jpeg_error(e)));
    }
    // JPEG sizes are at most 65,535 a side
    let (w, h) = (u32::try_from(w).ok()?, u32::try_from(h).ok()?);
    Some(Ok(if out == ColorSpace::Luma {
        image::DynamicImage::ImageLuma8(image::ImageBuffer::from_raw(w, h, data)?)
    } else {
        image::DynamicImage::ImageRgb8(image::ImageBuffer::from_raw(w, h, data)?)
    }))
}

/// zune-jpeg's error as the image crate words it.
fn jpeg_error(err: zune_jpeg::errors::DecodeErrors) -> image::ImageError {
    use image::error::{
        DecodingError, ImageFormatHint, LimitError, LimitErrorKind, UnsupportedError,
        UnsupportedErrorKind,
    };
    use zune_jpeg::errors::DecodeErrors;
    let jpeg = ImageFormatHint::Exact(image::ImageFormat::Jpeg);
    match err {
        DecodeErrors::Unsupported(desc) => {
            image::ImageError::Unsupported(UnsupportedError::from_format_and_kind(
                jpeg,
                UnsupportedErrorKind::GenericFeature(format!("{desc:?}")),
            ))
        }
        DecodeErrors::LargeDimensions(_) => {
            image::ImageError::Limits(LimitError::from_kind(LimitErrorKind::DimensionError))
        }
        err => image::ImageError::Decoding(DecodingError::new(jpeg, err)),
    }
}

fn from_dynamic(img: image::DynamicImage, gray: bool) -> Image<u8> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let (data, ch) = if gray {
        (img.into_luma8().into_raw(), 1)
    } else {
        (img.into_rgb8().into_raw(), 3)
    };
    // The decoder guarantees the buffer length; zero-size images cannot decode.
    Image::from_vec(w, h, ch, data).expect("decoder returned a consistent buffer")
}

/// Reads a PNG/JPEG frame keeping its colour kind: gray files give 1
/// channel, colour files 3 channels (alpha dropped), 8 bits per channel.
///
/// # Errors
/// [`ImageError::Io`] if the file cannot be opened; [`ImageError::Truncated`]
/// if it lacks its end marker; [`ImageError::Decode`] (naming the file) if
/// it is corrupt or not an image;
/// [`ImageError::ZeroSize`] for an empty image.
pub fn read_frame(path: impl AsRef<Path>) -> Result<Image<u8>> {
    read_frame_into(path.as_ref(), Vec::new())
}

/// [`read_frame`], a JPEG decoded into `buffer`'s memory.
fn read_frame_into(path: &Path, buffer: Vec<u8>) -> Result<Image<u8>> {
    let img = decode(path, buffer)?;
    check_nonempty(&img)?;
    let gray = !img.color().has_color();
    Ok(from_dynamic(img, gray))
}

/// Pixel buffers of frames already used, for the next frames to be
/// decoded into ([`FramePool::read_frame`], [`FramePool::give_back`]).
///
/// Each decoded frame otherwise takes new memory, which the system maps
/// (and zeroes) page by page and takes back when the frame is dropped: for
/// a 320 x 240 video that is most of a run's page faults, about 7 % of a
/// fast tracker's whole run. Clones share the buffers, so the threads that
/// decode and the one that tracks can hand them round. The pool keeps at
/// most [`FramePool::MAX_BUFFERS`] buffers and [`FramePool::MAX_BYTES`]
/// bytes; what comes back beyond that is freed.
#[derive(Debug, Clone, Default)]
pub struct FramePool {
    buffers: std::sync::Arc<std::sync::Mutex<Vec<Vec<u8>>>>,
}

impl FramePool {
    /// The most buffers kept.
    pub const MAX_BUFFERS: usize = 16;
    /// The most bytes kept (buffers' capacities).
    pub const MAX_BYTES: usize = 256 << 20;

    /// An empty pool.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    fn buffers(&self) -> std::sync::MutexGuard<'_, Vec<Vec<u8>>> {
        // a buffer list is whole whatever a panicking holder was doing
        self.buffers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Reads a frame as [`read_frame`] does (the same pixels, the same
    /// errors), a JPEG decoded into a buffer given back earlier when there
    /// is one.
    ///
    /// # Errors
    /// As [`read_frame`].
    pub fn read_frame(&self, path: impl AsRef<Path>) -> Result<Image<u8>> {
        let buffer = self.buffers().pop().unwrap_or_default();
        read_frame_into(path.as_ref(), buffer)
    }

    /// Takes back a frame's pixels for a later [`FramePool::read_frame`]
    /// (any image's: only its memory is reused).
    pub fn give_back(&self, image: Image<u8>) {
        let buffer = image.into_vec();
        let mut buffers = self.buffers();
        let held: usize = buffers.iter().map(Vec::capacity).sum();
        if buffers.len() < Self::MAX_BUFFERS
            && held.saturating_add(buffer.capacity()) <= Self::MAX_BYTES
        {
            buffers.push(buffer);
        }
    }

    /// Buffers held now.
    #[must_use]
    pub fn len(&self) -> usize {
        self.buffers().len()
    }

    /// Whether no buffer is held.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Decodes a PNG/JPEG frame held in memory, as [`read_frame`] does a file;
/// `path` only names the source in errors (and gives the format by its
/// extension when the bytes do not).
///
/// # Errors
/// As [`read_frame`], without [`ImageError::Io`].
pub fn decode_frame(bytes: &[u8], path: impl AsRef<Path>) -> Result<Image<u8>> {
    let img = decode_bytes(bytes, path.as_ref(), Vec::new())?;
    check_nonempty(&img)?;
    let gray = !img.color().has_color();
    Ok(from_dynamic(img, gray))
}

/// Reads a PNG/JPEG frame as 1-channel gray.
///
/// # Errors
/// As [`read_frame`].
pub fn read_frame_gray(path: impl AsRef<Path>) -> Result<Image<u8>> {
    let img = decode(path.as_ref(), Vec::new())?;
    check_nonempty(&img)?;
    Ok(from_dynamic(img, true))
}

/// Reads a PNG/JPEG frame as 3-channel RGB (gray files are replicated).
///
/// # Errors
/// As [`read_frame`].
pub fn read_frame_rgb(path: impl AsRef<Path>) -> Result<Image<u8>> {
    let img = decode(path.as_ref(), Vec::new())?;
    check_nonempty(&img)?;
    Ok(from_dynamic(img, false))
}

fn check_nonempty(img: &image::DynamicImage) -> Result<()> {
    if img.width() == 0 || img.height() == 0 {
        return Err(ImageError::ZeroSize {
            width: img.width() as usize,
            height: img.height() as usize,
            channels: usize::from(img.color().channel_count()),
        });
    }
    Ok(())
}

/// Writes a 1- or 3-channel 8-bit image (any stride) as PNG.
///
/// # Errors
/// [`ImageError::Channels`] for other channel counts; [`ImageError::Encode`]
/// naming the file if writing fails.
pub fn write_png(path: impl AsRef<Path>, img: ImageView<'_, u8>) -> Result<()> {
    let path = path.as_ref();
    let color = match img.channels() {
        1 => image::ExtendedColorType::L8,
        3 => image::ExtendedColorType::Rgb8,
        got => {
            return Err(ImageError::Channels {
                operation: "write_png",
                expected: 3,
                got,
            });
        }
    };
    let too_big = || ImageError::InvalidParameter {
        name: "image size",
        reason: format!("{}x{} exceeds u32", img.width(), img.height()),
    };
    let w = u32::try_from(img.width()).map_err(|_| too_big())?;
    let h = u32::try_from(img.height()).map_err(|_| too_big())?;
    let packed = img.to_image();
    image::save_buffer_with_format(
        path,
        packed.as_slice(),
        w,
        h,
        color,
        image::ImageFormat::Png,
    )
    .map_err(|source| ImageError::Encode {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes a frame as an RGB PNG with box outlines drawn on it (gray frames
/// are converted to RGB first).
///
/// # Errors
/// As [`write_png`] and [`draw_box`].
pub fn write_frame_with_boxes(
    path: impl AsRef<Path>,
    frame: ImageView<'_, u8>,
    boxes: &[(BBox, Rgb)],
    thickness: usize,
) -> Result<()> {
    let mut rgb = match frame.channels() {
        1 => gray_to_rgb(frame)?,
        3 => frame.to_image(),
        got => {
            return Err(ImageError::Channels {
                operation: "write_frame_with_boxes",
                expected: 3,
                got,
            });
        }
    };
    for (b, c) in boxes {
        draw_box(&mut rgb.view_mut(), b, *c, thickness)?;
    }
    write_png(path, rgb.view())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("bayestrack-image-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn frame_numbers() {
        assert_eq!(frame_number(Path::new("img/0001.jpg")), Some(1));
        assert_eq!(frame_number(Path::new("img00042.png")), Some(42));
        assert_eq!(frame_number(Path::new("a1b20.png")), Some(20));
        assert_eq!(frame_number(Path::new("x.png")), None);
    }

    /// A `w x h` gray JPEG in memory.
    fn jpeg_bytes(w: u32, h: u32) -> Vec<u8> {
        let pixels: Vec<u8> = (0..w * h).map(|i| (i * 7 % 251) as u8).collect();
        let mut out = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 90)
            .encode(&pixels, w, h, image::ExtendedColorType::L8)
            .unwrap();
        out
    }

    #[test]
    fn bytes_after_the_end_of_an_image_are_ignored_and_a_cut_file_is_not() {
        let d = tmpdir("trailing");
        let jpeg = jpeg_bytes(40, 24);
        let clean = decode_frame(&jpeg, "a.jpg").unwrap();
        // Cameras and editors append data after the end-of-image marker; a
        // long tail (more than the last 64 bytes) with an FF D8 in it too.
        let mut tail = jpeg.clone();
        tail.extend((0..5000u32).map(|i| (i * 31 % 256) as u8));
        tail.extend([0xFF, 0xD8, 0xFF, 0xE0, 0x00]);
        let p = d.join("trailing.jpg");
        fs::write(&p, &tail).unwrap();
        assert_eq!(read_frame(&p).unwrap(), clean);
        // Cut anywhere after the header: an error naming the file.
        for cut in [jpeg.len() - 1, jpeg.len() - 2, jpeg.len() * 2 / 3, 300] {
            let p = d.join(format!("cut{cut}.jpg"));
            fs::write(&p, &jpeg[..cut]).unwrap();
            match read_frame(&p) {
                Err(e @ ImageError::Truncated { .. }) => {
                    assert!(e.to_string().contains(p.to_str().unwrap()), "{e}");
                }
                other => panic!("cut at {cut}: expected Truncated, got {other:?}"),
            }
        }
        // The same for PNG: data after IEND decodes, a cut file does not.
        let img = Image::from_fn(9, 7, |x, y| (x * 20 + y) as u8).unwrap();
        let png = d.join("a.png");
        write_png(&png, img.view()).unwrap();
        let mut bytes = fs::read(&png).unwrap();
        let whole = bytes.len();
        bytes.extend(b"appended by an editor, longer than sixty-four bytes of text....");
        assert_eq!(decode_frame(&bytes, "a.png").unwrap(), img);
        assert!(matches!(
            decode_frame(&bytes[..whole - 1], "a.png"),
            Err(ImageError::Truncated { .. })
        ));
        let _ = fs::remove_dir_all(&d);
    }

    /// `bytes` as the image crate's own loading decodes them (the
    /// reference of [`decode_jpeg`]): the pixels in their kept colour kind,
    /// or the error's words.
    fn by_image_crate(bytes: &[u8]) -> std::result::Result<Image<u8>, String> {
        let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Jpeg)
            .map_err(|e| e.to_string())?;
        let gray = !img.color().has_color();
        Ok(from_dynamic(img, gray))
    }

    /// `bytes` through [`decode_jpeg`] into `buffer`; `None` where it
    /// leaves the image to the image crate.
    fn by_direct_path(
        bytes: &[u8],
        buffer: Vec<u8>,
    ) -> Option<std::result::Result<Image<u8>, String>> {
        Some(match decode_jpeg(bytes, buffer)? {
            Ok(img) => {
                let gray = !img.color().has_color();
                Ok(from_dynamic(img, gray))
            }
            Err(e) => Err(e.to_string()),
        })
    }

    /// A `w x h` JPEG of `channels` 1 or 3 in memory.
    fn jpeg_of(w: u32, h: u32, channels: u32, quality: u8) -> Vec<u8> {
        let pixels: Vec<u8> = (0..w * h * channels)
            .map(|i| ((i * 37 + i / 7 * 11) % 256) as u8)
            .collect();
        let kind = if channels == 1 {
            image::ExtendedColorType::L8
        } else {
            image::ExtendedColorType::Rgb8
        };
        let mut out = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, quality)
            .encode(&pixels, w, h, kind)
            .unwrap();
        out
    }

    #[test]
    fn jpegs_decode_as_the_image_crate_decodes_them() {
        for (w, h) in [(1, 1), (7, 5), (17, 9), (40, 24), (64, 48)] {
            for channels in [1, 3] {
                for quality in [30, 95] {
                    let bytes = jpeg_of(w, h, channels, quality);
                    let want = by_image_crate(&bytes).unwrap();
                    assert_eq!(want.channels(), channels as usize);
                    // new memory, a used buffer larger than the frame, a
                    // smaller one: each byte is the decoder's
                    let n = (w * h * 3) as usize;
                    for buffer in [Vec::new(), vec![0xAB; n + 100], vec![0x55; 3]] {
                        let got = by_direct_path(&bytes, buffer).unwrap().unwrap();
                        assert_eq!(got, want, "{w}x{h}x{channels} q{quality}");
                    }
                    assert_eq!(decode_frame(&bytes, "a.jpg").unwrap(), want);
                }
            }
        }
    }

    #[test]
    fn damaged_jpegs_fail_or_decode_as_the_image_crate_does() {
        // bytes changed anywhere past the start-of-image marker (headers,
        // tables, scan): the direct path gives the image crate's pixels or
        // its error, word for word
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as usize
        };
        let (mut failed, mut decoded) = (0, 0);
        for case in 0..400 {
            let mut bytes = jpeg_of(24, 16, if case % 2 == 0 { 3 } else { 1 }, 75);
            for _ in 0..1 + next(3) {
                let at = 2 + next(bytes.len() - 2);
                bytes[at] ^= 1 + next(255) as u8;
            }
            let Some(got) = by_direct_path(&bytes, vec![7; 100]) else {
                continue;
            };
            assert_eq!(got, by_image_crate(&bytes), "case {case}");
            if got.is_ok() {
                decoded += 1;
            } else {
                failed += 1;
            }
        }
        // both outcomes were exercised
        assert!(
            failed > 20 && decoded > 20,
            "{failed} failed, {decoded} decoded"
        );
    }

    #[test]
    fn a_frame_pool_reuses_buffers_within_its_bounds() {
        let d = tmpdir("pool");
        let colour = d.join("1.jpg");
        fs::write(&colour, jpeg_of(40, 24, 3, 80)).unwrap();
        let gray = d.join("2.jpg");
        fs::write(&gray, jpeg_of(17, 9, 1, 80)).unwrap();
        let png = d.join("3.png");
        write_png(
            &png,
            Image::from_fn(9, 7, |x, y| (x * 20 + y) as u8)
                .unwrap()
                .view(),
        )
        .unwrap();
        let pool = FramePool::new();
        assert!(pool.is_empty());
        // each frame decoded into the buffer the previous one gave back
        for p in [&colour, &gray, &png, &colour, &png, &gray] {
            let img = pool.read_frame(p).unwrap();
            assert_eq!(img, read_frame(p).unwrap(), "{}", p.display());
            pool.give_back(img);
            assert_eq!(pool.len(), 1);
        }
        // errors are read_frame's, and the buffer taken is not lost for good
        let bad = d.join("4.jpg");
        fs::write(&bad, b"not a JPEG at all").unwrap();
        assert_eq!(
            pool.read_frame(&bad).unwrap_err().to_string(),
            read_frame(&bad).unwrap_err().to_string()
        );
        // at most MAX_BUFFERS buffers, MAX_BYTES bytes
        for _ in 0..FramePool::MAX_BUFFERS + 5 {
            pool.give_back(Image::new(4, 4, 1, 0).unwrap());
        }
        assert_eq!(pool.len(), FramePool::MAX_BUFFERS);
        let pool = FramePool::new();
        // (zeroed memory the system maps lazily: nothing is touched)
        let big = Image::from_vec(
            FramePool::MAX_BYTES / 1024 + 1,
            1024,
            1,
            vec![0; (FramePool::MAX_BYTES / 1024 + 1) * 1024],
        )
        .unwrap();
        pool.give_back(big);
        assert!(pool.is_empty());
        let _ = fs::remove_dir_all(&d);
    }

    #[test]
    fn a_multibyte_character_before_the_number_does_not_panic() {
        // found by the otb frame-folder fuzz target (`*ť8ť` panicked)
        assert_eq!(frame_number(Path::new("\u{165}8.png")), Some(8));
        assert_eq!(frame_number(Path::new("*\u{165}8\u{165}")), Some(8));
    }

    #[test]
    fn png_round_trip_and_numeric_order() {
        let d = tmpdir("roundtrip");
        let img = Image::from_fn(7, 5, |x, y| (x * 30 + y) as u8).unwrap();
        // Written out of order and with different digit counts.
        for (name, add) in [("img10.png", 10u8), ("img2.png", 2), ("img1.png", 1)] {
            let shifted = img.map(|v| v.saturating_add(add));
            write_png(d.join(name), shifted.view()).unwrap();
        }
        fs::write(d.join("notes.txt"), "not a frame").unwrap();
        let frames = list_frames(&d).unwrap();
        let names: Vec<_> = frames
            .iter()
            .map(|p| p.file_name().unwrap().to_str().unwrap().to_string())
            .collect();
        assert_eq!(names, ["img1.png", "img2.png", "img10.png"]);
        let back = read_frame(&frames[1]).unwrap();
        assert_eq!(back.channels(), 1);
        assert_eq!(back, img.map(|v| v.saturating_add(2)));
        let rgb = read_frame_rgb(&frames[1]).unwrap();
        assert_eq!(rgb.channels(), 3);
        // A sequence folder with img/ is accepted too.
        let seq = tmpdir("seq");
        fs::create_dir_all(seq.join("img")).unwrap();
        write_png(seq.join("img/0001.png"), img.view()).unwrap();
        let frames = list_frames(&seq).unwrap();
        assert_eq!(frames, [seq.join("img/0001.png")]);
        assert_eq!(read_frame(&frames[0]).unwrap(), img);
        // Boxes drawn on a gray frame come back red.
        let out = seq.join("boxed.png");
        write_frame_with_boxes(
            &out,
            img.view(),
            &[(BBox::new(2.0, 2.0, 3.0, 3.0), Rgb::new(255, 0, 0))],
            1,
        )
        .unwrap();
        let boxed = read_frame(&out).unwrap();
        assert_eq!(boxed.pixel(1, 1).unwrap(), &[255, 0, 0]);
        assert_eq!(boxed.pixel(0, 0).unwrap(), &[0, 0, 0]);
        let _ = fs::remove_dir_all(&d);
        let _ = fs::remove_dir_all(&seq);
    }

    #[test]
    fn bad_files_name_the_file() {
        let d = tmpdir("bad");
        let img = Image::from_fn(32, 32, |x, y| (x * y) as u8).unwrap();
        let good = d.join("good.png");
        write_png(&good, img.view()).unwrap();
        let bytes = fs::read(&good).unwrap();
        let trunc = d.join("truncated.png");
        fs::write(&trunc, &bytes[..bytes.len() / 2]).unwrap();
        let text = d.join("text.jpg");
        fs::write(&text, "hello, I am not a JPEG").unwrap();
        let named = d.join("text.png");
        fs::write(&named, "a text file named .png\n").unwrap();
        let e = read_frame(&named).unwrap_err();
        assert!(matches!(e, ImageError::Decode { .. }), "{e:?}");
        assert!(e.to_string().contains("not a PNG file"), "{e}");
        for p in [&trunc, &text] {
            match read_frame(p) {
                Err(e @ (ImageError::Decode { .. } | ImageError::Truncated { .. })) => {
                    assert!(e.to_string().contains(p.to_str().unwrap()), "{e}");
                }
                other => panic!("{}: expected Decode, got {other:?}", p.display()),
            }
        }
        assert!(matches!(
            read_frame(d.join("missing.png")),
            Err(ImageError::Io { .. })
        ));
        let empty = tmpdir("empty");
        assert!(matches!(
            list_frames(&empty),
            Err(ImageError::NoFrames { .. })
        ));
        let _ = fs::remove_dir_all(&d);
        let _ = fs::remove_dir_all(&empty);
    }
}
