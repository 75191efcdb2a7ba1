//! The KITTI odometry layout: `sequences/NN/image_0/%06d.png`, `sequences/NN/calib.txt` (line
//! `P0:` with 12 numbers), `sequences/NN/times.txt` (seconds, one a line) and `poses/NN.txt`
//! (12 numbers a line: the 3x4 pose of camera 0 in the frame of camera 0 at the first frame).
//! Every error names the file, the line where there is one, and what was expected.

use image::GrayImage;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// A 3x4 pose `[R | t]`, row-major.
pub type Pose = [f64; 12];

/// The pose of a camera pose from the core (a vehicle pose lifted through the mount).
pub fn pose_of(camera: &roadvo::CameraPose) -> Pose {
    std::array::from_fn(|k| f64::from(camera.rows[k / 4][k % 4]))
}

/// What went wrong reading or writing KITTI files.
#[derive(Debug, Error)]
pub enum KittiError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A line does not hold what it should.
    #[error("{} line {line}: {what}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was expected and found.
        what: String,
    },
    /// The file or folder as a whole is wrong.
    #[error("{}: {what}", path.display())]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

pub(crate) fn read_text(path: &Path) -> Result<String, KittiError> {
    std::fs::read_to_string(path).map_err(|source| KittiError::Io {
        path: path.to_owned(),
        source,
    })
}

pub(crate) fn parse_numbers(path: &Path, line: usize, text: &str) -> Result<Vec<f64>, KittiError> {
    text.split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| KittiError::Line {
                    path: path.to_owned(),
                    line,
                    what: format!("{w:?} is not a finite number"),
                })
        })
        .collect()
}

/// Reads a pose file: one pose of 12 numbers per line; blank lines at the end are allowed.
pub fn read_poses(path: &Path) -> Result<Vec<Pose>, KittiError> {
    let text = read_text(path)?;
    let mut poses = Vec::new();
    for (i, line) in text.trim_end().lines().enumerate() {
        let nums = parse_numbers(path, i + 1, line)?;
        let pose: Pose = nums.as_slice().try_into().map_err(|_| KittiError::Line {
            path: path.to_owned(),
            line: i + 1,
            what: format!("expected 12 numbers (a 3x4 pose), found {}", nums.len()),
        })?;
        poses.push(pose);
    }
    if poses.is_empty() {
        return Err(KittiError::File {
            path: path.to_owned(),
            what: "holds no poses".into(),
        });
    }
    Ok(poses)
}

/// Writes a pose file, creating its folder.
pub fn write_poses(path: &Path, poses: &[Pose]) -> anyhow::Result<()> {
    let mut text = String::with_capacity(poses.len() * 200);
    for p in poses {
        let line: Vec<String> = p.iter().map(|x| format!("{x:.9e}")).collect();
        let _ = writeln!(text, "{}", line.join(" "));
    }
    write_text(path, &text)
}

/// Writes a text file whole or not at all ([`crate::output`]), creating its folder.
pub fn write_text(path: &Path, text: &str) -> anyhow::Result<()> {
    crate::output::write_atomic(path, text.as_bytes())
}

/// Reads the `P0:` line of a `calib.txt`: the 3x4 projection of camera 0.
pub fn read_calib_p0(path: &Path) -> Result<[f64; 12], KittiError> {
    let text = read_text(path)?;
    for (i, line) in text.lines().enumerate() {
        if let Some(rest) = line.trim_start().strip_prefix("P0:") {
            let nums = parse_numbers(path, i + 1, rest)?;
            return nums.as_slice().try_into().map_err(|_| KittiError::Line {
                path: path.to_owned(),
                line: i + 1,
                what: format!(
                    "P0 needs 12 numbers (a 3x4 projection), found {}",
                    nums.len()
                ),
            });
        }
    }
    Err(KittiError::File {
        path: path.to_owned(),
        what: "no line starts with `P0:` (the projection of camera 0)".into(),
    })
}

/// Writes a `calib.txt` whose `P0` is a camera with these intrinsics.
pub fn write_calib(path: &Path, fx: f64, fy: f64, cx: f64, cy: f64) -> anyhow::Result<()> {
    let p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0];
    let nums: Vec<String> = p.iter().map(|x| format!("{x:.12e}")).collect();
    write_text(path, &format!("P0: {}\n", nums.join(" ")))
}

/// Reads `times.txt`: one timestamp in seconds per line, strictly increasing.
pub fn read_times(path: &Path) -> Result<Vec<f64>, KittiError> {
    let text = read_text(path)?;
    let mut times: Vec<f64> = Vec::new();
    for (i, line) in text.trim_end().lines().enumerate() {
        let nums = parse_numbers(path, i + 1, line)?;
        let [t] = nums.as_slice() else {
            return Err(KittiError::Line {
                path: path.to_owned(),
                line: i + 1,
                what: format!(
                    "expected one timestamp in seconds, found {} numbers",
                    nums.len()
                ),
            });
        };
        if let Some(&prev) = times.last()
            && *t <= prev
        {
            return Err(KittiError::Line {
                path: path.to_owned(),
                line: i + 1,
                what: format!("timestamp {t} does not increase (previous line: {prev})"),
            });
        }
        times.push(*t);
    }
    Ok(times)
}

/// Writes `times.txt`.
pub fn write_times(path: &Path, times: &[f64]) -> anyhow::Result<()> {
    let mut text = String::new();
    for t in times {
        let _ = writeln!(text, "{t:.6e}");
    }
    write_text(path, &text)
}

/// The largest frame side the tools decode, pixels: far beyond any road camera, and a bound on
/// a frame's memory (a 20000x20000 PNG of a few hundred kilobytes would take 400 MB).
pub const MAX_FRAME_SIDE_PX: u32 = 8192;

/// The smallest frame side, pixels: below it no ground window fits the corner detector.
pub const MIN_FRAME_SIDE_PX: u32 = 16;

/// The size of the frame at `path` from its header alone, checked against
/// [`MIN_FRAME_SIDE_PX`]..=[`MAX_FRAME_SIDE_PX`].
pub fn frame_size(path: &Path) -> Result<(u32, u32), KittiError> {
    let file = |what: String| KittiError::File {
        path: path.to_owned(),
        what,
    };
    let (w, h) =
        image::image_dimensions(path).map_err(|e| file(format!("cannot read the image: {e}")))?;
    let range = MIN_FRAME_SIDE_PX..=MAX_FRAME_SIDE_PX;
    if !range.contains(&w) || !range.contains(&h) {
        return Err(file(format!(
            "is {w}x{h} pixels; frames must be {MIN_FRAME_SIDE_PX} to {MAX_FRAME_SIDE_PX} pixels \
             a side"
        )));
    }
    Ok((w, h))
}

/// The path of frame `i` in a sequence folder.
pub fn image_path(seq_dir: &Path, i: usize) -> PathBuf {
    seq_dir.join("image_0").join(format!("{i:06}.png"))
}

/// A KITTI sequence folder, checked: frames numbered from 0 without gaps, a timestamp for each,
/// a `P0` calibration.
#[derive(Clone, Debug)]
pub struct Sequence {
    /// The folder (`.../sequences/NN`).
    pub dir: PathBuf,
    /// Number of frames.
    pub frames: usize,
    /// Timestamps, seconds, one per frame.
    pub times_s: Vec<f64>,
    /// The `P0` projection.
    pub p0: [f64; 12],
    /// Frame size, from the first frame: (width, height).
    pub size: (u32, u32),
}

impl Sequence {
    /// Opens and checks a sequence folder.
    pub fn open(dir: &Path) -> Result<Self, KittiError> {
        let image_dir = dir.join("image_0");
        let entries = std::fs::read_dir(&image_dir).map_err(|source| KittiError::Io {
            path: image_dir.clone(),
            source,
        })?;
        let mut numbers = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|source| KittiError::Io {
                path: image_dir.clone(),
                source,
            })?;
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if let Some(stem) = name.strip_suffix(".png") {
                let n: usize = stem.parse().map_err(|_| KittiError::File {
                    path: entry.path(),
                    what: "frame names must be numbers, like 000042.png".into(),
                })?;
                numbers.push(n);
            }
        }
        numbers.sort_unstable();
        if numbers.is_empty() {
            return Err(KittiError::File {
                path: image_dir,
                what: "holds no .png frames".into(),
            });
        }
        for (expected, &n) in numbers.iter().enumerate() {
            if n != expected {
                let before = if expected == 0 {
                    "the sequence must start at 000000.png".to_string()
                } else {
                    format!("{:06}.png is followed by {n:06}.png", expected - 1)
                };
                return Err(KittiError::File {
                    path: image_dir,
                    what: format!("frame {expected:06}.png is missing ({before})"),
                });
            }
        }
        let frames = numbers.len();
        let times_path = dir.join("times.txt");
        let times_s = read_times(&times_path)?;
        if times_s.len() < frames {
            return Err(KittiError::File {
                path: times_path,
                what: format!(
                    "has {} timestamps but image_0 holds {frames} frames",
                    times_s.len()
                ),
            });
        }
        let p0 = read_calib_p0(&dir.join("calib.txt"))?;
        let size = frame_size(&image_path(dir, 0))?;
        Ok(Self {
            dir: dir.to_owned(),
            frames,
            times_s: times_s[..frames].to_vec(),
            p0,
            size,
        })
    }

    /// Frame `i`'s timestamp, to the microsecond, as every run of the odometer gives it.
    pub fn timestamp(&self, i: usize) -> roadvo::Instant {
        roadvo::Instant::from_micros((self.times_s[i] * 1e6).round() as u64)
    }

    /// Loads frame `i` as 8-bit grey; it must have the size of the first frame.
    pub fn load(&self, i: usize) -> Result<GrayImage, KittiError> {
        let path = image_path(&self.dir, i);
        let cannot_read = |e: &dyn std::fmt::Display| KittiError::File {
            path: path.clone(),
            what: format!("cannot read the image: {e}"),
        };
        // The header's size is checked before any pixel is decoded.
        let mut reader = image::ImageReader::open(&path)
            .and_then(image::ImageReader::with_guessed_format)
            .map_err(|e| cannot_read(&e))?;
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(self.size.0);
        limits.max_image_height = Some(self.size.1);
        reader.limits(limits);
        let grey = reader.decode().map_err(|e| cannot_read(&e))?.into_luma8();
        if grey.dimensions() != self.size {
            return Err(KittiError::File {
                path,
                what: format!(
                    "is {}x{}, expected {}x{} like 000000.png",
                    grey.width(),
                    grey.height(),
                    self.size.0,
                    self.size.1
                ),
            });
        }
        Ok(grey)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp() -> tempfile::TempDir {
        tempfile::tempdir().unwrap()
    }

    #[test]
    fn poses_round_trip() {
        let d = tmp();
        let p = d.path().join("poses/00.txt");
        let poses = vec![
            [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0, 0.1, 0.0, 1.0, 0.0, -0.2, 0.0, 0.0, 1.0, 1.5],
        ];
        write_poses(&p, &poses).unwrap();
        assert_eq!(read_poses(&p).unwrap(), poses);
    }

    #[test]
    fn short_pose_line_names_file_and_line() {
        let d = tmp();
        let p = d.path().join("00.txt");
        std::fs::write(&p, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n").unwrap();
        let e = read_poses(&p).unwrap_err().to_string();
        assert!(
            e.ends_with("00.txt line 2: expected 12 numbers (a 3x4 pose), found 11"),
            "{e}"
        );
        std::fs::write(&p, "1 0 0 0 0 1 0 0 0 0 1 x\n").unwrap();
        let e = read_poses(&p).unwrap_err().to_string();
        assert!(e.contains("line 1: \"x\" is not a finite number"), "{e}");
    }

    #[test]
    fn calib_without_p0_is_an_error() {
        let d = tmp();
        let p = d.path().join("calib.txt");
        std::fs::write(&p, "P1: 1 2 3\n").unwrap();
        let e = read_calib_p0(&p).unwrap_err().to_string();
        assert!(e.contains("no line starts with `P0:`"), "{e}");
        std::fs::write(&p, "P0: 1 2 3\n").unwrap();
        let e = read_calib_p0(&p).unwrap_err().to_string();
        assert!(e.contains("line 1: P0 needs 12 numbers"), "{e}");
        write_calib(&p, 700.0, 700.0, 600.0, 180.0).unwrap();
        let p0 = read_calib_p0(&p).unwrap();
        assert_eq!((p0[0], p0[2], p0[5], p0[6]), (700.0, 600.0, 700.0, 180.0));
    }

    fn sequence_with(frames: &[usize], sizes: &[(u32, u32)]) -> tempfile::TempDir {
        let d = tmp();
        for (&i, &(w, h)) in frames.iter().zip(sizes) {
            let path = image_path(d.path(), i);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            GrayImage::new(w, h).save(&path).unwrap();
        }
        let times: Vec<f64> = (0..frames.len()).map(|i| i as f64 * 0.1).collect();
        write_times(&d.path().join("times.txt"), &times).unwrap();
        write_calib(&d.path().join("calib.txt"), 500.0, 500.0, 32.0, 24.0).unwrap();
        d
    }

    #[test]
    fn sequence_opens_and_checks_frames() {
        let d = sequence_with(&[0, 1, 2], &[(64, 48); 3]);
        let s = Sequence::open(d.path()).unwrap();
        assert_eq!((s.frames, s.size), (3, (64, 48)));
        assert_eq!(s.load(2).unwrap().dimensions(), (64, 48));
    }

    #[test]
    fn gap_in_frame_numbers_is_named() {
        let d = sequence_with(&[0, 1, 3], &[(64, 48); 3]);
        let e = Sequence::open(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("frame 000002.png is missing (000001.png is followed by 000003.png)"),
            "{e}"
        );
    }

    #[test]
    fn frame_of_another_size_is_named() {
        let d = sequence_with(&[0, 1], &[(64, 48), (63, 48)]);
        let s = Sequence::open(d.path()).unwrap();
        let e = s.load(1).unwrap_err().to_string();
        assert!(
            e.contains("000001.png: is 63x48, expected 64x48 like 000000.png"),
            "{e}"
        );
    }

    #[test]
    fn times_must_increase() {
        let d = tmp();
        let p = d.path().join("times.txt");
        std::fs::write(&p, "0.0\n0.1\n0.1\n").unwrap();
        let e = read_times(&p).unwrap_err().to_string();
        assert!(e.contains("line 3: timestamp 0.1 does not increase"), "{e}");
    }
}
