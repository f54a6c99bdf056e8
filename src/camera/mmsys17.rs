//! Importer for the Corbillon et al. MMSys'17 360° video head-movement
//! dataset.
//!
//! Source: X. Corbillon, F. De Simone, G. Simon, "360-Degree Video Head
//! Movement Dataset", ACM MMSys 2017 (data: `dash.ipv6.enstb.fr/headMovements`,
//! recorder: `github.com/xmar/360Degree_Head_Movement_Dataset`). 59 users
//! watch five 360° videos in an OSVR HDK2 headset; one file per user and
//! video.
//!
//! # File format
//!
//! Space-separated text, no header, one sample per line. The recorder's
//! `Log` writer (`src/Log.hpp`) wrote two layouts over its history, both
//! read here (the layout is fixed by the first line's field count):
//!
//! ```text
//! t frameId pts w x y z      (7 fields: recorder commits 380d87e to 400c706)
//! t frameId w x y z          (6 fields: the final recorder, and the published
//!                             dataset as its loaders read it — timestamp,
//!                             frameId, q0, q1, q2, q3)
//! ```
//!
//! - `t`: seconds (`seconds.microseconds`) since the start of the log.
//! - `frameId`: index of the video frame displayed; `pts`: its presentation
//!   timestamp. Both describe the video, not the head: ignored.
//! - `w x y z`: unit quaternion, scalar first, head → world.
//!
//! # Axes
//!
//! +x forward, +y right, +z up, head → world: the frame the recorder writes
//! (`src/RenderManagerOpenGLHighPolyTest.cpp`: `Rz(−90°)·(w, −z, −x, −y)` of
//! the OSVR pose, whose frame is +x right, +y up, +z back: an OSVR left turn
//! becomes a rotation about −z, looking up raises +z) and the authors' viewport
//! tool reads (`360Transformations`: viewport centre `q·(1,0,0)`,
//! image-right +y, +z up; [`super::mmsys18`] module docs, "Axes"). The frame
//! is left-handed; the conversion to glTF is [`AxisConvention::CORBILLON`]:
//! `(qx, qy, qz, qw)_glTF = (−y, −z, x, w)`. (Until session 56 +y was read as
//! left, which mirrored every turn. The recorder's `Rz(−90°)` makes the
//! identity pose a view 90° left of the video's centre; a constant turn
//! changes nothing once a trace is placed at a scene camera.) The 2017
//! post-processing (`CQuaternion.cpp`'s `ComputeVision`, `Statistics.py`)
//! takes image-right as −y and forward as −x; the recorder and the viewport
//! tool agree with each other and are what wrote and read the data.
//! No MMSys'17 file is in `../shared`: the frame rests on the recorder's
//! code, not on data.
//!
//! # Position, repairs
//!
//! Orientation only: the eye midpoint comes from a [`HeadNeckModel`], as
//! for MMSys'18. Errors and repairs as for the generic CSV importer
//! ([`super::generic_csv`]); the kept window is in seconds from the first
//! sample.

use std::path::Path;

use super::convention::AxisConvention;
use super::generic_csv::{rows_to_trace, Columns, RowConversion};
use super::neck::HeadNeckModel;
use super::table::{read_table, HeaderRule};
use super::time_unit::{TimeUnit, TimeWindow};
use super::trace::{PoseTrace, TraceBuilder, TraceError};

/// How to import an MMSys'17 trace.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Mmsys17Options {
    /// Translation model (default: Oculus SDK neck-to-eye offsets).
    pub neck: HeadNeckModel,
    /// Samples kept, seconds from the first sample.
    pub window: TimeWindow,
}

/// Parses MMSys'17 text; `path` names the file in messages.
pub fn parse_mmsys17(
    path: impl AsRef<Path>,
    text: &str,
    opts: &Mmsys17Options,
) -> Result<PoseTrace, TraceError> {
    let mut b = TraceBuilder::new(path.as_ref());
    let expected = "lines `t frameId w x y z` or `t frameId pts w x y z`";
    let table = read_table(&mut b, text, HeaderRule::Never, expected)?;
    let first = &table.rows[0];
    // Quaternion fields (x, y, z, w order) by layout.
    let q = match first.fields.len() {
        6 => [3, 4, 5, 2],
        7 => [4, 5, 6, 3],
        n => {
            return Err(b.line_error(
                first.line,
                format!("{n} fields; an MMSys'17 trace has 6 or 7 ({expected})"),
            ))
        }
    };
    let columns = Columns::new(None, 0, None, q);
    let conv = RowConversion {
        columns: &columns,
        time_unit: TimeUnit::Seconds,
        convention: AxisConvention::CORBILLON,
        window: opts.window,
        neck: opts.neck,
    };
    rows_to_trace(b, &table.rows, &conv, |_, _| Ok(true))
}

/// Reads an MMSys'17 head-movement file.
pub fn read_mmsys17(
    path: impl AsRef<Path>,
    opts: &Mmsys17Options,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let text = super::trace::read_text(path)?;
    parse_mmsys17(path, &text, opts)
}
