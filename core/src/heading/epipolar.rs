//! The planar motion between two frames as the camera sees it, and how far a correspondence
//! lies from it.
//!
//! The vehicle turns by the heading change `alpha` about its vertical axis and, on its
//! suspension, pitches by `pitch` and rolls by `roll` (radians); it travels a distance in a
//! direction given by its azimuth, half the heading change (the arc's chord) plus `azimuth`,
//! and its `elevation`. A point seen by the camera at ray `x1` in the first frame and `x2` in the
//! second then satisfies `x2' E x1 = 0` whatever its depth, with `E = [t]x R` the essential
//! matrix of the camera's rotation `R` and translation `t` (rotation about the vertical moves
//! every point of the image alike, whatever the mount's pitch, roll or height, so the heading
//! needs no calibration of the ground plane). The Sampson distance is the correspondence's
//! distance from that constraint in the image, to first order.

use nalgebra::{Matrix3, Vector3};

/// The motion's parameters, radians.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Params {
    /// Heading change, counter-clockwise.
    pub alpha: f32,
    /// Change of the body's pitch, nose up.
    pub pitch: f32,
    /// Change of the body's roll, left side up.
    pub roll: f32,
    /// Direction of travel against the arc's chord, to the left.
    pub azimuth: f32,
    /// Direction of travel above the vehicle's horizontal.
    pub elevation: f32,
}

impl Params {
    /// Parameters in a fixed order, for the refinement.
    pub fn to_array(self) -> [f32; 5] {
        [
            self.alpha,
            self.pitch,
            self.roll,
            self.azimuth,
            self.elevation,
        ]
    }

    /// From [`to_array`](Self::to_array)'s order.
    pub fn from_array(a: [f32; 5]) -> Self {
        Self {
            alpha: a[0],
            pitch: a[1],
            roll: a[2],
            azimuth: a[3],
            elevation: a[4],
        }
    }
}

/// Least slope below the vehicle's horizontal of a ray taken to meet the road (about 1 in
/// 100: 165 m ahead for a camera 1.65 m up); shallower rays are turned alone.
const MIN_DEPRESSION: f32 = 0.01;

/// The camera on the vehicle: how its frame sits in the vehicle's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// Camera-to-vehicle rotation (body level): its columns are the camera's axes.
    m: Matrix3<f32>,
    /// The camera centre in the vehicle frame, metres.
    c: Vector3<f32>,
}

fn rot_x(a: f32) -> Matrix3<f32> {
    let (s, c) = (libm::sinf(a), libm::cosf(a));
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn rot_y(a: f32) -> Matrix3<f32> {
    let (s, c) = (libm::sinf(a), libm::cosf(a));
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

fn rot_z(a: f32) -> Matrix3<f32> {
    let (s, c) = (libm::sinf(a), libm::cosf(a));
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// The body's attitude to the road, `tilt`: a vector of the vehicle frame in the road's.
pub(crate) fn tilt_rotation(tilt: Tilt) -> Matrix3<f32> {
    rot_y(-tilt.pitch) * rot_x(tilt.roll)
}

/// The second vehicle frame's rotation in the first under motion `p`.
fn body_turn(p: &Params) -> Matrix3<f32> {
    rot_z(p.alpha) * rot_y(-p.pitch) * rot_x(p.roll)
}

/// The second vehicle frame in the first under motion `p` over `distance_m`: its rotation
/// (turned, pitched: a turn about y by -pitch lifts the nose, rolled) and its travel, metres.
fn vehicle_motion(p: &Params, distance_m: f32) -> (Matrix3<f32>, Vector3<f32>) {
    let q = body_turn(p);
    let az = 0.5 * p.alpha + p.azimuth;
    let (ce, se) = (libm::cosf(p.elevation), libm::sinf(p.elevation));
    let travel = Vector3::new(ce * libm::cosf(az), ce * libm::sinf(az), se) * distance_m;
    (q, travel)
}

impl Model {
    /// No camera: the placeholder of an unconfigured odometer.
    pub const ZERO: Self = Self {
        m: Matrix3::from_array_storage(nalgebra::ArrayStorage([[0.0; 3]; 3])),
        c: Vector3::from_array_storage(nalgebra::ArrayStorage([[0.0; 3]; 1])),
    };

    /// The camera of `mount`.
    pub fn new(mount: &crate::Mount) -> Self {
        Self {
            m: mount
                .rotation_vehicle_from_camera(Default::default())
                .cast::<f32>(),
            c: mount.position_vehicle().cast::<f32>(),
        }
    }

    /// The camera seen from a pivot `pivot_m` ahead of the rear axle, where the vehicle's arc
    /// is drawn from (tyre slip): a turn swings the camera about it.
    pub fn from_pivot(&self, pivot_m: f32) -> Self {
        Self {
            m: self.m,
            c: self.c - Vector3::new(pivot_m, 0.0, 0.0),
        }
    }

    /// How far the camera sits ahead of the point the vehicle's arc is drawn from, metres: the
    /// arm a turn swings it on, sideways by the turn times this.
    pub fn swing_arm_m(&self) -> f32 {
        self.c.x
    }

    /// Whether ray `x` (camera frame) points above the vehicle's horizontal: a point seen
    /// along it is not on the road's plane.
    pub fn above_horizon(&self, x: &Vector3<f32>) -> bool {
        (self.m * x).z > 0.0
    }

    /// The prediction of where rays of the first frame are seen in the second after a heading
    /// change of `alpha_rad` over `distance_m` (on the arc's chord): the turn and the travel,
    /// taken once for all of a frame's rays ([`Prediction::seen`]).
    pub fn predict(&self, alpha_rad: f32, distance_m: f32) -> Prediction<'_> {
        let half = 0.5 * alpha_rad;
        Prediction {
            model: self,
            turn: rot_z(alpha_rad).transpose(),
            travel: Vector3::new(libm::cosf(half), libm::sinf(half), 0.0) * distance_m,
        }
    }

    /// The camera's rotation under motion `p`: a ray of the first frame turned into the
    /// second's (the whole motion of a point far away).
    pub fn rotation(&self, p: &Params) -> Matrix3<f32> {
        self.m.transpose() * body_turn(p).transpose() * self.m
    }

    /// The essential matrix of motion `p` over `distance_m`: `x2' E x1 = 0` for the rays of a
    /// static point in the first and second frame.
    pub fn essential(&self, p: &Params, distance_m: f32) -> Matrix3<f32> {
        let (q, travel) = vehicle_motion(p, distance_m);
        let qt = q.transpose();
        // X2 = M' Q' (M X1 + c - T) - M' c.
        let r = self.m.transpose() * qt * self.m;
        let t = self.m.transpose() * (qt * (self.c - travel) - self.c);
        t.cross_matrix() * r
    }
}

/// The road's plane under the first frame: the body's pitch (nose up) and roll (left side up)
/// to it, radians, in the mount's vehicle frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tilt {
    /// Pitch, nose up.
    pub pitch: f32,
    /// Roll, left side up.
    pub roll: f32,
}

impl Model {
    /// Where ray `x` meets the road's plane under the camera's height, tilted by `tilt`, in
    /// the vehicle frame (from the point the arc is drawn from); `None` where it meets none
    /// ahead.
    pub fn road_point(&self, tilt: Tilt, x: &Vector3<f32>) -> Option<Vector3<f32>> {
        self.meet_road(&road_normal(tilt), x)
    }

    /// Where ray `x` meets the road's plane of normal `n` (vehicle frame) under the camera's
    /// height.
    fn meet_road(&self, n: &Vector3<f32>, x: &Vector3<f32>) -> Option<Vector3<f32>> {
        let g = self.m * x;
        let ng = n.dot(&g);
        (ng <= -MIN_DEPRESSION).then(|| self.c + g * (self.c.z / -ng))
    }

    /// The homography of the road's plane, tilted by `tilt`, between two frames of motion `p`
    /// over `distance_m`: taken once for all of a frame's rays ([`RoadMotion::seen`]).
    pub fn through_road(&self, p: &Params, distance_m: f32, tilt: Tilt) -> RoadMotion<'_> {
        let (q, travel) = vehicle_motion(p, distance_m);
        RoadMotion {
            model: self,
            normal: road_normal(tilt),
            turn: q.transpose(),
            travel,
        }
    }
}

/// The road's normal in the vehicle frame: the body's attitude `tilt` turns the road's up.
fn road_normal(tilt: Tilt) -> Vector3<f32> {
    tilt_rotation(tilt).transpose() * Vector3::z()
}

/// The road's homography between two frames ([`Model::through_road`]).
#[derive(Clone, Copy, Debug)]
pub struct RoadMotion<'a> {
    model: &'a Model,
    /// The road's normal in the vehicle frame.
    normal: Vector3<f32>,
    /// The second vehicle frame's rotation in the first, transposed.
    turn: Matrix3<f32>,
    /// The vehicle's travel, metres.
    travel: Vector3<f32>,
}

impl RoadMotion<'_> {
    /// Where ray `x1` of the first frame is seen in the second (normalised, z = 1) if it meets
    /// the road; `None` where it meets no road ahead or the point is behind the second camera.
    pub fn seen(&self, x1: &Vector3<f32>) -> Option<Vector3<f32>> {
        let Model { m, c } = self.model;
        let point = self.model.meet_road(&self.normal, x1)?;
        let x2 = m.transpose() * (self.turn * (point - self.travel) - c);
        (x2.z > 0.0).then(|| x2 / x2.z)
    }

    /// The multiple of this motion's travel that takes ray `x1`'s road point to where ray `x2`
    /// sees it, and how surely: the square of how far one unit of it moves the point across
    /// the image (normalised coordinates), the weight a pixel's error leaves it. After the turn
    /// the point is seen along `a - d b` (`a` its place, `b` the travel's), which is `x2`'s
    /// direction where `(a - d b) x x2 = 0`: `d` by least squares over the cross product's
    /// rows. `None` where `x1` meets no road, the travel does not move the point across `x2`,
    /// or the point would be behind the second camera.
    pub fn travel_to(&self, x1: &Vector3<f32>, x2: &Vector3<f32>) -> Option<(f32, f32)> {
        let Model { m, c } = self.model;
        let point = self.model.meet_road(&self.normal, x1)?;
        let a = m.transpose() * (self.turn * point - c);
        let b = m.transpose() * (self.turn * self.travel);
        let (ax, bx) = (a.cross(x2), b.cross(x2));
        let bb = bx.dot(&bx);
        if bb <= 0.0 {
            return None;
        }
        let d = ax.dot(&bx) / bb;
        let z = a.z - d * b.z;
        if z <= 0.0 {
            return None;
        }
        // The derivative of the point's projection (a - d b) / z by d, at x2.
        let sx = (b.z * x2.x - b.x) / z;
        let sy = (b.z * x2.y - b.y) / z;
        Some((d, sx * sx + sy * sy))
    }
}

/// A motion's prediction of where the first frame's rays are seen in the second
/// ([`Model::predict`]).
#[derive(Clone, Copy, Debug)]
pub struct Prediction<'a> {
    model: &'a Model,
    /// The heading change's turn of the vehicle frame, transposed.
    turn: Matrix3<f32>,
    /// The vehicle's travel along the arc's chord, metres.
    travel: Vector3<f32>,
}

impl Prediction<'_> {
    /// Where ray `x` is seen: a ray below the horizon as the point of the road's plane it
    /// meets, moved by the travel; any other turned alone.
    pub fn seen(&self, x: &Vector3<f32>) -> Vector3<f32> {
        let Model { m, c } = self.model;
        let g = m * x;
        if g.z > -MIN_DEPRESSION {
            return m.transpose() * (self.turn * g);
        }
        let point = c + g * (c.z / -g.z);
        m.transpose() * (self.turn * (point - self.travel) - c)
    }
}

/// Signed Sampson distance of rays `x1` and `x2` (normalised image coordinates, z = 1) from
/// `e`'s constraint, in normalised units (times the focal length: pixels).
pub fn sampson(e: &Matrix3<f32>, x1: &Vector3<f32>, x2: &Vector3<f32>) -> f32 {
    let ex1 = e * x1;
    let etx2 = e.transpose() * x2;
    let num = x2.dot(&ex1);
    let den = ex1.x * ex1.x + ex1.y * ex1.y + etx2.x * etx2.x + etx2.y * etx2.y;
    if den <= 0.0 {
        return 0.0;
    }
    num / libm::sqrtf(den)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::Mount;

    /// The KITTI-like mount: 1.65 m high, 1.2 m ahead of the rear axle, level.
    pub(crate) fn mount() -> Mount {
        Mount {
            x_m: 1.2,
            height_m: 1.65,
            ..Mount::DEFAULT
        }
    }

    /// A static point (vehicle frame of the first frame) seen from both frames of motion `p`
    /// over `d` metres: its two rays.
    pub(crate) fn rays(
        model: &Model,
        p: &Params,
        d: f32,
        point: Vector3<f32>,
    ) -> (Vector3<f32>, Vector3<f32>) {
        let (q, travel) = vehicle_motion(p, d);
        let x1 = model.m.transpose() * (point - model.c);
        let in2 = q.transpose() * (point - travel);
        let x2 = model.m.transpose() * (in2 - model.c);
        (x1 / x1.z, x2 / x2.z)
    }

    #[test]
    fn static_points_at_any_depth_meet_the_constraint_of_the_true_motion_only() {
        let model = Model::new(&mount());
        let truth = Params {
            alpha: 0.02,
            pitch: -0.003,
            roll: 0.002,
            azimuth: 0.01,
            elevation: -0.005,
        };
        let e = model.essential(&truth, 1.1);
        let wrong = model.essential(
            &Params {
                alpha: 0.021,
                ..truth
            },
            1.1,
        );
        for point in [
            Vector3::new(8.0, 2.0, 0.0),
            Vector3::new(25.0, -6.0, 4.0),
            Vector3::new(300.0, 40.0, 20.0),
        ] {
            let (x1, x2) = rays(&model, &truth, 1.1, point);
            assert!(sampson(&e, &x1, &x2).abs() < 1e-6, "{point:?}");
            // A thousandth of a radian of heading: 0.7 px at KITTI's focal length.
            let off = 718.0 * sampson(&wrong, &x1, &x2).abs();
            assert!(off > 0.1, "{point:?}: {off} px");
        }
    }

    #[test]
    fn a_turn_swings_the_camera_about_the_pivot() {
        // Tyre slip draws the arc from 0.4 m ahead of the rear axle: in a tight slow turn the
        // camera, 1.2 m ahead of the axle, swings about the pivot 0.8 m behind it, and the rear
        // axle's model would put it 0.02 m too far out in 0.3 m of travel.
        let model = Model::new(&mount());
        let pivoted = model.from_pivot(0.4);
        let turn = Params {
            alpha: 0.05,
            ..Params::default()
        };
        let (e, axle) = (pivoted.essential(&turn, 0.3), model.essential(&turn, 0.3));
        for point in [Vector3::new(6.0, 2.0, 0.0), Vector3::new(5.0, -2.0, 0.0)] {
            let (x1, x2) = rays(&pivoted, &turn, 0.3, point);
            assert!(sampson(&e, &x1, &x2).abs() < 1e-6, "{point:?}");
            let off = 718.0 * sampson(&axle, &x1, &x2).abs();
            assert!(off > 0.5, "{point:?}: {off} px");
        }
    }

    proptest::proptest! {
        #[test]
        fn a_road_point_is_predicted_where_the_moved_camera_sees_it(
            ahead in 3.0f32..60.0,
            y in -8.0f32..8.0,
            alpha in -0.06f32..0.06,
            d in 0.0f32..2.5,
            pitch_deg in -3.0f32..3.0,
        ) {
            let mount = Mount {
                pitch_rad: pitch_deg.to_radians(),
                ..mount()
            };
            let model = Model::new(&mount);
            let motion = Params {
                alpha,
                ..Params::default()
            };
            // A point of the road ahead of the camera in both frames (one it passes over has
            // no ray in an image).
            let x = mount.x_m + d + ahead;
            let (x1, x2) = rays(&model, &motion, d, Vector3::new(x, y, 0.0));
            let got = model.predict(alpha, d).seen(&x1);
            let got = got / got.z;
            // Single precision's rounding: a thousandth of a pixel at KITTI's focal length
            // near the image's centre.
            let tolerance = 2e-6 * (1.0 + x2.norm());
            proptest::prop_assert!((got - x2).norm() < tolerance, "{got:?} against {x2:?}");
        }
    }

    #[test]
    fn a_ray_above_the_horizon_is_turned_alone() {
        let model = Model::new(&mount());
        let motion = Params {
            alpha: 0.03,
            ..Params::default()
        };
        let (x1, _) = rays(&model, &motion, 1.0, Vector3::new(60.0, 5.0, 4.0));
        let turned = model.rotation(&motion) * x1;
        assert_eq!(model.predict(0.03, 1.0).seen(&x1), turned);
    }
}
