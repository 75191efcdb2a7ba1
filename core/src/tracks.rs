//! Tracked ground features (paper §2.3, last step): each holds a position on the road in the
//! vehicle frame of the last processed frame. Matched tracks take their new observation,
//! unmatched ones are carried along by the estimated motion and dropped after too many misses,
//! unmatched observations start tracks.
//!
//! Pool policy when full: a new observation replaces the track with the most misses, if that
//! track has missed at least once; otherwise the observation is refused and counted. Tracks that
//! have been seen recently are never evicted for ones not yet seen twice.

use crate::motion::Motion;
use crate::projection::{GroundPoint, Pixel};
use heapless::Vec;

/// A feature seen in a frame: where on the road, and where in the image.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Observation {
    /// Position on the road, vehicle frame of its frame.
    pub ground: GroundPoint,
    /// The corner in the image.
    pub pixel: Pixel,
}

/// A frame's observations, left and right of straight ahead, and which of them some track took.
#[derive(Clone, Debug)]
pub struct Observations<const F: usize> {
    /// Per side (left, right), in the order of the side's corners.
    pub sides: [Vec<Observation, F>; 2],
    /// Per side, whether a track took the observation of that place.
    pub taken: [[bool; F]; 2],
}

impl<const F: usize> Default for Observations<F> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const F: usize> Observations<F> {
    /// None; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            sides: [Vec::new(), Vec::new()],
            taken: [[false; F]; 2],
        }
    }

    /// Marks every observation untaken.
    pub fn untake_all(&mut self) {
        self.taken = [[false; F]; 2];
    }

    /// The observations no track took: they start tracks.
    pub fn untaken(&self) -> impl Iterator<Item = Observation> + '_ {
        self.sides
            .iter()
            .zip(&self.taken)
            .flat_map(|(obs, taken)| obs.iter().zip(taken).filter(|(_, t)| !**t).map(|(o, _)| *o))
    }
}

/// One tracked feature.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Track {
    /// Position on the road, vehicle frame of the last processed frame.
    pub ground: GroundPoint,
    /// Where it was seen in the last processed frame; None if it was not seen there.
    pub pixel: Option<Pixel>,
    /// Consecutive frames without a match.
    pub misses: u8,
    /// Frames since the track started.
    pub age: u16,
}

/// What [`Tracks::spawn`] did with an observation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Spawn {
    /// Stored in a free slot.
    Added,
    /// Stored in place of the track with the most misses.
    Evicted,
    /// Not stored: the pool is full of tracks seen in the last frame.
    Refused,
}

/// A fixed-capacity pool of tracks.
#[derive(Clone, Debug)]
pub struct Tracks<const N: usize> {
    items: Vec<Track, N>,
}

impl<const N: usize> Default for Tracks<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Tracks<N> {
    /// An empty pool; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self { items: Vec::new() }
    }

    /// Tracks held.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the pool is empty.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The tracks, oldest first unless evictions reordered them.
    pub fn as_slice(&self) -> &[Track] {
        &self.items
    }

    /// Drops every track.
    pub fn clear(&mut self) {
        self.items.clear();
    }

    /// Moves every track into the current vehicle frame: track `i` takes `observed[i]` where
    /// given, otherwise it is carried by `motion` and counts a miss. Tracks missed more than
    /// `max_misses` times in a row, or whose new position fails `keep`, are dropped.
    pub fn update(
        &mut self,
        motion: Motion,
        observed: &[Option<Observation>],
        max_misses: u8,
        keep: impl Fn(GroundPoint) -> bool,
    ) {
        for (i, t) in self.items.iter_mut().enumerate() {
            match observed.get(i).copied().flatten() {
                Some(o) => {
                    t.ground = o.ground;
                    t.pixel = Some(o.pixel);
                    t.misses = 0;
                }
                None => {
                    t.ground = motion.move_point(t.ground);
                    t.pixel = None;
                    t.misses = t.misses.saturating_add(1);
                }
            }
            t.age = t.age.saturating_add(1);
        }
        self.items
            .retain(|t| t.misses <= max_misses && keep(t.ground));
    }

    /// Moves every track `dx_m` ahead (a change of the vehicle frame's origin along its axis).
    pub fn shift_ahead(&mut self, dx_m: f32) {
        for t in self.items.iter_mut() {
            t.ground = t.ground.moved_ahead(dx_m);
        }
    }

    /// Turns every track by `rad` (counter-clockwise seen from above) about `centre`: the road
    /// as a camera standing over `centre` and turned by as much sees it.
    pub fn turn_about(&mut self, centre: GroundPoint, rad: f32) {
        let (sin, cos) = (libm::sinf(rad), libm::cosf(rad));
        for t in self.items.iter_mut() {
            let (dx, dy) = (t.ground.x_m - centre.x_m, t.ground.y_m - centre.y_m);
            t.ground = GroundPoint {
                x_m: centre.x_m + cos * dx - sin * dy,
                y_m: centre.y_m + sin * dx + cos * dy,
            };
        }
    }

    /// Starts a track at each observation; returns how many a full pool refused.
    pub fn spawn_all(&mut self, observations: impl Iterator<Item = Observation>) -> u16 {
        let mut refused = 0u16;
        for o in observations {
            if self.spawn(o) == Spawn::Refused {
                refused = refused.saturating_add(1);
            }
        }
        refused
    }

    /// Starts a track at an observation (see the module docs for the policy when full).
    pub fn spawn(&mut self, o: Observation) -> Spawn {
        let track = Track {
            ground: o.ground,
            pixel: Some(o.pixel),
            misses: 0,
            age: 0,
        };
        if self.items.push(track).is_ok() {
            return Spawn::Added;
        }
        let worst = self
            .items
            .iter_mut()
            .filter(|t| t.misses > 0)
            .max_by_key(|t| (t.misses, t.age));
        match worst {
            Some(slot) => {
                *slot = track;
                Spawn::Evicted
            }
            None => Spawn::Refused,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(x: f32) -> GroundPoint {
        GroundPoint { x_m: x, y_m: 0.0 }
    }

    fn seen(x: f32) -> Observation {
        Observation {
            ground: at(x),
            pixel: Pixel::default(),
        }
    }

    #[test]
    fn a_track_whose_observation_disappears_is_dropped_after_n_frames() {
        let mut t = Tracks::<4>::default();
        t.spawn(seen(8.0));
        let still = Motion::ZERO;
        for frame in 1..=3 {
            t.update(still, &[], 3, |_| true);
            assert_eq!(t.len(), 1, "kept through miss {frame}");
        }
        t.update(still, &[], 3, |_| true);
        assert!(t.is_empty());
    }

    #[test]
    fn matched_tracks_take_their_observation_and_unmatched_ones_move() {
        let mut t = Tracks::<4>::default();
        t.spawn(seen(8.0));
        t.spawn(seen(10.0));
        let m = Motion {
            heading_change_rad: 0.0,
            distance_m: 1.0,
        };
        t.update(m, &[Some(seen(7.1)), None], 3, |_| true);
        let s = t.as_slice();
        assert_eq!((s[0].ground, s[0].misses), (at(7.1), 0));
        assert_eq!((s[1].ground, s[1].misses), (at(9.0), 1));
        // Tracks failing `keep` (say, behind the camera) go.
        t.update(m, &[], 3, |g| g.x_m > 8.5);
        assert_eq!(t.len(), 0);
    }

    #[test]
    fn shifting_the_origin_moves_every_track_and_nothing_else() {
        let mut t = Tracks::<4>::default();
        t.spawn(seen(8.0));
        t.spawn(seen(10.0));
        t.shift_ahead(-0.25);
        let s = t.as_slice();
        assert_eq!((s[0].ground, s[1].ground), (at(7.75), at(9.75)));
        assert_eq!((s[0].misses, s[0].pixel), (0, Some(Pixel::default())));
    }

    #[test]
    fn turning_about_the_camera_keeps_each_track_s_distance_from_it() {
        let mut t = Tracks::<4>::default();
        t.spawn(seen(11.5));
        t.spawn(seen(1.5));
        // A camera 1.5 m ahead turned a quarter turn left: the track 10 m ahead of it now
        // stands 10 m to its left, the one under it stays.
        t.turn_about(at(1.5), core::f32::consts::FRAC_PI_2);
        let s = t.as_slice();
        assert!((s[0].ground.x_m - 1.5).abs() < 1e-5, "{:?}", s[0].ground);
        assert!((s[0].ground.y_m - 10.0).abs() < 1e-5, "{:?}", s[0].ground);
        assert_eq!(s[1].ground, at(1.5));
    }

    #[test]
    fn a_full_pool_evicts_the_most_missed_and_never_panics() {
        let mut t = Tracks::<2>::default();
        assert_eq!(t.spawn(seen(1.0)), Spawn::Added);
        assert_eq!(t.spawn(seen(2.0)), Spawn::Added);
        assert_eq!(t.spawn(seen(3.0)), Spawn::Refused);
        t.update(Motion::ZERO, &[Some(seen(1.0))], 5, |_| true);
        assert_eq!(t.spawn(seen(4.0)), Spawn::Evicted);
        assert_eq!(t.as_slice()[1].ground, at(4.0));
        for _ in 0..100 {
            t.spawn(seen(5.0));
        }
        assert_eq!(t.len(), 2);
    }
}
