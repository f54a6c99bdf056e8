//! Writing outputs: linear EXR, tonemapped PNG, the raw first-hit buffer,
//! JSON and text. Every file goes through [`atomic`]: written under a
//! temporary name and renamed when complete, so an interrupted or failed
//! write never leaves a file that looks finished.

pub mod atomic;
pub mod label;
pub mod tonemap;

use crate::methods::EyeImage;
use std::path::Path;

pub use atomic::{partial_path, write_encoded, write_file, AtomicFile, OutputError};

/// A text field of a CSV line (RFC 4180): as it is, or in double quotes
/// (inner quotes doubled) where it holds a comma, a quote or a line break,
/// so a label or scene path with a comma does not shift the columns.
pub fn csv_field(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\"")).into()
    } else {
        s.into()
    }
}

/// Removes a previous run's output file or folder at `path`, if there is
/// one, so that a run that fails part way does not leave it beside its own
/// outputs looking like its results.
pub fn remove_stale(path: &Path) -> std::io::Result<()> {
    let r = if path.is_dir() {
        std::fs::remove_dir_all(path)
    } else {
        std::fs::remove_file(path)
    };
    match r {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        r => r,
    }
}

/// A text file (CSV, HTML, SVG, ...), written atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), OutputError> {
    write_file(path, text.as_bytes())
}

/// Linear RGB EXR (32-bit float).
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 4]],
) -> Result<(), OutputError> {
    use exr::prelude::{Image, SpecificChannels, Vec2, WritableImage};
    write_encoded(path, |bytes| {
        let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
            let p = rgb[y * width as usize + x];
            (p[0], p[1], p[2])
        });
        Image::from_channels((width as usize, height as usize), channels)
            .write()
            .to_buffered(std::io::Cursor::new(bytes))
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
    write_encoded(path, |out| encode_png_rgb8(out, width, height, bytes))
}

/// An 8-bit RGB image (`width · height · 3` bytes) as PNG into `out`.
pub fn encode_png_rgb8(
    out: &mut Vec<u8>,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<(), String> {
    use image::ImageEncoder;
    image::codecs::png::PngEncoder::new(out)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())
}

/// The 128-bit first hits as little-endian u32 quadruples (Listing 1 encoding).
pub fn write_first_hits(path: &Path, hits: &[[u32; 4]]) -> Result<(), OutputError> {
    write_file(path, bytemuck::cast_slice::<[u32; 4], u8>(hits))
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
    write_encoded(path, |out| {
        serde_json::to_writer_pretty(out, value).map_err(|e| e.to_string())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    #[test]
    fn csv_fields_with_commas_or_quotes_are_quoted() {
        assert_eq!(csv_field("plain-label_1"), "plain-label_1");
        assert_eq!(csv_field("both, 4x4"), "\"both, 4x4\"");
        assert_eq!(csv_field("a \"b\""), "\"a \"\"b\"\"\"");
        assert_eq!(csv_field("x\ny"), "\"x\ny\"");
    }

    /// A full disk, for every kind of output file: the temporary name is a
    /// symbolic link to `/dev/full` (opens fine, every write fails with
    /// ENOSPC), the way a disk fills up after a file was created. Each writer
    /// must return an error naming the final path and leave nothing under the
    /// final name; whole-file writers also remove their temporary (the link,
    /// not `/dev/full`), a streamed file keeps it as `.partial`.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_fails_every_writer_and_leaves_no_file() {
        let full = Path::new("/dev/full");
        assert!(full.exists(), "/dev/full is needed for this test");
        let d = std::env::temp_dir().join(format!("stereocache-full-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let rgb = vec![[0.5f32, 0.25, 1.0, 1.0]; 64 * 48];
        type Writer<'a> = Box<dyn Fn(&Path) -> Result<(), OutputError> + 'a>;
        let writers: Vec<(&str, Writer)> = vec![
            ("a.exr", Box::new(|p: &Path| write_exr(p, 64, 48, &rgb))),
            (
                "a.png",
                Box::new(|p: &Path| write_png(p, 64, 48, &rgb, 1.0)),
            ),
            (
                "b.png",
                Box::new(|p: &Path| write_png_clamped(p, 64, 48, &rgb)),
            ),
            (
                "a_firsthit.bin",
                Box::new(|p: &Path| write_first_hits(p, &[[1, 2, 3, 4]; 100])),
            ),
            (
                "a.json",
                Box::new(|p: &Path| write_json(p, &serde_json::json!({"a": 1}))),
            ),
            ("a.csv", Box::new(|p: &Path| write_text(p, "a,b\n1,2\n"))),
            (
                "a.html",
                Box::new(|p: &Path| write_text(p, "<html></html>")),
            ),
            ("a.svg", Box::new(|p: &Path| write_text(p, "<svg/>"))),
            (
                "a.jsonl",
                Box::new(|p: &Path| {
                    let mut f = AtomicFile::create(p)?;
                    f.write_all(b"{\"index\":0}\n")?;
                    f.commit()
                }),
            ),
        ];
        for (name, write) in &writers {
            let p: PathBuf = d.join(name);
            let tmp = partial_path(&p);
            std::os::unix::fs::symlink(full, &tmp).unwrap();
            let e = write(&p).expect_err(name).to_string();
            assert!(
                e.starts_with(&format!("{}: cannot write: ", p.display())) && !e.contains('\n'),
                "{name}: {e}"
            );
            assert!(
                !p.exists() && p.symlink_metadata().is_err(),
                "{name}: a file under its final name"
            );
            if name.ends_with(".jsonl") {
                std::fs::remove_file(&tmp).unwrap();
            } else {
                assert!(
                    tmp.symlink_metadata().is_err(),
                    "{name}: the temporary was left"
                );
            }
            assert!(full.exists(), "/dev/full itself must not be touched");
            // The same writer succeeds where the disk has room.
            write(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(std::fs::metadata(&p).unwrap().len() > 0, "{name}");
        }
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn images_round_trip() {
        let d = std::env::temp_dir().join(format!("stereocache-img-{}", std::process::id()));
        let rgb: Vec<[f32; 4]> = (0..12).map(|i| [i as f32 * 0.1, 0.5, 2.0, 1.0]).collect();
        write_exr(&d.join("a.exr"), 4, 3, &rgb).unwrap();
        write_png(&d.join("a.png"), 4, 3, &rgb, 1.0).unwrap();
        use exr::prelude::*;
        let exr = read_first_rgba_layer_from_file(
            d.join("a.exr"),
            |res: Vec2<usize>, _| (res.width(), vec![[0.0f32; 3]; res.width() * res.height()]),
            |(w, px): &mut (usize, Vec<[f32; 3]>),
             pos: Vec2<usize>,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * *w + pos.x()] = [r, g, b];
            },
        )
        .unwrap();
        assert_eq!(exr.layer_data.size, Vec2(4, 3));
        let (_, px) = &exr.layer_data.channel_data.pixels;
        for (p, q) in px.iter().zip(&rgb) {
            assert_eq!(*p, [q[0], q[1], q[2]]);
        }
        let png = image::open(d.join("a.png")).unwrap().into_rgb8();
        assert_eq!(png.as_raw(), &tonemap::to_srgb8(&rgb, 1.0));
        let _ = std::fs::remove_dir_all(&d);
    }
}
