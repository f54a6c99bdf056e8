//! glTF images → `Texture`s: each referenced image is read and decoded once
//! (PNG/JPEG via the `image` crate), then turned into one RGBA8 mip chain per
//! encoding it is used with (sRGB for base colour/emissive, linear otherwise).
//! Images are independent, so they are decoded on all cores.
//!
//! A missing or undecodable image is not an error: it yields a warning and no
//! texture, and the materials that use it fall back to their factors.
//!
//! Samplers (wrap modes, filters) are not part of the image: they go into
//! each material's `TextureRef` (`texture_sampler`), so one image read with
//! two samplers is still decoded and uploaded once.

use super::gltf_buffers::read_uri;
use super::texture::gl;
use super::{Filter, Texture, TextureEncoding, TextureSampler, Wrap};
use std::collections::BTreeMap;
use std::path::Path;

/// Each image must name exactly one source: a `uri`, or a `bufferView`
/// with a `mimeType` (glTF 2.0 §5.18). The `gltf` crate's `Image::source`
/// unwraps these (a panic inside the decoder threads), so they are checked
/// on the raw JSON before the typed parse: one error naming the image.
pub(crate) fn check_image_sources(
    path: &Path,
    obj: &serde_json::Map<String, serde_json::Value>,
) -> Result<(), super::SceneError> {
    let Some(images) = obj.get("images").and_then(|i| i.as_array()) else {
        return Ok(());
    };
    for (i, image) in images.iter().enumerate() {
        let Some(image) = image.as_object() else {
            continue; // reported by the typed parse
        };
        let name = match image.get("name").and_then(|n| n.as_str()) {
            Some(n) => format!("images[{i}] '{}'", n.chars().take(40).collect::<String>()),
            None => format!("images[{i}]"),
        };
        // `null` reads as absent in the typed parse.
        let has = |key: &str| image.get(key).is_some_and(|v| !v.is_null());
        let problem = match (has("uri"), has("bufferView"), has("mimeType")) {
            (false, false, _) => "has neither `uri` nor `bufferView`",
            (_, true, false) => "has a `bufferView` but no `mimeType`, which glTF requires",
            _ => continue,
        };
        return Err(super::SceneError::invalid(
            path,
            format!("invalid glTF: {name} {problem}"),
        ));
    }
    Ok(())
}

/// Which encodings each image index is needed in.
pub(crate) type ImageUses = BTreeMap<usize, Vec<TextureEncoding>>;

/// A texture built from one image for one encoding.
pub(crate) type KeyedTexture = ((usize, TextureEncoding), Texture);

/// Decoded textures keyed by (image index, encoding), plus warnings.
pub(crate) struct DecodedImages {
    pub textures: Vec<KeyedTexture>,
    pub warnings: Vec<String>,
}

fn image_label(image: &gltf::Image) -> String {
    let name = image
        .name()
        .map(str::to_owned)
        .or_else(|| match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                Some(uri.to_owned())
            }
            _ => None,
        });
    match name {
        Some(n) => format!("image {} '{n}'", image.index()),
        None => format!("image {}", image.index()),
    }
}

fn image_bytes(
    image: &gltf::Image,
    gltf_path: &Path,
    buffers: &[Vec<u8>],
    label: &str,
) -> Result<Vec<u8>, String> {
    match image.source() {
        gltf::image::Source::Uri { uri, .. } => {
            let base = gltf_path.parent().unwrap_or(Path::new("."));
            read_uri(gltf_path, base, uri, label, None).map_err(|e| e.to_string())
        }
        gltf::image::Source::View { view, .. } => {
            let buf = buffers
                .get(view.buffer().index())
                .ok_or_else(|| format!("{label}: buffer not loaded"))?;
            view.offset()
                .checked_add(view.length())
                .and_then(|end| buf.get(view.offset()..end))
                .map(<[u8]>::to_vec)
                .ok_or_else(|| {
                    format!(
                        "{}: {label}: bufferView {} exceeds its buffer",
                        gltf_path.display(),
                        view.index()
                    )
                })
        }
    }
}

fn decode_one(
    image: &gltf::Image,
    encodings: &[TextureEncoding],
    gltf_path: &Path,
    buffers: &[Vec<u8>],
) -> Result<Vec<KeyedTexture>, String> {
    let label = image_label(image);
    let bytes = image_bytes(image, gltf_path, buffers, &label)?;
    let decoded = image::load_from_memory(&bytes)
        .map_err(|e| format!("{}: {label}: cannot decode: {e}", gltf_path.display()))?;
    let rgba = decoded.to_rgba8();
    let (w, h) = rgba.dimensions();
    if w == 0 || h == 0 {
        return Err(format!("{}: {label}: empty image", gltf_path.display()));
    }
    let level0 = rgba.into_raw();
    let base_name = image
        .name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("image{}", image.index()));
    Ok(encodings
        .iter()
        .map(|&enc| {
            let name = if encodings.len() > 1 && enc == TextureEncoding::Linear {
                format!("{base_name} (linear)")
            } else {
                base_name.clone()
            };
            let tex = Texture::with_mips(name, enc, w, h, level0.clone());
            ((image.index(), enc), tex)
        })
        .collect())
}

/// Decodes the images in `uses`, in parallel over the available cores.
pub(crate) fn decode_images(
    doc: &gltf::Document,
    uses: &ImageUses,
    gltf_path: &Path,
    buffers: &[Vec<u8>],
) -> DecodedImages {
    let jobs: Vec<(gltf::Image, &[TextureEncoding])> = uses
        .iter()
        .filter_map(|(&i, enc)| doc.images().nth(i).map(|img| (img, enc.as_slice())))
        .collect();
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .clamp(1, 8)
        .min(jobs.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<(usize, Result<Vec<_>, String>)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut out = Vec::new();
                    loop {
                        let j = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some((img, enc)) = jobs.get(j) else { break };
                        out.push((j, decode_one(img, enc, gltf_path, buffers)));
                    }
                    out
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| {
                w.join()
                    .unwrap_or_else(|_| vec![(usize::MAX, Err("image decoder panicked".into()))])
            })
            .collect()
    });
    // Deterministic order regardless of thread scheduling.
    results.sort_by_key(|(j, _)| *j);
    let mut out = DecodedImages {
        textures: Vec::new(),
        warnings: Vec::new(),
    };
    for (_, r) in results {
        match r {
            Ok(t) => out.textures.extend(t),
            Err(w) => out.warnings.push(format!(
                "{w}; materials using it fall back to their factors"
            )),
        }
    }
    out
}

/// The sampler a glTF texture is read with ([`TextureSampler::default`]
/// for a texture without one, and for each field a sampler leaves out:
/// the Khronos sample viewer's defaults). Call on a document whose
/// samplers went through [`patch_invalid_samplers`].
pub(crate) fn texture_sampler(texture: &gltf::texture::Texture) -> TextureSampler {
    let s = texture.sampler();
    let d = TextureSampler::default();
    let (min_filter, mipmap) = s
        .min_filter()
        .and_then(|m| TextureSampler::min_from_gl(m.as_gl_enum()))
        .unwrap_or((d.min_filter, d.mipmap));
    TextureSampler {
        wrap_s: Wrap::from_gl(s.wrap_s().as_gl_enum()).unwrap_or(d.wrap_s),
        wrap_t: Wrap::from_gl(s.wrap_t().as_gl_enum()).unwrap_or(d.wrap_t),
        mag_filter: s
            .mag_filter()
            .and_then(|m| Filter::from_gl_mag(m.as_gl_enum()))
            .unwrap_or(d.mag_filter),
        min_filter,
        mipmap,
    }
}

/// Sampler fields whose value glTF does not define (e.g. `magFilter: 9987`,
/// a string, a negative number) would make the `gltf` crate reject the
/// whole file. Each such field is removed from the raw JSON, so that the
/// default for that field applies, and each sampler with such fields gets
/// one warning naming the file, the sampler, the textures using it and the
/// value used instead. A whole-number float (`9729.0`) is read as the integer.
pub(crate) fn patch_invalid_samplers(
    path: &Path,
    obj: &mut serde_json::Map<String, serde_json::Value>,
) -> Vec<String> {
    use serde_json::Value;
    let mut users: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    if let Some(Value::Array(textures)) = obj.get("textures") {
        for (i, t) in textures.iter().enumerate() {
            if let Some(s) = t.get("sampler").and_then(Value::as_u64) {
                let label = match t.get("name").and_then(Value::as_str) {
                    Some(n) => format!("texture {i} '{n}'"),
                    None => format!("texture {i}"),
                };
                users.entry(s).or_default().push(label);
            }
        }
    }
    let Some(Value::Array(samplers)) = obj.get_mut("samplers") else {
        return Vec::new();
    };
    let mut warnings = Vec::new();
    for (si, s) in samplers.iter_mut().enumerate() {
        let Value::Object(s) = s else { continue };
        let mut bad = Vec::new();
        for (key, valid, fallback) in [
            ("magFilter", &[gl::NEAREST, gl::LINEAR][..], "LINEAR (9729)"),
            (
                "minFilter",
                &[
                    gl::NEAREST,
                    gl::LINEAR,
                    gl::NEAREST_MIPMAP_NEAREST,
                    gl::LINEAR_MIPMAP_NEAREST,
                    gl::NEAREST_MIPMAP_LINEAR,
                    gl::LINEAR_MIPMAP_LINEAR,
                ][..],
                "LINEAR_MIPMAP_LINEAR (9987)",
            ),
            (
                "wrapS",
                &[gl::REPEAT, gl::CLAMP_TO_EDGE, gl::MIRRORED_REPEAT][..],
                "REPEAT (10497)",
            ),
            (
                "wrapT",
                &[gl::REPEAT, gl::CLAMP_TO_EDGE, gl::MIRRORED_REPEAT][..],
                "REPEAT (10497)",
            ),
        ] {
            let Some(v) = s.get(key) else { continue };
            let as_int = v.as_u64().or_else(|| {
                v.as_f64()
                    .filter(|f| f.fract() == 0.0 && *f >= 0.0 && *f <= f64::from(u32::MAX))
                    .map(|f| f as u64)
            });
            match as_int {
                Some(n) if valid.iter().any(|&g| u64::from(g) == n) => {
                    s.insert(key.into(), Value::from(n));
                }
                _ => {
                    bad.push(format!("{key} {v} is not a glTF value, {fallback} is used"));
                    s.remove(key);
                }
            }
        }
        if !bad.is_empty() {
            let name = match s.get("name").and_then(Value::as_str) {
                Some(n) => format!("sampler {si} '{n}'"),
                None => format!("sampler {si}"),
            };
            let used = match users.get(&(si as u64)) {
                Some(u) => format!("used by {}", u.join(", ")),
                None => "used by no texture".into(),
            };
            warnings.push(format!(
                "{}: {name} ({used}): {}",
                path.display(),
                bad.join("; ")
            ));
        }
    }
    warnings
}
