//! The integration tests of bayestrack-particle, built as one binary (one link and one
//! instantiation of the generics they share, where one binary per file
//! cost CI a link and a compile of the same code each). Every file of
//! `tests/` is a module here (`Cargo.toml`: `autotests = false`);
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
    let here = include_str!("integration.rs");
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests");
    for entry in std::fs::read_dir(dir).expect("tests/ is readable") {
        let path = entry.expect("tests/ is readable").path();
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let module = path.extension().is_some_and(|e| e == "rs") && stem != "integration"
            || path.join("mod.rs").is_file();
        if module {
            assert!(
                here.contains(&format!("\nmod {stem};\n")),
                "tests/{stem} is not a module of tests/integration.rs: its tests never run"
            );
        }
    }
}
