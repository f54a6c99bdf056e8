//! Importance sampling of an equirectangular environment map: a piecewise-
//! constant 2D distribution over its texels (pbrt-v3 §14.2.4, "Infinite Area
//! Lights"), sampled in shaders/common/sky.glsl (`env_sample`, `env_pdf`).
//!
//! Texel cell (x, y) gets weight f(x, y) = L̄(x, y) · sin θ_y, θ_y = π(y + ½)/h,
//! so the density in (u, v) ∈ [0, 1)² follows the radiance per solid angle
//! (dω = 2π² sin θ du dv). L̄ is the mean over the cell of the luminance as
//! the shader sees it — the map is looked up with bilinear filtering (u
//! wraps, v clamps: gpu_scene.rs' sampler) — which is the separable filter
//! (⅛, ¾, ⅛) over the texel and its neighbours (the cell average of a tent of
//! one texel's width; as pbrt-v4 builds its image-light distribution from the
//! filtered image). Weighting by the bare texel instead would leave about a
//! third of a small bright source's energy (its bilinear halo) in cells of
//! its dim neighbours, sampled with their small probability. The marginal CDF over rows and each row's
//! conditional CDF over columns are stored as h + 1 and h·(w + 1) floats; the
//! GPU computes probabilities as differences of consecutive CDF entries, so the
//! pdf it evaluates is exactly the one it samples with. Rows (or maps) without
//! energy get a uniform conditional (never picked: their marginal mass is 0).
//!
//! Within a cell the filtered radiance still varies while the pdf is
//! constant; MIS with BSDF sampling keeps the estimate unbiased either way.

use super::emitters::luminance;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct EnvDistribution {
    pub width: u32,
    pub height: u32,
    /// h + 1 entries, 0 … 1.
    pub marginal_cdf: Vec<f32>,
    /// h rows of w + 1 entries, each 0 … 1.
    pub conditional_cdf: Vec<f32>,
}

fn cdf(weights: &[f64]) -> Vec<f32> {
    let total: f64 = weights.iter().sum();
    let n = weights.len();
    let mut c = Vec::with_capacity(n + 1);
    c.push(0.0f32);
    let mut acc = 0.0f64;
    for (i, w) in weights.iter().enumerate() {
        acc += w;
        c.push(if total > 0.0 {
            (acc / total) as f32
        } else {
            (i + 1) as f32 / n as f32
        });
    }
    // Exactly 1 at the end, non-decreasing throughout.
    c[n] = 1.0;
    for i in 1..=n {
        c[i] = c[i].max(c[i - 1]).min(1.0);
    }
    c
}

/// Mean luminance of the bilinearly filtered map over each texel cell: the
/// separable (⅛, ¾, ⅛) filter, wrapping in u and clamping in v. Non-finite or
/// negative texels count as 0.
pub fn cell_mean_luminance(width: u32, height: u32, texels: &[[f32; 3]]) -> Vec<f64> {
    let (w, h) = (width as usize, height as usize);
    let lum: Vec<f64> = texels
        .iter()
        .map(|t| {
            let l = luminance(Vec3::from_array(*t));
            if l.is_finite() && l > 0.0 {
                l
            } else {
                0.0
            }
        })
        .collect();
    const K: [f64; 3] = [0.125, 0.75, 0.125];
    // Along u (wrapping), then along v (clamped).
    let mut along_u = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            along_u[y * w + x] = (0..3)
                .map(|k| K[k] * lum[y * w + (x + w + k - 1) % w])
                .sum();
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            out[y * w + x] = (0..3)
                .map(|k| K[k] * along_u[(y + k).saturating_sub(1).min(h - 1) * w + x])
                .sum();
        }
    }
    out
}

impl EnvDistribution {
    /// `None` when the map has no energy (nothing to importance-sample).
    pub fn new(width: u32, height: u32, texels: &[[f32; 3]]) -> Option<EnvDistribution> {
        let (w, h) = (width as usize, height as usize);
        if w == 0 || h == 0 || texels.len() != w * h {
            return None;
        }
        let filtered = cell_mean_luminance(width, height, texels);
        let mut rows = Vec::with_capacity(h);
        let mut conditional_cdf = Vec::with_capacity(h * (w + 1));
        for y in 0..h {
            let sin_t = (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
            let f: Vec<f64> = filtered[y * w..(y + 1) * w]
                .iter()
                .map(|l| l * sin_t)
                .collect();
            rows.push(f.iter().sum::<f64>());
            conditional_cdf.extend(cdf(&f));
        }
        if rows.iter().sum::<f64>() <= 0.0 {
            return None;
        }
        Some(EnvDistribution {
            width,
            height,
            marginal_cdf: cdf(&rows),
            conditional_cdf,
        })
    }

    /// Density in (u, v) of texel (x, y) — what `env_pdf` computes on the GPU.
    pub fn pdf_uv(&self, x: u32, y: u32) -> f64 {
        let (w, h) = (self.width as usize, self.height as usize);
        let (x, y) = (x as usize, y as usize);
        let pm = (self.marginal_cdf[y + 1] - self.marginal_cdf[y]) as f64;
        let row = &self.conditional_cdf[y * (w + 1)..(y + 1) * (w + 1)];
        let pc = (row[x + 1] - row[x]) as f64;
        pm * h as f64 * pc * w as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn density_integrates_to_one_and_follows_luminance_times_sine() {
        let (w, h) = (8u32, 4u32);
        let texels: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                if i % 5 == 0 {
                    [0.0; 3]
                } else {
                    [i as f32, 1.0, 0.5]
                }
            })
            .collect();
        let d = EnvDistribution::new(w, h, &texels).unwrap();
        let mut total = 0.0;
        for y in 0..h {
            for x in 0..w {
                total += d.pdf_uv(x, y) / (w * h) as f64;
            }
        }
        assert!((total - 1.0).abs() < 1e-5, "∫p = {total}");
        // Ratio of two cells' densities = ratio of filtered lum·sinθ.
        let lf = cell_mean_luminance(w, h, &texels);
        let f = |x: u32, y: u32| {
            lf[(y * w + x) as usize] * (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin()
        };
        let r = d.pdf_uv(3, 1) / d.pdf_uv(6, 2);
        assert!((r - f(3, 1) / f(6, 2)).abs() < 1e-4 * r, "{r}");
        assert!(EnvDistribution::new(2, 1, &[[0.0; 3]; 2]).is_none());
    }

    #[test]
    fn cell_means_are_the_bilinear_filter_averaged_over_each_cell() {
        // One bright texel in a 4×3 map: ¾·¾ in its cell, ⅛·¾ beside it
        // (wrapping across u = 0), ⅛·⅛ diagonally, clamped rows keep the mass.
        let mut t = vec![[0.0f32; 3]; 12];
        t[4] = [1.0; 3]; // (x 0, y 1)
        let m = cell_mean_luminance(4, 3, &t);
        let l = 1.0;
        assert!((m[4] - 0.5625 * l).abs() < 1e-12);
        assert!((m[5] - 0.09375 * l).abs() < 1e-12 && (m[7] - 0.09375 * l).abs() < 1e-12);
        assert!((m[0] - 0.09375 * l).abs() < 1e-12 && (m[3] - 0.015625 * l).abs() < 1e-12);
        assert!((m.iter().sum::<f64>() - l).abs() < 1e-12, "mass is kept");
        // A constant map stays constant (clamped v rows included).
        let c = cell_mean_luminance(5, 2, &[[2.0; 3]; 10]);
        assert!(c.iter().all(|v| (v - 2.0).abs() < 1e-12), "{c:?}");
    }
}
