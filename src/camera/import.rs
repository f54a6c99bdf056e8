//! One entry point for every recording format `trace convert` reads: the
//! format with its options, the import, and the convention check after it.

use std::path::Path;

use super::generic_csv::{read_generic_csv, CsvOptions};
use super::mmsys17::{read_mmsys17, Mmsys17Options};
use super::mmsys18::{read_mmsys18, Mmsys18Options};
use super::motion_check::convention_warning;
use super::openxr::read_openxr;
use super::time_unit::TimeWindow;
use super::trace::{PoseTrace, TraceError};

/// A recording format and how to read it.
#[derive(Clone, Debug, PartialEq)]
pub enum TraceFormat {
    /// MMSys'18 multi-viewpoint 360° logs ([`super::mmsys18`]).
    Mmsys18(Mmsys18Options),
    /// Corbillon et al. MMSys'17 360° head movements ([`super::mmsys17`]).
    Mmsys17(Mmsys17Options),
    /// OpenXR-style `XrTime` + `XrPosef` logs ([`super::openxr`]).
    OpenXr(TimeWindow),
    /// Any delimited layout, columns/unit/axes given ([`super::generic_csv`]).
    Csv(CsvOptions),
}

/// Reads `path` in `format`; when the motion disagrees with the view
/// direction ([`super::motion_check`]) a warning is added.
pub fn import_trace(path: impl AsRef<Path>, format: &TraceFormat) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let mut trace = match format {
        TraceFormat::Mmsys18(o) => read_mmsys18(path, o)?,
        TraceFormat::Mmsys17(o) => read_mmsys17(path, o)?,
        TraceFormat::OpenXr(w) => read_openxr(path, *w)?,
        TraceFormat::Csv(o) => read_generic_csv(path, o)?,
    };
    if let Some(w) = convention_warning(&trace) {
        trace.warnings.push(w);
    }
    Ok(trace)
}

/// Imports `input` and writes it to `output` in the project's CSV format
/// (backs `stereocache trace convert`). Returns the converted trace.
pub fn convert_trace(
    input: impl AsRef<Path>,
    output: impl AsRef<Path>,
    format: &TraceFormat,
) -> Result<PoseTrace, TraceError> {
    let trace = import_trace(input, format)?;
    trace.write_csv(output)?;
    Ok(trace)
}
