//! An inelastic pile on the exact engine: 150 balls dropped as a lattice under gravity (e = 0.5,
//! no drag) land, come to rest and stay at rest, in a bounded number of events: the engine
//! never grinds to a halt on ever-shorter events (inelastic collapse), and once the pile is at
//! rest nothing happens at all. The floor then carries exactly the pile's weight.
//!
//! Seen to fail on broken builds: with the weight of balls at rest left off the gauge
//! (`World::wall_impulses` without `static_push`) the floor's rate is 0; with the rules for
//! collisions at one instant off (`World::note_instant`'s limits at `u32::MAX` and no backstop)
//! the run did not end in 15 minutes (killed; it takes 6 s). With the limits off but the backstop
//! on, it passes: the backstop ended two sequences at one instant, at their 65,537th collision.
//! With the collapse model off (`soft_restitution` returning the scene's e) it passes too: the
//! rules for collisions at one instant end this pile's collapses (see `exact_collapse.rs`).

use ballfield::engine::{Engine, ExactEngine};
use ballfield::scene::{Origin, Scene};

fn pile(restitution: f64) -> Scene {
    let toml = format!(
        r#"
name = "exact-pile"
[field]
width = 12.0
height = 30.0
restitution = {restitution}
[simulation]
dt = 0.001
seed = 5
max-balls = 150
[effects]
collisions = {{ restitution = {restitution} }}
gravity = {{ g = [0.0, -9.81] }}
[[generate]]
count = 150
diameter = 1.0
mass = 1.0
speed = 1.0
layout = "lattice"
gap = 0.2
region = [0.0, 12.0, 12.0, 30.0]
"#
    );
    Scene::from_toml_str(&toml, &Origin("exact-pile.toml".into())).unwrap()
}

/// Measured (e = 0.5): every ball at rest (or sliding on the floor, frictionless) from t = 6.5 s;
/// the busiest half second holds 5.9e5 events (at rest from 5.5 s and 6.2e5 before balls at rest
/// and sliding balls were in rounds of simultaneous impacts, 6.4e5 before a ball at rest on the
/// floor alone was struck through to it, 5.7e5 before simultaneous impacts were one round); none
/// from 10 s to 15 s, while the floor's gauge grows at the pile's weight M·g to 2.9e-15
/// (relative) and the other walls' not at all. Bounds: at rest by 8 s, 1.5e6 events in any half
/// second, none in the last 5 s, the weight to 1e-12.
#[test]
fn an_inelastic_pile_settles_and_holds_in_bounded_events_on_the_floor() {
    let scene = pile(0.5);
    let mut e = ExactEngine::new(&scene).unwrap();
    let n = e.ball_count();
    let (mut busiest, mut last, mut settled) = (0u64, 0u64, None);
    for k in 1..=20 {
        let t = 0.5 * k as f64;
        e.advance_to(t);
        let s = e.stats();
        busiest = busiest.max(s.events - last);
        last = s.events;
        if settled.is_none() && s.at_rest + s.sliding == n {
            settled = Some(t);
        }
    }
    let s = e.stats();
    eprintln!("settled at {settled:?} s, busiest half second {busiest} events, {:?}", s.counters);
    assert!(settled.is_some_and(|t| t <= 8.0), "every ball at rest by 8 s (at {settled:?}; {} at rest)", s.at_rest);
    assert!(busiest < 1_500_000, "at most 1.5e6 events in a half second ({busiest})");

    let (w0, t0, quiet) = (e.wall_impulses(), e.time(), s.events);
    e.advance_to(15.0);
    assert_eq!(e.stats().events, quiet, "nothing happens in a pile at rest");
    let (w1, t1) = (e.wall_impulses(), e.time());
    let weight = 9.81 * n as f64;
    let rate = (w1.bottom - w0.bottom) / (t1 - t0);
    let err = (rate - weight).abs() / weight;
    eprintln!("floor rate {rate} N for a weight of {weight} N: {err:e}");
    assert!(err < 1e-12, "the floor takes {rate} N of a {weight} N pile");
    assert_eq!((w1.left - w0.left, w1.right - w0.right, w1.top - w0.top), (0.0, 0.0, 0.0));

    let d = e.diagnostics();
    assert!(d.kinetic < 1e-3, "kinetic energy {:e} J", d.kinetic);
    assert!(d.largest_overlap < 1e-9, "overlap {:e} m", d.largest_overlap);
    assert_eq!((d.outside, d.non_finite), (0, 0));
}
