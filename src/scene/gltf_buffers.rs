//! glTF binary data: the GLB container, buffer sources (relative files, data
//! URIs, the GLB `BIN` chunk) and typed, bounds-checked accessor reads.
//!
//! The `gltf` crate's own reader (`gltf::import`, `Reader`) unwraps on invalid
//! percent-encoding and computes `offset + stride * (count - 1)` without overflow
//! checks, so this module does the byte work itself: every range is computed with
//! checked arithmetic and compared against the real buffer length *before* any
//! allocation, so a huge declared count is an error, not an out-of-memory abort.
//! An accessor without a `bufferView` reads as zeros (glTF 2.0 §5.1.1), its
//! `sparse` values, if any, substituted.

use super::SceneError;
use gltf::accessor::{DataType, Dimensions};
use std::path::Path;

/// The two parts of a glTF asset: its JSON text and (for `.glb`) the `BIN` chunk.
pub(crate) struct GltfContainer {
    pub json: Vec<u8>,
    pub bin: Option<Vec<u8>>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

fn le_u32(b: &[u8], at: usize) -> Option<u32> {
    let s = b.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// Splits a file into JSON and binary chunk; plain `.gltf` text is returned as is.
pub(crate) fn split_container(path: &Path, bytes: Vec<u8>) -> Result<GltfContainer, SceneError> {
    if !bytes.starts_with(GLB_MAGIC) {
        // A `.glb` that is not one (empty, cut before its magic, another
        // format) is named as such, not as JSON that fails to parse.
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("glb"))
        {
            return Err(SceneError::invalid(
                path,
                format!(
                    "GLB container: does not start with the 'glTF' magic ({} bytes)",
                    bytes.len()
                ),
            ));
        }
        return Ok(GltfContainer {
            json: bytes,
            bin: None,
        });
    }
    let bad = |m: &str| SceneError::invalid(path, format!("GLB container: {m}"));
    let version = le_u32(&bytes, 4).ok_or_else(|| bad("truncated header"))?;
    if version != 2 {
        return Err(bad(&format!("version {version}, only 2 is supported")));
    }
    let declared = le_u32(&bytes, 8).ok_or_else(|| bad("truncated header"))? as usize;
    if declared > bytes.len() {
        return Err(bad(&format!(
            "header declares {declared} bytes but the file has {}",
            bytes.len()
        )));
    }
    let mut at = 12usize;
    let mut json = None;
    let mut bin = None;
    while at < declared {
        let len = le_u32(&bytes, at).ok_or_else(|| bad("truncated chunk header"))? as usize;
        let kind = le_u32(&bytes, at + 4).ok_or_else(|| bad("truncated chunk header"))?;
        let start = at + 8;
        let end = start
            .checked_add(len)
            .filter(|&e| e <= declared)
            .ok_or_else(|| bad(&format!("chunk at byte {at} runs past the end of the file")))?;
        match kind {
            CHUNK_JSON if json.is_none() => json = Some(bytes[start..end].to_vec()),
            CHUNK_BIN if bin.is_none() => bin = Some(bytes[start..end].to_vec()),
            _ => {} // unknown chunks must be ignored (glTF 2.0 §4.4.3.3)
        }
        // Chunks are 4-byte aligned.
        at = end.div_ceil(4) * 4;
    }
    let json = json.ok_or_else(|| bad("no JSON chunk"))?;
    Ok(GltfContainer { json, bin })
}

/// Decodes `%XX` escapes of a relative URI (RFC 3986). Invalid escapes are kept literally.
pub(crate) fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            let hex = |c: u8| (c as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648, padding optional, whitespace ignored).
pub(crate) fn base64_decode(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' | b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// Resolves a glTF URI (data URI or path relative to the asset) to bytes.
/// `what` names the referring item for messages ("buffer 0", "image 3 'wood'").
/// Only a regular file is read (not `/dev/zero`, a FIFO, a directory:
/// [`crate::input`]); with `length` (a buffer's `byteLength`), a file
/// shorter than it is refused before reading and at most `length` bytes
/// are read.
pub(crate) fn read_uri(
    gltf_path: &Path,
    base_dir: &Path,
    uri: &str,
    what: &str,
    length: Option<u64>,
) -> Result<Vec<u8>, SceneError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let payload = rest.split_once(";base64,").map(|(_, d)| d).ok_or_else(|| {
            SceneError::invalid(gltf_path, format!("{what}: data URI is not base64"))
        })?;
        return base64_decode(payload).ok_or_else(|| {
            SceneError::invalid(gltf_path, format!("{what}: invalid base64 in data URI"))
        });
    }
    let rel = uri.strip_prefix("file://").unwrap_or(uri);
    if rel.contains("://") {
        return Err(SceneError::invalid(
            gltf_path,
            format!(
                "{what}: unsupported URI scheme in '{uri}' (only relative paths and data URIs)"
            ),
        ));
    }
    let file = base_dir.join(percent_decode(rel));
    let cannot = |e: std::io::Error| {
        SceneError::invalid(
            gltf_path,
            format!("{what}: cannot read '{}': {e}", file.display()),
        )
    };
    let Some(length) = length else {
        return crate::input::read(&file).map_err(cannot);
    };
    let len = crate::input::regular_len(&file).map_err(cannot)?;
    if len < length {
        return Err(SceneError::invalid(
            gltf_path,
            format!(
                "{what} is shorter than declared: '{}' has {len} bytes, byteLength {length}",
                file.display()
            ),
        ));
    }
    crate::input::read_at_most(&file, length).map_err(cannot)
}

/// Loads every buffer of the document, checking each is at least as long as declared.
pub(crate) fn load_buffers(
    doc: &gltf::Document,
    gltf_path: &Path,
    mut bin: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let base_dir = gltf_path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let what = match buffer.name() {
            Some(n) => format!("buffer {} '{n}'", buffer.index()),
            None => format!("buffer {}", buffer.index()),
        };
        let data = match buffer.source() {
            gltf::buffer::Source::Uri(uri) => read_uri(
                gltf_path,
                base_dir,
                uri,
                &what,
                Some(buffer.length() as u64),
            )?,
            gltf::buffer::Source::Bin => bin.take().ok_or_else(|| {
                SceneError::invalid(
                    gltf_path,
                    format!("{what} has no uri and the file has no GLB BIN chunk"),
                )
            })?,
        };
        if data.len() < buffer.length() {
            return Err(SceneError::invalid(
                gltf_path,
                format!(
                    "{what} is shorter than declared: {} bytes, byteLength {}",
                    data.len(),
                    buffer.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Bounds-checked typed reads of accessors for one file.
pub(crate) struct AccessorReader<'b> {
    pub path: &'b Path,
    pub buffers: &'b [Vec<u8>],
}

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn dims_count(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

/// Reads component `k` of type `t` at `b[0..]` as f32 (normalized integers mapped per glTF §3.11).
fn read_component(b: &[u8], t: DataType, normalized: bool) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        DataType::U8 if normalized => b[0] as f32 / 255.0,
        DataType::I8 if normalized => (b[0] as i8 as f32 / 127.0).max(-1.0),
        DataType::U16 if normalized => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        DataType::I16 if normalized => {
            (i16::from_le_bytes([b[0], b[1]]) as f32 / 32767.0).max(-1.0)
        }
        DataType::U8 => b[0] as f32,
        DataType::I8 => b[0] as i8 as f32,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f32,
        DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f32,
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
    }
}

fn read_uint(b: &[u8], t: DataType) -> Option<u32> {
    match t {
        DataType::U8 => Some(b[0] as u32),
        DataType::U16 => Some(u16::from_le_bytes([b[0], b[1]]) as u32),
        DataType::U32 => Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        _ => None,
    }
}

impl AccessorReader<'_> {
    fn err(&self, msg: String) -> SceneError {
        SceneError::invalid(self.path, msg)
    }

    /// The bytes of `count` elements of `elem` bytes starting `offset` bytes into
    /// `view`, with the view's stride; returns (slice starting at the first element, stride).
    fn view_elements(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        elem: usize,
        what: &str,
    ) -> Result<(&[u8], usize), SceneError> {
        let buffer = self.buffers.get(view.buffer().index()).ok_or_else(|| {
            self.err(format!(
                "{what}: buffer {} is not loaded",
                view.buffer().index()
            ))
        })?;
        let view_end = view
            .offset()
            .checked_add(view.length())
            .filter(|&e| e <= buffer.len())
            .ok_or_else(|| {
                self.err(format!(
                    "{what}: bufferView {} (offset {}, length {}) exceeds buffer {} of {} bytes",
                    view.index(),
                    view.offset(),
                    view.length(),
                    view.buffer().index(),
                    buffer.len()
                ))
            })?;
        let view_bytes = &buffer[view.offset()..view_end];
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(format!(
                "{what}: bufferView {} byteStride {stride} is smaller than the element size {elem}",
                view.index()
            )));
        }
        if count == 0 {
            return Ok((&view_bytes[0..0], stride));
        }
        let needed = (count - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(elem))
            .and_then(|n| n.checked_add(offset));
        match needed {
            Some(end) if end <= view_bytes.len() => Ok((&view_bytes[offset..end], stride)),
            _ => Err(self.err(format!(
                "{what}: {count} elements of {elem} bytes (stride {stride}, offset {offset}) \
                 exceed bufferView {} of {} bytes",
                view.index(),
                view_bytes.len()
            ))),
        }
    }

    /// Reads an accessor of `N` float-convertible components per element.
    /// `what` names the use ("POSITION of mesh 'x' primitive 0").
    pub fn read_vec<const N: usize>(
        &self,
        acc: &gltf::Accessor,
        what: &str,
    ) -> Result<Vec<[f32; N]>, SceneError> {
        let what = format!("accessor {} ({what})", acc.index());
        let ncomp = dims_count(acc.dimensions());
        if ncomp != N {
            return Err(self.err(format!(
                "{what} has {ncomp} components per element, expected {N}"
            )));
        }
        let t = acc.data_type();
        let csize = component_size(t);
        let elem = csize * N;
        let count = acc.count();
        let decode = |b: &[u8]| -> [f32; N] {
            std::array::from_fn(|k| read_component(&b[k * csize..], t, acc.normalized()))
        };
        let mut out = match acc.view() {
            Some(view) => {
                let (bytes, stride) =
                    self.view_elements(&view, acc.offset(), count, elem, &what)?;
                let mut v = Vec::with_capacity(count);
                for i in 0..count {
                    v.push(decode(&bytes[i * stride..]));
                }
                v
            }
            None => {
                // No view: all zeros (glTF 2.0 §5.1.1, accessor.bufferView:
                // "When undefined, the accessor MUST be initialized with
                // zeros; sparse property or extensions MAY override zeros"),
                // sparse values substituted below. Bound the allocation by
                // what the file's buffers could plausibly describe.
                let total: usize = self.buffers.iter().map(|b| b.len()).sum();
                if count > total.saturating_mul(16).max(1 << 20) {
                    return Err(self.err(format!(
                        "{what} declares {count} elements, implausible for {total} bytes of buffers"
                    )));
                }
                vec![[0.0; N]; count]
            }
        };
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let idx = sparse.indices();
            let it = match idx.index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let isz = component_size(it);
            let (ib, _) = self.view_elements(
                &idx.view(),
                idx.offset(),
                n,
                isz,
                &format!("{what} sparse indices"),
            )?;
            let vals = sparse.values();
            let (vb, _) = self.view_elements(
                &vals.view(),
                vals.offset(),
                n,
                elem,
                &format!("{what} sparse values"),
            )?;
            for s in 0..n {
                let target = read_uint(&ib[s * isz..], it).unwrap_or(u32::MAX) as usize;
                let slot = out.get_mut(target).ok_or_else(|| {
                    self.err(format!(
                        "{what}: sparse index {target} is out of range (count {count})"
                    ))
                })?;
                *slot = decode(&vb[s * elem..]);
            }
        }
        Ok(out)
    }

    /// Reads an index accessor (unsigned scalar) as u32.
    pub fn read_indices(&self, acc: &gltf::Accessor, what: &str) -> Result<Vec<u32>, SceneError> {
        let what = format!("accessor {} ({what})", acc.index());
        let t = acc.data_type();
        if acc.dimensions() != Dimensions::Scalar
            || matches!(t, DataType::F32 | DataType::I8 | DataType::I16)
        {
            return Err(self.err(format!("{what}: indices must be unsigned integer scalars")));
        }
        if acc.sparse().is_some() {
            // Sparse indices are legal but unheard of; reading them as floats would lose precision.
            return Err(self.err(format!("{what}: sparse index accessors are not supported")));
        }
        let view = acc
            .view()
            .ok_or_else(|| self.err(format!("{what} has no bufferView")))?;
        let elem = component_size(t);
        let count = acc.count();
        let (bytes, stride) = self.view_elements(&view, acc.offset(), count, elem, &what)?;
        let mut v = Vec::with_capacity(count);
        for i in 0..count {
            v.push(read_uint(&bytes[i * stride..], t).unwrap_or(0));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_values() {
        assert_eq!(base64_decode("TWFu").unwrap(), b"Man");
        assert_eq!(base64_decode("TWE=").unwrap(), b"Ma");
        assert_eq!(base64_decode("TQ==").unwrap(), b"M");
        assert!(base64_decode("T*==").is_none());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin"), "a b.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("%zz%4"), "%zz%4");
        assert_eq!(percent_decode("%C3%A9"), "é");
    }

    #[test]
    fn glb_truncated_is_an_error() {
        let p = Path::new("x.glb");
        assert!(split_container(p, b"glTF\x02\0\0\0".to_vec()).is_err());
        for bytes in [&b""[..], b"glT", b"{\"asset\":{}}"] {
            let e = split_container(p, bytes.to_vec())
                .err()
                .unwrap()
                .to_string();
            assert!(
                e.starts_with("x.glb: GLB container: does not start with"),
                "{e}"
            );
        }
        // A .gltf is JSON text.
        assert!(split_container(Path::new("x.gltf"), b"{}".to_vec()).is_ok());
        let mut b = b"glTF".to_vec();
        b.extend(2u32.to_le_bytes());
        b.extend(1000u32.to_le_bytes());
        assert!(split_container(p, b).is_err());
    }
}
