//! The examples' shared code: the 2019 report's demo scene, built through the library's
//! public API. The runnable examples are beside this folder (`cargo run -p svo-examples
//! --example NAME`).

pub mod report2019;
