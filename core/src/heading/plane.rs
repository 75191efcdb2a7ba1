//! The road's plane from the pairs on it. Points of one plane seen from two places move by its
//! homography, which holds the camera's rotation, its travel over the camera's height and the
//! plane's normal: so with the height known, the pairs below the horizon tell the body's pitch
//! and roll to the road under it and the distance travelled, a frame at a time, matched by
//! appearance rather than by where the ground vote expects them. A Gauss-Newton fit over the
//! motion's five parameters, the distance and the tilt, started from the consensus
//! ([`super::consensus`]), on the pairs that meet the road where the caller takes it for road
//! (the ground window's lane, twice as far and as wide): the consensus's inliers and the ground
//! window's corners found again by patch ([`crate::ground_patches`]), weighed robustly: points
//! off the road (a car's flank, a kerb's face) leave it.

use super::consensus::{Pair, cauchy, solve};
use super::epipolar::{Model, Params, RoadMotion, Tilt};
use nalgebra::Vector3;

/// What the pairs on the road said.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Road {
    /// The body's pitch (nose up) to the road under the first frame, in the mount's vehicle
    /// frame, radians: on average over a drive, the mount's pitch error.
    pub pitch_rad: f32,
    /// The body's roll (left side up) to the road, as `pitch_rad`.
    pub roll_rad: f32,
    /// The direction of travel left of the arc's chord as the mount sets it, radians: on
    /// average, the mount's yaw error less the camera's distance ahead of the axle's error
    /// times the curvature ([`crate::calibration`]).
    pub azimuth_rad: f32,
    /// The distance travelled, metres (from the pivot the motion is drawn from).
    pub distance_m: f32,
    /// The standard error of `azimuth_rad`, radians: from the fit's normal equations and its
    /// residuals' spread.
    pub azimuth_sd_rad: f32,
    /// Pairs that took part.
    pub pairs: u16,
    /// Their root mean square distance from the fit, pixels (each axis).
    pub rms_px: f32,
}

impl Road {
    /// How far `azimuth_rad` would move right, radians, were the camera a metre further ahead
    /// of the pivot than the mount says, over a heading change of `turn_rad`: its sine over the
    /// fitted distance. The homography holds the camera's travel whole, so the travel from the
    /// pivot takes up all of the camera's further swing, `(Q - I)` times the metre
    /// ([`crate::calibration`] learns the distance ahead against it). The turn is best another
    /// fit's (the frame's heading): this fit's own trades with its azimuth, frame by frame, and
    /// a line of one against the other would be tilted by that (on a swaying body, 0.08 m).
    pub fn swing_rad_per_m(&self, turn_rad: f32) -> f32 {
        libm::sinf(turn_rad) / self.distance_m
    }
}

/// Parameters: the motion's five ([`Params`]), the distance, the tilt's pitch and roll.
const N: usize = 8;
/// Gauss-Newton steps, and the band a residual is taken within at each, times `inlier_px`:
/// wide at first, for the start's distance is the prediction's.
const STEPS: usize = 6;
const BAND: [f32; STEPS] = [8.0, 4.0, 2.0, 1.0, 1.0, 1.0];
/// Fewest pairs on the road for a fit: a homography has eight degrees of freedom, and each
/// pair gives two equations; three times as many, for the robust weights to set some aside.
const MIN_PAIRS: usize = 12;
/// Step of the numeric derivatives: radians for the angles, a share of the distance for it.
const DERIVATIVE_STEP: f32 = 1e-4;
/// Least distance the fit ends at, metres: under it the travel hardly moves the road's points
/// and the plane is not seen.
const MIN_DISTANCE_M: f32 = 0.2;

/// The parameters as an array: the motion's five, the distance, the tilt.
fn to_array(p: &Params, distance_m: f32, t: Tilt) -> [f32; N] {
    let [a, b, c, d, e] = p.to_array();
    [a, b, c, d, e, distance_m, t.pitch, t.roll]
}

/// The inverse of [`to_array`].
fn from_array(a: [f32; N]) -> (Params, f32, Tilt) {
    let [a0, a1, a2, a3, a4, d, tp, tr] = a;
    (
        Params::from_array([a0, a1, a2, a3, a4]),
        d,
        Tilt {
            pitch: tp,
            roll: tr,
        },
    )
}

/// The road's homography under the parameters `a`.
fn road_motion<'a>(model: &'a Model, a: &[f32; N]) -> RoadMotion<'a> {
    let (p, d, t) = from_array(*a);
    model.through_road(&p, d, t)
}

/// The residual of pair `c` under the homography `h`, pixels (columns, rows); `None` where its
/// first ray meets no road.
fn residual(h: &RoadMotion, c: &Pair, focal_px: f32) -> Option<[f32; 2]> {
    let x2 = h.seen(&c.x1)?;
    Some([focal_px * (x2.x - c.x2.x), focal_px * (x2.y - c.x2.y)])
}

/// Whether pair `c`'s first ray meets the level road where `on_road` takes the point.
pub fn on_the_road(model: &Model, on_road: impl Fn(Vector3<f32>) -> bool, c: &Pair) -> bool {
    model
        .road_point(Tilt::default(), &c.x1)
        .is_some_and(on_road)
}

/// Pairs [`median_travel`] takes at most.
const MEDIAN_PAIRS: usize = 64;

/// The median over `pairs` (at most [`MEDIAN_PAIRS`]) of the distance each alone tells under
/// the motion `motion` over the level road ([`RoadMotion::travel_to`]), each weighed by how far
/// a metre moves its point across the image (squared): metres, and how many told one; `None`
/// where none did. A point far ahead moves a pixel over metres of travel, so a pixel's error in
/// its match, or in the consensus's heading, would move its distance as much.
pub fn median_travel<'a>(
    model: &Model,
    motion: &Params,
    pairs: impl Iterator<Item = &'a Pair>,
) -> Option<(f32, usize)> {
    let unit = model.through_road(motion, 1.0, Tilt::default());
    let mut told = heapless::Vec::<(f32, f32), MEDIAN_PAIRS>::new();
    for (d, w) in pairs.filter_map(|c| unit.travel_to(&c.x1, &c.x2)) {
        if d.is_finite() && w.is_finite() && told.push((d, w)).is_err() {
            break;
        }
    }
    crate::sort::sort_by_key(&mut told, |&(d, _)| d);
    let half = told.iter().map(|&(_, w)| w).sum::<f32>() / 2.0;
    let mut acc = 0.0;
    let at = told.iter().position(|&(_, w)| {
        acc += w;
        acc >= half
    })?;
    Some((told[at].0, told.len()))
}

/// Fits the road's plane to the `pairs` whose first ray meets the road where
/// `on_road` takes the point (vehicle frame, from the point the arc is drawn from), from the
/// motion `start` over `distance_m`: residuals over `inlier_px` are set aside (more in the
/// first steps), the rest weighed by Cauchy's weights at `scale_px`. `None` under
/// [`MIN_PAIRS`] pairs, where the fitted distance is under [`MIN_DISTANCE_M`], or where the
/// normal equations are singular.
pub fn fit<'a, I: Iterator<Item = &'a Pair>>(
    model: &Model,
    pairs: impl Fn() -> I,
    on_road: impl Fn(Vector3<f32>) -> bool,
    start: Params,
    distance_m: f32,
    (focal_px, scale_px, inlier_px): (f32, f32, f32),
) -> Option<Road> {
    // Started from the least distance where the motion's is shorter: a start under it would
    // leave out the frames whose motion ran short, and keep those that ran long.
    let mut a = to_array(&start, distance_m.max(MIN_DISTANCE_M), Tilt::default());
    let chosen = || pairs().filter(|c| on_the_road(model, &on_road, c));
    let mut used = 0usize;
    let mut sum_sq = 0.0f32;
    let mut azimuth_var = 0.0f32;
    for (step, band) in BAND.map(|b| b * inlier_px).into_iter().enumerate() {
        let mut jtj = [[0.0f32; N]; N];
        let mut jtr = [0.0f32; N];
        (used, sum_sq) = (0, 0.0);
        let steps: [f32; N] = core::array::from_fn(|k| {
            if k == 5 {
                DERIVATIVE_STEP * a[5].max(MIN_DISTANCE_M)
            } else {
                DERIVATIVE_STEP
            }
        });
        // The homographies at the parameters and each moved by its step, once for all pairs.
        let base = road_motion(model, &a);
        let moved: [RoadMotion; N] = core::array::from_fn(|k| {
            let mut moved = a;
            moved[k] += steps[k];
            road_motion(model, &moved)
        });
        for c in chosen() {
            let Some(r) = residual(&base, c, focal_px) else {
                continue;
            };
            if r[0].abs() > band || r[1].abs() > band {
                continue;
            }
            // Both axes' derivatives; a pair whose moved ray leaves the road is left out.
            let mut j = [[0.0f32; N]; 2];
            let mut whole = true;
            for (k, h) in moved.iter().enumerate() {
                match residual(h, c, focal_px) {
                    Some(m) => {
                        j[0][k] = (m[0] - r[0]) / steps[k];
                        j[1][k] = (m[1] - r[1]) / steps[k];
                    }
                    None => whole = false,
                }
            }
            if !whole {
                continue;
            }
            used += 1;
            for (axis, ja) in j.iter().enumerate() {
                let w = cauchy(r[axis], scale_px);
                sum_sq += r[axis] * r[axis];
                for x in 0..N {
                    jtr[x] += w * ja[x] * r[axis];
                    for y in 0..N {
                        jtj[x][y] += w * ja[x] * ja[y];
                    }
                }
            }
        }
        if used < MIN_PAIRS {
            return None;
        }
        let delta = solve(jtj, jtr)?;
        if step + 1 == STEPS {
            // The azimuth's variance a pixel squared of residual: its diagonal entry of the
            // last step's inverse normal matrix (which `solve` has just factored: it cannot
            // fail here where it did not above).
            let unit = core::array::from_fn(|k| if k == 3 { 1.0 } else { 0.0 });
            azimuth_var = solve(jtj, unit)?[3];
        }
        a = core::array::from_fn(|k| a[k] - delta[k]);
        // A distance that fell under the least (or is not a number) is no fit.
        if a[5].is_nan() || a[5] < MIN_DISTANCE_M {
            return None;
        }
    }
    let (p, d, t) = from_array(a);
    Some(Road {
        pitch_rad: t.pitch,
        roll_rad: t.roll,
        azimuth_rad: p.azimuth,
        distance_m: d,
        azimuth_sd_rad: libm::sqrtf(azimuth_var.max(0.0) * sum_sq / (2.0 * used as f32)),
        pairs: u16::try_from(used).unwrap_or(u16::MAX),
        rms_px: libm::sqrtf(sum_sq / (2.0 * used as f32)),
    })
}

#[cfg(test)]
mod tests {
    use super::super::epipolar::tests::{mount, rays};
    use super::*;
    use std::vec::Vec;

    /// Pairs of road points ahead, on the road tilted by `tilt` under the camera, seen from
    /// both frames of motion `p` over `d` metres; every fifth a point 0.5 m above it (a car's
    /// flank), and each ray moved by up to `noise_px`.
    fn road_pairs(model: &Model, p: &Params, d: f32, tilt: Tilt, noise_px: f32) -> Vec<Pair> {
        let mut next = crate::test_rng::uniform(77u32);
        let b = super::super::epipolar::tilt_rotation(tilt);
        let height = 1.65;
        (0..80)
            .map(|k| {
                // On the road's plane, in the road's frame under the camera, then the vehicle's.
                let (ahead, left) = (6.0 + 18.0 * next(), 5.0 * (next() - 0.5) * 2.0);
                let up = if k % 5 == 0 { 0.5 } else { 0.0 };
                let point = b.transpose() * Vector3::new(ahead, left, up - height)
                    + Vector3::new(1.2, 0.0, height);
                let (x1, x2) = rays(model, p, d, point);
                let shake = |v: f32, next: &mut dyn FnMut() -> f32| {
                    v + noise_px / 700.0 * 2.0 * (next() - 0.5)
                };
                Pair {
                    x1,
                    x2: Vector3::new(shake(x2.x, &mut next), shake(x2.y, &mut next), 1.0),
                }
            })
            .collect()
    }

    #[test]
    fn the_road_s_tilt_and_the_distance_come_back_from_pairs_on_it() {
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 0.01,
            pitch: 0.002,
            roll: -0.001,
            azimuth: 0.0,
            elevation: 0.0,
        };
        let tilt = Tilt {
            pitch: 1f32.to_radians(),
            roll: -0.7f32.to_radians(),
        };
        let pairs = road_pairs(&model, &truth, 0.9, tilt, 0.2);
        // Started from the level road and a distance 10 % short.
        let road = fit(
            &model,
            || pairs.iter(),
            |_| true,
            truth,
            0.81,
            (700.0, 0.3, 1.0),
        )
        .expect("a fit");
        let pitch_deg = road.pitch_rad.to_degrees();
        let roll_deg = road.roll_rad.to_degrees();
        assert!((pitch_deg - 1.0).abs() < 0.05, "{road:?}");
        assert!((roll_deg + 0.7).abs() < 0.05, "{road:?}");
        assert!((road.distance_m - 0.9).abs() < 0.01, "{road:?}");
        // The points off the road were set aside.
        assert!(road.pairs >= 60 && road.pairs <= 66, "{road:?}");
        assert!(road.rms_px < 0.2, "{road:?}");
    }

    #[test]
    fn a_camera_further_ahead_than_the_model_shows_in_the_direction_of_travel() {
        // Pairs seen by a camera 0.2 m further ahead of the pivot than the model draws it, in a
        // bend of 3 deg over 0.9 m: the fit's direction of travel leaves the chord by 0.2 m
        // times the swing a metre gives.
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 3f32.to_radians(),
            ..Params::default()
        };
        let ahead = model.from_pivot(-0.2);
        for noise_px in [0.0, 0.2] {
            let pairs = road_pairs(&ahead, &truth, 0.9, Tilt::default(), noise_px);
            let road = fit(
                &model,
                || pairs.iter(),
                |_| true,
                truth,
                0.9,
                (700.0, 0.3, 1.0),
            )
            .expect("a fit");
            let swing = road.swing_rad_per_m(truth.alpha);
            let expected = libm::sinf(truth.alpha) / 0.9;
            assert!((swing - expected).abs() < 0.02 * expected, "{road:?}");
            // Within three of the fit's own standard errors.
            let told = road.azimuth_rad / swing;
            let sd_m = road.azimuth_sd_rad / swing;
            assert!(
                (told - 0.2).abs() < 0.005 + 3.0 * sd_m,
                "{noise_px}: {told} m, {road:?}"
            );
            // The fit knows its direction to a tenth of a degree, noise or none.
            assert!(road.azimuth_sd_rad < 0.1f32.to_radians(), "{road:?}");
        }
    }

    #[test]
    fn too_few_pairs_or_too_short_a_step_give_no_plane() {
        let model = Model::new(&mount());
        let p = Params::default();
        let tilt = Tilt::default();
        let pairs = road_pairs(&model, &p, 0.9, tilt, 0.0);
        let scales = (700.0, 0.3, 1.0);
        let few = || pairs.iter().take(10);
        assert_eq!(fit(&model, few, |_| true, p, 0.9, scales), None);
        let all = || pairs.iter();
        // None on the road where the caller says the road is not.
        assert_eq!(fit(&model, all, |_| false, p, 0.9, scales), None);
        // A step of 0.1 m is too short to see the plane, whatever the motion's distance says.
        let short = road_pairs(&model, &p, 0.1, tilt, 0.0);
        for start_m in [0.1, 0.9] {
            let fitted = fit(&model, || short.iter(), |_| true, p, start_m, scales);
            assert_eq!(fitted, None, "{start_m}");
        }
    }

    #[test]
    fn a_motion_that_ran_short_still_gets_the_plane_s_distance() {
        // The plane fitted from a distance under its least, 0.05 m where the road moved 0.3 m:
        // a frame whose vote ran short is measured as one that ran long.
        let model = Model::new(&mount());
        let p = Params::default();
        let pairs = road_pairs(&model, &p, 0.3, Tilt::default(), 0.0);
        let road = fit(
            &model,
            || pairs.iter(),
            |_| true,
            p,
            0.05,
            (700.0, 0.3, 1.0),
        );
        let road = road.expect("a fit");
        assert!((road.distance_m - 0.3).abs() < 0.003, "{road:?}");
    }
    #[test]
    fn each_pair_on_the_road_tells_the_distance_and_their_median_holds_off_the_rest() {
        // The level road, a turn and a pitch change, 1.3 m: every pair on it alone gives the
        // distance back, and with every fifth point half a metre above the road (a car's flank)
        // the median still does, far from the 0.2 m the caller's prediction might have said.
        let model = Model::new(&mount());
        let p = Params {
            alpha: 0.02,
            pitch: -0.003,
            ..Params::default()
        };
        let pairs = road_pairs(&model, &p, 1.3, Tilt::default(), 0.0);
        let unit = model.through_road(&p, 1.0, Tilt::default());
        for c in pairs.iter().skip(1).step_by(5) {
            let (d, _) = unit.travel_to(&c.x1, &c.x2).expect("a distance");
            assert!((d - 1.3).abs() < 1e-3, "{d}");
        }
        let (d, n) = median_travel(&model, &p, pairs.iter()).expect("a median");
        assert!((d - 1.3).abs() < 0.01, "{d}");
        assert_eq!(n, MEDIAN_PAIRS.min(pairs.len()));
        // Under noise of a fifth of a pixel, within a few centimetres.
        let noisy = road_pairs(&model, &p, 1.3, Tilt::default(), 0.2);
        let (d, _) = median_travel(&model, &p, noisy.iter()).expect("a median");
        assert!((d - 1.3).abs() < 0.05, "{d}");
        // A point 6 m ahead weighs more than ten times one 20 m ahead (about the inverse
        // square of the distance, squared).
        let weight = |ahead: f32| {
            let (x1, x2) = rays(&model, &p, 1.3, Vector3::new(1.2 + ahead, 1.0, 0.0));
            unit.travel_to(&x1, &x2).expect("a distance").1
        };
        assert!(
            weight(6.0) > 10.0 * weight(20.0),
            "{} {}",
            weight(6.0),
            weight(20.0)
        );
        // No pair, no distance.
        assert_eq!(median_travel(&model, &p, pairs.iter().take(0)), None);
    }
}
