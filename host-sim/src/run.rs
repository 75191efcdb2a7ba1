//! `roadvo run`: the odometer over a KITTI-layout sequence, frame by frame, as an ECU would run
//! it, with the images decoded beforehand so that the odometry's own speed is measured apart.

use crate::frame_store::{timestamp_us, trace_line};
use crate::kitti::{Pose, Sequence, pose_of};
use crate::mount::{CameraSection, MethodName, MountFile};
use anyhow::{Context, Result, anyhow, bail};
use indicatif::{ProgressBar, ProgressStyle};
use roadvo::{Estimate, Method, Odometer, SliceFrame, Smoother, ValidConfig};
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

/// One frame's estimate as a JSON line.
#[derive(Serialize)]
struct QualityLine {
    frame: usize,
    time_s: f64,
    heading_change_rad: f32,
    distance_m: f32,
    x_m: f32,
    y_m: f32,
    heading_rad: f32,
    features_detected: u16,
    tracks: u16,
    tracks_matched: u16,
    inlier_ratio: f32,
    fallback: bool,
    startup: bool,
    vote_peak: u32,
    pitch_rad: f32,
    roll_rad: f32,
    tracks_refused: u16,
    features_comoving: u16,
}

/// What a run produced.
pub struct RunOutput {
    /// Per-frame estimates.
    pub estimates: Vec<Estimate>,
    /// Camera-0 poses through the mount, KITTI format (smoothed if the mount file says so).
    pub poses: Vec<Pose>,
    /// The heading smoother's lag, frames (0: none).
    pub smooth_lag_frames: u8,
    /// Time in `process()` alone.
    pub odometry: Duration,
    /// Time decoding PNGs.
    pub decode: Duration,
}

impl RunOutput {
    /// Frames that fell back to the previous motion.
    pub fn fallbacks(&self) -> usize {
        self.estimates.iter().filter(|e| e.quality.fallback).count()
    }

    /// Frames per second of the odometry alone.
    pub fn frames_per_s(&self) -> f64 {
        self.estimates.len() as f64 / self.odometry.as_secs_f64().max(1e-9)
    }
}

/// Timings of [`bench_sequence`].
pub struct BenchOutput {
    /// Time of each call to `process()`, all repeats in order.
    pub per_frame: Vec<Duration>,
}

impl BenchOutput {
    /// Frames per second over all calls.
    pub fn frames_per_s(&self) -> f64 {
        let total: Duration = self.per_frame.iter().sum();
        self.per_frame.len() as f64 / total.as_secs_f64().max(1e-9)
    }

    /// (min, median, max) time of one call, milliseconds.
    pub fn spread_ms(&self) -> (f64, f64, f64) {
        let mut ms: Vec<f64> = self
            .per_frame
            .iter()
            .map(|d| 1e3 * d.as_secs_f64())
            .collect();
        ms.sort_by(f64::total_cmp);
        let pick = |q: f64| {
            ms.get(((ms.len() - 1) as f64 * q) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        (pick(0.0), pick(0.5), pick(1.0))
    }
}

/// Frames decoded ahead of the odometry, for runs that time or repeat it.
pub struct Preloaded {
    images: Vec<image::GrayImage>,
    times_us: Vec<u64>,
    size: (u16, u16),
}

impl Preloaded {
    /// Decodes `frames` of `seq` (clipped to the sequence).
    pub fn load(seq: &Sequence, frames: std::ops::Range<usize>) -> Result<Self> {
        let frames = frames.start.min(seq.frames)..frames.end.min(seq.frames);
        let images = frames
            .clone()
            .map(|i| seq.load(i))
            .collect::<Result<Vec<_>, _>>()?;
        let size = (
            u16::try_from(seq.size.0).context("frame width")?,
            u16::try_from(seq.size.1).context("frame height")?,
        );
        Ok(Self {
            images,
            times_us: frames.map(|i| timestamp_us(seq, i)).collect(),
            size,
        })
    }

    /// Frames held.
    pub fn len(&self) -> usize {
        self.images.len()
    }

    /// Whether no frame is held.
    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    /// Runs a fresh odometer with `config` over the frames on this thread; `each` sees every
    /// frame's estimate and the time `process()` took.
    pub fn run(
        &self,
        config: ValidConfig,
        mut each: impl FnMut(&Estimate, Duration),
    ) -> Result<()> {
        let mut odo: Box<Odometer> = Box::new(Odometer::new(config).map_err(|e| anyhow!("{e}"))?);
        let (w, h) = self.size;
        for (i, (img, &t)) in self.images.iter().zip(&self.times_us).enumerate() {
            let frame =
                SliceFrame::new(img.as_raw(), w, h, usize::from(w)).context("frame buffer")?;
            let start = Instant::now();
            let est = odo.process(&frame, t);
            let took = start.elapsed();
            each(&est.with_context(|| format!("frame {i:06}"))?, took);
        }
        Ok(())
    }

    /// The camera-0 trajectory of a fresh odometer with `config` over the frames (KITTI poses
    /// through the mount, smoothed as `mount` says).
    pub fn poses(&self, mount: &MountFile, config: ValidConfig) -> Result<Vec<Pose>> {
        let mut trajectory = Trajectory::new(mount, config, self.len())?;
        let mut times = self.times_us.iter();
        self.run(config, |e, _| {
            trajectory.push(*e, times.next().copied().unwrap_or(u64::MAX));
        })?;
        while trajectory.flush().is_some() {}
        Ok(trajectory.into_poses())
    }
}

/// The longest `smooth_lag_frames` the host's smoother holds.
pub const MAX_SMOOTH_LAG_FRAMES: u8 = 4;

/// The camera-0 trajectory of a run: each estimate through the mount file's heading smoother,
/// then lifted through the mount to a KITTI pose.
pub struct Trajectory {
    smoother: Smoother<{ 2 * MAX_SMOOTH_LAG_FRAMES as usize + 1 }>,
    config: ValidConfig,
    poses: Vec<Pose>,
}

impl Trajectory {
    /// A trajectory of up to `frames` poses, with `mount`'s `smooth_lag_frames` for the default
    /// method and none for the paper's, which stays as written.
    pub fn new(mount: &MountFile, config: ValidConfig, frames: usize) -> Result<Self> {
        let lag = match config.config().method {
            Method::PitchVote => mount.odometer.smooth_lag_frames,
            Method::Paper => 0,
        };
        let smoother =
            Smoother::new(lag).map_err(|e| anyhow!("mount file: smooth_lag_frames: {e}"))?;
        Ok(Self {
            smoother,
            config,
            poses: Vec::with_capacity(frames),
        })
    }

    /// The smoother's lag, frames (0: the odometer's estimates as they are).
    pub fn lag_frames(&self) -> u8 {
        self.smoother.lag_frames()
    }

    /// Takes the estimate of the frame at `timestamp_us`; the estimate the smoother hands back
    /// (`lag_frames` frames earlier), if any, with its frame number: its pose is now the
    /// trajectory's last.
    pub fn push(&mut self, estimate: Estimate, timestamp_us: u64) -> Option<(usize, Estimate)> {
        let e = self.smoother.push(estimate, timestamp_us)?;
        Some(self.lift(e))
    }

    /// At the end of the run, the next estimate the smoother still holds, if any, with its
    /// frame number.
    pub fn flush(&mut self) -> Option<(usize, Estimate)> {
        let e = self.smoother.flush()?;
        Some(self.lift(e))
    }

    /// The poses of the estimates handed back, in order (every frame's, once flushed).
    pub fn into_poses(self) -> Vec<Pose> {
        self.poses
    }

    /// Appends `e`'s pose; `e` with its frame number (the poses before it).
    fn lift(&mut self, e: Estimate) -> (usize, Estimate) {
        let frame = self.poses.len();
        self.poses
            .push(pose_of(&self.config.lift().camera_pose(&e.pose)));
        (frame, e)
    }
}

/// Times `process()` alone: every frame decoded first, then the whole sequence run `repeats`
/// times on one thread, a fresh odometer each time.
pub fn bench_sequence(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<MethodName>,
    frames: usize,
    repeats: usize,
) -> Result<BenchOutput> {
    let config = config_for(seq, mount, method)?;
    let frames = Preloaded::load(seq, 0..frames)?;
    let mut per_frame = Vec::with_capacity(frames.len() * repeats);
    for _ in 0..repeats {
        frames.run(config, |est, took| {
            std::hint::black_box(est);
            per_frame.push(took);
        })?;
    }
    Ok(BenchOutput { per_frame })
}

/// The validated configuration of `mount` (its method replaced by `method` if given) for the
/// frames of `seq`, whose size it must match.
pub fn config_for(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<MethodName>,
) -> Result<ValidConfig> {
    let mut mount = mount.clone();
    if let Some(m) = method {
        mount.odometer.method = m;
    }
    let (w, h) = seq.size;
    let camera = (
        u32::from(mount.camera.width_px),
        u32::from(mount.camera.height_px),
    );
    if camera != (w, h) {
        bail!(
            "the mount file's camera is {}x{} but the frames of {} are {w}x{h}",
            camera.0,
            camera.1,
            seq.dir.display()
        );
    }
    mount
        .to_config()
        .validate()
        .map_err(|e| anyhow!("mount file: {e}"))
}

/// The mount file of a sequence: `--mount` if given, else `SEQ_DIR/mount.toml`; without a
/// `[camera]` section it takes the sequence's (`calib.txt` and the frames' size).
pub fn mount_for(seq: &Sequence, mount: Option<&Path>) -> Result<MountFile> {
    let path = mount.map_or_else(|| seq.dir.join("mount.toml"), Path::to_owned);
    if !path.exists() {
        bail!(
            "no mount file: {} does not exist (pass --mount FILE, e.g. mounts/kitti.toml; see \
             the README for the format)",
            path.display()
        );
    }
    MountFile::read(&path, Some(&CameraSection::of_sequence(seq)?))
}

/// Runs the odometer with `mount` (its method replaced by `method` if given) over `seq`.
pub fn run_sequence(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<MethodName>,
    quality: Option<&Path>,
    trace: Option<&Path>,
    progress: bool,
) -> Result<RunOutput> {
    let config = config_for(seq, mount, method)?;
    let (w, h) = seq.size;
    let mut odo: Box<Odometer> = Box::new(Odometer::new(config).map_err(|e| anyhow!("{e}"))?);
    let bar = if progress {
        ProgressBar::new(seq.frames as u64).with_style(
            ProgressStyle::with_template("odometry {bar:40} {pos}/{len} frames, eta {eta}")
                .expect("valid template"),
        )
    } else {
        ProgressBar::hidden()
    };
    let create = |p: &Path| -> Result<_> {
        let file =
            std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?;
        Ok(std::io::BufWriter::new(file))
    };
    let mut quality_out = quality.map(create).transpose()?;
    let mut trace_out = trace.map(create).transpose()?;
    let (mut decode, mut odometry) = (Duration::ZERO, Duration::ZERO);
    let mut estimates = Vec::with_capacity(seq.frames);
    let mut trajectory = Trajectory::new(mount, config, seq.frames)?;
    for i in 0..seq.frames {
        let t0 = Instant::now();
        let img = seq.load(i)?;
        decode += t0.elapsed();
        let frame = SliceFrame::new(img.as_raw(), w as u16, h as u16, w as usize)
            .context("frame buffer")?;
        let t_us = timestamp_us(seq, i);
        let t1 = Instant::now();
        let est = odo
            .process(&frame, t_us)
            .with_context(|| format!("frame {i:06}"))?;
        odometry += t1.elapsed();
        let smoothed = trajectory.push(est, t_us);
        if let Some(out) = quality_out.as_mut() {
            let q = &est.quality;
            let line = QualityLine {
                frame: i,
                time_s: seq.times_s[i],
                heading_change_rad: est.motion.heading_change_rad,
                distance_m: est.motion.distance_m,
                x_m: est.pose.x_m,
                y_m: est.pose.y_m,
                heading_rad: est.pose.heading_rad,
                features_detected: q.features_detected,
                tracks: q.tracks,
                tracks_matched: q.tracks_matched,
                inlier_ratio: q.inlier_ratio,
                fallback: q.fallback,
                startup: q.startup,
                vote_peak: q.vote_peak,
                pitch_rad: q.pitch_rad,
                roll_rad: q.roll_rad,
                tracks_refused: q.tracks_refused,
                features_comoving: q.features_comoving,
            };
            writeln!(out, "{}", serde_json::to_string(&line)?)?;
        }
        if let Some(out) = trace_out.as_mut() {
            writeln!(out, "{}", trace_line("estimate", i, &est))?;
            if let Some((frame, s)) = smoothed.filter(|_| trajectory.lag_frames() > 0) {
                writeln!(out, "{}", trace_line("smoothed", frame, &s))?;
            }
        }
        estimates.push(est);
        bar.inc(1);
    }
    bar.finish_and_clear();
    while let Some((frame, s)) = trajectory.flush() {
        if let Some(out) = trace_out.as_mut() {
            writeln!(out, "{}", trace_line("smoothed", frame, &s))?;
        }
    }
    for mut out in [quality_out, trace_out].into_iter().flatten() {
        out.flush()?;
    }
    Ok(RunOutput {
        estimates,
        smooth_lag_frames: trajectory.lag_frames(),
        poses: trajectory.into_poses(),
        odometry,
        decode,
    })
}
