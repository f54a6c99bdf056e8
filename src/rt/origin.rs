//! The render origin: the point every GPU-side position is relative to.
//!
//! f32 positions lose precision with their magnitude (spacing 2⁻²³·|x|: 6 cm
//! at 1e6 m). A scene placed far from its file's origin would otherwise be
//! flattened, traced, reprojected and hashed with that error. The renderer
//! therefore subtracts a per-scene origin, in f64 on the CPU, from instance
//! transforms, light positions and eye positions before they become f32 GPU
//! data; GPU magnitudes are then the scene's extent, not its distance from
//! the glTF origin (docs/ROBUSTNESS.md).
//!
//! The origin is the centre of the scene's bounds snapped to a grid of
//! `ORIGIN_GRID` metres, so a scene near the file's origin keeps origin 0
//! and its GPU data bit-identical to world space, while a scene 1e6 m away
//! is rebased to within `ORIGIN_GRID / 2` of its centre.

use crate::scene::Scene;
use glam::{DMat4, DVec3, Mat4, Vec3};

/// Grid of the origin, in metres (a power of two: snapping is exact).
pub const ORIGIN_GRID: f64 = 64.0;

/// The render origin of a scene: its bounds' centre snapped to `ORIGIN_GRID`.
pub fn render_origin(scene: &Scene) -> DVec3 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for inst in &scene.instances {
        let m = inst.transform.as_dmat4();
        for p in &scene.meshes[inst.mesh as usize].positions {
            let w = m.transform_point3(p.as_dvec3());
            if w.is_finite() {
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    if lo.x > hi.x {
        return DVec3::ZERO;
    }
    ((lo + hi) * 0.5 / ORIGIN_GRID).round() * ORIGIN_GRID
}

/// `transform` followed by a translation by −origin, composed in f64.
pub fn relative_transform(transform: Mat4, origin: DVec3) -> Mat4 {
    if origin == DVec3::ZERO {
        return transform;
    }
    (DMat4::from_translation(-origin) * transform.as_dmat4()).as_mat4()
}

/// A world point relative to the origin, subtracted in f64.
pub fn relative_point(p: Vec3, origin: DVec3) -> Vec3 {
    (p.as_dvec3() - origin).as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_origin_scenes_keep_origin_zero() {
        let s = crate::scene::generate::generate("cornell").unwrap();
        assert_eq!(render_origin(&s), DVec3::ZERO);
        let m = Mat4::from_translation(Vec3::new(0.25, 1.0, -3.0));
        assert_eq!(relative_transform(m, DVec3::ZERO), m);
    }

    #[test]
    fn far_scenes_are_rebased_near_their_centre() {
        let mut s = crate::scene::generate::generate("cornell").unwrap();
        let offset = Vec3::new(1e6, 1e6, -1e6);
        for i in &mut s.instances {
            i.transform = Mat4::from_translation(offset) * i.transform;
        }
        let o = render_origin(&s);
        assert!((o - offset.as_dvec3()).abs().max_element() <= ORIGIN_GRID / 2.0 + 2.0);
        // The relative transform of a translation by `offset` is exact: both
        // operands are f32 values and their f64 difference is representable.
        let r = relative_transform(Mat4::from_translation(offset), o);
        assert_eq!(r.w_axis.truncate().as_dvec3(), offset.as_dvec3() - o);
        // A point 0.3 m from a 1e6 m offset keeps sub-millimetre precision
        // relative to the origin (f32 spacing at |x| ≤ 64 is ≤ 3.9e-6).
        let p = offset + Vec3::new(0.3, 0.0, 0.0);
        let d = relative_point(p, o).as_dvec3() - (p.as_dvec3() - o);
        assert!(d.abs().max_element() <= 3.9e-6);
    }
}
