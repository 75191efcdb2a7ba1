//! A video file as the frames of a drive, through the `ffprobe` and `ffmpeg` programs (Debian
//! package `ffmpeg`) run as subprocesses: [`probe`] reads the frame size and every frame's
//! timestamp from the container (`best_effort_timestamp_time`, which decodes the video once),
//! and [`Video`] streams the frames as 8-bit grey (ffmpeg's `gray`, the luma) from a pipe,
//! one at a time, in presentation order, none dropped or repeated (`-fps_mode passthrough`).
//! Rotation metadata is not applied: frames are taken as coded.

use crate::kitti::{KittiError, MAX_FRAME_SIDE_PX, MIN_FRAME_SIDE_PX};
use image::GrayImage;
use serde::Deserialize;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::Mutex;
use std::thread::JoinHandle;

/// What [`probe`] found in a video file.
#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// Frame size of the first video stream: (width, height).
    pub size: (u32, u32),
    /// Every frame's timestamp, seconds, strictly increasing; shifted to start at 0 where the
    /// container's first one is negative.
    pub times_s: Vec<f64>,
}

/// `ffprobe`'s JSON answer, the parts asked for.
#[derive(Deserialize)]
struct ProbeJson {
    #[serde(default)]
    streams: Vec<StreamJson>,
    #[serde(default)]
    frames: Vec<FrameJson>,
}

#[derive(Deserialize)]
struct StreamJson {
    width: Option<u32>,
    height: Option<u32>,
}

#[derive(Deserialize)]
struct FrameJson {
    best_effort_timestamp_time: Option<String>,
}

/// Why a file could not be probed as a video: a sentence for the message that lists the
/// layouts a sequence may have.
#[derive(Debug)]
pub struct NotAVideo(pub String);

/// Reads the frame size and the timestamps of `path`'s first video stream with `ffprobe`.
/// A file ffprobe cannot read (or a missing ffprobe) is [`NotAVideo`]; a video whose
/// timestamps or size are unusable is a [`KittiError`] naming the file and the frame.
pub fn probe(path: &Path) -> Result<Result<Probe, NotAVideo>, KittiError> {
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
        .arg("stream=width,height:frame=best_effort_timestamp_time")
        .args(["-of", "json"])
        .arg(path)
        .stdin(Stdio::null())
        .output();
    let out = match out {
        Ok(out) => out,
        Err(e) => {
            return Ok(Err(NotAVideo(format!(
                "cannot run ffprobe to read it as a video: {e}; install ffmpeg (Debian: \
                 apt-get install ffmpeg)"
            ))));
        }
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    // ffprobe starts its message with the path, which the caller names already.
    let last = stderr.lines().next_back().unwrap_or("").trim();
    let prefix = format!("{}: ", path.display());
    let reason = last.strip_prefix(&prefix).unwrap_or(last);
    if !out.status.success() {
        return Ok(Err(NotAVideo(format!("ffprobe: {reason}"))));
    }
    let file = |what: String| KittiError::File {
        path: path.to_owned(),
        what,
    };
    let json: ProbeJson = serde_json::from_slice(&out.stdout)
        .map_err(|e| file(format!("ffprobe's answer cannot be read: {e}")))?;
    let Some(StreamJson {
        width: Some(w),
        height: Some(h),
    }) = json.streams.first()
    else {
        return Ok(Err(NotAVideo("ffprobe finds no video stream in it".into())));
    };
    let (w, h) = (*w, *h);
    let range = MIN_FRAME_SIDE_PX..=MAX_FRAME_SIDE_PX;
    if !range.contains(&w) || !range.contains(&h) {
        return Err(file(format!(
            "its frames are {w}x{h} pixels; frames must be {MIN_FRAME_SIDE_PX} to \
             {MAX_FRAME_SIDE_PX} pixels a side"
        )));
    }
    let mut times_s: Vec<f64> = Vec::with_capacity(json.frames.len());
    for (i, f) in json.frames.iter().enumerate() {
        let text = f.best_effort_timestamp_time.as_deref().unwrap_or("N/A");
        let t = text
            .parse::<f64>()
            .ok()
            .filter(|t| t.is_finite())
            .ok_or_else(|| file(format!("frame {i} has no timestamp ({text:?})")))?;
        if let Some(&prev) = times_s.last()
            && t <= prev
        {
            return Err(file(format!(
                "frame {i}'s timestamp {t} s does not come after frame {}'s, {prev} s",
                i - 1
            )));
        }
        times_s.push(t);
    }
    let Some(&first) = times_s.first() else {
        return Err(file("its video stream holds no frame".into()));
    };
    if first < 0.0 {
        times_s.iter_mut().for_each(|t| *t -= first);
    }
    Ok(Ok(Probe {
        size: (w, h),
        times_s,
    }))
}

/// A video's frames, decoded on demand by an `ffmpeg` subprocess that writes them to a pipe:
/// reading in order streams them (one frame in memory at a time); a frame before the last one
/// read restarts the decoder.
#[derive(Debug)]
pub struct Video {
    path: PathBuf,
    size: (u32, u32),
    frames: usize,
    decoder: Mutex<Option<Decoder>>,
}

impl Clone for Video {
    /// The same video with a decoder of its own, started when a frame is asked for.
    fn clone(&self) -> Self {
        Self::new(&self.path, self.size, self.frames)
    }
}

impl Video {
    /// The video at `path` with `frames` frames of `size` ([`probe`] gives both).
    pub fn new(path: &Path, size: (u32, u32), frames: usize) -> Self {
        Self {
            path: path.to_owned(),
            size,
            frames,
            decoder: Mutex::new(None),
        }
    }

    /// Frame `i` as 8-bit grey.
    pub fn frame(&self, i: usize) -> Result<GrayImage, KittiError> {
        let mut decoder = self
            .decoder
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if decoder.as_ref().is_none_or(|d| d.next > i) {
            *decoder = Some(Decoder::start(&self.path)?);
        }
        let d = decoder.as_mut().expect("started above");
        let bytes = self.size.0 as usize * self.size.1 as usize;
        let mut buf = vec![0u8; bytes];
        while d.next <= i {
            if let Err(e) = d.stdout.read_exact(&mut buf) {
                let why = decoder.take().expect("started above").finish();
                return Err(KittiError::File {
                    path: self.path.clone(),
                    what: format!(
                        "frame {i}: ffmpeg ended before it ({e}); ffprobe counted {} frames{why}",
                        self.frames
                    ),
                });
            }
            d.next += 1;
        }
        Ok(GrayImage::from_raw(self.size.0, self.size.1, buf).expect("a whole frame"))
    }
}

/// A running `ffmpeg` writing raw grey frames to a pipe.
#[derive(Debug)]
struct Decoder {
    child: Child,
    stdout: ChildStdout,
    /// ffmpeg's error output, gathered on a thread so that it cannot fill its pipe.
    stderr: Option<JoinHandle<String>>,
    /// The number of the next frame the pipe gives.
    next: usize,
}

impl Decoder {
    /// Starts `ffmpeg` on `path`.
    fn start(path: &Path) -> Result<Self, KittiError> {
        let mut child = Command::new("ffmpeg")
            .args(["-v", "error", "-nostdin", "-noautorotate", "-i"])
            .arg(path)
            .args(["-map", "0:v:0", "-fps_mode", "passthrough"])
            .args(["-f", "rawvideo", "-pix_fmt", "gray", "-"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| KittiError::File {
                path: path.to_owned(),
                what: format!(
                    "cannot run ffmpeg to decode it: {e}; install ffmpeg (Debian: apt-get \
                     install ffmpeg)"
                ),
            })?;
        let stdout = child.stdout.take().expect("piped");
        let mut stderr = child.stderr.take().expect("piped");
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            let _ = stderr.read_to_string(&mut text);
            text
        });
        Ok(Self {
            child,
            stdout,
            stderr: Some(stderr),
            next: 0,
        })
    }

    /// Waits for ffmpeg to end; what it said, as `" (ffmpeg: ...)"`, or nothing.
    fn finish(mut self) -> String {
        let _ = self.child.wait();
        let said = self
            .stderr
            .take()
            .and_then(|h| h.join().ok())
            .unwrap_or_default();
        match said.trim() {
            "" => String::new(),
            s => format!(" (ffmpeg: {})", s.lines().next_back().unwrap_or(s)),
        }
    }
}

impl Drop for Decoder {
    /// Ends an ffmpeg that is still decoding frames nobody will read.
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lossless video (FFV1) of three 32x24 frames, each of one grey level, at 5 frames/s.
    fn three_frames(dir: &Path) -> PathBuf {
        for (i, level) in [10u8, 20, 30].into_iter().enumerate() {
            GrayImage::from_pixel(32, 24, image::Luma([level]))
                .save(dir.join(format!("{i}.png")))
                .unwrap();
        }
        let video = dir.join("v.mkv");
        let status = Command::new("ffmpeg")
            .args(["-v", "error", "-framerate", "5", "-i"])
            .arg(dir.join("%d.png"))
            .args(["-c:v", "ffv1"])
            .arg(&video)
            .status()
            .expect("ffmpeg runs (scripts/test installs it)");
        assert!(status.success());
        video
    }

    #[test]
    fn frames_stream_in_order_and_a_step_back_restarts_the_decoder() {
        let d = tempfile::tempdir().unwrap();
        let path = three_frames(d.path());
        let p = probe(&path).unwrap().unwrap();
        assert_eq!(p.size, (32, 24));
        assert_eq!(p.times_s, [0.0, 0.2, 0.4]);
        let video = Video::new(&path, p.size, 3);
        let level = |i| video.frame(i).unwrap().get_pixel(0, 0).0[0];
        assert_eq!([level(1), level(2), level(0), level(2)], [20, 30, 10, 30]);
        let e = video.frame(3).unwrap_err().to_string();
        assert!(
            e.contains("frame 3: ffmpeg ended before it") && e.contains("counted 3 frames"),
            "{e}"
        );
    }

    #[test]
    fn a_file_that_is_no_video_says_why() {
        let d = tempfile::tempdir().unwrap();
        let text = d.path().join("notes.mp4");
        std::fs::write(&text, "no video here\n").unwrap();
        let Ok(Err(NotAVideo(why))) = probe(&text) else {
            panic!("a text file probed as a video")
        };
        assert!(
            why.starts_with("ffprobe: ") && !why.contains("notes.mp4"),
            "{why}"
        );
    }
}
