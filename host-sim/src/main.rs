//! `roadvo`: the command line. Each subcommand parses its arguments, calls into the library and
//! prints what it did.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use roadvo_sim::eval::{Report, evaluate, format_report};
use roadvo_sim::kitti::{Pose, read_poses};
use roadvo_sim::plot::{Track, plot_trajectories};
use roadvo_sim::scenario::{BUILT_IN, Scenario};
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
    },
    /// Render the paper's s-course, evaluate, and plot: the default demo.
    Demo {
        /// Folder to render into (default: a temporary folder, removed afterwards).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed of the texture, noise and suspension phases.
        #[arg(long, default_value_t = 1)]
        seed: u64,
    },
}

fn load_scenario(name: &str) -> Result<Scenario> {
    let as_path = Path::new(name);
    if BUILT_IN.contains(&name) || !as_path.exists() {
        Scenario::built_in(name)
    } else {
        Scenario::read(as_path)
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

fn eval_files(gt: &Path, est: &Path) -> Result<Evaluated> {
    let g = read_poses(gt)?;
    let e = read_poses(est)?;
    let report = evaluate(&g, &e)
        .with_context(|| format!("comparing {} with {}", est.display(), gt.display()))?;
    Ok(Evaluated {
        report,
        gt: g,
        est: e,
    })
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Simulate {
            scenario,
            out,
            seed,
            frames,
            print_scenario,
        } => {
            let sc = load_scenario(&scenario)?;
            if print_scenario {
                match Scenario::built_in_text(&scenario) {
                    Ok(text) if BUILT_IN.contains(&scenario.as_str()) => print!("{text}"),
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
        } => {
            let Evaluated {
                report,
                gt: g,
                est: e,
            } = eval_files(&gt, &est)?;
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
        Command::Demo { out, seed } => {
            // Dropped (and removed) when the demo ends, unless --out names a folder to keep.
            let tmp = tempfile::Builder::new().prefix("roadvo-demo-").tempdir()?;
            let out = out.unwrap_or_else(|| tmp.path().to_owned());
            let sc = Scenario::built_in("s-course")?;
            render(&sc, &out, seed, None)?;
            let gt = poses_path(&out);
            let Evaluated { report, gt: g, .. } = eval_files(&gt, &gt)?;
            println!("\nground truth against itself (the odometer arrives with the engine):");
            print!("{}", format_report(&report));
            let plot = PathBuf::from("roadvo-demo.png");
            let tracks = [Track {
                label: "ground truth",
                poses: &g,
            }];
            plot_trajectories(&plot, "roadvo demo: s-course", &tracks, Some(&report))?;
            println!("plot written to {}", plot.display());
            Ok(())
        }
    }
}
