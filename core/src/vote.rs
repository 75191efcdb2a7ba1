//! The Hough-like vote (paper §2.3): an integer accumulator over a window of motions, heading
//! change by distance, and the ways to read an estimate out of it.

use crate::motion::Motion;
use heapless::Vec;

/// A rectangle of motions: heading change by distance per frame. Bin `(i, j)` of a `GRID x GRID`
/// accumulator covers heading bin `i` and distance bin `j`; bin centres sit half a bin in.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotionWindow {
    /// Lowest heading change, radians.
    pub heading_lo_rad: f32,
    /// Highest heading change, radians.
    pub heading_hi_rad: f32,
    /// Shortest distance, metres.
    pub distance_lo_m: f32,
    /// Longest distance, metres.
    pub distance_hi_m: f32,
}

impl MotionWindow {
    /// The window `centre +- (heading_half_rad, distance_half_m)`.
    pub fn around(centre: Motion, heading_half_rad: f32, distance_half_m: f32) -> Self {
        Self {
            heading_lo_rad: centre.heading_change_rad - heading_half_rad,
            heading_hi_rad: centre.heading_change_rad + heading_half_rad,
            distance_lo_m: centre.distance_m - distance_half_m,
            distance_hi_m: centre.distance_m + distance_half_m,
        }
    }

    /// The same window, its distance range kept from reaching a stop further than the window
    /// `centre +- distance_half_m` does: on the side facing zero it ends no nearer than half
    /// the centre's distance. A window widened after fallbacks would otherwise take in standing
    /// still, where a vehicle ahead driving at our speed (its corners still in the image) votes
    /// with every corner it has and holds the estimate there.
    pub fn short_of_stop(self, centre: Motion, distance_half_m: f32) -> Self {
        let d = centre.distance_m;
        let mut w = self;
        if d > 0.0 {
            w.distance_lo_m = w.distance_lo_m.max((d - distance_half_m).min(0.5 * d));
        } else if d < 0.0 {
            w.distance_hi_m = w.distance_hi_m.min((d + distance_half_m).max(0.5 * d));
        }
        w
    }

    /// The same window, its heading range `heading_rad +- half_rad`.
    pub fn with_heading(self, heading_rad: f32, half_rad: f32) -> Self {
        Self {
            heading_lo_rad: heading_rad - half_rad,
            heading_hi_rad: heading_rad + half_rad,
            ..self
        }
    }

    /// The same window, its distance range stretched to take in `distance_m +- half_m`.
    pub fn taking_in(self, distance_m: f32, half_m: f32) -> Self {
        Self {
            distance_lo_m: self.distance_lo_m.min(distance_m - half_m),
            distance_hi_m: self.distance_hi_m.max(distance_m + half_m),
            ..self
        }
    }

    /// Heading change at the centre of heading bin `i` (fractional bins allowed).
    pub fn heading_at(&self, i: f32, grid: usize) -> f32 {
        self.heading_lo_rad + (i + 0.5) * (self.heading_hi_rad - self.heading_lo_rad) / grid as f32
    }

    /// Distance at the centre of distance bin `j` (fractional bins allowed).
    pub fn distance_at(&self, j: f32, grid: usize) -> f32 {
        self.distance_lo_m + (j + 0.5) * (self.distance_hi_m - self.distance_lo_m) / grid as f32
    }

    /// The distance bin holding `distance_m`, if inside the window.
    pub fn distance_bin(&self, distance_m: f32, grid: usize) -> Option<usize> {
        let f = (distance_m - self.distance_lo_m) / (self.distance_hi_m - self.distance_lo_m);
        // NaN is in no range.
        (0.0..1.0)
            .contains(&f)
            .then(|| ((f * grid as f32) as usize).min(grid - 1))
    }

    /// The distance bin holding `distance_m`, the nearest end bin if outside the window by
    /// less than a window's length; `None` if farther or NaN.
    pub fn distance_bin_clamped(&self, distance_m: f32, grid: usize) -> Option<usize> {
        let f = (distance_m - self.distance_lo_m) / (self.distance_hi_m - self.distance_lo_m);
        (-1.0..2.0)
            .contains(&f)
            .then(|| ((f.max(0.0) * grid as f32) as usize).min(grid - 1))
    }

    /// Distance bin width, metres.
    pub fn distance_step_m(&self, grid: usize) -> f32 {
        (self.distance_hi_m - self.distance_lo_m) / grid as f32
    }

    /// The motion at fractional bin `(i, j)`.
    pub fn motion_at(&self, i: f32, j: f32, grid: usize) -> Motion {
        Motion {
            heading_change_rad: self.heading_at(i, grid),
            distance_m: self.distance_at(j, grid),
        }
    }
}

/// The accumulator: `cells[i][j]` counts votes for heading bin `i`, distance bin `j`.
#[derive(Clone, Debug, PartialEq)]
pub struct VoteGrid<const GRID: usize> {
    cells: [[u16; GRID]; GRID],
}

impl<const GRID: usize> VoteGrid<GRID> {
    /// An empty accumulator.
    pub const fn new() -> Self {
        Self {
            cells: [[0; GRID]; GRID],
        }
    }
}

impl<const GRID: usize> Default for VoteGrid<GRID> {
    fn default() -> Self {
        Self::new()
    }
}

/// Bins one voter may hold before [`BestPerBin`] stops listing them and scans the whole grid
/// instead (a track rarely holds more than a few hundred; 2 bytes each), and past bin 255.
pub const KEPT_BINS: usize = 1024;

/// One voter's votes before they join an accumulator: each bin keeps the voter's best weight.
#[derive(Clone, Debug, PartialEq)]
pub struct BestPerBin<const GRID: usize> {
    cells: [[u8; GRID]; GRID],
    /// The bins holding weights, (heading bin, distance bin), in the order first kept: adding
    /// them costs the bins voted, not the box around them (a track's pairs reach a handful of
    /// bins scattered over the window, and scanning their bounding box took a fifth of the
    /// vote's time).
    kept: Vec<(u8, u8), KEPT_BINS>,
    /// More bins were kept than listed: the whole grid is scanned. (A flag rather than an
    /// `Option` of the list: an empty voter stays all zeros, so an odometer `static` stays in
    /// `.bss` rather than taking its size in flash.)
    spilled: bool,
}

impl<const GRID: usize> BestPerBin<GRID> {
    /// No votes.
    pub const fn new() -> Self {
        Self {
            cells: [[0; GRID]; GRID],
            kept: Vec::new(),
            spilled: false,
        }
    }

    /// Keeps `weight` for bin `(i, j)` if it beats the one there; ignored outside the grid or
    /// when 0.
    pub fn keep(&mut self, i: usize, j: usize, weight: u8) {
        let Some(cell) = self.cells.get_mut(i).and_then(|row| row.get_mut(j)) else {
            return;
        };
        if *cell == 0 && weight > 0 && !self.spilled {
            self.spilled = match (u8::try_from(i), u8::try_from(j)) {
                (Ok(i), Ok(j)) => self.kept.push((i, j)).is_err(),
                _ => true,
            };
        }
        *cell = (*cell).max(weight);
    }

    /// Adds the kept weights to `grid` and forgets them.
    pub fn add_to(&mut self, grid: &mut VoteGrid<GRID>) {
        if self.spilled {
            for (i, row) in self.cells.iter_mut().enumerate() {
                for (j, cell) in row.iter_mut().enumerate() {
                    if *cell > 0 {
                        grid.add(i, j, u16::from(*cell));
                        *cell = 0;
                    }
                }
            }
        } else {
            for &(i, j) in self.kept.iter() {
                let (i, j) = (usize::from(i), usize::from(j));
                if let Some(cell) = self.cells.get_mut(i).and_then(|row| row.get_mut(j)) {
                    grid.add(i, j, u16::from(*cell));
                    *cell = 0;
                }
            }
        }
        self.kept.clear();
        self.spilled = false;
    }
}

impl<const GRID: usize> Default for BestPerBin<GRID> {
    fn default() -> Self {
        Self::new()
    }
}

/// A peak of the accumulator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Peak {
    /// Votes in the 3x3 bins around the highest bin.
    pub score: u32,
    /// Fractional heading bin of the centre of gravity.
    pub heading_bin: f32,
    /// Fractional distance bin of the centre of gravity.
    pub distance_bin: f32,
}

impl<const GRID: usize> VoteGrid<GRID> {
    /// Sets every bin to zero.
    pub fn clear(&mut self) {
        self.cells = [[0; GRID]; GRID];
    }

    /// Adds a vote of `weight`; saturates rather than wraps.
    pub fn add(&mut self, i: usize, j: usize, weight: u16) {
        if let Some(c) = self.cells.get_mut(i).and_then(|row| row.get_mut(j)) {
            *c = c.saturating_add(weight);
        }
    }

    /// Votes in bin `(i, j)`; 0 outside the grid.
    pub fn get(&self, i: usize, j: usize) -> u16 {
        self.cells
            .get(i)
            .and_then(|row| row.get(j))
            .copied()
            .unwrap_or(0)
    }

    /// Votes in the 3x3 bins around bin `(i, j)` (those inside the grid).
    pub fn around(&self, i: usize, j: usize) -> u32 {
        let rows = self.cells.iter().skip(i.saturating_sub(1));
        let rows = rows.take(3 - usize::from(i == 0));
        rows.flat_map(|row| {
            let cells = row.iter().skip(j.saturating_sub(1));
            cells.take(3 - usize::from(j == 0))
        })
        .map(|&c| u32::from(c))
        .sum()
    }

    /// The highest bin, the votes in the 3x3 bins around it (the score), and the centre of
    /// gravity of a 3x3-bin square that is moved onto its own centre of gravity (eight
    /// mean-shift steps, bins counted by the share of them inside the square). Starting from the
    /// highest bin alone would lean towards the lower index whenever two bins tie, a heading
    /// bias on a straight road (`docs/experiments.md`, "The vote"). `None` when the grid is empty.
    pub fn peak(&self) -> Option<Peak> {
        let (mut best, mut at) = (0u16, (0usize, 0usize));
        for (i, row) in self.cells.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                if c > best {
                    best = c;
                    at = (i, j);
                }
            }
        }
        if best == 0 {
            return None;
        }
        let score = self.around(at.0, at.1);
        let (mut mi, mut mj) = (at.0 as f32, at.1 as f32);
        // Share of bin k (covering k - 0.5 .. k + 0.5) inside m - 1.5 .. m + 1.5.
        let cover = |k: usize, m: f32| {
            let k = k as f32;
            ((k + 0.5).min(m + 1.5) - (k - 0.5).max(m - 1.5)).clamp(0.0, 1.0)
        };
        for _ in 0..8 {
            let (i0, i1) = (
                libm::floorf(mi - 1.5).max(0.0) as usize,
                (libm::ceilf(mi + 1.5) as usize).min(GRID - 1),
            );
            let (j0, j1) = (
                libm::floorf(mj - 1.5).max(0.0) as usize,
                (libm::ceilf(mj + 1.5) as usize).min(GRID - 1),
            );
            let (mut sum, mut si, mut sj) = (0.0f32, 0.0f32, 0.0f32);
            for i in i0..=i1 {
                let wi = cover(i, mi);
                for j in j0..=j1 {
                    let w = wi * cover(j, mj) * f32::from(self.cells[i][j]);
                    sum += w;
                    si += w * i as f32;
                    sj += w * j as f32;
                }
            }
            if sum <= 0.0 {
                break;
            }
            (mi, mj) = (si / sum, sj / sum);
        }
        Some(Peak {
            score,
            heading_bin: mi,
            distance_bin: mj,
        })
    }

    /// The paper's estimate (§2.3): the centre of gravity of every bin holding at least
    /// `fraction` of the highest count. `None` when the grid is empty.
    pub fn centre_above(&self, fraction: f32) -> Option<Peak> {
        let max = self.cells.iter().flatten().copied().max().unwrap_or(0);
        if max == 0 {
            return None;
        }
        // Integer threshold: ceil(fraction * max).
        let floor = libm::ceilf(fraction * f32::from(max)) as u32;
        let (mut sum, mut si, mut sj) = (0u64, 0u64, 0u64);
        for (i, row) in self.cells.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                let c = u32::from(c);
                if c >= floor {
                    sum += u64::from(c);
                    si += u64::from(c) * i as u64;
                    sj += u64::from(c) * j as u64;
                }
            }
        }
        Some(Peak {
            score: u32::from(max),
            heading_bin: si as f32 / sum as f32,
            distance_bin: sj as f32 / sum as f32,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_widened_window_stops_short_of_standing_still() {
        let ahead = Motion {
            heading_change_rad: 0.0,
            distance_m: 0.6,
        };
        // Widened four times: 0.6 +- 0.6 would take in standing still; it ends at 0.3.
        let w = MotionWindow::around(ahead, 0.02, 0.6).short_of_stop(ahead, 0.15);
        assert_eq!((w.distance_lo_m, w.distance_hi_m), (0.3, 1.2));
        // Unwidened, the window is kept as it is...
        let w = MotionWindow::around(ahead, 0.02, 0.15).short_of_stop(ahead, 0.15);
        assert!((w.distance_lo_m - 0.45).abs() < 1e-6);
        // ...even where it reaches a stop.
        let slow = Motion {
            heading_change_rad: 0.0,
            distance_m: 0.1,
        };
        let w = MotionWindow::around(slow, 0.02, 0.15).short_of_stop(slow, 0.15);
        assert!((w.distance_lo_m + 0.05).abs() < 1e-6);
        // Reversing: the mirror image.
        let back = Motion {
            heading_change_rad: 0.0,
            distance_m: -0.6,
        };
        let w = MotionWindow::around(back, 0.02, 0.6).short_of_stop(back, 0.15);
        assert_eq!((w.distance_lo_m, w.distance_hi_m), (-1.2, -0.3));
    }

    #[test]
    fn taking_in_a_distance_stretches_only_the_distance_range() {
        let centre = Motion {
            heading_change_rad: 0.01,
            distance_m: 0.5,
        };
        let w = MotionWindow::around(centre, 0.02, 0.15);
        let longer = w.taking_in(0.7, 0.15);
        assert_eq!((longer.distance_lo_m, longer.distance_hi_m), (0.35, 0.85));
        let shorter = w.taking_in(0.3, 0.15);
        assert!((shorter.distance_lo_m - 0.15).abs() < 1e-6);
        assert_eq!(shorter.distance_hi_m, w.distance_hi_m);
        assert_eq!(w.taking_in(0.5, 0.1), w);
        assert_eq!(
            (longer.heading_lo_rad, longer.heading_hi_rad),
            (w.heading_lo_rad, w.heading_hi_rad)
        );
    }

    #[test]
    fn peak_is_the_centre_of_gravity_around_the_highest_bin() {
        let mut g = VoteGrid::<8>::default();
        for _ in 0..4 {
            g.add(3, 5, 1);
        }
        g.add(3, 6, 1);
        g.add(3, 6, 1);
        g.add(0, 0, 1);
        let p = g.peak().unwrap();
        assert_eq!(p.score, 6);
        assert!((p.heading_bin - 3.0).abs() < 1e-6);
        assert!((p.distance_bin - (5.0 * 4.0 + 6.0 * 2.0) / 6.0).abs() < 1e-6);
        assert!(VoteGrid::<8>::default().peak().is_none());
    }

    #[test]
    fn a_voter_gives_each_bin_its_best_weight_once() {
        let mut votes = BestPerBin::<8>::new();
        votes.keep(2, 3, 4);
        votes.keep(2, 3, 7);
        votes.keep(2, 3, 5);
        votes.keep(5, 1, 2);
        votes.keep(9, 9, 50); // outside: ignored
        let mut g = VoteGrid::<8>::new();
        votes.add_to(&mut g);
        assert_eq!((g.get(2, 3), g.get(5, 1)), (7, 2));
        // Forgotten once added: a second voter starts empty.
        votes.keep(2, 3, 1);
        votes.add_to(&mut g);
        assert_eq!(g.get(2, 3), 8);
        let total: u32 = (0..8)
            .flat_map(|i| (0..8).map(move |j| (i, j)))
            .map(|(i, j)| u32::from(g.get(i, j)))
            .sum();
        assert_eq!(total, 10);
    }

    #[test]
    fn a_voter_with_more_bins_than_listed_adds_the_same_votes() {
        let mut votes = BestPerBin::<64>::new();
        let mut direct = VoteGrid::<64>::new();
        let cells = (0..64).flat_map(|i| (0..64).map(move |j| (i, j)));
        for (n, (i, j)) in cells.enumerate().filter(|(n, _)| n % 3 != 1) {
            let w = (n % 7 + 1) as u8;
            votes.keep(i, j, w);
            direct.add(i, j, u16::from(w));
        }
        let mut g = VoteGrid::<64>::new();
        votes.add_to(&mut g);
        const { assert!(2 * 64 * 64 / 3 > KEPT_BINS) };
        assert_eq!(g, direct);
        // Listing again afterwards, from empty.
        votes.keep(1, 2, 5);
        votes.add_to(&mut g);
        assert_eq!(g.get(1, 2), direct.get(1, 2) + 5);
        votes.add_to(&mut g);
        assert_eq!(g.get(1, 2), direct.get(1, 2) + 5);
    }

    #[test]
    fn tied_bins_give_their_midpoint_whichever_comes_first() {
        // Two equal bins with equal shoulders: the answer is halfway, not biased to the first.
        let mut g = VoteGrid::<16>::default();
        for (j, n) in [(5, 2), (6, 9), (7, 9), (8, 2)] {
            for _ in 0..n {
                g.add(4, j, 1);
            }
        }
        let p = g.peak().unwrap();
        assert!((p.distance_bin - 6.5).abs() < 1e-3, "{p:?}");
        assert!((p.heading_bin - 4.0).abs() < 1e-6);
    }

    #[test]
    fn centre_above_keeps_bins_over_the_fraction() {
        let mut g = VoteGrid::<4>::default();
        for _ in 0..10 {
            g.add(1, 1, 1);
        }
        for _ in 0..7 {
            g.add(1, 3, 1);
        }
        for _ in 0..6 {
            g.add(3, 3, 1);
        }
        let p = g.centre_above(0.7).unwrap();
        assert!((p.distance_bin - (10.0 + 21.0) / 17.0).abs() < 1e-6);
        assert!((p.heading_bin - 1.0).abs() < 1e-6);
    }

    #[test]
    fn window_bins_round_trip() {
        let w = MotionWindow::around(
            Motion {
                heading_change_rad: 0.01,
                distance_m: 1.0,
            },
            0.02,
            0.3,
        );
        let j = w.distance_bin(1.05, 64).unwrap();
        assert!((w.distance_at(j as f32, 64) - 1.05).abs() <= 0.5 * w.distance_step_m(64));
        assert!(w.distance_bin(1.31, 64).is_none());
        assert!(w.distance_bin(f32::NAN, 64).is_none());
        let m = w.motion_at(31.5, 31.5, 64);
        assert!((m.heading_change_rad - 0.01).abs() < 1e-6 && (m.distance_m - 1.0).abs() < 1e-6);
    }

    #[test]
    fn adding_outside_the_grid_is_ignored() {
        let mut g = VoteGrid::<4>::default();
        g.add(4, 0, 1);
        g.add(0, 9, 1);
        assert!(g.peak().is_none());
        for _ in 0..70_000 {
            g.add(0, 0, 1);
        }
        assert_eq!(g.get(0, 0), u16::MAX);
    }
}
