//! Track a real OTB sequence with any registered tracker and score it. The
//! frames stream from the folder one at a time (`Sequence::source`); a
//! video decoder or a camera plugs in the same way, as a `FrameSource`.
//!
//! `cargo run --release --example track_sequence -- ../shared/data/sequences/Crossing ncc-scale`

use bayestrack::otb::{OnBadFrame, Sequence, metrics::score_otb, track_source};
use bayestrack::trackers::build_tracker;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = args
        .next()
        .unwrap_or_else(|| "../shared/data/sequences/Crossing".into());
    let name = args.next().unwrap_or_else(|| "ncc-scale".into());

    let seq = Sequence::open(&dir)?;
    let init = seq.initial_box().ok_or("frame 1 has no ground-truth box")?;
    let mut tracker = build_tracker(&name, 0)?;
    let run = track_source(
        tracker.as_mut(),
        &mut seq.source(),
        init,
        OnBadFrame::Stop,
        |_| Ok(()),
    )?;
    let score = score_otb(&run.boxes, &seq.ground_truth)?;
    println!(
        "{name} on {}: AUC {:.3}, precision at 20 px {:.3}, {:.0} fps",
        seq.name,
        score.auc,
        score.precision_20,
        run.fps()
    );
    Ok(())
}
