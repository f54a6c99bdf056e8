//! The material-graph memoization table on the GPU (issue 17; thesis
//! §5.3): four buffers that join a scene's descriptor set 0 when its graphs
//! are memoized (`--memo …`; gpu_scene.rs binds them after the TLAS slot):
//! the key words, the stamps, the records (shaders/memo/table.glsl) and the
//! state words (src/materials/memo/state.rs: the frame's parameters, then its
//! counters). The table is shared by every method's passes and both eyes;
//! [`MemoGpu::reset`] empties it before a run so that methods compared one
//! after another each start from an empty cache.

use crate::gpu::{Buffer, GpuContext, GpuError, GpuResult, Recorder};
use crate::materials::memo::state::{frame_words, MemoCounters, PARAM_WORDS, STATE_BYTES};
use crate::materials::memo::table::RECORD_WORDS;
use crate::materials::memo::{MemoClock, MemoSettings};
use std::sync::Arc;

pub struct MemoGpu {
    pub settings: MemoSettings,
    ctx: Arc<GpuContext>,
    pub keys: Buffer,
    pub stamps: Buffer,
    pub values: Buffer,
    pub state: Buffer,
}

impl MemoGpu {
    /// Creates the empty table; the state holds frame 0's parameters, so a
    /// single `render` memoizes without a frame loop.
    pub fn new(ctx: &Arc<GpuContext>, settings: &MemoSettings) -> GpuResult<MemoGpu> {
        settings.validate().map_err(GpuError::Unsupported)?;
        if settings.clock == MemoClock::Counter
            && !(ctx.enabled.buffer_int64_atomics && ctx.enabled.shader_int64)
        {
            return Err(GpuError::Unsupported(format!(
                "device '{}' lacks shaderInt64 or shaderBufferInt64Atomics, which --memo-clock counter needs",
                ctx.caps.name
            )));
        }
        let n = settings.entries as u64;
        let b = |name: &str, bytes: u64| Buffer::storage(ctx, &format!("memo.{name}"), bytes);
        let m = MemoGpu {
            settings: *settings,
            ctx: ctx.clone(),
            keys: b("keys", n * 4)?,
            // The access clock's counter, then per entry: stamp (one word,
            // or two with the access clock), write version (table.glsl).
            stamps: b(
                "stamps",
                settings.clock.counter_bytes() + n * 4 * settings.clock.stamp_words(),
            )?,
            values: b(
                "values",
                n * settings.texels_per_entry() * 4 * RECORD_WORDS as u64,
            )?,
            state: b("state", STATE_BYTES)?,
        };
        m.reset()?;
        Ok(m)
    }

    /// Empties the table (every key EMPTY) and sets frame 0's parameters.
    pub fn reset(&self) -> GpuResult<()> {
        let mut rec = Recorder::new(&self.ctx, 1)?;
        rec.pass("memo.reset")
            .write(&self.keys)
            .write(&self.stamps)
            .write(&self.values)
            .fill(0);
        rec.finish()?;
        self.begin_frame(0)
    }

    /// The parameters of frame `index` (stamps `index + 1`), counters zeroed.
    pub fn begin_frame(&self, index: u32) -> GpuResult<()> {
        let w = frame_words(&self.settings, index.wrapping_add(1));
        self.state.upload(bytemuck::cast_slice(&w))
    }

    /// The counters of the frames since the last `begin_frame`.
    pub fn counters(&self) -> GpuResult<MemoCounters> {
        let w: Vec<u32> = self.state.download_pod()?;
        Ok(MemoCounters::from_words(&w[PARAM_WORDS.min(w.len())..]))
    }

    /// Bytes of the four buffers.
    pub fn bytes(&self) -> u64 {
        [&self.keys, &self.stamps, &self.values, &self.state]
            .iter()
            .map(|b| b.size)
            .sum()
    }
}
