//! The OTB-100 sequence table: for each of the benchmark's 100 sequences,
//! which frames of which folder it runs on and which ground-truth file
//! scores it.
//!
//! The facts are the benchmark's own configuration (Wu, Lim and Yang,
//! "Object Tracking Benchmark", TPAMI 2015; `configSeqs` of the public
//! `tracker_benchmark` code), compiled into the crate from
//! `data/otb100_sequences.csv` so that a published crate needs no data
//! beside it. They are what makes a folder of OTB images track as the
//! benchmark does: David runs on frames 300-770 of its folder, Football1 on
//! frames 1-74 of its 81 images, BlurCar1 starts at frame 247, Board's files
//! have five digits, Tiger1 leaves out its first 5 frames
//! (`init_omit`), and Jogging, Skating2 and Human4 hold more than one target,
//! each with its own ground-truth file.

use std::sync::OnceLock;

/// The table as committed: `name,img_dir,start_frame,end_frame,digits,ext,
/// groundtruth,init_omit,object_class`, one row per sequence.
const TABLE_CSV: &str = include_str!("../data/otb100_sequences.csv");

/// One OTB-100 sequence, as the benchmark's configuration defines it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OtbEntry {
    /// Sequence name (`Jogging_1`, `Jogging_2` are the two targets of the
    /// folder `Jogging`).
    pub name: String,
    /// Folder of frames relative to the dataset root (`David/img`).
    pub img_dir: String,
    /// First frame number of the sequence (David: 300).
    pub start_frame: usize,
    /// Last frame number, inclusive (Football1: 74 of 81 images).
    pub end_frame: usize,
    /// Digits in a frame file's name, zero-padded (`0001.jpg`: 4; Board: 5).
    pub digits: usize,
    /// Frame file extension without the dot (`jpg`, `png`).
    pub ext: String,
    /// Ground-truth file relative to the dataset root; its first row is
    /// frame `start_frame`.
    pub groundtruth: String,
    /// Frames left out at the start (and their ground-truth rows): the run
    /// starts at `start_frame + init_omit` (Tiger1: 5).
    pub init_omit: usize,
    /// What the target is (`person`, `face`, `car`, ...).
    pub object_class: String,
}

impl OtbEntry {
    /// The sequence's folder: the first component of
    /// [`OtbEntry::img_dir`] (`Jogging` for `Jogging_1`).
    pub fn folder(&self) -> &str {
        self.img_dir.split('/').next().unwrap_or(&self.img_dir)
    }

    /// The frame folder inside the sequence folder (`img`).
    pub fn frame_subdir(&self) -> &str {
        self.img_dir.split_once('/').map_or("", |(_, rest)| rest)
    }

    /// The ground-truth file's name inside the sequence folder
    /// (`groundtruth_rect.2.txt`).
    pub fn groundtruth_file(&self) -> &str {
        self.groundtruth
            .split_once('/')
            .map_or(self.groundtruth.as_str(), |(_, rest)| rest)
    }

    /// The file name of frame number `number` (`0300.jpg`).
    pub fn frame_file(&self, number: usize) -> String {
        format!("{number:0width$}.{}", self.ext, width = self.digits)
    }

    /// The frame numbers run, in order: `start_frame + init_omit ..=
    /// end_frame`.
    pub fn frames(&self) -> std::ops::RangeInclusive<usize> {
        self.start_frame + self.init_omit..=self.end_frame
    }

    /// Number of frames run.
    pub fn len(&self) -> usize {
        self.frames().count()
    }

    /// Whether no frame is run (never true for a table entry).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Every OTB-100 sequence, in the table's order (by name).
pub fn otb100() -> &'static [OtbEntry] {
    static TABLE: OnceLock<Vec<OtbEntry>> = OnceLock::new();
    TABLE.get_or_init(|| parse_table(TABLE_CSV).unwrap_or_else(|e| panic!("{e}")))
}

/// The entry called `name` (`Jogging_2`), if OTB-100 has one.
pub fn entry(name: &str) -> Option<&'static OtbEntry> {
    otb100().iter().find(|e| e.name == name)
}

/// The entries whose frames are in the folder `folder` (`Jogging`:
/// `Jogging_1` and `Jogging_2`), in the table's order.
pub fn entries_in_folder(folder: &str) -> Vec<&'static OtbEntry> {
    otb100().iter().filter(|e| e.folder() == folder).collect()
}

/// Parses the table; the committed one is checked by the tests, so an
/// error here is a bad edit of `data/otb100_sequences.csv`.
fn parse_table(text: &str) -> Result<Vec<OtbEntry>, String> {
    let mut lines = text.lines().enumerate();
    let header = lines.next().map(|(_, l)| l.trim()).unwrap_or_default();
    let expected =
        "name,img_dir,start_frame,end_frame,digits,ext,groundtruth,init_omit,object_class";
    if header != expected {
        return Err(format!(
            "otb100_sequences.csv: header {header:?}, expected {expected:?}"
        ));
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let bad = |why: &str| format!("otb100_sequences.csv:{}: {why}: {line}", i + 1);
        let f: Vec<&str> = line.trim().split(',').collect();
        if f.len() != 9 {
            return Err(bad("expected 9 fields"));
        }
        let num = |s: &str| s.parse::<usize>().map_err(|_| bad("not a whole number"));
        let e = OtbEntry {
            name: f[0].to_string(),
            img_dir: f[1].to_string(),
            start_frame: num(f[2])?,
            end_frame: num(f[3])?,
            digits: num(f[4])?,
            ext: f[5].to_string(),
            groundtruth: f[6].to_string(),
            init_omit: num(f[7])?,
            object_class: f[8].to_string(),
        };
        if e.start_frame + e.init_omit > e.end_frame || e.digits == 0 {
            return Err(bad("empty frame range or zero digits"));
        }
        out.push(e);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_the_benchmarks_hundred_sequences() {
        let t = otb100();
        assert_eq!(t.len(), 100);
        let david = entry("David").unwrap();
        assert_eq!(
            (david.start_frame, david.end_frame, david.len()),
            (300, 770, 471)
        );
        assert_eq!(david.frame_file(300), "0300.jpg");
        let football = entry("Football1").unwrap();
        assert_eq!((football.frames(), football.len()), (1..=74, 74));
        assert_eq!(entry("BlurCar1").unwrap().start_frame, 247);
        let board = entry("Board").unwrap();
        assert_eq!(board.frame_file(1), "00001.jpg");
        let tiger = entry("Tiger1").unwrap();
        assert_eq!((tiger.frames(), tiger.len()), (6..=354, 349));
        let jogging: Vec<_> = entries_in_folder("Jogging")
            .iter()
            .map(|e| (e.name.as_str(), e.groundtruth_file()))
            .collect();
        assert_eq!(
            jogging,
            [
                ("Jogging_1", "groundtruth_rect.1.txt"),
                ("Jogging_2", "groundtruth_rect.2.txt")
            ]
        );
        assert_eq!(entry("Human4_2").unwrap().folder(), "Human4");
        assert_eq!(entry("Crossing").unwrap().frame_subdir(), "img");
        assert!(entry("Nope").is_none());
    }

    #[test]
    fn a_bad_table_row_names_its_line() {
        let head =
            "name,img_dir,start_frame,end_frame,digits,ext,groundtruth,init_omit,object_class\n";
        let e = parse_table(&format!("{head}A,A/img,1,x,4,jpg,A/g.txt,0,car\n")).unwrap_err();
        assert!(e.contains(":2:"), "{e}");
        assert!(parse_table(&format!("{head}A,A/img,9,4,4,jpg,A/g.txt,0,car\n")).is_err());
        assert!(parse_table("a,b\n").is_err());
    }
}
