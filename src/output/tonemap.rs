//! Display transform for PNG previews: exposure, the ACES filmic fit of
//! Narkowicz (2015), then the sRGB transfer function. Non-finite values map to
//! black so a preview never hides a NaN as white.

/// `x` is capped at 10⁶ (the curve reaches 1 at x ≈ 7.24 and is clamped
/// to 1 above): a
/// larger finite value overflowed x² to ∞ and ∞/∞ = NaN, a black pixel in
/// the preview (until session 47).
pub fn aces_narkowicz(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    let x = x.min(1e6);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

pub fn to_srgb8(rgb: &[[f32; 4]], exposure: f32) -> Vec<u8> {
    let mut out = Vec::with_capacity(rgb.len() * 3);
    for p in rgb {
        for &c in &p[..3] {
            let v = if c.is_finite() {
                aces_narkowicz(c.max(0.0) * exposure)
            } else {
                0.0
            };
            out.push((linear_to_srgb(v) * 255.0 + 0.5) as u8);
        }
    }
    out
}

/// Linear values clamped to [0, 1] and sRGB-encoded, without exposure or
/// tone curve: for debug views whose values are meant to be shown as they are.
pub fn to_srgb8_clamped(rgb: &[[f32; 4]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(rgb.len() * 3);
    for p in rgb {
        for &c in &p[..3] {
            let v = if c.is_finite() {
                c.clamp(0.0, 1.0)
            } else {
                0.0
            };
            out.push((linear_to_srgb(v) * 255.0 + 0.5) as u8);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Very bright finite values are white (also where the exposure's
    /// product overflows: 1e38 × 10 is ∞ in f32), non-finite ones black.
    #[test]
    fn bright_is_white_and_non_finite_black() {
        let px = [[1e25, 3e19, 1e38, 1.0], [f32::NAN, f32::INFINITY, 0.0, 1.0]];
        assert_eq!(to_srgb8(&px, 1.0), vec![255, 255, 255, 0, 0, 0]);
        assert_eq!(to_srgb8(&px[..1], 10.0), vec![255, 255, 255]);
        // The curve itself at ordinary values: 0 → 0, 1 → 0.8038 (2.54 / 3.16).
        assert_eq!(aces_narkowicz(0.0), 0.0);
        assert!((aces_narkowicz(1.0) - 2.54 / 3.16).abs() < 1e-6);
    }
}
