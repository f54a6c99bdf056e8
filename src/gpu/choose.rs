//! Choose: which probed device to open. Pure data in, pure data out (no
//! Vulkan calls), so the rules are testable with hand-made [`DeviceCaps`].
//!
//! A device is usable with Vulkan 1.2, a compute queue and every feature in
//! `required`; each unusable one is rejected with its reason. Among the
//! usable ones `--device NAME` picks the first whose name contains NAME
//! (case-insensitive), otherwise the preference is discrete GPU, integrated,
//! virtual, CPU, other (enumeration order among equals).
#![deny(clippy::undocumented_unsafe_blocks)]

use super::caps::{DeviceCaps, Features};
use super::error::{GpuError, GpuResult};
use serde::Serialize;

/// A device `choose` did not take, and why.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Rejection {
    /// Index among the probed devices.
    pub index: usize,
    pub device: String,
    pub reason: String,
    /// The device cannot be used at all (not merely passed over).
    pub unusable: bool,
}

/// The outcome of `choose`: the index of the chosen device among the
/// probed ones and every other device with the reason it was not taken.
#[derive(Clone, Debug, Serialize)]
pub struct Choice {
    pub chosen: usize,
    pub rejected: Vec<Rejection>,
}

/// Why `caps` cannot be used at all (`None`: it can).
pub fn unusable_reason(caps: &DeviceCaps, required: &Features) -> Option<String> {
    if caps.api < (1, 2) {
        return Some(format!("no Vulkan 1.2 (has {})", caps.api_version));
    }
    if caps.compute_queue_family.is_none() {
        return Some("no compute queue".into());
    }
    // Every scene shader indexes its texture array non-uniformly
    // (scene.glsl), and every pass is timed (gpu/pass.rs): a device
    // without either was taken and its pipelines or timings were invalid.
    if !caps.supported.descriptor_indexing {
        return Some(
            "no descriptor indexing (runtimeDescriptorArray, shaderSampledImageArrayNonUniformIndexing: the scene's texture array)".into(),
        );
    }
    if !caps.has_timestamps() {
        return Some("no timestamps on its compute queue (every pass is timed)".into());
    }
    let missing = required.missing_from(&caps.supported);
    (!missing.is_empty()).then(|| format!("lacks required {}", missing.join(", ")))
}

fn type_rank(device_type: &str) -> u32 {
    match device_type {
        "discrete GPU" => 0,
        "integrated GPU" => 1,
        "virtual GPU" => 2,
        "CPU" => 3,
        _ => 4,
    }
}

/// Picks a device among `devices` (see the module comment).
pub fn choose(
    devices: &[DeviceCaps],
    name: Option<&str>,
    required: &Features,
) -> GpuResult<Choice> {
    let mut rejected = Vec::new();
    let mut usable = Vec::new();
    for (i, c) in devices.iter().enumerate() {
        match unusable_reason(c, required) {
            Some(reason) => rejected.push((i, reason, true)),
            None => usable.push(i),
        }
    }
    let chosen = match name {
        Some(f) => {
            let fl = f.to_lowercase();
            let matches = |i: &usize| devices[*i].name.to_lowercase().contains(&fl);
            let Some(chosen) = usable.iter().copied().find(matches) else {
                let list: Vec<String> = devices
                    .iter()
                    .enumerate()
                    .map(|(i, d)| match rejected.iter().find(|(j, ..)| *j == i) {
                        Some((_, r, _)) => format!("{} (unusable: {r})", d.name),
                        None => d.name.clone(),
                    })
                    .collect();
                return Err(GpuError::NoDevice(format!(
                    " whose name contains '{f}' (devices: {})",
                    list.join(", ")
                )));
            };
            for &i in &usable {
                if i != chosen {
                    rejected.push((i, format!("name does not match --device '{f}'"), false));
                }
            }
            chosen
        }
        None => {
            let Some(&chosen) = usable
                .iter()
                .min_by_key(|&&i| (type_rank(&devices[i].device_type), i))
            else {
                let why: Vec<String> = rejected
                    .iter()
                    .map(|(i, r, _)| format!("{}: {r}", devices[*i].name))
                    .collect();
                return Err(GpuError::NoDevice(if why.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", why.join("; "))
                }));
            };
            for &i in &usable {
                if i != chosen {
                    let (c, d) = (&devices[chosen], &devices[i]);
                    let reason = if c.device_type == d.device_type {
                        format!("{} is enumerated first", c.name)
                    } else {
                        format!("{} preferred over {}", c.device_type, d.device_type)
                    };
                    rejected.push((i, reason, false));
                }
            }
            chosen
        }
    };
    rejected.sort_by_key(|(i, ..)| *i);
    Ok(Choice {
        chosen,
        rejected: rejected
            .into_iter()
            .map(|(i, reason, unusable)| Rejection {
                index: i,
                device: devices[i].name.clone(),
                reason,
                unusable,
            })
            .collect(),
    })
}
