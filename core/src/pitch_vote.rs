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
//! 2. **Hypotheses.** For each of `pitch_steps` body pitches over +-`pitch_range_rad`, every
//!    corner is backprojected exactly (a point, not a quadrilateral) through that pitch's
//!    homography, computed once per configuration.
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
use crate::tracks::Track;
use crate::vote::{MotionWindow, Peak, VoteGrid};
use heapless::Vec;

/// Most bins one track may vote for in a frame; more are ignored.
const MAX_CELLS_PER_TRACK: usize = 256;

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

/// Working memory of the vote; holds nothing between frames.
#[derive(Clone, Debug)]
pub struct PitchVoteScratch<const F: usize, const GRID: usize> {
    grid: VoteGrid<GRID>,
    /// Observations under one pitch, left and right of straight ahead.
    obs: [Vec<GroundPoint, F>; 2],
    /// Which observations a track took in the last matching.
    used: [[bool; F]; 2],
    cells: Vec<u16, MAX_CELLS_PER_TRACK>,
    trig: [Trig; GRID],
}

impl<const F: usize, const GRID: usize> Default for PitchVoteScratch<F, GRID> {
    fn default() -> Self {
        Self {
            grid: VoteGrid::default(),
            obs: [Vec::new(), Vec::new()],
            used: [[false; F]; 2],
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
    /// Index of the winning pitch hypothesis.
    pub pitch_index: usize,
    /// The winning accumulator's peak.
    pub peak: Peak,
}

impl<const F: usize, const GRID: usize> PitchVoteScratch<F, GRID> {
    /// Backprojects the corners through `h` into `self.obs`.
    pub fn observe(&mut self, corners: &Corners<F>, h: &Homography) {
        for (side, heap) in self.obs.iter_mut().zip([&corners.left, &corners.right]) {
            side.clear();
            for c in heap.iter() {
                if let Some(g) = h.backproject(c.pixel()) {
                    // Cannot overflow: as many observations as corners.
                    let _ = side.push(g);
                }
            }
        }
    }

    /// Fills the accumulator with the votes of every track under the current observations.
    fn vote(&mut self, tracks: &[Track], window: &MotionWindow, tolerance_m: f32) {
        self.grid.clear();
        let max_turn = window.heading_lo_rad.abs().max(window.heading_hi_rad.abs());
        let reach = window.distance_lo_m.abs().max(window.distance_hi_m.abs());
        let last = GRID - 1;
        for t in tracks {
            let p = t.ground;
            let radius = libm::hypotf(p.x_m, p.y_m);
            // A turn of at most max_turn moves the point by at most this much, plus the drive.
            let slack = (radius + reach) * max_turn + tolerance_m;
            self.cells.clear();
            for c in self.obs[0].iter().chain(self.obs[1].iter()) {
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
                        // Full: later bins of this track are ignored.
                        let _ = self.cells.push((i * GRID + j) as u16);
                    }
                }
            }
            self.cells.sort_unstable();
            let mut prev = None;
            for &cell in self.cells.iter() {
                if prev != Some(cell) {
                    self.grid
                        .add(usize::from(cell) / GRID, usize::from(cell) % GRID);
                    prev = Some(cell);
                }
            }
        }
    }

    /// Runs the vote: the best pitch hypothesis and the motion it supports. `None` when no pair
    /// voted. `prefer` is the pitch index that wins ties (the previous frame's).
    pub fn estimate(
        &mut self,
        cfg: &ValidConfig,
        tracks: &[Track],
        corners: &Corners<F>,
        window: &MotionWindow,
        prefer: usize,
    ) -> Option<VoteOutcome> {
        for (i, t) in self.trig.iter_mut().enumerate() {
            *t = trig(window.heading_at(i as f32, GRID));
        }
        let tolerance = cfg.config().pitch_vote.lateral_tolerance_m;
        let mut best: Option<(u32, usize)> = None;
        for (k, h) in cfg.pitch_fan().iter().enumerate() {
            self.observe(corners, h);
            self.vote(tracks, window, tolerance);
            let Some(peak) = self.grid.peak() else {
                continue;
            };
            let better = match best {
                None => true,
                Some((score, at)) => {
                    peak.score > score
                        || (peak.score == score && k.abs_diff(prefer) < at.abs_diff(prefer))
                }
            };
            if better {
                best = Some((peak.score, k));
            }
        }
        let (_, k) = best?;
        let h = cfg.pitch_fan()[k];
        self.observe(corners, &h);
        self.vote(tracks, window, tolerance);
        let peak = self.grid.peak()?;
        Some(VoteOutcome {
            motion: window.motion_at(peak.heading_bin, peak.distance_bin, GRID),
            pitch_index: k,
            peak,
        })
    }

    /// Matches tracks to the observations of the last [`estimate`](Self::estimate) under
    /// `motion`: `observed[i]` becomes track `i`'s observation, if any. Returns the matches.
    pub fn match_tracks(
        &mut self,
        tracks: &[Track],
        motion: Motion,
        tolerance_m: f32,
        distance_tolerance_m: f32,
        observed: &mut [Option<GroundPoint>],
    ) -> usize {
        let t = trig(motion.heading_change_rad);
        self.used = [[false; F]; 2];
        let mut matched = 0;
        for (track, slot) in tracks.iter().zip(observed.iter_mut()) {
            *slot = None;
            let mut best: Option<(f32, usize, usize)> = None;
            for (side, obs) in self.obs.iter().enumerate() {
                for (k, c) in obs.iter().enumerate() {
                    if self.used[side][k] {
                        continue;
                    }
                    let (across, v) = residual(track.ground, *c, &t);
                    let along = (v - motion.distance_m).abs();
                    if across.abs() < tolerance_m && along < distance_tolerance_m {
                        let cost = across.abs() + along;
                        if best.is_none_or(|b| cost < b.0) {
                            best = Some((cost, side, k));
                        }
                    }
                }
            }
            if let Some((_, side, k)) = best {
                self.used[side][k] = true;
                *slot = Some(self.obs[side][k]);
                matched += 1;
            }
        }
        matched
    }

    /// Observations of the last vote that no track took in the last
    /// [`match_tracks`](Self::match_tracks).
    pub fn unmatched(&self) -> impl Iterator<Item = GroundPoint> + '_ {
        self.obs
            .iter()
            .zip(&self.used)
            .flat_map(|(obs, used)| obs.iter().zip(used).filter(|(_, u)| !**u).map(|(c, _)| *c))
    }

    /// Marks every observation untaken (nothing matched this frame).
    pub fn forget_matches(&mut self) {
        self.used = [[false; F]; 2];
    }

    /// Every observation of the last vote.
    pub fn observations(&self) -> impl Iterator<Item = GroundPoint> + '_ {
        self.obs[0].iter().chain(self.obs[1].iter()).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
