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
//! Right-handed, +x forward (the centre of the equirectangular frame), +y
//! left, +z up: the MMSys'18 dataset's README says its quaternions use
//! "the same convention as for the dataset of Corbillon et al.", and the
//! MMSys'18 importer ([`super::mmsys18`]) established and checked that
//! reading against its data (head up axis stays near +z, yaw dominates,
//! small roll). The recorder's own post-processing reads `values[2..6]` as
//! `w, x, y, z` and takes yaw about +z. So the conversion to glTF is the
//! same proper rotation, [`AxisConvention::CORBILLON`]:
//! `(qx, qy, qz, qw)_glTF = (−y, z, −x, w)`.
//!
//! What could not be checked here: no MMSys'17 file is in `../shared`, so
//! the sign of the forward axis (+x rather than −x, i.e. which way is the
//! centre of the video) rests on the MMSys'18 data and the shared
//! convention, and the dataset's recorder (`CQuaternion.cpp`, which builds
//! the viewport from head-frame corners (1, ±y, ±z)). A wrong sign would
//! keep yaw but reverse pitch and roll: the replayed head would nod up
//! where the user nodded down.
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
