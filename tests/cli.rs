//! The command line end to end, driving the built binary as a user's script would: frames
//! (`--frames`, `--frame-every`, `--size`), runs whose `--report` or `--state-out` cannot be
//! written, and a field without balls through the state file.
//!
//! Frames are drawn for real on whatever adapter wgpu finds (a CPU one in CI: see
//! `ci-notes.md`); these tests check what the command line promises — how many frames, named how,
//! of what size, showing a moving field — not what they look like (that is `tests/render.rs`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use ballfield::headless::read_state;
use ballfield::physics::Field;

/// A fresh, empty directory of our own under the system's temp dir.
fn temp_dir(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("ballfield-cli-{}-{n}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a temp dir");
    dir
}

fn ballfield(args: &[&str]) -> Output {
    let runtime_dir = std::env::temp_dir().join(format!("ballfield-cli-xdg-{}", std::process::id()));
    std::fs::create_dir_all(&runtime_dir).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // lavapipe warns on every start unless this is a private directory.
        std::fs::set_permissions(&runtime_dir, std::fs::Permissions::from_mode(0o700)).unwrap();
    }
    Command::new(env!("CARGO_BIN_EXE_ballfield"))
        .args(args)
        .env_remove("RUST_LOG")
        .env("XDG_RUNTIME_DIR", &runtime_dir)
        .output()
        .expect("the ballfield binary runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[track_caller]
fn assert_ok(args: &[&str], out: &Output) {
    assert!(out.status.success(), "`ballfield {}` failed:\n{}", args.join(" "), text(&out.stderr));
}

/// Asserts that the run failed cleanly (an error, not a panic or a signal) with `needles` in its
/// message.
#[track_caller]
fn assert_failed(args: &[&str], out: &Output, needles: &[&str]) {
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "`ballfield {}` should fail; stderr:\n{stderr}", args.join(" "));
    assert!(out.status.code().is_some(), "killed by a signal: {:?}", out.status);
    assert!(!stderr.contains("panicked"), "panicked:\n{stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "stderr should contain {needle:?}:\n{stderr}");
    }
}

/// The PNG files in `dir`, sorted by name, and every other file name there.
fn frames_in(dir: &Path) -> (Vec<PathBuf>, Vec<String>) {
    let mut frames = Vec::new();
    let mut other = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "png") {
            frames.push(path);
        } else {
            other.push(path.display().to_string());
        }
    }
    frames.sort();
    (frames, other)
}

/// Frames named `frame-00000.png` on, each a PNG of `w`×`h` pixels.
#[track_caller]
fn check_frames(frames: &[PathBuf], w: u32, h: u32) {
    for (k, path) in frames.iter().enumerate() {
        assert_eq!(path.file_name().unwrap().to_string_lossy(), format!("frame-{k:05}.png"));
        let size = image::image_dimensions(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(size, (w, h), "{}", path.display());
    }
}

/// The report written at `path`, as JSON.
fn report(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("the report is JSON")
}

/// Lockstep frames are taken every `--frame-every` of simulated time, from t = 0 to the end
/// inclusive: 100 steps of 1 ms at 20 ms are frames at 0, 20, ..., 100 ms — six of them; at a bare
/// 0.025 (seconds) five. Each is `--size` pixels, and the cradle's striker moves between the
/// first and the last. Seen to fail with the run's last frame left out (`at >= steps` for
/// `at > steps` in `frames::run_lockstep`: five frames) and with `--size` ignored (720×520, the
/// field at 10 px/m and its margin).
#[test]
fn lockstep_frames_every_and_size() {
    for (every, expected) in [("20ms", 6), ("0.025", 5)] {
        let dir = temp_dir("lockstep-frames");
        let frames = dir.join("frames");
        let f = frames.display().to_string();
        let args = [
            "headless",
            "--scene",
            "cradle",
            "--steps",
            "100",
            "--frames",
            &f,
            "--frame-every",
            every,
            "--size",
            "320x180",
        ];
        let out = ballfield(&args);
        assert_ok(&args, &out);
        let (found, other) = frames_in(&frames);
        assert!(other.is_empty(), "only frames in {f}: {other:?}");
        assert_eq!(found.len(), expected, "--frame-every {every}: frames {found:?}");
        check_frames(&found, 320, 180);
        let stdout = text(&out.stdout);
        assert!(stdout.contains(&format!("frames       {expected} of 320x180 in {f} (0 skipped)")), "{stdout}");
        let (first, last) = (std::fs::read(&found[0]).unwrap(), std::fs::read(found.last().unwrap()).unwrap());
        assert_ne!(first, last, "the field moved between the first frame and the last");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// Threaded frames are taken every `--frame-every` of wall-clock time, and a slot whose time
/// passed while the previous frame was drawn is skipped and counted: over 0.25 s at 62.5 ms (both
/// exact in binary) the slots are at 0, 62.5, ..., 250 ms, and the frames written plus the slots
/// skipped are at least those five. Frame 0 is always written. Seen to fail with `--size` ignored
/// (720×520).
#[test]
fn threaded_frames_every_and_size() {
    let dir = temp_dir("threaded-frames");
    let frames = dir.join("frames");
    let f = frames.display().to_string();
    let args = [
        "headless",
        "--engine",
        "threaded",
        "--scene",
        "vacuum",
        "--duration",
        "0.25",
        "--frames",
        &f,
        "--frame-every",
        "62.5ms",
        "--size",
        "160x90",
    ];
    let out = ballfield(&args);
    assert_ok(&args, &out);
    let (found, other) = frames_in(&frames);
    assert!(other.is_empty(), "only frames in {f}: {other:?}");
    check_frames(&found, 160, 90);
    let stdout = text(&out.stdout);
    let line = stdout.lines().find(|l| l.starts_with("frames ")).unwrap_or_else(|| panic!("no frames line:\n{stdout}"));
    let skipped: usize = line
        .split_once('(')
        .and_then(|(_, rest)| rest.split_once(' '))
        .and_then(|(n, _)| n.parse().ok())
        .unwrap_or_else(|| panic!("no skipped count in {line:?}"));
    assert!(line.starts_with(&format!("frames       {} of 160x90 in {f} (", found.len())), "{line}");
    assert!(!found.is_empty(), "frame 0 is always written");
    assert!(found.len() + skipped >= 5, "{} frames and {skipped} skipped of 5 slots", found.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `--report` that cannot be written fails the run, after its state and frames are written.
/// (As root every directory is writable, so "cannot be written" is a path under a plain file.)
#[test]
fn an_unwritable_report_leaves_the_state_and_the_frames() {
    let dir = temp_dir("bad-report");
    std::fs::write(dir.join("file"), "not a directory").unwrap();
    let bad = dir.join("file/report.json").display().to_string();
    let state = dir.join("state.csv");
    let frames = dir.join("frames");
    let (s, f) = (state.display().to_string(), frames.display().to_string());
    let args = [
        "headless",
        "--scene",
        "vacuum",
        "--steps",
        "40",
        "--report",
        &bad,
        "--state-out",
        &s,
        "--frames",
        &f,
        "--frame-every",
        "20ms",
        "--size",
        "64x48",
        "--quiet",
    ];
    let out = ballfield(&args);
    assert_failed(&args, &out, &["--report", &bad]);
    let balls = read_state(&state, &Field::default()).expect("the state was written and reads back");
    assert_eq!(balls.len(), 31, "the vacuum's 30 balls and the key ball");
    let (found, _) = frames_in(&frames);
    assert_eq!(found.len(), 3, "frames at 0, 20 and 40 ms");
    check_frames(&found, 64, 48);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `--state-out` that cannot be written fails the run, after its report and frames are written,
/// on every engine (the vacuum has no drag or attraction, so the exact engine runs it too). Seen
/// to fail before the report was kept through that error (the run stopped at the state, and no
/// report was written).
#[test]
fn an_unwritable_state_leaves_the_report_and_the_frames() {
    for engine in ["lockstep", "threaded", "exact"] {
        let dir = temp_dir("bad-state");
        std::fs::write(dir.join("file"), "not a directory").unwrap();
        let bad = dir.join("file/state.csv").display().to_string();
        let report_path = dir.join("report.json");
        let frames = dir.join("frames");
        let (r, f) = (report_path.display().to_string(), frames.display().to_string());
        let args = [
            "headless",
            "--engine",
            engine,
            "--scene",
            "vacuum",
            "--steps",
            "40",
            "--state-out",
            &bad,
            "--report",
            &r,
            "--frames",
            &f,
            "--frame-every",
            "20ms",
            "--size",
            "64x48",
            "--quiet",
        ];
        let out = ballfield(&args);
        assert_failed(&args, &out, &["--state-out", &bad]);
        let json = report(&report_path);
        assert_eq!(json["engine"], engine);
        assert_eq!(json["balls"], 31);
        let (found, _) = frames_in(&frames);
        assert!(!found.is_empty(), "{engine}: the frames were written");
        check_frames(&found, 64, 48);
        // Without frames too (the plain headless path).
        let args =
            ["headless", "--engine", engine, "--scene", "vacuum", "--steps", "40", "--state-out", &bad, "--report", &r];
        std::fs::remove_file(&report_path).unwrap();
        let out = ballfield(&args);
        assert_failed(&args, &out, &["--state-out", &bad]);
        assert_eq!(report(&report_path)["balls"], 31, "{engine}: the report was written");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A field without balls goes through the state file and back: the header alone in, the header
/// alone out, a report of 0 balls, on every engine (the exact engine on the gravity scene: it
/// refuses the default scene's drag). Seen to fail with the state writer taking its header from
/// the first row (a file of 0 bytes came out, and reading it back was refused: "the header must
/// be `id,kind,x,y,vx,vy,mass,diameter`, found ``").
#[test]
fn a_state_without_balls_round_trips() {
    let header = "id,kind,x,y,vx,vy,mass,diameter\n";
    for (engine, scene) in [("lockstep", "default"), ("threaded", "default"), ("exact", "gravity")] {
        let dir = temp_dir("zero-balls");
        let (input, output, report_path) = (dir.join("in.csv"), dir.join("out.csv"), dir.join("report.json"));
        std::fs::write(&input, header).unwrap();
        let (i, o, r) = (input.display().to_string(), output.display().to_string(), report_path.display().to_string());
        let args = [
            "headless",
            "--engine",
            engine,
            "--scene",
            scene,
            "--steps",
            "20",
            "--state-in",
            &i,
            "--state-out",
            &o,
            "--report",
            &r,
            "--quiet",
        ];
        let out = ballfield(&args);
        assert_ok(&args, &out);
        assert_eq!(std::fs::read_to_string(&output).unwrap(), header, "{engine}: the header alone");
        let json = report(&report_path);
        assert_eq!(json["balls"], 0);
        assert_eq!(json["end"]["kinetic"].as_f64(), Some(0.0));
        // And what came out is good input.
        let again = ["headless", "--engine", engine, "--scene", scene, "--steps", "5", "--state-in", &o, "--quiet"];
        let out = ballfield(&again);
        assert_ok(&again, &out);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The exact engine's report holds its own figures beside the common ones: the events (its unit
/// of work, in `steps`), the collisions, wall bounces and cell crossings, events and collisions
/// per second, the events invalidated in the calendar, and the state hash; the terminal summary
/// says the same. A lockstep report has none of them. Measured (the gravity scene, 1 s): 4
/// collisions, 3 wall bounces, 24 cell crossings; 4 events invalidated as superseded and 1 by a
/// partner's change. Bounds: each count above zero. Seen to fail with the report's `exact` left
/// out (`exact: None` in `headless::finish`).
#[test]
fn the_exact_report_has_its_own_figures() {
    let dir = temp_dir("exact-report");
    let report_path = dir.join("report.json");
    let r = report_path.display().to_string();
    let args = ["headless", "--engine", "exact", "--scene", "gravity", "--steps", "1000", "--report", &r];
    let out = ballfield(&args);
    assert_ok(&args, &out);
    let json = report(&report_path);
    assert_eq!(json["engine"], "exact");
    assert_eq!(json["integrator"], "exact parabolas");
    assert_eq!(json["simulated_seconds"].as_f64(), Some(1.0));
    let x = &json["exact"];
    let count = |key: &str| x[key].as_u64().unwrap_or_else(|| panic!("no {key} in {x}"));
    let (collisions, bounces, crossings) = (count("collisions"), count("wall_bounces"), count("cell_crossings"));
    eprintln!(
        "{collisions} collisions, {bounces} bounces, {crossings} crossings; invalidated {} superseded, {} partner",
        count("invalidated_superseded"),
        count("invalidated_partner")
    );
    assert!(collisions > 0 && bounces > 0 && crossings > 0, "{x}");
    assert_eq!(count("events"), collisions + bounces + crossings);
    assert_eq!(json["steps"].as_u64(), Some(count("events")), "the engine's unit of work is the event");
    assert!(count("invalidated_superseded") > 0 && count("invalidated_partner") > 0, "{x}");
    for key in ["events_per_second", "collisions_per_second"] {
        assert!(x[key].as_f64().is_some_and(|v| v > 0.0), "{key} in {x}");
    }
    let hash = json["state_hash"].as_str().expect("a state hash");
    assert!(hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()), "{hash}");
    let stdout = text(&out.stdout);
    assert!(stdout.contains(&format!("events       {} ({collisions} collisions", count("events"))), "{stdout}");
    assert!(stdout.contains("calendar     "), "{stdout}");
    // The lockstep engine's report has no exact figures.
    let args = ["headless", "--scene", "gravity", "--steps", "10", "--report", &r, "--quiet"];
    let out = ballfield(&args);
    assert_ok(&args, &out);
    assert!(report(&report_path)["exact"].is_null());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Exact frames are taken at instants of simulated time, as lockstep's: 100 steps of 1 ms at
/// 20 ms are six frames, at 0, 20, ..., 100 ms, each `--size` pixels, the cradle's striker
/// moving between the first and the last. Stopping at the frames changes nothing: the run ends
/// in the state hash of the run without them. Seen to fail with frames ignored for the exact
/// engine (`record` skipped when the engine is exact: no frames written).
#[test]
fn exact_frames_every_and_size() {
    let dir = temp_dir("exact-frames");
    let frames = dir.join("frames");
    let (f, r) = (frames.display().to_string(), dir.join("report.json").display().to_string());
    let plain = ["headless", "--engine", "exact", "--scene", "cradle", "--steps", "100", "--report", &r, "--quiet"];
    let out = ballfield(&plain);
    assert_ok(&plain, &out);
    let hash = report(&dir.join("report.json"))["state_hash"].clone();
    let args = [&plain[..], &["--frames", &f, "--frame-every", "20ms", "--size", "320x180"]].concat();
    let out = ballfield(&args);
    assert_ok(&args, &out);
    let (found, other) = frames_in(&frames);
    assert!(other.is_empty(), "only frames in {f}: {other:?}");
    assert_eq!(found.len(), 6, "frames {found:?}");
    check_frames(&found, 320, 180);
    let (first, last) = (std::fs::read(&found[0]).unwrap(), std::fs::read(found.last().unwrap()).unwrap());
    assert_ne!(first, last, "the field moved between the first frame and the last");
    assert_eq!(report(&dir.join("report.json"))["state_hash"], hash, "the same bits with frames as without");
    let _ = std::fs::remove_dir_all(&dir);
}

/// An exact run continued from its `--state-out` against one long run (the gravity scene, 0.5 s
/// and 0.5 s against 1 s): the same balls, ids, kinds, masses and diameters, at positions and
/// velocities that agree to rounding but not bit for bit. The state file keeps every bit, but
/// not the course each ball flies: the long run reads a ball's position off the parabola from its
/// last event, `x₀ + (v₀ + ½a·t)·t` at `t` since then, while the continued run starts a new
/// parabola at the written point with its clock at 0, so every later event's instant and
/// position is rounded anew (and the rest and collapse parameters are drawn again from the
/// balls' speeds). Measured: 7 of the 31 balls the same bits, the others within 1.4e-14 m (and
/// 1.8e-15 m/s). Bounds: 1e-12 m, 1e-13 m/s. Seen to fail with `headless::prepare` ignoring the
/// `--state-in` balls (the continued run starts from the scene again, far past both bounds).
#[test]
fn an_exact_run_continued_from_its_state_file() {
    let dir = temp_dir("exact-continued");
    let (long, half, rest) = (dir.join("long.csv"), dir.join("half.csv"), dir.join("rest.csv"));
    let (l, h, r) = (long.display().to_string(), half.display().to_string(), rest.display().to_string());
    let run = |args: &[&str]| {
        let out = ballfield(args);
        assert_ok(args, &out);
    };
    let exact = ["headless", "--engine", "exact", "--scene", "gravity", "--quiet", "--steps"];
    run(&[&exact[..], &["1000", "--state-out", &l]].concat());
    run(&[&exact[..], &["500", "--state-out", &h]].concat());
    run(&[&exact[..], &["500", "--state-in", &h, "--state-out", &r]].concat());
    let field = Field { width: 70.0, height: 50.0, restitution: 1.0 };
    let (one, two) = (read_state(&long, &field).unwrap(), read_state(&rest, &field).unwrap());
    assert_eq!(one.len(), 31, "the gravity scene's 30 balls and the key ball");
    assert_eq!(one.len(), two.len());
    let (mut dx, mut dv, mut identical) = (0.0f64, 0.0f64, 0);
    for (a, b) in one.iter().zip(&two) {
        assert_eq!((a.id, a.kind, a.mass, a.diameter), (b.id, b.kind, b.mass, b.diameter));
        dx = dx.max(a.position.distance(b.position));
        dv = dv.max(a.velocity.distance(b.velocity));
        identical += usize::from(a == b);
    }
    eprintln!("{identical} of {} identical; largest differences {dx:e} m, {dv:e} m/s", one.len());
    assert!(dx < 1e-12 && dv < 1e-13, "{dx:e} m, {dv:e} m/s");
    let _ = std::fs::remove_dir_all(&dir);
}
