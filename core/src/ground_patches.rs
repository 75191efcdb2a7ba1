//! The ground window's matched corners as pairs for the road's plane
//! ([`crate::heading::plane`]). The ground vote matches a track to this frame's corner by place,
//! to the corner detector's precision; but a corner's place drifts over the texture as it nears
//! (a blob's corner response peaks inside it by a share of the blob, which grows), and the
//! plane reads that drift as a tilt (kitti-like: 0.09 deg nose down, a per-frame spread of
//! 1 deg against the image's 0.7). So each frame keeps a patch of grey levels at each of its
//! ground corners, and the next frame finds the patch again from where the vote matched it, to
//! a fraction of a pixel ([`crate::heading::patch`]): that pair is the plane's.

use crate::frame::Frame;
use crate::heading::consensus::Pair;
use crate::heading::patch::{self, Patch};
use crate::heading::ray;
use crate::projection::{Camera, Pixel};
use crate::tracks::{Observation, Observations, Track};
use heapless::Vec;

/// A corner's patch and the frame pixel (rounded, in the lens's image) it was read at.
#[derive(Clone, Copy, Debug)]
struct Kept {
    u: u16,
    v: u16,
    patch: Patch,
}

/// The last frame's ground corners' patches, up to `F` a side (the odometer's corners a side).
#[derive(Clone, Debug)]
pub struct GroundPatches<const F: usize> {
    /// Per side of straight ahead, in the order of the side's observations.
    kept: [Vec<Kept, F>; 2],
}

impl<const F: usize> Default for GroundPatches<F> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const F: usize> GroundPatches<F> {
    /// None kept; `const` so that an odometer can be a zero-initialised `static`.
    pub const fn new() -> Self {
        Self {
            kept: [Vec::new(), Vec::new()],
        }
    }

    /// Forgets every patch.
    pub fn clear(&mut self) {
        self.kept.iter_mut().for_each(Vec::clear);
    }

    /// Keeps a patch of `frame` at each of its `observations` (those too near the frame's edge
    /// for a search are left out), in place of the last frame's.
    pub fn keep<Fr: Frame + ?Sized>(
        &mut self,
        frame: &Fr,
        camera: &Camera,
        observations: &Observations<F>,
    ) {
        for (kept, side) in self.kept.iter_mut().zip(&observations.sides) {
            kept.clear();
            for o in side {
                if let Some((u, v)) = searchable(frame, camera, o.pixel) {
                    let patch = patch::read(frame, u, v);
                    // Never full: as many slots as the side's observations.
                    let _ = kept.push(Kept { u, v, patch });
                }
            }
        }
    }

    /// The pairs for the road's plane into `out` (cleared first; as many as it holds): each of
    /// `tracks` seen in the last frame that `observed` matches in `frame` (the vote's matches,
    /// by track), from the place its patch was read at to where it is found again around the
    /// match. A track whose patch is not kept, or not found again, gives none.
    pub fn pairs<Fr: Frame + ?Sized, const N: usize>(
        &self,
        frame: &Fr,
        camera: &Camera,
        (tracks, observed): (&[Track], &[Option<Observation>]),
        out: &mut Vec<Pair, N>,
    ) {
        out.clear();
        for (track, o) in tracks.iter().zip(observed) {
            let (Some(last), Some(o)) = (track.pixel, o) else {
                continue;
            };
            let Some((u, v)) = searchable(frame, camera, last) else {
                continue;
            };
            let mut kept = self.kept.iter().flatten();
            let Some(k) = kept.find(|k| (k.u, k.v) == (u, v)) else {
                continue;
            };
            let Some((su, sv)) = searchable(frame, camera, o.pixel) else {
                continue;
            };
            let Some(found) = patch::find(frame, &k.patch, su, sv) else {
                continue;
            };
            let x1 = ray(camera, f32::from(u), f32::from(v));
            let x2 = ray(camera, found.u_px, found.v_px);
            if let (Some(x1), Some(x2)) = (x1, x2)
                && out.push(Pair { x1, x2 }).is_err()
            {
                return;
            }
        }
    }
}

/// The frame pixel of the ideal (pinhole) pixel `p`, rounded, where a patch search fits inside
/// the frame ([`patch::MARGIN`]).
fn searchable<Fr: Frame + ?Sized>(frame: &Fr, camera: &Camera, p: Pixel) -> Option<(u16, u16)> {
    let seen = camera.distort(p);
    let margin = f32::from(patch::MARGIN);
    let inside = |x: f32, n: u16| x >= margin && x < f32::from(n) - margin;
    let (u, v) = (libm::roundf(seen.u_px), libm::roundf(seen.v_px));
    // A cast saturates; inside the frame it is exact.
    (inside(u, frame.width()) && inside(v, frame.height())).then_some((u as u16, v as u16))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::SliceFrame;
    use crate::heading::patch::tests::blobs;
    use crate::projection::GroundPoint;
    use nalgebra::Vector3;

    fn at(u_px: f32, v_px: f32) -> Observation {
        Observation {
            ground: GroundPoint::default(),
            pixel: Pixel { u_px, v_px },
        }
    }

    fn seen_at(pixel: Option<Pixel>) -> Track {
        Track {
            pixel,
            ..Track::default()
        }
    }

    #[test]
    fn a_matched_corner_is_found_again_where_its_patch_moved_not_where_it_was_detected() {
        let camera = crate::config::tests::kitti_config().camera;
        let (w, h) = (64usize, 48usize);
        let (du, dv) = (1.3f32, 2.6f32);
        let before = blobs(w, h, 0.0, 0.0, 1.0);
        let after = blobs(w, h, du, dv, 1.0);
        let f0 = SliceFrame::new(&before, w as u16, h as u16, w).unwrap();
        let f1 = SliceFrame::new(&after, w as u16, h as u16, w).unwrap();
        let mut last = Observations::<4>::new();
        last.sides[0].push(at(20.0, 20.0)).unwrap();
        last.sides[1].push(at(40.0, 25.0)).unwrap();
        // Near the edge: no patch is kept for it.
        last.sides[1].push(at(2.0, 25.0)).unwrap();
        let mut patches = GroundPatches::<4>::new();
        patches.keep(&f0, &camera, &last);
        let tracks = [
            seen_at(Some(at(20.0, 20.0).pixel)),
            seen_at(Some(at(40.0, 25.0).pixel)),
            // Not seen last frame, or seen where no patch was kept: no pair.
            seen_at(None),
            seen_at(Some(at(2.0, 25.0).pixel)),
            seen_at(Some(at(30.0, 30.0).pixel)),
            // Not matched this frame.
            seen_at(Some(at(20.0, 20.0).pixel)),
        ];
        // The vote matched them where the detector put them, up to a pixel off the motion.
        let observed = [
            Some(at(20.0 + du + 0.5, 20.0 + dv - 0.4)),
            Some(at(40.0 + du - 0.6, 25.0 + dv + 0.7)),
            Some(at(30.0, 30.0)),
            Some(at(2.0 + du, 25.0 + dv)),
            Some(at(30.0 + du, 30.0 + dv)),
            None,
        ];
        let mut pairs = Vec::<Pair, 8>::new();
        patches.pairs(&f1, &camera, (&tracks, &observed), &mut pairs);
        assert_eq!(pairs.len(), 2, "{pairs:?}");
        let px = |x: Vector3<f32>| {
            (
                camera.cx_px + camera.fx_px * x.x,
                camera.cy_px + camera.fy_px * x.y,
            )
        };
        for (pair, (u, v)) in pairs.iter().zip([(20.0, 20.0), (40.0, 25.0)]) {
            let (u1, v1) = px(pair.x1);
            assert!((u1 - u).abs() < 1e-3 && (v1 - v).abs() < 1e-3, "{pair:?}");
            let (u2, v2) = px(pair.x2);
            assert!((u2 - u - du).abs() < 0.12, "{u2} {v2}");
            assert!((v2 - v - dv).abs() < 0.12, "{u2} {v2}");
        }
        // A full output keeps what it holds; forgetting leaves nothing to pair.
        let mut one = Vec::<Pair, 1>::new();
        patches.pairs(&f1, &camera, (&tracks, &observed), &mut one);
        assert_eq!(one.len(), 1);
        patches.clear();
        patches.pairs(&f1, &camera, (&tracks, &observed), &mut pairs);
        assert!(pairs.is_empty());
    }
}
