//! Nothing here: the crate holds the criterion benchmarks of wolfpack-core (`benches/step.rs`,
//! run with `cargo bench -p wolfpack-bench --bench step`).
