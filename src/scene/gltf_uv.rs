//! Which uv set, under which `KHR_texture_transform`, a material's textures
//! read (issue 18). Done at import: each primitive's mesh gets up to two uv
//! channels, each a uv set its material's textures name (`texCoord`, or the
//! extension's `texCoord` override) with that slot's offset, rotation and
//! scale applied; the material says which slots read the second channel.
//! Two (set, transform) choices per material get channels: the first bound
//! slot's and the first different one, in [`ORDER`] (base colour, then the
//! normal texture, whose channel the vertex tangents follow, then the
//! rest). A slot naming a further choice of a set that a channel holds
//! reads that channel through a [`UvAffine`], the map from the channel's
//! transform to its own, applied at shading time (`MaterialGpu::uv_affine`);
//! only a further uv set (or a channel whose transform is singular) is left
//! reading the first channel, and the importer warns naming it. A
//! clearcoat normal texture whose uvs are not the vertex tangents' (another
//! channel, or a map) takes its tangent frame from the triangle's gradients
//! of the uvs it reads (scene.glsl `surface_at` coat_tangent).
//!
//! The `gltf` crate is built without its `KHR_texture_transform` feature, so
//! the extension is read here from the raw JSON.
//!
//! **Rotation sign.** The extension's GLSL listing builds its rotation with
//! GLSL's column-major `mat3(cos, sin, 0, -sin, cos, 0, 0, 0, 1)`, i.e.
//! u' = cos·u − sin·v. Its own example ("the lower left quadrant of the
//! source image, rotated": offset (0, 1), rotation π/2, scale ½), its text
//! ("counter-clockwise" in the v-down uv space), the sample model
//! TextureTransformTest and the implementations (Babylon.js, three.js,
//! Blender) all use the transpose, as KhronosGroup/glTF issue #1563 says:
//!
//! ```text
//! u' = sx·cos r·u + sy·sin r·v + ox
//! v' = −sx·sin r·u + sy·cos r·v + oy      (T · R · S, R = [cos sin; −sin cos])
//! ```
//!
//! That is what is implemented here.

use glam::{Mat2, Vec2, Vec3, Vec4};
use serde_json::Value;
use std::path::Path;

/// The extension's name.
pub const TEXTURE_TRANSFORM: &str = "KHR_texture_transform";

/// The texture slots a material binds, in the order that picks the winner
/// when they disagree (base colour first): name for messages, JSON pointer
/// of the textureInfo inside a material.
pub const SLOTS: [(&str, &str); SLOT_COUNT] = [
    (
        "base colour texture",
        "/pbrMetallicRoughness/baseColorTexture",
    ),
    (
        "metallic-roughness texture",
        "/pbrMetallicRoughness/metallicRoughnessTexture",
    ),
    ("normal texture", "/normalTexture"),
    ("emissive texture", "/emissiveTexture"),
    (
        "transmission texture",
        "/extensions/KHR_materials_transmission/transmissionTexture",
    ),
    (
        "specular texture",
        "/extensions/KHR_materials_specular/specularTexture",
    ),
    (
        "specular colour texture",
        "/extensions/KHR_materials_specular/specularColorTexture",
    ),
    (
        "clearcoat texture",
        "/extensions/KHR_materials_clearcoat/clearcoatTexture",
    ),
    (
        "clearcoat roughness texture",
        "/extensions/KHR_materials_clearcoat/clearcoatRoughnessTexture",
    ),
    (
        "clearcoat normal texture",
        "/extensions/KHR_materials_clearcoat/clearcoatNormalTexture",
    ),
];

/// How many texture slots a material has ([`SLOTS`]).
pub const SLOT_COUNT: usize = 10;

/// The order in which slots claim the two uv channels ([`choose`]): base
/// colour first, then the normal texture, then the others in [`SLOTS`]
/// order.
pub const ORDER: [usize; SLOT_COUNT] = [0, 2, 1, 3, 4, 5, 6, 7, 8, 9];

/// The normal texture's slot: the vertex tangents carry its frame.
pub const NORMAL_SLOT: usize = 2;

/// The base colour texture's slot.
pub const BASE_COLOR_SLOT: usize = 0;

/// The emissive texture's slot (KHR_materials_unlit moves the base colour
/// texture there, with the base colour's uv set and transform).
pub const EMISSIVE_SLOT: usize = 3;

/// The clearcoat normal texture's slot: the vertex tangents carry its frame
/// where the material has no normal texture; else its frame is the
/// triangle's, from the uvs it reads (scene.glsl `surface_at`).
pub const CLEARCOAT_NORMAL_SLOT: usize = 9;

/// A tangent (w: handedness) turned to the direction of increasing u' for
/// uvs with ∂(u, v)/∂u' = column 0 of `d_uv` (M⁻¹ for uv' = M · uv; M itself
/// for the way back), ∂P/∂u = T and ∂P/∂v = −w · N × T; w flips when the
/// map `m` mirrors. A singular `m` leaves the tangent as it is.
fn turn_tangent(m: Mat2, d_uv: Mat2, normal: Vec3, tangent: Vec4) -> Vec4 {
    let det = m.determinant();
    if det == 0.0 || !det.is_finite() {
        return tangent;
    }
    let t = tangent.truncate();
    let w = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    let dpdv = -w * normal.cross(t);
    let d = d_uv.x_axis;
    let turned = d.x * t + d.y * dpdv;
    match turned.try_normalize() {
        Some(xyz) => xyz.extend(if det < 0.0 { -w } else { w }),
        None => tangent,
    }
}

/// A `KHR_texture_transform`: uv' = T(offset) · R(rotation) · S(scale) · uv.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub offset: Vec2,
    /// Radians.
    pub rotation: f32,
    pub scale: Vec2,
}

impl Default for UvTransform {
    fn default() -> Self {
        UvTransform::IDENTITY
    }
}

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform {
        offset: Vec2::ZERO,
        rotation: 0.0,
        scale: Vec2::ONE,
    };

    /// The linear part R · S (columns), see the module documentation.
    pub fn linear(&self) -> Mat2 {
        let (s, c) = self.rotation.sin_cos();
        let r = Mat2::from_cols(Vec2::new(c, -s), Vec2::new(s, c));
        r * Mat2::from_diagonal(self.scale)
    }

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.linear() * uv + self.offset
    }

    /// Whether it changes no uv (compared as the matrix it gives, so an
    /// explicit identity equals no extension).
    pub fn is_identity(&self) -> bool {
        self.same_as(&UvTransform::IDENTITY)
    }

    /// Whether both give the same affine map.
    pub fn same_as(&self, other: &UvTransform) -> bool {
        self.linear() == other.linear() && self.offset == other.offset
    }

    /// Re-expresses a supplied tangent (xyz the surface direction of
    /// increasing u, w the handedness: the bitangent w · normal × xyz points
    /// up the image, towards −v, as glTF and `mesh_ops::generate_tangents`
    /// have it) for the transformed uvs: the direction of increasing u' is
    /// ∂P/∂u' = (M⁻¹)₀₀ · ∂P/∂u + (M⁻¹)₁₀ · ∂P/∂v with M = R · S,
    /// ∂P/∂u = T and ∂P/∂v = −w · N × T: a turn of the tangent within the
    /// tangent plane; w flips when M mirrors (det M < 0). A singular M (a
    /// zero scale) leaves the tangent as it is.
    pub fn tangent(&self, normal: Vec3, tangent: Vec4) -> Vec4 {
        let m = self.linear();
        turn_tangent(m, m.inverse(), normal, tangent)
    }

    /// The inverse of [`UvTransform::tangent`]: the tangent of the
    /// untransformed uvs that this transform turns into `tangent` (what the
    /// glTF writer stores for a normal texture it writes under this
    /// transform). Exact for maps without shear (a rotation and a uniform
    /// scale turn the tangent plane rigidly).
    pub fn tangent_back(&self, normal: Vec3, tangent: Vec4) -> Vec4 {
        let m = self.linear();
        turn_tangent(m, m, normal, tangent)
    }

    /// "offset (0.5, 0), rotation 1.5708, scale (2, 2)", the non-default parts.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if self.offset != Vec2::ZERO {
            parts.push(format!("offset ({}, {})", self.offset.x, self.offset.y));
        }
        if self.rotation != 0.0 {
            parts.push(format!("rotation {}", self.rotation));
        }
        if self.scale != Vec2::ONE {
            parts.push(format!("scale ({}, {})", self.scale.x, self.scale.y));
        }
        if parts.is_empty() {
            "no transform".into()
        } else {
            parts.join(", ")
        }
    }
}

/// uv' = linear · uv + offset: how a slot whose (set, transform) has no
/// channel of its own reads a channel of the same set. With the channel's
/// transform (L_c, o_c) and the slot's (L_s, o_s), uv = L_c·raw + o_c gives
/// uv' = L_s·raw + o_s = (L_s L_c⁻¹)·uv + (o_s − L_s L_c⁻¹ o_c).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvAffine {
    pub linear: Mat2,
    pub offset: Vec2,
}

impl UvAffine {
    /// The map from the channel's uvs under `channel` to those under
    /// `slot`; `None` where `channel` is singular (a zero scale).
    pub fn between(channel: &UvTransform, slot: &UvTransform) -> Option<UvAffine> {
        let lc = channel.linear();
        let det = lc.determinant();
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let linear = slot.linear() * lc.inverse();
        let offset = slot.offset - linear * channel.offset;
        (linear.is_finite() && offset.is_finite()).then_some(UvAffine { linear, offset })
    }

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.linear * uv + self.offset
    }

    /// As a `KHR_texture_transform` (offset, rotation, scale), where its
    /// linear part is a rotation times a scale (columns orthogonal, within
    /// float precision); `None` where it shears.
    pub fn as_transform(&self) -> Option<UvTransform> {
        // linear() = R · S: column 0 = sx (cos r, −sin r), column 1 = sy (sin r, cos r).
        let (c0, c1) = (self.linear.x_axis, self.linear.y_axis);
        let sx = c0.length();
        if sx == 0.0 || !sx.is_finite() {
            return None;
        }
        let (cos, sin) = (c0.x / sx, -c0.y / sx);
        let sy = c1.dot(Vec2::new(sin, cos));
        let t = UvTransform {
            offset: self.offset,
            rotation: sin.atan2(cos),
            scale: Vec2::new(sx, sy),
        };
        let err = (t.linear() - self.linear).abs();
        let tol = 1e-5
            * self
                .linear
                .abs()
                .to_cols_array()
                .iter()
                .fold(0.0f32, |a, &b| a.max(b));
        (err.x_axis.max_element().max(err.y_axis.max_element()) <= tol).then_some(t)
    }
}

/// What one textureInfo asks for beyond the core `texCoord`: the
/// extension's transform and its `texCoord` override.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SlotUv {
    pub transform: UvTransform,
    pub tex_coord: Option<u32>,
}

/// A uv set and the transform applied to it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvChoice {
    pub set: u32,
    pub transform: UvTransform,
}

impl UvChoice {
    pub fn same_as(&self, other: &UvChoice) -> bool {
        self.set == other.set && self.transform.same_as(&other.transform)
    }

    /// "TEXCOORD_1, offset (0.5, 0)".
    pub fn describe(&self) -> String {
        format!("TEXCOORD_{}, {}", self.set, self.transform.describe())
    }
}

/// Per material (by index), per slot of [`SLOTS`]: its `KHR_texture_transform`
/// as read from the raw JSON (`None` where the slot has no extension). A
/// field of the wrong type or a non-finite value is one warning naming the
/// material and slot, and that field takes its default.
pub fn texture_transforms_json(
    path: &Path,
    root: &serde_json::Map<String, Value>,
    warnings: &mut Vec<String>,
) -> Vec<[Option<SlotUv>; SLOT_COUNT]> {
    let Some(materials) = root.get("materials").and_then(Value::as_array) else {
        return Vec::new();
    };
    materials
        .iter()
        .enumerate()
        .map(|(mi, m)| {
            let mut out = [None; SLOT_COUNT];
            for (k, (slot, pointer)) in SLOTS.iter().enumerate() {
                let Some(ext) = m
                    .pointer(pointer)
                    .and_then(|info| info.pointer(&format!("/extensions/{TEXTURE_TRANSFORM}")))
                else {
                    continue;
                };
                let label = match m.get("name").and_then(Value::as_str) {
                    Some(n) if !n.is_empty() => format!("material {mi} '{n}'"),
                    _ => format!("material {mi}"),
                };
                let mut bad = Vec::new();
                out[k] = Some(parse_slot(ext, &mut bad));
                if !bad.is_empty() {
                    warnings.push(format!(
                        "{}: {label}: {slot}: {TEXTURE_TRANSFORM} has {}; the default is used \
                         for {}",
                        path.display(),
                        bad.join(", "),
                        if bad.len() == 1 { "it" } else { "them" }
                    ));
                }
            }
            out
        })
        .collect()
}

fn parse_slot(ext: &Value, bad: &mut Vec<String>) -> SlotUv {
    let mut uv = SlotUv::default();
    let vec2 = |key: &str, default: Vec2, bad: &mut Vec<String>| -> Vec2 {
        let Some(v) = ext.get(key) else {
            return default;
        };
        let parsed = v.as_array().filter(|a| a.len() == 2).and_then(|a| {
            let x = a[0].as_f64()? as f32;
            let y = a[1].as_f64()? as f32;
            (x.is_finite() && y.is_finite()).then_some(Vec2::new(x, y))
        });
        parsed.unwrap_or_else(|| {
            bad.push(format!("{key} {v} (not two finite numbers)"));
            default
        })
    };
    uv.transform.offset = vec2("offset", Vec2::ZERO, bad);
    uv.transform.scale = vec2("scale", Vec2::ONE, bad);
    if let Some(v) = ext.get("rotation") {
        match v.as_f64().map(|r| r as f32).filter(|r| r.is_finite()) {
            Some(r) => uv.transform.rotation = r,
            None => bad.push(format!("rotation {v} (not a finite number)")),
        }
    }
    if let Some(v) = ext.get("texCoord") {
        match v.as_u64().filter(|&n| n <= u32::MAX as u64) {
            Some(n) => uv.tex_coord = Some(n as u32),
            None => bad.push(format!("texCoord {v} (not a non-negative integer)")),
        }
    }
    uv
}

/// The uv channels of one material: the first bound slot's (set,
/// transform) choice in [`ORDER`] is channel 1 (`Mesh::uvs`); channel 2
/// (`Mesh::uvs2`) is the first choice of another uv set if there is one (so
/// that two uv sets always fit), else the first other transform of channel
/// 1's set. `second_slots` has bit k set where slot k of [`SLOTS`] reads
/// channel 2; `relative` lists the slots whose choice is neither but whose
/// set a channel holds: they read that channel through the [`UvAffine`];
/// `wrong` lists the rest (they read channel 1, and the importer warns).
/// `tangent` is the choice of the slot whose tangent frame the vertex
/// tangents carry (the normal texture's, else the clearcoat normal
/// texture's): the importer generates or turns them for those uvs, read
/// through a map or not.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UvChannels {
    pub first: UvChoice,
    pub second: Option<UvChoice>,
    pub second_slots: u32,
    pub relative: Vec<(usize, UvAffine)>,
    pub wrong: Vec<(usize, UvChoice)>,
    pub tangent: Option<UvChoice>,
}

/// The channels of one material from its bound slots (`Some((core texCoord,
/// extension))` per slot of [`SLOTS`], `None` where the slot binds no
/// texture). No bound slot: TEXCOORD_0 untransformed, one channel.
///
/// Any slot may read through a map. The vertex tangents follow the normal
/// texture's own uvs (channel or map); a clearcoat normal texture reading
/// other uvs than those gets the triangle's frame of its own (scene.glsl
/// `surface_at`), so it constrains no choice here.
pub fn choose(slots: &[Option<(u32, Option<SlotUv>)>; SLOT_COUNT]) -> UvChannels {
    let choices: Vec<(usize, UvChoice)> = ORDER
        .iter()
        .filter_map(|&k| {
            slots[k].map(|(core, ext)| {
                let ext = ext.unwrap_or_default();
                (
                    k,
                    UvChoice {
                        set: ext.tex_coord.unwrap_or(core),
                        transform: ext.transform,
                    },
                )
            })
        })
        .collect();
    let Some(&(_, first)) = choices.first() else {
        return UvChannels::default();
    };
    let other_transform = choices.iter().map(|&(_, c)| c).find(|c| !c.same_as(&first));
    let other_set = choices.iter().map(|&(_, c)| c).find(|c| c.set != first.set);
    let mut out = assign(&choices, first, other_set.or(other_transform));
    let tangent_slot = if slots[NORMAL_SLOT].is_some() {
        NORMAL_SLOT
    } else {
        CLEARCOAT_NORMAL_SLOT
    };
    out.tangent = choices
        .iter()
        .find(|&&(k, _)| k == tangent_slot)
        .map(|&(_, c)| c);
    out
}

/// [`choose`] with channel 2 given: each choice reads the channel it equals,
/// else a channel of its set through a map, else is wrong.
fn assign(choices: &[(usize, UvChoice)], first: UvChoice, second: Option<UvChoice>) -> UvChannels {
    let mut out = UvChannels {
        first,
        second,
        ..Default::default()
    };
    for &(k, c) in choices {
        if c.same_as(&first) {
            continue;
        }
        if second.is_some_and(|s| c.same_as(&s)) {
            out.second_slots |= 1 << k;
            continue;
        }
        let through = |channel: &UvChoice| {
            (channel.set == c.set)
                .then(|| UvAffine::between(&channel.transform, &c.transform))
                .flatten()
        };
        if let Some(a) = through(&first) {
            out.relative.push((k, a));
        } else if let Some(a) = second.as_ref().and_then(through) {
            out.relative.push((k, a));
            out.second_slots |= 1 << k;
        } else {
            out.wrong.push((k, c));
        }
    }
    out.relative.sort_by_key(|&(k, _)| k);
    out.wrong.sort_by_key(|&(k, _)| k);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    fn close(a: Vec2, b: Vec2) -> bool {
        // sin/cos of π/2 in f32: cos is −4.4·10⁻⁸, times |uv| ≤ 4.
        (a - b).abs().max_element() < 1e-6
    }

    #[test]
    fn the_spec_example_maps_the_unit_square_to_the_lower_left_quadrant() {
        // KHR_texture_transform README, "Example JSON": offset (0, 1),
        // rotation π/2, scale ½ "utilizes only the lower left quadrant"
        // (v points down: the lower half is v in [0.5, 1]).
        let t = UvTransform {
            offset: Vec2::new(0.0, 1.0),
            rotation: FRAC_PI_2,
            scale: Vec2::splat(0.5),
        };
        // u' = ½v, v' = 1 − ½u.
        for (uv, want) in [
            (Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0)),
            (Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.5)),
            (Vec2::new(0.0, 1.0), Vec2::new(0.5, 1.0)),
            (Vec2::new(1.0, 1.0), Vec2::new(0.5, 0.5)),
        ] {
            assert!(
                close(t.apply(uv), want),
                "{uv} → {} not {want}",
                t.apply(uv)
            );
        }
    }

    /// A slot with a third (set, transform) choice reads a channel of its
    /// set through the affine map between the two transforms: applied to
    /// the channel's uvs it gives the slot's own transform of the raw uvs.
    #[test]
    fn a_third_choice_of_a_channels_set_reads_it_through_the_affine_map() {
        let t = |o: [f32; 2], r: f32, s: [f32; 2]| UvTransform {
            offset: Vec2::from(o),
            rotation: r,
            scale: Vec2::from(s),
        };
        let ext = |tr: UvTransform, set: Option<u32>| {
            Some(SlotUv {
                transform: tr,
                tex_coord: set,
            })
        };
        let base = t([0.5, 0.0], FRAC_PI_2, [2.0, 2.0]);
        let normal = t([0.0, 0.0], 0.3, [1.0, 3.0]);
        let emissive = t([0.0, 1.0], FRAC_PI_2, [0.5, 0.5]);
        let mut slots = [None; SLOT_COUNT];
        slots[0] = Some((0, ext(base, None)));
        slots[1] = Some((0, ext(base, None)));
        slots[2] = Some((0, ext(normal, None)));
        slots[3] = Some((0, ext(emissive, None)));
        // A second uv set takes channel 2; a third one (TEXCOORD_2) has
        // no channel.
        slots[4] = Some((1, None));
        slots[5] = Some((2, None));
        // The clearcoat normal texture reads through a map too (its frame
        // is the triangle's of the mapped uvs, scene.glsl).
        slots[9] = Some((0, ext(emissive, None)));
        let ch = choose(&slots);
        assert!(ch.first.transform.same_as(&base));
        assert_eq!(ch.second.map(|c| c.set), Some(1), "{ch:?}");
        assert_eq!(ch.second_slots, 1 << 4);
        let relative: Vec<usize> = ch.relative.iter().map(|r| r.0).collect();
        assert_eq!(relative, [2, 3, 9], "{ch:?}");
        assert_eq!(ch.relative[1].1, ch.relative[2].1, "one choice, one map");
        let wrong: Vec<usize> = ch.wrong.iter().map(|w| w.0).collect();
        assert_eq!(wrong, [5]);
        let a = ch.relative[1].1;
        for raw in [
            Vec2::ZERO,
            Vec2::new(1.0, 0.0),
            Vec2::new(0.3, 0.8),
            Vec2::new(-2.0, 5.0),
        ] {
            let got = a.apply(base.apply(raw));
            let want = emissive.apply(raw);
            assert!(close(got, want), "{raw}: {got} not {want}");
        }
        // Rotation and uniform scale relative to a rotated, uniformly
        // scaled channel: a rotation and a scale again.
        let back = a.as_transform().expect("no shear");
        assert!(
            (back.rotation - 0.0).abs() < 1e-6 && close(back.scale, Vec2::splat(0.25)),
            "{back:?}"
        );
        // Non-uniform scale under a channel turned by other than a quarter
        // turn shears (a quarter turn only swaps the scale's axes).
        let turned = t([0.0, 0.0], 0.7, [1.0, 1.0]);
        assert!(UvAffine::between(&turned, &normal)
            .unwrap()
            .as_transform()
            .is_none());
        assert!(UvAffine::between(&base, &normal)
            .unwrap()
            .as_transform()
            .is_some());
        // A singular channel relates to nothing.
        assert!(UvAffine::between(&t([0.0, 0.0], 0.0, [0.0, 1.0]), &emissive).is_none());
    }

    /// Up to two choices, the channels are as before the maps existed: the
    /// normal texture's claim comes before the metallic-roughness one's only
    /// when there would be a third.
    #[test]
    fn two_choices_need_no_map() {
        let tr = UvTransform {
            offset: Vec2::new(0.5, 0.0),
            ..UvTransform::IDENTITY
        };
        let mut slots = [None; SLOT_COUNT];
        slots[0] = Some((0, None));
        slots[1] = Some((
            0,
            Some(SlotUv {
                transform: tr,
                tex_coord: None,
            }),
        ));
        slots[2] = Some((0, None));
        let ch = choose(&slots);
        assert_eq!(ch.second_slots, 1 << 1);
        assert!(ch.relative.is_empty() && ch.wrong.is_empty());
    }

    /// Two transforms of TEXCOORD_0 (base colour, normal texture) and an
    /// occlusion-style texture on TEXCOORD_1: channel 2 goes to the second
    /// uv set, and the normal texture reads channel 1 through a map (its
    /// tangents follow its own uvs: `tangent`). A clearcoat normal texture
    /// on the normal texture's uvs changes nothing: it reads channel 1
    /// through the same map (until session 38 the normal texture then took
    /// channel 2 from the second uv set, which was warned).
    #[test]
    fn a_second_uv_set_gets_channel_two_and_the_normal_texture_a_map() {
        let t = |o: f32, set: Option<u32>| {
            Some(SlotUv {
                transform: UvTransform {
                    offset: Vec2::new(o, 0.0),
                    ..UvTransform::IDENTITY
                },
                tex_coord: set,
            })
        };
        let mut slots = [None; SLOT_COUNT];
        slots[0] = Some((0, t(0.5, None)));
        slots[2] = Some((0, t(0.25, None)));
        slots[3] = Some((1, None));
        let ch = choose(&slots);
        assert_eq!(ch.second.map(|c| c.set), Some(1), "{ch:?}");
        assert_eq!(ch.second_slots, 1 << 3);
        assert_eq!(ch.relative.len(), 1, "{ch:?}");
        assert_eq!(ch.relative[0].0, 2);
        assert!(ch.wrong.is_empty());
        let tangent = ch.tangent.expect("the normal texture's choice");
        assert_eq!(tangent.set, 0);
        assert_eq!(tangent.transform.offset, Vec2::new(0.25, 0.0));
        // The map takes channel 1's uvs (offset 0.5) to the normal's (0.25).
        let uv = Vec2::new(0.3, 0.7);
        let got = ch.relative[0].1.apply(uv + Vec2::new(0.5, 0.0));
        assert!((got - (uv + Vec2::new(0.25, 0.0))).length() < 1e-6, "{got}");

        slots[9] = Some((0, t(0.25, None)));
        let with_coat = choose(&slots);
        assert_eq!(with_coat.second, ch.second, "{with_coat:?}");
        assert_eq!(with_coat.second_slots, 1 << 3);
        let relative: Vec<(usize, UvAffine)> = vec![ch.relative[0], (9, ch.relative[0].1)];
        assert_eq!(with_coat.relative, relative);
        assert!(with_coat.wrong.is_empty(), "{with_coat:?}");
        assert_eq!(with_coat.tangent, ch.tangent);
    }

    /// The writer stores a mapped normal texture's tangents turned back:
    /// turning them again under the same transform gives them exactly back
    /// (rotation and uniform scale, as the writer allows, and a mirror).
    #[test]
    fn tangent_back_undoes_tangent() {
        let n = Vec3::Z;
        for tr in [
            UvTransform {
                offset: Vec2::new(0.3, 0.1),
                rotation: 0.7,
                scale: Vec2::splat(2.5),
            },
            UvTransform {
                rotation: -1.2,
                scale: Vec2::new(-0.5, 0.5),
                ..UvTransform::IDENTITY
            },
        ] {
            for t in [
                Vec4::new(1.0, 0.0, 0.0, 1.0),
                Vec4::new(0.6, 0.8, 0.0, -1.0),
            ] {
                let back = tr.tangent(n, tr.tangent_back(n, t));
                assert!((back - t).abs().max_element() < 1e-6, "{tr:?} {t}: {back}");
            }
        }
    }

    #[test]
    fn tangents_turn_with_the_uvs_and_flip_under_a_mirror() {
        let n = Vec3::Z;
        // ∂P/∂u = +x; w = +1: the bitangent +z × +x = +y points up the
        // image (−v), so ∂P/∂v = −y.
        let t = Vec4::new(1.0, 0.0, 0.0, 1.0);
        // A quarter turn, u' = v: u' grows along −y.
        let q = UvTransform {
            rotation: FRAC_PI_2,
            ..UvTransform::IDENTITY
        };
        let got = q.tangent(n, t);
        assert!(
            (got - Vec4::new(0.0, -1.0, 0.0, 1.0)).abs().max_element() < 1e-6,
            "{got}"
        );
        // u' = −u (scale (−1, 1)): u' grows along −x, and the frame mirrors.
        let m = UvTransform {
            scale: Vec2::new(-1.0, 1.0),
            ..UvTransform::IDENTITY
        };
        assert_eq!(m.tangent(n, t), Vec4::new(-1.0, 0.0, 0.0, -1.0));
        // Offsets and uniform scales change no direction.
        let o = UvTransform {
            offset: Vec2::new(0.3, 0.7),
            scale: Vec2::splat(3.0),
            ..UvTransform::IDENTITY
        };
        assert!((o.tangent(n, t) - t).abs().max_element() < 1e-6);
    }
}
