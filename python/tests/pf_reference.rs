//! The Rust side of "a built-in model run from Python equals the Rust run
//! bit for bit": [`pf_models::reference_run`] (the Rust API: `Smc` with
//! `Bootstrap` on paper 000's model) on the measurements stored in
//! data/pf_reference.txt must reproduce the means, ESSs and log evidences
//! stored next to them, which test_particle.py checks the Python run
//! against. `BLESS=1 cargo test -p bayestrack-py --test pf_reference`
//! rewrites the stored results (after a deliberate change of the particle
//! crate's streams).
//!
//! The model file is compiled into this test directly: the extension
//! module itself (a cdylib whose Python symbols resolve at import time)
//! cannot be linked into a test binary.

#[path = "../src/pf_models.rs"]
#[allow(dead_code)]
mod pf_models;

use std::path::PathBuf;

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/pf_reference.txt")
}

/// The header line with `n=` and `seed=`, and the rows of f64 bits.
fn read() -> (String, usize, u64, Vec<[f64; 4]>) {
    let text = std::fs::read_to_string(path()).expect("read data/pf_reference.txt");
    let mut lines = text.lines();
    let header = lines.next().expect("a header").to_string();
    let field = |name: &str| -> u64 {
        let rest = header
            .split(name)
            .nth(1)
            .expect("n= and seed= in the header");
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        digits.parse().expect("a number")
    };
    let (n, seed) = (field("n=") as usize, field("seed="));
    let rows = lines
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|h| f64::from_bits(u64::from_str_radix(h, 16).expect("hex bits")))
                .collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect();
    (header, n, seed, rows)
}

#[test]
fn reference_run_matches_the_stored_vector() {
    let (header, n, seed, rows) = read();
    let zs: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let run = pf_models::reference_run(n, seed, &zs).expect("the reference run steps");
    if std::env::var_os("BLESS").is_some() {
        let mut s = format!("{header}\n");
        for (z, r) in zs.iter().zip(&run) {
            s.push_str(&format!(
                "{:016x} {:016x} {:016x} {:016x}\n",
                z.to_bits(),
                r[0].to_bits(),
                r[1].to_bits(),
                r[2].to_bits()
            ));
        }
        std::fs::write(path(), s).expect("write the reference");
        return;
    }
    assert_eq!(run.len(), rows.len());
    for (k, (r, stored)) in run.iter().zip(&rows).enumerate() {
        for (j, name) in ["mean", "ess", "log_evidence"].iter().enumerate() {
            assert_eq!(
                r[j].to_bits(),
                stored[j + 1].to_bits(),
                "step {}: {name} {} != stored {}",
                k + 1,
                r[j],
                stored[j + 1]
            );
        }
    }
}

#[test]
fn reference_run_follows_the_measurements() {
    // the stored run is a working filter: h(estimate) within 0.1 of z
    // at every step (z's noise is 0.003; the model's h is x^2 / 5, then
    // x / 2 - 2)
    let (_, n, seed, rows) = read();
    let zs: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let run = pf_models::reference_run(n, seed, &zs).unwrap();
    for (k, (z, r)) in zs.iter().zip(&run).enumerate() {
        let h = pf_models::Hikpf::observe(r[0], k + 2);
        assert!(
            (h - z).abs() < 0.1,
            "step {}: h(mean) = {h}, z = {z}",
            k + 1
        );
        assert!(r[1] >= 1.0 && r[1] <= n as f64);
    }
}
