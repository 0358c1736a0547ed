//! Cycle detection: how often each working set has been factored in one run.

use sweeping_api::FastMap;

/// How often the same working set may be factored before the method is declared cycling.
pub(super) const REPEATS: u32 = 3;

/// How often each support (a set of rows) has been factored in one run of the method.
///
/// Sorting and hashing every support to count it would cost more than the count is worth
/// (measured: `docs/lab/2026-11-25-one-ldl-code.md`): a support is found by a fingerprint
/// that does not depend on the order of its rows, and sorted only when the fingerprint has
/// been seen before (to tell a repeat from a collision).
#[derive(Debug, Default)]
pub(super) struct Visits {
    /// By fingerprint: the supports seen with it (sorted once a later one shares it) and
    /// their counts.
    seen: FastMap<u64, Vec<(Vec<usize>, bool, u32)>>,
}

impl Visits {
    /// Counts one more visit of `support` and returns its number of visits.
    pub(super) fn count(&mut self, support: &[usize]) -> u32 {
        let fingerprint = support
            .iter()
            .fold(0u64, |acc, &i| acc.wrapping_add(mix(i as u64)));
        let same = self.seen.entry(fingerprint).or_default();
        if !same.is_empty() {
            let mut key = support.to_vec();
            key.sort_unstable();
            for (other, sorted, count) in same.iter_mut() {
                if !*sorted {
                    other.sort_unstable();
                    *sorted = true;
                }
                if *other == key {
                    *count += 1;
                    return *count;
                }
            }
            same.push((key, true, 1));
        } else {
            same.push((support.to_vec(), false, 1));
        }
        1
    }

    pub(super) fn clear(&mut self) {
        self.seen.clear();
    }
}

/// SplitMix64's finalizer: a row index spread over 64 bits, so that sums of them collide
/// rarely.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_support_is_counted_whatever_the_order_of_its_rows() {
        let mut visits = Visits::default();
        assert_eq!(visits.count(&[3, 1, 2]), 1);
        assert_eq!(visits.count(&[1, 2]), 1);
        assert_eq!(visits.count(&[1, 2, 3]), 2);
        assert_eq!(visits.count(&[2, 3, 1]), 3);
        assert_eq!(visits.count(&[2, 1]), 2);
        assert_eq!(visits.count(&[]), 1);
        visits.clear();
        assert_eq!(visits.count(&[1, 2, 3]), 1);
    }

    #[test]
    fn supports_sharing_a_fingerprint_are_told_apart() {
        // A support seen before under the fingerprint of {1, 2} (a collision, planted).
        let mut visits = Visits::default();
        let fingerprint = mix(1).wrapping_add(mix(2));
        visits
            .seen
            .insert(fingerprint, vec![(vec![7, 5, 6], false, 4)]);
        assert_eq!(visits.count(&[2, 1]), 1);
        assert_eq!(visits.count(&[1, 2]), 2);
        // The planted support was sorted to be compared, and keeps its count.
        let same = &visits.seen[&fingerprint];
        assert_eq!(same[0], (vec![5, 6, 7], true, 4));
        assert_eq!(same[1], (vec![1, 2], true, 2));
        // mix is SplitMix64's output (its published first three from seed 0)…
        let gamma = 0x9e37_79b9_7f4a_7c15u64;
        assert_eq!(mix(0), 0xe220_a839_7b1d_cdaf);
        assert_eq!(mix(gamma), 0x6e78_9e6a_a1b9_65f4);
        assert_eq!(mix(gamma.wrapping_mul(2)), 0x06c4_5d18_8009_454f);
        // …and spreads neighbouring rows: no two of the first thousand collide.
        let mut mixed: Vec<u64> = (0..1000).map(mix).collect();
        mixed.sort_unstable();
        mixed.dedup();
        assert_eq!(mixed.len(), 1000);
    }
}
