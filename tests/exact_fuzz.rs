//! The exact engine under random scenes and commands: 16 seeded scenes (2–30 balls of random
//! sizes and masses at random places — overlaps included —, random restitution, gravity or not)
//! driven for 5 s with the window's commands at random (the pull on and off, balls added at a
//! free spot and removed, the key ball thrown and made heavier or lighter, the restitutions
//! changed). Nothing panics, no ball leaves the field or turns non-finite, no pair overlaps, and
//! every run ends.
//!
//! Measured: at most 1.8e-15 m of overlap, at most 33,008 events in a run. Bounds: 1e-9 m, 2e5.
//!
//! Seen to fail on a broken build: the walls predicted for the cells one in from the edge instead
//! of the edge's (27 balls of the first scene leave the field). With `World::separate_overlaps`
//! skipped it still passes: the event rule lets the overlapping pairs the random places make part.

use ballfield::engine::{Engine, ExactEngine, Placement};
use ballfield::physics::{Ball, BallId, BallKind, Collisions, Effects, Field, Gravity};
use glam::DVec2;

#[test]
fn random_scenes_and_commands_keep_the_balls_whole_and_inside() {
    let (mut most_overlap, mut most_events) = (0.0f64, 0u64);
    for seed in 0..16u64 {
        let mut r = Placement::new(seed * 7919 + 1);
        let mut u = || r.next_uniform();
        let e = if u() < 0.3 { 1.0 } else { u() };
        let gravity = u() < 0.7;
        let field = Field { width: 10.0 + 30.0 * u(), height: 10.0 + 30.0 * u(), restitution: e };
        let n = 2 + (u() * 28.0) as usize;
        let balls: Vec<Ball> = (0..n)
            .map(|i| {
                let d = 0.3 + 1.5 * u();
                Ball {
                    id: BallId(i as u32),
                    kind: if i == 0 { BallKind::Key } else { BallKind::Ball },
                    position: DVec2::new(d + u() * (field.width - 2.0 * d), d + u() * (field.height - 2.0 * d)),
                    velocity: DVec2::new(u() - 0.5, u() - 0.5) * 10.0 * u(),
                    mass: 0.1 + 10.0 * u(),
                    diameter: d,
                }
            })
            .collect();
        let effects = Effects {
            collisions: Some(Collisions { restitution: e }),
            gravity: gravity.then_some(Gravity { g: DVec2::new(0.0, -9.81) }),
            ..Effects::default()
        };
        let mut x = ExactEngine::from_parts(field, effects, &balls).unwrap();
        for k in 1..=100 {
            match k % 23 {
                3 => x.set_pull(DVec2::new(u() - 0.5, u() - 0.5) * 200.0),
                7 => x.set_pull(DVec2::ZERO),
                11 => {
                    let _ = x.add_ball_at_free_spot(1.0, 0.5 + u());
                }
                13 => {
                    x.remove_last();
                }
                17 => {
                    if let Some(key) = x.key_ball() {
                        x.set_velocity(key, DVec2::new(u() - 0.5, u()) * 20.0).unwrap();
                    }
                }
                19 => {
                    if let Some(key) = x.key_ball() {
                        x.set_mass(key, 0.1 + 20.0 * u()).unwrap();
                    }
                }
                21 => x.set_restitution(u(), u()),
                _ => {}
            }
            x.advance_to(0.05 * k as f64);
        }
        let d = x.diagnostics();
        assert_eq!((d.non_finite, d.outside), (0, 0), "seed {seed}: {d:?}");
        assert!(d.largest_overlap < 1e-9, "seed {seed}: overlap {} m", d.largest_overlap);
        most_overlap = most_overlap.max(d.largest_overlap);
        most_events = most_events.max(x.stats().events);
    }
    eprintln!("largest overlap {most_overlap:e} m, most events {most_events}");
    assert!(most_events < 200_000, "{most_events} events in a run");
}
