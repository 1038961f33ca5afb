//! The arrow keys pull the key ball, in the real window under Xvfb, on both engines: each arrow
//! alone and a diagonal, each from rest after R (reset). The displacement is checked against
//! ½·(F/m)·t², F the scene's pull and m the key ball's mass, with t bounded by the instants this
//! test pressed and released the keys; and against the same motion integrated over the engine
//! times the window logged for each press and release. A diagonal pulls as hard as one arrow.
//! Esc closes the window, which still writes its report. See `xwindow/mod.rs` for the harness.

mod xwindow;

use std::time::Duration;

use glam::DVec2;
use xwindow::{Record, Session, one_at_a_time, tools_present};

/// Vacuum, no collisions: only the pull moves the key ball, which starts at rest in the middle
/// and stays far from every wall (2-8 m from the middle at the end of a hold, then coasting at
/// 8-17 m/s until the next R).
const SCENE: &str = r#"
name = "pull"
description = "the key ball alone in vacuum"

[field]
width = 70.0
height = 50.0
restitution = 1.0

[simulation]
dt = 0.001
seed = 7

[key-ball]
position = [35.0, 25.0]
velocity = [0.0, 0.0]
mass = 10.0
diameter = 2.0
pull = 200.0
"#;

const START: DVec2 = DVec2::new(35.0, 25.0);
/// The scene's pull (N) and key-ball mass (kg).
const PULL: f64 = 200.0;
const MASS: f64 = 10.0;
/// F/m, m/s².
const ACCELERATION: f64 = PULL / MASS;
/// The scene's step (lockstep) and ball cycle (threaded, the default), s.
const DT: f64 = 0.001;

/// The X keysym and winit's name of each arrow, and its direction.
const ARROWS: [(&str, &str, DVec2); 4] = [
    ("Right", "ArrowRight", DVec2::X),
    ("Left", "ArrowLeft", DVec2::NEG_X),
    ("Up", "ArrowUp", DVec2::Y),
    ("Down", "ArrowDown", DVec2::NEG_Y),
];

fn arrow(keysym: &str) -> (&'static str, &'static str, DVec2) {
    *ARROWS.iter().find(|a| a.0 == keysym).unwrap()
}

/// The pull this test expects while `held` (winit names) are down: one arrow's strength,
/// whichever are held.
fn expected_acceleration(held: &[&str]) -> DVec2 {
    let sum: DVec2 = ARROWS.iter().filter(|a| held.contains(&a.1)).map(|a| a.2).sum();
    sum.normalize_or_zero() * ACCELERATION
}

/// One hold: the keys, how long they stay down, and what was measured.
struct Hold {
    keys: &'static [&'static str],
    seconds: f64,
}

const HOLDS: &[Hold] = &[
    Hold { keys: &["Right"], seconds: 0.4 },
    Hold { keys: &["Left"], seconds: 0.4 },
    Hold { keys: &["Up"], seconds: 0.4 },
    Hold { keys: &["Down"], seconds: 0.4 },
    // Longer than X's default auto-repeat delay (660 ms): repeats, if the server sends them,
    // must neither count as presses nor change the pull.
    Hold { keys: &["Right", "Up"], seconds: 0.8 },
];

fn run(engine: &str) {
    if !tools_present() {
        return;
    }
    let _one = one_at_a_time();
    let mut s = Session::start(&format!("pull-{engine}"), SCENE, &["--engine", engine, "--exit-after", "120"]);
    let mut holds = Vec::new();
    for hold in HOLDS {
        s.press("r", "KeyR");
        let keys: Vec<(&str, &'static str)> = hold.keys.iter().map(|k| (arrow(k).0, arrow(k).1)).collect();
        holds.push(s.hold(&keys, hold.seconds));
    }
    s.press("Escape", "Escape");
    let done = s.finish(Duration::from_secs(30));
    done.assert_clean("Escape");
    let r = &done.report;
    let log = &r.log;
    assert_eq!(r.commands.get("Pull"), Some(&6));
    assert_eq!(r.commands.get("Release"), Some(&6));
    assert_eq!(r.commands.get("Reset"), Some(&(HOLDS.len() as u64)));

    eprintln!(
        "[{engine}] tick gap median {:.1} ms, max {:.1} ms; {} frames in {:.1} s",
        r.tick_gap_ms_median, r.tick_gap_ms_max, r.frames, r.seconds
    );
    for (hold, h) in HOLDS.iter().zip(&holds) {
        let reset = &log[h.first - 1];
        assert_eq!(reset.command, "Reset");
        let k = reset.state.key();
        // Seen to fail with R restarting from the balls as they are.
        assert_eq!((k.position, k.velocity), (START, DVec2::ZERO), "R puts the key ball back at rest");
        check_hold(engine, hold, &log[h.first..=h.last], h.shortest, h.longest, r.tick_gap_ms_max * 1e-3);
    }
    done.clean_up();
}

/// Checks one hold from its records (the presses, then the releases).
fn check_hold(engine: &str, hold: &Hold, records: &[Record], shortest: f64, longest: f64, tick_gap: f64) {
    let names: Vec<&str> = hold.keys.iter().map(|k| arrow(k).1).collect();
    // What the window logged, press by press, is what this test did.
    let mut held: Vec<&str> = Vec::new();
    for (i, rec) in records.iter().enumerate() {
        let name = rec.source.as_str();
        assert!(names.contains(&name), "{name} was not pressed");
        let expect = if i < names.len() { "Pull" } else { "Release" };
        assert!(rec.command.starts_with(expect), "{} after {held:?}", rec.command);
        if i < names.len() {
            held.push(names[i]);
        } else {
            held.retain(|h| *h != name);
        }
        // The window asks for one arrow's pull however many are held.
        let want = expected_acceleration(&held) * MASS;
        assert!((DVec2::from(rec.state.pull) - want).length() < 1e-9, "{held:?}: pull {:?}", rec.state.pull);
    }
    let (p0, p1) = (records.first().unwrap(), records.last().unwrap());
    let (k0, k1) = (p0.state.key(), p1.state.key());
    if engine == "lockstep" {
        assert_eq!((k0.position, k0.velocity), (START, DVec2::ZERO), "{engine} {:?}: not from rest", hold.keys);
    } else {
        // The record's key ball is the window's latest sample of the table, and on the threaded
        // engine the ball thread may have run a cycle of the first pull before it was taken
        // (seen once in twenty-odd runs: 34.99998 m, -0.02 m/s, one 1 ms cycle at 20 m/s²). So:
        // at rest, or moving along the first pull only, by at most 10 cycles of it.
        let first = expected_acceleration(&names[..1]).normalize();
        let late = 10.0 * DT;
        let (dx, dv) = (k0.position - START, k0.velocity);
        let from_rest = dv.perp_dot(first).abs() <= 1e-12
            && dv.dot(first) >= 0.0
            && dv.length() <= ACCELERATION * late
            && dx.perp_dot(first).abs() <= 1e-12
            && dx.length() <= 0.5 * ACCELERATION * late * late;
        assert!(from_rest, "{engine} {:?}: not from rest: {:?}, {:?}", hold.keys, k0.position, k0.velocity);
    }

    // 1. The motion the test expects, integrated exactly over the engine times the window
    //    logged at each press and release (the lockstep engine's pull applies from the logged
    //    step on; the threaded engine's from the ball's next cycle). Seen to fail with the
    //    engine given a diagonal's pull un-normalised (3.1 m off) and 1.5 times the pull (1.2 m
    //    off on one arrow).
    let (mut x, mut v) = (k0.position, k0.velocity);
    let mut held: Vec<&str> = Vec::new();
    for w in records.windows(2) {
        let name = w[0].source.as_str();
        if w[0].command.starts_with("Pull") {
            held.push(name)
        } else {
            held.retain(|h| *h != name)
        }
        let a = expected_acceleration(&held);
        let dt = w[1].state.time - w[0].state.time;
        assert!(dt >= 0.0);
        x += v * dt + 0.5 * a * dt * dt;
        v += a * dt;
    }
    let t_engine = p1.state.time - p0.state.time;
    let moved = k1.position - k0.position;
    let free = 0.5 * ACCELERATION * t_engine * t_engine;
    let (dx, dv) = ((k1.position - x).length(), (k1.velocity - v).length());
    eprintln!(
        "[{engine}] {:?}: held {t_engine:.4} s of engine time ({shortest:.4}..{longest:.4} s by this test's clock); \
         moved {:.4} m, integrated {:.4} m: off by {dx:.2e} m ({:.2e} of ½at²), {dv:.2e} m/s",
        hold.keys,
        moved.length(),
        (x - k0.position).length(),
        dx / free
    );
    let (dx_max, dv_max) = if engine == "lockstep" {
        // Semi-implicit Euler from rest runs ahead by ½·a·dt·t (x_n = a·dt²·n(n+1)/2) and gets
        // the speed exact: measured 1.1e-3..2.3e-3 of ½at² (= dt/t) and 3e-13 m/s.
        (ACCELERATION * DT * t_engine, 1e-9)
    } else {
        // The pull reaches the ball thread at its next cycle (1 ms), at the press and at the
        // release: measured at most 2.0e-2 m and 1.3e-2 m/s (under a cycle's worth). The bounds
        // allow the ball to be 10 cycles late, as a preempted thread on two shared cores is.
        let late = 10.0 * DT;
        (ACCELERATION * late * t_engine, ACCELERATION * late)
    };
    assert!(dx <= dx_max, "{engine} {:?}: {dx} m from the integrated motion (at most {dx_max})", hold.keys);
    assert!(dv <= dv_max, "{engine} {:?}: {dv} m/s from the integrated motion (at most {dv_max})", hold.keys);

    // 2. ½·(F/m)·t² with t between the spans this test measured. The threaded engine's clock is
    //    the wall clock, read while the window handles the key: between the spans' ends. The
    //    lockstep engine's clock is that of its last step, taken at the last tick: up to one
    //    tick behind the wall clock at each end (tick gaps measured 15 ms median, 27-80 ms
    //    max). Seen to fail with the engine's clock running 1.5 times too fast (0.646 s of
    //    engine time in a hold of 0.344-0.624 s).
    let slack = if engine == "lockstep" { tick_gap } else { 0.0 };
    let (lo, hi) = ((shortest - slack).max(0.0), longest + slack);
    assert!((lo..=hi).contains(&t_engine), "{engine} {:?}: engine time {t_engine} s outside {lo}..{hi}", hold.keys);
    let along = expected_acceleration(&names).normalize();
    let (d_along, d_across) = (moved.dot(along), moved.perp_dot(along));
    let (min, max) = (0.5 * ACCELERATION * lo * lo, 0.5 * ACCELERATION * hi * hi);
    if names.len() == 1 {
        assert!(
            (min..=max).contains(&d_along),
            "{engine} {:?}: moved {d_along} m along the pull, ½·(F/m)·t² is {min}..{max} m",
            hold.keys
        );
        // Nothing else acts on the ball: not a hair across the pull (measured 0).
        eprintln!("[{engine}] {:?}: {d_across:e} m across the pull", hold.keys);
        assert!(d_across.abs() <= 1e-9, "{engine} {:?}: {d_across} m across the pull", hold.keys);
    } else {
        // The two keys go down and up a few ms apart, so one arrow pulls alone for a moment:
        // at F/m either way, a diagonal's pull being normalised. The ball is then no further
        // than ½·(F/m)·t² and no faster than (F/m)·t, and along the diagonal it moves at least
        // as far as at (F/m)/√2. Seen to fail with the engine given the un-normalised pull (and
        // check 1 left out): the threaded ball moved 14.0 m (at most 10.3), the lockstep one
        // reached 23.8 m/s, √2 times (F/m)·t.
        assert!(moved.length() <= max, "{engine} {:?}: moved {} m, at most {max}", hold.keys, moved.length());
        assert!(k1.velocity.length() <= ACCELERATION * hi, "{engine} {:?}: {:?} m/s", hold.keys, k1.velocity);
        assert!(d_along >= min / 2f64.sqrt(), "{engine} {:?}: {d_along} m along the diagonal", hold.keys);
    }
}

#[test]
fn arrows_pull_the_key_ball_by_f_over_m_threaded() {
    run("threaded");
}

#[test]
fn arrows_pull_the_key_ball_by_f_over_m_lockstep() {
    run("lockstep");
}
