//! Time as the odometer counts it: [`Instant`]s of frames and the [`Duration`]s between them, in
//! whole microseconds (a camera's timestamps; 584,000 years before a `u64` wraps).

use core::fmt;

/// A moment, microseconds from whatever origin the camera's clock has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Instant {
    micros: u64,
}

/// A span of time, microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Duration {
    micros: u64,
}

impl Instant {
    /// The clock's origin.
    pub const ZERO: Self = Self { micros: 0 };

    /// The moment `micros` microseconds after the clock's origin.
    pub const fn from_micros(micros: u64) -> Self {
        Self { micros }
    }

    /// Microseconds since the clock's origin.
    pub const fn total_micros(self) -> u64 {
        self.micros
    }

    /// The time from `earlier` to this moment; `None` if `earlier` is later.
    pub const fn since(self, earlier: Instant) -> Option<Duration> {
        match self.micros.checked_sub(earlier.micros) {
            Some(micros) => Some(Duration { micros }),
            None => None,
        }
    }
}

impl Instant {
    /// The time between this moment and `other`, whichever is earlier.
    pub const fn abs_diff(self, other: Instant) -> Duration {
        Duration {
            micros: self.micros.abs_diff(other.micros),
        }
    }
}

impl Duration {
    /// No time.
    pub const ZERO: Self = Self { micros: 0 };

    /// A span of `micros` microseconds.
    pub const fn from_micros(micros: u64) -> Self {
        Self { micros }
    }

    /// The span, microseconds.
    pub const fn total_micros(self) -> u64 {
        self.micros
    }

    /// The span, seconds (rounded to an `f32`).
    pub fn secs_f32(self) -> f32 {
        self.micros as f32 * 1e-6
    }

    /// How much of something that goes at `rate_per_s` a second this span holds (a speed's
    /// distance): the rate times the microseconds, times 1e-6, rounded in that order.
    pub fn at_rate(self, rate_per_s: f32) -> f32 {
        rate_per_s * self.micros as f32 * 1e-6
    }

    /// This span over `other`: how many times longer it is (rounded to an `f32`).
    pub fn ratio(self, other: Duration) -> f32 {
        self.micros as f32 / other.micros as f32
    }
}

impl fmt::Display for Instant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} us", self.micros)
    }
}

impl fmt::Display for Duration {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} us", self.micros)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_between_instants() {
        let (a, b) = (Instant::from_micros(1_000), Instant::from_micros(101_000));
        assert_eq!(b.since(a), Some(Duration::from_micros(100_000)));
        assert_eq!(a.since(b), None);
        assert_eq!(Duration::from_micros(100_000).secs_f32(), 0.1);
        assert_eq!(
            Duration::from_micros(50).ratio(Duration::from_micros(100)),
            0.5
        );
    }
}
