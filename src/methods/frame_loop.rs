//! The frame loop every method shares ([`super::Method::render_frame`]):
//! a recorder, the method's passes, one batched readback of its outputs and
//! counters into its persistent staging buffer, one submit-and-wait, then
//! the timestamps and statistics of the frame.

use super::{FrameInput, FrameStats, Method, StereoFrame};
use crate::gpu::{guard, GpuResult, Recorder};

/// Timestamp pairs the recorder starts with (it adds more as needed).
const INITIAL_PASSES: u32 = 32;

pub(crate) fn render<M: Method + ?Sized>(
    method: &mut M,
    input: &FrameInput,
) -> GpuResult<StereoFrame> {
    let ctx = method.context().clone();
    let mut rec = Recorder::new(&ctx, INITIAL_PASSES)?;
    let outputs = method.record(&mut rec, input)?;
    let sources = outputs.sources();
    let ranges = rec.read_back(outputs.readback, &sources)?;
    let passes = rec.finish()?;
    // Debugging aid, off by default (`STEREOCACHE_GUARD_BANDS=1`): fail the
    // frame when a pass wrote past the end of a storage buffer.
    guard::check(&ctx)?;
    let (eyes, rays, counters) = outputs.decode(&ranges);
    Ok(StereoFrame {
        width: outputs.width,
        height: outputs.height,
        eyes,
        stats: FrameStats {
            passes,
            rays,
            counters,
        },
    })
}
