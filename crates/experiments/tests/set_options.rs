//! Property tests of `--set key=value` parsing: any key and any value give
//! either a typed error or options whose every number is finite.

use bayestrack_experiments::ExperimentError;
use bayestrack_experiments::affine::AffineConfig;
use bayestrack_experiments::ball::BallOptions;
use bayestrack_experiments::condensation::CondensationConfig;
use bayestrack_experiments::correlation::CorrelationConfig;
use bayestrack_experiments::hikpf::HikpfConfig;
use proptest::prelude::*;

/// The case count: `n`, or `PROPTEST_CASES` when set.
fn cases(n: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(n)
}

const KEYS: &[&str] = &[
    // hikpf
    "runs",
    "particles",
    "steps",
    "seed",
    "sin_freq",
    "iekf_iterations",
    "iekf_tolerance",
    "error",
    "prior",
    "proposal_noise",
    "hybrid_prior",
    "likelihood_floor",
    "sweep",
    "resampling",
    // ball
    "seconds",
    "motion_noise",
    "bounce_noise",
    "lost_radius",
    "found_radius",
    "rt_elapsed",
    "model",
    "acceleration_noise",
    "initial_speed",
    "measurement_noise",
    "search_margin",
    "likelihood_sigma",
    "lost_distance",
    "bins",
    "ukf_alpha",
    "ukf_beta",
    "ukf_kappa",
    "budget",
    "speed",
    "exposure",
    "flicker",
    "auto_exposure",
    "frame_jitter",
    "jpeg_quality",
    "webcam",
    "sweep_speeds",
    "sweep_noises",
    "sweep_runs",
    "sweep_seconds",
    // correlation
    "scene_seed",
    "mad_margin",
    "sigma",
    "spread",
    "b",
    "gain",
    "printed_b",
    "cap",
    "const_b",
];

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        (-1e3f64..1e3).prop_map(|v| v.to_string()),
        any::<u64>().prop_map(|v| v.to_string()),
        prop::sample::select(vec![
            "inf",
            "-inf",
            "NaN",
            "nan",
            "infinity",
            "1e309",
            "-0",
            "0",
            "1",
            "true",
            "false",
            "rmse",
            "eq11",
            "transition",
            "demo",
            "moments",
            "predicted",
            "posterior",
            "systematic",
            "multinomial",
            "matched",
            "linear",
            "",
            " ",
            "18446744073709551616",
        ])
        .prop_map(String::from),
        "\\PC{0,12}",
    ]
}

/// Every number in a `describe()` line is finite.
fn finite_line(line: &str) -> bool {
    let lower = line.to_ascii_lowercase();
    !lower.contains("nan") && !lower.contains("inf")
}

fn typed(e: &ExperimentError) -> bool {
    matches!(e, ExperimentError::BadOption { .. })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(512), ..ProptestConfig::default() })]

    #[test]
    fn any_option_is_applied_finite_or_refused(
        sets in prop::collection::vec((prop_oneof![3 => prop::sample::select(KEYS).prop_map(String::from), 1 => "\\PC{0,8}"], value()), 1..4),
    ) {
        let mut hikpf = HikpfConfig::quick();
        let mut ball = BallOptions::quick();
        let mut corr = CorrelationConfig::quick();
        for (k, v) in &sets {
            match hikpf.apply(k, v) {
                Ok(()) => prop_assert!(finite_line(&hikpf.describe()), "hikpf {k}={v}: {}", hikpf.describe()),
                Err(e) => prop_assert!(typed(&e), "{e}"),
            }
            match ball.apply(k, v) {
                Ok(()) => prop_assert!(finite_line(&ball.describe()), "ball {k}={v}: {}", ball.describe()),
                Err(e) => prop_assert!(typed(&e), "{e}"),
            }
            match corr.apply(k, v) {
                Ok(()) => prop_assert!(finite_line(&corr.describe()), "correlation {k}={v}: {}", corr.describe()),
                Err(e) => prop_assert!(typed(&e), "{e}"),
            }
        }
    }
}

#[test]
fn a_bad_key_lists_the_valid_keys_and_a_bad_value_names_its_domain() {
    let e = HikpfConfig::quick().apply("foo", "1").unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("`foo=1` for hikpf; valid keys: runs (1..=100000)"),
        "{msg}"
    );
    assert!(
        msg.contains("particles") && msg.contains("resampling"),
        "{msg}"
    );
    let msg = BallOptions::quick()
        .apply("model", "curved")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("bad value `model=curved` for ball: expected matched|linear"),
        "{msg}"
    );
    let msg = CorrelationConfig::quick()
        .apply("runs", "x")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("bad value `runs=x` for correlation: expected 1..=100000"),
        "{msg}"
    );
    assert!(!msg.contains("valid keys"), "{msg}");
    let msg = AffineConfig::quick()
        .apply("fames", "3")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("for affine; valid keys: frames"), "{msg}");
    let msg = CondensationConfig::quick()
        .apply("frames", "1")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("bad value `frames=1` for condensation: expected"),
        "{msg}"
    );
}

/// Values each option's domain admits but the run would refuse later (or
/// run without bound on) are refused when they are set (issue 28).
#[test]
fn values_the_run_would_refuse_are_refused_when_set() {
    let refused = |r: Result<(), ExperimentError>, says: &str| match r {
        Err(e @ ExperimentError::BadOption { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(says), "{msg}");
            assert!(!msg.contains("000000000"), "a 300-digit number: {msg}");
        }
        other => panic!("expected a refusal saying {says:?}, got {other:?}"),
    };
    refused(
        HikpfConfig::quick().apply("iekf_tolerance", "-1"),
        "iekf_tolerance",
    );
    let mut big = HikpfConfig::quick();
    big.apply("runs", "100000").unwrap();
    refused(big.apply("steps", "1000000"), "particle steps");
    refused(BallOptions::quick().apply("seconds", "1e-300"), "seconds");
    refused(
        BallOptions::quick().apply("sweep_seconds", "0.01"),
        "sweep_seconds",
    );
    refused(BallOptions::quick().apply("ukf_kappa", "-4"), "kappa");
    refused(BallOptions::quick().apply("ukf_alpha", "1e-300"), "alpha");
    refused(BallOptions::quick().apply("ukf_alpha", "1e-160"), "alpha");
    refused(AffineConfig::quick().apply("max_particles", "1"), "batch");
    refused(
        AffineConfig::quick().apply("hkpf_particles", "1000000"),
        "HKPF: invalid parameter particles",
    );
    let mut big = AffineConfig::quick();
    big.apply("frames", "300").unwrap();
    refused(big.apply("runs", "100000"), "particle-frames");
    // the entering scene has 90 frames after the entry: more were cut
    // silently; a lock-on longer than the window could never be counted
    refused(
        CondensationConfig::quick().apply("reinit_frames", "91"),
        "reinit_frames = 91",
    );
    refused(
        CondensationConfig::quick().apply("lock_frames", "46"),
        "lock_frames = 46",
    );
    let mut big = CondensationConfig::quick();
    big.apply("frames", "1000").unwrap();
    refused(big.apply("runs", "100000"), "frames (all scenes)");
    // what a run accepts stays accepted
    BallOptions::quick().apply("ukf_kappa", "-3").unwrap();
    BallOptions::quick().apply("ukf_alpha", "1e-3").unwrap();
    HikpfConfig::quick().apply("iekf_tolerance", "0").unwrap();
    AffineConfig::quick().apply("max_particles", "5").unwrap();
    AffineConfig::quick()
        .apply("hkpf_particles", "65536")
        .unwrap();
}

#[test]
fn absurd_values_are_refused_not_run() {
    let refused =
        |r: Result<(), ExperimentError>| matches!(r, Err(ExperimentError::BadOption { .. }));
    assert!(refused(HikpfConfig::quick().apply("runs", "100001")));
    assert!(refused(HikpfConfig::quick().apply("steps", "1000001")));
    assert!(refused(HikpfConfig::quick().apply("particles", "1000001")));
    assert!(refused(BallOptions::quick().apply("runs", "100001")));
    assert!(refused(BallOptions::quick().apply("seconds", "1e300")));
    assert!(refused(BallOptions::quick().apply("seconds", "86401")));
    assert!(refused(
        BallOptions::quick().apply("search_margin", "100000")
    ));
    assert!(refused(CorrelationConfig::quick().apply("runs", "100001")));
    assert!(refused(
        CorrelationConfig::quick().apply("mad_margin", "100000")
    ));
    assert!(refused(AffineConfig::quick().apply("frames", "1000001")));
    assert!(refused(AffineConfig::quick().apply("runs", "100001")));
    assert!(refused(
        CondensationConfig::quick().apply("frames", "1000001")
    ));
    assert!(refused(CondensationConfig::quick().apply("runs", "100001")));
    // the limits themselves are accepted
    assert!(HikpfConfig::quick().apply("runs", "100000").is_ok());
    assert!(BallOptions::quick().apply("seconds", "86400").is_ok());
    assert!(AffineConfig::quick().apply("frames", "1000000").is_ok());
    assert!(
        CondensationConfig::quick()
            .apply("frames", "1000000")
            .is_ok()
    );
}
