//! The paper's method (§2.2 and §2.3) as written, kept reproducible for comparison: each corner's
//! observation quadrilateral under the four extremal body attitudes
//! ([`GroundProjection::observe`](crate::projection::GroundProjection::observe)), each track's
//! prediction quadrilateral over the patch of plausible motions (the previous motion +- the
//! dynamics limits), matching where the two overlap (the patch doubling, up to `MAX_WIDEN`
//! times, while too few match), a `GRID x GRID` vote over the patch, and the centre of gravity of
//! the bins holding at least 70% of the highest count (`docs/method.md`, "The paper's method").
//!
//! Open points the paper leaves, decided here: at start-up the patch is heading +-2 deg by 0 to
//! 2.6 m a frame (constants of its own, so that tuning the pitch vote leaves this method alone); a
//! track with several overlapping observations takes the one whose centroid lies nearest its
//! prediction; the grid is the odometer's `GRID`, finer than the paper's noise.

use super::{Frame, Outcome};
use crate::config::ValidConfig;
use crate::harris::Corners;
use crate::motion::Motion;
use crate::projection::{Attitude, GroundPoint, Quad};
use crate::tracks::{Observation, Observations, Track};
use crate::vote::{MotionWindow, VoteGrid};
use heapless::Vec;

/// Start-up heading window half width, radians (2 deg).
const STARTUP_HEADING_HALF_RAD: f32 = 2.0 * (core::f32::consts::PI / 180.0);
/// Start-up distance window upper end, metres per frame.
const STARTUP_DISTANCE_MAX_M: f32 = 2.6;

/// Most patch doublings while too few tracks match.
const MAX_WIDEN: u8 = 4;
/// Share of the peak that counts in the centre of gravity (paper §2.3: 70%).
const PEAK_FRACTION: f32 = 0.7;

/// Working memory of the paper's method; it holds nothing between frames.
#[derive(Clone, Debug)]
pub struct Paper<const N: usize, const F: usize, const GRID: usize> {
    grid: VoteGrid<GRID>,
    /// Observation regions, left and right of straight ahead.
    quads: [Vec<Quad, F>; 2],
    /// Their centroids and corners' pixels, and which regions some track overlapped.
    obs: Observations<F>,
    /// Bins one track votes for: one bit per distance bin, a word per heading bin.
    bits: [[u64; 4]; GRID],
    /// Track i's observation in this frame, if matched.
    observed: [Option<Observation>; N],
}

/// The four corner motions of a patch moved `p` to; in this order they go round the region.
fn prediction_quad(p: GroundPoint, w: &MotionWindow) -> Quad {
    let at = |a, v| {
        Motion {
            heading_change_rad: a,
            distance_m: v,
        }
        .move_point(p)
    };
    Quad {
        corners: [
            at(w.heading_lo_rad, w.distance_lo_m),
            at(w.heading_hi_rad, w.distance_lo_m),
            at(w.heading_hi_rad, w.distance_hi_m),
            at(w.heading_lo_rad, w.distance_hi_m),
        ],
    }
}

impl<const N: usize, const F: usize, const GRID: usize> Paper<N, F, GRID> {
    /// Empty working memory: every bit zero, for a zero-initialised `static`.
    pub const ZERO: Self = Self {
        grid: VoteGrid::new(),
        quads: [Vec::new(), Vec::new()],
        obs: Observations::new(),
        bits: [[0; 4]; GRID],
        observed: [None; N],
    };

    /// The first frame's observations, every corner seen with the body level: they start the
    /// tracks.
    pub fn first_observations<'a>(
        cfg: &'a ValidConfig,
        corners: &'a Corners<F>,
    ) -> impl Iterator<Item = Observation> + 'a {
        let h = &cfg.projection().nominal;
        corners.iter().filter_map(move |c| {
            let pixel = c.pixel();
            h.backproject(pixel)
                .map(|ground| Observation { ground, pixel })
        })
    }

    /// Estimates the motion and matches the tracks (steps 1 to 5).
    pub fn vote(&mut self, cfg: &ValidConfig, frame: &Frame<F>) -> Outcome<'_, F> {
        let Frame {
            tracks,
            corners,
            prior,
            interval,
            ..
        } = *frame;
        let proj = cfg.projection();
        let sides = self.quads.iter_mut().zip(self.obs.sides.iter_mut());
        for ((quads, obs), heap) in sides.zip([&corners.left, &corners.right]) {
            quads.clear();
            obs.clear();
            for c in heap.iter() {
                let pixel = c.pixel();
                if let Some(q) = proj.observe(pixel) {
                    let _ = quads.push(q);
                    let _ = obs.push(Observation {
                        ground: q.centroid(),
                        pixel,
                    });
                }
            }
        }
        let s = cfg.settings();
        let needed = s.min_inlier_ratio * corners.len() as f32;
        let mut window = match prior.prediction {
            None => MotionWindow {
                heading_lo_rad: -STARTUP_HEADING_HALF_RAD,
                heading_hi_rad: STARTUP_HEADING_HALF_RAD,
                distance_lo_m: 0.0,
                distance_hi_m: STARTUP_DISTANCE_MAX_M,
            },
            // The change limits over this frame's interval.
            Some(m) => {
                let interval_s = interval.secs_f32();
                let dt2 = interval_s * interval_s;
                MotionWindow::around(
                    m,
                    s.max_heading_accel_rad_s2 * dt2,
                    s.max_longitudinal_accel_m_s2 * dt2,
                )
            }
        };
        let mut matched = self.count_matches(tracks, &window);
        for _ in 0..MAX_WIDEN {
            if matched as f32 >= needed {
                break;
            }
            let centre =
                window.motion_at((GRID as f32 - 1.0) * 0.5, (GRID as f32 - 1.0) * 0.5, GRID);
            let (ha, hd) = (
                window.heading_hi_rad - centre.heading_change_rad,
                window.distance_hi_m - centre.distance_m,
            );
            window = MotionWindow::around(centre, 2.0 * ha, 2.0 * hd);
            matched = self.count_matches(tracks, &window);
        }
        self.grid.clear();
        for t in tracks {
            self.vote_track(t.ground, &window);
        }
        self.obs.untake_all();
        let Some(peak) = self.grid.centre_above(PEAK_FRACTION) else {
            return Outcome::nothing(&self.obs);
        };
        let motion = window.motion_at(peak.heading_bin, peak.distance_bin, GRID);
        let n = tracks.len().min(N);
        for (t, slot) in tracks.iter().zip(self.observed.iter_mut().take(n)) {
            let region = prediction_quad(t.ground, &window);
            let predicted = motion.move_point(t.ground);
            let mut best: Option<(f32, Observation)> = None;
            let sides = self.quads.iter().zip(&self.obs.sides);
            for ((quads, obs), taken) in sides.zip(&mut self.obs.taken) {
                for ((q, o), taken) in quads.iter().zip(obs).zip(taken.iter_mut()) {
                    if q.overlaps(&region) {
                        *taken = true;
                        let c = o.ground;
                        let d = libm::hypotf(c.x_m - predicted.x_m, c.y_m - predicted.y_m);
                        if best.is_none_or(|b| d < b.0) {
                            best = Some((d, *o));
                        }
                    }
                }
            }
            *slot = best.map(|b| b.1);
        }
        Outcome {
            motion: Some(motion),
            matched,
            peak: peak.score,
            attitude: Attitude::default(),
            prior_matches: None,
            sideways: None,
            observed: self.observed.get(..n).unwrap_or_default(),
            observations: &self.obs,
            ground_heading_rad: None,
        }
    }

    /// Tracks whose prediction region overlaps some observation region.
    fn count_matches(&self, tracks: &[Track], w: &MotionWindow) -> usize {
        tracks
            .iter()
            .filter(|t| {
                let region = prediction_quad(t.ground, w);
                self.quads.iter().flatten().any(|q| q.overlaps(&region))
            })
            .count()
    }

    /// One track's votes: each bin whose motion moves it into an observation region it overlaps.
    fn vote_track(&mut self, p: GroundPoint, w: &MotionWindow) {
        let region = prediction_quad(p, w);
        // The affine map from bin (i, j) to the predicted position.
        let last = (GRID - 1) as f32;
        let at = |i: f32, j: f32| w.motion_at(i, j, GRID).move_point(p);
        let o = at(0.0, 0.0);
        let (pi, pj) = (at(last, 0.0), at(0.0, last));
        let a = ((pi.x_m - o.x_m) / last, (pi.y_m - o.y_m) / last);
        let b = ((pj.x_m - o.x_m) / last, (pj.y_m - o.y_m) / last);
        let det = a.0 * b.1 - a.1 * b.0;
        if det.abs() < 1e-12 {
            return;
        }
        let to_bins = |g: GroundPoint| {
            let (dx, dy) = (g.x_m - o.x_m, g.y_m - o.y_m);
            ((dx * b.1 - dy * b.0) / det, (a.0 * dy - a.1 * dx) / det)
        };
        self.bits = [[0; 4]; GRID];
        let mut any = false;
        for q in self.quads.iter().flatten() {
            if !q.overlaps(&region) {
                continue;
            }
            any = true;
            let corners = q.corners.map(to_bins);
            fill_rows(&corners, &mut self.bits);
        }
        if !any {
            return;
        }
        for (i, row) in self.bits.iter().enumerate() {
            for (word, &bits) in row.iter().enumerate() {
                let mut b = bits;
                while b != 0 {
                    let j = word * 64 + b.trailing_zeros() as usize;
                    self.grid.add(i, j, 1);
                    b &= b - 1;
                }
            }
        }
    }
}

/// Sets the bits of every bin centre inside the convex quadrilateral `q` (bin coordinates).
fn fill_rows<const GRID: usize>(q: &[(f32, f32); 4], bits: &mut [[u64; 4]; GRID]) {
    let lo = q.iter().map(|c| c.0).fold(f32::MAX, f32::min);
    let hi = q.iter().map(|c| c.0).fold(f32::MIN, f32::max);
    let first = libm::ceilf(lo).max(0.0);
    let last = libm::floorf(hi).min((GRID - 1) as f32);
    if first > last {
        return;
    }
    for (i, row) in bits
        .iter_mut()
        .enumerate()
        .take(last as usize + 1)
        .skip(first as usize)
    {
        let x = i as f32;
        let (mut jlo, mut jhi) = (f32::MAX, f32::MIN);
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            if (a.0 <= x && x <= b.0) || (b.0 <= x && x <= a.0) {
                let j = if (b.0 - a.0).abs() < 1e-12 {
                    // An edge along the row: both ends count.
                    jlo = jlo.min(a.1.min(b.1));
                    a.1.max(b.1)
                } else {
                    a.1 + (x - a.0) * (b.1 - a.1) / (b.0 - a.0)
                };
                jlo = jlo.min(j);
                jhi = jhi.max(j);
            }
        }
        let j0 = libm::ceilf(jlo).max(0.0);
        let j1 = libm::floorf(jhi).min((GRID - 1).min(255) as f32);
        if j0 > j1 {
            continue;
        }
        for j in j0 as usize..=j1 as usize {
            if let Some(word) = row.get_mut(j / 64) {
                *word |= 1 << (j % 64);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_rows_marks_bins_inside() {
        let mut bits = [[0u64; 4]; 8];
        fill_rows(&[(1.0, 1.0), (3.0, 1.0), (3.0, 4.0), (1.0, 4.0)], &mut bits);
        for (i, row) in bits.iter().enumerate() {
            let expect = if (1..=3).contains(&i) { 0b11110 } else { 0 };
            assert_eq!(row[0], expect, "row {i}");
        }
    }

    #[test]
    fn prediction_region_contains_the_centre_motion() {
        let w = MotionWindow::around(
            Motion {
                heading_change_rad: 0.01,
                distance_m: 1.0,
            },
            0.002,
            0.05,
        );
        let p = GroundPoint { x_m: 8.0, y_m: 1.0 };
        let q = prediction_quad(p, &w);
        let c = Motion {
            heading_change_rad: 0.01,
            distance_m: 1.0,
        }
        .move_point(p);
        let probe = Quad {
            corners: [c, c, c, c],
        };
        assert!(q.overlaps(&probe));
    }
}
