//! Walker's alias method (Vose 1991 construction): O(1) sampling of a
//! discrete distribution, used to pick mesh triangles by area.

/// A discrete distribution over `n` items sampled in constant time.
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    bins: Vec<AliasBin>,
    pmf: Vec<f32>,
    total: f64,
}

#[derive(Clone, Copy, Debug)]
struct AliasBin {
    threshold: f32,
    alias: u32,
}

impl AliasTable {
    /// Builds from non-negative weights; `None` if their sum is not
    /// positive and finite.
    pub fn new(weights: &[f32]) -> Option<Self> {
        let total: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        if weights.is_empty() || !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let n = weights.len();
        let pmf: Vec<f32> = weights
            .iter()
            .map(|&w| (w.max(0.0) as f64 / total) as f32)
            .collect();
        let mut scaled: Vec<f64> = weights
            .iter()
            .map(|&w| w.max(0.0) as f64 / total * n as f64)
            .collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut bins = vec![
            AliasBin {
                threshold: 1.0,
                alias: 0
            };
            n
        ];
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            bins[s] = AliasBin {
                threshold: scaled[s] as f32,
                alias: l as u32,
            };
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        for i in small.into_iter().chain(large) {
            bins[i] = AliasBin {
                threshold: 1.0,
                alias: i as u32,
            };
        }
        Some(Self { bins, pmf, total })
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.bins.len()
    }

    /// True when there are no items.
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// Sum of the weights it was built from.
    pub fn total(&self) -> f32 {
        self.total as f32
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Picks an item with `u` in [0, 1); returns it and `u` remapped to a
    /// fresh uniform value in [0, 1) for reuse.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let n = self.bins.len();
        let x = u * n as f32;
        let i = (x as usize).min(n - 1);
        let frac = (x - i as f32).min(1.0 - f32::EPSILON / 2.0);
        let bin = self.bins[i];
        if frac < bin.threshold {
            (i, (frac / bin.threshold).min(ONE_MINUS_EPS))
        } else {
            (
                bin.alias as usize,
                ((frac - bin.threshold) / (1.0 - bin.threshold)).min(ONE_MINUS_EPS),
            )
        }
    }
}

const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::chi2_discrete;

    #[test]
    fn alias_table_matches_weights() {
        let w = [1.0, 0.0, 3.0, 0.5, 2.5, 7.0];
        let t = AliasTable::new(&w).unwrap();
        let n = 200_000;
        let mut counts = vec![0u64; w.len()];
        let mut rng = crate::sampler::Pcg32::new(7, 1);
        for _ in 0..n {
            counts[t.sample(rng.next_f32()).0] += 1;
        }
        let expected: Vec<f64> = (0..w.len()).map(|i| t.pmf(i) as f64 * n as f64).collect();
        chi2_discrete(&counts, &expected, 0.01).unwrap();
        assert_eq!(counts[1], 0);
    }

    #[test]
    fn rejects_zero_weights() {
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[]).is_none());
    }
}
