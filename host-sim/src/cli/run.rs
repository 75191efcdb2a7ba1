//! `roadvo run`.

use super::{SequenceArgs, bar};
use anyhow::{Result, bail};
use roadvo::AngleEstimate;
use roadvo_sim::eval::evaluate;
use roadvo_sim::interrupt;
use roadvo_sim::kitti::{Pose, read_poses};
use roadvo_sim::plot::{Track, check_format, plot_trajectories};
use roadvo_sim::pose_file::{PoseFormat, write_trajectory};
use roadvo_sim::run::{BadFrames, FrameSource, RunFiles, RunOutput, config_for, run};
use std::path::{Path, PathBuf};

/// Run the odometer over a sequence (a KITTI folder, a folder of frames or a video) and write
/// its trajectory.
#[derive(clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    seq: SequenceArgs,
    /// Where to write the estimated camera-0 poses, in camera 0's frame at the first frame:
    /// KITTI (12 numbers a line) or, for a `.tum` file, TUM (`timestamp tx ty tz qx qy qz qw`).
    #[arg(long)]
    out: PathBuf,
    /// The format of --out, whatever its extension.
    #[arg(long, value_enum)]
    format: Option<PoseFormat>,
    /// Write each frame's estimate and quality (vehicle frame): JSON lines, or CSV with a
    /// header for a `.csv` file.
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
    /// Leave out frames that cannot be read or that the odometer refuses, and carry on (the
    /// odometer sees a longer interval, as for a dropped frame; their poses are interpolated).
    /// Without it a run stops at such a frame and writes what it has, as a partial result.
    #[arg(long)]
    skip_bad_frames: bool,
    /// Write the mount as the odometer learned it while driving (`learn_yaw`, `learn_pitch`,
    /// `learn_roll`, `learn_x`): the mount file with its yaw, pitch and roll turned and its
    /// camera moved ahead by the learned corrections, the rest as given.
    #[arg(long)]
    learned_mount: Option<PathBuf>,
}

impl RunArgs {
    pub fn run(self) -> Result<()> {
        interrupt::install();
        self.check_outputs()?;
        let (seq, mount) = self.seq.open()?;
        let config = config_for(&seq, &mount, self.seq.method)?;
        let files = RunFiles {
            quality: self.quality.as_deref(),
            trace: self.trace.as_deref(),
        };
        let bad = if self.skip_bad_frames {
            BadFrames::Skip
        } else {
            BadFrames::Stop
        };
        let progress = bar(seq.frames, "odometry", "frames");
        let output = run(&seq, config, &files, bad, || progress.inc(1))?;
        progress.finish_and_clear();
        for s in &output.ran.skipped {
            eprintln!("frame {:06} left out: {:#}", s.frame, s.cause);
        }
        if output.poses.is_empty() {
            let why = output
                .ran
                .stopped
                .map(|s| format!("frame {:06}: {:#}", s.frame, s.cause));
            bail!(
                "no frame was run, nothing written ({})",
                why.unwrap_or_default()
            );
        }
        let first = output.first_frame();
        let times_s: Vec<f64> = (first..first + output.poses.len())
            .map(|i| seq.time_s(i))
            .collect();
        let format = PoseFormat::for_output(&self.out, self.format);
        write_trajectory(&self.out, format, &output.poses, &times_s)?;
        print_summary(&output, &self.out);
        if let Some(p) = &self.learned_mount {
            let c = &output.ran.calibration;
            let l = output.ran.learned;
            let mut learned = mount;
            let rad = |e: Option<AngleEstimate>| e.map_or(0.0, |e| e.rad);
            learned.mount.yaw_rad += rad(l.yaw);
            learned.mount.pitch_rad += rad(l.pitch);
            learned.mount.roll_rad += rad(l.roll);
            let x_m = l.x_m.map_or(0.0, |(m, _)| m);
            learned.mount.x_m += x_m;
            let note = format!(
                "# Learned by `roadvo run` over {:.0} m of {}: yaw {:+.3} deg, pitch {:+.3} \
                 deg, roll {:+.3} deg, x {:+.3} m from the mount file's.\n",
                c.distance_m,
                self.seq.seq_dir.display(),
                rad(l.yaw).to_degrees(),
                rad(l.pitch).to_degrees(),
                rad(l.roll).to_degrees(),
                x_m
            );
            // [camera] where the sequence has no calib.txt to give it (a video, a folder of
            // frames): the file must stand for it as the one given did.
            learned.write(p, seq.p0.is_none(), &note)?;
            println!("learned mount written to {}", p.display());
        }
        // Not after a Ctrl-C: the user asked to stop.
        if let Some(p) = self.plot.as_ref().filter(|_| interrupt::check().is_ok()) {
            self.plot(p, &output.poses)?;
        }
        if let Some(s) = output.ran.stopped {
            bail!(
                "stopped at frame {:06} of {}: {:#}\nthe outputs are partial: they hold frames \
                 000000 to {:06}",
                s.frame,
                seq.frames,
                s.cause,
                output.poses.len() - 1
            );
        }
        Ok(())
    }

    /// Refuses, before any work, outputs that would overwrite an input or each other, that
    /// cannot be written, and a plot in an unknown format.
    fn check_outputs(&self) -> Result<()> {
        let gt: Vec<PathBuf> = ground_truth_for(&self.seq.seq_dir).into_iter().collect();
        let mut outputs = vec![("--out", self.out.as_path())];
        outputs.extend(self.quality.as_deref().map(|p| ("--quality", p)));
        outputs.extend(self.trace.as_deref().map(|p| ("--trace", p)));
        outputs.extend(self.plot.as_deref().map(|p| ("--plot", p)));
        outputs.extend(
            self.learned_mount
                .as_deref()
                .map(|p| ("--learned-mount", p)),
        );
        if let Some(p) = &self.plot {
            check_format(p)?;
        }
        self.seq.check_outputs(&gt, &outputs)
    }

    /// Draws the trajectory, with the ground truth beside the sequence if there is one.
    fn plot(&self, p: &Path, poses: &[Pose]) -> Result<()> {
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
            poses,
        });
        let report = gt_poses
            .as_deref()
            .map(|g| evaluate(g, poses))
            .transpose()?;
        let title = self.seq.seq_dir.display().to_string();
        plot_trajectories(p, &title, &tracks, report.as_ref())?;
        println!("plot written to {}", p.display());
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
         single-threaded), decoding {:.1} ms a frame; trajectory written to {}",
        run.fallbacks(),
        1e3 * run.ran.timing.odometry.as_secs_f64() / n.max(1) as f64,
        run.frames_per_s(),
        1e3 * run.ran.timing.decode.as_secs_f64() / n.max(1) as f64,
        out.display()
    );
    let c = &run.ran.calibration;
    let deg = |e: AngleEstimate| {
        format!(
            "{:+.3} deg (+-{:.3})",
            e.rad.to_degrees(),
            e.sd_rad.to_degrees()
        )
    };
    // The yaw with the camera's turn about the vertical each kind of evidence shows (the yaw
    // and the roll's share of it): where the two disagree, the road's plane (a rolled mount, a
    // banked road) is what the ground's step leans on.
    let l = run.ran.learned;
    let yaw = l.yaw.map(|e| {
        let sources: Vec<String> = [("ground", &c.yaw_ground), ("image", &c.yaw_image)]
            .into_iter()
            .filter_map(|(source, s)| s.estimate().map(|e| format!("{source} {}", deg(e))))
            .collect();
        format!("yaw {} [turn: {}]", deg(e), sources.join("; "))
    });
    let pitch = l.pitch.map(|e| format!("pitch {}", deg(e)));
    let roll = l.roll.map(|e| format!("roll {}", deg(e)));
    let x = l.x_m.map(|(m, sd)| format!("x {m:+.3} m (+-{sd:.3})"));
    let learned: Vec<String> = [yaw, pitch, roll, x].into_iter().flatten().collect();
    if !learned.is_empty() {
        println!(
            "learned mount: {} from the mount file's, over {:.0} m of road",
            learned.join(", "),
            c.distance_m
        );
    }
}
