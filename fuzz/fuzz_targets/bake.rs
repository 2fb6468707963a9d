//! Fuzz target `bake`: see `crates/svo/tests/common/fuzz_cases.rs` for what it checks.
#![no_main]

#[path = "../../crates/svo/tests/common/exact_sat.rs"]
#[allow(dead_code)]
mod exact_sat;
#[path = "../../crates/svo/tests/common/fuzz_cases.rs"]
#[allow(dead_code)]
mod fuzz_cases;
#[path = "../../crates/svo/tests/common/oracle.rs"]
#[allow(dead_code)]
mod oracle;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_cases::bake(data));
