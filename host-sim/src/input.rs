//! Bounded reads of the text files a user hands the tools: a pose file, `times.txt`,
//! `calib.txt`, a mount file, a scenario. Each kind has a size limit ([`Input::limit`]), read
//! through `Read::take(limit + 1)`, so that `/dev/zero` or a file of gigabytes is refused after
//! reading one byte more than the limit, never held whole; text that is not UTF-8 is refused
//! with the line where it stops being so.

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// One mebibyte.
const MIB: u64 = 1 << 20;

/// The largest pose file read: 64 MiB, about 300,000 poses of 12 numbers in KITTI's
/// `%e` format (the longest KITTI sequence has 4,661).
pub const MAX_POSES_BYTES: u64 = 64 * MIB;
/// The largest `times.txt` read: 64 MiB, millions of timestamps.
pub const MAX_TIMES_BYTES: u64 = 64 * MIB;
/// The largest `calib.txt` read: 1 MiB (KITTI's are under 1 KiB).
pub const MAX_CALIB_BYTES: u64 = MIB;
/// The largest mount file read: 1 MiB (a complete one is under 4 KiB).
pub const MAX_MOUNT_BYTES: u64 = MIB;
/// The largest scenario or overlay file read: 1 MiB (the built-ins are under 8 KiB).
pub const MAX_SCENARIO_BYTES: u64 = MIB;

/// The kinds of text file read, each with its limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// A KITTI pose file.
    Poses,
    /// A KITTI `times.txt`.
    Times,
    /// A KITTI `calib.txt`.
    Calib,
    /// A mount file.
    Mount,
    /// A scenario or an overlay.
    Scenario,
}

impl Input {
    /// The most bytes a file of this kind may hold.
    pub const fn limit(self) -> u64 {
        match self {
            Input::Poses => MAX_POSES_BYTES,
            Input::Times => MAX_TIMES_BYTES,
            Input::Calib => MAX_CALIB_BYTES,
            Input::Mount => MAX_MOUNT_BYTES,
            Input::Scenario => MAX_SCENARIO_BYTES,
        }
    }

    /// The kind in words, for messages.
    pub const fn name(self) -> &'static str {
        match self {
            Input::Poses => "a pose file",
            Input::Times => "times.txt",
            Input::Calib => "calib.txt",
            Input::Mount => "a mount file",
            Input::Scenario => "a scenario file",
        }
    }
}

impl fmt::Display for Input {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a text file could not be read.
#[derive(Debug, Error)]
pub enum InputError {
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file holds more than its kind's limit.
    #[error("{}: larger than {} (the limit for {kind})", path.display(), bytes(kind.limit()))]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// What it was read as.
        kind: Input,
    },
    /// The file is not UTF-8 text.
    #[error("{} line {line}: not UTF-8 text (byte {byte} of the file)", path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// 1-based line of the first byte that is not UTF-8.
        line: usize,
        /// 1-based offset of that byte in the file.
        byte: usize,
    },
}

/// A size in words: `64 MiB (67108864 bytes)`.
fn bytes(n: u64) -> String {
    format!("{} MiB ({n} bytes)", n / MIB)
}

/// Reads `path` as UTF-8 text of `kind`, refusing a file larger than the kind's limit without
/// reading more than one byte past it.
pub fn read_text(path: &Path, kind: Input) -> Result<String, InputError> {
    let io = |source| InputError::Io {
        path: path.to_owned(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let limit = kind.limit();
    let mut buf = Vec::new();
    file.take(limit + 1).read_to_end(&mut buf).map_err(io)?;
    if buf.len() as u64 > limit {
        return Err(InputError::TooLarge {
            path: path.to_owned(),
            kind,
        });
    }
    String::from_utf8(buf).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        InputError::NotUtf8 {
            path: path.to_owned(),
            line: before.iter().filter(|&&b| b == b'\n').count() + 1,
            byte: at + 1,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dev_zero_is_refused_as_too_large() {
        let e = read_text(Path::new("/dev/zero"), Input::Mount)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "/dev/zero: larger than 1 MiB (1048576 bytes) (the limit for a mount file)"
        );
    }

    #[test]
    fn a_file_one_byte_over_the_limit_is_refused_and_one_at_it_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("calib.txt");
        std::fs::write(&p, vec![b' '; MAX_CALIB_BYTES as usize + 1]).unwrap();
        let e = read_text(&p, Input::Calib).unwrap_err().to_string();
        assert!(
            e.contains("calib.txt: larger than 1 MiB") && e.contains("the limit for calib.txt"),
            "{e}"
        );
        std::fs::write(&p, vec![b' '; MAX_CALIB_BYTES as usize]).unwrap();
        assert_eq!(read_text(&p, Input::Calib).unwrap().len(), 1 << 20);
    }

    #[test]
    fn a_pose_file_over_its_limit_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("00.txt");
        let f = std::fs::File::create(&p).unwrap();
        f.set_len(MAX_POSES_BYTES + 1).unwrap();
        let e = read_text(&p, Input::Poses).unwrap_err().to_string();
        assert!(
            e.ends_with("00.txt: larger than 64 MiB (67108864 bytes) (the limit for a pose file)"),
            "{e}"
        );
    }

    #[test]
    fn text_that_is_not_utf8_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("times.txt");
        std::fs::write(&p, b"0.0\n0.1\n0.\xff2\n").unwrap();
        let e = read_text(&p, Input::Times).unwrap_err().to_string();
        assert!(
            e.ends_with("times.txt line 3: not UTF-8 text (byte 11 of the file)"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_file_is_named() {
        let e = read_text(Path::new("/nonexistent/mount.toml"), Input::Mount)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("/nonexistent/mount.toml: "), "{e}");
    }
}
