//! Writing frames: linear EXR, tonemapped PNG, and the raw first-hit buffer.
//! Every file is written under a temporary name and renamed when complete, so
//! an interrupted run never leaves a file that looks finished.

pub mod label;
pub mod tonemap;

use crate::methods::EyeImage;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: cannot write: {message}")]
    Write { path: PathBuf, message: String },
}

fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Writes with `f` to a temporary file next to `path`, then renames it into place.
pub fn write_atomically(
    path: &Path,
    f: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), OutputError> {
    let tmp = tmp_path(path);
    let err = |message: String| OutputError::Write {
        path: path.to_path_buf(),
        message,
    };
    if let Some(parent) = path.parent() {
        if !parent.as_os_str().is_empty() {
            std::fs::create_dir_all(parent).map_err(|e| err(e.to_string()))?;
        }
    }
    match f(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| err(e.to_string())),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(err(e))
        }
    }
}

/// Linear RGB EXR (32-bit float).
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 4]],
) -> Result<(), OutputError> {
    write_atomically(path, |tmp| {
        exr::prelude::write_rgb_file(tmp, width as usize, height as usize, |x, y| {
            let p = rgb[y * width as usize + x];
            (p[0], p[1], p[2])
        })
        .map_err(|e| e.to_string())
    })
}

/// Single-channel float data (depth) as a grey EXR.
pub fn write_exr_scalar(
    path: &Path,
    width: u32,
    height: u32,
    v: &[f32],
) -> Result<(), OutputError> {
    let rgb: Vec<[f32; 4]> = v.iter().map(|&d| [d, d, d, 1.0]).collect();
    write_exr(path, width, height, &rgb)
}

/// Tonemapped 8-bit sRGB PNG (see `tonemap`).
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 4]],
    exposure: f32,
) -> Result<(), OutputError> {
    write_png_bytes(path, width, height, &tonemap::to_srgb8(rgb, exposure))
}

/// A debug view as an 8-bit sRGB PNG: linear values clamped to [0, 1], no
/// exposure or tone curve.
pub fn write_png_clamped(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 4]],
) -> Result<(), OutputError> {
    write_png_bytes(path, width, height, &tonemap::to_srgb8_clamped(rgb))
}

fn write_png_bytes(path: &Path, width: u32, height: u32, bytes: &[u8]) -> Result<(), OutputError> {
    write_atomically(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            bytes,
            width,
            height,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
}

/// The 128-bit first hits as little-endian u32 quadruples (Listing 1 encoding).
pub fn write_first_hits(path: &Path, hits: &[[u32; 4]]) -> Result<(), OutputError> {
    write_atomically(path, |tmp| {
        std::fs::write(tmp, bytemuck::cast_slice::<[u32; 4], u8>(hits)).map_err(|e| e.to_string())
    })
}

/// Writes one eye as `DIR/<eye>.exr`, `<eye>.png`, `<eye>_depth.exr`,
/// `<eye>_albedo.exr` and `<eye>_firsthit.bin`.
pub fn write_eye(
    dir: &Path,
    eye: &str,
    width: u32,
    height: u32,
    img: &EyeImage,
    exposure: f32,
) -> Result<(), OutputError> {
    write_exr(
        &dir.join(format!("{eye}.exr")),
        width,
        height,
        &img.radiance,
    )?;
    write_png(
        &dir.join(format!("{eye}.png")),
        width,
        height,
        &img.radiance,
        exposure,
    )?;
    write_exr_scalar(
        &dir.join(format!("{eye}_depth.exr")),
        width,
        height,
        &img.depth,
    )?;
    write_exr(
        &dir.join(format!("{eye}_albedo.exr")),
        width,
        height,
        &img.albedo,
    )?;
    write_first_hits(&dir.join(format!("{eye}_firsthit.bin")), &img.first_hit)
}

/// Writes a JSON value atomically.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<(), OutputError> {
    write_atomically(path, |tmp| {
        let s = serde_json::to_string_pretty(value).map_err(|e| e.to_string())?;
        std::fs::write(tmp, s).map_err(|e| e.to_string())
    })
}
