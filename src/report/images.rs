//! The images the report's error maps and viewer show, written by `compare`
//! next to the report, for each shown frame `f` (left eye):
//!
//! - `viewer/frame_<f>/reference.png` and `method-<label>.png`: the
//!   reference and every configuration, tonemapped as the side-by-side grids
//!   (exposure, ACES fit of Narkowicz, sRGB: [`tonemap::to_srgb8`]);
//! - `method-<label>.flip.png`: the configuration's per-pixel HDR-FLIP map
//!   against the reference (the same HDR-FLIP and pixels per degree the
//!   summary's `flip` is the mean of), through [`RAMP`];
//! - `reference.crop.png`, `method-<label>.crop.png`, `method-<label>.flip.crop.png`:
//!   the [`CROP`]×[`CROP`] window where the methods differ most ([`crop_window`]).
//!
//! `viewer/index.json` lists the frames, sizes, crops and FLIP means. Without
//! a reference (`--reference-spp` not given) only the method images are written.

use crate::error::{Error, Result};
use crate::evaluate::ReferenceFrame;
use crate::methods::StereoFrame;
use crate::metrics::{flip_hdr, LinearImage};
use crate::output::{self, tonemap};
use std::path::Path;

/// Side of the crop window, in pixels (smaller images: the whole image).
pub const CROP: usize = 32;

/// Colour ramp of the FLIP maps, value 0 → first, 1 → last, linear between:
/// black, purple, red, orange, pale yellow (close to the magma map the
/// FLIP paper shows its maps in).
pub const RAMP: [[f32; 3]; 5] = [
    [0.0, 0.0, 4.0],
    [81.0, 18.0, 124.0],
    [183.0, 55.0, 121.0],
    [252.0, 137.0, 97.0],
    [252.0, 253.0, 191.0],
];

/// `v` in `[0, 1]` through [`RAMP`] as sRGB8.
pub fn ramp(v: f32) -> [u8; 3] {
    let t = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        1.0
    } * (RAMP.len() - 1) as f32;
    let i = (t.floor() as usize).min(RAMP.len() - 2);
    let f = t - i as f32;
    let (a, b) = (RAMP[i], RAMP[i + 1]);
    [0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * f + 0.5) as u8)
}

/// The top-left corner of the `cw`×`ch` window of a `w`×`h` image where the
/// methods differ most: the largest sum over the window of the per-pixel
/// variance across methods of their error (`errors[m][pixel]`). With one
/// method there is no variance; its largest summed error is used instead.
/// Ties go to the first window in row-major order.
pub fn crop_window(
    errors: &[Vec<f32>],
    w: usize,
    h: usize,
    cw: usize,
    ch: usize,
) -> (usize, usize) {
    let (cw, ch) = (cw.min(w), ch.min(h));
    let n = errors.len() as f64;
    if errors.is_empty() || cw == 0 || ch == 0 {
        return (0, 0);
    }
    let score: Vec<f64> = (0..w * h)
        .map(|p| {
            let vals = errors.iter().map(|e| e[p] as f64).filter(|v| v.is_finite());
            let (s, s2) = vals.fold((0.0, 0.0), |(s, s2), v| (s + v, s2 + v * v));
            if errors.len() == 1 {
                s
            } else {
                (s2 / n - (s / n).powi(2)).max(0.0)
            }
        })
        .collect();
    // Summed-area table, (w+1)×(h+1).
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        for x in 0..w {
            sat[(y + 1) * (w + 1) + x + 1] =
                score[y * w + x] + sat[y * (w + 1) + x + 1] + sat[(y + 1) * (w + 1) + x]
                    - sat[y * (w + 1) + x];
        }
    }
    let mut best = (f64::NEG_INFINITY, (0, 0));
    for y in 0..=h - ch {
        for x in 0..=w - cw {
            let s = sat[(y + ch) * (w + 1) + x + cw]
                - sat[y * (w + 1) + x + cw]
                - sat[(y + ch) * (w + 1) + x]
                + sat[y * (w + 1) + x];
            if s > best.0 {
                best = (s, (x, y));
            }
        }
    }
    best.1
}

fn crop(rgb: &[u8], w: usize, (x0, y0, cw, ch): (usize, usize, usize, usize)) -> Vec<u8> {
    let mut out = Vec::with_capacity(cw * ch * 3);
    for y in y0..y0 + ch {
        out.extend_from_slice(&rgb[(y * w + x0) * 3..(y * w + x0 + cw) * 3]);
    }
    out
}

fn png(path: &Path, w: usize, h: usize, rgb: &[u8]) -> Result<()> {
    output::write_encoded(path, |out| {
        output::encode_png_rgb8(out, w as u32, h as u32, rgb)
    })?;
    Ok(())
}

/// Writes `out/viewer/` for the shown frames: `kept[k][m]` is frame
/// `shown[k]` as configuration `labels[m]` rendered it, `references[shown[k]]`
/// its reference (when there are references); `ppd` as the metrics use.
pub fn write(
    out: &Path,
    labels: &[String],
    shown: &[usize],
    kept: &[Vec<StereoFrame>],
    references: &[ReferenceFrame],
    exposure: f32,
    ppd: f32,
) -> Result<()> {
    let m = |e: crate::metrics::MetricsError| Error::Usage(format!("metrics: {e}"));
    let mut index = Vec::new();
    for (k, &f) in shown.iter().enumerate() {
        let dir = out.join("viewer").join(format!("frame_{f:05}"));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let frames = &kept[k];
        let (w, h) = (frames[0].width as usize, frames[0].height as usize);
        let rgb: Vec<Vec<u8>> = frames
            .iter()
            .map(|fr| tonemap::to_srgb8(&fr.eyes[0].radiance, exposure))
            .collect();
        for (l, img) in labels.iter().zip(&rgb) {
            png(&dir.join(format!("method-{l}.png")), w, h, img)?;
        }
        let mut entry = serde_json::json!({
            "frame": f, "width": w, "height": h, "labels": labels,
        });
        if let Some(r) = references.get(f) {
            let rimg = LinearImage::from_rgba(&r.frame.eyes[0].radiance, w, h).map_err(m)?;
            let mut maps = Vec::new();
            for fr in frames {
                let t = LinearImage::from_rgba(&fr.eyes[0].radiance, w, h).map_err(m)?;
                maps.push(flip_hdr(&t, &rimg, ppd).map_err(m)?.flip);
            }
            let errors: Vec<Vec<f32>> = maps.iter().map(|fm| fm.map.clone()).collect();
            let (cw, ch) = (CROP.min(w), CROP.min(h));
            let (cx, cy) = crop_window(&errors, w, h, cw, ch);
            let window = (cx, cy, cw, ch);
            let ref_rgb = tonemap::to_srgb8(&r.frame.eyes[0].radiance, exposure);
            png(&dir.join("reference.png"), w, h, &ref_rgb)?;
            png(
                &dir.join("reference.crop.png"),
                cw,
                ch,
                &crop(&ref_rgb, w, window),
            )?;
            for ((l, img), fm) in labels.iter().zip(&rgb).zip(&maps) {
                let flip_rgb: Vec<u8> = fm.map.iter().flat_map(|&v| ramp(v)).collect();
                png(&dir.join(format!("method-{l}.flip.png")), w, h, &flip_rgb)?;
                png(
                    &dir.join(format!("method-{l}.crop.png")),
                    cw,
                    ch,
                    &crop(img, w, window),
                )?;
                png(
                    &dir.join(format!("method-{l}.flip.crop.png")),
                    cw,
                    ch,
                    &crop(&flip_rgb, w, window),
                )?;
            }
            entry["crop"] = serde_json::json!([cx, cy, cw, ch]);
            entry["flip_means"] =
                serde_json::json!(maps.iter().map(|fm| fm.mean).collect::<Vec<_>>());
        }
        index.push(entry);
    }
    let doc = serde_json::json!({
        "frames": index,
        "exposure": exposure,
        "ppd": ppd,
        "eye": "left",
        "error_map": "HDR-FLIP (left eye) against the reference",
        "crop_rule": format!("the {CROP}x{CROP} window (or the whole image when smaller) with the largest sum of the per-pixel variance across configurations of their FLIP value"),
    });
    let path = out.join("viewer").join("index.json");
    output::write_text(
        &path,
        &serde_json::to_string_pretty(&doc).unwrap_or_default(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_window_finds_where_methods_disagree() {
        let (w, h) = (80, 60);
        // Two methods agree everywhere but a 4×4 patch at (50, 20), where
        // method b's error is larger; both have a larger common error elsewhere.
        let mut a = vec![0.5f32; w * h];
        for y in 0..10 {
            for x in 0..10 {
                a[y * w + x] = 0.9;
            }
        }
        let mut b = a.clone();
        for y in 20..24 {
            for x in 50..54 {
                b[y * w + x] = 0.9;
            }
        }
        let (x, y) = crop_window(&[a, b], w, h, 32, 32);
        assert!(
            x <= 50 && x + 32 >= 54 && y <= 20 && y + 32 >= 24,
            "({x}, {y})"
        );
        // One method: its largest error.
        let mut c = vec![0.0f32; w * h];
        c[59 * w + 79] = 1.0;
        assert_eq!(crop_window(&[c], w, h, 32, 32), (48, 28));
        // A window larger than the image is the image.
        assert_eq!(crop_window(&[vec![1.0; 12]], 4, 3, 32, 32), (0, 0));
    }

    #[test]
    fn ramp_ends() {
        assert_eq!(ramp(0.0), [0, 0, 4]);
        assert_eq!(ramp(1.0), [252, 253, 191]);
        assert_eq!(ramp(f32::NAN), [252, 253, 191]);
    }
}
