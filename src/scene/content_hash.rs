//! A 64-bit FNV-1a hash of everything in a loaded scene that can change its
//! images: geometry, instances, materials, textures, lights, environment,
//! animation and material graphs — not its name, cameras or warnings. The
//! reference cache keys on it (src/evaluate.rs), so an edited `.bin`,
//! texture, `.mtlx` or environment map, another `--lighting`, or a change
//! of a built-in scene's generator never reuses references rendered from
//! the old content (until session 47 the key held the glTF file's length
//! and time and the lights' count alone).

use super::{Environment, Scene};
use std::fmt::Write;

/// 64-bit FNV-1a, fed byte by byte or by `write!` (the `Debug` text of a
/// scene's small parts; the large arrays go in as their bytes). The
/// project's one FNV: the reference cache's key hashes with [`fnv1a`].
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn byte(&mut self, x: u8) {
        self.0 ^= x as u64;
        self.0 = self.0.wrapping_mul(0x0000_0100_0000_01B3);
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.byte(x);
        }
    }
    /// A length first, so that adjacent arrays cannot trade elements.
    fn slice<T: bytemuck::Pod>(&mut self, v: &[T]) {
        self.bytes(&(v.len() as u64).to_le_bytes());
        self.bytes(bytemuck::cast_slice(v));
    }
}

impl Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// 64-bit FNV-1a over a byte stream.
pub(crate) fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    let mut h = Fnv::new();
    for b in bytes {
        h.byte(b);
    }
    h.0
}

impl Scene {
    /// See the module documentation. Linear in the scene's bytes (about a
    /// nanosecond a byte: a quarter of a second for the Sponza's textures).
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv::new();
        let _ = write!(h, "meshes {}", self.meshes.len());
        for m in &self.meshes {
            h.slice(&m.positions);
            h.slice(&m.normals);
            h.slice(&m.uvs);
            h.slice(&m.uvs2);
            h.slice(&m.tangents);
            h.slice(&m.colors);
            h.slice(&m.indices);
            let _ = write!(h, "material {}", m.material);
        }
        let _ = write!(h, "{:?}", self.instances);
        let _ = write!(h, "{:?}", self.materials);
        let _ = write!(h, "textures {}", self.textures.len());
        for t in &self.textures {
            let _ = write!(
                h,
                "{:?} {}x{} mips {}",
                t.encoding,
                t.width,
                t.height,
                t.mips.len()
            );
            for m in &t.mips {
                h.slice(m);
            }
        }
        let _ = write!(h, "{:?}", self.lights);
        match &self.environment {
            Some(Environment::Map {
                width,
                height,
                texels,
                scale,
                ..
            }) => {
                let _ = write!(h, "map {width}x{height} scale {scale:?}");
                h.slice(texels);
            }
            other => {
                let _ = write!(h, "{other:?}");
            }
        }
        let _ = write!(h, "{:?}", self.animation);
        let _ = write!(h, "{:?}", self.graphs);
        h.0
    }
}

#[cfg(test)]
mod tests {

    use crate::scene::{generate, Environment};
    use glam::Vec3;

    /// Equal content hashes equal; every kind of content the reference's
    /// image depends on moves the hash, including what a file key missed
    /// (lighting, a buffer, a texture, an environment map, a graph).
    #[test]
    fn every_part_of_the_content_moves_the_hash() {
        let base = generate("plane").expect("plane");
        let h0 = base.content_hash();
        assert_eq!(
            h0,
            generate("plane").unwrap().content_hash(),
            "deterministic"
        );
        let mut renamed = base.clone();
        renamed.source = "elsewhere".into();
        renamed.warnings.push("a warning".into());
        assert_eq!(h0, renamed.content_hash(), "name and warnings do not count");

        let mut changed: Vec<(&str, crate::scene::Scene)> = Vec::new();
        let mut s = base.clone();
        s.meshes[0].positions[0].x += 1e-3;
        changed.push(("a vertex", s));
        let mut s = base.clone();
        s.meshes[0].indices.swap(0, 1);
        changed.push(("the winding", s));
        let mut s = base.clone();
        s.materials[0].base_color.x *= 0.5;
        changed.push(("a material", s));
        let mut s = base.clone();
        s.instances[0].transform.w_axis.y += 1.0;
        changed.push(("an instance", s));
        let mut s = base.clone();
        s.lights.clear();
        changed.push(("the lights", s));
        let mut s = base.clone();
        s.environment = Some(Environment::Constant(Vec3::splat(5.0)));
        changed.push(("the environment", s));
        let map = |v: f32| Environment::Map {
            name: "m".into(),
            width: 2,
            height: 1,
            texels: vec![[1.0, 1.0, 1.0], [v, 1.0, 1.0]],
            scale: 1.0,
        };
        let mut a = base.clone();
        a.environment = Some(map(1.0));
        let mut b = base.clone();
        b.environment = Some(map(2.0));
        assert_ne!(a.content_hash(), b.content_hash(), "an environment texel");
        let tex = |v: u8| {
            crate::scene::Texture::with_mips(
                "t".into(),
                crate::scene::TextureEncoding::Srgb,
                2,
                2,
                vec![v, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255],
            )
        };
        let mut a = base.clone();
        a.textures.push(tex(10));
        let mut b = base.clone();
        b.textures.push(tex(11));
        assert_ne!(a.content_hash(), b.content_hash(), "a texel");
        let mut s = base.clone();
        let mut m = s.materials[0].clone();
        s.graphs
            .attach_mtlx(
                0,
                &mut m,
                "g.mtlx",
                r#"<?xml version="1.0"?>
<materialx version="1.39">
  <nodegraph name="g">
    <texcoord name="uv" type="vector2" />
    <extract name="u" type="float"><input name="in" type="vector2" nodename="uv" /><input name="index" type="integer" value="0" /></extract>
    <multiply name="c" type="color3"><input name="in1" type="color3" value="1, 0.5, 0.25" /><input name="in2" type="float" nodename="u" /></multiply>
    <output name="base_color" type="color3" nodename="c" />
  </nodegraph>
</materialx>
"#,
            )
            .expect("graph binds");
        s.materials[0] = m;
        changed.push(("a material graph", s));
        for (what, s) in &changed {
            assert_ne!(h0, s.content_hash(), "{what} changed, the hash did not");
        }
    }
}
