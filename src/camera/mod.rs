//! Head pose → eye views, projections, pose-trace formats.
//!
//! Conventions (DESIGN.md): glTF axes — right-handed, +Y up, metres, column
//! vectors; a head (and each eye) looks down its −Z. Eyes sit at ±IPD/2 along
//! the head's +X (default IPD 0.063 m). A pose trace gives the head in *stage
//! space*; a [`Stage`] places the stage in the scene.
//!
//! - [`pose`]: [`HeadPose`], a rigid head transform.
//! - [`neck`]: [`HeadNeckModel`], translation for orientation-only tracking.
//! - [`stereo`]: [`Eye`], [`StereoCamera`], [`EyeView`] — rays and projection,
//!   the single source of truth for the camera model.
//! - [`trace`]: [`PoseTrace`] and the project's CSV format, repairs,
//!   hemisphere continuity, resampling to the render rate.
//! - [`stage`]: [`Stage`], placing a trace's stage in a scene.
//! - [`framing`]: [`frame_bounds`], the camera for a scene without one.
//! - Recording importers, one per format, all converting to the project's
//!   trace ([`import`] dispatches and checks the result):
//!   - [`mmsys18`]: the MMSys'18 multi-viewpoint 360° video head-orientation
//!     logs (orientation only; translation from the neck model);
//!   - [`mmsys17`]: Corbillon et al.'s MMSys'17 360° video head movements;
//!   - [`openxr`]: OpenXR-style `XrTime` + `XrPosef` logs;
//!   - [`generic_csv`]: any delimited layout with the columns, time unit and
//!     axis convention given (HoloLens/Unity recordings such as pred6dof).
//!
//!   Shared by them: [`convention`] (handedness and axes → glTF),
//!   [`time_unit`] (units, exact integer clocks), `table` (line splitting),
//!   and [`motion_check`] (warns when a trace walks backwards relative to
//!   its view, the symptom of a wrong convention).
//! - [`synth`](mod@synth): seeded synthetic traces (head turn, walk, saccade, still),
//!   with [`pcg`], the small PCG32 generator they use.

pub mod convention;
pub mod framing;
pub mod generic_csv;
pub mod import;
pub mod mmsys17;
pub mod mmsys18;
pub mod motion_check;
pub mod neck;
pub mod openxr;
pub mod pcg;
pub mod pose;
pub mod stage;
pub mod stereo;
pub mod synth;
mod table;
pub mod time_unit;
pub mod trace;

pub use convention::{AxisConvention, Handedness, SignedAxis};
pub use framing::{frame_bounds, Framing, FRAMING_MARGIN};
pub use generic_csv::{parse_generic_csv, read_generic_csv, ColumnMap, CsvOptions};
pub use import::{convert_trace, import_trace, TraceFormat};
pub use mmsys17::{parse_mmsys17, read_mmsys17, Mmsys17Options};
pub use mmsys18::{convert_mmsys18, read_mmsys18, Mmsys18Options};
pub use motion_check::{convention_warning, motion_vs_view, MotionStats};
pub use neck::HeadNeckModel;
pub use openxr::{parse_openxr, read_openxr};
pub use pose::HeadPose;
pub use stage::Stage;
pub use stereo::{Eye, EyeView, Projection, StereoCamera, DEFAULT_IPD, DEFAULT_ZNEAR};
pub use synth::{synth, SynthKind};
pub use time_unit::{RawTime, TimeUnit, TimeWindow};
pub use trace::{PoseSample, PoseTrace, TraceError};
