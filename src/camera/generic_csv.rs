//! Importer for head-pose recordings in any delimited text layout: the
//! columns, the time unit and the coordinate convention are given by the
//! caller (`stereocache trace convert --format csv`).
//!
//! # What it reads
//!
//! Delimited text as split by `src/camera/table.rs` (comma, semicolon or
//! whitespace; optional header line, detected as a first line without a
//! numeric field). A [`ColumnMap`] says which field holds the time, the
//! position `x, y, z` (optional) and the quaternion `qx, qy, qz, qw`, by
//! 0-based index or by header name (two quantities in one field is an
//! error: a typo, not a layout):
//!
//! ```text
//! --columns t=0,x=1,y=2,z=3,qx=4,qy=5,qz=6,qw=7
//! --columns t=timestamp,qw=rot_w,qx=rot_x,qy=rot_y,qz=rot_z    (orientation only)
//! ```
//!
//! Without a map the header is searched (case-insensitively) for `t`,
//! `time` or `timestamp`; `x`/`px`, `y`/`py`, `z`/`pz`; `qx`, `qy`, `qz`,
//! `qw` — the layout of the Fraunhofer HHI pred6dof HoloLens traces
//! (`timestamp,x,y,z,qx,qy,qz,qw`, .NET ticks, Unity axes: convert with
//! `--format csv --time-unit ticks --handedness left --up y`). Other
//! columns are ignored: recorders log controllers, eyes and more beside the
//! head. A map naming a column or index the file does not have is an error.
//!
//! Without position columns the eye midpoint comes from a
//! [`HeadNeckModel`] (orientation-only trackers), as for MMSys'18.
//!
//! # Conversion
//!
//! Time: [`TimeUnit`], integers differenced exactly ([`super::time_unit`]),
//! re-based so the first kept sample is at 0 s. Positions (metres) and
//! orientations (head → world) are mapped from the given
//! [`AxisConvention`] to glTF axes ([`super::convention`]). Quaternions are
//! normalized (warning when far from unit), made hemisphere-continuous
//! (count in the warnings).
//!
//! # Errors (one line naming the file and the line)
//!
//! Empty file, no samples, unknown column, field count different from the
//! header's (a truncated final line is dropped with a warning instead), a
//! field that is not a number, NaN/±Inf, a position beyond f32's range,
//! a zero-norm quaternion, a time earlier than the previous line's (also
//! outside the kept window: an unsorted file is a clock or concatenation
//! problem). Equal times drop the later sample with a warning.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use glam::Vec3;

use super::convention::AxisConvention;
use super::neck::HeadNeckModel;
use super::pose::HeadPose;
use super::table::{read_table, HeaderRule, Record, Table};
use super::time_unit::{RawTime, TimeUnit, TimeWindow};
use super::trace::{excerpt, PoseSample, PoseTrace, TraceBuilder, TraceError};

/// The quantities a column map assigns, in [`ColumnMap`] order.
pub const COLUMN_KEYS: [&str; 8] = ["t", "x", "y", "z", "qx", "qy", "qz", "qw"];

/// Where a quantity is: a 0-based field index or a header name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ColumnRef {
    /// 0-based field index.
    Index(usize),
    /// A header name (exact, after trimming).
    Name(String),
}

impl fmt::Display for ColumnRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ColumnRef::Index(i) => write!(f, "{i}"),
            ColumnRef::Name(n) => f.write_str(n),
        }
    }
}

/// Which field holds each quantity (`--columns t=0,x=1,...`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnMap {
    /// Time.
    pub t: ColumnRef,
    /// Position x, y, z; `None` = orientation only (head–neck model).
    pub position: Option<[ColumnRef; 3]>,
    /// Quaternion qx, qy, qz, qw.
    pub orientation: [ColumnRef; 4],
}

impl ColumnMap {
    /// A map by 0-based indices: `t`, `x, y, z` (or none), `qx, qy, qz, qw`.
    pub fn indices(t: usize, position: Option<[usize; 3]>, orientation: [usize; 4]) -> Self {
        Self {
            t: ColumnRef::Index(t),
            position: position.map(|p| p.map(ColumnRef::Index)),
            orientation: orientation.map(ColumnRef::Index),
        }
    }
}

/// A `--columns` value that cannot be a column map.
#[derive(Debug, thiserror::Error)]
#[error("bad column map `{text}`: {problem}")]
pub struct BadColumnMap {
    /// The value given.
    pub text: String,
    /// What is wrong.
    pub problem: String,
}

impl FromStr for ColumnMap {
    type Err = BadColumnMap;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = |problem: String| BadColumnMap {
            text: s.to_string(),
            problem,
        };
        let mut slots: [Option<ColumnRef>; 8] = Default::default();
        for item in s.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let Some((key, value)) = item.split_once('=') else {
                return Err(bad(format!(
                    "`{item}` is not KEY=COLUMN (e.g. t=0 or qw=rot_w)"
                )));
            };
            let (key, value) = (key.trim(), value.trim());
            let Some(k) = COLUMN_KEYS.iter().position(|c| *c == key) else {
                return Err(bad(format!(
                    "unknown key `{key}`; the keys are t, x, y, z, qx, qy, qz, qw"
                )));
            };
            if value.is_empty() {
                return Err(bad(format!("`{key}` has no column")));
            }
            let r = match value.parse::<usize>() {
                Ok(i) => ColumnRef::Index(i),
                Err(_) => ColumnRef::Name(value.to_string()),
            };
            if slots[k].replace(r).is_some() {
                return Err(bad(format!("`{key}` is given twice")));
            }
        }
        let [t, x, y, z, qx, qy, qz, qw] = slots;
        let t = t.ok_or_else(|| bad("no `t` (time) column".into()))?;
        let position =
            match (x, y, z) {
                (Some(x), Some(y), Some(z)) => Some([x, y, z]),
                (None, None, None) => None,
                _ => return Err(bad(
                    "give all of x, y, z or none (none: the position comes from a head–neck model)"
                        .into(),
                )),
            };
        let orientation = match (qx, qy, qz, qw) {
            (Some(qx), Some(qy), Some(qz), Some(qw)) => [qx, qy, qz, qw],
            _ => return Err(bad("qx, qy, qz and qw are all needed".into())),
        };
        Ok(Self {
            t,
            position,
            orientation,
        })
    }
}

/// How to import a generic CSV recording.
#[derive(Clone, Debug, PartialEq)]
pub struct CsvOptions {
    /// Column map; `None` finds the columns by header name (module docs).
    pub columns: Option<ColumnMap>,
    /// Unit of the time column.
    pub time_unit: TimeUnit,
    /// Coordinate convention of positions and orientations.
    pub convention: AxisConvention,
    /// Samples kept, seconds from the first sample of the file.
    pub window: TimeWindow,
    /// Translation model when there are no position columns.
    pub neck: HeadNeckModel,
}

impl CsvOptions {
    /// Options for a unit and convention; all samples, default neck model.
    pub fn new(time_unit: TimeUnit, convention: AxisConvention) -> Self {
        Self {
            columns: None,
            time_unit,
            convention,
            window: TimeWindow::default(),
            neck: HeadNeckModel::default(),
        }
    }
}

/// Field indices of each quantity, resolved against a file.
#[derive(Clone, Debug)]
pub(crate) struct Columns {
    pub t: usize,
    pub position: Option<[usize; 3]>,
    pub orientation: [usize; 4],
    /// How messages name each quantity's column, [`COLUMN_KEYS`] order.
    pub labels: [String; 8],
}

impl Columns {
    /// Labels from the header names (or field indices) of a resolved map.
    pub(crate) fn new(
        header: Option<&Record>,
        t: usize,
        position: Option<[usize; 3]>,
        orientation: [usize; 4],
    ) -> Self {
        let label = |k: usize, i: Option<usize>| match (i, header) {
            (Some(i), Some(h)) => format!("column `{}` (index {i})", excerpt(h.fields[i])),
            (Some(i), None) => format!("field index {i} (`{}`)", COLUMN_KEYS[k]),
            (None, _) => String::new(),
        };
        let p = position.map_or([None; 3], |p| p.map(Some));
        let labels = [
            label(0, Some(t)),
            label(1, p[0]),
            label(2, p[1]),
            label(3, p[2]),
            label(4, Some(orientation[0])),
            label(5, Some(orientation[1])),
            label(6, Some(orientation[2])),
            label(7, Some(orientation[3])),
        ];
        Self {
            t,
            position,
            orientation,
            labels,
        }
    }
}

/// Header-name synonyms searched when no column map is given.
const DEFAULT_NAMES: [&[&str]; 8] = [
    &["t", "time", "timestamp"],
    &["x", "px"],
    &["y", "py"],
    &["z", "pz"],
    &["qx"],
    &["qy"],
    &["qz"],
    &["qw"],
];

fn resolve(
    b: &TraceBuilder,
    table: &Table,
    map: Option<&ColumnMap>,
) -> Result<Columns, TraceError> {
    let header = table.header.as_ref();
    let n_fields = table.rows[0].fields.len();
    let first_line = header.map_or(table.rows[0].line, |h| h.line);
    let Some(map) = map else {
        let Some(h) = header else {
            return Err(b.line_error(
                first_line,
                "no header line to find the columns by name; give --columns with field indices, e.g. t=0,x=1,y=2,z=3,qx=4,qy=5,qz=6,qw=7",
            ));
        };
        let find = |k: usize| {
            h.fields.iter().position(|f| {
                DEFAULT_NAMES[k]
                    .iter()
                    .any(|name| f.eq_ignore_ascii_case(name))
            })
        };
        let found: Vec<Option<usize>> = (0..8).map(find).collect();
        for k in [0, 4, 5, 6, 7] {
            if found[k].is_none() {
                return Err(b.line_error(
                    h.line,
                    format!(
                        "no column named {} in the header; name the columns with --columns (e.g. t=timestamp,qw=rot_w,...)",
                        DEFAULT_NAMES[k].join(" or ")
                    ),
                ));
            }
        }
        let position = match (found[1], found[2], found[3]) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            (None, None, None) => None,
            _ => {
                return Err(b.line_error(
                    h.line,
                    "the header has some but not all of the position columns x, y, z",
                ))
            }
        };
        let o = [found[4], found[5], found[6], found[7]].map(Option::unwrap);
        return Ok(Columns::new(header, found[0].unwrap(), position, o));
    };
    let index = |key: &str, r: &ColumnRef| -> Result<usize, TraceError> {
        match r {
            ColumnRef::Index(i) if *i < n_fields => Ok(*i),
            ColumnRef::Index(i) => Err(b.line_error(
                first_line,
                format!(
                    "--columns {key}={i}: the file has {n_fields} fields per line (indices 0 to {})",
                    n_fields - 1
                ),
            )),
            ColumnRef::Name(n) => {
                let Some(h) = header else {
                    return Err(b.line_error(
                        first_line,
                        format!("--columns {key}={n}: the file has no header line, give a field index"),
                    ));
                };
                h.fields.iter().position(|f| f == n).ok_or_else(|| {
                    b.line_error(
                        h.line,
                        format!(
                            "unknown column `{}` (--columns {key}={}); the header has {}",
                            excerpt(n),
                            excerpt(n),
                            h.fields.iter().map(|f| excerpt(f)).collect::<Vec<_>>().join(", ")
                        ),
                    )
                })
            }
        }
    };
    let t = index("t", &map.t)?;
    let position = match &map.position {
        Some(p) => Some([index("x", &p[0])?, index("y", &p[1])?, index("z", &p[2])?]),
        None => None,
    };
    let o = &map.orientation;
    let orientation = [
        index("qx", &o[0])?,
        index("qy", &o[1])?,
        index("qz", &o[2])?,
        index("qw", &o[3])?,
    ];
    let mut used: Vec<(usize, &str)> = vec![(t, "t")];
    if let Some(p) = position {
        used.extend(p.into_iter().zip(["x", "y", "z"]));
    }
    used.extend(orientation.into_iter().zip(["qx", "qy", "qz", "qw"]));
    for (k, &(i, key)) in used.iter().enumerate() {
        if let Some(&(_, other)) = used[..k].iter().find(|(j, _)| *j == i) {
            return Err(b.line_error(
                first_line,
                format!("--columns maps both `{other}` and `{key}` to field index {i}"),
            ));
        }
    }
    Ok(Columns::new(header, t, position, orientation))
}

/// How rows become samples: shared by the generic CSV, OpenXR and MMSys'17
/// importers (each fixes some of it).
pub(crate) struct RowConversion<'a> {
    pub columns: &'a Columns,
    pub time_unit: TimeUnit,
    pub convention: AxisConvention,
    pub window: TimeWindow,
    pub neck: HeadNeckModel,
}

fn number(b: &TraceBuilder, line: usize, label: &str, text: &str) -> Result<f64, TraceError> {
    let v: f64 = text.parse().map_err(|_| {
        b.line_error(
            line,
            format!("{label}: `{}` is not a number", excerpt(text)),
        )
    })?;
    if !v.is_finite() {
        return Err(b.line_error(
            line,
            format!("{label}: value `{}` is not finite", excerpt(text)),
        ));
    }
    Ok(v)
}

/// Converts rows to a trace (module docs). `keep` may drop a row (after its
/// time was checked) by returning `false`.
pub(crate) fn rows_to_trace(
    mut b: TraceBuilder,
    rows: &[Record],
    conv: &RowConversion,
    mut keep: impl FnMut(&mut TraceBuilder, &Record) -> Result<bool, TraceError>,
) -> Result<PoseTrace, TraceError> {
    let c = conv.columns;
    let mut origin: Option<RawTime> = None;
    let mut prev: Option<(f64, usize, &str)> = None;
    let mut t_first_kept: Option<f64> = None;
    for row in rows {
        let line = row.line;
        let text = row.fields[c.t];
        let raw = RawTime::parse(text).ok_or_else(|| {
            b.line_error(
                line,
                format!("{}: `{}` is not a number", c.labels[0], excerpt(text)),
            )
        })?;
        if !raw.is_finite() {
            return Err(b.line_error(
                line,
                format!("{}: value `{}` is not finite", c.labels[0], excerpt(text)),
            ));
        }
        let t = raw.seconds_since(*origin.get_or_insert(raw), conv.time_unit);
        if let Some((t_prev, line_prev, text_prev)) = prev {
            if t < t_prev {
                return Err(b.line_error(
                    line,
                    format!(
                        "time `{text}` is earlier than `{text_prev}` on line {line_prev}; samples must be in time order"
                    ),
                ));
            }
        }
        prev = Some((t, line, text));
        if !conv.window.contains(t) || !keep(&mut b, row)? {
            continue;
        }
        let mut q = [0.0; 4];
        for (k, &i) in c.orientation.iter().enumerate() {
            q[k] = number(&b, line, &c.labels[4 + k], row.fields[i])?;
        }
        let orientation = b.quaternion(line, conv.convention.quaternion(q))?;
        let pose = match c.position {
            Some(pi) => {
                let mut p = [0.0; 3];
                for (k, &i) in pi.iter().enumerate() {
                    p[k] = number(&b, line, &c.labels[1 + k], row.fields[i])?;
                    if !(p[k] as f32).is_finite() {
                        return Err(b.line_error(
                            line,
                            format!(
                                "{}: position {} m is out of range (|x| ≤ {:e})",
                                c.labels[1 + k],
                                p[k],
                                f32::MAX
                            ),
                        ));
                    }
                }
                let [x, y, z] = conv.convention.position(p);
                HeadPose {
                    position: Vec3::new(x as f32, y as f32, z as f32),
                    orientation,
                }
            }
            None => conv.neck.pose(orientation),
        };
        let t0 = *t_first_kept.get_or_insert(t);
        b.push(
            line,
            PoseSample {
                t: t - t0,
                pose,
                ipd: None,
            },
        )?;
    }
    if b.sample_count() == 0 {
        return Err(b.trace_error(format!(
            "no samples with {} s ≤ t ≤ {} s (seconds from the first sample)",
            conv.window.start, conv.window.end
        )));
    }
    Ok(finish_continuous(b))
}

/// Finishes a trace and makes it hemisphere-continuous, with the count of
/// flipped samples in the warnings.
pub(crate) fn finish_continuous(b: TraceBuilder) -> PoseTrace {
    let mut trace = b.finish();
    let flips = trace.make_hemisphere_continuous();
    if flips > 0 {
        let msg = format!(
            "{}: {flips} sample(s) had their quaternion sign flipped for hemisphere continuity",
            trace.source.display()
        );
        trace.warnings.push(msg);
    }
    trace
}

/// Parses generic CSV text (module docs); `path` names the file in messages.
pub fn parse_generic_csv(
    path: impl AsRef<Path>,
    text: &str,
    opts: &CsvOptions,
) -> Result<PoseTrace, TraceError> {
    let mut b = TraceBuilder::new(path.as_ref());
    let table = read_table(
        &mut b,
        text,
        HeaderRule::Detect,
        "delimited rows of time, position and quaternion",
    )?;
    let columns = resolve(&b, &table, opts.columns.as_ref())?;
    let conv = RowConversion {
        columns: &columns,
        time_unit: opts.time_unit,
        convention: opts.convention,
        window: opts.window,
        neck: opts.neck,
    };
    rows_to_trace(b, &table.rows, &conv, |_, _| Ok(true))
}

/// Reads a generic CSV recording.
pub fn read_generic_csv(
    path: impl AsRef<Path>,
    opts: &CsvOptions,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let text = super::trace::read_text(path)?;
    parse_generic_csv(path, &text, opts)
}
