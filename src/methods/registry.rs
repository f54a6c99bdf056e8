//! The method registry: every rendering method named once, with its
//! description, its constructor and its configuration type. The CLI
//! (`--method`, `--methods`), [`crate::session::Session::create`],
//! `compare`, `bench` and `replay` ask this table; nothing else matches
//! method names.
//!
//! Adding a method: its own folder under `src/methods/` (a type implementing
//! [`Method`] with a constructor of the shape
//! `fn(&Arc<GpuContext>, &Arc<SceneGpu>, &Option<Environment>, &RenderSettings, &Options) -> GpuResult<T>`
//! where `Options` implements [`MethodOptions`]; a method without options
//! uses [`NoOptions`] and wraps a four-argument constructor in
//! [`no_options`]), `pub mod` in `methods/mod.rs`, and one line in the
//! `methods!` list below.

use super::config::{MethodOptions, NoOptions};
use super::{
    baseline, DebugNormals, HashCache, HashCacheSettings, Hybrid, HybridConfig, Isrt, IsrtSettings,
    Method, MethodArgs, Reference, RenderSettings, SampleCache, SampleCacheSettings, Taa,
    TaaOnOutput, TaaSettings,
};
use crate::error::{Error, Result};
use crate::gpu::{GpuContext, GpuResult};
use crate::rt::SceneGpu;
use crate::scene::Environment;
use crate::session::Session;
use std::str::FromStr;
use std::sync::Arc;

/// A constructor of a method without options: the shape every method had
/// before it had a configuration.
pub type PlainConstructor<T> =
    fn(&Arc<GpuContext>, &Arc<SceneGpu>, &Option<Environment>, &RenderSettings) -> GpuResult<T>;

/// A method constructor that takes no options as one of the registry's
/// shape (the options, [`NoOptions`], are ignored).
pub fn no_options<T>(
    ctor: PlainConstructor<T>,
) -> impl Fn(
    &Arc<GpuContext>,
    &Arc<SceneGpu>,
    &Option<Environment>,
    &RenderSettings,
    &NoOptions,
) -> GpuResult<T> {
    move |ctx, scene, env, settings, _| ctor(ctx, scene, env, settings)
}

/// Declares [`MethodKind`], [`MethodConfig`] and their table from one line
/// per method: `Variant = "cli-name", constructor, config_fn: Options, "description"`.
macro_rules! methods {
    ($($variant:ident = $name:literal, $ctor:expr, $cfn:ident: $cfg:ty, $about:literal;)+) => {
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

        /// A method with its own options: what [`MethodConfig::create`] (and
        /// [`Session::create`]) create a method from, beside the shared
        /// [`RenderSettings`]. `MethodKind::X.into()` is X with default options.
        #[derive(Clone, Debug)]
        pub enum MethodConfig {
            $(
                #[doc = $about]
                $variant($cfg),
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

            /// The method with its default options.
            pub fn default_config(self) -> MethodConfig {
                match self {
                    $(MethodKind::$variant => MethodConfig::$variant(<$cfg>::default()),)+
                }
            }

            /// The method with its options from the command line (checked).
            pub fn config_from_args(self, args: &MethodArgs, debug_views: bool) -> std::result::Result<MethodConfig, String> {
                Ok(match self {
                    $(MethodKind::$variant => MethodConfig::$variant(<$cfg as MethodOptions>::from_args(args, debug_views)?),)+
                })
            }
        }

        impl MethodConfig {
            $(
                #[doc = concat!("`", $name, "` with its default options changed by `edit`.")]
                pub fn $cfn(edit: impl FnOnce(&mut $cfg)) -> MethodConfig {
                    let mut options = <$cfg>::default();
                    edit(&mut options);
                    MethodConfig::$variant(options)
                }
            )+

            /// The method's options if they are a `T` (`None` otherwise).
            pub fn options<T: 'static>(&self) -> Option<&T> {
                match self {
                    $(MethodConfig::$variant(o) => (o as &dyn std::any::Any).downcast_ref::<T>(),)+
                }
            }

            /// The method's options if they are a `T`, to change (`None` otherwise).
            pub fn options_mut<T: 'static>(&mut self) -> Option<&mut T> {
                match self {
                    $(MethodConfig::$variant(o) => (o as &mut dyn std::any::Any).downcast_mut::<T>(),)+
                }
            }

            /// Which method this configures.
            pub fn kind(&self) -> MethodKind {
                match self {
                    $(MethodConfig::$variant(_) => MethodKind::$variant,)+
                }
            }

            /// Turns on the method's debug views, where it has any.
            pub fn enable_debug_views(&mut self) {
                match self {
                    $(MethodConfig::$variant(o) => o.enable_debug_views(),)+
                }
            }

            /// The settings record of a run (summary.json, stats.json): the
            /// shared `settings` with this method's options beside them.
            pub fn record(&self, settings: &RenderSettings) -> serde_json::Value {
                let mut v = serde_json::to_value(settings).unwrap_or_default();
                if let Some(map) = v.as_object_mut() {
                    match self {
                        $(MethodConfig::$variant(o) => o.record(map),)+
                    }
                }
                v
            }

            /// Creates the method on `session`'s device and scene.
            pub fn create(&self, session: &Session, settings: &RenderSettings) -> Result<Box<dyn Method>> {
                let (ctx, scene, env) = (&session.ctx, &session.scene_gpu, &session.scene.environment);
                let mut method: Box<dyn Method> = match self {
                    $(MethodConfig::$variant(o) => Box::new(($ctor)(ctx, scene, env, settings, o)?),)+
                };
                // `--taa-output`: the one TAA on the output of every method
                // that does not already end in it.
                if let Some(taa) = &settings.taa_output {
                    if !method.resolves_with_taa() {
                        method = Box::new(TaaOnOutput::new(method, scene, settings, taa)?);
                    }
                }
                // The name a method reports (summary.json, stats.json) is its registry name.
                debug_assert_eq!(method.name(), self.kind().name());
                Ok(method)
            }
        }
    };
}

methods! {
    Reference = "reference", no_options(Reference::new), reference: NoOptions, "Path tracing at --spp samples per pixel (the ground truth).";
    SampleCache = "sample-cache", SampleCache::new, sample_cache: SampleCacheSettings, "The paper's screen-space sample cache (§3).";
    Naive = "naive", no_options(baseline::naive), naive: NoOptions, "1 spp jittered path tracing, no reuse.";
    Supersample = "supersample", no_options(baseline::supersample), supersample: NoOptions, "--spp jittered samples per pixel per frame, no reuse.";
    Taa = "taa", Taa::new, taa: TaaSettings, "1 spp path tracing with temporal antialiasing (Halton jitter, YCoCg clipping).";
    Isrt = "isrt", Isrt::new, isrt: IsrtSettings, "Interactive stable ray tracing (Dal Corso et al. 2017: M×M cells per pixel).";
    HashCache = "hash-cache", HashCache::new, hash_cache: HashCacheSettings, "A world-space hash-grid radiance cache, with TAA on its output.";
    Hybrid = "hybrid", Hybrid::new, hybrid: HybridConfig, "Sample-cache visibility shaded from the hash-grid cache, with TAA.";
    DebugNormals = "debug-normals", no_options(DebugNormals::new), debug_normals: NoOptions, "Scene check: the first hit's shading normal as colour (0.5·n + 0.5, world space; misses black).";
}

impl From<MethodKind> for MethodConfig {
    /// The method with its default options.
    fn from(kind: MethodKind) -> MethodConfig {
        kind.default_config()
    }
}

impl From<&MethodConfig> for MethodConfig {
    fn from(config: &MethodConfig) -> MethodConfig {
        config.clone()
    }
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
    let names: Vec<&str> = list.split(',').map(str::trim).collect();
    if names.iter().all(|m| m.is_empty()) {
        return Err(Error::Usage(format!(
            "bad --methods '{list}': name at least one method"
        )));
    }
    if names.iter().any(|m| m.is_empty()) {
        return Err(Error::Usage(format!(
            "bad --methods '{list}': an empty name in the list"
        )));
    }
    let methods = names
        .iter()
        .map(|m| MethodKind::from_str(m))
        .collect::<Result<Vec<_>>>()?;
    // Each method's outputs go to a folder of its name: twice would
    // overwrite one run with the other.
    for (i, m) in methods.iter().enumerate() {
        if methods[..i].contains(m) {
            return Err(Error::Usage(format!(
                "bad --methods '{list}': {} is named twice",
                names[i]
            )));
        }
    }
    Ok(methods)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `MethodArgs` as a command line would give it.
    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        methods: MethodArgs,
    }

    fn args(line: &[&str]) -> MethodArgs {
        <Cli as clap::Parser>::try_parse_from(std::iter::once("x").chain(line.iter().copied()))
            .unwrap()
            .methods
    }

    #[test]
    fn every_method_has_a_config_of_its_own_kind() {
        let defaults = args(&[]);
        for &k in MethodKind::ALL {
            assert_eq!(k.default_config().kind(), k);
            assert_eq!(MethodConfig::from(k).kind(), k);
            assert_eq!(defaults.config(k, false).unwrap().kind(), k);
        }
        let c = MethodConfig::sample_cache(|c| c.slots = 8);
        assert_eq!(c.kind(), MethodKind::SampleCache);
        assert_eq!(c.options::<SampleCacheSettings>().unwrap().slots, 8);
        assert!(c.options::<HashCacheSettings>().is_none());
        let mut h = MethodKind::Hybrid.default_config();
        h.options_mut::<HybridConfig>().unwrap().hash.capacity = 64;
        h.enable_debug_views();
        let hy = h.options::<HybridConfig>().unwrap();
        assert!(hy.cache.debug_views && hy.hash.debug_views && hy.hash.capacity == 64);
    }

    #[test]
    fn the_command_line_builds_the_chosen_methods_config() {
        let a = args(&[
            "--slots",
            "6",
            "--n-target",
            "3",
            "--hash-capacity",
            "256",
            "--isrt-m",
            "2",
        ]);
        let sc = a.config(MethodKind::SampleCache, true).unwrap();
        let sc = sc.options::<SampleCacheSettings>().unwrap();
        assert_eq!((sc.slots, sc.n_target, sc.debug_views), (6, 3, true));
        let hy = a.config(MethodKind::Hybrid, false).unwrap();
        let hy = hy.options::<HybridConfig>().unwrap();
        assert_eq!((hy.cache.slots, hy.hash.capacity), (6, 256));
        let isrt = a.config(MethodKind::Isrt, false).unwrap();
        assert_eq!(isrt.options::<IsrtSettings>().unwrap().m, 2);
        // A bad option of one method is refused whichever method runs.
        let bad = args(&["--slots", "2", "--n-target", "4"]);
        assert!(bad.config(MethodKind::Reference, false).is_ok());
        let e = bad
            .settings(
                crate::values::Size {
                    width: 8,
                    height: 8,
                },
                1,
                1,
                1,
                false,
            )
            .unwrap_err();
        assert!(e.contains("--n-target"), "{e}");
    }

    #[test]
    fn a_runs_settings_record_has_the_methods_own_options_only() {
        let st = RenderSettings::default();
        let keys = |c: MethodConfig| -> Vec<String> {
            let v = c.record(&st);
            let m = v.as_object().unwrap();
            assert_eq!(m["spp"], st.spp);
            ["cache", "taa", "isrt", "hash"]
                .iter()
                .filter(|k| m.contains_key(**k))
                .map(|k| k.to_string())
                .collect()
        };
        assert!(keys(MethodKind::Reference.into()).is_empty());
        assert_eq!(keys(MethodKind::SampleCache.into()), ["cache"]);
        assert_eq!(keys(MethodKind::Taa.into()), ["taa"]);
        assert_eq!(keys(MethodKind::Isrt.into()), ["isrt"]);
        assert_eq!(keys(MethodKind::HashCache.into()), ["hash"]);
        assert_eq!(keys(MethodKind::Hybrid.into()), ["cache", "hash"]);
        let v = MethodConfig::sample_cache(|c| c.slots = 5).record(&st);
        assert_eq!(v["cache"]["slots"], 5);
    }

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
        assert!(parse_list("naive,,taa")
            .unwrap_err()
            .to_string()
            .contains("an empty name in the list"));
        assert!(parse_list("naive, taa,naive")
            .unwrap_err()
            .to_string()
            .contains("naive is named twice"));
    }
}
