//! `roadvo`: the command line. Each subcommand parses its arguments, calls into the library and
//! prints what it did.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use roadvo_sim::calibrate::{Metric, calibrate};
use roadvo_sim::eval::{Report, evaluate, evaluate_planar, format_report};
use roadvo_sim::frame_store::pack;
use roadvo_sim::kitti::Sequence;
use roadvo_sim::kitti::{Pose, read_poses, write_poses};
use roadvo_sim::mount::{MethodName, MountFile};
use roadvo_sim::plot::{Track, plot_trajectories};
use roadvo_sim::run::{RunOutput, bench_sequence, mount_for, run_sequence};
use roadvo_sim::scenario::{BUILT_IN, Scenario};
use roadvo_sim::sensitivity::{format_rows, sensitivity};
use roadvo_sim::simulate::{poses_path, sequence_dir, simulate};
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "roadvo",
    version,
    about = "Monocular visual odometry for road vehicles"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a synthetic drive with exact ground truth, in KITTI layout.
    Simulate {
        /// A built-in scenario (s-course, kitti-like) or a scenario TOML file.
        #[arg(long, default_value = "s-course")]
        scenario: String,
        /// Partial scenarios merged over it, in order: built-in (suspension, traffic, slip) or files.
        #[arg(long)]
        overlay: Vec<String>,
        /// Output folder: OUT/sequences/00/..., OUT/poses/00.txt.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the texture, noise and suspension phases.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Render only the first N frames (default: until the path ends).
        #[arg(long)]
        frames: Option<usize>,
        /// Print the scenario as TOML (a starting point for your own) instead of rendering.
        #[arg(long)]
        print_scenario: bool,
    },
    /// Compare an estimated trajectory with ground truth (KITTI pose files).
    Eval {
        /// Ground-truth poses.
        gt: PathBuf,
        /// Estimated poses.
        est: PathBuf,
        /// Print one JSON object instead of the table.
        #[arg(long)]
        json: bool,
        /// Draw the top view and the error per segment length (.png or .svg).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Also score both trajectories in the ground plane only (x-z positions and heading),
        /// and report the ground truth's planar floors: the first camera level, and in the
        /// estimate's own ground plane.
        #[arg(long)]
        planar: bool,
    },
    /// Run the odometer over a KITTI-layout sequence and write its trajectory.
    Run {
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
    },
    /// Refine the mount (pitch, yaw, roll, height, offset ahead of the rear axle) so that the
    /// odometry over a section with ground truth matches it.
    Calibrate {
        #[command(flatten)]
        seq: SequenceArgs,
        /// Ground-truth poses of the sequence (KITTI format).
        #[arg(long)]
        gt: PathBuf,
        /// The section, frames A..B (default: the whole sequence).
        #[arg(long, value_parser = parse_frames)]
        frames: Option<std::ops::Range<usize>>,
        /// Where to write the refined mount file (without [camera]: each sequence's calibration
        /// supplies it).
        #[arg(long)]
        out: PathBuf,
        /// Most mounts tried (each costs five odometry runs over the section, at heights -2..+2 mm).
        #[arg(long, default_value_t = 150)]
        max_runs: usize,
        /// What a mount is scored on: segments of 10..50 m (short) or KITTI's 100..800 m
        /// (kitti, for a section of 100 m or more).
        #[arg(long, value_enum, default_value_t = Metric::Short)]
        metric: Metric,
    },
    /// Pack a sequence into the firmware example's frame store (the rows the odometer reads).
    Pack {
        #[command(flatten)]
        seq: SequenceArgs,
        /// Where to write the store.
        #[arg(long)]
        out: PathBuf,
        /// Frames from the start of the sequence (default: all).
        #[arg(long)]
        frames: Option<usize>,
    },
    /// Time the odometry alone on a sequence: frames preloaded, one thread, both methods.
    Bench {
        /// The sequence and mount; with `--method` only that method (default: both).
        #[command(flatten)]
        seq: SequenceArgs,
        /// Frames from the start of the sequence.
        #[arg(long, default_value_t = 300)]
        frames: usize,
        /// Times to run the frames.
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// The paper's sensitivity study on the s-course: +1 deg of roll, pitch, yaw and +10 cm of
    /// each offset in the mount file, a kerb and crowned roads; both methods beside the paper.
    Sensitivity {
        /// Folder to render into (default: a temporary folder, removed afterwards); drives
        /// already there are reused.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the texture and noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Render only the first N frames of each drive (default: the whole course).
        #[arg(long)]
        frames: Option<usize>,
        /// Change one value of every case's mount file (after the case's own change), as its
        /// line would: KEY=VALUE in [odometer], or SECTION.KEY=VALUE.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        settings: Vec<String>,
    },
    /// Render the paper's s-course, run both methods, evaluate, and plot: the default demo.
    Demo {
        /// Folder to render into (default: a temporary folder, removed afterwards).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the texture, noise and suspension phases.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

/// A KITTI-layout sequence and the mount to run it with.
#[derive(clap::Args)]
struct SequenceArgs {
    /// The sequence folder (holding image_0/, times.txt, calib.txt).
    seq_dir: PathBuf,
    /// Mount file (default: SEQ_DIR/mount.toml); without [camera] it takes the sequence's.
    #[arg(long)]
    mount: Option<PathBuf>,
    /// Override the mount file's method.
    #[arg(long, value_enum)]
    method: Option<MethodName>,
    /// Change one value of the mount file, as its line would: KEY=VALUE in [odometer], or
    /// SECTION.KEY=VALUE (e.g. `--set max_roll_change_steps=0 --set mount.yaw_deg=-0.25`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    settings: Vec<String>,
}

impl SequenceArgs {
    /// Opens the sequence and reads its mount file, with the `--set` changes.
    fn open(&self) -> Result<(Sequence, MountFile)> {
        let seq = Sequence::open(&self.seq_dir)?;
        let mut mount = mount_for(&seq, self.mount.as_deref())?;
        for s in &self.settings {
            mount.set(s)?;
        }
        Ok((seq, mount))
    }
}

fn render(scenario: &Scenario, out: &Path, seed: u64, frames: Option<usize>) -> Result<()> {
    let s = simulate(scenario, out, seed, frames, true)?;
    println!(
        "rendered {} frames of {} ({:.1} m) in {:.1} s ({:.1} frames/s) into {}",
        s.frames,
        scenario.name,
        s.distance_m,
        s.render_s,
        s.frames as f64 / s.render_s,
        sequence_dir(out).display()
    );
    Ok(())
}

/// Two pose files and how they compare.
struct Evaluated {
    report: Report,
    gt: Vec<Pose>,
    est: Vec<Pose>,
}

fn eval_files(gt: &Path, est: &Path, planar: bool) -> Result<Evaluated> {
    let g = read_poses(gt)?;
    let e = read_poses(est)?;
    let report = if planar {
        evaluate_planar(&g, &e)
    } else {
        evaluate(&g, &e)
    };
    let report =
        report.with_context(|| format!("comparing {} with {}", est.display(), gt.display()))?;
    Ok(Evaluated {
        report,
        gt: g,
        est: e,
    })
}

/// Parses a section of frames, `A..B`.
fn parse_frames(s: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("{s:?} is not a section: write A..B, e.g. 0..100"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|e| format!("{v:?} in {s:?}: {e}"))
    };
    let (a, b) = (n(a)?, n(b)?);
    if a >= b {
        return Err(format!("{s:?}: the section is empty"));
    }
    Ok(a..b)
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Simulate {
            scenario,
            overlay,
            out,
            seed,
            frames,
            print_scenario,
        } => {
            let sc = Scenario::load(&scenario, &overlay)?;
            if print_scenario {
                match Scenario::built_in_text(&scenario) {
                    Ok(text) if overlay.is_empty() && BUILT_IN.contains(&scenario.as_str()) => {
                        print!("{text}")
                    }
                    _ => print!("{}", sc.to_toml()?),
                }
                return Ok(());
            }
            let out = out.context("--out is required to render")?;
            render(&sc, &out, seed, frames)
        }
        Command::Eval {
            gt,
            est,
            json,
            plot,
            planar,
        } => {
            let Evaluated {
                report,
                gt: g,
                est: e,
            } = eval_files(&gt, &est, planar)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{}", format_report(&report));
            }
            if let Some(p) = plot {
                let tracks = [
                    Track {
                        label: "ground truth",
                        poses: &g,
                    },
                    Track {
                        label: "estimate",
                        poses: &e,
                    },
                ];
                plot_trajectories(&p, &format!("{}", est.display()), &tracks, Some(&report))?;
                eprintln!("plot written to {}", p.display());
            }
            Ok(())
        }
        Command::Run {
            seq: args,
            out,
            quality,
            plot,
            trace,
        } => {
            let (seq, mount) = args.open()?;
            let (seq_dir, method) = (args.seq_dir, args.method);
            let run = run_sequence(
                &seq,
                &mount,
                method,
                quality.as_deref(),
                trace.as_deref(),
                true,
            )?;
            write_poses(&out, &run.poses)?;
            print_run_summary(&run, &out);
            if let Some(p) = plot {
                let gt = ground_truth_for(&seq_dir).filter(|g| g.exists());
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
                    poses: &run.poses,
                });
                let report = gt_poses
                    .as_deref()
                    .map(|g| evaluate(g, &run.poses))
                    .transpose()?;
                plot_trajectories(&p, &seq_dir.display().to_string(), &tracks, report.as_ref())?;
                println!("plot written to {}", p.display());
            }
            Ok(())
        }
        Command::Calibrate {
            seq: args,
            gt,
            frames,
            out,
            max_runs,
            metric,
        } => {
            let (seq, start) = args.open()?;
            let (seq_dir, method) = (args.seq_dir, args.method);
            let poses = read_poses(&gt)?;
            let section = frames.unwrap_or(0..seq.frames);
            let bar = ProgressBar::new(max_runs as u64).with_style(
                ProgressStyle::with_template("calibrating {bar:40} {pos}/{len} mounts {msg}")
                    .expect("valid template"),
            );
            let cal = calibrate(
                &seq,
                &poses,
                section.clone(),
                &start,
                method,
                metric,
                max_runs,
                |n, c| {
                    bar.set_position(n as u64);
                    bar.set_message(format!("cost {c:.3}"));
                },
            )?;
            bar.finish_and_clear();
            println!(
                "frames {}..{} of {}: cost ({}) {:.3} -> {:.3}, {} mounts tried, {:.1} s",
                section.start,
                section.end,
                seq_dir.display(),
                metric.describe(),
                cal.cost_before,
                cal.cost_after,
                cal.evaluations,
                cal.elapsed.as_secs_f64()
            );
            for (name, unit, before, after) in &cal.changes {
                println!("  {name:>28}: {before:>8.3} -> {after:>8.3} {unit}");
            }
            let note = format!(
                "# Calibrated by `roadvo calibrate` on frames {}..{} of {}: cost {:.3} -> {:.3}.\n",
                section.start,
                section.end,
                seq_dir.display(),
                cal.cost_before,
                cal.cost_after
            );
            cal.mount.write(&out, false, &note)?;
            println!("mount written to {}", out.display());
            Ok(())
        }
        Command::Pack {
            seq: args,
            out,
            frames,
        } => {
            let (seq, mount) = args.open()?;
            let packed = pack(&seq, &mount, args.method, frames, &out)?;
            println!(
                "{} frames, rows {}..{} of each, {} bytes written to {}",
                packed.frames,
                packed.rows.start,
                packed.rows.end,
                packed.bytes,
                out.display()
            );
            Ok(())
        }
        Command::Bench {
            seq: args,
            frames,
            repeats,
        } => {
            let (seq, mount) = args.open()?;
            let seq_dir = args.seq_dir;
            let methods = match args.method {
                Some(m) => vec![m],
                None => vec![MethodName::Default, MethodName::Paper],
            };
            println!(
                "{} frames of {}x{} from {}, {repeats} runs, one thread, frames preloaded",
                frames.min(seq.frames),
                seq.size.0,
                seq.size.1,
                seq_dir.display()
            );
            for m in methods {
                let b = bench_sequence(&seq, &mount, Some(m), frames, repeats)?;
                let (lo, mid, hi) = b.spread_ms();
                println!(
                    "{:>8}: {:.0} frames/s; per frame min {lo:.2} ms, median {mid:.2} ms, max {hi:.2} ms",
                    format!("{m:?}").to_lowercase(),
                    b.frames_per_s()
                );
            }
            Ok(())
        }
        Command::Sensitivity {
            out,
            seed,
            frames,
            settings,
        } => {
            let tmp = tempfile::Builder::new()
                .prefix("roadvo-sensitivity-")
                .tempdir()?;
            let out = out.unwrap_or_else(|| tmp.path().to_owned());
            let bar = ProgressBar::new_spinner().with_style(
                ProgressStyle::with_template("{spinner} {elapsed} {msg}").expect("valid template"),
            );
            bar.enable_steady_tick(std::time::Duration::from_millis(200));
            let rows = sensitivity(&out, seed, frames, &settings, |what| {
                bar.set_message(what.to_string())
            })?;
            bar.finish_and_clear();
            println!(
                "s-course, seed {seed}: translation = path length error (positive: too long), \
                 rotation = final heading error over the path length"
            );
            for s in &settings {
                println!("every case with --set {s}");
            }
            println!();
            print!("{}", format_rows(&rows));
            Ok(())
        }
        Command::Demo { out, seed } => {
            // Dropped (and removed) when the demo ends, unless --out names a folder to keep.
            let tmp = tempfile::Builder::new().prefix("roadvo-demo-").tempdir()?;
            let out = out.unwrap_or_else(|| tmp.path().to_owned());
            let sc = Scenario::built_in("s-course")?;
            render(&sc, &out, seed, None)?;
            let seq_dir = sequence_dir(&out);
            let seq = Sequence::open(&seq_dir)?;
            let mount = mount_for(&seq, None)?;
            let gt = read_poses(&poses_path(&out))?;
            let mut reports = Vec::new();
            let mut runs = Vec::new();
            for (name, method) in [
                ("default", MethodName::Default),
                ("paper", MethodName::Paper),
            ] {
                let run = run_sequence(&seq, &mount, Some(method), None, None, true)?;
                println!(
                    "{name:>8}: {} frames, {} fallbacks, odometry {:.0} frames/s",
                    run.estimates.len(),
                    run.fallbacks(),
                    run.frames_per_s()
                );
                reports.push((name, evaluate(&gt, &run.poses)?));
                runs.push((name, run));
            }
            println!("\n{}", side_by_side(&reports));
            let plot = PathBuf::from("roadvo-demo.png");
            let mut tracks = vec![Track {
                label: "ground truth",
                poses: &gt,
            }];
            for (name, run) in &runs {
                tracks.push(Track {
                    label: name,
                    poses: &run.poses,
                });
            }
            plot_trajectories(
                &plot,
                "roadvo demo: the paper's s-course",
                &tracks,
                Some(&reports[0].1),
            )?;
            println!("plot written to {}", plot.display());
            Ok(())
        }
    }
}

/// The ground truth beside a KITTI sequence folder: `SEQ/../../poses/NN.txt`.
fn ground_truth_for(seq_dir: &Path) -> Option<PathBuf> {
    let name = seq_dir.canonicalize().ok()?.file_name()?.to_owned();
    let root = seq_dir.canonicalize().ok()?.parent()?.parent()?.to_owned();
    Some(root.join("poses").join(name).with_extension("txt"))
}

fn print_run_summary(run: &RunOutput, out: &Path) {
    let n = run.estimates.len();
    let smoothing = match run.smooth_lag_frames {
        0 => String::new(),
        lag => format!(", heading smoothed over +-{lag} frames"),
    };
    println!(
        "{n} frames, {} fallbacks{smoothing}; odometry {:.1} ms ({:.0} frames/s \
         single-threaded), PNG decoding {:.1} ms a frame; trajectory written to {}",
        run.fallbacks(),
        1e3 * run.odometry.as_secs_f64() / n.max(1) as f64,
        run.frames_per_s(),
        1e3 * run.decode.as_secs_f64() / n.max(1) as f64,
        out.display()
    );
}

/// The main figures of several reports in columns.
fn side_by_side(reports: &[(&str, Report)]) -> String {
    /// A figure of a report, formatted.
    type Figure = fn(&Report) -> String;
    fn opt(v: Option<f64>, d: usize) -> String {
        v.map_or("-".to_string(), |x| format!("{x:.d$}"))
    }
    let mut s = format!("{:<32}", "method");
    for (name, _) in reports {
        s += &format!("{name:>12}");
    }
    s.push('\n');
    let rows: [(&str, Figure); 6] = [
        ("KITTI t_err (%)", |r| opt(r.t_err_pct, 2)),
        ("KITTI r_err (deg/m)", |r| opt(r.r_err_deg_per_m, 4)),
        ("short t_err, 10..50 m (%)", |r| opt(r.short_t_err_pct, 2)),
        ("short r_err, 10..50 m (deg/m)", |r| {
            opt(r.short_r_err_deg_per_m, 4)
        }),
        ("end-point drift (%)", |r| format!("{:.2}", r.end_drift_pct)),
        ("final heading error (deg)", |r| {
            format!("{:.2}", r.end_heading_err_deg)
        }),
    ];
    for (label, f) in rows {
        s += &format!("{label:<32}");
        for (_, r) in reports {
            s += &format!("{:>12}", f(r));
        }
        s.push('\n');
    }
    s
}
