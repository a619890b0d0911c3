//! `--shard K/N` then merge writes exactly the files of one run, byte for
//! byte, for every experiment (at a reduced scale, with `timing=false` so
//! that no wall-clock time reaches a file).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use bayestrack_experiments::{Experiment, ExperimentError, Mode, REGISTRY, RunOptions, Shard};

/// A small run of each experiment that still has every kind of job
/// (hikpf's and ball's sweeps, correlation's two-car run, condensation's
/// side runs and snapshot).
fn reduced(id: &str) -> Vec<(&'static str, &'static str)> {
    match id {
        "hikpf" => vec![
            ("runs", "2"),
            ("particles", "20"),
            ("steps", "20"),
            ("sweep", "true"),
        ],
        "ball" => vec![
            ("runs", "1"),
            ("seconds", "1"),
            ("sweep", "true"),
            ("sweep_speeds", "2,3"),
            ("sweep_noises", "0,1"),
            ("sweep_runs", "1"),
            ("sweep_seconds", "1"),
            ("timing", "false"),
        ],
        "correlation" => vec![("runs", "2")],
        "affine" => vec![
            ("frames", "6"),
            ("hkpf_particles", "10"),
            ("max_particles", "10"),
            ("readings", "true"),
            ("timing", "false"),
        ],
        "condensation" => vec![
            ("runs", "1"),
            ("frames", "8"),
            ("reinit_frames", "4"),
            ("timing", "false"),
        ],
        _ => vec![],
    }
}

/// Every file under `dir` (relative path -> bytes).
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(dir).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

fn opts(out: PathBuf, set: &[(&str, &str)], shard: Option<Shard>) -> RunOptions {
    RunOptions {
        mode: Mode::Quick,
        out,
        progress: false,
        set: set
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        shard,
    }
}

fn check(e: &dyn Experiment, root: &Path) {
    let id = e.id();
    let set = reduced(id);
    let one = root.join(id).join("one");
    e.run(&opts(one.clone(), &set, None))
        .unwrap_or_else(|err| panic!("{id}: {err}"));
    let n = 3;
    let shards: Vec<PathBuf> = (1..=n)
        .map(|k| {
            let dir = root.join(id).join(format!("shard{k}"));
            e.run(&opts(dir.clone(), &set, Some(Shard::new(k, n).unwrap())))
                .unwrap_or_else(|err| panic!("{id} shard {k}/{n}: {err}"));
            dir
        })
        .collect();
    let merged = root.join(id).join("merged");
    let tables = e.merge(&shards, &merged).unwrap().expect("shards found");
    assert!(!tables.is_empty());
    let (a, b) = (files(&one.join(id)), files(&merged.join(id)));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "{id}: the same files"
    );
    for (path, bytes) in &a {
        assert!(
            bytes == &b[path],
            "{id}: {} differs between one run and the merged shards",
            path.display()
        );
    }
    // an untimed run prints no fps, not frames / 0 (a 15-digit number),
    // in its summary tables
    for (path, bytes) in &a {
        let text = String::from_utf8_lossy(bytes);
        let longest = text
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(
            longest < 13 || !path.ends_with("summary.csv"),
            "{id}: {} has a {longest}-digit number",
            path.display()
        );
    }
    // a missing shard is refused, naming it
    let err = e
        .merge(&shards[..2], &root.join(id).join("bad"))
        .unwrap_err();
    assert!(
        matches!(&err, ExperimentError::Merge(m) if m.contains("3/3 missing")),
        "{err}"
    );
}

#[test]
fn merged_shards_are_byte_identical_to_one_run() {
    let root = std::env::temp_dir().join(format!("bayestrack-shards-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    for e in REGISTRY.iter().filter(|e| e.implemented()) {
        let start = std::time::Instant::now();
        check(*e, &root);
        eprintln!("{}: {:.1} s", e.id(), start.elapsed().as_secs_f64());
    }
    std::fs::remove_dir_all(&root).unwrap();
}
