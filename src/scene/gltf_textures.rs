//! glTF images → `Texture`s: each referenced image is read and decoded once
//! (PNG/JPEG via the `image` crate), then turned into one RGBA8 mip chain per
//! encoding it is used with (sRGB for base colour/emissive, linear otherwise).
//! Images are independent, so they are decoded on all cores.
//!
//! A missing or undecodable image is not an error: it yields a warning and no
//! texture, and the materials that use it fall back to their factors.

use super::gltf_buffers::read_uri;
use super::{Texture, TextureEncoding};
use std::collections::BTreeMap;
use std::path::Path;

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
            read_uri(gltf_path, base, uri, label).map_err(|e| e.to_string())
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
