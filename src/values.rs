//! Typed command-line values with their range checks, applied while the
//! arguments are parsed (before any file is read or the GPU is opened), so an
//! impossible request is one `error:` line naming the flag.
//!
//! The bounds here are *static*: they hold on every device. Dispatch sizes
//! need no per-device check: at [`MAX_SIDE`] a per-pixel pass dispatches
//! ⌈16384/8⌉ = 2048 workgroups per axis, below the 65 535 every Vulkan device
//! supports (`maxComputeWorkGroupCount`). What depends on the device's memory
//! is refused when the method allocates, before anything is rendered, as one
//! "GPU out of memory while allocating NAME" line (gpu::buffer).
use std::fmt;
use std::path::Path;
use std::str::FromStr;

/// The most samples per pixel and frame: the reference path tracer records
/// one pass (two timestamps, one pass name) per 16 samples, so 2^16 spp is
/// 4 096 passes in one command buffer. More samples: render more frames.
pub const MAX_SPP: u32 = 1 << 16;

/// The most scattering events per path (the shaders' loop bound is a
/// specialization constant; 64 is far past where any path still carries light).
pub const MAX_BOUNCES: u32 = 64;

/// The most pixels per image side (the sample cache's 2^26 pixels per eye and
/// the float precision of pixel coordinates are the tighter bounds there).
pub const MAX_SIDE: u32 = 16384;

/// The most frames of a replay or comparison (frame indices are 32-bit and
/// seed the random numbers; the trace bounds them further).
pub const MAX_FRAMES: usize = 1 << 24;

/// An image size per eye, `WIDTHxHEIGHT`, each side in `1..=MAX_SIDE`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

impl FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Size, String> {
        let (width, height) = crate::session::parse_size(s)?;
        Ok(Size { width, height })
    }
}

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// A clap value parser for an integer flag in `lo..=hi`; the message names
/// the flag and says what the number counts.
pub fn int_in<T>(
    flag: &'static str,
    lo: T,
    hi: T,
    what: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: FromStr + PartialOrd + Copy + fmt::Display + Send + Sync + 'static,
{
    move |s: &str| match s.trim().parse::<T>() {
        Ok(v) if v >= lo && v <= hi => Ok(v),
        _ => Err(format!("bad {flag} {s}: expected {what} in {lo}..={hi}")),
    }
}

/// A clap value parser for a finite number with `ok(v)`; `expected` says
/// which numbers are (it completes "expected ...").
pub fn float_with<T>(
    flag: &'static str,
    ok: fn(T) -> bool,
    expected: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: FromStr + Copy + Send + Sync + 'static,
{
    move |s: &str| match s.trim().parse::<T>() {
        Ok(v) if ok(v) => Ok(v),
        _ => Err(format!("bad {flag} {s}: expected {expected}")),
    }
}

/// A clap value parser for a `FromStr` value whose message is prefixed with
/// `bad FLAG: ` (for parsers whose own messages do not name the flag).
pub fn named<T>(
    flag: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: FromStr + Send + Sync + 'static,
    T::Err: fmt::Display,
{
    move |s: &str| s.parse::<T>().map_err(|e| format!("bad {flag}: {e}"))
}

/// Positive and finite.
pub fn positive_f32(v: f32) -> bool {
    v.is_finite() && v > 0.0
}

/// Checks that `dir` can be the output directory, without creating it: it is
/// a directory or does not exist yet, and its nearest existing ancestor is a
/// directory this process can create files in (probed with a file that is
/// removed at once, so root on a read-only mount is refused too).
pub fn check_output_dir(dir: &Path) -> Result<(), String> {
    let show = dir.display();
    if dir.exists() && !dir.is_dir() {
        return Err(format!(
            "{show}: the output directory is a file, not a directory"
        ));
    }
    let mut existing = dir;
    while !existing.exists() {
        existing = match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
    if !existing.is_dir() {
        return Err(format!(
            "{show}: cannot create the output directory: {} is a file, not a directory",
            existing.display()
        ));
    }
    let probe = existing.join(format!(".stereocache-write-probe-{}", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(format!(
            "{show}: the output directory is not writable ({}: {e})",
            existing.display()
        )),
    }
}

/// Checks that `file` can be written as an output file, without writing
/// it: it is not a directory, and its directory passes
/// [`check_output_dir`] (writes create missing parents).
pub fn check_output_file(file: &Path) -> Result<(), String> {
    if file.is_dir() {
        return Err(format!("{}: is a directory, not a file", file.display()));
    }
    // A device (/dev/null), FIFO or socket: the atomic rename would replace it.
    if std::fs::metadata(file).is_ok_and(|m| !m.is_file()) {
        return Err(format!(
            "{}: is a device, FIFO or socket, not a regular file",
            file.display()
        ));
    }
    let parent = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    check_output_dir(parent).map_err(|e| format!("cannot write {}: {e}", file.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_name_the_flag() {
        let spp = int_in("--spp", 1u32, MAX_SPP, "samples per pixel");
        assert_eq!(spp("16"), Ok(16));
        assert!(spp("0").unwrap_err().starts_with("bad --spp 0"));
        assert!(spp("4294967295").unwrap_err().contains("1..=65536"));
        assert!(spp("-1").is_err() && spp("x").is_err());
        let fps = float_with("--fps", |v: f64| v > 0.0 && v <= 10.0, "(0, 10]");
        assert!(fps("nan").is_err() && fps("0").is_err() && fps("10").is_ok());
        assert_eq!(
            "64x48".parse::<Size>(),
            Ok(Size {
                width: 64,
                height: 48
            })
        );
        assert!("100000x100000"
            .parse::<Size>()
            .unwrap_err()
            .contains("at most 16384"));
    }

    #[test]
    fn output_dirs() {
        let base = std::env::temp_dir().join(format!("stereocache-values-{}", std::process::id()));
        std::fs::create_dir_all(&base).unwrap();
        check_output_dir(&base.join("a/b/c")).unwrap();
        assert!(!base.join("a").exists(), "the check created a directory");
        let file = base.join("f");
        std::fs::write(&file, b"x").unwrap();
        assert!(check_output_dir(&file).unwrap_err().contains("is a file"));
        assert!(check_output_dir(&file.join("sub"))
            .unwrap_err()
            .contains("is a file"));
        let _ = std::fs::remove_dir_all(&base);
    }
}
