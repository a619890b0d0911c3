//! The claims of paper 000 (and van der Merwe et al. 2000) that our quick
//! `hikpf` run reproduces, and one that it does not (asserted as measured,
//! so a change that makes it reproduce is noticed). See docs/reproduction.md.

use std::sync::OnceLock;

use bayestrack_experiments::hikpf::{FilterKind, FilterSummary, HikpfConfig, golden_configs, run};

fn results() -> &'static [Vec<FilterSummary>; 2] {
    static CELL: OnceLock<[Vec<FilterSummary>; 2]> = OnceLock::new();
    CELL.get_or_init(|| {
        let [(_, a), (_, b)] = golden_configs();
        let r = |c: &HikpfConfig| run(c, None, false).unwrap().summary();
        [r(&a), r(&b)]
    })
}

fn get(s: &[FilterSummary], k: FilterKind) -> &FilterSummary {
    s.iter().find(|x| x.kind == k).unwrap()
}

fn mean(s: &[FilterSummary], k: FilterKind) -> f64 {
    get(s, k).mean
}

#[test]
fn accuracy_of_every_filter_on_the_quick_runs() {
    // Upper bounds on the mean per-run RMSE over the 20 quick runs: the
    // measured value (in the comment) plus 25-40 %, not the paper's. The
    // runs are seeded, so the bounds only leave room for a legitimate
    // change of random streams; a loss of accuracy fails here even after
    // `cargo xtask bless`.
    use FilterKind::*;
    let bounds = [
        // (filter, default, with the demo's floor)
        (Ekf, 0.50, 0.50),         // 0.391, 0.391
        (Ukf, 0.37, 0.37),         // 0.293, 0.293
        (Pf, 0.060, 0.50),         // 0.0442, 0.397
        (PfMcmc, 0.060, 0.50),     // 0.0428, 0.396
        (PfEkf, 0.28, 0.39),       // 0.215, 0.308
        (PfEkfMcmc, 0.28, 0.39),   // 0.214, 0.312
        (PfUkf, 0.055, 0.090),     // 0.0400, 0.0695
        (PfUkfMcmc, 0.055, 0.095), // 0.0411, 0.0733
        (PfIekf, 0.0075, 0.0075),  // 0.00549, 0.00549
        (Hikpf, 0.0080, 0.0080),   // 0.00599, 0.00599
    ];
    for (k, exact, floored) in bounds {
        for (s, bound) in [(&results()[0], exact), (&results()[1], floored)] {
            let m = mean(s, k);
            assert!(m <= bound, "{}: mean RMSE {m} > {bound}", k.name());
        }
    }
    // The typical run, not only the mean: medians (measured 0.0075,
    // 0.0057, 0.0059) and the spread of the iterated proposals (measured
    // variances 3.8e-7 and 9.0e-7).
    let s = &results()[0];
    assert!(get(s, PfUkf).median <= 0.011, "{:?}", get(s, PfUkf));
    assert!(get(s, PfIekf).median <= 0.0075, "{:?}", get(s, PfIekf));
    assert!(get(s, Hikpf).median <= 0.0080, "{:?}", get(s, Hikpf));
    assert!(get(s, PfIekf).var <= 1.5e-6, "{:?}", get(s, PfIekf));
    assert!(get(s, Hikpf).var <= 3e-6, "{:?}", get(s, Hikpf));
}

#[test]
fn the_metropolis_hastings_move_accepts_some_proposals() {
    // A move that never accepts leaves the MCMC rows equal to their
    // plain rows, which the error bounds cannot see. Measured acceptance
    // (default / floor): PF 0.8 % / 6.0 %, PF-EKF 1.1 % / 5.6 %, PF-UKF
    // 1.0 % / 1.5 %.
    for s in results() {
        for k in [
            FilterKind::PfMcmc,
            FilterKind::PfEkfMcmc,
            FilterKind::PfUkfMcmc,
        ] {
            let a = get(s, k).acceptance;
            assert!((0.004..0.12).contains(&a), "{}: acceptance {a}", k.name());
        }
        assert_eq!(get(s, FilterKind::Pf).acceptance, 0.0);
    }
}

#[test]
fn ekf_and_ukf_reproduce_van_der_merwe_within_15_percent() {
    let s = &results()[0];
    for k in [FilterKind::Ekf, FilterKind::Ukf] {
        let ratio = mean(s, k) / k.van_der_merwe().unwrap();
        assert!(
            (ratio - 1.0).abs() < 0.15,
            "{}: ours/vdM = {ratio}",
            k.name()
        );
    }
    assert!(mean(s, FilterKind::Ukf) < mean(s, FilterKind::Ekf));
}

#[test]
fn better_proposals_give_smaller_errors() {
    let s = &results()[0];
    // PF-UKF beats PF-EKF by 2x or more (both papers)
    assert!(mean(s, FilterKind::PfUkf) * 2.0 <= mean(s, FilterKind::PfEkf));
    // the iterated proposals beat PF-UKF by 2x or more (paper 000)
    assert!(mean(s, FilterKind::PfIekf) * 2.0 <= mean(s, FilterKind::PfUkf));
    assert!(mean(s, FilterKind::Hikpf) * 2.0 <= mean(s, FilterKind::PfUkf));
    // every proposal that uses z_k beats the EKF alone
    for k in [
        FilterKind::PfEkf,
        FilterKind::PfUkf,
        FilterKind::PfIekf,
        FilterKind::Hikpf,
    ] {
        assert!(mean(s, k) < mean(s, FilterKind::Ekf), "{}", k.name());
    }
}

#[test]
fn with_the_demos_likelihood_floor_the_pf_rows_match_van_der_merwe() {
    // The demo adds 1e-99 to linear-domain likelihoods; with that floor the
    // bootstrap PF falls back to its prior whenever every likelihood
    // underflows, which is what van der Merwe's PF row measured.
    let s = &results()[1];
    for k in [FilterKind::Pf, FilterKind::PfEkf, FilterKind::PfUkf] {
        let ratio = mean(s, k) / k.van_der_merwe().unwrap();
        assert!(
            (ratio - 1.0).abs() < 0.25,
            "{}: ours/vdM = {ratio}",
            k.name()
        );
    }
    // "PF-UKF error at most half of PF"
    assert!(mean(s, FilterKind::PfUkf) * 2.0 <= mean(s, FilterKind::Pf));
}

#[test]
fn log_domain_weights_make_the_bootstrap_pf_far_better_than_published() {
    let (exact, floored) = (&results()[0], &results()[1]);
    assert!(mean(exact, FilterKind::Pf) * 4.0 < mean(floored, FilterKind::Pf));
}

#[test]
fn not_reproduced_hikpf_does_not_beat_pf_iekf_by_the_papers_margin() {
    // Paper 000: HIKPF 0.0156 vs PF-IEKF 0.0494 (3.2x). Ours, with the
    // IEKF iterated to convergence (c = 10): within 25% of each other. If
    // this fails, the claim may now reproduce: update docs/reproduction.md.
    let s = &results()[0];
    let ratio = mean(s, FilterKind::PfIekf) / mean(s, FilterKind::Hikpf);
    assert!(ratio > 0.75 && ratio < 1.25, "PF-IEKF / HIKPF = {ratio}");
}

/// The quick runs with `c` = 1 and 2 IEKF iterations (two cells of the
/// sweep that `--full` prints).
fn few_iterations() -> &'static [Vec<FilterSummary>; 2] {
    static CELL: OnceLock<[Vec<FilterSummary>; 2]> = OnceLock::new();
    CELL.get_or_init(|| {
        let r = |c: usize| {
            let config = HikpfConfig {
                iekf_iterations: c,
                ..HikpfConfig::quick()
            };
            run(&config, None, false).unwrap().summary()
        };
        [r(1), r(2)]
    })
}

#[test]
fn with_few_iekf_iterations_hikpf_beats_pf_iekf() {
    // Paper 000's unstated `c`: with c = 1 PF-IEKF is PF-EKF (the IEKF's
    // first iterate is the EKF) and HIKPF keeps its UKF stage; with c = 2
    // HIKPF is about 2.8x better (full scale; the paper: 3.2x). Bounds from
    // the quick runs with margin.
    let [one, two] = few_iterations();
    let pf_ekf = mean(one, FilterKind::PfEkf);
    let ratio = mean(one, FilterKind::PfIekf) / pf_ekf;
    assert!(
        (ratio - 1.0).abs() < 0.05,
        "c = 1: PF-IEKF / PF-EKF = {ratio}"
    );
    let r1 = mean(one, FilterKind::PfIekf) / mean(one, FilterKind::Hikpf);
    let r2 = mean(two, FilterKind::PfIekf) / mean(two, FilterKind::Hikpf);
    assert!(r1 > 10.0, "c = 1: PF-IEKF / HIKPF = {r1}");
    assert!(r2 > 1.5, "c = 2: PF-IEKF / HIKPF = {r2}");
    assert!(mean(two, FilterKind::Hikpf) <= 0.008);
}
