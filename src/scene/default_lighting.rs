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
//!
//! **When it is added** ([`decide_lighting`], the one rule; the CLI prints
//! its [`LightingDecision::line`] when a command loads a scene):
//! - A scene has **lighting of its own** when it has a punctual light
//!   (`KHR_lights_punctual`), an environment, or an **HDR emitter**: a
//!   material, used by some instance, whose emitted radiance (emissiveFactor
//!   × KHR_materials_emissive_strength, the bound of an emissive texture's
//!   radiance too, texels being ≤ 1) exceeds [`HDR_EMITTER_THRESHOLD`] = 1 in
//!   some channel. glTF's emissiveFactor is ≤ 1 by schema: a glow (screens,
//!   labels, signs); a file marks a surface as a light source with an
//!   emissive strength > 1, as the Cornell box's ceiling light (17, 12, 4).
//!   Emitters ≤ 1 (*glows*) still emit and are still sampled as lights by
//!   next-event estimation; they just do not switch the default lighting off.
//! - Without a `--lighting` choice (or an experiment file's `lighting`), a
//!   scene with lighting of its own is rendered by it alone; any other scene
//!   gets the default sun and sky ([`DefaultLighting::default`]).
//! - **An explicit choice always wins**: it is added whatever the scene
//!   holds. Its environment, if it has one (sun-sky, constant, env),
//!   replaces the scene's; a choice without one (directional) keeps it. The
//!   scene's punctual lights and emitters stay.
//! - Lights named [`DEFAULT_SUN_NAME`] are default lighting, not the scene's:
//!   a scene lit by default lighting alone (the generated hairball, plane,
//!   material-balls, [`has_default_lighting_only`]) has it replaced.

use super::env_map::load_env_map;
use super::{Environment, Light, LightKind, Scene, SceneError, SkyModel};
use glam::Vec3;
use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

/// Emitted radiance (in some channel) above which a material is a light
/// source of the scene's own, not a glow (see the module docs).
pub const HDR_EMITTER_THRESHOLD: f32 = 1.0;

/// Sun illuminance (linear RGB, white-ish: a 5800 K-like tint).
pub const SUN_ILLUMINANCE: Vec3 = Vec3::new(3.0, 2.9, 2.7);
/// Sky radiance per kcd/m² of the Preetham model (see module docs).
pub const SKY_SCALE: f32 = 1.0 / 33.0;
/// Name of every light [`apply_default_lighting`] adds (the sun of
/// `sun-sky`, the delta light of `directional:`); the glTF writer leaves
/// them out (the command line's lighting, not the scene's), so a reloaded
/// file without lights gets sun and sky together again.
pub const DEFAULT_SUN_NAME: &str = "default sun";
/// Angular radius of the sun disc (0.266°).
pub const SUN_ANGULAR_RADIUS: f32 = 0.00465;

#[derive(Clone, Debug, PartialEq)]
pub enum DefaultLighting {
    /// Sun at `elevation_deg` (0..=90) above the horizon, `azimuth_deg` from
    /// −Z towards +X (0 = in front of a camera looking down −Z, 90 = to its
    /// right).
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

/// The `--lighting` string of a lighting (it parses back to the same value).
impl fmt::Display for DefaultLighting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            l @ DefaultLighting::SunSky { .. } if *l == DefaultLighting::default() => {
                write!(f, "sun-sky")
            }
            DefaultLighting::SunSky {
                elevation_deg,
                azimuth_deg,
                turbidity,
            } => write!(f, "sun-sky:{elevation_deg},{azimuth_deg},{turbidity}"),
            DefaultLighting::Constant(c) if c.x == c.y && c.y == c.z => {
                write!(f, "constant:{}", c.x)
            }
            DefaultLighting::Constant(c) => write!(f, "constant:{},{},{}", c.x, c.y, c.z),
            DefaultLighting::EnvironmentMap(p) => write!(f, "env:{}", p.display()),
            DefaultLighting::Directional {
                elevation_deg,
                azimuth_deg,
                illuminance: e,
            } => {
                write!(f, "directional:{elevation_deg},{azimuth_deg}")?;
                if *e != SUN_ILLUMINANCE {
                    write!(f, ",{},{},{}", e.x, e.y, e.z)?;
                }
                Ok(())
            }
            DefaultLighting::Sum(parts) => {
                for (i, p) in parts.iter().enumerate() {
                    if i > 0 {
                        write!(f, "+")?;
                    }
                    write!(f, "{p}")?;
                }
                Ok(())
            }
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
                // The Preetham sky puts a sun below the horizon on it
                // (preetham.rs), while the sun light would shine from below
                // the ground: the two would disagree, so sun-sky's sun stays
                // above the horizon (directional keeps −90..90).
                if !(0.0..=90.0).contains(&elevation_deg) {
                    return Err(err(
                        "the sun-sky elevation must be within 0..90 degrees (the sun above the \
                         horizon; a directional:ELEV,AZIM light may come from below)",
                    ));
                }
                // preetham.rs clamps into the fit's range; refusing what it
                // would clamp says so instead of rendering another sky.
                let (lo, hi) = super::preetham::TURBIDITY_RANGE;
                if !(lo..=hi).contains(&turbidity) {
                    return Err(err(&format!(
                        "turbidity must be within {lo}..{hi} (the range of Preetham et al.'s fit)"
                    )));
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
            if c.max_element() > super::MAX_EMISSION {
                return Err(err(&format!(
                    "radiance beyond the brightest emission accepted ({:e}; a path's throughput would overflow)",
                    super::MAX_EMISSION
                )));
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
            if illuminance.max_element() > super::MAX_EMISSION {
                return Err(err(&format!(
                    "illuminance beyond the brightest emission accepted ({:e}; a path's throughput would overflow)",
                    super::MAX_EMISSION
                )));
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

/// Adds `choice` to `scene` when the scene has no lighting at all: no light
/// (default lighting's included), no environment and no HDR emitter (glows
/// ≤ 1 do not count, see the module docs); otherwise leaves it unchanged.
/// What the generators run on a fresh scene. Fails only when an environment
/// map cannot be loaded.
pub fn apply_default_lighting(
    scene: &mut Scene,
    choice: &DefaultLighting,
) -> Result<(), SceneError> {
    if !scene.lights.is_empty() || scene.environment.is_some() || hdr_emitter_count(scene) > 0 {
        return Ok(());
    }
    add_lighting(scene, choice)
}

/// The emissive materials that some instance uses, as (HDR emitters, glows):
/// the largest channel of the emitted radiance (factor × strength, which
/// bounds a texture's emission too) above [`HDR_EMITTER_THRESHOLD`], or in
/// (0, 1].
fn emissive_counts(scene: &Scene) -> (usize, usize) {
    let mut used = vec![false; scene.materials.len()];
    for inst in &scene.instances {
        if let Some(m) = scene.meshes.get(inst.mesh as usize) {
            if !m.indices.is_empty() {
                if let Some(u) = used.get_mut(m.material as usize) {
                    *u = true;
                }
            }
        }
    }
    let (mut hdr, mut glow) = (0, 0);
    for (m, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
        let peak = m.emissive.max_element();
        if peak > HDR_EMITTER_THRESHOLD {
            hdr += 1;
        } else if peak > 0.0 {
            glow += 1;
        }
    }
    (hdr, glow)
}

fn hdr_emitter_count(scene: &Scene) -> usize {
    emissive_counts(scene).0
}

/// Whether `scene`'s lighting is default lighting alone (every light added
/// by [`apply_default_lighting`], no HDR emitter): the shipped generated
/// scenes (hairball, plane, material-balls) carry the default sun and sky
/// as a stand-in until a `--lighting` choice replaces it.
pub fn has_default_lighting_only(scene: &Scene) -> bool {
    !scene.lights.is_empty()
        && scene.lights.iter().all(|l| l.name == DEFAULT_SUN_NAME)
        && hdr_emitter_count(scene) == 0
}

/// The lighting a scene brings itself, by the rule of the module docs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct OwnLighting {
    /// Punctual lights other than default lighting's ([`DEFAULT_SUN_NAME`]).
    pub punctual_lights: usize,
    /// Used materials emitting more than [`HDR_EMITTER_THRESHOLD`]: lights.
    pub hdr_emitters: usize,
    /// Used materials emitting at most 1: glows, not lights.
    pub glows: usize,
    /// An environment other than default lighting's.
    pub environment: bool,
    /// The scene is lit by default lighting alone ([`has_default_lighting_only`]),
    /// which is replaced.
    pub default_only: bool,
}

impl OwnLighting {
    pub fn of(scene: &Scene) -> OwnLighting {
        let default_only = has_default_lighting_only(scene);
        let (hdr_emitters, glows) = emissive_counts(scene);
        OwnLighting {
            punctual_lights: scene
                .lights
                .iter()
                .filter(|l| l.name != DEFAULT_SUN_NAME)
                .count(),
            hdr_emitters,
            glows,
            environment: scene.environment.is_some() && !default_only,
            default_only,
        }
    }

    /// Whether the scene has lighting of its own (then default lighting is
    /// added only on an explicit choice).
    pub fn any(&self) -> bool {
        self.punctual_lights > 0 || self.hdr_emitters > 0 || self.environment
    }

    /// "1 HDR emitter, 0 punctual lights, an environment, 2 glows ≤ 1".
    fn summary(&self) -> String {
        let plural =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        let mut s = format!(
            "{}, {}",
            plural(self.hdr_emitters, "HDR emitter", "HDR emitters"),
            plural(self.punctual_lights, "punctual light", "punctual lights")
        );
        if self.environment {
            s.push_str(", an environment");
        }
        if self.glows > 0 {
            s.push_str(&format!(
                ", {}",
                plural(self.glows, "glow ≤ 1", "glows ≤ 1")
            ));
        }
        s
    }
}

/// What [`decide_lighting`] chose for a scene, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct LightingDecision {
    /// The scene's own lighting.
    pub own: OwnLighting,
    /// The lighting added; `None`: the scene's own lighting alone.
    pub added: Option<DefaultLighting>,
    /// Whether `added` is an explicit choice (`--lighting`, an experiment
    /// file's `lighting`) rather than the default for an unlit scene.
    pub explicit: bool,
    /// Whether `added`'s environment replaces the scene's own.
    pub replaces_environment: bool,
}

impl LightingDecision {
    /// Whether default lighting is added.
    pub fn adds_default(&self) -> bool {
        self.added.is_some()
    }

    /// The one stderr line a command prints, e.g. `lighting: sun-sky
    /// (default: the scene's 2 emissive materials are glows ≤ 1, not lights)`.
    pub fn line(&self) -> String {
        let own = &self.own;
        match (&self.added, self.explicit) {
            (None, _) => format!(
                "lighting: the scene's own ({}); --lighting adds default lighting",
                own.summary()
            ),
            (Some(l), true) if own.any() => format!(
                "lighting: {l} (--lighting) added to the scene's own ({}){}",
                own.summary(),
                if self.replaces_environment {
                    "; its environment replaced"
                } else {
                    ""
                }
            ),
            (Some(l), explicit) => {
                let why = match own.glows {
                    0 => "the scene has no lights of its own".to_string(),
                    1 => "the scene's 1 emissive material is a glow ≤ 1, not a light".to_string(),
                    n => format!("the scene's {n} emissive materials are glows ≤ 1, not lights"),
                };
                let replaced = if own.default_only && explicit {
                    "; the scene's stand-in default lighting replaced"
                } else {
                    ""
                };
                if explicit {
                    format!("lighting: {l} (--lighting; {why}{replaced})")
                } else {
                    format!("lighting: {l} (default: {why})")
                }
            }
        }
    }
}

/// The lighting rule of the module docs, as a pure function: what
/// [`light_scene`] adds to `scene` for the explicit choice `explicit`
/// (`None`: none given).
pub fn decide_lighting(scene: &Scene, explicit: Option<&DefaultLighting>) -> LightingDecision {
    decide(scene, explicit.cloned(), explicit.is_some())
}

fn decide(scene: &Scene, choice: Option<DefaultLighting>, explicit: bool) -> LightingDecision {
    let own = OwnLighting::of(scene);
    let added = match choice {
        Some(c) if explicit || !own.any() => Some(c),
        None if !own.any() => Some(DefaultLighting::default()),
        _ => None,
    };
    let replaces_environment =
        own.environment && added.as_ref().is_some_and(|l| l.has_environment());
    LightingDecision {
        own,
        added,
        explicit,
        replaces_environment,
    }
}

/// Applies [`decide_lighting`]'s decision to `scene`: default lighting
/// already there (a generated scene's stand-in) is removed, the chosen
/// lighting added. Returns the decision (its [`LightingDecision::line`] is
/// what commands print). Fails only when an environment map cannot be loaded.
pub fn light_scene(
    scene: &mut Scene,
    explicit: Option<&DefaultLighting>,
) -> Result<LightingDecision, SceneError> {
    let d = decide_lighting(scene, explicit);
    apply_decision(scene, &d)?;
    Ok(d)
}

fn apply_decision(scene: &mut Scene, d: &LightingDecision) -> Result<(), SceneError> {
    if d.own.default_only {
        scene.lights.clear();
        scene.environment = None;
    }
    if let Some(l) = &d.added {
        add_lighting(scene, l)?;
    }
    Ok(())
}

/// Gives `scene` the lighting `choice` where it has none of its own (the
/// rule of the module docs without an explicit choice, `choice` standing in
/// for the default sun and sky); a scene lit by default lighting alone
/// ([`has_default_lighting_only`]) has it replaced (with the default choice
/// by the identical lighting).
pub fn relight(scene: &mut Scene, choice: &DefaultLighting) -> Result<(), SceneError> {
    let d = decide(scene, Some(choice.clone()), false);
    apply_decision(scene, &d)
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
        DefaultLighting::EnvironmentMap(p) => {
            let (env, warning) = load_env_map(p)?;
            scene.environment = Some(env);
            scene.warnings.extend(warning);
        }
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
            // Beyond MAX_EMISSION (sample-cache rendered ∞ pixels) and
            // outside the sky fit's turbidities (clamped silently before).
            "constant:1e38",
            "constant:1,1e31,1",
            "directional:45,0,1e38,1,1",
            "sun-sky:45,0,1e30",
            "sun-sky:45,0,1.5",
            "sun-sky:45,0,10.5",
        ] {
            let e = bad.parse::<DefaultLighting>().unwrap_err().to_string();
            assert!(e.contains("invalid lighting"), "{e}");
        }
    }

    /// A sun-sky sun below the horizon is refused (the sky would show it on
    /// the horizon while the light shone from below); a directional light
    /// from below stays legal.
    #[test]
    fn a_sun_sky_sun_below_the_horizon_is_refused() {
        let e = "sun-sky:-10,0,3"
            .parse::<DefaultLighting>()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("invalid lighting 'sun-sky:-10,0,3'")
                && e.contains("sun-sky elevation must be within 0..90 degrees"),
            "{e}"
        );
        assert!("constant:0.2+sun-sky:-0.5,0,3"
            .parse::<DefaultLighting>()
            .is_err());
        assert!("sun-sky:0,0,3".parse::<DefaultLighting>().is_ok());
        assert!("directional:-30,0".parse::<DefaultLighting>().is_ok());
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

    /// A one-quad scene whose material emits `emissive` (zero: none).
    fn quad_emitting(emissive: Vec3) -> Scene {
        use crate::scene::generate::{add_material, add_mesh, grid};
        use crate::scene::Material;
        let mut s = Scene::default();
        let m = add_material(
            &mut s,
            Material {
                emissive,
                ..Material::diffuse("m", Vec3::splat(0.5))
            },
        );
        let q = grid("q", Vec3::ZERO, Vec3::X, Vec3::Y, 1, 1, glam::Vec2::ONE);
        add_mesh(&mut s, q, m, glam::Mat4::IDENTITY);
        s
    }

    fn lamp() -> Light {
        Light {
            name: "lamp".into(),
            kind: LightKind::Point,
            radiant: Vec3::ONE,
            position: Vec3::Y,
            direction: Vec3::NEG_Y,
            range: None,
        }
    }

    #[test]
    fn the_lighting_rule() {
        let sun_sky = DefaultLighting::default();
        let constant: DefaultLighting = "constant:0.25".parse().unwrap();
        let directional: DefaultLighting = "directional:60,45".parse().unwrap();

        // No lights: the default sun and sky.
        let none = quad_emitting(Vec3::ZERO);
        let d = decide_lighting(&none, None);
        assert_eq!(d.added, Some(sun_sky.clone()));
        assert!(!d.explicit && !d.own.any());
        assert_eq!(
            d.line(),
            "lighting: sun-sky (default: the scene has no lights of its own)"
        );

        // Emission ≤ 1 in every channel (glTF's emissiveFactor alone): a
        // glow, the default is added; exactly 1 is still a glow.
        for glow in [Vec3::new(1.0, 0.5, 0.0), Vec3::ONE] {
            let s = quad_emitting(glow);
            let d = decide_lighting(&s, None);
            assert_eq!(d.added, Some(sun_sky.clone()), "{glow}");
            assert_eq!((d.own.glows, d.own.hdr_emitters), (1, 0));
            assert_eq!(
                d.line(),
                "lighting: sun-sky (default: the scene's 1 emissive material is a glow ≤ 1, not a light)"
            );
        }

        // KHR_materials_emissive_strength 5 on factor (1, 0.2, 0): an HDR
        // emitter, the scene's own lighting.
        let hdr = quad_emitting(Vec3::new(1.0, 0.2, 0.0) * 5.0);
        let d = decide_lighting(&hdr, None);
        assert_eq!(d.added, None);
        assert_eq!((d.own.glows, d.own.hdr_emitters), (0, 1));
        assert_eq!(
            d.line(),
            "lighting: the scene's own (1 HDR emitter, 0 punctual lights); --lighting adds default lighting"
        );

        // A punctual light: the scene's own.
        let mut lit = quad_emitting(Vec3::ZERO);
        lit.lights.push(lamp());
        let d = decide_lighting(&lit, None);
        assert_eq!(d.added, None);
        assert_eq!(d.own.punctual_lights, 1);

        // An environment: the scene's own.
        let mut env = quad_emitting(Vec3::ZERO);
        env.environment = Some(Environment::Constant(Vec3::ONE));
        assert_eq!(decide_lighting(&env, None).added, None);

        // An explicit choice is always added.
        for s in [&none, &hdr, &lit, &env, &quad_emitting(Vec3::ONE)] {
            for c in [&sun_sky, &constant, &directional] {
                let d = decide_lighting(s, Some(c));
                assert_eq!(d.added.as_ref(), Some(c));
                assert!(d.explicit);
                // The scene's environment is replaced only by a choice with one.
                assert_eq!(
                    d.replaces_environment,
                    s.environment.is_some() && c != &directional
                );
            }
        }
        assert_eq!(
            decide_lighting(&env, Some(&constant)).line(),
            "lighting: constant:0.25 (--lighting) added to the scene's own (0 HDR emitters, 0 punctual lights, an environment); its environment replaced"
        );
        assert_eq!(
            decide_lighting(&none, Some(&directional)).line(),
            "lighting: directional:60,45 (--lighting; the scene has no lights of its own)"
        );

        // A material no instance uses does not count.
        let mut unused = quad_emitting(Vec3::ZERO);
        unused.materials.push(crate::scene::Material {
            emissive: Vec3::splat(10.0),
            ..crate::scene::Material::diffuse("unused", Vec3::ONE)
        });
        assert_eq!(decide_lighting(&unused, None).added, Some(sun_sky.clone()));
    }

    #[test]
    fn light_scene_adds_explicit_lighting_and_keeps_the_scenes_own() {
        // An HDR emitter and a lamp, with --lighting sun-sky: both stay, the
        // sun and sky are added.
        let mut s = quad_emitting(Vec3::splat(5.0));
        s.lights.push(lamp());
        let d = light_scene(&mut s, Some(&DefaultLighting::default())).unwrap();
        assert!(d.explicit && d.own.any());
        assert_eq!(s.lights.len(), 2);
        assert_eq!(s.lights[0].name, "lamp");
        assert_eq!(s.lights[1].name, DEFAULT_SUN_NAME);
        assert!(matches!(s.environment, Some(Environment::Sky { .. })));
        assert_eq!(s.materials[0].emissive, Vec3::splat(5.0));
        // Without a choice the same scene stays as it is.
        let mut s = quad_emitting(Vec3::splat(5.0));
        light_scene(&mut s, None).unwrap();
        assert!(s.lights.is_empty() && s.environment.is_none());
        // A glow gets the sun and sky and keeps glowing.
        let mut s = quad_emitting(Vec3::splat(0.8));
        light_scene(&mut s, None).unwrap();
        assert_eq!(s.lights.len(), 1);
        assert!(matches!(s.environment, Some(Environment::Sky { .. })));
        assert_eq!(s.materials[0].emissive, Vec3::splat(0.8));
        // ... and, lit by default lighting only, has it replaced by a choice
        // (the environment too), not summed.
        assert!(has_default_lighting_only(&s));
        let c: DefaultLighting = "constant:0.5".parse().unwrap();
        let d = light_scene(&mut s, Some(&c)).unwrap();
        assert!(!d.replaces_environment && d.own.default_only);
        assert_eq!(
            d.line(),
            "lighting: constant:0.5 (--lighting; the scene's 1 emissive material is a glow ≤ 1, not a light; the scene's stand-in default lighting replaced)"
        );
        assert!(s.lights.is_empty());
        assert!(matches!(s.environment, Some(Environment::Constant(v)) if v == Vec3::splat(0.5)));
    }

    #[test]
    fn display_gives_the_cli_string_back() {
        for s in [
            "sun-sky",
            "sun-sky:30,90,4",
            "constant:0.5",
            "constant:1,2,3.5",
            "env:a/b.hdr",
            "directional:60,45",
            "directional:60,45,1,2,3",
            "constant:0.3+directional:60,45",
        ] {
            let l: DefaultLighting = s.parse().unwrap();
            assert_eq!(l.to_string(), s);
            assert_eq!(l.to_string().parse::<DefaultLighting>().unwrap(), l);
        }
    }
}
