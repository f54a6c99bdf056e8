//! `bench tradeoff`: run time against error for every method and a sweep of
//! their settings.

/// The configurations `bench tradeoff` sweeps: every method, and for the
/// sample cache N ∈ {4, 8, 12, 16}, n_target, retrace single/multi/adaptive,
/// shading uniform/adaptive at several rates, one-/two-pass reprojection;
/// hash-cache capacities and LoD rules; supersampling at several spp.
pub fn tradeoff_configs(base: &crate::methods::RenderSettings) -> Vec<crate::compare::Config> {
    use crate::compare::Config;
    use crate::methods::hash_cache::settings::HashLod;
    use crate::methods::sample_cache::{Reproject, Retrace, Shading};
    use crate::methods::{MethodConfig, MethodKind};
    let mut v = Vec::new();
    let cfg = |label: String, config: MethodConfig, s: crate::methods::RenderSettings| Config {
        label,
        config,
        settings: s,
    };
    for n in [4u32, 8, 12, 16] {
        let c = MethodConfig::sample_cache(|c| {
            c.slots = n;
            c.n_target = 4.min(n - 1).max(2);
            c.delta = 1;
        });
        v.push(cfg(format!("sc-N{n}"), c, base.clone()));
    }
    for nt in [2u32, 6] {
        let c = MethodConfig::sample_cache(|c| c.n_target = nt);
        v.push(cfg(format!("sc-ntarget{nt}"), c, base.clone()));
    }
    for (name, r) in [("single", Retrace::Single), ("multi", Retrace::Multi)] {
        let c = MethodConfig::sample_cache(|c| c.retrace = r);
        v.push(cfg(format!("sc-retrace-{name}"), c, base.clone()));
    }
    for rate in [0.25f32, 0.5, 1.0] {
        let c = MethodConfig::sample_cache(|c| {
            c.shading = Shading::Adaptive;
            c.shading_rate = rate;
        });
        v.push(cfg(format!("sc-adaptive-shading{rate}"), c, base.clone()));
    }
    let c = MethodConfig::sample_cache(|c| c.reproject = Reproject::TwoPass);
    v.push(cfg("sc-two-pass".into(), c, base.clone()));
    for (cap, lod) in [
        (1u32 << 16, HashLod::Distance),
        (1 << 20, HashLod::Distance),
        (1 << 20, HashLod::DistanceNormal),
    ] {
        let c = MethodConfig::hash_cache(|c| {
            c.capacity = cap;
            c.lod = lod;
        });
        let lname = if lod == HashLod::Distance {
            "dist"
        } else {
            "distnormal"
        };
        v.push(cfg(
            format!("hash-2e{}-{lname}", cap.trailing_zeros()),
            c,
            base.clone(),
        ));
    }
    v.push(cfg(
        "hybrid".into(),
        MethodKind::Hybrid.into(),
        base.clone(),
    ));
    v.push(cfg("taa".into(), MethodKind::Taa.into(), base.clone()));
    v.push(cfg("isrt".into(), MethodKind::Isrt.into(), base.clone()));
    v.push(cfg("naive".into(), MethodKind::Naive.into(), base.clone()));
    for spp in [2u32, 4, 8] {
        v.push(cfg(
            format!("supersample-{spp}spp"),
            MethodKind::Supersample.into(),
            crate::methods::RenderSettings {
                spp,
                ..base.clone()
            },
        ));
    }
    v
}

/// The ratios `bench tradeoff` prints under its table (configurations of
/// the same run on the same device, run one after another): each method's
/// default configuration against naive, and the sample cache's variants
/// against its default (`sc-N12`). Pairs whose rows are missing are skipped.
pub fn tradeoff_ratios(rows: &[crate::compare::MethodRow]) -> String {
    let row = |label: &str| rows.iter().find(|r| r.method == label);
    let rse = |r: &crate::compare::MethodRow| r.metrics.get("rse").copied();
    let mut out =
        String::from("ratios (same run, same device; configurations one after another):\n");
    let mut line = |a: &str, b: &str, what: &str| {
        if let (Some(x), Some(y)) = (row(a), row(b)) {
            let mut l = format!(
                "  {:<44} {:.2}x time, {:.2}x rays",
                format!("{a} / {b}{what}:"),
                x.steady_mean_gpu_ms / y.steady_mean_gpu_ms,
                x.rays_per_frame / y.rays_per_frame
            );
            if let (Some(ex), Some(ey)) = (rse(x), rse(y)) {
                l.push_str(&format!(", {:.2}x RSE", ex / ey));
            }
            out.push_str(&l);
            out.push('\n');
        }
    };
    for m in [
        "sc-N12",
        "hash-2e20-dist",
        "hybrid",
        "taa",
        "isrt",
        "supersample-4spp",
    ] {
        line(m, "naive", "");
    }
    line("sc-retrace-multi", "sc-N12", " (multi / adaptive retrace)");
    line(
        "sc-retrace-single",
        "sc-N12",
        " (single / adaptive retrace)",
    );
    line("sc-two-pass", "sc-N12", " (two- / one-pass reprojection)");
    line(
        "sc-adaptive-shading1",
        "sc-N12",
        " (adaptive / uniform shading)",
    );
    out
}
