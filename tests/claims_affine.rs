//! The claims of paper 002 (Xu, Gao and Yang 2015) at the paper's scale
//! (300 frames, 5 seeded runs per setting: `cargo xtask reproduce-table
//! affine --full --set readings=false` prints these numbers) under the
//! readings closest to the paper's text (Cock: the camera shakes every
//! frame; Dudek: smooth fast motion with pose change; see
//! `Setting::Cock`, `Setting::Dudek` and docs/reproduction.md, section
//! `affine`). Each bound is two-sided, about the measured value, and the
//! claims that do not reproduce are asserted as measured, so that a change
//! that moves them is noticed. The readings sweep (`--full`) is not run
//! here.
//!
//! Measured at this commit (RMS mean in px, lost share of frames,
//! self-tuning particles per frame):
//! - Cock: HKPF 5.10 / 2 %, ISPF 16.6 / 28 %, self-tuning 20.0 / 20 %
//!   (one run lost from frame 5, four never), 5.2 particles (paper 28.2);
//! - Sylvester: HKPF 5.29 / 3 %, ISPF 3.75 / 19 %, self-tuning 0.90 / 0 %,
//!   6.9 particles against ISPF's 10.5 (paper 9.7 vs 13.2);
//! - Dudek: HKPF 2.91 / 0 %, ISPF 0.69 / 0 %, self-tuning 0.58 / 0 %, 6.8
//!   particles against ISPF's 11.3 (paper 8.6 vs 15.5).

use std::sync::OnceLock;

use bayestrack_experiments::affine::{
    AffineConfig, AffineResult, Claim, Filter, Setting, Summary, run,
};

fn result() -> &'static AffineResult {
    static CELL: OnceLock<AffineResult> = OnceLock::new();
    CELL.get_or_init(|| {
        let config = AffineConfig {
            readings: false,
            timing: false,
            ..AffineConfig::paper()
        };
        run(&config, false).unwrap()
    })
}

fn summary(setting: Setting, filter: Filter) -> Summary {
    result().summary(setting, filter)
}

fn lost(setting: Setting, filter: Filter) -> f64 {
    result().lost_share(setting, filter)
}

fn holds(claim: Claim) -> bool {
    let v = result().verdicts();
    v.iter().find(|v| v.claim == claim).unwrap().holds
}

fn within(v: f64, lo: f64, hi: f64) -> bool {
    (lo..=hi).contains(&v)
}

#[test]
fn cock_vibration_traps_ispf_while_hkpf_tracks_with_150_particles() {
    // Paper sec. 3.2: ISPF is trapped near frame 148; HKPF "could track
    // the target robustly and accurately with as much as 150 particles".
    assert!(holds(Claim::IspfTrappedOnCock));
    assert!(holds(Claim::HkpfTracksCock));
    let (h, i) = (
        lost(Setting::Cock, Filter::Hkpf),
        lost(Setting::Cock, Filter::Ispf),
    );
    assert!(within(h, 0.0, 0.05) && within(i, 0.10, 0.60), "{h} {i}");
    // trapped for good: a run that loses it does not get it back
    let first = summary(Setting::Cock, Filter::Ispf).first_lost;
    assert!(
        first.iter().filter(|f| f.is_some()).count() >= 2,
        "{first:?}"
    );
    let h = summary(Setting::Cock, Filter::Hkpf);
    assert!(within(h.rms[0], 2.0, 10.0) && h.particles == 150.0, "{h:?}");
}

#[test]
fn not_reproduced_the_self_tuning_filter_loses_one_cock_run_of_five() {
    // Paper: on Cock "our PF achieves best performance". Ours: four runs
    // of five track to the end (median RMS 0.55 px), one loses the toy at
    // frame 5, in the first shakes, and never recovers.
    assert!(!holds(Claim::StpfBestOnCock));
    let s = summary(Setting::Cock, Filter::Stpf);
    let lost_runs = s.first_lost.iter().filter(|f| f.is_some()).count();
    assert_eq!(lost_runs, 1, "{s:?}");
    assert!(within(s.rms[1], 0.3, 1.0), "{s:?}");
    assert!(within(lost(Setting::Cock, Filter::Stpf), 0.1, 0.3));
}

#[test]
fn pose_change_on_sylvester_throws_hkpf_off_and_the_self_tuning_filter_holds() {
    // Paper sec. 3.2: HKPF "tracks the target with a big error on
    // orientation"; the self-tuning filter "could follow the target very
    // tightly".
    assert!(holds(Claim::HkpfOffOnSylvester));
    let (h, s) = (
        summary(Setting::Sylvester, Filter::Hkpf),
        summary(Setting::Sylvester, Filter::Stpf),
    );
    assert!(within(h.rms[0], 3.0, 10.0), "{h:?}");
    assert!(within(s.rms[0], 0.5, 1.5) && s.lost_frames == 0.0, "{s:?}");
}

#[test]
fn not_reproduced_ispf_loses_a_fifth_of_sylvester() {
    // Paper: "ISPF solve[s] the problem easily". Ours: its median RMS is
    // the self-tuning filter's (0.89 vs 0.75 px) but it loses the target
    // for 19 % of the frames.
    assert!(!holds(Claim::IspfTracksSylvester));
    let i = summary(Setting::Sylvester, Filter::Ispf);
    assert!(within(i.rms[1], 0.5, 1.5), "{i:?}");
    assert!(within(lost(Setting::Sylvester, Filter::Ispf), 0.08, 0.4));
}

#[test]
fn dudek_fast_motion_hkpf_tracks_with_its_pose_off_and_ispf_matches_the_self_tuning_filter() {
    // Paper sec. 3.3: HKPF "tracks the face in the whole process, but the
    // scale and orientation of the tracking box do not match"; ISPF "is
    // hardly distinguished from our PF".
    assert!(holds(Claim::HkpfTracksDudekPoseOff));
    assert!(holds(Claim::IspfLikeStpfOnDudek));
    let (h, i, s) = (
        summary(Setting::Dudek, Filter::Hkpf),
        summary(Setting::Dudek, Filter::Ispf),
        summary(Setting::Dudek, Filter::Stpf),
    );
    assert!(within(h.rms[0], 1.5, 6.0) && h.lost_frames == 0.0, "{h:?}");
    assert!(within(s.rms[0], 0.3, 1.0) && s.lost_frames == 0.0, "{s:?}");
    assert!(within(i.rms[0], 0.3, 1.2) && i.lost_frames == 0.0, "{i:?}");
}

#[test]
fn the_self_tuning_filter_needs_fewer_particles_than_ispf() {
    // Paper: 9.7 vs 13.2 (Sylvester), 8.6 vs 15.5 (Dudek). Ours: 6.9 vs
    // 10.5 and 6.8 vs 11.3, with fewer pose-estimator calls too.
    assert!(holds(Claim::StpfFewerParticles));
    for (setting, paper) in [(Setting::Sylvester, 9.7), (Setting::Dudek, 8.6)] {
        let (s, i) = (
            summary(setting, Filter::Stpf),
            summary(setting, Filter::Ispf),
        );
        // the paper's count within a factor 2 (a stated band)
        assert!(within(s.particles, paper / 2.0, paper * 2.0), "{s:?}");
        assert!(s.particles <= 0.8 * i.particles, "{s:?} {i:?}");
        assert!(
            s.pose_estimator_calls <= 0.8 * i.pose_estimator_calls,
            "{s:?} {i:?}"
        );
    }
}

#[test]
fn not_reproduced_the_self_tuning_filter_uses_a_fifth_of_the_papers_particles_on_cock() {
    // Paper: 28.2 particles per frame on Cock. Ours: 5.2; a frame stops
    // at its first batch unless a shake throws the target out of the
    // region (docs/reproduction.md).
    assert!(!holds(Claim::StpfParticleCounts));
    let s = summary(Setting::Cock, Filter::Stpf);
    assert!(within(s.particles, 3.0, 10.0), "{s:?}");
}

#[test]
fn particles_per_frame_within_their_bands_on_every_setting() {
    // Paper 002 gives particles per frame (sec. 3.2-3.3, Fig. 8): HKPF
    // 150 / 100 / 50 (fixed), the self-tuning filter 28.2 / 9.7 / 8.6,
    // ISPF - / 13.2 / 15.5. Bands, each two-sided: HKPF's count is the
    // paper's exactly; the self-tuning filter and ISPF within 25 % of
    // the count measured at this commit (the runs are seeded, so the band
    // is headroom for a change of code that keeps the filters, not for
    // noise), and, where the paper gives a count and ours reproduces it,
    // within half to twice the paper's.
    let measured = [
        // (setting, self-tuning, ISPF), measured
        (Setting::Cock, 5.2, 9.9),
        (Setting::Sylvester, 6.9, 10.5),
        (Setting::Dudek, 6.8, 11.3),
    ];
    for (setting, stpf, ispf) in measured {
        let [hkpf_paper, ispf_paper, stpf_paper] = setting.paper_particles();
        let h = summary(setting, Filter::Hkpf);
        assert_eq!(Some(h.particles), hkpf_paper, "{h:?}");
        let s = summary(setting, Filter::Stpf);
        assert!(within(s.particles, 0.75 * stpf, 1.25 * stpf), "{s:?}");
        let i = summary(setting, Filter::Ispf);
        assert!(within(i.particles, 0.75 * ispf, 1.25 * ispf), "{i:?}");
        if setting != Setting::Cock {
            // (Cock's 28.2 is not reproduced: see the test above)
            let (sp, ip) = (stpf_paper.unwrap(), ispf_paper.unwrap());
            assert!(within(s.particles, sp / 2.0, sp * 2.0), "{s:?}");
            assert!(within(i.particles, ip / 2.0, ip * 2.0), "{i:?}");
        }
    }
}
