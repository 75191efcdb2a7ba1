//! The KITTI odometry layout: `sequences/NN/image_0/%06d.png`, `sequences/NN/calib.txt` (line
//! `P0:` with 12 numbers), `sequences/NN/times.txt` (seconds, one a line) and `poses/NN.txt`
//! (12 numbers a line: the 3x4 pose of camera 0 in the frame of camera 0 at the first frame).
//! Every error names the file, the line where there is one, and what was expected.

use crate::input::{Input, InputError, read_text};
use crate::layout::Layout;
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

/// What went wrong reading or writing KITTI files, or reading a sequence of another layout
/// ([`crate::layout`]).
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
    /// The file is too large or not text.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The file or folder as a whole is wrong.
    #[error("{}: {what}", path.display())]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
}

/// The largest timestamp taken, seconds (about 31 years): larger ones lose the microsecond.
pub const MAX_TIME_S: f64 = 1e9;

/// A [`KittiError::Line`]: `what` is wrong on line `line` (1-based) of `path`.
pub(crate) fn line_error(path: &Path, line: usize, what: String) -> KittiError {
    KittiError::Line {
        path: path.to_owned(),
        line,
        what,
    }
}

pub(crate) fn parse_numbers(path: &Path, line: usize, text: &str) -> Result<Vec<f64>, KittiError> {
    text.split_whitespace()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| line_error(path, line, format!("{w:?} is not a finite number")))
        })
        .collect()
}

/// Reads a pose file (see [`parse_poses`]), at most [`MAX_POSES_BYTES`](crate::input::MAX_POSES_BYTES).
pub fn read_poses(path: &Path) -> Result<Vec<Pose>, KittiError> {
    parse_poses(&read_text(path, Input::Poses)?, path)
}

/// Parses the text of a pose file: one pose of 12 numbers per line (a KITTI trajectory, as
/// [`crate::pose_file::parse_trajectory`] reads one: blank lines and `#` comments skipped).
/// Errors name `path`, and the line where there is one.
pub fn parse_poses(text: &str, path: &Path) -> Result<Vec<Pose>, KittiError> {
    crate::pose_file::parse_trajectory(text, path, Some(crate::pose_file::PoseFormat::Kitti))
        .map(|t| t.poses)
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

/// Reads the `P0:` line of a `calib.txt` (see [`parse_calib_p0`]), at most
/// [`MAX_CALIB_BYTES`](crate::input::MAX_CALIB_BYTES).
pub fn read_calib_p0(path: &Path) -> Result<[f64; 12], KittiError> {
    parse_calib_p0(&read_text(path, Input::Calib)?, path)
}

/// What a rectified camera-0 projection looks like, for messages.
const P0_SHAPE: &str = "a rectified camera-0 projection is `fx 0 cx tx 0 fy cy ty 0 0 1 0` \
                        with fx, fy > 0";

/// Parses the text of a `calib.txt`: its one `P0:` line, the 3x4 projection of camera 0, which
/// must be a rectified camera's (no skew, third row `0 0 1 0`, positive focal lengths). Other
/// lines are left alone. Errors name `path` and the line.
pub fn parse_calib_p0(text: &str, path: &Path) -> Result<[f64; 12], KittiError> {
    let mut found: Option<(usize, [f64; 12])> = None;
    for (i, line) in text.lines().enumerate() {
        let Some(rest) = line.trim_start().strip_prefix("P0:") else {
            continue;
        };
        let line = i + 1;
        if let Some((first, _)) = found {
            return Err(line_error(
                path,
                line,
                format!(
                    "a second `P0:` line (the first is line {first}): which one is camera 0's?"
                ),
            ));
        }
        let nums = parse_numbers(path, line, rest)?;
        let p: [f64; 12] = nums.as_slice().try_into().map_err(|_| {
            line_error(
                path,
                line,
                format!(
                    "P0 needs 12 numbers (a 3x4 projection), found {}",
                    nums.len()
                ),
            )
        })?;
        check_p0(&p).map_err(|what| line_error(path, line, format!("{what}: {P0_SHAPE}")))?;
        found = Some((line, p));
    }
    found.map(|(_, p)| p).ok_or_else(|| KittiError::File {
        path: path.to_owned(),
        what: "no line starts with `P0:` (the projection of camera 0)".into(),
    })
}

/// What is wrong with `p` as a rectified camera-0 projection, if anything.
fn check_p0(p: &[f64; 12]) -> Result<(), String> {
    let named = |k: usize| format!("P0 number {} is {}, not 0", k + 1, p[k]);
    if p[1] != 0.0 {
        return Err(format!("{} (a skewed camera)", named(1)));
    }
    if p[4] != 0.0 {
        return Err(named(4));
    }
    if p[8] != 0.0 || p[9] != 0.0 || p[10] != 1.0 || p[11] != 0.0 {
        return Err(format!(
            "the third row is `{} {} {} {}`, not `0 0 1 0`",
            p[8], p[9], p[10], p[11]
        ));
    }
    if !(p[0] > 0.0 && p[5] > 0.0) {
        return Err(format!(
            "the focal lengths (numbers 1 and 6) are {} and {}",
            p[0], p[5]
        ));
    }
    Ok(())
}

/// Writes a `calib.txt` whose `P0` is a camera with these intrinsics.
pub fn write_calib(path: &Path, fx: f64, fy: f64, cx: f64, cy: f64) -> anyhow::Result<()> {
    let p = [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0];
    let nums: Vec<String> = p.iter().map(|x| format!("{x:.12e}")).collect();
    write_text(path, &format!("P0: {}\n", nums.join(" ")))
}

/// Reads `times.txt` (see [`parse_times`]), at most
/// [`MAX_TIMES_BYTES`](crate::input::MAX_TIMES_BYTES).
pub fn read_times(path: &Path) -> Result<Vec<f64>, KittiError> {
    parse_times(&read_text(path, Input::Times)?, path)
}

/// Parses the text of a `times.txt`: one timestamp in seconds per line, from 0 to
/// [`MAX_TIME_S`], each at least a microsecond after the one before (the odometer counts
/// microseconds). Errors name `path` and the line.
pub fn parse_times(text: &str, path: &Path) -> Result<Vec<f64>, KittiError> {
    let mut times: Vec<f64> = Vec::new();
    for (i, line) in text.trim_end().lines().enumerate() {
        let nums = parse_numbers(path, i + 1, line)?;
        let fail = |what| Err(line_error(path, i + 1, what));
        let [t] = nums.as_slice() else {
            return fail(format!(
                "expected one timestamp in seconds, found {} numbers",
                nums.len()
            ));
        };
        if !(0.0..=MAX_TIME_S).contains(t) {
            return fail(format!(
                "timestamp {t} s is outside 0 to {MAX_TIME_S:e} s (seconds from the sequence's start)"
            ));
        }
        if let Some(&prev) = times.last()
            && micros(*t) <= micros(prev)
        {
            return fail(format!(
                "timestamp {t} does not increase by a microsecond or more (previous line: {prev})"
            ));
        }
        times.push(*t);
    }
    Ok(times)
}

/// A timestamp in seconds to the microsecond, as the odometer is given it.
pub fn micros(t_s: f64) -> u64 {
    (t_s * 1e6).round() as u64
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

/// A sequence of frames, checked: a timestamp for each, all of the first one's size. A KITTI
/// sequence folder ([`Sequence::open`]: frames numbered from 0 without gaps, a `P0` calibration
/// where `calib.txt` exists), or another layout ([`crate::layout::open`]).
#[derive(Clone, Debug)]
pub struct Sequence {
    /// The folder (`.../sequences/NN`), or the path of a sequence of another layout (a folder
    /// or glob of frames, a video file).
    pub dir: PathBuf,
    /// Number of frames.
    pub frames: usize,
    /// Timestamps, seconds, one per frame.
    pub times_s: Vec<f64>,
    /// The `P0` projection, where the sequence has a `calib.txt`.
    pub p0: Option<[f64; 12]>,
    /// Frame size, from the first frame: (width, height).
    pub size: (u32, u32),
    /// Where the frames come from.
    pub layout: Layout,
}

impl Sequence {
    /// Opens and checks a KITTI sequence folder; `calib.txt` may be missing (a mount file's
    /// `[camera]` then gives the camera).
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
        if times_s.len() != frames {
            return Err(KittiError::File {
                path: times_path,
                what: format!(
                    "has {} timestamps but image_0 holds {frames} frames: one a frame",
                    times_s.len()
                ),
            });
        }
        let calib = dir.join("calib.txt");
        let p0 = calib.exists().then(|| read_calib_p0(&calib)).transpose()?;
        let size = frame_size(&image_path(dir, 0))?;
        Ok(Self {
            dir: dir.to_owned(),
            frames,
            times_s,
            p0,
            size,
            layout: Layout::Kitti,
        })
    }

    /// Frame `i`'s timestamp, to the microsecond, as every run of the odometer gives it.
    pub fn timestamp(&self, i: usize) -> roadvo::Instant {
        roadvo::Instant::from_micros(micros(self.times_s[i]))
    }

    /// The image file of frame `i`, where frames are files.
    pub fn frame_path(&self, i: usize) -> Option<PathBuf> {
        match &self.layout {
            Layout::Kitti => Some(image_path(&self.dir, i)),
            Layout::Images(files) => files.get(i).cloned(),
            Layout::Video(_) => None,
        }
    }

    /// Loads frame `i` as 8-bit grey; it must have the size of the first frame.
    pub fn load(&self, i: usize) -> Result<GrayImage, KittiError> {
        if let Layout::Video(video) = &self.layout {
            return video.frame(i);
        }
        let missing = || KittiError::File {
            path: self.dir.clone(),
            what: format!("has no frame {i} ({} frames)", self.frames),
        };
        let path = self.frame_path(i).ok_or_else(missing)?;
        let first = self.frame_path(0).ok_or_else(missing)?;
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
                    "is {}x{}, expected {}x{} like {}",
                    grey.width(),
                    grey.height(),
                    self.size.0,
                    self.size.1,
                    first.file_name().unwrap_or_default().to_string_lossy()
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
    fn calib_txt_is_optional() {
        let d = sequence_with(&[0, 1], &[(64, 48); 2]);
        std::fs::remove_file(d.path().join("calib.txt")).unwrap();
        assert_eq!(Sequence::open(d.path()).unwrap().p0, None);
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

    const P0: &str = "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 \
                      0.000000000000e+00 0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 \
                      0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 \
                      0.000000000000e+00";

    #[test]
    fn a_second_p0_line_names_both_lines() {
        let text = format!("{P0}\nP1: 1 2 3\n{P0}\n");
        let e = parse_calib_p0(&text, Path::new("seq/calib.txt"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "seq/calib.txt line 3: a second `P0:` line (the first is line 1): which one is \
             camera 0's?"
        );
        assert_eq!(parse_calib_p0(P0, Path::new("c")).unwrap()[0], 718.856);
    }

    #[test]
    fn a_p0_that_is_not_a_rectified_camera_is_refused_with_its_line() {
        let numbers: Vec<&str> = P0.split_whitespace().skip(1).collect();
        for (k, value, says) in [
            (1, "0.5", "P0 number 2 is 0.5, not 0 (a skewed camera)"),
            (4, "1", "P0 number 5 is 1, not 0"),
            (8, "0.1", "the third row is `0.1 0 1 0`, not `0 0 1 0`"),
            (9, "-2", "the third row is `0 -2 1 0`, not `0 0 1 0`"),
            (10, "2", "the third row is `0 0 2 0`, not `0 0 1 0`"),
            (
                0,
                "-700",
                "the focal lengths (numbers 1 and 6) are -700 and 718.856",
            ),
        ] {
            let mut n = numbers.clone();
            n[k] = value;
            let text = format!("# camera 0\nP0: {}\n", n.join(" "));
            let e = parse_calib_p0(&text, Path::new("seq/calib.txt"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("seq/calib.txt line 2: "), "{e}");
            assert!(e.contains(says), "{k}: {e}");
            assert!(
                e.ends_with("a rectified camera-0 projection is `fx 0 cx tx 0 fy cy ty 0 0 1 0` with fx, fy > 0"),
                "{e}"
            );
        }
    }

    #[test]
    fn negative_huge_and_crowded_timestamps_name_the_file_and_line() {
        let path = Path::new("seq/times.txt");
        for (text, says) in [
            (
                "0.0\n-0.1\n",
                "seq/times.txt line 2: timestamp -0.1 s is outside 0 to 1e9 s",
            ),
            (
                "0.0\n0.1\n2e9\n",
                "seq/times.txt line 3: timestamp 2000000000 s is outside 0 to 1e9 s",
            ),
            (
                "0.0\nNaN\n",
                "seq/times.txt line 2: \"NaN\" is not a finite number",
            ),
            (
                "0.0\ninf\n",
                "seq/times.txt line 2: \"inf\" is not a finite number",
            ),
            (
                "0.0\n0.1\n0.1000001\n",
                "seq/times.txt line 3: timestamp 0.1000001 does not increase by a microsecond",
            ),
            (
                "0.0\n0.1 0.2\n",
                "seq/times.txt line 2: expected one timestamp",
            ),
        ] {
            let e = parse_times(text, path).unwrap_err().to_string();
            assert!(e.starts_with(says), "{text:?}: {e}");
        }
    }

    #[test]
    fn times_for_more_or_fewer_frames_than_image_0_holds_are_refused() {
        let d = sequence_with(&[0, 1, 2], &[(64, 48); 3]);
        let times = d.path().join("times.txt");
        for (n, says) in [(4, "has 4 timestamps"), (2, "has 2 timestamps")] {
            let t: Vec<f64> = (0..n).map(|i| f64::from(i) * 0.1).collect();
            write_times(&times, &t).unwrap();
            let e = Sequence::open(d.path()).unwrap_err().to_string();
            assert!(e.contains("times.txt: ") && e.contains(says), "{e}");
            assert!(
                e.ends_with("but image_0 holds 3 frames: one a frame"),
                "{e}"
            );
        }
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
