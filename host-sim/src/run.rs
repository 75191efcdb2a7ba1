//! Running the odometer over a sequence, frame by frame, as an ECU would run it: one loop
//! ([`run_frames`]) over a source of frames, decoded on the way ([`Sequence`], of any layout:
//! [`crate::layout`]; its `frame(i)` is called in order, so a video streams) or beforehand
//! ([`Preloaded`], so that the odometry's own speed is measured apart); the trajectory through
//! the mount file's heading smoother ([`Trajectory`]); and `roadvo run`'s outputs.

use crate::kitti::{Pose, Sequence, pose_of};
use crate::layout::{Layout, no_calibration};
use crate::mount::{MountFile, NoCamera, camera_of_sequence, file_key};
use crate::output::OutputFile;
use crate::quality::QualityWriter;
use anyhow::{Context, Result, anyhow, bail};
use image::GrayImage;
use roadvo::wire::trace;
use roadvo::{
    AngleEstimate, Calibration, Camera, ConfigError, Estimate, Instant, Method, Odometer, Pose2,
    SliceFrame, Smoother, ValidConfig,
};
use serde::Serialize;
use std::borrow::Cow;
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
    /// through the mount as learned by the last frame, smoothed as the configuration says),
    /// and the mount it learned.
    pub fn poses(&self, config: ValidConfig) -> Result<(Vec<Pose>, LearnedMount)> {
        let mut trajectory = Trajectory::new(config, self.len())?;
        let ran = run_frames(self, config, BadFrames::Stop, |_, e, t, _| {
            trajectory.push(e, t);
            Ok(())
        })?;
        let (config, learned) = (ran.config, ran.learned);
        ran.complete()?;
        while trajectory.flush().is_some() {}
        Ok((trajectory.into_poses(&config), learned))
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
    /// Fetching the frames (decoding PNGs, JPEGs or a video, for a sequence).
    pub decode: Duration,
}

/// What to do with a frame that cannot be read or that the odometer refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadFrames {
    /// End the run there: the frames before it are the (partial) result.
    Stop,
    /// Leave it out and carry on: the odometer sees a longer interval, as for a dropped frame.
    Skip,
}

/// A frame left out of a run, and why.
#[derive(Debug)]
pub struct Skipped {
    /// The frame's number in the source.
    pub frame: usize,
    /// Why it was left out.
    pub cause: anyhow::Error,
}

/// How a run over a source ended.
#[derive(Debug)]
pub struct Ran {
    /// Time spent.
    pub timing: Timing,
    /// Frames left out ([`BadFrames::Skip`]), in order.
    pub skipped: Vec<Skipped>,
    /// The frame the run stopped at and why (a bad frame under [`BadFrames::Stop`], or an
    /// interruption); `None` when every frame was run.
    pub stopped: Option<Skipped>,
    /// The mount the odometer learned, after the last frame run.
    pub calibration: Calibration,
    /// The corrections to the mount file read from it then, as the odometer gave them
    /// ([`LearnedMount::of`]).
    pub learned: LearnedMount,
    /// The configuration in use after the last frame run: the one given, its mount turned by
    /// the calibration.
    pub config: ValidConfig,
}

impl Skipped {
    /// Why the frame was left out, as an error naming the frame.
    pub fn into_error(self) -> anyhow::Error {
        self.cause.context(format!("frame {:06}", self.frame))
    }
}

/// The corrections to the mount file's mount that a run learned, each with its standard error;
/// `None` where nothing measured it (the setting off, or the drive never showed it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LearnedMount {
    /// Yaw, radians (counter-clockwise seen from above).
    pub yaw: Option<AngleEstimate>,
    /// Pitch, radians (nose up).
    pub pitch: Option<AngleEstimate>,
    /// Roll, radians (left side up).
    pub roll: Option<AngleEstimate>,
    /// The correction to the camera's distance ahead of the rear axle (added to the mount
    /// file's) and its standard error, metres.
    pub x_m: Option<(f32, f32)>,
}

impl LearnedMount {
    /// The corrections `odo` has learned, its yaw read through the mount in use
    /// ([`Odometer::learned_yaw`]).
    pub fn of(odo: &Odometer) -> Self {
        let c = odo.calibration();
        Self {
            yaw: odo.learned_yaw(),
            pitch: c.pitch(),
            roll: c.roll(),
            x_m: c.x_ahead(),
        }
    }
}

impl Ran {
    /// The timing of a run that went to the end; an error naming the frame otherwise.
    pub fn complete(self) -> Result<Timing> {
        match self.stopped {
            None => Ok(self.timing),
            Some(s) => Err(s.into_error()),
        }
    }
}

/// Runs a fresh odometer with `config` over the frames of `source` on this thread; `each` sees
/// every frame's number, estimate and timestamp and the time `process()` took. A frame that
/// cannot be read or is refused is handled as `bad` says; a Ctrl-C ([`crate::interrupt`]) ends
/// the run before the next frame. Errors from `each` end it with an error. The one frame loop
/// of the host.
pub fn run_frames(
    source: &impl FrameSource,
    config: ValidConfig,
    bad: BadFrames,
    mut each: impl FnMut(usize, Estimate, Instant, Duration) -> Result<()>,
) -> Result<Ran> {
    run_frames_inspected(source, config, bad, |i, est, t, took, _| {
        each(i, est, t, took)
    })
}

/// [`run_frames`], with `each` also seeing the odometer after the frame (its tracks, for a
/// debug view).
pub fn run_frames_inspected(
    source: &impl FrameSource,
    config: ValidConfig,
    bad: BadFrames,
    mut each: impl FnMut(usize, Estimate, Instant, Duration, &Odometer) -> Result<()>,
) -> Result<Ran> {
    let mut odo: Box<Odometer> = Box::new(Odometer::new(config).map_err(config_error)?);
    let mut ran = Ran {
        timing: Timing::default(),
        skipped: Vec::new(),
        stopped: None,
        calibration: Calibration::NONE,
        learned: LearnedMount::default(),
        config,
    };
    for i in 0..source.len() {
        if let Err(cause) = crate::interrupt::check() {
            ran.stopped = Some(Skipped { frame: i, cause });
            break;
        }
        let t0 = std::time::Instant::now();
        let frame = source.frame(i);
        ran.timing.decode += t0.elapsed();
        let t1 = std::time::Instant::now();
        let est = frame.and_then(|(img, t)| {
            let (w, h) = img.dimensions();
            let frame = SliceFrame::new(img.as_raw(), w as u16, h as u16, w as usize)
                .context("frame buffer")?;
            Ok((odo.process(&frame, t)?, t))
        });
        let took = t1.elapsed();
        ran.timing.odometry += took;
        match est {
            Ok((est, t)) => each(i, est, t, took, &odo)?,
            Err(cause) => {
                let skipped = Skipped { frame: i, cause };
                match bad {
                    BadFrames::Skip => ran.skipped.push(skipped),
                    BadFrames::Stop => {
                        ran.stopped = Some(skipped);
                        break;
                    }
                }
            }
        }
    }
    ran.calibration = *odo.calibration();
    ran.learned = LearnedMount::of(&odo);
    ran.config = *odo.config();
    Ok(ran)
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
        Some(key) => anyhow!("{e} ({key})"),
        None => anyhow!("{e}"),
    }
}

/// The camera-0 trajectory of a run: each estimate through the configuration's heading
/// smoother (`smooth_lag_frames`, pitch vote only), then, at the end, lifted through a mount to
/// KITTI poses.
pub struct Trajectory {
    smoother: Smoother<{ 2 * MAX_SMOOTH_LAG_FRAMES as usize + 1 }>,
    /// The vehicle's poses of the estimates handed back.
    poses: Vec<Pose2>,
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

    /// The camera poses of the estimates handed back, in order (every frame's, once flushed),
    /// through `config`'s mount: the one given, or the one the odometer learned by the end of
    /// the drive (a camera's pose is its mount's, whichever frame it was learned on).
    pub fn into_poses(self, config: &ValidConfig) -> Vec<Pose> {
        let lift = config.lift();
        let camera = |p: &Pose2| pose_of(&lift.camera_pose(p));
        self.poses.iter().map(camera).collect()
    }

    /// Appends `e`'s pose; `e` with its frame number (the poses before it).
    fn lift(&mut self, e: Estimate) -> (usize, Estimate) {
        let frame = self.poses.len();
        self.poses.push(e.pose);
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

/// The mount file of a sequence: `--mount` if given, else `SEQ_DIR/mount.toml` for a KITTI
/// sequence folder (the other layouts need `--mount`); without a `[camera]` section it takes
/// the sequence's (`calib.txt` and the frames' size), and with one it must agree with them
/// where the sequence has a `calib.txt` ([`check_same_camera`]).
pub fn mount_for(seq: &Sequence, mount: Option<&Path>) -> Result<MountFile> {
    let path = match mount {
        Some(path) => path.to_owned(),
        None if matches!(seq.layout, Layout::Kitti) => seq.dir.join("mount.toml"),
        None => bail!("{}; pass one with --mount FILE", no_calibration(seq)),
    };
    if !path.exists() {
        bail!(
            "no mount file: {} does not exist (pass --mount FILE, e.g. mounts/kitti.toml; \
             docs/mount-file.md has the format)",
            path.display()
        );
    }
    if seq.p0.is_none() {
        return MountFile::read(&path, None).map_err(|e| match e.downcast_ref::<NoCamera>() {
            Some(_) => anyhow!("{}, and {} has none", no_calibration(seq), path.display()),
            None => e,
        });
    }
    let seq_camera = camera_of_sequence(seq)?;
    let file = MountFile::read(&path, Some(&seq_camera))?;
    check_same_camera(&file.camera, &seq_camera, &path, seq)?;
    Ok(file)
}

/// Largest difference in focal length or principal point between a mount file's `[camera]`
/// and a sequence's `calib.txt` taken as the same, pixels.
pub const SAME_CAMERA_PX: f32 = 1e-3;

/// Refuses a mount file `[camera]` (`camera`, read from `path`) that disagrees with the
/// sequence's own (`seq_camera`: its `calib.txt` and its frames' size): a focal length or
/// principal point more than [`SAME_CAMERA_PX`] apart, or another frame size. The error names
/// both files and every value that differs.
pub fn check_same_camera(
    camera: &Camera,
    seq_camera: &Camera,
    path: &Path,
    seq: &Sequence,
) -> Result<()> {
    let mut differ = Vec::new();
    if camera.image() != seq_camera.image() {
        differ.push(format!(
            "frame size {}x{} vs {}x{}",
            camera.width_px, camera.height_px, seq_camera.width_px, seq_camera.height_px
        ));
    }
    for (key, a, b) in [
        ("fx_px", camera.fx_px, seq_camera.fx_px),
        ("fy_px", camera.fy_px, seq_camera.fy_px),
        ("cx_px", camera.cx_px, seq_camera.cx_px),
        ("cy_px", camera.cy_px, seq_camera.cy_px),
    ] {
        if (a - b).abs() > SAME_CAMERA_PX {
            differ.push(format!("{key} {a} vs {b}"));
        }
    }
    if differ.is_empty() {
        return Ok(());
    }
    let first = seq.frame_path(0).unwrap_or_else(|| seq.dir.clone());
    bail!(
        "the [camera] of mount file {} disagrees with {} and the size of {}: {}; make them \
         agree, or leave [camera] out to take calib.txt's",
        path.display(),
        seq.dir.join("calib.txt").display(),
        first.display(),
        differ.join(", ")
    )
}

/// One frame's estimate as a quality record (a JSON line or a CSV row): the odometer's own (never smoothed), in the vehicle
/// frame of the first frame (x forward, y left, heading counter-clockwise).
#[derive(Serialize)]
pub struct QualityLine {
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
    /// The learned correction of the mount's yaw after the frame, radians
    /// ([`Calibration::yaw`]).
    learned_yaw_rad: f32,
    /// The learned correction of the mount's pitch after the frame, radians.
    learned_pitch_rad: f32,
    /// The learned correction of the mount's roll after the frame, radians.
    learned_roll_rad: f32,
    /// The learned correction of the camera's distance ahead of the rear axle after the
    /// frame, metres (0 until the bends driven tell it).
    learned_x_m: f32,
    /// The road it rests on, metres.
    learned_road_m: f32,
}

impl QualityLine {
    /// Frame `frame`'s line, taken at `time_s`, for its estimate `e` and the mount `odo`
    /// learned after it.
    pub fn of(frame: usize, time_s: f64, e: &Estimate, odo: &Odometer) -> Self {
        let q = &e.quality;
        let l = LearnedMount::of(odo);
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
            learned_yaw_rad: l.yaw.map_or(0.0, |e| e.rad),
            learned_pitch_rad: l.pitch.map_or(0.0, |e| e.rad),
            learned_roll_rad: l.roll.map_or(0.0, |e| e.rad),
            learned_x_m: l.x_m.map_or(0.0, |(m, _)| m),
            learned_road_m: odo.calibration().distance_m,
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
    /// Per-frame estimates of the frames run, in order.
    pub estimates: Vec<Estimate>,
    /// Camera-0 poses through the mount, KITTI format (smoothed if the configuration says so):
    /// one a frame from the first up to the last frame run, skipped frames in between
    /// interpolated.
    pub poses: Vec<Pose>,
    /// The heading smoother's lag, frames (0: none).
    pub smooth_lag_frames: u8,
    /// Where the time went, what was skipped and where the run stopped early.
    pub ran: Ran,
}

impl RunOutput {
    /// The output of a run that went to the end; an error naming the frame otherwise.
    pub fn complete(mut self) -> Result<Self> {
        match self.ran.stopped.take() {
            None => Ok(self),
            Some(s) => Err(s.into_error()),
        }
    }

    /// Frames that fell back to the previous motion.
    pub fn fallbacks(&self) -> usize {
        self.estimates.iter().filter(|e| e.quality.fallback).count()
    }

    /// The frame of the first pose: the first frame not left out.
    pub fn first_frame(&self) -> usize {
        let mut first = 0;
        for s in &self.ran.skipped {
            if s.frame == first {
                first += 1;
            }
        }
        first
    }

    /// Frames per second of the odometry alone.
    pub fn frames_per_s(&self) -> f64 {
        self.estimates.len() as f64 / self.ran.timing.odometry.as_secs_f64().max(1e-9)
    }
}

/// Optional per-frame outputs of a run, each written whole or not at all
/// ([`crate::output`]).
#[derive(Default)]
pub struct RunFiles<'a> {
    /// Each frame's estimate and quality: JSON lines, or CSV for `.csv` ([`crate::quality`]).
    pub quality: Option<&'a Path>,
    /// Each estimate's trace line, and each smoothed one's.
    pub trace: Option<&'a Path>,
}

/// Runs the odometer with `config` over `source`, writing `files` on the way; `progress` hears
/// of each frame done. Bad frames are handled as `bad` says; a run that stops early (a bad
/// frame, Ctrl-C) still returns, its outputs holding the frames before the stop
/// ([`RunOutput::ran`] says where). A file that cannot be written is an error, and leaves
/// every earlier version of the files as it was.
pub fn run(
    source: &impl FrameSource,
    config: ValidConfig,
    files: &RunFiles,
    bad: BadFrames,
    mut progress: impl FnMut(),
) -> Result<RunOutput> {
    let mut quality_out = files.quality.map(QualityWriter::create).transpose()?;
    let mut trace_out = files.trace.map(OutputFile::create).transpose()?;
    let mut estimates = Vec::with_capacity(source.len());
    let mut frames_run = Vec::with_capacity(source.len());
    let mut trajectory = Trajectory::new(config, source.len())?;
    let ran = run_frames_inspected(source, config, bad, |i, est, t, _, odo| {
        frames_run.push(i);
        let smoothed = trajectory.push(est, t);
        if let Some(out) = quality_out.as_mut() {
            out.write(&QualityLine::of(i, source.time_s(i), &est, odo))?;
        }
        if let Some(out) = trace_out.as_mut() {
            out.write_line(&trace_line("estimate", i, &est))?;
            if let Some((k, s)) = smoothed.filter(|_| trajectory.lag_frames() > 0) {
                out.write_line(&trace_line("smoothed", frames_run[k], &s))?;
            }
        }
        estimates.push(est);
        progress();
        Ok(())
    })?;
    while let Some((k, s)) = trajectory.flush() {
        if let Some(out) = trace_out.as_mut() {
            out.write_line(&trace_line("smoothed", frames_run[k], &s))?;
        }
    }
    if let Some(out) = quality_out {
        out.commit()?;
    }
    if let Some(out) = trace_out {
        out.commit()?;
    }
    Ok(RunOutput {
        estimates,
        smooth_lag_frames: trajectory.lag_frames(),
        // Through the mount as the odometer learned it (`learn_yaw`, `learn_pitch`,
        // `learn_roll`, `learn_x`).
        poses: fill_skipped(&trajectory.into_poses(&ran.config), &frames_run),
        ran,
    })
}

/// One pose a frame from `frames[0]` to the last of `frames`: `poses[k]` is frame `frames[k]`'s
/// and the frames between two run frames are interpolated (position linearly, rotation along
/// the shortest arc). Frames before the first run frame have no pose.
fn fill_skipped(poses: &[Pose], frames: &[usize]) -> Vec<Pose> {
    let mut out = Vec::with_capacity(frames.last().map_or(0, |l| l + 1));
    for (k, pair) in poses.windows(2).enumerate() {
        let (a, b) = (frames[k], frames[k + 1]);
        out.push(pair[0]);
        for f in a + 1..b {
            out.push(interpolate(
                &pair[0],
                &pair[1],
                (f - a) as f64 / (b - a) as f64,
            ));
        }
    }
    out.extend(poses.last());
    out
}

/// The pose a fraction `s` of the way from `a` to `b`.
fn interpolate(a: &Pose, b: &Pose, s: f64) -> Pose {
    let rotation = |p: &Pose| {
        let m = nalgebra::Matrix3::from_fn(|r, c| p[4 * r + c]);
        nalgebra::UnitQuaternion::from_matrix(&m)
    };
    let r = rotation(a).slerp(&rotation(b), s).to_rotation_matrix();
    std::array::from_fn(|k| {
        let (row, col) = (k / 4, k % 4);
        if col == 3 {
            a[k] + s * (b[k] - a[k])
        } else {
            r[(row, col)]
        }
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
        run_frames(frames, config, BadFrames::Stop, |_, est, _, took| {
            std::hint::black_box(est);
            per_frame.push(took);
            Ok(())
        })?
        .complete()?;
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
    let output = run(
        seq,
        config_for(seq, mount, method)?,
        &RunFiles::default(),
        BadFrames::Stop,
        || {},
    )?;
    output
        .complete()
        .with_context(|| seq.dir.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::level_pose;

    #[test]
    fn skipped_frames_are_interpolated_between_their_neighbours() {
        let (a, b) = (level_pose(0.0, 0.0, 0.0), level_pose(3.0, 6.0, 0.3));
        let filled = fill_skipped(&[a, b], &[2, 5]);
        assert_eq!(filled.len(), 4, "frames 2 to 5");
        assert_eq!((filled[0], filled[3]), (a, b));
        for (k, p) in filled.iter().enumerate() {
            let want = level_pose(k as f64, 2.0 * k as f64, 0.1 * k as f64);
            for (got, want) in p.iter().zip(want) {
                assert!((got - want).abs() < 1e-12, "frame {}: {p:?}", k + 2);
            }
        }
        assert!(fill_skipped(&[], &[]).is_empty());
    }
}
