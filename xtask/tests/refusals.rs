//! `cargo xtask` refuses what it would otherwise drop silently or run
//! without bound, saying why (issue 28).

use std::process::Command;

fn xtask(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .output()
        .expect("the xtask binary runs")
}

#[test]
fn reproduce_table_list_refuses_run_options() {
    let o = xtask(&["reproduce-table", "list", "--set", "runs=3"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--set runs=3") && err.contains("runs nothing"),
        "{err}"
    );
    let o = xtask(&["reproduce-table", "list"]);
    assert!(o.status.success());
}

#[test]
fn scenes_with_absurd_frames_are_refused_before_writing() {
    let out = std::env::temp_dir().join(format!("bayestrack-xtask-scenes-{}", std::process::id()));
    let o = xtask(&[
        "scenes",
        "road",
        "--frames",
        "100000000",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("frames"), "{err}");
    assert!(!out.exists());
}
