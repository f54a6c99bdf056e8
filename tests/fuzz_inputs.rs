//! Property-based fuzzing (proptest) of the three user-input parsers: the
//! pose-trace CSV reader, the MMSys'18 importer and the glTF/GLB importer.
//!
//! Inputs are random token soups and mutations of valid files (truncation,
//! byte flips, numbers replaced by huge / negative / tiny values, fields
//! dropped or retyped). Properties, for every input:
//!
//! * the parser returns (no panic; for glTF, not even one swallowed by the
//!   importer's `catch_unwind`, whose message says "failed internally");
//! * an error's message names the file;
//! * a successful result is usable: trace samples are finite with unit
//!   quaternions and strictly increasing times; a scene validates and its
//!   positions, normals and instance transforms are finite.
//!
//! Case counts keep the whole file under a minute on two cores; longer
//! campaigns: `PROPTEST_CASES=100000 cargo test --release --test fuzz_inputs`
//! (see `fuzz/README.md`). Inputs that once failed live in `tests/data/fuzz/`
//! and are replayed by the `regression_*` tests at the end.

mod common;

use proptest::prelude::*;
use proptest::test_runner::Config;
use serde_json::Value;
use std::path::{Path, PathBuf};
use stereocache::camera::mmsys18::{parse_mmsys18, Mmsys18Options};
use stereocache::camera::PoseTrace;
use stereocache::scene::{gltf_import::load_gltf, Scene};

/// Cases per property: `PROPTEST_CASES` when set, else `default`.
fn cases(default: u32) -> Config {
    let n = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default);
    Config {
        cases: n,
        failure_persistence: None,
        ..Config::default()
    }
}

// ---------------------------------------------------------------- traces

const CSV_VALID: &str = "t,px,py,pz,qx,qy,qz,qw,ipd\n\
0,0,0,0,0,0,0,1,0.063\n\
0.011111111,0.0001,0,-0.0002,0,0.0087,0,0.99996,0.063\n\
0.022222222,0.0002,0.001,-0.0004,0.001,0.0174,0,0.9998,\n\
0.033333333,0.0003,0.002,-0.0006,0.002,-0.0261,0.001,-0.9996,0.064\n";

const MMSYS_VALID: &str = "timestamp viewpoint w x y z\n\
10.0 0 1 0 0 0\n\
10.017 0 0.9999 0.001 0.002 0.01\n\
10.034 1 -0.9998 -0.002 -0.003 -0.02\n\
10.051 1 0.9997 0.003 0.004 0.03\n";

/// Numbers that stress f64 → f32 conversion, norms and comparisons.
const NASTY_NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "1e308",
    "-1e308",
    "1e39",
    "-1e39",
    "3.5e38",
    "1e-320",
    "1e-45",
    "1e200",
    "NaN",
    "inf",
    "-inf",
    "+1",
    "0x10",
    "1_0",
    "",
    " ",
    "9999999999999999999999",
    "4294967296",
    "-4294967296",
    "1e",
    ".",
    "-",
    "1.7976931348623157e308",
];

fn token_soup(tokens: &'static [&'static str]) -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(tokens), 0..60).prop_map(|v| v.concat())
}

const CSV_TOKENS: &[&str] = &[
    "t", "px", "py", "pz", "qx", "qy", "qz", "qw", "ipd", ",", ",", ",", "\n", "\n", "\r\n", "#",
    " ", "0", "1", "-1", "0.5", "1e308", "1e39", "NaN", "inf", "-", ".", "e", "\u{feff}", "é",
    "\0", "2", "0.063",
];

const MMSYS_TOKENS: &[&str] = &[
    "timestamp",
    "viewpoint",
    "w",
    "x",
    "y",
    "z",
    " ",
    " ",
    " ",
    "\t",
    "\n",
    "\n",
    "0",
    "1",
    "-1",
    "0.5",
    "1e308",
    "1e39",
    "NaN",
    "inf",
    "-",
    ".",
    "e",
    "10.0",
    "2",
    "é",
];

/// A line-oriented mutation of `base`: replace fields with nasty numbers,
/// delete or duplicate lines, truncate.
fn mutate_lines(base: &'static str, sep: char) -> impl Strategy<Value = String> {
    let edits = prop::collection::vec(
        (
            0usize..6,
            0usize..16,
            0usize..16,
            prop::sample::select(NASTY_NUMBERS),
        ),
        1..6,
    );
    (edits, prop::option::of(0usize..200)).prop_map(move |(edits, cut)| {
        let mut lines: Vec<Vec<String>> = base
            .lines()
            .map(|l| l.split(sep).map(str::to_owned).collect())
            .collect();
        for (kind, a, b, num) in edits {
            let n = lines.len();
            if n == 0 {
                break;
            }
            let li = a % n;
            match kind {
                0..=2 => {
                    let m = lines[li].len();
                    if m > 0 {
                        lines[li][b % m] = num.to_string();
                    }
                }
                3 => {
                    lines.remove(li);
                }
                4 => {
                    let l = lines[li].clone();
                    lines.insert(b % (n + 1), l);
                }
                _ => {
                    let m = lines[li].len();
                    if m > 0 {
                        lines[li].remove(b % m);
                    }
                }
            }
        }
        let mut s: String = lines
            .iter()
            .map(|l| l.join(&sep.to_string()) + "\n")
            .collect();
        if let Some(c) = cut {
            let mut c = c.min(s.len());
            while !s.is_char_boundary(c) {
                c -= 1;
            }
            s.truncate(c);
        }
        s
    })
}

/// Byte-level mutation of `base` (flips, inserts, deletes, truncation).
fn mutate_bytes(base: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    let len = base.len();
    let edits = prop::collection::vec((0usize..4, 0..len.max(1), any::<u8>()), 1..8);
    (edits, prop::option::of(0..len.max(1) + 1)).prop_map(move |(edits, cut)| {
        let mut b = base.clone();
        for (kind, at, byte) in edits {
            if b.is_empty() {
                b.push(byte);
                continue;
            }
            let at = at % b.len();
            match kind {
                0 => b[at] = byte,
                1 => b[at] ^= 1 << (byte % 8),
                2 => b.insert(at, byte),
                _ => {
                    b.remove(at);
                }
            }
        }
        if let Some(c) = cut {
            b.truncate(c);
        }
        b
    })
}

fn check_trace(
    result: Result<PoseTrace, impl std::fmt::Display>,
    file: &str,
) -> Result<(), TestCaseError> {
    match result {
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(msg.contains(file), "error does not name {file}: {msg}");
        }
        Ok(tr) => {
            prop_assert!(!tr.samples.is_empty());
            let mut prev = f64::NEG_INFINITY;
            for s in &tr.samples {
                prop_assert!(
                    s.t.is_finite() && s.t > prev,
                    "times not increasing: {:?}",
                    s
                );
                prev = s.t;
                prop_assert!(s.pose.position.is_finite(), "non-finite position {:?}", s);
                let q = s.pose.orientation;
                prop_assert!(
                    q.is_finite() && (q.length() - 1.0).abs() < 1e-3,
                    "orientation not a finite unit quaternion: {:?}",
                    s
                );
                if let Some(ipd) = s.ipd {
                    prop_assert!(ipd.is_finite() && ipd >= 0.0, "bad ipd {:?}", s);
                }
            }
            for w in &tr.warnings {
                prop_assert!(w.contains(file), "warning does not name {file}: {w}");
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(cases(4000))]

    #[test]
    fn csv_token_soup(text in token_soup(CSV_TOKENS)) {
        check_trace(PoseTrace::parse_csv("soup.csv", &text), "soup.csv")?;
    }

    #[test]
    fn csv_mutated(text in mutate_lines(CSV_VALID, ',')) {
        check_trace(PoseTrace::parse_csv("mutated.csv", &text), "mutated.csv")?;
    }

    #[test]
    fn mmsys18_token_soup(text in token_soup(MMSYS_TOKENS)) {
        check_trace(parse_mmsys18("soup.txt", &text, &Mmsys18Options::default()), "soup.txt")?;
    }

    #[test]
    fn mmsys18_mutated(text in mutate_lines(MMSYS_VALID, ' '), start in -1.0f64..11.0, len in 0.0f64..2.0) {
        let opts = Mmsys18Options { start, end: start + len, ..Default::default() };
        check_trace(parse_mmsys18("mutated.txt", &text, &opts), "mutated.txt")?;
        check_trace(parse_mmsys18("mutated.txt", &text, &Mmsys18Options::default()), "mutated.txt")?;
    }
}

proptest! {
    #![proptest_config(cases(1000))]

    /// Arbitrary bytes from disk (invalid UTF-8 included) through `read_csv`.
    #[test]
    fn csv_file_bytes(bytes in mutate_bytes(CSV_VALID.as_bytes().to_vec())) {
        let dir = temp_dir("csv");
        let path = dir.join("bytes.csv");
        std::fs::write(&path, &bytes).unwrap();
        check_trace(PoseTrace::read_csv(&path), "bytes.csv")?;
    }
}

// ---------------------------------------------------------------- glTF

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

fn valid_gltf() -> Vec<u8> {
    std::fs::read(data_dir().join("bad_scenes/valid_triangle.gltf")).unwrap()
}

/// The valid triangle as a GLB (JSON chunk + BIN chunk, buffer without uri).
fn valid_glb() -> Vec<u8> {
    let mut json: Value = serde_json::from_slice(&valid_gltf()).unwrap();
    let uri = json["buffers"][0]["uri"].as_str().unwrap().to_owned();
    let b64 = uri.split_once(",").unwrap().1;
    let bin = base64_decode(b64);
    json["buffers"][0].as_object_mut().unwrap().remove("uri");
    glb(&serde_json::to_vec(&json).unwrap(), &bin)
}

fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |v: &[u8], with: u8| {
        let mut v = v.to_vec();
        while v.len() % 4 != 0 {
            v.push(with);
        }
        v
    };
    let (j, b) = (pad(json, b' '), pad(bin, 0));
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(&j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(&b);
    out
}

fn base64_decode(s: &str) -> Vec<u8> {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.decode(s).unwrap()
}

fn temp_dir(tag: &str) -> common::TempDir {
    common::TempDir::new(&format!("fuzz-{tag}"))
}

fn check_scene(
    result: Result<Scene, impl std::fmt::Display>,
    file: &str,
) -> Result<(), TestCaseError> {
    match result {
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(msg.contains(file), "error does not name {file}: {msg}");
            prop_assert!(
                !msg.contains("failed internally"),
                "the importer panicked: {msg}"
            );
        }
        Ok(scene) => {
            prop_assert!(scene.validate().is_ok());
            for m in &scene.meshes {
                prop_assert!(
                    m.positions.iter().all(|p| p.is_finite()),
                    "non-finite position"
                );
                prop_assert!(m.normals.iter().all(|n| n.is_finite()), "non-finite normal");
                prop_assert!(m.uvs.iter().all(|n| n.is_finite()), "non-finite uv");
            }
            for i in &scene.instances {
                prop_assert!(i.transform.is_finite(), "non-finite transform");
            }
            for c in &scene.cameras {
                prop_assert!(c.transform.is_finite(), "non-finite camera {c:?}");
                prop_assert!(
                    c.yfov > 0.0 && c.yfov < std::f32::consts::PI,
                    "bad yfov {c:?}"
                );
                prop_assert!(
                    c.aspect.is_none_or(|a| a.is_finite() && a > 0.0),
                    "bad aspect {c:?}"
                );
                prop_assert!(c.znear.is_finite() && c.znear > 0.0, "bad znear {c:?}");
            }
            for l in &scene.lights {
                prop_assert!(
                    l.position.is_finite() && l.direction.is_finite() && l.radiant.is_finite(),
                    "bad light {l:?}"
                );
                if let stereocache::scene::LightKind::Spot {
                    inner_cone,
                    outer_cone,
                } = l.kind
                {
                    prop_assert!(
                        0.0 <= inner_cone
                            && inner_cone < outer_cone
                            && outer_cone <= std::f32::consts::FRAC_PI_2,
                        "spot cone out of range {l:?}"
                    );
                }
            }
            for m in &scene.materials {
                prop_assert!(
                    m.base_color.is_finite() && m.emissive.is_finite(),
                    "bad material {m:?}"
                );
            }
            for w in &scene.warnings {
                prop_assert!(w.contains(file), "warning does not name {file}: {w}");
            }
        }
    }
    Ok(())
}

/// Replacement values for a JSON number: huge, negative, fractional, f32
/// overflow, integer overflow, wrong types.
fn json_replacement() -> impl Strategy<Value = Value> {
    use serde_json::json;
    prop::sample::select(vec![
        json!(0),
        json!(-1),
        json!(1),
        json!(2),
        json!(3),
        json!(7),
        json!(4_294_967_295u64),
        json!(4_294_967_296u64),
        json!(18_446_744_073_709_551_615u64),
        json!(-9_223_372_036_854_775_807i64),
        json!(1e39),
        json!(-1e39),
        json!(1e308),
        json!(3.4e38),
        json!(1e-45),
        json!(0.5),
        json!(-0.0),
        json!(5126),
        json!(5121),
        json!(5123),
        json!(5125),
        json!(34962),
        json!("NaN"),
        json!(null),
        json!([]),
        json!({}),
        json!(true),
    ])
}

/// All JSON pointers to leaves and containers of `v`.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                let p = format!("{at}/{}", k.replace('~', "~0").replace('/', "~1"));
                out.push(p.clone());
                pointers(c, p, out);
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                let p = format!("{at}/{i}");
                out.push(p.clone());
                pointers(c, p, out);
            }
        }
        _ => {}
    }
}

/// Extra members that a valid file could carry (so mutations reach the
/// camera, light, sparse and material code paths too).
fn enriched(mut v: Value) -> Value {
    use serde_json::json;
    v["nodes"][0]["translation"] = json!([0.0, 0.0, -2.0]);
    v["nodes"][0]["rotation"] = json!([0.0, 0.0, 0.0, 1.0]);
    v["nodes"][0]["scale"] = json!([1.0, 1.0, 1.0]);
    v["nodes"][0]["children"] = json!([1]);
    v["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "cam", "camera": 0, "translation": [0.0, 0.0, 3.0]}));
    v["cameras"] = json!([{"type": "perspective",
        "perspective": {"yfov": 0.8, "znear": 0.01, "zfar": 100.0, "aspectRatio": 1.5}}]);
    v["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    v["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "color": [1.0, 0.9, 0.8], "intensity": 10.0, "range": 5.0,
         "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}]}});
    v["nodes"][1]["extensions"] = json!({"KHR_lights_punctual": {"light": 0}});
    v["materials"] = json!([{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 0.5}, "emissiveFactor": [0.0, 0.0, 0.0]}]);
    v["meshes"][0]["primitives"][0]["material"] = json!(0);
    v["meshes"][0]["primitives"][0]["mode"] = json!(4);
    v
}

fn mutate_json(base: Value) -> impl Strategy<Value = Vec<u8>> {
    let mut ptrs = Vec::new();
    pointers(&base, String::new(), &mut ptrs);
    let edits = prop::collection::vec(
        (0usize..3, prop::sample::select(ptrs), json_replacement()),
        1..5,
    );
    edits.prop_map(move |edits| {
        let mut v = base.clone();
        for (kind, ptr, new) in edits {
            match kind {
                // Drop the member / element.
                0 => {
                    let (parent, last) = ptr.rsplit_once('/').unwrap();
                    match v.pointer_mut(parent) {
                        Some(Value::Object(m)) => {
                            m.remove(&last.replace("~1", "/").replace("~0", "~"));
                        }
                        Some(Value::Array(a)) => {
                            if let Ok(i) = last.parse::<usize>() {
                                if i < a.len() {
                                    a.remove(i);
                                }
                            }
                        }
                        _ => {}
                    }
                }
                // Replace (numbers most often: the interesting ones).
                _ => {
                    if let Some(slot) = v.pointer_mut(&ptr) {
                        *slot = new;
                    }
                }
            }
        }
        serde_json::to_vec(&v).unwrap()
    })
}

fn load_bytes(
    dir: &Path,
    name: &str,
    bytes: &[u8],
) -> Result<Scene, stereocache::scene::SceneError> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    load_gltf(&path)
}

#[test]
fn fuzz_bases_are_valid() {
    let dir = temp_dir("bases");
    load_bytes(&dir, "base.gltf", &valid_gltf()).unwrap();
    load_bytes(&dir, "base.glb", &valid_glb()).unwrap();
    let rich = enriched(serde_json::from_slice(&valid_gltf()).unwrap());
    let s = load_bytes(&dir, "rich.gltf", &serde_json::to_vec(&rich).unwrap()).unwrap();
    assert_eq!(s.cameras.len(), 1);
    assert_eq!(s.lights.len(), 1);
}

proptest! {
    #![proptest_config(cases(1500))]

    #[test]
    fn gltf_bytes_mutated(bytes in mutate_bytes(valid_gltf())) {
        let dir = temp_dir("gltf-bytes");
        check_scene(load_bytes(&dir, "mutated.gltf", &bytes), "mutated.gltf")?;
    }

    #[test]
    fn glb_bytes_mutated(bytes in mutate_bytes(valid_glb())) {
        let dir = temp_dir("glb-bytes");
        check_scene(load_bytes(&dir, "mutated.glb", &bytes), "mutated.glb")?;
    }

    #[test]
    fn gltf_json_mutated(bytes in mutate_json(enriched(serde_json::from_slice(&valid_gltf()).unwrap()))) {
        let dir = temp_dir("gltf-json");
        check_scene(load_bytes(&dir, "json.gltf", &bytes), "json.gltf")?;
    }

    #[test]
    fn glb_json_mutated(json in mutate_json(enriched({
        let g = valid_glb();
        let n = u32::from_le_bytes([g[12], g[13], g[14], g[15]]) as usize;
        serde_json::from_slice(&g[20..20 + n]).unwrap()
    }))) {
        let g = valid_glb();
        let n = u32::from_le_bytes([g[12], g[13], g[14], g[15]]) as usize;
        let bin = &g[20 + n + 8..];
        let dir = temp_dir("glb-json");
        check_scene(load_bytes(&dir, "json.glb", &glb(&json, bin)), "json.glb")?;
    }
}

// ------------------------------------------------ regressions (tests/data/fuzz)

fn fuzz_file(name: &str) -> PathBuf {
    data_dir().join("fuzz").join(name)
}

/// A component of 1e308 overflowed the quaternion norm to ∞ and the sample
/// became NaN; it is now normalized (with the renormalization warning).
#[test]
fn regression_huge_quaternion_csv() {
    let tr = PoseTrace::read_csv(fuzz_file("huge_quaternion.csv")).unwrap();
    let q = tr.samples[0].pose.orientation;
    assert!(q.is_finite() && (q.length() - 1.0).abs() < 1e-6, "{q:?}");
    assert!((q.w - 1.0).abs() < 1e-6);
    assert!(tr.warnings.iter().any(|w| w.contains("normalized")));
}

#[test]
fn regression_huge_quaternion_mmsys18() {
    let tr = stereocache::camera::read_mmsys18(
        fuzz_file("huge_quaternion_mmsys18.txt"),
        &Mmsys18Options::default(),
    )
    .unwrap();
    assert!(tr
        .samples
        .iter()
        .all(|s| s.pose.orientation.is_finite() && s.pose.position.is_finite()));
}

/// A position of 1e308 m (finite in f64) became ∞ in f32; now an error.
#[test]
fn regression_huge_position_csv() {
    let e = PoseTrace::read_csv(fuzz_file("huge_position.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("huge_position.csv:2:") && e.contains("`px`") && e.contains("out of range"),
        "{e}"
    );
}

/// `attributes.POSITION` pointing past the accessors made `gltf-json`'s
/// validation index out of bounds (a panic, caught as "failed internally").
#[test]
fn regression_dangling_position_accessor() {
    let e = load_gltf(&fuzz_file("dangling_position.gltf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("dangling_position.gltf"), "{e}");
    assert!(e.contains("POSITION refers to accessor 5126"), "{e}");
    assert!(!e.contains("failed internally"), "{e}");
}

/// A camera node with scale 0 gave a NaN camera transform, a negative yfov
/// was taken as is; both are now skipped with a warning naming the camera.
#[test]
fn regression_degenerate_cameras() {
    let s = load_gltf(&fuzz_file("degenerate_cameras.gltf")).unwrap();
    assert!(s.cameras.is_empty(), "{:?}", s.cameras);
    assert!(
        s.warnings.iter().any(|w| w.contains("degenerate")),
        "{:?}",
        s.warnings
    );
    assert!(
        s.warnings.iter().any(|w| w.contains("yfov -1")),
        "{:?}",
        s.warnings
    );
}

/// An image with neither `uri` nor `bufferView` (or a `bufferView` without
/// `mimeType`) made the `gltf` crate's `Image::source` unwrap inside an
/// image decoder thread: a panic message and backtrace on stderr, a vague
/// warning and exit 0. Now one error naming the file and the image.
#[test]
fn regression_image_without_source() {
    let dir = temp_dir("image-source");
    let cases = [
        (
            serde_json::json!({"name": "checker", "mimeType": "image/png"}),
            "images[0] 'checker' has neither `uri` nor `bufferView`",
        ),
        (
            serde_json::json!({"uri": null, "bufferView": null}),
            "images[0] has neither `uri` nor `bufferView`",
        ),
        (
            serde_json::json!({"bufferView": 0}),
            "images[0] has a `bufferView` but no `mimeType`",
        ),
    ];
    for (k, (image, want)) in cases.into_iter().enumerate() {
        let mut v: Value = serde_json::from_slice(&valid_gltf()).unwrap();
        v["images"] = serde_json::json!([image]);
        v["textures"] = serde_json::json!([{"source": 0}]);
        v["materials"] = serde_json::json!([
            {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
        ]);
        v["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
        let name = format!("image_source_{k}.gltf");
        let e = load_bytes(&dir, &name, &serde_json::to_vec(&v).unwrap())
            .err()
            .unwrap_or_else(|| panic!("{name} loaded"))
            .to_string();
        assert!(e.contains(&name) && e.contains(want), "{e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

/// A camera node translated to 3e38 m was accepted (black images); the
/// bound instances have (±1e15) applies to cameras, one error naming it.
#[test]
fn regression_far_away_camera() {
    let dir = temp_dir("far-camera");
    let mut v: Value = serde_json::from_slice(&valid_gltf()).unwrap();
    v["cameras"] =
        serde_json::json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}}]);
    v["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "eye", "camera": 0, "translation": [0, 3e38, 0]}));
    v["scenes"][0]["nodes"] = serde_json::json!([0, 1]);
    let e = load_bytes(&dir, "far.gltf", &serde_json::to_vec(&v).unwrap())
        .err()
        .unwrap_or_else(|| panic!("a camera at 3e38 m loaded"))
        .to_string();
    assert!(
        e.contains("far.gltf: camera 'eye' (node 1): its position reaches 3.000e38"),
        "{e}"
    );
}

/// Huge finite brightness (emissive strength 3e38, a light intensity of
/// 3e38, an RGBE texel at 1.7e38) rendered ∞ pixels and `"rse": null`
/// without a word; each is one error above `scene::MAX_EMISSION` (1e30).
#[test]
fn regression_emission_beyond_the_bound() {
    use serde_json::json;
    let dir = temp_dir("bright");
    let rich = enriched(serde_json::from_slice(&valid_gltf()).unwrap());
    let mut em = rich.clone();
    em["materials"][0]["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    em["materials"][0]["extensions"] =
        json!({"KHR_materials_emissive_strength": {"emissiveStrength": 3e38}});
    em["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_materials_emissive_strength"]);
    let e = load_bytes(&dir, "em.gltf", &serde_json::to_vec(&em).unwrap())
        .err()
        .unwrap_or_else(|| panic!("emission 3e38 loaded"))
        .to_string();
    assert!(
        e.starts_with(&format!("{}: material 0", dir.join("em.gltf").display()))
            && e.contains("beyond the brightest emission accepted (1e30 per channel)"),
        "{e}"
    );
    for intensity in [3e38, 1e39] {
        let mut li = rich.clone();
        li["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(intensity);
        let e = load_bytes(&dir, "li.gltf", &serde_json::to_vec(&li).unwrap())
            .err()
            .unwrap_or_else(|| panic!("light 3e38 loaded"))
            .to_string();
        assert!(
            e.contains("li.gltf: light 'cam': colour")
                && e.contains("beyond the brightest emission accepted"),
            "{e}"
        );
    }
    // Still accepted: 1e6 (a bright but real light).
    let mut ok = rich.clone();
    ok["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(1e6);
    load_bytes(&dir, "ok.gltf", &serde_json::to_vec(&ok).unwrap()).unwrap();
    // An environment map with one texel at 1.7e38 (finite in RGBE).
    let hdr = dir.join("sky.hdr");
    let mut px = vec![image::Rgb([0.5f32, 0.5, 0.5]); 8];
    px[5] = image::Rgb([1.7e38, 1.0, 1.0]);
    image::codecs::hdr::HdrEncoder::new(std::fs::File::create(&hdr).unwrap())
        .encode(&px, 4, 2)
        .unwrap();
    let e = stereocache::scene::env_map::load_env_map(&hdr)
        .err()
        .unwrap_or_else(|| panic!("a 1.7e38 texel loaded"))
        .to_string();
    assert!(
        e.contains("sky.hdr: texel (1, 1)") && e.contains("beyond the brightest emission"),
        "{e}"
    );
}
