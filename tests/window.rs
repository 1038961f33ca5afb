//! End-to-end test of the real window under a virtual X display: Xvfb, the `ballfield` binary,
//! and xdotool pressing keys as a person would. Holding Right must pull the key ball to the right,
//! and the add-ball hotkey (A) must add a ball — both read from the report the window writes when
//! it closes (`--exit-after S --report F.json`).
//!
//! Needs `xvfb`, `xauth` and `xdotool` (`.ci/run` installs them). With `CI` set, their absence is
//! a failure; elsewhere the test says loudly that it skipped.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        // SIGTERM first: Xvfb then removes its lock file and socket, so the next run's
        // `-displayfd` starts from a clean slate.
        let _ = Command::new("kill").arg(self.0.id().to_string()).status();
        let end = Instant::now() + Duration::from_secs(3);
        while Instant::now() < end {
            if let Ok(Some(_)) = self.0.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn have(tool: &str) -> bool {
    Command::new("sh").arg("-c").arg(format!("command -v {tool}")).output().is_ok_and(|o| o.status.success())
}

fn skip_or_fail(why: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{why} (CI is set: this test must run)");
    }
    eprintln!("\n!!!!!!!! SKIPPED the window test: {why}\n");
}

/// Starts Xvfb on a free display number it picks itself (`-displayfd`) and returns `:N`.
fn start_xvfb() -> (Killed, String) {
    let mut child = Command::new("Xvfb")
        // -noreset: without it the server resets whenever its last client leaves (our readiness
        // probe), and a client connecting meanwhile is refused.
        .args(["-displayfd", "1", "-screen", "0", "1280x800x24", "-nolisten", "tcp", "-noreset"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).expect("Xvfb prints its display");
    let display = format!(":{}", line.trim());
    let xvfb = Killed(child);
    // Make sure the server takes connections before anything else tries.
    let end = Instant::now() + Duration::from_secs(20);
    loop {
        let ok = Command::new("xdotool")
            .arg("getmouselocation")
            .env("DISPLAY", &display)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            break;
        }
        assert!(Instant::now() < end, "Xvfb on {display} takes no connections");
        std::thread::sleep(Duration::from_millis(50));
    }
    (xvfb, display)
}

fn xdotool(display: &str, args: &[&str]) -> String {
    let out = Command::new("xdotool").args(args).env("DISPLAY", display).output().expect("xdotool runs");
    assert!(out.status.success(), "xdotool {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

const SCENE: &str = r#"
name = "pull"
description = "the key ball alone on its row"

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
position = [10.0, 25.0]
velocity = [0.0, 0.0]
mass = 50.0
diameter = 2.0
pull = 200.0

[[balls]]
position = [60.0, 45.0]
mass = 1.0
diameter = 1.5
"#;

#[test]
fn arrow_keys_pull_the_key_ball_and_a_adds_a_ball() {
    for tool in ["Xvfb", "xdotool"] {
        if !have(tool) {
            return skip_or_fail(&format!("`{tool}` is not installed (apt-get install xvfb xauth xdotool)"));
        }
    }
    let (_xvfb, display) = start_xvfb();
    let dir = std::env::temp_dir().join(format!("ballfield-window-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = dir.join("report.json");
    let _ = std::fs::remove_file(&report);
    // No gravity or drag, so only the pull moves the key ball; it is heavy (200 N on 50 kg) so it
    // stays far from the right wall however long the key is held, and alone on its row.
    let scene = dir.join("pull.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let app = Command::new(env!("CARGO_BIN_EXE_ballfield"))
        .arg("--scene")
        .arg(&scene)
        .args(["--engine", "threaded", "--exit-after", "6", "--report"])
        .arg(&report)
        .env("DISPLAY", &display)
        .env("XDG_RUNTIME_DIR", &dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary starts");
    let mut app = Killed(app);

    // Wait for the window to be mapped (polling, so a binary that dies fails the test instead of
    // hanging it), then give it the keyboard.
    let deadline = Instant::now() + Duration::from_secs(60);
    let wid = loop {
        let out = Command::new("xdotool")
            .args(["search", "--onlyvisible", "--name", "ballfield"])
            .env("DISPLAY", &display)
            .output()
            .expect("xdotool runs");
        if let Some(id) = String::from_utf8_lossy(&out.stdout).lines().next() {
            break id.trim().to_string();
        }
        if let Some(status) = app.0.try_wait().unwrap() {
            let mut stderr = String::new();
            if let Some(mut e) = app.0.stderr.take() {
                use std::io::Read;
                let _ = e.read_to_string(&mut stderr);
            }
            panic!("ballfield exited ({status}) before its window appeared: {stderr}");
        }
        assert!(Instant::now() < deadline, "no ballfield window after 60 s");
        std::thread::sleep(Duration::from_millis(100));
    };
    xdotool(&display, &["windowfocus", "--sync", &wid]);
    // winit may report a synthetic key press right after focusing; the app ignores those, and
    // the pause lets it settle.
    std::thread::sleep(Duration::from_millis(800));
    xdotool(&display, &["keydown", "Right"]);
    std::thread::sleep(Duration::from_millis(1000));
    xdotool(&display, &["keyup", "Right"]);
    xdotool(&display, &["key", "a"]);

    let end = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = app.0.try_wait().unwrap() {
            break s;
        }
        assert!(Instant::now() < end, "the window did not close by itself");
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut stderr = String::new();
    if let Some(mut e) = app.0.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut stderr);
    }
    assert!(status.success(), "ballfield exited with {status}: {stderr}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(Path::new(&report)).unwrap()).unwrap();
    eprintln!("window report: {json:#}");
    let x = |k: &str| json[k][0].as_f64().unwrap_or_else(|| panic!("{k} missing in {json}"));
    let y = |k: &str| json[k][1].as_f64().unwrap();
    let (dx, dy) = (x("key_end") - x("key_start"), y("key_end") - y("key_start"));
    // 200 N on 50 kg for 1 s: 4 m/s² → 4 m/s and 2 m while held, then coasting a few seconds
    // (about 25 m at the end, far from the right wall at 70 m). Anything clearly to the right and
    // mostly horizontal is right.
    assert!(dx > 0.5, "the key ball moved {dx} m in x (expected to the right)");
    assert!(dx.abs() > dy.abs(), "the key ball moved ({dx}, {dy}): not mostly sideways");
    assert_eq!(json["balls_added"].as_u64(), Some(1), "{json}");
    let (start, end) = (json["balls_start"].as_u64().unwrap(), json["balls_end"].as_u64().unwrap());
    assert_eq!(end, start + 1);
    assert!(json["frames"].as_u64().unwrap() > 10, "{json}");
    let _ = std::fs::remove_dir_all(&dir);
}
