//! `roadvo run`.

use super::{SequenceArgs, bar};
use anyhow::Result;
use roadvo_sim::eval::evaluate;
use roadvo_sim::kitti::{read_poses, write_poses};
use roadvo_sim::plot::{Track, plot_trajectories};
use roadvo_sim::run::{RunFiles, RunOutput, config_for, run};
use std::path::{Path, PathBuf};

/// Run the odometer over a KITTI-layout sequence and write its trajectory.
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    seq: SequenceArgs,
    /// Where to write the estimated camera-0 poses (KITTI format).
    #[arg(long)]
    out: PathBuf,
    /// Write each frame's estimate and quality as JSON lines.
    #[arg(long)]
    quality: Option<PathBuf>,
    /// Draw the trajectory (with ground truth from SEQ_DIR/../../poses/NN.txt if present).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write each frame's estimate as the f32 bit patterns the firmware example logs, for a
    /// bit-for-bit comparison with it (scripts/firmware); with a smoother
    /// (`smooth_lag_frames`), each smoothed estimate too, as `smoothed` lines.
    #[arg(long)]
    trace: Option<PathBuf>,
}

impl RunArgs {
    pub fn run(self) -> Result<()> {
        let (seq, mount) = self.seq.open()?;
        let config = config_for(&seq, &mount, self.seq.method)?;
        let files = RunFiles {
            quality: self.quality.as_deref(),
            trace: self.trace.as_deref(),
        };
        let progress = bar(seq.frames, "odometry", "frames");
        let output = run(&seq, config, &files, || progress.inc(1))?;
        progress.finish_and_clear();
        write_poses(&self.out, &output.poses)?;
        print_summary(&output, &self.out);
        if let Some(p) = self.plot {
            let gt = ground_truth_for(&self.seq.seq_dir).filter(|g| g.exists());
            let gt_poses = gt.as_deref().map(read_poses).transpose()?;
            let mut tracks = Vec::new();
            if let Some(g) = gt_poses.as_deref() {
                tracks.push(Track {
                    label: "ground truth",
                    poses: g,
                });
            }
            tracks.push(Track {
                label: "estimate",
                poses: &output.poses,
            });
            let report = gt_poses
                .as_deref()
                .map(|g| evaluate(g, &output.poses))
                .transpose()?;
            let title = self.seq.seq_dir.display().to_string();
            plot_trajectories(&p, &title, &tracks, report.as_ref())?;
            println!("plot written to {}", p.display());
        }
        Ok(())
    }
}

/// The ground truth beside a KITTI sequence folder: `SEQ/../../poses/NN.txt`.
fn ground_truth_for(seq_dir: &Path) -> Option<PathBuf> {
    let name = seq_dir.canonicalize().ok()?.file_name()?.to_owned();
    let root = seq_dir.canonicalize().ok()?.parent()?.parent()?.to_owned();
    Some(root.join("poses").join(name).with_extension("txt"))
}

fn print_summary(run: &RunOutput, out: &Path) {
    let n = run.estimates.len();
    let smoothing = match run.smooth_lag_frames {
        0 => String::new(),
        lag => format!(", heading smoothed over +-{lag} frames"),
    };
    println!(
        "{n} frames, {} fallbacks{smoothing}; odometry {:.1} ms ({:.0} frames/s \
         single-threaded), PNG decoding {:.1} ms a frame; trajectory written to {}",
        run.fallbacks(),
        1e3 * run.timing.odometry.as_secs_f64() / n.max(1) as f64,
        run.frames_per_s(),
        1e3 * run.timing.decode.as_secs_f64() / n.max(1) as f64,
        out.display()
    );
}
