//! A streaming reader of YUV4MPEG2 (Y4M), the uncompressed video stream
//! `ffmpeg -f yuv4mpegpipe` writes: how video reaches the tracker with no
//! video library linked (`ffmpeg -i clip.mp4 -f yuv4mpegpipe - | bayestrack
//! track --seq - ...`).
//!
//! The stream is a header line `YUV4MPEG2 W<width> H<height> [F<n>:<d>]
//! [I<p|t|b|m|?>] [A<n>:<d>] [C<colour>] [X<extension>]...`, then per frame
//! a line `FRAME [params]` and the planes Y, then U and V (Cb, Cr), each row
//! by row. Colour spaces read: `420jpeg` (the default), `420paldv`,
//! `420mpeg2` and `420` (chroma halved both ways, rounded up), `422`
//! (halved across), `444`, `444alpha` (the alpha plane is skipped) and
//! `mono` (Y only). Samples of more than 8 bits (`420p10`, `mono16`, ...)
//! are refused with the ffmpeg option that avoids them.
//!
//! Colour frames become RGB by the BT.601 equations (ITU-R BT.601: `R = Y +
//! 1.402 Cr`, `G = Y - 0.344136 Cb - 0.714136 Cr`, `B = Y + 1.772 Cb`, with
//! `Y`, `Cb`, `Cr` first expanded from the limited range 16-235 / 16-240 to
//! full scale unless the header says `XCOLORRANGE=FULL`); chroma is
//! upsampled by repeating each sample (the 4:2:0 sitings differ by under a
//! pixel, which a tracker's box does not resolve). `mono` frames stay
//! 1-channel gray. Interlaced streams (`It`, `Ib`) are read as whole frames.
//!
//! Only one frame's bytes are held at a time: memory does not grow with the
//! length of the stream, and nothing is read before it is asked for.

use std::io::{BufRead, BufReader, Read};

use bayestrack_image::Image;

use crate::error::OtbError;

/// Longest header or frame-header line read (ffmpeg writes under 100 bytes).
const MAX_LINE: usize = 4096;

/// Largest frame side accepted (a corrupt header must not allocate
/// gigabytes).
const MAX_SIDE: usize = 1 << 15;

/// Largest frame read by default, in pixels (`W x H`): 2^25, a little over
/// 8K UHD (7680 x 4320). A 4:4:4 frame this size holds 100 MB of samples
/// and as much again once converted to RGB; a header that asks for more
/// (`W32768 H32768`, 3 GB a frame) is refused with
/// [`OtbError::Y4mFrameTooLarge`] before any frame is read, unless
/// [`Y4M_MAX_PIXELS_ENV`] raises the limit.
pub const Y4M_MAX_PIXELS: usize = 1 << 25;

/// The environment variable that overrides [`Y4M_MAX_PIXELS`] (a whole
/// number of pixels) for a user who does mean to track on larger frames.
pub const Y4M_MAX_PIXELS_ENV: &str = "BAYESTRACK_Y4M_MAX_PIXELS";

/// The pixel limit of [`Y4mReader::new`]: [`Y4M_MAX_PIXELS`], or the whole
/// number [`Y4M_MAX_PIXELS_ENV`] holds.
pub fn y4m_max_pixels() -> usize {
    std::env::var(Y4M_MAX_PIXELS_ENV)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(Y4M_MAX_PIXELS)
}

/// The layout of a Y4M stream's chroma planes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Chroma {
    /// 4:2:0: U and V at half width and half height (`420jpeg`,
    /// `420paldv`, `420mpeg2`, `420`; they differ only in chroma siting).
    C420,
    /// 4:2:2: U and V at half width.
    C422,
    /// 4:4:4: U and V at full size.
    C444,
    /// 4:4:4 with a fourth, alpha plane (skipped).
    C444Alpha,
    /// Luma only: gray frames.
    Mono,
}

/// A Y4M stream header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Y4mHeader {
    /// Frame width in pixels (`W`).
    pub width: usize,
    /// Frame height in pixels (`H`).
    pub height: usize,
    /// Frame rate `numerator:denominator` (`F`; `None` when absent or `0:0`).
    pub frame_rate: Option<(u32, u32)>,
    /// Interlacing (`I`): `p` progressive, `t` top field first, `b` bottom
    /// first, `m` mixed, `?` unknown (default `?`).
    pub interlace: char,
    /// Pixel aspect ratio (`A`; `None` when absent or `0:0`).
    pub aspect: Option<(u32, u32)>,
    /// Chroma layout (`C`; default 4:2:0).
    pub chroma: Chroma,
    /// The `C` value as written (`420jpeg` when absent).
    pub colour_space: String,
    /// Whether samples use the full 0-255 range (`XCOLORRANGE=FULL`)
    /// rather than the limited 16-235 of video.
    pub full_range: bool,
    /// The `X` extension fields, without the `X`.
    pub extensions: Vec<String>,
}

impl Y4mHeader {
    /// Parses the header line (without its newline).
    ///
    /// # Errors
    /// A message saying what is wrong: no `YUV4MPEG2` magic, a missing or
    /// zero width or height, a malformed field, an unsupported colour space.
    pub fn parse(line: &str) -> Result<Self, String> {
        // A CRLF line end (a stream written on Windows, or by hand) is read
        // as LF: the CR is not part of the last field.
        let line = line.strip_suffix('\r').unwrap_or(line);
        let mut fields = line.split(' ').filter(|f| !f.is_empty());
        if fields.next() != Some("YUV4MPEG2") {
            return Err(format!(
                "not a YUV4MPEG2 stream (it starts {:?})",
                line.chars().take(20).collect::<String>()
            ));
        }
        let ratio = |tag: char, v: &str| -> Result<Option<(u32, u32)>, String> {
            let (n, d) = v
                .split_once(':')
                .ok_or_else(|| format!("field {tag}{v}: expected {tag}<n>:<d>"))?;
            let n: u32 = n
                .parse()
                .map_err(|_| format!("field {tag}{v}: {n:?} is not a whole number"))?;
            let d: u32 = d
                .parse()
                .map_err(|_| format!("field {tag}{v}: {d:?} is not a whole number"))?;
            Ok((n != 0 && d != 0).then_some((n, d)))
        };
        let side = |tag: char, v: &str| -> Result<usize, String> {
            match v.parse::<usize>() {
                Ok(n) if (1..=MAX_SIDE).contains(&n) => Ok(n),
                _ => Err(format!(
                    "field {tag}{v}: expected a size from 1 to {MAX_SIDE}"
                )),
            }
        };
        let (mut width, mut height) = (None, None);
        let mut h = Self {
            width: 0,
            height: 0,
            frame_rate: None,
            interlace: '?',
            aspect: None,
            chroma: Chroma::C420,
            colour_space: "420jpeg".to_string(),
            full_range: false,
            extensions: Vec::new(),
        };
        for field in fields {
            let mut chars = field.chars();
            let tag = chars.next().unwrap_or(' ');
            let value = chars.as_str();
            match tag {
                'W' => width = Some(side('W', value)?),
                'H' => height = Some(side('H', value)?),
                'F' => h.frame_rate = ratio('F', value)?,
                'A' => h.aspect = ratio('A', value)?,
                'I' => {
                    h.interlace = match value {
                        "p" | "t" | "b" | "m" | "?" => value.chars().next().unwrap_or('?'),
                        _ => return Err(format!("field I{value}: expected Ip, It, Ib, Im or I?")),
                    }
                }
                'C' => {
                    h.chroma = match value {
                        "420jpeg" | "420paldv" | "420mpeg2" | "420" => Chroma::C420,
                        "422" => Chroma::C422,
                        "444" => Chroma::C444,
                        "444alpha" => Chroma::C444Alpha,
                        "mono" => Chroma::Mono,
                        v if v.contains('p') || v.starts_with("mono") => {
                            return Err(format!(
                                "colour space C{v} has more than 8 bits per sample, which is not \
                                 read; convert it with ffmpeg's -pix_fmt yuv420p (or gray)"
                            ));
                        }
                        v => {
                            return Err(format!(
                                "colour space C{v} is not read (420jpeg, 420paldv, 420mpeg2, 420, \
                                 422, 444, 444alpha and mono are); convert it with ffmpeg's \
                                 -pix_fmt yuv420p"
                            ));
                        }
                    };
                    h.colour_space = value.to_string();
                }
                'X' => {
                    match value {
                        "COLORRANGE=FULL" => h.full_range = true,
                        "COLORRANGE=LIMITED" => h.full_range = false,
                        _ => {}
                    }
                    h.extensions.push(value.to_string());
                }
                // Unknown tags are for future versions of the format: skipped.
                _ => {}
            }
        }
        h.width = width.ok_or("the header has no width (W field)")?;
        h.height = height.ok_or("the header has no height (H field)")?;
        Ok(h)
    }

    /// Width and height of each chroma plane (0 x 0 for mono).
    pub fn chroma_size(&self) -> (usize, usize) {
        let (w, h) = (self.width, self.height);
        match self.chroma {
            Chroma::C420 => (w.div_ceil(2), h.div_ceil(2)),
            Chroma::C422 => (w.div_ceil(2), h),
            Chroma::C444 | Chroma::C444Alpha => (w, h),
            Chroma::Mono => (0, 0),
        }
    }

    /// The header as its size fields read (`W1920 H1080 C420jpeg`), for
    /// messages.
    pub fn describe(&self) -> String {
        format!("W{} H{} C{}", self.width, self.height, self.colour_space)
    }

    /// Bytes of one frame's planes. The sides are at most 2^15, so this
    /// does not overflow on 64-bit targets (at most 4 x 2^30).
    pub fn frame_bytes(&self) -> usize {
        let luma = self.width * self.height;
        let (cw, ch) = self.chroma_size();
        let alpha = if self.chroma == Chroma::C444Alpha {
            luma
        } else {
            0
        };
        luma + 2 * cw * ch + alpha
    }
}

/// Reads Y4M frames one at a time from any byte stream.
pub struct Y4mReader<R: Read> {
    input: BufReader<R>,
    name: String,
    header: Y4mHeader,
    buf: Vec<u8>,
    frames_read: usize,
    done: bool,
    /// Whether the last frame had a bad `FRAME` line (a second in a row
    /// ends the stream: the data is not frames of the header's size).
    bad_marker: bool,
}

impl<R: Read> std::fmt::Debug for Y4mReader<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Y4mReader")
            .field("name", &self.name)
            .field("header", &self.header)
            .field("frames_read", &self.frames_read)
            .finish_non_exhaustive()
    }
}

fn y4m_error(name: &str, frame: Option<usize>, reason: impl Into<String>) -> OtbError {
    OtbError::Y4m {
        source_name: name.to_string(),
        frame,
        reason: reason.into(),
    }
}

/// Reads one line up to `\n` (at most [`MAX_LINE`] bytes); `Ok(None)` at
/// the end of the stream before any byte.
fn read_line<R: Read>(input: &mut BufReader<R>) -> Result<Option<Vec<u8>>, String> {
    let mut line = Vec::new();
    let n = input
        .by_ref()
        .take(MAX_LINE as u64 + 1)
        .read_until(b'\n', &mut line)
        .map_err(|e| format!("reading failed: {e}"))?;
    if n == 0 {
        return Ok(None);
    }
    if line.last() != Some(&b'\n') {
        return Err(if line.len() > MAX_LINE {
            format!("a header line longer than {MAX_LINE} bytes")
        } else {
            "the stream ends inside a header line".to_string()
        });
    }
    line.pop();
    if line.last() == Some(&b'\r') {
        line.pop();
    }
    Ok(Some(line))
}

impl<R: Read> Y4mReader<R> {
    /// Reads the stream header; `name` names the stream in errors (`stdin`,
    /// a file).
    ///
    /// # Errors
    /// [`OtbError::Y4m`] naming the stream for an empty stream or a bad
    /// header.
    pub fn new(input: R, name: impl Into<String>) -> Result<Self, OtbError> {
        let name = name.into();
        let mut input = BufReader::with_capacity(1 << 16, input);
        let line = read_line(&mut input)
            .map_err(|e| y4m_error(&name, None, e))?
            .ok_or_else(|| y4m_error(&name, None, "the stream is empty (no Y4M header)"))?;
        let header = Y4mHeader::parse(&String::from_utf8_lossy(&line))
            .map_err(|e| y4m_error(&name, None, e))?;
        let limit = y4m_max_pixels();
        if header.width * header.height > limit {
            return Err(OtbError::Y4mFrameTooLarge {
                source_name: name,
                header: header.describe(),
                pixels: header.width * header.height,
                bytes: header.frame_bytes(),
                limit,
            });
        }
        Ok(Self {
            input,
            name,
            header,
            buf: Vec::new(),
            frames_read: 0,
            done: false,
            bad_marker: false,
        })
    }

    /// The stream header.
    pub fn header(&self) -> &Y4mHeader {
        &self.header
    }

    /// The stream's name in errors.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Frames read so far.
    pub fn frames_read(&self) -> usize {
        self.frames_read
    }

    /// Reads the next frame's planes into the buffer: `Ok(false)` at the
    /// end of the stream.
    fn read_planes(&mut self) -> Result<bool, OtbError> {
        if self.done {
            return Ok(false);
        }
        let number = self.frames_read + 1;
        let fail = |done: &mut bool, reason: String| {
            *done = true;
            y4m_error(&self.name, Some(number), reason)
        };
        let need = self.header.frame_bytes();
        let mismatch = || {
            format!(
                "no FRAME line where frame {number} should start (after {} frames of {need} \
                 bytes): the frames hold more or fewer bytes than the header's {} says (is \
                 the colour space right? 4:4:4 data labelled 420 reads this way), or the \
                 stream is corrupt",
                number - 1,
                self.header.describe()
            )
        };
        // The marker is checked before the rest of its line is read: frame
        // data where a FRAME line should be is a size mismatch, not "a
        // header line longer than 4096 bytes".
        let mut magic = Vec::with_capacity(5);
        match self.input.by_ref().take(5).read_to_end(&mut magic) {
            Ok(0) => {
                self.done = true;
                return Ok(false);
            }
            Ok(n) if n < 5 => {
                return Err(fail(
                    &mut self.done,
                    "the stream ends inside a FRAME line".to_string(),
                ));
            }
            Ok(_) => {}
            Err(e) => return Err(fail(&mut self.done, format!("reading failed: {e}"))),
        }
        let marked = magic == b"FRAME";
        let rest = match read_line(&mut self.input) {
            Ok(Some(rest)) => rest,
            Ok(None) if marked => Vec::new(),
            Ok(None) => return Err(fail(&mut self.done, mismatch())),
            Err(_) if !marked || self.bad_marker => {
                return Err(fail(&mut self.done, mismatch()));
            }
            Err(e) => return Err(fail(&mut self.done, e)),
        };
        if !marked || !matches!(rest.first(), None | Some(b' ')) {
            if self.bad_marker {
                return Err(fail(&mut self.done, mismatch()));
            }
            // One bad marker line: its frame is passed over (the stream
            // goes on, so `--on-bad-frame skip` reaches the frames after
            // it); a second in a row ends the stream.
            self.bad_marker = true;
            let mut line = magic;
            line.extend_from_slice(&rest);
            let start = String::from_utf8_lossy(&line[..line.len().min(20)]).into_owned();
            let skipped = std::io::copy(
                &mut self.input.by_ref().take(need as u64),
                &mut std::io::sink(),
            );
            self.frames_read = number;
            return Err(match skipped {
                Ok(n) if n == need as u64 => y4m_error(
                    &self.name,
                    Some(number),
                    format!("expected a FRAME line, found {start:?}; the frame is passed over"),
                ),
                Ok(n) => fail(
                    &mut self.done,
                    format!(
                        "expected a FRAME line, found {start:?}; then cut short: {n} of its {need} bytes"
                    ),
                ),
                Err(e) => fail(&mut self.done, format!("reading failed: {e}")),
            });
        }
        self.bad_marker = false;
        // Read as the bytes arrive (the buffer keeps its capacity from frame
        // to frame): a header that promises a huge frame allocates only
        // what the stream holds.
        self.buf.clear();
        let got = self
            .input
            .by_ref()
            .take(need as u64)
            .read_to_end(&mut self.buf);
        match got {
            Ok(n) if n == need => {}
            Ok(n) => {
                return Err(fail(
                    &mut self.done,
                    format!("cut short: {n} of its {need} bytes"),
                ));
            }
            Err(e) => return Err(fail(&mut self.done, format!("reading failed: {e}"))),
        }
        self.frames_read = number;
        Ok(true)
    }

    /// Decodes the next frame: RGB for colour streams, gray for `mono`;
    /// `None` at the end of the stream.
    ///
    /// # Errors
    /// [`OtbError::Y4m`] naming the stream and the 1-based frame for a
    /// frame cut short, a bad `FRAME` line or a failed read; the stream
    /// ends after an error.
    pub fn next_image(&mut self) -> Option<Result<Image<u8>, OtbError>> {
        match self.read_planes() {
            Ok(true) => Some(Ok(self.convert())),
            Ok(false) => None,
            Err(e) => Some(Err(e)),
        }
    }

    /// Passes over the next frame without converting it; `None` at the end.
    ///
    /// # Errors
    /// As [`Y4mReader::next_image`].
    pub fn skip_image(&mut self) -> Option<Result<(), OtbError>> {
        match self.read_planes() {
            Ok(true) => Some(Ok(())),
            Ok(false) => None,
            Err(e) => Some(Err(e)),
        }
    }

    fn convert(&self) -> Image<u8> {
        let h = &self.header;
        let (w, ht) = (h.width, h.height);
        let luma = &self.buf[..w * ht];
        let data = if h.chroma == Chroma::Mono {
            luma.to_vec()
        } else {
            let (cw, ch) = h.chroma_size();
            let u = &self.buf[w * ht..w * ht + cw * ch];
            let v = &self.buf[w * ht + cw * ch..w * ht + 2 * cw * ch];
            let (sx, sy) = (w.div_ceil(cw).max(1), ht.div_ceil(ch).max(1));
            let mut out = Vec::with_capacity(w * ht * 3);
            for y in 0..ht {
                let crow = (y / sy) * cw;
                for x in 0..w {
                    let c = crow + x / sx;
                    out.extend(yuv_to_rgb(luma[y * w + x], u[c], v[c], h.full_range));
                }
            }
            out
        };
        let channels = if h.chroma == Chroma::Mono { 1 } else { 3 };
        // The header bounds the sides to 1..=2^15, and the buffer is full.
        Image::from_vec(w, ht, channels, data).expect("a Y4M frame has its header's size")
    }
}

/// BT.601 Y'CbCr to R'G'B', limited (16-235 / 16-240) or full range input.
pub fn yuv_to_rgb(y: u8, u: u8, v: u8, full_range: bool) -> [u8; 3] {
    let (y, cb, cr) = if full_range {
        (f64::from(y), f64::from(u) - 128.0, f64::from(v) - 128.0)
    } else {
        (
            (f64::from(y) - 16.0) * 255.0 / 219.0,
            (f64::from(u) - 128.0) * 255.0 / 224.0,
            (f64::from(v) - 128.0) * 255.0 / 224.0,
        )
    };
    let q = |c: f64| c.round().clamp(0.0, 255.0) as u8;
    [
        q(y + 1.402 * cr),
        q(y - 0.344_136 * cb - 0.714_136 * cr),
        q(y + 1.772 * cb),
    ]
}

/// R'G'B' to BT.601 Y'CbCr, limited range (the inverse of [`yuv_to_rgb`]
/// up to rounding): for writing test streams.
pub fn rgb_to_yuv(rgb: [u8; 3]) -> [u8; 3] {
    let [r, g, b] = rgb.map(f64::from);
    let y = 0.299 * r + 0.587 * g + 0.114 * b;
    let cb = (b - y) / 1.772;
    let cr = (r - y) / 1.402;
    let q = |c: f64| c.round().clamp(0.0, 255.0) as u8;
    [
        q(16.0 + y * 219.0 / 255.0),
        q(128.0 + cb * 224.0 / 255.0),
        q(128.0 + cr * 224.0 / 255.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(line: &str) -> Result<Y4mHeader, String> {
        Y4mHeader::parse(line)
    }

    #[test]
    fn header_fields_are_read() {
        let h = header(
            "YUV4MPEG2 W5 H3 F30000:1001 It A1:1 C420mpeg2 XYSCSS=420MPEG2 XCOLORRANGE=FULL",
        )
        .unwrap();
        assert_eq!((h.width, h.height), (5, 3));
        assert_eq!(h.frame_rate, Some((30000, 1001)));
        assert_eq!((h.interlace, h.aspect), ('t', Some((1, 1))));
        assert_eq!((h.chroma, h.full_range), (Chroma::C420, true));
        assert_eq!(h.extensions, ["YSCSS=420MPEG2", "COLORRANGE=FULL"]);
        assert_eq!(h.chroma_size(), (3, 2));
        assert_eq!(h.frame_bytes(), 15 + 2 * 6);
        let d = header("YUV4MPEG2 W4 H2").unwrap();
        assert_eq!(
            (d.chroma, d.frame_rate, d.full_range),
            (Chroma::C420, None, false)
        );
        for (c, chroma, bytes) in [
            ("420jpeg", Chroma::C420, 8 + 2 * 2),
            ("420paldv", Chroma::C420, 12),
            ("422", Chroma::C422, 8 + 2 * 4),
            ("444", Chroma::C444, 24),
            ("444alpha", Chroma::C444Alpha, 32),
            ("mono", Chroma::Mono, 8),
        ] {
            let h = header(&format!("YUV4MPEG2 W4 H2 C{c} F25:1")).unwrap();
            assert_eq!((h.chroma, h.frame_bytes()), (chroma, bytes), "{c}");
        }
    }

    #[test]
    fn bad_headers_say_what_is_wrong() {
        for (line, says) in [
            ("YUV4MPEG W4 H2", "not a YUV4MPEG2"),
            ("YUV4MPEG2 H2", "no width"),
            ("YUV4MPEG2 W4", "no height"),
            ("YUV4MPEG2 W0 H2", "W0"),
            ("YUV4MPEG2 W4 H99999999", "H99999999"),
            ("YUV4MPEG2 W4 H2 F30", "F30"),
            ("YUV4MPEG2 W4 H2 Fx:1", "not a whole number"),
            ("YUV4MPEG2 W4 H2 Iz", "Iz"),
            ("YUV4MPEG2 W4 H2 C420p10", "more than 8 bits"),
            ("YUV4MPEG2 W4 H2 Cmono16", "more than 8 bits"),
            ("YUV4MPEG2 W4 H2 C411", "C411"),
        ] {
            let e = header(line).unwrap_err();
            assert!(e.contains(says), "{line}: {e}");
        }
    }

    #[test]
    fn crlf_lines_and_frames_past_the_limit() {
        // a CR before the LF is not part of the last field
        let h = header("YUV4MPEG2 W4 H2 C444\r").unwrap();
        assert_eq!(h.chroma, Chroma::C444);
        let mut stream = b"YUV4MPEG2 W4 H2 Cmono\r\nFRAME\r\n".to_vec();
        stream.extend([16u8; 8]);
        stream.extend(b"FRA");
        let mut r = Y4mReader::new(&stream[..], "s").unwrap();
        assert!(r.next_image().unwrap().is_ok());
        let e = r.next_image().unwrap().unwrap_err().to_string();
        assert!(
            e.contains("Y4M frame 2") && e.contains("inside a FRAME line"),
            "{e}"
        );
        assert!(r.next_image().is_none());
        // a header asking for more pixels than the limit: refused before
        // any frame is read, naming the header and the override
        let e = Y4mReader::new(&b"YUV4MPEG2 W32768 H32768 C444\nFRAME\n"[..], "big")
            .unwrap_err()
            .to_string();
        assert!(e.contains("W32768 H32768 C444"), "{e}");
        assert!(e.contains(Y4M_MAX_PIXELS_ENV), "{e}");
    }

    #[test]
    fn yuv_and_rgb_round_trip_within_rounding() {
        for rgb in [
            [0, 0, 0],
            [255, 255, 255],
            [200, 30, 90],
            [12, 240, 180],
            [128, 128, 128],
        ] {
            let back = yuv_to_rgb_arr(rgb_to_yuv(rgb));
            for k in 0..3 {
                assert!(
                    (i32::from(back[k]) - i32::from(rgb[k])).abs() <= 2,
                    "{rgb:?} -> {back:?}"
                );
            }
        }
        // Limited-range black and white are 16 and 235.
        assert_eq!(yuv_to_rgb(16, 128, 128, false), [0, 0, 0]);
        assert_eq!(yuv_to_rgb(235, 128, 128, false), [255, 255, 255]);
        assert_eq!(yuv_to_rgb(100, 128, 128, true), [100, 100, 100]);
    }

    fn yuv_to_rgb_arr(yuv: [u8; 3]) -> [u8; 3] {
        yuv_to_rgb(yuv[0], yuv[1], yuv[2], false)
    }
}
