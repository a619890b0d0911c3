//! Writing result files without leaving them half written: text and CSV
//! replaced whole, CSV rows appended as results finish, OTB box files
//! written through row by row, and the `PARTIAL.txt` marker. Every
//! failure is a [`WriteError`] naming the file.

use std::path::{Path, PathBuf};

use bayestrack_image::BBox;

use crate::error::WriteError;

/// Writes `contents` to `path` without ever leaving it half written: the
/// text goes to a temporary file beside it (`.<name>.tmp`), which is then
/// renamed over `path`. A run killed part-way leaves the previous `path`
/// whole (and at most a stray temporary file).
///
/// # Errors
/// [`WriteError`] naming the file.
pub fn write_text(path: &Path, contents: &str) -> Result<(), WriteError> {
    let tmp = temporary_path(path);
    std::fs::write(&tmp, contents).map_err(|e| WriteError::new(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        WriteError::new(path, e)
    })
}

/// Copies the file `from` to `to` as [`write_text`] writes: to a
/// temporary file beside `to`, renamed over it.
///
/// # Errors
/// [`WriteError`] naming the file that cannot be copied or written.
pub fn copy_file(from: &Path, to: &Path) -> Result<(), WriteError> {
    let tmp = temporary_path(to);
    std::fs::copy(from, &tmp).map_err(|e| WriteError::new(from, e))?;
    std::fs::rename(&tmp, to).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        WriteError::new(to, e)
    })
}

/// `dir/.name.tmp` for `dir/name`.
fn temporary_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp"))
}

/// `dir/stem.partial.ext` for `dir/stem.ext`: where the rows of a result
/// that is still being computed go.
pub fn partial_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    match path.extension() {
        Some(ext) => path.with_file_name(format!("{stem}.partial.{}", ext.to_string_lossy())),
        None => path.with_file_name(format!("{stem}.partial")),
    }
}

/// `rows` as CSV text, written by the `csv` crate from typed rows: the
/// header is the field names of `R` (serde), every float is written with
/// full precision (the shortest text that reads back to the same `f64`),
/// `None` is an empty cell, and text is quoted where RFC 4180 needs it.
/// No rows give an empty text (the header comes from the first row).
///
/// # Panics
/// When `R` is not a flat record (a field that is itself a sequence or a
/// map): a programming error, which the first test that writes the row
/// finds.
pub fn csv_text<R: serde::Serialize>(rows: &[R]) -> String {
    let mut out = csv::Writer::from_writer(Vec::new());
    for row in rows {
        out.serialize(row).unwrap_or_else(|e| {
            panic!(
                "{} is not a flat CSV record: {e}",
                std::any::type_name::<R>()
            )
        });
    }
    into_text(out)
}

/// The text a CSV writer to memory wrote.
pub(crate) fn into_text(out: csv::Writer<Vec<u8>>) -> String {
    let bytes = out
        .into_inner()
        .unwrap_or_else(|e| panic!("writing CSV to memory: {e}"));
    String::from_utf8(bytes).unwrap_or_else(|e| panic!("CSV of UTF-8 text is UTF-8: {e}"))
}

/// Writes `rows` to `path` as [`csv_text`] does, atomically ([`write_text`]).
///
/// # Errors
/// [`WriteError`] naming the file.
pub fn write_csv<R: serde::Serialize>(path: &Path, rows: &[R]) -> Result<(), WriteError> {
    write_text(path, &csv_text(rows))
}

/// A CSV of typed rows written as results finish, beside the file it will
/// replace: rows go to [`partial_path`] (`runs.partial.csv` for
/// `runs.csv`), created fresh, and are handed to the operating system after
/// every [`PartialCsv::append`] (the header with the first rows);
/// [`PartialCsv::finish`] writes the complete file over `path`
/// (atomically, [`write_text`]) and removes the partial one. A run killed
/// part-way keeps every row it appended, under a name that says it is
/// partial, and the previous `path` untouched.
///
/// Appends may come from several threads (each call writes whole rows).
#[derive(Debug)]
pub struct PartialCsv<R> {
    path: PathBuf,
    partial: PathBuf,
    file: std::sync::Mutex<(std::fs::File, bool)>,
    rows: std::marker::PhantomData<fn(&R)>,
}

impl<R: serde::Serialize> PartialCsv<R> {
    /// Creates the (empty) partial file of `path`.
    ///
    /// # Errors
    /// [`WriteError`] naming the partial file.
    pub fn create(path: &Path) -> Result<Self, WriteError> {
        let partial = partial_path(path);
        let file = std::fs::File::create(&partial).map_err(|e| WriteError::new(&partial, e))?;
        Ok(Self {
            path: path.to_path_buf(),
            partial,
            file: std::sync::Mutex::new((file, false)),
            rows: std::marker::PhantomData,
        })
    }

    /// The file the rows go to until [`PartialCsv::finish`].
    pub fn partial(&self) -> &Path {
        &self.partial
    }

    /// Appends `rows` (with the header, the first time rows come) and
    /// hands them to the operating system before returning.
    ///
    /// # Errors
    /// [`WriteError`] naming the partial file.
    pub fn append(&self, rows: &[R]) -> Result<(), WriteError> {
        use std::io::Write;
        if rows.is_empty() {
            return Ok(());
        }
        let mut guard = self
            .file
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let (file, has_header) = &mut *guard;
        let text = csv_text(rows);
        let text = if *has_header {
            text.split_once('\n').map_or("", |(_, body)| body)
        } else {
            text.as_str()
        };
        file.write_all(text.as_bytes())
            .and_then(|()| file.flush())
            .map_err(|e| WriteError::new(&self.partial, e))?;
        *has_header = true;
        Ok(())
    }

    /// Removes the partial file, once the complete rows are written
    /// elsewhere (a caller that stages every file of a run before they
    /// replace the previous run's).
    ///
    /// # Errors
    /// [`WriteError`] naming the partial file.
    pub fn discard(self) -> Result<(), WriteError> {
        drop(self.file);
        std::fs::remove_file(&self.partial).map_err(|e| WriteError::new(&self.partial, e))
    }

    /// Writes the complete `rows` over the final path and removes the
    /// partial file.
    ///
    /// # Errors
    /// [`WriteError`] naming the file.
    pub fn finish(self, rows: &[R]) -> Result<(), WriteError> {
        write_csv(&self.path, rows)?;
        drop(self.file);
        std::fs::remove_file(&self.partial).map_err(|e| WriteError::new(&self.partial, e))
    }
}

/// A column header as a CSV key: lower case, every run of characters other
/// than letters and digits one `_` (`%` reads `pct`), none at the ends
/// (`"centre (px)"` is `centre_px`, `"ours/paper"` is `ours_paper`).
pub fn csv_key(header: &str) -> String {
    let mut key = String::with_capacity(header.len());
    for c in header.replace('%', " pct ").chars() {
        if c.is_alphanumeric() {
            key.extend(c.to_lowercase());
        } else if !key.is_empty() && !key.ends_with('_') {
            key.push('_');
        }
    }
    while key.ends_with('_') {
        key.pop();
    }
    key
}

/// The name of the marker [`mark_partial`] writes.
pub const PARTIAL_MARKER: &str = "PARTIAL.txt";

/// Marks the folder `dir` as holding an unfinished run: writes
/// `dir/PARTIAL.txt` saying what started (`what`) and that the files
/// beside it may be from an earlier run, with the finished part of this
/// one in the `*.partial.*` files. [`clear_partial`] removes it when the run
/// has written everything.
///
/// # Errors
/// [`WriteError`] naming the marker.
pub fn mark_partial(dir: &Path, what: &str) -> Result<(), WriteError> {
    create_dir(dir)?;
    write_text(
        &dir.join(PARTIAL_MARKER),
        &format!(
            "PARTIAL: {what} started here and has not finished (it is running, was killed, or failed).\n\
             Files named *.partial.* hold what it finished so far; every other file here\n\
             is from the last run that finished, not from this one.\n"
        ),
    )
}

/// Removes the marker of [`mark_partial`] (absent is fine).
///
/// # Errors
/// [`WriteError`] naming the marker.
pub fn clear_partial(dir: &Path) -> Result<(), WriteError> {
    let path = dir.join(PARTIAL_MARKER);
    match std::fs::remove_file(&path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(WriteError::new(&path, e)),
        _ => Ok(()),
    }
}

/// Creates `dir` and its parents.
///
/// # Errors
/// [`WriteError`] naming the folder.
pub fn create_dir(dir: &Path) -> Result<(), WriteError> {
    std::fs::create_dir_all(dir).map_err(|e| WriteError::new(dir, e))
}

/// Where a [`BoxFile`] writes: standard output, a file not created yet
/// (created with the first row), or a file whose length before each row is
/// known, so a row that fails part-way is cut off.
enum BoxOut {
    Stdout(std::io::Stdout),
    Pending,
    File { file: std::fs::File, len: u64 },
}

/// Writes `row` whole or not at all: when the write fails part-way (a full
/// disk), the target is cut back to `*len`, its length before the row.
fn write_whole<W: std::io::Write + Rewind>(
    out: &mut W,
    len: &mut u64,
    row: &[u8],
) -> std::io::Result<()> {
    match out.write_all(row).and_then(|()| out.flush()) {
        Ok(()) => {
            *len += row.len() as u64;
            Ok(())
        }
        Err(e) => {
            // Best effort: the error that matters is the write's.
            let _ = out.rewind_to(*len);
            Err(e)
        }
    }
}

/// A writer that can be cut back to a length.
trait Rewind {
    fn rewind_to(&mut self, len: u64) -> std::io::Result<()>;
}

impl Rewind for std::fs::File {
    fn rewind_to(&mut self, len: u64) -> std::io::Result<()> {
        use std::io::{Seek, SeekFrom};
        self.set_len(len)?;
        self.seek(SeekFrom::Start(len)).map(|_| ())
    }
}

/// How messages name the path `-`: standard output.
pub const STDOUT_NAME: &str = "standard output";

/// `path` for messages: `standard output` for `-`, the path otherwise.
pub fn display_out(path: &Path) -> String {
    if path == Path::new("-") {
        STDOUT_NAME.to_string()
    } else {
        path.display().to_string()
    }
}

/// An OTB result file, one `x,y,w,h` row per frame, written through row
/// by row so that an interrupted run keeps every box it wrote. A row is
/// written whole or not at all: when the disk fills part-way through one,
/// the file is cut back to the rows before it. The file is created (and a
/// previous one replaced) only when the first row is written: a run that
/// fails before its first box leaves the previous file as it was. The path
/// `-` is standard output (named so in errors).
pub struct BoxFile {
    path: PathBuf,
    out: BoxOut,
}

impl BoxFile {
    /// A box file at `path`, created with the first row. Checks now what
    /// can be checked without touching a previous file: that `path` is not
    /// a folder and that its folder exists.
    ///
    /// # Errors
    /// [`WriteError`] naming the file.
    pub fn create(path: &Path) -> Result<Self, WriteError> {
        let out = if path == Path::new("-") {
            BoxOut::Stdout(std::io::stdout())
        } else {
            if path.is_dir() {
                return Err(WriteError::new(
                    path,
                    std::io::Error::new(std::io::ErrorKind::IsADirectory, "it is a folder"),
                ));
            }
            let parent = path
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            if !parent.is_dir() {
                return Err(WriteError::new(
                    path,
                    std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        format!("its folder {} does not exist", parent.display()),
                    ),
                ));
            }
            BoxOut::Pending
        };
        Ok(Self {
            path: path.to_path_buf(),
            out,
        })
    }

    /// Appends one row, whole or not at all, and flushes it (creating the
    /// file with the first row).
    ///
    /// # Errors
    /// [`WriteError`] naming the file (`standard output` for `-`).
    pub fn write(&mut self, b: &BBox) -> Result<(), WriteError> {
        use std::io::Write;
        let row = format!("{}\n", box_row(b));
        if matches!(self.out, BoxOut::Pending) {
            let file =
                std::fs::File::create(&self.path).map_err(|e| WriteError::new(&self.path, e))?;
            self.out = BoxOut::File { file, len: 0 };
        }
        let done = match &mut self.out {
            BoxOut::Stdout(out) => out.write_all(row.as_bytes()).and_then(|()| out.flush()),
            BoxOut::File { file, len } => write_whole(file, len, row.as_bytes()),
            BoxOut::Pending => Ok(()),
        };
        done.map_err(|e| {
            if self.path == Path::new("-") {
                WriteError::new(Path::new(STDOUT_NAME), e)
            } else {
                WriteError::new(&self.path, e)
            }
        })
    }
}

/// Formats a box as an OTB result row `x,y,w,h` (at most 2 decimals,
/// trailing zeros dropped; numbers from 1e15 up in exponent form, `1e300`).
pub fn box_row(b: &BBox) -> String {
    let f = |v: f64| {
        if !v.is_finite() || v.abs() >= 1e15 {
            // never a 300-digit decimal
            return format!("{v:e}");
        }
        let s = format!("{v:.2}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".to_string()
        } else {
            s.to_string()
        }
    };
    format!("{},{},{},{}", f(b.x), f(b.y), f(b.width), f(b.height))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::File;
    use std::io::Write;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("bayestrack-write-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        create_dir(&dir).unwrap();
        dir
    }

    #[derive(serde::Serialize)]
    struct Row {
        name: &'static str,
        x: f64,
        missing: Option<f64>,
    }

    #[test]
    fn typed_rows_keep_full_precision_and_leave_missing_cells_empty() {
        let rows = [
            Row {
                name: "a, b",
                x: 0.1 + 0.2,
                missing: None,
            },
            Row {
                name: "c",
                x: 1e-300,
                missing: Some(2.5),
            },
        ];
        let text = csv_text(&rows);
        assert_eq!(
            text,
            "name,x,missing\n\"a, b\",0.30000000000000004,\nc,1e-300,2.5\n"
        );
        let read: Vec<f64> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').rev().nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(read, [0.1 + 0.2, 1e-300]);
        assert_eq!(csv_text::<Row>(&[]), "");
    }

    #[test]
    fn a_killed_run_keeps_its_rows_and_the_previous_file() {
        let dir = scratch("rows");
        let path = dir.join("frames.csv");
        write_text(&path, "old\n").unwrap();
        let log = PartialCsv::<Row>::create(&path).unwrap();
        assert_eq!(log.partial(), dir.join("frames.partial.csv"));
        log.append(&[]).unwrap();
        log.append(&[Row {
            name: "a",
            x: 1.0,
            missing: None,
        }])
        .unwrap();
        log.append(&[Row {
            name: "b",
            x: 2.0,
            missing: Some(3.0),
        }])
        .unwrap();
        assert_eq!(
            std::fs::read_to_string(log.partial()).unwrap(),
            "name,x,missing\na,1.0,\nb,2.0,3.0\n"
        );
        // killed here, the finished rows and the previous file both stay
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        log.finish(&[Row {
            name: "a",
            x: 1.0,
            missing: None,
        }])
        .unwrap();
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            "name,x,missing\na,1.0,\n"
        );
        assert!(!dir.join("frames.partial.csv").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn headers_become_keys_without_spaces() {
        assert_eq!(csv_key("centre (px)"), "centre_px");
        assert_eq!(csv_key("ours/paper"), "ours_paper");
        assert_eq!(csv_key("ours self-lost %"), "ours_self_lost_pct");
        assert_eq!(csv_key("PF eq.6 printed x"), "pf_eq_6_printed_x");
        assert_eq!(csv_key("run"), "run");
    }

    #[test]
    fn the_marker_comes_and_goes() {
        let dir = scratch("marker");
        mark_partial(&dir, "test").unwrap();
        let text = std::fs::read_to_string(dir.join(PARTIAL_MARKER)).unwrap();
        assert!(text.starts_with("PARTIAL: test started"), "{text}");
        clear_partial(&dir).unwrap();
        clear_partial(&dir).unwrap();
        assert!(!dir.join(PARTIAL_MARKER).exists());
        assert_eq!(
            partial_path(Path::new("x/results.csv")),
            Path::new("x/results.partial.csv")
        );
        assert_eq!(
            partial_path(Path::new("x/boxes")),
            Path::new("x/boxes.partial")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A disk that fills after `room` bytes: writes past it fail part-way.
    struct FillingDisk {
        data: Vec<u8>,
        room: usize,
    }

    impl Write for FillingDisk {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let n = buf.len().min(self.room - self.data.len());
            if n == 0 {
                return Err(std::io::Error::from(std::io::ErrorKind::StorageFull));
            }
            self.data.extend(&buf[..n]);
            Ok(n)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Rewind for FillingDisk {
        fn rewind_to(&mut self, len: u64) -> std::io::Result<()> {
            self.data.truncate(len as usize);
            Ok(())
        }
    }

    #[test]
    fn a_row_is_written_whole_or_not_at_all() {
        let mut disk = FillingDisk {
            data: Vec::new(),
            room: 20,
        };
        let mut len = 0;
        write_whole(&mut disk, &mut len, b"1,2,3,4\n").unwrap();
        write_whole(&mut disk, &mut len, b"5,6,7,8\n").unwrap();
        // 4 bytes of room left: the third row would be torn.
        let e = write_whole(&mut disk, &mut len, b"9,10,11,12\n").unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::StorageFull);
        assert_eq!(disk.data, b"1,2,3,4\n5,6,7,8\n");
        assert_eq!(len, 16);
    }

    #[test]
    fn a_real_file_is_cut_back_to_its_whole_rows() {
        let path = std::env::temp_dir().join(format!("bayestrack-rewind-{}", std::process::id()));
        let mut file = File::create(&path).unwrap();
        file.write_all(b"1,2,3,4\n9,9").unwrap();
        file.rewind_to(8).unwrap();
        file.write_all(b"5,6,7,8\n").unwrap();
        drop(file);
        assert_eq!(std::fs::read(&path).unwrap(), b"1,2,3,4\n5,6,7,8\n");
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn box_rows_are_short() {
        assert_eq!(box_row(&BBox::new(1.0, 2.5, 10.126, 3.0)), "1,2.5,10.13,3");
        assert_eq!(box_row(&BBox::new(1.0, 2.0, 1e300, 3.0)), "1,2,1e300,3");
    }

    #[test]
    fn a_box_file_is_created_with_its_first_row() {
        let dir = scratch("lazy");
        let path = dir.join("boxes.txt");
        std::fs::write(&path, "previous\n").unwrap();
        let mut file = BoxFile::create(&path).unwrap();
        // nothing written yet: the previous file is as it was
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "previous\n");
        file.write(&BBox::new(1.0, 2.0, 3.0, 4.0)).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "1,2,3,4\n");
        drop(file);
        assert!(BoxFile::create(&dir).is_err());
        assert!(BoxFile::create(&dir.join("no/such/folder.txt")).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
