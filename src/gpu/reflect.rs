//! Reflection of a compiled compute shader: which descriptor bindings its
//! entry point statically uses, and whether it reads or writes each one.
//! The SPIR-V words are parsed here (no dependency), following the
//! specification's physical layout (§2.3: a five-word header, then
//! instructions whose first word is `word_count << 16 | opcode`).
//!
//! A binding is a module-scope `OpVariable` decorated with `DescriptorSet`
//! and `Binding`. Pointers derived from it (`OpAccessChain` and relatives,
//! `OpCopyObject`, `OpSelect`/`OpPhi`, function parameters it is passed to)
//! are followed; `OpLoad` and `OpAtomicLoad` read, `OpStore` and
//! `OpAtomicStore` write, every read-modify-write atomic does both. Any other
//! instruction inside a function that takes such a pointer counts as both
//! (conservative). A binding is *used* when the entry point lists it in its
//! interface (SPIR-V 1.4+ lists every global it references) or any
//! instruction references it (`OpArrayLength` uses without accessing).
//!
//! This is what the shader actually does, whatever its GLSL qualifiers say:
//! [`check_interface`] compares it with the Rust interface (src/interface/),
//! and the pass builder binds and tracks only the bindings a shader uses.

use crate::interface::{Access, Interface};
use std::collections::{HashMap, HashSet};

const MAGIC: u32 = 0x0723_0203;

mod op {
    pub const ENTRY_POINT: u32 = 15;
    pub const EXT_INST: u32 = 12;
    pub const FUNCTION: u32 = 54;
    pub const FUNCTION_PARAMETER: u32 = 55;
    pub const FUNCTION_END: u32 = 56;
    pub const FUNCTION_CALL: u32 = 57;
    pub const VARIABLE: u32 = 59;
    pub const IMAGE_TEXEL_POINTER: u32 = 60;
    pub const LOAD: u32 = 61;
    pub const STORE: u32 = 62;
    pub const COPY_MEMORY: u32 = 63;
    pub const COPY_MEMORY_SIZED: u32 = 64;
    pub const ACCESS_CHAIN: u32 = 65;
    pub const IN_BOUNDS_ACCESS_CHAIN: u32 = 66;
    pub const PTR_ACCESS_CHAIN: u32 = 67;
    pub const ARRAY_LENGTH: u32 = 68;
    pub const IN_BOUNDS_PTR_ACCESS_CHAIN: u32 = 70;
    pub const DECORATE: u32 = 71;
    pub const MEMBER_DECORATE: u32 = 72;
    pub const COPY_OBJECT: u32 = 83;
    pub const SELECT: u32 = 169;
    pub const ATOMIC_LOAD: u32 = 227;
    pub const ATOMIC_STORE: u32 = 228;
    /// OpAtomicExchange ..= OpAtomicXor: read-modify-write, pointer at word 3.
    pub const ATOMIC_RMW: std::ops::RangeInclusive<u32> = 229..=242;
    pub const PHI: u32 = 245;
    pub const LOOP_MERGE: u32 = 246;
    pub const SELECTION_MERGE: u32 = 247;
    pub const SWITCH: u32 = 251;
    pub const ATOMIC_FLAG_TEST_AND_SET: u32 = 318;
    pub const ATOMIC_FLAG_CLEAR: u32 = 319;
    pub const LINE: u32 = 8;
    pub const NO_LINE: u32 = 317;
    /// OpPtrEqual, OpPtrNotEqual, OpPtrDiff: compare pointers, access nothing.
    pub const PTR_COMPARE: std::ops::RangeInclusive<u32> = 401..=403;
    pub const ATOMIC_FMIN_EXT: u32 = 5614;
    pub const ATOMIC_FMAX_EXT: u32 = 5615;
    pub const ATOMIC_FADD_EXT: u32 = 6035;
}

mod decoration {
    pub const NON_WRITABLE: u32 = 24;
    pub const NON_READABLE: u32 = 25;
    pub const BINDING: u32 = 33;
    pub const DESCRIPTOR_SET: u32 = 34;
}

/// How the entry point uses one descriptor binding.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingUse {
    pub set: u32,
    pub binding: u32,
    /// Some instruction reads memory through it.
    pub reads: bool,
    /// Some instruction writes memory through it (stores, atomics).
    pub writes: bool,
    /// The GLSL `readonly` / `writeonly` qualifiers (NonWritable /
    /// NonReadable on the variable or every member of its block).
    pub non_writable: bool,
    pub non_readable: bool,
}

/// The bindings a shader module's entry point uses, by (set, binding).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShaderUse {
    pub bindings: Vec<BindingUse>,
}

impl ShaderUse {
    pub fn get(&self, set: u32, binding: u32) -> Option<&BindingUse> {
        self.bindings
            .iter()
            .find(|b| b.set == set && b.binding == binding)
    }
}

/// SPIR-V bytes as little-endian words.
pub fn words(spirv: &[u8]) -> Result<Vec<u32>, String> {
    if spirv.is_empty() || spirv.len() % 4 != 0 {
        return Err(format!(
            "SPIR-V size {} is not a multiple of 4",
            spirv.len()
        ));
    }
    Ok(spirv
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect())
}

/// The bindings the (one) entry point of `spirv` uses; see the module docs.
pub fn reflect(spirv: &[u8]) -> Result<ShaderUse, String> {
    let words = words(spirv)?;
    if words.len() < 5 || words[0] != MAGIC {
        return Err("not a SPIR-V module (bad magic number)".into());
    }
    let mut insts: Vec<&[u32]> = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        if count == 0 || i + count > words.len() {
            return Err(format!("malformed SPIR-V instruction at word {i}"));
        }
        insts.push(&words[i..i + count]);
        i += count;
    }

    let mut set_of: HashMap<u32, u32> = HashMap::new();
    let mut binding_of: HashMap<u32, u32> = HashMap::new();
    let mut non_writable: HashSet<u32> = HashSet::new();
    let mut non_readable: HashSet<u32> = HashSet::new();
    // struct type -> [members decorated NonWritable, NonReadable]
    let mut member_flags: HashMap<u32, [HashSet<u32>; 2]> = HashMap::new();
    let mut member_count: HashMap<u32, u32> = HashMap::new();
    let mut pointee: HashMap<u32, u32> = HashMap::new();
    let mut var_type: HashMap<u32, u32> = HashMap::new();
    let mut interface: HashSet<u32> = HashSet::new();
    let mut params: HashMap<u32, Vec<u32>> = HashMap::new();
    let mut current_fn: Option<u32> = None;
    // Instructions inside function bodies (the only ones that access memory).
    let mut body: Vec<&[u32]> = Vec::new();
    for ins in &insts {
        let opcode = ins[0] & 0xffff;
        match opcode {
            op::ENTRY_POINT if ins.len() >= 4 => {
                // execution model, id, literal name (nul-terminated, padded), interface ids
                let name_end = (3..ins.len())
                    .find(|&k| ins[k].to_le_bytes().contains(&0))
                    .ok_or("OpEntryPoint without a terminated name")?;
                interface.extend(&ins[name_end + 1..]);
            }
            op::DECORATE if ins.len() >= 3 => match (ins[2], ins.get(3)) {
                (decoration::DESCRIPTOR_SET, Some(&s)) => {
                    set_of.insert(ins[1], s);
                }
                (decoration::BINDING, Some(&b)) => {
                    binding_of.insert(ins[1], b);
                }
                (decoration::NON_WRITABLE, _) => {
                    non_writable.insert(ins[1]);
                }
                (decoration::NON_READABLE, _) => {
                    non_readable.insert(ins[1]);
                }
                _ => {}
            },
            op::MEMBER_DECORATE if ins.len() >= 4 => {
                let e = member_flags.entry(ins[1]).or_default();
                match ins[3] {
                    decoration::NON_WRITABLE => {
                        e[0].insert(ins[2]);
                    }
                    decoration::NON_READABLE => {
                        e[1].insert(ins[2]);
                    }
                    _ => {}
                }
            }
            // OpTypeStruct: result, member types
            30 => {
                member_count.insert(ins[1], ins.len() as u32 - 2);
            }
            // OpTypePointer: result, storage class, type
            32 if ins.len() >= 4 => {
                pointee.insert(ins[1], ins[3]);
            }
            op::VARIABLE if ins.len() >= 4 && current_fn.is_none() => {
                var_type.insert(ins[2], ins[1]);
            }
            op::FUNCTION if ins.len() >= 3 => {
                current_fn = Some(ins[2]);
                params.insert(ins[2], Vec::new());
            }
            op::FUNCTION_PARAMETER if ins.len() >= 3 => {
                if let Some(f) = current_fn {
                    params.entry(f).or_default().push(ins[2]);
                }
            }
            op::FUNCTION_END => current_fn = None,
            _ => {}
        }
        if current_fn.is_some() {
            body.push(ins);
        }
    }

    // Descriptor variables, and every pointer derived from one.
    let vars: Vec<u32> = var_type
        .keys()
        .copied()
        .filter(|v| set_of.contains_key(v) && binding_of.contains_key(v))
        .collect();
    let mut roots: HashMap<u32, Vec<u32>> = vars.iter().map(|&v| (v, vec![v])).collect();
    loop {
        let mut changed = false;
        let mut derive = |result: u32, src: u32, roots: &mut HashMap<u32, Vec<u32>>| {
            let Some(from) = roots.get(&src).cloned() else {
                return;
            };
            let to = roots.entry(result).or_default();
            for r in from {
                if !to.contains(&r) {
                    to.push(r);
                    changed = true;
                }
            }
        };
        for ins in &body {
            let opcode = ins[0] & 0xffff;
            match opcode {
                op::ACCESS_CHAIN
                | op::IN_BOUNDS_ACCESS_CHAIN
                | op::PTR_ACCESS_CHAIN
                | op::IN_BOUNDS_PTR_ACCESS_CHAIN
                | op::COPY_OBJECT
                | op::IMAGE_TEXEL_POINTER
                    if ins.len() >= 4 =>
                {
                    derive(ins[2], ins[3], &mut roots)
                }
                op::SELECT if ins.len() >= 6 => {
                    derive(ins[2], ins[4], &mut roots);
                    derive(ins[2], ins[5], &mut roots);
                }
                op::PHI => {
                    for k in (3..ins.len()).step_by(2) {
                        derive(ins[2], ins[k], &mut roots);
                    }
                }
                op::FUNCTION_CALL if ins.len() >= 4 => {
                    if let Some(ps) = params.get(&ins[3]) {
                        for (p, &arg) in ps.iter().zip(&ins[4..]) {
                            derive(*p, arg, &mut roots);
                        }
                    }
                }
                _ => {}
            }
        }
        if !changed {
            break;
        }
    }

    // Accesses.
    let mut reads: HashSet<u32> = HashSet::new();
    let mut writes: HashSet<u32> = HashSet::new();
    let mut touched: HashSet<u32> = HashSet::new();
    let mark = |id: u32,
                r: bool,
                w: bool,
                reads: &mut HashSet<u32>,
                writes: &mut HashSet<u32>,
                touched: &mut HashSet<u32>| {
        if let Some(vs) = roots.get(&id) {
            for &v in vs {
                touched.insert(v);
                if r {
                    reads.insert(v);
                }
                if w {
                    writes.insert(v);
                }
            }
        }
    };
    for ins in &body {
        let opcode = ins[0] & 0xffff;
        let (rw, operands): (&[(usize, bool, bool)], usize) = match opcode {
            op::LOAD | op::ATOMIC_LOAD => (&[(3, true, false)], 0),
            op::STORE | op::ATOMIC_STORE | op::ATOMIC_FLAG_CLEAR => (&[(1, false, true)], 0),
            op::COPY_MEMORY | op::COPY_MEMORY_SIZED => (&[(1, false, true), (2, true, false)], 0),
            o if op::ATOMIC_RMW.contains(&o)
                || o == op::ATOMIC_FLAG_TEST_AND_SET
                || o == op::ATOMIC_FADD_EXT
                || o == op::ATOMIC_FMIN_EXT
                || o == op::ATOMIC_FMAX_EXT =>
            {
                (&[(3, true, true)], 0)
            }
            op::ARRAY_LENGTH => (&[(3, false, false)], 0),
            // Derivations and pointer comparisons: no access of their own.
            op::ACCESS_CHAIN
            | op::IN_BOUNDS_ACCESS_CHAIN
            | op::PTR_ACCESS_CHAIN
            | op::IN_BOUNDS_PTR_ACCESS_CHAIN
            | op::COPY_OBJECT
            | op::IMAGE_TEXEL_POINTER
            | op::SELECT
            | op::PHI
            | op::FUNCTION_CALL
            | op::FUNCTION
            | op::FUNCTION_PARAMETER
            | op::FUNCTION_END
            | op::VARIABLE => (&[], usize::MAX),
            o if op::PTR_COMPARE.contains(&o) => (&[], usize::MAX),
            // Literals that may look like ids: not scanned.
            op::SWITCH | op::LINE | op::NO_LINE | op::LOOP_MERGE | op::SELECTION_MERGE => {
                (&[], usize::MAX)
            }
            // result type, result, set, instruction literal, operands...
            op::EXT_INST => (&[], 5),
            // Anything else that takes a binding's pointer: read and write.
            _ => (&[], 1),
        };
        for &(k, r, w) in rw {
            if let Some(&id) = ins.get(k) {
                mark(id, r, w, &mut reads, &mut writes, &mut touched);
            }
        }
        if operands != usize::MAX && rw.is_empty() {
            for &id in ins.iter().skip(operands) {
                mark(id, true, true, &mut reads, &mut writes, &mut touched);
            }
        }
    }

    let qualifier = |v: u32, own: &HashSet<u32>, which: usize| {
        if own.contains(&v) {
            return true;
        }
        let Some(block) = var_type.get(&v).and_then(|t| pointee.get(t)) else {
            return false;
        };
        match (member_flags.get(block), member_count.get(block)) {
            (Some(f), Some(&n)) => n > 0 && (0..n).all(|m| f[which].contains(&m)),
            _ => false,
        }
    };
    let mut bindings: Vec<BindingUse> = vars
        .iter()
        .filter(|v| interface.contains(v) || touched.contains(v))
        .map(|&v| BindingUse {
            set: set_of[&v],
            binding: binding_of[&v],
            reads: reads.contains(&v),
            writes: writes.contains(&v),
            non_writable: qualifier(v, &non_writable, 0),
            non_readable: qualifier(v, &non_readable, 1),
        })
        .collect();
    bindings.sort_by_key(|b| (b.set, b.binding));
    Ok(ShaderUse { bindings })
}

/// What a pass does with one binding of its interface, from the reflection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassUse {
    /// Not referenced by the shader: not bound, no barrier.
    Unused,
    /// Referenced without a memory access (`.length()` only): bound, no barrier.
    Bound,
    Read,
    /// Written (and perhaps read).
    Write,
}

impl PassUse {
    pub fn of(b: &BindingUse) -> PassUse {
        match (b.reads, b.writes) {
            (_, true) => PassUse::Write,
            (true, false) => PassUse::Read,
            (false, false) => PassUse::Bound,
        }
    }
}

/// The persistent bindings a shader may write: the scene set's bindings
/// that its interface declares `write` (the material-graph memoization
/// table, src/rt/memo.rs). A pipeline that writes them marks the set's
/// written buffers for the recorder's hazard tracking (ComputePass).
pub fn persistent_writable(set: u32, binding: u32) -> bool {
    let scene = &crate::interface::scene::INTERFACE;
    set == scene.set
        && scene
            .bindings
            .get(binding as usize)
            .is_some_and(|b| b.access == crate::interface::Access::Write)
}

/// Whether the shader writes a binding of a persistent set (one allowed by
/// [`persistent_writable`]).
pub fn writes_persistent(used: &ShaderUse, iface: &Interface) -> bool {
    used.bindings.iter().any(|b| b.set < iface.set && b.writes)
}

/// The shader `pipeline`'s use against `iface`, whose bindings are set
/// `iface.set`; the sets before it are persistent (the scene's) and must
/// not be written (the recorder tracks no hazards on them). Returns the
/// use of each of `iface`'s bindings, or the first mismatch: a binding the
/// shader uses that the interface lacks, one it writes that the interface
/// declares read, a write into a persistent set, a set the pipeline lacks.
pub fn check_interface(
    pipeline: &str,
    used: &ShaderUse,
    iface: &Interface,
) -> Result<Vec<PassUse>, String> {
    let mut uses = vec![PassUse::Unused; iface.bindings.len()];
    for b in &used.bindings {
        if b.set < iface.set {
            if b.writes && !persistent_writable(b.set, b.binding) {
                return Err(format!(
                    "pipeline {pipeline}: the shader writes binding {} of persistent set {}, which passes only read",
                    b.binding, b.set
                ));
            }
            continue;
        }
        if b.set > iface.set {
            return Err(format!(
                "pipeline {pipeline}: the shader uses set {} binding {}; interface {} binds set {} and the persistent sets before it",
                b.set, b.binding, iface.name, iface.set
            ));
        }
        let Some(want) = iface.bindings.get(b.binding as usize) else {
            return Err(format!(
                "pipeline {pipeline}: the shader uses binding {} of set {}, interface {} has {} binding(s)",
                b.binding,
                b.set,
                iface.name,
                iface.bindings.len()
            ));
        };
        if b.writes && want.access == Access::Read {
            return Err(format!(
                "pipeline {pipeline}: the shader writes binding {} `{}`, interface {} declares it read",
                b.binding, want.name, iface.name
            ));
        }
        uses[b.binding as usize] = PassUse::of(b);
    }
    Ok(uses)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interface::{read, write};

    const IFACE: Interface = Interface {
        name: "t",
        set: 1,
        bindings: &[read("a"), write("b")],
        push: &[],
        counters: &[],
        spec: &[],
    };

    fn uses(set: u32, binding: u32, reads: bool, writes: bool) -> ShaderUse {
        ShaderUse {
            bindings: vec![BindingUse {
                set,
                binding,
                reads,
                writes,
                non_writable: false,
                non_readable: false,
            }],
        }
    }

    #[test]
    fn persistent_sets_are_read_only_and_later_sets_do_not_exist() {
        let read_scene = check_interface("p", &uses(0, 7, true, false), &IFACE).unwrap();
        assert_eq!(read_scene, [PassUse::Unused, PassUse::Unused]);
        let e = check_interface("p", &uses(0, 7, true, true), &IFACE).unwrap_err();
        assert!(e.contains("writes binding 7 of persistent set 0"), "{e}");
        let e = check_interface("p", &uses(2, 0, true, false), &IFACE).unwrap_err();
        assert!(e.contains("uses set 2 binding 0"), "{e}");
    }

    #[test]
    fn a_read_binding_may_be_declared_written_not_the_reverse() {
        let u = check_interface("p", &uses(1, 1, true, false), &IFACE).unwrap();
        assert_eq!(u, [PassUse::Unused, PassUse::Read]);
        let e = check_interface("p", &uses(1, 0, false, true), &IFACE).unwrap_err();
        assert!(
            e.contains("writes binding 0 `a`, interface t declares it read"),
            "{e}"
        );
    }

    #[test]
    fn malformed_modules_are_errors_not_panics() {
        assert!(reflect(&[]).is_err());
        assert!(reflect(&[1, 2, 3]).is_err());
        assert!(reflect(&[0u8; 20]).is_err());
        // A header and an instruction claiming more words than there are.
        let mut w = vec![MAGIC, 0x0001_0500, 0, 100, 0, (9 << 16) | 17];
        let bytes: Vec<u8> = w.iter().flat_map(|x| x.to_le_bytes()).collect();
        assert!(reflect(&bytes).is_err());
        w.truncate(5);
        let bytes: Vec<u8> = w.iter().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(reflect(&bytes).unwrap(), ShaderUse::default());
    }
}
