//! The trace of an estimate: the words the host (`roadvo run --trace`) and the firmware print
//! for each frame, after its kind (`estimate`, the odometer's; `smoothed`, the smoother's) and
//! its frame number, so that two runs compare bit for bit.

use crate::odometer::Estimate;

/// Words a record holds.
pub const WORDS: usize = 11;

/// The record of `e`: the bit patterns of the motion (distance, heading change), the pose (x, y,
/// heading), the pitch and the inlier ratio, then the corners detected, the tracks matched, the
/// fallback flag and the corners set aside.
pub fn record(e: &Estimate) -> [u32; WORDS] {
    let q = &e.quality;
    [
        e.motion.distance_m.to_bits(),
        e.motion.heading_change_rad.to_bits(),
        e.pose.x_m.to_bits(),
        e.pose.y_m.to_bits(),
        e.pose.heading_rad.to_bits(),
        q.pitch_rad.to_bits(),
        q.inlier_ratio.to_bits(),
        u32::from(q.features_detected),
        u32::from(q.tracks_matched),
        u32::from(q.fallback),
        u32::from(q.features_comoving),
    ]
}
