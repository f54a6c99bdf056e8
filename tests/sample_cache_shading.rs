//! The sample cache's shading (issue 12 items 3–7): adaptive shading holds
//! its rate and leaves no visible pixel black, the two-pass reprojection
//! resolves a visible/invisible race for the visible sample, stereo blending
//! does not blur the colour, emission survives the cache, and the
//! adaptive-shading fallback demodulates what it borrows.

mod common;
use common::*;
use glam::Vec3;
use stereocache::camera::{synth, SynthKind};
use stereocache::methods::sample_cache::{
    CacheSnapshot, Reproject, Retrace, SampleCacheSettings, Shading,
};
use stereocache::methods::{RenderSettings, StereoFrame};
use stereocache::metrics::{cpbd, LinearImage};
use stereocache::replay::trace_cameras;
use stereocache::rt::RtChoice;
use stereocache::scene::Material;
use stereocache::session::CameraSelect;
use stereocache::stereo::BlendMode;

fn settings(w: u32, h: u32, cache: SampleCacheSettings) -> CacheSetup {
    cache_settings(w, h, cache, 9)
}

/// Per eye: the expected number of dispatched shading paths and the
/// variance of its coin tosses, from what `shade.count` counted (histogram,
/// base-rate and unshaded pixels): the base rate is shaded as is; of the
/// budget rate × covered pixels (a visible surface sample) left, the unshaded pixels take one path each with
/// probability p_u = min(1, left / their count) (Bernoulli: var p_u(1 − p_u)
/// each); what remains goes down the histogram, every sample above the
/// straddling bucket shaded and that bucket's by coin tosses with
/// probability p (var p(1 − p) each).
fn expected_dispatch(snap: &CacheSnapshot, rate: f32, eye: usize) -> (f64, f64) {
    // The rate is a fraction of what uniform shading shades: the pixels with
    // a visible surface sample (until session 50 of all pixels). Counted
    // here from the masks, and the shader's own count must agree.
    let covered = snap.covered(eye);
    assert_eq!(
        snap.covered_pixels[eye] as usize, covered,
        "eye {eye}: covered pixels"
    );
    let budget = rate as f64 * covered as f64;
    let base = snap.base_pixels[eye] as f64;
    let left = (budget - base).max(0.0);
    let unshaded = snap.unshaded_pixels[eye] as f64;
    let p_u = if unshaded > 0.0 {
        (left / unshaded).min(1.0)
    } else {
        0.0
    };
    let (mut mean, mut var) = (base + unshaded * p_u, unshaded * p_u * (1.0 - p_u));
    let requested = (left - unshaded).max(0.0);
    let hist = &snap.histogram[eye * 13..(eye + 1) * 13];
    let mut above = 0.0;
    for &c in hist.iter().rev() {
        let c = c as f64;
        if above + c >= requested {
            let p = if c > 0.0 {
                (requested - above) / c
            } else {
                0.0
            };
            mean += above + c * p;
            var += c * p * (1.0 - p);
            return (mean, var);
        }
        above += c;
    }
    (mean + above, var)
}

/// Adaptive shading on a fast head turn (the synthetic head-turn trace's
/// first sweep, 0 → 30° at a drawn 80–120 °/s peak, rendered at 30 Hz: a few
/// pixels of new view per frame) and from frame 0 on: in every frame the
/// dispatched paths equal the requested rate × covered pixels within 4 standard
/// deviations of the frame's coin tosses (variance computed from what the
/// shader counted), and no pixel with a visible sample is black. On the
/// sunlit plane every shaded path is positive (sun unoccluded, the sky above
/// every bounce), so a black visible pixel can only be an unshaded one.
#[test]
fn adaptive_shading_holds_the_rate_and_leaves_no_visible_pixel_black() {
    let ctx = context();
    let s = session(&ctx, shipped("plane"), RtChoice::Software);
    let (w, h) = (64, 48);
    let rate = 0.5f32;
    let trace = synth(SynthKind::HeadTurn, 0.6, 3, 1000.0);
    let cams = trace_cameras(
        &s,
        &trace,
        30.0,
        w,
        h,
        &CameraSelect::Default,
        None,
        None,
        None,
    )
    .unwrap();
    for subgroup_ops in [true, false] {
        let mut st = settings(
            w,
            h,
            SampleCacheSettings {
                shading: Shading::Adaptive,
                shading_rate: rate,
                ..Default::default()
            },
        );
        st.subgroup_ops = subgroup_ops;
        let mut m = cache_method(&s, &st);
        let mut prev = None;
        for (f, cam) in cams.iter().enumerate() {
            let fr = render_at(&mut m, f as u32, *cam, prev);
            prev = Some(*cam);
            let snap = m.snapshot().unwrap();
            let (mut mean, mut var) = (0.0, 0.0);
            for e in 0..2 {
                let (a, b) = expected_dispatch(&snap, rate, e);
                mean += a;
                var += b;
            }
            let shaded = snap.shade_count as f64;
            // Rate × the pixels uniform shading shades (session 50; all
            // pixels before).
            let requested = rate as f64 * (snap.covered(0) + snap.covered(1)) as f64;
            let new = fr.stats.counters["new_sample_rays"];
            eprintln!(
                "subgroup {subgroup_ops} frame {f}: {shaded} paths, requested {requested}, expected {mean:.1} ± {:.1}; {new} new samples, {:?} unshaded pixels",
                var.sqrt(),
                snap.unshaded_pixels
            );
            assert_eq!(shaded, fr.stats.counters["shaded_samples"]);
            // The plane covers more than the rate in samples: the budget is spent in full.
            assert!(
                (mean - requested).abs() <= 1e-6 * requested,
                "frame {f}: expected dispatch {mean} for {requested} requested"
            );
            assert!(
                (shaded - requested).abs() <= 4.0 * var.sqrt() + 1.0,
                "frame {f}: {shaded} paths dispatched for a requested {requested} (± {:.1})",
                var.sqrt()
            );
            // The histogram holds every candidate once: the visible surface
            // samples (background samples are never shaded) but the
            // base-rate and unshaded pixels' round-robin ones.
            let visible: u32 = (0..2)
                .flat_map(|e| (0..snap.npix()).map(move |p| (e, p)))
                .map(|(e, p)| {
                    snap.surface(e, p, snap.visible(snap.mask(e, p)))
                        .count_ones()
                })
                .sum();
            let hist: u32 = snap.histogram.iter().sum();
            let first: u32 = snap.base_pixels.iter().chain(&snap.unshaded_pixels).sum();
            assert_eq!(hist, visible - first, "frame {f}: histogram total");
            let mut black = 0;
            for (e, eye) in fr.eyes.iter().enumerate() {
                for (p, px) in eye.radiance.iter().enumerate() {
                    if snap.visible(snap.mask(e, p)) != 0 && px[..3].iter().all(|c| *c <= 0.0) {
                        black += 1;
                    }
                }
            }
            assert_eq!(black, 0, "frame {f}: {black} visible pixels are black");
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Two-pass reprojection (§3.1's race-free variant): an invisible and a
/// visible source sample (two real first hits of one pixel T) are placed in
/// neighbouring source pixels of a one-slot cache, so both reserve T's only
/// slot — the invisible one on the free slot, the visible one over it. In
/// both orders (invisible source in the lower or the higher lane), T ends
/// with the visible sample's first hit and radiance record under v = 1.
/// One-pass reprojection, racy by design, is run alongside and reported.
#[test]
fn two_pass_reprojection_keeps_the_visible_sample_on_a_shared_slot() {
    let ctx = context();
    let s = session(&ctx, shipped("plane"), RtChoice::Software);
    let (w, h) = (32, 24);
    let cam = default_camera(&s, w, h);
    // Two first hits of one ground pixel from a two-slot cache's first frame.
    let mut probe = cache_method(
        &s,
        &settings(
            w,
            h,
            SampleCacheSettings {
                slots: 2,
                n_target: 2,
                delta: 0,
                ..Default::default()
            },
        ),
    );
    render_at(&mut probe, 0, cam, None);
    let ps = probe.snapshot().unwrap();
    let target = (ps.npix() * 3 / 4..ps.npix())
        .find(|&p| {
            let vis = ps.visible(ps.mask(0, p));
            vis == 0b11 && ps.first_hits[ps.slot(0, 0, p)] != ps.first_hits[ps.slot(0, 1, p)]
        })
        .expect("a ground pixel with two visible samples");
    let (a, b) = (
        ps.first_hits[ps.slot(0, 0, target)],
        ps.first_hits[ps.slot(0, 1, target)],
    );
    for reproject in [Reproject::TwoPass, Reproject::OnePass] {
        for invisible_first in [true, false] {
            let cs = SampleCacheSettings {
                slots: 1,
                n_target: 1,
                delta: 0,
                reproject,
                retrace: Retrace::Multi,
                ..Default::default()
            };
            let mut m = cache_method(&s, &settings(w, h, cs));
            let mut snap = CacheSnapshot::empty(1, w, h);
            // Source pixels 0 and 1 of eye 0 (neighbouring lanes of one workgroup).
            let (inv, vis) = if invisible_first { (0, 1) } else { (1, 0) };
            snap.masks[inv] = 0b01; // occupied, invisible
            snap.masks[vis] = 0b11; // occupied, visible
            snap.first_hits[inv] = a;
            snap.first_hits[vis] = b;
            snap.radiance[inv] = [1.0, 0.0, 0.0, 1000.0];
            snap.radiance[vis] = [0.0, 1.0, 0.0, 7.0];
            m.load(&snap).unwrap();
            render_at(&mut m, 0, cam, Some(cam));
            let out = m.snapshot().unwrap();
            let mask = out.mask(0, target);
            let (fh, rad) = (out.first_hits[target], out.radiance[target]);
            let ok = mask == 0b11 && fh == b && (7.0..=8.01).contains(&rad[3]);
            eprintln!(
                "{reproject:?}, invisible source {}: mask {mask:#b}, {}, c = {}",
                if invisible_first { "first" } else { "second" },
                if fh == b {
                    "visible sample's hit"
                } else if fh == a {
                    "INVISIBLE sample's hit"
                } else {
                    "another hit"
                },
                rad[3]
            );
            if reproject == Reproject::TwoPass {
                assert!(
                    ok,
                    "two-pass, invisible first {invisible_first}: mask {mask:#b}, hit {fh:?} (visible {b:?}, invisible {a:?}), record {rad:?}"
                );
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

fn luminance_image(f: &StereoFrame, eye: usize) -> LinearImage {
    LinearImage::from_rgba(&f.eyes[eye].radiance, f.width as usize, f.height as usize).unwrap()
}

/// Stereo blending (§3.6, §5.2) on a textured scene: the plane's checker
/// made an emitter with a black base colour, so every path is exactly its
/// texture's emission (item 7) and the images carry no Monte Carlo noise:
/// only resampling and blending change the sharpness. X's colour is
/// resampled without the moments' blur, so the blended image's CPBD at R = 0
/// (the widest blur of the moments) and at R = 1 stays within noise of the
/// unblended image's. Noise: CPBD is a fraction p of n edge pixels,
/// standard error √(p(1 − p)/n) per image; the tolerance is 4 standard
/// errors of the difference (√2 of one image's, the two taken as independent).
#[test]
fn stereo_blending_does_not_blur_the_colour() {
    let ctx = context();
    let mut scene = shipped("plane");
    for m in &mut scene.materials {
        m.emissive_texture = m.base_color_texture;
        m.emissive = Vec3::ONE;
        m.base_color = glam::Vec4::new(0.0, 0.0, 0.0, 1.0);
        m.base_color_texture = None;
        m.specular = 0.0;
        m.metallic = 0.0;
    }
    let s = session(&ctx, scene, RtChoice::Software);
    let (w, h) = (256, 192);
    let cam = default_camera(&s, w, h);
    let run = |mode: BlendMode, sharpness: f32| -> StereoFrame {
        let st = settings(
            w,
            h,
            SampleCacheSettings {
                stereo_blend: mode,
                sharpness,
                ..Default::default()
            },
        );
        let mut m = cache_method(&s, &st);
        render_still(&mut m, cam, 2)
    };
    let none = run(BlendMode::None, 0.0);
    for r in [0.0f32, 1.0] {
        let blended = run(BlendMode::Moments, r);
        for e in 0..2 {
            let a = cpbd(&luminance_image(&none, e)).unwrap();
            let b = cpbd(&luminance_image(&blended, e)).unwrap();
            assert!(
                a.edges > 100 && b.edges > 100,
                "too few edges: {} {}",
                a.edges,
                b.edges
            );
            let p = a.cpbd as f64;
            let se = (p * (1.0 - p) / a.edges.min(b.edges) as f64)
                .sqrt()
                .max(1e-3);
            eprintln!(
                "R = {r}, eye {e}: CPBD {:.3} ({} edges) unblended vs {:.3} ({} edges) blended, se {se:.3}",
                a.cpbd, a.edges, b.cpbd, b.edges
            );
            assert!(
                ((b.cpbd - a.cpbd) as f64).abs() <= 4.0 * std::f64::consts::SQRT_2 * se,
                "R = {r}, eye {e}: CPBD {} blended vs {} unblended (se {se:.3})",
                b.cpbd,
                a.cpbd
            );
        }
    }
    assert_no_validation_messages(&ctx);
}

/// Emission survives the cache (issue 12 item 7): an emitter with a black
/// base colour (and no specular layer, so it reflects nothing) fills the
/// view; its radiance is its emission, exactly, through `reference` and
/// through `sample-cache` (which once divided it by max(base, 10⁻³) and
/// multiplied it back by the black base: 0; since session 58 records hold
/// radiance as shaded, and this pins that the emission stays in them).
#[test]
fn black_base_emitter_renders_its_emission_through_the_cache() {
    let ctx = context();
    let le = Vec3::new(2.0, 1.0, 0.5);
    let emitter = Material {
        base_color: glam::Vec4::new(0.0, 0.0, 0.0, 1.0),
        metallic: 0.0,
        specular: 0.0,
        emissive: le,
        ..Material::diffuse("black emitter", Vec3::ZERO)
    };
    let s = session(
        &ctx,
        plane_in_environment(emitter, 8.0, Vec3::splat(0.4)),
        RtChoice::Software,
    );
    let (w, h) = (32, 24);
    let cam = look_at_camera(
        Vec3::new(0.0, 1.0, 0.3),
        Vec3::ZERO,
        45.0,
        w as f32 / h as f32,
    );
    let st = settings(w, h, SampleCacheSettings::default());
    let reference = render(
        &s,
        "reference",
        cam,
        &RenderSettings {
            spp: 4,
            ..st.settings.clone()
        },
    );
    let mut m = cache_method(&s, &st);
    for f in 0..3 {
        let fr = render_at(&mut m, f, cam, if f > 0 { Some(cam) } else { None });
        for (e, (a, b)) in reference.eyes.iter().zip(&fr.eyes).enumerate() {
            for (p, (x, y)) in a.radiance.iter().zip(&b.radiance).enumerate() {
                for k in 0..3 {
                    assert!(
                        (x[k] - le[k]).abs() <= 1e-5 * le[k] && (y[k] - le[k]).abs() <= 1e-5 * le[k],
                        "frame {f}, eye {e}, pixel {p}: reference {x:?}, sample cache {y:?}, emission {le}"
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}

/// `--accumulation` (common/accumulation.glsl `accumulation_floor`) in both
/// methods that accumulate a sample's shadings, against the CPU twin
/// (`heuristics::accumulate`): a still view of a rough dielectric plane
/// (roughness 0.6: α_GGX = 0.36, appendix C's α_min = 0.5·0.64 + 0.1·0.36
/// = 0.356), K shadings of the samples traced at frame 0. The sample cache
/// with one slot per pixel shades its one sample every frame (K = 12);
/// isrt (M = 2, every cell filled) shades its four cells round robin, so a
/// cell of frame 0 is shaded every fourth frame (K = 4 over 16 frames).
/// Every surface sample of the sample cache holds the twin's effective
/// count c after K = 12 shadings (the view is still, the plane fills every
/// pixel, so no sample is replaced); every isrt cell holds the twin's count
/// after k ≤ 4 shadings (a cell filled later has fewer), the largest after
/// 4: K for `mean` (the default since session 50: until then `mean` was
/// `alpha-min`), the floored sequences for `alpha-min` and `fixed:0.5` (all
/// three differ at these K). Tolerance: f32 rounding of the count's
/// recurrence (K steps, relative 1e-5).
#[test]
fn accumulation_modes_floor_the_blend_factor_as_the_cpu_twin() {
    use stereocache::methods::isrt::{Isrt, IsrtRetrace, IsrtSettings};
    use stereocache::methods::sample_cache::{heuristics, Accumulation};
    let ctx = context();
    let plane = Material {
        metallic: 0.0,
        specular: 1.0,
        roughness: 0.6,
        ..Material::diffuse("rough dielectric", Vec3::splat(0.5))
    };
    let s = session(
        &ctx,
        plane_in_environment(plane, 8.0, Vec3::splat(0.4)),
        RtChoice::Software,
    );
    let (w, h) = (16, 12);
    let cam = look_at_camera(
        Vec3::new(0.0, 1.0, 0.3),
        Vec3::ZERO,
        45.0,
        w as f32 / h as f32,
    );
    let twin = |floor: f32, k: u32| (0..k).fold(0.0f32, |c, _| heuristics::accumulate(c, floor).1);
    let a_min = heuristics::alpha_min(0.36);
    let modes = [
        (Accumulation::RunningMean, 0.0),
        (Accumulation::AlphaMin, a_min),
        (Accumulation::FixedAlpha(0.5), 0.5),
    ];
    let close = |got: f32, want: f32| (got - want).abs() <= 1e-5 * want;
    // The effective counts of the surface samples (Listing 1: the no-hit
    // marker w = u32::MAX marks empty cells and background samples).
    let counts = |first_hits: &[[u32; 4]], radiance: &[[f32; 4]]| -> Vec<f32> {
        first_hits
            .iter()
            .zip(radiance)
            .filter(|(fh, _)| fh[3] != u32::MAX)
            .map(|(_, r)| r[3])
            .collect()
    };
    for (mode, floor) in modes {
        // The sample cache: one slot per pixel, shaded every frame.
        let st = settings(
            w,
            h,
            SampleCacheSettings {
                slots: 1,
                n_target: 1,
                delta: 0,
                accumulation: mode,
                ..Default::default()
            },
        );
        let mut m = cache_method(&s, &st);
        for f in 0..12 {
            render_at(&mut m, f, cam, if f > 0 { Some(cam) } else { None });
        }
        let snap = m.snapshot().unwrap();
        let c = counts(&snap.first_hits, &snap.radiance);
        let want = twin(floor, 12);
        assert_eq!(
            c.len(),
            2 * (w * h) as usize,
            "sample cache {mode:?}: one surface sample a pixel"
        );
        for (i, &got) in c.iter().enumerate() {
            assert!(
                close(got, want),
                "sample cache {mode:?}: sample {i}'s count {got}, twin {want} after 12 shadings"
            );
        }
        // isrt: four cells per pixel, each shaded every fourth frame.
        let is = IsrtSettings {
            m: 2,
            retrace: IsrtRetrace::Every,
            accumulation: mode,
            ..Default::default()
        };
        let mut m = Isrt::new(
            &s.ctx,
            &s.scene_gpu,
            &s.scene.environment,
            &st.settings,
            &is,
        )
        .unwrap();
        for f in 0..16 {
            render_at(&mut m, f, cam, if f > 0 { Some(cam) } else { None });
        }
        let snap = m.snapshot().unwrap();
        let c = counts(&snap.first_hits, &snap.radiance);
        let want = twin(floor, 4);
        assert!(!c.is_empty(), "isrt {mode:?}: no surface cell");
        for (i, &got) in c.iter().enumerate() {
            assert!(
                (0..=4).any(|k| close(got, twin(floor, k))),
                "isrt {mode:?}: cell {i}'s count {got} is no twin count of 0-4 shadings"
            );
        }
        let max = c.iter().copied().fold(0.0f32, f32::max);
        assert!(
            close(max, want),
            "isrt {mode:?}: largest count {max}, twin {want} after 4 shadings"
        );
    }
    assert_no_validation_messages(&ctx);
}

/// The adaptive-shading fallback (issue 12 item 3) with known answers, now
/// that records hold radiance as shaded (session 58). Two Lambertian
/// halves of a 1 m square, white (x < 0) and grey 0.5 (x > 0), no specular
/// layer (demodulation factor = base colour), seen head-on by orthographic
/// eyes 40 px over 2 m (20 px per metre, both eyes alike: ipd 0): columns
/// 10..20 white, 20..30 grey, rows 10..30. After two still frames the
/// cache is loaded with every grey sample shaded at radiance 0.25 (c = 1)
/// and every white one unshaded, and one more still frame is rendered
/// without shading (`--shading skip`: only the loaded records). Then
/// - a grey pixel shows its records' radiance, 0.25 (until session 58 a
///   record was demodulated radiance, remodulated to 0.125 here);
/// - a white pixel within 4 columns of the grey half borrows its nearest
///   shaded neighbours' radiance demodulated by their own material and
///   remodulated by its own: 0.25 / 0.5 × 1 = 0.5 (without the
///   demodulation by the neighbours' material: 0.25);
/// - a white pixel farther away finds no shaded sample within 4 pixels and
///   shows its own emission, 0.
#[test]
fn the_unshaded_fallback_borrows_demodulated_radiance() {
    use glam::{Mat4, Quat, Vec2};
    use stereocache::camera::{Eye, HeadPose, Projection, StereoCamera};
    use stereocache::scene::generate::{add_material, add_mesh, grid};
    use stereocache::scene::{Environment, Scene};
    let ctx = context();
    let mut scene = Scene {
        source: "test:two-halves".into(),
        ..Default::default()
    };
    for (name, base, x0) in [("white", 1.0f32, -0.5f32), ("grey", 0.5, 0.0)] {
        let mut m = Material::diffuse(name, Vec3::splat(base));
        m.specular = 0.0;
        let mat = add_material(&mut scene, m);
        let quad = grid(
            name,
            Vec3::new(x0, -0.5, 0.0),
            0.5 * Vec3::X,
            Vec3::Y,
            1,
            1,
            Vec2::ONE,
        );
        add_mesh(&mut scene, quad, mat, Mat4::IDENTITY);
    }
    scene.environment = Some(Environment::Constant(Vec3::ONE));
    scene.validate().unwrap();
    let s = session(&ctx, scene, RtChoice::Software);
    let w = 40u32;
    let mut cam = StereoCamera::new(
        HeadPose::new(Vec3::new(0.0, 0.0, 2.0), Quat::IDENTITY),
        1.0,
        1.0,
    );
    cam.ipd = 0.0;
    cam.projection = Projection::Orthographic { ymag: 1.0 };
    let st = settings(
        w,
        w,
        SampleCacheSettings {
            shading: Shading::Skip,
            ..Default::default()
        },
    );
    let mut m = cache_method(&s, &st);
    for f in 0..2 {
        render_at(&mut m, f, cam, Some(cam));
    }
    // Instance 1 is the grey half (meshes are instanced in order).
    let mut snap = m.snapshot().unwrap();
    let mut grey_samples = 0;
    for i in snap.visible_surface_records() {
        let grey = snap.first_hits[i][3] == 1;
        grey_samples += grey as usize;
        snap.radiance[i] = if grey {
            [0.25, 0.25, 0.25, 1.0]
        } else {
            [0.0; 4]
        };
    }
    assert!(grey_samples > 2 * 200, "{grey_samples} grey samples");
    m.load(&snap).unwrap();
    let fr = render_at(&mut m, 2, cam, Some(cam));
    for (e, eye) in [Eye::Left, Eye::Right].into_iter().enumerate() {
        for j in 10..30u32 {
            for i in 10..30u32 {
                let want = match i {
                    20.. => 0.25,
                    16..=19 => 0.5,
                    _ => 0.0,
                };
                let p = fr.eye(eye).radiance[(j * w + i) as usize];
                for c in &p[..3] {
                    assert!(
                        (c - want).abs() <= 1e-5,
                        "eye {e}, pixel ({i}, {j}): {p:?}, want {want}"
                    );
                }
            }
        }
    }
    assert_no_validation_messages(&ctx);
}
