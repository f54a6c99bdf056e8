//! Compiles every compute shader under `shaders/` to SPIR-V with glslc
//! (`--target-env=vulkan1.2 -O`). A shader that includes `common/rt.glsl`
//! traces rays and is compiled twice, with `-DRT_QUERY` and `-DRT_SOFTWARE`.
//! A shader with a line `// variant: SUBGROUP_OPS` is also compiled with
//! `-DSUBGROUP_OPS` as `NAME.subgroup` (subgroup arithmetic and ballot, for
//! devices that support them; the plain build is the fallback), and one
//! with `// variant: MEMO_CLOCK_COUNTER` with `-DMEMO_CLOCK_COUNTER` as
//! `NAME.counter` (the memoization table's 64-bit access clock).
//! A glslc error is printed with its file and line and stops the build.
//! Before compiling, the shader interface written in Rust (src/interface/)
//! becomes one GLSL header per group, `OUT_DIR/interface/<group>.glsl`, on
//! glslc's include path: binding numbers, push-constant fields, counter
//! slots and specialization-constant ids come from one place.
//! For shaders recompiled at run time (a scene's material graphs,
//! src/materials/scene_shaders.rs) the table also embeds every shader source,
//! every interface header and each variant's (source, defines).

#[allow(dead_code)]
#[path = "src/interface/mod.rs"]
mod interface;

use std::path::{Path, PathBuf};
use std::process::Command;

/// Every file under `dir` whose extension is one of `exts`, sorted by path.
fn collect(dir: &Path, exts: &[&str], out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = rd.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            collect(&p, exts, out);
        } else if p.extension().is_some_and(|e| exts.iter().any(|x| e == *x)) {
            out.push(p);
        }
    }
}

/// True when `file` includes `common/rt.glsl`, directly or through other includes.
fn traces_rays(file: &Path, root: &Path, seen: &mut Vec<PathBuf>) -> bool {
    if seen.iter().any(|p| p == file) {
        return false;
    }
    seen.push(file.to_path_buf());
    let text = std::fs::read_to_string(file).unwrap_or_default();
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("#include"))
        .any(|rest| {
            let name = rest.trim().trim_matches('"');
            name == "common/rt.glsl" || traces_rays(&root.join(name), root, seen)
        })
}

fn main() {
    println!("cargo:rerun-if-changed=shaders");
    println!("cargo:rerun-if-changed=src/interface");
    println!("cargo:rerun-if-env-changed=GLSLC");
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let shader_dir = root.join("shaders");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let header_dir = out_dir.join("interface");
    std::fs::create_dir_all(&header_dir).unwrap();
    let headers: Vec<(&str, String)> = interface::ALL
        .iter()
        .map(|i| (i.name, interface::glsl::header(i)))
        .chain([("frame", interface::glsl::frame_header())])
        .collect();
    for (name, text) in &headers {
        let path = header_dir.join(format!("{name}.glsl"));
        // Rewritten only when changed, so glslc's inputs keep their times.
        if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            std::fs::write(&path, text).unwrap();
        }
    }
    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());

    let mut sources = Vec::new();
    collect(&shader_dir, &["comp"], &mut sources);

    // (name, source, defines)
    let mut jobs: Vec<(String, PathBuf, Vec<&str>)> = Vec::new();
    for src in &sources {
        let rel = src.strip_prefix(&shader_dir).unwrap().with_extension("");
        let name = rel.to_string_lossy().replace('\\', "/");
        let text = std::fs::read_to_string(src).unwrap_or_default();
        let mut variants = vec![(name.clone(), vec![])];
        for (line, suffix, define) in [
            ("// variant: SUBGROUP_OPS", "subgroup", "-DSUBGROUP_OPS"),
            (
                "// variant: MEMO_CLOCK_COUNTER",
                "counter",
                "-DMEMO_CLOCK_COUNTER",
            ),
        ] {
            if text.lines().any(|l| l.trim() == line) {
                variants.push((format!("{name}.{suffix}"), vec![define]));
            }
        }
        let rt = traces_rays(src, &shader_dir, &mut Vec::new());
        for (name, defs) in variants {
            if rt {
                for (suffix, def) in [("query", "-DRT_QUERY"), ("software", "-DRT_SOFTWARE")] {
                    let mut d = defs.clone();
                    d.push(def);
                    jobs.push((format!("{name}.{suffix}"), src.clone(), d));
                }
            } else {
                jobs.push((name, src.clone(), defs));
            }
        }
    }

    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(2);
    let chunks: Vec<Vec<(String, PathBuf, Vec<&str>)>> = {
        let mut c: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
        for (i, j) in jobs.iter().cloned().enumerate() {
            c[i % threads].push(j);
        }
        c
    };
    let failures: Vec<String> = std::thread::scope(|s| {
        let handles: Vec<_> = chunks
            .into_iter()
            .map(|chunk| {
                let glslc = glslc.clone();
                let out_dir = out_dir.clone();
                let shader_dir = shader_dir.clone();
                s.spawn(move || {
                    let mut errs = Vec::new();
                    for (name, src, defs) in chunk {
                        let out = out_dir.join(format!("{}.spv", name.replace('/', "__")));
                        let res = Command::new(&glslc)
                            .arg("--target-env=vulkan1.2")
                            .arg("-O")
                            .arg("-fshader-stage=compute")
                            .arg("-I")
                            .arg(&shader_dir)
                            .arg("-I")
                            .arg(&out_dir)
                            .args(&defs)
                            .arg(&src)
                            .arg("-o")
                            .arg(&out)
                            .output();
                        match res {
                            Err(e) => errs.push(format!("cannot run glslc ({e}); install it with scripts/setup.sh or set GLSLC")),
                            Ok(o) if !o.status.success() => errs.push(format!(
                                "glslc failed on {} ({}):\n{}{}",
                                src.display(),
                                defs.join(" "),
                                String::from_utf8_lossy(&o.stdout),
                                String::from_utf8_lossy(&o.stderr)
                            )),
                            Ok(_) => {}
                        }
                    }
                    errs
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("{f}");
        }
        eprintln!("error: {} shader(s) failed to compile", failures.len());
        std::process::exit(1);
    }

    let mut table = String::from(
        "/// (name, SPIR-V) of every compiled shader.\npub static SHADERS: &[(&str, &[u8])] = &[\n",
    );
    for (name, _, _) in &jobs {
        let file = out_dir.join(format!("{}.spv", name.replace('/', "__")));
        table.push_str(&format!(
            "    ({name:?}, include_bytes!({:?})),\n",
            file.to_string_lossy()
        ));
    }
    table.push_str("];\n");
    table.push_str(
        "/// (variant name, source under shaders/, glslc defines) of every compiled shader.\n\
         pub static VARIANTS: &[(&str, &str, &[&str])] = &[\n",
    );
    for (name, src, defs) in &jobs {
        let rel = src.strip_prefix(&shader_dir).unwrap();
        let rel = rel.to_string_lossy().replace('\\', "/");
        table.push_str(&format!("    ({name:?}, {rel:?}, &{defs:?}),\n"));
    }
    table.push_str("];\n");
    table.push_str(
        "/// (path under shaders/, text) of every shader source and include.\n\
         pub static SOURCES: &[(&str, &str)] = &[\n",
    );
    let mut all = Vec::new();
    collect(&shader_dir, &["comp", "glsl"], &mut all);
    for f in &all {
        let rel = f.strip_prefix(&shader_dir).unwrap();
        let rel = rel.to_string_lossy().replace('\\', "/");
        table.push_str(&format!(
            "    ({rel:?}, include_str!({:?})),\n",
            f.to_string_lossy()
        ));
    }
    table.push_str("];\n");
    table.push_str(
        "/// (include name, text) of the generated interface headers (`interface/<group>.glsl`).\n\
         pub static HEADERS: &[(&str, &str)] = &[\n",
    );
    for (name, _) in &headers {
        let file = header_dir.join(format!("{name}.glsl"));
        table.push_str(&format!(
            "    (\"interface/{name}.glsl\", include_str!({:?})),\n",
            file.to_string_lossy()
        ));
    }
    table.push_str("];\n");
    std::fs::write(out_dir.join("shaders.rs"), table).unwrap();
}
