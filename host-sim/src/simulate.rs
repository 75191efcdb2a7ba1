//! `roadvo simulate`: renders a scenario into a KITTI-layout folder with exact ground truth.
//!
//! ```text
//! OUT/sequences/00/image_0/000000.png ...   the frames
//! OUT/sequences/00/calib.txt                P0 of the camera
//! OUT/sequences/00/times.txt                seconds
//! OUT/sequences/00/mount.toml               mount (plus any calibration error) and settings
//! OUT/sequences/00/scenario.toml            the scenario and seed, to render it again
//! OUT/poses/00.txt                          true camera-0 poses
//! ```
//!
//! The ground truth is the vehicle's planar path lifted through the true mount, so a perfect
//! planar odometer scores zero; the body's suspension motion is a disturbance, not truth.

use crate::Progress;
use crate::kitti::{self, Pose};
use crate::output::StagingDir;
use crate::path::{DistanceClock, Path, WorldPose, speed_at};
use crate::render::{BoxState, FrameState, Scene};
use crate::scenario::{MAX_DRIVE_S, MAX_FRAMES, Scenario};
use anyhow::{Context, Result, bail};
use rayon::prelude::*;
use roadvo::{Attitude, Pose2};
use std::path::{Path as FsPath, PathBuf};

/// Where a drive's files go inside `OUT`.
pub fn sequence_dir(out: &FsPath) -> PathBuf {
    out.join("sequences").join("00")
}

/// Where a drive's ground truth goes inside `OUT`.
pub fn poses_path(out: &FsPath) -> PathBuf {
    out.join("poses").join("00.txt")
}

/// What `simulate` did.
#[derive(Clone, Debug)]
pub struct Summary {
    /// Frames rendered.
    pub frames: usize,
    /// Path driven, metres.
    pub distance_m: f64,
    /// Wall-clock rendering time, seconds.
    pub render_s: f64,
}

/// The drive's state at each frame: vehicle poses, body attitude, other road users.
pub(crate) struct Drive {
    /// Each frame's time, seconds.
    pub(crate) times_s: Vec<f64>,
    /// Each frame's scene state.
    pub(crate) states: Vec<FrameState>,
    /// Distance along the path at the last frame, metres.
    pub(crate) distance_m: f64,
}

/// The drive's state at each frame of `scenario` along `path`: until the path ends, or
/// `frames` frames (an error if the path ends first).
pub(crate) fn plan(
    scenario: &Scenario,
    path: &Path,
    frames: Option<usize>,
    seed: u64,
) -> Result<Drive> {
    let fps = scenario.frames_per_second;
    let length = path.length_m();
    if let Some(n) = frames
        && n > MAX_FRAMES
    {
        bail!("--frames {n}: a drive renders at most {MAX_FRAMES} frames");
    }
    // Frames until the path ends, unless a number is asked for.
    let mut clock = DistanceClock::new(&scenario.speed);
    let (mut times_s, mut dist) = (Vec::new(), Vec::new());
    for i in 0..frames.unwrap_or(MAX_FRAMES) {
        let t = i as f64 / fps;
        if t > MAX_DRIVE_S {
            bail!(
                "scenario {}: frame {i} would be at {t:.1} s, beyond the longest drive of \
                 {MAX_DRIVE_S} s (the path is {length:.1} m long; is the speed too low?)",
                scenario.name
            );
        }
        let s = clock.advance_to(t);
        if s > length + 1e-9 {
            if let Some(n) = frames {
                bail!(
                    "the path is {length:.1} m long: it ends before frame {i} of the {n} asked for"
                );
            }
            break;
        }
        times_s.push(t);
        dist.push(s);
    }
    let last = *dist.last().context("--frames must be at least 1")?;
    if frames.is_none() && times_s.len() == MAX_FRAMES {
        bail!("the drive does not reach the end of the path in {MAX_FRAMES} frames: pass --frames");
    }
    let sus = &scenario.suspension;
    let two_pi = std::f64::consts::TAU;
    // Phases from the seed, so that different seeds shake differently.
    let phase = |salt: u64| {
        let h = (seed ^ salt).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        (h >> 11) as f64 / (1u64 << 53) as f64 * two_pi
    };
    let (pitch_phase, roll_phase) = (phase(1), phase(2));
    // Other vehicles: where each is along the path when it appears.
    let appear_s: Vec<f64> = scenario
        .vehicles
        .iter()
        .map(|v| v.appear_s.max(0.0))
        .collect();
    let ego_at_appear: Vec<f64> = appear_s
        .iter()
        .map(|&t| DistanceClock::new(&scenario.speed).advance_to(t))
        .collect();
    let states = times_s
        .iter()
        .zip(&dist)
        .map(|(&t, &s)| {
            let attitude = Attitude {
                pitch_rad: (sus.pitch_amplitude_deg.to_radians()
                    * (two_pi * sus.pitch_frequency_hz * t + pitch_phase).sin())
                    as f32,
                roll_rad: (sus.roll_amplitude_deg.to_radians()
                    * (two_pi * sus.roll_frequency_hz * t + roll_phase).sin())
                    as f32,
            };
            let boxes = scenario
                .vehicles
                .iter()
                .enumerate()
                .filter(|(_, v)| t >= v.appear_s && t < v.disappear_s)
                .map(|(i, v)| {
                    let along = match v.speed_m_s {
                        Some(speed) => ego_at_appear[i] + v.ahead_m + speed * (t - appear_s[i]),
                        None => s + v.ahead_m,
                    };
                    let centre_pose = path.pose_at(along);
                    let lateral_m = v.lateral_m + v.cross_speed_m_s * (t - appear_s[i]);
                    // Facing the way it goes, along the road and across it.
                    let along_speed = v.speed_m_s.unwrap_or_else(|| speed_at(&scenario.speed, s));
                    BoxState {
                        centre: centre_pose.to_world(0.0, lateral_m),
                        heading_rad: centre_pose.heading_rad + v.cross_speed_m_s.atan2(along_speed),
                        size: (0.5 * v.length_m, 0.5 * v.width_m, v.height_m),
                        shade: 60.0 + 120.0 * ((i as f64 * 0.618_034 + 0.3) % 1.0),
                    }
                })
                .collect();
            // With tyre slip the path is the pivot's; the rear axle is behind it.
            let on_path = path.pose_at(s);
            let behind_m = scenario.slip.as_ref().map_or(0.0, |slip| {
                slip.pivot_s2_per_m * speed_at(&scenario.speed, s).powi(2)
            });
            let (x_m, y_m) = on_path.to_world(-behind_m, 0.0);
            FrameState {
                pose: WorldPose {
                    x_m,
                    y_m,
                    ..on_path
                },
                attitude,
                boxes,
            }
        })
        .collect();
    Ok(Drive {
        times_s,
        states,
        distance_m: last,
    })
}

/// Writes `drive` of `scenario` into the folder `out`: the ground truth, the sequence's files
/// and every frame, rendered on all cores.
fn write_drive(
    scenario: &Scenario,
    path: &Path,
    drive: &Drive,
    seed: u64,
    out: &FsPath,
    progress: &dyn Progress,
) -> Result<()> {
    let n = drive.states.len();
    let seq = sequence_dir(out);
    std::fs::create_dir_all(seq.join("image_0"))
        .with_context(|| format!("cannot create {}", seq.display()))?;

    // Ground truth: planar poses relative to the first frame, lifted through the true mount.
    let truth = scenario
        .mount_file(false)
        .to_config()
        .validate()
        .map_err(|e| anyhow::anyhow!("scenario camera and mount: {e}"))?;
    let origin = drive.states[0].pose;
    let poses: Vec<Pose> = drive
        .states
        .iter()
        .map(|st| {
            let rel = st.pose.relative_to(&origin);
            let planar = Pose2 {
                x_m: rel.x_m as f32,
                y_m: rel.y_m as f32,
                heading_rad: roadvo::motion::wrap_angle_rad(rel.heading_rad as f32),
            };
            kitti::pose_of(&truth.lift().camera_pose(&planar))
        })
        .collect();
    kitti::write_poses(&poses_path(out), &poses)?;
    kitti::write_times(&seq.join("times.txt"), &drive.times_s)?;
    let cam = &scenario.camera;
    kitti::write_calib(
        &seq.join("calib.txt"),
        f64::from(cam.fx_px),
        f64::from(cam.fy_px),
        f64::from(cam.cx_px),
        f64::from(cam.cy_px),
    )?;
    scenario
        .mount_file(true)
        .write(&seq.join("mount.toml"), true, "")?;
    let record = format!(
        "# Rendered by `roadvo simulate` with --seed {seed} --frames {n}\n{}",
        scenario.to_toml()?
    );
    kitti::write_text(&seq.join("scenario.toml"), &record)?;

    let scene = Scene::new(scenario, path, seed);
    progress.start(n);
    drive
        .states
        .par_iter()
        .enumerate()
        .try_for_each(|(i, st)| -> Result<()> {
            crate::interrupt::check()?;
            let img = scene.render(st, i as u64);
            let file = kitti::image_path(&seq, i);
            img.save(&file)
                .with_context(|| format!("cannot write {}", file.display()))?;
            progress.step();
            Ok(())
        })?;
    Ok(())
}

/// Renders `scenario` into `out` (KITTI layout), whole or not at all: a failed or interrupted
/// render leaves an earlier drive in `out` as it was, and a folder holding anything but an
/// earlier drive is refused. `frames` cuts the drive short; `progress` hears of each frame
/// rendered.
pub fn simulate(
    scenario: &Scenario,
    out: &FsPath,
    seed: u64,
    frames: Option<usize>,
    progress: &dyn Progress,
) -> Result<Summary> {
    let path = Path::new(&scenario.segments).context("in the scenario's path")?;
    let drive = plan(scenario, &path, frames, seed)?;
    let n = drive.states.len();
    // Rendered beside `out` and moved into place when complete; an earlier drive there is
    // replaced, anything else refused.
    let staging = StagingDir::new(out, |dir| sequence_dir(dir).join("scenario.toml").exists())?;
    let start = std::time::Instant::now();
    write_drive(scenario, &path, &drive, seed, staging.path(), progress)
        .with_context(|| format!("rendering into {}", out.display()))?;
    staging.commit()?;
    Ok(Summary {
        frames: n,
        distance_m: drive.distance_m,
        render_s: start.elapsed().as_secs_f64(),
    })
}
