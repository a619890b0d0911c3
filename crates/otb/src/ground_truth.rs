//! OTB ground truth: finding a sequence's ground-truth files and reading
//! their rows (`x y w h` per frame, OTB box convention). This crate owns
//! the format; `bayestrack-image` decodes frames and knows nothing of it.

use std::path::{Path, PathBuf};

use bayestrack_image::BBox;

use crate::error::OtbError;

/// Largest ground-truth file read, in bytes (64 MiB: over a million rows,
/// a hundred times OTB-100's longest sequence). A larger file, or an endless
/// one (`/dev/zero`), is refused with [`OtbError::GroundTruthTooLarge`]
/// instead of being read without bound; [`GROUND_TRUTH_MAX_BYTES_ENV`]
/// raises the limit.
pub const GROUND_TRUTH_MAX_BYTES: u64 = 64 << 20;

/// The environment variable that overrides [`GROUND_TRUTH_MAX_BYTES`]
/// (a whole number of bytes) for a user whose ground truth really is larger.
pub const GROUND_TRUTH_MAX_BYTES_ENV: &str = "BAYESTRACK_GT_MAX_BYTES";

/// The box `x,y,w,h` (OTB convention) when it is one a tracker can be
/// given: four finite numbers, width and height above 0, and far edges
/// `x + w`, `y + h` that are finite too (`1e308 + 1e308` is not). The same
/// rule holds for `bayestrack track --init` and for every labelled
/// ground-truth row, so a box refused as an initial box is never scored
/// against either.
///
/// # Errors
/// A sentence saying which rule the box breaks.
pub fn check_box(x: f64, y: f64, w: f64, h: f64) -> Result<BBox, String> {
    if ![x, y, w, h].iter().all(|v| v.is_finite()) {
        return Err("every number must be finite".to_string());
    }
    if w <= 0.0 || h <= 0.0 {
        return Err(format!(
            "width and height must be above 0 (width {}, height {})",
            short_number(w),
            short_number(h)
        ));
    }
    if !(x + w).is_finite() || !(y + h).is_finite() {
        return Err("the far edges x + w, y + h must be finite".to_string());
    }
    Ok(BBox::new(x, y, w, h))
}

/// `v` as a short text: the shortest form that reads back to `v`, in
/// exponent form from 1e15 up and below 1e-5 (never a 300-digit decimal).
pub fn short_number(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-5..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Parses OTB ground truth: one `x y w h` row per frame, numbers separated
/// by commas, tabs and/or spaces, mixed even within one row as OTB ships
/// them (BlurCar1's row 496: `1 2,3\t4`). A comma with spaces or tabs
/// around it is one separator, and so is a run of spaces and tabs; two
/// commas with nothing between them (`1,,2,3,4`) are an empty field, an
/// error rather than a silently shifted row. A UTF-8 byte-order mark at the
/// start and CRLF line ends are accepted. A row of four zeros means
/// "unlabelled" and becomes `None`; every other row must be a box
/// [`check_box`] accepts (the rule of `--init`). Blank lines are skipped
/// (they number no frame).
///
/// `path` only names the source in errors.
///
/// # Errors
/// [`OtbError::GroundTruth`] naming the 1-based line for a row that is not
/// four numbers, has an empty field, or is a box [`check_box`] refuses
/// (not finite, no area, far edges not finite).
pub fn parse_ground_truth(
    text: &str,
    path: impl AsRef<Path>,
) -> Result<Vec<Option<BBox>>, OtbError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        let bad = |reason: String| OtbError::GroundTruth {
            path: path.as_ref().to_path_buf(),
            line: i + 1,
            text: line.chars().take(80).collect(),
            reason,
        };
        let mut fields: Vec<&str> = Vec::with_capacity(4);
        for (k, part) in trimmed.split(',').enumerate() {
            if part.trim().is_empty() {
                return Err(bad(format!(
                    "field {} is empty (two commas with nothing between them, or a comma \
                     at an end of the row)",
                    k + 1
                )));
            }
            fields.extend(part.split_whitespace());
            if fields.len() > 4 {
                break;
            }
        }
        if fields.len() != 4 {
            let found = if fields.len() > 4 {
                "more".to_string()
            } else {
                fields.len().to_string()
            };
            return Err(bad(format!("expected 4 numbers, found {found}")));
        }
        let mut v = [0f64; 4];
        for (slot, f) in v.iter_mut().zip(&fields) {
            *slot = f.parse::<f64>().map_err(|e| {
                let shown: String = f.chars().take(24).collect();
                bad(format!("{shown:?} is not a number ({e})"))
            })?;
            if !slot.is_finite() {
                return Err(bad(format!("{f:?} is not finite")));
            }
        }
        if v == [0.0; 4] {
            out.push(None);
            continue;
        }
        let b = check_box(v[0], v[1], v[2], v[3]).map_err(|why| {
            bad(format!(
                "{why}; a box an initial box could not be (0,0,0,0 marks an unlabelled frame)"
            ))
        })?;
        out.push(Some(b));
    }
    Ok(out)
}

/// The byte limit of [`read_ground_truth`]: [`GROUND_TRUTH_MAX_BYTES`], or
/// the whole number [`GROUND_TRUTH_MAX_BYTES_ENV`] holds.
pub fn ground_truth_max_bytes() -> u64 {
    std::env::var(GROUND_TRUTH_MAX_BYTES_ENV)
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(GROUND_TRUTH_MAX_BYTES)
}

/// Reads an OTB ground-truth file; see [`parse_ground_truth`]. At most
/// [`ground_truth_max_bytes`] bytes are read: a larger or endless file
/// (`/dev/zero`, a FIFO that never ends) is refused, not read without
/// bound.
///
/// # Errors
/// [`OtbError::Read`] if the file cannot be read;
/// [`OtbError::GroundTruthTooLarge`] past the limit;
/// [`OtbError::GroundTruth`] naming the file and line of a bad row.
pub fn read_ground_truth(path: impl AsRef<Path>) -> Result<Vec<Option<BBox>>, OtbError> {
    use std::io::Read;
    let path = path.as_ref();
    let read_err = |source| OtbError::Read {
        path: path.to_path_buf(),
        source,
    };
    let limit = ground_truth_max_bytes();
    let file = std::fs::File::open(path).map_err(read_err)?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(read_err)?;
    if bytes.len() as u64 > limit {
        return Err(OtbError::GroundTruthTooLarge {
            path: path.to_path_buf(),
            limit,
        });
    }
    let text = String::from_utf8_lossy(&bytes);
    parse_ground_truth(&text, path)
}

/// Every ground-truth file of an OTB sequence folder (`*_gt*.txt` and
/// `groundtruth*.txt`; a folder with two targets has two):
/// `groundtruth_rect.txt` first when there is one, the others by name.
///
/// # Errors
/// [`OtbError::Read`] if the folder cannot be listed;
/// [`OtbError::NoGroundTruth`] if there is none.
pub fn find_ground_truth_files(dir: impl AsRef<Path>) -> Result<Vec<PathBuf>, OtbError> {
    let dir = dir.as_ref();
    let io = |source| OtbError::Read {
        path: dir.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let p = entry.map_err(io)?.path();
        let name = p
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_ascii_lowercase();
        if p.is_file()
            && name.ends_with(".txt")
            && (name.contains("_gt") || name.starts_with("groundtruth"))
        {
            files.push(p);
        }
    }
    files.sort();
    let standard = dir.join("groundtruth_rect.txt");
    if let Some(i) = files.iter().position(|p| *p == standard) {
        let p = files.remove(i);
        files.insert(0, p);
    }
    if files.is_empty() {
        return Err(OtbError::NoGroundTruth {
            path: dir.to_path_buf(),
        });
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ground_truth_formats() {
        let t = "1,2,3,4\n5\t6\t7\t8\n\n9 10  11 12\n0,0,0,0\n87.586,40.153,75,97\r\n";
        let gt = parse_ground_truth(t, "gt.txt").unwrap();
        assert_eq!(gt.len(), 5);
        assert_eq!(gt[0], Some(BBox::new(1.0, 2.0, 3.0, 4.0)));
        assert_eq!(gt[1], Some(BBox::new(5.0, 6.0, 7.0, 8.0)));
        assert_eq!(gt[2], Some(BBox::new(9.0, 10.0, 11.0, 12.0)));
        assert_eq!(gt[3], None);
        assert_eq!(gt[4], Some(BBox::new(87.586, 40.153, 75.0, 97.0)));
    }

    #[test]
    fn ground_truth_as_otb_ships_it() {
        // A byte-order mark, CRLF, separators mixed within a row (BlurCar1's
        // row 496), a comma with spaces around it, tabs.
        let t = "\u{feff}1,2,3,4\r\n5 6,7\t8\r\n9 , 10,\t11  12\r\n";
        let gt = parse_ground_truth(t, "gt.txt").unwrap();
        assert_eq!(
            gt,
            [
                Some(BBox::new(1.0, 2.0, 3.0, 4.0)),
                Some(BBox::new(5.0, 6.0, 7.0, 8.0)),
                Some(BBox::new(9.0, 10.0, 11.0, 12.0)),
            ]
        );
        // An empty field is an error naming the line, not a shifted row.
        for (text, line) in [
            ("1,2,3,4\n1,,2,3,4\n", 2),
            ("1,2,3,4\n1, ,2,3\n", 2),
            (",1,2,3,4\n", 1),
            ("1,2,3,4,\n", 1),
        ] {
            match parse_ground_truth(text, "gt.txt") {
                Err(e @ OtbError::GroundTruth { line: l, .. }) => {
                    assert_eq!(l, line, "{text:?}");
                    assert!(e.to_string().contains("empty"), "{e}");
                }
                other => panic!("{text:?}: expected an empty-field error, got {other:?}"),
            }
        }
    }

    #[test]
    fn bad_ground_truth_names_the_line() {
        for (text, line) in [
            ("1,2,3,4\n1,2,x,4\n", 2),
            ("1,2,3\n", 1),
            ("1,2,3,4\n\n1,2,3,4,5\n", 3),
            ("1,2,-3,4\n", 1),
            ("1,2,NaN,4\n", 1),
            // what --init refuses: no area, far edges past f64
            ("1,2,3,4\n20,13,0,12\n", 2),
            ("1e308,1e308,1e308,1e308\n", 1),
            ("0,0,0,5\n", 1),
        ] {
            match parse_ground_truth(text, "seq/gt.txt") {
                Err(OtbError::GroundTruth { line: l, path, .. }) => {
                    assert_eq!(l, line, "{text:?}");
                    assert_eq!(path, Path::new("seq/gt.txt"));
                }
                other => panic!("{text:?}: expected a parse error, got {other:?}"),
            }
        }
        let e = parse_ground_truth("1;2;3;4", "a.txt").unwrap_err();
        assert!(e.to_string().contains("a.txt:1"), "{e}");
    }

    #[test]
    fn an_endless_or_huge_file_is_refused_not_read_without_bound() {
        if Path::new("/dev/zero").exists() {
            match read_ground_truth("/dev/zero") {
                Err(e @ OtbError::GroundTruthTooLarge { .. }) => {
                    let msg = e.to_string();
                    assert!(msg.contains("/dev/zero"), "{msg}");
                    assert!(msg.contains(GROUND_TRUTH_MAX_BYTES_ENV), "{msg}");
                }
                other => panic!("expected a size error, got {other:?}"),
            }
        }
    }

    #[test]
    fn huge_numbers_are_printed_short() {
        assert_eq!(short_number(1e300), "1e300");
        assert_eq!(short_number(12.5), "12.5");
        assert_eq!(short_number(1e-300), "1e-300");
        assert_eq!(short_number(0.0), "0");
        let e = parse_ground_truth("1,2,3,4\n1e300,1,0,4\n", "gt.txt").unwrap_err();
        assert!(!e.to_string().contains("000000000"), "{e}");
    }

    #[test]
    fn a_folder_without_ground_truth_says_so() {
        let dir = std::env::temp_dir().join(format!("bayestrack-otb-nogt-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        assert!(matches!(
            find_ground_truth_files(&dir),
            Err(OtbError::NoGroundTruth { .. })
        ));
        std::fs::write(dir.join("b_gt.txt"), "1,1,1,1\n").unwrap();
        std::fs::write(dir.join("groundtruth_rect.txt"), "1,1,1,1\n").unwrap();
        let found = find_ground_truth_files(&dir).unwrap();
        assert_eq!(
            found,
            [dir.join("groundtruth_rect.txt"), dir.join("b_gt.txt")]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
