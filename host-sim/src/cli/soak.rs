//! `roadvo soak`.

use super::{Bar, bar};
use anyhow::Result;
use roadvo_sim::soak::course::Course;
use roadvo_sim::soak::{HOUR_FRAMES, soak};

/// An hour of driving through one odometer: a lap of a ring road rendered once and replayed,
/// timestamps and ground truth moving on. Prints the time per frame at both ends, the counters,
/// the odometer's size and the f32 pose's rounding against f64.
#[derive(clap::Args)]
pub struct SoakArgs {
    /// Frames to run (36,000: an hour at 10 frames/s).
    #[arg(long, default_value_t = HOUR_FRAMES)]
    frames: usize,
    /// Frames a lap of the ring (its circumference is this many frames' travel).
    #[arg(long, default_value_t = Course::default().lap_frames)]
    lap_frames: usize,
    /// Speed, m/s.
    #[arg(long, default_value_t = Course::default().speed_m_s)]
    speed: f64,
    /// Divide kitti-like's camera (1241x376) by this: 2 gives 620x188.
    #[arg(long, default_value_t = 1)]
    downscale: u16,
    /// Seed of the texture and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The first frame's timestamp, microseconds.
    #[arg(long, default_value_t = 0)]
    start_us: u64,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

impl SoakArgs {
    pub fn run(self) -> Result<()> {
        let course = Course {
            lap_frames: self.lap_frames,
            speed_m_s: self.speed,
            downscale: self.downscale,
            seed: self.seed,
        };
        let rendering = Bar(bar(course.lap_frames, "rendering the lap", "frames"));
        let lap = course.render(&rendering)?;
        rendering.0.finish_and_clear();
        let progress = bar(self.frames, "soak", "frames");
        let run = soak(&lap, self.frames, self.start_us, || progress.inc(1))?;
        progress.finish_and_clear();
        let report = run.report(&lap);
        if self.json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            println!("{report}");
        }
        Ok(())
    }
}
