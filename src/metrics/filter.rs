//! Separable 2-D filtering of single-channel float planes, shared by SSIM,
//! FLIP and CPBD.
//!
//! Filters are applied as *correlations* (`out(x) = Σ_k k[i] · in(x + i − r)`);
//! every kernel used in this module is symmetric or antisymmetric, and the
//! metrics only use the magnitude of antisymmetric responses, so correlation
//! and convolution give the same metric. Borders **clamp to the edge**
//! (`… 0 0 | 0 1 … n−1 | n−1 n−1 …`), as NVIDIA's C++/Python FLIP package
//! (`flip-evaluator` 1.7) does; with it our FLIP maps match that package at
//! every pixel, borders included (see the tests in `flip.rs`).

/// Clamp index `i` into `0..n`. `n > 0`.
#[inline]
pub(crate) fn clamp_index(i: isize, n: usize) -> usize {
    i.clamp(0, n as isize - 1) as usize
}

/// Correlate a `width × height` plane with `kx` along x and then `ky` along y
/// (odd lengths, centred). Returns a plane of the same size.
pub(crate) fn separable(
    plane: &[f32],
    width: usize,
    height: usize,
    kx: &[f32],
    ky: &[f32],
) -> Vec<f32> {
    debug_assert_eq!(plane.len(), width * height);
    if width == 0 || height == 0 {
        return Vec::new();
    }
    let rx = (kx.len() / 2) as isize;
    let ry = (ky.len() / 2) as isize;
    let mut tmp = vec![0.0f32; width * height];
    for y in 0..height {
        let row = &plane[y * width..(y + 1) * width];
        let out = &mut tmp[y * width..(y + 1) * width];
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0f32;
            for (i, &k) in kx.iter().enumerate() {
                acc += k * row[clamp_index(x as isize + i as isize - rx, width)];
            }
            *o = acc;
        }
    }
    let mut out = vec![0.0f32; width * height];
    for y in 0..height {
        for (i, &k) in ky.iter().enumerate() {
            let sy = clamp_index(y as isize + i as isize - ry, height);
            let src = &tmp[sy * width..(sy + 1) * width];
            let dst = &mut out[y * width..(y + 1) * width];
            for (d, &s) in dst.iter_mut().zip(src) {
                *d += k * s;
            }
        }
    }
    out
}

/// Samples of the Gaussian `exp(−x² / (2σ²))` at integer `x ∈ [−r, r]`,
/// normalized to sum 1.
pub(crate) fn gaussian_kernel(sigma: f32, radius: usize) -> Vec<f32> {
    let r = radius as isize;
    let mut k: Vec<f32> = (-r..=r)
        .map(|x| (-((x * x) as f32) / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f32 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamp_index_repeats_edges() {
        let idx: Vec<usize> = (-3..7).map(|i| clamp_index(i, 4)).collect();
        assert_eq!(idx, vec![0, 0, 0, 0, 1, 2, 3, 3, 3, 3]);
        assert_eq!(clamp_index(-5, 1), 0);
    }

    #[test]
    fn normalized_filter_preserves_constants() {
        let plane = vec![0.25f32; 5 * 3];
        let k = gaussian_kernel(1.5, 5);
        let out = separable(&plane, 5, 3, &k, &k);
        assert!(out.iter().all(|v| (v - 0.25).abs() < 1e-6));
    }
}
