//! Importer for the MMSys'18 multi-viewpoint 360° video navigation traces.
//!
//! Source: X. Corbillon, F. De Simone, G. Simon, P. Frossard, "Dynamic
//! Adaptive Streaming for Multi-Viewpoint Omnidirectional Videos", ACM MMSys
//! 2018 (`github.com/xmar/MultiViewpoint360_MMSys18`, `rawNavigationTrace/`,
//! MIT licence). Four users watch a multi-viewpoint 360° video in a headset.
//!
//! # File format
//!
//! Space-separated text, one header line `timestamp viewpoint w x y z`, then
//! one sample per line:
//! - `timestamp`: seconds since the start of the session (checked against the
//!   data: ≈272–307 s sessions, mean step 17 ms ≈ 59 Hz, steps from 3 ms to
//!   0.27 s — jitter and dropped frames; strictly increasing in all four
//!   files).
//! - `viewpoint`: index (0, 1, 2) of the 360° camera whose video the user was
//!   watching; the user switches between cameras placed at different spots of
//!   the filmed scene. It is a content switch, not a head motion: the head
//!   orientation is continuous across switches (< 0.25° between the samples
//!   around every switch in `user1`). The importer ignores it and reports
//!   the number of switches in the warnings.
//! - `w x y z`: unit quaternion, scalar first, with sign flips between
//!   neighbouring samples (≈200–380 per file).
//!
//! # Axes
//!
//! The README says the quaternions use "the same convention as for the
//! dataset of Corbillon et al." (2017). That frame is **+x forward** (the
//! centre of the viewport tool's equirectangular frame; the authors' own
//! MMSys'18 scripts turn the traces 180° about z first, below), **+y
//! right**, **+z up** — a
//! left-handed frame, the quaternion applied algebraically head → world —
//! as the authors' own code fixes it (session 56; `xmar` repositories):
//! - their viewport tool, `360Transformations`, which they ran on exactly
//!   these traces (`MultiViewpoint360_MMSys18/reconstruct/`): the viewport
//!   centre is `q·(1,0,0)`, image-right is +y (`LayoutFlatFixed.cpp`),
//!   equirectangular `u = 0.5 + atan2(y, x)/2π` and `v = acos(z)/π`
//!   (`LayoutEquirectangular.hpp`, `Vector.hpp`): +y to the right, +z up;
//! - their 2017 recorder (`360Degree_Head_Movement_Dataset`,
//!   `RenderManagerOpenGLHighPolyTest.cpp`: `Rz(−90°)·(w, −z, −x, −y)` of
//!   the OSVR pose), in which a left turn is a rotation about −z and
//!   looking up raises +z;
//! - their tile-visibility inputs (`MILP_Multiview/scenarios/`), which
//!   match the traces read so (a session-56 audit: top against bottom
//!   visibility in 520 of 523 chunks).
//!
//! Until session 56 this importer read +y as **left** (right-handed), an
//! assumption from the 2017 Python helpers' `atan2(y, x)`, which does not
//! fix the side: every turn replayed mirrored. What stays unverifiable is
//! the Unity logger that wrote the MMSys'18 files (not public): if it got
//! a sign wrong, the authors' own pipeline shares the error. The data
//! agrees with the frame: over all four users the head's up axis stays
//! within a few degrees of +z, yaw dominates, pitch stays moderate and roll
//! small (mirroring would not change these).
//!
//! The conversion to glTF axes (+X right, +Y up, −Z forward) is the
//! change of frame `M` with `M·x̂ = −Ẑ` (forward), `M·ŷ = +X̂` (right),
//! `M·ẑ = +Ŷ` (up), a reflection (det −1); a rotation `(w, v)` becomes
//! `(w, −M·v)` ([`mmsys18_to_gltf`], [`AxisConvention::CORBILLON`]):
//!
//! ```text
//! (qx, qy, qz, qw)_glTF = (−y, −z, x, w)_MMSys18
//! ```
//!
//! so a positive yaw in the data (about +z: x towards +y, a right turn) is a
//! right turn in glTF. The data's +x is not where the authors' own pipeline
//! looks at the video's centre: it turns every sample 180° about z first
//! (`Navigation_user_*.txt` = `k ⊗ q`); a constant turn of the whole trace
//! changes nothing once the trace is placed at a scene camera
//! ([`super::Stage`]).
//!
//! # Composition order
//!
//! The quaternion files were computed from the Unity logger's Euler
//! angles (`user*_euler.txt` upstream: multiples of 0.1°, columns labelled
//! yaw/pitch/roll holding roll A, yaw B and pitch C) as
//! `q = Rx(−A)·Rz(B)·Ry(−C)`, exactly (residual 10⁻¹⁶, all four users; a
//! session-54 audit, confirmed in session 56) — roll outermost, where a
//! head's yaw·pitch·roll (Unity's own order) has yaw outermost. Near a yaw
//! of ±90° that order turns roll into pitch: whole-session rotation errors
//! of ≈2–4° (median, users 1–4: 4.3°, 1.8°, 2.9°, 2.7°) and up to 15° in
//! the shipped excerpt, and at the end of
//! user 4's session rotation speeds of 6300°/s that the head never made.
//! The importer decomposes each quaternion in the files' order
//! ([`mmsys18_euler`]; on the data every angle comes out on the 0.1° grid,
//! `tests/camera_traces.rs`) and composes the angles yaw outermost
//! ([`mmsys18_head_rotation`]: `Rz(b)·Ry(c)·Rx(a)`). At a yaw of exactly
//! ±90.0° (12 of user 1's 16 053 samples) the files' order is at its gimbal
//! lock, only pitch ∓ roll survives, and the roll is the previous sample's.
//!
//! # Position
//!
//! The data has orientation only; the eye midpoint comes from a
//! [`HeadNeckModel`]: `position = R·offset − offset`, so the identity
//! orientation (looking along the data's +x) is at the stage origin.
//!
//! # Repairs
//!
//! As for the CSV format (see [`super::trace`]): NaN/Inf, zero-norm
//! quaternions and decreasing timestamps (also outside the kept
//! `start..end` window) are errors naming the line;
//! non-unit quaternions are normalized; duplicate timestamps are dropped
//! with a warning; a truncated final line (fewer fields and no newline at
//! the end of the file) is dropped with a warning, as in the other
//! importers; sign flips are removed with
//! [`PoseTrace::make_hemisphere_continuous`] (count in the warnings). Real
//! (jittered) timestamps are kept; [`PoseTrace::resample`] produces the
//! render-rate frames.

use std::path::Path;

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DMat3, DQuat, DVec3};

use super::convention::AxisConvention;

use super::neck::HeadNeckModel;
use super::trace::{excerpt, PoseSample, PoseTrace, TraceBuilder, TraceError};

/// Column names of the MMSys'18 quaternion files.
pub const MMSYS18_COLUMNS: [&str; 6] = ["timestamp", "viewpoint", "w", "x", "y", "z"];

/// How to import an MMSys'18 trace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mmsys18Options {
    /// Translation model (default: Oculus SDK neck-to-eye offsets).
    pub neck: HeadNeckModel,
    /// Keep samples with `start ≤ timestamp ≤ end` (source seconds).
    pub start: f64,
    /// See `start`; `f64::INFINITY` keeps everything to the end.
    pub end: f64,
    /// Shift times so the first kept sample is at `t = 0`.
    pub rebase_time: bool,
}

impl Default for Mmsys18Options {
    fn default() -> Self {
        Self {
            neck: HeadNeckModel::default(),
            start: 0.0,
            end: f64::INFINITY,
            rebase_time: true,
        }
    }
}

/// An MMSys'18 rotation (`w, x, y, z` in the data's axes: +x forward, +y
/// right, +z up, the axes of the dataset authors' own viewport tool; module
/// docs "Axes") in glTF axes (+X right, +Y up, −Z forward). The data's
/// axes are left-handed, so the map is a reflection: the rotation axis
/// maps to (y, z, −x) and the angle changes sign:
/// `(qx, qy, qz, qw) = (−y, −z, x, w)` — [`AxisConvention::CORBILLON`],
/// the generic importers' convention of the same frame.
pub fn mmsys18_to_gltf(q: DQuat) -> DQuat {
    let [x, y, z, w] = AxisConvention::CORBILLON.quaternion([q.x, q.y, q.z, q.w]);
    DQuat::from_xyzw(x, y, z, w)
}

/// Roll `a`, yaw `b` and pitch `c` (radians) of the decomposition
/// `R = Rx(a)·Rz(b)·Ry(c)` of the unit quaternion `q` (the data's axes),
/// the order the MMSys'18 quaternions were composed in (module docs
/// "Composition order"), on the branch with |c| ≤ 90°: the pitch of
/// Unity's `eulerAngles` (the angles the files were made from) lies in
/// [−90°, 90°], its yaw and roll take the full circle (a head looking
/// straight down reaches rolls of 176°: the end of user 4's session; until
/// session 56's review the branch was the one with the smaller of |a| and
/// |c|, which alternated there, and the rebuilt head turned at 11 938°/s).
/// At |c| = 90° (within 10⁻⁹ rad), the branch whose roll is nearer
/// `roll_hint`.
/// Where cos b is 0 (a
/// yaw of exactly ±90°, a gimbal lock of this order) only c ∓ a is
/// determined (R = Rz(±90°)·Ry(c ∓ a)); the roll is then `roll_hint` (the
/// previous sample's), or that plus π where that keeps |c| ≤ 90°.
pub fn mmsys18_euler(q: DQuat, roll_hint: f64) -> (f64, f64, f64) {
    let m = DMat3::from_quat(q);
    let r = |i: usize, j: usize| m.col(j)[i];
    // R = [[cb cc, −sb, cb sc], [ca sb cc + sa sc, ca cb, ca sb sc − sa cc],
    //      [sa sb cc − ca sc, sa cb, sa sb sc + ca cc]].
    let sb = (-r(0, 1)).clamp(-1.0, 1.0);
    let cb = (r(1, 1).hypot(r(2, 1))).min(1.0);
    if cb < 1e-12 {
        // b = ±90°: Rx(a)·Rz(b) = Rz(b)·Ry(∓a), so R = Rz(b)·Ry(φ) with
        // φ = c ∓ a; R's first column rotated back by Rz(−b) is Ry(φ)·x̂ =
        // (cos φ, 0, −sin φ).
        let s = sb.signum();
        let b = s * FRAC_PI_2;
        let v = DQuat::from_rotation_z(-b) * (q * DVec3::X);
        let phi = (-v.z).atan2(v.x);
        // (a + π, c + π) is the same rotation here; the one with |c| ≤ 90°.
        let wrap = |x: f64| (x + PI).rem_euclid(TAU) - PI;
        let (a, c) = (roll_hint, wrap(phi + s * roll_hint));
        return if c.abs() <= FRAC_PI_2 {
            (a, b, c)
        } else {
            (wrap(a + PI), b, wrap(c + PI))
        };
    }
    let branch = |s: f64| {
        let a = (s * r(2, 1)).atan2(s * r(1, 1));
        let c = (s * r(0, 2)).atan2(s * r(0, 0));
        (a, sb.atan2(s * cb), c)
    };
    let (p, n) = (branch(1.0), branch(-1.0));
    let angle_to = |x: f64, y: f64| {
        let d = (x - y).rem_euclid(TAU);
        d.min(TAU - d)
    };
    // The two branches' pitches differ by π: one has |c| ≤ 90°, unless
    // |c| = 90° (r00 = 0 but for rounding: within 10⁻⁹ rad counts), where
    // the roll nearer the hint decides.
    if (p.2.abs() - FRAC_PI_2).abs() < 1e-9 {
        if angle_to(p.0, roll_hint) <= angle_to(n.0, roll_hint) {
            p
        } else {
            n
        }
    } else if p.2.abs() < FRAC_PI_2 {
        p
    } else {
        n
    }
}

/// The head rotation an MMSys'18 quaternion stands for (the data's axes):
/// its roll `a`, yaw `b` and pitch `c` (`mmsys18_euler`) composed yaw
/// outermost, `Rz(b)·Ry(c)·Rx(a)`, as a head pose's Euler angles compose
/// (Unity's own order). Returns it and its roll (the next sample's hint).
pub fn mmsys18_head_rotation(q: DQuat, roll_hint: f64) -> (DQuat, f64) {
    let (a, b, c) = mmsys18_euler(q, roll_hint);
    let r = DQuat::from_rotation_z(b) * DQuat::from_rotation_y(c) * DQuat::from_rotation_x(a);
    (r, a)
}

/// Reads an MMSys'18 `user*_quaternion.txt` file into a stage-space trace.
pub fn read_mmsys18(
    path: impl AsRef<Path>,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    let text = crate::input::read_to_string(path).map_err(|source| TraceError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_mmsys18(path, &text, opts)
}

/// Reads `input` (MMSys'18) and writes it to `output` in the project's CSV
/// format (backs `stereocache trace convert`). Returns the converted trace.
pub fn convert_mmsys18(
    input: impl AsRef<Path>,
    output: impl AsRef<Path>,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let trace = read_mmsys18(input, opts)?;
    trace.write_csv(output)?;
    Ok(trace)
}

/// Parses MMSys'18 text; `path` is used in messages and as the trace source.
pub fn parse_mmsys18(
    path: impl AsRef<Path>,
    text: &str,
    opts: &Mmsys18Options,
) -> Result<PoseTrace, TraceError> {
    let path = path.as_ref();
    // A byte-order mark (editors on Windows write one) is not part of the
    // header's first column name (as in table.rs).
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut b = TraceBuilder::new(path);
    let mut cols: Option<[usize; 6]> = None;
    let mut n_fields = 0;
    // The header's line and whether any sample line followed it.
    let mut header_line = 0;
    let mut any_row = false;
    let mut t_first: Option<f64> = None;
    // The previous sample's (timestamp, line), kept or not.
    let mut prev: Option<(f64, usize)> = None;
    let mut last_viewpoint: Option<i64> = None;
    let mut switches = 0usize;
    let mut fields: Vec<&str> = Vec::with_capacity(6);
    // The previous sample's roll (mmsys18_euler's hint at a gimbal lock).
    let mut roll = 0.0f64;
    // A truncated final line (fewer fields, no newline at the end: a
    // recording cut off mid-write) is dropped with a warning, as the
    // MMSys'17, OpenXR and generic CSV importers do (`table.rs`).
    let ends_with_newline = text.ends_with('\n');
    let last_content = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, _)| i)
        .last();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        fields.clear();
        fields.extend(line.split_whitespace());
        let Some(c) = cols else {
            let mut found = [None; 6];
            for (k, name) in fields.iter().enumerate() {
                let Some(j) = MMSYS18_COLUMNS.iter().position(|c| c == name) else {
                    return Err(b.line_error(
                        line_no,
                        format!(
                            "unknown column `{}` (column {}); an MMSys'18 quaternion file has `timestamp viewpoint w x y z`",
                            excerpt(name),
                            k + 1
                        ),
                    ));
                };
                if found[j].replace(k).is_some() {
                    return Err(b.line_error(line_no, format!("column `{name}` appears twice")));
                }
            }
            let mut c = [0; 6];
            for (j, slot) in c.iter_mut().enumerate() {
                *slot = found[j].ok_or_else(|| {
                    b.line_error(line_no, format!("missing column `{}`", MMSYS18_COLUMNS[j]))
                })?;
            }
            cols = Some(c);
            n_fields = fields.len();
            header_line = line_no;
            continue;
        };
        any_row = true;
        if fields.len() < n_fields && !ends_with_newline && last_content == Some(i) {
            b.warn(
                Some(line_no),
                format!(
                    "truncated final line ({} of {n_fields} fields, no newline at the end of the file): dropped, the recording was cut off mid-write",
                    fields.len()
                ),
            );
            continue;
        }
        if fields.len() != n_fields {
            return Err(b.line_error(
                line_no,
                format!("{} fields, the header has {n_fields}", fields.len()),
            ));
        }
        let mut v = [0.0f64; 6];
        for (j, &col) in c.iter().enumerate() {
            let text = fields[col];
            let x: f64 = text.parse().map_err(|_| {
                b.line_error(
                    line_no,
                    format!(
                        "column `{}`: `{}` is not a number",
                        MMSYS18_COLUMNS[j],
                        excerpt(text)
                    ),
                )
            })?;
            if !x.is_finite() {
                return Err(b.line_error(
                    line_no,
                    format!(
                        "column `{}`: value `{}` is not finite",
                        MMSYS18_COLUMNS[j],
                        excerpt(text)
                    ),
                ));
            }
            v[j] = x;
        }
        let [t, viewpoint, w, x, y, z] = v;
        // Time order is checked on every sample, before the start..end
        // window drops any (module docs: decreasing timestamps are errors;
        // as the generic CSV importer does): an unsorted file is a clock or
        // concatenation bug wherever it falls.
        if let Some((t_prev, line_prev)) = prev {
            if t < t_prev {
                return Err(b.line_error(
                    line_no,
                    format!(
                        "timestamp {t} is earlier than {t_prev} on line {line_prev}; pose traces \
                         must be sorted by time"
                    ),
                ));
            }
        }
        prev = Some((t, line_no));
        // The rebuilt rotation (module docs "Composition order"), computed
        // for every row, kept or not, so the roll hint at a gimbal lock is
        // the previous row's and an excerpt is the same slice of a full
        // import. A row of zero norm is an error below if it is kept.
        let scale = [w, x, y, z].iter().fold(0.0f64, |m, c| m.max(c.abs()));
        let head = (scale > 0.0).then(|| {
            let q = DQuat::from_xyzw(x / scale, y / scale, z / scale, w / scale).normalize();
            let (head, a) = mmsys18_head_rotation(q, roll);
            roll = a;
            head
        });
        if t < opts.start || t > opts.end {
            continue;
        }
        let vp = viewpoint as i64;
        if last_viewpoint.is_some_and(|p| p != vp) {
            switches += 1;
        }
        last_viewpoint = Some(vp);
        // Checked (finite, not of zero norm: then `head` exists), mapped to
        // glTF axes (module docs).
        b.quaternion(line_no, [x, y, z, w])?;
        let Some(head) = head else { continue };
        let g = mmsys18_to_gltf(head);
        let orientation = b.quaternion(line_no, [g.x, g.y, g.z, g.w])?;
        let t0 = *t_first.get_or_insert(t);
        let t_out = if opts.rebase_time { t - t0 } else { t };
        b.push(
            line_no,
            PoseSample {
                t: t_out,
                pose: opts.neck.pose(orientation),
                ipd: None,
            },
        )?;
    }
    if cols.is_none() {
        return Err(b.line_error(
            1,
            "empty file; expected a header `timestamp viewpoint w x y z` and samples",
        ));
    }
    if !any_row {
        return Err(b.line_error(
            header_line + 1,
            "no samples after the header; a trace needs at least one",
        ));
    }
    if b.sample_count() == 0 {
        return Err(TraceError::Trace {
            path: path.to_path_buf(),
            problem: format!("no samples with {} ≤ timestamp ≤ {}", opts.start, opts.end),
        });
    }
    if switches > 0 {
        b.warn(
            None,
            format!("column `viewpoint` ignored: {switches} switch(es) between 360° cameras (content changes, not head motion)"),
        );
    }
    let mut trace = b.finish();
    let flips = trace.make_hemisphere_continuous();
    if flips > 0 {
        let msg = format!(
            "{}: {flips} sample(s) had their quaternion sign flipped for hemisphere continuity",
            path.display()
        );
        trace.warnings.push(msg);
    }
    Ok(trace)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The map is the change of frame x → −Z (forward), y → +X (right),
    /// z → +Y (up): for any rotation, the glTF rotation carries each mapped
    /// axis where the data's rotation carries the axis, mapped.
    #[test]
    fn axes_map_forward_right_up() {
        let map = |v: DVec3| DVec3::new(v.y, v.z, -v.x);
        for (axis, angle) in [
            (DVec3::Z, 0.7),
            (DVec3::Y, -0.4),
            (DVec3::X, 0.3),
            (DVec3::new(0.3, -0.5, 0.8).normalize(), 2.1),
        ] {
            let q = DQuat::from_axis_angle(axis, angle);
            let g = mmsys18_to_gltf(q);
            for v in [DVec3::X, DVec3::Y, DVec3::Z] {
                assert!(
                    (g * map(v)).abs_diff_eq(map(q * v), 1e-12),
                    "{axis} {angle} {v}"
                );
            }
        }
        // A positive yaw (about +z) turns the head right: forward (−Z)
        // towards +X. A positive rotation about +y pitches it down.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = mmsys18_to_gltf(DQuat::from_xyzw(0.0, 0.0, h, h));
        assert!((q * DVec3::NEG_Z).abs_diff_eq(DVec3::X, 1e-12));
        let q = mmsys18_to_gltf(DQuat::from_rotation_y(0.4));
        assert!((q * DVec3::NEG_Z).y < -0.3);
    }

    /// `mmsys18_euler` inverts Rx(a)·Rz(b)·Ry(c) on its branch, yaw over
    /// the full circle; at a yaw of exactly ±90° it keeps the hint's roll
    /// and the composition is still q.
    #[test]
    fn euler_decomposition_inverts_the_data_order() {
        let compose = |a: f64, b: f64, c: f64| {
            DQuat::from_rotation_x(a) * DQuat::from_rotation_z(b) * DQuat::from_rotation_y(c)
        };
        let mut checked = 0;
        for i in 0..24 {
            // Rolls beyond ±90° (a head looking straight down) included.
            for (a, c) in [
                (0.1, -0.3),
                (-1.2, 0.9),
                (0.0, 0.0),
                (1.5, -1.5),
                (2.5, 0.3),
                (-2.8, -1.2),
            ] {
                let b = -3.1 + i as f64 * 0.26;
                let (ga, gb, gc) = mmsys18_euler(compose(a, b, c), 0.0);
                assert!(
                    (ga - a).abs() < 1e-9 && (gb - b).abs() < 1e-9 && (gc - c).abs() < 1e-9,
                    "({a}, {b}, {c}) -> ({ga}, {gb}, {gc})"
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 144);
        for b in [FRAC_PI_2, -FRAC_PI_2] {
            let q = compose(0.2, b, -0.5);
            let (a, gb, c) = mmsys18_euler(q, 0.05);
            assert_eq!(a, 0.05);
            assert!((gb - b).abs() < 1e-12);
            let back = compose(a, gb, c);
            assert!(back.dot(q).abs() > 1.0 - 1e-12, "{b}: {back} vs {q}");
        }
        // At a pitch of ±90° (both branches' |c| = 90° but for rounding)
        // the hint's roll decides, whichever branch rounding favours.
        for (a, c) in [(0.3, FRAC_PI_2), (-2.0, -FRAC_PI_2)] {
            let q = compose(a, 0.7, c);
            for hint in [a, a + PI] {
                let (ga, gb, gc) = mmsys18_euler(q, hint);
                let back = compose(ga, gb, gc);
                assert!(back.dot(q).abs() > 1.0 - 1e-12);
                assert!(
                    ((ga - hint + PI).rem_euclid(TAU) - PI).abs() < 1e-6,
                    "pitch {c}, hint {hint}: roll {ga}"
                );
            }
        }
        // At the gimbal lock a hint that would put |c| beyond 90° gives the
        // equivalent angles (hint + π, c + π).
        let q = compose(0.2, FRAC_PI_2, 0.1);
        let (a, _, c) = mmsys18_euler(q, 2.0);
        assert!(
            c.abs() <= FRAC_PI_2 && ((a - (2.0 - PI)).abs() < 1e-12),
            "({a}, {c})"
        );
        assert!(compose(a, FRAC_PI_2, c).dot(q).abs() > 1.0 - 1e-12);
        // The rebuilt head rotation is the same angles composed yaw first.
        let (r, a) = mmsys18_head_rotation(compose(0.1, 2.0, -0.3), 0.0);
        let want = DQuat::from_rotation_z(2.0)
            * DQuat::from_rotation_y(-0.3)
            * DQuat::from_rotation_x(0.1);
        assert!(r.dot(want).abs() > 1.0 - 1e-12 && (a - 0.1).abs() < 1e-12);
    }

    /// A timestamp earlier than the previous one is an error even where
    /// the start..end window would drop one of the two samples.
    #[test]
    fn decreasing_timestamps_outside_the_window_are_errors() {
        let text = "timestamp viewpoint w x y z\n\
            10 0 1 0 0 0\n\
            5 0 1 0 0 0\n\
            20 0 1 0 0 0\n";
        let opts = Mmsys18Options {
            start: 8.0,
            ..Default::default()
        };
        let e = parse_mmsys18("u.txt", text, &opts).unwrap_err().to_string();
        assert!(
            e.contains("u.txt:3: timestamp 5 is earlier than 10 on line 2"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
    }

    /// A header and nothing else says so (not "no samples with 0 ≤
    /// timestamp ≤ inf", which blamed a time window nobody gave).
    #[test]
    fn a_header_without_samples_is_an_error_naming_the_line_after_it() {
        let e = parse_mmsys18(
            "u.txt",
            "timestamp viewpoint w x y z\n",
            &Default::default(),
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "u.txt:2: no samples after the header; a trace needs at least one"
        );
        // Samples outside the window keep the window's message.
        let opts = Mmsys18Options {
            start: 5.0,
            ..Default::default()
        };
        let text = "timestamp viewpoint w x y z\n1 0 1 0 0 0\n";
        let e = parse_mmsys18("u.txt", text, &opts).unwrap_err().to_string();
        assert!(e.contains("no samples with 5 ≤ timestamp"), "{e}");
    }

    /// A UTF-8 byte-order mark and CRLF line ends read as the plain file.
    #[test]
    fn a_byte_order_mark_and_crlf_are_read() {
        let plain = "timestamp viewpoint w x y z\n0 1 1 0 0 0\n0.1 1 1 0 0 0\n";
        let marked = format!("\u{feff}{}", plain.replace('\n', "\r\n"));
        let opts = Mmsys18Options::default();
        let a = parse_mmsys18("a.txt", plain, &opts).unwrap();
        let b = parse_mmsys18("b.txt", &marked, &opts).unwrap();
        assert_eq!(a.samples.len(), 2);
        assert_eq!(a.samples.len(), b.samples.len());
        for (x, y) in a.samples.iter().zip(&b.samples) {
            assert_eq!((x.t, x.pose.orientation), (y.t, y.pose.orientation));
        }
    }

    #[test]
    fn parses_excerpt_and_repairs() {
        // Yaw 179° then −179° (the rebuilt quaternions' signs part across
        // ±180°), a duplicate time, an identity of norm 2.
        let text = "timestamp viewpoint w x y z\n\
            10.0 0 0.0087265355 0 0 0.9999619231\n\
            10.5 0 0.0087265355 0 0 -0.9999619231\n\
            10.5 1 1 0 0 0\n\
            11.0 1 2 0 0 0\n\
            12.0 1 1 0 0 0\n";
        let opts = Mmsys18Options {
            end: 11.0,
            ..Default::default()
        };
        let tr = parse_mmsys18("u.txt", text, &opts).unwrap();
        let t: Vec<f64> = tr.samples.iter().map(|s| s.t).collect();
        assert_eq!(t, vec![0.0, 0.5, 1.0]);
        for w in tr.samples.windows(2) {
            assert!(w[0].pose.orientation.dot(w[1].pose.orientation) > 0.0);
        }
        assert!(tr.warnings.iter().any(|w| w.contains("u.txt:4: duplicate")));
        assert!(tr
            .warnings
            .iter()
            .any(|w| w.contains("hemisphere continuity")));
        assert!(tr.warnings.iter().any(|w| w.contains("viewpoint")));
        assert!(tr.warnings.iter().any(|w| w.contains("normalized")));
    }
}
