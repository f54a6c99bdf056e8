//! Walker's alias method (Walker 1977; Vose 1991's numerically stable
//! construction): draws index i with probability w_i / Σw in O(1) from two
//! uniform numbers. Used to pick an emissive triangle by power for next-event
//! estimation (shaders/common/lights.glsl, `sample_emitter`).
//!
//! Why an alias table and not a light BVH (Conty & Kulla 2018): the table is
//! O(1) per sample with one cache line read, needs no traversal stack, and its
//! pmf (power / total power) is what the MIS weight of a BSDF-sampled hit needs
//! in one lookup. A light BVH would also weigh emitters by distance and
//! orientation, which pays off with thousands of emitters spread over a large
//! scene; the shipped scenes have a handful (the Cornell box: 2 triangles).

/// One table entry: keep index `i` with probability `prob`, else take `alias`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AliasEntry {
    pub prob: f32,
    pub alias: u32,
}

#[derive(Clone, Debug)]
pub struct AliasTable {
    pub entries: Vec<AliasEntry>,
    /// The normalised probabilities w_i / Σw (f32, as the GPU reads them).
    pub pmf: Vec<f32>,
}

impl AliasTable {
    /// A table over non-negative weights; `None` when there is nothing to pick
    /// (no weights, or all zero / not finite).
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let w: Vec<f64> = weights
            .iter()
            .map(|&x| if x.is_finite() && x > 0.0 { x } else { 0.0 })
            .collect();
        let total: f64 = w.iter().sum();
        let n = w.len();
        if n == 0 || total <= 0.0 || !total.is_finite() {
            return None;
        }
        // Scaled probabilities n·p_i; "small" below 1, "large" at or above.
        let mut q: Vec<f64> = w.iter().map(|x| x * n as f64 / total).collect();
        let mut entries = vec![
            AliasEntry {
                prob: 1.0,
                alias: 0
            };
            n
        ];
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| q[i] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            entries[s] = AliasEntry {
                prob: q[s] as f32,
                alias: l as u32,
            };
            q[l] -= 1.0 - q[s];
            if q[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What remains has q = 1 up to rounding (Vose): keep with probability 1.
        for i in small.into_iter().chain(large) {
            entries[i] = AliasEntry {
                prob: 1.0,
                alias: i as u32,
            };
        }
        let pmf = w.iter().map(|x| (x / total) as f32).collect();
        Some(AliasTable { entries, pmf })
    }

    /// The index for 32 uniform random bits `pick` (the column,
    /// ⌊pick·n / 2^32⌋: uniform over up to 2^32 columns to within one part
    /// in 2^32/n) and a uniform `u_alias` ∈ [0, 1) — exactly what
    /// `sample_emitter` in lights.glsl computes.
    pub fn sample(&self, pick: u32, u_alias: f32) -> usize {
        let n = self.entries.len();
        let i = ((pick as u64 * n as u64) >> 32) as usize;
        let e = self.entries[i];
        if u_alias < e.prob {
            i
        } else {
            e.alias as usize
        }
    }

    /// The probability with which `sample` returns each index, from the table
    /// itself (for checking the construction): (1/n)·(prob_i + Σ_{j: alias_j = i} (1 − prob_j)).
    pub fn implied_pmf(&self) -> Vec<f64> {
        let n = self.entries.len();
        let mut p = vec![0.0f64; n];
        for (i, e) in self.entries.iter().enumerate() {
            p[i] += e.prob as f64 / n as f64;
            p[e.alias as usize] += (1.0 - e.prob as f64) / n as f64;
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn implied_probabilities_equal_the_weights() {
        let w = [0.0, 1.0, 3.0, 0.5, 10.0, 1e-6, 2.0];
        let t = AliasTable::new(&w).unwrap();
        let total: f64 = w.iter().sum();
        for (i, p) in t.implied_pmf().iter().enumerate() {
            // f32 probabilities: a few ulps of 1 per entry.
            assert!(
                (p - w[i] / total).abs() < 1e-6,
                "index {i}: {p} vs {}",
                w[i] / total
            );
            assert!((t.pmf[i] as f64 - w[i] / total).abs() < 1e-7);
        }
        // A zero weight is never returned.
        for k in 0..1000u64 {
            let pick = ((k << 32) / 1000) as u32;
            for v in [0.0, 0.3, 0.999] {
                assert_ne!(t.sample(pick, v), 0);
            }
        }
    }

    #[test]
    fn nothing_to_pick() {
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[f64::NAN]).is_none());
        let one = AliasTable::new(&[2.0]).unwrap();
        assert_eq!(one.sample(u32::MAX, 0.99), 0);
    }

    /// The column is uniform over many columns: with 3·10^6 of them every
    /// column gets ⌊2^32/n⌋ or ⌈2^32/n⌉ of the 2^32 picks (a relative spread
    /// of 1/1431, where a 24-bit float's ⌊u·n⌋ gave columns 5 or 6 of its
    /// 2^24 values: −11 % to +7 %, or none at all beyond 2^24 columns).
    /// Counted exactly over the picks' column boundaries.
    #[test]
    fn the_column_is_uniform_over_millions_of_entries() {
        let n: u64 = 3_000_000;
        let t = AliasTable::new(&vec![1.0; n as usize]).unwrap();
        // Column i takes the picks in [⌈i·2^32/n⌉, ⌈(i+1)·2^32/n⌉).
        let first = |i: u64| (i << 32).div_ceil(n);
        let (lo, hi) = ((1u64 << 32) / n, (1u64 << 32).div_ceil(n));
        for i in (0..n).step_by(997).chain([n - 1]) {
            let count = first(i + 1) - first(i);
            assert!(count == lo || count == hi, "column {i}: {count} picks");
            assert_eq!(t.sample(first(i) as u32, 0.5), i as usize);
            assert_eq!(t.sample((first(i + 1) - 1) as u32, 0.5), i as usize);
        }
    }
}
