//! Drawing ancestors from a weighted set without replacing it: selection
//! for schemes whose next generation is not the set resampled in place
//! (a different number of children, or children added to a growing pool
//! batch by batch, as in the self-tuning particle filters of paper 002).

use rand::Rng;

use crate::error::Result;
use crate::resample::Resampler;
use crate::set::ParticleSet;

impl<T: Clone> ParticleSet<T> {
    /// Draws `ancestors.len()` indices into the set with probabilities
    /// proportional to its weights, by `scheme`, and leaves the particles
    /// and weights as they are (unlike [`ParticleSet::resample`], which
    /// draws `N` and replaces the set by them). The caller builds the
    /// children from `particles()[ancestors[j]]`. Allocation-free once the
    /// set has been stepped or drawn from (the weights go through the set's
    /// step buffer, hence `&mut`).
    ///
    /// With `ancestors.len() == N` the indices are those
    /// [`ParticleSet::resample`] would gather from the same stream.
    ///
    /// # Errors
    /// As [`Resampler::resample`]; no draw is written on error.
    pub fn draw_ancestors<S: Resampler, R: Rng + ?Sized>(
        &mut self,
        scheme: &S,
        rng: &mut R,
        ancestors: &mut [usize],
    ) -> Result<()> {
        let mut weights = std::mem::take(&mut self.scratch.weights);
        self.weights_into(&mut weights);
        let drawn = scheme.resample(&weights, rng, ancestors);
        self.scratch.weights = weights;
        drawn
    }
}

#[cfg(test)]
mod tests {
    use crate::{ParticleError, ParticleSet, Resampler, Resampling, stream_rng};

    #[test]
    fn draws_any_number_of_ancestors_and_leaves_the_set_alone() {
        let lw = vec![0.0, f64::NEG_INFINITY, 2.0_f64.ln(), 1.0_f64.ln()];
        let mut set = ParticleSet::from_log_weights(vec![10, 11, 12, 13], lw).unwrap();
        let before = set.clone();
        for scheme in Resampling::ALL {
            for m in [1, 3, 4, 7, 4000] {
                let mut a = vec![usize::MAX; m];
                set.draw_ancestors(&scheme, &mut stream_rng(&[5, m as u64]), &mut a)
                    .unwrap();
                assert_eq!(set, before, "{scheme:?}");
                assert!(a.iter().all(|&i| i < 4 && i != 1), "{scheme:?}: {a:?}");
                if m == 4000 {
                    // weights 1 : 0 : 2 : 1 of 4
                    let share = |i| a.iter().filter(|&&j| j == i).count() as f64 / m as f64;
                    for (i, w) in [(0, 0.25), (2, 0.5), (3, 0.25)] {
                        assert!((share(i) - w).abs() < 0.04, "{scheme:?} {i}: {}", share(i));
                    }
                }
            }
        }
    }

    #[test]
    fn is_the_resampler_on_the_normalised_weights() {
        // the same draws as the scheme itself on weights() (and, for N
        // draws, as resample's gathering)
        let lw: Vec<f64> = (0..9).map(|i| -0.3 * f64::from(i)).collect();
        let particles: Vec<usize> = (0..9).collect();
        let mut set = ParticleSet::from_log_weights(particles, lw).unwrap();
        for scheme in Resampling::ALL {
            let mut a = vec![0; 5];
            set.draw_ancestors(&scheme, &mut stream_rng(&[1]), &mut a)
                .unwrap();
            let mut b = vec![0; 5];
            scheme
                .resample(&set.weights(), &mut stream_rng(&[1]), &mut b)
                .unwrap();
            assert_eq!(a, b, "{scheme:?}");
            let mut n = vec![0; 9];
            set.draw_ancestors(&scheme, &mut stream_rng(&[2]), &mut n)
                .unwrap();
            let mut copy = set.clone();
            let mut gathered = Vec::new();
            copy.resample(&scheme, &mut stream_rng(&[2]), &mut gathered)
                .unwrap();
            assert_eq!(n, gathered, "{scheme:?}");
            assert_eq!(copy.particles(), &n[..], "{scheme:?}");
        }
    }

    #[test]
    fn an_empty_draw_is_fine_and_errors_are_the_resamplers() {
        let mut set = ParticleSet::new(vec![1.0, 2.0]).unwrap();
        set.draw_ancestors(&Resampling::Systematic, &mut stream_rng(&[0]), &mut [])
            .unwrap();
        let mut set =
            ParticleSet::from_log_weights(vec![1, 2], vec![0.0, f64::NEG_INFINITY]).unwrap();
        let (_, lw) = set.parts_mut();
        lw[0] = f64::NEG_INFINITY;
        let mut a = [7; 3];
        assert!(matches!(
            set.draw_ancestors(&Resampling::Multinomial, &mut stream_rng(&[0]), &mut a),
            Err(ParticleError::AllWeightsZero { count: 2 })
        ));
        assert_eq!(a, [7; 3]);
    }
}
