//! Scene import, generators and the glTF writer, CPU only.

use std::path::{Path, PathBuf};
use stereocache::scene::load_gltf;

fn sponza_path() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/scenes/sponza/Sponza.gltf"
    ))
}

#[test]
fn sponza_loads_with_warnings() {
    let path = sponza_path();
    if !path.exists() {
        eprintln!(
            "skipped: ../shared not present ({} missing)",
            path.display()
        );
        return;
    }
    let t = std::time::Instant::now();
    let scene = load_gltf(&path).expect("Sponza loads");
    eprintln!(
        "Sponza: {:?}, {} triangles, {} textures, {} warnings",
        t.elapsed(),
        scene.instanced_triangle_count(),
        scene.textures.len(),
        scene.warnings.len()
    );
    for w in &scene.warnings {
        eprintln!("  {w}");
    }
    assert!(scene.instanced_triangle_count() > 200_000);
    let all = scene.warnings.join("\n");
    assert!(all.contains("AMD_split_roughnessMetallic"), "{all}");
    assert!(all.contains("sponza_curtain_diff.png"), "{all}");
    let _ = Path::new("");
}
