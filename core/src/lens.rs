//! Lens distortion: OpenCV's radial-tangential model (`k1`, `k2`, `p1`, `p2`, `k3` of
//! [`Camera`], as `cv::calibrateCamera` gives them). The core undistorts positions, never
//! images: a corner is found in the frame as the lens drew it, and its position is mapped to the
//! ideal (pinhole) image before it becomes a ray or a point on the road.
//!
//! In normalised coordinates (pixels less the principal point, over the focal length), with
//! `r^2 = x^2 + y^2`, the lens takes the ideal point `(x, y)` to
//!
//! ```text
//! x' = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//! y' = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y
//! ```
//!
//! The inverse has no closed form: [`Camera::undistort`] takes a fixed number of Newton steps,
//! as `cv::undistortPoints` takes a fixed number of fixed-point ones; the same operations on
//! every target, no early exit. With every coefficient zero (the default) nothing is computed
//! and every position passes through untouched, bit for bit.

use crate::projection::{Camera, Pixel};

/// Newton steps of an undistortion: from the distorted point itself, 8 reach a
/// `k1 = -0.3, k2 = 0.1` lens's frame corners to f32's precision.
const NEWTON_STEPS: usize = 8;

/// Largest distance of an undistorted point's distortion from the pixel it came from, pixels
/// (each axis), for the undistortion to stand.
const TOLERANCE_PX: f32 = 0.01;

/// Least Jacobian determinant of the lens's map where an undistorted point lands: below it the
/// lens folds the image (the polynomial model's edge of validity) and the pixel has no
/// trustworthy ray.
const MIN_JACOBIAN: f32 = 1.0e-2;

/// Pixels between the frame's border points whose undistortion bounds the ideal image.
const BORDER_STEP_PX: usize = 4;

/// Points each edge of a polygon is sampled at for its distorted bounds.
const EDGE_SAMPLES: u16 = 64;

/// Margin added to sampled distorted bounds, pixels: a distorted edge bows between its samples.
const SAG_MARGIN_PX: f32 = 1.0;

/// Bounds of a set of image points: lowest and highest (u, v), pixels.
pub type Bounds = ([f32; 2], [f32; 2]);

impl Camera {
    /// Whether every distortion coefficient is zero: frame pixels are pinhole pixels, and
    /// [`undistort`](Self::undistort) and [`distort`](Self::distort) pass them through.
    pub fn is_pinhole(&self) -> bool {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
            .iter()
            .all(|&c| c == 0.0)
    }

    /// The lens's map at ideal normalised `(x, y)`: the distorted normalised point and the
    /// map's Jacobian `[[a, b], [b, d]]` as `[a, b, d]` (it is symmetric).
    fn lens_map(&self, x: f32, y: f32) -> ([f32; 2], [f32; 3]) {
        let (k1, k2, k3, p1, p2) = (self.k1, self.k2, self.k3, self.p1, self.p2);
        let (xx, yy, xy) = (x * x, y * y, x * y);
        let r2 = xx + yy;
        let radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        // d(radial) / d(r^2).
        let slope = k1 + r2 * (2.0 * k2 + r2 * (3.0 * k3));
        let point = [
            x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * xx),
            y * radial + p1 * (r2 + 2.0 * yy) + 2.0 * p2 * xy,
        ];
        let a = radial + 2.0 * xx * slope + 2.0 * p1 * y + 6.0 * p2 * x;
        let b = 2.0 * xy * slope + 2.0 * p1 * x + 2.0 * p2 * y;
        let d = radial + 2.0 * yy * slope + 6.0 * p1 * y + 2.0 * p2 * x;
        (point, [a, b, d])
    }

    /// Where the lens draws the ideal (pinhole) image position `ideal`, pixels. Not checked
    /// against the model's edge of validity: far outside the frame the polynomial folds back.
    pub fn distort(&self, ideal: Pixel) -> Pixel {
        if self.is_pinhole() {
            return ideal;
        }
        let x = (ideal.u_px - self.cx_px) / self.fx_px;
        let y = (ideal.v_px - self.cy_px) / self.fy_px;
        let ([xd, yd], _) = self.lens_map(x, y);
        Pixel {
            u_px: self.cx_px + self.fx_px * xd,
            v_px: self.cy_px + self.fy_px * yd,
        }
    }

    /// The ideal (pinhole) image position of the frame position `px`, pixels: the inverse of
    /// [`distort`](Self::distort) by [`NEWTON_STEPS`] Newton steps. `None` where they do not
    /// reach it within [`TOLERANCE_PX`], or where the lens folds the image there.
    pub fn undistort(&self, px: Pixel) -> Option<Pixel> {
        if self.is_pinhole() {
            return Some(px);
        }
        let xd = (px.u_px - self.cx_px) / self.fx_px;
        let yd = (px.v_px - self.cy_px) / self.fy_px;
        let (mut x, mut y) = (xd, yd);
        for _ in 0..NEWTON_STEPS {
            let ([fx, fy], [a, b, d]) = self.lens_map(x, y);
            let det = a * d - b * b;
            // NaN too: only a positive determinant goes on.
            if det.partial_cmp(&0.0) != Some(core::cmp::Ordering::Greater) {
                return None;
            }
            let (ex, ey) = (fx - xd, fy - yd);
            x -= (d * ex - b * ey) / det;
            y -= (a * ey - b * ex) / det;
        }
        let ([fx, fy], [a, b, d]) = self.lens_map(x, y);
        let near = ((fx - xd) * self.fx_px).abs() <= TOLERANCE_PX
            && ((fy - yd) * self.fy_px).abs() <= TOLERANCE_PX;
        let ideal = Pixel {
            u_px: self.cx_px + self.fx_px * x,
            v_px: self.cy_px + self.fy_px * y,
        };
        let finite = ideal.u_px.is_finite() && ideal.v_px.is_finite();
        (near && a * d - b * b >= MIN_JACOBIAN && finite).then_some(ideal)
    }

    /// Bounds of the ideal (pinhole) image of the frame: of the undistortions of its border's
    /// pixels, every [`BORDER_STEP_PX`] and the corners. `None` where one of them has none:
    /// a lens the model does not invert over the frame.
    pub fn ideal_frame_bounds(&self) -> Option<Bounds> {
        let (w, h) = (usize::from(self.width_px), usize::from(self.height_px));
        let (last_u, last_v) = (w.checked_sub(1)?, h.checked_sub(1)?);
        let across = (0..w)
            .step_by(BORDER_STEP_PX)
            .chain([last_u])
            .flat_map(|u| [(u, 0), (u, last_v)]);
        let down = (0..h)
            .step_by(BORDER_STEP_PX)
            .chain([last_v])
            .flat_map(|v| [(0, v), (last_u, v)]);
        let mut bounds = None;
        for (u, v) in across.chain(down) {
            let px = Pixel {
                u_px: u as f32,
                v_px: v as f32,
            };
            let p = self.undistort(px)?;
            bounds = Some(widen(bounds, [p.u_px, p.v_px]));
        }
        bounds
    }

    /// Bounds of where the lens draws the closed polygon `ideal` (ideal image positions,
    /// pixels, in order round it), each edge sampled at [`EDGE_SAMPLES`] points and the bounds
    /// widened by [`SAG_MARGIN_PX`]; `None` for no point. The polygon should lie within
    /// [`ideal_frame_bounds`](Self::ideal_frame_bounds), where the model holds.
    pub fn distorted_bounds(&self, ideal: &[[f32; 2]]) -> Option<Bounds> {
        let mut bounds = None;
        for (i, &a) in ideal.iter().enumerate() {
            let b = ideal.get(i + 1).or(ideal.first()).copied().unwrap_or(a);
            for s in 0..EDGE_SAMPLES {
                let t = f32::from(s) / f32::from(EDGE_SAMPLES);
                let p = self.distort(Pixel {
                    u_px: a[0] + t * (b[0] - a[0]),
                    v_px: a[1] + t * (b[1] - a[1]),
                });
                if p.u_px.is_finite() && p.v_px.is_finite() {
                    bounds = Some(widen(bounds, [p.u_px, p.v_px]));
                }
            }
        }
        let (lo, hi) = bounds?;
        Some((lo.map(|x| x - SAG_MARGIN_PX), hi.map(|x| x + SAG_MARGIN_PX)))
    }
}

/// `bounds` taking in `p`.
fn widen(bounds: Option<Bounds>, p: [f32; 2]) -> Bounds {
    let (lo, hi) = bounds.unwrap_or((p, p));
    (
        [lo[0].min(p[0]), lo[1].min(p[1])],
        [hi[0].max(p[0]), hi[1].max(p[1])],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// KITTI's camera 0 behind a wide lens's distortion.
    fn wide() -> Camera {
        Camera {
            k1: -0.3,
            k2: 0.1,
            p1: 1.0e-3,
            p2: -5.0e-4,
            k3: 0.0,
            ..crate::config::tests::kitti_config().camera
        }
    }

    #[test]
    fn a_pinhole_passes_every_position_through_bit_for_bit() {
        let k = crate::config::tests::kitti_config().camera;
        assert!(k.is_pinhole());
        let px = Pixel {
            u_px: 12.345,
            v_px: 300.5,
        };
        assert_eq!(k.undistort(px), Some(px));
        assert_eq!(k.distort(px), px);
    }

    #[test]
    fn opencv_model_by_hand() {
        // A point half a focal length right of the principal point: r^2 = 0.25.
        let k = Camera {
            p1: 0.0,
            p2: 0.0,
            ..wide()
        };
        let ideal = Pixel {
            u_px: k.cx_px + 0.5 * k.fx_px,
            v_px: k.cy_px,
        };
        let radial = 1.0 - 0.3 * 0.25 + 0.1 * 0.0625;
        let d = k.distort(ideal);
        assert!(
            (d.u_px - (k.cx_px + 0.5 * radial * k.fx_px)).abs() < 1e-3,
            "{d:?}"
        );
        assert!((d.v_px - k.cy_px).abs() < 1e-3, "{d:?}");
    }

    #[test]
    fn the_frame_of_a_wide_lens_undistorts_outwards() {
        let k = wide();
        let (lo, hi) = k.ideal_frame_bounds().unwrap();
        // Barrel distortion: the ideal image of the frame reaches beyond it.
        assert!(
            lo[0] < -1.0 && hi[0] > f32::from(k.width_px),
            "{lo:?} {hi:?}"
        );
        // A lens that folds within the frame has no inverse there.
        let folding = Camera { k1: -3.0, ..wide() };
        assert_eq!(folding.ideal_frame_bounds(), None);
    }

    proptest! {
        #[test]
        fn undistortion_inverts_distortion_over_the_frame(u in 0.0f32..1240.0, v in 0.0f32..375.0) {
            let k = wide();
            let px = Pixel { u_px: u, v_px: v };
            let ideal = k.undistort(px).unwrap();
            let back = k.distort(ideal);
            prop_assert!((back.u_px - u).abs() < 2e-3 && (back.v_px - v).abs() < 2e-3, "{back:?}");
        }
    }
}
