//! The pitch vote's search and matching on scenes of known motion and attitude.

use super::attitude::{AttitudeDrift, AttitudeIndex, Fans};
use super::matching::match_tracks;
use super::pairs::tests::scene;
use super::search::{Inputs, Search, VoteOutcome};
use crate::config::ValidConfig;
use crate::config::tests::kitti_config;
use crate::harris::{Corner, Corners};
use crate::motion::Motion;
use crate::projection::{Attitude, GroundPoint, Homography};
use crate::tracks::Track;
use crate::vote::MotionWindow;
use fixed::types::I16F16;

/// The vote of `tracks` against `corners` in `window`, the previous frame at `previous`, points
/// measured from `pivot_m` ahead of the rear axle; the search holds its working memory after.
fn vote(
    cfg: &ValidConfig,
    search: &mut Search<64, 64, 64>,
    (tracks, corners): (&[Track], &Corners<64>),
    window: &MotionWindow,
    previous: AttitudeIndex,
    pivot_m: f32,
) -> VoteOutcome {
    let mut fans = Fans::ZERO;
    fans.build(cfg);
    let hidden = [[false; 64]; 2];
    let inputs = Inputs {
        tracks,
        corners,
        hidden: &hidden,
        fans: &fans,
        pivot_m,
    };
    let mut drift = AttitudeDrift::default();
    search
        .estimate(cfg, &inputs, window, previous, &mut drift, true)
        .unwrap()
}

fn frame_pair(
    cfg: &ValidConfig,
    points: &[GroundPoint],
    motion: Motion,
    attitude: Attitude,
) -> (std::vec::Vec<Track>, Corners<64>) {
    frame_pair_about(cfg, points, motion, attitude, 0.0)
}

/// Tracks (measured from the pivot `pivot_m` ahead of the rear axle) and the corners they
/// become when the pivot moves along `motion`'s arc.
fn frame_pair_about(
    cfg: &ValidConfig,
    points: &[GroundPoint],
    motion: Motion,
    attitude: Attitude,
    pivot_m: f32,
) -> (std::vec::Vec<Track>, Corners<64>) {
    let c = cfg.config();
    let h = Homography::new(&c.camera, &c.mount, attitude).unwrap();
    let nominal = cfg.projection().nominal;
    let mut tracks = std::vec::Vec::new();
    let mut corners = Corners::<64>::default();
    for (i, p) in points.iter().enumerate() {
        let before = nominal.project(*p).unwrap();
        tracks.push(Track {
            ground: nominal.backproject(before).unwrap().moved_ahead(-pivot_m),
            pixel: Some(before),
            misses: 0,
            age: 1,
        });
        let moved = motion
            .move_point(p.moved_ahead(-pivot_m))
            .moved_ahead(pivot_m);
        let px = h.project(moved).unwrap();
        let c = Corner {
            response: 1000 + i as i32,
            v_px: I16F16::from_num(px.v_px),
            u_px: I16F16::from_num(px.u_px),
        };
        let side = if i % 2 == 0 {
            &mut corners.left
        } else {
            &mut corners.right
        };
        let _ = side.push(c);
    }
    (tracks, corners)
}

fn degrees(pitch_deg: f32, roll_deg: f32) -> Attitude {
    Attitude {
        pitch_rad: pitch_deg.to_radians(),
        roll_rad: roll_deg.to_radians(),
    }
}

/// The tracks matched under `motion` to the observations the last vote left in `search`, with
/// a 4 cm tolerance across the chord and 5 cm along it.
fn matched(
    cfg: &ValidConfig,
    search: &mut Search<64, 64, 64>,
    tracks: usize,
    motion: Motion,
) -> super::matching::Matches {
    let mut observed = [None; 64];
    let prev = search.prev;
    match_tracks(
        cfg,
        &prev[..tracks],
        &mut search.obs,
        0.0,
        motion,
        (0.04, 0.05),
        &mut observed[..tracks],
    )
}

#[test]
fn a_known_motion_gives_its_vote_peak() {
    let cfg = kitti_config().validate().unwrap();
    let level = AttitudeIndex::level(cfg.settings());
    for (alpha_deg, v) in [(0.0f32, 0.9f32), (0.4, 0.7), (-0.6, 1.1)] {
        let truth = Motion {
            heading_change_rad: alpha_deg.to_radians(),
            distance_m: v,
        };
        let (tracks, corners) = frame_pair(&cfg, &scene(50), truth, degrees(0.0, 0.0));
        let window = MotionWindow::around(
            Motion {
                heading_change_rad: truth.heading_change_rad + 0.003,
                distance_m: v - 0.07,
            },
            1f32.to_radians(),
            0.3,
        );
        let mut search = Search::new();
        let out = vote(&cfg, &mut search, (&tracks, &corners), &window, level, 0.0);
        let m = out.motion;
        std::println!(
            "{alpha_deg} {v}: {m:?} {:?} peak {:?}",
            out.attitude,
            out.peak
        );
        assert_eq!(out.attitude, level);
        assert!((m.distance_m - v).abs() < 0.005, "{m:?}");
        assert!(
            (m.heading_change_rad - truth.heading_change_rad).abs() < 0.002f32.to_radians() * 5.0,
            "{m:?}"
        );
    }
}

#[test]
fn a_turn_about_a_pivot_ahead_of_the_rear_axle_is_seen_from_it() {
    let cfg = kitti_config().validate().unwrap();
    let level = AttitudeIndex::level(cfg.settings());
    let truth = Motion {
        heading_change_rad: 2f32.to_radians(),
        distance_m: 1.2,
    };
    let pivot_m = 0.6;
    let (tracks, corners) = frame_pair_about(&cfg, &scene(50), truth, degrees(0.0, 0.0), pivot_m);
    let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
    let heading_error_deg = |pivot: f32, tracks: &[Track]| {
        let mut search = Search::new();
        let out = vote(&cfg, &mut search, (tracks, &corners), &window, level, pivot);
        assert!(
            (out.motion.distance_m - truth.distance_m).abs() < 0.01,
            "{out:?}"
        );
        (out.motion.heading_change_rad - truth.heading_change_rad).to_degrees()
    };
    let seen_from_pivot = heading_error_deg(pivot_m, &tracks);
    // The same tracks measured from the rear axle, as a model without slip would.
    let from_axle: std::vec::Vec<Track> = tracks
        .iter()
        .map(|t| Track {
            ground: t.ground.moved_ahead(pivot_m),
            ..*t
        })
        .collect();
    let seen_from_axle = heading_error_deg(0.0, &from_axle);
    std::println!(
        "heading error: from the pivot {seen_from_pivot} deg, from the axle {seen_from_axle} deg"
    );
    assert!(seen_from_pivot.abs() < 0.015, "{seen_from_pivot}");
    // The arc from the wrong point puts a sideways slip of 0.6 m x 2 deg into the turn.
    assert!(seen_from_axle.abs() > 0.05, "{seen_from_axle}");
}

#[test]
fn a_known_change_of_pitch_or_roll_is_recovered() {
    let cfg = kitti_config().validate().unwrap();
    let level = AttitudeIndex::level(cfg.settings());
    let truth = Motion {
        heading_change_rad: -0.004,
        distance_m: 1.0,
    };
    // Between the frames the body pitches 0.3 deg nose down (three 0.1 deg steps), or rolls
    // 0.4 deg to the right (two 0.2 deg steps). The search is coordinate-wise (pitch at the
    // previous roll, then roll), so under a roll change the pitch may lean by a step, and
    // the distance with it (here 4%): a second pitch pass under the new roll removes that
    // here, but measured worse over the synthetic drives (per-frame heading error sd
    // 0.06-0.10 deg against 0.06-0.08: it lets the pitch chase each frame's noise).
    for (attitude, pitch_steps, roll_steps, pitch_slack, distance_slack) in [
        (degrees(-0.3, 0.0), -3, 0, 0, 3e-3),
        (degrees(0.0, -0.4), 0, -2, 1, 0.05),
    ] {
        let (tracks, corners) = frame_pair(&cfg, &scene(50), truth, attitude);
        let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
        let mut search = Search::new();
        let out = vote(&cfg, &mut search, (&tracks, &corners), &window, level, 0.0);
        let at = out.attitude;
        assert_eq!(
            at.roll,
            level.roll.saturating_add_signed(roll_steps),
            "{at:?}"
        );
        let pitch = level.pitch.saturating_add_signed(pitch_steps);
        assert!(at.pitch.abs_diff(pitch) <= pitch_slack, "{at:?}");
        // Half-pixel distance tents widen the peak; exact pairs keep its centre within 3 mm.
        assert!(
            (out.motion.distance_m - 1.0).abs() < distance_slack,
            "{out:?}"
        );
        assert!(
            (out.motion.heading_change_rad + 0.004).abs() < 3e-4,
            "{out:?}"
        );
    }
}

#[test]
fn a_heading_off_by_a_tenth_of_a_degree_is_refined_from_the_residuals_across_the_chord() {
    let mut config = kitti_config();
    config.settings.refine_heading = true;
    let cfg = config.validate().unwrap();
    let truth = Motion {
        heading_change_rad: 0.01,
        distance_m: 0.9,
    };
    let (tracks, corners) = frame_pair(&cfg, &scene(60), truth, degrees(0.0, 0.0));
    let mut search = Search::new();
    let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
    let level = AttitudeIndex::level(cfg.settings());
    vote(&cfg, &mut search, (&tracks, &corners), &window, level, 0.0);
    // Matched under a heading a tenth of a degree off (2.6 cm across the chord at 15 m,
    // inside the 4 cm tolerance), the pairs' residuals lean one way; the refined heading
    // balances them.
    let off = Motion {
        heading_change_rad: truth.heading_change_rad + 0.1f32.to_radians(),
        ..truth
    };
    let m = matched(&cfg, &mut search, tracks.len(), off);
    assert!(m.count > 40, "{}", m.count);
    let refined = m.refined(off);
    let error_deg = (refined.heading_change_rad - truth.heading_change_rad).to_degrees();
    assert!(
        error_deg.abs() < 0.005,
        "refined heading off by {error_deg} deg"
    );
    assert_eq!(refined.distance_m, off.distance_m);
    // Without the setting no sums are kept and the motion stays as it was.
    let plain = kitti_config().validate().unwrap();
    let m = matched(&plain, &mut search, tracks.len(), off);
    assert_eq!(m.refined(off), off);
}

#[test]
fn a_common_pitch_error_shows_in_distance_against_range() {
    let cfg = kitti_config().validate().unwrap();
    let level = AttitudeIndex::level(cfg.settings());
    let truth = Motion {
        heading_change_rad: 0.002,
        distance_m: 0.9,
    };
    let (mut tracks, corners) = frame_pair(&cfg, &scene(60), truth, degrees(0.0, 0.0));
    // Both frames read 0.3 deg too far nose down.
    let low = AttitudeIndex {
        pitch: level.pitch - 3,
        ..level
    };
    let mut fans = Fans::ZERO;
    fans.build(&cfg);
    let low_h = fans.pitch()[low.pitch];
    for t in tracks.iter_mut() {
        t.ground = low_h.backproject(t.pixel.unwrap()).unwrap();
    }
    let mut search = Search::new();
    let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
    // Fix the hypotheses by voting with the low pitch as the previous frame's.
    let out = vote(&cfg, &mut search, (&tracks, &corners), &window, low, 0.0);
    assert_eq!(out.attitude, low);
    let m = matched(&cfg, &mut search, tracks.len(), out.motion);
    assert!(m.count > 40, "{}", m.count);
    let e = m.common_pitch_error_rad(1.65).unwrap().to_degrees();
    assert!((e - 0.3).abs() < 0.1, "measured {e} deg");
}
