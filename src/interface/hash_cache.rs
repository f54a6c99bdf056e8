//! Interface of shaders/hash_cache/primary.comp (src/methods/hash_cache/):
//! the hash table's bindings ([`super::hash_table::BINDINGS`]) and push
//! constants, then the pixel-centre view depth and first hits that the
//! method's TAA reads (resolve.comp uses the table's interface alone).

use super::hash_table::{BINDINGS, PUSH};
use super::{write, Binding, Interface};

const fn bindings() -> [Binding; 16] {
    let mut b = [write("taa_depth"); 16];
    let mut i = 0;
    while i < BINDINGS.len() {
        b[i] = BINDINGS[i];
        i += 1;
    }
    b[15] = write("taa_fh");
    b
}
const BINDINGS_PRIMARY: [Binding; 16] = bindings();

pub const INTERFACE: Interface = Interface {
    name: "hash_cache",
    set: 1,
    bindings: &BINDINGS_PRIMARY,
    push: &[PUSH],
    // The table's C_HT_* (interface/hash_table.glsl, included by table.glsl).
    counters: &[],
    spec: &[],
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tables_bindings_come_first() {
        assert_eq!(&INTERFACE.bindings[..BINDINGS.len()], &BINDINGS[..]);
    }
}
