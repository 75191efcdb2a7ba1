//! The default method: a joint vote over the frame's body pitch, its heading change and its
//! distance (BRIEF §7).
//!
//! ## Why not the paper's vote
//! Under the paper's dynamics limits the motion patch at 10 frames/s is +-0.1 deg by +-1.5 cm,
//! while a pitch of +-1 deg makes each observation quadrilateral +-0.4 m long at 6 m and +-1.5 m
//! at 12 m: every overlapping quadrilateral covers the whole patch, the vote is flat and speed
//! cannot be observed. But the body's pitch is one value per frame, shared by every feature; the
//! quadrilaterals treat it as independent per feature. Voting over it recovers the information.
//!
//! ## The method, per frame
//! 1. **Window.** The motions considered are the previous motion +- (`heading_half_rad`,
//!    `distance_half_m`) per frame, scaled to the frame interval; with no previous motion, heading
//!    +-`startup_heading_half_rad` and distance 0 to `startup_distance_max_m`. After a fallback
//!    frame the window doubles (up to the start-up window) until a vote succeeds.
//! 2. **Hypotheses.** For body pitches over +-`pitch_range_rad` in `pitch_steps` steps, every
//!    corner is backprojected exactly (a point, not a quadrilateral) through that pitch's
//!    homography, computed once per configuration. The search runs in two passes:
//!    - *relative*: the tracks stay where the previous frame put them, under its pitch estimate,
//!      and every pitch of the current frame is tried;
//!    - *absolute*: the relative pass only sees changes of pitch; an error common to both frames
//!      goes unseen by it and the pitch drifts, the distance with it (measured: -1 deg and 14%
//!      short after 150 frames). But a common error `e` (radians, too far nose down) moves a
//!      point at range `x` nearer by about `(x^2 + h^2) e / h`, so a matched pair at mean range
//!      `x` shows the distance `v (1 - 2 x e / h)`: the slope of the matched pairs' distances
//!      against their range measures `e` ([`PitchVoteScratch::common_pitch_error_rad`]). Each
//!      frame's measurement feeds an integrator (gain `ABSOLUTE_GAIN`, in pitch steps); its whole
//!      steps move both frames' pitches and the track positions are backprojected again from
//!      their pixels. The relative pass only looks `max_pitch_change_steps` each way, so that it
//!      cannot run away from the absolute correction (seen in a tight turn: 0.2 deg a frame). Comparing vote peaks over common shifts instead
//!      was tried and measured too noisy (the best shift jumped by +-0.3 deg frame to frame).
//! 3. **Pairs.** Each track `p` (a ground point in the previous vehicle frame) and each
//!    observation `c` (in the current one) that the window can join form a pair. For a heading
//!    change alpha the arc model says `p - R(alpha) c` is the chord, of direction alpha/2: its
//!    component along alpha/2 gives the distance `v = l / sinc(alpha/2)`, the component across
//!    it is the residual. The residual is nearly linear in alpha, so the heading bins where it is
//!    under `lateral_tolerance_m` are found from its values at the window's two ends, then
//!    checked exactly.
//! 4. **Vote.** Each track gives one vote to each bin (heading, distance) that any of its pairs
//!    reaches: a track cannot outvote others by pairing with clustered observations. The pitch
//!    whose accumulator has the strongest peak (votes in the 3x3 bins around its highest bin)
//!    wins; the motion is the centre of gravity of those 3x3 bins.
//! 5. **Matches.** At the winning pitch and motion each track takes the unused observation with
//!    the smallest residual, if under the tolerance both across and along the chord.
//!
//! Fallback, track update and integration are the odometer's (paper §2.3 and §5).

use crate::config::ValidConfig;
use crate::harris::Corners;
use crate::motion::Motion;
use crate::projection::{GroundPoint, Homography};
use crate::tracks::{Observation, Track};
use crate::vote::{MotionWindow, Peak, VoteGrid};
use heapless::Vec;

/// Most bins one track may vote for in a frame; more are ignored.
const MAX_CELLS_PER_TRACK: usize = 256;
/// Largest weight of a vote, for a pair that fits exactly (1 at the tolerance's edge).
const VOTE_WEIGHT: u16 = 8;
/// Share of each frame's measured common pitch error (in steps) that goes into the integrator.
pub const ABSOLUTE_GAIN: f32 = 0.2;

/// Per heading bin: cos alpha, sin alpha, cos alpha/2, sin alpha/2, 1 / sinc(alpha/2).
type Trig = [f32; 5];

fn trig(alpha: f32) -> Trig {
    let half = 0.5 * alpha;
    let sinc = if half.abs() < 1e-2 {
        1.0 - half * half / 6.0
    } else {
        libm::sinf(half) / half
    };
    [
        libm::cosf(alpha),
        libm::sinf(alpha),
        libm::cosf(half),
        libm::sinf(half),
        1.0 / sinc,
    ]
}

/// Residual across the chord and distance along the arc of track `p` and observation `c` under
/// the heading change of `t`.
fn residual(p: GroundPoint, c: GroundPoint, t: &Trig) -> (f32, f32) {
    let [ca, sa, ch, sh, inv_sinc] = *t;
    let wx = p.x_m - (ca * c.x_m - sa * c.y_m);
    let wy = p.y_m - (sa * c.x_m + ca * c.y_m);
    let along = wx * ch + wy * sh;
    let across = -wx * sh + wy * ch;
    (across, along * inv_sinc)
}

/// Sorts one track's cells, ascending. Insertion sort rather than `sort_unstable`: a track's
/// cells are few and mostly in order already, and core's sort keeps a panic path (for `Ord`
/// impls that break its contract) that the firmware's panic-free link check refuses.
fn sort_cells(cells: &mut [(u16, u16)]) {
    for i in 1..cells.len() {
        let mut j = i;
        while j > 0 && cells[j - 1] > cells[j] {
            cells.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// Working memory of the vote; holds nothing between frames.
#[derive(Clone, Debug)]
pub struct PitchVoteScratch<const N: usize, const F: usize, const GRID: usize> {
    grid: VoteGrid<GRID>,
    /// Observations under one pitch, left and right of straight ahead.
    obs: [Vec<Observation, F>; 2],
    /// The tracks' positions in the previous frame under one pitch hypothesis for it.
    prev: [GroundPoint; N],
    /// Which observations a track took in the last matching.
    used: [[bool; F]; 2],
    /// Sums over the last matching's pairs of (range, distance): n, x, v, xx, xv.
    regression: [f32; 5],
    /// One track's bins as (heading bin * GRID + distance bin, weight).
    cells: Vec<(u16, u16), MAX_CELLS_PER_TRACK>,
    trig: [Trig; GRID],
}

impl<const N: usize, const F: usize, const GRID: usize> Default for PitchVoteScratch<N, F, GRID> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const F: usize, const GRID: usize> PitchVoteScratch<N, F, GRID> {
    /// Empty working memory; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            grid: VoteGrid::new(),
            obs: [Vec::new(), Vec::new()],
            prev: [GroundPoint::ORIGIN; N],
            used: [[false; F]; 2],
            regression: [0.0; 5],
            cells: Vec::new(),
            trig: [[0.0; 5]; GRID],
        }
    }
}

/// The outcome of a vote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoteOutcome {
    /// The estimated motion.
    pub motion: Motion,
    /// Index of the winning pitch hypothesis for this frame.
    pub pitch_index: usize,
    /// The winning accumulator's peak.
    pub peak: Peak,
}

impl<const N: usize, const F: usize, const GRID: usize> PitchVoteScratch<N, F, GRID> {
    /// Backprojects the corners through `h` into `self.obs`.
    pub fn observe(&mut self, corners: &Corners<F>, h: &Homography) {
        for (side, heap) in self.obs.iter_mut().zip([&corners.left, &corners.right]) {
            side.clear();
            for c in heap.iter() {
                let pixel = c.pixel();
                if let Some(ground) = h.backproject(pixel) {
                    // Cannot overflow: as many observations as corners.
                    let _ = side.push(Observation { ground, pixel });
                }
            }
        }
    }

    /// Places the tracks in the previous frame: those seen there backprojected from their pixel
    /// through `h` (`None`: as stored, under the previous frame's own estimate), the others
    /// where the motion carried them.
    fn place_tracks(&mut self, tracks: &[Track], h: Option<&Homography>) {
        for (slot, t) in self.prev.iter_mut().zip(tracks) {
            *slot = match (h, t.pixel) {
                (Some(h), Some(px)) => h.backproject(px).unwrap_or(t.ground),
                _ => t.ground,
            };
        }
    }

    /// Fills the accumulator with the votes of every track under the current observations.
    fn vote(&mut self, tracks: usize, window: &MotionWindow, tolerance_m: f32) {
        self.grid.clear();
        let max_turn = window.heading_lo_rad.abs().max(window.heading_hi_rad.abs());
        let reach = window.distance_lo_m.abs().max(window.distance_hi_m.abs());
        let last = GRID - 1;
        for &p in self.prev.iter().take(tracks) {
            let radius = libm::hypotf(p.x_m, p.y_m);
            // A turn of at most max_turn moves the point by at most this much, plus the drive.
            let slack = (radius + reach) * max_turn + tolerance_m;
            self.cells.clear();
            for o in self.obs[0].iter().chain(self.obs[1].iter()) {
                let c = &o.ground;
                let dx = p.x_m - c.x_m;
                if dx < window.distance_lo_m - slack
                    || dx > window.distance_hi_m + slack
                    || (p.y_m - c.y_m).abs() > slack
                {
                    continue;
                }
                let (r0, _) = residual(p, *c, &self.trig[0]);
                let (r1, _) = residual(p, *c, &self.trig[last]);
                let slope = (r1 - r0) / last as f32;
                let (lo, hi) = if slope.abs() < 1e-9 {
                    if r0.abs() >= tolerance_m {
                        continue;
                    }
                    (0, last)
                } else {
                    let centre = -r0 / slope;
                    let half = tolerance_m / slope.abs();
                    // One bin of margin each side for the curvature of the residual.
                    let lo = libm::floorf(centre - half) - 1.0;
                    let hi = libm::ceilf(centre + half) + 1.0;
                    if hi < 0.0 || lo > last as f32 {
                        continue;
                    }
                    (lo.max(0.0) as usize, (hi as usize).min(last))
                };
                for i in lo..=hi {
                    let (r, v) = residual(p, *c, &self.trig[i]);
                    if r.abs() < tolerance_m
                        && let Some(j) = window.distance_bin(v, GRID)
                    {
                        // A tent over the tolerance: a pair fits a band of headings, and only
                        // weights that fall off across it give the band's sum a sharp peak.
                        let weight =
                            1 + (f32::from(VOTE_WEIGHT) * (1.0 - r.abs() / tolerance_m)) as u16;
                        // Full: later bins of this track are ignored.
                        let _ = self.cells.push(((i * GRID + j) as u16, weight));
                    }
                }
            }
            // Each bin takes a track's best weight once.
            sort_cells(&mut self.cells);
            for (k, &(cell, weight)) in self.cells.iter().enumerate() {
                let last_of_cell = self.cells.get(k + 1).is_none_or(|next| next.0 != cell);
                if last_of_cell {
                    self.grid
                        .add(usize::from(cell) / GRID, usize::from(cell) % GRID, weight);
                }
            }
        }
    }

    /// Votes with the tracks placed by `prev` and the corners seen through `cur`; the peak.
    fn try_pitches(
        &mut self,
        tracks: &[Track],
        corners: &Corners<F>,
        prev: Option<&Homography>,
        cur: &Homography,
        window: &MotionWindow,
        tolerance_m: f32,
    ) -> Option<Peak> {
        self.place_tracks(tracks, prev);
        self.observe(corners, cur);
        self.vote(tracks.len(), window, tolerance_m);
        self.grid.peak()
    }

    /// Runs the vote: the best pitch hypotheses and the motion they support. `None` when no pair
    /// voted. `previous` is the pitch index the previous frame settled on; `integrator` is the
    /// absolute-pitch integrator (in steps): where it holds a whole step, both frames' pitches
    /// move by it.
    pub fn estimate(
        &mut self,
        cfg: &ValidConfig,
        tracks: &[Track],
        corners: &Corners<F>,
        window: &MotionWindow,
        previous: usize,
        integrator: &mut f32,
    ) -> Option<VoteOutcome> {
        for (i, t) in self.trig.iter_mut().enumerate() {
            *t = trig(window.heading_at(i as f32, GRID));
        }
        let tolerance = cfg.config().pitch_vote.lateral_tolerance_m;
        let fan = cfg.pitch_fan();
        // Relative pass: the previous frame as it was estimated, every pitch for this one. Better
        // score wins; on a tie, the smaller change.
        let mut best: Option<(u32, usize)> = None;
        let reach = usize::from(cfg.config().pitch_vote.max_pitch_change_steps);
        let near = previous.saturating_sub(reach)..=previous + reach;
        for (k, h) in fan.iter().enumerate().filter(|(k, _)| near.contains(k)) {
            let Some(peak) = self.try_pitches(tracks, corners, None, h, window, tolerance) else {
                continue;
            };
            let better = best.is_none_or(|(s, at)| {
                peak.score > s || (peak.score == s && k.abs_diff(previous) < at.abs_diff(previous))
            });
            if better {
                best = Some((peak.score, k));
            }
        }
        let (_, cur) = best?;
        // Absolute correction: the integrator's whole steps move both frames, as far as the
        // range allows; what the range cuts off is dropped, so the integrator cannot wind up.
        let last = fan.len() as isize - 1;
        let (lo, hi) = (previous.min(cur) as isize, previous.max(cur) as isize);
        // max then min rather than clamp: no panic path for bounds the compiler cannot order.
        let step = (libm::truncf(*integrator) as isize).max(-lo).min(last - hi);
        *integrator = (*integrator - step as f32).clamp(-1.0, 1.0);
        let (p, c) = (
            previous.saturating_add_signed(step),
            cur.saturating_add_signed(step),
        );
        let prev_h = if p == previous { None } else { fan.get(p) };
        let peak = self.try_pitches(tracks, corners, prev_h, fan.get(c)?, window, tolerance)?;
        Some(VoteOutcome {
            motion: window.motion_at(peak.heading_bin, peak.distance_bin, GRID),
            pitch_index: c,
            peak,
        })
    }

    /// Matches tracks to the observations of the last [`estimate`](Self::estimate) under
    /// `motion`: `observed[i]` becomes track `i`'s observation, if any. Returns the matches.
    pub fn match_tracks(
        &mut self,
        cfg: &ValidConfig,
        tracks: &[Track],
        motion: Motion,
        tolerance_m: f32,
        distance_tolerance_m: f32,
        observed: &mut [Option<Observation>],
    ) -> usize {
        let t = trig(motion.heading_change_rad);
        self.used = [[false; F]; 2];
        self.regression = [0.0; 5];
        let mut matched = 0;
        for (&p, slot) in self.prev.iter().take(tracks.len()).zip(observed.iter_mut()) {
            *slot = None;
            let mut best: Option<(f32, usize, usize)> = None;
            for (side, (obs, used)) in self.obs.iter().zip(&self.used).enumerate() {
                for (k, (c, &used)) in obs.iter().zip(used).enumerate() {
                    if used {
                        continue;
                    }
                    let (across, v) = residual(p, c.ground, &t);
                    let along = (v - motion.distance_m).abs();
                    if across.abs() < tolerance_m && along < distance_tolerance_m {
                        let cost = across.abs() + along;
                        if best.is_none_or(|b| cost < b.0) {
                            best = Some((cost, side, k));
                        }
                    }
                }
            }
            let taken = best.and_then(|(_, side, k)| {
                let used = self.used.get_mut(side)?.get_mut(k)?;
                *used = true;
                self.obs.get(side)?.get(k).copied()
            });
            if let Some(o) = taken {
                *slot = Some(o);
                matched += 1;
                let (_, v) = residual(p, o.ground, &t);
                let x = 0.5 * (cfg.window_coords(p).0 + cfg.window_coords(o.ground).0);
                let r = &mut self.regression;
                *r = [r[0] + 1.0, r[1] + x, r[2] + v, r[3] + x * x, r[4] + x * v];
            }
        }
        matched
    }

    /// Observations of the last vote that no track took in the last
    /// [`match_tracks`](Self::match_tracks).
    pub fn unmatched(&self) -> impl Iterator<Item = Observation> + '_ {
        self.obs
            .iter()
            .zip(&self.used)
            .flat_map(|(obs, used)| obs.iter().zip(used).filter(|(_, u)| !**u).map(|(c, _)| *c))
    }

    /// The common pitch error of both frames the last matching's pairs show, radians, positive
    /// when the hypotheses are too far nose down (see the module docs). `None` with fewer than
    /// eight pairs, ranges spread over less than a metre, or under 0.2 m of travel.
    pub fn common_pitch_error_rad(&self, height_m: f32) -> Option<f32> {
        let [n, sx, sv, sxx, sxv] = self.regression;
        if n < 8.0 {
            return None;
        }
        let var = sxx / n - (sx / n) * (sx / n);
        let v = sv / n;
        if var < 1.0 || v.abs() < 0.2 {
            return None;
        }
        let slope = (sxv / n - (sx / n) * v) / var;
        Some(-slope * height_m / (2.0 * v))
    }

    /// Marks every observation untaken (nothing matched this frame).
    pub fn forget_matches(&mut self) {
        self.used = [[false; F]; 2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::kitti_config;
    use crate::harris::Corner;
    use fixed::types::I16F16;

    /// Ground points spread over the KITTI window, pseudo-random but fixed.
    fn scene(n: usize) -> std::vec::Vec<GroundPoint> {
        let mut x = 12345u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x % 10_000) as f32 / 10_000.0
        };
        (0..n)
            .map(|_| GroundPoint {
                x_m: 7.0 + 6.0 * next(),
                y_m: -2.5 + 5.0 * next(),
            })
            .collect()
    }

    /// Tracks at `points` and the corners where `motion` moves them, seen at body pitch `pitch_index`.
    fn frame_pair(
        cfg: &ValidConfig,
        points: &[GroundPoint],
        motion: Motion,
        pitch_index: usize,
    ) -> (std::vec::Vec<Track>, Corners<64>) {
        let h = cfg.pitch_fan()[pitch_index];
        let nominal = cfg.pitch_fan()[cfg.pitch_fan().len() / 2];
        let mut tracks = std::vec::Vec::new();
        let mut corners = Corners::<64>::default();
        for (i, p) in points.iter().enumerate() {
            let before = nominal.project(*p).unwrap();
            tracks.push(Track {
                ground: nominal.backproject(before).unwrap(),
                pixel: Some(before),
                misses: 0,
                age: 1,
            });
            let px = h.project(motion.move_point(*p)).unwrap();
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

    #[test]
    fn a_known_motion_gives_its_vote_peak() {
        let cfg = kitti_config().validate().unwrap();
        let level = cfg.pitch_fan().len() / 2;
        for (alpha_deg, v) in [(0.0f32, 0.9f32), (0.4, 0.7), (-0.6, 1.1)] {
            let truth = Motion {
                heading_change_rad: alpha_deg.to_radians(),
                distance_m: v,
            };
            let (tracks, corners) = frame_pair(&cfg, &scene(50), truth, level);
            let window = MotionWindow::around(
                Motion {
                    heading_change_rad: truth.heading_change_rad + 0.003,
                    distance_m: v - 0.07,
                },
                1f32.to_radians(),
                0.3,
            );
            let mut scratch = PitchVoteScratch::<64, 64, 64>::default();
            let mut integrator = 0.0;
            let out = scratch
                .estimate(&cfg, &tracks, &corners, &window, level, &mut integrator)
                .unwrap();
            let m = out.motion;
            std::println!(
                "{alpha_deg} {v}: {m:?} pitch {} peak {:?}",
                out.pitch_index,
                out.peak
            );
            assert_eq!(out.pitch_index, level);
            assert!((m.distance_m - v).abs() < 0.005, "{m:?}");
            assert!(
                (m.heading_change_rad - truth.heading_change_rad).abs()
                    < 0.002f32.to_radians() * 5.0,
                "{m:?}"
            );
        }
    }

    #[test]
    fn a_known_change_of_pitch_is_recovered() {
        let cfg = kitti_config().validate().unwrap();
        let level = cfg.pitch_fan().len() / 2;
        let truth = Motion {
            heading_change_rad: -0.004,
            distance_m: 1.0,
        };
        // The body pitches 0.3 deg nose down between the frames.
        let (tracks, corners) = frame_pair(&cfg, &scene(50), truth, level - 3);
        let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
        let mut scratch = PitchVoteScratch::<64, 64, 64>::default();
        let out = scratch
            .estimate(&cfg, &tracks, &corners, &window, level, &mut 0.0)
            .unwrap();
        assert_eq!(out.pitch_index, level - 3);
        assert!((out.motion.distance_m - 1.0).abs() < 2e-3, "{out:?}");
    }

    #[test]
    fn a_common_pitch_error_shows_in_distance_against_range() {
        let cfg = kitti_config().validate().unwrap();
        let level = cfg.pitch_fan().len() / 2;
        let truth = Motion {
            heading_change_rad: 0.002,
            distance_m: 0.9,
        };
        let (mut tracks, corners) = frame_pair(&cfg, &scene(60), truth, level);
        // Both frames read 0.3 deg too far nose down.
        let low = cfg.pitch_fan()[level - 3];
        for t in tracks.iter_mut() {
            t.ground = low.backproject(t.pixel.unwrap()).unwrap();
        }
        let mut scratch = PitchVoteScratch::<64, 64, 64>::default();
        let window = MotionWindow::around(truth, 1f32.to_radians(), 0.3);
        let mut integrator = 0.0;
        // Fix the hypotheses by voting with the low pitch as the previous frame's.
        let out = scratch
            .estimate(&cfg, &tracks, &corners, &window, level - 3, &mut integrator)
            .unwrap();
        assert_eq!(out.pitch_index, level - 3);
        let mut observed = [None; 64];
        let n = tracks.len();
        let matched =
            scratch.match_tracks(&cfg, &tracks, out.motion, 0.04, 0.05, &mut observed[..n]);
        assert!(matched > 40, "{matched}");
        let e = scratch.common_pitch_error_rad(1.65).unwrap().to_degrees();
        assert!((e - 0.3).abs() < 0.1, "measured {e} deg");
    }

    #[test]
    fn residual_is_zero_for_the_true_motion() {
        let m = Motion {
            heading_change_rad: 0.02,
            distance_m: 1.1,
        };
        let p = GroundPoint {
            x_m: 9.0,
            y_m: -1.2,
        };
        let c = m.move_point(p);
        let (across, v) = residual(p, c, &trig(m.heading_change_rad));
        assert!(across.abs() < 1e-5, "{across}");
        assert!((v - 1.1).abs() < 1e-5, "{v}");
        // A wrong heading leaves a lateral residual of about the point's range times the error.
        let (off, _) = residual(p, c, &trig(m.heading_change_rad + 0.01));
        assert!(off.abs() > 0.05, "{off}");
    }
}
