//! The mount learned while driving (`learn_yaw`), end to end: a kitti-like drive with
//! suspension rendered with one mount, the odometer told a yaw 1 deg off, and the calibration
//! carried across an ignition cycle as the bytes an ECU would keep.

use roadvo::{Calibration, Estimate, Method, Odometer, SliceFrame, ValidConfig};
use roadvo_sim::eval::{evaluate, heading_change_errors};
use roadvo_sim::kitti::{Sequence, read_poses};
use roadvo_sim::mount::MountFile;
use roadvo_sim::run::{FrameSource, config_for, mount_for, run_sequence};
use roadvo_sim::scenario::Scenario;
use roadvo_sim::simulate::{poses_path, sequence_dir, simulate};

/// Frames of the drive: about 260 m, its first two bends.
const FRAMES: usize = 300;

/// The rendered drive, its truth, and the mount file beside it with its yaw 1 deg too far left.
fn drive(dir: &std::path::Path) -> (Sequence, Vec<[f64; 12]>, MountFile) {
    let sc = Scenario::load("kitti-like", &["suspension".to_string()]).unwrap();
    simulate(&sc, dir, 1, Some(FRAMES), &()).unwrap();
    let seq = Sequence::open(&sequence_dir(dir)).unwrap();
    let truth = read_poses(&poses_path(dir)).unwrap();
    let mut told = mount_for(&seq, None).unwrap();
    told.mount.yaw_rad += 1f32.to_radians();
    (seq, truth, told)
}

/// Runs `frames` of `seq` through one odometer, restored with `saved` first if given: the
/// estimates and the calibration after the last frame.
fn run_part(
    seq: &Sequence,
    config: ValidConfig,
    frames: std::ops::Range<usize>,
    saved: Option<&[u8]>,
) -> (Vec<Estimate>, Calibration) {
    let mut odo: Box<Odometer> = Box::new(Odometer::new(config).unwrap());
    if let Some(bytes) = saved {
        odo.restore_calibration(Calibration::from_bytes(bytes).unwrap())
            .unwrap();
    }
    let estimates = frames
        .map(|i| {
            let (img, t) = seq.frame(i).unwrap();
            let (w, h) = img.dimensions();
            let frame = SliceFrame::new(img.as_raw(), w as u16, h as u16, w as usize).unwrap();
            odo.process(&frame, t).unwrap()
        })
        .collect();
    (estimates, *odo.calibration())
}

#[test]
fn a_yaw_error_in_the_mount_file_is_learned_while_driving() {
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, told) = drive(dir.path());
    let mut fixed = told;
    fixed.settings.learn_yaw = false;
    let learned = run_sequence(&seq, &told, Some(Method::PitchVote)).unwrap();
    let kept = run_sequence(&seq, &fixed, Some(Method::PitchVote)).unwrap();
    let c = learned.ran.calibration;
    // The learned correction: -1 deg, to about its standard error (0.1 deg over this road).
    let yaw_deg = c.yaw.rad.to_degrees();
    assert!((yaw_deg + 1.0).abs() < 0.25, "{c:?}");
    assert!(c.yaw.sd_rad().unwrap().to_degrees() < 0.2, "{c:?}");
    assert_eq!(kept.ran.calibration, Calibration::NONE);
    // The error turned the ground's heading by about 0.09 deg/m; learned, it is gone after the
    // first tens of metres.
    let (l, k) = (
        evaluate(&truth, &learned.poses).unwrap(),
        evaluate(&truth, &kept.poses).unwrap(),
    );
    let (lr, kr) = (l.r_err_deg_per_m.unwrap(), k.r_err_deg_per_m.unwrap());
    let (lt, kt) = (l.t_err_pct.unwrap(), k.t_err_pct.unwrap());
    assert!(
        3.0 * lr < kr && 3.0 * lt < kt,
        "learned {lt:.2} %, {lr:.4} deg/m; mount file's {kt:.2} %, {kr:.4} deg/m"
    );
}

#[test]
fn a_calibration_kept_over_an_ignition_cycle_carries_on_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, told) = drive(dir.path());
    let config = config_for(&seq, &told, Some(Method::PitchVote)).unwrap();
    let split = FRAMES / 2;
    let (whole, whole_cal) = run_part(&seq, config, 0..FRAMES, None);
    // The first part, its calibration saved as bytes; the second part on a fresh odometer
    // restored from them, and on one that starts from the mount file again.
    let (_, first_cal) = run_part(&seq, config, 0..split, None);
    let saved = first_cal.to_bytes();
    let (restored, restored_cal) = run_part(&seq, config, split..FRAMES, Some(&saved));
    let (cold, _) = run_part(&seq, config, split..FRAMES, None);
    // The learned yaw ends where the drive in one piece ends it, within two of its standard
    // errors (0.1 deg each over this road: after the split the two saw other pairs).
    let gap = (restored_cal.yaw.rad - whole_cal.yaw.rad).abs();
    let sd = restored_cal.yaw.sd_rad().unwrap();
    assert!(gap < 2.0 * sd, "{restored_cal:?} against {whole_cal:?}");
    // After the split, the heading changes are as good as the one piece's, to within what a
    // yaw one standard error apart turns (0.1 deg: about 0.008 deg a frame here): the cold
    // start, which has the whole error to learn again, is worse.
    let level = told.mount.rotation_vehicle_from_camera(Default::default());
    let errors = |e: &[Estimate]| {
        let rad: Vec<f64> = e
            .iter()
            .map(|e| f64::from(e.motion.heading_change_rad))
            .collect();
        heading_change_errors(&truth[split..], &rad, &level).unwrap()
    };
    let (w, r, c) = (errors(&whole[split..]), errors(&restored), errors(&cold));
    assert!(
        (r.mean_deg - w.mean_deg).abs() < 0.015 && r.rms_deg < w.rms_deg + 0.01,
        "restored {r:?}, in one piece {w:?}"
    );
    assert!(
        c.mean_deg.abs() > r.mean_deg.abs() && c.rms_deg > r.rms_deg,
        "a cold start {c:?} against restored {r:?}"
    );
}
