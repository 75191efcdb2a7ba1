//! End to end on synthetic drives with known truth: what `roadvo simulate` writes is a KITTI
//! sequence the readers accept, its images show a road, and its ground truth matches the path.

use roadvo_sim::eval::evaluate;
use roadvo_sim::kitti::{Sequence, read_poses};
use roadvo_sim::scenario::Scenario;
use roadvo_sim::simulate::{poses_path, sequence_dir, simulate};

#[test]
fn s_course_renders_a_road_with_exact_ground_truth() {
    let dir = tempfile::tempdir().unwrap();
    let sc = Scenario::built_in("s-course").unwrap();
    let summary = simulate(&sc, dir.path(), 1, Some(11), &()).unwrap();
    assert_eq!(summary.frames, 11);
    // 2.5 m/s for one second.
    assert!((summary.distance_m - 2.5).abs() < 1e-6, "{summary:?}");

    let seq = Sequence::open(&sequence_dir(dir.path())).unwrap();
    assert_eq!((seq.frames, seq.size), (11, (640, 480)));
    assert!((seq.times_s[10] - 1.0).abs() < 1e-9);
    let gt = read_poses(&poses_path(dir.path())).unwrap();
    assert_eq!(gt.len(), 11);
    // The camera pitched 20 deg down drives straight ahead: its z (forward along the optical
    // axis) and y (down) move as cos/sin of the pitch.
    let (pitch, d) = (20f64.to_radians(), 2.5);
    assert!((gt[10][11] - d * pitch.cos()).abs() < 1e-5, "{:?}", gt[10]);
    assert!((gt[10][7] + d * pitch.sin()).abs() < 1e-5, "{:?}", gt[10]);
    let report = evaluate(&gt, &gt).unwrap();
    assert_eq!(report.end_drift_pct, 0.0);

    // Sky at the top is bright, road below is mid-grey with texture and lane paint.
    let img = seq.load(5).unwrap();
    let mean = |rows: std::ops::Range<u32>| {
        let (mut sum, mut n) = (0u64, 0u64);
        for y in rows {
            for x in 0..img.width() {
                sum += u64::from(img.get_pixel(x, y)[0]);
                n += 1;
            }
        }
        sum as f64 / n as f64
    };
    let (sky, road) = (mean(0..20), mean(400..480));
    assert!(
        sky > 160.0 && road > 70.0 && road < 140.0,
        "sky {sky}, road {road}"
    );
    let bright = img.pixels().skip(640 * 300).filter(|p| p[0] > 180).count();
    assert!(bright > 500, "lane paint: {bright} bright pixels");
    let dark = img.pixels().skip(640 * 300).filter(|p| p[0] < 70).count();
    assert!(dark > 500, "dark texture patches: {dark} pixels");
}

#[test]
fn same_seed_same_frames_other_seed_other_texture() {
    let sc = Scenario::built_in("s-course").unwrap();
    let render = |seed| {
        let dir = tempfile::tempdir().unwrap();
        simulate(&sc, dir.path(), seed, Some(2), &()).unwrap();
        let seq = Sequence::open(&sequence_dir(dir.path())).unwrap();
        seq.load(1).unwrap().into_raw()
    };
    let (a, b, c) = (render(1), render(1), render(2));
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn too_many_frames_for_the_path_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let sc = Scenario::built_in("s-course").unwrap();
    let e = simulate(&sc, dir.path(), 1, Some(10_000), &()).unwrap_err();
    assert!(e.to_string().contains("ends before frame 481"), "{e}");
}

#[test]
fn town_renders_the_same_twice_with_texture_above_the_horizon() {
    let sc = Scenario::built_in("town").unwrap();
    let render = || {
        let dir = tempfile::tempdir().unwrap();
        simulate(&sc, dir.path(), 1, Some(2), &()).unwrap();
        let seq = Sequence::open(&sequence_dir(dir.path())).unwrap();
        (0..2).map(|i| seq.load(i).unwrap()).collect::<Vec<_>>()
    };
    let (a, b) = (render(), render());
    assert!(a == b, "same seed, same frames");

    // Above the horizon (row 185 on the level KITTI camera) buildings, trees and poles give
    // strong gradients in both halves of the frame; kitti-like has none there (sky and haze).
    let img = &a[1];
    let (w, horizon) = (img.width(), 180);
    let strong = |columns: std::ops::Range<u32>| {
        let (mut n, mut all) = (0usize, 0usize);
        let px = |x: u32, y: u32| i32::from(img.get_pixel(x, y)[0]);
        for y in 1..horizon {
            for x in columns.clone() {
                let gx = px(x + 1, y) - px(x - 1, y);
                let gy = px(x, y + 1) - px(x, y - 1);
                n += usize::from(gx.abs() >= 40 || gy.abs() >= 40);
                all += 1;
            }
        }
        n as f64 / all as f64
    };
    let (left, right) = (strong(1..w / 2), strong(w / 2..w - 1));
    assert!(
        left > 0.02 && right > 0.02,
        "strong gradients: left {left}, right {right}"
    );
}
