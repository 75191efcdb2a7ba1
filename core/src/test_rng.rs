//! Fixed pseudo-random numbers for tests: a xorshift generator, so that scenes are spread but
//! the same on every run and target.

/// Uniform numbers in [0, 1) in steps of 1e-4, from `seed` (not zero).
pub(crate) fn uniform(seed: u32) -> impl FnMut() -> f32 {
    let mut x = seed;
    move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        (x % 10_000) as f32 / 10_000.0
    }
}
