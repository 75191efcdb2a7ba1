//! The `roadvo` command line, run as a user runs it.

mod common;

use common::{refused, roadvo, simulate};
use std::path::Path;

/// `roadvo run` on `seq` with `extra` arguments, its poses written to `dir/name`: the poses.
fn run_poses(dir: &Path, seq: &Path, name: &str, extra: &[&str]) -> String {
    let out = dir.join(name);
    let mut args = vec!["run", seq.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    roadvo(&args);
    std::fs::read_to_string(out).unwrap()
}

/// `roadvo run` on `seq` with `--set assignment`, expecting a refusal: its error output.
fn run_refused_with(dir: &Path, seq: &Path, assignment: &str) -> String {
    let out = dir.join("refused.txt");
    refused(&[
        "run",
        seq.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--set",
        assignment,
    ])
}

#[test]
fn simulate_then_eval_ground_truth_against_itself_prints_zeros() {
    let dir = tempfile::tempdir().unwrap();
    simulate("s-course", dir.path(), 45);
    let gt = dir.path().join("poses/00.txt");
    let plot = dir.path().join("plot.svg");
    let json = roadvo(&[
        "eval",
        gt.to_str().unwrap(),
        gt.to_str().unwrap(),
        "--json",
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    for key in [
        "short_t_err_pct",
        "short_r_err_deg_per_m",
        "end_drift_pct",
        "end_heading_err_deg",
    ] {
        assert_eq!(v[key], serde_json::json!(0.0), "{key}: {v}");
    }
    // 11 m: short segments only; the KITTI figures are null rather than invented.
    assert!(
        v["t_err_pct"].is_null() && v["r_err_deg_per_m"].is_null(),
        "{v}"
    );
    assert_eq!(v["segments"], 0);
    assert!(std::fs::metadata(&plot).unwrap().len() > 1000);
}

#[test]
fn print_scenario_gives_toml_that_renders() {
    let out = roadvo(&["simulate", "--scenario", "kitti-like", "--print-scenario"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("name = \"kitti-like\""), "{text}");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.toml");
    // A user's own scenario: the built-in, smaller and with a vehicle ahead.
    let mine = text
        .replace("width_px = 1241", "width_px = 620")
        .replace("cx_px = 607.1928", "cx_px = 310.0")
        + "\n[[vehicle]]\nlateral_m = 0.0\nahead_m = 12.0\n";
    std::fs::write(&file, mine).unwrap();
    let seq = dir.path().join("run");
    simulate(file.to_str().unwrap(), &seq, 2);
    let img = image::open(seq.join("sequences/00/image_0/000001.png")).unwrap();
    assert_eq!((img.width(), img.height()), (620, 376));
}

#[test]
fn bad_input_says_which_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let gt = dir.path().join("gt.txt");
    std::fs::write(&gt, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n").unwrap();
    let err = refused(&["eval", gt.to_str().unwrap(), gt.to_str().unwrap()]);
    assert!(
        err.contains("gt.txt line 2: expected 12 numbers (a 3x4 pose), found 11"),
        "{err}"
    );
}

#[test]
fn pack_stores_the_configuration_and_the_rows_the_odometer_reads() {
    use roadvo::wire::frame_store::FrameStore;
    use roadvo::{Frame, Instant};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    roadvo(&[
        "simulate",
        "--scenario",
        "s-course",
        "--out",
        out,
        "--frames",
        "3",
    ]);
    let seq = dir.path().join("sequences/00");
    let store = dir.path().join("frames.bin");
    // A changed setting travels with the frames.
    roadvo(&[
        "pack",
        seq.to_str().unwrap(),
        "--out",
        store.to_str().unwrap(),
        "--set",
        "features_per_side=16",
    ]);
    let bytes = std::fs::read(&store).unwrap();
    let store = FrameStore::open(&bytes).unwrap();
    let h = store.header();
    assert_eq!(h.frames, 3);
    assert_eq!(h.config.settings.features_per_side, 16);
    let config = h.config.validate().unwrap();
    assert!(store.holds_rows(config.rows_read()));
    // Frame 2's band is the image's rows, byte for byte, and its time the sequence's.
    let img = image::open(seq.join("image_0/000002.png"))
        .unwrap()
        .into_luma8();
    let (frame, t) = store.frame(2).unwrap();
    let w = img.width() as usize;
    for y in config.rows_read() {
        let row = &img.as_raw()[usize::from(y) * w..(usize::from(y) + 1) * w];
        assert_eq!(frame.row(y), row, "row {y}");
    }
    let times = std::fs::read_to_string(seq.join("times.txt")).unwrap();
    let t2: f64 = times.lines().nth(2).unwrap().trim().parse().unwrap();
    assert_eq!(t, Instant::from_micros((t2 * 1e6).round() as u64));
}

#[test]
fn set_runs_as_the_edited_mount_file_would_and_names_a_bad_key() {
    let dir = tempfile::tempdir().unwrap();
    simulate("s-course", dir.path(), 12);
    let seq = dir.path().join("sequences/00");
    let mount = std::fs::read_to_string(seq.join("mount.toml")).unwrap();
    assert!(
        !mount.contains("[odometer]") && mount.contains("yaw_deg = 0.0"),
        "{mount}"
    );
    let edited = dir.path().join("edited.toml");
    std::fs::write(
        &edited,
        mount.replace("yaw_deg = 0.0", "yaw_deg = 0.5")
            + "\n[odometer]\nmax_roll_change_steps = 0\n",
    )
    .unwrap();
    let run = |name: &str, extra: &[&str]| run_poses(dir.path(), &seq, name, extra);
    let from_file = run("file.txt", &["--mount", edited.to_str().unwrap()]);
    let from_set = run(
        "set.txt",
        &[
            "--set",
            "max_roll_change_steps=0",
            "--set",
            "mount.yaw_deg=0.5",
        ],
    );
    assert_eq!(from_set, from_file);
    assert_ne!(from_set, run("plain.txt", &[]));

    let err = run_refused_with(dir.path(), &seq, "max_roll_change=0");
    assert!(
        err.contains("--set max_roll_change=0: [odometer] has no key `max_roll_change`"),
        "{err}"
    );
}

#[test]
fn the_smoother_keeps_every_frame_leaves_the_paper_alone_and_refuses_a_long_lag() {
    let dir = tempfile::tempdir().unwrap();
    simulate("s-course", dir.path(), 12);
    let seq = dir.path().join("sequences/00");
    let run = |name: &str, extra: &[&str]| run_poses(dir.path(), &seq, name, extra);
    let plain = run("plain.txt", &[]);
    let trace = dir.path().join("trace.txt");
    let smoothed = run(
        "smoothed.txt",
        &[
            "--set",
            "smooth_lag_frames=2",
            "--trace",
            trace.to_str().unwrap(),
        ],
    );
    assert_eq!(smoothed.lines().count(), 12);
    assert_ne!(smoothed, plain);
    // Each frame's estimate, then from the third on the smoothed one two frames back.
    let trace = std::fs::read_to_string(trace).unwrap();
    let kinds: Vec<(&str, usize)> = trace
        .lines()
        .map(|l| {
            let mut words = l.split(' ');
            let kind = words.next().unwrap();
            (kind, words.next().unwrap().parse().unwrap())
        })
        .collect();
    let mut expected = Vec::new();
    for i in 0..12 {
        expected.push(("estimate", i));
        if i >= 2 {
            expected.push(("smoothed", i - 2));
        }
    }
    expected.extend([("smoothed", 10), ("smoothed", 11)]);
    assert_eq!(kinds, expected);
    let paper = ["--method", "paper"];
    assert_eq!(
        run(
            "paper-smoothed.txt",
            &[&paper[..], &["--set", "smooth_lag_frames=2"]].concat()
        ),
        run("paper.txt", &paper)
    );

    let err = run_refused_with(dir.path(), &seq, "smooth_lag_frames=5");
    assert!(
        err.contains("smooth_lag_frames is out of range: at most 4"),
        "{err}"
    );
}

#[test]
fn calibrating_on_the_kitti_metric_asks_for_100_m() {
    let dir = tempfile::tempdir().unwrap();
    simulate("s-course", dir.path(), 12);
    let seq = dir.path().join("sequences/00");
    let gt = dir.path().join("poses/00.txt");
    let out = dir.path().join("calibrated.toml");
    let err = refused(&[
        "calibrate",
        seq.to_str().unwrap(),
        "--gt",
        gt.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--metric",
        "kitti",
    ]);
    assert!(
        err.contains("too short for the KITTI metric: it needs at least 100 m"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn view_writes_a_picture_of_every_nth_frame_with_its_panel() {
    let dir = tempfile::tempdir().unwrap();
    simulate("s-course", dir.path(), 12);
    let seq = dir.path().join("sequences/00");
    let out = dir.path().join("view");
    roadvo(&[
        "view",
        seq.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--every",
        "5",
        "--no-video",
    ]);
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["000000.png", "000005.png", "000010.png"]);
    let frame = image::open(seq.join("image_0/000005.png")).unwrap();
    let picture = image::open(out.join("000005.png")).unwrap().into_rgb8();
    assert!(picture.width() > frame.width() && picture.height() >= frame.height());
    // Tracks are drawn in their fates' colours (matched, new, carried).
    let fates = [[44, 200, 44], [255, 200, 0], [230, 40, 40]];
    let tracks = picture.pixels().filter(|p| fates.contains(&p.0)).count();
    assert!(tracks > 100, "{tracks} pixels of tracks");
}

#[test]
fn a_reader_that_stops_early_ends_the_command_quietly() {
    // `roadvo eval ... | head -1`: the reader gone before the table is printed. The command
    // ends as `cat` does (SIGPIPE), not in a panic of a print to the closed pipe.
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.txt");
    let lines: String = (0..300)
        .map(|i| format!("1 0 0 0 0 1 0 0 0 0 1 {}\n", f64::from(i) * 0.8))
        .collect();
    std::fs::write(&poses, lines).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_roadvo"))
        .args(["eval", poses.to_str().unwrap(), poses.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        out.status.success() || out.status.signal() == Some(13),
        "{:?}: {stderr}",
        out.status
    );
}
