//! The mouse in the real window under Xvfb, on both engines: a ball dragged and let go is thrown
//! (the same ball, its id kept, at the cursor's speed, where the cursor let it go), a click on
//! empty field drops a new ball there, and so does a right click. Q closes the window.

mod xwindow;

use std::time::Duration;

use ballfield::physics::{BallId, BallKind};
use glam::DVec2;
use xwindow::{Session, one_at_a_time, tools_present};

/// Vacuum with collisions; the key ball out of the way in a corner, the target ball at rest
/// alone on its row (the throw sends it along the row).
const SCENE: &str = r#"
name = "mouse"
description = "a ball to throw"

[field]
width = 70.0
height = 50.0
restitution = 1.0

[simulation]
dt = 0.001
seed = 7

[effects]
collisions = { restitution = 1.0 }

[key-ball]
position = [10.0, 10.0]
mass = 10.0
diameter = 2.0
pull = 200.0

[[balls]]
position = [20.0, 25.0]
mass = 1.0
diameter = 2.0
"#;

const TARGET: DVec2 = DVec2::new(20.0, 25.0);

/// Field metres to window pixels: the window is the field's default size without the panel
/// (`--size 720x520 --no-panel`), 10 px per metre inside a 10 px margin, y up.
fn px(p: DVec2) -> DVec2 {
    DVec2::new(10.0 + 10.0 * p.x, 510.0 - 10.0 * p.y)
}

fn run(engine: &str) {
    if !tools_present() {
        return;
    }
    let _one = one_at_a_time();
    let args = ["--engine", engine, "--exit-after", "120", "--size", "720x520", "--no-panel"];
    let mut s = Session::start(&format!("mouse-{engine}"), SCENE, &args);

    // Drag the target 6 m to the right in 20 moves 15 ms apart (a tick), and let go: one xdotool
    // run, so the moves keep their cadence however busy the machine is (an xdotool run per move
    // took 15-50 ms to start, and the window, which measures the throw over its last ~100 ms,
    // saw the cursor speed up and slow down).
    s.mouse_to(px(TARGET));
    s.mouse_down(1);
    let grab = s.expect_command();
    let to = TARGET + DVec2::new(6.0, 0.0);
    let moves = 20;
    let mut chain: Vec<String> = Vec::new();
    for k in 1..=moves {
        let p = px(TARGET.lerp(to, k as f64 / moves as f64));
        chain.extend(["mousemove", "--window", &s.window, &p.x.to_string(), &p.y.to_string()].map(String::from));
        if k < moves {
            chain.extend(["sleep", "0.015"].map(String::from));
        }
    }
    chain.extend(["mouseup", "1"].map(String::from));
    let drag = s.xdotool(&chain.iter().map(String::as_str).collect::<Vec<_>>());
    let throw = s.expect_command();
    // The cursor's speed by this test's clock, at most: 19 moves of 0.3 m in the run's time.
    let speed = 6.0 * (moves - 1) as f64 / moves as f64 / (drag.done - drag.sent).as_secs_f64();

    // A click on empty field, and a right click.
    let drop_at = DVec2::new(50.0, 40.0);
    s.mouse_to(px(drop_at));
    s.xdotool(&["click", "1"]);
    let drop = s.expect_command();
    let right_at = DVec2::new(60.0, 10.0);
    s.mouse_to(px(right_at));
    s.xdotool(&["click", "3"]);
    let right = s.expect_command();
    s.press("q", "KeyQ");
    let done = s.finish(Duration::from_secs(30));
    done.assert_clean("KeyQ");
    let log = &done.report.log;

    let g = &log[grab];
    assert_eq!((g.command.as_str(), g.source.as_str()), ("Grab", "mouse-left"));
    let grabbed = g.ball.expect("the grabbed ball");
    assert_eq!((grabbed.id, grabbed.position), (BallId(1), TARGET), "the ball under the cursor is grabbed");
    assert_eq!(g.state.balls, 1, "a grabbed ball is off the field");

    let t = &log[throw];
    assert_eq!(t.command, "Throw");
    let thrown = t.ball.expect("the thrown ball is on the field");
    // Seen to fail with the throw adding the ball anew instead of putting it back (a new id).
    assert_eq!((thrown.id, thrown.kind, thrown.mass), (grabbed.id, BallKind::Ball, 1.0), "the same ball is thrown");
    assert_eq!(t.state.balls, 2);
    // Let go where the cursor was (the pixel grid is 0.1 m), at the cursor's speed along its
    // path. The window measures the speed over the last ~100 ms of its 15 ms ticks: measured
    // 0.85-1.11 times the cursor's mean speed (13.6-20.0 m/s; 16-19 m/s by this test's clock).
    // Seen to fail with the throw at rest.
    let released_at = (thrown.position - to).length();
    let v = thrown.velocity;
    let angle = v.y.atan2(v.x).abs().to_degrees();
    eprintln!(
        "[{engine}] thrown from {:?} at {v:?} m/s ({:.1} m/s, {angle:.1}°); the cursor moved at {speed:.1} m/s",
        thrown.position,
        v.length()
    );
    assert!(released_at <= 0.1, "{engine}: let go at {:?}, the cursor was at {to:?}", thrown.position);
    assert!(angle <= 5.0, "{engine}: thrown {angle}° off the cursor's path");
    assert!((0.5 * speed..=1.5 * speed).contains(&v.x), "{engine}: thrown at {v:?}, the cursor moved at {speed} m/s");

    // Seen to fail with the ball dropped 1 m right of the click.
    for (i, at, source, balls) in [(drop, drop_at, "mouse-left", 3), (right, right_at, "mouse-right", 4)] {
        let d = &log[i];
        assert_eq!((d.command.as_str(), d.source.as_str()), ("Drop", source));
        let b = d.ball.expect("the dropped ball");
        assert!((b.position - at).length() <= 0.05, "{engine}: dropped at {:?}, clicked at {at:?}", b.position);
        assert_eq!((b.kind, b.velocity, b.mass, b.diameter), (BallKind::Ball, DVec2::ZERO, 1.0, 2.0));
        assert!(b.id.0 > 1, "{b:?}: not a new id");
        assert_eq!(d.state.balls, balls);
    }
    assert_eq!(done.report.balls_added, 2, "a throw adds no ball");
    done.clean_up();
}

#[test]
fn drag_throws_the_ball_and_a_click_drops_one_threaded() {
    run("threaded");
}

#[test]
fn drag_throws_the_ball_and_a_click_drops_one_lockstep() {
    run("lockstep");
}
