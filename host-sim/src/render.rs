//! The renderer behind `roadvo simulate`: every pixel is ray-cast into a procedural scene, with
//! several samples per pixel for anti-aliasing and sensor noise on top.
//!
//! The scene: a road laid along the drive's path (our lane centred on it, a second lane to its
//! left, painted edge and centre lines), asphalt carrying random patches whose corners a Harris
//! detector finds, grass verges, haze towards a visible horizon and a sky gradient, optional
//! raised kerb and crowned surface, and optional boxes driving along the road. Everything is a
//! pure function of world position and the seed, so frames render independently and in parallel.

use crate::path::{Path, WorldPose};
use crate::scenario::{Crown, Kerb, Scenario};
use image::GrayImage;
use roadvo::{Attitude, Camera, Mount};

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
    let (fx, fy) = (x.floor(), y.floor());
    let (ix, iy) = (fx as i64, fy as i64);
    let (tx, ty) = (x - fx, y - fy);
    let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
    let v = |dx: i64, dy: i64| unit(hash(ix + dx, iy + dy, seed, salt), 0);
    let top = v(0, 0) + (v(1, 0) - v(0, 0)) * sx;
    let bottom = v(0, 1) + (v(1, 1) - v(0, 1)) * sx;
    top + (bottom - top) * sy
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
        Self {
            samples,
            origin,
            cells_x,
            cells_y,
            cell_start: counts,
            items,
        }
    }

    /// (arc length, lateral offset positive left) of the nearest path point, for points within
    /// `CELL_M` of the path; `None` farther away. The cells index every `COARSE`-th sample; the
    /// nearest of those is refined among its fine neighbours.
    ///
    /// Tries the fine samples around `hint` first the fine samples around `hint` (the sample found
    /// for a neighbouring ray): where their distance has a minimum inside that stretch, within
    /// `HINT_REACH_M`, it is taken without the cell search. `hint` is updated.
    fn locate(&self, x: f64, y: f64, hint: &mut usize) -> Option<(f64, f64)> {
        let d2 = |i: usize| {
            let p = &self.samples[i];
            (x - p[0]).powi(2) + (y - p[1]).powi(2)
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
            if interior && nearest.0 < HINT_REACH_M * HINT_REACH_M {
                *hint = nearest.1;
                return Some(self.offsets(x, y, nearest.1));
            }
        }
        let cx = ((x - self.origin.0) / CELL_M).floor() as i64;
        let cy = ((y - self.origin.1) / CELL_M).floor() as i64;
        let mut best = (f64::MAX, 0usize);
        for gy in (cy - 1).max(0)..=(cy + 1).min(self.cells_y - 1) {
            for gx in (cx - 1).max(0)..=(cx + 1).min(self.cells_x - 1) {
                let c = (gy * self.cells_x + gx) as usize;
                let run = self.cell_start[c] as usize..self.cell_start[c + 1] as usize;
                for &i in &self.items[run] {
                    let d = d2(i as usize);
                    if d < best.0 {
                        best = (d, i as usize);
                    }
                }
            }
        }
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
        let (s, c) = self.heading_rad.sin_cos();
        let (ox, oy) = (o[0] - self.centre.0, o[1] - self.centre.1);
        let lo = [c * ox + s * oy, -s * ox + c * oy, o[2]];
        let ld = [c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]];
        let (hl, hw, h) = self.size;
        let bounds = [(-hl, hl), (-hw, hw), (CLEARANCE_M, h)];
        let (mut t0, mut t1, mut axis) = (0.0f64, f64::MAX, 0usize);
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
                axis = k;
            }
            t1 = t1.min(b);
            if t0 > t1 {
                return None;
            }
        }
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
        let (s, c) = self.heading_rad.sin_cos();
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
    camera: Camera,
    mount: Mount,
    width: u32,
    height: u32,
    supersample: u32,
    noise_dn: f64,
    lane_width_m: f64,
    patch_probability: f64,
    bare_half_width_m: f64,
    seed: u64,
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
        Self {
            index: PathIndex::new(path),
            surface: Surface {
                kerb: scenario.kerb.clone(),
                crown: scenario.crown.clone(),
            },
            camera: cfg.camera,
            mount: cfg.mount,
            width: u32::from(cfg.camera.width_px),
            height: u32::from(cfg.camera.height_px),
            supersample: u32::from(scenario.render.supersample),
            noise_dn: scenario.render.noise_dn,
            lane_width_m: scenario.render.lane_width_m,
            patch_probability: (0.6 * scenario.render.texture_density).min(1.0),
            bare_half_width_m: scenario.render.bare_half_width_m,
            seed,
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
        let (fx, fy) = ((x / PATCH_CELL_M).floor(), (y / PATCH_CELL_M).floor());
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

    /// Grey level seen along one ray.
    fn trace(&self, o: [f64; 3], d: [f64; 3], boxes: &[BoxState], hint: &mut usize) -> f64 {
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let elevation = d[2] / norm;
        let sky = HAZE_DN - 45.0 * (elevation * 4.0).clamp(0.0, 1.0);
        let nearest_box = boxes
            .iter()
            .filter_map(|b| b.hit(o, d))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let ground = (d[2] < 0.0).then(|| self.hit_ground(o, d, hint));
        let (t, value) = match (ground, nearest_box) {
            (Some((tg, _)), Some((tb, shade))) if tb < tg => (tb, shade),
            (None, Some((tb, shade))) => (tb, shade),
            (Some((tg, sl)), _) => {
                let (x, y) = (o[0] + tg * d[0], o[1] + tg * d[1]);
                let mut g = self.ground(x, y, sl);
                if boxes.iter().any(|b| b.covers(x, y)) {
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
        let k = &self.camera;
        let (fx, fy) = (f64::from(k.fx_px), f64::from(k.fy_px));
        let (px, py) = (f64::from(k.cx_px), f64::from(k.cy_px));
        let n = self.supersample;
        let inv_n = 1.0 / f64::from(n);
        let frame_salt = mix(self.seed ^ 0x5eed ^ index.wrapping_mul(0x2545_f491_4f6c_dd1d));
        // Neighbouring rays meet the road near each other: carry the path sample along.
        let mut hint = NO_HINT;
        GrayImage::from_fn(self.width, self.height, |u, v| {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    // Pixel centres sit at integer coordinates.
                    let su = f64::from(u) - 0.5 + (f64::from(i) + 0.5) * inv_n;
                    let sv = f64::from(v) - 0.5 + (f64::from(j) + 0.5) * inv_n;
                    let dc = [(su - px) / fx, (sv - py) / fy, 1.0];
                    let d = std::array::from_fn(|r| {
                        rot[r][0] * dc[0] + rot[r][1] * dc[1] + rot[r][2] * dc[2]
                    });
                    sum += self.trace(o, d, &state.boxes, &mut hint);
                }
            }
            let mean = sum * inv_n * inv_n;
            // Gaussian sensor noise by Box-Muller from the pixel's own hash.
            let h = hash(i64::from(u), i64::from(v), frame_salt, 7);
            let (a, b) = (unit(h, 0).max(1e-12), unit(h, 1));
            let noise = (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos();
            image::Luma([(mean + self.noise_dn * noise).round().clamp(0.0, 255.0) as u8])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::Segment;

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
