//! The sample cache's invariants, read back from the GPU after every frame of
//! moving traces, and its convergence, dispatch and reprojection variants.

mod common;
use common::*;
use glam::UVec2;
use stereocache::camera::{Eye, StereoCamera};
use stereocache::methods::sample_cache::background::background_direction;
use stereocache::methods::sample_cache::{
    CacheSnapshot, Payload, Reproject, Retrace, SampleCache, SampleCacheSettings, Shading,
};
use stereocache::rt::{RtChoice, SoftwareBvh};
use stereocache::session::{CameraSelect, Session};

fn settings(w: u32, h: u32, cache: SampleCacheSettings) -> CacheSetup {
    cache_settings(w, h, cache, 5)
}

fn moving(start: &StereoCamera, frame: u32, deg_per_frame: f32) -> StereoCamera {
    turning_head(start, frame, deg_per_frame, 0.004)
}

/// Checks the structural invariants and returns the fraction of visible
/// samples whose stored hit differs from a fresh primary ray's hit.
fn check_invariants(
    snap: &CacheSnapshot,
    cam: &StereoCamera,
    bvh: &SoftwareBvh,
) -> (usize, usize, usize) {
    let (w, h) = (snap.width, snap.height);
    let (mut visible, mut mismatched, mut uncovered) = (0usize, 0usize, 0usize);
    for (e, eye) in Eye::BOTH.iter().enumerate() {
        let v = cam.eye(*eye);
        for pixel in 0..snap.npix() {
            let m = snap.mask(e, pixel);
            let (occ, vis) = (snap.occupied(m), snap.visible(m));
            assert_eq!(
                vis & !occ,
                0,
                "eye {e} pixel {pixel}: visible bit without occupancy (mask {m:#x})"
            );
            assert_eq!(m >> (2 * snap.slots), 0, "mask bits above 2N set");
            // Covered: a visible surface sample (background samples do not count).
            if snap.surface(e, pixel, vis) == 0 && fully_covered(bvh, &v, pixel, w, h) {
                uncovered += 1;
            }
            let mut bits = vis;
            while bits != 0 {
                let s = bits.trailing_zeros();
                bits &= bits - 1;
                let fh = snap.first_hits[snap.slot(e, s, pixel)];
                visible += 1;
                // A background sample (§3.3, a ray that missed the scene):
                // a fresh ray in its direction misses too, and the direction
                // projects into its own pixel.
                if let Some(d) = background_direction(fh) {
                    if bvh.closest_hit(v.position, d, 0.0, 1e30).is_some() {
                        mismatched += 1;
                    }
                    if let Some((q, _)) = v.project(v.position + d, UVec2::new(w, h)) {
                        assert!(
                            (q - pixel_centre(pixel, w)).abs().max_element() < 0.5 + 1e-3,
                            "background sample outside its pixel"
                        );
                    }
                    continue;
                }
                assert_ne!(fh[3], u32::MAX, "visible sample without a first hit");
                // Where does the stored sample lie, and what does a fresh ray towards it hit?
                let p = stored_position(bvh, fh);
                let d = (p - v.position).normalize();
                match bvh.closest_hit(v.position, d, 0.0, 1e30) {
                    Some(hit) if hit.instance == fh[3] && hit.prim == fh[2] => {}
                    Some(hit) if (hit.t - (p - v.position).length()).abs() <= 1e-3 * hit.t => {}
                    _ => mismatched += 1,
                }
                // The sample projects into its own pixel (reproject.comp
                // bins by truncation, trace.comp jitters inside the pixel):
                // within half a pixel of its centre, plus 1e-3 px for the
                // stored barycentrics' 24 bits and the CPU's projection
                // against the GPU's (both ~1e-5 px here). A pixel's
                // neighbour (a bin rounded to nearest) is a full pixel off.
                if let Some((q, _)) = v.project(p, UVec2::new(w, h)) {
                    assert!(
                        (q - pixel_centre(pixel, w)).abs().max_element() < 0.5 + 1e-3,
                        "sample outside its pixel: at {q}, pixel {pixel}"
                    );
                }
            }
        }
    }
    (visible, mismatched, uncovered)
}

/// Runs `frames` frames of a turning, drifting head and checks the invariants
/// after every frame; returns (visible samples, stale ones, retrace rays).
fn run_moving(
    scene: &str,
    retrace: Retrace,
    frames: u32,
    deg_per_frame: f32,
) -> (usize, usize, u64) {
    let ctx = context();
    let s = session(&ctx, shipped(scene), RtChoice::Software);
    let cs = SampleCacheSettings {
        retrace,
        ..Default::default()
    };
    let (w, h) = (48, 36);
    let mut m = cache_method(&s, &settings(w, h, cs));
    let cam0 = default_camera(&s, w, h);
    let bvh = SoftwareBvh::build(&s.scene);
    let (mut visible, mut stale, mut rays) = (0, 0, 0u64);
    let mut prev = None;
    for f in 0..frames {
        let cam = moving(&cam0, f, deg_per_frame);
        let frame = render_at(&mut m, f, cam, prev);
        prev = Some(cam);
        assert_finite_non_negative(&frame, "sample cache");
        let snap = m.snapshot().unwrap();
        let (v, bad, uncovered) = check_invariants(&snap, &cam, &bvh);
        // A pixel that geometry covers keeps a visible surface sample. On
        // solid surfaces this is exact with multi and adaptive retracing;
        // between thin hairball tubes a fresh sample can still fall through a
        // gap the 25 probes missed (≤ 1 % of pixels). Single retracing (one
        // slot per pixel and frame, round robin) leaves a pixel that an edge
        // moves over with its background samples (issue 12: rays that missed
        // are samples) visible until each is retraced — the lagging
        // visibility §3.2 ascribes to single sampling — so there it is
        // bounded like the stale samples (1 % of pixels), not zero.
        let limit = if scene == "hairball" {
            snap.npix() * 2 / 100
        } else if retrace == Retrace::Single {
            snap.npix() / 100
        } else {
            0
        };
        assert!(
            uncovered <= limit,
            "frame {f}: {uncovered} covered pixels without a visible sample"
        );
        let (checked, outside) = check_density(&snap, m.settings());
        // Thin hairball tubes cover pixels only partly (new samples miss), so
        // the density band is asserted where surfaces cover whole neighbourhoods.
        assert!(
            scene == "hairball" || outside * 20 <= checked,
            "frame {f}: 3×3 density outside n_target ± δ at {outside} of {checked} pixels"
        );
        if f > 0 {
            visible += v;
            stale += bad;
            rays += frame.stats.counters["retrace_rays"] as u64;
        }
    }
    assert_no_validation_messages(&ctx);
    (visible, stale, rays)
}

/// Density control acts on the 3×3 average of visible samples per pixel:
/// where a pixel's whole neighbourhood is covered by geometry, that average
/// ends the frame inside n_target ± δ (adds reach n_target at once; purges
/// remove one sample per frame, so a strong convergence of samples may take
/// a few frames). Returns (pixels checked, pixels outside the band).
fn check_density(snap: &CacheSnapshot, cs: &SampleCacheSettings) -> (usize, usize) {
    let (w, h) = (snap.width as i64, snap.height as i64);
    let (mut checked, mut outside) = (0, 0);
    for e in 0..2 {
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let mut sum = 0;
                let mut covered = true;
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let n = snap
                            .visible(snap.mask(e, ((y + dy) * w + x + dx) as usize))
                            .count_ones();
                        assert!(n <= cs.slots);
                        covered &= n > 0;
                        sum += n;
                    }
                }
                if !covered {
                    continue;
                }
                checked += 1;
                let avg = sum as f32 / 9.0;
                if avg < (cs.n_target - cs.delta) as f32 || avg > (cs.n_target + cs.delta) as f32 {
                    outside += 1;
                }
            }
        }
    }
    (checked, outside)
}

#[test]
fn invariants_hold_on_a_moving_trace_cornell() {
    let mut rays = std::collections::BTreeMap::new();
    for retrace in [Retrace::Single, Retrace::Multi, Retrace::Adaptive] {
        let (visible, stale, r) = run_moving("cornell", retrace, 8, 1.5);
        eprintln!("cornell {retrace:?}: {stale} stale of {visible} visible, {r} retrace rays");
        assert!(visible > 10_000);
        // Multi retraces every sample every frame, so a stale one is a
        // precision case (measured 0), as on the hairball; single and
        // adaptive lag by design (measured 0.7 % and 0.09 %).
        let bound = if retrace == Retrace::Multi {
            1e-3
        } else {
            0.01
        };
        assert!(
            stale as f64 <= bound * visible as f64,
            "cornell {retrace:?}: {stale} stale of {visible}"
        );
        rays.insert(format!("{retrace:?}"), r);
    }
    // On surfaces with few edges adaptive retracing is a small fraction of multi (measured 0.12×).
    assert!(rays["Adaptive"] * 4 < rays["Multi"], "{rays:?}");
}

/// Stale visibility (visible samples that a fresh ray does not reach) per
/// retrace mode on the hairball, the hard case for edges: multi retraces
/// everything, adaptive stays within 1.5× of multi's mismatch rate while
/// tracing far fewer rays, single lags clearly behind.
#[test]
fn retrace_modes_on_the_hairball() {
    let mut rate = std::collections::BTreeMap::new();
    let mut rays = std::collections::BTreeMap::new();
    for retrace in [Retrace::Multi, Retrace::Adaptive, Retrace::Single] {
        let (visible, stale, r) = run_moving("hairball", retrace, 8, 2.0);
        let k = format!("{retrace:?}");
        rate.insert(k.clone(), stale as f64 / visible as f64);
        rays.insert(k, r);
    }
    eprintln!("stale rates {rate:?}, retrace rays {rays:?}");
    let (multi, adaptive, single) = (rate["Multi"], rate["Adaptive"], rate["Single"]);
    // Multi retraces every sample every frame, so its stale rate is the float
    // floor between GPU and CPU traversal (measured 0). Adaptive may miss a
    // visibility change outside the flagged neighbourhoods for a frame:
    // its budget is 1 % of samples (measured 0.14 %), i.e. within 1.5× of
    // multi plus that budget; single round robin lags an order of magnitude
    // behind (measured 3.7 %).
    assert!(multi <= 1e-3, "multi {multi:.5}");
    assert!(
        adaptive <= 1.5 * multi + 0.01,
        "adaptive {adaptive:.5} vs multi {multi:.5}"
    );
    assert!(
        single > 10.0 * adaptive.max(1e-4),
        "single {single:.5} should lag adaptive {adaptive:.5}"
    );
    // Nearly every hairball pixel at 48×36 is an edge, so adaptive may trace
    // almost as much as multi here, never more.
    assert!(
        rays["Adaptive"] <= rays["Multi"],
        "adaptive traced {} vs multi's {} rays",
        rays["Adaptive"],
        rays["Multi"]
    );
}

#[test]
#[ignore]
fn dump_debug_views() {
    let ctx = context();
    for name in ["cornell", "plane"] {
        let s = session(&ctx, shipped(name), RtChoice::Software);
        let cs = SampleCacheSettings {
            debug_views: true,
            ..Default::default()
        };
        let st = settings(128, 96, cs);
        let mut m = cache_method(&s, &st);
        let cam = s
            .camera(&CameraSelect::Default, 128, 96, None, None)
            .unwrap();
        let mut last = None;
        for f in 0..4 {
            last = Some(render_at(&mut m, f, cam, Some(cam)));
        }
        let fr = last.unwrap();
        eprintln!("{name}: {:?}", fr.stats.counters);
        for (v, img) in &fr.eyes[0].debug {
            stereocache::output::write_png(
                std::path::Path::new(&format!("/tmp/dbg_{name}_{v}.png")),
                128,
                96,
                img,
                1.0,
            )
            .unwrap();
        }
        stereocache::output::write_png(
            std::path::Path::new(&format!("/tmp/dbg_{name}_color.png")),
            128,
            96,
            &fr.eyes[0].radiance,
            1.0,
        )
        .unwrap();
    }
}

/// Renders `frames` frames of a moving head and returns the method.
fn run_frames(s: &Session, st: &CacheSetup, frames: u32, deg_per_frame: f32) -> SampleCache {
    let mut m = cache_method(s, st);
    let cam0 = s
        .camera(&CameraSelect::Default, st.width, st.height, None, None)
        .unwrap();
    let mut prev = None;
    for f in 0..frames {
        let cam = moving(&cam0, f, deg_per_frame);
        render_at(&mut m, f, cam, prev);
        prev = Some(cam);
    }
    m
}

/// The race-free two-pass reprojection and the default one-pass agree: per
/// pixel, the sets of visible first hits match on ≥ 99.9 % of samples.
#[test]
fn one_pass_and_two_pass_reprojection_agree() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let mk = |reproject| {
        settings(
            40,
            30,
            SampleCacheSettings {
                reproject,
                ..Default::default()
            },
        )
    };
    let a = run_frames(&s, &mk(Reproject::OnePass), 8, 1.5)
        .snapshot()
        .unwrap();
    let b = run_frames(&s, &mk(Reproject::TwoPass), 8, 1.5)
        .snapshot()
        .unwrap();
    let visible_hits = |snap: &CacheSnapshot, e: usize, p: usize| {
        let mut v: Vec<[u32; 4]> = Vec::new();
        let mut bits = snap.visible(snap.mask(e, p));
        while bits != 0 {
            let s = bits.trailing_zeros();
            bits &= bits - 1;
            v.push(snap.first_hits[snap.slot(e, s, p)]);
        }
        v.sort();
        v
    };
    let (mut total, mut differ) = (0usize, 0usize);
    for e in 0..2 {
        for p in 0..a.npix() {
            let (va, vb) = (visible_hits(&a, e, p), visible_hits(&b, e, p));
            total += va.len().max(vb.len());
            differ += va
                .iter()
                .filter(|h| !vb.contains(h))
                .count()
                .max(vb.iter().filter(|h| !va.contains(h)).count());
        }
    }
    eprintln!("one-pass vs two-pass: {differ} of {total} visible samples differ");
    assert!(total > 5000);
    assert!(differ * 1000 <= total, "{differ} of {total} samples differ");
    assert_no_validation_messages(&ctx);
}

/// Static camera: the reconstruction converges to the 1024 spp reference as
/// the accumulated samples predict. Each pixel averages its (about n_target)
/// fixed sample positions, so the error against the reference is a floor B
/// from sample placement plus noise N / c with c the mean shading count per
/// visible sample (read back from the cache): MSE(F) = B + N / c(F). B and N
/// are fitted on frames 4 and 16; the prediction for frame 64 must match the
/// measurement within 4σ, σ from the per-pixel spread of the squared errors.
#[test]
fn static_view_converges_towards_the_reference() {
    let ctx = context();
    let (w, h) = (32, 24);
    let (s, cam, reference) = static_view_with_reference(&ctx, "cornell", w, h, 1024);
    let mut m = cache_method(&s, &settings(w, h, SampleCacheSettings::default()));
    let mut points = Vec::new(); // (mean shading count, MSE, standard error)
    for f in 0..64 {
        let fr = render_at(&mut m, f, cam, Some(cam));
        if [3, 15, 63].contains(&f) {
            let snap = m.snapshot().unwrap();
            let (mut c, mut n) = (0.0f64, 0usize);
            for e in 0..2 {
                for p in 0..snap.npix() {
                    let mut bits = snap.visible(snap.mask(e, p));
                    while bits != 0 {
                        let sl = bits.trailing_zeros();
                        bits &= bits - 1;
                        c += snap.radiance[snap.slot(e, sl, p)][3] as f64;
                        n += 1;
                    }
                }
            }
            let (mean, se) = mean_and_standard_error(&squared_errors(&fr, &reference));
            eprintln!(
                "frame {}: mean shading count {:.2}, MSE {mean:.4e} ± {se:.1e}",
                f + 1,
                c / n as f64
            );
            points.push((c / n as f64, mean, se));
        }
    }
    let [(c1, m1, s1), (c2, m2, s2), (c3, m3, s3)] = [points[0], points[1], points[2]];
    assert!(
        m1 > m2 && m2 > m3,
        "error must fall with frames: {m1} {m2} {m3}"
    );
    let k = (1.0 / c3 - 1.0 / c2) / (1.0 / c1 - 1.0 / c2);
    let predicted = m2 + (m1 - m2) * k;
    let sigma = ((1.0 - k).powi(2) * s2 * s2 + k * k * s1 * s1 + s3 * s3).sqrt();
    eprintln!("frame 64: MSE {m3:.4e}, predicted {predicted:.4e} ± {sigma:.1e}");
    assert!(
        (m3 - predicted).abs() < 4.0 * sigma,
        "MSE {m3:.4e} vs predicted {predicted:.4e} ± {sigma:.1e}"
    );
    assert_no_validation_messages(&ctx);
}

/// Adaptive shading dispatches the requested rate (within the coin toss's
/// binomial spread), prefers samples with few accumulated samples, and the
/// histogram holds every shading candidate (counted after tracing).
#[test]
fn adaptive_shading_dispatches_the_requested_rate() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    for subgroup_ops in [true, false] {
        adaptive_shading_rate(&s, subgroup_ops);
    }
    assert_no_validation_messages(&ctx);
}

/// §3.5's importance ordering, with a known answer (an audit found the
/// check above passes under uniformly random selection): a still view
/// whose cache is loaded with every pixel's visible surface samples
/// alternating between c = 50 (w = 1/51) and c = 0 (w = 1), twice (the
/// first loaded frame sets the bounds w_min, w_max the second one buckets
/// with; §3.5 uses the previous frame's). At rate 0.5 the budget (half the
/// covered pixels) is below the c = 0 samples' count (about two per
/// pixel), so outside the base-rate pixels' round-robin sample (one per
/// 4×4 block, which may be either) every shaded sample must come from the
/// top bucket, c = 0: its count after shading is 1, a c = 50 sample's is
/// 51. So at most the base pixels' count of shaded samples may show 51,
/// where random selection would give about a quarter of all shadings.
#[test]
fn adaptive_shading_picks_the_least_accumulated_samples() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (48, 36);
    let st = settings(
        w,
        h,
        SampleCacheSettings {
            shading: Shading::Adaptive,
            shading_rate: 0.5,
            ..Default::default()
        },
    );
    let mut m = cache_method(&s, &st);
    let cam = default_camera(&s, w, h);
    for f in 0..4 {
        render_at(&mut m, f, cam, (f > 0).then_some(cam));
    }
    let mut snap = m.snapshot().unwrap();
    let mut loaded = [0usize; 2]; // samples given c = 50, c = 0
    for e in 0..2 {
        for p in 0..snap.npix() {
            let mut bits = snap.surface(e, p, snap.visible(snap.mask(e, p)));
            let mut k = 0;
            while bits != 0 {
                let sl = bits.trailing_zeros();
                bits &= bits - 1;
                let i = snap.slot(e, sl, p);
                let c = if k % 2 == 0 { 50.0 } else { 0.0 };
                loaded[(c == 0.0) as usize] += 1;
                snap.radiance[i] = [0.5, 0.5, 0.5, c];
                k += 1;
            }
        }
    }
    for f in 4..6 {
        m.load(&snap).unwrap();
        render_at(&mut m, f, cam, Some(cam));
    }
    let out = m.snapshot().unwrap();
    let list = &out.shade_list[..out.shade_count as usize];
    let old = list
        .iter()
        .filter(|&&code| {
            let (e, sl, p) = (
                (code >> 31) as usize,
                (code >> 26) & 31,
                (code & 0x3FF_FFFF) as usize,
            );
            out.radiance[out.slot(e, sl, p)][3] > 2.0
        })
        .count();
    let base: u32 = out.base_pixels.iter().sum();
    eprintln!(
        "loaded {} samples at c = 50 and {} at c = 0; shaded {}, of them {old} at c = 50, base pixels {base}",
        loaded[0],
        loaded[1],
        list.len()
    );
    assert!(
        loaded[1] > list.len(),
        "the premise: more c = 0 samples than shadings"
    );
    assert!(
        list.len() as u32 > 2 * base,
        "the premise: most shadings outside the base rate"
    );
    assert!(
        old as u32 <= base,
        "{old} shaded samples had c = 50, more than the {base} base-rate picks"
    );
    assert_no_validation_messages(&ctx);
}

fn adaptive_shading_rate(s: &Session, subgroup_ops: bool) {
    let (w, h) = (48, 36);
    let rate = 0.5f32;
    let mut st = settings(
        w,
        h,
        SampleCacheSettings {
            shading: Shading::Adaptive,
            shading_rate: rate,
            retrace: Retrace::Multi,
            ..Default::default()
        },
    );
    st.subgroup_ops = subgroup_ops;
    let mut m = cache_method(s, &st);
    assert_eq!(m.uses_subgroup_ops(), subgroup_ops, "subgroup builds");
    let cam0 = default_camera(s, w, h);
    let mut prev = None;
    let npix = (w * h) as f64;
    for f in 0..10 {
        let cam = moving(&cam0, f, 0.5);
        let fr = render_at(&mut m, f, cam, prev);
        prev = Some(cam);
        let snap = m.snapshot().unwrap();
        // Histogram: every shading candidate was counted once — the visible
        // surface samples after tracing (new ones included, issue 12 item 3;
        // it used to hold the reprojected visible samples,
        // `reprojected_visible`) except the round-robin sample of base-rate
        // and unshaded pixels, which are selected outside it. Background
        // samples are never shaded (issue 12 item 1).
        let hist_total: u32 = snap.histogram.iter().sum();
        let visible: u32 = (0..2)
            .flat_map(|e| (0..snap.npix()).map(move |p| (e, p)))
            .map(|(e, p)| {
                snap.surface(e, p, snap.visible(snap.mask(e, p)))
                    .count_ones()
            })
            .sum();
        let first: u32 = snap.base_pixels.iter().chain(&snap.unshaded_pixels).sum();
        assert_eq!(hist_total, visible - first, "frame {f}: histogram total");
        if f < 3 {
            // The rate from frame 0 on: sample_cache_shading.rs
            // adaptive_shading_holds_the_rate_and_leaves_no_visible_pixel_black.
            // Here the importance ordering below wants settled bounds.
            continue;
        }
        assert!(snap_visible_reprojected(&fr) > 0.0);
        // Rate: base (one per 4×4 block) + rate × the pixels uniform shading
        // shades (a visible surface sample; all pixels until session 50).
        let shaded = snap.shade_count as f64;
        let covered = (snap.covered(0) + snap.covered(1)) as f64 / 2.0;
        let expected = 2.0 * (rate as f64 * covered).max(npix / 16.0);
        // Spread of the coin tosses (the straddling bucket's samples and the
        // unshaded pixels'): each candidate, a visible surface sample of
        // either eye, is tossed at most once, Bernoulli variance ≤ 1/4.
        let sigma = (visible as f64 / 4.0).sqrt();
        eprintln!("frame {f}: shaded {shaded} expected {expected:.0} ± {sigma:.0}");
        assert!(
            (shaded - expected).abs() <= 4.0 * sigma,
            "frame {f}: shaded {shaded}, expected {expected:.0}"
        );
        // Importance: the shaded samples have fewer accumulated samples than the average visible one.
        let (mut c_shaded, mut n_shaded) = (0.0, 0.0);
        for code in &snap.shade_list[..snap.shade_count as usize] {
            let (e, sl, p) = (
                (code >> 31) as usize,
                (code >> 26) & 31,
                (code & 0x3FF_FFFF) as usize,
            );
            c_shaded += snap.radiance[snap.slot(e, sl, p)][3] as f64;
            n_shaded += 1.0;
        }
        // Visible surface samples (background ones are not shaded).
        let (mut c_all, mut n_all) = (0.0, 0.0);
        for i in snap.visible_surface_records() {
            c_all += snap.radiance[i][3] as f64;
            n_all += 1.0;
        }
        // Counts are read after shading (each shaded sample gained one).
        assert!(
            c_shaded / n_shaded - 1.0 < c_all / n_all,
            "frame {f}: shaded mean count {} vs all {}",
            c_shaded / n_shaded,
            c_all / n_all
        );
        // The shade list holds each sample once (its reservation is per
        // subgroup in the subgroup builds).
        let list = &snap.shade_list[..snap.shade_count as usize];
        let unique: std::collections::HashSet<_> = list.iter().collect();
        assert_eq!(
            unique.len(),
            list.len(),
            "frame {f}: shade list entries repeat"
        );
    }
}

fn snap_visible_reprojected(fr: &stereocache::methods::StereoFrame) -> f64 {
    fr.stats.counters["reprojected_visible"]
}

/// A pixel through which the environment shows is cheap. Before background
/// samples (issue 6) it traced one missing ray per frame (the ray that adds
/// a sample and finds background ended the adding). With background samples
/// stored (§3.3, issue 12) such a pixel fills its n_target slots once, like
/// any pixel, and then traces only the base-rate retrace of §3.4 (one slot
/// per 4×4 block). Looking away from the scene: frame 0 traces exactly
/// n_target background rays per pixel, every later frame no new-sample ray
/// and exactly one retrace ray per 4×4 block (blocks cut by the border
/// included) — over the six frames fewer rays than the old one per pixel
/// and frame. Looking at a sphere that covers part of the view: frame 0
/// traces at most n_target new rays per pixel, at least n_target background
/// rays per pixel the sphere does not touch; every pixel keeps a visible
/// sample and every pixel the sphere fully covers a visible surface sample;
/// in the static later frames no sample is lost, so no new ray is traced.
#[test]
fn background_pixels_trace_one_ray_per_frame() {
    let ctx = context();
    let scene = sphere_in_environment(
        stereocache::scene::Material::default(),
        glam::Vec3::ZERO,
        1.0,
        glam::Vec3::splat(0.5),
    );
    let s = session(&ctx, scene, RtChoice::Software);
    let bvh = SoftwareBvh::build(&s.scene);
    let (w, h) = (40u32, 30u32);
    let npix = (w * h) as f64;
    let cs = SampleCacheSettings::default();
    let n_target = cs.n_target as f64;
    let blocks = 2.0 * (w.div_ceil(4) * h.div_ceil(4)) as f64;
    let st = settings(w, h, cs);
    let count = |fr: &stereocache::methods::StereoFrame, name: &str| {
        fr.stats.counters.get(name).copied().unwrap_or(0.0)
    };
    for (view, target) in [
        ("away", glam::Vec3::new(0.0, 0.0, 10.0)),
        ("sphere", glam::Vec3::ZERO),
    ] {
        let cam = look_at_camera(
            glam::Vec3::new(0.0, 0.0, 4.0),
            target,
            45.0,
            w as f32 / h as f32,
        );
        let mut m = cache_method(&s, &st);
        let mut total_rays = 0.0;
        for f in 0..6 {
            let fr = render_at(&mut m, f, cam, if f > 0 { Some(cam) } else { None });
            let bg = count(&fr, "background_rays");
            let new = count(&fr, "new_sample_rays");
            let retrace = count(&fr, "retrace_rays");
            total_rays += bg + new + retrace;
            let snap = m.snapshot().unwrap();
            let (mut sky, mut empty) = (0usize, 0usize);
            for (e, eye) in Eye::BOTH.iter().enumerate() {
                let v = cam.eye(*eye);
                for p in 0..snap.npix() {
                    let vis = snap.visible(snap.mask(e, p));
                    if vis == 0 {
                        empty += 1;
                    }
                    if snap.surface(e, p, vis) == 0 {
                        sky += 1;
                        assert!(
                            !fully_covered(&bvh, &v, p, w, h),
                            "{view} frame {f}: eye {e} pixel {p} covered but without a visible surface sample"
                        );
                    }
                }
            }
            eprintln!(
                "{view} frame {f}: {bg} background rays, {sky} pixels without a visible surface sample, {new} new-sample rays, {retrace} retrace rays"
            );
            assert_eq!(
                empty, 0,
                "{view} frame {f}: pixels without a visible sample"
            );
            if view == "away" {
                assert_eq!(sky as f64, 2.0 * npix);
                let expected_bg = if f == 0 { n_target * 2.0 * npix } else { 0.0 };
                assert_eq!(bg, expected_bg, "{view} frame {f}: background rays");
                assert_eq!(new, 0.0, "{view} frame {f}");
                let expected_retrace = if f == 0 { 0.0 } else { blocks };
                assert_eq!(retrace, expected_retrace, "{view} frame {f}: retrace rays");
            } else {
                assert!(
                    sky > 0 && (sky as f64) < 2.0 * npix,
                    "{view}: sphere covers part of the view"
                );
                if f == 0 {
                    assert!(
                        bg >= n_target * sky as f64 && bg + new <= n_target * 2.0 * npix,
                        "{view} frame {f}: {bg} background rays for {sky} sky pixels"
                    );
                } else {
                    assert_eq!(
                        bg + new,
                        0.0,
                        "{view} frame {f}: a static view loses no sample"
                    );
                }
            }
        }
        if view == "away" {
            // The old cost: one background ray per pixel and frame.
            assert!(
                total_rays < 6.0 * 2.0 * npix,
                "{view}: {total_rays} rays in 6 frames"
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// The subgroup-operation builds (`// variant: SUBGROUP_OPS`: counters, list
/// reservations and the importance histogram reduced per subgroup) and the
/// plain builds compute the same thing: over the first two frames the
/// visibility counters and the importance histogram are equal. These do not
/// depend on which invocation wins a slot in reprojection (a race); what
/// does — which sample the straddling bucket's coin tosses pick, hence the
/// shaded count and the paths' rays — is left out.
#[test]
fn subgroup_and_plain_builds_agree() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    // Without subgroup arithmetic/ballot only the plain builds exist: nothing to compare.
    if !require(
        ctx.caps.has_subgroup_ops(&["arithmetic", "ballot"]),
        "subgroup arithmetic and ballot",
    ) {
        return;
    }
    let (w, h) = (48, 36);
    let cam0 = default_camera(&s, w, h);
    let run = |subgroup_ops: bool| {
        let mut st = settings(
            w,
            h,
            SampleCacheSettings {
                shading: Shading::Adaptive,
                shading_rate: 0.75,
                ..Default::default()
            },
        );
        st.subgroup_ops = subgroup_ops;
        let mut m = cache_method(&s, &st);
        assert_eq!(m.uses_subgroup_ops(), subgroup_ops);
        let mut out = Vec::new();
        let mut prev = None;
        for f in 0..2 {
            let cam = moving(&cam0, f, 0.5);
            let fr = render_at(&mut m, f, cam, prev);
            prev = Some(cam);
            let snap = m.snapshot().unwrap();
            let mut counters = fr.stats.counters.clone();
            for order_dependent in ["shaded_samples", "bounce_rays", "shadow_rays"] {
                counters.remove(order_dependent);
            }
            out.push((counters, snap.histogram.clone()));
        }
        out
    };
    let (sg, plain) = (run(true), run(false));
    for f in 0..2 {
        assert_eq!(sg[f].0, plain[f].0, "frame {f}: counters");
        assert_eq!(sg[f].1, plain[f].1, "frame {f}: importance histogram");
    }
    let hist_total: u32 = sg[1].1.iter().sum();
    assert!(
        hist_total > 0,
        "the second frame reprojects samples into the histogram"
    );
    assert_no_validation_messages(&ctx);
}

/// Fig. 6's no-shade rows and Fig. 7's "shading is skipped" (issue 15): on a
/// moving Cornell trace, `--shading skip` dispatches no shading pass and
/// traces no path (0 shaded samples, bounce and shadow rays), and
/// `--payload none` allocates 128-bit entries (first hits only: one half of
/// the cache is the mask, the first hits and a 16-byte placeholder), while
/// the visibility is that of the shaded cache with its payload: in every
/// frame the visibility counters are equal and every pixel holds the same
/// occupied-slot count and the same set of visible first hits.
#[test]
fn skipped_shading_and_no_payload_keep_the_visibility() {
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    let (w, h) = (40, 30);
    let cam0 = default_camera(&s, w, h);
    let frames = 5;
    let run = |shading: Shading, payload: Payload| {
        let st = settings(
            w,
            h,
            SampleCacheSettings {
                shading,
                payload,
                ..Default::default()
            },
        );
        let mut m = cache_method(&s, &st);
        let mut out = Vec::new();
        let mut prev = None;
        for f in 0..frames {
            let cam = moving(&cam0, f, 1.5);
            let fr = render_at(&mut m, f, cam, prev);
            prev = Some(cam);
            out.push((fr.stats, m.snapshot().unwrap()));
        }
        (m.cache_bytes(), out)
    };
    let (bytes_full, full) = run(Shading::Uniform, Payload::Radiance);
    let (bytes_skip, skip) = run(Shading::Skip, Payload::Radiance);
    let (bytes_none, none) = run(Shading::Skip, Payload::None);
    let entries = 2 * (w * h) as u64 * SampleCacheSettings::default().slots as u64;
    let mask_bytes = 2 * (w * h) as u64 * 4;
    assert_eq!(bytes_full, mask_bytes + entries * 32, "256-bit entries");
    assert_eq!(bytes_skip, bytes_full);
    assert_eq!(
        bytes_none,
        mask_bytes + entries * 16 + 16,
        "128-bit entries"
    );
    let visible_hits = |snap: &CacheSnapshot, e: usize, p: usize| {
        let mut v: Vec<[u32; 4]> = Vec::new();
        let mut bits = snap.visible(snap.mask(e, p));
        while bits != 0 {
            let s = bits.trailing_zeros();
            bits &= bits - 1;
            v.push(snap.first_hits[snap.slot(e, s, p)]);
        }
        v.sort();
        v
    };
    // Counters that shading writes (its paths' rays are in `stats.rays`).
    let shading_only = ["shaded_samples"];
    for f in 0..frames as usize {
        let (ref_stats, ref_snap) = &full[f];
        assert!(
            ref_stats.counters["shaded_samples"] > 0.0,
            "frame {f}: the full cache shades"
        );
        for (label, (stats, snap)) in [("skip", &skip[f]), ("no payload", &none[f])] {
            assert_eq!(stats.counters["shaded_samples"], 0.0, "{label}, frame {f}");
            assert_eq!(
                (stats.rays.bounce, stats.rays.shadow),
                (0, 0),
                "{label}, frame {f}: path rays"
            );
            assert_eq!(
                stats.rays.primary, ref_stats.rays.primary,
                "{label}, frame {f}"
            );
            assert!(
                !stats.passes.iter().any(|p| p.name.starts_with("shade")),
                "{label}, frame {f}: a shading pass ran"
            );
            let mut a = ref_stats.counters.clone();
            let mut b = stats.counters.clone();
            for c in shading_only {
                a.remove(c);
                b.remove(c);
            }
            assert_eq!(a, b, "{label}, frame {f}: visibility counters");
            let mut differ = 0;
            for e in 0..2 {
                for p in 0..snap.npix() {
                    let (ma, mb) = (ref_snap.mask(e, p), snap.mask(e, p));
                    if ref_snap.occupied(ma).count_ones() != snap.occupied(mb).count_ones()
                        || visible_hits(ref_snap, e, p) != visible_hits(snap, e, p)
                    {
                        differ += 1;
                    }
                }
            }
            assert_eq!(differ, 0, "{label}, frame {f}: pixels whose samples differ");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Appendix C's roughness sweep: the scene `cornell:alpha=A` is the Cornell
/// box with both spheres at GGX α = A (glTF roughness √A, as the BSDF takes
/// α = roughness²) and every other material as shipped; bad options are one
/// clear error naming the scene.
#[test]
fn cornell_alpha_option_sets_the_spheres_roughness() {
    let shipped_box = stereocache::scene::load_scene("cornell").unwrap();
    for alpha in [0.0f32, 0.2, 0.4] {
        let spec = format!("cornell:alpha={alpha}");
        let sc = stereocache::scene::load_scene(&spec).unwrap();
        assert_eq!(sc.materials.len(), shipped_box.materials.len());
        for (m, m0) in sc.materials.iter().zip(&shipped_box.materials) {
            if m.name == "metal" || m.name == "glass" {
                assert_eq!(m.roughness, alpha.sqrt(), "{spec}: {}", m.name);
                assert_eq!((m.metallic, m.transmission), (m0.metallic, m0.transmission));
            } else {
                assert_eq!(m.roughness, m0.roughness, "{spec}: {}", m.name);
            }
        }
        assert_eq!(sc.meshes.len(), shipped_box.meshes.len());
    }
    for bad in [
        "cornell:alpha=1.5",
        "cornell:alpha=x",
        "cornell:roughness=0.2",
    ] {
        let e = stereocache::scene::load_scene(bad).unwrap_err().to_string();
        assert!(
            e.contains(bad) && e.contains("cornell:alpha=A"),
            "{bad}: {e}"
        );
    }
}

/// §3.4's base rate on the GPU follows its CPU twin
/// (heuristics.rs `is_sparse_base_pixel`, unit-tested to visit every pixel
/// of a block once in every 16 frames): on a camera-facing plane that fills
/// the view (no sky, and no Eq. 2 edge: at a 10° field of view over 14
/// pixels the plane's depth curvature across a 3×3 neighbourhood, ≈ 8φ²·t
/// against Eq. 2's 2Δn ≈ φ²·t, stays far inside ε1·t; at 40° it does not,
/// and the centre pixels are flagged), the pixels select.comp retraces — the
/// `trace-mask` view — are exactly the base pixels, in every frame after
/// the first (which has nothing to retrace) and both eyes, at a size whose
/// right and bottom blocks are cut by the border. Over 96 frames (six
/// visits of every pixel) every sample a pixel holds throughout is
/// retraced at least once: the base visit picks the slot round robin over
/// the visits (until session 49 by frame mod n_occ, the same slot at every
/// visit when n_occ divides 16: with four samples a pixel never retraced
/// three of them).
#[test]
fn base_rate_retraces_exactly_the_rotating_base_pixels() {
    use glam::{Vec2, Vec3};
    use stereocache::methods::sample_cache::heuristics::is_sparse_base_pixel;
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    let ctx = context();
    let mut scene = stereocache::scene::Scene {
        source: "test:wall".into(),
        ..Default::default()
    };
    let mut m = stereocache::scene::Material::diffuse("wall", Vec3::splat(0.6));
    m.double_sided = true;
    let mat = add_material(&mut scene, m);
    let wall = grid(
        "wall",
        Vec3::new(-10.0, -10.0, 0.0),
        Vec3::X * 20.0,
        Vec3::Y * 20.0,
        4,
        4,
        Vec2::ONE,
    );
    add_mesh(&mut scene, wall, mat, glam::Mat4::IDENTITY);
    scene.lights.push(directional_light(
        Vec3::new(0.2, 0.3, 1.0).normalize(),
        1.0,
        0.0,
    ));
    scene.environment = None;
    scene.validate().unwrap();
    let s = session(&ctx, scene, RtChoice::Software);
    let (w, h) = (18u32, 14u32);
    let st = settings(
        w,
        h,
        SampleCacheSettings {
            debug_views: true,
            ..Default::default()
        },
    );
    let mut m = cache_method(&s, &st);
    let cam = look_at_camera(
        Vec3::new(0.3, 0.2, 4.0),
        Vec3::new(0.3, 0.2, 0.0),
        10.0,
        w as f32 / h as f32,
    );
    // Per eye and pixel: the occupancy in every frame so far (AND) and the
    // slots retraced (OR), from frame 1 on.
    let n = (w * h) as usize;
    let mut held = vec![u32::MAX; 2 * n];
    let mut traced_slots = vec![0u32; 2 * n];
    for f in 0..97u32 {
        let fr = render_at(&mut m, f, cam, (f > 0).then_some(cam));
        assert_eq!(
            fr.stats.counters["edge_pixels"], 0.0,
            "frame {f}: an edge on a plane"
        );
        if f == 0 {
            continue;
        }
        let snap = m.snapshot().unwrap();
        for i in 0..2 * n {
            held[i] &= snap.occupied(snap.masks[i]);
            traced_slots[i] |= snap.pixel_stats[i][0];
        }
        for eye in 0..2u32 {
            let mask = &fr.eyes[eye as usize]
                .debug
                .iter()
                .find(|(n, _)| n == "trace-mask")
                .expect("trace-mask view")
                .1;
            for y in 0..h {
                for x in 0..w {
                    let traced = mask[(y * w + x) as usize][0] > 0.0;
                    let base = is_sparse_base_pixel([x, y], [w, h], f, eye);
                    assert_eq!(traced, base, "frame {f}, eye {eye}, pixel ({x}, {y})");
                }
            }
        }
    }
    // The still plane fills every pixel to n_target at frame 0 and loses no
    // sample (no edge, nothing occluded): each pixel held the same n_target
    // slots through frames 1–96 (a cache that dropped and refilled its
    // samples would hold none throughout and pass the retrace check below
    // vacuously). Six base visits (96 / 16 frames) then retrace all four
    // round robin.
    let n_target = SampleCacheSettings::default().n_target;
    for i in 0..2 * n {
        assert_eq!(
            held[i].count_ones(),
            n_target,
            "eye {}, pixel {}: held slots {:#b} through frames 1-96",
            i / n,
            i % n,
            held[i]
        );
        assert_eq!(
            traced_slots[i] & held[i],
            held[i],
            "eye {}, pixel {}: held slots {:#b}, retraced {:#b} in 96 frames",
            i / n,
            i % n,
            held[i],
            traced_slots[i]
        );
    }
    assert_no_validation_messages(&ctx);
}

/// `memory_bytes` (the `method_memory_bytes` of compare's summaries and
/// the experiments' claims) is every byte the method's buffers take on the
/// device: the allocator's count grows by exactly that much while the
/// method is created (until session 48 the retrace list, its count and the
/// indirect arguments were left out: 2·N·4 + 4 bytes a pixel, ≈ 216 MB at
/// 1080p with N = 12), for both reprojection variants and with the debug
/// views.
#[test]
fn memory_bytes_counts_every_buffer_the_method_allocates() {
    use stereocache::methods::Method;
    let ctx = context();
    let s = session(&ctx, shipped("cornell"), RtChoice::Software);
    for reproject in [Reproject::OnePass, Reproject::TwoPass] {
        let st = settings(
            24,
            16,
            SampleCacheSettings {
                reproject,
                ..Default::default()
            },
        );
        let before = ctx.allocated_bytes();
        let m = cache_method(&s, &st);
        let allocated = ctx.allocated_bytes() - before;
        assert_eq!(m.memory_bytes(), allocated, "{reproject:?}");
        drop(m);
        assert_eq!(ctx.allocated_bytes(), before, "{reproject:?}: freed");
    }
    assert_no_validation_messages(&ctx);
}
