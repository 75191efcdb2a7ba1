//! `roadvo run`'s trajectory and quality formats and `roadvo eval` on them, run as a user runs
//! them: KITTI and TUM files of one run score alike, TUM files are paired by timestamp.

mod common;

use common::{refused, roadvo, simulate};
use roadvo_sim::kitti::{read_poses, read_times};
use roadvo_sim::pose_file::{PoseFormat, write_trajectory};
use std::path::Path;

fn eval_json(gt: &Path, est: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "eval",
        gt.to_str().unwrap(),
        est.to_str().unwrap(),
        "--json",
    ];
    args.extend_from_slice(extra);
    serde_json::from_slice(&roadvo(&args).stdout).unwrap()
}

/// A figure of `v` at `path` (a JSON pointer), as a number.
fn figure(v: &serde_json::Value, path: &str) -> f64 {
    v.pointer(path)
        .and_then(serde_json::Value::as_f64)
        .unwrap_or_else(|| panic!("{path} in {v}"))
}

#[test]
fn kitti_and_tum_files_of_one_run_score_alike() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate("s-course", d, 60);
    let seq = d.join("sequences/00");
    let gt = d.join("poses/00.txt");
    let (kitti, tum) = (d.join("est.txt"), d.join("est.tum"));
    let (q_csv, q_jsonl) = (d.join("q.csv"), d.join("q.jsonl"));
    for (est, q) in [(&kitti, &q_jsonl), (&tum, &q_csv)] {
        roadvo(&[
            "run",
            seq.to_str().unwrap(),
            "--out",
            est.to_str().unwrap(),
            "--quality",
            q.to_str().unwrap(),
        ]);
    }
    // --format overrides the extension.
    let forced = d.join("forced.txt");
    roadvo(&[
        "run",
        seq.to_str().unwrap(),
        "--out",
        forced.to_str().unwrap(),
        "--format",
        "tum",
    ]);
    let text = std::fs::read_to_string(&tum).unwrap();
    assert_eq!(text, std::fs::read_to_string(&forced).unwrap());
    // TUM lines carry the sequence's timestamps; the first pose is camera 0's at the origin.
    let times = read_times(&seq.join("times.txt")).unwrap();
    let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(lines.len(), times.len());
    for (line, t) in lines.iter().zip(&times) {
        let stamp: f64 = line.split(' ').next().unwrap().parse().unwrap();
        assert!((stamp - t).abs() < 1e-9, "{line} vs {t}");
    }
    let first: Vec<f64> = lines[0].split(' ').map(|w| w.parse().unwrap()).collect();
    assert_eq!(&first[1..], &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    // The CSV holds the JSON lines' fields, a header first.
    let csv = std::fs::read_to_string(&q_csv).unwrap();
    assert!(
        csv.starts_with("frame,time_s,heading_change_rad,distance_m,x_m,y_m,heading_rad,"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 61);
    let jsonl = std::fs::read_to_string(&q_jsonl).unwrap();
    let last: serde_json::Value = serde_json::from_str(jsonl.lines().last().unwrap()).unwrap();
    let last_csv: Vec<&str> = csv.lines().last().unwrap().split(',').collect();
    assert_eq!(last["frame"], 59);
    assert_eq!(last_csv[0], "59");

    // The ground truth as TUM too, with the sequence's timestamps: paired by timestamp.
    let gt_tum = d.join("gt.tum");
    write_trajectory(&gt_tum, PoseFormat::Tum, &read_poses(&gt).unwrap(), &times).unwrap();
    let plot = d.join("plot.png");
    for align in ["none", "se3", "sim3"] {
        let a = eval_json(&gt, &kitti, &["--align", align, "--delta", "5"]);
        let b = eval_json(&gt, &tum, &["--align", align, "--delta", "5"]);
        let c = eval_json(
            &gt_tum,
            &tum,
            &[
                "--align",
                align,
                "--delta",
                "5",
                "--plot",
                plot.to_str().unwrap(),
                "--quality",
                q_csv.to_str().unwrap(),
            ],
        );
        assert_eq!(a["association"]["by"], "line");
        assert_eq!(c["association"]["by"], "timestamp");
        assert_eq!(c["association"]["matched"], 60);
        assert_eq!(a["ape"]["alignment"], align);
        for path in [
            "/ape/translation_m/rmse",
            "/ape/translation_m/max",
            "/ape/scale",
            "/rpe/translation_m/mean",
            "/rpe/rotation_deg/mean",
            "/short_t_err_pct",
            "/short_r_err_deg_per_m",
            "/end_drift_pct",
        ] {
            let x = figure(&a, path);
            // The run's rotations come from f32, orthonormal to about 1e-7; TUM's quaternions
            // are exactly so. Over a 10 m segment that is a few 1e-7 m.
            for other in [&b, &c] {
                let y = figure(other, path);
                assert!(
                    (y - x).abs() < 1e-6 + 1e-4 * x.abs(),
                    "{path}: {x} vs {other}"
                );
            }
        }
        assert!(figure(&a, "/ape/translation_m/rmse") > 0.0);
        assert!(figure(&a, "/rpe/pairs") >= 2.0);
    }
    assert!(std::fs::metadata(&plot).unwrap().len() > 10_000);
}

#[test]
fn tum_poses_pair_by_the_nearest_timestamp_within_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A curve every 0.1 s; the estimate every other pose, 4 ms late.
    let pose = |i: usize| {
        let a = 0.05 * i as f64;
        let (s, c) = a.sin_cos();
        [
            c,
            0.0,
            -s,
            10.0 * (1.0 - c),
            0.0,
            1.0,
            0.0,
            0.1 * s,
            s,
            0.0,
            c,
            10.0 * s,
        ]
    };
    let gt: Vec<_> = (0..100).map(pose).collect();
    let times: Vec<f64> = (0..100).map(|i| 0.1 * f64::from(i)).collect();
    let (gt_path, est_path) = (d.join("gt.tum"), d.join("est.tum"));
    write_trajectory(&gt_path, PoseFormat::Tum, &gt, &times).unwrap();
    let est: Vec<_> = gt.iter().step_by(2).copied().collect();
    let late: Vec<f64> = times.iter().step_by(2).map(|t| t + 0.004).collect();
    write_trajectory(&est_path, PoseFormat::Tum, &est, &late).unwrap();
    let v = eval_json(&gt_path, &est_path, &["--delta", "5"]);
    assert_eq!(v["association"]["matched"], 50, "{v}");
    assert_eq!(v["association"]["max_diff_s"], 0.01);
    assert!(figure(&v, "/ape/translation_m/max") < 1e-8, "{v}");
    // 4 ms is beyond a 3 ms limit: nothing pairs, and the refusal says so.
    let err = refused(&[
        "eval",
        gt_path.to_str().unwrap(),
        est_path.to_str().unwrap(),
        "--t-max-diff",
        "0.003",
    ]);
    assert!(
        err.contains("0 poses have timestamps within 0.003 s"),
        "{err}"
    );
    // The table names the pairing and the alignment.
    let table = roadvo(&[
        "eval",
        gt_path.to_str().unwrap(),
        est_path.to_str().unwrap(),
        "--align",
        "sim3",
    ]);
    let table = String::from_utf8_lossy(&table.stdout);
    assert!(
        table.contains(
            "Paired by timestamp (within 0.01 s): 50 of 100 ground-truth and 50 estimated poses"
        ),
        "{table}"
    );
    assert!(
        table.contains("Sim(3) Umeyama alignment, scale 1.000000"),
        "{table}"
    );
}
