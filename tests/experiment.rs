//! `stereocache experiment run FILE`: an experiment file runs end to end and
//! records the same tables as a direct `compare` of the same settings; two
//! shards merged give the tables of one run; malformed files fail before
//! rendering with one `error:` line naming the file and the key.

mod common;
use common::single_error_line;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_stereocache"));
    c.env("STEREOCACHE_VALIDATE", "1");
    c
}

fn trace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv")
}

fn run(c: &mut Command, what: &str) -> String {
    let o = c.output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{what} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

/// The tiny experiment: the Cornell box along the synthetic head turn, 4
/// frames at 24×18, software backend, 8 spp references; three deterministic
/// configurations (naive, taa, sample-cache with its own --slots), one claim.
fn tiny(refs: &Path) -> String {
    format!(
        r#"name = "tiny"
title = "a tiny experiment"
paper = "none"
figures = ["summary", "ratios", "per-frame"]

[run]
scenes = ["cornell"]
traces = ["{}"]
size = "24x18"
rt = "software"
reference-spp = 8
reference-cache = "{}"
baseline = "naive"

[scale.ci]
frames = 4

[[method]]
method = "naive"

[[method]]
method = "taa"

[[method]]
method = "sample-cache"
slots = 8

[[claim]]
text = "the sample cache has a lower RSE than 1 spp"
paper = "none"
metric = "rse"
of = "sample-cache"
over = "naive"
expect = "< 1"
"#,
        trace().display(),
        refs.display()
    )
}

/// What a summary.json records that does not depend on timing: per row its
/// label, method, frames, rays, memory, metrics with standard errors and
/// ratios to the baseline; the reference, baseline, FLIP and masks.
fn tables(dir: &Path) -> serde_json::Value {
    let p = dir.join("summary.json");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
    )
    .unwrap();
    let rows: Vec<serde_json::Value> = s["methods"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let mut r = r.clone();
            let o = r.as_object_mut().unwrap();
            for k in [
                "mean_gpu_ms",
                "p95_gpu_ms",
                "steady_mean_gpu_ms",
                "steady_p95_gpu_ms",
                "pass_mean_ms",
            ] {
                assert!(o.remove(k).is_some(), "row without {k}");
            }
            r
        })
        .collect();
    serde_json::json!({
        "rows": rows,
        "reference": s["reference"],
        "baseline": s["baseline"],
        "flip": s["flip"],
        "masks": s["masks"],
        "scene": s["scene"],
        "size": [s["width"], s["height"]],
    })
}

fn labels(dir: &Path) -> Vec<String> {
    tables(dir)["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["method"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn an_experiment_equals_compare_and_two_merged_shards_equal_one_run() {
    let root = std::env::temp_dir().join(format!("stereocache-experiment-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let file = root.join("tiny.toml");
    std::fs::write(&file, tiny(&root.join("refs"))).unwrap();
    let exp = |out: &Path, extra: &[&str]| {
        let mut c = bin();
        c.args(["experiment", "run", file.to_str().unwrap(), "--out"])
            .arg(out)
            .args(extra);
        run(&mut c, &format!("experiment run {extra:?}"))
    };
    let one = root.join("one");
    let printed = exp(&one, &[]);
    let group = "cornell-synth-head-turn";
    // End to end: the comparison's files, its report with the claim, claims.md.
    for f in [
        "summary.json",
        "summary.csv",
        "report.html",
        "experiment.json",
        "naive/frames.jsonl",
        "sample-cache/frames.jsonl",
        "viewer/index.json",
    ] {
        assert!(one.join(group).join(f).exists(), "{group}/{f} missing");
    }
    let report = std::fs::read_to_string(one.join(group).join("report.html")).unwrap();
    assert!(
        report.contains("id=\"claims\""),
        "the report shows the claims"
    );
    assert!(
        !report.contains("<h2 id=\"viewer\">"),
        "figures = [..] without the viewer: not drawn"
    );
    let claims = std::fs::read_to_string(one.join("claims.md")).unwrap();
    assert!(
        claims.contains("rse sample-cache / naive = "),
        "claims.md: {claims}"
    );
    assert!(printed.contains("claim: the sample cache"), "{printed}");
    let frames = std::fs::read_to_string(one.join(group).join("naive/frames.jsonl")).unwrap();
    assert_eq!(frames.lines().count(), 4, "[scale.ci] frames = 4");

    // The same settings as a direct compare: the same tables.
    let direct = root.join("direct");
    let mut c = bin();
    c.args(["compare", "--scene", "cornell", "--trace"])
        .arg(trace())
        .args([
            "--size",
            "24x18",
            "--rt",
            "software",
            "--reference-spp",
            "8",
            "--reference-cache",
        ])
        .arg(root.join("refs"))
        .args([
            "--baseline",
            "naive",
            "--frames",
            "4",
            "--methods",
            "naive,taa,sample-cache",
            "--slots",
            "8",
            "--out",
        ])
        .arg(&direct);
    run(&mut c, "compare");
    assert_eq!(tables(&one.join(group)), tables(&direct));

    // Two shards: disjoint, together every configuration; merged = one run.
    let (s1, s2, merged) = (root.join("s1"), root.join("s2"), root.join("merged"));
    exp(&s1, &["--shard", "1/2"]);
    exp(&s2, &["--shard", "2/2"]);
    assert_eq!(labels(&s1.join(group)), ["naive", "sample-cache"]);
    assert_eq!(labels(&s2.join(group)), ["taa"]);
    // An earlier merge's files in the output: a merge removes them (until
    // session 50 it only added, so an earlier merge's grids stayed in the
    // report and a configuration's folder kept files its part lacks), and
    // only them: a user's own file there stays (until session 52 the
    // configuration's folder went whole).
    let stale = [
        merged
            .join(group)
            .join("side-by-side/frame_09999.part7.png"),
        merged.join(group).join("naive/frames/09999_left.png"),
    ];
    let mine = merged.join(group).join("naive/notes.txt");
    for f in stale.iter().chain([&mine]) {
        std::fs::create_dir_all(f.parent().unwrap()).unwrap();
        std::fs::write(f, "old").unwrap();
    }
    let mut c = bin();
    c.args(["experiment", "merge"])
        .arg(&s1)
        .arg(&s2)
        .arg("--out")
        .arg(&merged);
    let printed = run(&mut c, "experiment merge");
    for f in &stale {
        assert!(!f.exists(), "{} kept by the merge", f.display());
    }
    assert!(mine.exists(), "{} removed by the merge", mine.display());
    assert_eq!(tables(&merged.join(group)), tables(&one.join(group)));
    assert!(merged.join(group).join("report.html").exists());
    assert!(merged.join(group).join("taa/frames.jsonl").exists());
    let index: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(merged.join(group).join("viewer/index.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        index["frames"][0]["labels"],
        serde_json::json!(["naive", "taa", "sample-cache"]),
        "the merged viewer lists every configuration"
    );
    assert_eq!(
        std::fs::read_to_string(merged.join("claims.md")).unwrap(),
        claims,
        "the merged claims equal one run's"
    );
    assert!(printed.contains("claim: the sample cache"), "{printed}");

    // A part from another device, or with another frame count, is not a
    // part of this comparison (timing ratios across machines, or means
    // over other frames, would pass as one run's): one error line naming
    // the part's summary.json, nothing merged.
    for (what, edit) in [
        (
            "'device' is",
            Box::new(|s: &mut serde_json::Value| s["device"] = "another GPU".into())
                as Box<dyn Fn(&mut serde_json::Value)>,
        ),
        (
            "a row has 3 frames",
            Box::new(|s: &mut serde_json::Value| s["methods"][0]["frames"] = 3.into()),
        ),
        (
            // FLIP scored at another PPD (`--set flip-ppd=…` on one shard).
            "'flip' is",
            Box::new(|s: &mut serde_json::Value| s["flip"]["ppd"] = 67.into()),
        ),
    ] {
        let other = root.join("s2-other");
        let _ = std::fs::remove_dir_all(&other);
        let mut c = std::process::Command::new("cp");
        c.arg("-r").arg(&s2).arg(&other);
        run(&mut c, "cp");
        let p = other.join(group).join("summary.json");
        let mut j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        edit(&mut j);
        std::fs::write(&p, j.to_string()).unwrap();
        let out = root.join("merged-other");
        // An earlier merge's claims there: removed although this one fails.
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join("claims.md"), "old").unwrap();
        let o = bin()
            .args(["experiment", "merge"])
            .arg(&s1)
            .arg(&other)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let line = single_error_line(&o, what);
        assert!(
            line.contains(&p.display().to_string()) && line.contains(what),
            "{line}"
        );
        assert!(
            !out.join(group).join("summary.json").exists(),
            "{what}: merged anyway"
        );
        assert!(!out.join("claims.md").exists(), "{what}: old claims kept");
    }

    // A metric this run does not produce (`ghost_rse`: no moving object;
    // a mistyped name is refused before rendering since session 48, see
    // malformed_files_…): everything is written, the claim says which
    // figures exist, and a warning names it.
    let bogus = root.join("bogus.toml");
    std::fs::write(
        &bogus,
        tiny(&root.join("refs")).replace(r#"metric = "rse""#, r#"metric = "ghost_rse""#),
    )
    .unwrap();
    let out = root.join("bogus");
    let o = bin()
        .args(["experiment", "run"])
        .arg(&bogus)
        .args(["--shard", "1/2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: claim 'the sample cache")
            && stderr
                .contains("metric 'ghost_rse' is not a figure of configuration 'sample-cache'"),
        "{stderr}"
    );
    let claims = std::fs::read_to_string(out.join("claims.md")).unwrap();
    assert!(
        claims.contains("metric 'ghost_rse' is not a figure of configuration 'sample-cache' in this run (its figures: ")
            && claims.contains("rse, ")
            && claims.contains("| no such figure |"),
        "{claims}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn malformed_files_fail_with_one_error_line_naming_the_file_and_key() {
    let root =
        std::env::temp_dir().join(format!("stereocache-experiment-bad-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let good = tiny(&root.join("refs"));
    let cases: Vec<(&str, String, &[&str])> = vec![
        (
            "unknown top-level key",
            good.replace(
                "paper = \"none\"\nfigures",
                "paper = \"none\"\ncolour = 3\nfigures",
            ),
            &["colour"],
        ),
        (
            "bad value",
            good.replace("reference-spp = 8", "spp = 0\nreference-spp = 8"),
            &["'spp'", "--spp"],
        ),
        (
            // A key of [scale.ci] overrides [run] and is named with its
            // own section (it read '[run]: key ...' until session 51).
            "bad key in a scale",
            good.replace("[scale.ci]\nframes = 4", "[scale.ci]\nframez = 4"),
            &["[scale.ci]: key 'framez'"],
        ),
        (
            "odd reference spp",
            good.replace("reference-spp = 8", "reference-spp = 7"),
            &["reference-spp"],
        ),
        (
            // A value option set to false (until session 50 left out
            // silently: the default spp ran); a switch may be false.
            "a value option set to false",
            good.replace(
                "slots = 8",
                "slots = 8
spp = false",
            ),
            &["'spp'", "expected a value, not false"],
        ),
        (
            "unknown method option",
            good.replace("slots = 8", "slot = 8"),
            &["'slot'", "sample-cache"],
        ),
        (
            "bad method option value",
            good.replace("slots = 8", "retrace = \"sometimes\""),
            &["'retrace'", "sometimes"],
        ),
        (
            "unknown method",
            good.replace("method = \"taa\"", "method = \"magic\""),
            &["'method'", "magic"],
        ),
        (
            "missing trace",
            good.replace("synth-head-turn.csv", "no-such-trace.csv"),
            &["traces", "no-such-trace.csv"],
        ),
        (
            "TOML syntax",
            good.replace("size = \"24x18\"", "size = \"24x18"),
            &["tiny.toml:"],
        ),
        (
            "unknown figure",
            good.replace("\"per-frame\"]", "\"pie-chart\"]"),
            &["figures", "pie-chart"],
        ),
        (
            "not in files",
            good.replace("size = \"24x18\"", "size = \"24x18\"\nout = \"x\""),
            &["'out'"],
        ),
        (
            "claim of an unknown configuration",
            good.replace("of = \"sample-cache\"", "of = \"nobody\""),
            &["'of'", "nobody"],
        ),
        (
            // Three runs of one configuration under three labels until
            // session 48: naive reads no method option.
            "a sweep over an option the method does not read",
            good.replace(
                "method = \"naive\"\n",
                "method = \"naive\"\nsweep = { sharpness = [0.0, 0.5] }\n",
            ),
            &["same run", "'naive'"],
        ),
        (
            // Found only after rendering until session 48.
            "claim of an unknown metric",
            good.replace("metric = \"rse\"", "metric = \"rsee\""),
            &["'metric'", "rsee"],
        ),
        (
            "claim over an unknown metric",
            good.replace("over = \"naive\"", "over-metric = \"cpbd_referense\""),
            &["'over-metric'", "cpbd_referense"],
        ),
        (
            // Both would render into one folder (until session 48 the
            // second overwrote the first).
            "two comparisons with one name",
            good.replace(
                "scenes = [\"cornell\"]",
                "scenes = [\"cornell\", \"cornell\"]",
            ),
            &["both named", "'cornell-synth-head-turn'"],
        ),
        (
            // A folder name that would write into out/ itself (until
            // session 49 accepted, removing out/experiment.json first).
            "an experiment named '..'",
            good.replace("name = \"tiny\"", "name = \"..\""),
            &["key 'name'", "'..'"],
        ),
        (
            // Refused before the first comparison renders (until session 48,
            // after the comparisons of earlier traces had).
            "more frames than the trace has",
            good.replace("frames = 4", "frames = 100000"),
            &["'frames'", "100000", "synth-head-turn.csv"],
        ),
    ];
    for (what, text, words) in cases {
        let file = root.join("tiny.toml");
        std::fs::write(&file, &text).unwrap();
        let out = root.join("out");
        let o = bin()
            .args(["experiment", "run", file.to_str().unwrap(), "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let line = single_error_line(&o, what);
        assert!(line.contains("tiny.toml"), "{what}: names the file: {line}");
        for w in words {
            assert!(line.contains(w), "{what}: '{w}' in: {line}");
        }
        assert!(!out.exists(), "{what}: failed before writing anything");
    }
    // A scale the file does not have: `--scale paper --check` on `text`.
    let paper_scale = |name: &str, text: &str| {
        std::fs::write(root.join(name), text).unwrap();
        let o = bin()
            .args(["experiment", "run"])
            .arg(root.join(name))
            .args(["--scale", "paper", "--check"])
            .output()
            .unwrap();
        single_error_line(&o, name)
    };
    let line = paper_scale("tiny.toml", &good);
    assert!(
        line.contains("scale.paper") && line.contains("ci"),
        "{line}"
    );
    // A file without scales says so (it listed "(scales: )").
    let start = good.find("[scale.ci]").unwrap();
    let end = good[start..]
        .find("\n\n")
        .map_or(good.len(), |e| start + e + 1);
    let unscaled = format!("{}{}", &good[..start], &good[end..]);
    assert!(!unscaled.contains("[scale."), "{unscaled}");
    let line = paper_scale("unscaled.toml", &unscaled);
    assert!(line.contains("defines no [scale.*] section"), "{line}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_sweep_gives_one_configuration_per_value_and_shards_deal_them_round_robin() {
    let root = std::env::temp_dir().join(format!(
        "stereocache-experiment-sweep-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let text = tiny(&root.join("refs"))
        .replace(
            "slots = 8",
            "slots = 8\nstereo-blend = \"moments\"\nsweep = { sharpness = [0.0, 0.5, 1.0] }",
        )
        .replace("of = \"sample-cache\"", "of = \"sample-cache-sharpness=0\"");
    let file = root.join("tiny.toml");
    std::fs::write(&file, text).unwrap();
    let listed = |extra: &[&str]| -> Vec<String> {
        let mut c = bin();
        c.args(["experiment", "run"])
            .arg(&file)
            .arg("--check")
            .args(extra);
        run(&mut c, "experiment run --check")
            .lines()
            .filter_map(|l| l.strip_prefix("  cornell-synth-head-turn / "))
            .map(str::to_string)
            .collect()
    };
    let all = [
        "naive",
        "taa",
        "sample-cache-sharpness=0",
        "sample-cache-sharpness=0.5",
        "sample-cache-sharpness=1",
    ];
    assert_eq!(listed(&[]), all);
    assert_eq!(listed(&["--shard", "1/2"]), [all[0], all[2], all[4]]);
    assert_eq!(listed(&["--shard", "2/2"]), [all[1], all[3]]);
    // A bad sweep value is refused with its key; so is a scene that does
    // not load (--check said OK to it until session 47; the run failed at
    // once).
    let refused = |text: String, what: &str| -> String {
        std::fs::write(&file, text).unwrap();
        let o = bin()
            .args(["experiment", "run"])
            .arg(&file)
            .arg("--check")
            .output()
            .unwrap();
        single_error_line(&o, what)
    };
    let base = tiny(&root.join("refs"));
    let line = refused(
        base.replace("slots = 8", "sweep = { sharpness = [0.5, 2.0] }"),
        "sharpness 2",
    );
    assert!(
        line.contains("'sharpness'") && line.contains("--sharpness"),
        "{line}"
    );
    let line = refused(
        base.replace("scenes = [\"cornell\"]", "scenes = [\"nosuchscene\"]"),
        "a missing scene",
    );
    assert!(
        line.contains("key 'scenes'") && line.contains("nosuchscene"),
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&root);
}

/// Every shipped experiment file (experiments/*.toml, all of them, at both
/// scales) reads and checks (`experiment run FILE --check`: the file, every
/// method option through compare's parser, the claims' labels), from the
/// repository root as documented. Files that name Sponza outside the
/// repository (`../shared/scenes/sponza`, present next to the main checkout
/// only) get their scenes set to the shipped Cornell box: everything else in
/// them is still read and checked.
#[test]
fn every_shipped_experiment_file_parses_at_both_scales() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(root.join("experiments"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(
        files.iter().any(|f| f.ends_with("fig19-animation.toml")),
        "{files:?}"
    );
    for f in &files {
        let outside = std::fs::read_to_string(f).unwrap().contains("../shared/");
        for scale in ["ci", "paper"] {
            let out = run(
                bin()
                    .current_dir(root)
                    .args(["experiment", "run"])
                    .arg(f)
                    .args(["--scale", scale, "--check"])
                    .args(match outside {
                        true => &["--set", "scenes=[\"cornell\"]"][..],
                        false => &[][..],
                    }),
                &format!("{} --scale {scale} --check", f.display()),
            );
            assert!(out.contains("run(s)"), "{}: {out}", f.display());
        }
    }
}

/// `bench tradeoff` is a thin front-end over the same runner: its 22
/// configurations come out in the sweep's order, tradeoff.csv is the run's
/// summary.csv, and the configurations that are also plain methods
/// (deterministic ones: naive, taa, isrt) record exactly the tables a direct
/// `compare` of the same settings records (timings aside).
#[test]
fn bench_tradeoff_records_through_the_compare_runner() {
    let root = std::env::temp_dir().join(format!("stereocache-tradeoff-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let refs = root.join("refs");
    let common = |c: &mut Command| {
        c.args(["--scene", "cornell", "--rt", "software", "--frames", "2"])
            .args(["--size", "16x12", "--reference-spp", "4"])
            .arg("--trace")
            .arg(trace())
            .arg("--reference-cache")
            .arg(&refs);
    };
    let t = root.join("tradeoff");
    let mut c = bin();
    c.args(["bench", "tradeoff"]).arg("--out").arg(&t);
    common(&mut c);
    let stdout = run(&mut c, "bench tradeoff");
    assert!(stdout.contains("sc-N12 / naive:"), "{stdout}");
    let d = root.join("compare");
    // An earlier run's files in the output folder: a plain compare removes
    // them (until session 50 an experiment's experiment.json stayed, and
    // the new report showed its title and claim verdicts).
    std::fs::create_dir_all(d.join("viewer")).unwrap();
    for f in ["experiment.json", "report.html", "viewer/index.json"] {
        std::fs::write(d.join(f), "{}").unwrap();
    }
    let mut c = bin();
    c.args(["compare", "--methods", "naive,taa,isrt", "--every", "0"])
        .arg("--out")
        .arg(&d);
    common(&mut c);
    run(&mut c, "compare");
    assert!(
        !d.join("experiment.json").exists(),
        "stale experiment.json kept"
    );
    assert_ne!(
        std::fs::read(d.join("report.html")).unwrap(),
        b"{}",
        "stale report.html kept"
    );

    let expected: Vec<&str> = vec![
        "sc-N4",
        "sc-N8",
        "sc-N12",
        "sc-N16",
        "sc-ntarget2",
        "sc-ntarget6",
        "sc-retrace-single",
        "sc-retrace-multi",
        "sc-adaptive-shading0.25",
        "sc-adaptive-shading0.5",
        "sc-adaptive-shading1",
        "sc-two-pass",
        "hash-2e16-dist",
        "hash-2e20-dist",
        "hash-2e20-distnormal",
        "hybrid",
        "taa",
        "isrt",
        "naive",
        "supersample-2spp",
        "supersample-4spp",
        "supersample-8spp",
    ];
    assert_eq!(labels(&t), expected, "tradeoff configurations");
    assert_eq!(
        std::fs::read(t.join("tradeoff.csv")).unwrap(),
        std::fs::read(t.join("summary.csv")).unwrap(),
        "tradeoff.csv is the run's summary.csv"
    );
    assert!(t.join("report.html").is_file());
    // Each configuration's summary.json records its own settings (until
    // session 50 the run's shared ones: supersample-4spp said spp 1).
    let spp = |label: &str| {
        let p = t.join(label).join("summary.json");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        v["settings"]["spp"].as_u64()
    };
    assert_eq!(spp("supersample-4spp"), Some(4));
    assert_eq!(spp("supersample-8spp"), Some(8));
    assert_eq!(spp("naive"), Some(1));

    let (mut tt, mut tc) = (tables(&t), tables(&d));
    // The reference's own estimate is the same; what it is set against (the
    // best configuration of the run) differs with the configurations run.
    for v in [&mut tt, &mut tc] {
        let r = v["reference"].as_object_mut().unwrap();
        for k in [
            "best_method",
            "best_method_rse",
            "ratio_to_best",
            "suggested_spp",
            "warning",
        ] {
            r.remove(k);
        }
    }
    for k in ["reference", "baseline", "flip", "masks", "scene", "size"] {
        assert_eq!(tt[k], tc[k], "{k}");
    }
    let row = |v: &serde_json::Value, label: &str| {
        v["rows"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["method"] == label)
            .unwrap_or_else(|| panic!("no row {label}"))
            .clone()
    };
    for label in ["naive", "taa", "isrt"] {
        assert_eq!(row(&tt, label), row(&tc, label), "row {label}");
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// `experiment merge DIR --out DIR` truncated the input's files (its viewer
/// images were left 0 bytes) before reading them: an `--out` that is an
/// input folder, lies inside one or contains one is now refused before
/// anything is written.
#[test]
fn merge_refuses_an_out_folder_overlapping_an_input() {
    let root = std::env::temp_dir().join(format!(
        "stereocache-experiment-merge-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&root);
    let shard = root.join("shard");
    std::fs::create_dir_all(shard.join("g")).unwrap();
    let plan = r#"{"name":"x","scale":"ci","figures":[],"claim_specs":[],"groups":[]}"#;
    std::fs::write(shard.join("experiment.json"), plan).unwrap();
    std::fs::write(shard.join("g").join("keep.png"), b"not empty").unwrap();
    // Through a symlink too: the folders are compared resolved.
    std::os::unix::fs::symlink(&shard, root.join("link")).unwrap();
    for (out, how) in [
        (shard.clone(), "is the input folder"),
        (root.join("link"), "is the input folder"),
        (shard.join("merged"), "lies inside the input folder"),
        (root.clone(), "contains the input folder"),
    ] {
        let o = bin()
            .args(["experiment", "merge"])
            .arg(&shard)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let line = single_error_line(&o, &format!("--out {}", out.display()));
        assert!(line.contains("bad --out") && line.contains(how), "{line}");
        assert_eq!(
            std::fs::read(shard.join("g").join("keep.png")).unwrap(),
            b"not empty"
        );
        assert!(!shard.join("merged").exists());
        assert_eq!(
            std::fs::read_to_string(shard.join("experiment.json")).unwrap(),
            plan
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}

/// Problems the fuzzing session found only once rendering had started (or
/// never): a broken second scene failed after the whole first comparison
/// rendered, naming neither the experiment file nor the key; labels "" and
/// "../../x" and --show-frames past the run's last frame failed after the
/// device opened, without the file; `expect = "< nan"` was accepted (a NaN
/// threshold makes every verdict false). Each is now one error line naming
/// the file and the key, before anything renders.
#[test]
fn experiment_values_are_checked_before_the_first_comparison() {
    let root = std::env::temp_dir().join(format!(
        "stereocache-experiment-early-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let broken = root.join("broken.gltf");
    std::fs::write(
        &broken,
        r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":["#,
    )
    .unwrap();
    let good = tiny(&root.join("refs"));
    let cases: Vec<(&str, String, &[&str])> = vec![
        (
            "second scene broken",
            good.replace(
                "scenes = [\"cornell\"]",
                &format!("scenes = [\"cornell\", \"{}\"]", broken.display()),
            ),
            &["[run]: key 'scenes': ", "broken.gltf: invalid JSON"],
        ),
        (
            "empty label",
            good.replace("method = \"taa\"", "method = \"taa\"\nlabel = \"\""),
            &["key 'label'", "configuration label ''"],
        ),
        (
            "label escaping the folder",
            good.replace("method = \"taa\"", "method = \"taa\"\nlabel = \"../../x\""),
            &["key 'label'", "'../../x'"],
        ),
        (
            "label ..",
            good.replace("method = \"taa\"", "method = \"taa\"\nlabel = \"..\""),
            &["key 'label'", "'..'"],
        ),
        (
            "show-frames past the end",
            good.replace(
                "size = \"24x18\"",
                "size = \"24x18\"\nshow-frames = \"0,99\"",
            ),
            &[
                "[run]: key 'show-frames'",
                "frame 99 is past the last frame 3",
            ],
        ),
        (
            "NaN expectation",
            good.replace("expect = \"< 1\"", "expect = \"< nan\""),
            &["key 'expect'", "'< nan'"],
        ),
    ];
    for (what, text, words) in cases {
        assert_ne!(text, good, "{what}: the case changed nothing");
        let file = root.join("tiny.toml");
        std::fs::write(&file, &text).unwrap();
        let out = root.join("out");
        let o = bin()
            .args(["experiment", "run", file.to_str().unwrap(), "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let line = single_error_line(&o, what);
        assert!(
            line.starts_with(&format!("error: {}: ", file.display())),
            "{what}: names the file first: {line}"
        );
        for w in words {
            assert!(line.contains(w), "{what}: '{w}' in: {line}");
        }
        assert!(!out.exists(), "{what}: failed before writing anything");
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            !stdout.contains("== "),
            "{what}: a comparison started:\n{stdout}"
        );
    }
    let _ = std::fs::remove_dir_all(&root);
}
