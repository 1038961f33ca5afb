//! The exact engine is deterministic: the same scene gives the same bits, and where a run is
//! stopped to be looked at (frames, the window's samples, `--duration`) changes nothing.
//!
//! Seen to fail on broken builds: `World::advance_while` bringing every ball to the instant it
//! stops at (`sync`, which rounds each ball's course anew): the gas stopped at frames had other
//! events than the gas run in one go.

use ballfield::engine::{Engine, ExactEngine};
use ballfield::scenes;

/// The exact engine on a built-in scene, with drag and attraction taken out and the
/// restitutions set to `e`.
fn engine(name: &str, e: f64) -> ExactEngine {
    let mut scene = scenes::builtin(name).unwrap().unwrap();
    scene.effects.drag = None;
    scene.effects.attraction = None;
    scene.field.restitution = e;
    if let Some(c) = &mut scene.effects.collisions {
        c.restitution = e;
    }
    ExactEngine::new(&scene).unwrap()
}

/// The gas (elastic, 500 balls), the gravity scene (31 balls bouncing at e = 0.7, coming to
/// rest) and the pile (1,000 balls at e = 0.8, the 2.8 s in which it lands: the rest model at
/// work).
const CASES: [(&str, f64, f64); 3] = [("gas", 1.0, 20.0), ("gravity", 0.7, 20.0), ("pile", 0.8, 2.8)];

#[test]
fn two_runs_of_the_same_scene_hash_identically() {
    for (name, e, t) in CASES {
        let (mut a, mut b) = (engine(name, e), engine(name, e));
        let before = a.state_hash();
        a.advance_to(t);
        b.advance_to(t);
        assert!(a.stats().events > 1000, "{name}: the run is not empty ({} events)", a.stats().events);
        if e < 1.0 {
            assert!(a.stats().counters.rests > 10, "{name}: the rest model acted ({:?})", a.stats().counters);
        }
        assert_eq!(a.state_hash(), b.state_hash(), "{name}");
        assert_ne!(a.state_hash(), before, "{name}: the balls moved");
    }
}

/// Stopped every 1/60 s, as frames are drawn, or run in one go: the same events, the same bits.
#[test]
fn stopping_to_look_changes_nothing() {
    for (name, e, t) in CASES {
        let (mut once, mut framed) = (engine(name, e), engine(name, e));
        once.advance_to(t);
        let frames = (t * 60.0) as u32;
        for k in 1..=frames {
            framed.advance_to(t * k as f64 / frames as f64);
            let mut balls = Vec::new();
            framed.sample(&mut balls);
        }
        assert_eq!(framed.time(), once.time(), "{name}");
        assert_eq!(framed.stats().events, once.stats().events, "{name}: the same events");
        assert_eq!(framed.state_hash(), once.state_hash(), "{name}: the same bits");
    }
}
