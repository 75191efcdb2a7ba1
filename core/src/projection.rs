//! Camera geometry (paper §2.1): intrinsics, the camera's mount on the vehicle, and the ground-plane
//! homographies that map between pixels and points on the road.
//!
//! Frames (BRIEF §3): the vehicle frame has its origin on the ground under the centre of the rear
//! axle, x forward, y left, z up. The camera frame has x right, y down, z forward. A pixel
//! `(u, v)` has u to the right and v down.
//!
//! The body of the vehicle rolls and pitches on its suspension; the camera is fixed to the body.
//! That body attitude is modelled as a rotation about the camera's centre (its height over the
//! road is taken as fixed: a 1 deg pitch about the rear axle moves a camera 1.5 m ahead of it by
//! 2.6 cm, well inside the uncertainty the attitude itself causes).
//!
//! Homographies are built in `f64` once per configuration and stored as `f32`: the per-frame path
//! only multiplies 3x3 matrices.

use crate::frame::ImageSize;
use crate::setting::settings;
use nalgebra::{ArrayStorage, Matrix3, Vector3};

settings! {
    /// The camera: its frames' size, its pinhole intrinsics and its lens distortion (OpenCV's
    /// radial-tangential model, [`crate::lens`]; all zero for a rectified, undistorted image), a
    /// mount file's `[camera]` section.
    pub struct Camera {
        /// Columns of a frame, pixels.
        width_px: u16 = val(0) required, min 1 => "width_px";
        /// Rows of a frame, pixels.
        height_px: u16 = val(0) required, min 1 => "height_px";
        /// Horizontal focal length, pixels.
        fx_px: f32 = val(0.0) required, above 0.0, max 100000.0 => "fx_px";
        /// Vertical focal length, pixels.
        fy_px: f32 = val(0.0) required, above 0.0, max 100000.0 => "fy_px";
        /// Principal point, column, pixels.
        cx_px: f32 = val(0.0) required, min -100000.0, max 100000.0 => "cx_px";
        /// Principal point, row, pixels.
        cy_px: f32 = val(0.0) required, min -100000.0, max 100000.0 => "cy_px";
        /// Lens distortion: OpenCV's first radial coefficient `k1` (of r^2, r the distance from
        /// the principal point in focal lengths), no unit; 0: none (negative: barrel).
        k1: f32 = val(0.0), min -10.0, max 10.0 => "k1";
        /// Lens distortion: OpenCV's second radial coefficient `k2` (of r^4), no unit.
        k2: f32 = val(0.0), min -100.0, max 100.0 => "k2";
        /// Lens distortion: OpenCV's first tangential coefficient `p1`, no unit.
        p1: f32 = val(0.0), min -1.0, max 1.0 => "p1";
        /// Lens distortion: OpenCV's second tangential coefficient `p2`, no unit.
        p2: f32 = val(0.0), min -1.0, max 1.0 => "p2";
        /// Lens distortion: OpenCV's third radial coefficient `k3` (of r^6), no unit.
        k3: f32 = val(0.0), min -1000.0, max 1000.0 => "k3";
    }
}

impl Camera {
    /// The KITTI odometry benchmark's camera 0 on sequences 00 to 02 (their calib.txt's `P0`,
    /// 1241x376, rectified): the reference camera of the tests, the fuzz targets and the
    /// firmware example's default configuration.
    pub const KITTI_00: Self = Self {
        width_px: 1241,
        height_px: 376,
        fx_px: 718.856,
        fy_px: 718.856,
        cx_px: 607.1928,
        cy_px: 185.2157,
        ..Self::DEFAULT
    };

    /// The size of its frames.
    pub fn image(&self) -> ImageSize {
        ImageSize {
            width_px: self.width_px,
            height_px: self.height_px,
        }
    }

    /// A camera of frames of `image` and the intrinsics of a KITTI `P0` projection matrix (3x4,
    /// row-major: `fx 0 cx tx; 0 fy cy ty; 0 0 1 0`). The fourth column (a stereo baseline, zero
    /// for camera 0) is ignored.
    pub fn from_kitti_p0(image: ImageSize, p: &[f32; 12]) -> Self {
        Self {
            width_px: image.width_px,
            height_px: image.height_px,
            fx_px: p[0],
            fy_px: p[5],
            cx_px: p[2],
            cy_px: p[6],
            ..Self::DEFAULT
        }
    }

    fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(
            f64::from(self.fx_px),
            0.0,
            f64::from(self.cx_px),
            0.0,
            f64::from(self.fy_px),
            f64::from(self.cy_px),
            0.0,
            0.0,
            1.0,
        )
    }
}

settings! {
    /// Where and how the camera sits on the vehicle (its extrinsics), in the vehicle frame: a
    /// mount file's `[mount]` section.
    pub struct Mount {
        /// Camera centre ahead of the rear-axle centre, metres (negative: behind it).
        x_m: f32 = val(0.0) required, min -50.0, max 50.0 => "x_m";
        /// Camera centre left of the vehicle's centre line, metres.
        y_m: f32 = val(0.0), min -10.0, max 10.0 => "y_m";
        /// Camera centre above the road, metres.
        height_m: f32 = val(0.0) required, above 0.0, max 20.0 => "height_m";
        /// Yaw of the optical axis, counter-clockwise from the vehicle's x axis seen from above
        /// (a rear-facing camera: 180 deg).
        yaw_rad: f32 = deg(0.0), min -360.0, max 360.0 => "yaw_deg";
        /// Pitch of the optical axis, positive looking up (the paper's -20 deg looks down).
        pitch_rad: f32 = deg(0.0), min -90.0, max 90.0 => "pitch_deg";
        /// Roll about the optical axis: a right-handed turn about the forward axis, so a
        /// positive roll lifts the camera's left side.
        roll_rad: f32 = deg(0.0), min -180.0, max 180.0 => "roll_deg";
    }
}

/// Attitude of the vehicle body relative to the road, from suspension travel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Attitude {
    /// Body pitch, radians, positive nose up.
    pub pitch_rad: f32,
    /// Body roll, radians, positive left side up.
    pub roll_rad: f32,
}

/// A point on the ground plane (z = 0) in the vehicle frame, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GroundPoint {
    /// Forward of the rear-axle centre, metres.
    pub x_m: f32,
    /// Left of the vehicle's centre line, metres.
    pub y_m: f32,
}

impl GroundPoint {
    /// The rear-axle centre.
    pub const ORIGIN: Self = Self { x_m: 0.0, y_m: 0.0 };

    /// The point `dx_m` further ahead: the same point measured from an origin `dx_m` further
    /// back along the vehicle's axis.
    pub fn moved_ahead(self, dx_m: f32) -> Self {
        Self {
            x_m: self.x_m + dx_m,
            ..self
        }
    }
}

/// An image position, pixels (u right, v down; pixel centres at integer coordinates).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Pixel {
    /// Column, pixels.
    pub u_px: f32,
    /// Row, pixels.
    pub v_px: f32,
}

fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn rot_y(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = (libm::sin(a), libm::cos(a));
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

impl Mount {
    /// Rotation taking camera-frame vectors into the vehicle frame (its columns are the camera's
    /// right, down and forward axes in vehicle coordinates), with the body at `attitude`.
    pub fn rotation_vehicle_from_camera(&self, attitude: Attitude) -> Matrix3<f64> {
        // Columns: camera x (right) = -y_v, camera y (down) = -z_v, camera z (forward) = x_v.
        let axes = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
        // Pitch up is a negative turn about y (left): it takes x towards +z.
        let body = rot_y(-f64::from(attitude.pitch_rad)) * rot_x(f64::from(attitude.roll_rad));
        let mount = rot_z(f64::from(self.yaw_rad))
            * rot_y(-f64::from(self.pitch_rad))
            * rot_x(f64::from(self.roll_rad));
        body * mount * axes
    }

    /// The camera's turn about the vehicle's vertical, radians, that a radian more of its roll
    /// gives it: the roll is about the optical axis, which a camera pitched down points below
    /// the horizontal, so part of it turns the camera left or right (the sine of the pitch:
    /// a third of it on the paper's rig pitched 20 deg down, none on a level camera).
    pub fn yaw_per_roll(&self) -> f32 {
        libm::sinf(self.pitch_rad)
    }

    /// Where the camera stands over the road, metres, in the vehicle frame.
    pub fn ground_point(&self) -> GroundPoint {
        GroundPoint {
            x_m: self.x_m,
            y_m: self.y_m,
        }
    }

    /// Camera centre in the vehicle frame, metres.
    pub fn position_vehicle(&self) -> Vector3<f64> {
        Vector3::new(
            f64::from(self.x_m),
            f64::from(self.y_m),
            f64::from(self.height_m),
        )
    }
}

/// Nearest depth along the optical axis that still projects, metres.
const MIN_DEPTH_M: f32 = 1.0e-3;

/// Smallest homogeneous scale accepted as "in front of the camera" (1 / depth in metres): points
/// farther than 10 km are treated as on the horizon.
const MIN_INVERSE_DEPTH: f32 = 1.0e-4;

/// The ground-plane homography of one camera attitude and its inverse.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Homography {
    ground_to_image: Matrix3<f32>,
    image_to_ground: Matrix3<f32>,
}

impl Homography {
    /// All zeros: no mapping. The placeholder of an unconfigured odometer.
    pub(crate) const ZERO: Self = Self {
        ground_to_image: Matrix3::from_array_storage(ArrayStorage([[0.0; 3]; 3])),
        image_to_ground: Matrix3::from_array_storage(ArrayStorage([[0.0; 3]; 3])),
    };

    /// The homography for a camera `camera` on `mount`, the body at `attitude`. `None`
    /// where the ground plane is seen edge-on (the camera lies in the plane of the road).
    pub fn new(camera: &Camera, mount: &Mount, attitude: Attitude) -> Option<Self> {
        let r_cv = mount.rotation_vehicle_from_camera(attitude).transpose();
        let t = -(r_cv * mount.position_vehicle());
        // Ground points have z = 0: the third column of R drops out (paper eq. 5).
        let rt = Matrix3::from_columns(&[r_cv.column(0).into(), r_cv.column(1).into(), t]);
        let h = camera.matrix() * rt;
        let g = h.try_inverse()?;
        let finite = h.iter().chain(g.iter()).all(|x| x.is_finite());
        finite.then(|| Self {
            ground_to_image: h.cast::<f32>(),
            image_to_ground: g.cast::<f32>(),
        })
    }

    /// Depth of a ground point along the optical axis, metres (negative behind the camera).
    pub fn depth_m(&self, p: GroundPoint) -> f32 {
        self.ground_to_image
            .row(2)
            .dot(&Vector3::new(p.x_m, p.y_m, 1.0).transpose())
    }

    /// Projects a ground point to the image. `None` behind the camera or on its horizon.
    pub fn project(&self, p: GroundPoint) -> Option<Pixel> {
        let q = self.ground_to_image * Vector3::new(p.x_m, p.y_m, 1.0);
        // q.z is the point's depth along the optical axis, metres.
        (q.z > MIN_DEPTH_M).then(|| Pixel {
            u_px: q.x / q.z,
            v_px: q.y / q.z,
        })
    }

    /// Backprojects a pixel onto the ground. `None` at or above the horizon (the pixel's ray never
    /// meets the road in front of the camera).
    pub fn backproject(&self, px: Pixel) -> Option<GroundPoint> {
        let g = self.image_to_ground * Vector3::new(px.u_px, px.v_px, 1.0);
        // g.z is the inverse depth of the ground point: positive in front of the camera.
        (g.z > MIN_INVERSE_DEPTH).then(|| GroundPoint {
            x_m: g.x / g.z,
            y_m: g.y / g.z,
        })
    }
}

/// Where a pixel seen with the body rolled would lie had the body been level in roll, at any
/// pitch. The body's attitude turns the camera about its centre, so the map is the image
/// rotation `K Q K^-1` with `Q` the roll seen in camera axes; and since the body rolls before it
/// pitches, `Q` does not depend on the pitch: one map per roll serves every pitch hypothesis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RollMap {
    rolled_to_level: Matrix3<f32>,
}

impl RollMap {
    /// No map: the placeholder of an unconfigured odometer.
    pub(crate) const ZERO: Self = Self {
        rolled_to_level: Matrix3::from_array_storage(ArrayStorage([[0.0; 3]; 3])),
    };

    /// No roll: every pixel maps to itself.
    pub const IDENTITY: Self = Self {
        rolled_to_level: Matrix3::from_array_storage(ArrayStorage([
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ])),
    };

    /// The map for a body rolled by `roll_rad` (positive: left side up).
    pub fn new(camera: &Camera, mount: &Mount, roll_rad: f32) -> Option<Self> {
        if roll_rad == 0.0 {
            // Exactly: a level body's pixels go through untouched, not through K K^-1's
            // rounding (which would also change the paper method's results, and it has no roll).
            return Some(Self::IDENTITY);
        }
        let level = mount.rotation_vehicle_from_camera(Attitude::default());
        let rolled = mount.rotation_vehicle_from_camera(Attitude {
            pitch_rad: 0.0,
            roll_rad,
        });
        let k = camera.matrix();
        let m = k * level.transpose() * rolled * k.try_inverse()?;
        m.iter().all(|x| x.is_finite()).then(|| Self {
            rolled_to_level: m.cast::<f32>(),
        })
    }

    /// The pixel a level body would have seen; `None` if it lies on the horizon of the turn.
    pub fn apply(&self, px: Pixel) -> Option<Pixel> {
        let q = self.rolled_to_level * Vector3::new(px.u_px, px.v_px, 1.0);
        (q.z.abs() > f32::EPSILON).then(|| Pixel {
            u_px: q.x / q.z,
            v_px: q.y / q.z,
        })
    }
}

/// A convex quadrilateral on the ground in the vehicle frame: where a corner may lie given the
/// body attitude bounds (paper §2.1, the observation uncertainty region).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quad {
    /// Corners in order around the boundary.
    pub corners: [GroundPoint; 4],
}

/// Whether the corners of `b` all lie beyond one of `a`'s edges (seen along its normal).
fn separated(a: &Quad, b: &Quad) -> bool {
    (0..4).any(|k| {
        let (p, q) = (a.corners[k], a.corners[(k + 1) % 4]);
        let (nx, ny) = (p.y_m - q.y_m, q.x_m - p.x_m);
        let span = |quad: &Quad| {
            quad.corners
                .iter()
                .fold((f32::MAX, f32::MIN), |(lo, hi), c| {
                    let d = nx * c.x_m + ny * c.y_m;
                    (lo.min(d), hi.max(d))
                })
        };
        let ((alo, ahi), (blo, bhi)) = (span(a), span(b));
        ahi < blo || bhi < alo
    })
}

impl Quad {
    /// Whether two convex quadrilaterals overlap (touching counts): the separating-axis test
    /// over both quadrilaterals' edge normals.
    pub fn overlaps(&self, other: &Quad) -> bool {
        !(separated(self, other) || separated(other, self))
    }

    /// The mean of the corners: the paper's best position estimate for the feature.
    pub fn centroid(&self) -> GroundPoint {
        let (sx, sy) = self
            .corners
            .iter()
            .fold((0.0, 0.0), |(x, y), c| (x + c.x_m, y + c.y_m));
        GroundPoint {
            x_m: sx * 0.25,
            y_m: sy * 0.25,
        }
    }
}

/// The nominal homography and the four of the extremal body attitudes (pitch +-P, roll +-R),
/// computed once per configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundProjection {
    /// The body level on its suspension.
    pub nominal: Homography,
    /// Attitudes (+P, +R), (+P, -R), (-P, -R), (-P, +R): in this order the four backprojections of
    /// a pixel go round their quadrilateral.
    pub extremes: [Homography; 4],
}

impl GroundProjection {
    /// Builds the five homographies; `None` if any is degenerate.
    pub fn new(camera: &Camera, mount: &Mount, bounds: Attitude) -> Option<Self> {
        let at = |p: f32, r: f32| {
            Homography::new(
                camera,
                mount,
                Attitude {
                    pitch_rad: p,
                    roll_rad: r,
                },
            )
        };
        let (p, r) = (bounds.pitch_rad, bounds.roll_rad);
        Some(Self {
            nominal: at(0.0, 0.0)?,
            extremes: [at(p, r)?, at(p, -r)?, at(-p, -r)?, at(-p, r)?],
        })
    }

    /// The observation uncertainty region of a pixel; `None` if the pixel is at or above the
    /// horizon under any of the extremal attitudes.
    pub fn observe(&self, px: Pixel) -> Option<Quad> {
        let [a, b, c, d] = &self.extremes;
        Some(Quad {
            corners: [
                a.backproject(px)?,
                b.backproject(px)?,
                c.backproject(px)?,
                d.backproject(px)?,
            ],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const DEG: f32 = core::f32::consts::PI / 180.0;

    /// The KITTI camera 0 of the shared test configuration.
    fn kitti() -> (Camera, Mount) {
        let c = crate::config::tests::kitti_config();
        (c.camera, c.mount)
    }

    #[test]
    fn level_camera_sees_ground_point_below_principal_point() {
        let (k, m) = kitti();
        let h = Homography::new(&k, &m, Attitude::default()).unwrap();
        // 10 m ahead of the camera on the centre line: row cy + f * h / d.
        let px = h
            .project(GroundPoint {
                x_m: 11.0,
                y_m: 0.0,
            })
            .unwrap();
        assert!((px.u_px - 607.1928).abs() < 1e-3);
        assert!((px.v_px - (185.2157 + 718.856 * 0.165)).abs() < 1e-3);
        // A point to the left appears left of the principal point.
        let left = h
            .project(GroundPoint {
                x_m: 11.0,
                y_m: 1.0,
            })
            .unwrap();
        assert!(left.u_px < px.u_px);
        // Behind the camera: no image.
        assert!(h.project(GroundPoint { x_m: 0.5, y_m: 0.0 }).is_none());
        // Above the horizon: no ground point.
        let sky = Pixel {
            u_px: 600.0,
            v_px: 100.0,
        };
        assert!(h.backproject(sky).is_none());
    }

    #[test]
    fn quads_overlap_unless_an_edge_separates_them() {
        let sq = |x: f32, y: f32| Quad {
            corners: [
                GroundPoint { x_m: x, y_m: y },
                GroundPoint {
                    x_m: x + 1.0,
                    y_m: y,
                },
                GroundPoint {
                    x_m: x + 1.0,
                    y_m: y + 1.0,
                },
                GroundPoint {
                    x_m: x,
                    y_m: y + 1.0,
                },
            ],
        };
        assert!(sq(0.0, 0.0).overlaps(&sq(0.5, 0.5)));
        assert!(sq(0.0, 0.0).overlaps(&sq(1.0, 0.0)));
        assert!(!sq(0.0, 0.0).overlaps(&sq(1.5, 0.0)));
        // A diamond beside the square's corner: only the diamond's edge separates them.
        let diamond = Quad {
            corners: [
                GroundPoint { x_m: 1.6, y_m: 1.0 },
                GroundPoint { x_m: 2.2, y_m: 1.6 },
                GroundPoint { x_m: 1.6, y_m: 2.2 },
                GroundPoint { x_m: 1.0, y_m: 1.6 },
            ],
        };
        assert!(!sq(0.0, 0.0).overlaps(&diamond));
    }

    #[test]
    fn rear_camera_sees_behind_the_vehicle() {
        let (k, mut m) = kitti();
        m.x_m = -1.0;
        m.yaw_rad = core::f32::consts::PI;
        m.pitch_rad = -20.0 * DEG;
        let h = Homography::new(&k, &m, Attitude::default()).unwrap();
        let px = h
            .project(GroundPoint {
                x_m: -6.0,
                y_m: 0.0,
            })
            .unwrap();
        assert!((px.u_px - 607.1928).abs() < 1e-2);
        // Seen from behind, a point on the vehicle's left is on the image's right.
        let left = h
            .project(GroundPoint {
                x_m: -6.0,
                y_m: 1.0,
            })
            .unwrap();
        assert!(left.u_px > px.u_px);
        assert!(h.project(GroundPoint { x_m: 6.0, y_m: 0.0 }).is_none());
    }

    #[test]
    fn pitching_up_moves_backprojection_away() {
        let (k, m) = kitti();
        let level = Homography::new(&k, &m, Attitude::default()).unwrap();
        let up = Homography::new(
            &k,
            &m,
            Attitude {
                pitch_rad: 1.0 * DEG,
                roll_rad: 0.0,
            },
        )
        .unwrap();
        let px = level.project(GroundPoint { x_m: 9.0, y_m: 0.0 }).unwrap();
        // Nose up: the same pixel looks at the ground farther away.
        assert!(up.backproject(px).unwrap().x_m > 9.0);
    }

    #[test]
    fn observation_quad_contains_the_true_point_and_grows_with_distance() {
        let (k, m) = kitti();
        let bounds = Attitude {
            pitch_rad: 1.0 * DEG,
            roll_rad: 2.0 * DEG,
        };
        let gp = GroundProjection::new(&k, &m, bounds).unwrap();
        let extent = |x: f32| {
            let px = gp
                .nominal
                .project(GroundPoint { x_m: x, y_m: 0.5 })
                .unwrap();
            let q = gp.observe(px).unwrap();
            let xs = q.corners.map(|c| c.x_m);
            let lo = xs.iter().copied().fold(f32::MAX, f32::min);
            let hi = xs.iter().copied().fold(f32::MIN, f32::max);
            assert!(lo < x && x < hi, "{lo} < {x} < {hi}");
            hi - lo
        };
        // BRIEF §7: about +-0.4 m at 6 m and +-1.5 m at 12 m (camera to point distance).
        let near = extent(7.0);
        let far = extent(13.0);
        assert!(near > 0.5 && near < 1.2, "{near}");
        assert!(far > 2.0 && far < 4.5, "{far}");
    }

    proptest! {
        #[test]
        fn a_roll_map_then_the_level_homography_is_the_rolled_homography(
            pitch in -2.0f32..2.0,
            body_pitch in -1.0f32..1.0,
            body_roll in -2.0f32..2.0,
            x in 6.0f32..14.0,
            y in -3.0f32..3.0,
        ) {
            let (k, mut m) = kitti();
            m.pitch_rad = pitch * DEG;
            let rolled = Attitude { pitch_rad: body_pitch * DEG, roll_rad: body_roll * DEG };
            let level = Attitude { pitch_rad: body_pitch * DEG, roll_rad: 0.0 };
            let p = GroundPoint { x_m: x, y_m: y };
            let px = Homography::new(&k, &m, rolled).unwrap().project(p).unwrap();
            let map = RollMap::new(&k, &m, body_roll * DEG).unwrap();
            let back = Homography::new(&k, &m, level).unwrap().backproject(map.apply(px).unwrap()).unwrap();
            prop_assert!((back.x_m - x).abs() < 2e-3 && (back.y_m - y).abs() < 2e-3, "{back:?}");
        }

        #[test]
        fn backprojection_inverts_projection(
            x in 2.5f32..13.0, y in -3.0f32..3.0,
            pitch in -25.0f32..5.0, roll in -3.0f32..3.0, yaw in -10.0f32..10.0,
            height in 1.0f32..3.0,
            body_pitch in -1.0f32..1.0, body_roll in -2.0f32..2.0,
        ) {
            let (k, mut m) = kitti();
            m.pitch_rad = pitch * DEG;
            m.roll_rad = roll * DEG;
            m.yaw_rad = yaw * DEG;
            m.height_m = height;
            let att = Attitude { pitch_rad: body_pitch * DEG, roll_rad: body_roll * DEG };
            let h = Homography::new(&k, &m, att).unwrap();
            let p = GroundPoint { x_m: m.x_m + x, y_m: y };
            if let Some(px) = h.project(p) {
                let back = h.backproject(px).unwrap();
                prop_assert!((back.x_m - p.x_m).abs() < 1e-3, "{:?} -> {:?}", p, back);
                prop_assert!((back.y_m - p.y_m).abs() < 1e-3, "{:?} -> {:?}", p, back);
            }
        }
    }
}
