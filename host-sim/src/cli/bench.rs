//! `roadvo bench`.

use super::SequenceArgs;
use anyhow::Result;
use roadvo::Method;
use roadvo_sim::run::{FrameSource, Preloaded, bench, config_for};

/// Time the odometry alone on a sequence: frames preloaded, one thread, both methods.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// The sequence and mount; with `--method` only that method (default: both).
    #[command(flatten)]
    seq: SequenceArgs,
    /// Frames from the start of the sequence (at least 1).
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Times to run the frames (at least 1).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    repeats: u32,
}

impl BenchArgs {
    pub fn run(self) -> Result<()> {
        let (seq, mount) = self.seq.open()?;
        let methods = match self.seq.method {
            Some(m) => vec![m],
            None => Method::ALL.to_vec(),
        };
        let frames = Preloaded::load(&seq, 0..self.frames as usize)?;
        println!(
            "{} frames of {}x{} from {}, {} runs, one thread, frames preloaded",
            frames.len(),
            seq.size.0,
            seq.size.1,
            self.seq.seq_dir.display(),
            self.repeats
        );
        for m in methods {
            let b = bench(
                &frames,
                config_for(&seq, &mount, Some(m))?,
                self.repeats as usize,
            )?;
            let (lo, mid, hi) = b.spread_ms();
            println!(
                "{:>10}: {:.0} frames/s; per frame min {lo:.2} ms, median {mid:.2} ms, max {hi:.2} ms",
                m.name(),
                b.frames_per_s()
            );
        }
        Ok(())
    }
}
