//! The Preetham, Shirley and Smits daylight sky ("A Practical Analytic Model
//! for Daylight", SIGGRAPH 1999), evaluated on the CPU.
//!
//! The GPU (`shaders/common/sky.glsl`) receives [`PreethamParams`] and must
//! evaluate exactly [`preetham_radiance`]; every step below is written so it
//! ports line by line to GLSL.
//!
//! Notation (paper §3 and appendix A.2): θ is the angle of the view direction
//! from the zenith (+Y), γ the angle between view direction and sun, θs the
//! sun's zenith angle, T the turbidity.

use glam::Vec3;

/// Coefficients of one evaluation of the sky model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreethamParams {
    /// Perez coefficients A..E for Y, x and y (rows), paper appendix A.2.
    pub perez: [[f32; 5]; 3],
    /// Zenith luminance Y_z (kcd/m²) and chromaticity x_z, y_z.
    pub zenith: [f32; 3],
    /// Sun zenith angle θs in radians, clamped to [0, π/2].
    pub sun_theta: f32,
    /// Unit direction *towards* the sun (y ≥ 0 after clamping), used for γ.
    pub sun_direction: Vec3,
}

/// Turbidity range over which the fit is meaningful (the paper fits 2..10;
/// 1.7 keeps every Perez B coefficient negative so the horizon stays finite).
pub const TURBIDITY_RANGE: (f32, f32) = (1.7, 10.0);
/// Below-horizon blend width in `dir.y` (see [`preetham_radiance`]).
pub const HORIZON_BLEND: f32 = 0.05;
/// Ground albedo used below the horizon.
pub const GROUND_ALBEDO: f32 = 0.3;
/// Smallest cos θ fed to the Perez function (avoids B / 0 at the horizon).
pub const MIN_COS_THETA: f32 = 1.0e-3;

/// Perez et al. 1993 luminance distribution, paper eq. (3):
/// F(θ, γ) = (1 + A·e^(B / cos θ)) · (1 + C·e^(D·γ) + E·cos²γ).
pub fn perez(c: &[f32; 5], cos_theta: f32, gamma: f32) -> f32 {
    let cos_gamma = gamma.cos();
    (1.0 + c[0] * (c[1] / cos_theta).exp())
        * (1.0 + c[2] * (c[3] * gamma).exp() + c[4] * cos_gamma * cos_gamma)
}

/// Model coefficients for a turbidity and a direction towards the sun.
/// Turbidity is clamped to [`TURBIDITY_RANGE`]; a sun below the horizon is
/// treated as a sun on the horizon (same azimuth).
pub fn preetham_params(turbidity: f32, sun_direction: Vec3) -> PreethamParams {
    let t = if turbidity.is_finite() {
        turbidity.clamp(TURBIDITY_RANGE.0, TURBIDITY_RANGE.1)
    } else {
        3.0
    };
    let mut sun = sun_direction.try_normalize().unwrap_or(Vec3::Y);
    if sun.y < 0.0 {
        sun = Vec3::new(sun.x, 0.0, sun.z)
            .try_normalize()
            .unwrap_or(Vec3::X);
    }
    let theta_s = sun.y.clamp(0.0, 1.0).acos();

    // Appendix A.2: Perez coefficients as linear functions of T.
    let perez = [
        [
            0.1787 * t - 1.4630,
            -0.3554 * t + 0.4275,
            -0.0227 * t + 5.3251,
            0.1206 * t - 2.5771,
            -0.0670 * t + 0.3703,
        ],
        [
            -0.0193 * t - 0.2592,
            -0.0665 * t + 0.0008,
            -0.0004 * t + 0.2125,
            -0.0641 * t - 0.8989,
            -0.0033 * t + 0.0452,
        ],
        [
            -0.0167 * t - 0.2608,
            -0.0950 * t + 0.0092,
            -0.0079 * t + 0.2102,
            -0.0441 * t - 1.6537,
            -0.0109 * t + 0.0529,
        ],
    ];

    // Zenith luminance, appendix A.2: χ = (4/9 − T/120)(π − 2θs),
    // Y_z = (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192  [kcd/m²].
    let chi = (4.0 / 9.0 - t / 120.0) * (std::f32::consts::PI - 2.0 * theta_s);
    let y_z = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192).max(0.0);

    // Zenith chromaticity: [T² T 1] · M · [θs³ θs² θs 1]ᵀ.
    let th = [theta_s.powi(3), theta_s.powi(2), theta_s, 1.0];
    let tv = [t * t, t, 1.0];
    let mx = [
        [0.00166, -0.00375, 0.00209, 0.0],
        [-0.02903, 0.06377, -0.03202, 0.00394],
        [0.11693, -0.21196, 0.06052, 0.25886],
    ];
    let my = [
        [0.00275, -0.00610, 0.00317, 0.0],
        [-0.04214, 0.08970, -0.04153, 0.00516],
        [0.15346, -0.26756, 0.06670, 0.26688],
    ];
    let chroma = |m: &[[f32; 4]; 3]| -> f32 {
        (0..3)
            .map(|r| tv[r] * (0..4).map(|c| m[r][c] * th[c]).sum::<f32>())
            .sum()
    };
    PreethamParams {
        perez,
        zenith: [y_z, chroma(&mx), chroma(&my)],
        sun_theta: theta_s,
        sun_direction: sun,
    }
}

/// CIE Yxy → XYZ → linear sRGB (D65, IEC 61966-2-1 matrix).
pub fn yxy_to_linear_srgb(big_y: f32, x: f32, y: f32) -> Vec3 {
    let y = y.max(1e-4);
    let cap_x = x / y * big_y;
    let cap_z = (1.0 - x - y) / y * big_y;
    Vec3::new(
        3.240_454_2 * cap_x - 1.537_138_5 * big_y - 0.498_531_4 * cap_z,
        -0.969_266 * cap_x + 1.876_010_8 * big_y + 0.041_556 * cap_z,
        0.055_643_4 * cap_x - 0.204_025_9 * big_y + 1.057_225_2 * cap_z,
    )
}

/// Sky radiance above the horizon, paper eq. (4) for each of Y, x, y:
/// `v = v_z · F(θ, γ) / F(0, θs)`, then Yxy → linear sRGB, × `scale`,
/// negative channels clamped to 0. `dir` must be unit with y ≥ 0.
fn above_horizon(p: &PreethamParams, dir: Vec3, scale: f32) -> Vec3 {
    let cos_theta = dir.y.max(MIN_COS_THETA);
    let gamma = dir.dot(p.sun_direction).clamp(-1.0, 1.0).acos();
    let yxy: [f32; 3] = std::array::from_fn(|k| {
        p.zenith[k] * perez(&p.perez[k], cos_theta, gamma) / perez(&p.perez[k], 1.0, p.sun_theta)
    });
    (yxy_to_linear_srgb(yxy[0], yxy[1], yxy[2]) * scale).max(Vec3::ZERO)
}

/// Linear sRGB sky radiance seen along the unit direction `dir` (pointing away
/// from the viewer into the sky), in kcd/m² × `scale`.
///
/// * `dir.y ≥ 0`: [`above_horizon`] with cos θ = max(dir.y, [`MIN_COS_THETA`]),
///   γ = acos(clamp(dot(dir, sun_direction), −1, 1)).
/// * `dir.y < 0` (below the horizon): a continuous blend
///   `mix(L_h, G, clamp(−dir.y / HORIZON_BLEND, 0, 1))` where `L_h` is the
///   above-horizon value at the horizon direction `normalize(dir.x, 0, dir.z)`
///   and `G = GROUND_ALBEDO × L(+Y)` (the zenith radiance as a ground stand-in).
///   Continuous everywhere and finite, including straight down.
pub fn preetham_radiance(params: &PreethamParams, dir: Vec3, scale: f32) -> Vec3 {
    let dir = dir.try_normalize().unwrap_or(Vec3::Y);
    if dir.y >= 0.0 {
        return above_horizon(params, dir, scale);
    }
    let ground = GROUND_ALBEDO * above_horizon(params, Vec3::Y, scale);
    let t = (-dir.y / HORIZON_BLEND).min(1.0);
    if t >= 1.0 {
        return ground;
    }
    // |(x, z)| ≥ sqrt(1 − HORIZON_BLEND²) here, so the normalisation is safe.
    let horizon = Vec3::new(dir.x, 0.0, dir.z).normalize();
    above_horizon(params, horizon, scale).lerp(ground, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_dirs(n: usize) -> impl Iterator<Item = Vec3> {
        // Fibonacci sphere.
        (0..n).map(move |i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).sqrt();
            let phi = i as f32 * 2.399_963;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
    }

    #[test]
    fn finite_and_non_negative_everywhere() {
        for t in [1.0, 1.7, 2.0, 3.0, 6.0, 10.0, 20.0] {
            for sun in [
                Vec3::Y,
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::X,
                Vec3::new(0.3, -0.5, 0.2),
                Vec3::NEG_Y,
            ] {
                let p = preetham_params(t, sun);
                for d in sphere_dirs(2000).chain([Vec3::Y, Vec3::NEG_Y, Vec3::X]) {
                    let l = preetham_radiance(&p, d, 1.0);
                    assert!(
                        l.is_finite() && l.min_element() >= 0.0,
                        "T={t} sun={sun} d={d} L={l}"
                    );
                }
            }
        }
    }

    #[test]
    fn brighter_near_the_sun() {
        let sun = Vec3::new(0.0, 0.5, -1.0).normalize();
        let p = preetham_params(3.0, sun);
        let near = preetham_radiance(&p, (sun + Vec3::new(0.05, 0.0, 0.0)).normalize(), 1.0);
        let away = preetham_radiance(&p, Vec3::new(0.0, 0.5, 1.0).normalize(), 1.0);
        assert!(
            near.element_sum() > 2.0 * away.element_sum(),
            "{near} vs {away}"
        );
    }

    #[test]
    fn zenith_value_equals_zenith_formula() {
        let sun = Vec3::new(0.4, 0.7, 0.2).normalize();
        let p = preetham_params(2.5, sun);
        let expect = yxy_to_linear_srgb(p.zenith[0], p.zenith[1], p.zenith[2]);
        let got = preetham_radiance(&p, Vec3::Y, 1.0);
        assert!(
            (got - expect).abs().max_element() < 1e-4 * expect.max_element(),
            "{got} vs {expect}"
        );
        // Y_z for T = 2.5 and a 45°-ish sun lies in the paper's plotted range (a few kcd/m²).
        assert!(p.zenith[0] > 1.0 && p.zenith[0] < 20.0, "{:?}", p.zenith);
        // Chromaticity near white.
        assert!((0.2..0.4).contains(&p.zenith[1]) && (0.2..0.4).contains(&p.zenith[2]));
    }

    #[test]
    fn continuous_across_the_horizon() {
        let p = preetham_params(3.0, Vec3::new(1.0, 0.3, 0.0));
        let d = |y: f32| Vec3::new(0.6, y, 0.8).normalize();
        let a = preetham_radiance(&p, d(1e-5), 1.0);
        let b = preetham_radiance(&p, d(-1e-5), 1.0);
        assert!((a - b).abs().max_element() < 1e-2 * a.max_element().max(1e-3));
    }
}
