//! The integration tests of bayestrack-particle, one binary: one link and one
//! instantiation of the generics they share (a binary per file cost CI a
//! link and a compile of the same code each). Every file of `tests/` is a
//! module here (`Cargo.toml`: `autotests = false`), and
//! `every_test_file_is_a_module` fails for a file that is not.

mod filter;
mod fuzz;
mod pmmh;
mod rbpf;
mod resampling;
mod time_and_keys;
mod toolbox;
mod toolbox_fuzz;

#[test]
fn every_test_file_is_a_module() {
    bayestrack_testkit::assert_every_test_file_is_a_module(
        concat!(env!("CARGO_MANIFEST_DIR"), "/tests"),
        "integration",
        include_str!("integration.rs"),
    );
}
