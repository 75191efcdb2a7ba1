//! The subcommands, one module each, and what they share: the sequence and mount arguments, the
//! progress bars.

mod bench;
mod calibrate;
mod demo;
mod eval;
mod export;
mod pack;
mod run;
mod sensitivity;
mod simulate;
mod soak;
mod view;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use roadvo::Method;
use roadvo_sim::kitti::Sequence;
use roadvo_sim::kitti::image_path;
use roadvo_sim::layout::{self, FrameTimes, inputs_of};
use roadvo_sim::mount::MountFile;
use roadvo_sim::mount::camera_of_sequence;
use roadvo_sim::output::check_outputs;
use roadvo_sim::run::{config_for, mount_for};
use std::path::{Path, PathBuf};

/// The command line.
#[derive(Parser)]
#[command(
    name = "roadvo",
    version,
    about = "Monocular visual odometry for road vehicles"
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// Render a synthetic drive with exact ground truth, in KITTI layout.
    Simulate(simulate::SimulateArgs),
    /// Compare an estimated trajectory with ground truth (KITTI or TUM pose files): the KITTI
    /// metric, evo's APE and RPE.
    Eval(eval::EvalArgs),
    /// Run the odometer over a sequence (a KITTI folder, a folder or glob of PNG/JPEG frames, or
    /// a video file) and write its trajectory.
    Run(run::RunArgs),
    /// Refine the mount (pitch, yaw, roll, height, offset ahead of the rear axle) so that the
    /// odometry over a section with ground truth matches it.
    Calibrate(calibrate::CalibrateArgs),
    /// Pack a sequence into the firmware example's frame store (the configuration and the rows
    /// the odometer reads).
    Pack(pack::PackArgs),
    /// Write a mount file's whole configuration as a Rust `const` or a C array for a firmware
    /// (checked as `run` checks it).
    ExportConfig(export::ExportArgs),
    /// Time the odometry alone on a sequence: frames preloaded, one thread, both methods.
    Bench(bench::BenchArgs),
    /// The paper's sensitivity study on the s-course: +1 deg of roll, pitch, yaw and +10 cm of
    /// each offset in the mount file, a kerb and crowned roads; both methods beside the paper,
    /// and the mount the pitch vote learned in each case.
    Sensitivity(sensitivity::SensitivityArgs),
    /// Render the paper's s-course, run both methods, evaluate, and plot: the default demo.
    Demo(demo::DemoArgs),
    /// Write what the odometer sees, frame by frame: the ground window, the tracks by fate, a
    /// bird's-eye view and the frame's quality (and a video where ffmpeg is installed).
    View(view::ViewArgs),
    /// An hour of driving (36,000 frames) through one odometer: time per frame at both ends,
    /// counters, the odometer's size, the f32 pose's rounding.
    Soak(soak::SoakArgs),
}

impl Command {
    /// Runs the subcommand.
    pub fn run(self) -> Result<()> {
        match self {
            Self::Simulate(a) => a.run(),
            Self::Eval(a) => a.run(),
            Self::Run(a) => a.run(),
            Self::Calibrate(a) => a.run(),
            Self::Pack(a) => a.run(),
            Self::ExportConfig(a) => a.run(),
            Self::Bench(a) => a.run(),
            Self::Sensitivity(a) => a.run(),
            Self::Demo(a) => a.run(),
            Self::View(a) => a.run(),
            Self::Soak(a) => a.run(),
        }
    }
}

/// A sequence (KITTI folder, folder or glob of frames, or video) and the mount to run it with.
#[derive(clap::Args)]
pub struct SequenceArgs {
    /// The sequence: a KITTI sequence folder (image_0/, times.txt, calib.txt), a folder or a
    /// quoted glob of PNG/JPEG frames ('drive/*.jpg', in natural order; timed by --times or
    /// --fps), or a video file (read through ffmpeg, timed by its container).
    pub seq_dir: PathBuf,
    /// Mount file (default: SEQ_DIR/mount.toml for a KITTI folder; required for the others,
    /// with [camera]); without [camera] it takes calib.txt's camera, with one it must agree.
    #[arg(long)]
    pub mount: Option<PathBuf>,
    /// Timestamps of a folder of frames: seconds, one a line (like KITTI's times.txt).
    #[arg(long, value_name = "FILE", conflicts_with = "fps")]
    pub times: Option<PathBuf>,
    /// Frame rate of a folder of frames: frame i at i/N seconds.
    #[arg(long, value_name = "N")]
    pub fps: Option<f64>,
    /// Override the mount file's method: pitch-vote or paper.
    #[arg(long, value_parser = parse_method)]
    pub method: Option<Method>,
    /// Change one value of the mount file, as its line would: KEY=VALUE in [odometer], or
    /// SECTION.KEY=VALUE (e.g. `--set max_roll_change_steps=0 --set mount.yaw_deg=-0.25`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub settings: Vec<String>,
}

impl SequenceArgs {
    /// Refuses, before any work, `outputs` (each with its option) that would overwrite the
    /// sequence's files (`extra_inputs` besides), each other, or cannot be written.
    pub fn check_outputs(&self, extra_inputs: &[PathBuf], outputs: &[(&str, &Path)]) -> Result<()> {
        let dir = &self.seq_dir;
        let mount = self.mount.clone().unwrap_or_else(|| dir.join("mount.toml"));
        let (mut inputs, dirs) = inputs_of(dir);
        inputs.push(mount);
        inputs.extend(self.times.clone());
        inputs.extend_from_slice(extra_inputs);
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        let dirs: Vec<&Path> = dirs.iter().map(PathBuf::as_path).collect();
        check_outputs(&inputs, &dirs, outputs)
    }

    /// Opens the sequence, whatever its layout, and reads its mount file, with the `--set`
    /// changes, and checks the configuration they make; a refusal names the mount file, and
    /// `calib.txt` and the first frame where the camera comes from them.
    pub fn open(&self) -> Result<(Sequence, MountFile)> {
        let times = FrameTimes {
            file: self.times.clone(),
            fps: self.fps,
        };
        let seq = layout::open(&self.seq_dir, &times)?;
        let mut mount = mount_for(&seq, self.mount.as_deref())?;
        for s in &self.settings {
            mount.set(s)?;
        }
        config_for(&seq, &mount, self.method).with_context(|| {
            let path = self
                .mount
                .clone()
                .unwrap_or_else(|| self.seq_dir.join("mount.toml"));
            let mut what = format!("the configuration of {}", path.display());
            if camera_of_sequence(&seq).is_ok_and(|c| c == mount.camera) {
                let calib = self.seq_dir.join("calib.txt");
                let first = image_path(&self.seq_dir, 0);
                what += &format!(
                    " with the camera of {} and the size of {}",
                    calib.display(),
                    first.display()
                );
            }
            what
        })?;
        Ok((seq, mount))
    }
}

/// A method by its name in a mount file.
pub fn parse_method(name: &str) -> Result<Method, String> {
    Method::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        format!("{name:?} is not a method: {}", names.join(" or "))
    })
}

/// A progress bar of `len` steps, labelled `what` (`{pos}/{len}` of `unit`).
pub fn bar(len: usize, what: &str, unit: &str) -> ProgressBar {
    ProgressBar::new(len as u64).with_style(
        ProgressStyle::with_template(&format!(
            "{what} {{bar:40}} {{pos}}/{{len}} {unit}, eta {{eta}}"
        ))
        .expect("valid template"),
    )
}

/// A progress bar that hears of the library's long work.
pub struct Bar(pub ProgressBar);

impl roadvo_sim::Progress for Bar {
    fn start(&self, total: usize) {
        self.0.set_length(total as u64);
    }

    fn step(&self) {
        self.0.inc(1);
    }
}
