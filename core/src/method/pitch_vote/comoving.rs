//! Corners that move with the vehicle: a vehicle ahead at our speed, dirt on the lens, the
//! bonnet in the picture. They stand still in the image while the road under them moves, and
//! under a pitch hypothesis a little off, a vehicle's corners (above the road, so backprojected
//! far away) line up with motions slower or sharper than ours: where it hides most of the ground
//! window they outvote the road's few and walk the estimate towards a stop or out of a bend.
//!
//! They betray themselves before any vote. Per frame, with a predicted motion: each corner's
//! displacement from the nearest corner of the previous frame (those turned by each of a few roll
//! changes of the body) goes into a histogram, whose fullest 3x3 bins are the frame's common
//! displacement; a corner found at it where a point on the road would not have gone is *still*;
//! a still corner whose previous corner was still too, or one of [`MIN_CORNERS_AT_ONCE`] at once,
//! is set aside: no vote, no match, no new track, but still counted as detected. The steps and
//! their reasons: `docs/method.md`, "Corners that move with the vehicle".

use crate::harris::Corners;
use crate::projection::Pixel;
use crate::vote::VoteGrid;
use heapless::Vec;

/// Largest displacement between two frames, in each image axis, of a corner that stands still,
/// pixels: a pitch change of 0.6 deg at KITTI's focal length.
pub const REACH_PX: i32 = 8;
/// Fewest still corners for them to be an object's. Among the road's corners a nearest
/// neighbour lands at one displacement by chance a few at a time: the road's own displacements
/// spread with each corner's range and lateral place.
pub const MIN_CORNERS: u32 = 8;
/// Still corners enough to be an object's in the first frame they stand still (see step 3).
pub const MIN_CORNERS_AT_ONCE: u32 = 12;
/// How far from its predicted place on the road, pixels, a still corner must be found: above
/// the common displacement's tolerance (1.5 pixels each way) with room for the prediction's
/// error.
pub const MIN_FLOW_PX: f32 = 4.0;
/// Roll changes between frames tried, each way.
pub const ROLL_STEPS: i8 = 5;
/// The roll step, radians: 0.2 deg, under a pixel at 300 pixels from the centre.
pub const ROLL_STEP_RAD: f32 = 0.2 * core::f32::consts::PI / 180.0;

/// Bins per axis of the displacement histogram.
const BINS: usize = 2 * REACH_PX as usize + 1;

/// The previous frame's corners, and which of them stood still: what finding this frame's
/// corners that move with us needs of the last.
#[derive(Clone, Debug)]
pub struct Comoving<const F: usize> {
    previous: Corners<F>,
    /// Per side (left, right), in heap order: the previous corner stood still where the road
    /// would have moved.
    previous_still: [[bool; F]; 2],
}

/// Per side (left, right), in heap order: the corner moves with us.
pub type Hidden<const F: usize> = [[bool; F]; 2];

impl<const F: usize> Default for Comoving<F> {
    fn default() -> Self {
        Self::new()
    }
}

/// A displacement in the image, pixels: (columns right, rows down).
type Shift = (f32, f32);

/// A corner of the previous frame turned by a roll.
#[derive(Clone, Copy, Debug)]
struct TurnedCorner {
    /// Where it lies once turned.
    at: Pixel,
    /// It stood still in its own frame.
    still: bool,
    /// Its place in the previous frame's order: left side first, each in heap order.
    order: u16,
}

/// Per side (left, right): the previous frame's corners turned by a roll, sorted by column.
type Turned<const F: usize> = [Vec<TurnedCorner, F>; 2];

/// Per side (left, right), in heap order: each corner's displacement from its nearest
/// previous corner, if within reach.
type Shifts<const F: usize> = [[Option<Shift>; F]; 2];

/// The bin of a displacement in the histogram, if within reach in both axes.
fn bin(d: Shift) -> Option<(usize, usize)> {
    let bin = |d: f32| {
        let b = libm::roundf(d) as i32 + REACH_PX;
        usize::try_from(b).ok().filter(|&b| b < BINS)
    };
    Some((bin(d.0)?, bin(d.1)?))
}

impl<const F: usize> Comoving<F> {
    /// No previous frame; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            previous: Corners::new(),
            previous_still: [[false; F]; 2],
        }
    }

    /// Forgets the previous frame.
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Finds this frame's corners that move with us (see the module docs), given the image's
    /// `principal` point and `flow_px`: the image motion (columns, rows) of a point on the road
    /// at a pixel under the predicted motion (`None` without a prediction: nothing is set
    /// aside). Then remembers `corners` for the next frame. Returns which were set aside.
    pub fn find(
        &mut self,
        corners: &Corners<F>,
        principal: Pixel,
        flow_px: Option<impl Fn(Pixel) -> Option<(f32, f32)>>,
    ) -> Hidden<F> {
        let mut hidden = [[false; F]; 2];
        let mut still = [[false; F]; 2];
        if let Some(flow_px) = flow_px {
            // The roll change under which most corners stand still: (corners, roll, bin).
            let mut best = (0, 0.0, (0, 0));
            for k in -ROLL_STEPS..=ROLL_STEPS {
                let roll_rad = f32::from(k) * ROLL_STEP_RAD;
                let turned = self.turned(principal, roll_rad);
                let (n, at) = common_shift(&self.nearest_shifts(corners, &turned));
                if n > best.0 {
                    best = (n, roll_rad, at);
                }
            }
            let (n, roll_rad, common) = best;
            let turned = self.turned(principal, roll_rad);
            if n >= MIN_CORNERS {
                let in_common = |d: Shift| {
                    bin(d).is_some_and(|(i, j)| {
                        i.abs_diff(common.0) <= 1 && j.abs_diff(common.1) <= 1
                    })
                };
                let sides = hidden.iter_mut().zip(&mut still);
                for ((hidden, still), side) in sides.zip([&corners.left, &corners.right]) {
                    for ((h, st), c) in hidden.iter_mut().zip(still.iter_mut()).zip(side.iter()) {
                        let c = c.pixel();
                        let Some((du, dv)) = flow_px(c) else { continue };
                        // Any previous corner will do, not only the nearest: along an edge the
                        // nearest is often the edge's next corner.
                        let mut was_still = false;
                        for (d, p) in within_reach(&turned, c) {
                            // Found where the road would not have taken it.
                            if in_common(d) && libm::hypotf(d.0 - du, d.1 - dv) >= MIN_FLOW_PX {
                                *st = true;
                                was_still |= p.still;
                            }
                        }
                        *h = *st && (was_still || n >= MIN_CORNERS_AT_ONCE);
                    }
                }
            }
        }
        self.previous.clone_from(corners);
        self.previous_still = still;
        hidden
    }

    /// The previous corners turned by `roll_rad` about `principal`, each side sorted by column.
    fn turned(&self, principal: Pixel, roll_rad: f32) -> Turned<F> {
        let mut turned = [Vec::new(), Vec::new()];
        let sides = [&self.previous.left, &self.previous.right].into_iter();
        let sides = sides.zip(&self.previous_still).zip(turned.iter_mut());
        for (side, ((corners, still), out)) in sides.enumerate() {
            for ((k, p), &still) in corners.iter().enumerate().zip(still) {
                // A heap holds far fewer than 2^16 corners; saturating keeps it panic-free.
                let order = u16::try_from(side * F + k).unwrap_or(u16::MAX);
                let p = p.pixel();
                let (x, y) = (p.u_px - principal.u_px, p.v_px - principal.v_px);
                // Turned by a small angle: (x - roll y, y + roll x).
                let at = Pixel {
                    u_px: p.u_px - roll_rad * y,
                    v_px: p.v_px + roll_rad * x,
                };
                // Cannot overflow: as many as the previous corners on the side.
                let _ = out.push(TurnedCorner { at, still, order });
            }
            crate::sort::sort_by_key(out, |p| p.at.u_px);
        }
        turned
    }

    /// Each corner's displacement from the nearest `turned` previous corner, if within reach (on
    /// a tie, the first in the previous frame's order).
    fn nearest_shifts(&self, corners: &Corners<F>, turned: &Turned<F>) -> Shifts<F> {
        let mut shifts = [[None; F]; 2];
        for (side_shifts, side) in shifts.iter_mut().zip([&corners.left, &corners.right]) {
            for (s, c) in side_shifts.iter_mut().zip(side.iter()) {
                let mut nearest: Option<(f32, u16, Shift)> = None;
                for (d, p) in within_reach(turned, c.pixel()) {
                    let norm = d.0.abs() + d.1.abs();
                    let nearer = nearest.is_none_or(|(n, order, _)| {
                        norm.total_cmp(&n).then(p.order.cmp(&order)).is_lt()
                    });
                    if nearer {
                        nearest = Some((norm, p.order, d));
                    }
                }
                *s = nearest.map(|(_, _, d)| d);
            }
        }
        shifts
    }
}

/// The displacements from `turned` previous corners to `c` within reach in both axes, with
/// those corners.
fn within_reach<const F: usize>(
    turned: &Turned<F>,
    c: Pixel,
) -> impl Iterator<Item = (Shift, &TurnedCorner)> {
    let reach = REACH_PX as f32 + 0.5;
    let runs = turned.iter().flat_map(move |side| {
        // The run of columns within reach, with a pixel to spare: the exact test follows.
        let from = side.partition_point(|p| p.at.u_px < c.u_px - reach - 1.0);
        let run = side.get(from..).unwrap_or_default().iter();
        run.take_while(move |p| p.at.u_px <= c.u_px + reach + 1.0)
    });
    runs.map(move |p| ((c.u_px - p.at.u_px, c.v_px - p.at.v_px), p))
        .filter(move |(d, _)| d.0.abs() < reach && d.1.abs() < reach)
}

/// The 3x3 bins holding the most displacements: how many they hold and their centre bin.
fn common_shift<const F: usize>(shifts: &Shifts<F>) -> (u32, (usize, usize)) {
    let mut histogram = VoteGrid::<BINS>::new();
    for (i, j) in shifts.iter().flatten().filter_map(|s| s.and_then(bin)) {
        histogram.add(i, j, 1);
    }
    let mut best = (0, (0, 0));
    for i in 0..BINS {
        for j in 0..BINS {
            let n = histogram.around(i, j);
            if n > best.0 {
                best = (n, (i, j));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harris::Corner;
    use fixed::types::I16F16;
    use std::vec::Vec;

    /// A road flow function.
    type Flow = fn(Pixel) -> Option<Shift>;

    const PRINCIPAL: Pixel = Pixel {
        u_px: 607.0,
        v_px: 185.0,
    };

    /// Corners at `points` (u, v), alternately left and right.
    fn corners(points: &[(f32, f32)]) -> Corners<32> {
        let mut c = Corners::<32>::default();
        for (i, &(u, v)) in points.iter().enumerate() {
            let corner = Corner {
                response: 1000 + i as i32,
                v_px: I16F16::from_num(v),
                u_px: I16F16::from_num(u),
            };
            let side = if i % 2 == 0 {
                &mut c.left
            } else {
                &mut c.right
            };
            side.push(corner).unwrap();
        }
        c
    }

    /// How many corners are hidden.
    fn count(hidden: &Hidden<32>) -> usize {
        hidden.iter().flatten().filter(|&&h| h).count()
    }

    /// The pixels of the `hidden` corners of `c`.
    fn pixels(hidden: &Hidden<32>, c: &Corners<32>) -> Vec<(f32, f32)> {
        let sides = [&c.left, &c.right].into_iter().zip(hidden);
        sides
            .flat_map(|(heap, hidden)| {
                let kept = heap.iter().zip(hidden).filter(|&(_, &h)| h);
                kept.map(|(c, _)| (c.pixel().u_px, c.pixel().v_px))
            })
            .collect()
    }

    /// Image motion of the road: a point moves away from the horizon, faster the lower it is
    /// (a crude perspective, enough to make every road corner move its own way).
    fn road_flow(px: Pixel) -> Option<(f32, f32)> {
        let below = px.v_px - PRINCIPAL.v_px;
        let k = 0.15 * below / 100.0;
        Some((k * (px.u_px - PRINCIPAL.u_px), k * below))
    }

    /// `n` road corners spread over the lower image, pseudo-random but fixed.
    fn road(n: usize, seed: u32) -> Vec<(f32, f32)> {
        let mut next = crate::test_rng::uniform(seed);
        (0..n)
            .map(|_| (100.0 + 1000.0 * next(), 240.0 + 130.0 * next()))
            .collect()
    }

    /// Where the road's flow takes each corner.
    fn flowed(points: &[(f32, f32)]) -> Vec<(f32, f32)> {
        let step = |&(u, v): &(f32, f32)| {
            let (du, dv) = road_flow(Pixel { u_px: u, v_px: v }).unwrap();
            (u + du, v + dv)
        };
        points.iter().map(step).collect()
    }

    /// A vehicle's rear: a grid of `n` corners ahead, near the image centre.
    fn vehicle(n: usize) -> Vec<(f32, f32)> {
        (0..n)
            .map(|i| (430.0 + 70.0 * (i % 6) as f32, 250.0 + 19.0 * (i / 6) as f32))
            .collect()
    }

    /// Turns `points` by `roll_deg` about the principal point and shifts them by `(du, dv)`.
    fn moved(points: &[(f32, f32)], roll_deg: f32, du: f32, dv: f32) -> Vec<(f32, f32)> {
        let (s, c) = roll_deg.to_radians().sin_cos();
        let turn = |&(u, v): &(f32, f32)| {
            let (x, y) = (u - PRINCIPAL.u_px, v - PRINCIPAL.v_px);
            (
                PRINCIPAL.u_px + c * x - s * y + du,
                PRINCIPAL.v_px + s * x + c * y + dv,
            )
        };
        points.iter().map(turn).collect()
    }

    fn with(a: &[(f32, f32)], b: &[(f32, f32)]) -> Vec<(f32, f32)> {
        a.iter().chain(b).copied().collect()
    }

    #[test]
    fn a_vehicle_ahead_at_our_speed_is_set_aside_and_the_road_is_not() {
        let (ground, car) = (road(18, 7), vehicle(14));
        let mut found = Comoving::<32>::new();
        let first = corners(&with(&ground, &car));
        assert_eq!(count(&found.find(&first, PRINCIPAL, Some(road_flow))), 0);
        // The body pitches and rolls a little between the frames.
        let car2 = moved(&car, 0.8, 0.4, -2.3);
        let second = corners(&with(&flowed(&ground), &car2));
        let hidden = found.find(&second, PRINCIPAL, Some(road_flow));
        assert_eq!(count(&hidden), 14);
        let mut got = pixels(&hidden, &second);
        let mut want = car2.clone();
        got.sort_by(|a, b| a.partial_cmp(b).unwrap());
        want.sort_by(|a, b| a.partial_cmp(b).unwrap());
        for (g, w) in got.iter().zip(&want) {
            assert!(
                (g.0 - w.0).abs() < 1e-3 && (g.1 - w.1).abs() < 1e-3,
                "{g:?} {w:?}"
            );
        }
    }

    #[test]
    fn standing_still_or_unpredicted_nothing_is_set_aside() {
        let scene = with(&road(18, 7), &vehicle(14));
        let frame = corners(&scene);
        let mut found = Comoving::<32>::new();
        let standing = |_: Pixel| Some((0.0, 0.0));
        for _ in 0..3 {
            assert_eq!(count(&found.find(&frame, PRINCIPAL, Some(standing))), 0);
        }
        let none: Option<Flow> = None;
        assert_eq!(count(&found.find(&frame, PRINCIPAL, none)), 0);
    }

    #[test]
    fn a_small_still_group_is_set_aside_from_its_second_still_frame() {
        let (ground, car) = (road(20, 11), vehicle(9));
        let mut found = Comoving::<32>::new();
        found.find(&corners(&with(&ground, &car)), PRINCIPAL, Some(road_flow));
        let ground2 = flowed(&ground);
        let second = corners(&with(&ground2, &moved(&car, 0.0, 0.0, 1.0)));
        assert_eq!(count(&found.find(&second, PRINCIPAL, Some(road_flow))), 0);
        let third = corners(&with(&flowed(&ground2), &moved(&car, 0.0, 0.0, 1.6)));
        assert_eq!(count(&found.find(&third, PRINCIPAL, Some(road_flow))), 9);
    }

    #[test]
    fn the_road_alone_is_never_set_aside() {
        // Dense road corners: many have a neighbour within reach in the next frame, and those
        // at one range move alike, but each moves as the road does.
        let band = (0..10).map(|i| (592.0 + 3.0 * i as f32, 250.0));
        let mut points: Vec<_> = band.chain(road(22, 3)).collect();
        let mut found = Comoving::<32>::new();
        for _ in 0..10 {
            assert_eq!(
                count(&found.find(&corners(&points), PRINCIPAL, Some(road_flow))),
                0
            );
            points = flowed(&points);
            for p in points.iter_mut().filter(|p| p.1 > 370.0) {
                p.1 -= 130.0;
            }
        }
    }
}
