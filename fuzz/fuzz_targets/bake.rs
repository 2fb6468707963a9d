//! Fuzz target `bake`: see `svo_tests::fuzz_cases` (`tests/src/fuzz_cases.rs`) for what it
//! checks.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| svo_tests::fuzz_cases::bake(data));
