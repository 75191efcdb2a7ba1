//! `roadvo pack`.

use super::{SequenceArgs, bar};
use anyhow::Result;
use roadvo_sim::frame_store::{Limit, pack};
use roadvo_sim::interrupt;
use std::path::PathBuf;

/// Pack a sequence into the firmware example's frame store.
#[derive(clap::Args)]
pub struct PackArgs {
    #[command(flatten)]
    seq: SequenceArgs,
    /// Where to write the store.
    #[arg(long)]
    out: PathBuf,
    /// Frames from the start of the sequence, at least 1 (default: all).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// At most this many bytes: as many frames as a frame memory of this size holds (e.g.
    /// 16777216 for the firmware example's board).
    #[arg(long)]
    max_bytes: Option<usize>,
}

impl PackArgs {
    pub fn run(self) -> Result<()> {
        interrupt::install();
        self.seq.check_outputs(&[], &[("--out", &self.out)])?;
        let (seq, mount) = self.seq.open()?;
        let frames = self.frames.map(|n| n as usize);
        let n = frames.unwrap_or(seq.frames).min(seq.frames);
        let progress = bar(n, "packing", "frames");
        let limit = Limit {
            frames,
            bytes: self.max_bytes,
        };
        let packed = pack(&seq, &mount, self.seq.method, limit, &self.out, || {
            progress.inc(1)
        })?;
        progress.finish_and_clear();
        println!(
            "{} frames, rows {}..{} of each, {} bytes written to {}",
            packed.frames,
            packed.rows.start,
            packed.rows.end,
            packed.bytes,
            self.out.display()
        );
        Ok(())
    }
}
