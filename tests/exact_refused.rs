//! The exact engine refuses the effects it cannot run exactly — drag and attraction, which are
//! not piecewise constant — with a message that names the effect: on the engine interface, on the
//! command line (a non-zero exit) and in the window (E onto the exact engine, and D pressed while
//! it runs).
//!
//! Seen to fail on broken builds: `exact::check_effects` not looking at attraction (the
//! attraction scene started), and the window's `toggle_effect` without its check of what the
//! engine runs (D on the exact engine left drag on in the panel and no message in the report).

mod xwindow;

use std::process::Command;
use std::time::Duration;

use ballfield::engine::{self, EngineError, EngineKind};
use ballfield::physics::{Attraction, Drag};
use ballfield::scenes;
use xwindow::{Session, one_at_a_time, tools_present};

#[test]
fn the_engine_refuses_drag_and_attraction_by_name() {
    let mut scene = scenes::builtin("gravity").unwrap().unwrap();
    assert!(engine::start(EngineKind::Exact, &scene, None).is_ok(), "gravity and collisions run");
    for (drag, attraction, named) in
        [(true, false, "drag"), (false, true, "attraction"), (true, true, "drag and attraction")]
    {
        scene.effects.drag = drag.then(Drag::default);
        scene.effects.attraction = attraction.then(Attraction::default);
        let Err(e) = engine::start(EngineKind::Exact, &scene, None) else { panic!("{named}: the scene started") };
        assert!(matches!(&e, EngineError::Unsupported { engine: EngineKind::Exact, effects } if effects == named));
        let message = e.to_string();
        assert!(message.contains(&format!("cannot run {named}")), "{message}");
        assert!(message.contains("lockstep or threaded"), "the message says what can: {message}");
    }
}

#[test]
fn the_command_line_exits_with_the_message() {
    for (scene, named) in [("pile", "drag"), ("attraction", "attraction")] {
        let out = Command::new(env!("CARGO_BIN_EXE_ballfield"))
            .args(["headless", "--scene", scene, "--engine", "exact", "--steps", "10"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{scene}: exit {:?}", out.status);
        assert!(stderr.contains(&format!("the exact engine cannot run {named}")), "{scene}: {stderr}");
    }
}

/// A vacuum with drag and collisions: two balls at rest.
const DRAG: &str = r#"
name = "exact-refused"
[field]
width = 40.0
height = 30.0
[simulation]
dt = 0.001
seed = 1
[effects]
collisions = { restitution = 1.0 }
drag = { model = "quadratic", rho = 1.225, cd = 0.47 }
[[balls]]
position = [10.0, 10.0]
mass = 1.0
diameter = 1.0
[[balls]]
position = [30.0, 10.0]
mass = 1.0
diameter = 1.0
"#;

/// In the window, E from lockstep tries the exact engine, which refuses the scene's drag: the
/// lockstep engine runs on and the report holds the message; the next E goes on to threaded.
/// Then D (drag off) and E, E to the exact engine, and D again: drag stays off, with the message.
#[test]
fn the_window_says_so_and_runs_on() {
    if !tools_present() {
        return;
    }
    let _one = one_at_a_time();
    let mut s = Session::start("exact-refused", DRAG, &["--engine", "lockstep", "--exit-after", "60"]);
    let to_exact = s.press("e", "KeyE");
    let on = s.press("e", "KeyE");
    let drag_off = s.press("d", "KeyD");
    let lockstep = s.press("e", "KeyE");
    let exact = s.press("e", "KeyE");
    let drag_on = s.press("d", "KeyD");
    s.press("Escape", "Escape");
    let done = s.finish(Duration::from_secs(60));
    let at = |i: usize| &done.report.log[i];
    assert_eq!(at(to_exact).state.engine, "lockstep", "the refused switch keeps the engine that ran");
    assert_eq!(at(on).state.engine, "threaded", "the next E goes on from the one tried");
    assert!(!at(drag_off).state.effects.contains(&"drag".to_string()));
    assert_eq!(at(lockstep).state.engine, "lockstep");
    assert_eq!(at(exact).state.engine, "exact", "without drag the exact engine runs");
    assert!(!at(drag_on).state.effects.contains(&"drag".to_string()), "{:?}", at(drag_on).state.effects);
    let refusals: Vec<&String> = done.report.errors.iter().filter(|e| e.contains("cannot run drag")).collect();
    assert_eq!(refusals.len(), 2, "two messages name drag: {:?}", done.report.errors);
    assert!(refusals[0].starts_with("cannot start the exact engine"), "{}", refusals[0]);
    assert!(done.status.success(), "the window exited with {}", done.status);
    done.clean_up();
}
