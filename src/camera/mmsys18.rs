//! Importer for the MMSys'18 multi-viewpoint 360° video navigation traces.
//!
//! Source: X. Corbillon, F. De Simone, G. Simon, P. Frossard, "Dynamic
//! Adaptive Streaming for Multi-Viewpoint Omnidirectional Videos", ACM MMSys
//! 2018 (`github.com/xmar/MultiViewpoint360_MMSys18`, `rawNavigationTrace/`,
//! MIT licence). Four users watch a multi-viewpoint 360° video in a headset.
//!
//! # File format
//!
//! Space-separated text, one header line `timestamp viewpoint w x y z`, then
//! one sample per line:
//! - `timestamp`: seconds since the start of the session (checked against the
//!   data: ≈272–307 s sessions, mean step 17 ms ≈ 59 Hz, steps from 3 ms to
//!   0.27 s — jitter and dropped frames; strictly increasing in all four
//!   files).
//! - `viewpoint`: index (0, 1, 2) of the 360° camera whose video the user was
//!   watching; the user switches between cameras placed at different spots of
//!   the filmed scene. It is a content switch, not a head motion: the head
//!   orientation is continuous across switches (< 0.25° between the samples
//!   around every switch in `user1`). The importer ignores it and reports
//!   the number of switches in the warnings.
//! - `w x y z`: unit quaternion, scalar first, with sign flips between
//!   neighbouring samples (≈200–380 per file).
//!
//! # Axes
//!
//! The quaternions use the convention of Corbillon et al.'s 2017 head-movement
//! dataset (the README says so): right-handed, **+x forward** (centre of the
//! equirectangular frame), **+y left**, **+z up**, and the quaternion
//! rotates head-frame vectors into the world frame — their tools compute the
//! viewing direction as `q · (1,0,0) · q*` and its azimuth as `atan2(y, x)`
//! (`360Degree_Head_Movement_Dataset`, `PythonInterface/Helpers/Quaternion.py`).
//! The data agrees: with this reading, over all four users the head's up
//! axis stays within a few degrees of +z, the largest rotation by far is about
//! +z (yaw), pitch stays moderate (5th–95th percentile between −32° and
//! +24°) and roll is small (median 0.3–1.3°, 95th percentile 4–10°). Reading
//! the quaternion as world → head instead, or taking +y as forward, gives
//! two to four times more roll.
//!
//! The conversion to glTF axes (+X right, +Y up, −Z forward) is the proper
//! rotation `M` with `M·x̂ = −Ẑ` (forward), `M·ŷ = −X̂` (left), `M·ẑ = +Ŷ` (up);
//! a quaternion `(w, v)` becomes `(w, M·v)`:
//!
//! ```text
//! (qx, qy, qz, qw)_glTF = (−y, z, −x, w)_MMSys18
//! ```
//!
//! so a positive yaw in the data (a left turn, +z) is a rotation about +Y.
//!
//! # Position
//!
//! The data has orientation only; the eye midpoint comes from a
//! [`HeadNeckModel`]: `position = R·offset − offset`, so the identity
//! orientation (looking at the centre of the video) is at the stage origin.
//!
//! # Repairs
//!
//! As for the CSV format (see [`super::trace`]): NaN/Inf, zero-norm
//! quaternions and decreasing timestamps (also outside the kept
//! `start..end` window) are errors naming the line;
//! non-unit quaternions are normalized; duplicate timestamps are dropped
//! with a warning; a truncated final line (fewer fields and no newline at
//! the end of the file) is dropped with a warning, as in the other
//! importers; sign flips are removed with
//! [`PoseTrace::make_hemisphere_continuous`] (count in the warnings). Real
//! (jittered) timestamps are kept; [`PoseTrace::resample`] produces the
//! render-rate frames.

use std::path::Path;

use glam::Quat;

use super::neck::HeadNeckModel;
use super::trace::{excerpt, PoseSample, PoseTrace, TraceBuilder, TraceError};

/// Column names of the MMSys'18 quaternion files.
pub const MMSYS18_COLUMNS: [&str; 6] = ["timestamp", "viewpoint", "w", "x", "y", "z"];

/// How to import an MMSys'18 trace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mmsys18Options {
    /// Translation model (default: Oculus SDK neck-to-eye offsets).
    pub neck: HeadNeckModel,
    /// Keep samples with `start ≤ timestamp ≤ end` (source seconds).
    pub start: f64,
    /// See `start`; `f64::INFINITY` keeps everything to the end.
    pub end: f64,
    /// Shift times so the first kept sample is at `t = 0`.
    pub rebase_time: bool,
}

impl Default for Mmsys18Options {
    fn default() -> Self {
        Self {
            neck: HeadNeckModel::default(),
            start: 0.0,
            end: f64::INFINITY,
            rebase_time: true,
        }
    }
}

/// An MMSys'18 quaternion (`w, x, y, z`, +x forward, +y left, +z up) in glTF
/// axes (+X right, +Y up, −Z forward). Not normalized.
pub fn mmsys18_to_gltf(w: f32, x: f32, y: f32, z: f32) -> Quat {
    Quat::from_xyzw(-y, z, -x, w)
}

/// Reads an MMSys'18 `user*_quaternion.txt` file into a stage-space trace.
pub fn read_mmsys18(
    path: impl AsRef<Path>,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let text = crate::input::read_to_string(path).map_err(|source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_mmsys18(path, &text, opts)
}

/// Reads `input` (MMSys'18) and writes it to `output` in the project's CSV
/// format (backs `stereocache trace convert`). Returns the converted trace.
pub fn convert_mmsys18(
    input: impl AsRef<Path>,
    output: impl AsRef<Path>,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let trace = read_mmsys18(input, opts)?;
    trace.write_csv(output)?;
    Ok(trace)
}

/// Parses MMSys'18 text; `path` is used in messages and as the trace source.
pub fn parse_mmsys18(
    path: impl AsRef<Path>,
    text: &str,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    // A byte-order mark (editors on Windows write one) is not part of the
    // header's first column name (as in table.rs).
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut b = TraceBuilder::new(path);
    let mut cols: Option<[usize; 6]> = None;
    let mut n_fields = 0;
    // The header's line and whether any sample line followed it.
    let mut header_line = 0;
    let mut any_row = false;
    let mut t_first: Option<f64> = None;
    // The previous sample's (timestamp, line), kept or not.
    let mut prev: Option<(f64, usize)> = None;
    let mut last_viewpoint: Option<i64> = None;
    let mut switches = 0usize;
    let mut fields: Vec<&str> = Vec::with_capacity(6);
    // A truncated final line (fewer fields, no newline at the end: a
    // recording cut off mid-write) is dropped with a warning, as the
    // MMSys'17, OpenXR and generic CSV importers do (`table.rs`).
    let ends_with_newline = text.ends_with('\n');
    let last_content = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, _)| i)
        .last();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        fields.clear();
        fields.extend(line.split_whitespace());
        let Some(c) = cols else {
            let mut found = [None; 6];
            for (k, name) in fields.iter().enumerate() {
                let Some(j) = MMSYS18_COLUMNS.iter().position(|c| c == name) else {
                    return Err(b.line_error(
                        line_no,
                        format!(
                            "unknown column `{}` (column {}); an MMSys'18 quaternion file has `timestamp viewpoint w x y z`",
                            excerpt(name),
                            k + 1
                        ),
                    ));
                };
                if found[j].replace(k).is_some() {
                    return Err(b.line_error(line_no, format!("column `{name}` appears twice")));
                }
            }
            let mut c = [0; 6];
            for (j, slot) in c.iter_mut().enumerate() {
                *slot = found[j].ok_or_else(|| {
                    b.line_error(line_no, format!("missing column `{}`", MMSYS18_COLUMNS[j]))
                })?;
            }
            cols = Some(c);
            n_fields = fields.len();
            header_line = line_no;
            continue;
        };
        any_row = true;
        if fields.len() < n_fields && !ends_with_newline && last_content == Some(i) {
            b.warn(
                Some(line_no),
                format!(
                    "truncated final line ({} of {n_fields} fields, no newline at the end of the file): dropped, the recording was cut off mid-write",
                    fields.len()
                ),
            );
            continue;
        }
        if fields.len() != n_fields {
            return Err(b.line_error(
                line_no,
                format!("{} fields, the header has {n_fields}", fields.len()),
            ));
        }
        let mut v = [0.0f64; 6];
        for (j, &col) in c.iter().enumerate() {
            let text = fields[col];
            let x: f64 = text.parse().map_err(|_| {
                b.line_error(
                    line_no,
                    format!(
                        "column `{}`: `{}` is not a number",
                        MMSYS18_COLUMNS[j],
                        excerpt(text)
                    ),
                )
            })?;
            if !x.is_finite() {
                return Err(b.line_error(
                    line_no,
                    format!(
                        "column `{}`: value `{}` is not finite",
                        MMSYS18_COLUMNS[j],
                        excerpt(text)
                    ),
                ));
            }
            v[j] = x;
        }
        let [t, viewpoint, w, x, y, z] = v;
        // Time order is checked on every sample, before the start..end
        // window drops any (module docs: decreasing timestamps are errors;
        // as the generic CSV importer does): an unsorted file is a clock or
        // concatenation bug wherever it falls.
        if let Some((t_prev, line_prev)) = prev {
            if t < t_prev {
                return Err(b.line_error(
                    line_no,
                    format!(
                        "timestamp {t} is earlier than {t_prev} on line {line_prev}; pose traces \
                         must be sorted by time"
                    ),
                ));
            }
        }
        prev = Some((t, line_no));
        if t < opts.start || t > opts.end {
            continue;
        }
        let vp = viewpoint as i64;
        if last_viewpoint.is_some_and(|p| p != vp) {
            switches += 1;
        }
        last_viewpoint = Some(vp);
        // glTF axes (module docs): (qx, qy, qz, qw) = (−y, z, −x, w).
        let orientation = b.quaternion(line_no, [-y, z, -x, w])?;
        let t0 = *t_first.get_or_insert(t);
        let t_out = if opts.rebase_time { t - t0 } else { t };
        b.push(
            line_no,
            PoseSample {
                t: t_out,
                pose: opts.neck.pose(orientation),
                ipd: None,
            },
        )?;
    }
    if cols.is_none() {
        return Err(b.line_error(
            1,
            "empty file; expected a header `timestamp viewpoint w x y z` and samples",
        ));
    }
    if !any_row {
        return Err(b.line_error(
            header_line + 1,
            "no samples after the header; a trace needs at least one",
        ));
    }
    if b.sample_count() == 0 {
        return Err(TraceError::Trace {
            path: path.to_path_buf(),
            problem: format!("no samples with {} ≤ timestamp ≤ {}", opts.start, opts.end),
        });
    }
    if switches > 0 {
        b.warn(
            None,
            format!("column `viewpoint` ignored: {switches} switch(es) between 360° cameras (content changes, not head motion)"),
        );
    }
    let mut trace = b.finish();
    let flips = trace.make_hemisphere_continuous();
    if flips > 0 {
        let msg = format!(
            "{}: {flips} sample(s) had their quaternion sign flipped for hemisphere continuity",
            path.display()
        );
        trace.warnings.push(msg);
    }
    Ok(trace)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn axes_map_forward_left_up() {
        // 90° left turn in MMSys'18 axes: about +z.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let q = mmsys18_to_gltf(h, 0.0, 0.0, h);
        // Forward (−Z) turns to the left (−X).
        assert!((q * Vec3::NEG_Z).abs_diff_eq(Vec3::NEG_X, 1e-6));
        // Positive rotation about +y (left axis) pitches the nose down.
        let (s, c) = (0.2f32).sin_cos();
        let q = mmsys18_to_gltf(c, 0.0, s, 0.0);
        assert!((q * Vec3::NEG_Z).y < -0.3);
    }

    /// A timestamp earlier than the previous one is an error even where
    /// the start..end window would drop one of the two samples.
    #[test]
    fn decreasing_timestamps_outside_the_window_are_errors() {
        let text = "timestamp viewpoint w x y z\n\
            10 0 1 0 0 0\n\
            5 0 1 0 0 0\n\
            20 0 1 0 0 0\n";
        let opts = Mmsys18Options {
            start: 8.0,
            ..Default::default()
        };
        let e = parse_mmsys18("u.txt", text, &opts).unwrap_err().to_string();
        assert!(
            e.contains("u.txt:3: timestamp 5 is earlier than 10 on line 2"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
    }

    /// A header and nothing else says so (not "no samples with 0 ≤
    /// timestamp ≤ inf", which blamed a time window nobody gave).
    #[test]
    fn a_header_without_samples_is_an_error_naming_the_line_after_it() {
        let e = parse_mmsys18(
            "u.txt",
            "timestamp viewpoint w x y z\n",
            &Default::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "u.txt:2: no samples after the header; a trace needs at least one"
        );
        // Samples outside the window keep the window's message.
        let opts = Mmsys18Options {
            start: 5.0,
            ..Default::default()
        };
        let text = "timestamp viewpoint w x y z\n1 0 1 0 0 0\n";
        let e = parse_mmsys18("u.txt", text, &opts).unwrap_err().to_string();
        assert!(e.contains("no samples with 5 ≤ timestamp"), "{e}");
    }

    /// A UTF-8 byte-order mark and CRLF line ends read as the plain file.
    #[test]
    fn a_byte_order_mark_and_crlf_are_read() {
        let plain = "timestamp viewpoint w x y z\n0 1 1 0 0 0\n0.1 1 1 0 0 0\n";
        let marked = format!("\u{feff}{}", plain.replace('\n', "\r\n"));
        let opts = Mmsys18Options::default();
        let a = parse_mmsys18("a.txt", plain, &opts).unwrap();
        let b = parse_mmsys18("b.txt", &marked, &opts).unwrap();
        assert_eq!(a.samples.len(), 2);
        assert_eq!(a.samples.len(), b.samples.len());
        for (x, y) in a.samples.iter().zip(&b.samples) {
            assert_eq!((x.t, x.pose.orientation), (y.t, y.pose.orientation));
        }
    }

    #[test]
    fn parses_excerpt_and_repairs() {
        let text = "timestamp viewpoint w x y z\n\
            10.0 0 1 0 0 0\n\
            10.5 0 -1 0 0 0\n\
            10.5 1 1 0 0 0\n\
            11.0 1 2 0 0 0\n\
            12.0 1 1 0 0 0\n";
        let opts = Mmsys18Options {
            end: 11.0,
            ..Default::default()
        };
        let tr = parse_mmsys18("u.txt", text, &opts).unwrap();
        let t: Vec<f64> = tr.samples.iter().map(|s| s.t).collect();
        assert_eq!(t, vec![0.0, 0.5, 1.0]);
        assert!(tr.samples.iter().all(|s| s.pose.orientation.w > 0.0));
        assert!(tr.warnings.iter().any(|w| w.contains("u.txt:4: duplicate")));
        assert!(tr
            .warnings
            .iter()
            .any(|w| w.contains("hemisphere continuity")));
        assert!(tr.warnings.iter().any(|w| w.contains("viewpoint")));
        assert!(tr.warnings.iter().any(|w| w.contains("normalized")));
    }
}
