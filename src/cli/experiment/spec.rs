//! An experiment file (TOML, `experiments/*.toml`) read into the
//! comparisons it runs. The file names its settings with the command line's
//! flag names (`spp = 4`, `retrace = "adaptive"`, `taa-output = true`), and
//! every value goes through `compare`'s own parser ([`CompareArgs`], which
//! flattens every method's [`stereocache::methods::MethodArgs`]): there is
//! no second option parser, and a value the command line refuses is refused
//! here with the same message, prefixed by the file and the key.
//!
//! ```toml
//! name = "fig15"                      # the folder-safe name
//! title = "Stereo blending"           # one line
//! paper = "§5.2, Fig. 15"             # where in the paper
//! figures = ["summary", "ratios"]     # report sections to draw (default: all, FIGURES)
//! missing = ["..."]                   # settings the paper uses that do not exist yet
//!
//! [run]                               # every comparison: compare's flags
//! scenes = ["cornell"]                # one comparison per scene × trace
//! traces = ["captures/synth-walk.csv"]
//! size = "64x48"
//! reference-spp = 64
//!
//! [scale.ci]                          # --scale ci (the default): overrides [run]
//! frames = 8
//! [scale.paper]                       # --scale paper
//! size = "1920x1080"
//!
//! [[method]]                          # one configuration (or one per sweep value)
//! label = "R0"                        # its folder and column (default: the method name)
//! method = "sample-cache"
//! stereo-blend = "moments"            # any method option or spp, bounces, seed
//! sweep = { sharpness = [0.0, 1.0] }  # optional: one configuration per value
//!
//! [[claim]]                           # see super::claims
//! ```
//!
//! Relative paths (scenes, traces) are relative to the current directory, as
//! on the command line: run experiments from the repository root.

use super::claims::ClaimSpec;
use crate::cli::compare::CompareArgs;
use clap::{Args, Parser};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use stereocache::compare::Config;
use stereocache::methods::{MethodArgs, MethodKind};

/// Report sections an experiment may ask for (`figures`), as
/// [`stereocache::report::html`] names them.
pub const FIGURES: &[&str] = stereocache::report::html::SECTIONS;

/// Keys of `[run]` that are not compare flags.
const LISTS: &[&str] = &["scenes", "traces"];
/// Compare flags an experiment does not set: where it writes is `--out` of
/// `experiment run`; its scenes, traces and methods are lists of their own.
const NOT_IN_FILES: &[&str] = &["out", "scene", "trace", "methods", "help"];
/// Settings a configuration may set beside its method's options.
const PER_CONFIG: &[&str] = &["spp", "bounces", "seed"];
/// Keys of a `[[method]]` entry that are not flags.
const METHOD_KEYS: &[&str] = &["label", "method", "sweep"];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    title: String,
    #[serde(default)]
    paper: String,
    #[serde(default)]
    figures: Vec<String>,
    #[serde(default)]
    missing: Vec<String>,
    run: toml::Table,
    #[serde(default)]
    scale: BTreeMap<String, toml::Table>,
    #[serde(rename = "method")]
    methods: Vec<toml::Table>,
    #[serde(default, rename = "claim")]
    claims: Vec<ClaimSpec>,
}

/// A scene entry that names a file or folder (not a built-in generator).
fn is_scene_path(s: &str) -> bool {
    s.contains('/') || s.ends_with(".gltf") || s.ends_with(".glb")
}

/// One comparison of an experiment: a scene along a trace, with its configurations.
pub struct Group {
    /// `<scene>-<trace>` (file stems): its folder under the output.
    pub label: String,
    pub scene: String,
    pub trace: PathBuf,
    /// The shared settings, parsed as `compare` parses them.
    pub args: CompareArgs,
    pub configs: Vec<Config>,
}

/// An experiment file read and checked.
pub struct Experiment {
    pub path: PathBuf,
    pub name: String,
    pub title: String,
    pub paper: String,
    pub figures: Vec<String>,
    pub missing: Vec<String>,
    pub claims: Vec<ClaimSpec>,
    pub scale: String,
    /// Where the `scenes` key came from (`[run]`, `[scale.X]` or `--set`),
    /// for errors about a scene found only when it is loaded.
    pub scenes_from: String,
    pub groups: Vec<Group>,
}

/// The experiment's runs (group, configuration) in order; a shard K/N
/// takes those whose index is K-1 modulo N.
pub fn runs(e: &Experiment) -> Vec<(usize, usize)> {
    e.groups
        .iter()
        .enumerate()
        .flat_map(|(g, grp)| (0..grp.configs.len()).map(move |c| (g, c)))
        .collect()
}

#[derive(Parser)]
#[command(name = "experiment", no_binary_name = true)]
struct Line {
    #[command(flatten)]
    compare: CompareArgs,
}

/// A string, number or boolean as text.
fn scalar(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        _ => None,
    }
}

/// The command-line words of `key = value`.
fn words(key: &str, v: &toml::Value) -> Result<Vec<String>, String> {
    let flag = format!("--{key}");
    Ok(match v {
        toml::Value::Boolean(true) => vec![flag],
        toml::Value::Boolean(false) => vec![],
        toml::Value::Array(a) => {
            let items: Option<Vec<String>> = a.iter().map(scalar).collect();
            let items = items.ok_or("expected a list of numbers or strings")?;
            vec![flag, items.join(",")]
        }
        other => match scalar(other) {
            Some(s) => vec![flag, s],
            None => return Err("expected a string, number, boolean or list".into()),
        },
    })
}

/// Parses compare's command line `argv`; clap's message cut to its first line.
pub(crate) fn parse(argv: &[String]) -> Result<CompareArgs, String> {
    use clap::{CommandFactory, FromArgMatches};
    crate::cli::negative_numbers(Line::command())
        .try_get_matches_from(argv)
        .and_then(|m| Line::from_arg_matches(&m))
        .map(|l| l.compare)
        .map_err(|e| {
            let text = e.to_string();
            let line = text.lines().next().unwrap_or("").trim();
            line.strip_prefix("error: ").unwrap_or(line).to_string()
        })
}

/// The long names of every method option.
fn method_flags() -> Vec<String> {
    MethodArgs::augment_args(clap::Command::new("m"))
        .get_arguments()
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect()
}

/// `table`'s flags as command-line words, each checked on its own so an
/// error names its key.
fn flags(
    table: &toml::Table,
    base: &[String],
    section: &str,
    skip: &[&str],
) -> Result<Vec<String>, String> {
    let mut argv = Vec::new();
    for (k, v) in table {
        if skip.contains(&k.as_str()) {
            continue;
        }
        if NOT_IN_FILES.contains(&k.as_str()) {
            return Err(format!(
                "{section}: key '{k}' is not set in experiment files (scenes = [..], traces = [..], [[method]] entries; the output folder is `experiment run --out`)"
            ));
        }
        let w = words(k, v).map_err(|e| format!("{section}: key '{k}': {e}"))?;
        let mut one = base.to_vec();
        if matches!(v, toml::Value::Boolean(false)) {
            // `key = false` leaves the flag out, which only a switch may
            // mean (until session 50 `spp = false` ran at the default spp):
            // the flag alone must parse.
            one.push(format!("--{k}"));
            parse(&one).map_err(|_| {
                format!("{section}: key '{k}': expected a value, not false (only a switch such as taa-output may be false)")
            })?;
        } else {
            one.extend(w.iter().cloned());
            parse(&one).map_err(|e| format!("{section}: key '{k}': {e}"))?;
        }
        argv.extend(w);
    }
    Ok(argv)
}

fn strings(v: Option<&toml::Value>, what: &str) -> Result<Vec<String>, String> {
    let a = v
        .and_then(|v| v.as_array())
        .ok_or(format!("[run]: key '{what}': expected a list of strings"))?;
    let s: Option<Vec<String>> = a.iter().map(|x| x.as_str().map(str::to_string)).collect();
    match s {
        Some(s) if !s.is_empty() => Ok(s),
        _ => Err(format!(
            "[run]: key '{what}': expected a non-empty list of strings"
        )),
    }
}

/// `a` with `b`'s keys replacing its own.
fn overlay(a: &toml::Table, b: &toml::Table) -> toml::Table {
    let mut t = a.clone();
    for (k, v) in b {
        t.insert(k.clone(), v.clone());
    }
    t
}

/// A label from a value: letters, digits and `-_.=` kept, others `_`.
fn label_part(v: &toml::Value) -> String {
    let s = match v {
        toml::Value::Boolean(b) => b.to_string(),
        other => scalar(other).unwrap_or_else(|| "value".into()),
    };
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.=".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// One line: "FILE:LINE: message" from a TOML error.
fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> String {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
        .map(|l| format!(":{l}"))
        .unwrap_or_default();
    format!(
        "{}{line}: {}",
        path.display(),
        e.message().trim().replace('\n', " ")
    )
}

/// `--set KEY=VALUE`: the value as TOML (a number, boolean, quoted string
/// or list), else as a string.
pub fn parse_set(s: &str) -> Result<(String, toml::Value), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or(format!("bad --set '{s}': expected KEY=VALUE"))?;
    let value = toml::from_str::<toml::Table>(&format!("v = {v}"))
        .ok()
        .and_then(|t| t.get("v").cloned())
        .unwrap_or_else(|| toml::Value::String(v.to_string()));
    Ok((k.trim().to_string(), value))
}

/// Reads and checks `path` at `scale` with `sets` applied last: every
/// comparison and configuration parsed, scenes and traces found. Errors are
/// one line naming the file and the key.
pub fn read(
    path: &Path,
    scale: &str,
    sets: &[(String, toml::Value)],
) -> Result<Experiment, String> {
    let text = stereocache::input::read_to_string(path)
        .map_err(|e| format!("{}: cannot read ({e})", path.display()))?;
    let file: File = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    let at = |m: String| format!("{}: {m}", path.display());
    // The name is a folder under out/experiments: '.' and '..' would put
    // the experiment's files into out/experiments or out itself (and remove
    // a stale experiment.json there first).
    if file.name.is_empty()
        || file.name == "."
        || file.name == ".."
        || !file
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
    {
        return Err(at(format!(
            "key 'name': '{}' must be letters, digits, '-', '_', '.' (and not '.' or '..')",
            file.name
        )));
    }
    for f in &file.figures {
        if !FIGURES.contains(&f.as_str()) {
            return Err(at(format!(
                "key 'figures': unknown figure '{f}' (available: {})",
                FIGURES.join(", ")
            )));
        }
    }
    let mut run = file.run.clone();
    // Where each key of the merged [run] came from when not from [run]
    // itself ([scale.X] or --set): an error about it names that source.
    let mut origin: BTreeMap<String, String> = BTreeMap::new();
    if !file.scale.is_empty() || scale != "ci" {
        let t = file.scale.get(scale).ok_or_else(|| {
            at(if file.scale.is_empty() {
                format!("no [scale.{scale}]: the file defines no [scale.*] section")
            } else {
                format!(
                    "no [scale.{scale}] (scales: {})",
                    file.scale.keys().cloned().collect::<Vec<_>>().join(", ")
                )
            })
        })?;
        run = overlay(&run, t);
        for k in t.keys() {
            origin.insert(k.clone(), format!("[scale.{scale}]"));
        }
    }
    let mut set_table = toml::Table::new();
    for (k, v) in sets {
        set_table.insert(k.clone(), v.clone());
        origin.insert(k.clone(), "--set".into());
    }
    run = overlay(&run, &set_table);
    let at = |m: String| {
        let m = match m
            .strip_prefix("[run]: key '")
            .and_then(|r| r.split_once('\''))
        {
            Some((k, rest)) if origin.contains_key(k) => {
                format!("{}: key '{k}'{rest}", origin[k])
            }
            _ => m,
        };
        format!("{}: {m}", path.display())
    };
    let scenes = strings(run.get("scenes"), "scenes").map_err(at)?;
    let traces = strings(run.get("traces"), "traces").map_err(at)?;
    for s in &scenes {
        let p = Path::new(s);
        if is_scene_path(s) && !p.exists() {
            return Err(at(format!(
                "[run]: key 'scenes': {s}: no such file or directory (paths are relative to the current directory: run from the repository root)"
            )));
        }
    }
    let mut trace_data = std::collections::BTreeMap::new();
    for t in &traces {
        let d = stereocache::camera::PoseTrace::read_csv(t)
            .map_err(|e| at(format!("[run]: key 'traces': {e}")))?;
        trace_data.insert(t.clone(), d);
    }
    let known = method_flags();
    // Method entries: kind, label, own flags, sweep points.
    struct Entry {
        label: String,
        kind: MethodKind,
        table: toml::Table,
        section: String,
    }
    let mut entries: Vec<Entry> = Vec::new();
    if file.methods.is_empty() {
        return Err(at("no [[method]] entries".into()));
    }
    for (i, m) in file.methods.iter().enumerate() {
        let kind_name = m.get("method").and_then(|v| v.as_str()).ok_or_else(|| {
            at(format!(
                "[[method]] #{}: key 'method': expected a method name",
                i + 1
            ))
        })?;
        let kind: MethodKind = kind_name.parse().map_err(|e: stereocache::error::Error| {
            at(format!("[[method]] #{}: key 'method': {e}", i + 1))
        })?;
        let label = match m.get("label") {
            None => kind.name().to_string(),
            Some(v) => v
                .as_str()
                .ok_or_else(|| {
                    at(format!(
                        "[[method]] #{}: key 'label': expected a string",
                        i + 1
                    ))
                })?
                .to_string(),
        };
        stereocache::compare::check_label(&label)
            .map_err(|m| at(format!("[[method]] #{}: key 'label': {m}", i + 1)))?;
        let section = format!("[[method]] '{label}'");
        for k in m.keys() {
            if !METHOD_KEYS.contains(&k.as_str())
                && !PER_CONFIG.contains(&k.as_str())
                && !known.contains(k)
            {
                return Err(at(format!(
                    "{section}: key '{k}' is not a method option (per configuration: {}, and every method option of `stereocache compare --help`)",
                    PER_CONFIG.join(", ")
                )));
            }
        }
        let mut own = m.clone();
        own.retain(|k, _| {
            let k: &str = k;
            !METHOD_KEYS.contains(&k)
        });
        let sweep = match m.get("sweep") {
            None => toml::Table::new(),
            Some(toml::Value::Table(t)) => t.clone(),
            Some(_) => {
                return Err(at(format!(
                    "{section}: key 'sweep': expected a table of lists, e.g. sweep = {{ spp = [1, 4] }}"
                )))
            }
        };
        // Cartesian product of the sweep's lists, in key order.
        let mut points: Vec<(String, toml::Table)> = vec![(label.clone(), own.clone())];
        for (k, v) in &sweep {
            if !PER_CONFIG.contains(&k.as_str()) && !known.contains(k) {
                return Err(at(format!(
                    "{section}: key 'sweep.{k}' is not a method option"
                )));
            }
            let values = v.as_array().filter(|a| !a.is_empty()).ok_or_else(|| {
                at(format!(
                    "{section}: key 'sweep.{k}': expected a non-empty list"
                ))
            })?;
            points = points
                .into_iter()
                .flat_map(|(l, t)| {
                    values.iter().map(move |x| {
                        let mut t = t.clone();
                        t.insert(k.clone(), x.clone());
                        (format!("{l}-{k}={}", label_part(x)), t)
                    })
                })
                .collect();
        }
        for (l, t) in points {
            entries.push(Entry {
                label: l,
                kind,
                table: t,
                section: section.clone(),
            });
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    for e in &entries {
        if !seen.insert(e.label.clone()) {
            return Err(at(format!(
                "{}: configuration '{}' appears twice (give each [[method]] its own label)",
                e.section, e.label
            )));
        }
    }
    let mut groups = Vec::new();
    for scene in &scenes {
        for trace in &traces {
            let stem = |s: &str| {
                Path::new(s)
                    .file_stem()
                    .map(|x| x.to_string_lossy().into_owned())
                    .unwrap_or_else(|| s.to_string())
            };
            // A built-in scene with options (`cornell:alpha=0.2`) is no file:
            // its whole spec names it, `:` and `=` as `-`.
            let scene_name = if is_scene_path(scene) {
                stem(scene)
            } else {
                scene.replace([':', '='], "-")
            };
            let label = format!("{}-{}", scene_name, stem(trace));
            let base: Vec<String> = [
                "--scene",
                scene,
                "--trace",
                trace,
                "--out",
                "experiment-out",
            ]
            .iter()
            .map(|s| s.to_string())
            .collect();
            let shared = flags(&run, &base, "[run]", LISTS).map_err(at)?;
            let mut argv = base.clone();
            argv.extend(shared);
            let args = parse(&argv).map_err(|e| at(format!("[run]: {e}")))?;
            if let (Some(k), Some(d)) = (args.frames, trace_data.get(trace)) {
                // Refused here, not after the comparisons before this one
                // have rendered (compare refuses it too).
                let available = d.resampled_len(args.fps).min(usize::MAX as f64) as usize;
                if k > available {
                    return Err(at(format!(
                        "[run]: key 'frames': {k} frames, but trace {trace} gives only {available} at {} fps",
                        args.fps
                    )));
                }
            }
            if let (Some(shown), Some(d)) = (&args.show_frames, trace_data.get(trace)) {
                let available = d.resampled_len(args.fps).min(usize::MAX as f64) as usize;
                let n = args.frames.map_or(available, |k| k.min(available));
                stereocache::compare::check_shown_frames(&shown.0, n)
                    .map_err(|m| at(format!("[run]: key 'show-frames': {m}")))?;
            }
            let mut configs = Vec::new();
            // (section, what the run records) of each configuration: two
            // points of one [[method]]'s sweep that record the same are
            // one run under two labels (a swept option the method does not
            // read, e.g. `sharpness` on `naive`).
            let mut runs_of: std::collections::BTreeMap<(String, String), String> =
                Default::default();
            for e in &entries {
                // The configuration's own keys replace [run]'s.
                let merged = overlay(&run, &e.table);
                let w = flags(&merged, &base, &e.section, LISTS).map_err(at)?;
                let mut argv = base.clone();
                argv.extend(w);
                let a = parse(&argv).map_err(|m| at(format!("{}: {m}", e.section)))?;
                let settings = a
                    .method_opts
                    .settings(args.size, a.spp, a.bounces, a.seed, false)
                    .map_err(|m| at(format!("{}: {m}", e.section)))?;
                let config = a
                    .method_opts
                    .config(e.kind, false)
                    .map_err(|m| at(format!("{}: {m}", e.section)))?;
                let key = (e.section.clone(), config.record(&settings).to_string());
                if let Some(other) = runs_of.insert(key, e.label.clone()) {
                    return Err(at(format!(
                        "{}: configurations '{other}' and '{}' are the same run: method '{}' does not read what the sweep changes (sweep only its own options: `stereocache compare --help`)",
                        e.section,
                        e.label,
                        e.kind.name()
                    )));
                }
                configs.push(Config {
                    label: e.label.clone(),
                    config,
                    settings,
                });
            }
            let labels: Vec<String> = configs.iter().map(|c| c.label.clone()).collect();
            stereocache::compare::choose_baseline(&labels, args.baseline.as_deref())
                .map_err(|m| at(format!("[run]: key 'baseline': {m}")))?;
            if args.reference_spp > 0 {
                stereocache::evaluate::check_reference_spp(args.reference_spp)
                    .map_err(|m| at(format!("[run]: key 'reference-spp': {m}")))?;
            }
            groups.push(Group {
                label,
                scene: scene.clone(),
                trace: PathBuf::from(trace),
                args,
                configs,
            });
        }
    }
    // Each comparison writes to the folder of its label: two scene/trace
    // pairs with one label would overwrite each other.
    let mut seen = std::collections::BTreeSet::new();
    for g in &groups {
        if !seen.insert(g.label.as_str()) {
            return Err(at(format!(
                "two comparisons are both named '{}' (scenes and traces are named by their file stems, `:` and `=` as `-`): rename a scene or trace file, or split the experiment",
                g.label
            )));
        }
    }
    for c in &file.claims {
        c.check(&groups).map_err(at)?;
    }
    Ok(Experiment {
        path: path.to_path_buf(),
        name: file.name,
        title: file.title,
        paper: file.paper,
        figures: file.figures,
        missing: file.missing,
        claims: file.claims,
        scale: scale.to_string(),
        scenes_from: origin
            .get("scenes")
            .cloned()
            .unwrap_or_else(|| "[run]".into()),
        groups,
    })
}

/// `--shard K/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Shard {
    pub k: usize,
    pub n: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("bad --shard '{s}': expected K/N with 1 <= K <= N, e.g. 1/2");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if k == 0 || n == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { k, n })
    }
}
