//! The consensus over the correspondences, then its refinement. No RANSAC: every
//! correspondence votes, through its Sampson distance, for the heading and pitch changes it
//! fits; the outliers (movers, mismatches) are whatever the peak does not hold. Then a few
//! Gauss-Newton steps over the five parameters of the motion, on the peak's inliers, refine it
//! to a fraction of a pixel; the direction of travel floats there (the real camera path leaves
//! the ideal arc by about a degree), the distance does not matter (it only scales `t`).

use super::epipolar::{Model, Params, sampson};
use nalgebra::{Matrix3, Vector3};

/// A correspondence: the rays of one point in the previous and this frame (normalised image
/// coordinates, z = 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// In the previous frame.
    pub x1: Vector3<f32>,
    /// In this frame.
    pub x2: Vector3<f32>,
}

/// The search's range and kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Search {
    /// Heading change at the centre of the search, radians (the prediction).
    pub alpha: f32,
    /// Half width of the heading search, radians.
    pub alpha_half: f32,
    /// Half width of the pitch-change search, radians.
    pub pitch_half: f32,
    /// Distance travelled, metres (the prediction; it only scales the translation).
    pub distance_m: f32,
    /// Focal length, pixels: normalised distances times this are pixels.
    pub focal_px: f32,
    /// A correspondence's distance from the motion at which its vote falls to nothing, pixels,
    /// in the finest pass.
    pub kernel_px: f32,
    /// Largest distance of an inlier in the refinement, pixels.
    pub inlier_px: f32,
    /// The drive's typical median distance of a frame's inliers from its motion, pixels (0
    /// before its first fit): the scale of the robust weights.
    pub typical_median_px: f32,
}

/// Bins each side of the centre in each pass of the vote: (2 x 5 + 1)^2 bins a pass.
const HALF_BINS: i32 = 5;
/// Passes of the vote, each over the previous one's best bin and its neighbours, finer by
/// [`NARROWING`].
const PASSES: usize = 3;
/// How much each pass narrows the search.
const NARROWING: f32 = 0.3;
/// A vote's weight at a distance of zero (a triangle down to the kernel's width).
const FULL_VOTE: f32 = 64.0;
/// Gauss-Newton steps, and after which of them the inliers are chosen again, each time within
/// the next of [`INLIER_SCALE`] times `inlier_px`: the vote's motion can lie a pixel or two off
/// for near points (its direction of travel is the arc's), so the first choice takes more in.
const STEPS: usize = 6;
const RESELECT_AFTER: [usize; 2] = [1, 3];
const INLIER_SCALE: [f32; 3] = [3.0, 2.0, 1.0];
/// How far the direction of travel leaves the arc's chord, one standard deviation, radians (6
/// deg: the real camera path leaves the ideal arc by 0.5-1.2 deg rms, BRIEF §8, and the chord
/// hangs on a distance that can be wrong by more; 2 deg turned KITTI 10's slow start), and how
/// well a pair is placed, pixels: together they weigh the refinement's prior on the direction
/// (its azimuth and elevation about the chord) against the pairs. Where the pairs determine the
/// direction the prior hardly matters; where they cannot (all on one plane: road alone) it
/// keeps the direction near the chord, so that a turn is not read as a sideways step (measured
/// on the s-course: 20 % too much turn in its bends without it).
const TRAVEL_SD_RAD: f32 = 6.0 * core::f32::consts::PI / 180.0;
const PAIR_SD_PX: f32 = 0.3;
/// The prior's weight on the azimuth and the elevation in the normal equations.
const TRAVEL_PRIOR: f32 = (PAIR_SD_PX / TRAVEL_SD_RAD) * (PAIR_SD_PX / TRAVEL_SD_RAD);

/// The camera's move ahead the swing's derivative is taken over, metres
/// ([`swing_rad_per_m`]): the model is linear in it.
const SWING_STEP_M: f32 = 0.1;

/// The distances tried where the direction of travel hangs on the distance
/// ([`distance_factor`]), as factors of the given one: half octaves, up to 2.8 times either way.
const DISTANCE_FACTORS: [f32; 7] = {
    use core::f32::consts::{FRAC_1_SQRT_2, SQRT_2};
    [
        0.5 * FRAC_1_SQRT_2,
        0.5,
        FRAC_1_SQRT_2,
        1.0,
        SQRT_2,
        2.0,
        2.0 * SQRT_2,
    ]
};

/// Step of the numeric derivatives, radians.
const DERIVATIVE_STEP: f32 = 1e-4;
/// The refinement's robust weights: a residual of `r` weighs `1 / (1 + (r / s)^2)` (Cauchy's),
/// so that a mismatch that falls within the inlier band by chance pulls little (Huber's
/// weights, falling as `1 / r`, let four such of twenty shift the heading by 0.015 deg on the
/// test's scene). The scale `s` is this many standard deviations of the pairs' distances from
/// their motion (the textbook constant: 95 % efficiency on normal residuals), taken from the
/// drive's typical median ([`Search::typical_median_px`]; the frame's own on the first fit):
/// the weights follow the camera's and the matcher's noise rather than a number of pixels
/// fitted to one camera, and a frame whose pairs are poorer than usual (a bend of blurred or
/// repeated texture) does not loosen them for its mismatches.
const CAUCHY_SDS: f32 = 2.385;
/// A normal distribution's standard deviation over the median of its absolute values.
const SD_PER_MEDIAN: f32 = 1.4826;
/// Least scale of the robust weights, pixels: a guard for residuals all but exactly zero (a
/// rendered scene), far below any matcher's noise.
const MIN_CAUCHY_PX: f32 = 0.01;
/// The scale of the weights the heading's standard deviation is taken under, pixels: the one
/// [`Search`]'s and the settings' heading gate (`image_max_heading_sd_rad`) were measured with.
/// The finer weights of the estimate set more of a frame's pairs aside than the gate counts.
const GATE_CAUCHY_PX: f32 = 0.5;
/// Bins of the histogram [`Median`] keeps over the inlier band.
const MEDIAN_BINS: usize = 128;

/// What the consensus found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// The motion.
    pub params: Params,
    /// Correspondences within [`Search::inlier_px`] of it.
    pub inliers: u16,
    /// Their root mean square distance, pixels.
    pub rms_px: f32,
    /// Their median distance, pixels (to a 128th of the inlier band).
    pub median_px: f32,
    /// The heading change's standard deviation, radians: how well the inliers determine it
    /// (the others free). Large where they lie on one plane (a scene of nothing but road),
    /// whose points cannot tell a turn from a sideways step.
    pub heading_sd_rad: f32,
    /// The scale of the robust weights the refinement ended with, pixels ([`objective`]).
    pub weights_px: f32,
}

/// The pairs' rays as columns, `[x1.x, x1.y, x2.x, x2.y]` (both at z = 1), where the compiler
/// has vector instructions for the vote's products over them (x86-64, AArch64). A Cortex-M has
/// none: there the columns cost instructions and stack, and the vote takes each pair as it is.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
type Columns<const K: usize> = [[f32; K]; 4];

/// The first `K` of `pairs` as columns, and how many.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
fn columns<const K: usize>(pairs: &[Pair]) -> (Columns<K>, usize) {
    let mut rays: Columns<K> = [[0.0; K]; 4];
    for (k, c) in pairs.iter().take(K).enumerate() {
        for (column, x) in rays.iter_mut().zip([c.x1.x, c.x1.y, c.x2.x, c.x2.y]) {
            if let Some(x_k) = column.get_mut(k) {
                *x_k = x;
            }
        }
    }
    (rays, pairs.len().min(K))
}

/// The Sampson distances from `e` of the first `n` pairs of `rays` (0 beyond them), each as
/// [`sampson`] computes it, operation for operation (the unit z terms written out: a product by
/// one is exact): the products for many pairs at once, then the square roots one at a time.
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
fn sampsons<const K: usize>(e: &Matrix3<f32>, (rays, n): (&Columns<K>, usize)) -> [f32; K] {
    let [u1, v1, u2, v2] = rays;
    let mut num = [0.0f32; K];
    let mut den = [0.0f32; K];
    let rows = num.iter_mut().zip(den.iter_mut()).take(n);
    for (((((num, den), &u1), &v1), &u2), &v2) in rows.zip(u1).zip(v1).zip(u2).zip(v2) {
        // E x1 and E' x2 as nalgebra's product sums them, column by column; then x2' E x1.
        let ex = [0, 1, 2].map(|i| e[(i, 0)] * u1 + e[(i, 1)] * v1 + e[(i, 2)]);
        let etx = [0, 1].map(|i| e[(0, i)] * u2 + e[(1, i)] * v2 + e[(2, i)]);
        *num = u2 * ex[0] + v2 * ex[1] + ex[2];
        *den = ex[0] * ex[0] + ex[1] * ex[1] + etx[0] * etx[0] + etx[1] * etx[1];
    }
    for (num, &den) in num.iter_mut().zip(&den).take(n) {
        *num = if den <= 0.0 {
            0.0
        } else {
            *num / libm::sqrtf(den)
        };
    }
    num
}

/// The votes of pairs at their Sampson `distances` from a motion: each adds `FULL_VOTE`
/// falling to zero at `kernel_px`.
fn score(distances: impl Iterator<Item = f32>, s: &Search, kernel_px: f32) -> u32 {
    distances
        .map(|sampson| {
            let d = (s.focal_px * sampson).abs();
            (FULL_VOTE * (1.0 - d / kernel_px)).max(0.0) as u32
        })
        .sum()
}

/// The vote of the first `K` of `pairs`: coarse to fine over heading change by pitch change;
/// the best motion and its votes. `None` when no correspondence voted.
pub fn vote<const K: usize>(model: &Model, pairs: &[Pair], s: &Search) -> Option<(Params, u32)> {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    let (rays, n) = columns::<K>(pairs);
    let mut centre = Params {
        alpha: s.alpha,
        ..Params::default()
    };
    let (mut alpha_half, mut pitch_half) = (s.alpha_half, s.pitch_half);
    let mut best = (centre, 0u32);
    for pass in 0..PASSES {
        let (da, dp) = (alpha_half / HALF_BINS as f32, pitch_half / HALF_BINS as f32);
        // The kernel shrinks with the bins, never below the finest pass's.
        let remaining = (PASSES - 1 - pass) as i32;
        let kernel = s.kernel_px / libm::powf(NARROWING, remaining as f32);
        let kernel = kernel.min(s.focal_px * da * 2.0).max(s.kernel_px);
        best = (centre, 0);
        for i in -HALF_BINS..=HALF_BINS {
            for j in -HALF_BINS..=HALF_BINS {
                let p = Params {
                    alpha: centre.alpha + i as f32 * da,
                    pitch: centre.pitch + j as f32 * dp,
                    ..centre
                };
                let e = model.essential(&p, s.distance_m);
                #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
                let votes = score(sampsons(&e, (&rays, n)).into_iter().take(n), s, kernel);
                #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
                let votes = score(
                    pairs.iter().take(K).map(|c| sampson(&e, &c.x1, &c.x2)),
                    s,
                    kernel,
                );
                if votes > best.1 {
                    best = (p, votes);
                }
            }
        }
        centre = best.0;
        alpha_half *= NARROWING;
        pitch_half *= NARROWING;
    }
    (best.1 > 0).then_some(best)
}

/// The scale of the robust weights, pixels, for a typical median distance `typical_px`.
pub fn weights_px(typical_px: f32) -> f32 {
    (CAUCHY_SDS * SD_PER_MEDIAN * typical_px).max(MIN_CAUCHY_PX)
}

/// Refines `start` on the correspondences within `inlier_px` of it (chosen again as it moves):
/// Gauss-Newton on their Sampson distances, weighted robustly. `None` with fewer than
/// `min_inliers` inliers or where the normal equations are singular.
pub fn refine(
    model: &Model,
    pairs: &[Pair],
    start: Params,
    s: &Search,
    min_inliers: u16,
    inlier: &mut [bool],
) -> Option<Fit> {
    let mut p = start;
    let residual = |p: &Params, c: &Pair| {
        let e = model.essential(p, s.distance_m);
        s.focal_px * sampson(&e, &c.x1, &c.x2)
    };
    // The inliers within `scale` times the band, and the robust weights' scale from them.
    let select = |p: &Params, inlier: &mut [bool], scale: f32| {
        let e = model.essential(p, s.distance_m);
        let mut kept = Median::new(scale * s.inlier_px);
        for (c, keep) in pairs.iter().zip(inlier.iter_mut()) {
            let r = (s.focal_px * sampson(&e, &c.x1, &c.x2)).abs();
            *keep = r < scale * s.inlier_px;
            if *keep {
                kept.add(r);
            }
        }
        (kept.n, kept.median())
    };
    let weights_px = |median_px: f32| {
        weights_px(if s.typical_median_px > 0.0 {
            s.typical_median_px
        } else {
            median_px
        })
    };
    let mut choice = INLIER_SCALE.iter();
    let (mut n, median_px) = select(&p, inlier, choice.next().copied().unwrap_or(1.0));
    let mut cauchy_px = weights_px(median_px);
    // The last step's normal matrix under the gate's weights, for the heading's deviation.
    let mut gate_jtj = [[0.0f32; 5]; 5];
    for step in 0..STEPS {
        let last = step + 1 == STEPS;
        if n < min_inliers {
            return None;
        }
        let (base, moved) = essentials(model, &p, s.distance_m);
        let mut jtj = [[0.0f32; 5]; 5];
        let mut jtr = [0.0f32; 5];
        for (c, _) in pairs.iter().zip(inlier.iter()).filter(|(_, k)| **k) {
            let (r, j) = residual_jacobian(&base, &moved, c, s.focal_px);
            let w = cauchy(r, cauchy_px);
            for a in 0..5 {
                jtr[a] += w * j[a] * r;
                for b in 0..5 {
                    jtj[a][b] += w * j[a] * j[b];
                }
            }
            if last {
                let w_gate = cauchy(r, GATE_CAUCHY_PX);
                for a in 0..5 {
                    for b in 0..5 {
                        gate_jtj[a][b] += w_gate * j[a] * j[b];
                    }
                }
            }
        }
        // The prior on the direction of travel: azimuth and elevation (params 3 and 4) about 0.
        let a = p.to_array();
        for k in [3, 4] {
            jtj[k][k] += TRAVEL_PRIOR;
            jtr[k] += TRAVEL_PRIOR * a[k];
            if last {
                gate_jtj[k][k] += TRAVEL_PRIOR;
            }
        }
        let delta = solve(jtj, jtr)?;
        let a = p.to_array();
        p = Params::from_array(core::array::from_fn(|k| a[k] - delta[k]));
        if RESELECT_AFTER.contains(&step) {
            let median_px;
            (n, median_px) = select(&p, inlier, choice.next().copied().unwrap_or(1.0));
            cauchy_px = weights_px(median_px);
        }
    }
    let (n, median_px) = select(&p, inlier, 1.0);
    if n < min_inliers {
        return None;
    }
    let sum_sq: f32 = pairs
        .iter()
        .zip(inlier.iter())
        .filter(|(_, k)| **k)
        .map(|(c, _)| {
            let r = residual(&p, c);
            r * r
        })
        .sum();
    let rms_px = libm::sqrtf(sum_sq / f32::from(n));
    // The heading's variance: the first diagonal entry of the inverse normal matrix, times the
    // residuals' variance.
    let inverse_00 = solve(gate_jtj, [1.0, 0.0, 0.0, 0.0, 0.0])?[0];
    Some(Fit {
        params: p,
        inliers: n,
        rms_px,
        median_px,
        heading_sd_rad: rms_px * libm::sqrtf(inverse_00.max(0.0)),
        weights_px: cauchy_px,
    })
}

/// The essential matrix at `p` over `distance_m`, and at `p` with each parameter moved by
/// [`DERIVATIVE_STEP`] (for the numeric derivatives).
fn essentials(model: &Model, p: &Params, distance_m: f32) -> (Matrix3<f32>, [Matrix3<f32>; 5]) {
    let moved = core::array::from_fn(|k| {
        let mut a = p.to_array();
        a[k] += DERIVATIVE_STEP;
        model.essential(&Params::from_array(a), distance_m)
    });
    (model.essential(p, distance_m), moved)
}

/// Pair `c`'s Sampson distance from `base`, pixels, and its derivatives in the five parameters
/// from the `moved` essentials ([`essentials`]).
fn residual_jacobian(
    base: &Matrix3<f32>,
    moved: &[Matrix3<f32>; 5],
    c: &Pair,
    focal_px: f32,
) -> (f32, [f32; 5]) {
    let r = focal_px * sampson(base, &c.x1, &c.x2);
    let j = core::array::from_fn(|k| {
        (focal_px * sampson(&moved[k], &c.x1, &c.x2) - r) / DERIVATIVE_STEP
    });
    (r, j)
}

/// How far a metre further ahead of the pivot than `model` draws it would move the camera's
/// fitted direction of travel to the right, radians: the fit's response to the camera's
/// distance ahead, through its normal equations at `fit` (the other parameters and the prior
/// as the refinement has them; the inliers and weights it ended with). About the curvature
/// driven where the pairs tell the travel from the turn, less where they tell it less
/// ([`crate::calibration`] learns the distance against it). `None` where the normal equations
/// cannot be solved.
pub fn swing_rad_per_m(
    model: &Model,
    pairs: &[Pair],
    inlier: &[bool],
    fit: &Fit,
    s: &Search,
) -> Option<f32> {
    let p = fit.params;
    let (base, moved) = essentials(model, &p, s.distance_m);
    let ahead = model.from_pivot(-SWING_STEP_M).essential(&p, s.distance_m);
    let mut jtj = [[0.0f32; 5]; 5];
    let mut jtx = [0.0f32; 5];
    for (c, _) in pairs.iter().zip(inlier).filter(|(_, k)| **k) {
        let (r, j) = residual_jacobian(&base, &moved, c, s.focal_px);
        let jx = (s.focal_px * sampson(&ahead, &c.x1, &c.x2) - r) / SWING_STEP_M;
        let w = cauchy(r, fit.weights_px);
        for a in 0..5 {
            jtx[a] += w * j[a] * jx;
            for b in 0..5 {
                jtj[a][b] += w * j[a] * j[b];
            }
        }
    }
    for k in [3, 4] {
        jtj[k][k] += TRAVEL_PRIOR;
    }
    // The parameters' change a metre ahead is -solve(jtj, jtx); the azimuth's, to the right.
    Some(solve(jtj, jtx)?[3])
}

/// What the refinement minimised, at `fit`'s end: each pair's robust loss (Cauchy's,
/// `s^2 / 2 ln(1 + (r / s)^2)`, the one its weights minimise; at most that of the inlier band's
/// edge, so that every pair counts) plus the prior's. Fits of the same pairs compare by it.
pub fn objective(model: &Model, pairs: &[Pair], s: &Search, fit: &Fit) -> f32 {
    let p = fit.params;
    let e = model.essential(&p, s.distance_m);
    let c2 = fit.weights_px * fit.weights_px;
    let losses: f32 = pairs
        .iter()
        .map(|c| {
            let r = (s.focal_px * sampson(&e, &c.x1, &c.x2))
                .abs()
                .min(s.inlier_px);
            0.5 * c2 * libm::logf(1.0 + r * r / c2)
        })
        .sum();
    let prior = 0.5 * TRAVEL_PRIOR;
    losses + prior * (p.azimuth * p.azimuth + p.elevation * p.elevation)
}

/// Whether a turn of `alpha_rad` over `distance_m` swings the camera's travel (the camera
/// sits ahead of the pivot, [`Model::swing_arm_m`]) by more than the prior's width on its
/// direction: then the direction the model expects hangs on the distance, which may be wrong
/// (the drive's first frame knows none; in a slow, tight turn the ground window may have taken
/// a verge or a bank for road), and the prior would turn the heading with it.
pub fn swing_exceeds_prior(model: &Model, alpha_rad: f32, distance_m: f32) -> bool {
    (alpha_rad * model.swing_arm_m()).abs() > TRAVEL_SD_RAD * distance_m
}

/// The factor on `s.distance_m` the pairs agree with best: the consensus ([`vote`] and
/// [`refine`]) at each of seven distances (half octaves up to 2.8 times either way; `given`,
/// the fit at `s.distance_m` itself), the least [`objective`], refined between its neighbours
/// by a parabola in the factor's logarithm. 1 where no other factor gives a fit. `inlier` is
/// left as the last fit's.
pub fn distance_factor<const K: usize>(
    model: &Model,
    pairs: &[Pair],
    s: &Search,
    given: &Fit,
    min_inliers: u16,
    inlier: &mut [bool],
) -> f32 {
    let objectives = DISTANCE_FACTORS.map(|factor| {
        if factor == 1.0 {
            return objective(model, pairs, s, given);
        }
        let s = Search {
            distance_m: s.distance_m * factor,
            ..*s
        };
        vote::<K>(model, pairs, &s)
            .and_then(|(start, _)| refine(model, pairs, start, &s, min_inliers, inlier))
            .map_or(f32::INFINITY, |fit| objective(model, pairs, &s, &fit))
    });
    let Some(best) = (0..DISTANCE_FACTORS.len())
        .filter(|&k| objectives[k].is_finite())
        .min_by(|&a, &b| objectives[a].total_cmp(&objectives[b]))
    else {
        return 1.0;
    };
    let step = 0.5 * core::f32::consts::LN_2;
    let mut log_factor = libm::logf(DISTANCE_FACTORS[best]);
    let below = best.checked_sub(1).and_then(|k| objectives.get(k));
    if let (Some(&below), Some(&above)) = (below, objectives.get(best + 1)) {
        let curvature = below - 2.0 * objectives[best] + above;
        if curvature.is_finite() && curvature > 0.0 {
            log_factor += (0.5 * step * (below - above) / curvature).clamp(-step, step);
        }
    }
    libm::expf(log_factor)
}

/// Cauchy's weight of a residual `r` at scale `scale` (both pixels).
pub(crate) fn cauchy(r: f32, scale: f32) -> f32 {
    1.0 / (1.0 + (r / scale) * (r / scale))
}

/// The median of values in `[0, top)` from a histogram of [`MEDIAN_BINS`] bins, interpolated
/// within its bin: no buffer of the values, no sort.
struct Median {
    counts: [u16; MEDIAN_BINS],
    bin_width: f32,
    /// Values counted.
    n: u16,
}

impl Median {
    fn new(top: f32) -> Self {
        Self {
            counts: [0; MEDIAN_BINS],
            bin_width: top / MEDIAN_BINS as f32,
            n: 0,
        }
    }

    /// Counts `v`, not negative: one at or past the top in the last bin.
    fn add(&mut self, v: f32) {
        // A float-to-integer cast saturates; `min` keeps a large one in the histogram.
        let bin = ((v / self.bin_width) as usize).min(MEDIAN_BINS - 1);
        if let Some(c) = self.counts.get_mut(bin) {
            *c = c.saturating_add(1);
        }
        self.n = self.n.saturating_add(1);
    }

    /// The median; 0 with nothing counted.
    fn median(&self) -> f32 {
        let half = f32::from(self.n) / 2.0;
        let mut below = 0.0;
        for (k, &c) in self.counts.iter().enumerate() {
            let c = f32::from(c);
            if c > 0.0 && below + c >= half {
                return (k as f32 + (half - below) / c) * self.bin_width;
            }
            below += c;
        }
        0.0
    }
}

/// Solves `a x = b` for a symmetric positive definite `a` (Cholesky), damped a little so that a
/// direction the correspondences do not see stays where it is. `None` if it is singular.
///
/// The system is first scaled to a unit diagonal, so that the damping is the same small share
/// of each parameter's own information whatever its unit: damped by a share of the trace
/// instead, the road plane's tilt (seen hundreds of times more weakly than the rotation)
/// kept a quarter of the mount's pitch error in every frame.
pub(crate) fn solve<const N: usize>(a: [[f32; N]; N], b: [f32; N]) -> Option<[f32; N]> {
    // A parameter nothing sees (a zero diagonal) keeps a unit scale: the damping holds it.
    let mut scale = [1.0f32; N];
    for (k, s) in scale.iter_mut().enumerate() {
        let d = a[k][k];
        if d.is_nan() || d < 0.0 {
            return None;
        }
        if d > 0.0 {
            *s = 1.0 / libm::sqrtf(d);
        }
    }
    let mut a: [[f32; N]; N] =
        core::array::from_fn(|i| core::array::from_fn(|j| a[i][j] * scale[i] * scale[j]));
    let b: [f32; N] = core::array::from_fn(|i| b[i] * scale[i]);
    for (k, row) in a.iter_mut().enumerate() {
        row[k] += 1e-6 * N as f32;
    }
    let mut l = [[0.0f32; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let sum: f32 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - sum;
                if d.is_nan() || d <= 0.0 {
                    return None;
                }
                l[i][j] = libm::sqrtf(d);
            } else {
                l[i][j] = (a[i][j] - sum) / l[j][j];
            }
        }
    }
    let mut y = [0.0f32; N];
    for i in 0..N {
        let sum: f32 = (0..i).map(|k| l[i][k] * y[k]).sum();
        y[i] = (b[i] - sum) / l[i][i];
    }
    let mut x = [0.0f32; N];
    for i in (0..N).rev() {
        let sum: f32 = (i + 1..N).map(|k| l[k][i] * x[k]).sum();
        x[i] = (y[i] - sum) / l[i][i];
    }
    let x: [f32; N] = core::array::from_fn(|i| x[i] * scale[i]);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::super::epipolar::tests::{mount, rays};
    use super::*;
    use std::vec::Vec;

    /// Points of a street scene: facades each side, far buildings, the road.
    fn scene(n: usize) -> Vec<Vector3<f32>> {
        let mut next = crate::test_rng::uniform(2463534242u32);
        (0..n)
            .map(|k| match k % 3 {
                0 => Vector3::new(8.0 + 40.0 * next(), 7.0 + 3.0 * next(), 0.5 + 8.0 * next()),
                1 => Vector3::new(8.0 + 40.0 * next(), -7.0 - 3.0 * next(), 0.5 + 8.0 * next()),
                _ => Vector3::new(60.0 + 200.0 * next(), -40.0 + 80.0 * next(), 10.0 * next()),
            })
            .collect()
    }

    #[test]
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    fn the_votes_columns_give_each_pair_the_sampson_distance_bit_for_bit() {
        let model = Model::new(&mount());
        let mut next = crate::test_rng::uniform(977);
        let mut pairs = Vec::new();
        for _ in 0..61 {
            let ray =
                |next: &mut dyn FnMut() -> f32| Vector3::new(next() * 2.0 - 1.0, next() - 0.5, 1.0);
            let (x1, x2) = (ray(&mut next), ray(&mut next));
            pairs.push(Pair { x1, x2 });
        }
        let (rays, n) = columns::<64>(&pairs);
        for _ in 0..50 {
            let p = Params {
                alpha: 0.1 * (next() - 0.5),
                pitch: 0.02 * (next() - 0.5),
                roll: 0.02 * (next() - 0.5),
                azimuth: 0.05 * (next() - 0.5),
                elevation: 0.05 * (next() - 0.5),
            };
            let e = model.essential(&p, 0.1 + 2.0 * next());
            let d = sampsons(&e, (&rays, n));
            for (k, c) in pairs.iter().enumerate() {
                assert_eq!(d[k].to_bits(), sampson(&e, &c.x1, &c.x2).to_bits(), "{p:?}");
            }
            assert!(d[n..].iter().all(|&x| x == 0.0));
        }
    }

    #[test]
    fn the_true_motion_is_found_among_outliers_to_a_hundredth_of_a_degree() {
        // Pixel noise up to +-0.3 px; a fifth as many mismatches as good pairs.
        const NOISE: f32 = 0.6;
        const OUTLIERS: usize = 20;
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 0.8f32.to_radians(),
            pitch: -0.2f32.to_radians(),
            roll: 0.1f32.to_radians(),
            azimuth: 0.5f32.to_radians(),
            elevation: -0.3f32.to_radians(),
        };
        let f = 718.0;
        let mut noise = 7u32;
        let mut jitter = || {
            noise = noise.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            ((noise >> 16) % 1000) as f32 / 1000.0 - 0.5
        };
        let mut pairs: Vec<Pair> = scene(90)
            .into_iter()
            .map(|pt| {
                let (x1, mut x2) = rays(&model, &truth, 1.0, pt);
                // A third of a pixel of noise.
                x2.x += NOISE * jitter() / f;
                x2.y += NOISE * jitter() / f;
                Pair { x1, x2 }
            })
            .collect();
        // A fifth of them mismatched.
        for k in 0..OUTLIERS {
            let x1 = pairs[k].x1;
            pairs.push(Pair {
                x1,
                x2: Vector3::new(x1.x + 0.03 * jitter(), x1.y + 0.02 * jitter(), 1.0),
            });
        }
        let s = Search {
            alpha: 0.0,
            alpha_half: 2f32.to_radians(),
            pitch_half: 0.5f32.to_radians(),
            distance_m: 0.9,
            focal_px: f,
            kernel_px: 0.7,
            inlier_px: 1.0,
            typical_median_px: 0.0,
        };
        let (coarse, _) = vote::<128>(&model, &pairs, &s).unwrap();
        // The vote's direction of travel is the arc's: half a degree off here, which near points
        // read as heading.
        assert!(
            (coarse.alpha - truth.alpha).abs() < 0.15f32.to_radians(),
            "{coarse:?}"
        );
        let mut inlier = std::vec![false; pairs.len()];
        let fit = refine(&model, &pairs, coarse, &s, 20, &mut inlier).unwrap();
        let err = (fit.params.alpha - truth.alpha).to_degrees();
        std::println!("{fit:?}, heading error {err} deg");
        assert!(err.abs() < 0.01, "{err} deg");
        assert!(fit.inliers >= 85 && fit.inliers <= 95, "{fit:?}");
    }

    /// The heading's mean pull over four draws of noise: 200 pairs placed to +-`noise_px / 2`,
    /// a fifth of them turned 0.05 deg more (0.6 px at this focal length: a vehicle ahead
    /// drifting across the lane), within the inlier band, refined with the drive's typical
    /// median `typical_median_px` (0: the frame's own). Weighed alike they would pull it by
    /// 0.01 deg.
    fn pull_of_a_drifting_fifth_deg(noise_px: f32, typical_median_px: f32) -> f32 {
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 0.8f32.to_radians(),
            ..Params::default()
        };
        let drifting = Params {
            alpha: truth.alpha + 0.05f32.to_radians(),
            ..truth
        };
        let f = 718.0;
        let s = Search {
            alpha: truth.alpha,
            alpha_half: 1f32.to_radians(),
            pitch_half: 0.5f32.to_radians(),
            distance_m: 1.0,
            focal_px: f,
            kernel_px: 0.7,
            inlier_px: 1.0,
            typical_median_px,
        };
        let mut pull_deg = 0.0;
        for seed in 5..9 {
            let mut next = crate::test_rng::uniform(seed);
            let pairs: Vec<Pair> = scene(200)
                .into_iter()
                .enumerate()
                .map(|(k, pt)| {
                    let motion = if k % 5 == 0 { &drifting } else { &truth };
                    let (x1, mut x2) = rays(&model, motion, 1.0, pt);
                    x2.x += noise_px * (next() - 0.5) / f;
                    x2.y += noise_px * (next() - 0.5) / f;
                    Pair { x1, x2 }
                })
                .collect();
            let mut inlier = std::vec![false; pairs.len()];
            let fit = refine(&model, &pairs, truth, &s, 20, &mut inlier).unwrap();
            pull_deg += (fit.params.alpha - truth.alpha).to_degrees() / 4.0;
        }
        pull_deg
    }

    #[test]
    fn pairs_a_few_tenths_of_a_pixel_off_pull_in_proportion_to_the_matcher_s_noise() {
        // The drive's first fit, weighed at its pairs' own spread: under half the pull.
        // (Weighed at a fixed half pixel: 0.0087 deg, measured.)
        let own = pull_of_a_drifting_fifth_deg(0.2, 0.0);
        assert!(own.abs() < 0.005, "{own} deg");
        // A drive whose pairs are typically placed to 0.2 px (a median): the weights take
        // these as no finer than its other pairs, and the drifting fifth pulls nearly fully.
        let coarse = pull_of_a_drifting_fifth_deg(0.2, 0.2);
        assert!(coarse > 0.008, "{coarse} deg");
    }

    #[test]
    fn a_frame_of_poorer_pairs_is_weighed_at_the_drive_s_spread() {
        // A bend whose pairs are placed to +-0.3 px on a drive whose pairs are typically
        // placed to a median of 0.05 px: weighed at the drive's spread the drifting fifth
        // pulls less than at the frame's own, which would loosen the weights for it
        // (measured: 0.0078 against 0.0094 deg).
        let own = pull_of_a_drifting_fifth_deg(0.6, 0.0);
        let drive = pull_of_a_drifting_fifth_deg(0.6, 0.05);
        std::println!("own {own} deg, drive's {drive} deg");
        assert!(
            drive.abs() < 0.9 * own.abs(),
            "own {own} deg, drive's {drive} deg"
        );
    }

    #[test]
    fn exact_pairs_keep_the_weights_finite() {
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 0.8f32.to_radians(),
            ..Params::default()
        };
        let pairs: Vec<Pair> = scene(60)
            .into_iter()
            .map(|pt| {
                let (x1, x2) = rays(&model, &truth, 1.0, pt);
                Pair { x1, x2 }
            })
            .collect();
        let s = Search {
            alpha: truth.alpha,
            alpha_half: 1f32.to_radians(),
            pitch_half: 0.5f32.to_radians(),
            distance_m: 1.0,
            focal_px: 718.0,
            kernel_px: 0.7,
            inlier_px: 1.0,
            typical_median_px: 0.0,
        };
        let mut inlier = std::vec![false; pairs.len()];
        let fit = refine(&model, &pairs, truth, &s, 20, &mut inlier).unwrap();
        assert!((fit.params.alpha - truth.alpha).abs() < 1e-5, "{fit:?}");
        assert_eq!(fit.inliers, 60);
    }

    #[test]
    fn a_weakly_seen_parameter_is_solved_whatever_its_unit() {
        // A rotation seen a million times more strongly than a tilt, correlated a little: both
        // come out whole (damped by a share of the trace, the tilt came out at half its value).
        let a = [[1e6, 10.0], [10.0, 1.0]];
        let x = [1.0f32, 0.5];
        let b = [
            a[0][0] * x[0] + a[0][1] * x[1],
            a[1][0] * x[0] + a[1][1] * x[1],
        ];
        let solved = solve(a, b).unwrap();
        assert!((solved[0] - x[0]).abs() < 1e-4, "{solved:?}");
        assert!((solved[1] - x[1]).abs() < 1e-4, "{solved:?}");
        // A parameter nothing sees stays where it is; a negative diagonal is no system.
        let unseen = solve([[4.0, 0.0], [0.0, 0.0]], [8.0, 0.0]).unwrap();
        assert!(
            (unseen[0] - 2.0).abs() < 1e-4 && unseen[1] == 0.0,
            "{unseen:?}"
        );
        assert_eq!(solve([[-1.0, 0.0], [0.0, 1.0]], [1.0, 1.0]), None);
        assert_eq!(solve([[f32::NAN, 0.0], [0.0, 1.0]], [1.0, 1.0]), None);
    }

    #[test]
    fn the_histogram_s_median_is_within_a_bin_of_the_values() {
        let mut m = Median::new(1.0);
        assert_eq!(m.median(), 0.0);
        for v in [0.1, 0.5, 0.3, 0.2, 5.0] {
            m.add(v);
        }
        // Sorted 0.1, 0.2, 0.3, 0.5, past the top: the median is 0.3.
        assert!(
            (m.median() - 0.3).abs() <= 1.0 / MEDIAN_BINS as f32,
            "{}",
            m.median()
        );
        assert_eq!(m.n, 5);
    }

    #[test]
    fn a_slow_tight_turn_finds_its_distance() {
        // 3 deg over 0.27 m where the prediction says 0.1 m (the ground window saw a verge):
        // at 0.1 m the camera's swing would turn its travel by 36 deg instead of 13.
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 3f32.to_radians(),
            pitch: 0.1f32.to_radians(),
            azimuth: 0.3f32.to_radians(),
            ..Params::default()
        };
        let f = 718.0;
        let mut next = crate::test_rng::uniform(11u32);
        let pairs: Vec<Pair> = scene(90)
            .into_iter()
            .map(|pt| {
                let (x1, mut x2) = rays(&model, &truth, 0.27, pt);
                // A third of a pixel of noise.
                x2.x += 0.6 * (next() - 0.5) / f;
                x2.y += 0.6 * (next() - 0.5) / f;
                Pair { x1, x2 }
            })
            .collect();
        let s = Search {
            alpha: 2.8f32.to_radians(),
            alpha_half: 1f32.to_radians(),
            pitch_half: 0.6f32.to_radians(),
            distance_m: 0.1,
            focal_px: f,
            kernel_px: 0.7,
            inlier_px: 1.0,
            typical_median_px: 0.0,
        };
        assert!(swing_exceeds_prior(&model, s.alpha, s.distance_m));
        let mut inlier = std::vec![false; pairs.len()];
        let heading_error_deg = |s: &Search, inlier: &mut [bool]| {
            let (start, _) = vote::<128>(&model, &pairs, s).unwrap();
            let fit = refine(&model, &pairs, start, s, 20, inlier).unwrap();
            (fit.params.alpha - truth.alpha).to_degrees()
        };
        let (start, _) = vote::<128>(&model, &pairs, &s).unwrap();
        let given = refine(&model, &pairs, start, &s, 20, &mut inlier).unwrap();
        let predicted = (given.params.alpha - truth.alpha).to_degrees();
        let factor = distance_factor::<128>(&model, &pairs, &s, &given, 20, &mut inlier);
        let found = Search {
            distance_m: s.distance_m * factor,
            ..s
        };
        let err = heading_error_deg(&found, &mut inlier);
        std::println!(
            "at the prediction {predicted} deg; found {} m, {err} deg",
            found.distance_m
        );
        assert!(
            (found.distance_m - 0.27).abs() < 0.04,
            "{} m",
            found.distance_m
        );
        assert!(
            err.abs() < 0.01 && predicted.abs() > 0.03,
            "{predicted} {err}"
        );
        // Straight on, the swing is nothing: the prediction's distance stands.
        assert!(!swing_exceeds_prior(&model, 0.0, s.distance_m));
    }
}
#[cfg(test)]
mod ground_only {
    use super::super::epipolar::tests::rays;
    use super::*;
    use std::vec::Vec;

    #[test]
    fn a_camera_looking_down_at_the_road_alone() {
        let mount = crate::Mount {
            x_m: 1.5,
            height_m: 2.7,
            pitch_rad: (-20f32).to_radians(),
            ..crate::Mount::DEFAULT
        };
        let model = Model::new(&mount);
        let truth = Params {
            alpha: 2f32.to_radians(),
            ..Params::default()
        };
        let mut next = crate::test_rng::uniform(99u32);
        let pairs: Vec<Pair> = (0..80)
            .map(|_| {
                let pt = Vector3::new(3.0 + 8.0 * next(), -3.0 + 6.0 * next(), 0.0);
                let (x1, x2) = rays(&model, &truth, 0.25, pt);
                Pair { x1, x2 }
            })
            .filter(|p| p.x1.x.abs() < 0.6 && p.x1.y.abs() < 0.45)
            .collect();
        let s = Search {
            alpha: 1.8f32.to_radians(),
            alpha_half: 1f32.to_radians(),
            pitch_half: 0.6f32.to_radians(),
            distance_m: 0.25,
            focal_px: 560.0,
            kernel_px: 0.7,
            inlier_px: 1.0,
            typical_median_px: 0.0,
        };
        let (coarse, _) = vote::<128>(&model, &pairs, &s).unwrap();
        let mut inlier = std::vec![false; pairs.len()];
        let fit = refine(&model, &pairs, coarse, &s, 20, &mut inlier).unwrap();
        std::println!("{} pairs; coarse {coarse:?}\nfit {fit:?}", pairs.len());
        let err = (fit.params.alpha - truth.alpha).to_degrees();
        assert!(err.abs() < 0.02, "{err} deg");
    }
}
