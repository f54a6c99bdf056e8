//! Background samples (§3.3: "the environment is evaluated where the stored
//! samples represent the rendered background"): a new-sample ray that misses
//! the scene is stored as its world direction in a first-hit record that
//! keeps Listing 1's no-hit marker (w = `u32::MAX`), with the direction's
//! octahedral coordinates as float bits in x, y, and in z the tag
//! [`BACKGROUND_TAG`] (high 16 bits) with the ray's position in its pixel
//! (low 16 bits, 8 bits per axis): an orthographic eye's background rays all
//! share one direction, and its retrace and reprojection need their origin.
//! CPU twin of shaders/common/first_hit.glsl (`encode_background`,
//! `background_direction`, `first_hit_is_background`); used by the sample
//! cache, `hybrid` (through it) and `isrt`.

use glam::{Vec2, Vec3};

/// High 16 bits of z of a background sample's record ("BG").
pub const BACKGROUND_TAG: u32 = 0x4247_0000;

/// The record holds a background sample.
pub fn is_background(fh: [u32; 4]) -> bool {
    fh[3] == u32::MAX && fh[2] & 0xFFFF_0000 == BACKGROUND_TAG
}

fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// The record of a background sample seen in direction `d` (any length > 0)
/// through the point `sub` ∈ [0, 1)² of its pixel.
pub fn encode_background(d: Vec3, sub: Vec2) -> [u32; 4] {
    let n = d / (d.x.abs() + d.y.abs() + d.z.abs());
    let p = if n.z >= 0.0 {
        Vec2::new(n.x, n.y)
    } else {
        (Vec2::ONE - Vec2::new(n.y, n.x).abs()) * sign_not_zero(Vec2::new(n.x, n.y))
    };
    let q = (sub * 256.0)
        .clamp(Vec2::ZERO, Vec2::splat(255.0))
        .as_uvec2();
    [
        p.x.to_bits(),
        p.y.to_bits(),
        BACKGROUND_TAG | q.x << 8 | q.y,
        u32::MAX,
    ]
}

/// Where in its pixel a background sample's ray went: the centre of its
/// 1/256-pixel cell, `None` for any other record.
pub fn background_subpixel(fh: [u32; 4]) -> Option<Vec2> {
    is_background(fh).then(|| {
        Vec2::new(
            ((fh[2] >> 8) & 255) as f32 + 0.5,
            (fh[2] & 255) as f32 + 0.5,
        ) / 256.0
    })
}

/// Unit world direction of a background sample, `None` for any other record.
pub fn background_direction(fh: [u32; 4]) -> Option<Vec3> {
    if !is_background(fh) {
        return None;
    }
    let p = Vec2::new(f32::from_bits(fh[0]), f32::from_bits(fh[1]));
    let mut n = Vec3::new(p.x, p.y, 1.0 - p.x.abs() - p.y.abs());
    if n.z < 0.0 {
        let xy = (Vec2::ONE - Vec2::new(n.y, n.x).abs()) * sign_not_zero(Vec2::new(n.x, n.y));
        n.x = xy.x;
        n.y = xy.y;
    }
    Some(n.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_round_trip_to_float_precision() {
        let mut worst = 0.0f32;
        for i in 0..2000 {
            // Fibonacci sphere plus the axes (octant borders).
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            for d in [
                Vec3::new(r * phi.cos(), r * phi.sin(), z),
                Vec3::X,
                -Vec3::Y,
                -Vec3::Z,
            ] {
                let sub = Vec2::new((i % 37) as f32 / 37.0, (i % 11) as f32 / 11.0);
                let fh = encode_background(d, sub);
                assert!(is_background(fh));
                let back = background_direction(fh).unwrap();
                worst = worst.max((back - d).length());
                let s = background_subpixel(fh).unwrap();
                assert!(
                    (s - sub).abs().max_element() <= 0.5 / 256.0 + 1e-7,
                    "{sub} -> {s}"
                );
            }
        }
        // A few ulps of the float octahedral coordinates.
        assert!(worst < 1e-6, "worst round-trip error {worst}");
        // An empty record (the buffers' initial fill) and a surface hit are not background.
        assert!(!is_background([u32::MAX; 4]));
        assert!(!is_background([0, 0, 7, 3]));
        assert!(!is_background([0, 0, 0, u32::MAX]));
        let corner = encode_background(Vec3::Z, Vec2::splat(0.999_999));
        assert_eq!(
            background_subpixel(corner),
            Some(Vec2::splat(255.5 / 256.0))
        );
    }
}
