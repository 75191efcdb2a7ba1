//! The pitch vote, the default method: a joint vote over the frame's body attitude (pitch and
//! roll), its heading change and its distance (BRIEF §7).
//!
//! The paper's vote cannot observe speed: under its dynamics limits the motion patch is far
//! smaller than a corner's observation quadrilateral, and every quadrilateral covers the whole
//! patch. But the body's attitude is one value per frame, shared by every corner; voting over it
//! recovers what the quadrilaterals spread out. Per frame (`docs/method.md` has the figures
//! behind each choice):
//!
//! 1. **Window** ([`PitchVote::window`]): the previous motion +- (`heading_window_deg`,
//!    `distance_window_m`), doubled after each fallback up to the start-up window, never
//!    reaching towards a stop further than half the previous distance, and always taking in the
//!    steady speed's distance; with no previous motion, the start-up window.
//! 2. **Hypotheses** ([`attitude`]): each corner backprojected exactly under body pitches and
//!    rolls about the previous frame's (relative passes: pitch, then roll); whole steps of the
//!    absolute correction (the common pitch error the matched pairs measure) and of the settling
//!    back to level move both frames' hypotheses.
//! 3. **Pairs** ([`pairs`]): every track and observation the window can join, measured from the
//!    pivot (`pivot_s2_per_m`: tyre slip), give a distance along the arc's chord and a residual
//!    across it.
//! 4. **Vote** ([`search`]): each track votes once for each bin its pairs reach, a tent across
//!    the lateral tolerance and along the distance its corners' rows allow; the attitude with
//!    the strongest 3x3 peak wins, its centre of gravity is the motion.
//! 5. **Match** ([`matching`]): each track takes its best observation under that motion; with
//!    `refine_heading` the heading is refined from the pairs' residuals across the chord.
//! 6. **Re-acquire**: after [`REACQUIRE_AFTER_FRAMES`] weakly supported frames in a row, a weak
//!    frame also votes over the start-up window and takes that outcome on a clear majority.
//! 7. **The ground's own heading**: where the vote was over distance at a heading the whole
//!    image took from the road alone (`weigh_road_heading`), steps 2 to 4 once more over the
//!    window of the heading too, for the heading they find.
//! 8. **Weigh** (in the odometer): the vote against the prediction, the prediction weighing as
//!    `prior_matches` tracks; the image's heading and the ground's of step 7 by their running
//!    disagreements ([`crate::road_heading`]).
//!
//! Corners that move with the vehicle ([`comoving`]) are set aside before all of it.

pub mod attitude;
pub mod comoving;
pub mod matching;
pub mod pairs;
pub mod search;
#[cfg(test)]
mod tests;

use super::{Frame, Outcome, Prior};
use crate::config::ValidConfig;
use crate::harris::Corners;
use crate::heading::{ImageHeading, ImageMotion, ImagePrior};
use crate::motion::Motion;
use crate::projection::{Attitude, Homography, Pixel, RollMap};
use crate::time::Duration;
use crate::tracks::Observation;
use crate::vote::MotionWindow;
use attitude::{AttitudeDrift, AttitudeIndex, Fans, backproject};
use comoving::{Comoving, Hidden};
use matching::{Matches, match_tracks};
use search::{Inputs, Search, VoteOutcome};

/// Largest pivot ahead of the rear axle, metres: a guard against a runaway speed, not part of
/// the model (whose pivot grows with the speed squared as long as the tyres stay linear; at
/// 0.004 s^2/m it binds above 127 km/h).
const MAX_PIVOT_M: f32 = 5.0;

/// Most window doublings after fallbacks in a row: 8 times the window, past which the start-up
/// window's size caps it anyway.
const MAX_WIDEN: u8 = 3;

/// Frames in a row with weak support after which each weak frame also votes over the start-up
/// window: the window around the last motion follows whatever it holds, and a vote that locked
/// on a wrong motion with a few consistent pairs (a start-up on few corners, frames the camera
/// dropped without saying so) would stay there while they last. Measured in `docs/experiments.md`
/// ("Re-acquisition").
pub const REACQUIRE_AFTER_FRAMES: u8 = 3;

/// A frame's support is weak under this many times `min_inlier_ratio` of its corners matched.
const WEAK_SUPPORT: f32 = 2.0;

/// The start-up window's outcome is taken where it matches at least this many times the tracks
/// the frame's own vote matched...
const REACQUIRE_FACTOR: usize = 2;
/// ...and this many more: a clear majority, so that near-equal draws keep the tracked estimate.
const REACQUIRE_MARGIN: usize = 4;

/// Along the chord a match may be off by the bins the 3x3 centre of gravity spans, each side.
const MATCH_ALONG_BINS: f32 = 2.0;

/// The pitch vote's state across frames and its working memory.
#[derive(Clone, Debug)]
pub struct PitchVote<const N: usize, const F: usize, const GRID: usize, const K: usize> {
    fans: Fans,
    /// The attitude hypothesis the last frame settled on.
    attitude: AttitudeIndex,
    /// Attitude corrections waiting to be applied.
    drift: AttitudeDrift,
    /// Frames in a row whose support was weak.
    weak_frames: u8,
    comoving: Comoving<F>,
    /// This frame's corners that move with us.
    hidden: Hidden<F>,
    search: Search<N, F, GRID>,
    /// Track i's observation in this frame, if matched.
    observed: [Option<Observation>; N],
    /// The heading change from the whole image.
    pub(crate) image: ImageHeading<K>,
}

impl<const N: usize, const F: usize, const GRID: usize, const K: usize> PitchVote<N, F, GRID, K> {
    /// No configuration: every bit zero, for a zero-initialised `static`.
    pub const ZERO: Self = Self {
        fans: Fans::ZERO,
        attitude: AttitudeIndex { pitch: 0, roll: 0 },
        drift: AttitudeDrift::ZERO,
        weak_frames: 0,
        comoving: Comoving::new(),
        hidden: [[false; F]; 2],
        search: Search::new(),
        observed: [None; N],
        image: ImageHeading::ZERO,
    };

    /// Takes `cfg` (its hypotheses built in place) and forgets every frame.
    pub fn configure(&mut self, cfg: &ValidConfig) {
        self.fans.build(cfg);
        self.image.configure(cfg);
        self.reset(cfg);
    }

    /// Takes `cfg`'s mount (turned by the calibration) in place, keeping what the frames
    /// taught: the hypotheses are built again, the tracks and the attitude stay.
    pub fn remount(&mut self, cfg: &ValidConfig) {
        self.fans.build(cfg);
        self.image.remount(cfg);
    }

    /// Forgets every frame: the body assumed level.
    pub fn reset(&mut self, cfg: &ValidConfig) {
        self.attitude = AttitudeIndex::level(cfg.settings());
        self.drift = AttitudeDrift::ZERO;
        self.weak_frames = 0;
        self.comoving.clear();
        self.image.reset();
    }

    /// The heading change from the whole image (with `image_heading`): this frame's corners
    /// matched with the last frame's, the motion they agree on. `prior`: what is known of the
    /// motion before (`None` on a drive's first frame).
    pub fn image_heading<Fr: crate::Frame + ?Sized>(
        &mut self,
        frame: &Fr,
        cfg: &ValidConfig,
        prior: Option<ImagePrior>,
    ) -> Option<ImageMotion> {
        cfg.settings()
            .image_heading
            .then(|| self.image.track(frame, cfg, prior))
    }

    /// How the last frame was seen: its attitude hypothesis's homography and roll map.
    fn seen(&self, cfg: &ValidConfig) -> (Homography, RollMap) {
        let h = self.fans.pitch().get(self.attitude.pitch).copied();
        let roll = self.fans.roll().get(self.attitude.roll).copied();
        (
            h.unwrap_or(cfg.projection().nominal),
            roll.unwrap_or(RollMap::IDENTITY),
        )
    }

    /// Finds the corners that move with us and leaves them out of this frame; returns how many.
    /// A point on the road at a pixel would move as the prediction moves it, seen at the last
    /// frame's attitude.
    pub fn set_aside(
        &mut self,
        cfg: &ValidConfig,
        corners: &Corners<F>,
        prediction: Option<Motion>,
    ) -> u16 {
        let (h, _) = self.seen(cfg);
        let flow_px = prediction.map(|m| {
            move |px: Pixel| {
                let moved = h.backproject(px).and_then(|g| h.project(m.move_point(g)));
                moved.map(|q| (q.u_px - px.u_px, q.v_px - px.v_px))
            }
        });
        let k = &cfg.config().camera;
        let principal = Pixel {
            u_px: k.cx_px,
            v_px: k.cy_px,
        };
        self.hidden = self.comoving.find(corners, principal, flow_px);
        let n = self.hidden.iter().flatten().filter(|&&h| h).count();
        u16::try_from(n).unwrap_or(u16::MAX)
    }

    /// The first frame's observations, every corner seen at the body's assumed attitude: they
    /// start the tracks.
    pub fn first_observations<'a>(
        &self,
        cfg: &ValidConfig,
        corners: &'a Corners<F>,
    ) -> impl Iterator<Item = Observation> + 'a {
        let (h, roll) = self.seen(cfg);
        corners.iter().filter_map(move |c| {
            let pixel = c.pixel();
            backproject((&h, &roll), pixel).map(|ground| Observation { ground, pixel })
        })
    }

    /// Where this frame's arcs are drawn from, metres ahead of the rear axle: the tyres' slip
    /// at the predicted speed (`pivot_s2_per_m`); `current_m` before a motion is known.
    pub fn pivot_m(
        cfg: &ValidConfig,
        prediction: Option<Motion>,
        interval: Duration,
        current_m: f32,
    ) -> f32 {
        match prediction {
            Some(m) if interval.total_micros() > 0 => {
                let v = m.distance_m / interval.secs_f32();
                (cfg.settings().pivot_s2_per_m * v * v).min(MAX_PIVOT_M)
            }
            _ => current_m,
        }
    }

    /// The start-up window: heading +-`startup_heading_window_deg`, distance 0 to
    /// `startup_distance_max_m`.
    fn startup_window(cfg: &ValidConfig) -> MotionWindow {
        let s = cfg.settings();
        MotionWindow {
            heading_lo_rad: -s.startup_heading_window_rad,
            heading_hi_rad: s.startup_heading_window_rad,
            distance_lo_m: 0.0,
            distance_hi_m: s.startup_distance_max_m,
        }
    }

    /// The window of this frame's vote (step 1); its heading the whole image's, where there is
    /// one: the vote is then over distance alone.
    pub fn window(cfg: &ValidConfig, prior: &Prior, interval: Duration) -> MotionWindow {
        let w = Self::ground_window(cfg, prior, interval);
        match prior.image_heading_rad {
            Some(h) => w.with_heading(h, 0.0),
            None => w,
        }
    }

    /// The window of the ground's own vote.
    fn ground_window(cfg: &ValidConfig, prior: &Prior, interval: Duration) -> MotionWindow {
        let s = cfg.settings();
        let Some(m) = prior.prediction else {
            return Self::startup_window(cfg);
        };
        // Doubled after each fallback, never past the start-up window's size.
        let grow = f32::from(1u8 << prior.fallbacks.min(MAX_WIDEN));
        let heading_cap = s.startup_heading_window_rad.max(s.heading_window_rad);
        let distance_cap = s.startup_distance_max_m.max(s.distance_window_m);
        let half = (s.distance_window_m * grow).min(distance_cap);
        let w = MotionWindow::around(m, (s.heading_window_rad * grow).min(heading_cap), half)
            .short_of_stop(m, s.distance_window_m);
        match prior.steady_speed_m_s {
            Some(v) => w.taking_in(interval.at_rate(v), half),
            None => w,
        }
    }

    /// Votes, matches and refines (steps 1 to 6) with the tracks as they stand.
    pub fn vote(&mut self, cfg: &ValidConfig, frame: &Frame<F>) -> Outcome<'_, F> {
        let Frame {
            tracks,
            corners,
            ref prior,
            interval,
            pivot_m,
        } = *frame;
        let s = cfg.settings();
        let window = Self::window(cfg, prior, interval);
        let n = tracks.len().min(N);
        let inputs = Inputs {
            tracks,
            corners,
            hidden: &self.hidden,
            fans: &self.fans,
            pivot_m,
        };
        let drift_before = self.drift;
        let first = self.search.estimate(
            cfg,
            &inputs,
            &window,
            self.attitude,
            &mut self.drift,
            prior.prediction.is_some(),
        );
        let Some(mut outcome) = first else {
            // No pair voted: every observation (at the previous attitude) starts a track.
            let (h, roll) = self.seen(cfg);
            self.search.observe(&inputs, (&h, &roll));
            self.search.obs.untake_all();
            return Outcome::nothing(&self.search.obs);
        };
        let match_in = |search: &mut Search<N, F, GRID>,
                        observed: &mut [Option<Observation>],
                        motion: Motion,
                        w: &MotionWindow|
         -> Matches {
            let tolerance_m = s.lateral_tolerance_m;
            let along_m = MATCH_ALONG_BINS * w.distance_step_m(GRID) + tolerance_m;
            let prev = search.prev.get(..n).unwrap_or_default();
            match_tracks(
                cfg,
                prev,
                &mut search.obs,
                pivot_m,
                motion,
                (tolerance_m, along_m),
                observed,
            )
        };
        let observed = self.observed.get_mut(..n).unwrap_or_default();
        let mut matches = match_in(&mut self.search, observed, outcome.motion, &window);
        if let Some(m) = prior.prediction {
            // Step 6: a weak frame after weak frames also votes over the start-up window.
            let weak =
                (matches.count as f32) < WEAK_SUPPORT * s.min_inlier_ratio * corners.len() as f32;
            self.weak_frames = if weak {
                self.weak_frames.saturating_add(1)
            } else {
                0
            };
            if self.weak_frames >= REACQUIRE_AFTER_FRAMES {
                let wide = Self::startup_window(cfg).short_of_stop(m, s.distance_window_m);
                let wide = match prior.image_heading_rad {
                    Some(h) => wide.with_heading(h, 0.0),
                    None => wide,
                };
                let drift_after = self.drift;
                self.drift = drift_before;
                let again = self.search.estimate(
                    cfg,
                    &inputs,
                    &wide,
                    self.attitude,
                    &mut self.drift,
                    false,
                );
                let majority = REACQUIRE_FACTOR * matches.count + REACQUIRE_MARGIN;
                let taken = again.filter(|a| {
                    match_in(&mut self.search, observed, a.motion, &window).count >= majority
                });
                let w = match taken {
                    Some(a) => {
                        outcome = a;
                        wide
                    }
                    None => {
                        self.drift = drift_after;
                        self.search.restore(&inputs, &outcome);
                        window
                    }
                };
                matches = match_in(&mut self.search, observed, outcome.motion, &w);
            }
        }
        // Step 7: where the vote was over distance at a heading the image took from the road
        // alone, the ground's own: the vote again over its own window, its attitude corrections
        // left as they were, the working memory put back for the observations.
        let ground_heading_rad = (prior.ground_heading && prior.image_heading_rad.is_some())
            .then(|| {
                let own = Self::ground_window(cfg, prior, interval);
                let (mut drift, spread) = (drift_before, prior.prediction.is_some());
                let voted =
                    self.search
                        .estimate(cfg, &inputs, &own, self.attitude, &mut drift, spread);
                self.search.restore(&inputs, &outcome);
                voted.map(|v| v.motion.heading_change_rad)
            })
            .flatten();
        self.settle(cfg, &outcome, &matches, interval);
        Outcome {
            motion: Some(matches.refined(outcome.motion)),
            matched: matches.count,
            peak: outcome.peak.score,
            attitude: outcome.attitude.attitude(s),
            prior_matches: Some(s.prior_matches),
            sideways: matches.sideways_step(),
            observed: self.observed.get(..n).unwrap_or_default(),
            observations: &self.search.obs,
            ground_heading_rad,
        }
    }

    /// Takes this frame's attitude and feeds the corrections: the common pitch error the
    /// matched pairs measure, and the settling back to level.
    fn settle(
        &mut self,
        cfg: &ValidConfig,
        outcome: &VoteOutcome,
        matches: &Matches,
        interval: Duration,
    ) {
        let s = cfg.settings();
        self.attitude = outcome.attitude;
        if let Some(e) = matches.common_pitch_error_rad(cfg.config().mount.height_m) {
            self.drift.measure_pitch(e, s);
        }
        let level = AttitudeIndex::level(s);
        self.drift
            .settle(outcome.attitude, level, interval.secs_f32(), s);
    }

    /// The body attitude the last frame settled on.
    pub fn attitude(&self, cfg: &ValidConfig) -> Attitude {
        self.attitude.attitude(cfg.settings())
    }
}
