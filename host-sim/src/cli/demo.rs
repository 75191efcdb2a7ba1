//! `roadvo demo`.

use super::bar;
use super::simulate::render;
use anyhow::Result;
use roadvo::Method;
use roadvo_sim::ape::{Alignment, ape};
use roadvo_sim::eval::{Report, evaluate};
use roadvo_sim::kitti::{Sequence, read_poses, write_poses};
use roadvo_sim::plot::{Figure, Scored, plot_figure};
use roadvo_sim::run::{BadFrames, RunFiles, config_for, mount_for, run};
use roadvo_sim::scenario::Scenario;
use roadvo_sim::simulate::{poses_path, sequence_dir};
use std::path::{Path, PathBuf};

/// Render the paper's s-course, run both methods, evaluate, and plot: the default demo.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Folder to render into and write the outputs to: the drive, each method's trajectory
    /// (`pitch-vote.txt`, `paper.txt`: KITTI format) and the plot (`roadvo-demo.png`). Default:
    /// a temporary folder, removed afterwards, and the plot in the current folder.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the texture, noise and suspension phases.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

impl DemoArgs {
    pub fn run(self) -> Result<()> {
        // Dropped (and removed) when the demo ends, unless --out names a folder to keep.
        let tmp = tempfile::Builder::new().prefix("roadvo-demo-").tempdir()?;
        let out = self.out.clone().unwrap_or_else(|| tmp.path().to_owned());
        let sc = Scenario::built_in("s-course")?;
        render(&sc, &out, self.seed, None)?;
        let seq = Sequence::open(&sequence_dir(&out))?;
        let mount = mount_for(&seq, None)?;
        let gt = read_poses(&poses_path(&out))?;
        let mut reports = Vec::new();
        let mut runs = Vec::new();
        for method in Method::ALL {
            let progress = bar(seq.frames, method.name(), "frames");
            let config = config_for(&seq, &mount, Some(method))?;
            let output = run(&seq, config, &RunFiles::default(), BadFrames::Stop, || {
                progress.inc(1)
            })?
            .complete()?;
            progress.finish_and_clear();
            println!(
                "{:>10}: {} frames, {} fallbacks, odometry {:.0} frames/s",
                method.name(),
                output.estimates.len(),
                output.fallbacks(),
                output.frames_per_s()
            );
            reports.push((method.name(), evaluate(&gt, &output.poses)?));
            runs.push((method.name(), output));
        }
        println!("\n{}", side_by_side(&reports));
        if let Some(dir) = &self.out {
            for (name, output) in &runs {
                let path = trajectory_path(dir, name);
                write_poses(&path, &output.poses)?;
                println!("{name} trajectory written to {}", path.display());
            }
        }
        let plot = plot_path(self.out.as_deref());
        let apes = runs
            .iter()
            .map(|(_, output)| Ok(ape(&gt, &output.poses, Alignment::None)?.errors_m))
            .collect::<Result<Vec<_>>>()?;
        let estimates: Vec<Scored> = runs
            .iter()
            .zip(&reports)
            .zip(&apes)
            .map(|(((name, output), (_, report)), ape_m)| Scored {
                label: name,
                poses: &output.poses,
                report: Some(report),
                ape_m: Some(ape_m),
            })
            .collect();
        plot_figure(
            &plot,
            &Figure {
                title: "roadvo demo: the paper's s-course",
                ground_truth: Some(&gt),
                estimates: &estimates,
                quality: None,
            },
        )?;
        println!("plot written to {}", plot.display());
        Ok(())
    }
}

/// Where the demo's plot goes: `roadvo-demo.png` in `--out`, or in the current folder without
/// it.
fn plot_path(out: Option<&Path>) -> PathBuf {
    const NAME: &str = "roadvo-demo.png";
    out.map_or_else(|| PathBuf::from(NAME), |dir| dir.join(NAME))
}

/// Where a method's trajectory goes in `--out`: `NAME.txt`, KITTI format, camera 0's frame at
/// the first frame.
fn trajectory_path(out: &Path, method: &str) -> PathBuf {
    out.join(format!("{method}.txt"))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_output_goes_under_out() {
        let out = Path::new("/tmp/d");
        assert_eq!(plot_path(Some(out)), out.join("roadvo-demo.png"));
        assert_eq!(plot_path(None), PathBuf::from("roadvo-demo.png"));
        assert_eq!(trajectory_path(out, "paper"), out.join("paper.txt"));
    }
}
