//! Heavy and light balls landing together (issue 13: hard cases, extreme mass ratios; resting
//! piles): 80 balls of 100 kg and 80 of 1 kg, all 1 m across, fall from up to 30 m into a 20 m
//! wide box and land on each other. Light balls caught between heavy ones are struck to well over
//! 100 m/s, and the position phase pushes them nearly the whole of each overlap. On the lockstep
//! engine no two balls overlap by more than 1 % of a diameter at the end of any step, at every e,
//! through the landing as well as once settled.

mod common;

use ballfield::Lockstep;

/// Over the first 3.5 s (the piles land from 1.7 s on), at e = 0, 0.5, 0.99 and 1, seeds 1 to 8:
/// the largest overlap at the end of any step stays within 1 % of a diameter. Measured
/// (2026-12-07): at most 0.861 % (the position phase stops at 0.51 %; what adds the rest is not
/// traced); the fastest light ball 239 m/s (e = 1).
///
/// Seen to fail with each of the three mechanisms it checks turned off (figures of seed 7, and
/// the worst seed):
/// - without the pairs a struck ball's new path reaches (`reach_struck_balls` in lockstep's
///   contact solver): 9.15 % at e = 0.99, a light ball struck to 176 m/s ending a step 9 % into a
///   ball it had no candidate pair with; with two such balls each beyond its skin and only the
///   grid's places of the others looked at, 3.16 % (seed 2, e = 0.99) and 5.83 % (seed 8, e = 1);
/// - without the pairs the position passes push together (`physics::pushed_together`): 3.06 % at
///   e = 0 (8.0 % at e = 0.5), a light ball pushed by the passes into a neighbour whose pair was
///   listed as apart;
/// - without the pairs of balls the passes push beyond the skin (`reach_pushed_balls`): 24.5 %
///   (seed 8, e = 0.5), a light ball pushed 0.2 m in one step.
///
/// Once settled (after 8 s) every e stayed within 1 % before these changes as well.
#[test]
fn heavy_and_light_balls_land_without_deep_overlaps_at_every_e() {
    let (mut reached, mut pushed) = (0, 0);
    for e in [0.0, 0.5, 0.99, 1.0] {
        let (mut worst, mut at, mut fastest) = (0.0f64, (0, 0.0), 0.0f64);
        for seed in 1..=8 {
            let mut engine = Lockstep::new(&common::heavy_and_light(e, seed));
            for _ in 0..3500 {
                engine.step();
                let d = engine.diagnostics();
                assert_eq!(d.non_finite + d.outside, 0, "e {e}, seed {seed}: a ball went bad or left the field");
                if d.largest_overlap_ratio > worst {
                    (worst, at) = (d.largest_overlap_ratio, (seed, engine.time()));
                }
                fastest = engine.bodies().velocity.iter().fold(fastest, |m, v| m.max(v.length()));
            }
            reached += engine.counters().pairs_reached;
            pushed += engine.counters().pushed_together;
        }
        eprintln!(
            "e {e}: largest overlap {:.3} % of a diameter (seed {}, t = {:.3} s), fastest ball {fastest:.0} m/s",
            100.0 * worst,
            at.0,
            at.1
        );
        assert!(
            worst <= 0.01,
            "e {e}: a pair overlapped by {:.2} % of a diameter (seed {}, t = {:.3} s)",
            100.0 * worst,
            at.0,
            at.1
        );
    }
    // The landings do take these paths: the test checks them, not quieter scenes.
    eprintln!("pairs reached {reached}, pairs pushed together {pushed}");
    assert!(reached > 0, "no ball left the broad phase's skin");
    assert!(pushed > 0, "the position passes pushed no unlisted pair together");
}
