//! GLSL -> SPIR-V at scene load with glslc (the tool build.rs uses; `GLSLC`
//! overrides it), cached on disk by content hash: the cache file is
//! `<dir>/<hash>.spv` with `<dir>` = `$STEREOCACHE_SHADER_CACHE`, else
//! `$XDG_CACHE_HOME/stereocache/spirv`, else `$HOME/.cache/stereocache/spirv`
//! (else the system temporary directory). The hash covers the whole
//! compiled text (the node library is inlined, no include path), the
//! glslc arguments and the compiler (`GLSLC` and its `--version`), so an
//! edit of a graph, of the node library or of the arguments, or another
//! glslc, compiles anew. Files are written to a temporary name and
//! renamed, so concurrent loads never read a half-written file; a cached
//! file that is not a whole module (a write cut short) is compiled again,
//! and a build glslc could only make unoptimized is marked and warned
//! about on every load.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The node library, inlined into every generated shader.
pub const NOISE_GLSL: &str = include_str!("../../shaders/materialx/noise.glsl");
pub const NODES_GLSL: &str = include_str!("../../shaders/materialx/nodes.glsl");

/// The node library as one text (nodes.glsl with noise.glsl in place of its include).
pub fn library() -> String {
    NODES_GLSL.replace("#include \"materialx/noise.glsl\"", NOISE_GLSL)
}

const ARGS: &[&str] = &["--target-env=vulkan1.2", "-O", "-fshader-stage=compute"];

/// The arguments of the second attempt when the optimizer runs out of
/// SPIR-V ids ("ID overflow": spirv-opt inlines every function, and a
/// shader that calls compute-heavy graphs from many sites — material_at,
/// the memo's fills, light sampling — exceeds the id bound), or crashes
/// (killed by a signal: Debian 12's glslc 2023.2 did, after minutes, on
/// the subgroup-cooperative memo fill of the procedural-heavy Sponza until
/// session 36, at `-O` and `-Os` alike, while `-O0` compiled it in a
/// fraction of a second; the same id overflow underneath, which spirv-opt
/// 2023.1 reports before crashing the same way, docs/PERFORMANCE.md; one
/// evaluation site per call and no light-sampling site without emission
/// graphs fixed that shader). Unoptimized SPIR-V is valid and the driver's
/// compiler optimizes it anyway.
const ARGS_UNOPTIMIZED: &[&str] = &["--target-env=vulkan1.2", "-O0", "-fshader-stage=compute"];

/// Which compiler a cached binary came from, part of every cache key: the
/// `GLSLC` setting and that glslc's `--version` output (run once per
/// process). Without it an upgraded or re-pointed glslc reused the binaries
/// of the old one (session 48's audit).
fn compiler_id() -> &'static str {
    static ID: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    ID.get_or_init(|| {
        let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
        let version = Command::new(&glslc)
            .arg("--version")
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_else(|e| format!("unavailable ({e})"));
        format!("GLSLC={glslc}\n{version}")
    })
}

/// The marker beside a cached binary that glslc built unoptimized (its
/// optimizer failed on the shader: [`ARGS_UNOPTIMIZED`]).
fn unoptimized_marker(spv: &Path) -> PathBuf {
    spv.with_extension("unoptimized")
}

/// The cache directory (see the module docs).
pub fn cache_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("STEREOCACHE_SHADER_CACHE") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(d).join("stereocache/spirv");
    }
    if let Some(h) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
        return PathBuf::from(h).join(".cache/stereocache/spirv");
    }
    std::env::temp_dir().join("stereocache-spirv")
}

/// 128-bit content hash (two FNV-1a 64 streams with different offsets), hex.
pub fn content_hash(parts: &[&str]) -> String {
    let mut a: u64 = 0xcbf2_9ce4_8422_2325;
    let mut b: u64 = 0x6c62_272e_07bb_0142;
    for p in parts {
        for &byte in p.as_bytes().iter().chain(&[0xffu8]) {
            a = (a ^ byte as u64).wrapping_mul(0x0000_0100_0000_01b3);
            b = (b ^ byte as u64)
                .wrapping_mul(0x0000_0100_0000_01b3)
                .rotate_left(5);
        }
    }
    format!("{a:016x}{b:016x}")
}

/// Outcome of [`compile`].
#[derive(Debug)]
pub struct Compiled {
    pub spirv: Vec<u8>,
    pub path: PathBuf,
    /// Whether the SPIR-V came from the cache.
    pub cached: bool,
}

/// The SPIR-V stored at `spv` by an earlier compile, if it is whole: the
/// magic number, whole words and a stream of whole instructions with the
/// entry point's bindings readable (`gpu::reflect`). A damaged file (a
/// write cut short by a full disk) is removed, so it is compiled again
/// instead of failing every later run. A binary glslc built unoptimized
/// says so on every load (its timings are not the optimized build's).
fn cached(what: &str, spv: &Path) -> Option<Compiled> {
    let bytes = std::fs::read(spv).ok()?;
    let whole = bytes.len() >= 20
        && bytes.len() % 4 == 0
        && bytes[..4] == [0x03, 0x02, 0x23, 0x07]
        && crate::gpu::reflect::reflect(&bytes).is_ok();
    if !whole {
        eprintln!(
            "warning: {what}: the cached SPIR-V {} is damaged; compiling it again",
            spv.display()
        );
        let _ = std::fs::remove_file(spv);
        return None;
    }
    if unoptimized_marker(spv).exists() {
        eprintln!(
            "warning: {what}: the cached build {} is unoptimized (glslc's optimizer failed on it; the driver optimizes it, timings may differ)",
            spv.display()
        );
    }
    Some(Compiled {
        spirv: bytes,
        path: spv.to_path_buf(),
        cached: true,
    })
}

/// A name part no other compile of this or another process uses, so
/// concurrent compiles never write the same temporary file.
fn unique_tag() -> String {
    static SEQ: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let seq = SEQ.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    format!("{}-{seq}", std::process::id())
}

/// Compiles a compute shader's GLSL text (`what` names it in errors).
pub fn compile(what: &str, source: &str) -> Result<Compiled, String> {
    compile_in(&cache_dir(), what, source)
}

pub fn compile_in(dir: &Path, what: &str, source: &str) -> Result<Compiled, String> {
    let mut parts = vec![source];
    parts.extend_from_slice(ARGS);
    parts.push(compiler_id());
    let hash = content_hash(&parts);
    let spv = dir.join(format!("{hash}.spv"));
    if let Some(hit) = cached(what, &spv) {
        return Ok(hit);
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        format!(
            "{what}: cannot create the shader cache {} ({e})",
            dir.display()
        )
    })?;
    let tag = unique_tag();
    let src = dir.join(format!("{hash}.{tag}.comp"));
    let tmp = dir.join(format!("{hash}.{tag}.spv.tmp"));
    std::fs::write(&src, source)
        .map_err(|e| format!("{what}: cannot write {} ({e})", src.display()))?;
    let res = run_glslc(what, &[src.as_os_str()], &src, &tmp, &spv);
    if res.is_ok() {
        let _ = std::fs::remove_file(&src);
    }
    res
}

/// Compiles `main` (a path inside the source tree `files`: (path, text)
/// pairs written under `<dir>/tree-<hash>/`, glslc's include path) with
/// `defines` (`-DNAME`), cached like [`compile_in`] by the hash of the whole
/// tree, `main`, the defines and the arguments.
pub fn compile_tree(
    dir: &Path,
    what: &str,
    files: &[(&str, &str)],
    main: &str,
    defines: &[&str],
) -> Result<Compiled, String> {
    let mut parts: Vec<&str> = Vec::new();
    for (p, t) in files {
        parts.push(p);
        parts.push(t);
    }
    let tree_hash = content_hash(&parts);
    let mut key = vec![tree_hash.as_str(), main];
    key.extend_from_slice(defines);
    key.extend_from_slice(ARGS);
    key.push(compiler_id());
    let hash = content_hash(&key);
    let spv = dir.join(format!("{hash}.spv"));
    if let Some(hit) = cached(what, &spv) {
        return Ok(hit);
    }
    let tag = unique_tag();
    let tree = dir.join(format!("tree-{tree_hash}"));
    if !tree.is_dir() {
        // Written under a temporary name and renamed: a half-written tree is never used.
        let tmp_tree = dir.join(format!("tree-{tree_hash}.{tag}.tmp"));
        let write = || -> std::io::Result<()> {
            for (p, t) in files {
                let f = tmp_tree.join(p);
                std::fs::create_dir_all(f.parent().unwrap_or(&tmp_tree))?;
                std::fs::write(f, t)?;
            }
            Ok(())
        };
        write().map_err(|e| {
            format!(
                "{what}: cannot write the shader sources to {} ({e})",
                tmp_tree.display()
            )
        })?;
        if std::fs::rename(&tmp_tree, &tree).is_err() {
            // Another process renamed its copy first: same content.
            let _ = std::fs::remove_dir_all(&tmp_tree);
        }
    }
    let tmp = dir.join(format!("{hash}.{tag}.spv.tmp"));
    let shown = tree.join(main);
    let mut args = vec![std::ffi::OsStr::new("-I"), tree.as_os_str()];
    args.extend(defines.iter().map(std::ffi::OsStr::new));
    args.push(shown.as_os_str());
    run_glslc(what, &args, &shown, &tmp, &spv)
}

/// Runs glslc with [`ARGS`], `args` and `-o tmp`, then stores its output as
/// `spv` and returns it; `shown` names the source in errors. `tmp` is
/// removed either way, so a failed compile leaves no SPIR-V behind.
fn run_glslc(
    what: &str,
    args: &[&std::ffi::OsStr],
    shown: &Path,
    tmp: &Path,
    spv: &Path,
) -> Result<Compiled, String> {
    let glslc = std::env::var("GLSLC").unwrap_or_else(|_| "glslc".into());
    let run = |base: &[&str]| {
        Command::new(&glslc)
            .args(base)
            .args(args)
            .arg("-o")
            .arg(tmp)
            .output()
    };
    let mut out = run(ARGS);
    let mut unoptimized = false;
    if let Ok(o) = &out {
        use std::os::unix::process::ExitStatusExt;
        let overflow = String::from_utf8_lossy(&o.stderr).contains("ID overflow");
        if !o.status.success() && (overflow || o.status.signal().is_some()) {
            eprintln!(
                "warning: {what}: glslc's optimizer {} ({}); compiling it unoptimized \
                 (the driver optimizes it; timings may differ)",
                if overflow {
                    "ran out of SPIR-V ids"
                } else {
                    "crashed"
                },
                o.status
            );
            out = run(ARGS_UNOPTIMIZED);
            unoptimized = true;
        }
    }
    let res = match out {
        Err(e) => Err(format!(
            "{what}: cannot run glslc ({e}); install it with scripts/setup.sh or set GLSLC"
        )),
        Ok(o) if !o.status.success() => Err(format!(
            "{what}: glslc failed ({}, {}):\n{}{}",
            shown.display(),
            o.status,
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )),
        Ok(_) => std::fs::rename(tmp, spv)
            .map_err(|e| format!("{what}: cannot store {} ({e})", spv.display())),
    };
    let _ = std::fs::remove_file(tmp);
    res?;
    // The marker goes with the binary it describes (a later optimized build
    // of the same key would come from another glslc: another key).
    if unoptimized {
        let _ = std::fs::write(unoptimized_marker(spv), "");
    }
    let spirv =
        std::fs::read(spv).map_err(|e| format!("{what}: cannot read {} ({e})", spv.display()))?;
    Ok(Compiled {
        spirv,
        path: spv.to_path_buf(),
        cached: false,
    })
}
