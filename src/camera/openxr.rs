//! Importer for OpenXR-style head-pose logs: `XrTime` and the `XrPosef` of
//! the head — the `VIEW` reference space located with `xrLocateSpace` in a
//! `STAGE` or `LOCAL` space — one sample per line.
//!
//! **The head, not an eye.** stereocache places the eyes itself, half the
//! IPD either side of the head pose along its +X ([`crate::camera`]), so a
//! log of one eye's `XrView` pose from `xrLocateViews` would be taken for
//! the head: that eye would be rendered at twice its offset from the head
//! and the other eye near the head's centre. A log of views only converts by taking the midpoint of the two
//! eyes' positions and the head's orientation (the views' own orientation
//! where the displays are parallel; canted displays rotate each view
//! outwards, which the head's pose does not have).
//!
//! # File format
//!
//! Comma-separated (split as in `src/camera/table.rs`) with a header naming the columns
//! after the OpenXR structure members, in any order:
//!
//! ```text
//! time,position.x,position.y,position.z,orientation.x,orientation.y,orientation.z,orientation.w[,flags]
//! 1234567890123,0.01,1.62,-0.02,0,0.0087,0,0.99996,15
//! ```
//!
//! - `time`: `XrTime`, int64 nanoseconds on the runtime's clock (arbitrary
//!   epoch); differenced exactly as integers and re-based to 0 at the
//!   first sample.
//! - `position.*`: `XrVector3f`, metres; `orientation.*`: `XrQuaternionf`
//!   in OpenXR's `x, y, z, w` order, view → space.
//! - `flags` (optional): `XrSpaceLocationFlags` from `xrLocateSpace` (or
//!   `XrViewStateFlags` from `xrLocateViews`, whose valid bits have the same
//!   values; decimal or `0x` hex). The OpenXR specification leaves
//!   a pose component undefined unless its `*_VALID_BIT` is set, so a
//!   sample without `ORIENTATION_VALID` (0x1) and `POSITION_VALID` (0x2) is
//!   dropped (one warning with the count and the first line; tracking loss
//!   is common in real logs). The `*_TRACKED` bits are not required
//!   (inferred poses are valid data).
//!
//! A column the format does not know is an error that names it (as for the
//! project's CSV): a typo must not be silently ignored. For other layouts
//! use the generic importer ([`super::generic_csv`],
//! `--format csv --time-unit ns --handedness right`).
//!
//! # Axes
//!
//! OpenXR's spaces are right-handed with +Y up and the view looking down
//! −Z (OpenXR specification, "Coordinate System"), the same as glTF: no axis
//! change ([`AxisConvention::GLTF`]). Errors and repairs as for the
//! generic CSV importer.

use std::path::Path;

use super::convention::AxisConvention;
use super::generic_csv::{rows_to_trace, Columns, RowConversion};
use super::neck::HeadNeckModel;
use super::table::{read_table, HeaderRule};
use super::time_unit::{TimeUnit, TimeWindow};
use super::trace::{excerpt, PoseTrace, TraceBuilder, TraceError};

/// Column names of the OpenXR-style format (`flags` optional), in
/// [`super::generic_csv::COLUMN_KEYS`] order.
pub const OPENXR_COLUMNS: [&str; 9] = [
    "time",
    "position.x",
    "position.y",
    "position.z",
    "orientation.x",
    "orientation.y",
    "orientation.z",
    "orientation.w",
    "flags",
];

/// `XR_SPACE_LOCATION_ORIENTATION_VALID_BIT | XR_SPACE_LOCATION_POSITION_VALID_BIT`.
pub const POSE_VALID_BITS: u64 = 0x1 | 0x2;

fn parse_flags(text: &str) -> Option<u64> {
    match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => text.parse().ok(),
    }
}

/// Parses OpenXR-style text; `window` in seconds from the first sample.
pub fn parse_openxr(
    path: impl AsRef<Path>,
    text: &str,
    window: TimeWindow,
) -> Result<PoseTrace, TraceError> {
    let mut b = TraceBuilder::new(path.as_ref());
    let expected = format!("a header `{}` and samples", OPENXR_COLUMNS[..8].join(","));
    let table = read_table(&mut b, text, HeaderRule::Required, &expected)?;
    let header = table.header.as_ref().expect("HeaderRule::Required");
    let mut found: [Option<usize>; 9] = [None; 9];
    for (i, name) in header.fields.iter().enumerate() {
        let Some(k) = OPENXR_COLUMNS.iter().position(|c| c == name) else {
            return Err(b.line_error(
                header.line,
                format!(
                    "unknown column `{}` (column {}); expected {} and optionally flags",
                    excerpt(name),
                    i + 1,
                    OPENXR_COLUMNS[..8].join(",")
                ),
            ));
        };
        if found[k].replace(i).is_some() {
            return Err(b.line_error(header.line, format!("column `{name}` appears twice")));
        }
    }
    let mut idx = [0usize; 8];
    for (k, slot) in idx.iter_mut().enumerate() {
        *slot = found[k].ok_or_else(|| {
            b.line_error(
                header.line,
                format!("missing column `{}`", OPENXR_COLUMNS[k]),
            )
        })?;
    }
    let columns = Columns::new(
        Some(header),
        idx[0],
        Some([idx[1], idx[2], idx[3]]),
        [idx[4], idx[5], idx[6], idx[7]],
    );
    let conv = RowConversion {
        columns: &columns,
        time_unit: TimeUnit::Nanoseconds,
        convention: AxisConvention::GLTF,
        window,
        neck: HeadNeckModel::NONE,
    };
    let flags_col = found[8];
    let mut invalid = 0usize;
    let mut first_invalid = 0usize;
    let result = rows_to_trace(b, &table.rows, &conv, |b, row| {
        let Some(col) = flags_col else {
            return Ok(true);
        };
        let text = row.fields[col];
        let flags = parse_flags(text).ok_or_else(|| {
            b.line_error(
                row.line,
                format!(
                    "column `flags` (column {}): `{}` is not an XrSpaceLocationFlags integer",
                    col + 1,
                    excerpt(text)
                ),
            )
        })?;
        if flags & POSE_VALID_BITS == POSE_VALID_BITS {
            return Ok(true);
        }
        if invalid == 0 {
            first_invalid = row.line;
        }
        invalid += 1;
        Ok(false)
    });
    let mut trace = match result {
        Err(TraceError::Trace { path, .. }) if invalid > 0 => {
            return Err(TraceError::Trace {
                path,
                problem: format!(
                    "no valid samples: all {invalid} sample(s) in the time window lack ORIENTATION_VALID and POSITION_VALID in `flags` (first: line {first_invalid})"
                ),
            })
        }
        r => r?,
    };
    if invalid > 0 {
        trace.warnings.push(format!(
            "{}: {invalid} sample(s) without ORIENTATION_VALID and POSITION_VALID in `flags` dropped (first: line {first_invalid})",
            trace.source.display()
        ));
    }
    Ok(trace)
}

/// Reads an OpenXR-style pose log.
pub fn read_openxr(path: impl AsRef<Path>, window: TimeWindow) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let text = super::trace::read_text(path)?;
    parse_openxr(path, &text, window)
}
