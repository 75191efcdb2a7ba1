//! The heading change from the whole image. The ground plane gives metric distance, but its
//! heading answers to the mount's roll and yaw as the ground window sees them; rotation about
//! the vertical moves every point of the image alike, at any depth, whatever the mount's pitch,
//! roll or height. Per frame:
//!
//! 1. **Corners** ([`corners`]): FAST corners over the whole frame, the strongest few per cell
//!    of a grid: the candidates.
//! 2. **Matches**: each of the last frame's features looks for its 7x7 patch ([`patch`]) among
//!    the candidates nearest where it should be (where its own image motion of the last frame
//!    takes it; for a new one, where the predicted motion takes the point of the road it would
//!    be, or turns it if it is above the horizon), to a fraction of a pixel; a pair stands where
//!    each is the other's best.
//! 3. **Consensus** ([`consensus`]): a vote over heading change by pitch change, every pair
//!    voting through its distance from the planar motion's epipolar constraint ([`epipolar`]),
//!    then Gauss-Newton on the peak's inliers over heading, pitch and roll change and the
//!    direction of travel. In a slow, tight turn, where the camera's swing about the pivot
//!    makes that direction hang on the distance, the distance is found with the motion
//!    ([`consensus::distance_factor`]). The heading stands where enough pairs agree and
//!    determine it.
//! 4. **Features for the next frame**: the paired candidates carry their tracks on; each cell
//!    is filled up to its share with its strongest other candidates. A track lives as long as
//!    its corner is found again, not only while it stays among its cell's strongest.
//!
//! The odometer takes the heading change where it stands, and the ground vote's distance given
//! that heading.

pub mod consensus;
pub mod corners;
pub mod epipolar;
pub mod patch;
pub mod plane;

use crate::calibration::MIN_INLIERS_ABOVE_HORIZON;
use crate::config::ValidConfig;
use crate::frame::Frame;
use crate::motion::Motion;
use crate::projection::{Camera, Pixel};
use consensus::{Fit, Pair, Search};
use corners::{Grid, ImageCorner};
use epipolar::{Model, Params};
use heapless::Vec;
use nalgebra::Vector3;
use patch::Patch;

/// Half width of the pitch-change search, radians (0.6 deg: a suspension's +-0.5 deg at 1.5 Hz
/// changes by up to 0.47 deg in 0.1 s).
const PITCH_HALF_RAD: f32 = 0.6 * core::f32::consts::PI / 180.0;

/// How far from its predicted place a feature tracked last frame is looked for, pixels (each
/// axis): its image motion changes little between two frames.
const TRACKED_REACH_PX: f32 = 10.0;

/// How far a feature new last frame is looked for around its predicted place, pixels (columns,
/// rows): anything standing on the road lies between the place a point at infinity would take
/// and the road's, and points a few metres away move tens of pixels a frame.
const NEW_REACH_PX: (f32, f32) = (48.0, 32.0);

/// At most this many headings either side of straight are tried where no motion predicts the
/// features' places ([`ImageHeading::start_guess`]): a bound on one frame's work.
const MAX_START_STEPS: f32 = 3.0;

/// Least distance travelled the translation is given, metres: standing still, the constraint
/// keeps a direction.
const MIN_DISTANCE_M: f32 = 0.1;

/// The road's plane is fitted to the pairs on the ground window's lane, this many times as
/// far ahead and as wide: the window is sized for the ground vote's corners, and the whole
/// image's grid puts more of its own beyond it.
const ROAD_REACH: f32 = 2.0;

/// Candidates a cell keeps for each feature it holds.
const CANDIDATES_PER_FEATURE: usize = 4;

/// Candidates a feature's patch is looked for at: those within reach nearest its predicted
/// place; two for a tracked feature, whose place is well predicted.
const TRIED: usize = 4;
const TRIED_TRACKED: usize = 2;

/// Fits the camera's typical spread is averaged over (about half a minute of driving at ten
/// frames a second), so that it follows a change of light or weather.
const TYPICAL_FITS: u16 = 256;

/// Image motions are kept in sixteenths of a pixel.
const FLOW_SCALE: f32 = 16.0;

/// One feature: its pixel, its patch, and its image motion from the frame before, sixteenths
/// of a pixel, where it was tracked there.
#[derive(Clone, Copy, Debug)]
struct Feature {
    u: u16,
    v: u16,
    patch: Patch,
    flow: Option<(i16, i16)>,
}

/// What the whole image said of a frame's heading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageMotion {
    /// Corners found over the frame.
    pub corners: u16,
    /// Pairs with the last frame's features.
    pub matches: u16,
    /// Pairs the motion holds (0 without a motion).
    pub inliers: u16,
    /// The heading change, radians, where enough pairs agree and determine it.
    pub heading_change_rad: Option<f32>,
    /// The change of the body's pitch the pairs show, radians (0 without a motion).
    pub pitch_change_rad: f32,
    /// Their root mean square distance from the motion, pixels (0 without one).
    pub rms_px: f32,
    /// The heading change's standard deviation, radians (0 without a motion).
    pub heading_sd_rad: f32,
    /// The direction of travel above the vehicle's horizontal as the mount sets it, radians
    /// (0 without a motion): on average, the mount's pitch error ([`crate::calibration`]).
    pub elevation_rad: f32,
    /// The direction of travel left of the arc's chord as the mount sets it, radians (0
    /// without a motion): on average, the mount's yaw error ([`crate::calibration`]).
    pub azimuth_rad: f32,
    /// Of the inliers, those seen above the horizon in the last frame: points off the road's
    /// plane (0 without a motion).
    pub inliers_above_horizon: u16,
    /// How far `azimuth_rad` would move right, radians, were the camera a metre further ahead
    /// of the pivot than the mount says: about the curvature driven where the pairs tell the
    /// travel from the turn ([`consensus::swing_rad_per_m`]); `None` without a motion, with
    /// `learn_x` off, on a frame that sees nothing but road or whose distance the pairs
    /// measured (`distance_m`), or where it cannot be told.
    pub swing_rad_per_m: Option<f32>,
    /// The distance travelled along the arc (from the pivot, as [`Motion::distance_m`]),
    /// metres, where the pairs measured it with the heading: in a slow, tight turn, from the
    /// camera's swing about the pivot
    /// ([`consensus::distance_factor`]); `None` elsewhere (the heading not standing included).
    pub distance_m: Option<f32>,
}

impl ImageMotion {
    /// Whether its heading stands on points off the road's plane as well: at least
    /// [`MIN_INLIERS_ABOVE_HORIZON`](crate::calibration::MIN_INLIERS_ABOVE_HORIZON) inliers
    /// above the horizon.
    pub fn sees_more_than_road(&self) -> bool {
        self.heading_change_rad.is_some() && self.inliers_above_horizon >= MIN_INLIERS_ABOVE_HORIZON
    }
}

/// The ray of frame position (`u`, `v`), pixels: normalised image coordinates (z = 1) of its
/// undistorted position; `None` where the lens has none.
pub(crate) fn ray(camera: &Camera, u: f32, v: f32) -> Option<Vector3<f32>> {
    let p = camera.undistort(Pixel { u_px: u, v_px: v })?;
    Some(Vector3::new(
        (p.u_px - camera.cx_px) / camera.fx_px,
        (p.v_px - camera.cy_px) / camera.fy_px,
        1.0,
    ))
}

/// What the odometer knows of a frame's motion before its image is matched.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImagePrior {
    /// The predicted motion; `None` before one is known.
    pub prediction: Option<Motion>,
    /// This frame's interval over the last one's.
    pub interval_ratio: f32,
    /// Where the vehicle's arc is drawn from, metres ahead of the rear axle (the tyres' slip,
    /// `pivot_s2_per_m`): the camera swings about it in a turn.
    pub pivot_m: f32,
}

/// A candidate's best previous feature: which, and how unlike (hundredths of a grey level).
type Best = Option<(u16, u8)>;

/// The stage's state across frames and its working memory, for up to `K` features a frame.
#[derive(Clone, Debug)]
pub struct ImageHeading<const K: usize> {
    model: Model,
    /// The last frame's features while this frame is matched; then this frame's.
    features: Vec<Feature, K>,
    /// This frame's candidates, `CANDIDATES_PER_FEATURE` slots for each feature slot.
    candidates: [[Option<ImageCorner>; CANDIDATES_PER_FEATURE]; K],
    /// Per feature: the candidate it found (index) and where it landed, pixels.
    found: [Option<(u16, f32, f32)>; K],
    /// Per candidate: the best previous feature.
    best: [[Best; CANDIDATES_PER_FEATURE]; K],
    /// Per candidate: its image motion from the feature it was paired with.
    flow: [[Option<(i16, i16)>; CANDIDATES_PER_FEATURE]; K],
    pairs: Vec<Pair, K>,
    inlier: [bool; K],
    /// The last frame's consensus, where it had one: its motion and its robust weights' scale,
    /// pixels; the road's plane starts from them ([`Self::road`]).
    fitted: Option<(Params, f32)>,
    /// The mean over the latest fits of their inliers' median distance from the motion,
    /// pixels, and over how many (up to [`TYPICAL_FITS`]): the camera's and the matcher's
    /// typical spread, the scale of the refinement's robust weights.
    typical_median_px: f32,
    fits: u16,
}

impl<const K: usize> ImageHeading<K> {
    /// Nothing seen: every bit zero.
    pub const ZERO: Self = Self {
        model: Model::ZERO,
        features: Vec::new(),
        candidates: [[None; CANDIDATES_PER_FEATURE]; K],
        found: [None; K],
        best: [[None; CANDIDATES_PER_FEATURE]; K],
        flow: [[None; CANDIDATES_PER_FEATURE]; K],
        pairs: Vec::new(),
        inlier: [false; K],
        fitted: None,
        typical_median_px: 0.0,
        fits: 0,
    };

    /// Takes `cfg`'s camera and forgets every frame and the camera's typical spread.
    pub fn configure(&mut self, cfg: &ValidConfig) {
        self.remount(cfg);
        self.reset();
        self.typical_median_px = 0.0;
        self.fits = 0;
    }

    /// Takes `cfg`'s mount (turned by the calibration), keeping the features.
    pub fn remount(&mut self, cfg: &ValidConfig) {
        self.model = Model::new(&cfg.config().mount);
    }

    /// Forgets every frame; the camera's typical spread stays (the same camera).
    pub fn reset(&mut self) {
        self.features.clear();
    }

    /// Finds this frame's corners, matches them with the last frame's features and, with
    /// `prior` (what is known of the motion before; `None` on the first frame of a drive), the
    /// motion they agree on; then keeps this frame's features for the next.
    pub fn track<F: Frame + ?Sized>(
        &mut self,
        frame: &F,
        cfg: &ValidConfig,
        prior: Option<ImagePrior>,
    ) -> ImageMotion {
        let s = cfg.settings();
        let grid = Grid {
            columns: u16::from(s.image_grid_columns),
            rows: u16::from(s.image_grid_rows),
            per_cell: u16::from(s.image_corners_per_cell) * CANDIDATES_PER_FEATURE as u16,
        };
        let slots = self.candidates.as_flattened_mut();
        corners::detect(frame, s.image_corner_threshold, grid, patch::MARGIN, slots);
        let mut out = ImageMotion {
            corners: self.candidates.as_flattened().iter().flatten().count() as u16,
            ..ImageMotion::default()
        };
        self.fitted = None;
        if let Some(prior) = prior {
            // The vehicle's arc is drawn from the pivot: the camera swings about it in a turn.
            let model = self.model.from_pivot(prior.pivot_m);
            let prediction = prior.prediction;
            let ratio = prior.interval_ratio;
            let guess = match prediction {
                Some(m) => m,
                None => self.start_guess(frame, cfg, grid, &model, ratio),
            };
            out.matches = self.pair(frame, cfg, grid, &model, guess, ratio) as u16;
            if let Some((fit, search, distance_m)) = self.consensus(cfg, &model, prediction) {
                out.inliers = fit.inliers;
                out.heading_change_rad =
                    (fit.heading_sd_rad <= s.image_max_heading_sd_rad).then_some(fit.params.alpha);
                // Found about the prediction's distance: with none (the start-up search's
                // least distance) it is no measurement.
                out.distance_m =
                    distance_m.filter(|_| out.heading_change_rad.is_some() && prediction.is_some());
                out.pitch_change_rad = fit.params.pitch;
                out.rms_px = fit.rms_px;
                out.heading_sd_rad = fit.heading_sd_rad;
                out.elevation_rad = fit.params.elevation;
                out.azimuth_rad = fit.params.azimuth;
                out.inliers_above_horizon = self.above_horizon();
                let inlier = self.inlier.get(..self.pairs.len()).unwrap_or_default();
                // Only where it measures the distance ahead of the axle: the frame sees more
                // than the road, and the distance is not the one the swing was fitted to.
                let swing_told =
                    distance_m.is_none() && out.inliers_above_horizon >= MIN_INLIERS_ABOVE_HORIZON;
                out.swing_rad_per_m = if s.learn_x && swing_told {
                    consensus::swing_rad_per_m(&model, &self.pairs, inlier, &fit, &search)
                } else {
                    None
                };
                self.fitted = Some((fit.params, fit.weights_px));
            }
        }
        self.keep_features(frame, grid);
        out
    }

    /// The road's plane under the last frame ([`plane::fit`]) from the pairs on it: this
    /// frame's consensus's inliers, where it had one, and the ground window's `ground` pairs,
    /// over the frame's `motion` (its arc drawn from `pivot_m`), started from the consensus's
    /// motion or else from `motion`'s turn; `None` before the drive's first consensus.
    pub fn road(
        &self,
        cfg: &ValidConfig,
        pivot_m: f32,
        motion: Motion,
        ground: &[Pair],
    ) -> Option<plane::Road> {
        let s = cfg.settings();
        let model = self.model.from_pivot(pivot_m);
        // Without this frame's consensus, its robust weights' scale is the camera's typical
        // one: none before the first consensus.
        let turn = Params {
            alpha: motion.heading_change_rad,
            ..Params::default()
        };
        let typical =
            (self.fits > 0).then(|| (turn, consensus::weights_px(self.typical_median_px)));
        let (start, scale_px) = self.fitted.or(typical)?;
        let n = if self.fitted.is_some() {
            self.pairs.len()
        } else {
            0
        };
        let image = self.pairs.iter().zip(&self.inlier).take(n);
        let pairs = || {
            image
                .clone()
                .filter(|(_, k)| **k)
                .map(|(c, _)| c)
                .chain(ground)
        };
        let scales = (cfg.config().camera.fx_px, scale_px, s.image_inlier_px);
        let on_road = Self::on_road(cfg, &model);
        plane::fit(&model, pairs, on_road, start, motion.distance_m, scales)
    }

    /// The distance travelled over the last frame that this frame's consensus's inliers on
    /// the road tell, each alone under the consensus's motion ([`plane::median_travel`]): their
    /// median, metres, and how many told one. Matched by appearance, it rests on neither a
    /// prediction nor the ground vote. `None` without a consensus this frame.
    pub fn road_travel(&self, cfg: &ValidConfig, pivot_m: f32) -> Option<(f32, usize)> {
        let (fitted, _) = self.fitted?;
        let model = self.model.from_pivot(pivot_m);
        let on_road = Self::on_road(cfg, &model);
        let inliers = self.pairs.iter().zip(&self.inlier).filter(|(_, k)| **k);
        let on = inliers
            .map(|(c, _)| c)
            .filter(|c| plane::on_the_road(&model, on_road, c));
        plane::median_travel(&model, &fitted, on)
    }

    /// Where the road's plane is looked for: the ground window's lane, [`ROAD_REACH`] times as
    /// far ahead and as wide (vehicle frame, from where `model`'s arc is drawn).
    fn on_road(cfg: &ValidConfig, model: &Model) -> impl Fn(Vector3<f32>) -> bool + Copy {
        let s = cfg.settings();
        let (arm, far) = (model.swing_arm_m(), ROAD_REACH * s.window_far_m);
        let half = ROAD_REACH * s.window_half_width_m;
        move |p: Vector3<f32>| {
            let ahead = p.x - arm;
            ahead > 0.0 && ahead < far && p.y.abs() < half
        }
    }

    /// How many of the consensus's inliers the last frame saw above the horizon.
    fn above_horizon(&self) -> u16 {
        let inliers = self.pairs.iter().zip(&self.inlier).filter(|(_, k)| **k);
        let above = inliers
            .filter(|(c, _)| self.model.above_horizon(&c.x1))
            .count();
        u16::try_from(above).unwrap_or(u16::MAX)
    }

    /// This frame's features, for the next: every paired candidate (its track goes on), then
    /// each cell's strongest others up to its share.
    fn keep_features<F: Frame + ?Sized>(&mut self, frame: &F, grid: Grid) {
        self.features.clear();
        let per_cell = usize::from(grid.per_cell).max(1);
        let share = per_cell / CANDIDATES_PER_FEATURE;
        let cells = self.candidates.as_flattened().chunks(per_cell);
        let flows = self.flow.as_flattened().chunks(per_cell);
        for (cell, flows) in cells.zip(flows) {
            let mut held = 0;
            let mut take = |c: &ImageCorner, flow| {
                let _ = self.features.push(Feature {
                    u: c.u,
                    v: c.v,
                    patch: patch::read(frame, c.u, c.v),
                    flow,
                });
            };
            for (c, flow) in cell.iter().zip(flows) {
                if let (Some(c), Some(_)) = (c, flow) {
                    held += 1;
                    take(c, *flow);
                }
            }
            // The rest of the cell's share: its strongest unpaired candidates, strongest first.
            let mut taken = [false; 4 * CANDIDATES_PER_FEATURE];
            while held < share {
                let strongest = cell
                    .iter()
                    .zip(flows)
                    .zip(&taken)
                    .enumerate()
                    .filter_map(|(k, ((c, flow), &t))| {
                        c.filter(|_| flow.is_none() && !t).map(|c| (k, c))
                    })
                    .max_by_key(|(_, c)| c.score);
                let Some((k, c)) = strongest else {
                    break;
                };
                if let Some(t) = taken.get_mut(k) {
                    *t = true;
                }
                held += 1;
                take(&c, None);
            }
        }
    }

    /// The frame position, pixels, of the ray `x` (camera frame, in front of the camera).
    fn seen_at(cfg: &ValidConfig, x: Vector3<f32>) -> (f32, f32) {
        let k = &cfg.config().camera;
        let p = k.distort(Pixel {
            u_px: k.cx_px + k.fx_px * x.x / x.z,
            v_px: k.cy_px + k.fy_px * x.y / x.z,
        });
        (p.u_px, p.v_px)
    }

    /// With no motion to predict from (the first frame that moves), the motion the features
    /// are looked for at: headings a reach apart across the start-up window and distances
    /// across the start-up one (standing, half way, its end), each paired and voted on, nearest
    /// straight and standing first; the one whose consensus holds the most pairs. A turn of a
    /// few degrees, or a metre of travel, moves features further than their reach, and pairs
    /// looked for at the wrong motion find no consensus.
    fn start_guess<F: Frame + ?Sized>(
        &mut self,
        frame: &F,
        cfg: &ValidConfig,
        grid: Grid,
        model: &Model,
        ratio: f32,
    ) -> Motion {
        let s = cfg.settings();
        let step_rad = libm::atanf(NEW_REACH_PX.0 / cfg.config().camera.fx_px);
        let steps = libm::roundf(s.startup_heading_window_rad / step_rad).min(MAX_START_STEPS);
        let search = Self::search(cfg, None, self.typical_median_px);
        let mut best = (0, Motion::ZERO);
        for distance_m in [0.0, 0.5, 1.0].map(|f| f * s.startup_distance_max_m) {
            for k in 0..=(2 * steps as i32) {
                // 0, -1, +1, -2, +2, ... steps.
                let step = if k % 2 == 0 { -(k / 2) } else { k / 2 + 1 };
                let guess = Motion {
                    heading_change_rad: step as f32 * step_rad,
                    distance_m,
                };
                self.pair(frame, cfg, grid, model, guess, ratio);
                let inliers = self
                    .fit(model, &search, s.image_min_inliers)
                    .map_or(0, |f| f.inliers);
                if inliers > best.0 {
                    best = (inliers, guess);
                }
            }
        }
        best.1
    }

    /// Pairs the last frame's features with this frame's candidates (found over `grid`),
    /// looked for where the `guess`ed motion takes them (`ratio`: this frame's interval over
    /// the last one's); how many.
    fn pair<F: Frame + ?Sized>(
        &mut self,
        frame: &F,
        cfg: &ValidConfig,
        grid: Grid,
        model: &Model,
        guess: Motion,
        ratio: f32,
    ) -> usize {
        let s = cfg.settings();
        // A new feature is looked for where the guess takes the road's point the feature would
        // be, or turns it if it is above the horizon.
        let predicted = model.predict(guess.heading_change_rad, guess.distance_m);
        self.best = [[None; CANDIDATES_PER_FEATURE]; K];
        self.found = [None; K];
        self.flow = [[None; CANDIDATES_PER_FEATURE]; K];
        let candidates = self.candidates.as_flattened();
        for (i, p) in self.features.iter().enumerate() {
            let (pu, pv) = (f32::from(p.u), f32::from(p.v));
            let tried = if p.flow.is_some() {
                TRIED_TRACKED
            } else {
                TRIED
            };
            let (centre, reach) = match p.flow {
                Some((du, dv)) => (
                    (
                        pu + f32::from(du) / FLOW_SCALE * ratio,
                        pv + f32::from(dv) / FLOW_SCALE * ratio,
                    ),
                    (TRACKED_REACH_PX, TRACKED_REACH_PX),
                ),
                None => {
                    let Some(ray) = ray(&cfg.config().camera, pu, pv) else {
                        continue;
                    };
                    let x = predicted.seen(&ray);
                    if x.z <= 0.0 {
                        continue;
                    }
                    (Self::seen_at(cfg, x), NEW_REACH_PX)
                }
            };
            // The candidates within reach nearest the predicted place, from the cells that
            // may hold them (in the order of the cells, as over all of them).
            let Some((columns, rows)) = grid.cells_within(
                (frame.width(), frame.height(), patch::MARGIN),
                (centre.0 - reach.0, centre.0 + reach.0),
                (centre.1 - reach.1, centre.1 + reach.1),
            ) else {
                continue;
            };
            let per_cell = usize::from(grid.per_cell);
            let slots = rows.flat_map(|row| {
                let cells = columns.clone().map(move |col| {
                    usize::from(row) * usize::from(grid.columns) + usize::from(col)
                });
                cells.flat_map(move |cell| cell * per_cell..(cell + 1) * per_cell)
            });
            let mut nearest: [Option<(f32, usize)>; TRIED] = [None; TRIED];
            for j in slots {
                let Some(Some(c)) = candidates.get(j) else {
                    continue;
                };
                let (du, dv) = (f32::from(c.u) - centre.0, f32::from(c.v) - centre.1);
                if du.abs() > reach.0 || dv.abs() > reach.1 {
                    continue;
                }
                let d = du * du + dv * dv;
                let farthest = nearest.iter_mut().take(tried).max_by(|a, b| {
                    let far = |x: &&mut Option<(f32, usize)>| x.map_or(f32::MAX, |x| x.0);
                    far(a).total_cmp(&far(b))
                });
                if let Some(slot) = farthest
                    && slot.is_none_or(|(far, _)| d < far)
                {
                    *slot = Some((d, j));
                }
            }
            let mut best: Option<(f32, usize, patch::Found)> = None;
            for &(_, j) in nearest.iter().flatten() {
                let Some(Some(c)) = candidates.get(j) else {
                    continue;
                };
                let Some(at) = patch::find(frame, &p.patch, c.u, c.v) else {
                    continue;
                };
                if at.unlikeness <= s.image_max_unlikeness_dn
                    && best.is_none_or(|b| at.unlikeness < b.0)
                {
                    best = Some((at.unlikeness, j, at));
                }
            }
            let Some((unlikeness, j, at)) = best else {
                continue;
            };
            if let Some(slot) = self.found.get_mut(i) {
                *slot = Some((j as u16, at.u_px, at.v_px));
            }
            // Hundredths of a grey level: the threshold is at most 255.
            let unlike = (unlikeness * 100.0) as u16;
            if let Some(b) = self.best.as_flattened_mut().get_mut(j)
                && b.is_none_or(|(u, _)| unlike < u)
            {
                *b = Some((unlike, i as u8));
            }
        }
        // A pair stands where each is the other's best.
        self.pairs.clear();
        for (i, p) in self.features.iter().enumerate() {
            let Some(Some((j, u, v))) = self.found.get(i).copied() else {
                continue;
            };
            let j = usize::from(j);
            let best = self.best.as_flattened().get(j).copied().flatten();
            if best.is_none_or(|(_, b)| usize::from(b) != i) {
                continue;
            }
            let Some(Some(c)) = candidates.get(j) else {
                continue;
            };
            let (Some(x1), Some(x2)) = (
                ray(&cfg.config().camera, f32::from(p.u), f32::from(p.v)),
                ray(&cfg.config().camera, u, v),
            ) else {
                continue;
            };
            let _ = self.pairs.push(Pair { x1, x2 });
            let moved = |a: u16, b: u16| ((f32::from(a) - f32::from(b)) * FLOW_SCALE) as i16;
            if let Some(flow) = self.flow.as_flattened_mut().get_mut(j) {
                *flow = Some((moved(c.u, p.u), moved(c.v, p.v)));
            }
        }
        self.pairs.len()
    }

    /// The vote's peak refined, over the distance `search` gives; the inliers kept.
    fn fit(&mut self, model: &Model, search: &Search, min_inliers: u16) -> Option<Fit> {
        let (start, _) = consensus::vote::<K>(model, &self.pairs, search)?;
        let inlier = self.inlier.get_mut(..self.pairs.len()).unwrap_or_default();
        consensus::refine(model, &self.pairs, start, search, min_inliers, inlier)
    }

    /// What the consensus searches: around the `prediction`, or over the start-up window
    /// where there is none.
    fn search(cfg: &ValidConfig, prediction: Option<Motion>, typical_median_px: f32) -> Search {
        let s = cfg.settings();
        let (alpha, alpha_half) = match prediction {
            Some(m) => (m.heading_change_rad, s.heading_window_rad),
            None => (0.0, s.startup_heading_window_rad),
        };
        Search {
            alpha,
            alpha_half,
            pitch_half: PITCH_HALF_RAD,
            distance_m: prediction.map_or(0.0, |m| m.distance_m).max(MIN_DISTANCE_M),
            focal_px: cfg.config().camera.fx_px,
            kernel_px: s.image_kernel_px,
            inlier_px: s.image_inlier_px,
            typical_median_px,
        }
    }

    /// The motion the pairs agree on, if enough do, the search it was found in, and the
    /// distance where the pairs found it.
    fn consensus(
        &mut self,
        cfg: &ValidConfig,
        model: &Model,
        prediction: Option<Motion>,
    ) -> Option<(Fit, Search, Option<f32>)> {
        let search = Self::search(cfg, prediction, self.typical_median_px);
        let min_inliers = cfg.settings().image_min_inliers;
        let mut fit = self.fit(model, &search, min_inliers)?;
        let mut distance_m = None;
        let mut used = search;
        // Where the camera's swing in a turn makes the direction of travel hang on the
        // distance, the distance is found with the motion; only where pairs beyond the road
        // tell that direction (road alone cannot tell it from a turn).
        if consensus::swing_exceeds_prior(model, fit.params.alpha, search.distance_m)
            && self.above_horizon() >= MIN_INLIERS_ABOVE_HORIZON
        {
            let inlier = self.inlier.get_mut(..self.pairs.len()).unwrap_or_default();
            let factor = consensus::distance_factor::<K>(
                model,
                &self.pairs,
                &search,
                &fit,
                min_inliers,
                inlier,
            );
            let found = Search {
                distance_m: search.distance_m * factor,
                ..search
            };
            fit = match self.fit(model, &found, min_inliers) {
                Some(fit) => {
                    distance_m = Some(found.distance_m);
                    used = found;
                    fit
                }
                None => self.fit(model, &search, min_inliers)?,
            };
        }
        // The running mean of the fits' medians, over the latest TYPICAL_FITS.
        self.fits = (self.fits + 1).min(TYPICAL_FITS);
        self.typical_median_px += (fit.median_px - self.typical_median_px) / f32::from(self.fits);
        Some((fit, used, distance_m))
    }
}
