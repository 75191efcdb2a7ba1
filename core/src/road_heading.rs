//! A frame's heading change where the whole image's rests on the road alone
//! (`weigh_road_heading`): then it and the ground vote's measure the same points' motion, the
//! image's through a five-parameter epipolar fit that a plane conditions badly, the ground's
//! through the mount's ground plane, which a kerb or a crown turns. Neither is the better on
//! every road, and the image's own spread (its fit's residuals) reads its error there several
//! times too small. So each is weighed by the variance a three-cornered hat gives it: the
//! running mean squares of the pairwise differences of three estimates of the same heading
//! change with errors apart (the image's, the ground's and the prediction, the last frame's
//! motion) give each one's variance with no truth and no threshold set by hand.

use crate::running_mean::RunningMeans;

/// Frames the running mean squares are taken over, at most (5 s at 10 frames/s): a road's
/// stretch, short enough to follow a change of surface.
const FRAMES: u16 = 50;

/// Frames the hat needs before it weighs: until then the image's heading stands, as where the
/// image sees more than the road.
const FIRST_FRAMES: u16 = 10;

/// The running three-cornered hat over the image's, the ground's and the predicted heading
/// change, on the frames whose image sees nothing but road. All zeros before the first.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RoadHeading {
    /// Running mean squares of the differences over up to [`FRAMES`], radians squared: image
    /// less ground, image less prediction, ground less prediction.
    squares: RunningMeans<3>,
}

impl RoadHeading {
    /// Before the first frame.
    pub const START: Self = Self {
        squares: RunningMeans::START,
    };

    /// The variances of the image's and the ground's heading change the hat gives, radians
    /// squared, each at least zero; `None` before [`FIRST_FRAMES`] or where both are zero.
    pub fn variances(&self) -> Option<(f32, f32)> {
        if self.squares.frames() < FIRST_FRAMES {
            return None;
        }
        let [ig, ip, gp] = self.squares.means();
        let image = (0.5 * (ig + ip - gp)).max(0.0);
        let ground = (0.5 * (ig + gp - ip)).max(0.0);
        let both = image + ground;
        (both > 0.0 && both.is_finite()).then_some((image, ground))
    }

    /// The frame's heading change, radians, from the image's `image_rad` and the ground
    /// vote's `ground_rad`: each weighed by the other's variance as the frames before this
    /// one give them (the image's alone until they give any). `predicted_rad`, the prediction,
    /// joins the hat with the two; a frame without it or with a difference that is no number
    /// leaves the hat as it was.
    pub fn weigh(&mut self, image_rad: f32, ground_rad: f32, predicted_rad: Option<f32>) -> f32 {
        let weighed = match self.variances() {
            Some((image, ground)) => {
                image_rad + image / (image + ground) * (ground_rad - image_rad)
            }
            None => image_rad,
        };
        if let Some(p) = predicted_rad {
            let d = [image_rad - ground_rad, image_rad - p, ground_rad - p];
            if d.iter().all(|d| d.is_finite()) {
                self.squares.add(d.map(|d| d * d), FRAMES);
            }
        }
        if weighed.is_finite() {
            weighed
        } else {
            image_rad
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::uniform;

    /// Feeds `frames` frames of a turn rate varying slowly, the image, the ground and the
    /// prediction each off by its own noise of these deviations; returns the hat and the rms
    /// error of the weighed heading and of the image's alone over the last half.
    fn run(sd: [f32; 3], frames: usize) -> (RoadHeading, f32, f32) {
        let mut u = uniform(7);
        // Four uniforms summed: near enough a unit normal.
        let mut normal = move || (u() + u() + u() + u() - 2.0) * libm::sqrtf(3.0);
        let mut h = RoadHeading::START;
        let (mut weighed, mut image, mut n) = (0.0, 0.0, 0.0);
        for k in 0..frames {
            let truth = 0.01 * libm::sinf(k as f32 * 0.05);
            let [i, g, p] = sd.map(|s| truth + s * normal());
            let w = h.weigh(i, g, Some(p));
            if k >= frames / 2 {
                weighed += (w - truth) * (w - truth);
                image += (i - truth) * (i - truth);
                n += 1.0;
            }
        }
        (h, libm::sqrtf(weighed / n), libm::sqrtf(image / n))
    }

    #[test]
    fn the_hat_finds_each_estimates_variance_without_the_truth() {
        let (h, _, _) = run([0.001, 0.0005, 0.002], 4000);
        let (image, ground) = h.variances().unwrap();
        assert!((libm::sqrtf(image) / 0.001 - 1.0).abs() < 0.3, "{image}");
        assert!((libm::sqrtf(ground) / 0.0005 - 1.0).abs() < 0.5, "{ground}");
    }

    #[test]
    fn the_weighed_heading_beats_the_worse_and_nears_the_better() {
        // The image twice as noisy as the ground: weighed, the error falls below the ground's.
        let (_, weighed, image) = run([0.002, 0.001, 0.003], 2000);
        assert!(weighed < 0.6 * image, "{weighed} {image}");
        assert!(weighed < 0.0011, "{weighed}");
        // The image the better by far: the ground hardly moves it.
        let (_, weighed, image) = run([0.0005, 0.005, 0.003], 2000);
        assert!(weighed < 1.1 * image, "{weighed} {image}");
    }

    #[test]
    fn the_image_stands_until_the_hat_has_frames_and_without_a_prediction_nothing_is_learned() {
        // The prediction halfway between the two every frame: each as far from the truth.
        let mut h = RoadHeading::START;
        for _ in 0..FIRST_FRAMES - 1 {
            assert_eq!(h.weigh(0.01, 0.02, Some(0.015)), 0.01);
        }
        let before = h;
        assert_eq!(h.weigh(0.01, 0.02, None), 0.01);
        assert_eq!(h.weigh(0.01, f32::NAN, Some(0.015)), 0.01);
        assert_eq!(h, before);
        h.weigh(0.01, 0.02, Some(0.015));
        let w = h.weigh(0.01, 0.02, None);
        assert!((w - 0.015).abs() < 1e-6, "{w}");
        // Whatever comes in, what goes out is a number.
        assert!(h.weigh(f32::MAX, -f32::MAX, Some(0.0)).is_finite());
    }
}
