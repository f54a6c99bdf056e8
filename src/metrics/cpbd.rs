//! CPBD, the no-reference sharpness metric of Narvekar & Karam: "A
//! No-Reference Image Blur Metric Based on the Cumulative Probability of
//! Blur Detection (CPBD)", IEEE TIP 20(9), 2011 — used by Philippi et al.
//! 2025 (Fig. 15) to compare sharpness with the reference.
//!
//! Input: the grey levels MATLAB's `rgb2gray` gives for the display image
//! saved as 8-bit sRGB ([`LinearImage::display_grey_8bit`]: channels
//! clamped to `[0, 1]`, encoded and rounded to 8 bits, then `round(0.2989
//! R′ + 0.5870 G′ + 0.1140 B′)`), as the original works on 8-bit grey
//! images made so. Until session 55 it was `round(255 · Y′)` of the Rec. 709
//! luminance before the encoding, which agrees on grey and differs on
//! saturated colours (pure red 127 against rgb2gray's 76), so edges
//! between coloured surfaces (the Cornell box's walls) had other contrasts
//! than the authors' code sees.
//!
//! Algorithm (Sec. III of the paper, and the authors' MATLAB code as ported
//! by the `cpbd` Python package):
//! 1. Edge pixels for width measurement: vertical-edge Sobel detector
//!    (MATLAB `edge(I, 'sobel', [], 'vertical')`): `b = (S_x ∗ I)²` with the
//!    Sobel kernel `/8`, threshold `b > 4 · mean(b)`, MATLAB's thinning on
//!    interior pixels: a local maximum of `b` along x (where `|S_x| ≥ |S_y|`)
//!    or along y, `b(−1) ≤ b > b(+1)` (ties keep the right/lower pixel).
//! 2. Edge width (Marziliano et al. 2002): at each such pixel whose gradient
//!    direction (central differences) quantizes to 0° or 180°, walk left and
//!    right along the row to the nearest local extremum; width = left + right
//!    steps (at most 101 each way).
//! 3. A 64 × 64 block grid over the whole image, with partial blocks at the
//!    right and bottom borders (see the deviation below); a block is an *edge
//!    block* when it holds more than `0.002 ·` (its pixel count) Canny edge
//!    pixels (MATLAB `edge(I, 'canny')` defaults: σ = √2, thresholds at the
//!    70th percentile of the gradient magnitude and 0.4 × that, hysteresis).
//! 4. Block contrast `C = max − min` of `I`; just-noticeable-blur width
//!    `w_JNB = 5` for `C ≤ 50`, `3` otherwise (Sec. II).
//! 5. `P_blur = 1 − exp(−|w / w_JNB|^β)`, `β = 3.6` (Eq. 4), per edge pixel of
//!    every edge block; histogram in steps of 0.01.
//! 6. `CPBD = P(P_blur ≤ P_JNB)`, `P_JNB = 0.63` (Eq. 6): the fraction of
//!    edges whose rounded `P_blur` is at most 0.63. Higher is sharper.
//!
//! Simplifications, stated honestly: our Canny smooths with a sampled
//! Gaussian and takes Sobel derivatives (MATLAB convolves with derivative-of-
//! Gaussian kernels) and uses the exact 70th percentile rather than MATLAB's
//! 64-bin histogram, so edge sets can differ by a few pixels.
//!
//! **Deviation from the authors' software: partial border blocks.** The
//! MATLAB code and the `cpbd` package use whole 64 × 64 blocks only, which is
//! harmless at the paper's 960 × 1080 but at our default 160 × 120 would score
//! only `x < 128, y < 64` (43 % of the image) and nothing at all in images
//! under 64 pixels in a dimension. We add the partial blocks at the right and
//! bottom borders, each with the edge-block threshold scaled by its own area
//! (`0.002 · width · height`). For images whose sides are multiples of 64
//! this changes nothing.
//!
//! **No edges** (e.g. a constant image): `cpbd = 0` with `edges = 0`, as the
//! `cpbd` Python package returns (the authors' MATLAB gives NaN); callers
//! check `edges`: `ImageMetrics` reports no value then, and the frame's
//! metric is the mean over the eyes that have edges.
//!
//! **Edge direction**: where the horizontal central difference is 0 and the
//! vertical is not, the gradient angle is ±90° and the pixel is not
//! measured (a vertical edge only); the authors' code leaves the angle at
//! 0° there and measures it as a rising edge. On noisy 64×64 images that
//! is 0.02 % of the Sobel edge pixels, below 10⁻³ in CPBD.

use super::check::MetricsError;
use super::filter::{gaussian_kernel, separable};
use super::image::LinearImage;

/// Block size (pixels), Sec. III.
pub const CPBD_BLOCK: usize = 64;
/// Edge-block threshold: fraction of edge pixels in a block.
pub const CPBD_EDGE_FRACTION: f32 = 0.002;
/// Shape parameter β of the psychometric function (Eq. 4).
pub const CPBD_BETA: f32 = 3.6;
/// Probability of blur detection at the JNB width (Eq. 6).
pub const CPBD_P_JNB: f32 = 0.63;

/// CPBD sharpness and how many edges it rests on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpbdResult {
    /// Fraction of edge pixels with `P_blur ≤ 0.63`, in `[0, 1]`; 0 without edges.
    pub cpbd: f32,
    /// Number of edge pixels with a measured width in edge blocks.
    pub edges: usize,
    /// Number of edge blocks.
    pub edge_blocks: usize,
}

/// CPBD of one image (no reference).
pub fn cpbd(image: &LinearImage) -> Result<CpbdResult, MetricsError> {
    super::check::check_len("cpbd: rgb pixels", image.len(), image.width, image.height)?;
    if image.is_empty() {
        return Err(MetricsError::Empty {
            what: "cpbd: image",
        });
    }
    let (w, h) = (image.width, image.height);
    let img: Vec<f32> = image.display_grey_8bit();
    let (sx, sy) = sobel(&img, w, h);
    let vertical = vertical_sobel_edges(&sx, &sy, w, h);
    let block_edges = canny_edges(&img, w, h);
    let widths = marziliano_widths(&vertical, &img, w, h);

    let mut hist = [0usize; 101];
    let (mut edges, mut edge_blocks) = (0usize, 0usize);
    // 64 × 64 grid over the whole image, partial blocks at the right and
    // bottom borders (a deviation, see the module doc).
    for y0 in (0..h).step_by(CPBD_BLOCK) {
        for x0 in (0..w).step_by(CPBD_BLOCK) {
            let (x1, y1) = ((x0 + CPBD_BLOCK).min(w), (y0 + CPBD_BLOCK).min(h));
            let idx = || (y0..y1).flat_map(move |y| (x0..x1).map(move |x| y * w + x));
            let count = idx().filter(|&i| block_edges[i]).count();
            if count as f32 <= CPBD_EDGE_FRACTION * ((x1 - x0) * (y1 - y0)) as f32 {
                continue;
            }
            edge_blocks += 1;
            let (lo, hi) = idx().fold((f32::MAX, f32::MIN), |(lo, hi), i| {
                (lo.min(img[i]), hi.max(img[i]))
            });
            let w_jnb = if hi - lo <= 50.0 { 5.0 } else { 3.0 };
            for i in idx() {
                if widths[i] > 0.0 {
                    let p = 1.0 - (-(widths[i] / w_jnb).abs().powf(CPBD_BETA)).exp();
                    hist[((p * 100.0).round() as usize).min(100)] += 1;
                    edges += 1;
                }
            }
        }
    }
    let last = (CPBD_P_JNB * 100.0).round() as usize;
    let sharp: usize = hist[..=last].iter().sum();
    Ok(CpbdResult {
        cpbd: if edges > 0 {
            sharp as f32 / edges as f32
        } else {
            0.0
        },
        edges,
        edge_blocks,
    })
}

/// MATLAB `edge(I, 'sobel', [], 'vertical')` with its default thinning
/// (`kx = 1`, `ky = 0`): `b = bx²` with `bx = |sx|`, `by = |sy|`; cutoff
/// `4 · mean(b)` over the whole image (MATLAB `scale * mean2(b)`); an interior
/// pixel is an edge when `b > cutoff` and it is a local maximum along x
/// (`bx ≥ kx·by − 100·eps`, `b(x−1) ≤ b > b(x+1)`) **or** along y
/// (`by ≥ ky·bx − 100·eps`, always true for `ky = 0`; `b(y−1) ≤ b > b(y+1)`).
/// Ties thus keep the right (lower) pixel; border pixels are never edges.
/// Computed in `f64` like MATLAB (`eps` = `f64::EPSILON`); for integer grey
/// levels `sx`, `sy` are multiples of 1/8, so `b` is exact either way.
fn vertical_sobel_edges(sx: &[f32], sy: &[f32], w: usize, h: usize) -> Vec<bool> {
    const KX: f64 = 1.0;
    const KY: f64 = 0.0;
    let tol = 100.0 * f64::EPSILON;
    let bx: Vec<f64> = sx.iter().map(|&v| (v as f64).abs()).collect();
    let by: Vec<f64> = sy.iter().map(|&v| (v as f64).abs()).collect();
    let b: Vec<f64> = bx
        .iter()
        .zip(&by)
        .map(|(x, y)| KX * x * x + KY * y * y)
        .collect();
    let mut edges = vec![false; w * h];
    if w < 3 || h < 3 {
        return edges;
    }
    let cutoff = 4.0 * b.iter().sum::<f64>() / b.len() as f64;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let along_x = bx[i] >= KX * by[i] - tol && b[i - 1] <= b[i] && b[i] > b[i + 1];
            let along_y = by[i] >= KY * bx[i] - tol && b[i - w] <= b[i] && b[i] > b[i + w];
            edges[i] = b[i] > cutoff && (along_x || along_y);
        }
    }
    edges
}

/// Canny (1986) edge detector with MATLAB `edge(I, 'canny')` defaults:
/// Gaussian smoothing σ = √2, Sobel gradient, non-maximum suppression in four
/// directions, hysteresis with the high threshold at the 70th percentile of
/// the gradient magnitude and the low threshold at 0.4 × high (8-connected).
fn canny_edges(img: &[f32], w: usize, h: usize) -> Vec<bool> {
    let k = gaussian_kernel(std::f32::consts::SQRT_2, 5);
    let s = separable(img, w, h, &k, &k);
    let (gx, gy) = sobel(&s, w, h);
    let mag: Vec<f32> = gx.iter().zip(&gy).map(|(a, b)| a.hypot(*b)).collect();
    let mut sorted = mag.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let high = sorted[((0.7 * sorted.len() as f32) as usize).min(sorted.len() - 1)];
    let low = 0.4 * high;
    let get = |x: isize, y: isize| -> f32 {
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            0.0
        } else {
            mag[y as usize * w + x as usize]
        }
    };
    // Non-maximum suppression along the quantized gradient direction.
    let mut thin = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let m = mag[i];
            if m <= low {
                continue;
            }
            let angle = gy[i].atan2(gx[i]).to_degrees().rem_euclid(180.0);
            let (dx, dy) = match ((angle + 22.5) / 45.0) as usize % 4 {
                0 => (1, 0),
                1 => (1, 1),
                2 => (0, 1),
                _ => (-1, 1),
            };
            let (x, y) = (x as isize, y as isize);
            thin[i] = m >= get(x + dx, y + dy) && m > get(x - dx, y - dy);
        }
    }
    // Hysteresis: grow from strong pixels through weak ones.
    let mut edges = vec![false; w * h];
    let mut stack: Vec<usize> = (0..w * h).filter(|&i| thin[i] && mag[i] > high).collect();
    for &i in &stack {
        edges[i] = true;
    }
    while let Some(i) = stack.pop() {
        let (x, y) = ((i % w) as isize, (i / w) as isize);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                    continue;
                }
                let j = ny as usize * w + nx as usize;
                if thin[j] && !edges[j] {
                    edges[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    edges
}

/// Sobel derivatives scaled by 1/8 (MATLAB's scaling), clamp-to-edge borders.
fn sobel(img: &[f32], w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let at = |x: isize, y: isize| -> f32 {
        img[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize]
    };
    let mut sx = vec![0.0f32; w * h];
    let mut sy = vec![0.0f32; w * h];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
            let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
            let i = y as usize * w + x as usize;
            sx[i] = gx / 8.0;
            sy[i] = gy / 8.0;
        }
    }
    (sx, sy)
}

/// Marziliano et al. edge widths at vertical edge pixels (0 elsewhere), as in
/// the `cpbd` package's `marziliano_method`.
fn marziliano_widths(edges: &[bool], img: &[f32], w: usize, h: usize) -> Vec<f32> {
    const MAX_MARGIN: usize = 100;
    let mut widths = vec![0.0f32; w * h];
    if w < 3 || h < 3 {
        return widths;
    }
    for row in 1..h - 1 {
        let line = &img[row * w..(row + 1) * w];
        for col in 1..w - 1 {
            let i = row * w + col;
            if !edges[i] {
                continue;
            }
            // numpy.gradient: central differences.
            let gx = 0.5 * (line[col + 1] - line[col - 1]);
            let gy = 0.5 * (img[i + w] - img[i - w]);
            let angle = 45.0 * (gy.atan2(gx).to_degrees() / 45.0).round();
            // +1: intensity rising left to right (0°); −1: falling (±180°).
            let rising = if angle == 0.0 {
                1.0
            } else if angle.abs() == 180.0 {
                -1.0
            } else {
                continue;
            };
            // Walk left while the intensity keeps moving away from the edge.
            let mut left = MAX_MARGIN + 1;
            for m in 0..=MAX_MARGIN {
                let (inner, outer) = (col as isize - 1 - m as isize, col as isize - 2 - m as isize);
                if outer < 0 || rising * (line[outer as usize] - line[inner as usize]) >= 0.0 {
                    left = m + 1;
                    break;
                }
            }
            let mut right = MAX_MARGIN + 1;
            for m in 0..=MAX_MARGIN {
                let (inner, outer) = (col + 1 + m, col + 2 + m);
                if outer >= w || rising * (line[outer] - line[inner]) <= 0.0 {
                    right = m + 1;
                    break;
                }
            }
            widths[i] = (left + right) as f32;
        }
    }
    widths
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(n: usize, cell: usize) -> LinearImage {
        LinearImage::from_fn(n, n, |x, y| [((x / cell + y / cell) % 2) as f32; 3])
    }

    fn random(n: usize) -> LinearImage {
        // 4 × 4 cells of PCG-like hashed grey levels.
        LinearImage::from_fn(n, n, |x, y| {
            let mut s = ((x / 4) as u32).wrapping_mul(73_856_093)
                ^ ((y / 4) as u32).wrapping_mul(19_349_663);
            s = s.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            s ^= s >> 16;
            [(s & 0xff) as f32 / 255.0; 3]
        })
    }

    fn box_blur(img: &LinearImage, r: usize) -> LinearImage {
        let k = vec![1.0 / (2 * r + 1) as f32; 2 * r + 1];
        let mut out = img.clone();
        for c in 0..3 {
            let plane: Vec<f32> = img.rgb.iter().map(|p| p[c]).collect();
            let b = separable(&plane, img.width, img.height, &k, &k);
            for (o, v) in out.rgb.iter_mut().zip(b) {
                o[c] = v;
            }
        }
        out
    }

    #[test]
    fn blur_lowers_cpbd() {
        for sharp in [checker(128, 8), random(128)] {
            let a = cpbd(&sharp).unwrap();
            let b = cpbd(&box_blur(&sharp, 2)).unwrap();
            let c = cpbd(&box_blur(&sharp, 4)).unwrap();
            assert!(
                a.edges > 0 && b.edges > 0 && c.edges > 0,
                "{a:?} {b:?} {c:?}"
            );
            // Full-contrast edges have w_JNB = 3: a sharp step measures width
            // 2 (P_blur ≈ 0.2), a 3-tap box blur width 3 (P_blur = 0.632, the
            // threshold), a 5-tap one ≥ 4 (P_blur ≥ 0.9). So the sharp
            // original sits near 1 and the blurred versions near 0.
            assert!(a.cpbd > 0.9, "{a:?}");
            assert!(b.cpbd < 0.5 && c.cpbd < 0.5, "{b:?} {c:?}");
        }
        // The checker's edges all have full contrast and one width each:
        // every sharp edge is below the threshold, every blurred one above.
        let sharp = checker(128, 8);
        assert_eq!(cpbd(&sharp).unwrap().cpbd, 1.0);
        assert_eq!(cpbd(&box_blur(&sharp, 2)).unwrap().cpbd, 0.0);
        assert_eq!(cpbd(&box_blur(&sharp, 4)).unwrap().cpbd, 0.0);
    }

    /// A linear image whose display luma is exactly the given 8-bit grey levels.
    fn from_grey(grey: &[f32], w: usize, h: usize) -> LinearImage {
        let img = LinearImage::from_fn(w, h, |x, y| {
            [super::super::image::srgb_decode(grey[y * w + x] / 255.0); 3]
        });
        assert_eq!(
            img.display_grey_8bit(),
            grey,
            "grey levels must survive the sRGB round trip"
        );
        img
    }

    /// The audit's hand test: 12 × 9, rows `min(max((x − 3) · s, 0), 200)`
    /// with slope `s = 40` in row 4 and 10 elsewhere. Row 4's `b` is 156,
    /// then 625 at x = 4..=7 (a plateau), then 225; rows 3 and 5 have 306
    /// there. MATLAB `edge(I, 'sobel', [], 'vertical')` marks (x, y) =
    /// (4..=7, 4): all four are maxima along y, and (7, 4) also along x (the
    /// tie `b(x−1) ≤ b` keeps the plateau's right end). The old x-only
    /// thinning `b(x−1) < b ≥ b(x+1)` kept (4, 4) alone.
    #[test]
    fn vertical_sobel_edges_match_matlab_thinning() {
        let (w, h) = (12, 9);
        let grey: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, i / w);
                let s = if y == 4 { 40.0 } else { 10.0 };
                ((x - 3.0) * s).clamp(0.0, 200.0)
            })
            .collect();
        let (sx, sy) = sobel(&grey, w, h);
        let e = vertical_sobel_edges(&sx, &sy, w, h);
        let got: Vec<(usize, usize)> = (0..w * h)
            .filter(|&i| e[i])
            .map(|i| (i % w, i / w))
            .collect();
        assert_eq!(got, [(4, 4), (5, 4), (6, 4), (7, 4)]);
    }

    /// Rise profiles (grey-level offsets) of [`pin_row`]: amplitude 52 on the
    /// left (block contrast 52 > 50: `w_JNB = 3`), 50 on the right (`w_JNB =
    /// 5`); each has a strict maximum of the Sobel response, so no thinning
    /// ties, where MATLAB and the `cpbd` package's Octave thinning differ.
    const PIN_LEFT: [&[u8]; 4] = [
        &[0, 26, 52],
        &[0, 10, 43, 52],
        &[0, 2, 7, 42, 49, 52],
        &[0, 1, 4, 8, 45, 48, 50, 52],
    ];
    const PIN_RIGHT: [&[u8]; 4] = [
        &[0, 25, 50],
        &[0, 10, 42, 50],
        &[0, 2, 7, 40, 47, 50],
        &[0, 1, 4, 8, 43, 46, 48, 50],
    ];

    /// One row of the pinned image (every row is the same), 128 wide:
    /// segments `8 × low, rise p, 8 × high, fall q` with `p = profiles[k % 4]`,
    /// `q = profiles[(3k + 1) % 4]`, each half cut to 64 columns.
    fn pin_row() -> Vec<f32> {
        let half = |lo: u8, profiles: [&[u8]; 4], k0: usize| {
            let mut out = Vec::new();
            let mut k = k0;
            while out.len() < 64 {
                let (p, q) = (profiles[k % 4], profiles[(3 * k + 1) % 4]);
                let top = *p.last().unwrap();
                out.extend_from_slice(&[0; 8]);
                out.extend_from_slice(p);
                out.extend_from_slice(&[top; 8]);
                out.extend(q.iter().rev());
                k += 1;
            }
            out.truncate(64);
            out.into_iter().map(move |v| (lo + v) as f32)
        };
        half(60, PIN_LEFT, 0)
            .chain(half(100, PIN_RIGHT, 2))
            .collect()
    }

    /// Independent value: the authors' port, PyPI `cpbd` 1.0.7 (numpy 2.4,
    /// scipy 1.17, scikit-image 0.26), on the same 128 × 128 image (`pin_row`
    /// in every row), obtained with
    /// `/tmp/audit_metrics/venv/bin/python /tmp/cpbd_pin/gen.py`, whose core is
    ///
    /// ```text
    /// import numpy as np, scipy.ndimage as nd
    /// nd.imread = None  # cpbd imports it (gone from SciPy); compute() never calls it
    /// import cpbd
    /// L = [[0,26,52],[0,10,43,52],[0,2,7,42,49,52],[0,1,4,8,45,48,50,52]]
    /// R = [[0,25,50],[0,10,42,50],[0,2,7,40,47,50],[0,1,4,8,43,46,48,50]]
    /// def half(lo, P, k):
    ///     out = []
    ///     while len(out) < 64:
    ///         p, q = P[k % 4], P[(3 * k + 1) % 4]
    ///         out += [lo + v for v in [0] * 8 + p + [p[-1]] * 8 + q[::-1]]; k += 1
    ///     return out[:64]
    /// row = half(60, L, 0) + half(100, R, 2)
    /// print(cpbd.compute(np.tile(np.array(row, np.uint8), (128, 1))))
    /// ```
    ///
    /// → `0.6666666666666666`. The package's edge
    /// detectors are not MATLAB's (Octave Sobel threshold `2·rms(S_x)` and
    /// strict two-sided thinning; skimage Canny, σ = 1, absolute thresholds),
    /// so the image is built for them to agree with ours: constant along y
    /// (no y maxima, no thinning ties), every peak well above both Sobel
    /// thresholds (the script checks the interior Sobel edge sets are equal:
    /// 9 columns × 126 rows = 1134), and all four blocks edge blocks under
    /// either Canny. What the pin checks is then the Marziliano widths (2, 3,
    /// 3, 2, 5 left; 5, 7, 7, 5 right), the block contrast → w_JNB choice,
    /// the histogram and the `P_blur ≤ 0.63` cut: 6 of 9 columns sharp.
    /// CPBD is a ratio of counts; float differences could only move an edge
    /// between histogram buckets if `100 · P_blur` lay within ~1e-4 of a
    /// `.5` (here it is 20.73, 63.21, 99.81, 14.70, 96.52), so the value is
    /// exact up to the f32 division: tolerance 1e-6. Sides are multiples of
    /// 64, so the partial-block deviation does not enter.
    #[test]
    fn matches_cpbd_package_on_synthetic_image() {
        let row = pin_row();
        assert_eq!(row.len(), 128);
        let grey: Vec<f32> = (0..128).flat_map(|_| row.iter().copied()).collect();
        let r = cpbd(&from_grey(&grey, 128, 128)).unwrap();
        assert_eq!((r.edges, r.edge_blocks), (1134, 4), "{r:?}");
        assert!((r.cpbd - 0.666_666_7).abs() < 1e-6, "{r:?}");
    }

    /// 160 × 120 (the default size): flat grey above row 64, an 8-pixel
    /// black-and-white checkerboard below. Whole blocks alone cover only
    /// `y < 64`, which is flat, so the old code found no edges at all; the
    /// partial bottom blocks (64 × 56 and 32 × 56) score the checkerboard.
    #[test]
    fn partial_border_blocks_are_scored() {
        let img = LinearImage::from_fn(160, 120, |x, y| {
            if y < 64 {
                [0.2; 3]
            } else {
                [((x / 8 + y / 8) % 2) as f32; 3]
            }
        });
        let r = cpbd(&img).unwrap();
        assert!(r.edges > 0 && r.edge_blocks > 0, "{r:?}");
        assert!(r.cpbd > 0.9, "{r:?}");
    }

    #[test]
    fn constant_image_has_no_edges_and_zero_cpbd() {
        let r = cpbd(&LinearImage::filled(64, 64, [0.3; 3])).unwrap();
        assert_eq!((r.cpbd, r.edges, r.edge_blocks), (0.0, 0, 0));
    }

    #[test]
    fn odd_inputs_do_not_panic() {
        assert!(cpbd(&checker(3, 1)).unwrap().cpbd.is_finite());
        assert!(cpbd(&LinearImage::filled(1, 1, [f32::NAN; 3])).is_ok());
        assert!(cpbd(&LinearImage::filled(0, 5, [0.0; 3])).is_err());
        let bad = LinearImage {
            width: 4,
            height: 4,
            rgb: vec![[0.0; 3]; 3],
        };
        assert!(cpbd(&bad).is_err());
    }
}
