//! The estimators that turn a frame's corners and the tracks into the frame's motion, each in
//! a room of its own: [`pitch_vote`] (the default) and [`paper`] (the paper's method as
//! written). The odometer holds one of them ([`Estimator`]), so that its memory is the larger
//! method's, not the sum.

pub mod paper;
pub mod pitch_vote;

use crate::calibration::SidewaysStep;
use crate::config::{Method, ValidConfig};
use crate::harris::Corners;
use crate::heading::consensus::Pair;
use crate::heading::plane::Road;
use crate::heading::{ImageMotion, ImagePrior};
use crate::motion::Motion;
use crate::projection::Attitude;
use crate::time::Duration;
use crate::tracks::{Observation, Observations, Track};
use paper::Paper;
use pitch_vote::PitchVote;

/// What the odometer knows of the motion before the frame's vote.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// The previous motion scaled to this frame's interval; `None` before a motion is known.
    pub prediction: Option<Motion>,
    /// The estimated speed's running mean, metres a second; `None` before a motion is known.
    pub steady_speed_m_s: Option<f32>,
    /// Frames in a row that fell back to the previous motion.
    pub fallbacks: u8,
    /// The heading change the whole image gives, radians, where it gives one.
    pub image_heading_rad: Option<f32>,
    /// Whether the ground's own heading change is wanted beside the image's (which then rests
    /// on the road alone; see [`Outcome::ground_heading_rad`]).
    pub ground_heading: bool,
}

/// What a frame's vote works with.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a, const F: usize> {
    /// The tracks, in the previous frame's vehicle frame (measured from `pivot_m`).
    pub tracks: &'a [Track],
    /// This frame's corners.
    pub corners: &'a Corners<F>,
    /// What the odometer knows of the motion beforehand.
    pub prior: Prior,
    /// Time since the previous frame.
    pub interval: Duration,
    /// How far ahead of the rear axle the tracks and this frame's points are measured from,
    /// metres.
    pub pivot_m: f32,
}

/// What a method's vote found; it borrows the method's working memory.
#[derive(Clone, Copy, Debug)]
pub struct Outcome<'a, const F: usize> {
    /// The vote's motion; `None` when nothing voted.
    pub motion: Option<Motion>,
    /// Tracks matched to an observation under it.
    pub matched: usize,
    /// Votes at the accumulator's peak.
    pub peak: u32,
    /// The body's attitude the method settled on (level for the paper's method).
    pub attitude: Attitude,
    /// How many matched tracks the prediction weighs as against the vote; `None`: the vote
    /// alone.
    pub prior_matches: Option<f32>,
    /// The vehicle's step across the arc's chord that the matched pairs show: a mount's yaw
    /// error times the distance, on average (see [`crate::calibration`]); `None` where the
    /// pairs cannot tell it, and for the paper's method.
    pub sideways: Option<SidewaysStep>,
    /// Track `i`'s observation in this frame, where matched (as many as the tracks or fewer:
    /// the others were not matched).
    pub observed: &'a [Option<Observation>],
    /// The frame's observations, the untaken of which start tracks.
    pub observations: &'a Observations<F>,
    /// The heading change the ground window's tracks vote for on their own, radians, where the
    /// prior asked for it and the vote was over distance at the image's heading; `None`
    /// otherwise, and for the paper's method.
    pub ground_heading_rad: Option<f32>,
}

impl<'a, const F: usize> Outcome<'a, F> {
    /// Nothing voted: no motion, no match; every observation starts a track.
    pub fn nothing(observations: &'a Observations<F>) -> Self {
        Self {
            motion: None,
            matched: 0,
            peak: 0,
            attitude: Attitude::default(),
            prior_matches: None,
            sideways: None,
            observed: &[],
            observations,
            ground_heading_rad: None,
        }
    }

    /// A trusted vote's motion `voted` weighed against the `prediction`.
    pub fn weigh(&self, voted: Motion, prediction: Motion) -> Motion {
        match self.prior_matches {
            Some(prior) => voted.weighted_mean(self.matched as f32, prediction, prior),
            None => voted,
        }
    }
}

/// The odometer's estimator: one method, its state and its working memory.
///
/// `repr(u8)`: an explicit tag, 0 for the pitch vote, so that an unconfigured odometer is all
/// zero bits (a `static` of it in `.bss`).
#[derive(Clone, Debug)]
#[repr(u8)]
// The variants' sizes differ; boxing would need an allocator, and the larger one is in use.
#[allow(clippy::large_enum_variant)]
pub enum Estimator<const N: usize, const F: usize, const GRID: usize, const K: usize> {
    /// The pitch vote.
    PitchVote(PitchVote<N, F, GRID, K>),
    /// The paper's method.
    Paper(Paper<N, F, GRID>),
}

impl<const N: usize, const F: usize, const GRID: usize, const K: usize> Estimator<N, F, GRID, K> {
    /// No configuration: every bit zero.
    pub const ZERO: Self = Self::PitchVote(PitchVote::ZERO);

    /// Takes `cfg`: the method it names, configured in place, every frame forgotten.
    pub fn configure(&mut self, cfg: &ValidConfig) {
        match cfg.settings().method {
            Method::PitchVote => {
                if !matches!(self, Self::PitchVote(_)) {
                    self.become_pitch_vote();
                }
                if let Self::PitchVote(pv) = self {
                    pv.configure(cfg);
                }
            }
            Method::Paper => {
                if !matches!(self, Self::Paper(_)) {
                    self.become_paper();
                }
            }
        }
    }

    /// Switches to the pitch vote, every bit zero. Out of line, as [`Self::become_paper`].
    #[cold]
    #[inline(never)]
    fn become_pitch_vote(&mut self) {
        // The constant, all zeros, is written in place (a memset), not built on the stack.
        *self = Self::ZERO;
    }

    /// Switches to the paper's method. Out of line: the new value is built on the stack
    /// (16 KB with the default capacities) before it is moved in, and inlined into
    /// `configure` that frame would count against every configuration's stack, a firmware's
    /// at boot among them, not only a switch's.
    #[cold]
    #[inline(never)]
    fn become_paper(&mut self) {
        *self = Self::Paper(Paper::ZERO);
    }

    /// Forgets every frame.
    pub fn reset(&mut self, cfg: &ValidConfig) {
        match self {
            Self::PitchVote(pv) => pv.reset(cfg),
            Self::Paper(_) => {}
        }
    }

    /// Takes `cfg`'s mount, turned by the calibration, keeping what the frames taught.
    pub fn remount(&mut self, cfg: &ValidConfig) {
        match self {
            Self::PitchVote(pv) => pv.remount(cfg),
            Self::Paper(_) => {}
        }
    }

    /// Sets aside this frame's corners that move with the vehicle (pitch vote); how many.
    pub fn set_aside(
        &mut self,
        cfg: &ValidConfig,
        corners: &Corners<F>,
        prediction: Option<Motion>,
    ) -> u16 {
        match self {
            Self::PitchVote(pv) => pv.set_aside(cfg, corners, prediction),
            Self::Paper(_) => 0,
        }
    }

    /// The heading change from the whole image (pitch vote with `image_heading`; `None`
    /// otherwise). `prior`: what is known of the motion before, `None` on a drive's first
    /// frame.
    pub fn image_heading<Fr: crate::Frame + ?Sized>(
        &mut self,
        frame: &Fr,
        cfg: &ValidConfig,
        prior: Option<ImagePrior>,
    ) -> Option<ImageMotion> {
        match self {
            Self::PitchVote(pv) => pv.image_heading(frame, cfg, prior),
            Self::Paper(_) => None,
        }
    }

    /// The road's plane under the last frame from the whole image's pairs on it and the
    /// ground's `ground` pairs; `None` without the whole image's stage
    /// ([`ValidConfig::whole_image`]).
    pub fn road(
        &self,
        cfg: &ValidConfig,
        pivot_m: f32,
        motion: Motion,
        ground: &[Pair],
    ) -> Option<Road> {
        match self {
            Self::PitchVote(pv) if cfg.whole_image() => pv.image.road(cfg, pivot_m, motion, ground),
            _ => None,
        }
    }

    /// The distance travelled that this frame's whole-image consensus's pairs on the road tell
    /// ([`crate::heading::ImageHeading::road_travel`]), metres, and how many told it; `None`
    /// without the whole image's stage or its consensus.
    pub fn road_travel(&self, cfg: &ValidConfig, pivot_m: f32) -> Option<(f32, usize)> {
        match self {
            Self::PitchVote(pv) if cfg.whole_image() => pv.image.road_travel(cfg, pivot_m),
            _ => None,
        }
    }

    /// Starts a track at each of the first frame's corners; returns those a full pool refused.
    pub fn start_tracks<const M: usize>(
        &self,
        cfg: &ValidConfig,
        corners: &Corners<F>,
        tracks: &mut crate::tracks::Tracks<M>,
    ) -> u16 {
        match self {
            Self::PitchVote(pv) => tracks.spawn_all(pv.first_observations(cfg, corners)),
            Self::Paper(_) => {
                tracks.spawn_all(Paper::<N, F, GRID>::first_observations(cfg, corners))
            }
        }
    }

    /// Where this frame's arcs are drawn from, metres ahead of the rear axle (the pitch vote's
    /// tyre slip; the rear axle for the paper's method).
    pub fn pivot_m(
        &self,
        cfg: &ValidConfig,
        prediction: Option<Motion>,
        interval: Duration,
        current_m: f32,
    ) -> f32 {
        match self {
            Self::PitchVote(_) => {
                PitchVote::<N, F, GRID, K>::pivot_m(cfg, prediction, interval, current_m)
            }
            Self::Paper(_) => current_m,
        }
    }

    /// Votes over the frame's motion and matches the tracks.
    pub fn vote(&mut self, cfg: &ValidConfig, frame: &Frame<F>) -> Outcome<'_, F> {
        match self {
            Self::PitchVote(pv) => pv.vote(cfg, frame),
            Self::Paper(p) => p.vote(cfg, frame),
        }
    }
}
