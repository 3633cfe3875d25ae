//! Where an episode folder is written and how it takes its place, so that nothing is lost:
//! - the folder is named by its absolute path; the root of the filesystem is refused;
//! - beside the target live the lock (`.NAME.lock`), the staging folder (`.NAME.partial`) and,
//!   for a moment in `finish`, the earlier episode moved aside (`.NAME.old`); a target that is
//!   a mount point (a Docker volume, NFS scratch), or whose parent may not be written, cannot be
//!   renamed, so it is written in place: the same three live inside it as `.splatloop.*` and
//!   the files move one by one; so is the current folder (`--out .`), which a rename would
//!   pull from under the user's shell;
//! - a run that died between `finish`'s renames is recovered by the next run before anything
//!   else: the finished episode or the earlier one put back where it belongs, never deleted;
//! - a folder is replaceable only when it holds nothing but its own manifest's files; that
//!   check never follows a link and stops at the first entry when it may not replace at all.

use crate::error::{Result, SimError};
use std::fs;
use std::path::{Path, PathBuf};

/// Our own entries inside a target written in place: never a user's files.
const IN_PLACE_LOCK: &str = ".splatloop.lock";
const IN_PLACE_STAGING: &str = ".splatloop.partial";
const IN_PLACE_ASIDE: &str = ".splatloop.old";

/// The paths of one episode folder's writing.
#[derive(Debug, Clone)]
pub(super) struct Places {
    /// The folder the episode ends up in, absolute.
    pub target: PathBuf,
    /// Where it is written until `finish`.
    pub staging: PathBuf,
    /// Where the earlier episode waits while the new one takes its place.
    pub aside: PathBuf,
    /// The lock file.
    pub lock: PathBuf,
    /// The target cannot be renamed: its files are moved in and out one by one.
    pub in_place: bool,
}

fn refuse(detail: String) -> SimError {
    SimError::InvalidArgument {
        what: "output folder",
        detail,
    }
}

impl Places {
    /// The places for `dir`, whose parent exists.
    pub fn resolve(dir: &Path) -> Result<Places> {
        let target = absolute(dir)?;
        let (Some(parent), Some(name)) = (target.parent(), target.file_name()) else {
            return Err(refuse(format!(
                "{} is the root of the filesystem; write an episode into a folder of its own",
                dir.display()
            )));
        };
        let name = name.to_string_lossy().into_owned();
        // The current folder (or one holding it) is written in place too: renamed, it would
        // leave the user's shell in a deleted folder.
        let holds_cwd = std::env::current_dir()
            .ok()
            .and_then(|cwd| fs::canonicalize(cwd).ok())
            .is_some_and(|cwd| cwd.starts_with(&target));
        let in_place =
            target.is_dir() && (holds_cwd || is_mount_point(&target) || !writable(parent));
        Ok(if in_place {
            Places {
                staging: target.join(IN_PLACE_STAGING),
                aside: target.join(IN_PLACE_ASIDE),
                lock: target.join(IN_PLACE_LOCK),
                target,
                in_place,
            }
        } else {
            Places {
                staging: parent.join(format!(".{name}.partial")),
                aside: parent.join(format!(".{name}.old")),
                lock: parent.join(format!(".{name}.lock")),
                target,
                in_place,
            }
        })
    }

    /// Our own names inside the target (none unless it is written in place).
    fn own_names(&self) -> &'static [&'static str] {
        if self.in_place {
            &[IN_PLACE_LOCK, IN_PLACE_STAGING, IN_PLACE_ASIDE]
        } else {
            &[]
        }
    }

    /// Whether the target holds an episode, or anything (our own entries aside).
    pub fn target_occupied(&self) -> Result<bool> {
        if !self.target.exists() {
            return Ok(false);
        }
        Ok(first_entry(&self.target, self.own_names())?.is_some())
    }

    /// Whether the target holds a complete episode: its episode.json, and no metrics.json
    /// saying it was interrupted. An interrupted run does not replace one.
    pub fn target_complete(&self) -> bool {
        if !self.target.join("episode.json").is_file() {
            return false;
        }
        let ended = fs::read(self.target.join("metrics.json"))
            .ok()
            .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
            .and_then(|m| m["ended"].as_str().map(str::to_owned));
        !ended.is_some_and(|e| e.starts_with("interrupted"))
    }

    /// Puts back what a run that died inside `finish` left: its finished episode (when the
    /// target is empty) or the earlier one, then clears a superseded earlier episode only when
    /// it holds nothing but its own files. Call with the lock held. Returns what it did, for a
    /// warning.
    pub fn recover(&self) -> Result<Vec<String>> {
        let mut done = Vec::new();
        let staging_finished = self.staging.join("episode.json").is_file();
        if !self.target_occupied()? {
            if staging_finished {
                self.move_into_target(&self.staging)?;
                done.push(format!(
                    "a run that ended while putting its episode in place left it in {}: moved it to {}",
                    self.staging.display(),
                    self.target.display()
                ));
            } else if self.aside.exists() {
                self.move_into_target(&self.aside)?;
                done.push(format!(
                    "a run that ended while replacing {} left the earlier episode in {}: put it back",
                    self.target.display(),
                    self.aside.display()
                ));
            }
        }
        if self.aside.exists() {
            check_replaceable(&self.aside, true, &[]).map_err(|_| {
                refuse(format!(
                    "{} holds an earlier episode that a run was replacing when it ended, with files splatloop did not write; move what you need out of it and delete it",
                    self.aside.display()
                ))
            })?;
            fs::remove_dir_all(&self.aside)
                .map_err(|e| SimError::io("cannot remove", &self.aside, e))?;
            done.push(format!(
                "removed {}, an episode already replaced by {}",
                self.aside.display(),
                self.target.display()
            ));
        }
        Ok(done)
    }

    /// Refuses a target that may not be replaced (see [`check_replaceable`]).
    pub fn check_target(&self, overwrite: bool) -> Result<()> {
        if self.target.exists() {
            if !self.target.is_dir() {
                return Err(refuse(format!("{} is a file", self.target.display())));
            }
            check_replaceable(&self.target, overwrite, self.own_names())?;
        }
        Ok(())
    }

    /// Replaces the target by the staging folder: the earlier episode moved aside, the new
    /// one moved in, the earlier one deleted.
    pub fn swap_in(&self) -> Result<()> {
        if self.in_place {
            fs::create_dir_all(&self.aside)
                .map_err(|e| SimError::io("cannot create", &self.aside, e))?;
            for entry in entries(&self.target, self.own_names())? {
                let name = entry.file_name();
                fs::rename(entry.path(), self.aside.join(&name))
                    .map_err(|e| SimError::io("cannot move aside", entry.path(), e))?;
            }
            self.move_into_target(&self.staging)?;
        } else {
            if self.target.exists() {
                fs::rename(&self.target, &self.aside)
                    .map_err(|e| SimError::io("cannot move aside", &self.target, e))?;
            }
            fs::rename(&self.staging, &self.target)
                .map_err(|e| SimError::io("cannot write", &self.target, e))?;
        }
        if self.aside.exists() {
            fs::remove_dir_all(&self.aside)
                .map_err(|e| SimError::io("cannot remove", &self.aside, e))?;
        }
        Ok(())
    }

    /// Moves the staging folder to a visible new name beside the target (inside it when the
    /// target is written in place): `NAME.SUFFIX`, numbered when that exists. Returns it.
    pub fn keep_beside(&self, suffix: &str) -> Result<PathBuf> {
        let name = self
            .target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let home = if self.in_place {
            self.target.clone()
        } else {
            self.target
                .parent()
                .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
        };
        let place = (1..)
            .map(|n| {
                let file = if n == 1 {
                    format!("{name}.{suffix}")
                } else {
                    format!("{name}.{suffix}.{n}")
                };
                home.join(file)
            })
            .find(|p| fs::symlink_metadata(p).is_err())
            .unwrap_or_else(|| home.join(format!("{name}.{suffix}")));
        fs::rename(&self.staging, &place).map_err(|e| SimError::io("cannot write", &place, e))?;
        Ok(place)
    }

    /// Moves `from` into the target: a rename of the whole folder, or entry by entry in place.
    fn move_into_target(&self, from: &Path) -> Result<()> {
        if !self.in_place {
            if self.target.exists() {
                // Empty (checked by the caller): make room for the rename.
                fs::remove_dir(&self.target)
                    .map_err(|e| SimError::io("cannot replace", &self.target, e))?;
            }
            return fs::rename(from, &self.target)
                .map_err(|e| SimError::io("cannot write", &self.target, e));
        }
        for entry in entries(from, &[])? {
            let to = self.target.join(entry.file_name());
            fs::rename(entry.path(), &to).map_err(|e| SimError::io("cannot write", &to, e))?;
        }
        fs::remove_dir(from).map_err(|e| SimError::io("cannot remove", from, e))
    }
}

/// `dir` as an absolute path without `.` or `..`: canonical when it exists, else its
/// canonical parent joined with its name.
fn absolute(dir: &Path) -> Result<PathBuf> {
    if fs::symlink_metadata(dir).is_ok() {
        return fs::canonicalize(dir).map_err(|e| SimError::io("cannot resolve", dir, e));
    }
    let parent = dir
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = dir.file_name().ok_or_else(|| {
        refuse(format!(
            "{} names no folder; give the episode folder's path",
            dir.display()
        ))
    })?;
    Ok(fs::canonicalize(parent)
        .map_err(|e| SimError::io("cannot resolve", parent, e))?
        .join(name))
}

/// Whether `dir` is a mount point: listed in the kernel's mount table, or on another device
/// than its parent.
fn is_mount_point(dir: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    let device = |p: &Path| fs::metadata(p).map(|m| m.dev()).ok();
    if let Some(parent) = dir.parent() {
        if device(dir).is_some() && device(dir) != device(parent) {
            return true;
        }
    }
    let Ok(table) = fs::read_to_string("/proc/self/mountinfo") else {
        return false;
    };
    table
        .lines()
        .filter_map(|line| line.split(' ').nth(4))
        .any(|point| Path::new(&unescape_mount_path(point)) == dir)
}

/// The kernel writes spaces, tabs, newlines and backslashes of mount paths as octal escapes.
fn unescape_mount_path(field: &str) -> String {
    let bytes = field.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let octal = bytes
            .get(i + 1..i + 4)
            .filter(|d| bytes[i] == b'\\' && d.iter().all(|c| (b'0'..=b'7').contains(c)));
        match octal {
            Some(d) => {
                out.push((d[0] - b'0') * 64 + (d[1] - b'0') * 8 + (d[2] - b'0'));
                i += 4;
            }
            None => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Whether a file can be created in `dir` (tried, then removed).
fn writable(dir: &Path) -> bool {
    let probe = dir.join(format!(".splatloop-probe-{}", std::process::id()));
    match fs::File::create(&probe) {
        Ok(_) => {
            let _ = fs::remove_file(&probe);
            true
        }
        Err(_) => false,
    }
}

/// The entries of `dir` but the names in `skip`.
fn entries(dir: &Path, skip: &[&str]) -> Result<Vec<fs::DirEntry>> {
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).map_err(|e| SimError::io("cannot read", dir, e))? {
        let entry = entry.map_err(|e| SimError::io("cannot read", dir, e))?;
        if !skip.iter().any(|s| entry.file_name() == *s) {
            out.push(entry);
        }
    }
    Ok(out)
}

/// The first entry of `dir` but the names in `skip`, without listing the rest.
fn first_entry(dir: &Path, skip: &[&str]) -> Result<Option<PathBuf>> {
    for entry in fs::read_dir(dir).map_err(|e| SimError::io("cannot read", dir, e))? {
        let entry = entry.map_err(|e| SimError::io("cannot read", dir, e))?;
        if !skip.iter().any(|s| entry.file_name() == *s) {
            return Ok(Some(entry.path()));
        }
    }
    Ok(None)
}

/// Every file under `dir` (links as files, never followed), relative to it, sorted.
pub(super) fn files_under(dir: &Path) -> Result<Vec<String>> {
    let mut out = Vec::new();
    walk(dir, &[], &mut |relative| {
        out.push(relative);
        true
    })?;
    out.sort();
    Ok(out)
}

/// Calls `visit` with each file under `dir` (relative, `/`-separated; a link is a file and
/// never followed; top-level names in `skip` left out) until it answers false.
fn walk(dir: &Path, skip: &[&str], visit: &mut dyn FnMut(String) -> bool) -> Result<()> {
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        let skip_here: &[&str] = if folder == dir { skip } else { &[] };
        for entry in entries(&folder, skip_here)? {
            let kind = entry
                .file_type()
                .map_err(|e| SimError::io("cannot read", entry.path(), e))?;
            let path = entry.path();
            if kind.is_dir() {
                stack.push(path);
            } else if let Ok(relative) = path.strip_prefix(dir) {
                if !visit(relative.to_string_lossy().replace('\\', "/")) {
                    return Ok(());
                }
            }
        }
    }
    Ok(())
}

/// Checks that `dir` may be replaced: empty (names in `skip` aside), or, with `overwrite`,
/// holding only what the manifest of its episode.json lists. Stops at the first entry without
/// `overwrite` and after the first few foreign files with it; never follows a link.
pub(super) fn check_replaceable(dir: &Path, overwrite: bool, skip: &[&str]) -> Result<()> {
    if first_entry(dir, skip)?.is_none() {
        return Ok(());
    }
    if !overwrite {
        return Err(refuse(format!("{} is not empty; choose a new --out, or pass --overwrite to replace an earlier episode", dir.display())));
    }
    let manifest: Option<Vec<String>> = fs::read_to_string(dir.join("episode.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|v| {
            v.get("files")
                .and_then(|f| serde_json::from_value(f.clone()).ok())
        });
    let Some(manifest) = manifest else {
        return Err(refuse(format!(
            "{} holds files but no splatloop manifest (episode.json with a file list), so --overwrite leaves it alone",
            dir.display()
        )));
    };
    const NAMED: usize = 5;
    let mut foreign = Vec::new();
    walk(dir, skip, &mut |file| {
        if !manifest.contains(&file) {
            foreign.push(file);
        }
        foreign.len() <= NAMED
    })?;
    if foreign.is_empty() {
        return Ok(());
    }
    let more = if foreign.len() > NAMED {
        foreign.truncate(NAMED);
        " and more"
    } else {
        ""
    };
    Err(refuse(format!(
        "{} holds files splatloop did not write ({}{more}); --overwrite replaces only an episode's own files, so move them first",
        dir.display(),
        foreign.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mount_paths_are_unescaped_as_the_kernel_escapes_them() {
        assert_eq!(unescape_mount_path(r"/mnt/my\040disk"), "/mnt/my disk");
        assert_eq!(unescape_mount_path(r"/a\134b"), r"/a\b");
        assert_eq!(unescape_mount_path(r"/plain\0x"), r"/plain\0x");
    }

    #[test]
    fn the_root_is_refused_and_dot_is_named_by_its_path() {
        assert!(Places::resolve(Path::new("/")).is_err());
        let here = std::env::current_dir().expect("a current folder");
        let places = Places::resolve(Path::new(".")).expect("resolves");
        assert_eq!(places.target, fs::canonicalize(&here).expect("real path"));
        assert!(places.in_place, "the current folder is written in place");
        assert!(places.lock.starts_with(&places.target));
    }
}
