//! The renderer behind `roadvo simulate`: every pixel is ray-cast into a procedural scene, with
//! several samples per pixel for anti-aliasing and sensor noise on top.
//!
//! The scene: a road laid along the drive's path (our lane centred on it, a second lane to its
//! left, painted edge and centre lines), asphalt carrying random patches whose corners a Harris
//! detector finds, grass verges, haze towards a visible horizon and a sky gradient, optional
//! raised kerb and crowned surface, and optional boxes driving along the road. Optionally,
//! structure above the ground at every depth (see [`Structure`]): buildings with windows, doors
//! and brick or panel walls, street lights and sign posts, trees, parked cars. Everything is a
//! pure function of world position and the seed, so frames render independently and in parallel.

use crate::lens_rays::LensRays;
use crate::path::{Path, WorldPose};
use crate::scenario::{Crown, Kerb, Scenario};
use image::GrayImage;
use roadvo::{Attitude, Mount};

/// A 64-bit mix (splitmix64's finaliser): decorrelates neighbouring integer inputs.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A hash of a 2D integer cell, a seed and a salt: one mix of their odd-multiplier blend, which
/// is plenty for texture.
fn hash(ix: i64, iy: i64, seed: u64, salt: u64) -> u64 {
    mix((ix as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
        ^ (iy as u64).wrapping_mul(0xc2b2_ae3d_27d4_eb4f)
        ^ seed.wrapping_mul(0x1656_67b1_9e37_79f9)
        ^ salt.wrapping_mul(0x27d4_eb2f_1656_67c5))
}

/// The `k`-th uniform number in [0, 1) drawn from a hash.
fn unit(h: u64, k: u64) -> f64 {
    (mix(h.wrapping_add(k.wrapping_mul(0x9e37_79b9_7f4a_7c15))) >> 11) as f64 / (1u64 << 53) as f64
}

/// Smooth value noise in [0, 1), with features of about one unit.
fn value_noise(x: f64, y: f64, seed: u64, salt: u64) -> f64 {
    let (fx, fy) = (fast_floor(x), fast_floor(y));
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let v = |dx: i64, dy: i64| unit(hash(ix + dx, iy + dy, seed, salt), 0);
    let top = v(0, 0) + (v(1, 0) - v(0, 0)) * sx;
    let bottom = v(0, 1) + (v(1, 1) - v(0, 1)) * sx;
    top + (bottom - top) * sy
}

/// Smooth 3D value noise in [0, 1), with features of about one unit.
fn value_noise3(p: [f64; 3], seed: u64, salt: u64) -> f64 {
    let f = p.map(fast_floor);
    let i = f.map(|x| x as i64);
    let s = std::array::from_fn::<f64, 3, _>(|k| {
        let t = p[k] - f[k];
        t * t * (3.0 - 2.0 * t)
    });
    // The third coordinate goes into the salt.
    let v = |dx: i64, dy: i64, dz: i64| {
        let salt = salt ^ ((i[2] + dz) as u64).wrapping_mul(0xd6e8_feb8_6659_fd93);
        unit(hash(i[0] + dx, i[1] + dy, seed, salt), 0)
    };
    let plane = |dz: i64| {
        let top = v(0, 0, dz) + (v(1, 0, dz) - v(0, 0, dz)) * s[0];
        let bottom = v(0, 1, dz) + (v(1, 1, dz) - v(0, 1, dz)) * s[0];
        top + (bottom - top) * s[1]
    };
    let (a, b) = (plane(0), plane(1));
    a + (b - a) * s[2]
}

/// Finds, for a world point, the nearest place on the path: arc length and lateral offset.
struct PathIndex {
    /// (x, y, cos heading, sin heading, s) every `SAMPLE_M`.
    samples: Vec<[f64; 5]>,
    origin: (f64, f64),
    cells_x: i64,
    cells_y: i64,
    /// Start of each cell's run in `items` (CSR layout), one more than the cell count.
    cell_start: Vec<u32>,
    items: Vec<u32>,
    /// Per cell: the samples in it and its eight neighbours are one stretch of the path (one
    /// unbroken run of indices) that bends gently (radius over `ONE_STRETCH_RADIUS_M`), so that
    /// the distance of any point in those cells to that stretch has one minimum.
    one_stretch: Vec<bool>,
}

const SAMPLE_M: f64 = 0.25;
/// Every `COARSE`-th sample (2 m apart) goes into the cells.
const COARSE: usize = 8;
/// A hint that points nowhere: the first search uses the cells.
const NO_HINT: usize = usize::MAX;
/// Fine samples searched each side of a hint.
const HINT_SPAN: usize = 6;
/// Farthest from the path a hinted answer is trusted, metres: beyond it two stretches of road
/// may compete for the nearest.
const HINT_REACH_M: f64 = 4.0;
/// Farthest a hinted answer is trusted where only one stretch of the path comes near, metres:
/// the cell search finds a coarse sample within `CELL_M` there too.
const ONE_STRETCH_REACH_M: f64 = 7.0;
/// Least radius of a stretch whose distance to points in its cells has one minimum, metres:
/// more than the diagonal of three cells by three (the squared distance is then convex along it).
const ONE_STRETCH_RADIUS_M: f64 = 40.0;
/// Cell size of the index: the nearest sample is found for points up to this far from the path.
const CELL_M: f64 = 8.0;

impl PathIndex {
    fn new(path: &Path) -> Self {
        let n = (path.length_m() / SAMPLE_M).ceil() as usize + 1;
        let samples: Vec<[f64; 5]> = (0..n)
            .map(|i| {
                let s = (i as f64 * SAMPLE_M).min(path.length_m());
                let p = path.pose_at(s);
                [p.x_m, p.y_m, p.heading_rad.cos(), p.heading_rad.sin(), s]
            })
            .collect();
        let lo = samples
            .iter()
            .fold((f64::MAX, f64::MAX), |a, p| (a.0.min(p[0]), a.1.min(p[1])));
        let hi = samples
            .iter()
            .fold((f64::MIN, f64::MIN), |a, p| (a.0.max(p[0]), a.1.max(p[1])));
        let origin = (lo.0 - CELL_M, lo.1 - CELL_M);
        let cells_x = ((hi.0 - origin.0) / CELL_M).ceil() as i64 + 2;
        let cells_y = ((hi.1 - origin.1) / CELL_M).ceil() as i64 + 2;
        let cell_of = |p: &[f64; 5]| {
            let cx = ((p[0] - origin.0) / CELL_M) as i64;
            let cy = ((p[1] - origin.1) / CELL_M) as i64;
            (cy * cells_x + cx) as usize
        };
        let mut counts = vec![0u32; (cells_x * cells_y) as usize + 1];
        for p in samples.iter().step_by(COARSE) {
            counts[cell_of(p) + 1] += 1;
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[counts.len() - 1] as usize];
        for (i, p) in samples.iter().enumerate().step_by(COARSE) {
            let c = cell_of(p);
            items[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let mut index = Self {
            samples,
            origin,
            cells_x,
            cells_y,
            cell_start: counts,
            items,
            one_stretch: Vec::new(),
        };
        index.one_stretch = (0..cells_y)
            .flat_map(|cy| (0..cells_x).map(move |cx| (cx, cy)))
            .map(|(cx, cy)| {
                let mut run = (usize::MAX, 0, 0);
                index.for_each_near(cx, cy, |i| {
                    run = (run.0.min(i), run.1.max(i), run.2 + 1);
                });
                let (first, last, count) = run;
                count == 0
                    || ((last - first) / COARSE + 1 == count
                        && index.gentle(first.saturating_sub(COARSE)..last + COARSE))
            })
            .collect();
        index
    }

    /// The path's radius over the fine samples `range` (clipped to the path) is at least
    /// `ONE_STRETCH_RADIUS_M`: each step turns by at most `SAMPLE_M` over that radius.
    fn gentle(&self, range: std::ops::Range<usize>) -> bool {
        let run =
            &self.samples[range.start.min(self.samples.len())..range.end.min(self.samples.len())];
        run.windows(2).all(|w| {
            let turn = (w[0][2] * w[1][3] - w[0][3] * w[1][2]).abs();
            turn <= SAMPLE_M / ONE_STRETCH_RADIUS_M
        })
    }

    /// Calls `f` with each coarse sample in cell (`cx`, `cy`) and its eight neighbours.
    fn for_each_near(&self, cx: i64, cy: i64, mut f: impl FnMut(usize)) {
        for gy in (cy - 1).max(0)..=(cy + 1).min(self.cells_y - 1) {
            for gx in (cx - 1).max(0)..=(cx + 1).min(self.cells_x - 1) {
                let c = (gy * self.cells_x + gx) as usize;
                let run = self.cell_start[c] as usize..self.cell_start[c + 1] as usize;
                self.items[run].iter().for_each(|&i| f(i as usize));
            }
        }
    }

    /// (arc length, lateral offset positive left) of the nearest path point, for points within
    /// `CELL_M` of the path; `None` farther away. The cells index every `COARSE`-th sample; the
    /// nearest of those is refined among its fine neighbours.
    ///
    /// Tries the fine samples around `hint` first (the sample found for a neighbouring ray):
    /// where their distance has a minimum inside that stretch, within `HINT_REACH_M` (within
    /// `ONE_STRETCH_REACH_M` where the cells hold one stretch of the path), it is taken without
    /// the cell search. `hint` is updated.
    fn locate(&self, x: f64, y: f64, hint: &mut usize) -> Option<(f64, f64)> {
        let d2 = |i: usize| {
            let p = &self.samples[i];
            (x - p[0]).powi(2) + (y - p[1]).powi(2)
        };
        let cx = fast_floor((x - self.origin.0) / CELL_M) as i64;
        let cy = fast_floor((y - self.origin.1) / CELL_M) as i64;
        // The cells hold one gently bending stretch of the path about the point.
        let one_stretch = || {
            (0..self.cells_x).contains(&cx)
                && (0..self.cells_y).contains(&cy)
                && self.one_stretch[(cy * self.cells_x + cx) as usize]
        };
        if *hint < self.samples.len() {
            let lo = hint.saturating_sub(HINT_SPAN);
            let hi = (*hint + HINT_SPAN).min(self.samples.len() - 1);
            let mut nearest = (f64::MAX, lo);
            for i in lo..=hi {
                let d = d2(i);
                if d < nearest.0 {
                    nearest = (d, i);
                }
            }
            let interior =
                (nearest.1 > lo || lo == 0) && (nearest.1 < hi || hi == self.samples.len() - 1);
            // Near the path the hint is trusted at once; farther only on one stretch.
            let trusted = nearest.0 < HINT_REACH_M * HINT_REACH_M
                || (nearest.0 < ONE_STRETCH_REACH_M * ONE_STRETCH_REACH_M && one_stretch());
            if interior && trusted {
                *hint = nearest.1;
                return Some(self.offsets(x, y, nearest.1));
            }
        }
        let mut best = (f64::MAX, 0usize);
        self.for_each_near(cx, cy, |i| {
            let d = d2(i);
            if d < best.0 {
                best = (d, i);
            }
        });
        if best.0 > CELL_M * CELL_M {
            return None;
        }
        let lo = best.1.saturating_sub(COARSE);
        let hi = (best.1 + COARSE).min(self.samples.len() - 1);
        let mut nearest = best;
        for i in lo..=hi {
            let d = d2(i);
            if d < nearest.0 {
                nearest = (d, i);
            }
        }
        *hint = nearest.1;
        Some(self.offsets(x, y, nearest.1))
    }

    /// (arc length, lateral offset) of a point relative to the tangent at sample `i`.
    fn offsets(&self, x: f64, y: f64, i: usize) -> (f64, f64) {
        let [px, py, cos, sin, s] = self.samples[i];
        let (dx, dy) = (x - px, y - py);
        (s + dx * cos + dy * sin, -dx * sin + dy * cos)
    }
}

/// Height of the road surface above the plane the vehicle drives on, by lateral offset.
#[derive(Clone, Debug)]
struct Surface {
    kerb: Option<Kerb>,
    crown: Option<Crown>,
}

/// Lateral distance over which a crown keeps falling before the ground levels out, metres.
const CROWN_REACH_M: f64 = 10.0;

impl Surface {
    fn flat(&self) -> bool {
        self.kerb.is_none() && self.crown.is_none()
    }

    fn height_m(&self, lateral_m: f64) -> f64 {
        let mut h = 0.0;
        if let Some(k) = &self.kerb
            && (k.from_m..=k.to_m).contains(&lateral_m)
        {
            h += k.height_m;
        }
        if let Some(c) = &self.crown {
            if lateral_m > c.left_from_m {
                h -= c.left_slope * (lateral_m - c.left_from_m).min(CROWN_REACH_M);
            }
            if lateral_m < -c.right_from_m {
                h -= c.right_slope * (-c.right_from_m - lateral_m).min(CROWN_REACH_M);
            }
        }
        h
    }

    /// Lowest and highest surface heights, metres.
    fn range_m(&self) -> (f64, f64) {
        let top = self.kerb.as_ref().map_or(0.0, |k| k.height_m.max(0.0));
        let bottom = self.crown.as_ref().map_or(0.0, |c| {
            -(c.left_slope.max(c.right_slope).max(0.0) * CROWN_REACH_M)
        }) + self.kerb.as_ref().map_or(0.0, |k| k.height_m.min(0.0));
        (bottom, top)
    }
}

/// A box on the road, in world coordinates.
#[derive(Clone, Copy, Debug)]
pub struct BoxState {
    /// Centre of its footprint, metres.
    pub centre: (f64, f64),
    /// Heading, radians.
    pub heading_rad: f64,
    /// Half length, half width, height, metres.
    pub size: (f64, f64, f64),
    /// Body grey level.
    pub shade: f64,
}

/// Clearance under a box: the road is visible below it, in its shadow.
const CLEARANCE_M: f64 = 0.3;

impl BoxState {
    /// Nearest intersection parameter and shade of a ray `o + t d` with the box.
    fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, f64)> {
        self.hit_turned(o, d, self.heading_rad.sin_cos())
    }

    /// [`BoxState::hit`] given the sine and cosine of its heading.
    fn hit_turned(&self, o: [f64; 3], d: [f64; 3], (s, c): (f64, f64)) -> Option<(f64, f64)> {
        let (ox, oy) = (o[0] - self.centre.0, o[1] - self.centre.1);
        let lo = [c * ox + s * oy, -s * ox + c * oy, o[2]];
        let ld = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]];
        let (hl, hw, h) = self.size;
        let bounds = [(-hl, hl), (-hw, hw), (CLEARANCE_M, h)];
        // Starting inside, the front face.
        let (t0, axis) = slab_entry(lo, ld, bounds)?;
        let axis = axis.unwrap_or(0);
        let p = [lo[0] + t0 * ld[0], lo[1] + t0 * ld[1], lo[2] + t0 * ld[2]];
        let z = p[2] / h;
        let shade = match axis {
            // Front or back: rear window, lights at the corners, a number plate.
            0 => {
                let y = p[1].abs();
                if z > 0.62 && z < 0.92 && y < hw - 0.15 {
                    35.0
                } else if z > 0.40 && z < 0.50 && y > hw - 0.35 {
                    235.0
                } else if z > 0.28 && z < 0.38 && y < 0.26 {
                    215.0
                } else {
                    self.shade
                }
            }
            // Sides: a band of windows.
            1 => {
                if z > 0.62 && z < 0.92 && p[0].abs() < hl - 0.5 {
                    40.0
                } else {
                    0.85 * self.shade
                }
            }
            _ => (1.1 * self.shade).min(255.0),
        };
        Some((t0, shade))
    }

    fn covers(&self, x: f64, y: f64) -> bool {
        self.covers_turned(x, y, self.heading_rad.sin_cos())
    }

    /// [`BoxState::covers`] given the sine and cosine of its heading.
    fn covers_turned(&self, x: f64, y: f64, (s, c): (f64, f64)) -> bool {
        let (dx, dy) = (x - self.centre.0, y - self.centre.1);
        (c * dx + s * dy).abs() <= self.size.0 && (-s * dx + c * dy).abs() <= self.size.1
    }
}

/// Where the camera is and what else is on the road at one frame.
#[derive(Clone, Debug)]
pub struct FrameState {
    /// The vehicle's pose in the world.
    pub pose: WorldPose,
    /// The body's attitude on its suspension.
    pub attitude: Attitude,
    /// Other road users in view.
    pub boxes: Vec<BoxState>,
}

/// Everything about the scene that does not change from frame to frame.
pub struct Scene {
    index: PathIndex,
    surface: Surface,
    rays: LensRays,
    mount: Mount,
    width: u32,
    height: u32,
    supersample: u32,
    noise_dn: f64,
    lane_width_m: f64,
    patch_probability: f64,
    bare_half_width_m: f64,
    seed: u64,
    /// Buildings, poles, trees and parked cars, with the corners of a box around each.
    structures: Vec<Structure>,
    bounds: Vec<[[f64; 3]; 8]>,
    /// Height of the road surface's highest point, metres: nothing on the ground is nearer.
    surface_top_m: f64,
}

/// Grey level of the sky at the horizon, where the haze fades to.
const HAZE_DN: f64 = 205.0;
/// Distance over which haze takes away 63% of the ground's contrast, metres.
const HAZE_M: f64 = 250.0;
/// Texture patches: one possible patch per cell of this size, metres.
const PATCH_CELL_M: f64 = 0.5;

impl Scene {
    /// The scene of a scenario along its integrated path.
    pub fn new(scenario: &Scenario, path: &Path, seed: u64) -> Self {
        let cfg = scenario.mount_file(false).to_config();
        let index = PathIndex::new(path);
        let structures = place_structures(scenario, path, &index, seed);
        let bounds = structures.iter().map(Structure::bound).collect();
        let surface = Surface {
            kerb: scenario.kerb.clone(),
            crown: scenario.crown.clone(),
        };
        Self {
            index,
            surface_top_m: surface.range_m().1,
            surface,
            rays: LensRays::new(cfg.camera),
            mount: cfg.mount,
            width: u32::from(cfg.camera.width_px),
            height: u32::from(cfg.camera.height_px),
            supersample: u32::from(scenario.render.supersample),
            noise_dn: scenario.render.noise_dn,
            lane_width_m: scenario.render.lane_width_m,
            patch_probability: (0.6 * scenario.render.texture_density).min(1.0),
            bare_half_width_m: scenario.render.bare_half_width_m,
            seed,
            structures,
            bounds,
        }
    }

    /// Albedo of the road surface at a world point, grey levels.
    fn ground(&self, x: f64, y: f64, lateral: Option<(f64, f64)>) -> f64 {
        let seed = self.seed;
        let w = self.lane_width_m;
        let (s, l) = lateral.unwrap_or((0.0, f64::INFINITY));
        let on_road = l > -0.5 * w - 0.6 && l < 1.5 * w + 0.6;
        if !on_road {
            // Grass: darker, coarser.
            return 70.0
                + 30.0 * (value_noise(x / 0.12, y / 0.12, seed, 11) - 0.5)
                + 14.0 * (value_noise(x / 1.5, y / 1.5, seed, 12) - 0.5);
        }
        let line = |centre: f64| (l - centre).abs() < 0.075;
        let dashed = line(0.5 * w) && s.rem_euclid(9.0) < 3.0;
        if line(-0.5 * w) || line(1.5 * w) || dashed {
            return 200.0 + 10.0 * (value_noise(x / 0.05, y / 0.05, seed, 13) - 0.5);
        }
        let mut g = 100.0
            + 16.0 * (value_noise(x / 2.5, y / 2.5, seed, 1) - 0.5)
            + 10.0 * (value_noise(x / 0.03, y / 0.03, seed, 2) - 0.5);
        if l.abs() >= self.bare_half_width_m {
            g += self.patch(x, y);
        }
        g
    }

    /// Offset of a patch (a rotated rectangle of darker or lighter asphalt) covering the point.
    fn patch(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = (fast_floor(x / PATCH_CELL_M), fast_floor(y / PATCH_CELL_M));
        let h = hash(fx as i64, fy as i64, self.seed, 3);
        if unit(h, 0) >= self.patch_probability {
            return 0.0;
        }
        let cx = (fx + 0.3 + 0.4 * unit(h, 1)) * PATCH_CELL_M;
        let cy = (fy + 0.3 + 0.4 * unit(h, 2)) * PATCH_CELL_M;
        let half_l = 0.05 + 0.12 * unit(h, 3);
        let half_w = 0.03 + 0.08 * unit(h, 4);
        let (s, c) = (std::f64::consts::PI * unit(h, 5)).sin_cos();
        let (dx, dy) = (x - cx, y - cy);
        let inside = (c * dx + s * dy).abs() < half_l && (-s * dx + c * dy).abs() < half_w;
        if !inside {
            return 0.0;
        }
        let strength = 25.0 + 30.0 * unit(h, 6);
        if unit(h, 7) < 0.5 {
            -strength
        } else {
            strength
        }
    }

    /// Where a ray from `o` along `d` (d.z < 0) meets the road: parameter t and (s, l).
    fn hit_ground(&self, o: [f64; 3], d: [f64; 3], hint: &mut usize) -> (f64, Option<(f64, f64)>) {
        let flat_t = -o[2] / d[2];
        let mut locate = |t: f64| self.index.locate(o[0] + t * d[0], o[1] + t * d[1], hint);
        if self.surface.flat() {
            return (flat_t, locate(flat_t));
        }
        // Bracket the surface between the planes of its highest and lowest points, take (s, l)
        // as linear along that short piece of ray, then march and bisect.
        let (bottom, top) = self.surface.range_m();
        let (ta, tb) = ((top - o[2]) / d[2], (bottom - o[2]) / d[2]);
        let (Some(a), Some(b)) = (locate(ta), locate(tb)) else {
            return (flat_t, locate(flat_t));
        };
        let at = |f: f64| {
            let t = ta + f * (tb - ta);
            let sl = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
            (t, sl, o[2] + t * d[2] - self.surface.height_m(sl.1))
        };
        const STEPS: u32 = 24;
        let mut lo = 0.0;
        for i in 1..=STEPS {
            let f = f64::from(i) / f64::from(STEPS);
            if at(f).2 <= 0.0 {
                let mut hi = f;
                for _ in 0..12 {
                    let mid = 0.5 * (lo + hi);
                    if at(mid).2 > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let (t, sl, _) = at(hi);
                return (t, Some(sl));
            }
            lo = f;
        }
        let (t, sl, _) = at(1.0);
        (t, Some(sl))
    }

    /// Nearest hit of a ray among `near`: parameter and grey level. `near` holds structures
    /// with the least depth (camera z) of any of their points, in increasing order; for rays
    /// from the camera, whose parameter is the depth, the search stops at the first structure
    /// that lies wholly behind the nearest hit so far.
    fn hit_structure(o: [f64; 3], d: [f64; 3], near: &[(f64, &Structure)]) -> Option<(f64, f64)> {
        let mut best: Option<(f64, f64)> = None;
        for &(depth, s) in near {
            let limit = best.map_or(f64::MAX, |b| b.0);
            if depth >= limit {
                break;
            }
            if let Some(h) = s.hit(o, d, limit) {
                best = Some(h);
            }
        }
        best
    }

    /// Grey level seen along one ray; `near` are the structures that may lie on it.
    fn trace(
        &self,
        o: [f64; 3],
        d: [f64; 3],
        boxes: &[BoxState],
        near: &[(f64, &Structure)],
        hint: &mut usize,
    ) -> f64 {
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let elevation = d[2] / norm;
        let sky = HAZE_DN - 45.0 * (elevation * 4.0).clamp(0.0, 1.0);
        let nearest_box = boxes
            .iter()
            .filter_map(|b| b.hit(o, d))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let structure = Self::hit_structure(o, d, near);
        // A structure nearer than the road surface's highest plane hides the road: skip the
        // search for where the ray meets it.
        let hides_ground =
            structure.is_some_and(|(t, _)| d[2] < 0.0 && t < (self.surface_top_m - o[2]) / d[2]);
        let nearest_box = match (nearest_box, structure) {
            (Some(b), Some(s)) if s.0 < b.0 => Some(s),
            (None, s) => s,
            (b, _) => b,
        };
        let ground = (d[2] < 0.0 && !hides_ground).then(|| self.hit_ground(o, d, hint));
        let (t, value) = match (ground, nearest_box) {
            (Some((tg, _)), Some((tb, shade))) if tb < tg => (tb, shade),
            (None, Some((tb, shade))) => (tb, shade),
            (Some((tg, sl)), _) => {
                let (x, y) = (o[0] + tg * d[0], o[1] + tg * d[1]);
                let mut g = self.ground(x, y, sl);
                if boxes.iter().any(|b| b.covers(x, y)) || near.iter().any(|(_, s)| s.covers(x, y))
                {
                    g *= 0.3;
                }
                (tg, g)
            }
            (None, None) => return sky,
        };
        let fade = (-(t * norm) / HAZE_M).exp();
        value * fade + HAZE_DN * (1.0 - fade)
    }

    /// Renders the frame `index` seen from `state`.
    pub fn render(&self, state: &FrameState, index: u64) -> GrayImage {
        self.render_culled(state, index, true)
    }

    /// Pixel rectangle (u0, u1, v0, v1, inclusive) holding the image of the convex volume with
    /// `corners` seen from `o` with camera-to-world rotation `rot`, one pixel of margin for the
    /// samples' spread, and the volume's least depth (camera z); `None` where it is out of
    /// view. The volume is clipped at a near plane 5 cm in front of the camera (its edges cut
    /// there add their crossing points).
    fn screen_rect(
        &self,
        corners: &[[f64; 3]; 8],
        o: [f64; 3],
        rot: &[[f64; 3]; 3],
    ) -> Option<([i64; 4], f64)> {
        const NEAR_M: f64 = 0.05;
        let cam: [[f64; 3]; 8] = corners.map(|p| {
            let q = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
            std::array::from_fn(|j| rot[0][j] * q[0] + rot[1][j] * q[1] + rot[2][j] * q[2])
        });
        let k = self.rays.camera();
        let (fx, fy) = (f64::from(k.fx_px), f64::from(k.fy_px));
        let (px, py) = (f64::from(k.cx_px), f64::from(k.cy_px));
        let (mut lo, mut hi, mut depth) = ([f64::MAX; 2], [f64::MIN; 2], f64::MAX);
        let mut add = |c: [f64; 3]| {
            depth = depth.min(c[2]);
            let uv = [fx * c[0] / c[2] + px, fy * c[1] / c[2] + py];
            for a in 0..2 {
                lo[a] = lo[a].min(uv[a]);
                hi[a] = hi[a].max(uv[a]);
            }
        };
        for (i, a) in cam.iter().enumerate() {
            if a[2] >= NEAR_M {
                add(*a);
            }
            // Every pair, not only the edges: points inside the volume change no bound.
            for b in &cam[i + 1..] {
                if (a[2] - NEAR_M) * (b[2] - NEAR_M) < 0.0 {
                    let f = (NEAR_M - a[2]) / (b[2] - a[2]);
                    add(std::array::from_fn(|j| a[j] + f * (b[j] - a[j])));
                }
            }
        }
        if lo[0] > hi[0] {
            return None;
        }
        let (lo, hi) = self.rays.seen(lo, hi)?;
        let size = [i64::from(self.width), i64::from(self.height)];
        let mut rect = [0i64; 4];
        for a in 0..2 {
            // Saturating casts: points near the clip plane project far out.
            let (l, h) = ((lo[a].floor() as i64) - 1, (hi[a].ceil() as i64) + 1);
            if h < 0 || l >= size[a] {
                return None;
            }
            rect[2 * a] = l.max(0);
            rect[2 * a + 1] = h.min(size[a] - 1);
        }
        Some((rect, depth))
    }

    /// [`Scene::render`]; without `cull` every structure is tried on every ray (for tests).
    fn render_culled(&self, state: &FrameState, index: u64, cull: bool) -> GrayImage {
        let r = self.mount.rotation_vehicle_from_camera(state.attitude);
        let (sh, ch) = state.pose.heading_rad.sin_cos();
        // World-from-camera rotation: the vehicle's heading after the mount.
        let rw = |i: usize, j: usize| match i {
            0 => ch * r[(0, j)] - sh * r[(1, j)],
            1 => sh * r[(0, j)] + ch * r[(1, j)],
            _ => r[(2, j)],
        };
        let rot: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| rw(i, j)));
        let (cx, cy) = state
            .pose
            .to_world(f64::from(self.mount.x_m), f64::from(self.mount.y_m));
        let o = [cx, cy, f64::from(self.mount.height_m)];
        let n = self.supersample;
        let inv_n = 1.0 / f64::from(n);
        let frame_salt = mix(self.seed ^ 0x5eed ^ index.wrapping_mul(0x2545_f491_4f6c_dd1d));
        // Structures in view, nearest first, each with the pixels its image may cover and its
        // least depth: a ray tries only those whose rectangle holds its pixel, in order, until
        // the next lies behind what it has hit.
        let full = [0, i64::from(self.width) - 1, 0, i64::from(self.height) - 1];
        let mut in_view: Vec<([i64; 4], f64, &Structure)> = self
            .structures
            .iter()
            .zip(&self.bounds)
            .filter_map(|(s, b)| {
                let (rect, depth) = if cull {
                    self.screen_rect(b, o, &rot)?
                } else {
                    (full, 0.0)
                };
                Some((rect, depth, s))
            })
            .collect();
        in_view.sort_by(|a, b| a.1.total_cmp(&b.1));
        // Almost everything in view spans the rows about the horizon: sort the structures into
        // tiles once per band of rows, so that a pixel sifts only its tile's.
        const TILE: u32 = 16;
        let mut tiles: Vec<Vec<([i64; 4], f64, &Structure)>> =
            vec![Vec::new(); self.width.div_ceil(TILE) as usize];
        let mut near: Vec<(f64, &Structure)> = Vec::with_capacity(in_view.len());
        // Neighbouring rays meet the road near each other: carry the path sample along, one
        // for each row of samples in a pixel (half a pixel apart, they meet the road metres apart
        // near the horizon).
        let mut hints = vec![NO_HINT; n as usize];
        let mut img = GrayImage::new(self.width, self.height);
        for v in 0..self.height {
            let vi = i64::from(v);
            if v % TILE == 0 {
                let band = vi..=vi + i64::from(TILE) - 1;
                tiles.iter_mut().for_each(Vec::clear);
                for item in in_view
                    .iter()
                    .filter(|(r, ..)| r[2] <= *band.end() && r[3] >= *band.start())
                {
                    let tile = |u: i64| (u / i64::from(TILE)) as usize;
                    for t in &mut tiles[tile(item.0[0])..=tile(item.0[1])] {
                        t.push(*item);
                    }
                }
            }
            for u in 0..self.width {
                let ui = i64::from(u);
                near.clear();
                near.extend(
                    tiles[(u / TILE) as usize]
                        .iter()
                        .filter(|(r, ..)| {
                            (r[0]..=r[1]).contains(&ui) && (r[2]..=r[3]).contains(&vi)
                        })
                        .map(|&(_, depth, s)| (depth, s)),
                );
                let mut sum = 0.0;
                for (j, hint) in (0..n).zip(&mut hints) {
                    for i in 0..n {
                        // Pixel centres sit at integer coordinates.
                        let su = f64::from(u) - 0.5 + (f64::from(i) + 0.5) * inv_n;
                        let sv = f64::from(v) - 0.5 + (f64::from(j) + 0.5) * inv_n;
                        // Black where the lens gives no ray (validation refuses such a lens).
                        let Some(dc) = self.rays.ray(su, sv) else {
                            continue;
                        };
                        let d = std::array::from_fn(|r| {
                            rot[r][0] * dc[0] + rot[r][1] * dc[1] + rot[r][2] * dc[2]
                        });
                        sum += self.trace(o, d, &state.boxes, &near, hint);
                    }
                }
                let mean = sum * inv_n * inv_n;
                // Gaussian sensor noise by Box-Muller from the pixel's own hash.
                let h = hash(i64::from(u), i64::from(v), frame_salt, 7);
                let (a, b) = (unit(h, 0).max(1e-12), unit(h, 1));
                let noise = (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos();
                let grey = (mean + self.noise_dn * noise).round().clamp(0.0, 255.0) as u8;
                img.put_pixel(u, v, image::Luma([grey]));
            }
        }
        img
    }
}

// Above-ground structure.
//
// How it is built: every item is a small convex solid placed once per scene in world
// coordinates (an oriented box, a vertical cylinder, an ellipsoid), positioned from the path's
// arc length and lateral offset. A building is a box whose front is the chord between two points
// at its setback, so on a curve it is flat (as real buildings are) and each ray needs one exact
// slab test, with no marching along the ray and no sensitivity to the path index's accuracy
// far from the road. Placement rejects anything whose footprint comes near the asphalt of any
// stretch of the road (tested with the path index on a 1 m grid over the footprint), which also
// handles the inside of tight turns and roads that pass near each other. Per frame, each item's
// bounding box is projected into the image (a rectangle and a least depth); a ray tries only the
// items whose rectangle holds its pixel, nearest first, stops at the first that lies wholly
// behind its nearest hit, and shades only that hit: town frames cost about 1.6 times kitti-like's.

/// Horizontal direction the light comes from (unit), for shading vertical faces.
const SUN_H: [f64; 2] = [0.832_050_294_337_843_2, 0.554_700_196_225_228_8];
/// Direction the light comes from (unit), for shading curved surfaces.
const SUN: [f64; 3] = [0.5, 0.333_333_333_333_333_3, 0.8];

/// Where a ray `lo + t ld` (t >= 0) enters the box `bounds` (per axis, low and high), in its
/// own frame (the slab method): the parameter, and the axis of the face entered (None where it
/// starts inside); None where it misses.
fn slab_entry(lo: [f64; 3], ld: [f64; 3], bounds: [(f64, f64); 3]) -> Option<(f64, Option<usize>)> {
    let (mut t0, mut t1, mut axis) = (0.0f64, f64::MAX, None);
    for k in 0..3 {
        if ld[k].abs() < 1e-12 {
            if lo[k] < bounds[k].0 || lo[k] > bounds[k].1 {
                return None;
            }
            continue;
        }
        let (mut a, mut b) = ((bounds[k].0 - lo[k]) / ld[k], (bounds[k].1 - lo[k]) / ld[k]);
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        if a > t0 {
            t0 = a;
            axis = Some(k);
        }
        t1 = t1.min(b);
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, axis))
}

/// `x.floor()` for finite `x` of magnitude under 2^63 (but +0 for -0), without the call that
/// `f64::floor` is on baseline x86-64.
fn fast_floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x { t - 1.0 } else { t }
}

fn lerp(r: [f64; 2], f: f64) -> f64 {
    r[0] + (r[1] - r[0]) * f
}

fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Shade of a vertical face whose outward horizontal normal is `n`.
fn face_light(n: [f64; 2]) -> f64 {
    0.75 + 0.25 * (n[0] * SUN_H[0] + n[1] * SUN_H[1])
}

/// Entry of a ray into a vertical cylinder (axis at `c`, radius `r`, from `z.0` to `z.1`):
/// parameter and the outward horizontal normal there. Rays entering through a cap miss.
fn cylinder(
    o: [f64; 3],
    d: [f64; 3],
    c: (f64, f64),
    r: f64,
    z: (f64, f64),
) -> Option<(f64, [f64; 2])> {
    let (ox, oy) = (o[0] - c.0, o[1] - c.1);
    let a = d[0] * d[0] + d[1] * d[1];
    if a < 1e-18 {
        return None;
    }
    let b = ox * d[0] + oy * d[1];
    let disc = b * b - a * (ox * ox + oy * oy - r * r);
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    let h = o[2] + t * d[2];
    if t <= 0.0 || h < z.0 || h > z.1 {
        return None;
    }
    Some((t, [(ox + t * d[0]) / r, (oy + t * d[1]) / r]))
}

/// An upright box turned to a heading, in world coordinates.
#[derive(Clone, Copy, Debug)]
struct Block {
    centre: (f64, f64),
    /// Sine and cosine of the heading of its length.
    sin_cos: (f64, f64),
    /// Half length (along the heading), half width.
    half: (f64, f64),
    /// Bottom and top, metres.
    z: (f64, f64),
}

impl Block {
    fn new(centre: (f64, f64), heading_rad: f64, half: (f64, f64), z: (f64, f64)) -> Self {
        Self {
            centre,
            sin_cos: heading_rad.sin_cos(),
            half,
            z,
        }
    }

    /// Entry of a ray from outside: parameter, the axis of the face entered (0: an end, 1: a
    /// side, 2: top or bottom) and the entry point in the box's frame (along, across, up).
    fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<(f64, usize, [f64; 3])> {
        let (s, c) = self.sin_cos;
        let (ox, oy) = (o[0] - self.centre.0, o[1] - self.centre.1);
        let lo = [c * ox + s * oy, -s * ox + c * oy, o[2]];
        let ld = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]];
        let bounds = [
            (-self.half.0, self.half.0),
            (-self.half.1, self.half.1),
            self.z,
        ];
        let (t0, axis) = slab_entry(lo, ld, bounds)?;
        // Starting inside: nothing to see of this box.
        Some((t0, axis?, std::array::from_fn(|k| lo[k] + t0 * ld[k])))
    }

    /// World point of a point in the box's frame (along, across).
    fn point(&self, a: f64, b: f64) -> (f64, f64) {
        let (s, c) = self.sin_cos;
        (self.centre.0 + c * a - s * b, self.centre.1 + s * a + c * b)
    }

    /// Outward horizontal normal of the face `axis` (0 or 1) on the side of local point `p`.
    fn normal(&self, axis: usize, p: [f64; 3]) -> [f64; 2] {
        let (s, c) = self.sin_cos;
        if axis == 0 {
            let k = p[0].signum();
            [k * c, k * s]
        } else {
            let k = p[1].signum();
            [-k * s, k * c]
        }
    }

    fn corners(&self) -> [[f64; 3]; 8] {
        std::array::from_fn(|i| {
            let a = if i & 1 == 0 {
                -self.half.0
            } else {
                self.half.0
            };
            let b = if i & 2 == 0 {
                -self.half.1
            } else {
                self.half.1
            };
            let (x, y) = self.point(a, b);
            [x, y, if i & 4 == 0 { self.z.0 } else { self.z.1 }]
        })
    }

    /// Points over the footprint, at most `step` apart along each axis, edges included.
    fn footprint(&self, step: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let n = |h: f64| (2.0 * h / step).ceil().max(1.0) as usize;
        let (na, nb) = (n(self.half.0), n(self.half.1));
        (0..=na).flat_map(move |i| {
            (0..=nb).map(move |j| {
                let a = -self.half.0 + 2.0 * self.half.0 * i as f64 / na as f64;
                let b = -self.half.1 + 2.0 * self.half.1 * j as f64 / nb as f64;
                self.point(a, b)
            })
        })
    }
}

/// Corners of the axis-aligned box around `points`.
fn aabb_corners(points: impl Iterator<Item = [f64; 3]>) -> [[f64; 3]; 8] {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    std::array::from_fn(|i| std::array::from_fn(|k| if i & (1 << k) == 0 { lo[k] } else { hi[k] }))
}

/// A building: a box with its front to the road.
#[derive(Clone, Debug)]
struct Building {
    block: Block,
    /// Hash of its look: wall kind and shade, storey height, window bays.
    style: u64,
}

/// Albedo of a window at (x from its centre, z from its sill) of a `w` by `h` opening.
fn window(x: f64, z: f64, w: f64, h: f64, look: u64) -> f64 {
    const FRAME_M: f64 = 0.07;
    const FRAME_DN: f64 = 215.0;
    if x.abs() > 0.5 * w - FRAME_M || z < FRAME_M || z > h - FRAME_M {
        return FRAME_DN;
    }
    // A mullion in wide windows, a transom in all.
    if (w > 1.1 && x.abs() < 0.03) || (z - 0.68 * h).abs() < 0.03 {
        return FRAME_DN;
    }
    // Glass: mostly dark, some reflecting the sky; a blind drawn part way in some.
    let blind = unit(look, 0);
    if blind < 0.3 && z > h * (0.45 + blind) {
        return 175.0 + 20.0 * unit(look, 1);
    }
    if unit(look, 2) < 0.2 {
        130.0 + 40.0 * unit(look, 3)
    } else {
        25.0 + 35.0 * unit(look, 3)
    }
}

/// Albedo of a building's wall at `u` metres from its left end and `z` metres up, the wall being
/// `width` wide and `height` high: storeys of windows in bays, doors and shop windows on the
/// ground floor, a cornice, and bricks, concrete panels or plaster between.
fn facade(style: u64, u: f64, z: f64, width: f64, height: f64) -> f64 {
    let storey = 2.8 + 0.8 * unit(style, 1);
    let bay = 2.4 + 1.2 * unit(style, 2);
    let base = 100.0 + 80.0 * unit(style, 3);
    let kind = unit(style, 4);
    if z > height - 0.35 {
        return 0.6 * base;
    }
    let bays = fast_floor(width / bay).max(1.0);
    let bu = u - 0.5 * (width - bays * bay);
    let bi = fast_floor(bu / bay);
    let fi = fast_floor(z / storey);
    let fz = z - fi * storey;
    if bi >= 0.0 && bi < bays && z < height - 0.9 {
        let x = bu - (bi + 0.5) * bay;
        let look = || hash(bi as i64, fi as i64, style, 31);
        if fi == 0.0 {
            let look = look();
            if unit(look, 5) < 0.3 {
                // A door: frame, dark panel, a handle.
                if x.abs() < 0.55 && z < 2.2 {
                    if x.abs() > 0.48 || z > 2.13 {
                        return 200.0;
                    }
                    if (x - 0.3).abs() < 0.04 && (z - 1.05).abs() < 0.1 {
                        return 220.0;
                    }
                    return 40.0 + 30.0 * unit(look, 6);
                }
            } else if x.abs() < 0.42 * bay && z > 0.6 && z < 2.3 {
                return window(x, z - 0.6, 0.84 * bay, 1.7, look);
            }
        } else {
            let w = (0.42 + 0.16 * unit(style, 5)) * bay;
            let (sill, h) = (0.3 * storey, (0.42 + 0.12 * unit(style, 6)) * storey);
            if x.abs() < 0.5 * w && fz > sill && fz < sill + h {
                return window(x, fz - sill, w, h, look());
            }
        }
    }
    if kind < 0.4 {
        // Bricks in stretcher bond, light mortar.
        const ROW_M: f64 = 0.075;
        const BRICK_M: f64 = 0.25;
        let row = fast_floor(z / ROW_M);
        let shifted = u + if row.rem_euclid(2.0) == 1.0 {
            0.5 * BRICK_M
        } else {
            0.0
        };
        let col = fast_floor(shifted / BRICK_M);
        if z - row * ROW_M < 0.012 || shifted - col * BRICK_M < 0.012 {
            return (base + 35.0).min(235.0);
        }
        base + 24.0 * (unit(hash(col as i64, row as i64, style, 32), 0) - 0.5)
    } else if kind < 0.7 {
        // Concrete panels: two a storey, dark joints.
        let (pw, ph) = (0.5 * bay, 0.5 * storey);
        let (pu, pz) = (fast_floor(u / pw), fast_floor(z / ph));
        if u - pu * pw < 0.035 || z - pz * ph < 0.035 {
            return 0.55 * base;
        }
        base + 14.0 * (unit(hash(pu as i64, pz as i64, style, 33), 0) - 0.5)
    } else {
        // Plaster with a band at each floor.
        if fz < 0.18 && fi > 0.0 {
            return 0.8 * base;
        }
        base + 14.0 * (value_noise(u / 0.7, z / 0.7, style, 34) - 0.5)
            + 8.0 * (value_noise(u / 0.08, z / 0.08, style, 35) - 0.5)
    }
}

impl Building {
    fn hit(&self, o: [f64; 3], d: [f64; 3], limit: f64) -> Option<(f64, f64)> {
        let (t, axis, p) = self.block.hit(o, d).filter(|h| h.0 < limit)?;
        let (hl, hw) = self.block.half;
        let height = self.block.z.1;
        let albedo = match axis {
            0 => facade(self.style ^ 0x51de, p[1] + hw, p[2], 2.0 * hw, height),
            1 => facade(self.style, p[0] + hl, p[2], 2.0 * hl, height),
            _ => return Some((t, 80.0)),
        };
        Some((t, albedo * face_light(self.block.normal(axis, p))))
    }
}

/// What stands on a pole.
#[derive(Clone, Copy, Debug)]
enum PoleKind {
    /// A street light: an arm over the road and a lamp at its end.
    Light { arm: Block, lamp: Block },
    /// A sign post: a plate facing along the road.
    Sign { plate: Block, symbol: u64 },
}

/// A pole: a vertical cylinder with a light or a sign.
#[derive(Clone, Debug)]
struct Pole {
    at: (f64, f64),
    radius: f64,
    height: f64,
    shade: f64,
    kind: PoleKind,
}

impl Pole {
    fn hit(&self, o: [f64; 3], d: [f64; 3], limit: f64) -> Option<(f64, f64)> {
        // Which part is nearest, then its shade.
        enum Part {
            Shaft([f64; 2]),
            Arm(usize, [f64; 3]),
            Lamp(usize, [f64; 3]),
            Plate(usize, [f64; 3]),
        }
        let mut best = cylinder(o, d, self.at, self.radius, (0.0, self.height))
            .map(|(t, n)| (t, Part::Shaft(n)));
        let mut consider = |hit: Option<(f64, usize, [f64; 3])>,
                            part: fn(usize, [f64; 3]) -> Part| {
            if let Some((t, axis, p)) = hit
                && best.as_ref().is_none_or(|b| t < b.0)
            {
                best = Some((t, part(axis, p)));
            }
        };
        match self.kind {
            PoleKind::Light { arm, lamp } => {
                consider(arm.hit(o, d), Part::Arm);
                consider(lamp.hit(o, d), Part::Lamp);
            }
            PoleKind::Sign { plate, .. } => consider(plate.hit(o, d), Part::Plate),
        }
        let (t, part) = best.filter(|b| b.0 < limit)?;
        let shade = match (part, self.kind) {
            (Part::Shaft(n), _) => {
                let z = o[2] + t * d[2];
                // A dark foot and a light band at eye height.
                let albedo = if z < 0.5 {
                    0.55 * self.shade
                } else if (z - 2.0).abs() < 0.1 {
                    (self.shade + 70.0).min(235.0)
                } else {
                    self.shade
                };
                albedo * face_light(n)
            }
            (Part::Arm(axis, p), PoleKind::Light { arm, .. }) => {
                let light = if axis == 2 {
                    0.8
                } else {
                    face_light(arm.normal(axis, p))
                };
                light * self.shade
            }
            // The glass underneath is bright.
            (Part::Lamp(axis, p), PoleKind::Light { lamp, .. }) => {
                if axis == 2 && p[2] < lamp.z.0 + 0.01 {
                    240.0
                } else {
                    60.0
                }
            }
            (Part::Plate(0, p), PoleKind::Sign { plate, symbol }) => {
                // The face: a dark border, and a bar or a square on white.
                let (x, z) = (p[1], p[2] - 0.5 * (plate.z.0 + plate.z.1));
                let half = plate.half.1;
                if x.abs() > half - 0.06 || z.abs() > half - 0.06 {
                    45.0
                } else if unit(symbol, 0) < 0.5 {
                    if x.abs() < half - 0.14 && z.abs() < 0.08 {
                        50.0
                    } else {
                        225.0
                    }
                } else if x.abs() < 0.13 && z.abs() < 0.13 {
                    55.0
                } else {
                    215.0
                }
            }
            _ => 120.0,
        };
        Some((t, shade))
    }

    fn bound(&self) -> [[f64; 3]; 8] {
        let (x, y, r) = (self.at.0, self.at.1, self.radius);
        let shaft = [[x - r, y - r, 0.0], [x + r, y + r, self.height]];
        let parts: Vec<[f64; 3]> = match self.kind {
            PoleKind::Light { arm, lamp } => {
                arm.corners().into_iter().chain(lamp.corners()).collect()
            }
            PoleKind::Sign { plate, .. } => plate.corners().to_vec(),
        };
        aabb_corners(shaft.into_iter().chain(parts))
    }
}

/// A tree: a trunk and an ellipsoid crown with leafy texture.
#[derive(Clone, Debug)]
struct Tree {
    at: (f64, f64),
    trunk_radius: f64,
    /// Height of the crown's centre, its horizontal and vertical radii.
    crown_z: f64,
    crown_radii: (f64, f64),
    seed: u64,
}

impl Tree {
    fn hit(&self, o: [f64; 3], d: [f64; 3], limit: f64) -> Option<(f64, f64)> {
        let trunk = cylinder(o, d, self.at, self.trunk_radius, (0.0, self.crown_z));
        // The crown: a sphere after scaling height by the radii's ratio.
        let (a, b) = self.crown_radii;
        let k = a / b;
        let q = [
            o[0] - self.at.0,
            o[1] - self.at.1,
            (o[2] - self.crown_z) * k,
        ];
        let e = [d[0], d[1], d[2] * k];
        let ee = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        let qe = q[0] * e[0] + q[1] * e[1] + q[2] * e[2];
        let disc = qe * qe - ee * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] - a * a);
        let crown = (disc >= 0.0)
            .then(|| (-qe - disc.sqrt()) / ee)
            .filter(|&t| t > 0.0);
        let crown_limit = trunk.map_or(limit, |(t, _)| t.min(limit));
        if let Some(t) = crown.filter(|&t| t < crown_limit) {
            let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
            // Normal of the ellipsoid: the scaled sphere's, scaled again.
            let n = [q[0] + t * e[0], q[1] + t * e[1], (q[2] + t * e[2]) * k];
            let nn = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            let lit = (n[0] * SUN[0] + n[1] * SUN[1] + n[2] * SUN[2]) / nn;
            // Clumps of leaves with dark gaps between, finer leaves on them.
            let clump = value_noise3(p.map(|x| x / 0.3), self.seed, 42);
            let fine = value_noise3(p.map(|x| x / 0.09), self.seed, 43);
            let leaf = smoothstep(0.4, 0.6, clump);
            let albedo = 30.0 + leaf * (70.0 + 60.0 * fine);
            return Some((t, albedo * (0.55 + 0.45 * lit.max(0.0))));
        }
        let (t, n) = trunk.filter(|&(t, _)| t < limit)?;
        let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
        let bark = value_noise((p[0] + p[1]) / 0.05, p[2] / 0.4, self.seed, 41);
        Some((t, (55.0 + 30.0 * bark) * face_light(n)))
    }

    fn bound(&self) -> [[f64; 3]; 8] {
        let (x, y) = self.at;
        let (a, b) = self.crown_radii;
        let r = a.max(self.trunk_radius);
        aabb_corners([[x - r, y - r, 0.0], [x + r, y + r, self.crown_z + b]].into_iter())
    }
}

/// Something above the ground that does not move.
#[derive(Clone, Debug)]
enum Structure {
    Building(Building),
    Pole(Pole),
    Tree(Tree),
    /// A parked car, and the sine and cosine of its heading.
    Car(BoxState, (f64, f64)),
}

impl Structure {
    /// Nearest hit of a ray nearer than `limit`: parameter and grey level (before haze). Only
    /// such a hit is shaded.
    fn hit(&self, o: [f64; 3], d: [f64; 3], limit: f64) -> Option<(f64, f64)> {
        match self {
            Structure::Building(b) => b.hit(o, d, limit),
            Structure::Pole(p) => p.hit(o, d, limit),
            Structure::Tree(t) => t.hit(o, d, limit),
            Structure::Car(c, turn) => c.hit_turned(o, d, *turn).filter(|h| h.0 < limit),
        }
    }

    /// Whether it shades the ground at (x, y).
    fn covers(&self, x: f64, y: f64) -> bool {
        matches!(self, Structure::Car(c, turn) if c.covers_turned(x, y, *turn))
    }

    /// Corners of a box that holds it (its shadow on the ground included).
    fn bound(&self) -> [[f64; 3]; 8] {
        match self {
            Structure::Building(b) => b.block.corners(),
            Structure::Pole(p) => p.bound(),
            Structure::Tree(t) => t.bound(),
            Structure::Car(c, _) => Block::new(
                c.centre,
                c.heading_rad,
                (c.size.0, c.size.1),
                (0.0, c.size.2),
            )
            .corners(),
        }
    }
}

/// World position of the point at arc length `s` and lateral offset `l` (positive left) and the
/// path's heading there; beyond either end the path goes on straight.
fn along(path: &Path, s: f64, l: f64) -> ((f64, f64), f64) {
    let pose = path.pose_at(s);
    let beyond = s - s.clamp(0.0, path.length_m());
    (pose.to_world(beyond, l), pose.heading_rad)
}

/// Salts of the placement hashes, one per kind of structure.
const SALT_FACADE: u64 = 0x00fa_cade;
const SALT_POLE: u64 = 0x901e;
const SALT_TREE: u64 = 0x74ee;
const SALT_PARKED: u64 = 0x0ca4;
/// Structures are placed from this far before the path's start to this far after its end.
const PLACE_MARGIN_M: f64 = 30.0;

/// The structures a scenario asks for along `path`, placed from the seed.
fn place_structures(
    scenario: &Scenario,
    path: &Path,
    index: &PathIndex,
    seed: u64,
) -> Vec<Structure> {
    let w = scenario.render.lane_width_m;
    // Lateral offset of a point `beyond` metres outside the asphalt on the side `sign`.
    let edge = |sign: f64, beyond: f64| {
        if sign > 0.0 {
            1.5 * w + 0.6 + beyond
        } else {
            -(0.5 * w + 0.6 + beyond)
        }
    };
    // Whether every point stays `keep` metres outside the asphalt of every stretch of road.
    let clear = |points: &mut dyn Iterator<Item = (f64, f64)>, keep: f64| {
        for (x, y) in points {
            let mut hint = NO_HINT;
            if let Some((_, l)) = index.locate(x, y, &mut hint)
                && l < edge(1.0, keep)
                && l > edge(-1.0, keep)
            {
                return false;
            }
        }
        true
    };
    let (start, end) = (-PLACE_MARGIN_M, path.length_m() + PLACE_MARGIN_M);
    let mut out = Vec::new();
    // Where poles stand, so that trees keep away from them: (side, arc length).
    let mut poles_at: Vec<(f64, f64)> = Vec::new();

    if let Some(p) = &scenario.parked {
        for (k, &sign) in p.sides.signs().iter().enumerate() {
            let mut s = start + lerp(p.gap_m, unit(hash(-1, k as i64, seed, SALT_PARKED), 0));
            for i in 0.. {
                if s >= end {
                    break;
                }
                let h = hash(i, k as i64, seed, SALT_PARKED);
                let (length, width, height) = (
                    3.9 + 0.9 * unit(h, 0),
                    1.75 + 0.1 * unit(h, 1),
                    1.4 + 0.2 * unit(h, 2),
                );
                let (centre, heading) =
                    along(path, s + 0.5 * length, edge(sign, p.offset_m + 0.5 * width));
                // On the left they mostly face the other lane's way.
                let turned = if sign > 0.0 && unit(h, 3) < 0.8 {
                    std::f64::consts::PI
                } else {
                    0.0
                };
                let car = BoxState {
                    centre,
                    heading_rad: heading + turned,
                    size: (0.5 * length, 0.5 * width, height),
                    shade: 50.0 + 150.0 * unit(h, 4),
                };
                let body = Block::new(centre, heading, (0.5 * length, 0.5 * width), (0.0, height));
                if clear(&mut body.footprint(1.0), p.offset_m - 0.05) {
                    out.push(Structure::Car(car, car.heading_rad.sin_cos()));
                }
                s += length + lerp(p.gap_m, unit(h, 5));
            }
        }
    }

    if let Some(p) = &scenario.poles {
        for (k, &sign) in p.sides.signs().iter().enumerate() {
            let mut s = start + p.spacing_m * unit(hash(-1, k as i64, seed, SALT_POLE), 0);
            for i in 0.. {
                if s >= end {
                    break;
                }
                let h = hash(i, k as i64, seed, SALT_POLE);
                let (at, heading) = along(path, s, edge(sign, p.offset_m));
                // Towards the road, across it.
                let across = heading - sign * std::f64::consts::FRAC_PI_2;
                let (ax, ay) = (across.cos(), across.sin());
                let pole = if unit(h, 0) < p.sign_fraction {
                    // The plate in front of the post, facing traffic coming along the path.
                    let (radius, bottom) = (0.04, 2.0 + 0.3 * unit(h, 1));
                    let back = radius + 0.025;
                    let centre = (at.0 - back * heading.cos(), at.1 - back * heading.sin());
                    let plate = Block::new(centre, heading, (0.02, 0.35), (bottom, bottom + 0.7));
                    let kind = PoleKind::Sign { plate, symbol: h };
                    Pole {
                        at,
                        radius,
                        height: bottom + 0.35,
                        shade: 150.0,
                        kind,
                    }
                } else {
                    let height = 6.0 + 2.0 * unit(h, 1);
                    let reach = 1.2 + 0.8 * unit(h, 2);
                    let arm = Block::new(
                        (at.0 + 0.5 * reach * ax, at.1 + 0.5 * reach * ay),
                        across,
                        (0.5 * reach, 0.05),
                        (height - 0.12, height),
                    );
                    let lamp = Block::new(
                        (at.0 + (reach - 0.3) * ax, at.1 + (reach - 0.3) * ay),
                        across,
                        (0.35, 0.18),
                        (height - 0.3, height - 0.05),
                    );
                    Pole {
                        at,
                        radius: 0.09,
                        height,
                        shade: 120.0 + 40.0 * unit(h, 3),
                        kind: PoleKind::Light { arm, lamp },
                    }
                };
                if clear(&mut std::iter::once(at), pole.radius + 0.1) {
                    out.push(Structure::Pole(pole));
                    poles_at.push((sign, s));
                }
                s += p.spacing_m * (0.7 + 0.6 * unit(h, 4));
            }
        }
    }

    if let Some(t) = &scenario.trees {
        for (k, &sign) in t.sides.signs().iter().enumerate() {
            let mut s = start + t.spacing_m * unit(hash(-1, k as i64, seed, SALT_TREE), 0);
            for i in 0.. {
                if s >= end {
                    break;
                }
                let h = hash(i, k as i64, seed, SALT_TREE);
                let height = lerp(t.height_m, unit(h, 0));
                let (b, a) = (0.3 * height, (0.22 + 0.12 * unit(h, 1)) * height);
                let (at, _) = along(path, s, edge(sign, t.offset_m));
                let tree = Tree {
                    at,
                    trunk_radius: 0.1 + 0.025 * height,
                    crown_z: height - b,
                    crown_radii: (a, b),
                    seed: h,
                };
                let by_pole = poles_at
                    .iter()
                    .any(|&(ps, pa)| ps == sign && (pa - s).abs() < 3.0);
                if !by_pole && clear(&mut std::iter::once(at), tree.trunk_radius + 0.2) {
                    out.push(Structure::Tree(tree));
                }
                s += t.spacing_m * (0.7 + 0.6 * unit(h, 2));
            }
        }
    }

    if let Some(f) = &scenario.facades {
        for (k, &sign) in f.sides.signs().iter().enumerate() {
            let mut s = start - lerp(f.length_m, unit(hash(-1, k as i64, seed, SALT_FACADE), 0));
            for i in 0.. {
                if s >= end {
                    break;
                }
                let h = hash(i, k as i64, seed, SALT_FACADE);
                let setback = lerp(f.setback_m, unit(h, 0));
                let (height, depth) = (lerp(f.height_m, unit(h, 1)), lerp(f.depth_m, unit(h, 2)));
                let mut length = lerp(f.length_m, unit(h, 3));
                // The front is the chord between its ends at the setback. Where the footprint
                // comes near the road (the chord cuts a bend, another stretch of road passes),
                // try it shorter, then leave it out.
                loop {
                    let (a, _) = along(path, s, edge(sign, setback));
                    let (b, _) = along(path, s + length, edge(sign, setback));
                    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                    let front = dx.hypot(dy);
                    let heading = dy.atan2(dx);
                    // Away from the road: left of the front's direction on the left side.
                    let (nx, ny) = (-sign * heading.sin(), sign * heading.cos());
                    let centre = (
                        0.5 * (a.0 + b.0) + 0.5 * depth * nx,
                        0.5 * (a.1 + b.1) + 0.5 * depth * ny,
                    );
                    let block =
                        Block::new(centre, heading, (0.5 * front, 0.5 * depth), (0.0, height));
                    if front > 2.0 && clear(&mut block.footprint(1.0), 0.5) {
                        out.push(Structure::Building(Building {
                            block,
                            style: mix(h),
                        }));
                        break;
                    }
                    if length < 6.0 {
                        break;
                    }
                    length *= 0.7;
                }
                s += length + lerp(f.gap_m, unit(h, 4));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::Segment;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn path_index_finds_offsets_along_a_curve() {
        let path = Path::new(&[
            Segment::Straight { length_m: 20.0 },
            Segment::Arc {
                radius_m: 10.0,
                angle_deg: 90.0,
            },
        ])
        .unwrap();
        let idx = PathIndex::new(&path);
        let mut hint = NO_HINT;
        let (s, l) = idx.locate(5.0, 2.0, &mut hint).unwrap();
        assert!((s - 5.0).abs() < 1e-9 && (l - 2.0).abs() < 1e-9);
        // On the arc (centre (20, 10)), 45 deg in, 1 m outside the path (to its right). Arc
        // length comes from the tangent at the nearest sample: off by up to 1.25 cm here.
        let a = std::f64::consts::FRAC_PI_4;
        let (x, y) = (20.0 + 11.0 * a.sin(), 10.0 - 11.0 * a.cos());
        // Found both from the cells and from a hint left on the straight.
        let mut fresh = NO_HINT;
        let (s, l) = idx.locate(x, y, &mut fresh).unwrap();
        assert!((s - (20.0 + 10.0 * a)).abs() < 0.015, "{s}");
        let (s, l2) = idx.locate(x, y, &mut hint).unwrap();
        assert!((l2 - l).abs() < 1e-9);
        assert!((s - (20.0 + 10.0 * a)).abs() < 0.015, "{s}");
        assert!((l + 1.0).abs() < 0.01, "{l}");
        assert!(idx.locate(500.0, 500.0, &mut hint).is_none());
    }

    #[test]
    fn kerb_raises_and_crown_lowers_the_surface() {
        let s = Surface {
            kerb: Some(Kerb {
                from_m: -3.0,
                to_m: -2.0,
                height_m: 0.15,
            }),
            crown: Some(Crown {
                left_from_m: 1.0,
                left_slope: 0.04,
                right_from_m: 100.0,
                right_slope: 0.0,
            }),
        };
        assert_eq!(s.height_m(-2.5), 0.15);
        assert_eq!(s.height_m(0.0), 0.0);
        assert!((s.height_m(3.0) + 0.08).abs() < 1e-12);
        let (lo, hi) = s.range_m();
        assert!(lo < -0.39 && hi == 0.15);
    }

    /// On every built-in course, a hinted answer (the hint left by a point nearby, as a
    /// neighbouring ray leaves it, or by one far away) is the cell search's, out to the reach
    /// the cells answer: the hint only saves time.
    #[test]
    fn a_hinted_answer_is_the_cell_searchs() {
        for name in ["s-course", "kitti-like", "town"] {
            let sc = Scenario::built_in(name).unwrap();
            let path = Path::new(&sc.segments).unwrap();
            let idx = PathIndex::new(&path);
            let mut checked = 0;
            let mut far_hint = NO_HINT;
            idx.locate(0.0, 0.0, &mut far_hint);
            for k in 0..(path.length_m() / 0.7) as usize {
                let p = path.pose_at(k as f64 * 0.7);
                let (sh, ch) = p.heading_rad.sin_cos();
                for l in [-7.4, -5.3, -3.1, 0.2, 2.9, 4.4, 6.1, 7.3] {
                    let (x, y) = (p.x_m - l * sh, p.y_m + l * ch);
                    let (mut none, mut near, mut far) = (NO_HINT, NO_HINT, far_hint);
                    let fresh = idx.locate(x, y, &mut none);
                    idx.locate(x + 0.3, y - 0.4, &mut near);
                    for hint in [&mut near, &mut far] {
                        assert_eq!(
                            idx.locate(x, y, hint),
                            fresh,
                            "{name}: ({x}, {y}), offset {l}"
                        );
                    }
                    checked += 1;
                }
            }
            assert!(checked > 1000, "{name}: {checked}");
        }
    }

    /// The town scenario on a small camera (quick to render), and its scene.
    fn small_town(seed: u64) -> (Scenario, Path, Scene) {
        let mut sc = Scenario::built_in("town").unwrap();
        sc.camera.width_px = 200;
        sc.camera.height_px = 64;
        (sc.camera.fx_px, sc.camera.fy_px) = (116.0, 116.0);
        (sc.camera.cx_px, sc.camera.cy_px) = (99.5, 30.0);
        let path = Path::new(&sc.segments).unwrap();
        let scene = Scene::new(&sc, &path, seed);
        (sc, path, scene)
    }

    fn state_at(path: &Path, s: f64) -> FrameState {
        FrameState {
            pose: path.pose_at(s),
            attitude: Attitude::default(),
            boxes: Vec::new(),
        }
    }

    #[test]
    fn building_pole_sign_and_tree_are_hit_where_expected() {
        let up = [0.0, 0.0, 1.0];
        // A building 4 m to the right (front at y = -4), seen from the side and end on.
        let b = Building {
            block: Block::new((10.0, -8.0), 0.0, (5.0, 4.0), (0.0, 12.0)),
            style: 7,
        };
        let (t, grey) = b.hit([10.0, 0.0, 3.0], [0.0, -1.0, 0.0], f64::MAX).unwrap();
        assert!(
            (t - 4.0).abs() < 1e-12 && (0.0..=255.0).contains(&grey),
            "{t} {grey}"
        );
        assert_eq!(b.block.hit([0.0, -8.0, 3.0], [1.0, 0.0, 0.0]).unwrap().1, 0);
        // Beyond the limit (something nearer was hit): no hit, no shading.
        assert!(b.hit([10.0, 0.0, 3.0], [0.0, -1.0, 0.0], 3.9).is_none());
        // Over the roof, and from inside: nothing.
        assert!(
            b.hit([10.0, 0.0, 13.0], [0.0, -1.0, 0.0], f64::MAX)
                .is_none()
        );
        assert!(
            b.hit([10.0, -8.0, 3.0], [0.0, 1.0, 0.0], f64::MAX)
                .is_none()
        );
        assert!(b.hit([10.0, 0.0, 3.0], up, f64::MAX).is_none());

        // A street light 3 m to the right: its shaft, and its lamp over the road from below.
        let light = Pole {
            at: (10.0, -3.0),
            radius: 0.1,
            height: 7.0,
            shade: 130.0,
            kind: PoleKind::Light {
                arm: Block::new((10.0, -2.25), FRAC_PI_2, (0.75, 0.05), (6.88, 7.0)),
                lamp: Block::new((10.0, -1.8), FRAC_PI_2, (0.35, 0.18), (6.7, 6.95)),
            },
        };
        let (t, _) = light
            .hit([0.0, -3.0, 1.0], [1.0, 0.0, 0.0], f64::MAX)
            .unwrap();
        assert!((t - 9.9).abs() < 1e-9, "{t}");
        let (t, grey) = light.hit([10.0, -1.8, 1.0], up, f64::MAX).unwrap();
        assert!((t - 5.7).abs() < 1e-9 && grey == 240.0, "{t} {grey}");
        assert!(
            light
                .hit([0.0, -3.5, 1.0], [1.0, 0.0, 0.0], f64::MAX)
                .is_none()
        );

        // A sign plate facing along the road: its border is dark, its middle white or dark.
        let sign = Pole {
            at: (10.0, -3.0),
            radius: 0.04,
            height: 2.35,
            shade: 150.0,
            kind: PoleKind::Sign {
                plate: Block::new((9.935, -3.0), 0.0, (0.02, 0.35), (2.0, 2.7)),
                symbol: 1,
            },
        };
        let (t, grey) = sign
            .hit([0.0, -3.0, 2.02], [1.0, 0.0, 0.0], f64::MAX)
            .unwrap();
        assert!((t - 9.915).abs() < 1e-9 && grey == 45.0, "{t} {grey}");
        let (t, grey) = sign
            .hit([0.0, -3.0, 2.35], [1.0, 0.0, 0.0], f64::MAX)
            .unwrap();
        assert!((t - 9.915).abs() < 1e-9 && grey == 50.0, "{t} {grey}");

        // A tree: the crown at its height, the trunk below it.
        let tree = Tree {
            at: (20.0, 0.0),
            trunk_radius: 0.25,
            crown_z: 5.0,
            crown_radii: (2.0, 3.0),
            seed: 3,
        };
        let (t, _) = tree
            .hit([0.0, 0.0, 5.0], [1.0, 0.0, 0.0], f64::MAX)
            .unwrap();
        assert!((t - 18.0).abs() < 1e-9, "{t}");
        let (t, _) = tree
            .hit([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], f64::MAX)
            .unwrap();
        assert!((t - 19.75).abs() < 1e-9, "{t}");
        // Straight up 1 m off the trunk's axis: the crown's underside.
        let (t, _) = tree.hit([21.0, 0.0, 0.0], up, f64::MAX).unwrap();
        assert!((t - (5.0 - 3.0 * (0.75f64).sqrt())).abs() < 1e-9, "{t}");
        assert!(
            tree.hit([0.0, 3.0, 5.0], [1.0, 0.0, 0.0], f64::MAX)
                .is_none()
        );
    }

    #[test]
    fn nearer_structures_hide_farther_ones_and_the_road() {
        let (_, _, scene) = small_town(1);
        let building = Structure::Building(Building {
            block: Block::new((10.0, -15.0), 0.0, (6.0, 5.0), (0.0, 10.0)),
            style: 1,
        });
        let pole = Structure::Pole(Pole {
            at: (10.0, -4.0),
            radius: 0.1,
            height: 7.0,
            shade: 130.0,
            kind: PoleKind::Sign {
                plate: Block::new((10.0, -4.0), 0.0, (0.02, 0.35), (2.0, 2.7)),
                symbol: 1,
            },
        });
        let car = Structure::Car(
            BoxState {
                centre: (12.0, -2.75),
                heading_rad: 0.0,
                size: (2.2, 0.9, 1.5),
                shade: 100.0,
            },
            (0.0, 1.0),
        );
        let o = [10.0, 0.0, 1.0];
        let right = [0.0, -1.0, 0.0];
        // In either order of the list (depth 0: no early stop), the pole in front wins.
        fn all<'a>(list: &[&'a Structure]) -> Vec<(f64, &'a Structure)> {
            list.iter().map(|s| (0.0, *s)).collect()
        }
        let (t, _) = Scene::hit_structure(o, right, &all(&[&building, &pole])).unwrap();
        assert!((t - 3.9).abs() < 1e-9, "{t}");
        let (t, _) = Scene::hit_structure(o, right, &all(&[&pole, &building])).unwrap();
        assert!((t - 3.9).abs() < 1e-9, "{t}");
        let (t, _) = Scene::hit_structure(o, right, &all(&[&building])).unwrap();
        assert!((t - 10.0).abs() < 1e-9, "{t}");
        // Depths in order stop the search at a structure wholly behind the nearest hit.
        let sorted = [(3.8, &pole), (9.9, &building)];
        let (t, _) = Scene::hit_structure(o, right, &sorted).unwrap();
        assert!((t - 3.9).abs() < 1e-9, "{t}");

        // Down towards the road behind the parked car: the car's side, not the road, and the
        // grey level is the car's own through the haze.
        let down = [2.0, -2.0, -0.5];
        let near = all(&[&car]);
        let mut hint = NO_HINT;
        let (t, shade) = Scene::hit_structure(o, down, &near).unwrap();
        let seen = scene.trace(o, down, &[], &near, &mut hint);
        assert!((t - 0.925).abs() < 1e-9, "{t}");
        let norm = (4.0f64 + 4.0 + 0.25).sqrt();
        let fade = (-(t * norm) / HAZE_M).exp();
        assert!((seen - (shade * fade + HAZE_DN * (1.0 - fade))).abs() < 1e-9);
        // Without it, the road.
        let mut hint = NO_HINT;
        let road = scene.trace(o, down, &[], &[], &mut hint);
        assert_ne!(road, seen);
    }

    #[test]
    fn culling_changes_no_pixel() {
        let (_, path, scene) = small_town(2);
        assert!(!scene.structures.is_empty());
        // On a straight, in a turn, and just before the start (structures beside and behind).
        for s in [0.0, 12.0, 60.0, 160.0, 255.0] {
            let mut state = state_at(&path, s);
            state.attitude.roll_rad = 0.02;
            let culled = scene.render_culled(&state, 0, true);
            let all = scene.render_culled(&state, 0, false);
            assert!(culled == all, "at {s} m");
        }
    }

    #[test]
    fn structures_keep_off_our_lane_and_follow_the_seed() {
        let (sc, path, scene) = small_town(1);
        let count = |f: fn(&Structure) -> bool| scene.structures.iter().filter(|s| f(s)).count();
        let buildings = count(|s| matches!(s, Structure::Building(_)));
        let poles = count(|s| matches!(s, Structure::Pole(_)));
        let trees = count(|s| matches!(s, Structure::Tree(_)));
        let cars = count(|s| matches!(s, Structure::Car(..)));
        assert!(
            buildings > 30 && poles > 15 && trees > 20 && cars > 20,
            "{buildings} buildings, {poles} poles, {trees} trees, {cars} cars"
        );
        // From the camera to our lane's centre 8 m ahead: nothing in between, all along the
        // drive (turns included).
        let all: Vec<(f64, &Structure)> = scene.structures.iter().map(|s| (0.0, s)).collect();
        let h = f64::from(sc.mount.height_m);
        let mut s = 0.0;
        while s + 8.0 < path.length_m() {
            let pose = path.pose_at(s);
            let (cx, cy) = pose.to_world(f64::from(sc.mount.x_m), 0.0);
            let (gx, gy) = path
                .pose_at(s + 8.0 + f64::from(sc.mount.x_m))
                .to_world(0.0, 0.0);
            let d = [gx - cx, gy - cy, -h];
            assert!(
                Scene::hit_structure([cx, cy, h], d, &all).is_none(),
                "at {s} m"
            );
            s += 1.0;
        }
        // The same seed places the same things; another seed others.
        let again = small_town(1).2;
        assert_eq!(
            format!("{:?}", scene.structures),
            format!("{:?}", again.structures)
        );
        let other = small_town(2).2;
        assert_ne!(
            format!("{:?}", scene.structures),
            format!("{:?}", other.structures)
        );
        // A scenario without the tables has none.
        let plain = Scenario::built_in("kitti-like").unwrap();
        let plain_path = Path::new(&plain.segments).unwrap();
        assert!(Scene::new(&plain, &plain_path, 1).structures.is_empty());
    }

    #[test]
    fn box_is_hit_from_behind_on_its_back_face() {
        let b = BoxState {
            centre: (10.0, 0.0),
            heading_rad: 0.0,
            size: (2.0, 0.9, 1.5),
            shade: 120.0,
        };
        let (t, _) = b.hit([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]).unwrap();
        assert!((t - 8.0).abs() < 1e-12);
        assert!(b.hit([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]).is_none());
        assert!(b.covers(10.0, 0.5) && !b.covers(13.0, 0.0));
    }
}
