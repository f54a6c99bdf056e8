//! Equirectangular environment maps from Radiance `.hdr` or OpenEXR `.exr`.
//!
//! Layout (the convention of [`Environment::Map`]): texel rows top to bottom,
//! row 0 at +Y; u ∈ [0, 1) across a row, u = 0 at −Z increasing towards +X.
//! For a unit direction d the lookup is
//! `u = atan2(d.x, −d.z) / 2π` wrapped into [0, 1), `v = acos(d.y) / π`,
//! filtered bilinearly (texel centres at ((x + ½)/width, (y + ½)/height),
//! repeat in u; sky.glsl `environment`, and the importance sampling's cell
//! weights follow the same filter: env_distribution.rs). See
//! [`equirect_direction`] for the inverse. (Khronos's sample viewer puts
//! u = 0 at −X: a panorama made for it shows here turned 90° about +Y;
//! this is Mitsuba 3's `envmap` convention.)

use super::{Environment, SceneError};
use glam::Vec3;
use std::path::Path;

/// Largest accepted map (16k × 8k); bigger files are almost certainly corrupt.
const MAX_TEXELS: usize = 16384 * 8192;

/// Loads an equirectangular radiance map (linear RGB; alpha ignored).
/// Negative values are clamped to 0 and NaN/Inf values become 0, so the
/// map is always safe to importance-sample; the second value is then one
/// warning line naming the file, how many texels were repaired and the
/// first of them (also for a map that is black everywhere). A finite texel
/// brighter than [`super::MAX_EMISSION`] is an error naming it.
pub fn load_env_map(path: &Path) -> Result<(Environment, Option<String>), SceneError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let (width, height, texels) = match ext.as_str() {
        "hdr" => load_hdr(path)?,
        "exr" => load_exr(path)?,
        _ => {
            return Err(SceneError::invalid(
                path,
                "environment map must be an equirectangular .hdr or .exr file",
            ))
        }
    };
    if width == 0 || height == 0 {
        return Err(SceneError::invalid(path, "environment map is empty"));
    }
    // Finite but beyond the brightest emission accepted (an RGBE texel of
    // 1.7e38): the paths that reach it overflow to ∞.
    if let Some((k, t)) = texels
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|c| c.is_finite() && *c > super::MAX_EMISSION))
    {
        return Err(SceneError::invalid(
            path,
            format!(
                "texel ({}, {}) = {:?} is beyond the brightest emission accepted ({:e} per channel)",
                k % width as usize,
                k / width as usize,
                t,
                super::MAX_EMISSION
            ),
        ));
    }
    let repaired = |t: &[f32; 3]| t.iter().any(|c| !c.is_finite() || *c < 0.0);
    let count = texels.iter().filter(|t| repaired(t)).count();
    let warning = if count > 0 {
        let (k, t) = texels
            .iter()
            .enumerate()
            .find(|(_, t)| repaired(t))
            .unwrap();
        Some(format!(
            "{}: {count} texel(s) negative, NaN or infinite, read with those values as 0 (the first: texel ({}, {}) = {:?})",
            path.display(),
            k % width as usize,
            k / width as usize,
            t
        ))
    } else {
        None
    };
    let texels: Vec<[f32; 3]> = texels
        .into_iter()
        .map(|t| t.map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 }))
        .collect();
    let warning = warning.or_else(|| {
        texels.iter().all(|t| *t == [0.0; 3]).then(|| {
            format!(
                "{}: the environment map is black everywhere",
                path.display()
            )
        })
    });
    let env = Environment::Map {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        width,
        height,
        texels,
        scale: 1.0,
    };
    Ok((env, warning))
}

type Texels = (u32, u32, Vec<[f32; 3]>);

fn load_hdr(path: &Path) -> Result<Texels, SceneError> {
    crate::input::check_regular(path).map_err(|e| SceneError::io(path, e))?;
    let reader = image::ImageReader::open(path).map_err(|e| SceneError::io(path, e))?;
    let img = reader
        .decode()
        .map_err(|e| SceneError::invalid(path, format!("cannot decode Radiance HDR: {e}")))?
        .into_rgb32f();
    let (w, h) = img.dimensions();
    let texels = img.pixels().map(|p| p.0).collect();
    Ok((w, h, texels))
}

fn load_exr(path: &Path) -> Result<Texels, SceneError> {
    use exr::prelude::*;
    crate::input::check_regular(path).map_err(|e| SceneError::io(path, e))?;
    let image = read_first_rgba_layer_from_file(
        path,
        |res: Vec2<usize>, _| {
            let n = res.width().saturating_mul(res.height());
            if n > MAX_TEXELS {
                (res.width(), Vec::new())
            } else {
                (res.width(), vec![[0.0f32; 3]; n])
            }
        },
        |(w, px): &mut (usize, Vec<[f32; 3]>),
         pos: Vec2<usize>,
         (r, g, b, _a): (f32, f32, f32, f32)| {
            if let Some(t) = px.get_mut(pos.y() * *w + pos.x()) {
                *t = [r, g, b];
            }
        },
    )
    .map_err(|e| SceneError::invalid(path, format!("cannot read OpenEXR RGB(A) layer: {e}")))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    if texels.len() != size.width() * size.height() {
        return Err(SceneError::invalid(
            path,
            format!(
                "OpenEXR image of {}×{} is too large",
                size.width(),
                size.height()
            ),
        ));
    }
    Ok((size.width() as u32, size.height() as u32, texels))
}

/// The unit direction at the centre of texel (x, y) of a `width × height` map.
pub fn equirect_direction(x: u32, y: u32, width: u32, height: u32) -> Vec3 {
    let u = (x as f32 + 0.5) / width as f32;
    let v = (y as f32 + 0.5) / height as f32;
    let phi = u * std::f32::consts::TAU;
    let theta = v * std::f32::consts::PI;
    Vec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn convention_corners() {
        // Row 0 looks up, u = 0 looks to −Z, u = 1/4 to +X.
        assert!(equirect_direction(0, 0, 4, 1000).y > 0.99);
        let d = equirect_direction(0, 500, 1000, 1001);
        assert!((d - Vec3::NEG_Z).length() < 0.01, "{d}");
        let d = equirect_direction(250, 500, 1000, 1001);
        assert!((d - Vec3::X).length() < 0.01, "{d}");
    }

    /// Repaired texels (negative, NaN, ∞) are one warning naming the count
    /// and the first; a map black everywhere is one too.
    #[test]
    fn repaired_and_black_maps_warn() {
        let dir = std::env::temp_dir().join(format!("stereocache-envw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("odd.exr");
        exr::prelude::write_rgb_file(&p, 4, 2, |x, y| match (x, y) {
            (1, 0) => (-1.0f32, 0.5, 0.5),
            (2, 1) => (f32::NAN, 0.5, 0.5),
            (3, 1) => (0.5, f32::INFINITY, 0.5),
            _ => (0.5, 0.5, 0.5),
        })
        .unwrap();
        let (env, w) = load_env_map(&p).unwrap();
        let w = w.expect("a warning");
        assert!(
            w.contains("odd.exr: 3 texel(s)") && w.contains("texel (1, 0) = [-1.0, 0.5, 0.5]"),
            "{w}"
        );
        let Environment::Map { texels, .. } = env else {
            panic!("not a map")
        };
        assert_eq!(texels[1], [0.0, 0.5, 0.5]);
        assert_eq!(texels[4 + 2], [0.0, 0.5, 0.5]);
        assert_eq!(texels[4 + 3], [0.5, 0.0, 0.5]);
        let p = dir.join("black.exr");
        exr::prelude::write_rgb_file(&p, 4, 2, |_, _| (0.0f32, 0.0, 0.0)).unwrap();
        let (_, w) = load_env_map(&p).unwrap();
        assert!(w
            .unwrap()
            .contains("black.exr: the environment map is black everywhere"));
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn hdr_round_trip_and_errors() {
        let dir = std::env::temp_dir().join(format!("stereocache-env-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("sky.hdr");
        let img = image::Rgb32FImage::from_fn(8, 4, |x, y| image::Rgb([x as f32, y as f32, 0.5]));
        image::DynamicImage::ImageRgb32F(img).save(&p).unwrap();
        let (env, warning) = load_env_map(&p).unwrap();
        assert_eq!(warning, None);
        match env {
            Environment::Map {
                width,
                height,
                texels,
                ..
            } => {
                assert_eq!((width, height), (8, 4));
                assert!((texels[8 + 3][0] - 3.0).abs() < 0.05);
                assert!((texels[8 + 3][1] - 1.0).abs() < 0.05);
            }
            _ => panic!("not a map"),
        }
        let garbage = dir.join("bad.exr");
        std::fs::write(&garbage, b"not an exr").unwrap();
        let e = load_env_map(&garbage).unwrap_err().to_string();
        assert!(e.contains("bad.exr") && e.contains("OpenEXR"), "{e}");
        let e = load_env_map(&dir.join("missing.hdr"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.hdr"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
