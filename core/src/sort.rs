//! Sorting without allocation or a panic path: the slices sorted here hold a few dozen items,
//! and `core`'s sorts keep a panic for comparisons that are not a total order, which the
//! firmware's link check refuses.

/// Sorts `items` by `key`, smallest first, keeping the order of equal keys (insertion sort).
pub(crate) fn sort_by_key<T>(items: &mut [T], key: impl Fn(&T) -> f32) {
    for i in 1..items.len() {
        let mut j = i;
        while j > 0 {
            let Some([a, b]) = items.get_mut(j - 1..=j) else {
                break;
            };
            if key(a) <= key(b) {
                break;
            }
            core::mem::swap(a, b);
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sorts_by_key_keeping_ties_in_order() {
        let mut items = [(3.0, 'a'), (1.0, 'b'), (3.0, 'c'), (-2.0, 'd'), (1.0, 'e')];
        sort_by_key(&mut items, |&(k, _)| k);
        assert_eq!(
            items,
            [(-2.0, 'd'), (1.0, 'b'), (1.0, 'e'), (3.0, 'a'), (3.0, 'c')]
        );
        sort_by_key(&mut items[..0], |&(k, _)| k);
    }
}
