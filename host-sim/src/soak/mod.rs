//! `roadvo soak`: an hour of driving (36,000 frames at 10 frames/s) through one odometer, to
//! show that nothing in it grows, wraps or slows down, and what its `f32` pose loses to
//! rounding.
//!
//! The frames are one lap of a ring road replayed ([`course`]: why that is honest). The run
//! ([`soak`]) keeps each frame's time in `process()` and its tracking counts, composes the
//! odometer's motions again in `f64` ([`rounding`]) and compares the end with the ground truth;
//! [`Soak::report`] sums it up.
//!
//! What the core could grow or wrap: it has no allocator, so its state is `size_of::<Odometer>()`
//! bytes whatever the run (reported); it keeps no frame counter; its timestamps are `u64`
//! microseconds (584,000 years to wrap) and only their differences are used; its small counters
//! (a track's age and misses, frames in a row that fell back) saturate.

pub mod course;
pub mod rounding;

use crate::path::WorldPose;
use crate::run::{BadFrames, run_frames};
use anyhow::{Result, ensure};
use course::Lap;
use roadvo::{Estimate, Odometer};
use rounding::{Bound, Gap, Reference};
use serde::Serialize;
use std::time::Duration;

/// An hour at 10 frames/s.
pub const HOUR_FRAMES: usize = 36_000;

/// Frames at each end of the run whose times and tracking are compared.
pub const WINDOW_FRAMES: usize = 1_000;

/// One frame of the run.
#[derive(Clone, Copy, Debug)]
struct FrameRecord {
    /// Time in `process()`.
    took: Duration,
    /// Tracks matched under the estimated motion.
    matched: u16,
    /// Whether the frame fell back to the previous motion.
    fallback: bool,
}

/// A finished soak run.
pub struct Soak {
    records: Vec<FrameRecord>,
    first_us: u64,
    last_us: u64,
    last: Estimate,
    reference: Reference,
    truth: WorldPose,
    distance_m: f64,
}

/// Runs `frames` frames of `lap`, the first at `start_us` microseconds, through a fresh
/// odometer with the lap's configuration; `progress` hears of each frame. Fails at the first
/// frame the odometer refuses.
pub fn soak(lap: &Lap, frames: usize, start_us: u64, mut progress: impl FnMut()) -> Result<Soak> {
    ensure!(frames >= 2, "a soak needs at least 2 frames");
    let replay = lap.replay(frames, start_us)?;
    let mut records = Vec::with_capacity(frames);
    let mut reference = Reference::new();
    let (mut first_us, mut last_us, mut last) = (None, 0, Estimate::default());
    run_frames(&replay, lap.config(), BadFrames::Stop, |_, e, t, took| {
        first_us.get_or_insert(t.total_micros());
        last_us = t.total_micros();
        reference.push(&e);
        records.push(FrameRecord {
            took,
            matched: e.quality.tracks_matched,
            fallback: e.quality.fallback,
        });
        last = e;
        progress();
        Ok(())
    })?
    .complete()?;
    let per_frame_m = lap.lap_m() / lap.frames() as f64;
    Ok(Soak {
        records,
        first_us: first_us.unwrap_or_default(),
        last_us,
        last,
        reference,
        truth: lap.truth(frames - 1),
        distance_m: (frames - 1) as f64 * per_frame_m,
    })
}

/// The median of `durations`, milliseconds.
fn median_ms(durations: impl Iterator<Item = Duration>) -> f64 {
    let mut ms: Vec<f64> = durations.map(|d| 1e3 * d.as_secs_f64()).collect();
    ms.sort_by(f64::total_cmp);
    match ms.len() {
        0 => 0.0,
        n if n % 2 == 1 => ms[n / 2],
        n => 0.5 * (ms[n / 2 - 1] + ms[n / 2]),
    }
}

impl Soak {
    /// Frames at each end that are compared: [`WINDOW_FRAMES`], or half the run if shorter.
    fn window(&self) -> usize {
        WINDOW_FRAMES.min(self.records.len() / 2)
    }

    /// The first and the last window's records (the first frame, which starts the trajectory,
    /// left out of the first).
    fn ends(&self) -> (&[FrameRecord], &[FrameRecord]) {
        let (n, w) = (self.records.len(), self.window());
        (&self.records[1..w], &self.records[n - w..])
    }

    /// The summary.
    pub fn report(&self, lap: &Lap) -> Report {
        let (first, last) = self.ends();
        let mean_matched = |r: &[FrameRecord]| {
            r.iter().map(|f| f64::from(f.matched)).sum::<f64>() / r.len().max(1) as f64
        };
        let first_ms = median_ms(first.iter().map(|f| f.took));
        let last_ms = median_ms(last.iter().map(|f| f.took));
        let frames = self.records.len();
        let fallbacks = self.records.iter().filter(|f| f.fallback).count();
        let truth = Gap::between(&self.last.pose, &self.truth);
        let course = lap.course();
        let camera = lap.config().config().camera;
        Report {
            frames,
            lap_frames: lap.frames(),
            laps: frames as f64 / lap.frames() as f64,
            camera: format!("{}x{}", camera.width_px, camera.height_px),
            ring_radius_m: lap.lap_m() / std::f64::consts::TAU,
            speed_m_s: course.speed_m_s,
            distance_m: self.distance_m,
            duration_s: (self.last_us - self.first_us) as f64 * 1e-6,
            timestamps: Timestamps {
                first_us: self.first_us,
                last_us: self.last_us,
                interval_us: lap.interval_us(),
                expected_last_us: self.first_us + (frames as u64 - 1) * lap.interval_us(),
            },
            timing: Timing {
                window_frames: self.window(),
                first_median_ms: first_ms,
                last_median_ms: last_ms,
                last_over_first: last_ms / first_ms,
            },
            counters: Counters {
                frames_processed: frames,
                fallbacks,
                fallback_fraction: fallbacks as f64 / frames as f64,
                mean_matched_first: mean_matched(first),
                mean_matched_last: mean_matched(last),
                last_tracks: self.last.quality.tracks,
                last_tracks_matched: self.last.quality.tracks_matched,
                last_features_detected: self.last.quality.features_detected,
                last_image_inliers: self.last.quality.image_inliers,
            },
            odometer_bytes: size_of::<Odometer>(),
            rounding: Rounding {
                end: self.reference.last_gap(),
                max: self.reference.max_gap(),
                bound: self.reference.bound(),
                heading_wraps: self.reference.wraps(),
                max_radius_m: self.reference.max_radius_m(),
            },
            truth: TruthError {
                position_m: truth.position_m,
                heading_deg: truth.heading_deg,
                position_pct: 100.0 * truth.position_m / self.distance_m,
            },
        }
    }
}

/// What a soak run showed.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Frames run.
    pub frames: usize,
    /// Frames in the lap replayed.
    pub lap_frames: usize,
    /// Laps driven.
    pub laps: f64,
    /// The frames' size, `WIDTHxHEIGHT` pixels.
    pub camera: String,
    /// The ring's radius, metres.
    pub ring_radius_m: f64,
    /// Speed, metres a second.
    pub speed_m_s: f64,
    /// Distance driven from the first frame to the last, metres.
    pub distance_m: f64,
    /// Time from the first frame to the last, seconds.
    pub duration_s: f64,
    /// The timestamps fed.
    pub timestamps: Timestamps,
    /// Time per frame at each end.
    pub timing: Timing,
    /// Frames, fallbacks and tracking.
    pub counters: Counters,
    /// `size_of::<Odometer>()`, bytes: the whole state, fixed by the type.
    pub odometer_bytes: usize,
    /// The `f32` pose against the same motions composed in `f64`.
    pub rounding: Rounding,
    /// The odometer's end pose against the ground truth.
    pub truth: TruthError,
}

/// The timestamps fed, microseconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Timestamps {
    /// The first frame's.
    pub first_us: u64,
    /// The last frame's.
    pub last_us: u64,
    /// Between frames.
    pub interval_us: u64,
    /// The last frame's if every interval was fed in full: `first + (frames - 1) interval`.
    pub expected_last_us: u64,
}

/// Wall-clock time in `process()` at each end of the run.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Timing {
    /// Frames at each end.
    pub window_frames: usize,
    /// Median over the first window (the first frame left out), milliseconds.
    pub first_median_ms: f64,
    /// Median over the last window, milliseconds.
    pub last_median_ms: f64,
    /// The last median over the first.
    pub last_over_first: f64,
}

/// Counts over the run and the last frame's quality.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Counters {
    /// Frames the odometer processed without error.
    pub frames_processed: usize,
    /// Frames that fell back to the previous motion.
    pub fallbacks: usize,
    /// `fallbacks` over the frames.
    pub fallback_fraction: f64,
    /// Mean tracks matched a frame over the first window (the first frame left out).
    pub mean_matched_first: f64,
    /// Mean tracks matched a frame over the last window.
    pub mean_matched_last: f64,
    /// Tracks held before the last frame's update.
    pub last_tracks: u16,
    /// Tracks matched in the last frame.
    pub last_tracks_matched: u16,
    /// Corners found in the ground window in the last frame.
    pub last_features_detected: u16,
    /// Whole-image pairs that held the last frame's heading.
    pub last_image_inliers: u16,
}

/// The rounding of the `f32` pose.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Rounding {
    /// The gap after the last frame.
    pub end: Gap,
    /// The largest gap of any frame.
    pub max: Gap,
    /// The worst case the run allows ([`rounding`] derives it).
    pub bound: Bound,
    /// Frames whose heading the core wrapped to [-pi, pi).
    pub heading_wraps: usize,
    /// Largest distance of the pose from the origin, metres.
    pub max_radius_m: f64,
}

/// The end pose's error against the ground truth.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TruthError {
    /// Position, metres.
    pub position_m: f64,
    /// Heading, degrees.
    pub heading_deg: f64,
    /// Position over the distance driven, percent.
    pub position_pct: f64,
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (t, c, r) = (&self.timestamps, &self.counters, &self.rounding);
        writeln!(
            f,
            "{} frames ({:.1} laps of {} frames) of {} on a ring of radius {:.2} m at {} m/s: \
             {:.1} km in {:.1} min",
            self.frames,
            self.laps,
            self.lap_frames,
            self.camera,
            self.ring_radius_m,
            self.speed_m_s,
            self.distance_m / 1e3,
            self.duration_s / 60.0
        )?;
        writeln!(
            f,
            "timestamps: first {} us, last {} us (first + {} x {} us: {}), every frame accepted",
            t.first_us,
            t.last_us,
            self.frames - 1,
            t.interval_us,
            if t.last_us == t.expected_last_us {
                "as fed, no wrap"
            } else {
                "NOT as fed"
            }
        )?;
        writeln!(
            f,
            "time per frame in process(), median: first {} frames {:.3} ms, last {} frames \
             {:.3} ms, last/first {:.3}",
            self.timing.window_frames,
            self.timing.first_median_ms,
            self.timing.window_frames,
            self.timing.last_median_ms,
            self.timing.last_over_first
        )?;
        writeln!(
            f,
            "counters: {} frames processed, {} fallbacks ({:.3} %); tracks matched a frame, \
             mean: first {:.1}, last {:.1}; last frame: {} tracks held, {} matched, {} corners, \
             {} image inliers",
            c.frames_processed,
            c.fallbacks,
            100.0 * c.fallback_fraction,
            c.mean_matched_first,
            c.mean_matched_last,
            c.last_tracks,
            c.last_tracks_matched,
            c.last_features_detected,
            c.last_image_inliers
        )?;
        writeln!(
            f,
            "state: size_of::<Odometer>() = {} bytes, fixed by the type (no allocator): it \
             cannot grow",
            self.odometer_bytes
        )?;
        writeln!(
            f,
            "f32 pose against the same motions composed in f64: at the end {:.3e} m, {:.3e} deg; \
             largest {:.3e} m, {:.3e} deg; worst-case bound {:.3} m, {:.3} deg ({} heading \
             wraps, pose within {:.1} m of the origin)",
            r.end.position_m,
            r.end.heading_deg,
            r.max.position_m,
            r.max.heading_deg,
            r.bound.position_m,
            r.bound.heading_deg,
            r.heading_wraps,
            r.max_radius_m
        )?;
        write!(
            f,
            "against the ground truth (context): at the end {:.3} m ({:.3} % of the distance), \
             {:.3} deg",
            self.truth.position_m, self.truth.position_pct, self.truth.heading_deg
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_of_odd_and_even_counts() {
        let ms = |v: &[u64]| median_ms(v.iter().map(|&m| Duration::from_millis(m)));
        assert_eq!(ms(&[3, 1, 2]), 2.0);
        assert_eq!(ms(&[4, 1, 2, 3]), 2.5);
        assert_eq!(ms(&[]), 0.0);
    }
}
