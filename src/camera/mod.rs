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
//! - [`mmsys18`]: importer for the MMSys'18 multi-viewpoint 360° video
//!   head-orientation logs (orientation only; translation from the neck model).
//! - [`synth`](mod@synth): seeded synthetic traces (head turn, walk, saccade, still),
//!   with [`pcg`], the small PCG32 generator they use.

pub mod mmsys18;
pub mod neck;
pub mod pcg;
pub mod pose;
pub mod stage;
pub mod stereo;
pub mod synth;
pub mod trace;

pub use mmsys18::{convert_mmsys18, read_mmsys18, Mmsys18Options};
pub use neck::HeadNeckModel;
pub use pose::HeadPose;
pub use stage::Stage;
pub use stereo::{Eye, EyeView, StereoCamera, DEFAULT_IPD, DEFAULT_ZNEAR};
pub use synth::{synth, SynthKind};
pub use trace::{PoseSample, PoseTrace, TraceError};
