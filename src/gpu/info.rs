//! `stereocache info`: what every device supports and, for the chosen one,
//! what was enabled; the devices not chosen with their reasons.
#![deny(clippy::undocumented_unsafe_blocks)]

use super::caps::DeviceCaps;
use super::context::GpuContext;

fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

/// The report as text, one `label: value` per line.
pub fn text(ctx: &GpuContext) -> String {
    let c = &ctx.caps;
    let e = &ctx.enabled;
    let mut out = Vec::new();
    out.push(format!(
        "device:              {} ({})",
        c.name, c.device_type
    ));
    out.push(format!(
        "driver:              {} {}",
        c.driver_name, c.driver_info
    ));
    out.push(format!("Vulkan API:          {}", c.api_version));
    out.push(format!(
        "ray query:           {}",
        match (c.supported.ray_query, e.ray_query) {
            (true, true) => "yes (VK_KHR_ray_query + acceleration structures), enabled",
            (true, false) => "yes (VK_KHR_ray_query + acceleration structures), not enabled",
            _ => "no (software traversal)",
        }
    ));
    out.push(format!(
        "64-bit buffer atomics: {}",
        c.supported.buffer_int64_atomics
    ));
    out.push(format!("shaderInt64:         {}", c.supported.shader_int64));
    out.push(format!(
        "subgroup size:       {} ({})",
        c.subgroup_size,
        c.subgroup_ops.join(", ")
    ));
    out.push(format!(
        "descriptor indexing: {}",
        c.supported.descriptor_indexing
    ));
    out.push(format!(
        "push descriptors:    {}",
        if c.supported.push_descriptor {
            format!("yes (at most {} per set)", c.max_push_descriptors)
        } else {
            "no".into()
        }
    ));
    out.push(format!(
        "timestamp period:    {} ns ({} valid bits)",
        c.timestamp_period_ns, c.timestamp_valid_bits
    ));
    out.push(format!(
        "device-local memory: {:.1} GiB",
        gib(c.device_local_bytes)
    ));
    out.push(format!("memory heaps:        {}", heaps(c)));
    out.push(format!(
        "storage buffer:      at most {} bytes (maxStorageBufferRange)",
        c.max_storage_buffer_range
    ));
    out.push(format!("supported features:  {}", c.supported.names()));
    out.push(format!("enabled features:    {}", e.names()));
    out.push(format!(
        "validation layer:    {}",
        if ctx.validation_enabled { "on" } else { "off" }
    ));
    for r in &ctx.rejected {
        let d = &ctx.devices[r.index];
        out.push(format!(
            "other device:        {} ({})",
            d.name, d.device_type
        ));
        out.push(format!("  not chosen:        {}", r.reason));
        out.push(format!("  Vulkan API:        {}", d.api_version));
        out.push(format!("  supported:         {}", d.supported.names()));
    }
    out.join("\n")
}

fn heaps(c: &DeviceCaps) -> String {
    c.memory_heaps
        .iter()
        .map(|h| {
            format!(
                "{:.1} GiB{}",
                gib(h.bytes),
                if h.device_local { " device-local" } else { "" }
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The report as JSON: the chosen device's capabilities at the top level
/// (as before), plus `enabled`, `validation_layer`, `devices` (every probed
/// device) and `rejected` (the others, each with its reason).
pub fn json(ctx: &GpuContext) -> serde_json::Value {
    let mut v = serde_json::to_value(&ctx.caps).unwrap_or_default();
    if let Some(o) = v.as_object_mut() {
        o.insert(
            "enabled".into(),
            serde_json::to_value(ctx.enabled).unwrap_or_default(),
        );
        o.insert(
            "validation_layer".into(),
            serde_json::Value::Bool(ctx.validation_enabled),
        );
        o.insert(
            "devices".into(),
            serde_json::to_value(&ctx.devices).unwrap_or_default(),
        );
        o.insert(
            "rejected".into(),
            serde_json::to_value(&ctx.rejected).unwrap_or_default(),
        );
    }
    v
}

/// Prints the report (`json`: as pretty JSON) to stdout.
/// A closed stdout (`stereocache info | head`) is not an error.
pub fn print(ctx: &GpuContext, json: bool) {
    use std::io::Write as _;
    if json {
        let _ = writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&self::json(ctx)).unwrap_or_default()
        );
    } else {
        let _ = writeln!(std::io::stdout(), "{}", text(ctx));
    }
}
