//! No code: this crate only pins the features of dependencies that the `madenet` binary and the
//! Python package (`madenet-py`) share, so that `cargo build --release -p madenet` and maturin's
//! separate `cargo rustc -p madenet-py` resolve them alike and the wheel reuses what the binary
//! build compiled (issue 25; the "workspace-hack" pattern of `rustc-workspace-hack` and
//! `cargo-hakari`). `.ci/feature-drift` checks that the two resolutions still agree.
