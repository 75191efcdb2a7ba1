//! Running means over a drive's last frames: each frame counts alike until `cap` frames have
//! been taken, then the means follow as exponential means over about `cap` frames. What
//! [`crate::road_distance`] and [`crate::road_heading`] keep of their measurements'
//! disagreements.

/// `K` running means sharing one count of frames. All zeros before the first frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunningMeans<const K: usize> {
    means: [f32; K],
    /// Frames taken, up to the `cap` of [`add`](Self::add).
    frames: u16,
}

impl<const K: usize> RunningMeans<K> {
    /// Before the first frame.
    pub const START: Self = Self {
        means: [0.0; K],
        frames: 0,
    };

    /// Takes one frame's `values`, the count held at `cap` frames.
    pub fn add(&mut self, values: [f32; K], cap: u16) {
        self.frames = self.frames.saturating_add(1).min(cap);
        let n = f32::from(self.frames);
        for (mean, v) in self.means.iter_mut().zip(values) {
            *mean += (v - *mean) / n;
        }
    }

    /// The means (zeros before the first frame).
    pub fn means(&self) -> [f32; K] {
        self.means
    }

    /// Frames taken, at most the cap.
    pub fn frames(&self) -> u16 {
        self.frames
    }
}

impl<const K: usize> Default for RunningMeans<K> {
    fn default() -> Self {
        Self::START
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plain_mean_up_to_the_cap_then_an_exponential_one() {
        let mut m = RunningMeans::<2>::START;
        m.add([1.0, 4.0], 3);
        m.add([3.0, 2.0], 3);
        assert_eq!(m.means(), [2.0, 3.0]);
        m.add([5.0, 3.0], 3);
        assert_eq!((m.means(), m.frames()), ([3.0, 3.0], 3));
        // Past the cap each frame moves the means a third of the way.
        m.add([6.0, 0.0], 3);
        assert_eq!((m.means(), m.frames()), ([4.0, 2.0], 3));
    }
}
