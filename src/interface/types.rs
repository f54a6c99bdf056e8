//! The vocabulary of the shader interface (see the module docs of
//! `crate::interface`). Plain Rust without dependencies: build.rs compiles it too.

/// How a pass uses one of its storage buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Only read (`readonly` in GLSL); declared with `.read(&buffer)`.
    Read,
    /// Written, perhaps also read; declared with `.write(&buffer)`.
    Write,
}

impl Access {
    pub const fn word(self) -> &'static str {
        match self {
            Access::Read => "read",
            Access::Write => "write",
        }
    }
}

/// One storage buffer of a pass, at the binding given by its position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Binding {
    /// snake_case; the GLSL constant is `B_<GROUP>_<NAME>`.
    pub name: &'static str,
    pub access: Access,
}

/// A buffer the pass only reads.
pub const fn read(name: &'static str) -> Binding {
    Binding {
        name,
        access: Access::Read,
    }
}

/// A buffer the pass writes (and may read).
pub const fn write(name: &'static str) -> Binding {
    Binding {
        name,
        access: Access::Write,
    }
}

/// GLSL types a push-constant field may have (std430 offsets; push
/// constants are laid out like std430 blocks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PushType {
    U32,
    I32,
    F32,
    Vec2,
    UVec2,
    Vec4,
    UVec4,
}

impl PushType {
    pub const fn glsl(self) -> &'static str {
        match self {
            PushType::U32 => "uint",
            PushType::I32 => "int",
            PushType::F32 => "float",
            PushType::Vec2 => "vec2",
            PushType::UVec2 => "uvec2",
            PushType::Vec4 => "vec4",
            PushType::UVec4 => "uvec4",
        }
    }
    /// (size, alignment) in bytes.
    pub const fn size_align(self) -> (u32, u32) {
        match self {
            PushType::U32 | PushType::I32 | PushType::F32 => (4, 4),
            PushType::Vec2 | PushType::UVec2 => (8, 8),
            PushType::Vec4 | PushType::UVec4 => (16, 16),
        }
    }
}

/// One push-constant field: (name, type).
pub type PushField = (&'static str, PushType);

/// A push-constant block. The header defines `<NAME>_PUSH` as its fields,
/// so a shader writes `layout(push_constant) uniform Push { NAME_PUSH } pc;`;
/// the Rust side is a `#[repr(C)]` Pod struct whose size is asserted
/// against [`PushBlock::size`] at compile time.
#[derive(Clone, Copy, Debug)]
pub struct PushBlock {
    /// SCREAMING_CASE macro prefix, e.g. `REFERENCE_TRACE`.
    pub name: &'static str,
    pub fields: &'static [PushField],
}

impl PushBlock {
    /// Size in bytes with std430 alignment, rounded up to the block's alignment.
    pub const fn size(&self) -> u32 {
        let mut offset = 0u32;
        let mut max_align = 4u32;
        let mut i = 0;
        while i < self.fields.len() {
            let (size, align) = self.fields[i].1.size_align();
            offset = offset.div_ceil(align) * align + size;
            if align > max_align {
                max_align = align;
            }
            i += 1;
        }
        offset.div_ceil(max_align) * max_align
    }
}

/// Counter slots of one `uint counters[]` buffer, from [`counter_slots!`].
#[derive(Clone, Copy, Debug)]
pub struct CounterTable {
    /// The GLSL constant is `C_<PREFIX>_<NAME>`.
    pub prefix: &'static str,
    /// SCREAMING_CASE names by slot.
    pub names: &'static [&'static str],
}

/// A typed counter slot (an enum made by [`counter_slots!`]).
pub trait CounterSlot: Copy + 'static {
    const ALL: &'static [Self];
    const TABLE: CounterTable;
    fn slot(self) -> usize;
    /// The name in frames.jsonl's counters, None for slots the method
    /// reports in another form (ray counts, sums turned into means).
    fn report_name(self) -> Option<&'static str>;
}

/// Declares a counter enum: `Variant = "GLSL_NAME"` (not reported) or
/// `Variant = "GLSL_NAME" => "report_name"`; slots are numbered in order.
#[macro_export]
macro_rules! counter_slots {
    ($(#[$m:meta])* $vis:vis enum $name:ident ($prefix:literal) {
        $($(#[$vm:meta])* $v:ident = $g:literal $(=> $report:literal)?),* $(,)?
    }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[repr(u32)]
        #[allow(clippy::enum_variant_names)]
        $vis enum $name { $($(#[$vm])* $v),* }
        impl $crate::interface::CounterSlot for $name {
            const ALL: &'static [$name] = &[$($name::$v),*];
            const TABLE: $crate::interface::CounterTable = $crate::interface::CounterTable {
                prefix: $prefix,
                names: &[$($g),*],
            };
            fn slot(self) -> usize {
                self as usize
            }
            fn report_name(self) -> Option<&'static str> {
                match self {
                    $($name::$v => $crate::counter_slots!(@report $($report)?)),*
                }
            }
        }
    };
    (@report) => { None };
    (@report $r:literal) => { Some($r) };
}

/// The interface of one group of shaders that share a binding list.
#[derive(Clone, Copy, Debug)]
pub struct Interface {
    /// lower_snake group name: the header is `interface/<name>.glsl`, the
    /// binding constants `B_<NAME>_<BINDING>`.
    pub name: &'static str,
    /// Descriptor set of the per-pass buffers (pushed per pass); the sets
    /// before it are persistent (the scene's set 0).
    pub set: u32,
    pub bindings: &'static [Binding],
    pub push: &'static [PushBlock],
    pub counters: &'static [CounterTable],
    /// Specialization constants: (SCREAMING name, constant_id).
    pub spec: &'static [(&'static str, u32)],
}

impl Interface {
    /// Binding number of `name` (compile-time lookup for Rust code that
    /// needs one, e.g. for error messages).
    pub const fn binding(&self, name: &str) -> u32 {
        let mut i = 0;
        while i < self.bindings.len() {
            if str_eq(self.bindings[i].name, name) {
                return i as u32;
            }
            i += 1;
        }
        panic!("no such binding")
    }
}

const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}
