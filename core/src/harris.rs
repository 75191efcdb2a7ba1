//! Harris corners (paper §2, step 1) in integer arithmetic, inside the image of the ground window
//! only, keeping the strongest few on each side of straight ahead.
//!
//! The region of interest is swept in vertical strips `STRIP` columns wide, each top to bottom,
//! with three-row ring buffers of gradients and responses: about 1.6 KiB of scratch whatever the
//! frame's width, and every image row is read straight from the [`Frame`].
//!
//! Per pixel: Sobel gradients (|g| <= 1020, `i16`), their products summed over a 3x3 box (`i32`),
//! the response `det - k trace^2` with k = 5/128 in `i64`, stored shifted right by
//! `RESPONSE_SHIFT` as `i32`. A corner is a 3x3 local maximum at or above the configured
//! threshold; a parabola through its neighbours' responses gives its sub-pixel position.

use crate::config::ValidConfig;
use crate::frame::Frame;
use crate::projection::{GroundPoint, Pixel};
use fixed::types::I16F16;
use heapless::binary_heap::{BinaryHeap, Min};

/// Columns per strip.
const STRIP: usize = 64;
/// Harris k = K_NUM / 2^K_SHIFT = 0.039.
const K_NUM: i64 = 5;
const K_SHIFT: u32 = 7;
/// Responses are stored divided by 2^RESPONSE_SHIFT: the largest (9 * 1020^2)^2 / 2^16 fits i32.
const RESPONSE_SHIFT: u32 = 16;
/// Corners keep this far from the frame's edge, pixels: Sobel, box sum and suppression each
/// need one more pixel around.
const BORDER: u16 = 3;

/// A detected corner. Ordered by response first, so heaps keep the strongest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Corner {
    /// Harris response, in units of (Sobel gradient)^4 / 2^16.
    pub response: i32,
    /// Row, pixels, sub-pixel.
    pub v_px: I16F16,
    /// Column, pixels, sub-pixel.
    pub u_px: I16F16,
}

impl Corner {
    /// The corner's position as a [`Pixel`].
    pub fn pixel(&self) -> Pixel {
        Pixel {
            u_px: self.u_px.to_num(),
            v_px: self.v_px.to_num(),
        }
    }
}

/// The corners of one frame: the `K` strongest (at most `features_per_side`) on each side of the
/// camera's look direction, as seen on the ground.
#[derive(Clone, Debug, Default)]
pub struct Corners<const K: usize> {
    /// Left of straight ahead.
    pub left: BinaryHeap<Corner, Min, K>,
    /// Right of straight ahead.
    pub right: BinaryHeap<Corner, Min, K>,
}

impl<const K: usize> Corners<K> {
    /// Empties both sides.
    pub fn clear(&mut self) {
        self.left.clear();
        self.right.clear();
    }

    /// Corners found, both sides.
    pub fn len(&self) -> usize {
        self.left.len() + self.right.len()
    }

    /// Whether no corner was found.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// All corners, left side first, each side in heap order.
    pub fn iter(&self) -> impl Iterator<Item = &Corner> {
        self.left.iter().chain(self.right.iter())
    }
}

/// Line buffers for [`detect`]; they hold nothing between frames.
#[derive(Clone, Debug)]
pub struct HarrisScratch {
    /// Sobel (gx, gy) of three rows, strip columns plus two each side.
    grad: [[[i16; 2]; STRIP + 4]; 3],
    /// Responses of three rows, strip columns plus one each side.
    resp: [[i32; STRIP + 2]; 3],
}

impl Default for HarrisScratch {
    fn default() -> Self {
        Self {
            grad: [[[0; 2]; STRIP + 4]; 3],
            resp: [[0; STRIP + 2]; 3],
        }
    }
}

/// Keeps `c` if it is among the `limit` strongest of `heap`.
fn offer<const K: usize>(heap: &mut BinaryHeap<Corner, Min, K>, c: Corner, limit: usize) {
    if heap.len() < limit.min(K) {
        // Cannot fail: below capacity.
        let _ = heap.push(c);
    } else if heap.peek().is_some_and(|weakest| c > *weakest) {
        let _ = heap.pop();
        let _ = heap.push(c);
    }
}

/// Sub-pixel offset of a parabola's peak through three responses, in [-0.5, 0.5].
fn parabola_peak(before: i32, at: i32, after: i32) -> I16F16 {
    let (b, a, f) = (i64::from(before), i64::from(at), i64::from(after));
    let curvature = b - 2 * a + f;
    if curvature >= 0 {
        return I16F16::ZERO;
    }
    // (b - f) / (2 curvature), in 1/65536 pixel, clamped to half a pixel.
    let num = (b - f) << 16;
    let q = num / (2 * curvature);
    I16F16::from_bits(q.clamp(-(1 << 15), 1 << 15) as i32)
}

/// Finds the corners of `frame` inside the ground window of `cfg` into `out` (cleared first).
pub fn detect<F: Frame + ?Sized, const K: usize>(
    frame: &F,
    cfg: &ValidConfig,
    scratch: &mut HarrisScratch,
    out: &mut Corners<K>,
) {
    out.clear();
    let roi = cfg.roi();
    let (w, h) = (frame.width(), frame.height());
    if w <= 2 * BORDER || h <= 2 * BORDER {
        return;
    }
    let top = roi.top_px.max(BORDER);
    let bottom = roi.bottom_px.min(h - 1 - BORDER);
    let left = roi.left_px.max(BORDER);
    let right = roi.right_px.min(w - 1 - BORDER);
    if top > bottom || left > right {
        return;
    }
    let limit = usize::from(cfg.config().features_per_side);
    let threshold = i32::try_from(cfg.config().corner_threshold).unwrap_or(i32::MAX);
    let mut x0 = left;
    while x0 <= right {
        let x1 = (x0 + STRIP as u16 - 1).min(right);
        strip(
            frame,
            cfg,
            scratch,
            out,
            (x0, x1),
            (top, bottom),
            threshold,
            limit,
        );
        x0 = x1 + 1;
    }
}

/// One strip: columns `x0..=x1`, rows `top..=bottom`, all at least `BORDER` inside the frame.
#[allow(clippy::too_many_arguments)]
fn strip<F: Frame + ?Sized, const K: usize>(
    frame: &F,
    cfg: &ValidConfig,
    scratch: &mut HarrisScratch,
    out: &mut Corners<K>,
    (x0, x1): (u16, u16),
    (top, bottom): (u16, u16),
    threshold: i32,
    limit: usize,
) {
    let gx0 = usize::from(x0) - 2;
    let ncols = usize::from(x1 - x0) + 1;
    for yg in top - 2..=bottom + 2 {
        // Sobel gradients of row yg, columns x0-2 ..= x1+2.
        let (above, here, below) = (frame.row(yg - 1), frame.row(yg), frame.row(yg + 1));
        let px = |row: &[u8], x: usize| i32::from(row.get(x).copied().unwrap_or(0));
        let slot = &mut scratch.grad[usize::from(yg) % 3];
        for (i, g) in slot.iter_mut().take(ncols + 4).enumerate() {
            let x = gx0 + i;
            let gx = px(above, x + 1) + 2 * px(here, x + 1) + px(below, x + 1)
                - px(above, x - 1)
                - 2 * px(here, x - 1)
                - px(below, x - 1);
            let gy = px(below, x - 1) + 2 * px(below, x) + px(below, x + 1)
                - px(above, x - 1)
                - 2 * px(above, x)
                - px(above, x + 1);
            // |g| <= 4 * 255: fits i16.
            *g = [gx as i16, gy as i16];
        }
        if yg < top {
            continue;
        }
        // Responses of row yr = yg - 1, columns x0-1 ..= x1+1.
        let yr = yg - 1;
        let rows = [
            &scratch.grad[usize::from(yr - 1) % 3],
            &scratch.grad[usize::from(yr) % 3],
            &scratch.grad[usize::from(yr + 1) % 3],
        ];
        let resp = &mut scratch.resp[usize::from(yr) % 3];
        for (i, r) in resp.iter_mut().take(ncols + 2).enumerate() {
            let (mut sxx, mut syy, mut sxy) = (0i32, 0i32, 0i32);
            for row in rows {
                for g in &row[i..i + 3] {
                    let (gx, gy) = (i32::from(g[0]), i32::from(g[1]));
                    sxx += gx * gx;
                    syy += gy * gy;
                    sxy += gx * gy;
                }
            }
            let (sxx, syy, sxy) = (i64::from(sxx), i64::from(syy), i64::from(sxy));
            let trace = sxx + syy;
            let value = sxx * syy - sxy * sxy - ((K_NUM * trace * trace) >> K_SHIFT);
            *r = (value >> RESPONSE_SHIFT).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
        }
        if yr <= top {
            continue;
        }
        // Non-maximum suppression on row yn = yr - 1.
        let yn = yr - 1;
        let (up, mid, down) = (
            &scratch.resp[usize::from(yn - 1) % 3],
            &scratch.resp[usize::from(yn) % 3],
            &scratch.resp[usize::from(yn + 1) % 3],
        );
        for i in 1..=ncols {
            let r = mid[i];
            if r < threshold {
                continue;
            }
            // Strict against earlier neighbours, not later ones: one peak per plateau.
            let is_max = r > up[i - 1]
                && r > up[i]
                && r > up[i + 1]
                && r > mid[i - 1]
                && r >= mid[i + 1]
                && r >= down[i - 1]
                && r >= down[i]
                && r >= down[i + 1];
            if !is_max {
                continue;
            }
            let u = I16F16::from_num(usize::from(x0) + i - 1)
                + parabola_peak(mid[i - 1], r, mid[i + 1]);
            let v = I16F16::from_num(yn) + parabola_peak(up[i], r, down[i]);
            let corner = Corner {
                response: r,
                v_px: v,
                u_px: u,
            };
            let Some(ground) = cfg.projection().nominal.backproject(corner.pixel()) else {
                continue;
            };
            match side(cfg, ground) {
                Some(Side::Left) => offer(&mut out.left, corner, limit),
                Some(Side::Right) => offer(&mut out.right, corner, limit),
                None => {}
            }
        }
    }
}

enum Side {
    Left,
    Right,
}

/// Which side of straight ahead a ground point lies, if it is inside the window.
fn side(cfg: &ValidConfig, p: GroundPoint) -> Option<Side> {
    let (ahead_m, left_m) = cfg.window_coords(p);
    let w = &cfg.config().window;
    let inside = ahead_m >= w.near_m && ahead_m <= w.far_m && left_m.abs() <= w.half_width_m;
    inside.then_some(if left_m >= 0.0 {
        Side::Left
    } else {
        Side::Right
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::kitti_config;
    use crate::frame::SliceFrame;
    use crate::projection::GroundPoint;
    use proptest::prelude::*;
    use std::vec;
    use std::vec::Vec;

    /// A KITTI-size frame of flat grey with bright squares at ground points.
    fn frame_with_squares(cfg: &ValidConfig, squares: &[GroundPoint], half_px: i32) -> Vec<u8> {
        let (w, h) = (1241usize, 376usize);
        let mut img = vec![90u8; w * h];
        for g in squares {
            let p = cfg.projection().nominal.project(*g).unwrap();
            let (cu, cv) = (p.u_px.round() as i32, p.v_px.round() as i32);
            for v in cv - half_px..cv + half_px {
                for u in cu - half_px..cu + half_px {
                    if (0..h as i32).contains(&v) && (0..w as i32).contains(&u) {
                        img[v as usize * w + u as usize] = 200;
                    }
                }
            }
        }
        img
    }

    #[test]
    fn finds_the_corners_of_a_square_on_each_side() {
        let cfg = kitti_config().validate().unwrap();
        let squares = [
            GroundPoint { x_m: 8.0, y_m: 1.0 },
            GroundPoint {
                x_m: 8.0,
                y_m: -1.0,
            },
        ];
        let img = frame_with_squares(&cfg, &squares, 6);
        let f = SliceFrame::new(&img, 1241, 376, 1241).unwrap();
        let mut out = Corners::<32>::default();
        detect(&f, &cfg, &mut HarrisScratch::default(), &mut out);
        assert_eq!((out.left.len(), out.right.len()), (4, 4), "{out:?}");
        // Each corner sits within a pixel of a square's corner.
        for c in out.iter() {
            let p = c.pixel();
            let near = squares.iter().any(|g| {
                let q = cfg.projection().nominal.project(*g).unwrap();
                let (du, dv) = (
                    (p.u_px - q.u_px.round()).abs(),
                    (p.v_px - q.v_px.round()).abs(),
                );
                (du - 6.0).abs() < 1.5 && (dv - 6.0).abs() < 1.5
            });
            assert!(near, "{p:?}");
        }
    }

    #[test]
    fn keeps_only_the_strongest_per_side() {
        let mut c = kitti_config();
        c.features_per_side = 2;
        let cfg = c.validate().unwrap();
        let squares = [
            GroundPoint { x_m: 8.0, y_m: 1.0 },
            GroundPoint { x_m: 9.0, y_m: 2.0 },
            GroundPoint {
                x_m: 8.5,
                y_m: -1.5,
            },
        ];
        let img = frame_with_squares(&cfg, &squares, 5);
        let f = SliceFrame::new(&img, 1241, 376, 1241).unwrap();
        let mut out = Corners::<8>::default();
        detect(&f, &cfg, &mut HarrisScratch::default(), &mut out);
        assert_eq!((out.left.len(), out.right.len()), (2, 2));
    }

    #[test]
    fn ignores_corners_outside_the_ground_window() {
        let cfg = kitti_config().validate().unwrap();
        // 5 m to the side: inside the image, outside the 3 m lateral cutoff.
        let img = frame_with_squares(&cfg, &[GroundPoint { x_m: 9.0, y_m: 5.0 }], 6);
        let f = SliceFrame::new(&img, 1241, 376, 1241).unwrap();
        let mut out = Corners::<32>::default();
        detect(&f, &cfg, &mut HarrisScratch::default(), &mut out);
        assert!(out.is_empty(), "{out:?}");
    }

    #[test]
    fn parabola_peak_is_half_a_pixel_at_most() {
        assert_eq!(parabola_peak(10, 20, 10), I16F16::ZERO);
        assert!(parabola_peak(10, 20, 18) > I16F16::ZERO);
        let off = parabola_peak(19, 20, 0);
        assert!(
            off > I16F16::from_num(-0.46) && off < I16F16::from_num(-0.45),
            "{off}"
        );
        assert_eq!(parabola_peak(20, 20, 0), I16F16::from_num(-0.5));
        assert_eq!(parabola_peak(5, 5, 5), I16F16::ZERO);
    }

    proptest! {
        #[test]
        fn any_frame_content_and_size_is_safe(
            w in 0u16..80, h in 0u16..60, seed in any::<u64>(), short in any::<bool>(),
        ) {
            // A small camera pitched down, so that small frames hold its window.
            let mut c = kitti_config();
            c.image = crate::config::ImageSize { width_px: 80, height_px: 60 };
            c.intrinsics = crate::projection::Intrinsics { fx_px: 60.0, fy_px: 60.0, cx_px: 40.0, cy_px: 30.0 };
            c.mount.pitch_rad = -15.0 * core::f32::consts::PI / 180.0;
            let cfg = c.validate().unwrap();
            let n = usize::from(w) * usize::from(h);
            let mut x = seed | 1;
            let img: Vec<u8> = (0..n).map(|_| { x ^= x << 13; x ^= x >> 7; x ^= x << 17; x as u8 }).collect();
            // A frame whose rows may be shorter than it claims.
            let stride = if short { usize::from(w / 2) } else { usize::from(w) };
            let data = &img[..(stride * usize::from(h)).min(img.len())];
            struct Odd<'a> { d: &'a [u8], w: u16, h: u16, s: usize }
            impl Frame for Odd<'_> {
                fn width(&self) -> u16 { self.w }
                fn height(&self) -> u16 { self.h }
                fn row(&self, y: u16) -> &[u8] {
                    let a = usize::from(y) * self.s;
                    self.d.get(a..a + self.s).unwrap_or(&[])
                }
            }
            let mut out = Corners::<4>::default();
            detect(&Odd { d: data, w, h, s: stride }, &cfg, &mut HarrisScratch::default(), &mut out);
            prop_assert!(out.len() <= 8);
        }
    }
}
