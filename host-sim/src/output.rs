//! Outputs written whole or not at all. Every file the tools write goes to a temporary file in
//! the same folder and is renamed into place when it is complete ([`OutputFile`],
//! [`write_atomic`]); a rendered drive goes to a temporary folder beside its destination
//! ([`StagingDir`]). A failed, full or interrupted write leaves the previous file or folder as
//! it was. [`check_outputs`] refuses, before any work, outputs that would overwrite an input or
//! each other, and folders that cannot be written.

use anyhow::{Context, Result, bail};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use tempfile::{NamedTempFile, TempDir};

/// A file being written: a temporary file beside `path` until [`commit`](Self::commit) renames
/// it into place. Dropped without a commit, it is removed and `path` keeps what it held.
pub struct OutputFile {
    path: PathBuf,
    writer: BufWriter<NamedTempFile>,
}

impl OutputFile {
    /// Starts writing `path`, creating its folder if needed.
    pub fn create(path: &Path) -> Result<Self> {
        let temp = temp_file_beside(path, "")?;
        Ok(Self {
            path: path.to_owned(),
            writer: BufWriter::new(temp),
        })
    }

    /// Where the file goes.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes `bytes`; errors name the destination.
    pub fn write_all(&mut self, bytes: &[u8]) -> Result<()> {
        self.writer
            .write_all(bytes)
            .with_context(|| format!("cannot write {}", self.path.display()))
    }

    /// Writes `line` and a newline.
    pub fn write_line(&mut self, line: &str) -> Result<()> {
        self.write_all(line.as_bytes())?;
        self.write_all(b"\n")
    }

    /// Flushes the file to disk and renames it into place, replacing what was there.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let failed = || format!("cannot write {}", path.display());
        let temp = self
            .writer
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(failed)?;
        temp.as_file().sync_all().with_context(failed)?;
        temp.persist(&path)
            .map_err(|e| e.error)
            .with_context(failed)?;
        Ok(())
    }
}

/// Writes `bytes` to `path` whole or not at all (see [`OutputFile`]).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut file = OutputFile::create(path)?;
    file.write_all(bytes)?;
    file.commit()
}

/// Writes `path` through `write`, which writes to the path it is given (a temporary file beside
/// `path` with the same extension, for writers that choose their format by it), then renames
/// the result into place, unless a Ctrl-C came meanwhile ([`crate::interrupt`]).
pub fn write_atomic_with(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let extension = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let temp = temp_file_beside(path, &extension)?;
    write(temp.path())?;
    crate::interrupt::check()?;
    let failed = || format!("cannot write {}", path.display());
    temp.as_file().sync_all().with_context(failed)?;
    temp.persist(path)
        .map_err(|e| e.error)
        .with_context(failed)?;
    Ok(())
}

/// The folder a file goes into (`.` for a bare file name), created if missing.
fn folder_of(path: &Path) -> Result<PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir)
        .with_context(|| format!("cannot create the folder of {}", path.display()))?;
    Ok(dir)
}

/// A hidden temporary file in `path`'s folder, named after it.
fn temp_file_beside(path: &Path, suffix: &str) -> Result<NamedTempFile> {
    if path.file_name().is_none() || path.is_dir() {
        bail!("{}: is a folder, not a file name", path.display());
    }
    let dir = folder_of(path)?;
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(suffix)
        .tempfile_in(&dir)
        .with_context(|| format!("cannot write {} (in {})", path.display(), dir.display()))
}

/// A folder being filled: a temporary folder beside `dest` until [`commit`](Self::commit) puts
/// it in `dest`'s place. Dropped without a commit, it is removed and `dest` is untouched.
pub struct StagingDir {
    dest: PathBuf,
    temp: TempDir,
}

impl StagingDir {
    /// Starts a folder for `dest`. `replaceable` says whether an existing, non-empty `dest` may
    /// be replaced (its contents are what this command writes, e.g. an earlier render); if
    /// not, it is refused before any work.
    pub fn new(dest: &Path, replaceable: impl Fn(&Path) -> bool) -> Result<Self> {
        if dest.exists() {
            if !dest.is_dir() {
                bail!("{}: exists and is not a folder", dest.display());
            }
            let empty = std::fs::read_dir(dest)
                .with_context(|| format!("cannot read {}", dest.display()))?
                .next()
                .is_none();
            if !empty && !replaceable(dest) {
                bail!(
                    "{}: the folder is not empty and holds something else; choose a new or \
                     empty folder",
                    dest.display()
                );
            }
        }
        let parent = folder_of(dest)?;
        let name = dest.file_name().unwrap_or_default().to_string_lossy();
        let temp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .tempdir_in(&parent)
            .with_context(|| format!("cannot write in {}", parent.display()))?;
        Ok(Self {
            dest: dest.to_owned(),
            temp,
        })
    }

    /// The temporary folder to fill.
    pub fn path(&self) -> &Path {
        self.temp.path()
    }

    /// Puts the filled folder in `dest`'s place; an earlier `dest` is removed only after.
    pub fn commit(self) -> Result<()> {
        let failed = || format!("cannot move the new files into {}", self.dest.display());
        let filled = self.temp.keep();
        if self.dest.exists() {
            let old = tempfile::Builder::new()
                .prefix(".old.")
                .tempdir_in(filled.parent().unwrap_or(Path::new(".")))
                .with_context(failed)?;
            let old_dest = old.path().join("previous");
            std::fs::rename(&self.dest, &old_dest).with_context(failed)?;
            if let Err(e) = std::fs::rename(&filled, &self.dest) {
                // Put the earlier folder back before saying so.
                let _ = std::fs::rename(&old_dest, &self.dest);
                let _ = std::fs::remove_dir_all(&filled);
                return Err(e).with_context(failed);
            }
            drop(old);
        } else {
            std::fs::rename(&filled, &self.dest).with_context(failed)?;
        }
        Ok(())
    }
}

/// A path's identity for comparing inputs with outputs: the canonical path of the file, or of
/// its folder joined with its name when it does not exist yet.
fn identity(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let name = path.file_name().map(PathBuf::from).unwrap_or_default();
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    dir.canonicalize()
        .map(|d| d.join(&name))
        .unwrap_or_else(|_| path.to_owned())
}

/// Refuses, before any work: an output that is one of `inputs` or lies inside an input folder
/// (`input_dirs`), two outputs on the same path, and an output whose folder cannot be written.
/// `outputs` pairs each path with the option that names it (`--out`, `--quality`, ...).
pub fn check_outputs(
    inputs: &[&Path],
    input_dirs: &[&Path],
    outputs: &[(&str, &Path)],
) -> Result<()> {
    let inputs: Vec<PathBuf> = inputs.iter().map(|p| identity(p)).collect();
    let dirs: Vec<PathBuf> = input_dirs.iter().map(|p| identity(p)).collect();
    for (k, &(option, path)) in outputs.iter().enumerate() {
        let id = identity(path);
        if inputs.contains(&id) {
            bail!(
                "{option} {}: is an input of this command; write the output elsewhere",
                path.display()
            );
        }
        if let Some(d) = dirs.iter().find(|d| id.starts_with(d)) {
            bail!(
                "{option} {}: is inside the input folder {}; write the output elsewhere",
                path.display(),
                d.display()
            );
        }
        if let Some((other, _)) = outputs[..k].iter().find(|(_, p)| identity(p) == id) {
            bail!(
                "{option} {} and {other} name the same file; give each its own",
                path.display()
            );
        }
        // Writable: a temporary file in its folder, removed at once.
        drop(temp_file_beside(path, "")?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_the_previous_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("est.txt");
        write_atomic(&p, b"good").unwrap();
        let mut f = OutputFile::create(&p).unwrap();
        f.write_line("half a traj").unwrap();
        drop(f); // no commit: an error or an interruption
        assert_eq!(std::fs::read(&p).unwrap(), b"good");
        assert_eq!(
            std::fs::read_dir(d.path()).unwrap().count(),
            1,
            "no temporary left"
        );
        let mut f = OutputFile::create(&p).unwrap();
        f.write_line("new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new\n");
    }

    #[test]
    fn outputs_may_not_overwrite_inputs_or_each_other() {
        let d = tempfile::tempdir().unwrap();
        let input = d.path().join("times.txt");
        std::fs::write(&input, "0\n").unwrap();
        let out = d.path().join("out.txt");
        let seq = d.path().join("seq");
        std::fs::create_dir(&seq).unwrap();
        let err = |inputs: &[&Path], outputs: &[(&str, &Path)]| {
            check_outputs(inputs, &[&seq], outputs)
                .unwrap_err()
                .to_string()
        };
        assert!(err(&[&input], &[("--out", &input)]).contains("is an input"));
        let msg = err(&[], &[("--out", &out), ("--quality", &out)]);
        assert!(msg.contains("--quality") && msg.contains("--out"), "{msg}");
        assert!(err(&[], &[("--out", &seq.join("x.txt"))]).contains("inside the input folder"));
        check_outputs(&[&input], &[&seq], &[("--out", &out)]).unwrap();
        assert!(!out.exists(), "the check writes nothing");
    }

    #[test]
    fn a_staged_folder_replaces_an_earlier_one_only_on_commit() {
        let d = tempfile::tempdir().unwrap();
        let dest = d.path().join("drive");
        std::fs::create_dir(&dest).unwrap();
        std::fs::write(dest.join("old.png"), "old").unwrap();
        let refused = StagingDir::new(&dest, |_| false).err().unwrap().to_string();
        assert!(refused.contains("not empty"), "{refused}");
        let staged = StagingDir::new(&dest, |_| true).unwrap();
        std::fs::write(staged.path().join("new.png"), "new").unwrap();
        drop(staged);
        assert!(dest.join("old.png").exists());
        let staged = StagingDir::new(&dest, |_| true).unwrap();
        std::fs::write(staged.path().join("new.png"), "new").unwrap();
        staged.commit().unwrap();
        assert!(!dest.join("old.png").exists() && dest.join("new.png").exists());
        let left: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
        assert_eq!(left.len(), 1, "only the folder itself is left");
    }
}
