//! Material graphs (issue 17): MaterialX import, errors, the CPU evaluator
//! against the standard library's own nodegraph definitions, and the
//! generated GLSL against the CPU evaluator.

mod common;

use common::*;
use std::path::PathBuf;
use stereocache::materials::graph::Source;
use stereocache::materials::signatures::{self, SIGNATURES};
use stereocache::materials::{compile, evaluate, harness, library, Document, Geom, Graph, Type};

/// The MaterialX Python package's `libraries/` folder, or
/// `$MATERIALX_LIBRARIES`. `scripts/setup.sh --test` installs the package into
/// the checkout's `.tools/venv`, whose interpreter is asked first, then
/// `python3`.
fn materialx_libraries() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MATERIALX_LIBRARIES") {
        return Some(PathBuf::from(p));
    }
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(".tools/venv/bin/python3");
    // The first interpreter that has the package (a venv made for other
    // packages may lack it).
    [venv, PathBuf::from("python3")]
        .into_iter()
        .find_map(|python| {
            let out = std::process::Command::new(python)
                .args([
                    "-c",
                    "import MaterialX, os; print(os.path.dirname(MaterialX.__file__))",
                ])
                .output()
                .ok()
                .filter(|o| o.status.success())?;
            let dir = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()).join("libraries");
            dir.join("stdlib/stdlib_defs.mtlx").exists().then_some(dir)
        })
}

fn mtlx_files(dir: &std::path::Path, out: &mut Vec<PathBuf>) {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    v.sort();
    for p in v {
        if p.is_dir() {
            mtlx_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "mtlx") {
            out.push(p);
        }
    }
}

/// A grid of surface points: uv over [−1.5, 2.5)² in steps of 1/8 + 1/64
/// (so both cell interiors and values past 1 are covered), positions over
/// a few units, unit normals and tangents perpendicular to them, a third
/// of them left-handed; object-space values of their own.
fn grid() -> Vec<Geom> {
    let mut v = Vec::new();
    for j in 0..24 {
        for i in 0..24 {
            let (u, w) = (
                -1.5 + i as f32 * (9.0 / 64.0),
                -1.5 + j as f32 * (9.0 / 64.0),
            );
            let a = (i * 7 + j * 3) as f32 * 0.1;
            let n = [a.cos() * 0.6, 0.8, a.sin() * 0.6];
            let t = [a.sin(), 0.0, -a.cos()];
            v.push(Geom {
                uv: [u, w],
                // Uv set 1 another affine map of the point, and its
                // derivative in set 0 (a shear and scale, turned over on
                // some points as a mirrored second set would be).
                uv1: [0.7 * u - 0.4 * w + 0.3, 0.2 * u + 1.3 * w - 0.6],
                uv1_per_uv: if (i + j) % 5 == 2 {
                    [[0.7, -0.2], [-0.4, -1.3]]
                } else {
                    [[0.7, 0.2], [-0.4, 1.3]]
                },
                position: [u * 1.7 - 0.3, w * 0.9 + 0.21, (u - w) * 1.3 + 0.05],
                normal: n,
                tangent: t,
                // Both handednesses (mirrored uv islands, back faces).
                tangent_sign: if (i + j) % 3 == 0 { -1.0 } else { 1.0 },
                footprint: 0.0,
                // Object space apart from world space (another map of the
                // same point, the frame's axes permuted, the handedness
                // turned over on other points), so a graph reading the
                // wrong space, or the harness passing the wrong one, differs.
                object: stereocache::materials::ObjectFrame {
                    position: [w * 1.1 + 0.4, u * 0.8 - 0.7, (u + w) * 0.6 - 0.2],
                    normal: [n[2], n[0], n[1]],
                    tangent: [t[2], t[0], t[1]],
                    tangent_sign: if (i + j) % 4 == 1 { -1.0 } else { 1.0 },
                },
            });
        }
    }
    v
}

fn err_of(text: &str) -> String {
    let doc = Document::parse("bad.mtlx", text).map_err(|e| e.to_string());
    match doc.and_then(|d| Graph::build_all(&d, &[]).map_err(|e| e.to_string())) {
        Ok(_) => panic!("document loaded:\n{text}"),
        Err(e) => e,
    }
}

fn wrap(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n<nodegraph name=\"g\">\n{body}\n</nodegraph>\n</materialx>\n")
}

/// Unknown node, bad type, cycle, missing input (node and interface), bad
/// value and bad XML: one line each, naming file, graph and node.
#[test]
fn malformed_documents_give_one_line_errors() {
    let cases: &[(&str, &[&str])] = &[
        (
            r#"<fancynoise name="n1" type="float" /><output name="out" type="float" nodename="n1" />"#,
            &["bad.mtlx:4: graph `g`, node `n1`: unknown node `fancynoise`"],
        ),
        (
            r#"<noise2d name="n1" type="float"><input name="texcoord" type="vector3" value="0,0,0" /></noise2d>
               <output name="out" type="float" nodename="n1" />"#,
            &["graph `g`, node `n1`: bad type: input `texcoord` is vector3"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" nodename="b" /></add>
               <add name="b" type="float"><input name="in1" type="float" nodename="a" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["graph `g`, node `a`: cycle: a -> b -> a"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" nodename="zz" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: missing input: `in1` refers to node `zz`"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" interfacename="k" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: missing input: `in1` refers to interface input `k`"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: missing input: `in1` has no value"],
        ),
        (
            r#"<add name="a" type="color3"><input name="in1" type="color3" value="1, 2" /></add>
               <output name="out" type="color3" nodename="a" />"#,
            &["node `a`: input `in1`: bad color3 value"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" value="1" /></add>
               <multiply name="m" type="color3"><input name="in1" type="color3" nodename="a" /></multiply>
               <output name="out" type="color3" nodename="m" />"#,
            &["node `m`: bad type: input `in1` is color3, its source is float"],
        ),
        (
            // Same width, different type: MaterialX's validate() refuses
            // it ("Mismatched types in port connection").
            r#"<position name="p" type="vector3" />
               <multiply name="m" type="color3"><input name="in1" type="color3" nodename="p" /></multiply>
               <output name="out" type="color3" nodename="m" />"#,
            &["node `m`: bad type: input `in1` is color3, its source is vector3"],
        ),
        (
            // An integer interface input into a float input.
            r#"<input name="k" type="integer" value="2" />
               <add name="a" type="float"><input name="in1" type="float" interfacename="k" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: bad type: input `in1` is float, its source is integer"],
        ),
        (
            r#"<position name="p" type="vector3" />
               <output name="out" type="color3" nodename="p" />"#,
            &["graph `g`: bad type: output `out` is color3, its source is vector3"],
        ),
        (
            // Graphs see two uv sets; a third is not read as another.
            r#"<texcoord name="t" type="vector2"><input name="index" type="integer" value="2" /></texcoord>
               <output name="out" type="vector2" nodename="t" />"#,
            &["graph `g`, node `t`: input `index` is 2: only texture coordinate sets 0 and 1"],
        ),
        (
            // MaterialX's spaces are model, object and world.
            r#"<position name="p" type="vector3"><input name="space" type="string" value="camera" /></position>
               <output name="out" type="vector3" nodename="p" />"#,
            &["graph `g`, node `p`: input `space` is `camera`: one of model, object or world"],
        ),
        (
            r#"<tangent name="t" type="vector3"><input name="index" type="integer" value="2" /></tangent>
               <output name="out" type="vector3" nodename="t" />"#,
            &["graph `g`, node `t`: input `index` is 2: only tangent set 0"],
        ),
        (
            r#"<place2d name="p" type="vector2"><input name="operationorder" type="integer" value="2" /></place2d>
               <output name="out" type="vector2" nodename="p" />"#,
            &["graph `g`, node `p`: input `operationorder` is 2; 0 (SRT) or 1 (TRS)"],
        ),
        (
            r#"<add name="a" type="float"><input name="bogus" type="float" value="1" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: node `add` has no input `bogus`"],
        ),
        (
            r#"<add name="a" type="float">"#,
            &["bad.mtlx: not a valid XML document"],
        ),
        (
            // An empty value is no number (it read as 0: a fractal of 0
            // octaves, a black colour, without a word).
            r#"<add name="a" type="color3"><input name="in1" type="color3" value="" /></add>
               <output name="out" type="color3" nodename="a" />"#,
            &["node `a`: input `in1`: bad color3 value: empty"],
        ),
        (
            r#"<fractal3d name="f" type="float"><input name="octaves" type="integer" value=" " /></fractal3d>
               <output name="out" type="float" nodename="f" />"#,
            &["node `f`: input `octaves`: bad integer value: empty"],
        ),
        (
            // An integer, but not a 32-bit one (it said "not an integer").
            r#"<fractal3d name="f" type="float"><input name="octaves" type="integer" value="99999999999" /></fractal3d>
               <output name="out" type="float" nodename="f" />"#,
            &["input `octaves`: bad integer value: `99999999999` is out of the 32-bit integer range"],
        ),
        (
            r#"<add name="a" type="float"><input name="in1" type="float" value="nan" /></add>
               <output name="out" type="float" nodename="a" />"#,
            &["node `a`: input `in1`: bad float value: `nan` is not a finite number"],
        ),
        (
            // Finite as text, infinite as f32.
            r#"<add name="a" type="color3"><input name="in1" type="color3" value="1e39, 0, 0" /></add>
               <output name="out" type="color3" nodename="a" />"#,
            &["node `a`: input `in1`: bad color3 value: `1e39` is not a finite number"],
        ),
    ];
    for (body, want) in cases {
        let e = err_of(&wrap(body));
        assert_eq!(e.lines().count(), 1, "one line: {e}");
        assert!(e.starts_with("bad.mtlx"), "names the file: {e}");
        for w in *want {
            assert!(e.contains(w), "error `{e}` lacks `{w}`");
        }
    }
}

/// Documents built to exhaust the stack (the XML parser and the graph's
/// placement recurse once per level) are refused with one line instead:
/// elements nested 20,000 deep, and a chain of 10,000 nodes each reading
/// the next. A chain of 500 (the limit is 512) still loads.
#[test]
fn hostile_depths_are_refused_not_overflowed() {
    let nested = format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{}{}</materialx>\n",
        "<a>".repeat(20_000),
        "</a>".repeat(20_000)
    );
    let e = err_of(&nested);
    assert!(
        e.starts_with("bad.mtlx") && e.contains("elements nest deeper than 256 levels (line 3)"),
        "{e}"
    );
    let chain = |n: usize| {
        let mut body = String::from(
            r#"<constant name="n0" type="float"><input name="value" type="float" value="1" /></constant>"#,
        );
        for i in 1..n {
            body.push_str(&format!(
                r#"<add name="n{i}" type="float"><input name="in1" type="float" nodename="n{}" /><input name="in2" type="float" value="1" /></add>"#,
                i - 1
            ));
        }
        body.push_str(&format!(
            r#"<output name="out" type="float" nodename="n{}" />"#,
            n - 1
        ));
        wrap(&body)
    };
    let e = err_of(&chain(10_000));
    assert!(
        e.contains("reads through a chain of more than 512 nodes"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1, "{e}");
    let doc = Document::parse("ok.mtlx", &chain(500)).unwrap();
    let graphs = Graph::build_all(&doc, &[]).unwrap_or_else(|e| panic!("{e}"));
    let v = evaluate(&graphs[0], &grid()[0]);
    assert_eq!(v[0].channels(), &[500.0]);
}

/// Every graph of scenes/materials loads, has tens of nodes and noise.
#[test]
fn shipped_library_loads_with_realistic_cost() {
    let graphs = library::load_all().unwrap_or_else(|e| panic!("{e}"));
    assert!(graphs.len() >= 12, "{} graphs", graphs.len());
    for g in &graphs {
        let noise = g
            .nodes
            .iter()
            .filter(|n| n.op().contains("noise") || n.op() == "fractal3d")
            .count();
        assert!(g.nodes.len() >= 15, "{}: {} nodes", g.name, g.nodes.len());
        assert!(noise >= 1, "{}: no noise", g.name);
        let base = g
            .output("base_color")
            .unwrap_or_else(|| panic!("{}: no base_color", g.name));
        assert_eq!(base.ty, Type::Color3);
        for p in grid() {
            for (o, v) in g.outputs.iter().zip(evaluate(g, &p)) {
                assert!(
                    v.channels().iter().all(|x| x.is_finite()),
                    "{} {}: {v:?} at {p:?}",
                    g.name,
                    o.name
                );
            }
        }
    }
}

/// The signature table equals the nodedefs of the package's stdlib_defs.mtlx
/// (names, node, output type, input names, types and defaults).
#[test]
fn signatures_match_the_materialx_stdlib() {
    let Some(lib) = materialx_libraries() else {
        require(false, "the MaterialX Python package (scripts/setup.sh)");
        return;
    };
    let doc = Document::load(&lib.join("stdlib/stdlib_defs.mtlx")).unwrap();
    for s in SIGNATURES {
        let nd = doc
            .nodedefs
            .iter()
            .find(|d| d.name == s.def)
            .unwrap_or_else(|| panic!("{} not in stdlib_defs", s.def));
        assert_eq!(nd.node, s.node, "{}", s.def);
        assert_eq!(nd.outputs.len(), 1, "{}", s.def);
        assert_eq!(nd.outputs[0].ty.as_deref(), Some(s.out.name()), "{}", s.def);
        let ins: Vec<(String, String, String)> = nd
            .inputs
            .iter()
            .map(|p| {
                let d = match (&p.value, &p.defaultgeomprop) {
                    (Some(v), _) => v.clone(),
                    (None, Some(g)) => format!("@{g}"),
                    (None, None) => String::new(),
                };
                (p.name.clone(), p.ty.clone().unwrap_or_default(), d)
            })
            .collect();
        let mine: Vec<(String, String, String)> = s
            .inputs
            .iter()
            .map(|(n, t, d)| (n.to_string(), t.name().to_string(), d.to_string()))
            .collect();
        assert_eq!(ins, mine, "{}", s.def);
    }
}

/// The MaterialX package's documents: every nodegraph whose nodes all have
/// a supported signature loads (typed and ordered), and where such a graph
/// defines a supported node (`nodedef=`), the node evaluated directly equals
/// the library's graph on the grid; the GLSL of all of them equals the CPU.
#[test]
fn materialx_package_graphs_with_supported_nodes_load_and_match_their_nodes() {
    let Some(lib) = materialx_libraries() else {
        require(false, "the MaterialX Python package (scripts/setup.sh)");
        return;
    };
    let mut files = Vec::new();
    mtlx_files(&lib, &mut files);
    let docs: Vec<Document> = files
        .iter()
        .map(|f| Document::load(f).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    let defs: Vec<&Document> = docs.iter().collect();
    let (mut loaded, mut compared) = (0, 0);
    let mut all = Vec::new();
    for doc in &docs {
        for raw in &doc.graphs {
            let supported = raw.nodes.iter().all(|n| {
                n.ty.as_deref().and_then(Type::from_name).is_some_and(|t| {
                    signatures::candidates(&n.category, t).any(|s| {
                        n.inputs.iter().all(|p| {
                            s.input(&p.name)
                                .is_some_and(|(_, want, _)| p.ty.as_deref() == Some(want.name()))
                        })
                    })
                }) && n
                    .inputs
                    .iter()
                    .all(|p| p.output.is_none() && p.nodegraph.is_none())
                    && n.category != "image"
            }) && raw.outputs.iter().all(|o| {
                o.ty.as_deref()
                    .and_then(Type::from_name)
                    .is_some_and(|t| t.is_varying())
            });
            if !supported {
                continue;
            }
            let g = Graph::build(doc, &raw.name, &defs).unwrap_or_else(|e| panic!("{e}"));
            loaded += 1;
            all.push(g.clone());
            let Some(nd) = raw
                .nodedef
                .as_deref()
                .and_then(|d| SIGNATURES.iter().find(|s| s.def == d))
            else {
                continue;
            };
            // The node itself, all inputs at their defaults.
            let text = format!(
                "<materialx version=\"1.39\"><nodegraph name=\"direct\"><{0} name=\"n\" type=\"{1}\" /><output name=\"out\" type=\"{1}\" nodename=\"n\" /></nodegraph></materialx>",
                nd.node,
                nd.out.name()
            );
            let direct_doc = Document::parse("direct.mtlx", &text).unwrap();
            let direct = Graph::build(&direct_doc, "direct", &[]).unwrap_or_else(|e| panic!("{e}"));
            for p in grid() {
                let (a, b) = (evaluate(&g, &p)[0], evaluate(&direct, &p)[0]);
                for (x, y) in a.channels().iter().zip(b.channels()) {
                    // Same operations in the same order: equal to one rounding of each input's magnitude.
                    assert!(
                        (x - y).abs() <= 2.0 * f32::EPSILON * x.abs().max(1.0),
                        "{} vs node {}: {a:?} != {b:?} at {p:?}",
                        raw.name,
                        nd.def
                    );
                }
            }
            compared += 1;
        }
    }
    eprintln!("{loaded} MaterialX library graphs loaded, {compared} compared with their node");
    assert!(
        loaded >= 10 && compared >= 1,
        "{loaded} loaded, {compared} compared"
    );
    // And the GLSL of every one of them equals the CPU.
    assert_gpu_equals_cpu(&all);
}

/// Topological order: every node reads only earlier nodes.
#[test]
fn nodes_are_ordered_from_the_outputs() {
    for g in library::load_all().unwrap() {
        for (i, n) in g.nodes.iter().enumerate() {
            for s in &n.inputs {
                if let Source::Node(j) = s {
                    assert!(*j < i, "{}: node {} reads later node {j}", g.name, n.name);
                }
            }
        }
    }
}

/// The on-disk cache: a second compile of the same text is a cache hit with
/// the same SPIR-V; another text compiles anew.
#[test]
fn compiled_spirv_is_cached_by_content() {
    let dir = std::env::temp_dir().join(format!("stereocache-spv-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let src = "#version 460\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
    let a = compile::compile_in(&dir, "t", src).unwrap();
    let b = compile::compile_in(&dir, "t", src).unwrap();
    assert!(!a.cached && b.cached);
    assert_eq!(a.spirv, b.spirv);
    assert_eq!(a.path, b.path);
    let c = compile::compile_in(&dir, "t", &src.replace("{}", "{ }")).unwrap();
    assert!(!c.cached && c.path != a.path);
    let e = compile::compile_in(&dir, "t", "#version 460\nvoid main() { nope; }\n").unwrap_err();
    assert!(
        e.contains("glslc failed") && e.contains("exit status"),
        "{e}"
    );
    // A damaged cache file (cut short mid-instruction, as a full disk can
    // leave it: the header and the first word of the first two-word
    // instruction) is not a hit: it is compiled again and replaced (it
    // failed every later run as "malformed SPIR-V" until session 48).
    std::fs::write(&a.path, &a.spirv[..24]).unwrap();
    let d = compile::compile_in(&dir, "t", src).unwrap();
    assert!(!d.cached && d.spirv == a.spirv && d.path == a.path);
    assert!(compile::compile_in(&dir, "t", src).unwrap().cached);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The generated GLSL of every shipped graph (and of the library graphs of
/// the package test) evaluated by a compute shader equals the CPU evaluator
/// on the grid.
#[test]
fn glsl_evaluation_equals_the_cpu_evaluator() {
    assert_gpu_equals_cpu(&library::load_all().unwrap());
}

/// Graphs per harness kernel in [`assert_gpu_equals_cpu`].
const GRAPHS_PER_PIPELINE: usize = 40;

/// Evaluates `graphs` on the GPU (harness) and the CPU at the grid; every
/// float agrees within TOLERANCE (NaN only where both are NaN).
fn assert_gpu_equals_cpu(graphs: &[Graph]) {
    let ctx = context();
    let points = grid();
    // One pipeline per GRAPHS_PER_PIPELINE graphs: a single kernel with all
    // 300+ signature graphs inlined into one main costs lavapipe (LLVM) far
    // more than the same code in parts, and is not served from Mesa's shader
    // cache (measured: 48 s CPU whole, 9 s in parts of 40 with warm caches,
    // 32 s cold). Every graph is still evaluated at every point.
    let mut gpu = Vec::new();
    for part in graphs.chunks(GRAPHS_PER_PIPELINE) {
        let (g, _) = harness::evaluate(&ctx, part, &points).unwrap_or_else(|e| panic!("{e}"));
        gpu.extend(g);
    }
    let mut worst = (0.0f32, String::new());
    let mut bad = Vec::new();
    for (g, vals) in graphs.iter().zip(&gpu) {
        for (p, got) in points.iter().zip(vals) {
            let want: Vec<f32> = evaluate(g, p)
                .iter()
                .flat_map(|v| v.channels().to_vec())
                .collect();
            assert_eq!(want.len(), got.len(), "{}", g.name);
            for (k, (x, y)) in want.iter().zip(got).enumerate() {
                // NaN only where both are NaN, an infinity only where both
                // are the same one (∞/∞ was NaN, and NaN > TOLERANCE is
                // false: a GPU 0 against a CPU +∞ passed).
                let err = match (x.is_nan(), y.is_nan()) {
                    (true, true) => 0.0,
                    (false, false) if x == y => 0.0,
                    (false, false) if x.is_infinite() || y.is_infinite() => f32::INFINITY,
                    (false, false) => (x - y).abs() / x.abs().max(1.0),
                    _ => f32::INFINITY,
                };
                let what = || format!("{} float {k} at {p:?}: cpu {x} gpu {y}", g.name);
                if err > worst.0 {
                    worst = (err, what());
                }
                if err > TOLERANCE {
                    bad.push(what());
                }
            }
        }
    }
    eprintln!("largest relative difference {:e}: {}", worst.0, worst.1);
    assert!(
        bad.is_empty(),
        "{} value(s) differ:\n{}",
        bad.len(),
        bad[..bad.len().min(30)].join("\n")
    );
    assert_no_validation_messages(&ctx);
}

/// One graph per supported signature: the node with each float/vector input
/// connected to its own varying source (positive, distinct per input, from
/// position and uv), `direct_<ND>`; integer and string inputs at their defaults.
fn one_node_graphs() -> Vec<Graph> {
    let mut text = String::from("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n");
    let mut names = Vec::new();
    // Nodes with no float/vector input (convert_integer_float, ...) are constants, folded at load.
    let varying = |s: &&signatures::Sig| {
        s.inputs.iter().any(|i| i.1.is_varying())
            || matches!(s.node, "texcoord" | "position" | "normal" | "tangent")
    };
    for s in SIGNATURES
        .iter()
        .filter(|s| s.node != "image")
        .filter(varying)
    {
        let mut g = format!("<nodegraph name=\"direct_{}\">\n", s.def);
        g.push_str(
            "<position name=\"p\" type=\"vector3\" /><texcoord name=\"t\" type=\"vector2\" />\n",
        );
        let mut inputs = String::new();
        for (k, (name, ty, default)) in s.inputs.iter().enumerate() {
            if !ty.is_varying() {
                // Declared, so the overload is the one under test (ifgreater_floatI, ...).
                inputs.push_str(&format!(
                    "<input name=\"{name}\" type=\"{ty}\" value=\"{default}\" />"
                ));
                continue;
            }
            let c = 0.5 + 0.37 * k as f32;
            // Base sources: |p| + 0.25 (vector3) and |t| + 0.25 (vector2).
            g.push_str(&format!(
                "<absval name=\"pa{k}\" type=\"vector3\"><input name=\"in\" type=\"vector3\" nodename=\"p\" /></absval>\n\
                 <add name=\"v{k}\" type=\"vector3\"><input name=\"in1\" type=\"vector3\" nodename=\"pa{k}\" /><input name=\"in2\" type=\"float\" value=\"{c}\" /></add>\n\
                 <absval name=\"ta{k}\" type=\"vector2\"><input name=\"in\" type=\"vector2\" nodename=\"t\" /></absval>\n\
                 <add name=\"w{k}\" type=\"vector2\"><input name=\"in1\" type=\"vector2\" nodename=\"ta{k}\" /><input name=\"in2\" type=\"float\" value=\"{c}\" /></add>\n"
            ));
            let src = match ty {
                Type::Vector3 => format!("v{k}"),
                Type::Vector2 => format!("w{k}"),
                Type::Float => {
                    g.push_str(&format!("<extract name=\"s{k}\" type=\"float\"><input name=\"in\" type=\"vector3\" nodename=\"v{k}\" /><input name=\"index\" type=\"integer\" value=\"{}\" /></extract>\n", k % 3));
                    format!("s{k}")
                }
                t => {
                    g.push_str(&format!("<convert name=\"s{k}\" type=\"{t}\"><input name=\"in\" type=\"vector3\" nodename=\"v{k}\" /></convert>\n"));
                    format!("s{k}")
                }
            };
            inputs.push_str(&format!(
                "<input name=\"{name}\" type=\"{ty}\" nodename=\"{src}\" />"
            ));
        }
        g.push_str(&format!("<{0} name=\"n\" type=\"{1}\">{inputs}</{0}>\n<output name=\"out\" type=\"{1}\" nodename=\"n\" />\n</nodegraph>\n", s.node, s.out));
        text.push_str(&g);
        names.push(format!("direct_{}", s.def));
    }
    text.push_str("</materialx>\n");
    let doc = Document::parse("one_node_graphs.mtlx", &text).unwrap();
    names
        .iter()
        .map(|n| Graph::build(&doc, n, &[]).unwrap_or_else(|e| panic!("{e}")))
        .collect()
}

/// Every supported signature, its node fed by varying inputs: the GLSL equals
/// the CPU evaluator on the grid (NaN where both are NaN: ln, sqrt and pow
/// are fed positive values, so none is expected).
#[test]
fn glsl_equals_the_cpu_for_every_signature() {
    let graphs = one_node_graphs();
    assert!(graphs.len() > 300, "{}", graphs.len());
    for g in &graphs {
        let n = g
            .nodes
            .last()
            .unwrap_or_else(|| panic!("{}: no nodes, outputs {:?}", g.name, g.outputs));
        assert_eq!(
            format!("direct_{}", n.sig.def),
            g.name,
            "the node under test is not folded away: {:?}",
            g.nodes.iter().map(|n| n.sig.def).collect::<Vec<_>>()
        );
    }
    assert_gpu_equals_cpu(&graphs);
}

/// Relative tolerance (of max(1, |value|)) for GLSL against the CPU: 64 ulp.
/// Additions, subtractions and multiplications are correctly rounded and
/// unfused on both sides (`precise`), so they agree exactly; the difference
/// comes from the GPU built-ins that are not (division, sqrt, sin/cos, pow,
/// exp, log: a few ulp each on llvmpipe). An output passes through at most
/// about eight of them, each error at most 4 ulp and amplified at most 2x by
/// the arithmetic after it: 8 * 4 * 2 = 64 ulp = 64 * 2^-23.
const TOLERANCE: f32 = 64.0 * f32::EPSILON;

/// A document of one graph `g` per body (`g0`, `g1`, …), built.
fn graphs_of(bodies: &[&str]) -> Vec<Graph> {
    let mut text = String::from("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n");
    for (i, b) in bodies.iter().enumerate() {
        text.push_str(&format!("<nodegraph name=\"g{i}\">\n{b}\n</nodegraph>\n"));
    }
    text.push_str("</materialx>\n");
    let doc = Document::parse("audit.mtlx", &text).unwrap_or_else(|e| panic!("{e}"));
    Graph::build_all(&doc, &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn first_output(g: &Graph, p: &Geom) -> Vec<f32> {
    evaluate(g, p)[0].channels().to_vec()
}

fn assert_close(got: &[f32], want: &[f32], tol: f32, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (x, y) in got.iter().zip(want) {
        assert!((x - y).abs() <= tol, "{what}: {got:?} != {want:?}");
    }
}

/// hsvadjust as MaterialX's graph (NG_hsvadjust_color3 → mx_hsvtorgb):
/// a saturation below 0.0001 — here scaled to 0 or below — is grey
/// (v, v, v), not the sector formula's overshoot ((1, 0, 0) desaturated
/// by amount (0, −1, 1) was (1, 2, 2)); a saturation above 1 is not
/// clamped (MaterialX's graph does not clamp either).
#[test]
fn hsvadjust_is_grey_below_materialx_saturation_threshold() {
    let g = graphs_of(&[
        r#"<hsvadjust name="h" type="color3"><input name="in" type="color3" value="1, 0, 0" /><input name="amount" type="vector3" value="0, -1, 1" /></hsvadjust><output name="out" type="color3" nodename="h" />"#,
        r#"<hsvadjust name="h" type="color3"><input name="in" type="color3" value="0.8, 0.2, 0.4" /><input name="amount" type="vector3" value="0.25, 0, 0.5" /></hsvadjust><output name="out" type="color3" nodename="h" />"#,
        r#"<hsvadjust name="h" type="color4"><input name="in" type="color4" value="0.6, 0.3, 0.3, 0.5" /><input name="amount" type="vector3" value="0, 0.00005, 1" /></hsvadjust><output name="out" type="color4" nodename="h" />"#,
        r#"<hsvadjust name="h" type="color3"><input name="in" type="color3" value="1, 0.5, 0.5" /><input name="amount" type="vector3" value="0, 3, 1" /></hsvadjust><output name="out" type="color3" nodename="h" />"#,
    ]);
    let p = Geom::default();
    assert_eq!(first_output(&g[0], &p), [1.0, 1.0, 1.0]);
    assert_eq!(first_output(&g[1], &p), [0.4, 0.4, 0.4]);
    assert_eq!(first_output(&g[2], &p), [0.6, 0.6, 0.6, 0.5]);
    // s = 0.5·3 = 1.5, hue 0: (v, v(1 − s), v(1 − s)), unclamped.
    assert_eq!(first_output(&g[3], &p), [1.0, -0.5, -0.5]);
}

/// ramp4 and remap against the definitions written out by hand, with
/// inputs that tell every corner and bound apart (the library-graph
/// comparison feeds the nodes their all-zero defaults, and the
/// every-signature run a texcoord past 1, clamped to one corner):
/// ramp4 is NG_ramp4's mix(mix(bl, br, s), mix(tl, tr, s), t) of the
/// texcoord (s, t) clamped to [0, 1]² — corners tl = 1, tr = 2, bl = 3,
/// br = 4 give 3 + s − 2t, and the colour overload its corners' blend per
/// channel; remap is the genglsl source's outlow + (in − inlow)(outhigh −
/// outlow) / (inhigh − inlow), the float-argument (FA) overload with the
/// bounds broadcast. Over the grid's uvs in [−1.5, 1.73]² (inside and
/// outside the clamp), CPU within 4 ulp of the f64 formula (one mix chain
/// or one division), and the GLSL equal to the CPU.
#[test]
fn ramp4_and_remap_follow_their_definitions() {
    let g = graphs_of(&[
        r#"<ramp4 name="r" type="float"><input name="valuetl" type="float" value="1" /><input name="valuetr" type="float" value="2" /><input name="valuebl" type="float" value="3" /><input name="valuebr" type="float" value="4" /></ramp4><output name="out" type="float" nodename="r" />"#,
        r#"<ramp4 name="r" type="color3"><input name="valuetl" type="color3" value="1, 0, 0" /><input name="valuetr" type="color3" value="0, 1, 0" /><input name="valuebl" type="color3" value="0, 0, 1" /><input name="valuebr" type="color3" value="1, 1, 1" /></ramp4><output name="out" type="color3" nodename="r" />"#,
        r#"<texcoord name="t" type="vector2" /><extract name="x" type="float"><input name="in" type="vector2" nodename="t" /><input name="index" type="integer" value="0" /></extract><remap name="m" type="float"><input name="in" type="float" nodename="x" /><input name="inlow" type="float" value="0.5" /><input name="inhigh" type="float" value="2.5" /><input name="outlow" type="float" value="10" /><input name="outhigh" type="float" value="20" /></remap><output name="out" type="float" nodename="m" />"#,
        r#"<texcoord name="t" type="vector2" /><remap name="m" type="vector2"><input name="in" type="vector2" nodename="t" /><input name="inlow" type="float" value="0.5" /><input name="inhigh" type="float" value="2.5" /><input name="outlow" type="float" value="-1" /><input name="outhigh" type="float" value="3" /></remap><output name="out" type="vector2" nodename="m" />"#,
    ]);
    let mix = |a: f64, b: f64, m: f64| a + (b - a) * m;
    let remap = |x: f64, il: f64, ih: f64, ol: f64, oh: f64| ol + (x - il) * (oh - ol) / (ih - il);
    let close = |got: &[f32], want: &[f64], what: &str| {
        assert_eq!(got.len(), want.len(), "{what}");
        for (x, y) in got.iter().zip(want) {
            let tol = 4.0 * f32::EPSILON as f64 * y.abs().max(1.0);
            assert!((*x as f64 - y).abs() <= tol, "{what}: {got:?} != {want:?}");
        }
    };
    let (mut inside, mut clamped) = (0, 0);
    for p in grid() {
        let (u, v) = (p.uv[0] as f64, p.uv[1] as f64);
        let (s, t) = (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0));
        if s == u && t == v {
            inside += 1;
        } else {
            clamped += 1;
        }
        let at = format!("uv {:?}", p.uv);
        close(
            &first_output(&g[0], &p),
            &[3.0 + s - 2.0 * t],
            &format!("ramp4 float, {at}"),
        );
        let corners = [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let want: Vec<f64> = (0..3)
            .map(|c| {
                let top = mix(corners[0][c], corners[1][c], s);
                let bottom = mix(corners[2][c], corners[3][c], s);
                mix(bottom, top, t)
            })
            .collect();
        close(
            &first_output(&g[1], &p),
            &want,
            &format!("ramp4 color3, {at}"),
        );
        close(
            &first_output(&g[2], &p),
            &[remap(u, 0.5, 2.5, 10.0, 20.0)],
            &format!("remap float, {at}"),
        );
        close(
            &first_output(&g[3], &p),
            &[remap(u, 0.5, 2.5, -1.0, 3.0), remap(v, 0.5, 2.5, -1.0, 3.0)],
            &format!("remap vector2FA, {at}"),
        );
    }
    assert!(
        inside > 20 && clamped > 20,
        "{inside} inside, {clamped} clamped"
    );
    assert_gpu_equals_cpu(&g);
}

/// normalmap maps an all-zero input to the unperturbed normal N (MaterialX's
/// mx_normalmap: "no data" is tangent-space (0, 0, 1)); it was
/// normalize(−T − B − N).
#[test]
fn normalmap_of_zero_is_the_unperturbed_normal() {
    let g = graphs_of(&[
        r#"<normalmap name="n" type="vector3"><input name="in" type="vector3" value="0, 0, 0" /></normalmap><output name="out" type="vector3" nodename="n" />"#,
    ]);
    for p in grid() {
        assert_close(&first_output(&g[0], &p), &p.normal, 1e-6, "normalmap(0)");
    }
}

/// power: CPU and GPU agree where GLSL's pow is undefined; a negative base
/// with an integer exponent is the real power, with any other exponent 0;
/// 0^y is 0 (y > 0), +∞ (y < 0), x⁰ = 1.
#[test]
fn power_is_defined_for_negative_bases() {
    let g = graphs_of(&[
        r#"<power name="p" type="vector4"><input name="in1" type="vector4" value="-2, -2, -2, -0.5" /><input name="in2" type="vector4" value="2, 3, 0.5, -3" /></power><output name="out" type="vector4" nodename="p" />"#,
        r#"<power name="p" type="vector3"><input name="in1" type="vector3" value="0, 0, -3" /><input name="in2" type="vector3" value="2, -1, 0" /></power><output name="out" type="vector3" nodename="p" />"#,
    ]);
    let p = Geom::default();
    assert_eq!(first_output(&g[0], &p), [4.0, -8.0, 0.0, -8.0]);
    assert_eq!(first_output(&g[1], &p), [0.0, f32::INFINITY, 1.0]);
}

/// heighttonormal as MaterialX 1.39: the gradient is taken with respect to
/// the `texcoord` input (not the geometric uv) and scaled by scale/16
/// (the reference implementation's Sobel parity factor); a mirrored
/// texcoord still gives n.z > 0. h = t.x of t = (4u, v) with scale 16:
/// ∂h/∂t.x = 1, out = normalize(−1, 0, 1)·½ + ½ (it was normalize(−4, 0, 1)).
#[test]
fn heighttonormal_differentiates_in_its_texcoord_with_the_sobel_scale() {
    let enc = |n: [f32; 3]| {
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        n.map(|c| c / l * 0.5 + 0.5)
    };
    let g = graphs_of(&[
        // Texcoord (4u, v), height t.x, scale 16.
        r#"<texcoord name="uv" type="vector2" />
           <multiply name="t" type="vector2"><input name="in1" type="vector2" nodename="uv" /><input name="in2" type="vector2" value="4, 1" /></multiply>
           <extract name="h" type="float"><input name="in" type="vector2" nodename="t" /><input name="index" type="integer" value="0" /></extract>
           <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="16" /><input name="texcoord" type="vector2" nodename="t" /></heighttonormal>
           <output name="out" type="vector3" nodename="n" />"#,
        // The default texcoord (UV0), height v, scale 1.
        r#"<texcoord name="uv" type="vector2" />
           <extract name="h" type="float"><input name="in" type="vector2" nodename="uv" /><input name="index" type="integer" value="1" /></extract>
           <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /></heighttonormal>
           <output name="out" type="vector3" nodename="n" />"#,
        // A mirrored texcoord (1 − u, v): h = t.x rises along t.x.
        r#"<texcoord name="uv" type="vector2" />
           <subtract name="m" type="vector2"><input name="in1" type="vector2" value="1, 0" /><input name="in2" type="vector2" nodename="uv" /></subtract>
           <multiply name="t" type="vector2"><input name="in1" type="vector2" nodename="m" /><input name="in2" type="vector2" value="1, -1" /></multiply>
           <extract name="h" type="float"><input name="in" type="vector2" nodename="t" /><input name="index" type="integer" value="0" /></extract>
           <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="8" /><input name="texcoord" type="vector2" nodename="t" /></heighttonormal>
           <output name="out" type="vector3" nodename="n" />"#,
    ]);
    for p in grid() {
        assert_close(
            &first_output(&g[0], &p),
            &enc([-1.0, 0.0, 1.0]),
            1e-5,
            "(4u, v)",
        );
        assert_close(
            &first_output(&g[1], &p),
            &enc([0.0, -1.0 / 16.0, 1.0]),
            1e-5,
            "UV0",
        );
        assert_close(
            &first_output(&g[2], &p),
            &enc([-0.5, 0.0, 1.0]),
            1e-5,
            "mirrored",
        );
    }
}

/// The audit's cases with varying inputs, GLSL against the CPU on the grid:
/// hsvadjust through the grey threshold, normalmap of a zero input, power
/// of negative and zero bases (constant and varying exponents, integer and
/// not), heighttonormal with a connected texcoord (scaled, rotated and
/// mirrored) and with the uv.
#[test]
fn audit_cases_glsl_equals_the_cpu() {
    let g = graphs_of(&[
        // Saturation scaled by x ∈ [−2.9, 2.7] (grey where x < 1e-4).
        r#"<position name="p" type="vector3" />
           <extract name="x" type="float"><input name="in" type="vector3" nodename="p" /><input name="index" type="integer" value="0" /></extract>
           <absval name="c0" type="vector3"><input name="in" type="vector3" nodename="p" /></absval>
           <convert name="c" type="color3"><input name="in" type="vector3" nodename="c0" /></convert>
           <combine3 name="a" type="vector3"><input name="in1" type="float" value="0.3" /><input name="in2" type="float" nodename="x" /><input name="in3" type="float" value="0.7" /></combine3>
           <hsvadjust name="h" type="color3"><input name="in" type="color3" nodename="c" /><input name="amount" type="vector3" nodename="a" /></hsvadjust>
           <output name="out" type="color3" nodename="h" />"#,
        // normalmap of p·0 (±0 in every channel).
        r#"<position name="p" type="vector3" />
           <multiply name="z" type="vector3"><input name="in1" type="vector3" nodename="p" /><input name="in2" type="float" value="0" /></multiply>
           <normalmap name="n" type="vector3"><input name="in" type="vector3" nodename="z" /><input name="scale" type="float" value="0.5" /></normalmap>
           <output name="out" type="vector3" nodename="n" />"#,
        // Negative bases: exponents 2, 3, 0.5, −1 and floor(3y) (varying integers).
        r#"<position name="p" type="vector3" />
           <power name="a" type="vector4"><input name="in1" type="vector4" nodename="p4" /><input name="in2" type="vector4" value="2, 3, 0.5, -1" /></power>
           <convert name="p4" type="vector4"><input name="in" type="vector3" nodename="p" /></convert>
           <extract name="y" type="float"><input name="in" type="vector3" nodename="p" /><input name="index" type="integer" value="1" /></extract>
           <multiply name="y3" type="float"><input name="in1" type="float" nodename="y" /><input name="in2" type="float" value="3" /></multiply>
           <floor name="k" type="float"><input name="in" type="float" nodename="y3" /></floor>
           <power name="b" type="vector4"><input name="in1" type="vector4" nodename="p4" /><input name="in2" type="float" nodename="k" /></power>
           <add name="s" type="vector4"><input name="in1" type="vector4" nodename="a" /><input name="in2" type="vector4" nodename="b" /></add>
           <output name="out" type="vector4" nodename="s" />"#,
        // A zero base (x − x) to exponents of both signs.
        r#"<position name="p" type="vector3" />
           <subtract name="z" type="vector3"><input name="in1" type="vector3" nodename="p" /><input name="in2" type="vector3" nodename="p" /></subtract>
           <power name="a" type="vector3"><input name="in1" type="vector3" nodename="z" /><input name="in2" type="vector3" value="2, 0, -1" /></power>
           <output name="out" type="vector3" nodename="a" />"#,
        // heighttonormal of a noise through a scaled, rotated texcoord.
        r#"<texcoord name="uv" type="vector2" />
           <place2d name="t" type="vector2"><input name="texcoord" type="vector2" nodename="uv" /><input name="scale" type="vector2" value="0.5, 2" /><input name="rotate" type="float" value="30" /></place2d>
           <noise2d name="h" type="float"><input name="texcoord" type="vector2" nodename="t" /></noise2d>
           <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="4" /><input name="texcoord" type="vector2" nodename="t" /></heighttonormal>
           <output name="out" type="vector3" nodename="n" />"#,
        // … through a mirrored texcoord, and with the uv.
        r#"<texcoord name="uv" type="vector2" />
           <multiply name="t" type="vector2"><input name="in1" type="vector2" nodename="uv" /><input name="in2" type="vector2" value="-3, 1" /></multiply>
           <noise2d name="h" type="float"><input name="texcoord" type="vector2" nodename="t" /></noise2d>
           <heighttonormal name="n" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="4" /><input name="texcoord" type="vector2" nodename="t" /></heighttonormal>
           <heighttonormal name="n2" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="16" /></heighttonormal>
           <add name="s" type="vector3"><input name="in1" type="vector3" nodename="n" /><input name="in2" type="vector3" nodename="n2" /></add>
           <output name="out" type="vector3" nodename="s" />"#,
    ]);
    // The cases are reached on the grid.
    let pts = grid();
    let grey = pts
        .iter()
        .filter(|p| {
            let v = first_output(&g[0], p);
            v[0] == v[1] && v[1] == v[2]
        })
        .count();
    assert!(grey > 50 && grey < pts.len() - 50, "{grey} grey points");
    // `position` reads object space (MaterialX's default).
    let negative = pts
        .iter()
        .filter(|p| p.object.position[0] < 0.0 && p.object.position[2] < 0.0)
        .count();
    assert!(negative > 50, "{negative} points with negative bases");
    assert_gpu_equals_cpu(&g);
}

/// The spaces of the geometry nodes (MaterialX: `space` "object" by
/// default, "model" the same here, "world"; `defaultgeomprop` names of
/// both): on the CPU each output is its field of the point, the bitangent
/// cross(N, T)·w of its own space's frame; the GPU equals the CPU.
#[test]
fn geometry_nodes_read_the_space_they_name() {
    let space = |node: &str, name: &str, sp: &str| {
        format!(
            r#"<{node} name="{name}" type="vector3"><input name="space" type="string" value="{sp}" /></{node}>"#
        )
    };
    let mut body = String::from(
        r#"<input name="bo" type="vector3" defaultgeomprop="Bobject" />
           <input name="bw" type="vector3" defaultgeomprop="Bworld" />
           <input name="pd" type="vector3" defaultgeomprop="Pobject" />
           <position name="p" type="vector3" /><normal name="n" type="vector3" /><tangent name="t" type="vector3" />"#,
    );
    for (node, short) in [("position", "p"), ("normal", "n"), ("tangent", "t")] {
        for sp in ["object", "model", "world"] {
            body.push_str(&space(node, &format!("{short}_{sp}"), sp));
        }
    }
    let outs = [
        "p", "n", "t", "p_object", "p_model", "p_world", "n_object", "n_model", "n_world",
        "t_object", "t_model", "t_world",
    ];
    for o in outs {
        body.push_str(&format!(
            r#"<output name="o_{o}" type="vector3" nodename="{o}" />"#
        ));
    }
    for i in ["bo", "bw", "pd"] {
        body.push_str(&format!(
            r#"<output name="o_{i}" type="vector3" interfacename="{i}" />"#
        ));
    }
    let g = graphs_of(&[&body]);
    let pts = grid();
    for p in &pts {
        let vals: Vec<Vec<f32>> = evaluate(&g[0], p)
            .iter()
            .map(|v| v.channels().to_vec())
            .collect();
        let o = &p.object;
        let b = |n: [f32; 3], t: [f32; 3], w: f32| {
            (glam::Vec3::from(n).cross(glam::Vec3::from(t)) * w).to_array()
        };
        let want: [[f32; 3]; 15] = [
            o.position,
            o.normal,
            o.tangent,
            o.position,
            o.position,
            p.position,
            o.normal,
            o.normal,
            p.normal,
            o.tangent,
            o.tangent,
            p.tangent,
            b(o.normal, o.tangent, o.tangent_sign),
            b(p.normal, p.tangent, p.tangent_sign),
            o.position,
        ];
        for (k, w) in want.iter().enumerate() {
            assert_close(&vals[k], w, 1e-6, &format!("output {k} at {p:?}"));
        }
    }
    assert_gpu_equals_cpu(&g);
}

/// `texcoord` index 0 and 1 read uv sets 0 and 1 (as vector2 and
/// vector3), and heighttonormal's central differences move set 1 with set
/// 0 along the surface (`Geom::uv1_per_uv`, J). For a height linear in set
/// 1, h = a·u₁ + b·v₁, the gradient in set 1 is (a, b) whatever J is,
/// and in set 0 it is Jᵀ(a, b): the normals are the analytic
/// normalize(−s·σ·∇h, 1) (s the scale, σ the Sobel scale), to f32
/// rounding of the differences (h is exactly linear, so only the
/// rounding of uv ± step and of h remain: a few ulps of |h| over the
/// 2·step of the difference). The GPU equals the CPU.
#[test]
fn texcoord_index_reads_its_set_and_differences_move_both() {
    let body = r#"<texcoord name="t0" type="vector2" />
        <texcoord name="t1" type="vector2"><input name="index" type="integer" value="1" /></texcoord>
        <texcoord name="t13" type="vector3"><input name="index" type="integer" value="1" /></texcoord>
        <dotproduct name="h" type="float"><input name="in1" type="vector2" nodename="t1" /><input name="in2" type="vector2" value="0.8, -1.7" /></dotproduct>
        <heighttonormal name="n1" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="4.0" /><input name="texcoord" type="vector2" nodename="t1" /></heighttonormal>
        <heighttonormal name="n0" type="vector3"><input name="in" type="float" nodename="h" /><input name="scale" type="float" value="4.0" /></heighttonormal>
        <output name="o_t0" type="vector2" nodename="t0" />
        <output name="o_t1" type="vector2" nodename="t1" />
        <output name="o_t13" type="vector3" nodename="t13" />
        <output name="o_n1" type="vector3" nodename="n1" />
        <output name="o_n0" type="vector3" nodename="n0" />"#;
    let g = graphs_of(&[body]);
    assert_eq!(g[0].uv_sets(), 3, "reads both sets");
    assert!(
        !g[0].reads_only_uv(),
        "set 1 is not memoizable by set 0's texel"
    );
    let (a, b, scale) = (0.8f32, -1.7f32, 4.0f32);
    let sigma = stereocache::materials::eval::HEIGHT_SOBEL_SCALE;
    let normal = |grad: [f32; 2]| {
        let n =
            glam::Vec3::new(-scale * sigma * grad[0], -scale * sigma * grad[1], 1.0).normalize();
        (n * 0.5 + 0.5).to_array()
    };
    let step = stereocache::materials::eval::HEIGHT_STEP;
    for p in &grid() {
        let vals: Vec<Vec<f32>> = evaluate(&g[0], p)
            .iter()
            .map(|v| v.channels().to_vec())
            .collect();
        assert_eq!(vals[0], p.uv.to_vec(), "set 0 at {p:?}");
        assert_eq!(vals[1], p.uv1.to_vec(), "set 1 at {p:?}");
        assert_eq!(vals[2], vec![p.uv1[0], p.uv1[1], 0.0], "set 1 as vector3");
        let j = p.uv1_per_uv;
        let grad0 = [a * j[0][0] + b * j[0][1], a * j[1][0] + b * j[1][1]];
        // Rounding: |h| and |uv1| up to ~6 here, f32 ulps of that over the
        // 2·step difference, times s·σ (the normal's slope per unit height
        // gradient), a few times over.
        let tol = 8.0 * 6.0 * f32::EPSILON / (2.0 * step) * scale * sigma;
        assert_close(
            &vals[3],
            &normal([a, b]),
            tol,
            &format!("∇ in set 1 at {p:?}"),
        );
        assert_close(
            &vals[4],
            &normal(grad0),
            tol,
            &format!("∇ in set 0 at {p:?}"),
        );
    }
    assert_gpu_equals_cpu(&g);
}

/// The measured contrast of the noises (docs/MATERIALS.md "Noise
/// amplitude"): noise2d's RMS over 400k points of a 2000² uv square is
/// 0.266 (MaterialX's reference Perlin noise: 0.319, with its 0.6616 2D
/// gradient scale), noise3d's likewise without MaterialX's 0.9820 3D scale.
#[test]
fn noise_contrast_is_the_documented_one() {
    use stereocache::materials::noise;
    let mut s = 0x9e37_79b9u32;
    let mut next = || {
        s = noise::pcg(s);
        (s >> 8) as f32 / (1u32 << 24) as f32 * 2000.0 - 1000.0
    };
    let n = 400_000;
    let (mut s2, mut s3) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let (x, y, z) = (next(), next(), next());
        s2 += (noise::perlin2([x, y], 0) as f64).powi(2);
        s3 += (noise::perlin3([x, y, z], 0) as f64).powi(2);
    }
    let (r2, r3) = ((s2 / n as f64).sqrt(), (s3 / n as f64).sqrt());
    eprintln!("noise2d rms {r2:.4}, noise3d rms {r3:.4}");
    assert!((r2 - 0.266).abs() < 0.005, "noise2d rms {r2}");
    assert!(r3 > 0.1 && r3 < 0.5, "noise3d rms {r3}");
}

/// Two GPU/CPU disagreements an audit found. (1) A constant that folding
/// makes non-finite (divide(1, 0) = +∞, sqrt(−1) = NaN) was written into
/// GLSL as 0.0, so a varying sum with it was u on the GPU and +∞ / NaN on
/// the CPU; the GLSL now carries the same bits. (2) hsvadjust of a hue
/// just below 0 (−10⁻⁸): x − floor(x) rounds to 1.0, sector 6, which fell to
/// the last sector: pure red came out magenta, (1, 0, 1); hue 0 is red.
/// Both graphs take a varying 0 (0·u) so they are evaluated on the GPU, not
/// folded on the CPU; the harness checks every float at the grid.
#[test]
fn folded_non_finite_constants_and_a_hue_just_below_zero_agree_on_gpu_and_cpu() {
    let g = graphs_of(&[
        r#"<texcoord name="uv" type="vector2" />
           <extract name="u" type="float"><input name="in" type="vector2" nodename="uv" /><input name="index" type="integer" value="0" /></extract>
           <divide name="inf" type="float"><input name="in1" type="float" value="1" /><input name="in2" type="float" value="0" /></divide>
           <sqrt name="nan" type="float"><input name="in" type="float" value="-1" /></sqrt>
           <add name="a" type="float"><input name="in1" type="float" nodename="inf" /><input name="in2" type="float" nodename="u" /></add>
           <add name="b" type="float"><input name="in1" type="float" nodename="nan" /><input name="in2" type="float" nodename="u" /></add>
           <subtract name="c" type="float"><input name="in1" type="float" nodename="u" /><input name="in2" type="float" nodename="inf" /></subtract>
           <combine3 name="o" type="vector3"><input name="in1" type="float" nodename="a" /><input name="in2" type="float" nodename="b" /><input name="in3" type="float" nodename="c" /></combine3>
           <output name="out" type="vector3" nodename="o" />"#,
        r#"<texcoord name="uv" type="vector2" />
           <extract name="u" type="float"><input name="in" type="vector2" nodename="uv" /><input name="index" type="integer" value="0" /></extract>
           <multiply name="z" type="float"><input name="in1" type="float" nodename="u" /><input name="in2" type="float" value="0" /></multiply>
           <add name="hue" type="float"><input name="in1" type="float" nodename="z" /><input name="in2" type="float" value="-1e-8" /></add>
           <combine3 name="amount" type="vector3"><input name="in1" type="float" nodename="hue" /><input name="in2" type="float" value="1" /><input name="in3" type="float" value="1" /></combine3>
           <hsvadjust name="h" type="color3"><input name="in" type="color3" value="1, 0, 0" /><input name="amount" type="vector3" nodename="amount" /></hsvadjust>
           <output name="out" type="color3" nodename="h" />"#,
    ]);
    let p = Geom::default();
    let v = first_output(&g[0], &p);
    assert!(
        v[0] == f32::INFINITY && v[1].is_nan() && v[2] == f32::NEG_INFINITY,
        "{v:?}"
    );
    assert_eq!(first_output(&g[1], &p), [1.0, 0.0, 0.0]);
    assert_gpu_equals_cpu(&g);
}
