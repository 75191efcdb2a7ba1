//! The ground window (paper §4, Figure 14) and its image: where on the road corners are looked
//! for, the image rectangle that holds it, and the rows of a frame the odometer reads.
//!
//! Distances in the window are measured from the point on the road under the camera, along the
//! camera's yaw, so the same window serves a rear-facing camera.

use super::ValidConfig;
use crate::projection::{Camera, GroundPoint};

/// Smallest width and height of the image region of interest, pixels.
pub const MIN_ROI_PX: u16 = 8;

/// Pixels the corner detector reads around each pixel it scores (Sobel, box sum, suppression).
pub const DETECTOR_BORDER_PX: u16 = 3;

/// The image rectangle that holds the ground window, pixels, inclusive bounds. Detection reads
/// only these rows and columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImageRoi {
    /// First column.
    pub left_px: u16,
    /// Last column.
    pub right_px: u16,
    /// First row (the far cutoff).
    pub top_px: u16,
    /// Last row (the near cutoff or the image's bottom).
    pub bottom_px: u16,
}

impl ImageRoi {
    /// No pixels: the placeholder of an unconfigured odometer.
    pub(crate) const ZERO: Self = Self {
        left_px: 0,
        right_px: 0,
        top_px: 0,
        bottom_px: 0,
    };
}

/// The ground window's image: its bounding rectangle and the polygon itself, clipped to the frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WindowImage {
    pub(crate) roi: ImageRoi,
    polygon: Polygon,
}

impl WindowImage {
    pub(crate) const ZERO: Self = Self {
        roi: ImageRoi::ZERO,
        polygon: Polygon::EMPTY,
    };

    /// The window's image for `cfg` (whose own window image is not set yet). `None` when the far
    /// end of the window is not visible, or when its pixel backprojects above the horizon under
    /// one of the extremal attitudes.
    pub(crate) fn of(cfg: &ValidConfig) -> Option<Self> {
        let s = &cfg.config.settings;
        let camera = &cfg.config.camera;
        let (max_u, max_v) = (
            f32::from(camera.width_px - 1),
            f32::from(camera.height_px - 1),
        );
        let proj = &cfg.projection;
        let far_px = proj
            .nominal
            .project(cfg.window_point(s.window_far_m, 0.0))?;
        let far_seen = camera.distort(far_px);
        let inside =
            (0.0..=max_u).contains(&far_seen.u_px) && (0.0..=max_v).contains(&far_seen.v_px);
        if !inside || proj.observe(far_px).is_none() {
            return None;
        }
        // The window rectangle, cut to the part in front of the camera, projected, cut to the
        // frame: its image is convex, so clipping by half-planes is exact.
        let mut ground = Polygon::default();
        for (ahead, left) in [
            (s.window_near_m, -1.0),
            (s.window_far_m, -1.0),
            (s.window_far_m, 1.0),
            (s.window_near_m, 1.0),
        ] {
            let p = cfg.window_point(ahead, left * s.window_half_width_m);
            ground.push([p.x_m, p.y_m]);
        }
        let seen =
            ground.clip(|[x, y]| proj.nominal.depth_m(GroundPoint { x_m: x, y_m: y }) - 0.01);
        let mut image = Polygon::default();
        for &[x, y] in seen.points() {
            let px = proj.nominal.project(GroundPoint { x_m: x, y_m: y })?;
            image.push([px.u_px, px.v_px]);
        }
        if !camera.is_pinhole() {
            image = Self::through_lens(camera, &image)?;
        }
        let image = image
            .clip(|[u, _]| u)
            .clip(|[u, _]| max_u - u)
            .clip(|[_, v]| v)
            .clip(|[_, v]| max_v - v);
        // Not empty: it holds the far end's pixel, inside the frame.
        let (lo, hi) = image.bounds()?;
        // Rounding outwards; the casts cannot wrap, the values lie in the frame.
        let roi = ImageRoi {
            left_px: libm::floorf(lo[0]) as u16,
            right_px: libm::ceilf(hi[0]) as u16,
            top_px: libm::floorf(lo[1]) as u16,
            bottom_px: libm::ceilf(hi[1]) as u16,
        };
        Some(Self {
            roi,
            polygon: image,
        })
    }
}

impl WindowImage {
    /// The rectangle of the frame that holds the window's ideal (pinhole) image `ideal` as the
    /// lens draws it: `ideal` cut to the ideal image of the frame, where the lens model holds,
    /// and the bounds of its distorted edges (the lens bows them: conservatively, the
    /// rectangle and not the curved shape). `None` if the lens does not invert over the frame.
    fn through_lens(camera: &Camera, ideal: &Polygon) -> Option<Polygon> {
        let (lo, hi) = camera.ideal_frame_bounds()?;
        let seen = ideal
            .clip(|[u, _]| u - lo[0])
            .clip(|[u, _]| hi[0] - u)
            .clip(|[_, v]| v - lo[1])
            .clip(|[_, v]| hi[1] - v);
        let (lo, hi) = camera.distorted_bounds(seen.points())?;
        let mut rect = Polygon::default();
        for p in [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]] {
            rect.push(p);
        }
        Some(rect)
    }
}

impl ValidConfig {
    /// The image rectangle holding the ground window.
    pub fn roi(&self) -> ImageRoi {
        self.window.roi
    }

    /// The rows of the region of interest where a point within a pixel of the columns
    /// `left_px..=right_px` can lie in the ground window's image: the window's image is a
    /// trapezoid, narrower at the far end than its bounding rectangle, so that a band of columns
    /// off the centre holds fewer of its rows. `None` if the band misses the window.
    pub fn roi_rows(&self, left_px: u16, right_px: u16) -> Option<(u16, u16)> {
        let (lo, hi) = (f32::from(left_px) - 1.0, f32::from(right_px) + 1.0);
        let band = self
            .window
            .polygon
            .clip(|[u, _]| u - lo)
            .clip(|[u, _]| hi - u);
        let ([_, top], [_, bottom]) = band.bounds()?;
        let roi = self.window.roi;
        // A pixel's corner may sit half a pixel off it: one pixel of margin, outwards.
        let top = (libm::floorf(top - 1.0).max(0.0) as u16).max(roi.top_px);
        let bottom = (libm::ceilf(bottom + 1.0).max(0.0) as u16).min(roi.bottom_px);
        (top <= bottom).then_some((top, bottom))
    }

    /// Whether the whole image's stage runs: the pitch vote with `image_heading`. It reads every
    /// row, and its model and pairs fit the road's plane.
    pub fn whole_image(&self) -> bool {
        let s = &self.config.settings;
        s.image_heading && s.method == crate::Method::PitchVote
    }

    /// The rows of each frame the odometer reads: every row with the whole image's stage
    /// ([`whole_image`](Self::whole_image)), else the region of interest and the corner
    /// detector's border. A camera need deliver no others.
    pub fn rows_read(&self) -> core::ops::Range<u16> {
        if self.whole_image() {
            return 0..self.config.camera.height_px;
        }
        let roi = self.window.roi;
        match inside_border(roi.top_px, roi.bottom_px, self.config.camera.height_px) {
            Some((top, bottom)) => top - DETECTOR_BORDER_PX..bottom + DETECTOR_BORDER_PX + 1,
            None => 0..0,
        }
    }

    /// A ground point of the window's own frame (`ahead_m` along the camera's look direction from
    /// the point under the camera, `left_m` to its left) in the vehicle frame.
    pub fn window_point(&self, ahead_m: f32, left_m: f32) -> GroundPoint {
        let m = &self.config.mount;
        let (s, c) = (libm::sinf(m.yaw_rad), libm::cosf(m.yaw_rad));
        GroundPoint {
            x_m: m.x_m + c * ahead_m - s * left_m,
            y_m: m.y_m + s * ahead_m + c * left_m,
        }
    }

    /// A ground point (vehicle frame) in the window's own frame: (metres ahead of the camera
    /// along its look direction, metres to the left of it).
    pub fn window_coords(&self, p: GroundPoint) -> (f32, f32) {
        let m = &self.config.mount;
        let (s, c) = (libm::sinf(m.yaw_rad), libm::cosf(m.yaw_rad));
        let (dx, dy) = (p.x_m - m.x_m, p.y_m - m.y_m);
        (c * dx + s * dy, -s * dx + c * dy)
    }

    /// Whether a ground point (vehicle frame) lies inside the ground window.
    pub fn in_window(&self, p: GroundPoint) -> bool {
        let s = &self.config.settings;
        let (ahead, left) = self.window_coords(p);
        ahead >= s.window_near_m && ahead <= s.window_far_m && left.abs() <= s.window_half_width_m
    }
}

/// `lo..=hi` clipped to the pixels at least [`DETECTOR_BORDER_PX`] inside `0..len`; `None` if
/// nothing is left.
pub(crate) fn inside_border(lo: u16, hi: u16, len: u16) -> Option<(u16, u16)> {
    const B: u16 = DETECTOR_BORDER_PX;
    if len <= 2 * B {
        return None;
    }
    let (lo, hi) = (lo.max(B), hi.min(len - 1 - B));
    (lo <= hi).then_some((lo, hi))
}

/// A small convex polygon for clipping: four corners, each half-plane cut adds at most one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Polygon {
    points: [[f32; 2]; 8],
    len: usize,
}

impl Polygon {
    const EMPTY: Self = Self {
        points: [[0.0; 2]; 8],
        len: 0,
    };

    /// The lowest and highest coordinates of the corners, `None` when there are none.
    fn bounds(&self) -> Option<([f32; 2], [f32; 2])> {
        let (first, rest) = self.points().split_first()?;
        let (mut lo, mut hi) = (*first, *first);
        for p in rest {
            for ((lo, hi), &x) in lo.iter_mut().zip(hi.iter_mut()).zip(p) {
                (*lo, *hi) = (lo.min(x), hi.max(x));
            }
        }
        Some((lo, hi))
    }

    fn points(&self) -> &[[f32; 2]] {
        &self.points[..self.len.min(self.points.len())]
    }

    fn push(&mut self, p: [f32; 2]) {
        if let Some(slot) = self.points.get_mut(self.len) {
            *slot = p;
            self.len += 1;
        }
    }

    /// Sutherland-Hodgman: keeps the part where `side(p) >= 0`.
    fn clip(&self, side: impl Fn([f32; 2]) -> f32) -> Polygon {
        let mut out = Polygon::default();
        let pts = self.points();
        for (i, &a) in pts.iter().enumerate() {
            let b = pts[(i + 1) % pts.len()];
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 {
                out.push(a);
            }
            if (sa >= 0.0) != (sb >= 0.0) {
                let t = sa / (sa - sb);
                out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        out
    }
}
