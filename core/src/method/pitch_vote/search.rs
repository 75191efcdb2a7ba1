//! The vote over the body's attitude: for each hypothesis tried, every corner is backprojected
//! exactly and every track votes for the (heading change, distance) bins its pairs reach; the
//! attitude whose accumulator has the strongest 3x3 peak wins (method steps 2 to 4).

use super::attitude::{AttitudeDrift, AttitudeIndex, Fans, Seen, backproject, near, shift};
use super::comoving::Hidden;
use super::pairs::{Spread, Trig, residual, sort_by_ahead, trig, vote_distance};
use crate::config::ValidConfig;
use crate::harris::Corners;
use crate::motion::Motion;
use crate::projection::GroundPoint;
use crate::tracks::{Observation, Observations, Track};
use crate::vote::{BestPerBin, MotionWindow, Peak, VoteGrid};
use heapless::Vec;

/// What a frame's vote works with.
#[derive(Clone, Copy)]
pub struct Inputs<'a, const F: usize> {
    /// The tracks, in the previous frame (measured from this frame's pivot).
    pub tracks: &'a [Track],
    /// This frame's corners.
    pub corners: &'a Corners<F>,
    /// The corners that move with us: left out of everything.
    pub hidden: &'a Hidden<F>,
    /// The attitude hypotheses.
    pub fans: &'a Fans,
    /// How far ahead of the rear axle this frame's points are measured from, metres.
    pub pivot_m: f32,
}

/// The outcome of a vote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoteOutcome {
    /// The estimated motion.
    pub motion: Motion,
    /// The winning attitude hypothesis for this frame.
    pub attitude: AttitudeIndex,
    /// The attitude the tracks were backprojected at in the previous frame, where a whole step
    /// of the absolute correction moved it; `None`: as the previous frame stored them.
    pub previous: Option<AttitudeIndex>,
    /// The winning accumulator's peak.
    pub peak: Peak,
}

/// Working memory of the vote: after a vote it holds the observations and the tracks' places
/// of the winning attitude, which the matching reads.
#[derive(Clone, Debug)]
pub struct Search<const N: usize, const F: usize, const GRID: usize> {
    grid: VoteGrid<GRID>,
    /// The observations under one attitude.
    pub obs: Observations<F>,
    /// The observations' ground points on each side, nearest first: a track's candidates are
    /// then one run of them (found by bisection) rather than a test of every observation.
    ahead: [Vec<GroundPoint, F>; 2],
    /// The tracks' positions in the previous frame under one attitude for it.
    pub prev: [GroundPoint; N],
    /// One track's votes before they join the accumulator.
    track_votes: BestPerBin<GRID>,
    trig: [Trig; GRID],
}

/// A ground point measured from `pivot_m` ahead of the rear axle.
fn from_pivot(g: Option<GroundPoint>, pivot_m: f32) -> Option<GroundPoint> {
    g.map(|g| g.moved_ahead(-pivot_m))
}

/// The better of `best` (score, index) and hypothesis `k`'s `peak`: the higher score, on a tie
/// the smaller change from `previous`.
fn better(
    best: Option<(u32, usize)>,
    peak: Option<Peak>,
    k: usize,
    previous: usize,
) -> Option<(u32, usize)> {
    let Some(peak) = peak else {
        return best;
    };
    let wins = best.is_none_or(|(s, at)| {
        peak.score > s || (peak.score == s && k.abs_diff(previous) < at.abs_diff(previous))
    });
    if wins { Some((peak.score, k)) } else { best }
}

impl<const N: usize, const F: usize, const GRID: usize> Default for Search<N, F, GRID> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const F: usize, const GRID: usize> Search<N, F, GRID> {
    /// Empty working memory; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            grid: VoteGrid::new(),
            obs: Observations::new(),
            ahead: [Vec::new(), Vec::new()],
            prev: [GroundPoint::ORIGIN; N],
            track_votes: BestPerBin::new(),
            trig: [[0.0; 5]; GRID],
        }
    }

    /// Backprojects the corners seen at body attitude `at` into `self.obs`, but for the hidden.
    pub fn observe(&mut self, inputs: &Inputs<F>, at: Seen) {
        let sides = self.obs.sides.iter_mut().zip(self.ahead.iter_mut());
        let sides = sides.zip(inputs.hidden);
        let heaps = [&inputs.corners.left, &inputs.corners.right];
        for (((side, ahead), hidden), heap) in sides.zip(heaps) {
            side.clear();
            ahead.clear();
            for (c, _) in heap.iter().zip(hidden).filter(|(_, h)| !**h) {
                let pixel = c.pixel();
                if let Some(ground) = from_pivot(backproject(at, pixel), inputs.pivot_m) {
                    // Cannot overflow: as many observations as corners.
                    let _ = side.push(Observation { ground, pixel });
                    let _ = ahead.push(ground);
                }
            }
            sort_by_ahead(ahead);
        }
    }

    /// Places the tracks in the previous frame: those seen there backprojected from their pixel
    /// at attitude `at` (`None`: as stored, under the previous frame's own estimate), the others
    /// where the motion carried them.
    fn place_tracks(&mut self, inputs: &Inputs<F>, at: Option<Seen>) {
        for (slot, t) in self.prev.iter_mut().zip(inputs.tracks) {
            *slot = match (at, t.pixel) {
                (Some(at), Some(px)) => {
                    from_pivot(backproject(at, px), inputs.pivot_m).unwrap_or(t.ground)
                }
                _ => t.ground,
            };
        }
    }

    /// Puts back the observations and the tracks' places of `outcome`, after another vote used
    /// this working memory.
    pub fn restore(&mut self, inputs: &Inputs<F>, outcome: &VoteOutcome) {
        let previous = outcome.previous.and_then(|p| inputs.fans.seen(p));
        self.place_tracks(inputs, previous);
        if let Some(cur) = inputs.fans.seen(outcome.attitude) {
            self.observe(inputs, cur);
        }
    }

    /// Fills the accumulator with the votes of every track under the current observations.
    fn vote(&mut self, cfg: &ValidConfig, inputs: &Inputs<F>, window: &MotionWindow, sharp: bool) {
        self.grid.clear();
        let tolerance_m = cfg.settings().lateral_tolerance_m;
        let max_turn = window.heading_lo_rad.abs().max(window.heading_hi_rad.abs());
        let reach = window.distance_lo_m.abs().max(window.distance_hi_m.abs());
        let last = GRID - 1;
        let spread = Spread::new(cfg, sharp, inputs.pivot_m);
        let Self {
            grid,
            ahead,
            prev,
            track_votes,
            trig,
            ..
        } = self;
        for &p in prev.iter().take(inputs.tracks.len()) {
            let radius = libm::hypotf(p.x_m, p.y_m);
            // A turn of at most max_turn moves the point by at most this much, plus the drive.
            let slack = (radius + reach) * max_turn + tolerance_m;
            let var_p = spread.range_variance(p);
            // The observations whose range can join the track: x in [p.x - hi, p.x - lo] with
            // the slack (and a centimetre for rounding, the exact test follows).
            let (near_m, far_m) = (
                p.x_m - window.distance_hi_m - slack - 0.01,
                p.x_m - window.distance_lo_m + slack + 0.01,
            );
            let candidates = ahead.iter().flat_map(|side| {
                let from = side.partition_point(|c| c.x_m < near_m);
                side.get(from..)
                    .unwrap_or_default()
                    .iter()
                    .take_while(move |c| c.x_m <= far_m)
            });
            for c in candidates {
                let dx = p.x_m - c.x_m;
                if dx < window.distance_lo_m - slack
                    || dx > window.distance_hi_m + slack
                    || (p.y_m - c.y_m).abs() > slack
                {
                    continue;
                }
                let (r0, _) = residual(p, *c, &trig[0]);
                let (r1, _) = residual(p, *c, &trig[last]);
                let slope = (r1 - r0) / last as f32;
                let (lo, hi) = if window.heading_lo_rad == window.heading_hi_rad {
                    // The heading is given (the whole image's): a vote over distance alone.
                    (GRID / 2, GRID / 2)
                } else if slope.abs() < 1e-9 {
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
                // Half width of the pair's distance tent, metres (0: sharp).
                let half_m = spread.half_width_m(var_p, *c);
                for (i, t) in trig.iter().enumerate().take(hi + 1).skip(lo) {
                    let (r, v) = residual(p, *c, t);
                    if r.abs() < tolerance_m {
                        // A tent over the tolerance: a pair fits a band of headings, and only
                        // weights that fall off across it give the band's sum a sharp peak.
                        let lateral = 1.0 - r.abs() / tolerance_m;
                        vote_distance(track_votes, window, i, v, half_m, lateral, tolerance_m);
                    }
                }
            }
            // A track gives each bin one vote: it cannot outvote others by pairing with
            // clustered observations.
            track_votes.add_to(grid);
        }
    }

    /// Votes with the tracks as placed and the corners seen at `cur`; the peak.
    fn try_attitude(
        &mut self,
        cfg: &ValidConfig,
        inputs: &Inputs<F>,
        cur: Seen,
        window: &MotionWindow,
        sharp: bool,
    ) -> Option<Peak> {
        self.observe(inputs, cur);
        self.vote(cfg, inputs, window, sharp);
        self.grid.peak()
    }

    /// Runs the vote: the best attitude hypotheses and the motion they support. `None` when no
    /// pair voted. `previous` is the attitude the previous frame settled on; `drift` holds the
    /// absolute pitch and roll corrections (in steps): where one holds a whole step, both
    /// frames' attitudes move by it. `spread`: the final vote uses distance tents (not at
    /// start-up, see the module docs).
    pub fn estimate(
        &mut self,
        cfg: &ValidConfig,
        inputs: &Inputs<F>,
        window: &MotionWindow,
        previous: AttitudeIndex,
        drift: &mut AttitudeDrift,
        spread: bool,
    ) -> Option<VoteOutcome> {
        for (i, t) in self.trig.iter_mut().enumerate() {
            *t = trig(window.heading_at(i as f32, GRID));
        }
        let s = cfg.settings();
        let (fan, rolls) = (inputs.fans.pitch(), inputs.fans.roll());
        let prev_roll = rolls.get(previous.roll)?;
        // Relative passes: the previous frame as it was estimated; this frame's pitches at the
        // previous roll, then its rolls at the best pitch. Better score wins; on a tie, the
        // smaller change.
        self.place_tracks(inputs, None);
        let mut pitch: Option<(u32, usize)> = None;
        for k in near(previous.pitch, s.max_pitch_change_steps, fan.len()) {
            let cur = (fan.get(k)?, prev_roll);
            let peak = self.try_attitude(cfg, inputs, cur, window, true);
            pitch = better(pitch, peak, k, previous.pitch);
        }
        let (score, cur_pitch) = pitch?;
        let h = fan.get(cur_pitch)?;
        let mut roll = Some((score, previous.roll));
        for j in near(previous.roll, s.max_roll_change_steps, rolls.len()) {
            if j != previous.roll {
                let cur = (h, rolls.get(j)?);
                let peak = self.try_attitude(cfg, inputs, cur, window, true);
                roll = better(roll, peak, j, previous.roll);
            }
        }
        let (_, cur_roll) = roll?;
        // Absolute corrections move both frames.
        let (p, c) = shift(&mut drift.pitch_steps, previous.pitch, cur_pitch, fan.len());
        let (pr, cr) = shift(&mut drift.roll_steps, previous.roll, cur_roll, rolls.len());
        let moved = AttitudeIndex { pitch: p, roll: pr };
        let placed = (moved != previous).then_some(moved);
        if let Some(at) = placed {
            self.place_tracks(inputs, Some((fan.get(at.pitch)?, rolls.get(at.roll)?)));
        }
        let cur = (fan.get(c)?, rolls.get(cr)?);
        let peak = self.try_attitude(cfg, inputs, cur, window, !spread)?;
        Some(VoteOutcome {
            motion: window.motion_at(peak.heading_bin, peak.distance_bin, GRID),
            attitude: AttitudeIndex { pitch: c, roll: cr },
            previous: placed,
            peak,
        })
    }
}
