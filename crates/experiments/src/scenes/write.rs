//! Writing a scene to a folder (PNG frames + OTB ground truth): what
//! `cargo xtask scenes <name> --out <dir>` runs.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use bayestrack_image::{BBox, Image, write_png};

use super::registry::named_stream;
use super::{FrameTruth, Result, SceneError, SceneInfo, SceneStream, box_meets_frame};

/// What [`write_scene`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct WriteSummary {
    /// The output folder.
    pub dir: PathBuf,
    /// The scene's size, rate and length.
    pub info: SceneInfo,
    /// Frames written.
    pub frames_written: usize,
    /// Ground-truth files written (`groundtruth_rect.txt` first).
    pub ground_truth_files: Vec<PathBuf>,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SceneError + '_ {
    move |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    }
}

struct TextOut {
    path: PathBuf,
    w: BufWriter<File>,
}

impl TextOut {
    fn create(path: PathBuf) -> Result<Self> {
        let f = File::create(&path).map_err(io_err(&path))?;
        Ok(Self {
            w: BufWriter::new(f),
            path,
        })
    }

    fn line(&mut self, text: &str) -> Result<()> {
        writeln!(self.w, "{text}").map_err(io_err(&self.path))
    }

    fn finish(mut self) -> Result<PathBuf> {
        self.w.flush().map_err(io_err(&self.path))?;
        Ok(self.path)
    }
}

fn otb_row(b: Option<BBox>) -> String {
    match b {
        Some(b) => format!(
            "{},{},{},{}",
            num(b.x),
            num(b.y),
            num(b.width),
            num(b.height)
        ),
        None => "0,0,0,0".to_string(),
    }
}

/// A number with at most 4 decimals and no trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// Writes every remaining frame of `stream` into `dir` (created if needed):
/// - `img/0001.png`, `img/0002.png`, ... (OTB layout, 1-based);
/// - `groundtruth_rect.txt`: the target's OTB box per frame, `x,y,w,h`,
///   `0,0,0,0` where its box is entirely outside the frame (so
///   [`bayestrack_otb::Sequence::open`] reads the folder back);
/// - `groundtruth_rect.<id>.txt` for every other object `id`;
/// - `truth.csv`: `frame,object,label,x,y,w,h,visible_fraction,gain` for every
///   object (boxes always given, also when hidden);
/// - `affine.csv` for the affine scene: `frame,a,b,tx,c,d,ty`, the seven
///   points `p1x,p1y..p7x,p7y`, the centre `cx,cy` (0-based), `jump,blur`;
/// - `scene.txt`: name, size, channels, fps, frame count.
///
/// Files are written frame by frame, so a run that fails part-way leaves
/// what it wrote.
///
/// # Errors
/// [`SceneError::Io`] naming the file or folder that could not be written;
/// [`SceneError::Image`] if a PNG cannot be encoded.
pub fn write_scene<S: SceneStream + ?Sized>(stream: &mut S, dir: &Path) -> Result<WriteSummary> {
    let info = stream.info();
    let img_dir = dir.join("img");
    fs::create_dir_all(&img_dir).map_err(io_err(&img_dir))?;
    let digits = info.frames.to_string().len().max(4);
    let meta = dir.join("scene.txt");
    fs::write(
        &meta,
        format!(
            "name = {}\nwidth = {}\nheight = {}\nchannels = {}\nfps = {}\nframes = {}\n",
            info.name, info.width, info.height, info.channels, info.fps, info.frames
        ),
    )
    .map_err(io_err(&meta))?;
    let mut truth_csv = TextOut::create(dir.join("truth.csv"))?;
    truth_csv.line("frame,object,label,x,y,w,h,visible_fraction,gain")?;
    let mut affine_csv: Option<TextOut> = None;
    let mut gt: Vec<(usize, TextOut)> = Vec::new();
    let mut frame = Image::new(info.width, info.height, info.channels, 0u8)?;
    let mut written = 0;
    while let Some(t) = stream.next_into(&mut frame) {
        if gt.is_empty() {
            for o in &t.objects {
                let name = if o.id == t.objects[0].id {
                    "groundtruth_rect.txt".to_string()
                } else {
                    format!("groundtruth_rect.{}.txt", o.id)
                };
                gt.push((o.id, TextOut::create(dir.join(name))?));
            }
        }
        let path = img_dir.join(format!("{:0digits$}.png", t.index + 1));
        write_png(&path, frame.view())?;
        write_truth(&t, &info, &mut gt, &mut truth_csv)?;
        if let Some(a) = t.affine {
            if affine_csv.is_none() {
                let mut out = TextOut::create(dir.join("affine.csv"))?;
                let pts: Vec<String> = (1..=7).map(|i| format!("p{i}x,p{i}y")).collect();
                out.line(&format!(
                    "frame,a,b,tx,c,d,ty,{},cx,cy,jump,blur",
                    pts.join(",")
                ))?;
                affine_csv = Some(out);
            }
            if let Some(out) = affine_csv.as_mut() {
                let m = a.matrix;
                let mut row = vec![(t.index + 1).to_string()];
                row.extend(
                    [m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2]]
                        .into_iter()
                        .chain(a.points.points.iter().flatten().copied())
                        .chain(a.points.center)
                        .map(num),
                );
                row.push(u8::from(a.jump).to_string());
                row.push(num(a.blur));
                out.line(&row.join(","))?;
            }
        }
        written += 1;
    }
    let mut ground_truth_files = Vec::new();
    for (_, out) in gt {
        ground_truth_files.push(out.finish()?);
    }
    truth_csv.finish()?;
    if let Some(out) = affine_csv {
        out.finish()?;
    }
    Ok(WriteSummary {
        dir: dir.to_path_buf(),
        info,
        frames_written: written,
        ground_truth_files,
    })
}

fn write_truth(
    t: &FrameTruth,
    info: &SceneInfo,
    gt: &mut [(usize, TextOut)],
    csv: &mut TextOut,
) -> Result<()> {
    for (id, out) in gt.iter_mut() {
        let b = t
            .object(*id)
            .map(|o| o.bbox)
            .filter(|b| box_meets_frame(b, info.width, info.height));
        out.line(&otb_row(b))?;
    }
    for o in &t.objects {
        csv.line(&format!(
            "{},{},{},{},{},{},{},{},{}",
            t.index + 1,
            o.id,
            o.label,
            num(o.bbox.x),
            num(o.bbox.y),
            num(o.bbox.width),
            num(o.bbox.height),
            num(o.visible_fraction),
            num(t.gain)
        ))?;
    }
    Ok(())
}

/// Most frames [`write_named_scene`] writes (a scene to look at, not a
/// data set: 100,000 PNG frames is over an hour of video at 22 fps).
pub const MAX_SCENE_FRAMES: usize = 100_000;

/// `path` with `suffix` appended to its last component (`out.partial`).
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Writes the named scene `name` (see [`super::SCENES`]) with `seed` into
/// `out`; what `cargo xtask scenes <name> --out <dir>` runs.
///
/// The scene is written to `<out>.partial/` first (with a `PARTIAL.txt`
/// that says so) and replaces `out` only when every file is written: a run
/// that is killed or fails leaves the previous `out` whole, never its ground
/// truth beside new frames.
///
/// # Errors
/// [`SceneError::InvalidParameter`] for more than [`MAX_SCENE_FRAMES`]
/// frames; those of [`named_stream`] and [`write_scene`].
pub fn write_named_scene(
    name: &str,
    seed: u64,
    frames: Option<usize>,
    out: &Path,
) -> Result<WriteSummary> {
    if let Some(n) = frames.filter(|&n| n > MAX_SCENE_FRAMES) {
        return Err(SceneError::InvalidParameter {
            scene: "scenes",
            name: "frames",
            reason: format!(
                "{n} frames is more than the {MAX_SCENE_FRAMES} a written scene may have"
            ),
        });
    }
    let mut s = named_stream(name, seed, frames)?;
    let staging = sibling(out, ".partial");
    if staging.exists() {
        fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
    }
    fs::create_dir_all(&staging).map_err(io_err(&staging))?;
    let marker = staging.join("PARTIAL.txt");
    fs::write(
        &marker,
        format!(
            "PARTIAL: `cargo xtask scenes {name}` is writing this folder and has not finished \
             (it is running, was killed, or failed).\n{} keeps the last scene that finished.\n",
            out.display()
        ),
    )
    .map_err(io_err(&marker))?;
    let mut summary = write_scene(s.as_mut(), &staging)?;
    fs::remove_file(&marker).map_err(io_err(&marker))?;
    if out.exists() {
        let old = sibling(out, ".old");
        if old.exists() {
            fs::remove_dir_all(&old).map_err(io_err(&old))?;
        }
        fs::rename(out, &old).map_err(io_err(out))?;
        fs::rename(&staging, out).map_err(io_err(out))?;
        fs::remove_dir_all(&old).map_err(io_err(&old))?;
    } else {
        fs::rename(&staging, out).map_err(io_err(out))?;
    }
    summary.dir = out.to_path_buf();
    for p in &mut summary.ground_truth_files {
        if let Ok(rest) = p.strip_prefix(&staging) {
            *p = out.join(rest);
        }
    }
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short() {
        assert_eq!(num(57.0), "57");
        assert_eq!(num(57.25), "57.25");
        assert_eq!(num(1.0 / 3.0), "0.3333");
        assert_eq!(num(-0.00001), "0");
        assert_eq!(otb_row(None), "0,0,0,0");
        assert_eq!(otb_row(Some(BBox::new(1.5, 2.0, 3.0, 4.0))), "1.5,2,3,4");
    }
}
