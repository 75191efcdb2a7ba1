//! Trajectory files in the two text formats evo reads. KITTI: 12 numbers a line, the 3x4 pose
//! `[R | t]` row-major, one line a frame, no timestamps. TUM: 8 numbers a line, `timestamp tx ty
//! tz qx qy qz qw` (seconds; the position in metres; the rotation as a unit quaternion, Hamilton,
//! scalar last), lines starting with `#` are comments. Both hold the pose of a camera (or body)
//! in a world frame: the files roadvo writes hold camera 0's pose in camera 0's frame at the
//! first frame (x right, y down, z forward), KITTI's convention.

use crate::input::{Input, read_text};
use crate::kitti::{KittiError, Pose, line_error, parse_numbers};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// A trajectory file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PoseFormat {
    /// 12 numbers a line: the 3x4 pose, row-major.
    Kitti,
    /// 8 numbers a line: `timestamp tx ty tz qx qy qz qw`.
    Tum,
}

impl PoseFormat {
    /// The format to write `path` in: `explicit` if given, else TUM for a `.tum` extension and
    /// KITTI for any other.
    pub fn for_output(path: &Path, explicit: Option<Self>) -> Self {
        explicit.unwrap_or_else(|| {
            let tum = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("tum"));
            if tum { Self::Tum } else { Self::Kitti }
        })
    }

    /// Numbers a line.
    fn columns(self) -> usize {
        match self {
            Self::Kitti => 12,
            Self::Tum => 8,
        }
    }

    /// The format's name as the command line spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Kitti => "kitti",
            Self::Tum => "tum",
        }
    }
}

/// The poses of a trajectory file, with their timestamps where the format has them.
#[derive(Clone, Debug, PartialEq)]
pub struct TimedPoses {
    /// The file's format.
    pub format: PoseFormat,
    /// Poses, KITTI layout (3x4, row-major), in the file's world frame; metres.
    pub poses: Vec<Pose>,
    /// Timestamps, seconds, one a pose (TUM); `None` for KITTI.
    pub times_s: Option<Vec<f64>>,
    /// The 1-based line of each pose in the file.
    pub lines: Vec<usize>,
}

/// How far a TUM quaternion's norm may be from 1 before it is refused rather than normalised.
const QUATERNION_NORM_TOLERANCE: f64 = 1e-2;

/// Reads a trajectory file in `format`, or, without one, in the format its first line's count of
/// numbers gives (12: KITTI, 8: TUM). Blank lines and lines starting with `#` are skipped; every
/// other line must hold the format's count of finite numbers. Errors name the file and line; a
/// file over [`MAX_POSES_BYTES`](crate::input::MAX_POSES_BYTES) is refused unread.
pub fn read_trajectory(path: &Path, format: Option<PoseFormat>) -> Result<TimedPoses, KittiError> {
    parse_trajectory(&read_text(path, Input::Poses)?, path, format)
}

/// Parses the text of a trajectory file read from `path` (named in errors, with the line), as
/// [`read_trajectory`] does.
pub fn parse_trajectory(
    text: &str,
    path: &Path,
    format: Option<PoseFormat>,
) -> Result<TimedPoses, KittiError> {
    let line_error = |line: usize, what: String| line_error(path, line, what);
    let mut format = format;
    let mut poses = Vec::new();
    let mut times = Vec::new();
    let mut lines = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let nums = parse_numbers(path, i + 1, trimmed)?;
        let f = match format {
            Some(f) => f,
            None => match nums.len() {
                12 => *format.insert(PoseFormat::Kitti),
                8 => *format.insert(PoseFormat::Tum),
                n => {
                    return Err(line_error(
                        i + 1,
                        format!(
                            "expected 12 numbers (KITTI: a 3x4 pose) or 8 (TUM: timestamp tx ty \
                             tz qx qy qz qw), found {n}"
                        ),
                    ));
                }
            },
        };
        if nums.len() != f.columns() {
            return Err(line_error(
                i + 1,
                match f {
                    PoseFormat::Kitti => {
                        format!("expected 12 numbers (a 3x4 pose), found {}", nums.len())
                    }
                    PoseFormat::Tum => format!(
                        "expected 8 numbers (TUM: timestamp tx ty tz qx qy qz qw), found {}",
                        nums.len()
                    ),
                },
            ));
        }
        lines.push(i + 1);
        match f {
            PoseFormat::Kitti => poses.push(std::array::from_fn(|k| nums[k])),
            PoseFormat::Tum => {
                times.push(nums[0]);
                poses.push(pose_of_tum(&nums[1..]).map_err(|what| line_error(i + 1, what))?);
            }
        }
    }
    let Some(format) = format.filter(|_| !poses.is_empty()) else {
        return Err(KittiError::File {
            path: path.to_owned(),
            what: "holds no poses".into(),
        });
    };
    Ok(TimedPoses {
        format,
        poses,
        times_s: (format == PoseFormat::Tum).then_some(times),
        lines,
    })
}

/// The pose of a TUM line's `tx ty tz qx qy qz qw`.
fn pose_of_tum(v: &[f64]) -> Result<Pose, String> {
    let q = Quaternion::new(v[6], v[3], v[4], v[5]);
    if (q.norm() - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
        return Err(format!(
            "the quaternion (qx qy qz qw) has norm {:.6}, not 1",
            q.norm()
        ));
    }
    let r = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
    Ok(std::array::from_fn(|k| {
        let (row, col) = (k / 4, k % 4);
        if col == 3 { v[row] } else { r[(row, col)] }
    }))
}

/// A pose's TUM fields after the timestamp: `tx ty tz qx qy qz qw`.
pub fn tum_fields(p: &Pose) -> [f64; 7] {
    let m = Matrix3::from_fn(|r, c| p[4 * r + c]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m));
    // One sign for the double cover: qw >= 0, as evo writes.
    let q = if q.w < 0.0 {
        -q.into_inner()
    } else {
        *q.quaternion()
    };
    [p[3], p[7], p[11], q.i, q.j, q.k, q.w]
}

/// Writes `poses` to `path` in `format`, whole or not at all, creating its folder. TUM takes
/// `times_s` (seconds, one a pose); KITTI ignores it.
pub fn write_trajectory(
    path: &Path,
    format: PoseFormat,
    poses: &[Pose],
    times_s: &[f64],
) -> anyhow::Result<()> {
    match format {
        PoseFormat::Kitti => crate::kitti::write_poses(path, poses),
        PoseFormat::Tum => {
            if times_s.len() != poses.len() {
                anyhow::bail!(
                    "{}: {} poses but {} timestamps",
                    path.display(),
                    poses.len(),
                    times_s.len()
                );
            }
            let mut text = String::from("# timestamp tx ty tz qx qy qz qw\n");
            for (t, p) in times_s.iter().zip(poses) {
                let fields: Vec<String> =
                    tum_fields(p).iter().map(|x| format!("{x:.9e}")).collect();
                let _ = writeln!(text, "{t:.9} {}", fields.join(" "));
            }
            crate::kitti::write_text(path, &text)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn turning(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let a = 0.3 * i as f64;
                let r = Rotation3::from_euler_angles(0.1 * a, a, -0.2 * a);
                std::array::from_fn(|k| {
                    let (row, col) = (k / 4, k % 4);
                    if col == 3 {
                        [1.0, -0.5, 2.0][row] * i as f64
                    } else {
                        r[(row, col)]
                    }
                })
            })
            .collect()
    }

    #[test]
    fn tum_round_trips_within_the_digits_written() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("est.tum");
        let poses = turning(30);
        let times: Vec<f64> = (0..30).map(|i| 1.5 + 0.103_642 * f64::from(i)).collect();
        let format = PoseFormat::for_output(&path, None);
        assert_eq!(format, PoseFormat::Tum);
        write_trajectory(&path, format, &poses, &times).unwrap();
        let back = read_trajectory(&path, None).unwrap();
        assert_eq!(back.format, PoseFormat::Tum);
        for (a, b) in back.poses.iter().zip(&poses) {
            assert!(
                a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-8),
                "{a:?} {b:?}"
            );
        }
        let back_times = back.times_s.unwrap();
        assert!(
            back_times
                .iter()
                .zip(&times)
                .all(|(a, b)| (a - b).abs() < 1e-9)
        );
    }

    #[test]
    fn kitti_is_told_from_tum_by_its_columns() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("est.txt");
        assert_eq!(PoseFormat::for_output(&path, None), PoseFormat::Kitti);
        write_trajectory(&path, PoseFormat::Kitti, &turning(3), &[]).unwrap();
        let back = read_trajectory(&path, None).unwrap();
        assert_eq!((back.format, back.times_s), (PoseFormat::Kitti, None));
        let e = read_trajectory(&path, Some(PoseFormat::Tum))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with(
                "est.txt line 1: expected 8 numbers (TUM: timestamp tx ty tz qx qy qz qw), found 12"
            ),
            "{e}"
        );
    }

    #[test]
    fn a_line_of_another_width_names_file_and_line() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("t.tum");
        std::fs::write(&path, "# a comment\n0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n").unwrap();
        let e = read_trajectory(&path, None).unwrap_err().to_string();
        assert!(
            e.ends_with(
                "t.tum line 3: expected 8 numbers (TUM: timestamp tx ty tz qx qy qz qw), found 7"
            ),
            "{e}"
        );
        std::fs::write(&path, "0 0 0 0 0 0 0 2\n").unwrap();
        let e = read_trajectory(&path, None).unwrap_err().to_string();
        assert!(
            e.ends_with("t.tum line 1: the quaternion (qx qy qz qw) has norm 2.000000, not 1"),
            "{e}"
        );
        std::fs::write(&path, "1 2 3\n").unwrap();
        let e = read_trajectory(&path, None).unwrap_err().to_string();
        assert!(
            e.contains("line 1: expected 12 numbers (KITTI: a 3x4 pose) or 8 (TUM"),
            "{e}"
        );
        std::fs::write(&path, "# nothing\n").unwrap();
        let e = read_trajectory(&path, None).unwrap_err().to_string();
        assert!(e.ends_with("t.tum: holds no poses"), "{e}");
    }
}
