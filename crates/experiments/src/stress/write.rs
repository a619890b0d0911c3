//! Writing the stress set to a folder in OTB layout, only what is missing
//! or differs: what `cargo xtask stress` runs before scoring.

use std::fs;
use std::path::{Path, PathBuf};

use super::StressScene;
use crate::scenes::{Result, SceneError, write_scene};

/// The manifest each written sequence folder holds: what was rendered
/// (set version, sequence, seed, frames, noise) and a hash of every file.
pub const MANIFEST_FILE: &str = "stress.txt";

/// Bumped whenever the rendering changes, so that older folders are
/// rewritten.
const SET_VERSION: u32 = 1;

/// What [`write_set`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SetSummary {
    /// The set's folder.
    pub dir: PathBuf,
    /// Sequences written because they were missing.
    pub written: Vec<String>,
    /// Sequences rewritten because their files differed from what the seed
    /// renders (edited, truncated, another seed or length, an older set).
    pub rewritten: Vec<String>,
    /// Sequences already there, every file as the seed renders it.
    pub kept: Vec<String>,
    /// Folders of an earlier stress set that this set does not have,
    /// removed (they would be scored with it).
    pub removed: Vec<String>,
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SceneError + '_ {
    move |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// FNV-1a, 64 bits, of a file's bytes.
fn hash_bytes(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
    })
}

/// Every file under `dir`, relative, `/`-separated, sorted.
fn files(dir: &Path) -> Result<Vec<String>> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<()> {
        for entry in fs::read_dir(dir).map_err(io_err(dir))? {
            let entry = entry.map_err(io_err(dir))?;
            let path = entry.path();
            if path.is_dir() {
                walk(root, &path, out)?;
            } else if let Ok(rel) = path.strip_prefix(root) {
                let parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                out.push(parts.join("/"));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out)?;
    out.sort();
    Ok(out)
}

/// The first lines of a manifest: what the folder was rendered from.
fn fingerprint(scene: &StressScene, seed: u64) -> String {
    format!(
        "bayestrack stress set, version {SET_VERSION} (written by `cargo xtask stress`; \
         the folder is rewritten when it differs)\nsequence = {}\nseed = {seed}\nframes = {}\n\
         noise_sigma = {}\nfiles:\n",
        scene.name(),
        scene.frames,
        scene.noise_sigma
    )
}

/// The manifest of the files now in `dir` (the manifest itself excluded).
fn manifest(dir: &Path, head: &str) -> Result<String> {
    let mut text = head.to_string();
    for rel in files(dir)? {
        if rel == MANIFEST_FILE {
            continue;
        }
        let path = dir.join(&rel);
        let bytes = fs::read(&path).map_err(io_err(&path))?;
        text.push_str(&format!("{:016x} {rel}\n", hash_bytes(&bytes)));
    }
    Ok(text)
}

/// Whether `dir` was written by the stress set (holds its manifest).
fn is_ours(dir: &Path) -> bool {
    fs::read_to_string(dir.join(MANIFEST_FILE))
        .is_ok_and(|m| m.starts_with("bayestrack stress set"))
        || fs::read_to_string(dir.join("PARTIAL.txt"))
            .is_ok_and(|m| m.contains("cargo xtask stress"))
}

/// `path` with `suffix` appended to its last component.
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Writes one sequence into `out` through `<out>.partial`, replacing `out`
/// only once every file is written.
fn write_one(scene: &StressScene, seed: u64, out: &Path) -> Result<()> {
    let staging = sibling(out, ".partial");
    if staging.exists() {
        fs::remove_dir_all(&staging).map_err(io_err(&staging))?;
    }
    fs::create_dir_all(&staging).map_err(io_err(&staging))?;
    let marker = staging.join("PARTIAL.txt");
    fs::write(
        &marker,
        "PARTIAL: `cargo xtask stress` is writing this sequence and has not finished.\n",
    )
    .map_err(io_err(&marker))?;
    write_scene(&mut scene.stream(seed)?, &staging)?;
    fs::remove_file(&marker).map_err(io_err(&marker))?;
    let text = manifest(&staging, &fingerprint(scene, seed))?;
    let path = staging.join(MANIFEST_FILE);
    fs::write(&path, text).map_err(io_err(&path))?;
    if out.exists() {
        fs::remove_dir_all(out).map_err(io_err(out))?;
    }
    fs::rename(&staging, out).map_err(io_err(out))
}

/// Writes the stress sequences `scenes` under seed `seed` into `dir`, one
/// OTB-layout folder per sequence (`<name>/img/0001.png`,
/// `groundtruth_rect.txt`, `truth.csv`, `scene.txt`, see
/// [`crate::scenes::write_scene`]) plus the manifest [`MANIFEST_FILE`].
///
/// A sequence folder is written only when it is missing, or rewritten when
/// its manifest says it was rendered otherwise (another seed, length,
/// noise or set version) or a file differs from the hash the manifest
/// holds; otherwise it is kept as it is. Folders of an earlier stress set
/// (they hold its manifest) that `scenes` does not have are removed, since
/// the suite would score them. Each sequence is written to
/// `<name>.partial/` first and replaces the folder only when complete.
///
/// # Errors
/// [`SceneError::InvalidParameter`] when `dir` holds a sequence folder
/// (or any folder named as one of the set's) that the stress set did not
/// write: nothing of a user's is overwritten or scored by mistake;
/// [`SceneError::Io`] naming the file that could not be read or written;
/// the scenes' own errors.
pub fn write_set(scenes: &[StressScene], seed: u64, dir: &Path) -> Result<SetSummary> {
    fs::create_dir_all(dir).map_err(io_err(dir))?;
    let names: Vec<&str> = scenes.iter().map(StressScene::name).collect();
    let mut summary = SetSummary {
        dir: dir.to_path_buf(),
        ..SetSummary::default()
    };
    let mut foreign = Vec::new();
    let mut stale = Vec::new();
    for entry in fs::read_dir(dir).map_err(io_err(dir))? {
        let entry = entry.map_err(io_err(dir))?;
        let path = entry.path();
        if !path.is_dir() {
            continue;
        }
        let name = entry.file_name().to_string_lossy().into_owned();
        if is_ours(&path) {
            if !names.contains(&name.as_str()) {
                stale.push((name, path));
            }
        } else if names.contains(&name.as_str()) || path.join("img").is_dir() {
            foreign.push(path.display().to_string());
        }
    }
    if !foreign.is_empty() {
        foreign.sort();
        return Err(SceneError::InvalidParameter {
            scene: "stress",
            name: "out",
            reason: format!(
                "{} holds folders that the stress set did not write ({}): they would be \
                 overwritten or scored with it; give another folder or move them",
                dir.display(),
                foreign.join(", ")
            ),
        });
    }
    stale.sort();
    for (name, path) in stale {
        fs::remove_dir_all(&path).map_err(io_err(&path))?;
        summary.removed.push(name);
    }
    for scene in scenes {
        let out = dir.join(scene.name());
        let name = scene.name().to_string();
        let head = fingerprint(scene, seed);
        if !out.exists() {
            write_one(scene, seed, &out)?;
            summary.written.push(name);
            continue;
        }
        let said = fs::read_to_string(out.join(MANIFEST_FILE)).unwrap_or_default();
        if said.starts_with(&head) && manifest(&out, &head)? == said {
            summary.kept.push(name);
        } else {
            write_one(scene, seed, &out)?;
            summary.rewritten.push(name);
        }
    }
    Ok(summary)
}
