//! `roadvo view`.

use super::{SequenceArgs, bar};
use anyhow::{Result, bail};
use image::GrayImage;
use roadvo::Instant;
use roadvo_sim::run::{FrameSource, config_for};
use roadvo_sim::view::write_views;
use std::borrow::Cow;
use std::path::PathBuf;
use std::process::Command;

/// Write what the odometer sees, frame by frame, as pictures (and a video where ffmpeg is
/// installed).
#[derive(clap::Args)]
pub struct ViewArgs {
    #[command(flatten)]
    seq: SequenceArgs,
    /// Folder for the pictures (`NNNNNN.png`) and `view.mp4`.
    #[arg(long)]
    out: PathBuf,
    /// Frames from the start of the sequence, at least 1 (default: all).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// Write every N-th frame's picture (the odometer still runs every frame).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    every: u32,
    /// Leave out the video even where ffmpeg is installed.
    #[arg(long)]
    no_video: bool,
}

/// The first `n` frames of a source.
struct First<'a, S> {
    source: &'a S,
    n: usize,
}

impl<S: FrameSource> FrameSource for First<'_, S> {
    fn len(&self) -> usize {
        self.n.min(self.source.len())
    }

    fn frame(&self, i: usize) -> Result<(Cow<'_, GrayImage>, Instant)> {
        self.source.frame(i)
    }

    fn time_s(&self, i: usize) -> f64 {
        self.source.time_s(i)
    }
}

impl ViewArgs {
    pub fn run(self) -> Result<()> {
        roadvo_sim::interrupt::install();
        let dir = &self.seq.seq_dir;
        if self.out.starts_with(dir) {
            bail!(
                "--out {}: is inside the input folder {}",
                self.out.display(),
                dir.display()
            );
        }
        let (seq, mount) = self.seq.open()?;
        let config = config_for(&seq, &mount, self.seq.method)?;
        let source = First {
            source: &seq,
            n: self.frames.map_or(usize::MAX, |n| n as usize),
        };
        let progress = bar(source.len(), "viewing", "frames");
        let (written, ran) = write_views(&source, config, &self.out, self.every as usize, || {
            progress.inc(1)
        })?;
        progress.finish_and_clear();
        println!(
            "{} pictures written to {}",
            written.len(),
            self.out.display()
        );
        if !self.no_video && !written.is_empty() {
            encode_video(&self.out)?;
        }
        if let Some(s) = ran.stopped {
            bail!("stopped at frame {:06}: {:#}", s.frame, s.cause);
        }
        Ok(())
    }
}

/// `view.mp4` from the pictures in `dir`, where ffmpeg is installed (10 frames/s, H.264).
fn encode_video(dir: &std::path::Path) -> Result<()> {
    let video = dir.join("view.mp4");
    let encoded = Command::new("ffmpeg")
        .args([
            "-y",
            "-loglevel",
            "error",
            "-framerate",
            "10",
            "-pattern_type",
            "glob",
            "-i",
        ])
        .arg(dir.join("[0-9]*.png"))
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
        ])
        .arg(&video)
        .status();
    match encoded {
        Ok(s) if s.success() => println!("video written to {}", video.display()),
        Ok(s) => bail!("ffmpeg could not write {} ({s})", video.display()),
        Err(_) => println!("no video: ffmpeg is not installed (apt-get install ffmpeg)"),
    }
    Ok(())
}
