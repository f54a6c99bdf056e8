//! `stereocache experiment run FILE` and `experiment merge DIRS…`: the
//! paper's experiments as files (experiments/*.toml, [`spec`]), run as one
//! comparison per scene × trace ([`runner`], the same as `compare`), split
//! into disjoint shards for machines that share a sweep, merged back into
//! one report ([`stereocache::merge`]), and each claim of the paper printed
//! beside what was measured ([`claims`]).
//!
//! Output (`--out DIR`, default `out/experiments/<name>`):
//! - `DIR/<scene>-<trace>/`: a compare directory per comparison (its
//!   report.html shows the experiment's claims and the figures it asks for;
//!   `experiment.json` there says which);
//! - `DIR/experiment.json`: the file, scale, shard, every comparison with
//!   its configurations and which of them ran here, the claims measured;
//! - `DIR/claims.md`: the claims, the paper's figures and this run's.

pub mod claims;
pub mod runner;
pub mod spec;

use crate::cli::common::check_out;
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand};
use spec::{Experiment, Shard};
use std::path::{Path, PathBuf};
use stereocache::output;

#[derive(Subcommand)]
pub enum ExperimentCommand {
    /// Run an experiment file (experiments/*.toml): one comparison per scene × trace.
    Run(RunArgs),
    /// Combine the outputs of `run --shard K/N` (all N shards) into one.
    Merge(MergeArgs),
}

#[derive(Args)]
pub struct RunArgs {
    /// The experiment file (TOML).
    file: PathBuf,
    /// Output folder (default out/experiments/<name>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// A [scale.NAME] of the file: ci (the default, small) or paper.
    #[arg(long, default_value = "ci")]
    scale: String,
    /// Run only the K-th of N disjoint parts (runs = scene × trace × configuration, taken round robin).
    #[arg(long)]
    shard: Option<Shard>,
    /// Override a [run] key after the scale, e.g. --set frames=60 (repeatable).
    #[arg(long = "set", value_parser = spec::parse_set)]
    set: Vec<(String, toml::Value)>,
    /// Read and check the file, print the runs, render nothing.
    #[arg(long)]
    check: bool,
}

#[derive(Args)]
pub struct MergeArgs {
    /// Output folders of `experiment run --shard K/N` of one experiment.
    #[arg(required = true)]
    dirs: Vec<PathBuf>,
    #[arg(long)]
    out: PathBuf,
}

pub fn run(c: ExperimentCommand) -> Result<()> {
    match c {
        ExperimentCommand::Run(a) => run_file(a),
        ExperimentCommand::Merge(a) => merge(a),
    }
}

fn run_file(a: RunArgs) -> Result<()> {
    let e = spec::read(&a.file, &a.scale, &a.set).map_err(|m| anyhow!(m))?;
    let runs = spec::runs(&e);
    let mine: Vec<(usize, usize)> = runs
        .iter()
        .enumerate()
        .filter(|(i, _)| a.shard.is_none_or(|s| i % s.n == s.k - 1))
        .map(|(_, r)| *r)
        .collect();
    println!(
        "experiment {} ({}): {} — scale {}, {} comparison(s), {} run(s){}",
        e.name,
        a.file.display(),
        e.title,
        e.scale,
        e.groups.len(),
        runs.len(),
        match a.shard {
            Some(s) => format!(", shard {}/{}: {} run(s)", s.k, s.n, mine.len()),
            None => String::new(),
        }
    );
    for m in &e.missing {
        println!("not yet available (the file runs without it): {m}");
    }
    // Every scene this run renders is loaded (parsed, its material graphs
    // bound) before the first comparison: a broken second scene failed
    // only after the first comparison had rendered; `--check` loads them
    // too (it said OK to a file naming a scene that does not exist).
    let mut loaded = std::collections::BTreeSet::new();
    for (g, _) in &mine {
        let scene = &e.groups[*g].args.scene.scene;
        if loaded.insert(scene.clone()) {
            stereocache::scene::load_scene(scene).map_err(|err| {
                anyhow!(
                    "{}: {}: key 'scenes': {err}",
                    a.file.display(),
                    e.scenes_from
                )
            })?;
        }
    }
    if a.check {
        for (g, c) in &mine {
            let grp = &e.groups[*g];
            println!("  {} / {}", grp.label, grp.configs[*c].label);
        }
        return Ok(());
    }
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/experiments").join(&e.name));
    check_out(&out)?;
    remove_stale_claims(&out, e.groups.iter().map(|g| g.label.as_str()))?;
    let mut ran: Vec<Vec<String>> = vec![Vec::new(); e.groups.len()];
    for (g, grp) in e.groups.iter().enumerate() {
        let configs: Vec<_> = mine
            .iter()
            .filter(|(gg, _)| *gg == g)
            .map(|(_, c)| grp.configs[*c].clone())
            .collect();
        if configs.is_empty() {
            continue;
        }
        println!("== {} ({} configuration(s))", grp.label, configs.len());
        // A shard without the baseline gives ratios to its first configuration; the merge recomputes them.
        let baseline = grp
            .args
            .baseline
            .as_deref()
            .filter(|b| configs.iter().any(|c| c.label == *b));
        runner::run_comparison(&grp.args, &configs, &out.join(&grp.label), baseline)?;
        ran[g] = configs.iter().map(|c| c.label.clone()).collect();
    }
    finish(&e.name, &plan(&e, a.shard, &ran), &out)
}

/// experiment.json before the claims: what the file asked for and what ran here.
fn plan(e: &Experiment, shard: Option<Shard>, ran: &[Vec<String>]) -> serde_json::Value {
    serde_json::json!({
        "name": e.name,
        "title": e.title,
        "paper": e.paper,
        "file": e.path,
        "scale": e.scale,
        "shard": shard,
        "figures": e.figures,
        "missing": e.missing,
        "claim_specs": e.claims,
        "groups": e.groups.iter().zip(ran).map(|(g, r)| serde_json::json!({
            "label": g.label,
            "scene": g.scene,
            "trace": g.trace,
            "baseline": g.args.baseline,
            "configs": g.configs.iter().map(|c| c.label.clone()).collect::<Vec<_>>(),
            "ran": r,
        })).collect::<Vec<_>>(),
    })
}

/// Measures the claims, writes DIR/experiment.json, DIR/claims.md and each
/// comparison's experiment.json, and redraws the comparisons' reports with them.
fn finish(name: &str, plan: &serde_json::Value, out: &Path) -> Result<()> {
    let specs: Vec<claims::ClaimSpec> = serde_json::from_value(plan["claim_specs"].clone())?;
    let groups: Vec<String> = plan["groups"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|g| g["ran"].as_array().is_some_and(|r| !r.is_empty()))
        .filter_map(|g| g["label"].as_str().map(str::to_string))
        .collect();
    let results = claims::evaluate(&specs, &groups, out);
    let mut doc = plan.clone();
    doc["claims"] = serde_json::to_value(&results)?;
    output::write_json(&out.join("experiment.json"), &doc)?;
    // A shard's claims see only its own configurations: the title says so.
    let shard = match (plan["shard"]["k"].as_u64(), plan["shard"]["n"].as_u64()) {
        (Some(k), Some(n)) => {
            format!(" — shard {k}/{n} only: claims between configurations of other shards are not measured; merge the shards for the whole run")
        }
        _ => String::new(),
    };
    let title = format!(
        "{name}: {} ({}){shard}",
        plan["title"].as_str().unwrap_or(""),
        plan["paper"].as_str().unwrap_or("")
    );
    output::write_text(&out.join("claims.md"), &claims::markdown(&title, &results))?;
    for g in &groups {
        let mine: Vec<&claims::ClaimResult> = results
            .iter()
            .filter(|r| r.groups.is_empty() || r.groups.iter().any(|m| &m.group == g))
            .collect();
        let gdoc = serde_json::json!({
            "name": name,
            "title": plan["title"],
            "paper": plan["paper"],
            "scale": plan["scale"],
            "figures": plan["figures"],
            "missing": plan["missing"],
            "claims": mine,
        });
        let dir = out.join(g);
        output::write_json(&dir.join("experiment.json"), &gdoc)?;
        stereocache::report::write_report(&dir)?;
    }
    print!("{}", claims::text(&results));
    println!(
        "wrote {} (experiment.json, claims.md, one folder per comparison with its report.html)",
        out.display()
    );
    // A claim's metric its configuration lacks is a mistyped name or a
    // figure this run did not produce (no reference, no timestamps): not
    // silent, but not a failure either.
    for r in results
        .iter()
        .filter(|r| r.verdict == claims::NO_SUCH_FIGURE)
    {
        eprintln!("warning: claim '{}': {}", r.spec.text, r.here);
    }
    Ok(())
}

fn read_plan(dir: &Path) -> Result<serde_json::Value> {
    let p = dir.join("experiment.json");
    let text = stereocache::input::read_to_string(&p).with_context(|| {
        format!(
            "{}: cannot read; is this an `experiment run` output folder?",
            p.display()
        )
    })?;
    serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", p.display()))
}

/// `path` made absolute with symlinks resolved as far as it exists (the
/// rest, not created yet, appended as given).
fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut head = abs.as_path();
    let mut tail = Vec::new();
    loop {
        if let Ok(c) = head.canonicalize() {
            return tail.iter().rev().fold(c, |p, t| p.join(t));
        }
        match (head.parent(), head.file_name()) {
            (Some(parent), Some(name)) => {
                tail.push(name.to_owned());
                head = parent;
            }
            _ => return abs,
        }
    }
}

/// Refuses a merge `--out` that is one of the input folders, lies inside
/// one, or contains one: writing it truncated the input's files (its
/// images were left 0 bytes) before they were read. Checked before
/// anything is written.
fn check_out_apart(out: &Path, dirs: &[PathBuf]) -> Result<()> {
    let o = resolved(out);
    for d in dirs {
        let r = resolved(d);
        let how = if o == r {
            "is"
        } else if o.starts_with(&r) {
            "lies inside"
        } else if r.starts_with(&o) {
            "contains"
        } else {
            continue;
        };
        bail!(
            "bad --out {}: it {how} the input folder {}; merge into a new folder",
            out.display(),
            d.display()
        );
    }
    Ok(())
}

/// Removes a previous run's (or merge's) claims and plans from `out` and
/// its comparisons `groups` before this one writes: each comparison's report
/// reads its experiment.json while this run renders, and a run or merge
/// that fails part way must not leave the old claims looking like its own
/// (until session 50 a merge removed none of them).
fn remove_stale_claims<'a>(out: &Path, groups: impl Iterator<Item = &'a str>) -> Result<()> {
    let mut stale = vec![out.join("experiment.json"), out.join("claims.md")];
    stale.extend(groups.map(|g| out.join(g).join("experiment.json")));
    for p in &stale {
        output::remove_stale(p).map_err(|err| anyhow!("{}: {err}", p.display()))?;
    }
    Ok(())
}

fn merge(a: MergeArgs) -> Result<()> {
    let plans: Vec<serde_json::Value> =
        a.dirs.iter().map(|d| read_plan(d)).collect::<Result<_>>()?;
    let first = &plans[0];
    for (d, p) in a.dirs.iter().zip(&plans) {
        for k in ["name", "scale", "figures", "claim_specs"] {
            if p[k] != first[k] {
                bail!(
                    "{}: '{k}' differs from {}'s: not shards of one experiment run",
                    d.join("experiment.json").display(),
                    a.dirs[0].display()
                );
            }
        }
        let configs = |p: &serde_json::Value| -> Vec<serde_json::Value> {
            p["groups"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|g| serde_json::json!([g["label"], g["configs"]]))
                .collect()
        };
        if configs(p) != configs(first) {
            bail!(
                "{}: its comparisons differ from {}'s: not shards of one experiment run",
                d.join("experiment.json").display(),
                a.dirs[0].display()
            );
        }
    }
    check_out_apart(&a.out, &a.dirs)?;
    check_out(&a.out)?;
    let group_labels = first["groups"].as_array().into_iter().flatten();
    remove_stale_claims(&a.out, group_labels.filter_map(|g| g["label"].as_str()))?;
    let name = first["name"].as_str().unwrap_or("experiment").to_string();
    let mut merged = first.clone();
    merged["shard"] = serde_json::Value::Null;
    merged["merged_from"] = serde_json::json!(a.dirs);
    let mut groups = Vec::new();
    for (gi, g) in first["groups"].as_array().into_iter().flatten().enumerate() {
        let label = g["label"].as_str().unwrap_or("").to_string();
        let labels: Vec<String> = serde_json::from_value(g["configs"].clone())?;
        let mut parts = Vec::new();
        let mut ran = Vec::new();
        for (d, p) in a.dirs.iter().zip(&plans) {
            let r: Vec<String> =
                serde_json::from_value(p["groups"][gi]["ran"].clone()).unwrap_or_default();
            if !r.is_empty() {
                parts.push(d.join(&label));
                ran.extend(r);
            }
        }
        let missing: Vec<&String> = labels.iter().filter(|l| !ran.contains(l)).collect();
        if !missing.is_empty() {
            bail!(
                "merge: {label}: {} ran in none of the given folders (give every shard's folder)",
                missing
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        println!("== {label} (from {} part(s))", parts.len());
        let cmp = stereocache::merge::merge_comparison(
            &parts,
            &labels,
            g["baseline"].as_str(),
            &a.out.join(&label),
        )?;
        runner::print_tables(&cmp);
        let mut g = g.clone();
        g["ran"] = serde_json::json!(labels);
        groups.push(g);
    }
    merged["groups"] = serde_json::json!(groups);
    finish(&name, &merged, &a.out)
}
