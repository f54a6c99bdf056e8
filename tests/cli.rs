//! The command line refuses bad input with one clear error line naming the
//! file or value and the problem, a non-zero exit, no panic, and no output
//! files left behind.

mod common;
use common::{bad_scene as data, cli, single_error_line};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The binary under `timeout` (see `common::cli`).
fn bin() -> Command {
    cli(300)
}

fn out_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("stereocache-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs `c` and expects success: returns its standard output.
fn succeeds(c: &mut std::process::Command) -> String {
    succeeded(&c.output().unwrap())
}

/// The standard output of a run that must have succeeded (else both streams).
fn succeeded(o: &std::process::Output) -> String {
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

/// Runs and expects failure: returns the single error line.
fn fails(args: &[&str]) -> String {
    fails_with(args, &[])
}

/// `fails` with extra environment variables.
fn fails_with(args: &[&str], env: &[(&str, &str)]) -> String {
    let o = bin().args(args).envs(env.iter().copied()).output().unwrap();
    single_error_line(&o, &format!("{args:?}"))
}

#[test]
fn malformed_scenes_give_one_error_line_naming_the_file() {
    for (file, phrase) in [
        ("truncated_json.gltf", "JSON"),
        ("wrong_types.gltf", "glTF"),
        ("missing_bin.gltf", "missing_buffer.bin"),
        ("short_buffer.gltf", "shorter"),
        ("accessor_out_of_range.gltf", "ndex"),
        ("index_out_of_range.gltf", "out of range"),
        ("huge_count.gltf", ""),
        ("cyclic_nodes.gltf", "cycle"),
        ("no_triangles.gltf", "no triangles"),
        ("draco_required.gltf", "KHR_draco_mesh_compression"),
        ("truncated.glb", "GLB"),
    ] {
        let out = out_dir("bad");
        let path = data(file);
        let line = fails(&[
            "render",
            "--scene",
            path.to_str().unwrap(),
            "--size",
            "8x8",
            "--spp",
            "1",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(
            line.contains(file),
            "{file}: error does not name the file: {line}"
        );
        assert!(
            line.contains(phrase),
            "{file}: error lacks '{phrase}': {line}"
        );
        assert!(
            !out.join("left.exr").exists() && !out.join("stats.json").exists(),
            "{file}: output left behind"
        );
    }
}

#[test]
fn recoverable_scene_problems_are_warnings() {
    for file in ["nan_vertices.gltf", "undecodable_image.gltf"] {
        let out = out_dir(file);
        let o = bin()
            .args([
                "render",
                "--scene",
                data(file).to_str().unwrap(),
                "--size",
                "8x8",
                "--spp",
                "1",
                "--pose",
                "0,0,3,0,0,0,1",
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{file}: {stderr}");
        assert!(
            stderr.contains("warning"),
            "{file}: no warning printed: {stderr}"
        );
        for f in [
            "left.exr",
            "left.png",
            "right.exr",
            "right.png",
            "stats.json",
            "left_firsthit.bin",
        ] {
            assert!(out.join(f).exists(), "{file}: {f} missing");
        }
        assert!(!std::fs::read_dir(&out).unwrap().any(|e| e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".partial")));
        let _ = std::fs::remove_dir_all(&out);
    }
}

#[test]
fn bad_command_line_values_are_refused() {
    let out = out_dir("args");
    let o = out.to_str().unwrap();
    for (args, phrase) in [
        (vec!["render", "--size", "0x10", "--out", o], "bad --size"),
        (vec!["render", "--size", "abc", "--out", o], "bad --size"),
        (vec!["render", "--size", "64x", "--out", o], "bad --size"),
        (
            vec!["render", "--size", "99999x10", "--out", o],
            "bad --size",
        ),
        (
            vec!["render", "--camera", "nope", "--size", "8x8", "--out", o],
            "no camera named 'nope'",
        ),
        (
            vec!["render", "--pose", "1,2,3", "--size", "8x8", "--out", o],
            "bad --pose",
        ),
        (
            vec![
                "render",
                "--pose",
                "0,0,0,0,0,0,0",
                "--size",
                "8x8",
                "--out",
                o,
            ],
            "zero length",
        ),
        (
            vec!["render", "--rt", "magic", "--size", "8x8", "--out", o],
            "bad --rt",
        ),
        (
            vec!["render", "--method", "nope", "--size", "8x8", "--out", o],
            "unknown method",
        ),
        (
            vec![
                "render",
                "--scene",
                "/nonexistent/scene.gltf",
                "--size",
                "8x8",
                "--out",
                o,
            ],
            "scene.gltf",
        ),
        (
            vec![
                "render",
                "--lighting",
                "purple",
                "--size",
                "8x8",
                "--out",
                o,
            ],
            "bad --lighting",
        ),
        (
            vec!["render", "--spp", "0", "--size", "8x8", "--out", o],
            "bad --spp",
        ),
        (
            vec!["trace", "synth", "--kind", "dance", "--out", o],
            "bad --kind",
        ),
    ] {
        let line = fails(&args);
        assert!(line.contains(phrase), "{args:?}: '{line}' lacks '{phrase}'");
    }
    assert!(!out.join("left.exr").exists());
}

#[test]
fn render_writes_every_promised_file() {
    let out = out_dir("ok");
    let o = bin()
        .args([
            "render",
            "--size",
            "16x12",
            "--spp",
            "2",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "left.exr",
        "right.exr",
        "left.png",
        "right.png",
        "left_depth.exr",
        "left_albedo.exr",
        "left_firsthit.bin",
        "stats.json",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    assert!(stats["gpu_ms"].as_f64().unwrap() > 0.0);
    // Two jittered first hits per pixel and eye (--spp 2); the pixel-centre
    // rays that fill the depth / first-hit outputs are not primary rays of
    // the method (their pass is diagnostic for a path tracer without TAA).
    assert_eq!(stats["rays"]["primary"].as_u64().unwrap(), 16 * 12 * 2 * 2);
    assert!(stats["passes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|p| p["name"] == "diag.reference.primary"));
    assert!(stats["passes"]
        .as_array()
        .unwrap()
        .iter()
        .any(|p| p["name"] == "reference.trace"));
    assert_eq!(
        std::fs::metadata(out.join("left_firsthit.bin"))
            .unwrap()
            .len(),
        16 * 12 * 16
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// Impossible sizes end at once with one clear line: the sample cache's
/// documented size limit (2^26 pixels per eye), or the first buffer the
/// device cannot take, named — never a hang, a panic or a half-written
/// output. At these sizes that buffer is over `maxStorageBufferRange` (on
/// lavapipe and on any device, whose limit is below 2^32 bytes), which is
/// refused before allocation and so before the out-of-memory error these
/// cases reported until the range was checked; the out-of-memory error is
/// pinned in tests/storage_range.rs.
#[test]
fn impossible_sizes_fail_cleanly() {
    let out = out_dir("oom");
    let o = out.to_str().unwrap();
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    let t = trace.to_str().unwrap();
    let replay = |size: &'static str| {
        vec![
            "replay",
            "--scene",
            "cornell",
            "--trace",
            t,
            "--frames",
            "1",
            "--size",
            size,
            "--method",
            "sample-cache",
            "--slots",
            "16",
            "--out",
            o,
        ]
    };
    for (args, phrase) in [
        (replay("16384x16384"), "at most 2^26 pixels per eye"),
        (replay("8192x8192"), "storage buffer sample_cache."),
        (
            vec![
                "render",
                "--scene",
                "cornell",
                "--size",
                "16384x16384",
                "--spp",
                "1",
                "--out",
                o,
            ],
            "storage buffer reference.",
        ),
    ] {
        let line = fails(&args);
        assert!(line.contains(phrase), "{args:?}: {line}");
        assert!(!out.join("left.exr").exists() && !out.join("summary.json").exists());
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A lost device (fault injected where the driver would report
/// VK_ERROR_DEVICE_LOST) and a hung one (a watchdog far shorter than the
/// frame) end with one error line, a non-zero exit and no complete-looking
/// output; a malformed setting of either variable is refused by name.
#[test]
fn lost_and_hung_devices_fail_cleanly() {
    let out = out_dir("lost");
    let o = out.to_str().unwrap();
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    let t = trace.to_str().unwrap();
    let replay = [
        "replay",
        "--scene",
        "cornell",
        "--trace",
        t,
        "--frames",
        "6",
        "--size",
        "32x24",
        "--method",
        "sample-cache",
        "--every",
        "1",
        "--out",
        o,
    ];
    let line = fails_with(&replay, &[("STEREOCACHE_FAULT_DEVICE_LOST_AFTER", "4")]);
    assert!(line.contains("GPU device was lost"), "{line}");
    assert!(
        !out.join("summary.json").exists() && !out.join("frames.jsonl").exists(),
        "a lost device left complete-looking output"
    );
    let _ = std::fs::remove_dir_all(&out);

    let render = [
        "render", "--scene", "hairball", "--size", "256x192", "--spp", "64", "--out", o,
    ];
    let line = fails_with(&render, &[("STEREOCACHE_GPU_TIMEOUT_S", "0.000001")]);
    assert!(line.contains("did not finish"), "{line}");
    assert!(!out.join("left.exr").exists() && !out.join("stats.json").exists());

    for (var, value) in [
        ("STEREOCACHE_GPU_TIMEOUT_S", "soon"),
        ("STEREOCACHE_GPU_TIMEOUT_S", "-1"),
        ("STEREOCACHE_FAULT_DEVICE_LOST_AFTER", "x"),
    ] {
        let line = fails_with(&["info"], &[(var, value)]);
        assert!(line.contains(var), "{var}={value}: {line}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// `bench specialization`: bad values are one error line before the GPU
/// opens; a tiny run prints the device first and writes the CSV it promises
/// (figures are not checked: timings belong in benchmarks, not tests).
#[test]
fn bench_specialization_checks_input_and_writes_csv() {
    for (args, phrase) in [
        (vec!["--frames", "0"], "bad --frames"),
        (vec!["--methods", "naive,nope"], "unknown method 'nope'"),
        (vec!["--bounces", "3,x"], "bad --bounces"),
        (vec!["--size", "0x8"], "bad --size"),
        (vec!["--rt", "magic"], "bad --rt"),
        (vec!["--scenes", "/nonexistent/s.gltf"], "s.gltf"),
    ] {
        let mut a = vec!["bench", "specialization"];
        a.extend(args.iter().copied());
        let line = fails(&a);
        assert!(line.contains(phrase), "{a:?}: '{line}' lacks '{phrase}'");
    }
    let out = out_dir("bench-spec");
    let csv = out.join("spec.csv");
    // Eight pipeline builds of the trace shader: with a cold Mesa shader
    // cache on a loaded 2-core machine they took over 300 s (a fresh
    // machine's first suite run), so this run gets a longer limit.
    let o = cli(1200)
        .args([
            "bench",
            "specialization",
            "--scenes",
            "plane",
            "--methods",
            "naive",
            "--bounces",
            "0",
            "--frames",
            "1",
            "--size",
            "8x6",
            "--out",
            csv.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stdout = succeeded(&o);
    assert!(stdout.starts_with("device: "), "{stdout}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("scene,method,bounces,build,passes,frame_ms,ratio,ratio_se,against")
    );
    let builds: Vec<&str> = lines.map(|l| l.split(',').nth(3).unwrap()).collect();
    // Bounces 0 is also the largest count: the plane lacks normal maps, so that
    // single-feature build is among them.
    for b in [
        "all features",
        "specialized",
        "specialized + skip",
        "specialized + normal_maps",
    ] {
        assert!(builds.contains(&b), "{b} missing from {builds:?}");
    }
}

/// Impossible numbers are refused while the command line is parsed, before
/// the GPU is opened: `--device` names no device here, so a command that got
/// as far as opening one would fail with the device error instead. One
/// `error:` line naming the flag, no output directory.
#[test]
fn out_of_range_values_are_refused_before_the_device_opens() {
    let out = out_dir("ranges");
    let o = out.to_str().unwrap();
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    let t = trace.to_str().unwrap();
    let replay = |flag: &'static str, value: &'static str| {
        vec![
            "replay",
            "--device",
            "no-such-gpu",
            "--trace",
            t,
            "--out",
            o,
            flag,
            value,
        ]
    };
    let render = |flag: &'static str, value: &'static str| {
        vec!["render", "--device", "no-such-gpu", "--out", o, flag, value]
    };
    for (args, phrase) in [
        (render("--spp", "4294967295"), "bad --spp 4294967295"),
        (render("--spp", "65537"), "bad --spp 65537"),
        (render("--spp", "0"), "bad --spp 0"),
        (render("--size", "100000x100000"), "at most 16384"),
        (render("--bounces", "65"), "bad --bounces 65"),
        (render("--slots", "17"), "bad --slots 17"),
        (render("--ipd", "2"), "bad --ipd 2"),
        (render("--fov", "0"), "bad --fov 0"),
        (render("--exposure", "0"), "bad --exposure 0"),
        (replay("--frames", "0"), "bad --frames 0"),
        (replay("--frames", "99999999999"), "bad --frames"),
        (replay("--fps", "1e9"), "bad --fps"),
        (replay("--spp", "4294967295"), "bad --spp"),
        (
            vec![
                "compare",
                "--device",
                "no-such-gpu",
                "--out",
                o,
                "--reference-spp",
                "131072",
            ],
            "bad --reference-spp 131072",
        ),
    ] {
        let line = fails(&args);
        assert!(line.contains(phrase), "{args:?}: '{line}' lacks '{phrase}'");
        assert!(
            !line.contains("no-such-gpu"),
            "{args:?}: the device was opened first: {line}"
        );
        assert!(!out.exists(), "{args:?}: output written");
    }
    // The same device flag alone does reach the device: the check above is meaningful.
    let line = fails(&render("--size", "8x8"));
    assert!(line.contains("no-such-gpu"), "{line}");
}

/// `render`, `replay` and `compare` refuse an output directory that is a
/// file, lies below a file, or cannot be created (here under /proc, which no
/// user can create files in) before opening the GPU, without creating anything.
#[test]
fn unusable_output_directories_are_refused_before_rendering() {
    let base = out_dir("outdir");
    std::fs::create_dir_all(&base).unwrap();
    let file = base.join("a-file");
    std::fs::write(&file, b"not a directory").unwrap();
    let below = file.join("sub");
    let proc_dir = Path::new("/proc/stereocache-cli-test");
    let trace = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    for (dir, phrase) in [
        (file.as_path(), "is a file"),
        (below.as_path(), "is a file"),
        (proc_dir, "not writable"),
    ] {
        let d = dir.to_str().unwrap();
        for cmd in [
            vec!["render", "--size", "8x8"],
            vec!["replay", "--trace", trace.to_str().unwrap()],
            vec!["compare", "--methods", "naive"],
        ] {
            let mut args = cmd.clone();
            args.extend(["--device", "no-such-gpu", "--out", d]);
            let line = fails(&args);
            assert!(
                line.contains(d) && line.contains(phrase),
                "{args:?}: {line}"
            );
            assert!(!line.contains("no-such-gpu"), "{args:?}: {line}");
        }
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"not a directory");
    assert!(!proc_dir.exists());
    let _ = std::fs::remove_dir_all(&base);
}

/// `debug-normals` is on the command line through the registry: an unknown
/// `--method` lists it among the available ones, and a render writes the
/// usual files with one primary ray per pixel and eye and nothing else.
#[test]
fn debug_normals_is_listed_and_renders() {
    let e = fails(&["render", "--method", "nope", "--size", "8x8"]);
    assert!(
        e.contains("unknown method 'nope'") && e.contains("debug-normals"),
        "{e}"
    );
    let out = out_dir("debug-normals");
    let o = bin()
        .args([
            "render",
            "--method",
            "debug-normals",
            "--scene",
            "plane",
            "--size",
            "16x12",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "left.exr",
        "right.png",
        "left_depth.exr",
        "left_firsthit.bin",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["method"], "debug-normals", "{stats}");
    let rays = &stats["rays"];
    assert_eq!(
        (
            rays["primary"].as_u64(),
            rays["bounce"].as_u64(),
            rays["shadow"].as_u64()
        ),
        (Some(16 * 12 * 2), Some(0), Some(0)),
        "{stats}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// `--lighting` presets and `--hybrid-lookups` from the command line: bad
/// values give one error line naming the option; on the shipped hairball
/// (whose default sun and sky are a stand-in) an explicit `sun-sky` renders
/// byte-identically to no `--lighting`, and a directional light or a
/// constant-plus-directional sum replace it (different images).
#[test]
fn lighting_presets_and_hybrid_lookups_from_the_command_line() {
    for (flag, value) in [
        ("--lighting", "directional:100,0"),
        ("--lighting", "directional:30"),
        ("--lighting", "constant:1+constant:2"),
        ("--hybrid-lookups", "nearest"),
    ] {
        let e = fails(&["render", flag, value, "--size", "8x8"]);
        assert!(e.contains(flag) && e.contains(value), "{flag} {value}: {e}");
    }
    let render = |tag: &str, lighting: Option<&str>| {
        let out = out_dir(tag);
        let mut args = vec![
            "render", "--scene", "hairball", "--spp", "1", "--size", "16x12",
        ];
        args.extend(["--rt", "software", "--method", "reference", "--out"]);
        let o = bin()
            .args(&args)
            .arg(&out)
            .args(lighting.map(|l| vec!["--lighting", l]).unwrap_or_default())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{tag}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let bytes = std::fs::read(out.join("left.exr")).unwrap();
        let _ = std::fs::remove_dir_all(&out);
        bytes
    };
    let default = render("light-default", None);
    let sun_sky = render("light-sun-sky", Some("sun-sky"));
    let directional = render("light-dir", Some("directional:60,45"));
    let sum = render("light-sum", Some("constant:0.3+directional:60,45"));
    assert!(
        default == sun_sky,
        "--lighting sun-sky changed the default image"
    );
    assert!(directional != default && sum != default && sum != directional);
}

/// `render --time T` poses an animated scene's instances at T (default 0),
/// not at rest: on `cornell-moving` (the cone's loop is 4 s) the first hits
/// at T = 1 and T = 5 are the same pose and identical, at T = 0 the cone is
/// elsewhere; stats.json records the time; a non-finite time is refused.
#[test]
fn render_poses_an_animated_scene_at_the_given_time() {
    let hits = |t: &str| {
        let out = out_dir(&format!("time-{t}"));
        let o = bin()
            .args([
                "render",
                "--scene",
                "cornell-moving",
                "--size",
                "24x18",
                "--spp",
                "2",
                "--time",
                t,
                "--out",
                out.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
        assert_eq!(stats["time"].as_f64(), Some(t.parse::<f64>().unwrap()));
        let fh = std::fs::read(out.join("left_firsthit.bin")).unwrap();
        let _ = std::fs::remove_dir_all(&out);
        fh
    };
    let (t0, t1, t5) = (hits("0"), hits("1"), hits("5"));
    assert_eq!(t1, t5, "the 4 s loop: T = 1 and T = 5 are one pose");
    // The cone is the generator's last instance; bytes 12..16 of each
    // 16-byte record are the instance id.
    let scene = stereocache::scene::load_scene("cornell-moving").unwrap();
    let cone = (scene.instances.len() - 1) as u32;
    let cone_pixels = |fh: &[u8]| -> Vec<usize> {
        fh.chunks_exact(16)
            .enumerate()
            .filter(|(_, r)| u32::from_le_bytes(r[12..16].try_into().unwrap()) == cone)
            .map(|(i, _)| i)
            .collect()
    };
    let (c0, c1) = (cone_pixels(&t0), cone_pixels(&t1));
    assert!(!c0.is_empty() && !c1.is_empty(), "the cone is in view");
    assert_ne!(c0, c1, "the cone moved between T = 0 and T = 1");
    let e = fails(&[
        "render",
        "--scene",
        "cornell-moving",
        "--time",
        "nan",
        "--size",
        "8x8",
    ]);
    assert!(e.contains("bad --time"), "{e}");
}

/// A bench's CSV output: the header's columns and the rows' fields.
struct Csv<'a> {
    header: Vec<&'a str>,
    rows: Vec<Vec<&'a str>>,
}

impl<'a> Csv<'a> {
    fn parse(text: &'a str) -> Csv<'a> {
        let mut lines = text.lines();
        let header = lines.next().unwrap().split(',').collect();
        let rows = lines.map(|l| l.split(',').collect()).collect();
        Csv { header, rows }
    }

    /// The index of column `name`.
    fn col(&self, name: &str) -> usize {
        self.header.iter().position(|h| *h == name).unwrap()
    }

    /// Row `r`'s field `name` as a number.
    fn f(&self, r: &[&str], name: &str) -> f64 {
        r[self.col(name)].parse().unwrap()
    }
}

/// `bench materials` (issue 17): bad sizes and a scene without graphs are
/// one error line before any rendering; a tiny sweep writes one CSV row per
/// configuration whose counters are consistent: "off" looks nothing up,
/// every memoized run does; hit rates lie in [0, 1]; fills and evictions
/// never exceed the lookups; a 64-entry table must evict (a 16×12 view of
/// the procedural Cornell box touches more texels than that), the 2^20
/// default never does. `--fill-cost` times a fill apart (below).
#[test]
fn bench_materials_checks_input_and_sweeps_the_table() {
    for (args, phrase) in [
        (vec!["--sizes", "4"], "bad --sizes"),
        (vec!["--frames", "0"], "bad --frames"),
        (vec!["--scene", "cornell"], "no material graphs"),
        (vec!["--sweep-tile", "3"], "bad --sweep-tile"),
    ] {
        let mut a = vec!["bench", "materials", "--rt", "software"];
        a.extend(args.iter().copied());
        let line = fails(&a);
        assert!(line.contains(phrase), "{a:?}: '{line}' lacks '{phrase}'");
    }
    let out = out_dir("bench-materials");
    std::fs::create_dir_all(&out).unwrap();
    // One run of the bench on a 16×12 view of the procedural Cornell box,
    // one round: the CSV's text.
    let bench = |name: &str, args: &[&str]| -> String {
        let csv = out.join(name);
        let mut o = cli(1200);
        o.args([
            "bench",
            "materials",
            "--scene",
            "procedural-uv:cornell",
            "--rt",
            "software",
            "--size",
            "16x12",
            "--repeats",
            "1",
        ])
        .args(args)
        .arg("--out")
        .arg(&csv);
        succeeds(&mut o);
        std::fs::read_to_string(&csv).unwrap()
    };
    let text = bench("memo.csv", &["--frames", "3", "--sizes", "64,4096"]);
    let csv = Csv::parse(&text);
    let (rows, col) = (&csv.rows, |name: &str| csv.col(name));
    let labels: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        labels,
        [
            "off",
            "primary",
            "secondary",
            "both",
            "both S=64",
            "both S=4096",
            "both tile 4x4",
            "both tile 4x4 bilinear",
            "both tile 4x4 plain fill",
            "both S=64 no eviction",
            "both S=64 random",
            "both S=64 lrw",
            "both S=64 lrw counter",
            "both S=64 lru counter"
        ]
    );
    let f = |r: &[&str], name: &str| csv.f(r, name);
    for r in rows {
        let lookups = f(r, "lookups_per_frame");
        let hr = f(r, "hit_rate");
        assert!((0.0..=1.0).contains(&hr), "{r:?}");
        if r[0] == "off" {
            assert_eq!(lookups, 0.0, "{r:?}");
            assert_eq!(f(r, "ratio_to_off"), 1.0, "{r:?}");
        } else {
            assert!(lookups > 0.0 && hr > 0.0, "{r:?}");
        }
        assert!(
            f(r, "fills_per_frame") + f(r, "evictions_per_frame") <= lookups,
            "{r:?}"
        );
        assert!(f(r, "frame_ms") > 0.0, "{r:?}");
    }
    let row = |l: &str| rows.iter().find(|r| r[0] == l).unwrap();
    // Tiles are filled cooperatively by default (lavapipe has subgroup
    // ballot and shuffle), by the missing lane alone with the plain fill.
    assert!(f(row("both tile 4x4"), "cooperative_fills_per_frame") > 0.0);
    assert_eq!(
        f(
            row("both tile 4x4 plain fill"),
            "cooperative_fills_per_frame"
        ),
        0.0
    );
    assert_eq!(f(row("both"), "cooperative_fills_per_frame"), 0.0);
    assert!(f(row("both S=64"), "evictions_per_frame") > 0.0);
    assert_eq!(row("both S=64 lru counter")[col("eviction")], "lru counter");
    assert!(f(row("both S=64 lru counter"), "evictions_per_frame") > 0.0);
    assert_eq!(f(row("both"), "evictions_per_frame"), 0.0);
    // No eviction: a 64-entry table fills up and then stores nothing more.
    let none = row("both S=64 no eviction");
    assert_eq!(none[col("eviction")], "none");
    assert_eq!(f(none, "evictions_per_frame"), 0.0, "{none:?}");
    assert!(f(none, "window_full_per_frame") > 0.0, "{none:?}");
    assert_eq!(f(row("both S=64"), "window_full_per_frame"), 0.0);
    // The other eye's fills of this frame: a share of the lookups.
    for r in rows {
        let share = f(r, "other_eye_share");
        assert!((0.0..=1.0).contains(&share), "{r:?}");
    }
    assert!(f(row("both tile 4x4"), "other_eye_share") > 0.0);
    // The size sweep and eviction rows of 4×4 tiles with the plain fill
    // (--sweep-tile, --sweep-fill: the thesis's tiled columns): 16 tiles
    // must evict, every row of them fills no tile cooperatively.
    let text = bench(
        "memo-tiled.csv",
        &[
            "--frames",
            "2",
            "--sizes",
            "16",
            "--sweep-tile",
            "4",
            "--sweep-fill",
            "plain",
        ],
    );
    let rows = Csv::parse(&text).rows;
    let tiled: Vec<&Vec<&str>> = rows
        .iter()
        .filter(|r| r[0].starts_with("both tile 4x4 plain fill S=16"))
        .collect();
    assert_eq!(tiled.len(), 6, "{rows:?}");
    for r in &tiled {
        assert_eq!(r[col("entries")], "16", "{r:?}");
        if r[0].ends_with("no eviction") {
            assert_eq!(f(r, "evictions_per_frame"), 0.0, "{r:?}");
            assert!(f(r, "window_full_per_frame") > 0.0, "{r:?}");
        } else {
            assert!(f(r, "evictions_per_frame") > 0.0, "{r:?}");
        }
        assert_eq!(f(r, "cooperative_fills_per_frame"), 0.0, "{r:?}");
    }
    // --sweep-fill plain puts the fixed 4×4 rows on the plain fill too: no
    // row of the run fills cooperatively (the heavy Sponza's cooperative
    // build is slow to compile on llvmpipe).
    for label in [
        "both tile 4x4 plain fill",
        "both tile 4x4 bilinear plain fill",
    ] {
        assert!(rows.iter().any(|r| r[0] == label), "{label}: {rows:?}");
    }
    for r in &rows {
        assert_eq!(f(r, "cooperative_fills_per_frame"), 0.0, "{r:?}");
    }
    let secondary = rows
        .iter()
        .find(|r| r[0] == "secondary tile 4x4 plain fill")
        .expect("the tiled secondary-only row");
    assert_eq!(secondary[col("hits")], "secondary");
    assert!(f(secondary, "lookups_per_frame") > 0.0, "{secondary:?}");
    // --fill-cost: the first camera from an emptied table, then again (the
    // same rays and keys). Every memoized row fills in the cold frame; the
    // warm frame can only fill keys the cold frame missed without storing
    // (a lock lost to another lane), and "off" looks nothing up.
    let text = bench("fill.csv", &["--frames", "1", "--fill-cost"]);
    let csv = Csv::parse(&text);
    let rows = &csv.rows;
    let labels: Vec<&str> = rows.iter().map(|r| r[0]).collect();
    assert_eq!(
        labels,
        [
            "off",
            "both",
            "both tile 4x4",
            "both tile 4x4 plain fill",
            "both tile 8x8",
            "both tile 8x8 plain fill"
        ]
    );
    let f = |r: &[&str], name: &str| csv.f(r, name);
    for r in rows {
        assert!(f(r, "cold_ms") > 0.0 && f(r, "warm_ms") > 0.0, "{r:?}");
        if r[0] == "off" {
            assert_eq!(f(r, "cold_fills") + f(r, "warm_hits"), 0.0, "{r:?}");
            continue;
        }
        assert!(f(r, "cold_fills") > 0.0, "{r:?}");
        assert!(
            f(r, "warm_fills") <= f(r, "cold_misses") - f(r, "cold_fills"),
            "{r:?}"
        );
        assert!(
            f(r, "warm_hits") > 0.0 && f(r, "us_per_fill").is_finite(),
            "{r:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A glslc whose optimizer crashes (killed by a signal, as Debian 12's
/// glslc 2023.2 was on the procedural-heavy Sponza's cooperative memo fill
/// before session 36, when its id overflow made spirv-opt crash)
/// does not fail the render: the scene's run-time shader is compiled again
/// unoptimized (`-O0`), with one warning naming it, and the frame renders.
/// The stand-in glslc kills itself with SIGSEGV when asked to optimize and
/// runs the real one otherwise; a fresh shader cache makes it compile.
#[test]
fn a_crashing_glslc_optimizer_falls_back_to_unoptimized_spirv() {
    let out = out_dir("glslc-crash");
    std::fs::create_dir_all(&out).unwrap();
    let fake = out.join("glslc");
    std::fs::write(
        &fake,
        "#!/bin/sh\nfor a in \"$@\"; do [ \"$a\" = -O ] && kill -SEGV $$; done\nexec glslc \"$@\"\n",
    )
    .unwrap();
    let status = Command::new("chmod").arg("+x").arg(&fake).status().unwrap();
    assert!(status.success());
    let o = cli(600)
        .args([
            "render",
            "--scene",
            "procedural-uv:cornell",
            "--method",
            "naive",
            "--rt",
            "software",
            "--size",
            "8x8",
            "--spp",
            "1",
            "--out",
        ])
        .arg(out.join("img"))
        .env("GLSLC", &fake)
        .env("STEREOCACHE_SHADER_CACHE", out.join("cache"))
        .output()
        .unwrap();
    succeeded(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    let crashes: Vec<&str> = err
        .lines()
        .filter(|l| l.contains("glslc's optimizer crashed"))
        .collect();
    assert!(
        !crashes.is_empty() && crashes.iter().all(|l| l.starts_with("warning: shader ")),
        "{err}"
    );
    assert!(out.join("img/left.exr").exists(), "{err}");
    let _ = std::fs::remove_dir_all(&out);
}

/// A one-triangle glTF in `dir` (positions in `tri.bin`) whose node carries
/// `node_extra` (JSON members) and, with `anim`, a translation animation
/// of node `anim.0` from (0, 0, 0) at 0 s to (anim.1, 0, 0) at 1 s.
fn triangle_gltf(dir: &Path, node_extra: &str, anim: Option<(u32, f32)>) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let mut bin: Vec<u8> = Vec::new();
    for v in [0.0f32, 0.0, -3.0, 1.0, 0.0, -3.0, 0.0, 1.0, -3.0] {
        bin.extend(v.to_le_bytes());
    }
    let x = anim.map_or(0.0, |a| a.1);
    for v in [0.0f32, 1.0, 0.0, 0.0, 0.0, x, 0.0, 0.0] {
        bin.extend(v.to_le_bytes());
    }
    std::fs::write(dir.join("tri.bin"), &bin).unwrap();
    let animations = match anim {
        Some((node, _)) => format!(
            r#","animations":[{{"channels":[{{"sampler":0,"target":{{"node":{node},"path":"translation"}}}}],"samplers":[{{"input":1,"output":2}}]}}]"#
        ),
        None => String::new(),
    };
    let gltf = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"name":"tri","mesh":0{node_extra}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"accessors":[
 {{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,-3],"max":[1,1,-3]}},
 {{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]}},
 {{"bufferView":2,"componentType":5126,"count":2,"type":"VEC3"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":8}},{{"buffer":0,"byteOffset":44,"byteLength":24}}],
"buffers":[{{"uri":"tri.bin","byteLength":68}}]{animations}}}"#
    );
    let path = dir.join("tri.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

/// Inputs that used to crash or hang (a bad-input sweep, session 39) now
/// fail with one error line naming the file, before anything is written:
/// a node scale that takes the bounds to 3e22 (the BVH builder panicked on
/// overflowing areas), a node scaled to zero (a BVH chain deeper than the
/// traversal stack), an animation key at 3e38 (the TLAS rebuild panicked
/// mid-run), an animation channel targeting a missing node (the gltf
/// crate's unwrap), and a trace whose timestamps span 1e300 s (resampling
/// never ended; its first frames still replay with --frames). The unbroken files render (the helper itself is sound).
/// (The animation loops over its 1 s of keys, so the key at 3e38 shows at
/// 0.5 s as 1.5e38: 2 frames at 2 fps.)
#[test]
fn hostile_geometry_animation_and_traces_fail_before_rendering() {
    let root = out_dir("hostile");
    let replay = |scene: &Path, trace: &Path, out: &Path| {
        bin()
            .args(["replay", "--scene"])
            .arg(scene)
            .arg("--trace")
            .arg(trace)
            .args(["--size", "8x6", "--spp", "1", "--frames", "2", "--fps", "2"])
            .args(["--rt", "software", "--out"])
            .arg(out)
            .output()
            .unwrap()
    };
    let render = |scene: &Path, out: &Path| {
        bin()
            .args(["render", "--scene"])
            .arg(scene)
            .args(["--size", "8x6", "--spp", "1", "--rt", "software", "--out"])
            .arg(out)
            .output()
            .unwrap()
    };
    std::fs::create_dir_all(&root).unwrap();
    let trace = root.join("still.csv");
    std::fs::write(
        &trace,
        "t,px,py,pz,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n2,0,0,0,0,0,0,1\n",
    )
    .unwrap();

    let ok = triangle_gltf(&root.join("ok"), "", Some((0, 0.5)));
    succeeded(&render(&ok, &root.join("ok-render")));
    succeeded(&replay(&ok, &trace, &root.join("ok-replay")));

    for (tag, extra, phrase) in [
        (
            "huge",
            r#","scale":[1e22,1e22,1e22]"#,
            "instance 0 (node 'tri'): its bounds reach 3.000e22 from the origin",
        ),
        (
            "zero",
            r#","scale":[0,0,0]"#,
            "every triangle has zero area",
        ),
    ] {
        let scene = triangle_gltf(&root.join(tag), extra, None);
        let out = root.join(format!("{tag}-out"));
        let line = single_error_line(&render(&scene, &out), tag);
        assert!(
            line.contains("tri.gltf") && line.contains(phrase),
            "{tag}: {line}"
        );
        assert!(!out.exists(), "{tag}: output written");
    }
    for (tag, anim, phrase) in [
        (
            "key",
            (0, 3e38),
            "at 0.5 s of its animation, instance 0 (node 'tri'): its bounds reach 1.500e38",
        ),
        (
            "target",
            (5, 1.0),
            "channel 0: targets node 5, but the file has 1 node(s)",
        ),
    ] {
        let scene = triangle_gltf(&root.join(tag), "", Some(anim));
        let out = root.join(format!("{tag}-out"));
        let line = single_error_line(&replay(&scene, &trace, &out), tag);
        assert!(
            line.contains("tri.gltf") && line.contains(phrase),
            "{tag}: {line}"
        );
        assert!(!out.exists(), "{tag}: output written");
    }
    let gap = root.join("gap.csv");
    std::fs::write(
        &gap,
        "t,px,py,pz,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n1e300,0,0,0,0,0,0,1\n",
    )
    .unwrap();
    // Its first frames replay (only those are built)...
    succeeded(&replay(&ok, &gap, &root.join("gap-2")));
    let frames = std::fs::read_to_string(root.join("gap-2").join("frames.jsonl")).unwrap();
    assert_eq!(frames.lines().count(), 2);
    // ... the whole of it is refused.
    let out = root.join("gap-out");
    let o = bin()
        .args(["replay", "--scene"])
        .arg(&ok)
        .arg("--trace")
        .arg(&gap)
        .args(["--size", "8x6", "--spp", "1", "--rt", "software", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let line = single_error_line(&o, "gap");
    assert!(
        line.contains("gap.csv")
            && line.contains("the trace spans 1.000000e300 s")
            && line.contains("replay the first ones with --frames"),
        "{line}"
    );
    assert!(!out.exists(), "gap: output written");
    let _ = std::fs::remove_dir_all(&root);
}

/// Every bench checks its frame count (and warm-up) against the trace before
/// the device opens: a one-sample trace panicked `bench sample-cache`
/// (index out of bounds) and gave NaN tables in `bench scaling` and
/// `bench materials`; `--frames 1000` on a 451-frame trace ran fewer frames.
#[test]
fn bench_frame_counts_beyond_the_trace_are_refused_up_front() {
    let dir = out_dir("bench-frames");
    std::fs::create_dir_all(&dir).unwrap();
    let one = dir.join("one_row.csv");
    std::fs::write(&one, "t,px,py,pz,qx,qy,qz,qw\n0,0,1.6,0,0,0,0,1\n").unwrap();
    let one = one.to_str().unwrap();
    let long = Path::new(env!("CARGO_MANIFEST_DIR")).join("captures/synth-head-turn.csv");
    let long = long.to_str().unwrap();
    let bench = |which: &'static str, trace: &'static str, frames: &'static str| {
        let t = if trace == "one" { one } else { long };
        let mut a = vec!["bench", which, "--device", "no-such-gpu", "--trace", t];
        a.extend(["--frames", frames, "--size", "8x8"]);
        if which == "materials" {
            a.extend(["--scene", "procedural-uv:cornell"]);
        }
        a.into_iter().map(str::to_owned).collect::<Vec<_>>()
    };
    for (args, phrase) in [
        (bench("sample-cache", "one", "5"), "bad --frames 5: "),
        (bench("sample-cache", "long", "1000"), "bad --frames 1000: "),
        (bench("scaling", "one", "1"), "bad --frames 1: "),
        (bench("specialization", "one", "1"), "bad --frames 1: "),
        (bench("materials", "one", "2"), "bad --frames 2: "),
        (bench("materials", "long", "1"), "warm-up; use at least 2"),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let line = fails(&args);
        assert!(line.contains(phrase), "{args:?}: '{line}' lacks '{phrase}'");
        assert!(
            line.contains("warm-up") || line.contains(".csv has "),
            "{args:?}: {line}"
        );
        assert!(!line.contains("no-such-gpu"), "{args:?}: {line}");
    }
}

/// The benchmarks pose an animated scene at each frame's time, as replay
/// does (they rendered it at its rest pose: no motion, no TLAS rebuilds in
/// the timings). A bench's frames are at 90 Hz, so an animation whose key
/// at 1 s is 3e38 (looped over its 1 s of keys, lerped from 0) places the
/// triangle at 3e38 / 90 = 3.333e36 on frame 1 (t = 1/90 s), beyond the
/// ±1e15 world: refused before anything renders, naming that time, as a
/// replay refuses it. The unbroken animation runs and reports the wall
/// time of posing its frames (non-zero: sampling, TLAS rebuild, uploads).
#[test]
fn benches_pose_animated_scenes_at_each_frame_time() {
    let root = out_dir("bench-poses");
    std::fs::create_dir_all(&root).unwrap();
    let trace = root.join("still.csv");
    std::fs::write(
        &trace,
        "t,px,py,pz,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n2,0,0,0,0,0,0,1\n",
    )
    .unwrap();
    let bench = |which: &str, scene: &Path, scene_flag: &str| {
        let mut c = cli(1200);
        c.args(["bench", which, scene_flag])
            .arg(scene)
            .arg("--trace")
            .arg(&trace)
            .args(["--frames", "2", "--size", "8x6", "--rt", "software"]);
        if which == "specialization" {
            c.args(["--methods", "naive", "--bounces", "1"]);
        }
        c.output().unwrap()
    };
    let broken = triangle_gltf(&root.join("key"), "", Some((0, 3e38)));
    let at = format!(
        "at {} s of its animation, instance 0 (node 'tri'): its bounds reach 3.333e36",
        1.0f64 / 90.0
    );
    for (which, flag) in [("sample-cache", "--scene"), ("specialization", "--scenes")] {
        let o = bench(which, &broken, flag);
        let line = single_error_line(&o, which);
        assert!(
            line.contains("tri.gltf") && line.contains(&at),
            "{which}: {line}"
        );
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            !stdout.contains("scene"),
            "{which}: rendered first:\n{stdout}"
        );
    }
    let ok = triangle_gltf(&root.join("ok"), "", Some((0, 0.5)));
    let o = bench("sample-cache", &ok, "--scene");
    succeeded(&o);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let posing: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("posing the animated instances"))
        .collect();
    assert_eq!(posing.len(), 1, "{stderr}");
    let ms: f64 = posing[0]
        .split("): ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no time in '{}'", posing[0]));
    // A wall-clock figure: only its presence is checked, not its size.
    assert!(ms.is_finite() && ms >= 0.0, "{}", posing[0]);
    assert!(posing[0].contains("2 measured frames"), "{}", posing[0]);
    let _ = std::fs::remove_dir_all(&root);
}

/// Makes a FIFO at `p` (a special file: reading it blocks until a writer
/// comes, like `/dev/zero` never ends; neither is a regular file).
fn mkfifo(p: &Path) {
    let _ = std::fs::remove_file(p);
    let ok = Command::new("mkfifo").arg(p).status().unwrap().success();
    assert!(ok, "mkfifo {}", p.display());
}

/// A user path to a device or FIFO (`/dev/zero` as a trace, a glTF buffer
/// or image, a MaterialX file or the image one of its nodes reads) was read until memory ran out or blocked
/// forever; each is now one error line naming the file, before the device
/// opens (an image node's file: one warning, the node's default). (FIFOs here: on the old code they block, so the test fails by
/// timeout instead of by exhausting memory.)
#[test]
fn special_files_are_refused_without_reading() {
    let dir = out_dir("special");
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.csv");
    mkfifo(&fifo);
    // A glTF whose buffer is a FIFO, and one whose MaterialX file is.
    let buffer = triangle_gltf(&dir.join("buffer"), "", None);
    mkfifo(&dir.join("buffer").join("tri.bin"));
    let mtlx = triangle_gltf(&dir.join("mtlx"), "", None);
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&mtlx).unwrap()).unwrap();
    v["materials"] = serde_json::json!([{"extras": {"materialx": {"file": "g.mtlx"}}}]);
    v["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    std::fs::write(&mtlx, serde_json::to_vec(&v).unwrap()).unwrap();
    mkfifo(&dir.join("mtlx").join("g.mtlx"));
    // A MaterialX document whose image node's file is a FIFO.
    let image = triangle_gltf(&dir.join("image"), "", None);
    std::fs::write(&image, serde_json::to_vec(&v).unwrap()).unwrap();
    std::fs::write(
        dir.join("image").join("g.mtlx"),
        r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="g">
    <image name="i" type="color3"><input name="file" type="filename" value="img.png" /></image>
    <output name="base_color" type="color3" nodename="i" />
  </nodegraph>
</materialx>
"#,
    )
    .unwrap();
    mkfifo(&dir.join("image").join("img.png"));
    let out = dir.join("out");
    let (f, o) = (fifo.to_str().unwrap(), out.to_str().unwrap());
    let (b, m, im) = (
        buffer.to_str().unwrap(),
        mtlx.to_str().unwrap(),
        image.to_str().unwrap(),
    );
    let csv = dir.join("t.csv");
    for (args, phrase) in [
        (
            vec![
                "replay",
                "--device",
                "no-such-gpu",
                "--trace",
                f,
                "--out",
                o,
            ],
            format!("{f}: not a regular file"),
        ),
        (
            vec!["trace", "convert", f, "--out", csv.to_str().unwrap()],
            format!("{f}: not a regular file"),
        ),
        (
            vec!["render", "--scene", b, "--size", "8x8", "--out", o],
            "buffer 0: cannot read '".to_string(),
        ),
        (
            vec!["render", "--scene", m, "--size", "8x8", "--out", o],
            "materials[0]: extras.materialx.file '".to_string(),
        ),
    ] {
        let o = cli(20).args(&args).output().unwrap();
        let line = single_error_line(&o, &format!("{args:?}"));
        assert!(
            line.contains(&phrase),
            "{args:?}: '{line}' lacks '{phrase}'"
        );
        assert!(line.contains("not a regular file"), "{args:?}: {line}");
        assert!(!line.contains("no-such-gpu"), "{args:?}: {line}");
        assert!(!out.exists() && !csv.exists(), "{args:?}: output written");
    }
    // The image node's FIFO is not read either: the node gives its default
    // input (MaterialX's rule for a file that cannot be read; a load error
    // until session 51) with one warning naming the file, and the render
    // finishes (within cli's timeout: a read would block).
    let image_out = dir.join("image-out");
    let o = cli(20)
        .args([
            "render", "--scene", im, "--size", "8x8", "--spp", "1", "--out",
        ])
        .arg(&image_out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "image FIFO: {stderr}");
    let warnings: Vec<_> = stderr
        .lines()
        .filter(|l| l.contains("img.png") && l.contains("not a regular file"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].starts_with("warning:") && warnings[0].contains("default"),
        "{stderr}"
    );
    assert!(image_out.join("left.png").exists(), "{stderr}");
}

/// A scene whose instances flatten to more triangles than the device's
/// storage buffers hold is refused before the software BVH is built: 10k to
/// 100k instances of a 4k-triangle mesh built for 100 s in 11–22 GB, then
/// failed on `bvh.tri_verts`. Sized from this device's limit (lavapipe:
/// 2^27 bytes, about 1,400 instances here). The message is the one
/// `Session`'s flattened-size check gives, which runs before the build.
#[test]
fn scenes_too_large_once_flattened_are_refused_before_the_bvh_build() {
    use stereocache::scene::{generate, Instance, Material};
    let ctx = common::context();
    let mut scene = common::plane_in_environment(Material::default(), 1.0, glam::Vec3::ONE);
    scene.source = "many-instances.gltf".into();
    scene.meshes[0] = generate::grid(
        "plane",
        glam::Vec3::ZERO,
        glam::Vec3::X,
        glam::Vec3::NEG_Z,
        32,
        32,
        glam::Vec2::ONE,
    );
    let tris = scene.meshes[0].triangle_count() as u64;
    let limit = ctx.caps.max_storage_buffer_range;
    let n = (limit / (48 * tris) + 1) as usize;
    scene.instances = (0..n)
        .map(|k| Instance {
            mesh: 0,
            transform: glam::Mat4::from_translation(glam::Vec3::Y * k as f32 * 1e-3),
            name: format!("n{k}"),
        })
        .collect();
    let e = match stereocache::session::Session::with_context(
        ctx,
        scene,
        stereocache::rt::RtChoice::Software,
    ) {
        Ok(_) => panic!("{n} instances of {tris} triangles uploaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.starts_with("many-instances.gltf: ")
            && e.contains(&format!("triangles once its {n} instances are flattened"))
            && e.contains("storage buffer bvh.tri_verts needs"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
}

/// Negative numbers reach the options' own checks (clap read `-1` as an
/// unknown flag and printed its usage); `--time -1` is a valid time. A
/// stdout closed by the reader (`render … | true`) made the first
/// `println!` panic (exit 101): the run now completes and writes its files.
/// `scene generate --out FILE` said "cannot read: File exists".
#[test]
fn negative_values_closed_stdout_and_a_file_as_output_folder() {
    let out = out_dir("negatives");
    let o = out.to_str().unwrap();
    let render = |flag: &'static str, value: &'static str| {
        vec!["render", "--device", "no-such-gpu", "--out", o, flag, value]
    };
    for (args, phrase) in [
        (render("--ipd", "-1"), "bad --ipd -1"),
        (render("--exposure", "-1"), "bad --exposure -1"),
        (render("--fov", "-5"), "bad --fov -5"),
        (render("--spp", "-1"), "bad --spp -1"),
        (
            render("--pose", "1e20,0,0,0,0,0,1"),
            "the position is beyond ±1e15 m",
        ),
        // Lists and sizes that start with '-' reach their parsers too.
        (
            render("--pose", "-1e20,0,0,0,0,0,1"),
            "the position is beyond ±1e15 m",
        ),
        (render("--size", "-16x12"), "bad --size '-16x12'"),
    ] {
        let line = fails(&args);
        assert!(line.contains(phrase), "{args:?}: '{line}' lacks '{phrase}'");
        assert!(!line.contains("unexpected argument"), "{line}");
        assert!(!out.exists(), "{args:?}: output written");
    }
    // `--time -1` renders, with stdout closed before the first line; so
    // does a head at a negative x.
    let mut child = bin()
        .args(["render", "--size", "8x6", "--spp", "1", "--rt", "software"])
        .args(["--time", "-1", "--pose", "-0.1,0,3,0,0,0,1", "--out", o])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let done = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(done.status.success(), "{:?}: {stderr}", done.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(out.join("stats.json").exists(), "{stderr}");
    // A file where the generated scene's folder should go.
    let file = out.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let line = fails(&[
        "scene",
        "generate",
        "cornell",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert!(
        line.contains("a-file: the output directory is a file, not a directory"),
        "{line}"
    );
    assert!(!line.contains("cannot read"), "{line}");
}

/// Outputs that could pass for another run's, and inputs overwritten by
/// their own output (each accepted until session 49, found by an audit):
/// a render that fails at its last write leaves no stats.json (the old
/// render's went first); `trace convert X --out X` is refused and X kept;
/// `compare --zoom 0` is refused (it was used as 1).
#[test]
fn stale_outputs_and_self_overwrites_are_refused() {
    let out = out_dir("stale-render");
    let o = out.to_str().unwrap();
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("stats.json"), b"{\"method\": \"an older render\"}").unwrap();
    // The final write of stats.json fails: its temporary name is a folder.
    std::fs::create_dir_all(out.join("stats.json.partial")).unwrap();
    let line = fails(&[
        "render", "--size", "8x6", "--spp", "1", "--rt", "software", "--out", o,
    ]);
    assert!(line.contains("stats.json"), "{line}");
    assert!(
        !out.join("stats.json").exists(),
        "the older render's stats.json survived a failed render"
    );
    let trace = out.join("trace.csv");
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/captures/mmsys18-user1.csv"),
        &trace,
    )
    .unwrap();
    let before = std::fs::read(&trace).unwrap();
    let t = trace.to_str().unwrap();
    let line = fails(&["trace", "convert", t, "--out", t]);
    assert!(line.contains("is the recording itself"), "{line}");
    assert_eq!(std::fs::read(&trace).unwrap(), before);
    let line = fails(&["compare", "--zoom", "0", "--out", o]);
    assert!(line.contains("bad --zoom 0"), "{line}");
    let _ = std::fs::remove_dir_all(&out);
}

/// A run never writes over its own inputs (an audit's findings: `render`
/// replaced an environment map named left.exr in --out, `replay` a trace
/// named frames.jsonl): refused with one line naming both, before
/// rendering, the input unchanged. A compare whose configuration folder
/// is a file is refused before the device opens (it failed after the
/// reference and the earlier configurations had rendered).
#[test]
fn runs_refuse_to_overwrite_their_inputs() {
    let out = out_dir("own-inputs");
    let o = out.to_str().unwrap();
    let common = ["--size", "8x6", "--spp", "1", "--rt", "software"];
    succeeds(bin().arg("render").args(common).args(["--out", o]));
    let env = out.join("left.exr");
    let before = std::fs::read(&env).unwrap();
    let lighting = format!("env:{}", env.display());
    let line = fails(
        &[
            &["render", "--lighting", &lighting, "--out", o][..],
            &common[..],
        ]
        .concat(),
    );
    assert!(
        line.contains("would overwrite") && line.contains("left.exr"),
        "{line}"
    );
    assert_eq!(std::fs::read(&env).unwrap(), before);
    // Elsewhere the same map is fine.
    let other = out_dir("own-inputs-elsewhere");
    succeeds(
        bin()
            .args(["render", "--lighting", &lighting, "--out"])
            .arg(&other)
            .args(common),
    );
    let trace = out.join("frames.jsonl");
    std::fs::copy(
        concat!(env!("CARGO_MANIFEST_DIR"), "/captures/synth-head-turn.csv"),
        &trace,
    )
    .unwrap();
    let before = std::fs::read(&trace).unwrap();
    let line = fails(
        &[
            &[
                "replay",
                "--trace",
                trace.to_str().unwrap(),
                "--frames",
                "1",
                "--out",
                o,
            ][..],
            &common[..],
        ]
        .concat(),
    );
    assert!(
        line.contains("would overwrite") && line.contains("frames.jsonl"),
        "{line}"
    );
    assert_eq!(std::fs::read(&trace).unwrap(), before);
    let cmp = out_dir("own-inputs-compare");
    std::fs::create_dir_all(&cmp).unwrap();
    std::fs::write(cmp.join("taa"), b"a file").unwrap();
    let line = fails(&[
        "compare",
        "--methods",
        "naive,taa",
        "--frames",
        "1",
        "--size",
        "8x6",
        "--rt",
        "software",
        "--reference-spp",
        "0",
        "--out",
        cmp.to_str().unwrap(),
    ]);
    assert!(line.contains("taa") && line.contains("is a file"), "{line}");
    assert!(
        !cmp.join("naive").exists(),
        "a configuration rendered before the refusal"
    );
    for d in [&out, &other, &cmp] {
        let _ = std::fs::remove_dir_all(d);
    }
}
