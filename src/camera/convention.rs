//! Coordinate conventions of recorded poses and their conversion to glTF axes.
//!
//! A recording states its poses in some coordinate convention: which way is
//! up, which way the head (camera) looks, and whether the axes are right- or
//! left-handed. The project uses glTF's (DESIGN.md): right-handed, **+Y up**,
//! the head looks down its **−Z**, +X to the wearer's right. OpenXR's
//! reference and view spaces use the same axes.
//!
//! [`AxisConvention`] describes a source convention by its handedness, its
//! up axis and its forward (viewing) axis; the third axis follows from them:
//! right = forward × up in a right-handed frame, up × forward in a
//! left-handed one (computed on coordinates). The same convention is assumed
//! for the world (stage) frame and for the head's own frame, as in Unity,
//! OpenXR and the Corbillon et al. datasets.
//!
//! # Conversion
//!
//! `M` is the signed permutation with `M·right = +X`, `M·up = +Y`,
//! `M·forward = −Z`. Positions map as `p' = M·p`. A head orientation `R`
//! (head → world, both in source axes) maps as `R' = M·R·Mᵀ`: convert a glTF
//! head vector to source axes, rotate, convert back. `R'` is a proper
//! rotation even when `M` is a reflection (det −1, a left-handed source),
//! because `M` appears twice. For the quaternion `q = (w, v)`:
//!
//! - det M = +1: `q' = (w, M·v)`;
//! - det M = −1: `M = −M₊` with `M₊ = −M` proper, and `M·R·Mᵀ = M₊·R·M₊ᵀ`,
//!   so `q' = (w, −M·v)`.
//!
//! Examples (checked in `tests/camera_traces.rs`):
//! - Unity / HoloLens (left-handed, +y up, +z forward): `M = diag(1, 1, −1)`,
//!   `p' = (x, y, −z)`, `q' = (−qx, −qy, qz, qw)`. A Unity camera with the
//!   identity rotation looks along Unity +Z; converted, it looks along glTF
//!   −Z, the image of Unity +Z, and a walk along Unity +Z stays a walk
//!   forward. A Unity yaw about +Y (clockwise seen from above: a right turn,
//!   +Z → +X) becomes a glTF yaw about +Y with the opposite sign — a right
//!   turn again.
//! - Corbillon et al. (left-handed: +z up, +x forward, +y right):
//!   `q' = (−y, −z, x, w)`, the MMSys'18 importer's mapping.

use std::fmt;
use std::str::FromStr;

/// Whether a coordinate frame is right- or left-handed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Handedness {
    /// Right-handed (glTF, OpenXR, OpenGL, ROS).
    Right,
    /// Left-handed (Unity, HoloLens Unity apps, Direct3D, Unreal, Corbillon et al.).
    Left,
}

impl fmt::Display for Handedness {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Handedness::Right => "right-handed",
            Handedness::Left => "left-handed",
        })
    }
}

/// A coordinate axis with a sign: `+x`, `-z`, ...
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SignedAxis {
    /// 0 = x, 1 = y, 2 = z.
    axis: u8,
    negative: bool,
}

impl SignedAxis {
    /// +x.
    pub const PX: Self = Self::new(0, false);
    /// −x.
    pub const NX: Self = Self::new(0, true);
    /// +y.
    pub const PY: Self = Self::new(1, false);
    /// −y.
    pub const NY: Self = Self::new(1, true);
    /// +z.
    pub const PZ: Self = Self::new(2, false);
    /// −z.
    pub const NZ: Self = Self::new(2, true);

    const fn new(axis: u8, negative: bool) -> Self {
        Self { axis, negative }
    }

    /// The axis index, 0 = x, 1 = y, 2 = z.
    pub fn index(self) -> usize {
        self.axis as usize
    }

    /// The unit vector.
    pub fn vector(self) -> [f64; 3] {
        let mut v = [0.0; 3];
        v[self.index()] = if self.negative { -1.0 } else { 1.0 };
        v
    }

    fn from_vector(v: [f64; 3]) -> Self {
        let i = (0..3).find(|&i| v[i] != 0.0).unwrap_or(0);
        Self::new(i as u8, v[i] < 0.0)
    }
}

impl fmt::Display for SignedAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sign = if self.negative { '-' } else { '+' };
        write!(f, "{sign}{}", ['x', 'y', 'z'][self.index()])
    }
}

/// An axis that is not one of x, y, z with an optional sign.
#[derive(Debug, thiserror::Error)]
#[error("unknown axis `{0}`; expected x, y or z with an optional sign: +x, -x, y, -y, z, -z")]
pub struct UnknownAxis(pub String);

impl FromStr for SignedAxis {
    type Err = UnknownAxis;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        let (negative, name) = match t.strip_prefix('-') {
            Some(rest) => (true, rest),
            None => (false, t.strip_prefix('+').unwrap_or(&t)),
        };
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return Err(UnknownAxis(s.to_string())),
        };
        Ok(Self::new(axis, negative))
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A source coordinate convention: handedness, up axis, forward axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AxisConvention {
    /// Handedness of the axes.
    pub handedness: Handedness,
    /// The world's up direction (and the head's up).
    pub up: SignedAxis,
    /// The direction a head (camera) with the identity orientation looks.
    pub forward: SignedAxis,
}

impl fmt::Display for AxisConvention {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}, {} up, {} forward",
            self.handedness, self.up, self.forward
        )
    }
}

impl AxisConvention {
    /// glTF (and OpenXR): right-handed, +y up, −z forward. No conversion.
    pub const GLTF: Self = Self {
        handedness: Handedness::Right,
        up: SignedAxis::PY,
        forward: SignedAxis::NZ,
    };
    /// Unity (HoloLens Unity apps, the Fraunhofer HHI pred6dof traces):
    /// left-handed, +y up, +z forward.
    pub const UNITY: Self = Self {
        handedness: Handedness::Left,
        up: SignedAxis::PY,
        forward: SignedAxis::PZ,
    };
    /// Corbillon et al.'s 360° video datasets (MMSys'17, MMSys'18):
    /// +z up, +x forward (the centre of the authors' viewport tool's
    /// equirectangular frame), +y right —
    /// left-handed, the frame of the authors' viewport tool
    /// (360Transformations) and of their 2017 recorder (`super::mmsys17`
    /// module docs, "Axes"). Until session 56 right-handed (+y left), which
    /// mirrored every turn.
    pub const CORBILLON: Self = Self {
        handedness: Handedness::Left,
        up: SignedAxis::PZ,
        forward: SignedAxis::PX,
    };

    /// A convention; `up` and `forward` must be different axes.
    pub fn new(
        handedness: Handedness,
        up: SignedAxis,
        forward: SignedAxis,
    ) -> Result<Self, String> {
        if up.index() == forward.index() {
            return Err(format!(
                "up {up} and forward {forward} are the same axis; they must be perpendicular"
            ));
        }
        Ok(Self {
            handedness,
            up,
            forward,
        })
    }

    /// The usual forward axis for a handedness and up axis: with +y up,
    /// −z for right-handed (OpenGL, glTF, OpenXR) and +z for left-handed
    /// (Unity, Direct3D); with ±z up, +x (ROS REP 103 and NED, Corbillon et
    /// al., Unreal). `None` where there is no common default (x up; −y up,
    /// e.g. OpenCV's camera frame looking along +z).
    pub fn default_forward(handedness: Handedness, up: SignedAxis) -> Option<SignedAxis> {
        match (up, handedness) {
            (SignedAxis::PY, Handedness::Right) => Some(SignedAxis::NZ),
            (SignedAxis::PY, Handedness::Left) => Some(SignedAxis::PZ),
            (SignedAxis::PZ | SignedAxis::NZ, _) => Some(SignedAxis::PX),
            _ => None,
        }
    }

    /// The wearer's right in source axes: forward × up (right-handed) or
    /// up × forward (left-handed), on coordinates.
    pub fn right(&self) -> SignedAxis {
        let (f, u) = (self.forward.vector(), self.up.vector());
        SignedAxis::from_vector(match self.handedness {
            Handedness::Right => cross(f, u),
            Handedness::Left => cross(u, f),
        })
    }

    /// `M`, source → glTF (rows): `M·right = +X`, `M·up = +Y`,
    /// `M·forward = −Z`; `M = G·Bᵀ` with `B = [right up forward]` and
    /// `G = [+X +Y −Z]`.
    pub fn matrix(&self) -> [[f64; 3]; 3] {
        let b = [
            self.right().vector(),
            self.up.vector(),
            self.forward.vector(),
        ];
        let g = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, x) in row.iter_mut().enumerate() {
                // (G·Bᵀ)[r][c] = Σ_k G[r][k]·B[k][c], column k of G = g[k].
                *x = (0..3).map(|k| g[k][r] * b[k][c]).sum();
            }
        }
        m
    }

    fn apply(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    /// A position in source axes → glTF axes (`M·p`). Exact: `M` is a signed
    /// permutation.
    pub fn position(&self, p: [f64; 3]) -> [f64; 3] {
        Self::apply(&self.matrix(), p)
    }

    /// A head orientation quaternion `(x, y, z, w)` in source axes → glTF
    /// axes, `M·R·Mᵀ` (module docs). Not normalized.
    pub fn quaternion(&self, q: [f64; 4]) -> [f64; 4] {
        let m = self.matrix();
        let v = Self::apply(&m, [q[0], q[1], q[2]]);
        let s = match self.handedness {
            Handedness::Right => 1.0,
            Handedness::Left => -1.0,
        };
        [s * v[0], s * v[1], s * v[2], q[3]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_have_the_documented_right_axis_and_matrix() {
        assert_eq!(AxisConvention::GLTF.right(), SignedAxis::PX);
        assert_eq!(AxisConvention::UNITY.right(), SignedAxis::PX);
        assert_eq!(AxisConvention::CORBILLON.right(), SignedAxis::PY);
        let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(AxisConvention::GLTF.matrix(), id);
        let unity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
        assert_eq!(AxisConvention::UNITY.matrix(), unity);
    }

    #[test]
    fn axes_parse_and_print() {
        assert_eq!("-z".parse::<SignedAxis>().unwrap(), SignedAxis::NZ);
        assert_eq!("+Y".parse::<SignedAxis>().unwrap(), SignedAxis::PY);
        assert_eq!("x".parse::<SignedAxis>().unwrap().to_string(), "+x");
        assert!("w".parse::<SignedAxis>().is_err());
        assert!(AxisConvention::new(Handedness::Left, SignedAxis::PY, SignedAxis::NY).is_err());
        let fwd = |h, up| AxisConvention::default_forward(h, up);
        assert_eq!(fwd(Handedness::Left, SignedAxis::PY), Some(SignedAxis::PZ));
        assert_eq!(fwd(Handedness::Right, SignedAxis::PY), Some(SignedAxis::NZ));
        assert_eq!(fwd(Handedness::Right, SignedAxis::NZ), Some(SignedAxis::PX));
        assert_eq!(fwd(Handedness::Right, SignedAxis::NY), None);
        assert_eq!(fwd(Handedness::Right, SignedAxis::PX), None);
    }
}
