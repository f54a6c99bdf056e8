//! The CPU evaluator of a typed graph: the test oracle of the generated GLSL
//! (shaders/materialx/nodes.glsl holds the same node implementations). Every
//! node is evaluated channel by channel with the operations in the order the
//! GLSL uses, in f32, without fused multiply-add.
//!
//! Node semantics follow the MaterialX 1.39 standard nodes; where the
//! specification defines a node by a nodegraph in stdlib_ng.mtlx (checkerboard,
//! place2d, hsvadjust, convert, ...) the implementation is that graph's
//! arithmetic, and `tests/material_graphs.rs` evaluates both and compares.

use super::graph::{GeomProp, Graph, Node, Source};
use super::noise;
use super::types::{Type, Value};

/// The texture coordinate a graph sees (`Geom::uv`, UV0) at a mesh's uv:
/// meshes carry glTF's convention (origin at the image's top left, v
/// down), MaterialX's texture space has v up (origin at the lower left),
/// so v is flipped, as MaterialX's own glTF loader does. The scene's
/// generated GLSL does the same (scene_shaders.rs); the image node turns
/// it back into stored rows (image.glsl), so an image reads upright, as
/// the glTF texture of the same file.
pub fn graph_uv(mesh_uv: [f32; 2]) -> [f32; 2] {
    [mesh_uv[0], 1.0 - mesh_uv[1]]
}

/// The surface point a graph is evaluated at, in world space and in the
/// mesh's object space (`tangent` may be zero where the mesh has none, then
/// `normalmap` returns the normal). `uv` is the graph's texture space (v
/// up): at a mesh's hit, [`graph_uv`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geom {
    /// Texture coordinate set 0 (glTF TEXCOORD_0, v up: [`graph_uv`]).
    pub uv: [f32; 2],
    /// Set 1 (TEXCOORD_1, v up), the `texcoord` node's index 1.
    pub uv1: [f32; 2],
    /// ∂uv1/∂uv on the surface (columns: along u, along v; the hit
    /// triangle's, scene.glsl `surface_at`, with both sets' v flipped:
    /// F·J·F, F = diag(1, −1), scene_shaders.rs): a central difference moving
    /// uv by d moves uv1 by this times d ([`shifted_input`]; zero where
    /// either set is degenerate or missing).
    pub uv1_per_uv: [[f32; 2]; 2],
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub tangent: [f32; 3],
    /// glTF's handedness w (±1): the bitangent is cross(normal, tangent)·w,
    /// the mesh's own (a mirrored uv island has w = −1; seen from behind
    /// the renderer turns normal, tangent and w over, scene.glsl surface_at).
    pub tangent_sign: f32,
    /// The width in uv the value stands for (image nodes pick their mip
    /// level from it, image.rs); 0: a point, level 0.
    pub footprint: f32,
    /// The same point in the mesh's object space (MaterialX "object" and
    /// "model"; graph.rs `GeomProp`): position, unit normal and unit
    /// tangent, and the handedness of that frame (`tangent_sign` times −1
    /// where the instance mirrors). The renderer takes the world values back
    /// through the instance's transform (scene_shaders.rs
    /// `sc_graph_object_space`).
    pub object: ObjectFrame,
}

/// Object-space values of a surface point ([`Geom::object`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectFrame {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub tangent: [f32; 3],
    pub tangent_sign: f32,
}

impl Default for ObjectFrame {
    /// The origin with zero vectors, right-handed.
    fn default() -> Self {
        ObjectFrame {
            position: [0.0; 3],
            normal: [0.0; 3],
            tangent: [0.0; 3],
            tangent_sign: 1.0,
        }
    }
}

impl Default for Geom {
    /// The origin with zero vectors, right-handed (w = +1), footprint 0,
    /// in both spaces.
    fn default() -> Self {
        Geom {
            uv: [0.0; 2],
            uv1: [0.0; 2],
            uv1_per_uv: [[0.0; 2]; 2],
            position: [0.0; 3],
            normal: [0.0; 3],
            tangent: [0.0; 3],
            tangent_sign: 1.0,
            footprint: 0.0,
            object: ObjectFrame::default(),
        }
    }
}

impl Geom {
    /// A point of a mesh placed without a transform: object space is world
    /// space.
    pub fn untransformed(self) -> Geom {
        Geom {
            object: ObjectFrame {
                position: self.position,
                normal: self.normal,
                tangent: self.tangent,
                tangent_sign: self.tangent_sign,
            },
            ..self
        }
    }

    /// The bitangent graphs read (`bitangent` node, `normalmap`'s default):
    /// cross(N, T)·w, as nodes.glsl `mx_bitangent`.
    pub fn bitangent(&self) -> [f32; 3] {
        cross(self.normal, self.tangent).map(|c| c * self.tangent_sign)
    }

    fn prop(&self, g: GeomProp) -> Value {
        let o = &self.object;
        match g {
            GeomProp::Uv => Value::new(Type::Vector2, &self.uv),
            GeomProp::Uv1 => Value::new(Type::Vector2, &self.uv1),
            GeomProp::Position => Value::new(Type::Vector3, &self.position),
            GeomProp::Normal => Value::new(Type::Vector3, &self.normal),
            GeomProp::Tangent => Value::new(Type::Vector3, &self.tangent),
            GeomProp::Bitangent => Value::new(Type::Vector3, &self.bitangent()),
            GeomProp::PositionObject => Value::new(Type::Vector3, &o.position),
            GeomProp::NormalObject => Value::new(Type::Vector3, &o.normal),
            GeomProp::TangentObject => Value::new(Type::Vector3, &o.tangent),
            GeomProp::BitangentObject => Value::new(
                Type::Vector3,
                &cross(o.normal, o.tangent).map(|c| c * o.tangent_sign),
            ),
        }
    }
}

/// Step in texture space of `heighttonormal`'s central differences (exact in binary).
pub const HEIGHT_STEP: f32 = 1.0 / 1024.0;

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// One argument of a node: a number or a string (strings are uniform
/// parameters no implemented node reads at evaluation time).
#[derive(Clone, Copy)]
enum Arg {
    V(Value),
    S,
}

impl Arg {
    fn v(&self) -> Value {
        match self {
            Arg::V(v) => *v,
            Arg::S => Value::float(0.0),
        }
    }
}

/// The outputs of `g` at `geom`, in `g.outputs` order.
pub fn evaluate(g: &Graph, geom: &Geom) -> Vec<Value> {
    let vals = eval_nodes(g, g.nodes.len(), geom);
    g.outputs
        .iter()
        .map(|o| read(&o.source, &vals, geom))
        .collect()
}

/// The values of the first `n` nodes of `g` at `geom`.
fn eval_nodes(g: &Graph, n: usize, geom: &Geom) -> Vec<Value> {
    let mut vals: Vec<Value> = Vec::with_capacity(n);
    for (i, node) in g.nodes[..n].iter().enumerate() {
        let v = if node.op() == "heighttonormal" {
            height_to_normal(g, i, geom)
        } else if node.op() == "image" {
            image_node(g, i, geom, &vals)
        } else {
            let args: Vec<Arg> = node
                .inputs
                .iter()
                .map(|s| match s {
                    Source::Str(_) => Arg::S,
                    s => Arg::V(read(s, &vals, geom)),
                })
                .collect();
            apply(node, &args, geom)
        };
        vals.push(v);
    }
    vals
}

fn read(s: &Source, vals: &[Value], geom: &Geom) -> Value {
    match s {
        Source::Const(v) => *v,
        Source::Str(_) => Value::float(0.0),
        Source::Geom(p) => geom.prop(*p),
        Source::Node(i) => vals[*i],
    }
}

/// A node whose inputs are all constants (constant folding at load).
pub fn eval_constant(node: &Node) -> Value {
    let args: Vec<Arg> = node
        .inputs
        .iter()
        .map(|s| match s {
            Source::Const(v) => Arg::V(*v),
            Source::Str(_) => Arg::S,
            _ => unreachable!("eval_constant on a varying node"),
        })
        .collect();
    apply(node, &args, &Geom::default())
}

/// MaterialX's heighttonormal scales the height gradient by 1/16 "for
/// parity with traditional Sobel filtering" (the reference implementation,
/// genglsl/genosl mx_heighttonormal_vector3): out = normalize(−scale/16 ·
/// ∇ₜh, 1), t the node's texcoord.
pub const HEIGHT_SOBEL_SCALE: f32 = 1.0 / 16.0;

/// Below this squared length the gradient frame is degenerate (a texcoord
/// that does not vary) and the normal is (0, 0, 1) (MaterialX's
/// M_FLOAT_EPS², 1e-8²).
pub const HEIGHT_DEGENERATE: f32 = 1e-16;

/// `heighttonormal` (node `i`): MaterialX's construction with the
/// derivatives taken in the graph's uv instead of screen space: central
/// differences at ±HEIGHT_STEP of the height (input 0, scaled by
/// scale/16) and of the texcoord (input 2; exactly the identity when it is
/// the uv), the whole upstream graph re-evaluated at the shifted uv;
/// n = (∂t/∂u, s·∂h/∂u) × (∂t/∂v, s·∂h/∂v), turned to n.z ≥ 0 (a mirrored
/// texcoord), (0, 0, 1) if degenerate; out = normalize(n)·0.5 + 0.5. By the
/// chain rule n ∥ (−s·∂h/∂t₁, −s·∂h/∂t₂, 1): the gradient with respect to
/// the texcoord, whatever the uv.
fn height_to_normal(g: &Graph, i: usize, geom: &Geom) -> Value {
    let node = &g.nodes[i];
    let at = |k: usize, du: f32, dv: f32| shifted_input(g, i, k, geom, du, dv).v;
    let scale = match &node.inputs[1] {
        Source::Const(v) => v.v[0],
        s => read(s, &eval_nodes(g, i, geom), geom).v[0],
    };
    let st = HEIGHT_STEP;
    let h = [
        at(0, st, 0.0)[0],
        at(0, -st, 0.0)[0],
        at(0, 0.0, st)[0],
        at(0, 0.0, -st)[0],
    ];
    let (tdu, tdv) = if node.inputs[2] == Source::Geom(GeomProp::Uv) {
        ([1.0, 0.0], [0.0, 1.0])
    } else {
        let (u1, u0, v1, v0) = (
            at(2, st, 0.0),
            at(2, -st, 0.0),
            at(2, 0.0, st),
            at(2, 0.0, -st),
        );
        let inv = 1.0 / (2.0 * st);
        (
            [(u1[0] - u0[0]) * inv, (u1[1] - u0[1]) * inv],
            [(v1[0] - v0[0]) * inv, (v1[1] - v0[1]) * inv],
        )
    };
    height_normal(h, scale, tdu, tdv)
}

/// The normal of heighttonormal from the height at uv ± step·x̂, uv ±
/// step·ŷ (`h` = [u+, u−, v+, v−]) and the texcoord's derivatives along u
/// and v (nodes.glsl `mx_height_normal`).
pub fn height_normal(h: [f32; 4], scale: f32, tdu: [f32; 2], tdv: [f32; 2]) -> Value {
    let inv = 1.0 / (2.0 * HEIGHT_STEP);
    let hu = (h[0] - h[1]) * inv * scale * HEIGHT_SOBEL_SCALE;
    let hv = (h[2] - h[3]) * inv * scale * HEIGHT_SOBEL_SCALE;
    let mut n = cross([tdu[0], tdu[1], hu], [tdv[0], tdv[1], hv]);
    if dot(&n, &n) < HEIGHT_DEGENERATE {
        n = [0.0, 0.0, 1.0];
    } else if n[2] < 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    let n = normalize3(n);
    Value::new(
        Type::Vector3,
        &[n[0] * 0.5 + 0.5, n[1] * 0.5 + 0.5, n[2] * 0.5 + 0.5],
    )
}

/// Input `k` of node `i` with the graph re-evaluated at the uv shifted by
/// (du, dv): heighttonormal's and the image texcoord's central differences.
/// Uv set 1 moves with it along the surface (nodes.glsl `mx_uv1_at`).
fn shifted_input(g: &Graph, i: usize, k: usize, geom: &Geom, du: f32, dv: f32) -> Value {
    let mut q = *geom;
    q.uv = [geom.uv[0] + du, geom.uv[1] + dv];
    let j = geom.uv1_per_uv;
    q.uv1 = [
        geom.uv1[0] + (j[0][0] * du + j[1][0] * dv),
        geom.uv1[1] + (j[0][1] * du + j[1][1] * dv),
    ];
    read(&g.nodes[i].inputs[k], &eval_nodes(g, i, &q), &q)
}

/// `image` (node `i`): the file's texel filtering at the texture
/// coordinate (input 3), for the footprint scaled by the coordinate's
/// Jacobian (central differences at ±HEIGHT_STEP unless it is the uv).
fn image_node(g: &Graph, i: usize, geom: &Geom, vals: &[Value]) -> Value {
    let node = &g.nodes[i];
    let (_, im) = g.image_of(i).expect("image nodes have an image");
    let tc = read(&node.inputs[3], vals, geom).v;
    let mut footprint = geom.footprint;
    if footprint > 0.0 && node.inputs[3] != Source::Geom(super::graph::GeomProp::Uv) {
        let at = |du: f32, dv: f32| shifted_input(g, i, 3, geom, du, dv).v;
        let (u1, u0) = (at(HEIGHT_STEP, 0.0), at(-HEIGHT_STEP, 0.0));
        let (v1, v0) = (at(0.0, HEIGHT_STEP), at(0.0, -HEIGHT_STEP));
        footprint *= texcoord_scale(u1, u0, v1, v0, HEIGHT_STEP);
    }
    let d = read(&node.inputs[2], vals, geom);
    let dflt = bc(d, 4);
    let r = super::image::evaluate(im, [tc[0], tc[1]], footprint, dflt);
    let w = node.ty().width();
    let mut v = [0.0; 4];
    v[..w].copy_from_slice(&r[..w]);
    Value { ty: node.ty(), v }
}

/// √|det J| of a texture coordinate's Jacobian from central differences
/// (shaders/materialx/image.glsl `mx_texcoord_scale`).
fn texcoord_scale(u1: [f32; 4], u0: [f32; 4], v1: [f32; 4], v0: [f32; 4], step: f32) -> f32 {
    let du = [
        (u1[0] - u0[0]) / (2.0 * step),
        (u1[1] - u0[1]) / (2.0 * step),
    ];
    let dv = [
        (v1[0] - v0[0]) / (2.0 * step),
        (v1[1] - v0[1]) / (2.0 * step),
    ];
    (du[0] * dv[1] - du[1] * dv[0]).abs().sqrt()
}

fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut s = a[0] * b[0];
    for k in 1..a.len() {
        s += a[k] * b[k];
    }
    s
}

fn normalize3(v: [f32; 3]) -> [f32; 3] {
    let l = dot(&v, &v).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        v
    }
}

/// Broadcasts a float to `w` channels; passes a vector through.
fn bc(v: Value, w: usize) -> [f32; 4] {
    if v.ty.width() == 1 && w > 1 {
        [v.v[0]; 4]
    } else {
        v.v
    }
}

fn map1(out: Type, a: Value, f: impl Fn(f32) -> f32) -> Value {
    let w = out.width();
    let a = bc(a, w);
    let mut r = [0.0; 4];
    for k in 0..w {
        r[k] = f(a[k]);
    }
    Value { ty: out, v: r }
}

fn map2(out: Type, a: Value, b: Value, f: impl Fn(f32, f32) -> f32) -> Value {
    let w = out.width();
    let (a, b) = (bc(a, w), bc(b, w));
    let mut r = [0.0; 4];
    for k in 0..w {
        r[k] = f(a[k], b[k]);
    }
    Value { ty: out, v: r }
}

fn map3(out: Type, a: Value, b: Value, c: Value, f: impl Fn(f32, f32, f32) -> f32) -> Value {
    let w = out.width();
    let (a, b, c) = (bc(a, w), bc(b, w), bc(c, w));
    let mut r = [0.0; 4];
    for k in 0..w {
        r[k] = f(a[k], b[k], c[k]);
    }
    Value { ty: out, v: r }
}

/// `power` with every case defined, so the GPU (nodes.glsl `mx_pow`, where
/// GLSL's pow is undefined for x < 0 and for x = 0, y ≤ 0) and the CPU agree:
/// x⁰ = 1; 0^y = 0 for y > 0, +∞ for y < 0; a negative base with an integer
/// exponent is the real power (−2² = 4, −2³ = −8), with any other exponent 0
/// (no real result; OSL's pow, MaterialX's OSL reference, gives 0 there,
/// where C's powf gives NaN).
pub fn power(x: f32, y: f32) -> f32 {
    if y == 0.0 {
        return 1.0;
    }
    if x == 0.0 {
        return if y > 0.0 { 0.0 } else { f32::INFINITY };
    }
    let a = x.abs().powf(y);
    if x > 0.0 || x.is_nan() {
        return a;
    }
    if y != y.floor() {
        return 0.0;
    }
    let half = y * 0.5;
    if half == half.floor() {
        a
    } else {
        -a
    }
}

pub fn modulo(a: f32, b: f32) -> f32 {
    a - b * (a / b).floor()
}

pub fn mix(bg: f32, fg: f32, m: f32) -> f32 {
    bg + (fg - bg) * m
}

/// 1 at or above `hi`, 0 at or below `lo`, the Hermite cubic between (no
/// division when `lo == hi`).
pub fn smoothstep(x: f32, lo: f32, hi: f32) -> f32 {
    if x >= hi {
        1.0
    } else if x <= lo {
        0.0
    } else {
        let t = (x - lo) / (hi - lo);
        t * t * (3.0 - 2.0 * t)
    }
}

fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    x.max(lo).min(hi)
}

/// RGB -> HSV (hue in [0, 1)), the hexcone model (Smith 1978).
pub fn rgb_to_hsv(c: [f32; 3]) -> [f32; 3] {
    let (r, g, b) = (c[0], c[1], c[2]);
    let mx = r.max(g).max(b);
    let mn = r.min(g).min(b);
    let d = mx - mn;
    let s = if mx > 0.0 { d / mx } else { 0.0 };
    let mut h = 0.0;
    if d > 0.0 {
        h = if r >= mx {
            (g - b) / d
        } else if g >= mx {
            2.0 + (b - r) / d
        } else {
            4.0 + (r - g) / d
        };
        h /= 6.0;
        if h < 0.0 {
            h += 1.0;
        }
    }
    [h, s, mx]
}

/// Saturation below which HSV -> RGB returns grey (v, v, v), as
/// MaterialX's `hsvtorgb` does (so a saturation scaled to zero or below
/// gives grey, not the sector formula's 1 + |s|·… overshoot).
pub const HSV_GREY_SATURATION: f32 = 0.0001;

/// HSV -> RGB (hue wraps); grey below [`HSV_GREY_SATURATION`]. Saturation
/// above 1 is not clamped (MaterialX's graph does not clamp either).
pub fn hsv_to_rgb(c: [f32; 3]) -> [f32; 3] {
    let (s, v) = (c[1], c[2]);
    if s < HSV_GREY_SATURATION {
        return [v, v, v];
    }
    // x − floor(x) rounds to 1 for x just below 0 (−1e-8): that hue is 0,
    // not sector 6 (which fell to the last sector's magenta).
    let h = c[0] - c[0].floor();
    let h = if h >= 1.0 { 0.0 } else { h };
    let h6 = h * 6.0;
    let sector = h6.floor();
    let f = h6 - sector;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match sector as i32 {
        0 => [v, t, p],
        1 => [q, v, p],
        2 => [p, v, t],
        3 => [p, q, v],
        4 => [t, p, v],
        _ => [v, p, q],
    }
}

/// Counter-clockwise rotation by `deg` degrees (rotate2d).
fn rotate2d(p: [f32; 2], deg: f32) -> [f32; 2] {
    let r = deg.to_radians();
    let (s, c) = (r.sin(), r.cos());
    [p[0] * c - p[1] * s, p[0] * s + p[1] * c]
}

fn apply(node: &Node, a: &[Arg], geom: &Geom) -> Value {
    let out = node.ty();
    let w = out.width();
    let op = node.op();
    let v = |i: usize| a[i].v();
    let int = |i: usize| a[i].v().v[0] as i32;
    let uv = |i: usize| [v(i).v[0], v(i).v[1]];
    let p3 = |i: usize| [v(i).v[0], v(i).v[1], v(i).v[2]];
    match op {
        "constant" | "dot" => v(0),
        "texcoord" => {
            let t = geom
                .prop(node.geom_prop().expect("texcoord reads a uv set"))
                .v;
            Value::new(out, &[t[0], t[1], 0.0][..w])
        }
        "position" | "normal" | "tangent" => geom.prop(node.geom_prop().expect("geometry node")),
        "add" => map2(out, v(0), v(1), |x, y| x + y),
        "subtract" => map2(out, v(0), v(1), |x, y| x - y),
        "multiply" => map2(out, v(0), v(1), |x, y| x * y),
        "divide" => map2(out, v(0), v(1), |x, y| x / y),
        "modulo" => map2(out, v(0), v(1), modulo),
        "power" => map2(out, v(0), v(1), power),
        "min" => map2(out, v(0), v(1), f32::min),
        "max" => map2(out, v(0), v(1), f32::max),
        "absval" => map1(out, v(0), f32::abs),
        "floor" => map1(out, v(0), f32::floor),
        "ceil" => map1(out, v(0), f32::ceil),
        "fract" => map1(out, v(0), |x| x - x.floor()),
        "sign" => map1(out, v(0), sign),
        "sin" => map1(out, v(0), f32::sin),
        "cos" => map1(out, v(0), f32::cos),
        "sqrt" => map1(out, v(0), f32::sqrt),
        "exp" => map1(out, v(0), f32::exp),
        "ln" => map1(out, v(0), f32::ln),
        "invert" => map2(out, v(1), v(0), |amount, x| amount - x),
        "mix" => map3(out, v(1), v(0), v(2), mix),
        "clamp" => map3(out, v(0), v(1), v(2), clamp),
        "smoothstep" => map3(out, v(0), v(1), v(2), smoothstep),
        "ifgreater" | "ifgreatereq" => {
            let (x, y) = (v(0).v[0], v(1).v[0]);
            let take = if op == "ifgreater" { x > y } else { x >= y };
            Value {
                ty: out,
                ..if take { v(2) } else { v(3) }
            }
        }
        "ramplr" => {
            let t = clamp(v(2).v[0], 0.0, 1.0);
            map2(out, v(0), v(1), |l, r| mix(l, r, t))
        }
        "ramptb" => {
            let t = clamp(v(2).v[1], 0.0, 1.0);
            map2(out, v(1), v(0), |b, tp| mix(b, tp, t))
        }
        "ramp4" => {
            // NG_ramp4: the texcoord clamped to [0, 1]²; mix(bl, br, s) and
            // mix(tl, tr, s), then mix(bottom, top, t).
            let tc = v(4).v;
            let (s, t) = (clamp(tc[0], 0.0, 1.0), clamp(tc[1], 0.0, 1.0));
            let top = map2(out, v(0), v(1), |l, r| mix(l, r, s));
            let bottom = map2(out, v(2), v(3), |l, r| mix(l, r, s));
            map2(out, bottom, top, |b, tp| mix(b, tp, t))
        }
        "remap" => {
            // The genglsl source: outlow + (in − inlow)(outhigh − outlow) / (inhigh − inlow).
            let (x, il, ih, ol, oh) = (
                bc(v(0), w),
                bc(v(1), w),
                bc(v(2), w),
                bc(v(3), w),
                bc(v(4), w),
            );
            let mut r = [0.0; 4];
            for k in 0..w {
                r[k] = ol[k] + (x[k] - il[k]) * (oh[k] - ol[k]) / (ih[k] - il[k]);
            }
            Value { ty: out, v: r }
        }
        "checkerboard" => {
            // NG_checkerboard_color3: mix(color2, color1, mod(dot(floor(uv·tiling − offset), 1), 2)).
            let (t, tile, off) = (uv(4), uv(2), uv(3));
            let fx = (t[0] * tile[0] - off[0]).floor();
            let fy = (t[1] * tile[1] - off[1]).floor();
            let m = modulo(fx + fy, 2.0);
            map2(out, v(1), v(0), |c2, c1| mix(c2, c1, m))
        }
        "place2d" => {
            // NG_place2d_vector2: SRT (order 0) or TRS (order 1).
            let (t, pivot, scale, rot, off) = (uv(0), uv(1), uv(2), v(3).v[0], uv(4));
            let sp = [t[0] - pivot[0], t[1] - pivot[1]];
            let r = if int(5) == 0 {
                let r = rotate2d([sp[0] / scale[0], sp[1] / scale[1]], rot);
                [r[0] - off[0] + pivot[0], r[1] - off[1] + pivot[1]]
            } else {
                let r = rotate2d([sp[0] - off[0], sp[1] - off[1]], rot);
                [r[0] / scale[0] + pivot[0], r[1] / scale[1] + pivot[1]]
            };
            Value::new(out, &r)
        }
        "rotate2d" => Value::new(out, &rotate2d(uv(0), v(1).v[0])),
        "noise2d" | "noise3d" => {
            let (amp, pivot) = (bc(v(0), w), v(1).v[0]);
            let mut r = [0.0; 4];
            for (c, o) in r.iter_mut().enumerate().take(w) {
                let n = if op == "noise2d" {
                    noise::perlin2(uv(2), c as u32)
                } else {
                    noise::perlin3(p3(2), c as u32)
                };
                *o = n * amp[c] + pivot;
            }
            Value { ty: out, v: r }
        }
        "fractal3d" => {
            let (amp, oct, lac, dim) = (bc(v(0), w), int(1), v(2).v[0], v(3).v[0]);
            let mut r = [0.0; 4];
            for (c, o) in r.iter_mut().enumerate().take(w) {
                *o = noise::fractal3(p3(4), c as u32, oct, lac, dim) * amp[c];
            }
            Value { ty: out, v: r }
        }
        "cellnoise2d" => Value::float(noise::cell2(uv(0), 0)),
        "cellnoise3d" => Value::float(noise::cell3(p3(0), 0)),
        "worleynoise2d" => Value {
            ty: out,
            v: noise::worley2(uv(0), v(1).v[0], int(2), w),
        },
        "worleynoise3d" => Value {
            ty: out,
            v: noise::worley3(p3(0), v(1).v[0], int(2), w),
        },
        "hsvadjust" => {
            let (c, amt) = (v(0).v, v(1).v);
            let hsv = rgb_to_hsv([c[0], c[1], c[2]]);
            let rgb = hsv_to_rgb([hsv[0] + amt[0], hsv[1] * amt[1], hsv[2] * amt[2]]);
            Value::new(out, &[rgb[0], rgb[1], rgb[2], c[3]][..w])
        }
        "luminance" => {
            let (c, k) = (v(0).v, v(1).v);
            let l = c[0] * k[0] + c[1] * k[1] + c[2] * k[2];
            Value::new(out, &[l, l, l, c[3]][..w])
        }
        "normalmap" => {
            // in: tangent-space normal encoded in [0, 1]; scale on x and y.
            let (t, sc) = (v(0).v, bc(v(1), 2));
            let (n, tg, bt) = (p3(2), p3(3), p3(4));
            // An all-zero input (no data) is the unperturbed normal, as in
            // MaterialX's mx_normalmap: tangent-space (0, 0, 1).
            let m = if t[0] == 0.0 && t[1] == 0.0 && t[2] == 0.0 {
                [0.0, 0.0, 1.0]
            } else {
                [
                    (t[0] * 2.0 - 1.0) * sc[0],
                    (t[1] * 2.0 - 1.0) * sc[1],
                    t[2] * 2.0 - 1.0,
                ]
            };
            let s = [
                tg[0] * m[0] + bt[0] * m[1] + n[0] * m[2],
                tg[1] * m[0] + bt[1] * m[1] + n[1] * m[2],
                tg[2] * m[0] + bt[2] * m[1] + n[2] * m[2],
            ];
            Value::new(out, &normalize3(s))
        }
        "dotproduct" => Value::float(dot(v(0).channels(), v(1).channels())),
        "crossproduct" => Value::new(out, &cross(p3(0), p3(1))),
        "magnitude" => Value::float(dot(v(0).channels(), v(0).channels()).sqrt()),
        "normalize" => {
            let x = v(0);
            let l = dot(x.channels(), x.channels()).sqrt();
            map1(out, x, |c| if l > 0.0 { c / l } else { c })
        }
        "convert" => {
            let x = v(0);
            let iw = x.ty.width();
            let mut r = [0.0, 0.0, 0.0, 1.0];
            for (k, o) in r.iter_mut().enumerate().take(w) {
                *o = if iw == 1 {
                    x.v[0]
                } else if k < iw {
                    x.v[k]
                } else if k == 3 {
                    1.0
                } else {
                    0.0
                };
            }
            Value { ty: out, v: r }
        }
        "extract" => Value::float(v(0).v[int(1) as usize]),
        "combine2" | "combine3" => {
            let mut r = Vec::with_capacity(4);
            for x in &a[..if op == "combine2" { 2 } else { 3 }] {
                r.extend_from_slice(x.v().channels());
            }
            Value::new(out, &r)
        }
        other => unreachable!("node `{other}` has a signature but no implementation"),
    }
}
