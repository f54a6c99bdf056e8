//! GLSL code generation: one SSA function per graph (thesis §4.2), nodes in
//! the graph's topological order, every temporary `precise` (no fused
//! multiply-add, so the result matches the CPU evaluator to rounding), node
//! implementations from shaders/materialx/. The function writes the graph's
//! outputs as consecutive floats:
//!
//! ```glsl
//! void mxg_<symbol>(in MxGeom g, out float o[N]);   // N = Layout::floats
//! ```
//!
//! `heighttonormal` gets a helper function per node that evaluates its
//! height input (the nodes it reads) at a shifted uv, and one for its
//! texcoord input unless that is the uv; so does an `image`
//! node whose texture coordinate is not the uv (its scale against the uv
//! sets the mip level, image.rs). An image node reads texture `slots[k]`
//! of the scene's array, k its index in `Graph::images`.

use super::eval::HEIGHT_STEP;
use super::graph::{GeomProp, Graph, Node, Source};
use super::types::{Type, Value};
use std::fmt::Write;

/// Where each output lies in the function's float array.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// (output name, type, first float)
    pub outputs: Vec<(String, Type, usize)>,
    pub floats: usize,
}

impl Layout {
    pub fn of(g: &Graph) -> Layout {
        let mut off = 0;
        let outputs = g
            .outputs
            .iter()
            .map(|o| {
                let r = (o.name.clone(), o.ty, off);
                off += o.ty.width();
                r
            })
            .collect();
        Layout {
            outputs,
            floats: off,
        }
    }

    pub fn get(&self, name: &str) -> Option<(Type, usize)> {
        self.outputs
            .iter()
            .find(|o| o.0 == name)
            .map(|o| (o.1, o.2))
    }
}

/// A GLSL identifier from a graph name (letters, digits, `_`) and a number.
pub fn symbol(g: &Graph, index: usize) -> String {
    let clean: String = g
        .name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    format!("{index}_{clean}")
}

fn geom(p: GeomProp, g: &str) -> String {
    match p {
        GeomProp::Uv => format!("{g}.uv"),
        GeomProp::Uv1 => format!("{g}.uv1"),
        GeomProp::Position => format!("{g}.position"),
        GeomProp::Normal => format!("{g}.normal"),
        GeomProp::Tangent => format!("{g}.tangent"),
        GeomProp::Bitangent => format!("mx_bitangent({g})"),
        GeomProp::PositionObject => format!("{g}.position_object"),
        GeomProp::NormalObject => format!("{g}.normal_object"),
        GeomProp::TangentObject => format!("{g}.tangent_object"),
        GeomProp::BitangentObject => format!("mx_bitangent_object({g})"),
    }
}

struct Emit<'a> {
    graph: &'a Graph,
    geom: &'a str,
    prefix: String,
    /// Base name of the heighttonormal helpers (`<hfn>_<node>`) and the
    /// image texcoord helpers (`<hfn>_t<node>`).
    hfn: String,
    /// Texture slot of each of the graph's images.
    slots: &'a [u32],
}

impl Emit<'_> {
    /// `q<i>` moved by `d` in uv set 0 (heighttonormal's and an image
    /// texcoord's central differences): uv set 1 moves with it along the
    /// triangle (`mx_uv1_at`, eval.rs `shifted_input`) in graphs that read it.
    fn shift(&self, i: usize, d: &str) -> String {
        let g = self.geom;
        let mut s = format!("q{i}.uv = {g}.uv + vec2({d});");
        if self.graph.uv_sets() & 2 != 0 {
            let _ = write!(s, " q{i}.uv1 = mx_uv1_at({g}, vec2({d}));");
        }
        s
    }

    fn src(&self, s: &Source) -> String {
        match s {
            Source::Const(v) => v.glsl(),
            Source::Str(_) => "0".into(),
            Source::Geom(p) => geom(*p, self.geom),
            Source::Node(i) => format!("{}{i}", self.prefix),
        }
    }

    /// Input `k` of `n`, broadcast to the node's type when it is a float.
    fn arg(&self, n: &Node, k: usize) -> String {
        let e = self.src(&n.inputs[k]);
        let (t, o) = (self.graph.source_ty(&n.inputs[k]), n.ty());
        if t.width() == 1 && o.width() > 1 && t != Type::Integer {
            format!("{}({e})", o.glsl())
        } else {
            e
        }
    }

    fn raw(&self, n: &Node, k: usize) -> String {
        self.src(&n.inputs[k])
    }

    fn int(&self, n: &Node, k: usize) -> i32 {
        match &n.inputs[k] {
            Source::Const(v) => v.v[0] as i32,
            _ => 0,
        }
    }

    /// (sin, cos) of a rotation in degrees: computed here when constant
    /// (the CPU evaluator's f32 sin/cos), on the GPU otherwise.
    fn sincos(&self, n: &Node, k: usize) -> String {
        match &n.inputs[k] {
            Source::Const(v) => {
                let r = v.v[0].to_radians();
                Value::new(Type::Vector2, &[r.sin(), r.cos()]).glsl()
            }
            s => format!("mx_sincos_deg({})", self.src(s)),
        }
    }

    /// The per-channel call of a noise function, as a value of the node's type.
    fn channels(&self, n: &Node, f: impl Fn(usize) -> String) -> String {
        let w = n.ty().width();
        if w == 1 {
            f(0)
        } else {
            let c: Vec<String> = (0..w).map(f).collect();
            format!("{}({})", n.ty().glsl(), c.join(", "))
        }
    }

    fn expr(&self, i: usize, n: &Node, out: &mut String) -> String {
        let t = n.ty();
        let ty = t.glsl();
        let a = |k| self.arg(n, k);
        let swz = |w: usize| ["x", "xy", "xyz", "xyzw"][w - 1];
        match n.op() {
            "constant" | "dot" => a(0),
            "texcoord" => {
                let uv = geom(n.geom_prop().expect("texcoord reads a uv set"), self.geom);
                match t.width() {
                    3 => format!("vec3({uv}, 0.0)"),
                    _ => uv,
                }
            }
            "position" | "normal" | "tangent" => {
                geom(n.geom_prop().expect("geometry node"), self.geom)
            }
            "add" => format!("{} + {}", a(0), a(1)),
            "subtract" => format!("{} - {}", a(0), a(1)),
            "multiply" => format!("{} * {}", a(0), a(1)),
            "divide" => format!("{} / {}", a(0), a(1)),
            "modulo" => format!("mx_modulo({}, {})", a(0), a(1)),
            "power" => format!("mx_pow({}, {})", a(0), a(1)),
            "min" | "max" => format!("{}({}, {})", n.op(), a(0), a(1)),
            "floor" | "ceil" | "sign" | "sin" | "cos" | "sqrt" | "exp" => {
                format!("{}({})", n.op(), a(0))
            }
            "ln" => format!("log({})", a(0)),
            "absval" => format!("abs({})", a(0)),
            "fract" => format!("mx_fract({})", a(0)),
            "invert" => format!("{} - {}", a(1), a(0)),
            "mix" => format!("mx_mix({}, {}, {})", a(1), a(0), a(2)),
            "clamp" => format!("mx_clamp({}, {}, {})", a(0), a(1), a(2)),
            "smoothstep" => format!("mx_smoothstep({}, {}, {})", a(0), a(1), a(2)),
            "ifgreater" => format!(
                "({} > {} ? {} : {})",
                self.raw(n, 0),
                self.raw(n, 1),
                a(2),
                a(3)
            ),
            "ifgreatereq" => format!(
                "({} >= {} ? {} : {})",
                self.raw(n, 0),
                self.raw(n, 1),
                a(2),
                a(3)
            ),
            "ramplr" => format!(
                "mx_mix({}, {}, {ty}(mx_clamp({}.x, 0.0, 1.0)))",
                a(0),
                a(1),
                self.raw(n, 2)
            ),
            "ramptb" => format!(
                "mx_mix({}, {}, {ty}(mx_clamp({}.y, 0.0, 1.0)))",
                a(1),
                a(0),
                self.raw(n, 2)
            ),
            "ramp4" => {
                let tc = self.raw(n, 4);
                let s = format!("{ty}(mx_clamp({tc}.x, 0.0, 1.0))");
                format!(
                    "mx_mix(mx_mix({}, {}, {s}), mx_mix({}, {}, {s}), {ty}(mx_clamp({tc}.y, 0.0, 1.0)))",
                    a(2),
                    a(3),
                    a(0),
                    a(1)
                )
            }
            "remap" => format!(
                "{} + ({} - {}) * ({} - {}) / ({} - {})",
                a(3),
                a(0),
                a(1),
                a(4),
                a(3),
                a(2),
                a(1)
            ),
            "checkerboard" => format!(
                "mx_checkerboard({}, {}, {}, {}, {})",
                a(0),
                a(1),
                a(2),
                a(3),
                a(4)
            ),
            "place2d" => format!(
                "mx_place2d({}, {}, {}, {}, {}, {})",
                a(0),
                a(1),
                a(2),
                self.sincos(n, 3),
                a(4),
                self.int(n, 5)
            ),
            "rotate2d" => format!("mx_rotate_sc({}, {})", a(0), self.sincos(n, 1)),
            "noise2d" | "noise3d" => {
                let f = if n.op() == "noise2d" {
                    "mx_perlin2"
                } else {
                    "mx_perlin3"
                };
                let p = self.raw(n, 2);
                let noise = self.channels(n, |c| format!("{f}({p}, {c}u)"));
                format!("{noise} * {} + {ty}({})", a(0), self.raw(n, 1))
            }
            "fractal3d" => {
                let (p, oct, lac, dim) = (
                    self.raw(n, 4),
                    self.int(n, 1),
                    self.raw(n, 2),
                    self.raw(n, 3),
                );
                let noise = self.channels(n, |c| {
                    format!("mx_fractal3({p}, {c}u, {oct}, {lac}, {dim})")
                });
                format!("{noise} * {}", a(0))
            }
            "cellnoise2d" => format!("mx_cell2({}, 0u)", self.raw(n, 0)),
            "cellnoise3d" => format!("mx_cell3({}, 0u)", self.raw(n, 0)),
            "worleynoise2d" | "worleynoise3d" => format!(
                "mx_worley{}({}, {}, {}, {}).{}",
                if n.op() == "worleynoise2d" { 2 } else { 3 },
                self.raw(n, 0),
                self.raw(n, 1),
                self.int(n, 2),
                t.width(),
                swz(t.width())
            ),
            "hsvadjust" if t.width() == 4 => format!(
                "vec4(mx_hsvadjust({0}.rgb, {1}), {0}.a)",
                self.raw(n, 0),
                self.raw(n, 1)
            ),
            "hsvadjust" => format!("mx_hsvadjust({}, {})", self.raw(n, 0), self.raw(n, 1)),
            "luminance" if t.width() == 4 => format!(
                "vec4(vec3(mx_luminance({0}.rgb, {1})), {0}.a)",
                self.raw(n, 0),
                self.raw(n, 1)
            ),
            "luminance" => format!("vec3(mx_luminance({}, {}))", self.raw(n, 0), self.raw(n, 1)),
            "normalmap" => {
                let s = self.raw(n, 1);
                let s = if self.graph.source_ty(&n.inputs[1]).width() == 1 {
                    format!("vec2({s})")
                } else {
                    s
                };
                format!(
                    "mx_normalmap({}, {s}, {}, {}, {})",
                    self.raw(n, 0),
                    self.raw(n, 2),
                    self.raw(n, 3),
                    self.raw(n, 4)
                )
            }
            "heighttonormal" => {
                let f = format!("{}_{i}", self.hfn);
                let g = self.geom;
                let st = Value::float(HEIGHT_STEP).glsl();
                let shifts = [
                    ("u1", format!("{st}, 0.0")),
                    ("u0", format!("-{st}, 0.0")),
                    ("v1", format!("0.0, {st}")),
                    ("v0", format!("0.0, -{st}")),
                ];
                let _ = writeln!(out, "    MxGeom q{i} = {g};");
                for (name, d) in &shifts {
                    let _ = writeln!(
                        out,
                        "    {} float h{name}_{i} = {f}(q{i});",
                        self.shift(i, d)
                    );
                }
                // The texcoord's derivatives in uv: the identity for the uv itself.
                let (tdu, tdv) = if n.inputs[2] == Source::Geom(GeomProp::Uv) {
                    ("vec2(1.0, 0.0)".to_string(), "vec2(0.0, 1.0)".to_string())
                } else {
                    let fc = format!("{}_c{i}", self.hfn);
                    for (name, d) in &shifts {
                        let _ = writeln!(
                            out,
                            "    {} vec2 c{name}_{i} = {fc}(q{i});",
                            self.shift(i, d)
                        );
                    }
                    let inv = Value::float(1.0 / (2.0 * HEIGHT_STEP)).glsl();
                    let _ = writeln!(
                        out,
                        "    precise vec2 cdu_{i} = (cu1_{i} - cu0_{i}) * {inv};\n    precise vec2 cdv_{i} = (cv1_{i} - cv0_{i}) * {inv};"
                    );
                    (format!("cdu_{i}"), format!("cdv_{i}"))
                };
                format!(
                    "mx_height_normal(hu1_{i}, hu0_{i}, hv1_{i}, hv0_{i}, {}, {tdu}, {tdv})",
                    self.raw(n, 1)
                )
            }
            "image" => {
                let g = self.geom;
                let (k, im) = self.graph.image_of(i).expect("image nodes have an image");
                let _ = writeln!(out, "    float fp{i} = {g}.footprint;");
                if n.inputs[3] != Source::Geom(GeomProp::Uv) {
                    let f = format!("{}_t{i}", self.hfn);
                    let st = Value::float(HEIGHT_STEP).glsl();
                    let _ = writeln!(out, "    if (fp{i} > 0.0) {{\n        MxGeom q{i} = {g};");
                    for (name, d) in [
                        ("tu1", format!("{st}, 0.0")),
                        ("tu0", format!("-{st}, 0.0")),
                        ("tv1", format!("0.0, {st}")),
                        ("tv0", format!("0.0, -{st}")),
                    ] {
                        let _ = writeln!(
                            out,
                            "        {} vec2 {name}_{i} = {f}(q{i});",
                            self.shift(i, &d)
                        );
                    }
                    let _ = writeln!(
                        out,
                        "        fp{i} *= mx_texcoord_scale(tu1_{i}, tu0_{i}, tv1_{i}, tv0_{i}, {st});\n    }}"
                    );
                }
                let d = self.raw(n, 2);
                let d4 = match self.graph.source_ty(&n.inputs[2]).width() {
                    1 => format!("vec4({d})"),
                    2 => format!("vec4({d}, 0.0, 0.0)"),
                    3 => format!("vec4({d}, 0.0)"),
                    _ => d,
                };
                format!(
                    "mx_image({}, vec2({}), fp{i}, {}, {}, {d4}).{}",
                    self.slots.get(k).copied().unwrap_or(0),
                    self.raw(n, 3),
                    im.constant[0],
                    im.constant[1],
                    swz(t.width())
                )
            }
            "dotproduct" => format!("mx_dot({}, {})", self.raw(n, 0), self.raw(n, 1)),
            "crossproduct" => format!("mx_cross({}, {})", self.raw(n, 0), self.raw(n, 1)),
            "magnitude" => format!("sqrt(mx_dot({0}, {0}))", self.raw(n, 0)),
            "normalize" => format!("mx_normalize({})", self.raw(n, 0)),
            "convert" => {
                let x = self.raw(n, 0);
                let iw = self.graph.source_ty(&n.inputs[0]).width();
                let w = t.width();
                if iw == 1 {
                    format!("{ty}({x})")
                } else if iw >= w {
                    if w == iw {
                        x
                    } else {
                        format!("{x}.{}", swz(w))
                    }
                } else {
                    let pad: Vec<&str> = (iw..w)
                        .map(|k| if k == 3 { "1.0" } else { "0.0" })
                        .collect();
                    format!("{ty}({x}, {})", pad.join(", "))
                }
            }
            "extract" => format!("{}[{}]", self.raw(n, 0), self.int(n, 1)),
            "combine2" => format!("{ty}({}, {})", self.raw(n, 0), self.raw(n, 1)),
            "combine3" => format!(
                "{ty}({}, {}, {})",
                self.raw(n, 0),
                self.raw(n, 1),
                self.raw(n, 2)
            ),
            other => unreachable!("node `{other}` has a signature but no GLSL"),
        }
    }

    /// SSA statements for `nodes` (only those in `used`).
    fn body(&self, nodes: &[Node], used: &[bool], out: &mut String) {
        for (i, n) in nodes.iter().enumerate() {
            if !used[i] {
                continue;
            }
            let e = self.expr(i, n, out);
            let _ = writeln!(
                out,
                "    precise {} {}{i} = {e}; // {} ({})",
                n.ty().glsl(),
                self.prefix,
                n.name,
                n.sig.def
            );
        }
    }
}

/// Which of the first `n` nodes `s` depends on (the cone of `s`).
fn cone(g: &Graph, s: &Source, n: usize) -> Vec<bool> {
    let mut used = vec![false; n];
    let mut stack: Vec<usize> = match s {
        Source::Node(i) => vec![*i],
        _ => vec![],
    };
    while let Some(i) = stack.pop() {
        if i >= n || used[i] {
            continue;
        }
        used[i] = true;
        for s in &g.nodes[i].inputs {
            if let Source::Node(j) = s {
                stack.push(*j);
            }
        }
    }
    used
}

/// A function `<ty> mxh_<symbol>_<name><i>(MxGeom g)` returning input `k`
/// of node `i` (the nodes it reads re-evaluated for `g`): heighttonormal's
/// height and an image's texture coordinate at shifted uvs.
fn input_helper(
    s: &mut String,
    g: &Graph,
    symbol: &str,
    slots: &[u32],
    i: usize,
    k: usize,
    (ty, name, prefix): (&str, &str, &str),
) {
    let e = Emit {
        graph: g,
        geom: "g",
        prefix: format!("{prefix}{i}_"),
        hfn: format!("mxh_{symbol}"),
        slots,
    };
    let _ = writeln!(s, "{ty} mxh_{symbol}_{name}{i}(MxGeom g) {{");
    let src = &g.nodes[i].inputs[k];
    let used = cone(g, src, i);
    let mut body = String::new();
    e.body(&g.nodes[..i], &used, &mut body);
    s.push_str(&body);
    let _ = writeln!(s, "    return {ty}({});\n}}", e.src(src));
}

/// The GLSL of graph `g` as function `mxg_<symbol>`; its image nodes read
/// texture slots `slots` (one per `g.images`).
pub fn glsl(g: &Graph, symbol: &str, slots: &[u32]) -> String {
    let layout = Layout::of(g);
    let mut s = format!(
        "// MaterialX nodegraph `{}` of {} ({} nodes)\n",
        g.name,
        g.file.replace('\n', " "),
        g.nodes.len()
    );
    // Helpers for heighttonormal: the height input's cone, as its own function.
    for (i, n) in g.nodes.iter().enumerate() {
        if n.op() == "heighttonormal" {
            input_helper(&mut s, g, symbol, slots, i, 0, ("float", "", "h"));
            if n.inputs[2] != Source::Geom(GeomProp::Uv) {
                input_helper(&mut s, g, symbol, slots, i, 2, ("vec2", "c", "c"));
            }
        }
        if n.op() == "image" && n.inputs[3] != Source::Geom(GeomProp::Uv) {
            input_helper(&mut s, g, symbol, slots, i, 3, ("vec2", "t", "t"));
        }
    }
    let e = Emit {
        graph: g,
        geom: "g",
        prefix: "n".into(),
        hfn: format!("mxh_{symbol}"),
        slots,
    };
    let _ = writeln!(
        s,
        "void mxg_{symbol}(in MxGeom g, out float o[{}]) {{",
        layout.floats.max(1)
    );
    let mut all = vec![false; g.nodes.len()];
    for o in &g.outputs {
        for (k, u) in cone(g, &o.source, g.nodes.len()).into_iter().enumerate() {
            all[k] |= u;
        }
    }
    let mut body = String::new();
    e.body(&g.nodes, &all, &mut body);
    s.push_str(&body);
    for (o, (_, ty, off)) in g.outputs.iter().zip(&layout.outputs) {
        let v = e.src(&o.source);
        if ty.width() == 1 {
            let _ = writeln!(s, "    o[{off}] = float({v}); // {}", o.name);
        } else {
            for c in 0..ty.width() {
                let _ = writeln!(s, "    o[{}] = {v}[{c}]; // {}", off + c, o.name);
            }
        }
    }
    if layout.floats == 0 {
        s.push_str("    o[0] = 0.0;\n");
    }
    s.push_str("}\n");
    s
}
