//! Runnable examples live beside this file; see `cargo run -p svo-examples --example ...`.
