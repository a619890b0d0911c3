//! A new particle tracker: a random walk weighed by an RGB-histogram cue on
//! the particle engine, in a `Shell` that checks frames and boxes.
//! `cargo run --release --example custom_tracker [DIR]`

use bayestrack::appearance::{Candidate, HistogramCue, HistogramDistance, RgbHistogram};
use bayestrack::image::BBox;
use bayestrack::otb::{OnBadFrame, Sequence, metrics::score_otb, track_source};
use bayestrack::rand_distr::{Distribution, StandardNormal};
use bayestrack::trackers::{ChannelPolicy, CueFilter, Estimate, InitialBox, Planes, Result};
use bayestrack::trackers::{Shell, StateModel, TrackerCore, TrackerError, select_predict_measure};
use bayestrack::{nalgebra::SVector, particle::Resampling, rand::Rng};

type Corner = SVector<f64, 2>;

/// The box's top-left corner walks 4 px a frame; its box is scored.
#[derive(Default)]
struct Walk {
    size: (f64, f64),
    frame: (usize, usize),
}

impl StateModel<2> for Walk {
    fn predict<R: Rng + ?Sized>(&self, _: usize, x: &Corner, rng: &mut R) -> Corner {
        x + 4.0 * Corner::from_fn(|_, _| StandardNormal.sample(&mut *rng))
    }
    fn candidate(&self, x: &Corner) -> Option<Candidate> {
        let (bbox, (w, h)) = (BBox::new(x[0], x[1], self.size.0, self.size.1), self.frame);
        bbox.to_rect(w, h).map(Candidate::Window)
    }
}

#[derive(Default)]
struct Walker {
    walk: Walk,
    pf: Option<(CueFilter<2>, HistogramCue)>,
}

impl TrackerCore for Walker {
    fn name(&self) -> &'static str {
        "walker"
    }
    fn channels(&self) -> ChannelPolicy {
        ChannelPolicy::Rgb("3 (RGB: the histogram is of colour)")
    }
    fn start(&mut self, frame: &Planes<'_>, target: InitialBox) -> Result<()> {
        let b = target.bbox;
        self.walk.size = (b.width, b.height);
        self.walk.frame = (frame.width(), frame.height());
        let reference = RgbHistogram::from_window(frame.input(), target.rect, 16)?;
        let cue = HistogramCue::new(reference, HistogramDistance::Bhattacharyya, 0.1, 1)?;
        let filter = select_predict_measure(Resampling::Systematic);
        let particles = vec![Corner::new(b.x, b.y); 300];
        self.pf = Some((CueFilter::new(filter, particles, 7)?, cue));
        Ok(())
    }
    fn track(&mut self, frame: &Planes<'_>) -> Result<Estimate> {
        let (pf, cue) = self.pf.as_mut().ok_or(TrackerError::NotInitialised)?;
        let report = pf.step(&self.walk, cue, frame.cues())?;
        let (m, (w, h), n) = (pf.mean(), self.walk.size, pf.len());
        Ok(Estimate {
            bbox: BBox::new(m[0], m[1], w, h),
            pose: None,
            particles: n,
            evaluations: n,
            lost: report.max_log_increment < -18.0, // best distance above 0.6
        })
    }
}

const CROSSING: &str = "../shared/data/sequences/Crossing";
fn main() -> std::result::Result<(), Box<dyn std::error::Error>> {
    let seq = Sequence::open(std::env::args().nth(1).unwrap_or(CROSSING.into()))?;
    let init = seq.initial_box().ok_or("frame 1 has no ground-truth box")?;
    let (mut t, stop) = (Shell::wrap(Walker::default()), OnBadFrame::Stop);
    let run = track_source(&mut t, &mut seq.source(), init, stop, |_| Ok(()))?;
    let auc = score_otb(&run.boxes, &seq.ground_truth)?.auc;
    println!("walker on {}: AUC {auc:.3}, {:.0} fps", seq.name, run.fps());
    Ok(())
}
