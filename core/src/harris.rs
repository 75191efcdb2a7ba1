//! Harris corners (paper §2, step 1) in integer arithmetic, inside the image of the ground window
//! only, keeping the strongest few on each side of straight ahead.
//!
//! The region of interest is swept in vertical strips `STRIP` columns wide, each top to bottom,
//! with three-row ring buffers of gradient products and responses: about 3.5 KiB of scratch
//! whatever the frame's width, and every image row is read from the [`Frame`] once per strip
//! and row of the strip's three-row stencil.
//!
//! Per pixel: Sobel gradients (|g| <= 1020), their products (`i32`, a row of each product
//! apart, which the host's compiler vectorises) summed over a 3x3 box as a column's sum down
//! three rows and a sliding sum of three columns (the same integers as a direct 3x3 sum),
//! the response `det - k trace^2` with k = 5/128 in `i64`, stored shifted right by
//! `RESPONSE_SHIFT` as `i32`. A corner is a 3x3 local maximum at or above the configured
//! threshold; a parabola through its neighbours' responses gives its sub-pixel position, which
//! the lens's model then takes to the ideal image ([`crate::lens`]; untouched without
//! distortion).

use crate::config::{DETECTOR_BORDER_PX, ValidConfig, inside_border};
use crate::frame::Frame;
use crate::projection::{Camera, GroundPoint, Pixel};
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
const BORDER: u16 = DETECTOR_BORDER_PX;
const _: () = assert!(
    BORDER == 3,
    "the line buffers below read three rows and columns around"
);

/// A detected corner. Ordered by response first, so heaps keep the strongest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Corner {
    /// Harris response, in units of (Sobel gradient)^4 / 2^16.
    pub response: i32,
    /// Row, pixels, sub-pixel: in the ideal (pinhole) image once [`detect`] returns it (the
    /// frame's row for a camera without distortion).
    pub v_px: I16F16,
    /// Column, pixels, sub-pixel: in the ideal image, as the row.
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

    /// The corner at its ideal (pinhole) image position through `camera`'s lens (itself,
    /// untouched, for a pinhole camera); `None` where the position has none.
    pub fn undistorted(self, camera: &Camera) -> Option<Self> {
        if camera.is_pinhole() {
            return Some(self);
        }
        let px = camera.undistort(self.pixel())?;
        Some(Self {
            u_px: I16F16::checked_from_num(px.u_px)?,
            v_px: I16F16::checked_from_num(px.v_px)?,
            ..self
        })
    }
}

/// The corners of one frame: the `K` strongest (at most `features_per_side`) on each side of the
/// camera's look direction, as seen on the ground.
#[derive(Clone, Debug)]
pub struct Corners<const K: usize> {
    /// Left of straight ahead.
    pub left: BinaryHeap<Corner, Min, K>,
    /// Right of straight ahead.
    pub right: BinaryHeap<Corner, Min, K>,
}

impl<const K: usize> Corners<K> {
    /// No corners; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            left: BinaryHeap::new(),
            right: BinaryHeap::new(),
        }
    }

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

impl<const K: usize> Default for Corners<K> {
    fn default() -> Self {
        Self::new()
    }
}

/// Line buffers for [`detect`]; they hold nothing between frames.
#[derive(Clone, Debug)]
pub struct HarrisScratch {
    /// The three image rows a gradient row reads, strip columns plus three each side; zero
    /// beyond a short row's end.
    pixels: [[u8; STRIP + 6]; 3],
    /// Gradient products (gx gx, gy gy, gx gy) of three rows, strip columns plus two each side.
    prod: [[[i32; STRIP + 4]; 3]; 3],
    /// Responses of three rows, strip columns plus one each side.
    resp: [[i32; STRIP + 2]; 3],
}

impl HarrisScratch {
    /// Zeroed line buffers; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            pixels: [[0; STRIP + 6]; 3],
            prod: [[[0; STRIP + 4]; 3]; 3],
            resp: [[0; STRIP + 2]; 3],
        }
    }
}

impl Default for HarrisScratch {
    fn default() -> Self {
        Self::new()
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
    let Some((left, right)) = inside_border(roi.left_px, roi.right_px, frame.width()) else {
        return;
    };
    let limit = usize::from(cfg.settings().features_per_side);
    let threshold = i32::try_from(cfg.settings().corner_threshold).unwrap_or(i32::MAX);
    let mut x0 = left;
    while x0 <= right {
        let x1 = (x0 + STRIP as u16 - 1).min(right);
        // Only the rows where the strip meets the window's image: the corners outside it are
        // not kept (see `side`), and the rows are read with their border around them, so the
        // corners inside are those of the whole rectangle, bit for bit.
        let rows = cfg
            .roi_rows(x0, x1)
            .and_then(|(top, bottom)| inside_border(top, bottom, frame.height()));
        let Some((top, bottom)) = rows else {
            x0 = x1 + 1;
            continue;
        };
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
    let camera = &cfg.config().camera;
    // At most a strip: the bound also lets the compiler drop the buffers' index checks.
    let ncols = (usize::from(x1 - x0) + 1).min(STRIP);
    for yg in top - 2..=bottom + 2 {
        // Sobel gradients of row yg, columns x0-2 ..= x1+2.
        for (dy, span) in scratch.pixels.iter_mut().enumerate() {
            let row = frame.row(yg - 1 + dy as u16);
            let src = row.get(gx0 - 1..).unwrap_or(&[]);
            let n = src.len().min(span.len());
            let (head, tail) = span.split_at_mut(n);
            head.copy_from_slice(src.get(..n).unwrap_or(&[]));
            tail.fill(0);
        }
        let [above, here, below] = &scratch.pixels;
        let [xx, yy, xy] = &mut scratch.prod[usize::from(yg) % 3];
        // Column i's stencil is pixels i..i+3 of each row: every index is bounded by the
        // arrays', so the compiler drops the checks and vectorises the loop.
        let products = xx.iter_mut().zip(yy.iter_mut()).zip(xy.iter_mut());
        for (i, ((xx, yy), xy)) in products.enumerate().take(ncols + 4) {
            let px = |row: &[u8; STRIP + 6], k: usize| i32::from(row[i + k]);
            let gx = px(above, 2) + 2 * px(here, 2) + px(below, 2)
                - px(above, 0)
                - 2 * px(here, 0)
                - px(below, 0);
            let gy = px(below, 0) + 2 * px(below, 1) + px(below, 2)
                - px(above, 0)
                - 2 * px(above, 1)
                - px(above, 2);
            *xx = gx * gx;
            *yy = gy * gy;
            *xy = gx * gy;
        }
        if yg < top {
            continue;
        }
        // Responses of row yr = yg - 1, columns x0-1 ..= x1+1: the ring holds rows yr-1..=yr+1,
        // and their order does not matter to a sum.
        let yr = yg - 1;
        // Each column's products summed down the three rows once, three such columns summed
        // across as the row is swept.
        let [p0, p1, p2] = &scratch.prod;
        let down =
            |i: usize| -> [i32; 3] { core::array::from_fn(|ch| p0[ch][i] + p1[ch][i] + p2[ch][i]) };
        let resp = &mut scratch.resp[usize::from(yr) % 3];
        let (mut left, mut middle) = (down(0), down(1));
        for (i, r) in resp.iter_mut().enumerate().take(ncols + 2) {
            let right = down(i + 2);
            let [sxx, syy, sxy]: [i32; 3] =
                core::array::from_fn(|ch| left[ch] + middle[ch] + right[ch]);
            // Sums reach 9 * 1020^2, the trace twice that: i32. Products widen to i64 (one
            // 32x32->64 multiply each on a Cortex-M).
            let trace = i64::from(sxx + syy);
            let det = i64::from(sxx) * i64::from(syy) - i64::from(sxy) * i64::from(sxy);
            let value = det - ((K_NUM * (trace * trace)) >> K_SHIFT);
            *r = (value >> RESPONSE_SHIFT).clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
            (left, middle) = (middle, right);
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
        // Column i of the strip is entry i + 1 of the rows: the middle of window i.
        let windows = up.windows(3).zip(mid.windows(3)).zip(down.windows(3));
        for (i, ((up, mid), down)) in windows.take(ncols).enumerate() {
            let (&[ul, uc, ur], &[ml, r, mr], &[dl, dc, dr]) = (up, mid, down) else {
                continue;
            };
            if r < threshold {
                continue;
            }
            // Strict against earlier neighbours, not later ones: one peak per plateau.
            let is_max =
                r > ul && r > uc && r > ur && r > ml && r >= mr && r >= dl && r >= dc && r >= dr;
            if !is_max {
                continue;
            }
            let u = I16F16::from_num(usize::from(x0) + i) + parabola_peak(ml, r, mr);
            let v = I16F16::from_num(yn) + parabola_peak(uc, r, dc);
            let corner = Corner {
                response: r,
                v_px: v,
                u_px: u,
            };
            let Some(corner) = corner.undistorted(camera) else {
                continue;
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
    let w = cfg.settings();
    let inside = ahead_m >= w.window_near_m
        && ahead_m <= w.window_far_m
        && left_m.abs() <= w.window_half_width_m;
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

    /// A frame that notes the first and last rows asked of it.
    struct Recording<'a> {
        inner: SliceFrame<'a>,
        asked: core::cell::Cell<(u16, u16)>,
    }

    impl Frame for Recording<'_> {
        fn width(&self) -> u16 {
            self.inner.width()
        }
        fn height(&self) -> u16 {
            self.inner.height()
        }
        fn row(&self, y: u16) -> &[u8] {
            let (lo, hi) = self.asked.get();
            self.asked.set((lo.min(y), hi.max(y)));
            self.inner.row(y)
        }
    }

    #[test]
    fn detection_reads_exactly_rows_read() {
        for far_m in [12.0, 20.0] {
            let mut c = kitti_config();
            c.settings.window_far_m = far_m;
            // The ground window's rows alone: the whole image's heading reads every row.
            c.settings.image_heading = false;
            let cfg = c.validate().unwrap();
            let img = frame_with_squares(&cfg, &[GroundPoint { x_m: 8.0, y_m: 1.0 }], 6);
            let f = Recording {
                inner: SliceFrame::new(&img, 1241, 376, 1241).unwrap(),
                asked: core::cell::Cell::new((u16::MAX, 0)),
            };
            detect(
                &f,
                &cfg,
                &mut HarrisScratch::new(),
                &mut Corners::<32>::new(),
            );
            let rows = cfg.rows_read();
            assert!(rows.start > 150 && rows.end <= 376, "{rows:?}");
            assert_eq!(f.asked.get(), (rows.start, rows.end - 1));
        }
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
        c.settings.features_per_side = 2;
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
            c.camera = Camera {
                width_px: 80, height_px: 60, fx_px: 60.0, fy_px: 60.0, cx_px: 40.0, cy_px: 30.0,
                ..Camera::DEFAULT
            };
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
