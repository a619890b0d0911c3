//! The integration tests of bayestrack-kalman, one binary: one link and one
//! instantiation of the generics they share (a binary per file cost CI a
//! link and a compile of the same code each). Every file of `tests/` is a
//! module here (`Cargo.toml`: `autotests = false`), and
//! `every_test_file_is_a_module` fails for a file that is not.

mod bad_input;
mod ckf;
mod common;
mod extreme_toolbox;
mod filterpy_imm;
mod fuzz;
mod generic_and_angles;
mod identities;
mod imm;
mod imm_alloc;
mod manifold;
mod noise_form;
mod properties;
mod smoothing;
mod srkf;
mod srukf;
mod statistics;
mod usability;

#[test]
fn every_test_file_is_a_module() {
    bayestrack_testkit::assert_every_test_file_is_a_module(
        concat!(env!("CARGO_MANIFEST_DIR"), "/tests"),
        "integration",
        include_str!("integration.rs"),
    );
}
