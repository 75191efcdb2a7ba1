//! The renderer's view through the camera's lens: each sample's ray is that of its undistorted
//! position, and a volume's pixel rectangle is where the lens draws its pinhole image. Without
//! distortion both are the pinhole camera's own, computed as before, bit for bit.

use roadvo::{Camera, Pixel};

/// Rays and screen rectangles of one camera.
#[derive(Clone, Copy, Debug)]
pub struct LensRays {
    camera: Camera,
    /// Bounds of the frame's ideal (pinhole) image, pixels; `None` for a pinhole camera (or a
    /// lens the model does not invert over the frame, which validation refuses).
    ideal_bounds: Option<([f32; 2], [f32; 2])>,
}

impl LensRays {
    /// The view of `camera`.
    pub fn new(camera: Camera) -> Self {
        let ideal_bounds = if camera.is_pinhole() {
            None
        } else {
            camera.ideal_frame_bounds()
        };
        Self {
            camera,
            ideal_bounds,
        }
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The ray (camera frame, z = 1) of the frame position (`u`, `v`), pixels; `None` where the
    /// lens gives it none.
    pub fn ray(&self, u: f64, v: f64) -> Option<[f64; 3]> {
        let k = &self.camera;
        let (fx, fy) = (f64::from(k.fx_px), f64::from(k.fy_px));
        let (px, py) = (f64::from(k.cx_px), f64::from(k.cy_px));
        if k.is_pinhole() {
            return Some([(u - px) / fx, (v - py) / fy, 1.0]);
        }
        let ideal = k.undistort(Pixel {
            u_px: u as f32,
            v_px: v as f32,
        })?;
        Some([
            (f64::from(ideal.u_px) - px) / fx,
            (f64::from(ideal.v_px) - py) / fy,
            1.0,
        ])
    }

    /// The frame's rectangle (lowest and highest u, v; pixels, unclipped) holding what the
    /// pinhole image within `lo..hi` looks like through the lens; `None` where none of it is
    /// in the frame's ideal image.
    pub fn seen(&self, lo: [f64; 2], hi: [f64; 2]) -> Option<([f64; 2], [f64; 2])> {
        let Some((flo, fhi)) = self.ideal_bounds else {
            return Some((lo, hi));
        };
        // Cut to the frame's ideal image, where the model holds.
        let lo = [lo[0].max(f64::from(flo[0])), lo[1].max(f64::from(flo[1]))];
        let hi = [hi[0].min(f64::from(fhi[0])), hi[1].min(f64::from(fhi[1]))];
        if lo[0] > hi[0] || lo[1] > hi[1] {
            return None;
        }
        let corner = |u: f64, v: f64| [u as f32, v as f32];
        let rect = [
            corner(lo[0], lo[1]),
            corner(hi[0], lo[1]),
            corner(hi[0], hi[1]),
            corner(lo[0], hi[1]),
        ];
        let (dlo, dhi) = self.camera.distorted_bounds(&rect)?;
        Some((dlo.map(f64::from), dhi.map(f64::from)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(k1: f32, k2: f32) -> Camera {
        Camera {
            width_px: 320,
            height_px: 200,
            fx_px: 250.0,
            fy_px: 250.0,
            cx_px: 160.0,
            cy_px: 100.0,
            k1,
            k2,
            ..Camera::DEFAULT
        }
    }

    #[test]
    fn a_barrel_lens_bends_rays_outwards_and_draws_rectangles_inwards() {
        let (pin, wide) = (
            LensRays::new(camera(0.0, 0.0)),
            LensRays::new(camera(-0.3, 0.1)),
        );
        let (a, b) = (
            pin.ray(300.0, 190.0).unwrap(),
            wide.ray(300.0, 190.0).unwrap(),
        );
        assert!(b[0] > a[0] && b[1] > a[1], "{a:?} {b:?}");
        assert_eq!(
            pin.seen([0.0, 0.0], [10.0, 10.0]),
            Some(([0.0, 0.0], [10.0, 10.0]))
        );
        let (lo, _) = wide.seen([-50.0, -50.0], [100.0, 100.0]).unwrap();
        assert!(lo[0] > -50.0 && lo[1] > -50.0, "{lo:?}");
    }
}
