//! Pose traces: the project's CSV format, repairs, hemisphere continuity and
//! resampling to the render rate.
//!
//! # CSV format
//!
//! ```text
//! t,px,py,pz,qx,qy,qz,qw[,ipd]
//! 0,0,0,0,0,0,0,1,0.063
//! 0.011111111,0.0001,0,-0.0002,0,0.0087,0,0.99996,0.063
//! ```
//!
//! - `t` seconds, `px,py,pz` metres (head = eye midpoint in stage space,
//!   glTF axes: +Y up, head looks down its −Z), `qx,qy,qz,qw` the head
//!   orientation (head → stage), `ipd` metres in [0, 1) like `--ipd`
//!   (optional column; an empty `ipd` field means "use the default"; a value
//!   of 1 or more, such as millimetres written by mistake, is an error).
//!   Every other field must hold a number: an empty `t`…`qw` is an error
//!   saying that only `ipd` may be left empty.
//! - A header line is required. Columns are found by name, in any order;
//!   names are trimmed and case-sensitive. A column the format does not
//!   know is an error that names it (a typo such as `qW` must not be
//!   silently ignored).
//! - Blank lines and lines starting with `#` are skipped; fields are trimmed;
//!   a leading UTF-8 byte-order mark is ignored.
//!
//! # What reading checks and repairs
//!
//! Errors (one line naming file, line and problem — no panics):
//! empty file, header only, unknown/duplicate/missing column, wrong field
//! count, unparsable number, NaN or ±Inf anywhere, an `ipd` outside
//! [0, 1) metres, a zero-norm quaternion,
//! a timestamp **earlier** than the previous one (an unsorted trace is more
//! likely a concatenation or a clock bug than something to sort silently).
//!
//! Repairs, each recorded in [`PoseTrace::warnings`]:
//! - a non-unit quaternion is normalized (one warning giving the count and
//!   the worst line when any norm is off by more than 1e-3; smaller
//!   deviations are rounding and are normalized silently);
//! - a sample whose timestamp **equals** the previous one is dropped (the
//!   first one is kept): one warning naming the first such line, with the
//!   count and last line of any others (20,000 repeated timestamps used to
//!   print 20,000 lines).
//!
//! Quaternion signs are kept as read; [`PoseTrace::make_hemisphere_continuous`]
//! flips them and [`PoseTrace::resample`] applies it to a copy before
//! interpolating.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::pose::HeadPose;

/// How far from the origin a trace's head may be, metres, along any axis:
/// the scene's bound ([`crate::scene::MAX_WORLD_COORDINATE`]). A head at
/// 3e38 m rendered black frames without a word.
pub const MAX_POSITION_M: f64 = 1e15;

/// Upper bound (exclusive) of an `ipd` value, metres: the range of `--ipd`.
pub const MAX_IPD_M: f32 = 1.0;

/// One timed head pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseSample {
    /// Time, seconds.
    pub t: f64,
    /// Head pose in stage space.
    pub pose: HeadPose,
    /// Interpupillary distance for this sample, metres; `None` = default.
    pub ipd: Option<f32>,
}

/// A head-pose trace: samples sorted by strictly increasing time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseTrace {
    /// Where the samples came from (a file, or `synth:<kind>:seed=<n>`).
    pub source: PathBuf,
    /// Samples, strictly increasing `t`.
    pub samples: Vec<PoseSample>,
    /// What reading repaired, one line each, naming file and line.
    pub warnings: Vec<String>,
}

/// An error reading or writing a pose trace. Displays as one line that names
/// the file, the line (where there is one) and the problem.
#[derive(Debug, Error)]
pub enum TraceError {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A problem on one line of the file (1-based).
    #[error("{}:{line}: {problem}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong and, where it helps, what to do.
        problem: String,
    },
    /// A problem with the trace as a whole.
    #[error("{}: {problem}", path.display())]
    Trace {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// Column names of the CSV format, in the order they are written.
pub const CSV_COLUMNS: [&str; 9] = ["t", "px", "py", "pz", "qx", "qy", "qz", "qw", "ipd"];

/// Norm deviation above which normalizing a quaternion earns a warning.
const NORM_WARN_TOLERANCE: f64 = 1e-3;

/// Builds a trace sample by sample, enforcing the ordering rules and
/// collecting repairs. Shared by every reader so that all formats repair the
/// same way.
pub(crate) struct TraceBuilder {
    path: PathBuf,
    samples: Vec<PoseSample>,
    last_line: usize,
    warnings: Vec<String>,
    renormalized: usize,
    worst_norm: Option<(usize, f64)>,
    /// Dropped duplicate timestamps: the first one's line and message, the
    /// count and the last line (one warning for all of them, at `finish`).
    first_duplicate: Option<(usize, String)>,
    duplicates: usize,
    last_duplicate: usize,
}

impl TraceBuilder {
    pub(crate) fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            samples: Vec::new(),
            last_line: 0,
            warnings: Vec::new(),
            renormalized: 0,
            worst_norm: None,
            first_duplicate: None,
            duplicates: 0,
            last_duplicate: 0,
        }
    }

    pub(crate) fn line_error(&self, line: usize, problem: impl Into<String>) -> TraceError {
        TraceError::Line {
            path: self.path.clone(),
            line,
            problem: problem.into(),
        }
    }

    pub(crate) fn trace_error(&self, problem: impl Into<String>) -> TraceError {
        TraceError::Trace {
            path: self.path.clone(),
            problem: problem.into(),
        }
    }

    pub(crate) fn warn(&mut self, line: Option<usize>, message: impl AsRef<str>) {
        let w = match line {
            Some(l) => format!("{}:{l}: {}", self.path.display(), message.as_ref()),
            None => format!("{}: {}", self.path.display(), message.as_ref()),
        };
        self.warnings.push(w);
    }

    /// Checks and normalizes a quaternion given as `(x, y, z, w)` in f64.
    pub(crate) fn quaternion(&mut self, line: usize, q: [f64; 4]) -> Result<Quat, TraceError> {
        // Components are finite (checked by the readers) but may be huge
        // (1e308): scale by the largest magnitude before squaring so the norm
        // cannot overflow to ∞ (which turned the quaternion into NaNs; found
        // by `tests/fuzz_inputs.rs`, regression `tests/data/fuzz/huge_quaternion.csv`).
        let scale = q.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        if scale == 0.0 {
            return Err(self.line_error(
                line,
                "quaternion has zero norm; a head orientation needs a unit quaternion (qx,qy,qz,qw)",
            ));
        }
        let q = q.map(|c| c / scale);
        // `unit` ∈ [1, 2]; `norm` may round to ∞ near f64::MAX, harmless below.
        let unit = q.iter().map(|c| c * c).sum::<f64>().sqrt();
        let norm = unit * scale;
        if norm <= 1e-9 {
            return Err(self.line_error(
                line,
                "quaternion has (nearly) zero norm, at most 1e-9; a head orientation needs a unit quaternion (qx,qy,qz,qw)",
            ));
        }
        let dev = (norm - 1.0).abs();
        if dev > NORM_WARN_TOLERANCE {
            self.renormalized += 1;
            if self.worst_norm.is_none_or(|(_, d)| dev > d) {
                self.worst_norm = Some((line, dev));
            }
        }
        let [x, y, z, w] = q.map(|c| (c / unit) as f32);
        Ok(Quat::from_xyzw(x, y, z, w).normalize())
    }

    /// Appends a sample read on `line`: a time before the previous one is an
    /// error, an equal time drops the sample with a warning.
    pub(crate) fn push(&mut self, line: usize, sample: PoseSample) -> Result<(), TraceError> {
        // Each time field is finite on its own, but a time relative to the
        // first sample may not be (`1e308` after `-1e308`): refused here,
        // naming the recording's line, not later in the converted file.
        if !sample.t.is_finite() {
            return Err(self.line_error(
                line,
                format!("time {} s after the first sample is out of range", sample.t),
            ));
        }
        let p = sample.pose.position;
        if !p.is_finite() || p.abs().max_element() as f64 > MAX_POSITION_M {
            return Err(self.line_error(
                line,
                format!(
                    "head position ({}, {}, {}) m is out of range (|x| ≤ {MAX_POSITION_M:e} along each axis)",
                    p.x, p.y, p.z
                ),
            ));
        }
        if let Some(prev) = self.samples.last() {
            if sample.t < prev.t {
                return Err(self.line_error(
                    line,
                    format!(
                        "timestamp {} is earlier than {} on line {}; pose traces must be sorted by time",
                        sample.t, prev.t, self.last_line
                    ),
                ));
            }
            if sample.t == prev.t {
                if self.first_duplicate.is_none() {
                    let msg = format!(
                        "duplicate timestamp {} (same as line {}); sample dropped, first kept",
                        sample.t, self.last_line
                    );
                    self.first_duplicate = Some((line, msg));
                }
                self.duplicates += 1;
                self.last_duplicate = line;
                return Ok(());
            }
        }
        self.samples.push(sample);
        self.last_line = line;
        Ok(())
    }

    pub(crate) fn sample_count(&self) -> usize {
        self.samples.len()
    }

    pub(crate) fn finish(mut self) -> PoseTrace {
        if let Some((line, msg)) = self.first_duplicate.take() {
            let more = match self.duplicates {
                0 | 1 => String::new(),
                n => format!(
                    " ({} more duplicate timestamp(s) dropped the same way, up to line {})",
                    n - 1,
                    self.last_duplicate
                ),
            };
            self.warn(Some(line), format!("{msg}{more}"));
        }
        if let Some((line, dev)) = self.worst_norm {
            let msg = format!(
                "{} quaternion(s) were not unit length and were normalized (worst: line {line}, |norm − 1| = {dev:.3e})",
                self.renormalized
            );
            self.warn(None, msg);
        }
        PoseTrace {
            source: self.path,
            samples: self.samples,
            warnings: self.warnings,
        }
    }
}

/// The text of a trace file (an I/O or UTF-8 error names the file).
pub(crate) fn read_text(path: &Path) -> Result<String, TraceError> {
    crate::input::read_to_string(path).map_err(|e| io_error(path, e))
}

fn io_error(path: &Path, source: std::io::Error) -> TraceError {
    TraceError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Index of each known column in a CSV header.
struct CsvHeader {
    /// Field index of t, px, py, pz, qx, qy, qz, qw.
    required: [usize; 8],
    ipd: Option<usize>,
    fields: usize,
}

fn parse_header(b: &TraceBuilder, line_no: usize, line: &str) -> Result<CsvHeader, TraceError> {
    let mut found: [Option<usize>; 9] = [None; 9];
    let names: Vec<&str> = line.split(',').map(str::trim).collect();
    for (i, name) in names.iter().enumerate() {
        let Some(k) = CSV_COLUMNS.iter().position(|c| c == name) else {
            return Err(b.line_error(
                line_no,
                format!(
                    "unknown column `{}` (column {}); expected t,px,py,pz,qx,qy,qz,qw and optionally ipd",
                    excerpt(name),
                    i + 1
                ),
            ));
        };
        if found[k].is_some() {
            return Err(b.line_error(
                line_no,
                format!("column `{name}` appears twice (column {})", i + 1),
            ));
        }
        found[k] = Some(i);
    }
    let mut required = [0; 8];
    for (k, slot) in required.iter_mut().enumerate() {
        *slot = found[k].ok_or_else(|| {
            b.line_error(
                line_no,
                format!(
                    "missing column `{}`; the header must name t,px,py,pz,qx,qy,qz,qw (ipd optional)",
                    CSV_COLUMNS[k]
                ),
            )
        })?;
    }
    Ok(CsvHeader {
        required,
        ipd: found[8],
        fields: names.len(),
    })
}

/// A field as an error message quotes it: whole up to 40 characters, else
/// its first 40 and the count (a corrupt file may hold megabytes in one).
pub(crate) fn excerpt(text: &str) -> String {
    const MAX: usize = 40;
    match text.char_indices().nth(MAX) {
        None => text.to_string(),
        Some((cut, _)) => format!("{}… ({} characters)", &text[..cut], text.chars().count()),
    }
}

fn parse_field(
    b: &TraceBuilder,
    line_no: usize,
    column: usize,
    name: &str,
    text: &str,
) -> Result<f64, TraceError> {
    if text.is_empty() {
        // Only `ipd` has a default (module docs); the readers skip its
        // empty fields before they get here.
        return Err(b.line_error(
            line_no,
            format!(
                "column `{name}` (column {}): empty field; only `ipd` may be left empty (for the default IPD)",
                column + 1
            ),
        ));
    }
    let v: f64 = text.parse().map_err(|_| {
        b.line_error(
            line_no,
            format!(
                "column `{name}` (column {}): `{}` is not a number",
                column + 1,
                excerpt(text)
            ),
        )
    })?;
    if !v.is_finite() {
        return Err(b.line_error(
            line_no,
            format!(
                "column `{name}` (column {}): value `{}` is not finite",
                column + 1,
                excerpt(text)
            ),
        ));
    }
    Ok(v)
}

impl PoseTrace {
    /// A trace from samples already known to be sorted (synthetic traces,
    /// tests). No checks, no warnings.
    pub fn from_samples(source: impl Into<PathBuf>, samples: Vec<PoseSample>) -> Self {
        Self {
            source: source.into(),
            samples,
            warnings: Vec::new(),
        }
    }

    /// Reads the project's CSV format (see the module documentation for
    /// the format, the errors and the repairs).
    pub fn read_csv(path: impl AsRef<Path>) -> Result<PoseTrace, TraceError> {
        let path = path.as_ref();
        let text = crate::input::read_to_string(path).map_err(|e| io_error(path, e))?;
        Self::parse_csv(path, &text)
    }

    /// Parses CSV text; `path` is used in messages only.
    pub fn parse_csv(path: impl AsRef<Path>, text: &str) -> Result<PoseTrace, TraceError> {
        // A UTF-8 byte-order mark (spreadsheet exports) is not part of `t`.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut b = TraceBuilder::new(path.as_ref());
        let mut header: Option<CsvHeader> = None;
        let mut header_line = 0;
        let mut fields: Vec<&str> = Vec::with_capacity(9);
        for (i, raw) in text.lines().enumerate() {
            let line_no = i + 1;
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let Some(h) = &header else {
                header = Some(parse_header(&b, line_no, line)?);
                header_line = line_no;
                continue;
            };
            fields.clear();
            fields.extend(line.split(',').map(str::trim));
            if fields.len() != h.fields {
                return Err(b.line_error(
                    line_no,
                    format!("{} fields, the header has {}", fields.len(), h.fields),
                ));
            }
            let mut v = [0.0f64; 8];
            for (k, &col) in h.required.iter().enumerate() {
                v[k] = parse_field(&b, line_no, col, CSV_COLUMNS[k], fields[col])?;
                // Positions are stored as f32: a finite f64 beyond f32::MAX
                // would become ∞ (found by `tests/fuzz_inputs.rs`); beyond
                // the scene's ±1e15 bound the render is black.
                if (1..4).contains(&k) && v[k].abs() > MAX_POSITION_M {
                    return Err(b.line_error(
                        line_no,
                        format!(
                            "column `{}` (column {}): position {:e} m is out of range (|x| ≤ {MAX_POSITION_M:e})",
                            CSV_COLUMNS[k],
                            col + 1,
                            v[k],
                        ),
                    ));
                }
            }
            let ipd = match h.ipd {
                Some(col) if !fields[col].is_empty() => {
                    let ipd = parse_field(&b, line_no, col, "ipd", fields[col])?;
                    // Metres in [0, 1), the range of `--ipd` (src/cli/args.rs):
                    // a value in millimetres (63) would otherwise be 63 m.
                    if !(0.0..MAX_IPD_M).contains(&(ipd as f32)) {
                        return Err(b.line_error(
                            line_no,
                            format!(
                                "column `ipd` (column {}): IPD {ipd} is out of range; the column \
                                 is in metres, in [0, {MAX_IPD_M}) as for --ipd (63 mm is 0.063)",
                                col + 1
                            ),
                        ));
                    }
                    Some(ipd as f32)
                }
                _ => None,
            };
            let orientation = b.quaternion(line_no, [v[4], v[5], v[6], v[7]])?;
            let sample = PoseSample {
                t: v[0],
                pose: HeadPose {
                    position: Vec3::new(v[1] as f32, v[2] as f32, v[3] as f32),
                    orientation,
                },
                ipd,
            };
            b.push(line_no, sample)?;
        }
        let path = path.as_ref().to_path_buf();
        if header.is_none() {
            return Err(TraceError::Line {
                path,
                line: 1,
                problem: "empty file; expected a header `t,px,py,pz,qx,qy,qz,qw` and samples"
                    .into(),
            });
        }
        if b.sample_count() == 0 {
            return Err(TraceError::Line {
                path,
                line: header_line + 1,
                problem: "no samples after the header; a trace needs at least one".into(),
            });
        }
        Ok(b.finish())
    }

    /// The CSV text of this trace (full round-trip precision). The `ipd`
    /// column is written when any sample has an IPD; samples without one
    /// get an empty field.
    pub fn to_csv_string(&self) -> String {
        let with_ipd = self.samples.iter().any(|s| s.ipd.is_some());
        let mut out = String::with_capacity(64 * (self.samples.len() + 1));
        out.push_str(&CSV_COLUMNS[..8].join(","));
        if with_ipd {
            out.push_str(",ipd");
        }
        out.push('\n');
        for s in &self.samples {
            let p = s.pose.position;
            let q = s.pose.orientation;
            let _ = write!(
                out,
                "{},{},{},{},{},{},{},{}",
                s.t, p.x, p.y, p.z, q.x, q.y, q.z, q.w
            );
            if with_ipd {
                out.push(',');
                if let Some(ipd) = s.ipd {
                    let _ = write!(out, "{ipd}");
                }
            }
            out.push('\n');
        }
        out
    }

    /// Writes the CSV format to `path` through the one output path
    /// (`output::write_text`: `<path>.partial` beside it, synced, renamed
    /// over `path`), so a reader never sees a half-written file.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<(), TraceError> {
        crate::output::write_text(path.as_ref(), &self.to_csv_string()).map_err(|e| {
            let (path, problem) = e.into_parts();
            TraceError::Trace { path, problem }
        })
    }

    /// Time from the first to the last sample, seconds (0 for fewer than two).
    pub fn duration(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Flips the sign of each quaternion whose dot product with the previous
    /// (already continuous) one is negative, so that neighbouring samples lie
    /// in the same hemisphere of S³ and interpolation takes the short arc.
    /// The rotations are unchanged (`q` and `−q` are the same rotation).
    /// Returns the number of samples whose sign was flipped (a recording
    /// that jumps to the other hemisphere and stays there for a while counts
    /// every sample of that stretch).
    pub fn make_hemisphere_continuous(&mut self) -> usize {
        let mut flips = 0;
        for i in 1..self.samples.len() {
            let prev = self.samples[i - 1].pose.orientation;
            let q = &mut self.samples[i].pose.orientation;
            if prev.dot(*q) < 0.0 {
                *q = -*q;
                flips += 1;
            }
        }
        flips
    }

    /// The interpolated sample at time `t` (clamped to the trace's time
    /// range): position lerp, orientation slerp (shortest arc), IPD lerp
    /// (when only one neighbour has an IPD, that one is used).
    ///
    /// # Panics
    /// If the trace is empty.
    pub fn sample_at(&self, t: f64) -> PoseSample {
        let s = &self.samples;
        assert!(!s.is_empty(), "sample_at on an empty pose trace");
        // First index with time > t.
        let hi = s.partition_point(|x| x.t <= t);
        if hi == 0 {
            return PoseSample { t, ..s[0] };
        }
        if hi == s.len() {
            return PoseSample { t, ..s[hi - 1] };
        }
        interpolate(&s[hi - 1], &s[hi], t)
    }

    /// How many frames [`resample`](Self::resample) gives at `fps`:
    /// ⌊(t_last − t_0)·fps⌋ + 1, as a float so that a trace spanning an
    /// absurd time (a corrupt timestamp) can be refused before anything is
    /// allocated (0 without samples).
    pub fn resampled_len(&self, fps: f64) -> f64 {
        if self.samples.is_empty() {
            return 0.0;
        }
        ((self.duration() * fps) + 1e-9).floor() + 1.0
    }

    /// Resamples at exactly `1/fps` steps from the first to the last
    /// timestamp: `t_k = t_0 + k / fps` for `k = 0 ..= ⌊(t_last − t_0)·fps⌋`
    /// (computed from `k`, not accumulated, so times do not drift). Works on a
    /// hemisphere-continuous copy; position lerp, orientation slerp, IPD lerp.
    ///
    /// # Panics
    /// If `fps` is not finite and positive, or the result would not fit in
    /// memory (callers validate user input: `replay::trace_cameras` refuses
    /// more than `replay::MAX_TRACE_FRAMES` by [`resampled_len`](Self::resampled_len)).
    pub fn resample(&self, fps: f64) -> Vec<PoseSample> {
        assert!(
            self.resampled_len(fps) < usize::MAX as f64 / 2.0,
            "resample: {} s at {fps} fps is too many frames",
            self.duration()
        );
        self.resample_first(fps, usize::MAX)
    }

    /// The first `limit` frames of [`resample`](Self::resample) (all of
    /// them when there are fewer): a replay of the first frames of a long
    /// trace builds only those.
    ///
    /// # Panics
    /// If `fps` is not finite and positive, or the frames to build would
    /// not fit in memory.
    pub fn resample_first(&self, fps: f64, limit: usize) -> Vec<PoseSample> {
        assert!(
            fps.is_finite() && fps > 0.0,
            "resample: fps must be positive, got {fps}"
        );
        let Some(first) = self.samples.first() else {
            return Vec::new();
        };
        let mut cont = self.clone();
        cont.make_hemisphere_continuous();
        let s = &cont.samples;
        let t0 = first.t;
        // Tolerate rounding in (t_last − t_0)·fps so the last frame is kept
        // when the duration is a whole number of frames (resampled_len).
        let count = if self.resampled_len(fps) >= limit as f64 {
            limit
        } else {
            self.resampled_len(fps) as usize
        };
        let mut out = Vec::with_capacity(count);
        let mut hi = 0usize;
        for k in 0..count {
            let t = t0 + k as f64 / fps;
            while hi < s.len() && s[hi].t <= t {
                hi += 1;
            }
            let sample = if hi == 0 {
                PoseSample { t, ..s[0] }
            } else if hi == s.len() {
                PoseSample { t, ..s[hi - 1] }
            } else {
                interpolate(&s[hi - 1], &s[hi], t)
            };
            out.push(sample);
        }
        out
    }
}

fn interpolate(a: &PoseSample, b: &PoseSample, t: f64) -> PoseSample {
    let u = ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0);
    let uf = u as f32;
    let ipd = match (a.ipd, b.ipd) {
        (Some(x), Some(y)) => Some(x + (y - x) * uf),
        (x, y) => x.or(y),
    };
    PoseSample {
        t,
        pose: a.pose.interpolate(&b.pose, uf),
        ipd,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, x: f32, yaw: f32) -> PoseSample {
        PoseSample {
            t,
            pose: HeadPose::new(Vec3::new(x, 0.0, 0.0), Quat::from_rotation_y(yaw)),
            ipd: None,
        }
    }

    #[test]
    fn parse_is_order_free_and_normalizes() {
        let text = "qw,qx,qy,qz,t,pz,py,px,ipd\n2,0,0,0,0,3,2,1,0.06\n1,0,0,0,0.5,0,0,0,\n";
        let tr = PoseTrace::parse_csv("x.csv", text).unwrap();
        assert_eq!(tr.samples.len(), 2);
        assert_eq!(tr.samples[0].pose.position, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(tr.samples[0].pose.orientation, Quat::IDENTITY);
        assert_eq!(tr.samples[0].ipd, Some(0.06));
        assert_eq!(tr.samples[1].ipd, None);
        assert_eq!(tr.warnings.len(), 1, "{:?}", tr.warnings);
        assert!(tr.warnings[0].contains("line 2"));
    }

    /// The `ipd` column is metres in [0, 1), as `--ipd`: 63 (millimetres
    /// by mistake) is an error naming the file, the line and the column.
    #[test]
    fn an_ipd_in_millimetres_is_an_error_naming_line_and_column() {
        let head = "t,px,py,pz,qx,qy,qz,qw,ipd\n0,0,0,0,0,0,0,1,0.063\n";
        let tr = PoseTrace::parse_csv("x.csv", head).unwrap();
        assert_eq!(tr.samples[0].ipd, Some(0.063));
        let text = format!("{head}0.1,0,0,0,0,0,0,1,63\n");
        let e = PoseTrace::parse_csv("x.csv", &text)
            .unwrap_err()
            .to_string();
        for part in ["x.csv:3:", "column `ipd` (column 9)", "IPD 63", "metres"] {
            assert!(e.contains(part), "'{part}' missing in: {e}");
        }
        assert!(!e.contains('\n'), "{e}");
        let one = format!("{head}0.1,0,0,0,0,0,0,1,1\n");
        assert!(PoseTrace::parse_csv("x.csv", &one).is_err());
    }

    #[test]
    fn errors_quote_a_huge_field_in_part() {
        let junk = "9x".repeat(2_500_000);
        let text = format!("t,px,py,pz,qx,qy,qz,qw\n0,{junk},0,0,0,0,0,1\n");
        let e = PoseTrace::parse_csv("big.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(e.len() < 300, "{} characters", e.len());
        assert!(
            e.contains(
                "`9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x9x… (5000000 characters)` is not a number"
            ),
            "{e}"
        );
        assert_eq!(excerpt("0.25"), "0.25");
    }

    #[test]
    fn resampled_len_counts_frames_without_allocating() {
        let tr = PoseTrace::from_samples("mem", vec![sample(1.0, 0.0, 0.0), sample(2.0, 1.0, 1.0)]);
        assert_eq!(tr.resampled_len(4.0), tr.resample(4.0).len() as f64);
        let far =
            PoseTrace::from_samples("mem", vec![sample(0.0, 0.0, 0.0), sample(1e300, 0.0, 0.0)]);
        let n = far.resampled_len(90.0);
        assert!(n.is_finite() && (n / 9e301 - 1.0).abs() < 1e-12, "{n}");
        assert_eq!(
            PoseTrace::from_samples("mem", vec![]).resampled_len(90.0),
            0.0
        );
    }

    #[test]
    fn resample_hits_exact_times_and_interpolates() {
        let tr = PoseTrace::from_samples("mem", vec![sample(1.0, 0.0, 0.0), sample(2.0, 1.0, 1.0)]);
        let r = tr.resample(4.0);
        let times: Vec<f64> = r.iter().map(|s| s.t).collect();
        assert_eq!(times, vec![1.0, 1.25, 1.5, 1.75, 2.0]);
        assert!((r[2].pose.position.x - 0.5).abs() < 1e-6);
        let (_, angle) = r[2].pose.orientation.to_axis_angle();
        assert!((angle - 0.5).abs() < 1e-5);
        assert_eq!(tr.sample_at(5.0).pose, tr.samples[1].pose);
    }

    #[test]
    fn hemisphere_continuity_flips_negative_dot() {
        let mut tr = PoseTrace::from_samples(
            "mem",
            vec![
                sample(0.0, 0.0, 0.1),
                sample(1.0, 0.0, 0.2),
                sample(2.0, 0.0, 0.3),
            ],
        );
        tr.samples[1].pose.orientation = -tr.samples[1].pose.orientation;
        assert_eq!(tr.make_hemisphere_continuous(), 1);
        assert!(tr.samples[1].pose.orientation.w > 0.0);
        assert_eq!(tr.make_hemisphere_continuous(), 0);
    }
}
