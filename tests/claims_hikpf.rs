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

fn mean(s: &[FilterSummary], k: FilterKind) -> f64 {
    s.iter().find(|x| x.kind == k).unwrap().mean
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
    // Paper 000: HIKPF 0.0156 vs PF-IEKF 0.0494 (3.2x). Ours: within 25% of
    // each other. If this fails, the claim may now reproduce: update
    // docs/reproduction.md.
    let s = &results()[0];
    let ratio = mean(s, FilterKind::PfIekf) / mean(s, FilterKind::Hikpf);
    assert!(ratio > 0.75 && ratio < 1.25, "PF-IEKF / HIKPF = {ratio}");
}
