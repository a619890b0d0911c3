//! Regression: the quick-mode numbers of every experiment are pinned in
//! `tests/golden/<id>.csv`. A deliberate change is re-pinned with
//! `cargo xtask bless`, which prints the diff.

use bayestrack_experiments::REGISTRY;

/// Relative tolerance: runs are seeded and bit-reproducible; this only
/// absorbs printing round-off.
const TOL: f64 = 1e-9;

fn cells_match(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x == y || (x - y).abs() <= TOL * x.abs().max(y.abs()),
        _ => a == b,
    }
}

#[test]
fn quick_reproductions_match_their_golden_files() {
    let mut checked = 0;
    for e in REGISTRY.iter().filter(|e| e.implemented()) {
        let Some(now) = e.golden().unwrap_or_else(|err| panic!("{}: {err}", e.id())) else {
            continue;
        };
        let path = format!("{}/tests/golden/{}.csv", env!("CARGO_MANIFEST_DIR"), e.id());
        let pinned = std::fs::read_to_string(&path)
            .unwrap_or_else(|err| panic!("{path}: {err}; run `cargo xtask bless`"));
        let (a, b): (Vec<&str>, Vec<&str>) = (pinned.lines().collect(), now.lines().collect());
        let mut diffs = vec![];
        for i in 0..a.len().max(b.len()) {
            let (x, y) = (
                a.get(i).copied().unwrap_or(""),
                b.get(i).copied().unwrap_or(""),
            );
            let same = x.split(',').count() == y.split(',').count()
                && x.split(',')
                    .zip(y.split(','))
                    .all(|(p, q)| cells_match(p, q));
            if !same {
                diffs.push(format!("line {}:\n  pinned {x}\n  now    {y}", i + 1));
            }
        }
        assert!(
            diffs.is_empty(),
            "{} differs from {path} (if the change is deliberate, run `cargo xtask bless`):\n{}",
            e.id(),
            diffs.join("\n")
        );
        checked += 1;
    }
    assert!(checked >= 1, "no experiment is pinned");
}
