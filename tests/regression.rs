//! Regressions: the lockstep state hash of every shipped scene after a fixed number of steps,
//! checked against the committed table `tests/regression/hashes.txt`.
//!
//! The hash is of the exact bits of every ball (`Lockstep::state_hash`), and the lockstep engine
//! gives the same bits on every run and thread count, so any change to what the engine computes
//! — physics, the order of a sum, a constant — changes a line of the table. That is the point: a
//! change to physics updates the table in the same commit, and the commit message says why the
//! hashes moved (and which). A refactor must leave it alone.
//!
//! Regenerate the table (after a deliberate change to physics) with one command:
//!
//! ```sh
//! BALLFIELD_REGENERATE_HASHES=1 cargo test --release --test regression
//! ```
//!
//! It rewrites `tests/regression/hashes.txt` and passes; `git diff tests/regression` then shows
//! which scenes moved. The table's lines are `scene hash` for every built-in scene
//! (`scenes::BUILTIN`, the files of `assets/scenes/`), after `STEPS` steps from the scene as
//! shipped. The hash does not depend on the thread count (`tests/determinism.rs`); this test runs
//! each engine on one thread and the scenes side by side (2,000 steps of all 24: about 2 s). They
//! are the figures `ballfield headless --scene NAME --steps 2000 --report R.json` writes as
//! `state_hash`.
//!
//! Seen to fail with the sub-step split's `MAX_TRAVEL` at 0.51 radii instead of 0.5
//! (`src/engine/lockstep.rs`): "hard/scales: 998ba4ec894ec8d9, the table says 2783572d6e106457".

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use ballfield::Lockstep;
use ballfield::scenes;

/// Steps each scene runs before its hash is taken (2 s of the usual 1 ms step).
const STEPS: u64 = 2000;

fn table_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/regression/hashes.txt")
}

/// Every built-in scene's hash after `STEPS` steps, by name, computed in parallel over the scenes
/// (each engine on one thread of its own).
fn hashes_now() -> BTreeMap<String, String> {
    let names: Vec<&str> = scenes::BUILTIN.iter().map(|(n, _)| *n).collect();
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(names.len());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let found = std::sync::Mutex::new(BTreeMap::new());
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(name) = names.get(k) else { break };
                    let scene = scenes::builtin(name).unwrap().unwrap_or_else(|e| panic!("{name}: {e}"));
                    let mut engine = Lockstep::new(&scene);
                    engine.set_threads(1);
                    engine.run(STEPS);
                    found.lock().unwrap().insert(name.to_string(), format!("{:016x}", engine.state_hash()));
                }
            });
        }
    });
    found.into_inner().unwrap()
}

fn read_table(text: &str) -> BTreeMap<String, String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (name, hash) = l.split_once(' ').unwrap_or_else(|| panic!("bad line in hashes.txt: {l:?}"));
            (name.to_string(), hash.trim().to_string())
        })
        .collect()
}

fn write_table(hashes: &BTreeMap<String, String>) -> String {
    let mut text = format!(
        "# The lockstep state hash of every built-in scene after {STEPS} steps (tests/regression.rs).\n\
         # Regenerate: BALLFIELD_REGENERATE_HASHES=1 cargo test --release --test regression\n"
    );
    for (name, hash) in hashes {
        writeln!(text, "{name} {hash}").unwrap();
    }
    text
}

#[test]
fn every_shipped_scene_hashes_as_the_table_says() {
    let now = hashes_now();
    assert_eq!(now.len(), scenes::BUILTIN.len());
    let path = table_path();
    if std::env::var_os("BALLFIELD_REGENERATE_HASHES").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, write_table(&now)).unwrap();
        eprintln!("wrote {}", path.display());
        return;
    }
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let table = read_table(&text);
    let mut wrong = Vec::new();
    for (name, hash) in &now {
        match table.get(name) {
            Some(expected) if expected == hash => {}
            Some(expected) => wrong.push(format!("{name}: {hash}, the table says {expected}")),
            None => wrong.push(format!("{name}: {hash}, not in the table")),
        }
    }
    for name in table.keys().filter(|n| !now.contains_key(*n)) {
        wrong.push(format!("{name}: in the table but not a built-in scene"));
    }
    assert!(
        wrong.is_empty(),
        "the lockstep bits changed:\n  {}\nIf the change to physics is deliberate, regenerate the table with\n  \
         BALLFIELD_REGENERATE_HASHES=1 cargo test --release --test regression\nand say in the commit why these moved.",
        wrong.join("\n  ")
    );
}
