//! Lighting for scenes that bring none: a sun with a Preetham sky, a constant
//! environment, an environment map, delta directional lights, or a sum of
//! these (e.g. the paper's Sponza: a constant background plus a directional
//! light, §5.1; its hairball under one non-stochastic directional light,
//! Fig. 8). Chosen on the command line (`--lighting`, grammar in
//! [`DefaultLighting`]'s `FromStr`) and in experiment files (the same strings).
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
    /// A delta directional light (no disc: every shadow ray goes exactly
    /// towards it, so direct lighting is not stochastic) of illuminance
    /// `illuminance` on a surface facing it, from the direction given as for
    /// [`DefaultLighting::SunSky`]; no environment of its own (black).
    Directional {
        elevation_deg: f32,
        azimuth_deg: f32,
        illuminance: Vec3,
    },
    /// Several of the above at once (`A+B`): every part's lights, and the
    /// environment of the one part that has one (at most one does).
    Sum(Vec<DefaultLighting>),
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
#[error("invalid lighting '{input}': {reason}; expected sun-sky, sun-sky:ELEV,AZIM,TURB, constant:R,G,B, constant:V, env:PATH, directional:ELEV,AZIM[,R,G,B], or several joined by '+' (e.g. constant:0.3+directional:60,45)")]
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

/// The forms a part of a `+` sum starts with (a '+' elsewhere, e.g. inside
/// an environment map's path, does not split).
const KINDS: [&str; 4] = ["sun-sky", "constant", "env:", "directional"];

/// Splits `s` at each '+' that is followed by one of [`KINDS`].
fn sum_parts(s: &str) -> Vec<&str> {
    let mut parts = Vec::new();
    let mut start = 0;
    for (i, _) in s.match_indices('+') {
        if KINDS.iter().any(|k| s[i + 1..].starts_with(k)) {
            parts.push(&s[start..i]);
            start = i + 1;
        }
    }
    parts.push(&s[start..]);
    parts
}

impl DefaultLighting {
    /// Whether this lighting sets the scene's environment.
    fn has_environment(&self) -> bool {
        match self {
            DefaultLighting::SunSky { .. }
            | DefaultLighting::Constant(_)
            | DefaultLighting::EnvironmentMap(_) => true,
            DefaultLighting::Directional { .. } => false,
            DefaultLighting::Sum(parts) => parts.iter().any(|p| p.has_environment()),
        }
    }
}

impl FromStr for DefaultLighting {
    type Err = LightingParseError;

    /// `sun-sky[:ELEV,AZIM,TURB]`, `constant:V` or `constant:R,G,B`,
    /// `env:PATH`, `directional:ELEV,AZIM[,R,G,B]` (illuminance R,G,B;
    /// default [`SUN_ILLUMINANCE`]), or several joined by `+` with at most
    /// one environment among them (`constant:0.3+directional:60,45`).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let parts = sum_parts(s);
        if parts.len() == 1 {
            return parse_part(s, s);
        }
        let parts = parts
            .into_iter()
            .map(|p| parse_part(s, p))
            .collect::<Result<Vec<_>, _>>()?;
        if parts.iter().filter(|p| p.has_environment()).count() > 1 {
            return Err(LightingParseError {
                input: s.into(),
                reason: "at most one of sun-sky, constant and env may be summed".into(),
            });
        }
        Ok(DefaultLighting::Sum(parts))
    }
}

/// One part (no '+') of the `--lighting` string `input`.
fn parse_part(input: &str, s: &str) -> Result<DefaultLighting, LightingParseError> {
    let err = |reason: &str| LightingParseError {
        input: input.into(),
        reason: reason.into(),
    };
    let (kind, arg) = match s.split_once(':') {
        Some((k, a)) => (k, Some(a)),
        None => (s, None),
    };
    match (kind, arg) {
        ("sun-sky", None) => Ok(DefaultLighting::default()),
        ("sun-sky", Some(a)) => match numbers(input, a)?.as_slice() {
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
            let v = numbers(input, a)?;
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
        ("directional", Some(a)) => {
            let v = numbers(input, a)?;
            let (elevation_deg, azimuth_deg, illuminance) =
                match *v.as_slice() {
                    [e, z] => (e, z, SUN_ILLUMINANCE),
                    [e, z, r, g, b] => (e, z, Vec3::new(r, g, b)),
                    _ => return Err(err(
                        "directional takes elevation, azimuth and optionally an illuminance R,G,B",
                    )),
                };
            if !(-90.0..=90.0).contains(&elevation_deg) {
                return Err(err("elevation must be within −90..90 degrees"));
            }
            if illuminance.min_element() < 0.0 {
                return Err(err("illuminance must not be negative"));
            }
            Ok(DefaultLighting::Directional {
                elevation_deg,
                azimuth_deg,
                illuminance,
            })
        }
        _ => Err(err("unknown form")),
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
    add_lighting(scene, choice)
}

/// Whether `scene`'s lighting is default lighting alone (every light added
/// by [`apply_default_lighting`], no emissive triangles): the shipped
/// generated scenes (hairball, plane) carry the default sun and sky as a
/// stand-in until a `--lighting` choice replaces it.
pub fn has_default_lighting_only(scene: &Scene) -> bool {
    !scene.lights.is_empty()
        && scene.lights.iter().all(|l| l.name == DEFAULT_SUN_NAME)
        && !scene.has_emissive_triangles()
}

/// Gives `scene` the lighting `choice` where it has none of its own: as
/// [`apply_default_lighting`], and a scene lit by default lighting alone
/// ([`has_default_lighting_only`]) has it replaced (with the default choice
/// by the identical lighting). Used where a scene is loaded for a command.
pub fn relight(scene: &mut Scene, choice: &DefaultLighting) -> Result<(), SceneError> {
    if has_default_lighting_only(scene) {
        scene.lights.clear();
        scene.environment = None;
    }
    apply_default_lighting(scene, choice)
}

/// Adds `choice`'s lights and environment to `scene`.
fn add_lighting(scene: &mut Scene, choice: &DefaultLighting) -> Result<(), SceneError> {
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
        DefaultLighting::Directional {
            elevation_deg,
            azimuth_deg,
            illuminance,
        } => scene.lights.push(Light {
            // Default lighting like the sun: the glTF writer leaves it out.
            name: DEFAULT_SUN_NAME.into(),
            kind: LightKind::Directional {
                angular_radius: 0.0,
            },
            radiant: *illuminance,
            position: Vec3::ZERO,
            direction: -sun_direction(*elevation_deg, *azimuth_deg),
            range: None,
        }),
        DefaultLighting::Sum(parts) => {
            for p in parts {
                add_lighting(scene, p)?;
            }
        }
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

    #[test]
    fn parses_directional_lights_and_sums() {
        assert_eq!(
            "directional:30,90".parse::<DefaultLighting>().unwrap(),
            DefaultLighting::Directional {
                elevation_deg: 30.0,
                azimuth_deg: 90.0,
                illuminance: SUN_ILLUMINANCE
            }
        );
        let dir = DefaultLighting::Directional {
            elevation_deg: 60.0,
            azimuth_deg: 45.0,
            illuminance: Vec3::new(1.0, 2.0, 3.0),
        };
        assert_eq!(
            "directional:60,45,1,2,3"
                .parse::<DefaultLighting>()
                .unwrap(),
            dir
        );
        assert_eq!(
            "constant:0.3+directional:60,45,1,2,3"
                .parse::<DefaultLighting>()
                .unwrap(),
            DefaultLighting::Sum(vec![
                DefaultLighting::Constant(Vec3::splat(0.3)),
                dir.clone()
            ])
        );
        // A '+' not followed by a form stays in the map's path.
        assert_eq!(
            "env:a+b.hdr+directional:60,45,1,2,3"
                .parse::<DefaultLighting>()
                .unwrap(),
            DefaultLighting::Sum(vec![DefaultLighting::EnvironmentMap("a+b.hdr".into()), dir])
        );
        for bad in [
            "directional",
            "directional:30",
            "directional:30,0,1",
            "directional:91,0",
            "directional:30,0,-1,1,1",
            "constant:1+constant:2",
            "sun-sky+env:a.hdr",
            "constant:1+",
            "constant:1+directional:x,0",
        ] {
            let e = bad.parse::<DefaultLighting>().unwrap_err().to_string();
            assert!(
                e.contains("invalid lighting") && e.contains(bad),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn relight_replaces_default_lighting_only() {
        let dir: DefaultLighting = "constant:0.25+directional:60,45".parse().unwrap();
        // A scene lit by default lighting alone (as the shipped hairball).
        let mut s = Scene::default();
        apply_default_lighting(&mut s, &DefaultLighting::default()).unwrap();
        relight(&mut s, &dir).unwrap();
        assert_eq!(s.lights.len(), 1);
        assert_eq!(
            s.lights[0].kind,
            LightKind::Directional {
                angular_radius: 0.0
            }
        );
        assert!((s.lights[0].direction + sun_direction(60.0, 45.0)).length() < 1e-6);
        assert!(
            matches!(s.environment, Some(Environment::Constant(c)) if c == Vec3::splat(0.25)),
            "{:?}",
            s.environment
        );
        // The default choice gives the default lighting back, identically.
        let mut again = Scene::default();
        apply_default_lighting(&mut again, &DefaultLighting::default()).unwrap();
        relight(&mut s, &DefaultLighting::default()).unwrap();
        assert_eq!(format!("{:?}", s.lights), format!("{:?}", again.lights));
        assert_eq!(
            format!("{:?}", s.environment),
            format!("{:?}", again.environment)
        );
        // A scene with a light of its own keeps its lighting.
        let mut own = Scene::default();
        own.lights.push(Light {
            name: "lamp".into(),
            ..s.lights[0].clone()
        });
        relight(&mut own, &dir).unwrap();
        assert_eq!(own.lights.len(), 1);
        assert!(own.environment.is_none());
    }
}
