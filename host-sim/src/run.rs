//! Running the odometer over a sequence, frame by frame, as an ECU would run it: one loop
//! ([`run_frames`]) over a source of frames, decoded on the way ([`Sequence`]) or beforehand
//! ([`Preloaded`], so that the odometry's own speed is measured apart); the trajectory through
//! the mount file's heading smoother ([`Trajectory`]); and `roadvo run`'s outputs.

use crate::kitti::{Pose, Sequence, pose_of};
use crate::mount::{MountFile, camera_of_sequence, file_key};
use anyhow::{Context, Result, anyhow, bail};
use image::GrayImage;
use roadvo::wire::trace;
use roadvo::{ConfigError, Estimate, Instant, Method, Odometer, SliceFrame, Smoother, ValidConfig};
use serde::Serialize;
use std::borrow::Cow;
use std::io::Write;
use std::path::Path;
use std::time::Duration;

/// Frames to run: each an 8-bit grey image and its timestamp.
pub trait FrameSource {
    /// Frames held.
    fn len(&self) -> usize;
    /// Whether it holds no frame.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Frame `i` and its timestamp.
    fn frame(&self, i: usize) -> Result<(Cow<'_, GrayImage>, Instant)>;
    /// Frame `i`'s time as recorded, seconds.
    fn time_s(&self, i: usize) -> f64;
}

impl FrameSource for Sequence {
    fn len(&self) -> usize {
        self.frames
    }

    fn frame(&self, i: usize) -> Result<(Cow<'_, GrayImage>, Instant)> {
        Ok((Cow::Owned(self.load(i)?), self.timestamp(i)))
    }

    fn time_s(&self, i: usize) -> f64 {
        self.times_s[i]
    }
}

/// Frames decoded ahead of the odometry, for runs that time or repeat it.
pub struct Preloaded {
    images: Vec<GrayImage>,
    times: Vec<Instant>,
}

impl Preloaded {
    /// Decodes `frames` of `seq` (clipped to the sequence).
    pub fn load(seq: &Sequence, frames: std::ops::Range<usize>) -> Result<Self> {
        let frames = frames.start.min(seq.frames)..frames.end.min(seq.frames);
        let images = frames
            .clone()
            .map(|i| seq.load(i))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            images,
            times: frames.map(|i| seq.timestamp(i)).collect(),
        })
    }

    /// The camera-0 trajectory of a fresh odometer with `config` over the frames (KITTI poses
    /// through the mount, smoothed as the configuration says).
    pub fn poses(&self, config: ValidConfig) -> Result<Vec<Pose>> {
        let mut trajectory = Trajectory::new(config, self.len())?;
        run_frames(self, config, |_, e, t, _| {
            trajectory.push(e, t);
            Ok(())
        })?;
        while trajectory.flush().is_some() {}
        Ok(trajectory.into_poses())
    }
}

impl FrameSource for Preloaded {
    fn len(&self) -> usize {
        self.images.len()
    }

    fn frame(&self, i: usize) -> Result<(Cow<'_, GrayImage>, Instant)> {
        let img = self.images.get(i).context("no such frame")?;
        Ok((Cow::Borrowed(img), self.times[i]))
    }

    fn time_s(&self, i: usize) -> f64 {
        self.times[i].total_micros() as f64 / 1e6
    }
}

/// Time spent in a run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timing {
    /// In `process()` alone.
    pub odometry: Duration,
    /// Fetching the frames (decoding PNGs, for a sequence).
    pub decode: Duration,
}

/// Runs a fresh odometer with `config` over every frame of `source` on this thread; `each` sees
/// every frame's number, estimate and timestamp and the time `process()` took. The one frame
/// loop of the host.
pub fn run_frames(
    source: &impl FrameSource,
    config: ValidConfig,
    mut each: impl FnMut(usize, Estimate, Instant, Duration) -> Result<()>,
) -> Result<Timing> {
    let mut odo: Box<Odometer> = Box::new(Odometer::new(config).map_err(config_error)?);
    let mut timing = Timing::default();
    for i in 0..source.len() {
        let t0 = std::time::Instant::now();
        let (img, t) = source.frame(i)?;
        timing.decode += t0.elapsed();
        let (w, h) = img.dimensions();
        let frame = SliceFrame::new(img.as_raw(), w as u16, h as u16, w as usize)
            .context("frame buffer")?;
        let t1 = std::time::Instant::now();
        let est = odo.process(&frame, t);
        let took = t1.elapsed();
        timing.odometry += took;
        each(i, est.with_context(|| format!("frame {i:06}"))?, t, took)?;
    }
    Ok(timing)
}

/// A configuration the core refused, its setting named as a mount file writes it.
pub fn config_error(e: ConfigError) -> anyhow::Error {
    let field = match e {
        ConfigError::NonFinite { field }
        | ConfigError::OutOfRange { field }
        | ConfigError::EvenHypotheses { field }
        | ConfigError::ExceedsCapacity { field } => file_key(field),
        _ => None,
    };
    match field {
        Some(key) => anyhow!("mount file: {e} ({key})"),
        None => anyhow!("mount file: {e}"),
    }
}

/// The camera-0 trajectory of a run: each estimate through the configuration's heading
/// smoother (`smooth_lag_frames`, pitch vote only), then lifted through the mount to a KITTI
/// pose.
pub struct Trajectory {
    smoother: Smoother<{ 2 * MAX_SMOOTH_LAG_FRAMES as usize + 1 }>,
    config: ValidConfig,
    poses: Vec<Pose>,
}

/// The longest `smooth_lag_frames` the host's smoother holds.
pub const MAX_SMOOTH_LAG_FRAMES: u8 = 4;

impl Trajectory {
    /// A trajectory of up to `frames` poses, with the configuration's `smooth_lag_frames` for
    /// the pitch vote and none for the paper's method, which stays as written.
    pub fn new(config: ValidConfig, frames: usize) -> Result<Self> {
        let lag = match config.settings().method {
            Method::PitchVote => config.settings().smooth_lag_frames,
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

    /// Takes the estimate of the frame at `timestamp`; the estimate the smoother hands back
    /// (`lag_frames` frames earlier), if any, with its frame number: its pose is now the
    /// trajectory's last.
    pub fn push(&mut self, estimate: Estimate, timestamp: Instant) -> Option<(usize, Estimate)> {
        let e = self.smoother.push(estimate, timestamp)?;
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

/// The validated configuration of `mount` (its method replaced by `method` if given) for the
/// frames of `seq`, whose size it must match.
pub fn config_for(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<Method>,
) -> Result<ValidConfig> {
    let mut mount = *mount;
    if let Some(m) = method {
        mount.settings.method = m;
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
    mount.to_config().validate().map_err(config_error)
}

/// The mount file of a sequence: `--mount` if given, else `SEQ_DIR/mount.toml`; without a
/// `[camera]` section it takes the sequence's (`calib.txt` and the frames' size).
pub fn mount_for(seq: &Sequence, mount: Option<&Path>) -> Result<MountFile> {
    let path = mount.map_or_else(|| seq.dir.join("mount.toml"), Path::to_owned);
    if !path.exists() {
        bail!(
            "no mount file: {} does not exist (pass --mount FILE, e.g. mounts/kitti.toml; \
             docs/mount-file.md has the format)",
            path.display()
        );
    }
    MountFile::read(&path, Some(&camera_of_sequence(seq)?))
}

/// One frame's estimate as a JSON line: the odometer's own (never smoothed), in the vehicle
/// frame of the first frame (x forward, y left, heading counter-clockwise).
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
    image_corners: u16,
    image_matches: u16,
    image_inliers: u16,
    image_heading: bool,
}

impl QualityLine {
    fn of(frame: usize, time_s: f64, e: &Estimate) -> Self {
        let q = &e.quality;
        Self {
            frame,
            time_s,
            heading_change_rad: e.motion.heading_change_rad,
            distance_m: e.motion.distance_m,
            x_m: e.pose.x_m,
            y_m: e.pose.y_m,
            heading_rad: e.pose.heading_rad,
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
            image_corners: q.image_corners,
            image_matches: q.image_matches,
            image_inliers: q.image_inliers,
            image_heading: q.image_heading,
        }
    }
}

/// One frame's trace line: `kind` (`estimate` or `smoothed`), the frame number, the record's
/// words ([`roadvo::wire::trace`]), as the firmware prints them.
pub fn trace_line(kind: &str, frame: usize, e: &Estimate) -> String {
    let words: Vec<String> = trace::record(e).iter().map(u32::to_string).collect();
    format!("{kind} {frame} {}", words.join(" "))
}

/// What a run produced.
pub struct RunOutput {
    /// Per-frame estimates.
    pub estimates: Vec<Estimate>,
    /// Camera-0 poses through the mount, KITTI format (smoothed if the configuration says so).
    pub poses: Vec<Pose>,
    /// The heading smoother's lag, frames (0: none).
    pub smooth_lag_frames: u8,
    /// Where the time went.
    pub timing: Timing,
}

impl RunOutput {
    /// Frames that fell back to the previous motion.
    pub fn fallbacks(&self) -> usize {
        self.estimates.iter().filter(|e| e.quality.fallback).count()
    }

    /// Frames per second of the odometry alone.
    pub fn frames_per_s(&self) -> f64 {
        self.estimates.len() as f64 / self.timing.odometry.as_secs_f64().max(1e-9)
    }
}

/// Optional per-frame outputs of a run.
#[derive(Default)]
pub struct RunFiles<'a> {
    /// Each frame's estimate and quality as JSON lines.
    pub quality: Option<&'a Path>,
    /// Each estimate's trace line, and each smoothed one's.
    pub trace: Option<&'a Path>,
}

/// Runs the odometer with `config` over `source`, writing `files` on the way; `progress` hears
/// of each frame done.
pub fn run(
    source: &impl FrameSource,
    config: ValidConfig,
    files: &RunFiles,
    mut progress: impl FnMut(),
) -> Result<RunOutput> {
    let create = |p: &Path| -> Result<_> {
        let file =
            std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?;
        Ok(std::io::BufWriter::new(file))
    };
    let mut quality_out = files.quality.map(create).transpose()?;
    let mut trace_out = files.trace.map(create).transpose()?;
    let mut estimates = Vec::with_capacity(source.len());
    let mut trajectory = Trajectory::new(config, source.len())?;
    let timing = run_frames(source, config, |i, est, t, _| {
        let smoothed = trajectory.push(est, t);
        if let Some(out) = quality_out.as_mut() {
            let line = QualityLine::of(i, source.time_s(i), &est);
            writeln!(out, "{}", serde_json::to_string(&line)?)?;
        }
        if let Some(out) = trace_out.as_mut() {
            writeln!(out, "{}", trace_line("estimate", i, &est))?;
            if let Some((frame, s)) = smoothed.filter(|_| trajectory.lag_frames() > 0) {
                writeln!(out, "{}", trace_line("smoothed", frame, &s))?;
            }
        }
        estimates.push(est);
        progress();
        Ok(())
    })?;
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
        timing,
    })
}

/// Timings of [`bench`].
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
            ms.get(((ms.len().max(1) - 1) as f64 * q) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        (pick(0.0), pick(0.5), pick(1.0))
    }
}

/// Times `process()` alone: the frames decoded first, then run `repeats` times on one thread,
/// a fresh odometer each time.
pub fn bench(frames: &Preloaded, config: ValidConfig, repeats: usize) -> Result<BenchOutput> {
    let mut per_frame = Vec::with_capacity(frames.len() * repeats);
    for _ in 0..repeats {
        run_frames(frames, config, |_, est, _, took| {
            std::hint::black_box(est);
            per_frame.push(took);
            Ok(())
        })?;
    }
    Ok(BenchOutput { per_frame })
}

/// Runs the odometer with `mount` (its method replaced by `method` if given) over `seq`: no
/// files, no progress.
pub fn run_sequence(
    seq: &Sequence,
    mount: &MountFile,
    method: Option<Method>,
) -> Result<RunOutput> {
    run(
        seq,
        config_for(seq, mount, method)?,
        &RunFiles::default(),
        || {},
    )
}
