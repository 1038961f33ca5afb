//! Changes in the middle of a lockstep run give the same bits as a fresh start from the same
//! state: adding or removing a ball, turning effects on or off or changing them, the restitution
//! of the walls or of the collisions, the integrator, the step and the pull.
//!
//! The engine keeps what it derived from the balls and effects between steps (the pair list, the
//! speeds and drag constants the sub-step split is judged by, the orbit rate last met, the force
//! passes and their attraction method). A mutator that forgets to forget one of them makes the
//! next steps run on a stale cache: the run goes on, plausibly, but not as the same state started
//! fresh would (the class of bug `Lockstep::forget_derived` fixed). So each case runs a scene for
//! a while, changes it, builds a fresh engine from the changed engine's state
//! (`Lockstep::from_parts` of its field, effects, integrator, step and balls, and its pull), runs
//! both on, and compares their state hashes (every bit of every ball).
//!
//! No such bug was found by these cases. Seen to fail with `forget_derived` not clearing the split
//! speeds (`self.split_speeds = None` removed: "default, a fast ball added" diverges), with
//! `add_ball` not calling `forget_derived` (that one and "drag fall, a light large ball added"),
//! with `set_effects` not calling it ("drag fall, air 100 times denser"), and with `remove_last`
//! not calling it ("attraction, the fast ball removed").

use ballfield::Lockstep;
use ballfield::physics::{Attraction, Ball, BallId, BallKind, Collisions, Drag, Effects, Gravity, Integrator};
use ballfield::scenes;
use glam::DVec2;

/// Steps before the change, and after it.
const BEFORE: u64 = 300;
const AFTER: u64 = 300;

/// A fresh engine from `e`'s state.
fn fresh(e: &Lockstep) -> Lockstep {
    let mut f =
        Lockstep::from_parts(*e.field(), *e.effects(), e.integrator(), e.dt(), e.max_balls(), &e.bodies().to_balls());
    f.set_pull(e.pull());
    f
}

/// Runs `start` for `BEFORE` steps, changes it with `change`, and checks that it then runs as a
/// fresh engine built from the changed state does.
#[track_caller]
fn same_as_fresh(what: &str, start: &Lockstep, change: impl Fn(&mut Lockstep)) {
    let mut running = start.clone();
    running.run(BEFORE);
    let before = running.state_hash();
    change(&mut running);
    let mut restarted = fresh(&running);
    assert_eq!(running.state_hash(), restarted.state_hash(), "{what}: the fresh engine starts from the same state");
    running.run(AFTER);
    restarted.run(AFTER);
    assert_ne!(running.state_hash(), before, "{what}: the field moved");
    assert_eq!(
        running.state_hash(),
        restarted.state_hash(),
        "{what}: {AFTER} steps after the change differ from {AFTER} steps of a fresh engine from the same state"
    );
}

fn builtin(name: &str) -> Lockstep {
    Lockstep::new(&scenes::builtin(name).unwrap().unwrap())
}

/// A ball that is not on any other (the engine does not care; the comparison is bit for bit
/// either way), fast enough to make the split take more sub-steps.
fn newcomer(x: f64, y: f64, speed: f64) -> Ball {
    Ball {
        id: BallId(0),
        kind: BallKind::Ball,
        position: DVec2::new(x, y),
        velocity: DVec2::new(speed, -0.5 * speed),
        mass: 2.0,
        diameter: 0.7,
    }
}

/// The scenes the cases run on: every effect, the support pass of an inelastic pile, a 500-ball
/// gas, attraction summed directly, and two without collisions (a drag fall, a Kepler orbit),
/// for the changes that turn them on.
const SCENES: [&str; 7] =
    ["default", "attraction", "pile", "gas", "cradle", "reference/drag-fall", "reference/kepler-e0"];

#[test]
fn without_a_change_a_run_goes_on_as_a_fresh_one() {
    for name in SCENES {
        same_as_fresh(&format!("{name}, unchanged"), &builtin(name), |_| {});
    }
}

#[test]
fn adding_a_ball_mid_run() {
    for name in SCENES {
        same_as_fresh(&format!("{name}, a slow ball added"), &builtin(name), |e| {
            e.add_ball(newcomer(3.0, 47.0, 1.0)).unwrap();
        });
        // 400 m/s: the split needs several sub-steps at once.
        same_as_fresh(&format!("{name}, a fast ball added"), &builtin(name), |e| {
            e.add_ball(newcomer(3.0, 47.0, 400.0)).unwrap();
        });
    }
}

#[test]
fn removing_a_ball_mid_run() {
    for name in SCENES {
        same_as_fresh(&format!("{name}, a ball removed"), &builtin(name), |e| {
            let id = e.bodies().id[e.bodies().len() / 2];
            e.remove_ball(id).unwrap();
        });
        same_as_fresh(&format!("{name}, the last ball removed"), &builtin(name), |e| {
            e.remove_last().unwrap();
        });
        // The fastest ball gone: the split must stop judging by its speed at once.
        let mut with_fast = builtin(name);
        with_fast.add_ball(newcomer(3.0, 47.0, 400.0)).unwrap();
        same_as_fresh(&format!("{name}, the fast ball removed"), &with_fast, |e| {
            e.remove_last().unwrap();
        });
    }
}

#[test]
fn changing_effects_mid_run() {
    type Change = (&'static str, fn(&mut Effects));
    let changes: [Change; 8] = [
        ("drag off", |f| f.drag = None),
        ("drag on", |f| f.drag = Some(Drag::Quadratic { rho: 1.225, cd: 0.47 })),
        ("stronger drag", |f| f.drag = Some(Drag::Quadratic { rho: 12.25, cd: 0.47 })),
        ("gravity off", |f| f.gravity = None),
        ("gravity sideways", |f| f.gravity = Some(Gravity { g: DVec2::new(3.0, -9.81) })),
        ("collisions off", |f| f.collisions = None),
        ("collisions on, e = 0.5", |f| f.collisions = Some(Collisions { restitution: 0.5 })),
        ("attraction at G = 2", |f| f.attraction = Some(Attraction { g_constant: 2.0, ..Attraction::default() })),
    ];
    for name in SCENES {
        for (what, change) in changes {
            same_as_fresh(&format!("{name}, {what}"), &builtin(name), |e| {
                let mut effects = *e.effects();
                change(&mut effects);
                e.set_effects(effects);
            });
        }
    }
}

/// A 500-ball gas that ran without collisions, overlapping as it went, has them turned on: the
/// pair list is found afresh, the split judged by the speeds as they are.
#[test]
fn collisions_turned_on_in_a_crowd_mid_run() {
    let gas = scenes::builtin("gas").unwrap().unwrap();
    let start = Lockstep::from_parts(
        gas.field,
        Effects { collisions: None, ..gas.effects },
        gas.integrator,
        gas.dt,
        gas.max_balls,
        &gas.balls,
    );
    same_as_fresh("gas, collisions on", &start, |e| {
        e.set_effects(Effects { collisions: Some(Collisions { restitution: 1.0 }), ..*e.effects() });
    });
}

/// Changes that make drag stiff, so that the step must be split for it: the split is judged by
/// the drag constants of the balls and effects as they are now, not as they were. The 1.6 g ball
/// of 2.2 m of the fuzzer's findings falls at its terminal speed, where its drag rate is 82 /s
/// (one sub-step of 1 ms resolves it); in air a hundred times denser its rate is 8,200 /s at that
/// speed and 820 /s at its new terminal speed, which takes up to 17 sub-steps.
#[test]
fn drag_made_stiff_mid_run() {
    let scene = scenes::builtin("reference/drag-fall").unwrap().unwrap();
    let light = Ball { mass: 1.6e-3, diameter: 2.2, ..newcomer(30.0, 40.0, 0.0) };
    let mut balls = scene.balls.clone();
    balls.push(Ball { id: BallId(balls.len() as u32), ..light });
    let start = Lockstep::from_parts(scene.field, scene.effects, scene.integrator, scene.dt, 10, &balls);
    same_as_fresh("drag fall, air 100 times denser", &start, |e| {
        e.set_effects(Effects { drag: Some(Drag::Quadratic { rho: 122.5, cd: 0.47 }), ..*e.effects() });
    });
    let start = Lockstep::from_parts(scene.field, scene.effects, scene.integrator, scene.dt, 10, &scene.balls);
    same_as_fresh("drag fall, a light large ball added", &start, |e| {
        e.set_effects(Effects { drag: Some(Drag::Quadratic { rho: 122.5, cd: 0.47 }), ..*e.effects() });
        e.run(1);
        e.add_ball(light).unwrap();
    });
}

#[test]
fn changing_restitution_mid_run() {
    for name in SCENES {
        same_as_fresh(&format!("{name}, walls at e = 0.3"), &builtin(name), |e| e.set_field_restitution(0.3));
        same_as_fresh(&format!("{name}, collisions at e = 0.2"), &builtin(name), |e| {
            let mut effects = *e.effects();
            if let Some(c) = &mut effects.collisions {
                c.restitution = 0.2;
            }
            e.set_effects(effects);
        });
    }
}

#[test]
fn changing_the_integrator_the_step_or_the_pull_mid_run() {
    for name in SCENES {
        same_as_fresh(&format!("{name}, rk4"), &builtin(name), |e| e.set_integrator(Integrator::Rk4));
        same_as_fresh(&format!("{name}, dt = 0.4 ms"), &builtin(name), |e| e.set_dt(4e-4));
        same_as_fresh(&format!("{name}, pulled"), &builtin(name), |e| e.set_pull(DVec2::new(-300.0, 500.0)));
    }
}

/// Attraction through the Barnes–Hut tree, and the switch to the direct sum and back as balls come
/// and go across `TREE_MIN_BALLS`.
#[test]
fn crossing_the_tree_threshold_mid_run() {
    use ballfield::physics::{Field, TREE_MIN_BALLS};
    let n = TREE_MIN_BALLS + 2;
    let side = (n as f64).sqrt().ceil() as usize;
    let balls: Vec<Ball> = (0..n)
        .map(|k| Ball {
            id: BallId(k as u32),
            kind: BallKind::Ball,
            position: DVec2::new(5.0 + 3.0 * (k % side) as f64, 5.0 + 3.0 * (k / side) as f64),
            velocity: DVec2::new(((k * 7) % 5) as f64 - 2.0, ((k * 3) % 5) as f64 - 2.0),
            mass: 1.0,
            diameter: 1.0,
        })
        .collect();
    let effects = Effects {
        attraction: Some(Attraction { g_constant: 0.5, ..Attraction::default() }),
        collisions: Some(Collisions { restitution: 1.0 }),
        ..Effects::default()
    };
    let field = Field { width: 60.0, height: 60.0, restitution: 1.0 };
    let start = Lockstep::from_parts(field, effects, Integrator::Leapfrog, 1e-3, 1000, &balls);
    assert_eq!(start.active_effects(), vec!["attraction (tree)", "collisions"]);
    same_as_fresh("tree, down to the direct sum", &start, |e| {
        for _ in 0..5 {
            e.remove_last().unwrap();
        }
        assert_eq!(e.active_effects(), vec!["attraction (direct)", "collisions"]);
    });
    let mut below = start.clone();
    for _ in 0..3 {
        below.remove_last().unwrap();
    }
    same_as_fresh("direct sum, up to the tree", &below, |e| {
        for k in 0..4 {
            e.add_ball(newcomer(50.0 + 2.0 * k as f64, 50.0, 3.0)).unwrap();
        }
        assert_eq!(e.active_effects(), vec!["attraction (tree)", "collisions"]);
    });
}
