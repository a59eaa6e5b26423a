//! Feature unification between jeffcott's test build and its Python wheel's build; see
//! this crate's Cargo.toml. It has no code.
