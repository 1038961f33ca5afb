//! Drives the real `ballfield` window under a virtual X display, as a person would: Xvfb, the
//! binary, and xdotool pressing keys and moving the mouse. The window's report
//! (`--report F.json`, `AppReport`) says what happened; its log lines (`RUST_LOG=ballfield=info`)
//! say when it is ready and when it has carried out each command, so the tests wait for those
//! instead of sleeping a guessed time.
//!
//! Needs `xvfb`, `xauth` and `xdotool` (`.ci/run` installs them). With `CI` set, their absence is
//! a failure; elsewhere the tests say loudly that they skipped.

#![allow(dead_code)] // each test file uses its own part of the harness

use std::io::{BufRead, BufReader, Read};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use ballfield::physics::Ball;
use glam::DVec2;
use serde::Deserialize;

/// One window at a time per test binary: two windows on two shared cores would each draw at half
/// speed, and the timing margins are measured for one.
pub fn one_at_a_time() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// Whether the tools are here. Without them: a failure with `CI` set, a loud skip elsewhere.
pub fn tools_present() -> bool {
    for tool in ["Xvfb", "xdotool"] {
        let found =
            Command::new("sh").arg("-c").arg(format!("command -v {tool}")).output().is_ok_and(|o| o.status.success());
        if !found {
            let why = format!("`{tool}` is not installed (apt-get install xvfb xauth xdotool)");
            if std::env::var_os("CI").is_some() {
                panic!("{why} (CI is set: the window tests must run)");
            }
            eprintln!("\n!!!!!!!! SKIPPED a window test: {why}\n");
            return false;
        }
    }
    true
}

/// A child process that is stopped when dropped (also when a test fails half-way).
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        if let Ok(Some(_)) = self.0.try_wait() {
            return;
        }
        // SIGTERM first: Xvfb then removes its lock file and socket, so the next run's
        // `-displayfd` starts from a clean slate.
        let _ = Command::new("kill").arg(self.0.id().to_string()).stderr(Stdio::null()).status();
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

/// The window's stderr, line by line, each with the instant it arrived here.
#[derive(Default)]
struct Lines {
    lines: Mutex<Vec<(Instant, String)>>,
    more: Condvar,
}

/// The `ballfield` window running on its own Xvfb.
pub struct Session {
    pub display: String,
    pub window: String,
    pub dir: PathBuf,
    report: PathBuf,
    lines: Arc<Lines>,
    /// Commands the window has carried out, as this test counts them, and the keys it pressed
    /// (winit's names), in order.
    pub commands: usize,
    pub sent: Vec<&'static str>,
    // Dropped in this order: the window, then its display.
    app: Killed,
    _xvfb: Killed,
}

/// How the window ended.
pub struct Finished {
    pub status: ExitStatus,
    /// What the session counted: commands given, keys pressed.
    pub commands: usize,
    pub sent: Vec<&'static str>,
    pub report: Report,
    /// The report as written, for messages.
    pub json: String,
    pub stderr: String,
    pub dir: PathBuf,
}

/// The parts of `AppReport` the tests read.
#[derive(Clone, Debug, Deserialize)]
pub struct Report {
    pub engine: String,
    pub seconds: f64,
    pub frames: u64,
    pub tick_gap_ms_median: f64,
    pub tick_gap_ms_max: f64,
    pub balls_start: usize,
    pub balls_end: usize,
    pub balls_added: u64,
    pub balls_removed: u64,
    pub key_presses: u64,
    pub keys: std::collections::BTreeMap<String, u64>,
    pub commands: std::collections::BTreeMap<String, u64>,
    pub log: Vec<Record>,
    pub log_dropped: u64,
    pub closed_by: String,
    pub end: Option<State>,
    pub errors: Vec<String>,
}

/// One command the window carried out (`CommandRecord`).
#[derive(Clone, Debug, Deserialize)]
pub struct Record {
    pub at: f64,
    pub source: String,
    pub command: String,
    pub ball: Option<Ball>,
    #[serde(flatten)]
    pub state: State,
}

/// The window's state after a command (`WindowState`).
#[derive(Clone, Debug, Deserialize)]
pub struct State {
    pub engine: String,
    pub scene: String,
    pub time: f64,
    pub paused: bool,
    pub balls: usize,
    pub effects: Vec<String>,
    pub pull: [f64; 2],
    pub key_ball: Option<Ball>,
    pub panel: bool,
    pub help: bool,
    pub vectors: bool,
    pub centre_of_mass: bool,
    pub traces: bool,
}

impl State {
    pub fn key(&self) -> Ball {
        self.key_ball.unwrap_or_else(|| panic!("no key ball in {self:?}"))
    }
}

/// One hold of keys: the log records of its presses and releases, and the bounds on how long
/// the window saw the keys down.
#[derive(Clone, Copy, Debug)]
pub struct Held {
    /// Indices in the report's log of the first press and the last release.
    pub first: usize,
    pub last: usize,
    /// The window saw the first press after the keys were sent down and before this test read
    /// its log line, and the last release likewise: so the keys were down, to the window, for
    /// at least `shortest` and at most `longest` seconds.
    pub shortest: f64,
    pub longest: f64,
}

/// The instants around one xdotool command: it started at `sent`, and had returned (so the X
/// server had the event) by `done`.
#[derive(Clone, Copy, Debug)]
pub struct Sent {
    pub sent: Instant,
    pub done: Instant,
}

fn xdotool_output(display: &str, args: &[&str]) -> std::process::Output {
    Command::new("xdotool").args(args).env("DISPLAY", display).output().expect("xdotool runs")
}

/// Starts Xvfb on a display number it picks itself (`-displayfd`) and returns it with `:N`.
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
    let end = Instant::now() + Duration::from_secs(20);
    while !xdotool_output(&display, &["getmouselocation"]).status.success() {
        assert!(Instant::now() < end, "Xvfb on {display} takes no connections");
        std::thread::sleep(Duration::from_millis(50));
    }
    (xvfb, display)
}

impl Session {
    /// Writes `scene` (TOML) to a fresh directory, opens the window on it with `args` (after
    /// `--scene F --report F`), waits for its first frame and gives it the keyboard.
    pub fn start(name: &str, scene: &str, args: &[&str]) -> Session {
        let dir = std::env::temp_dir().join(format!("ballfield-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        // lavapipe warns on every start unless XDG_RUNTIME_DIR is a private directory.
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700)).unwrap();
        let scene_file = dir.join("scene.toml");
        std::fs::write(&scene_file, scene).unwrap();
        let report = dir.join("report.json");

        let (xvfb, display) = start_xvfb();
        let mut child = Command::new(env!("CARGO_BIN_EXE_ballfield"))
            .arg("--scene")
            .arg(&scene_file)
            .arg("--report")
            .arg(&report)
            .args(args)
            .env("DISPLAY", &display)
            .env("XDG_RUNTIME_DIR", &dir)
            .env("RUST_LOG", "warn,ballfield=info")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the binary starts");
        let lines = Arc::new(Lines::default());
        let stderr = child.stderr.take().unwrap();
        let sink = lines.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                sink.lines.lock().unwrap().push((Instant::now(), line));
                sink.more.notify_all();
            }
        });
        let mut s = Session {
            display,
            window: String::new(),
            dir,
            report,
            lines,
            commands: 0,
            sent: Vec::new(),
            app: Killed(child),
            _xvfb: xvfb,
        };
        // The first start on a machine compiles Mesa's shaders (~1 s); 60 s is for a loaded one.
        s.wait_line("first frame drawn", Duration::from_secs(60));
        let out = xdotool_output(&s.display, &["search", "--onlyvisible", "--name", "ballfield"]);
        s.window = String::from_utf8_lossy(&out.stdout).lines().next().expect("the window is mapped").trim().into();
        // Bare Xvfb has no window manager: focus by hand, and wait until the window knows.
        s.xdotool(&["windowfocus", "--sync", &s.window.clone()]);
        s.wait_line("the window has the keyboard focus", Duration::from_secs(20));
        s
    }

    /// The arrival instant of the first stderr line containing `text`. Fails if the window
    /// exits or `timeout` passes first.
    pub fn wait_line(&mut self, text: &str, timeout: Duration) -> Instant {
        let end = Instant::now() + timeout;
        let mut lines = self.lines.lines.lock().unwrap();
        loop {
            if let Some((t, _)) = lines.iter().find(|(_, l)| l.contains(text)) {
                return *t;
            }
            if let Ok(Some(status)) = self.app.0.try_wait() {
                let all: Vec<&str> = lines.iter().map(|(_, l)| l.as_str()).collect();
                panic!("the window exited ({status}) before {text:?}; its stderr:\n{}", all.join("\n"));
            }
            assert!(Instant::now() < end, "no {text:?} from the window after {timeout:?}");
            lines = self.lines.more.wait_timeout(lines, Duration::from_millis(50)).unwrap().0;
        }
    }

    /// Waits until the window has carried out its `n`-th command (counted from 1) and returns
    /// when that was seen here.
    pub fn wait_command(&mut self, n: usize) -> Instant {
        self.wait_line(&format!("command {n}: "), Duration::from_secs(30))
    }

    pub fn xdotool(&self, args: &[&str]) -> Sent {
        let sent = Instant::now();
        let out = xdotool_output(&self.display, args);
        assert!(out.status.success(), "xdotool {args:?}: {}", String::from_utf8_lossy(&out.stderr));
        Sent { sent, done: Instant::now() }
    }

    /// Presses and releases one key (an X keysym name: "a", "KP_Add", "Escape").
    pub fn key(&self, key: &str) -> Sent {
        self.xdotool(&["key", key])
    }

    /// Presses and releases `keysym` (winit's `code`), a hotkey that gives one command, and
    /// waits until the window has carried it out. Returns the command's index in the log.
    pub fn press(&mut self, keysym: &str, code: &'static str) -> usize {
        self.key(keysym);
        self.sent.push(code);
        self.commands += 1;
        self.wait_command(self.commands);
        self.commands - 1
    }

    /// A command that is not a key (the mouse's), given by `f`: waits until it is carried out
    /// and returns its index in the log.
    pub fn expect_command(&mut self) -> usize {
        self.commands += 1;
        self.wait_command(self.commands);
        self.commands - 1
    }

    /// Holds the arrow keys `keys` (`(keysym, winit's code)`) down together for `seconds`.
    pub fn hold(&mut self, keys: &[(&str, &'static str)], seconds: f64) -> Held {
        let syms: Vec<&str> = keys.iter().map(|k| k.0).collect();
        let first = self.commands + 1;
        let down = self.key_down(&syms);
        self.commands += keys.len();
        let pressed_seen = self.wait_command(first);
        self.wait_command(self.commands);
        std::thread::sleep(Duration::from_secs_f64(seconds));
        let up = self.key_up(&syms);
        self.commands += keys.len();
        let released_seen = self.wait_command(self.commands);
        self.sent.extend(keys.iter().map(|k| k.1));
        Held {
            first: first - 1,
            last: self.commands - 1,
            shortest: (up.sent - pressed_seen).as_secs_f64(),
            longest: (released_seen - down.sent).as_secs_f64(),
        }
    }

    pub fn key_down(&self, keys: &[&str]) -> Sent {
        self.xdotool(&[&["keydown"], keys].concat())
    }

    pub fn key_up(&self, keys: &[&str]) -> Sent {
        self.xdotool(&[&["keyup"], keys].concat())
    }

    /// Moves the pointer to pixel `p` of the window (from its top-left corner).
    pub fn mouse_to(&self, p: DVec2) -> Sent {
        let (x, y) = (format!("{}", p.x.round()), format!("{}", p.y.round()));
        self.xdotool(&["mousemove", "--window", &self.window, &x, &y])
    }

    pub fn mouse_down(&self, button: u8) -> Sent {
        self.xdotool(&["mousedown", &button.to_string()])
    }

    pub fn mouse_up(&self, button: u8) -> Sent {
        self.xdotool(&["mouseup", &button.to_string()])
    }

    /// Waits for the window to close by itself (within `timeout`) and reads its report.
    pub fn finish(mut self, timeout: Duration) -> Finished {
        let end = Instant::now() + timeout;
        let status = loop {
            if let Some(s) = self.app.0.try_wait().unwrap() {
                break s;
            }
            assert!(Instant::now() < end, "the window did not close within {timeout:?}");
            std::thread::sleep(Duration::from_millis(50));
        };
        // The reader thread ends with the pipe; give it a moment to take the last lines.
        std::thread::sleep(Duration::from_millis(50));
        let stderr: Vec<String> = self.lines.lines.lock().unwrap().iter().map(|(_, l)| l.clone()).collect();
        let stderr = stderr.join("\n");
        let mut json = String::new();
        if let Ok(mut f) = std::fs::File::open(&self.report) {
            let _ = f.read_to_string(&mut json);
        }
        assert!(
            !json.is_empty(),
            "the window ({status}) wrote no report to {}; stderr:\n{stderr}",
            self.report.display()
        );
        let report = serde_json::from_str(&json).unwrap_or_else(|e| panic!("the report does not parse: {e}\n{json}"));
        let (commands, sent) = (self.commands, std::mem::take(&mut self.sent));
        Finished { status, commands, sent, report, json, stderr, dir: self.dir.clone() }
    }
}

impl Finished {
    /// The checks every session makes: a clean exit by `closed_by`, no errors, every key press
    /// the test sent counted once under its key and nothing else counted, every command logged.
    /// Seen to fail with key releases counted as presses, and (the report missing) with Esc
    /// ending the process at once.
    pub fn assert_clean(&self, closed_by: &str) {
        let r = &self.report;
        let keys_sent = &tally(&self.sent);
        assert!(self.status.success(), "the window exited with {}; stderr:\n{}", self.status, self.stderr);
        assert_eq!(r.closed_by, closed_by, "what closed the window");
        assert!(r.errors.is_empty(), "the window reported errors: {:?}", r.errors);
        assert_eq!(&r.keys, keys_sent, "key presses counted by key (left: the window's, right: sent)");
        assert_eq!(r.key_presses, keys_sent.values().sum::<u64>(), "key presses counted");
        assert_eq!(r.log_dropped, 0);
        let commands: Vec<&str> = r.log.iter().map(|r| r.command.as_str()).collect();
        assert_eq!(r.log.len(), self.commands, "commands logged: {commands:?}");
        assert!(r.frames > 10, "only {} frames drawn", r.frames);
    }

    /// Removes the session's directory (kept when a test fails, for a look at the report).
    pub fn clean_up(self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Counts keys as the report does: `(winit KeyCode name, presses)`.
pub fn tally(keys: &[&str]) -> std::collections::BTreeMap<String, u64> {
    let mut m = std::collections::BTreeMap::new();
    for k in keys {
        *m.entry(k.to_string()).or_insert(0) += 1;
    }
    m
}
