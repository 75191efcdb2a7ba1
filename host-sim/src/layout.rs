//! What a sequence may be on disk, picked by what its path is: a KITTI sequence folder (holding
//! `image_0/`, [`crate::kitti`]), a folder or a glob of PNG/JPEG frames ([`crate::image_files`],
//! timed by a file or a frame rate: [`FrameTimes`]), or a video file ([`crate::video`]). Each
//! opens as a [`Sequence`]; only the KITTI layout carries a calibration (`calib.txt`), the
//! others need a mount file with `[camera]`.

use crate::image_files;
use crate::kitti::{KittiError, Sequence, frame_size, read_times};
use crate::video::{self, NotAVideo, Video};
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// Where a sequence's frames come from.
#[derive(Clone, Debug)]
pub enum Layout {
    /// `image_0/%06d.png` in the sequence folder.
    Kitti,
    /// These image files, in this order.
    Images(Vec<PathBuf>),
    /// A video file's frames.
    Video(Video),
}

impl Layout {
    /// The layout in words, for messages: `a KITTI sequence folder`, `a video file`...
    pub fn describe(&self) -> &'static str {
        match self {
            Self::Kitti => "a KITTI sequence folder",
            Self::Images(_) => "a folder of frames",
            Self::Video(_) => "a video file",
        }
    }
}

/// The layouts a sequence may have, as the message for a path that is none of them ends.
pub const LAYOUTS: &str = "not a KITTI sequence folder (no image_0/), a folder or glob of \
                           .png/.jpg frames, or a video file";

/// The timestamps of a folder of frames: `--times FILE` (seconds, one a line, like KITTI's
/// `times.txt`) or `--fps N`. The other layouts carry their own.
#[derive(Clone, Debug, Default)]
pub struct FrameTimes {
    /// A file of timestamps, one a line.
    pub file: Option<PathBuf>,
    /// A constant frame rate, frames per second: frame `i` at `i / fps` seconds.
    pub fps: Option<f64>,
}

impl FrameTimes {
    /// Whether neither is given.
    pub fn is_empty(&self) -> bool {
        self.file.is_none() && self.fps.is_none()
    }

    /// The timestamps of `frames` frames of `what` (the folder or glob, for messages).
    fn times(&self, what: &Path, frames: usize) -> Result<Vec<f64>> {
        match (&self.file, self.fps) {
            (Some(_), Some(_)) => bail!("give --times FILE or --fps N, not both"),
            (None, None) => bail!(
                "{}: a folder of frames needs their timestamps: --times FILE (seconds, one a \
                 line) or --fps N",
                what.display()
            ),
            (None, Some(fps)) => {
                if !(fps.is_finite() && fps > 0.0) {
                    bail!("--fps {fps}: expected a frame rate above 0");
                }
                Ok((0..frames).map(|i| i as f64 / fps).collect())
            }
            (Some(file), None) => {
                let times = read_times(file)?;
                if times.len() < frames {
                    return Err(KittiError::File {
                        path: file.clone(),
                        what: format!(
                            "has {} timestamps but {} holds {frames} frames",
                            times.len(),
                            what.display()
                        ),
                    }
                    .into());
                }
                Ok(times[..frames].to_vec())
            }
        }
    }
}

/// Opens `path` as whichever layout it has; `times` times a folder of frames and is refused for
/// the others. A path of no layout is refused with [`LAYOUTS`] and why.
pub fn open(path: &Path, times: &FrameTimes) -> Result<Sequence> {
    let not_a_sequence = |why: &str| anyhow::anyhow!("{}: {LAYOUTS} ({why})", path.display());
    if path.join("image_0").is_dir() {
        refuse_times(path, times, "its times.txt")?;
        return Ok(Sequence::open(path)?);
    }
    if path.is_dir() || image_files::is_pattern(path) {
        let files = image_files::list(path).map_err(|e| {
            not_a_sequence(&format!(
                "{} cannot be listed: {e}",
                image_files::folder_of(path).display()
            ))
        })?;
        if files.is_empty() {
            return Err(not_a_sequence(if path.is_dir() {
                "it holds no image_0/ and no .png/.jpg file"
            } else {
                "no .png/.jpg file matches"
            }));
        }
        return open_images(path, files, times);
    }
    if !path.is_file() {
        return Err(not_a_sequence("no such file or folder"));
    }
    match video::probe(path)? {
        Err(NotAVideo(why)) => Err(not_a_sequence(&why)),
        Ok(probe) => {
            refuse_times(path, times, "the container's timestamps")?;
            let frames = probe.times_s.len();
            Ok(Sequence {
                dir: path.to_owned(),
                frames,
                times_s: probe.times_s,
                p0: None,
                size: probe.size,
                layout: Layout::Video(Video::new(path, probe.size, frames)),
            })
        }
    }
}

/// A folder of frames `files` (at least one), timed by `times`.
fn open_images(path: &Path, files: Vec<PathBuf>, times: &FrameTimes) -> Result<Sequence> {
    let times_s = times.times(path, files.len())?;
    Ok(Sequence {
        dir: path.to_owned(),
        frames: files.len(),
        times_s,
        p0: None,
        size: frame_size(&files[0])?,
        layout: Layout::Images(files),
    })
}

/// Refuses `--times`/`--fps` for `path`, whose timestamps come from `own`.
fn refuse_times(path: &Path, times: &FrameTimes, own: &str) -> Result<()> {
    if !times.is_empty() {
        bail!(
            "--times and --fps time a folder of frames; {} takes {own}",
            path.display()
        );
    }
    Ok(())
}

/// Why `seq` gives no camera, and what must: a mount file with `[camera]`.
pub fn no_calibration(seq: &Sequence) -> String {
    let what = match seq.layout {
        Layout::Kitti => "a KITTI sequence folder without calib.txt",
        _ => seq.layout.describe(),
    };
    format!(
        "{} is {what}, which carries no camera calibration: its mount file needs a [camera] \
         section or an opencv_calibration (docs/mount-file.md)",
        seq.dir.display()
    )
}

/// The files and folders a sequence at `path` reads, which outputs must not overwrite: its
/// `times.txt`, `calib.txt` and `image_0/` for the KITTI layout, the folder of frames, or the
/// video file.
pub fn inputs_of(path: &Path) -> (Vec<PathBuf>, Vec<PathBuf>) {
    if path.join("image_0").is_dir() {
        let files = vec![path.join("times.txt"), path.join("calib.txt")];
        (files, vec![path.join("image_0")])
    } else if path.is_dir() || image_files::is_pattern(path) {
        (Vec::new(), vec![image_files::folder_of(path)])
    } else {
        (vec![path.to_owned()], Vec::new())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::GrayImage;

    fn message(path: &Path, times: &FrameTimes) -> String {
        format!("{:#}", open(path, times).unwrap_err())
    }

    #[test]
    fn a_path_of_no_layout_lists_the_layouts() {
        let d = tempfile::tempdir().unwrap();
        let text = d.path().join("notes.txt");
        std::fs::write(&text, "not a video\n").unwrap();
        let none = FrameTimes::default();
        for (path, why) in [
            (
                d.path().to_owned(),
                "holds no image_0/ and no .png/.jpg file",
            ),
            (d.path().join("*.png"), "no .png/.jpg file matches"),
            (d.path().join("missing"), "no such file or folder"),
            (text, "ffprobe"),
        ] {
            let e = message(&path, &none);
            assert!(e.contains(LAYOUTS) && e.contains(why), "{e}");
            assert!(!e.contains("Not a directory"), "{e}");
        }
    }

    #[test]
    fn a_folder_of_frames_is_timed_by_a_file_or_a_rate() {
        let d = tempfile::tempdir().unwrap();
        for i in [1, 2, 10] {
            GrayImage::new(64, 48)
                .save(d.path().join(format!("f{i}.png")))
                .unwrap();
        }
        let fps = FrameTimes {
            fps: Some(4.0),
            ..FrameTimes::default()
        };
        let s = open(d.path(), &fps).unwrap();
        assert_eq!((s.frames, s.size), (3, (64, 48)));
        assert_eq!(s.times_s, [0.0, 0.25, 0.5]);
        let Layout::Images(files) = &s.layout else {
            panic!("{:?}", s.layout)
        };
        assert!(files[2].ends_with("f10.png"), "{files:?}");
        assert_eq!(s.load(2).unwrap().dimensions(), (64, 48));
        let e = message(d.path(), &FrameTimes::default());
        assert!(
            e.contains("--times FILE (seconds, one a line) or --fps N"),
            "{e}"
        );
        let times = d.path().join("t.txt");
        std::fs::write(&times, "0.5\n0.6\n").unwrap();
        let file = FrameTimes {
            file: Some(times),
            ..FrameTimes::default()
        };
        let e = message(d.path(), &file);
        assert!(e.contains("t.txt: has 2 timestamps but"), "{e}");
    }
}
