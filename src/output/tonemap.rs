//! Display transform for PNG previews: exposure, the ACES filmic fit of
//! Narkowicz (2015), then the sRGB transfer function. Non-finite values map to
//! black so a preview never hides a NaN as white.

pub fn aces_narkowicz(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
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
