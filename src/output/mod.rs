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

/// Removes a previous run's output file at `path`, if there is one, so that
/// a run that fails part way does not leave it beside its own outputs
/// looking like its results. A folder there is left alone (folders of
/// outputs: [`remove_run_files`]).
pub fn remove_stale(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(_) => std::fs::remove_file(path),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// Removes, under the folder `dir`, what a previous run wrote there: the
/// files, and the folders once empty, whose path relative to `dir` `ours`
/// recognises (`ours(relative path, is a folder)`), and nothing else: a
/// user's own files stay, and the folders that hold them. Symbolic links
/// are never followed (one `ours` names is removed itself; `dir` itself a
/// link: nothing is removed). No error when
/// `dir` does not exist. Until session 52 the outputs' folders were removed
/// whole (`remove_dir_all`), a user's notes and subfolders in them too (an
/// audit's finding).
pub fn remove_run_files(dir: &Path, ours: &dyn Fn(&Path, bool) -> bool) -> std::io::Result<()> {
    fn walk(root: &Path, rel: &Path, ours: &dyn Fn(&Path, bool) -> bool) -> std::io::Result<()> {
        let entries = match std::fs::read_dir(root.join(rel)) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
            r => r?,
        };
        for e in entries {
            let e = e?;
            let name = rel.join(e.file_name());
            if e.file_type()?.is_dir() {
                if ours(&name, true) {
                    walk(root, &name, ours)?;
                    // Kept where it still holds something not ours.
                    let _ = std::fs::remove_dir(root.join(&name));
                }
            } else if ours(&name, false) {
                std::fs::remove_file(root.join(&name))?;
            }
        }
        Ok(())
    }
    // A symbolic link in place of the folder is left alone: its target is
    // not the run's.
    if std::fs::symlink_metadata(dir).is_ok_and(|m| m.file_type().is_symlink()) {
        return Ok(());
    }
    walk(dir, Path::new(""), ours)
}

/// Whether `name` is `prefix`, five or more digits, then `suffix`
/// (`frame_00012.png`, a viewer's `frame_00012`).
pub fn is_numbered(name: &Path, prefix: &str, suffix: &str) -> bool {
    name.to_str()
        .and_then(|n| n.strip_prefix(prefix))
        .and_then(|n| n.strip_suffix(suffix))
        .is_some_and(|d| d.len() >= 5 && d.bytes().all(|b| b.is_ascii_digit()))
}

/// A compare's (or merge's) side-by-side grid: `frame_NNNNN.png`, or
/// `frame_NNNNN.partK.png` from a merge of parts.
pub fn is_grid_image(rel: &Path) -> bool {
    if is_numbered(rel, "frame_", ".png") {
        return true;
    }
    let Some((stem, part)) = rel
        .to_str()
        .and_then(|n| n.strip_suffix(".png"))
        .and_then(|n| n.rsplit_once(".part"))
    else {
        return false;
    };
    !part.is_empty()
        && part.bytes().all(|b| b.is_ascii_digit())
        && is_numbered(Path::new(stem), "frame_", "")
}

/// What a compare writes into its `viewer/` (a path relative to it):
/// `index.json` and `frame_NNNNN/*.png`; `dir`: a folder of them.
pub fn is_viewer_output(rel: &Path, dir: bool) -> bool {
    if dir {
        return is_numbered(rel, "frame_", "");
    }
    rel == Path::new("index.json")
        || (rel.extension().is_some_and(|x| x == "png")
            && rel.parent().is_some_and(|d| is_numbered(d, "frame_", "")))
}

/// What a replay writes into its folder (a compare's method folders, a
/// merge's copies): `frames.jsonl`, `summary.json` and `frames/` with its
/// [`is_frame_image`]s; for [`remove_run_files`].
pub fn is_replay_output(rel: &Path, dir: bool) -> bool {
    let frames = Path::new("frames");
    if dir {
        return rel == frames;
    }
    rel == Path::new("frames.jsonl")
        || rel == Path::new("summary.json")
        || rel.strip_prefix(frames).is_ok_and(is_frame_image)
}

/// Whether `rel` (a path relative to a replay's `frames/`) is one of the
/// images replay writes there: `NNNNN_left.exr`, `NNNNN_right.png`,
/// `NNNNN_left_VIEW.png` (a debug view), with at least five digits.
pub fn is_frame_image(rel: &Path) -> bool {
    let Some(name) = rel.to_str().filter(|n| !n.contains(['/', '\\'])) else {
        return false;
    };
    let digits = name.bytes().take_while(u8::is_ascii_digit).count();
    let rest = &name[digits..];
    digits >= 5
        && ["_left", "_right"].iter().any(|eye| {
            rest.strip_prefix(eye).is_some_and(|r| {
                r == ".exr"
                    || r == ".png"
                    || (r.starts_with('_') && r.ends_with(".png") && r.len() > 5)
            })
        })
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

/// Whether `rel` is one of the files [`write_eye`] writes for `left` or
/// `right` (what a render's outputs may not overwrite).
pub fn is_eye_output(rel: &Path) -> bool {
    let name = rel.to_str().unwrap_or("");
    ["left", "right"].iter().any(|eye| {
        name.strip_prefix(eye).is_some_and(|tail| {
            [".exr", ".png", "_depth.exr", "_albedo.exr", "_firsthit.bin"].contains(&tail)
        })
    })
}

/// Writes one eye as `DIR/<eye>.exr`, `<eye>.png`, `<eye>_depth.exr`,
/// `<eye>_albedo.exr` and `<eye>_firsthit.bin` ([`is_eye_output`] names them).
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

    /// A replay's and a compare's previous outputs go; a user's own files
    /// and folders beside them stay (they were deleted with the folder),
    /// as do symbolic links' targets.
    #[test]
    fn stale_outputs_go_and_the_users_files_stay() {
        let d = std::env::temp_dir().join(format!("sc-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        let files = [
            "frames/00000_left.exr",
            "frames/00001_right.png",
            "frames/00001_left_trace-mask.png",
            "frames/readme.txt",
            "frames/notes/x.txt",
            "frames/00002_left.exr/precious.txt",
            "frames/0001_left.exr",
            "frames/00003_middle.png",
            "frames.jsonl",
            "summary.json",
            "mine.json",
        ];
        for f in files {
            let p = d.join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, b"x").unwrap();
        }
        let outside = d.join("outside.txt");
        std::fs::write(&outside, b"keep").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(&outside, d.join("frames/00004_left.png")).unwrap();
        remove_run_files(&d, &is_replay_output).unwrap();
        let left: Vec<&str> = files
            .iter()
            .copied()
            .filter(|f| d.join(f).exists())
            .collect();
        assert_eq!(
            left,
            [
                "frames/readme.txt",
                "frames/notes/x.txt",
                "frames/00002_left.exr/precious.txt",
                "frames/0001_left.exr",
                "frames/00003_middle.png",
                "mine.json"
            ]
        );
        assert!(outside.exists());
        #[cfg(unix)]
        assert!(std::fs::symlink_metadata(d.join("frames/00004_left.png")).is_err());
        // A folder that held only outputs goes with them; none at all is no error.
        remove_run_files(&d.join("absent"), &is_replay_output).unwrap();
        let e = d.join("only");
        std::fs::create_dir_all(e.join("frames")).unwrap();
        std::fs::write(e.join("frames/00000_left.png"), b"x").unwrap();
        remove_run_files(&e, &is_replay_output).unwrap();
        assert!(!e.join("frames").exists());
        // remove_stale leaves a folder alone.
        remove_stale(&d.join("frames")).unwrap();
        assert!(d.join("frames/readme.txt").exists());
        // A link in place of the folder: its target is not the run's.
        #[cfg(unix)]
        {
            let target = d.join("elsewhere");
            std::fs::create_dir_all(target.join("frames")).unwrap();
            std::fs::write(target.join("frames/00000_left.png"), b"x").unwrap();
            std::os::unix::fs::symlink(&target, d.join("linked")).unwrap();
            remove_run_files(&d.join("linked"), &is_replay_output).unwrap();
            assert!(target.join("frames/00000_left.png").exists());
        }
        assert!(is_viewer_output(Path::new("frame_00003/naive.png"), false));
        assert!(is_viewer_output(Path::new("index.json"), false));
        assert!(is_viewer_output(Path::new("frame_00003"), true));
        assert!(!is_viewer_output(Path::new("mine/naive.png"), false));
        assert!(!is_viewer_output(Path::new("notes.txt"), false));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn output_names_are_recognised_exactly() {
        for (n, want) in [
            ("00000_left.exr", true),
            ("123456_right.png", true),
            ("00007_right_spp.png", true),
            ("00007_right_.png", false),
            ("0007_right.png", false),
            ("00007_left.exr.partial", false),
            ("00007_left.txt", false),
            ("a/00007_left.png", false),
        ] {
            assert_eq!(is_frame_image(Path::new(n)), want, "{n}");
        }
        assert!(is_numbered(Path::new("frame_00012.png"), "frame_", ".png"));
        assert!(!is_numbered(Path::new("frame_12.png"), "frame_", ".png"));
        assert!(!is_numbered(Path::new("frame_0001x.png"), "frame_", ".png"));
        assert!(is_numbered(Path::new("frame_00012"), "frame_", ""));
        assert!(is_grid_image(Path::new("frame_00012.png")));
        assert!(is_grid_image(Path::new("frame_09999.part7.png")));
        assert!(!is_grid_image(Path::new("frame_09999.part.png")));
        assert!(!is_grid_image(Path::new("my_frame.png")));
    }
}
