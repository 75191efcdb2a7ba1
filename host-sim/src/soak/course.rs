//! The soak's course: a ring road driven lap after lap, one lap rendered and replayed.
//!
//! An hour at 10 frames/s is 36,000 frames and 36 km of road: rendered at KITTI's size that is
//! over an hour of ray casting and 17 GB of frames. A ring is the cheapest honest route round
//! it: one circular arc of 360 degrees, driven at constant speed, whose circumference is a whole
//! number of frames' travel ([`Course::lap_frames`]). Frame `i` of every lap then sees the scene
//! from exactly the same world pose as frame `i` of the first lap, so it *is* the same image,
//! and the lap is rendered once and replayed from memory ([`Replay`]): the frame after the
//! lap's last is the lap's first, one frame's arc further on, so the odometer sees one
//! continuous drive round and round. What moves on is everything the odometer is told or
//! keeps: the timestamps (one frame interval apart from the first to the last frame), its pose
//! (the truth's heading grows by a full turn a lap, [`Lap::truth`]), its tracks and its
//! estimates of the body's attitude. What repeats and would not on a real road: the texture
//! and the sensor noise are the same each lap (the noise is drawn per rendered frame).
//!
//! The camera and mount are `kitti-like`'s, or that camera scaled down by a whole factor
//! ([`Course::downscale`]: 2 gives 620x188, which the odometer still tracks with the default
//! settings and runs faster), with no suspension motion and no traffic, and the odometer's
//! default settings with the true mount.

use crate::Progress;
use crate::path::{Path, Segment, SpeedKnot, WorldPose};
use crate::run::{FrameSource, config_error};
use crate::scenario::Scenario;
use crate::simulate::plan;
use anyhow::{Context, Result, bail, ensure};
use image::GrayImage;
use rayon::prelude::*;
use roadvo::{Camera, Instant, ValidConfig};
use std::borrow::Cow;
use std::f64::consts::TAU;

/// The ring and how it is seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Course {
    /// Frames a lap: the ring's circumference is this many frames' travel (250: 25 s a lap at
    /// 10 frames/s; 1,000 frames, the span the soak compares, are four laps).
    pub lap_frames: usize,
    /// Speed, metres a second (10: 36 km in the hour).
    pub speed_m_s: f64,
    /// `kitti-like`'s camera with its size and focal lengths divided by this (1: KITTI's
    /// 1241x376).
    pub downscale: u16,
    /// Seed of the texture and the noise.
    pub seed: u64,
}

impl Default for Course {
    fn default() -> Self {
        Self {
            lap_frames: 250,
            speed_m_s: 10.0,
            downscale: 1,
            seed: 1,
        }
    }
}

/// `camera` with its size and focal lengths divided by `factor`, the principal point moved so
/// that it stays over the same point of the scene (pixel centres at whole numbers).
fn scaled(camera: Camera, factor: u16) -> Camera {
    let f = f32::from(factor);
    let centre = |c: f32| (c + 0.5) / f - 0.5;
    Camera {
        width_px: camera.width_px / factor,
        height_px: camera.height_px / factor,
        fx_px: camera.fx_px / f,
        fy_px: camera.fy_px / f,
        cx_px: centre(camera.cx_px),
        cy_px: centre(camera.cy_px),
        // Coefficients of normalised coordinates: the same at any scale.
        ..camera
    }
}

impl Course {
    /// The ring as a scenario: `kitti-like`'s frame rate, camera (scaled) and mount, one arc of
    /// 360 degrees, one speed.
    pub fn scenario(&self) -> Result<Scenario> {
        ensure!(self.lap_frames >= 2, "a lap needs at least 2 frames");
        ensure!(
            self.downscale >= 1,
            "the downscale factor must be at least 1"
        );
        ensure!(
            self.speed_m_s.is_finite() && self.speed_m_s > 0.0,
            "the speed must be positive"
        );
        let mut s = Scenario::built_in("kitti-like")?;
        s.name = "soak-ring".into();
        s.camera = scaled(s.camera, self.downscale);
        let lap_m = self.lap_frames as f64 * self.speed_m_s / s.frames_per_second;
        s.segments = vec![Segment::Arc {
            radius_m: lap_m / TAU,
            angle_deg: 360.0,
        }];
        s.speed = vec![SpeedKnot {
            at_m: 0.0,
            speed_m_s: self.speed_m_s,
        }];
        Ok(s)
    }

    /// Renders one lap (in parallel); `progress` hears of each frame.
    pub fn render(&self, progress: &dyn Progress) -> Result<Lap> {
        let scenario = self.scenario()?;
        let config = scenario
            .mount_file(false)
            .to_config()
            .validate()
            .map_err(config_error)
            .context("the soak's camera and mount")?;
        let interval_us = (1e6 / scenario.frames_per_second).round() as u64;
        let path = Path::new(&scenario.segments)?;
        let drive = plan(&scenario, &path, Some(self.lap_frames), self.seed)?;
        let scene = crate::render::Scene::new(&scenario, &path, self.seed);
        progress.start(self.lap_frames);
        let images = drive
            .states
            .par_iter()
            .enumerate()
            .map(|(i, st)| {
                let img = scene.render(st, i as u64);
                progress.step();
                img
            })
            .collect();
        Ok(Lap {
            course: *self,
            config,
            interval_us,
            images,
            truth: drive.states.iter().map(|st| st.pose).collect(),
            lap_m: path.length_m(),
        })
    }
}

/// One rendered lap of the ring: its frames, their true poses and the odometer's
/// configuration.
pub struct Lap {
    course: Course,
    config: ValidConfig,
    interval_us: u64,
    images: Vec<GrayImage>,
    /// The vehicle's pose at each frame, in the vehicle frame of the first (the path's origin).
    truth: Vec<WorldPose>,
    lap_m: f64,
}

impl Lap {
    /// The course it was rendered for.
    pub fn course(&self) -> &Course {
        &self.course
    }

    /// The odometer's configuration: the true mount, the default settings.
    pub fn config(&self) -> ValidConfig {
        self.config
    }

    /// Frames in the lap.
    pub fn frames(&self) -> usize {
        self.images.len()
    }

    /// Time between frames, microseconds.
    pub fn interval_us(&self) -> u64 {
        self.interval_us
    }

    /// The ring's circumference, metres.
    pub fn lap_m(&self) -> f64 {
        self.lap_m
    }

    /// Frame `i` of the lap.
    pub fn image(&self, i: usize) -> &GrayImage {
        &self.images[i]
    }

    /// The true pose at frame `j` of the replay, in the vehicle frame of its first frame; the
    /// heading unwrapped (a full turn more each lap).
    pub fn truth(&self, j: usize) -> WorldPose {
        let n = self.frames();
        let p = self.truth[j % n];
        WorldPose {
            heading_rad: p.heading_rad + TAU * (j / n) as f64,
            ..p
        }
    }

    /// `frames` frames of the lap, round and round, the first at `start_us` microseconds.
    pub fn replay(&self, frames: usize, start_us: u64) -> Result<Replay<'_>> {
        let span = (frames.saturating_sub(1) as u64).checked_mul(self.interval_us);
        if span.and_then(|s| s.checked_add(start_us)).is_none() {
            bail!("{frames} frames from {start_us} us run past the clock's end");
        }
        Ok(Replay {
            lap: self,
            frames,
            start_us,
        })
    }
}

/// A lap replayed: frame `j` is the lap's frame `j % lap frames`, taken at `start_us + j`
/// intervals.
pub struct Replay<'a> {
    lap: &'a Lap,
    frames: usize,
    start_us: u64,
}

impl Replay<'_> {
    /// Frame `j`'s timestamp.
    pub fn timestamp(&self, j: usize) -> Instant {
        Instant::from_micros(self.start_us + j as u64 * self.lap.interval_us)
    }
}

impl FrameSource for Replay<'_> {
    fn len(&self) -> usize {
        self.frames
    }

    fn frame(&self, i: usize) -> Result<(Cow<'_, GrayImage>, Instant)> {
        ensure!(i < self.frames, "no frame {i}");
        let img = self.lap.image(i % self.lap.frames());
        Ok((Cow::Borrowed(img), self.timestamp(i)))
    }

    fn time_s(&self, i: usize) -> f64 {
        self.timestamp(i).total_micros() as f64 * 1e-6
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ring_closes_after_a_whole_number_of_frames() {
        let course = Course::default();
        let s = course.scenario().unwrap();
        let path = Path::new(&s.segments).unwrap();
        let d = course.speed_m_s / s.frames_per_second;
        assert!((path.length_m() - course.lap_frames as f64 * d).abs() < 1e-9);
        // The pose one frame after the lap's last is the first one's, a turn on.
        let end = path.pose_at(path.length_m());
        assert!(end.x_m.abs() < 1e-9 && end.y_m.abs() < 1e-9, "{end:?}");
        assert!((end.heading_rad - TAU).abs() < 1e-9, "{end:?}");
    }

    #[test]
    fn a_scaled_camera_sees_the_same_rays() {
        let k = Scenario::built_in("kitti-like").unwrap().camera;
        let half = scaled(k, 2);
        assert_eq!((half.width_px, half.height_px), (620, 188));
        // The centre of the full image's pixels (0, 0) and (1, 1) is the half image's (0, 0).
        let ray = |c: &Camera, u: f32| (u - c.cx_px) / c.fx_px;
        assert!((ray(&k, 0.5) - ray(&half, 0.0)).abs() < 1e-6);
        assert_eq!(scaled(k, 1), k);
    }
}
