//! Background samples (§3.3: "the environment is evaluated where the stored
//! samples represent the rendered background"): a new-sample ray that misses
//! the scene is stored as its world direction in a first-hit record that
//! keeps Listing 1's no-hit marker (w = `u32::MAX`), with the direction's
//! octahedral coordinates as float bits in x, y and [`BACKGROUND_TAG`] in z.
//! CPU twin of shaders/common/first_hit.glsl (`encode_background`,
//! `background_direction`, `first_hit_is_background`); used by the sample
//! cache, `hybrid` (through it) and `isrt`.

use glam::{Vec2, Vec3};

/// z of a background sample's record ("BGND").
pub const BACKGROUND_TAG: u32 = 0x4247_4E44;

/// The record holds a background sample.
pub fn is_background(fh: [u32; 4]) -> bool {
    fh[3] == u32::MAX && fh[2] == BACKGROUND_TAG
}

fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(
        if v.x >= 0.0 { 1.0 } else { -1.0 },
        if v.y >= 0.0 { 1.0 } else { -1.0 },
    )
}

/// The record of a background sample seen in direction `d` (any length > 0).
pub fn encode_background(d: Vec3) -> [u32; 4] {
    let n = d / (d.x.abs() + d.y.abs() + d.z.abs());
    let p = if n.z >= 0.0 {
        Vec2::new(n.x, n.y)
    } else {
        (Vec2::ONE - Vec2::new(n.y, n.x).abs()) * sign_not_zero(Vec2::new(n.x, n.y))
    };
    [p.x.to_bits(), p.y.to_bits(), BACKGROUND_TAG, u32::MAX]
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
                let fh = encode_background(d);
                assert!(is_background(fh));
                let back = background_direction(fh).unwrap();
                worst = worst.max((back - d).length());
            }
        }
        // A few ulps of the float octahedral coordinates.
        assert!(worst < 1e-6, "worst round-trip error {worst}");
        // An empty record (the buffers' initial fill) and a surface hit are not background.
        assert!(!is_background([u32::MAX; 4]));
        assert!(!is_background([0, 0, 7, 3]));
    }
}
