//! Lighting for scenes that bring none: a sun with a Preetham sky, a constant
//! environment, or an environment map. Chosen on the command line.
//!
//! Units: the renderer is linear and unit-free; the sun's illuminance
//! [`SUN_ILLUMINANCE`] = 3.0 stands for ≈ 100 klux, so one unit ≈ 33 klux and
//! the Preetham sky (kcd/m², i.e. klux/sr) is scaled by [`SKY_SCALE`] = 1/33 to
//! the same units. A white Lambertian floor under a 45° sun then has radiance
//! ≈ 3 · cos 45° / π ≈ 0.7 plus the sky's share: comfortably exposed at 1.0.

use super::env_map::load_env_map;
use super::{Environment, Light, LightKind, Scene, SceneError, SkyModel};
use glam::Vec3;
use std::path::PathBuf;
use std::str::FromStr;

/// Sun illuminance (linear RGB, white-ish: a 5800 K-like tint).
pub const SUN_ILLUMINANCE: Vec3 = Vec3::new(3.0, 2.9, 2.7);
/// Sky radiance per kcd/m² of the Preetham model (see module docs).
pub const SKY_SCALE: f32 = 1.0 / 33.0;
/// Name of the sun light added by [`apply_default_lighting`]; the glTF writer
/// leaves it out so a reloaded file gets sun and sky together again.
pub const DEFAULT_SUN_NAME: &str = "default sun";
/// Angular radius of the sun disc (0.266°).
pub const SUN_ANGULAR_RADIUS: f32 = 0.00465;

#[derive(Clone, Debug, PartialEq)]
pub enum DefaultLighting {
    /// Sun at `elevation_deg` above the horizon, `azimuth_deg` from −Z towards
    /// +X (0 = in front of a camera looking down −Z, 90 = to its right).
    SunSky {
        elevation_deg: f32,
        azimuth_deg: f32,
        turbidity: f32,
    },
    Constant(Vec3),
    EnvironmentMap(PathBuf),
}

impl Default for DefaultLighting {
    fn default() -> Self {
        DefaultLighting::SunSky {
            elevation_deg: 40.0,
            azimuth_deg: 135.0,
            turbidity: 3.0,
        }
    }
}

/// A `--lighting` string that does not parse.
#[derive(Debug, thiserror::Error)]
#[error("invalid lighting '{input}': {reason}; expected sun-sky, sun-sky:ELEV,AZIM,TURB, constant:R,G,B, constant:V or env:PATH")]
pub struct LightingParseError {
    pub input: String,
    pub reason: String,
}

fn numbers(input: &str, list: &str) -> Result<Vec<f32>, LightingParseError> {
    list.split(',')
        .map(|s| {
            s.trim()
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| LightingParseError {
                    input: input.into(),
                    reason: format!("'{}' is not a finite number", s.trim()),
                })
        })
        .collect()
}

impl FromStr for DefaultLighting {
    type Err = LightingParseError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let err = |reason: &str| LightingParseError {
            input: s.into(),
            reason: reason.into(),
        };
        let (kind, arg) = match s.split_once(':') {
            Some((k, a)) => (k, Some(a)),
            None => (s, None),
        };
        match (kind, arg) {
            ("sun-sky", None) => Ok(DefaultLighting::default()),
            ("sun-sky", Some(a)) => match numbers(s, a)?.as_slice() {
                &[elevation_deg, azimuth_deg, turbidity] => {
                    if !(-90.0..=90.0).contains(&elevation_deg) {
                        return Err(err("elevation must be within −90..90 degrees"));
                    }
                    if turbidity < 1.0 {
                        return Err(err("turbidity must be at least 1"));
                    }
                    Ok(DefaultLighting::SunSky {
                        elevation_deg,
                        azimuth_deg,
                        turbidity,
                    })
                }
                _ => Err(err(
                    "sun-sky takes three numbers: elevation, azimuth, turbidity",
                )),
            },
            ("constant", Some(a)) => {
                let v = numbers(s, a)?;
                let c = match v.as_slice() {
                    [v] => Vec3::splat(*v),
                    [r, g, b] => Vec3::new(*r, *g, *b),
                    _ => return Err(err("constant takes one or three numbers")),
                };
                if c.min_element() < 0.0 {
                    return Err(err("radiance must not be negative"));
                }
                Ok(DefaultLighting::Constant(c))
            }
            ("env", Some(p)) if !p.is_empty() => Ok(DefaultLighting::EnvironmentMap(p.into())),
            _ => Err(err("unknown form")),
        }
    }
}

/// Unit direction towards a sun at the given elevation/azimuth (see [`DefaultLighting::SunSky`]).
pub fn sun_direction(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()).normalize()
}

/// Adds `choice` to `scene` when the scene has no light of its own (no
/// punctual lights, no emissive material, no environment); otherwise leaves
/// it unchanged. Fails only when an environment map cannot be loaded.
pub fn apply_default_lighting(
    scene: &mut Scene,
    choice: &DefaultLighting,
) -> Result<(), SceneError> {
    if !scene.lights.is_empty() || scene.has_emissive_triangles() || scene.environment.is_some() {
        return Ok(());
    }
    match choice {
        DefaultLighting::SunSky {
            elevation_deg,
            azimuth_deg,
            turbidity,
        } => {
            let to_sun = sun_direction(*elevation_deg, *azimuth_deg);
            scene.lights.push(Light {
                name: DEFAULT_SUN_NAME.into(),
                kind: LightKind::Directional {
                    angular_radius: SUN_ANGULAR_RADIUS,
                },
                radiant: SUN_ILLUMINANCE,
                position: Vec3::ZERO,
                direction: -to_sun,
                range: None,
            });
            scene.environment = Some(Environment::Sky {
                model: SkyModel::Preetham {
                    turbidity: *turbidity,
                },
                sun_direction: to_sun,
                scale: SKY_SCALE,
            });
        }
        DefaultLighting::Constant(c) => scene.environment = Some(Environment::Constant(*c)),
        DefaultLighting::EnvironmentMap(p) => scene.environment = Some(load_env_map(p)?),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_cli_forms() {
        assert_eq!(
            "sun-sky".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::default()
        );
        assert_eq!(
            "sun-sky:30,90,4".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::SunSky {
                elevation_deg: 30.0,
                azimuth_deg: 90.0,
                turbidity: 4.0
            }
        );
        assert_eq!(
            "constant:0.5".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::Constant(Vec3::splat(0.5))
        );
        assert_eq!(
            "constant:1,2,3".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::Constant(Vec3::new(1.0, 2.0, 3.0))
        );
        assert_eq!(
            "env:a/b.hdr".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::EnvironmentMap("a/b.hdr".into())
        );
        for bad in [
            "",
            "sun",
            "sun-sky:1,2",
            "constant:x",
            "constant:1,2",
            "constant:NaN",
            "env:",
            "sun-sky:100,0,3",
        ] {
            let e = bad.parse::<DefaultLighting>().unwrap_err().to_string();
            assert!(e.contains("invalid lighting"), "{e}");
        }
    }

    #[test]
    fn sun_direction_convention() {
        assert!((sun_direction(0.0, 0.0) - Vec3::NEG_Z).length() < 1e-6);
        assert!((sun_direction(0.0, 90.0) - Vec3::X).length() < 1e-6);
        assert!((sun_direction(90.0, 0.0) - Vec3::Y).length() < 1e-6);
    }

    #[test]
    fn only_unlit_scenes_get_default_lighting() {
        let mut s = Scene::default();
        apply_default_lighting(&mut s, &DefaultLighting::default()).unwrap();
        assert_eq!(s.lights.len(), 1);
        assert!(matches!(s.environment, Some(Environment::Sky { .. })));
        let l = &s.lights[0];
        if let Some(Environment::Sky { sun_direction, .. }) = &s.environment {
            assert!((l.direction + *sun_direction).length() < 1e-6);
        }
        // Already lit: unchanged.
        apply_default_lighting(&mut s, &DefaultLighting::Constant(Vec3::ONE)).unwrap();
        assert!(matches!(s.environment, Some(Environment::Sky { .. })));
    }
}
