//! Stalls on the threaded runtime are harmless: a ball thread that wakes late does not integrate
//! through its contacts, and a stall of the whole process is a pause.

use std::process::Command;
use std::time::Duration;

use ballfield::Scene;
use ballfield::physics::{Ball, BallId, BallKind, Field};
use ballfield::runtime::{BallRecord, Runtime, RuntimeConfig};
use ballfield::scene::Origin;
use glam::DVec2;

static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Five 1 kg balls of 1 m resting in a column on the floor of a 10 m field; everything elastic.
const STACK: &str = "name = \"stack\"\n[field]\nwidth = 10.0\nheight = 10.0\nrestitution = 1.0\n\
    [effects]\ncollisions = { restitution = 1.0 }\ngravity = { g = [0.0, -9.81] }\n";

fn stack_scene() -> Scene {
    let mut s = Scene::from_toml_str(STACK, &Origin("test".into())).unwrap();
    s.balls = (0..5)
        .map(|k| Ball {
            id: BallId(k),
            kind: BallKind::Ball,
            position: DVec2::new(5.0, 0.5 + k as f64),
            velocity: DVec2::ZERO,
            mass: 1.0,
            diameter: 1.0,
        })
        .collect();
    s
}

fn energy(records: &[BallRecord]) -> f64 {
    records
        .iter()
        .map(|r| 0.5 * r.ball.mass * r.ball.velocity.length_squared() + r.ball.mass * 9.81 * r.ball.position.y)
        .sum()
}

fn largest_overlap(records: &[BallRecord]) -> f64 {
    let mut worst = 0.0f64;
    for (k, a) in records.iter().enumerate() {
        for b in &records[k + 1..] {
            let reach = a.ball.radius() + b.ball.radius();
            worst = worst.max(reach - a.ball.position.distance(b.ball.position));
        }
    }
    worst
}

/// The whole process stopped for 0.5 s (SIGSTOP, then SIGCONT) while the stack rests: a headless
/// run of the binary, stopped from here, once with everything elastic (e = 1) and once at
/// e = 0.8 (the resting contacts' solve, not sequential elastic impulses). Every thread wakes at
/// once after the gap; the balls find the monitor's horizon where it was and wait, and the
/// monitor drops the gap from the clock, as a pause would. The stack's energy at the end (the
/// run's report) is its energy at the start within 1e-3 (the issue asks 1 %), no ball sinks into
/// another, and the column keeps its order (the run's state file): nothing tunnelled.
///
/// Measured (four runs each, a busy machine, before e = 0.8 was added: |ΔE|/E 2e-6 to 2.6e-5,
/// largest overlap up to 1.5e-4 m, 0.50 to 0.75 s dropped). With the real contact solver
/// (`scripts/threaded-contacts.sh stall`): e = 1, |ΔE|/E 9e-8 to 7e-7, overlap up to 1.5e-6 m;
/// e = 0.8, 8e-8 to 1.5e-5, overlap up to 2.4e-5 m; 0.50 s dropped, the order kept, in every
/// run. The runtime before the horizon gained 26 % to 36 % (a late cycle integrated the whole
/// gap with contacts off and the push-apart kept the fall speed). Seen to fail with the balls
/// integrating to the clock past the horizon (`catch_up(clock, …)` in `run_ball`): +41 % to +46 %
/// at e = 1, +44 % at e = 0.8, where the top balls also swapped places (the column's order).
/// Waits (up to 10 s) until process `pid` has a thread named as the runtime names its monitor.
#[cfg(target_os = "linux")]
fn wait_for_monitor(pid: u32) -> bool {
    let started = std::time::Instant::now();
    while started.elapsed() < Duration::from_secs(10) {
        let tasks = std::fs::read_dir(format!("/proc/{pid}/task")).into_iter().flatten().flatten();
        if tasks
            .into_iter()
            .any(|t| std::fs::read_to_string(t.path().join("comm")).is_ok_and(|name| name.trim() == "collision-monit"))
        {
            return true;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    false
}

#[cfg(target_os = "linux")]
#[test]
fn a_stall_of_the_whole_process_leaves_a_resting_stack_as_it_was() {
    let _serial = serial();
    for e in [1.0, 0.8] {
        let dir = std::env::temp_dir().join(format!("ballfield-stall-{}-{e}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = dir.join("stack.toml");
        let mut text = STACK.replace("restitution = 1.0", &format!("restitution = {e:.1}"));
        for k in 0..5 {
            text += &format!("[[balls]]\nposition = [5.0, {}]\nmass = 1.0\ndiameter = 1.0\n", 0.5 + k as f64);
        }
        std::fs::write(&scene, text).unwrap();
        let (report, state) = (dir.join("report.json"), dir.join("state.csv"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_ballfield"))
            .arg("--scene")
            .arg(&scene)
            .args(["headless", "--engine", "threaded", "--duration", "2.5", "-q", "--report"])
            .arg(&report)
            .arg("--state-out")
            .arg(&state)
            .spawn()
            .unwrap();
        // The stall falls inside the run: half a second after the runtime's monitor is up (a
        // fixed second after the spawn missed the run once on a loaded machine, whose start took
        // longer, and the runtime saw no stall to drop).
        assert!(wait_for_monitor(child.id()), "the run's monitor thread did not start within 10 s");
        std::thread::sleep(Duration::from_millis(500));
        let pid = child.id() as libc::pid_t;
        // SAFETY: kill takes no pointers; `pid` is our own child, not yet waited for, so the id
        // cannot have been reused.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGSTOP) }, 0);
        std::thread::sleep(Duration::from_millis(500));
        // SAFETY: as above.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGCONT) }, 0);
        assert!(child.wait().unwrap().success());
        let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
        let balls =
            ballfield::headless::read_state(&state, &Field { width: 10.0, height: 10.0, restitution: e }).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let f = |path: &str| r.pointer(path).and_then(|v| v.as_f64()).unwrap_or_else(|| panic!("{path} in {r}"));
        let (start, end) = (f("/start/total"), f("/end/total"));
        let change = (end - start).abs() / start;
        let overlap = f("/end/largest_overlap");
        let dropped = f("/runtime/clock_dropped_seconds");
        let mut heights: Vec<(BallId, f64)> = balls.iter().map(|b| (b.id, b.position.y)).collect();
        heights.sort_by_key(|&(id, _)| id);
        eprintln!(
            "process stall, e = {e}: energy {start} -> {end} ({change:e}), overlap {overlap:e}, dropped {dropped} s, \
             heights {heights:?}"
        );
        assert!(dropped >= 0.45, "e = {e}: the stall was dropped from the clock ({dropped} s)");
        assert!(change < 1e-3, "e = {e}: energy {start} -> {end}");
        assert!(overlap < 1e-3, "e = {e}: overlap {overlap} m");
        assert!(heights.windows(2).all(|w| w[0].1 < w[1].1), "e = {e}: the column's order changed: {heights:?}");
    }
}

/// One ball in the middle of the resting stack stalls for 0.3 s (the test hook: its thread
/// sleeps). The monitor keeps judging it from its last record and its responses pile up in its
/// inbox; when it wakes it catches up, applying each at its own instant, so it stays where the
/// stack holds it. Energy within 1e-4 of before, no overlap beyond 1e-3 m.
///
/// Measured: |ΔE|/E 1e-6 to 7e-6, largest overlap 1e-4 m, no response applied late. Seen to fail
/// with the held responses all applied at once when the ball wakes (the `catch_up` loop never
/// advancing to a response's instant): |ΔE|/E 7e-4; with the balls integrating past the
/// horizon: responses applied late; and with the responses that found the ball's ring full (the
/// stall outlasts its 256 slots) taken from the channel ahead of those in the ring: 256 applied
/// late, |ΔE|/E 6.7e-3.
#[test]
fn a_stalled_ball_in_a_stack_stays_where_the_stack_holds_it() {
    let _serial = serial();
    // The stack kept awake: asleep, it gets no responses to pile up.
    let rt = Runtime::start(&stack_scene(), RuntimeConfig { sleep: false, ..RuntimeConfig::default() }).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    assert!(rt.settle(Duration::from_secs(5)));
    let before = rt.snapshot();
    rt.resume();
    rt.inject_stall(rt.ball_ids()[2], Duration::from_millis(300)).unwrap();
    std::thread::sleep(Duration::from_millis(600));
    assert!(rt.settle(Duration::from_secs(5)));
    let after = rt.snapshot();
    let (e0, e1) = (energy(&before), energy(&after));
    let overlap = largest_overlap(&after);
    let stats = rt.stats();
    eprintln!("ball stall: energy {e0} -> {e1} ({:e}), overlap {overlap:e}; {stats:?}", (e1 - e0).abs() / e0);
    assert!((e1 - e0).abs() < 1e-4 * e0, "energy {e0} -> {e1}");
    assert!(overlap < 1e-3, "overlap {overlap} m");
    assert_eq!(stats.responses_late, 0);
    // The stall outlasts the ring: the fallback to the channel is what this case exercises (seen
    // to fail with the monitor's count of channel responses never incremented).
    assert!(stats.responses_by_channel > 0, "no response went by the channel: {stats:?}");
}

/// Stops this whole test process for `gap` (SIGSTOP from a shell it waits for, then SIGCONT):
/// every thread of the runtime misses that much wall time, the monitor as a starved one would.
/// Returns the wall time the stop lasted.
#[cfg(target_os = "linux")]
fn stall_this_process(gap: Duration) -> Duration {
    let started = std::time::Instant::now();
    let script = format!("kill -STOP {pid}; sleep {}; kill -CONT {pid}", gap.as_secs_f64(), pid = std::process::id());
    assert!(Command::new("sh").args(["-c", &script]).status().unwrap().success());
    started.elapsed()
}

/// A ball (0.2 kg, 1 m) dropped 1 m onto a ball of 1 kg resting on the floor, e = 0.8 for both
/// and the walls, leapfrog; the whole process stalls about 10 ms (under `MAX_ADVANCE`, so
/// nothing is dropped from the clock) 10 ms before the impact, when the monitor has judged up to
/// about 6 ms before it. Its next pass comes late by the stall and judges the periods it missed
/// one solve each, the impact's among them, and the dropped ball rebounds as the chain of
/// sequential impacts says within lockstep's bound at dt = 1 ms, 1.2·g·dt (read off its energy 5
/// ms after the impact, as `contacts_every_engine` does). A late pass judged in one solve is
/// lockstep's step at the stall's length: on a 2-core CI machine running tests beside it, passes
/// 2 to 5 ms apart put this rebound 0.037 m/s off (bound 0.034 then).
///
/// Measured: the rebound −7.7e-3 m/s off the chain (lockstep's figure at dt = 1 ms, to the
/// bit), every span one period, stalls of 12.6 to 15.2 ms. Seen to fail with every late pass
/// judged in one solve (`solves_are_cheap` false): the longest span 11 to 12 ms, the rebound
/// 0.067 to 0.082 m/s low.
#[cfg(target_os = "linux")]
#[test]
fn a_late_monitor_judges_the_periods_it_missed_one_solve_each() {
    use ballfield::engine::{self, EngineKind};
    let _serial = serial();
    const G: f64 = 9.81;
    let (e, ma, mb, fall) = (0.8, 0.2, 1.0, 1.0);
    let mut text = format!(
        "name = \"late\"\n[field]\nwidth = 10.0\nheight = 20.0\nrestitution = {e:?}\n\
         [simulation]\ndt = 0.001\nintegrator = \"leapfrog\"\n\
         [effects]\ncollisions = {{ restitution = {e:?} }}\ngravity = {{ g = [0.0, {:?}] }}\n",
        -G
    );
    for (y, m) in [(1.5 + fall, ma), (0.5, mb)] {
        text += &format!("[[balls]]\nposition = [5.0, {y:?}]\nmass = {m:?}\ndiameter = 1.0\n");
    }
    let scene = Scene::from_toml_str(&text, &Origin("late.toml".into())).unwrap();
    let t_impact = (2.0 * fall / G).sqrt();
    let mut run = engine::start(EngineKind::Threaded, &scene, Some(1)).unwrap();
    run.advance_to(t_impact - 0.010);
    let stalled = stall_this_process(Duration::from_millis(10));
    run.advance_to(t_impact + 5e-3);
    run.quiesce();
    let mut balls = Vec::new();
    run.sample(&mut balls);
    let stats = run.figures().runtime.expect("the threaded engine's figures");
    run.shutdown();
    let a = &balls[0];
    let rebound = (a.velocity.y * a.velocity.y + 2.0 * G * (a.position.y - 1.5)).max(0.0).sqrt();
    // The chain: A–B, B–floor, … until nothing approaches.
    let (mut va, mut vb) = (-(2.0 * G * fall).sqrt(), 0.0);
    loop {
        if va < vb {
            let j = -(1.0 + e) * (va - vb) / (1.0 / ma + 1.0 / mb);
            (va, vb) = (va + j / ma, vb - j / mb);
        } else if vb < 0.0 {
            vb *= -e;
        } else {
            break;
        }
    }
    eprintln!(
        "stalled {stalled:?}: A rebounds at {rebound:.6} m/s, the chain {va:.6} ({:+.1e}); longest span {} s, \
         {} s dropped",
        rebound - va,
        stats.monitor_span_max_seconds,
        stats.clock_dropped_seconds
    );
    assert!(stalled >= Duration::from_millis(8), "the process stalled only {stalled:?}");
    assert!(
        stats.monitor_span_max_seconds <= 1e-3 + 1e-9,
        "a span of {} s in one solve",
        stats.monitor_span_max_seconds
    );
    assert!((rebound - va).abs() <= 1.2 * G * 1e-3, "A rebounds at {rebound}, the chain {va}");
}
