//! Only tells cargo to rebuild this crate (and so the extension above it) when
//! `WOLFPACK_PGO` changes: rust/pgo/rustc-wrapper reads it to decide whether to add the
//! profile-guided optimisation flag, which cargo cannot see in its own fingerprints. A change
//! of the profile itself needs nothing here: rustc lists the profile among the build's inputs.
fn main() {
    println!("cargo::rerun-if-env-changed=WOLFPACK_PGO");
}
