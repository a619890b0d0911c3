//! `Imm::step_into` reuses its output buffers (the crate forbids unsafe
//! code, so no counting allocator here: the whole step's heap use is
//! measured with valgrind on `examples/steps.rs imm_into`, see count.sh)
//! and gives `Imm::step`'s bits.

use bayestrack_kalman::{
    Ckf, Gaussian, Imm, ImmStep, Kf, LinearDynamics, LinearMeasurement, Mode, NoiseModel, SrKf,
    SrUkf, Ukf,
};
use nalgebra::{Matrix2, Vector2, Vector4};

#[test]
fn imm_step_into_reuses_its_buffers_and_gives_the_bits_of_step() {
    let sensor =
        LinearMeasurement::<4, 2>::position_with_noise(Matrix2::identity() * 0.25).unwrap();
    let quiet = LinearDynamics::<4>::constant_velocity(0.1, 0.01, NoiseModel::Discrete).unwrap();
    let agile = LinearDynamics::<4>::constant_velocity(0.1, 5.0, NoiseModel::Discrete).unwrap();
    // every filter kind of the crate, in its own belief form
    let imm = Imm::new(
        vec![
            Box::new(Mode::new(Kf::default(), quiet, sensor)),
            Box::new(Mode::new(Ukf::new(1.0, 2.0, 0.0).unwrap(), agile, sensor)),
            Box::new(Mode::new(SrUkf::new(1.0, 2.0, 0.0).unwrap(), agile, sensor)),
            Box::new(Mode::new(Ckf, quiet, sensor)),
            Box::new(Mode::new(SrKf, agile, sensor)),
        ],
        &[
            0.8, 0.05, 0.05, 0.05, 0.05, //
            0.05, 0.8, 0.05, 0.05, 0.05, //
            0.05, 0.05, 0.8, 0.05, 0.05, //
            0.05, 0.05, 0.05, 0.8, 0.05, //
            0.05, 0.05, 0.05, 0.05, 0.8,
        ],
    )
    .unwrap();
    let start = Gaussian::diagonal(Vector4::zeros(), Vector4::repeat(1.0)).unwrap();
    let mut now = ImmStep {
        belief: imm.start(&[0.2; 5], &start).unwrap(),
        ..ImmStep::default()
    };
    let mut next = ImmStep::default();
    let zs: Vec<Vector2<f64>> = (0..50)
        .map(|k| Vector2::new(0.1 * k as f64, (0.3 * k as f64).sin()))
        .collect();
    // two warm-up steps grow both buffers
    for z in &zs[..2] {
        imm.step_into(&now.belief, Some(z), &mut next).unwrap();
        std::mem::swap(&mut now, &mut next);
    }
    let buffers = |s: &ImmStep<4, 2>| {
        (
            s.belief.probabilities().as_ptr() as usize,
            s.belief.modes().as_ptr() as usize,
            s.innovations.as_ptr() as usize,
        )
    };
    let grown = [buffers(&now), buffers(&next)];
    let mut reference = now.belief.clone();
    for (k, z) in zs[2..].iter().enumerate() {
        // every fourth measurement missing
        let z = (k % 4 != 3).then_some(z);
        let stepped = imm.step(&reference, z).unwrap();
        imm.step_into(&now.belief, z, &mut next).unwrap();
        assert_eq!(next, stepped, "step {k}");
        std::mem::swap(&mut now, &mut next);
        reference = stepped.belief;
        assert!(
            grown.contains(&buffers(&now)) && grown.contains(&buffers(&next)),
            "step {k}: a buffer moved"
        );
    }
    // an error leaves a usable output behind
    let bad = ImmStep::<4, 2>::default();
    assert!(imm.step_into(&bad.belief, None, &mut next).is_err());
    imm.step_into(&now.belief, None, &mut next).unwrap();
    assert_eq!(next, imm.step(&now.belief, None).unwrap());
}
