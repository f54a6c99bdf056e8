//! The method registry: every rendering method named once, with its
//! description and its constructor. The CLI (`--method`, `--methods`),
//! [`crate::session::Session::create`], `compare`, `bench` and `replay` ask
//! this table; nothing else matches method names.
//!
//! Adding a method: its own folder under `src/methods/` (a type implementing
//! [`Method`] with a constructor of the shape
//! `fn(&Arc<GpuContext>, &Arc<SceneGpu>, &Option<Environment>, &RenderSettings) -> GpuResult<T>`),
//! `pub mod` in `methods/mod.rs`, and one line in the `methods!` list below.

use super::{
    baseline, DebugNormals, HashCache, Hybrid, Isrt, Method, Reference, RenderSettings,
    SampleCache, Taa, TaaOnOutput,
};
use crate::error::{Error, Result};
use crate::session::Session;
use std::str::FromStr;

/// Declares [`MethodKind`] and its table from one line per method:
/// `Variant = "cli-name", constructor, "description"`.
macro_rules! methods {
    ($($variant:ident = $name:literal, $ctor:path, $about:literal;)+) => {
        /// A rendering method (`--method`), in the order `--help` lists them.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize)]
        pub enum MethodKind {
            $(
                #[doc = $about]
                #[value(name = $name)]
                #[serde(rename = $name)]
                $variant,
            )+
        }

        impl MethodKind {
            /// Every method, in registry order.
            pub const ALL: &'static [MethodKind] = &[$(MethodKind::$variant),+];

            /// The method's name on the command line.
            pub const fn name(self) -> &'static str {
                match self {
                    $(MethodKind::$variant => $name,)+
                }
            }

            /// One line on what the method does.
            pub const fn about(self) -> &'static str {
                match self {
                    $(MethodKind::$variant => $about,)+
                }
            }

            /// Creates the method on `session`'s device and scene.
            pub fn create(self, session: &Session, settings: &RenderSettings) -> Result<Box<dyn Method>> {
                let (ctx, scene, env) = (&session.ctx, &session.scene_gpu, &session.scene.environment);
                let mut method: Box<dyn Method> = match self {
                    $(MethodKind::$variant => Box::new($ctor(ctx, scene, env, settings)?),)+
                };
                // `--taa-output`: the one TAA on the output of every method
                // that does not already end in it.
                if settings.taa_output && !method.resolves_with_taa() {
                    method = Box::new(TaaOnOutput::new(method, scene, settings, &settings.taa)?);
                }
                // The name a method reports (summary.json, stats.json) is its registry name.
                debug_assert_eq!(method.name(), self.name());
                Ok(method)
            }
        }
    };
}

methods! {
    Reference = "reference", Reference::new, "Path tracing at --spp samples per pixel (the ground truth).";
    SampleCache = "sample-cache", SampleCache::new, "The paper's screen-space sample cache (§3).";
    Naive = "naive", baseline::naive, "1 spp jittered path tracing, no reuse.";
    Supersample = "supersample", baseline::supersample, "--spp jittered samples per pixel per frame, no reuse.";
    Taa = "taa", Taa::new, "1 spp path tracing with temporal antialiasing (Halton jitter, YCoCg clipping).";
    Isrt = "isrt", Isrt::new, "Interleaved super-resolution ray tracing (M×M cells per pixel).";
    HashCache = "hash-cache", HashCache::new, "A world-space hash-grid radiance cache, with TAA on its output.";
    Hybrid = "hybrid", Hybrid::new, "Sample-cache visibility shaded from the hash-grid cache, with TAA.";
    DebugNormals = "debug-normals", DebugNormals::new, "Scene check: the first hit's shading normal as colour (0.5·n + 0.5, world space; misses black).";
}

/// Every method's command-line name, in registry order.
pub fn names() -> Vec<&'static str> {
    MethodKind::ALL.iter().map(|m| m.name()).collect()
}

impl std::fmt::Display for MethodKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MethodKind {
    type Err = Error;
    /// A method by its command-line name; the message lists the others.
    fn from_str(s: &str) -> Result<MethodKind> {
        MethodKind::ALL
            .iter()
            .copied()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                Error::Usage(format!(
                    "unknown method '{s}' (available: {})",
                    names().join(", ")
                ))
            })
    }
}

/// A comma-separated list of methods (`--methods a,b`), at least one, each known.
pub fn parse_list(list: &str) -> Result<Vec<MethodKind>> {
    let methods = list
        .split(',')
        .map(str::trim)
        .filter(|m| !m.is_empty())
        .map(MethodKind::from_str)
        .collect::<Result<Vec<_>>>()?;
    if methods.is_empty() {
        return Err(Error::Usage(format!(
            "bad --methods '{list}': name at least one method"
        )));
    }
    Ok(methods)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_list_the_others() {
        for m in MethodKind::ALL {
            assert_eq!(m.name().parse::<MethodKind>().unwrap(), *m);
            assert_eq!(
                <MethodKind as clap::ValueEnum>::to_possible_value(m)
                    .unwrap()
                    .get_name(),
                m.name()
            );
        }
        let e = "magic".parse::<MethodKind>().unwrap_err().to_string();
        assert!(e.contains("unknown method 'magic'") && e.contains("hash-cache"));
        assert_eq!(
            parse_list(" naive, taa ").unwrap(),
            [MethodKind::Naive, MethodKind::Taa]
        );
        assert!(parse_list(",")
            .unwrap_err()
            .to_string()
            .contains("at least one"));
    }
}
