//! Determinism: the same scene gives the same bits; a run continued from a state file gives the
//! same bits as one long run.

mod common;

use ballfield::Lockstep;
use ballfield::scenes;
use ballfield::state_file::{parse_state, write_state};

#[test]
fn two_runs_of_the_same_scene_hash_identically() {
    for name in ["default", "pile", "attraction"] {
        let scene = scenes::builtin(name).unwrap().unwrap();
        let mut a = Lockstep::new(&scene);
        let mut b = Lockstep::new(&scene);
        a.run(1500);
        b.run(1500);
        assert_eq!(a.state_hash(), b.state_hash(), "scene {name}");
        assert_ne!(a.state_hash(), Lockstep::new(&scene).state_hash(), "scene {name} moved");
    }
}

#[test]
fn generated_scenes_are_the_same_for_the_same_seed_and_differ_for_another() {
    let text = scenes::BUILTIN.iter().find(|(n, _)| *n == "gas").unwrap().1;
    let origin = ballfield::scene::Origin("gas".into());
    let a = ballfield::Scene::from_toml_str(text, &origin).unwrap();
    let b = ballfield::Scene::from_toml_str(text, &origin).unwrap();
    assert_eq!(a.balls, b.balls);
    let c = ballfield::Scene::from_toml_str(&text.replace("seed = 42", "seed = 43"), &origin).unwrap();
    assert_ne!(a.balls, c.balls);
}

#[test]
fn a_run_continued_from_its_state_file_matches_one_long_run() {
    let dir = std::env::temp_dir().join(format!("ballfield-determinism-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["default", "pile", "attraction", "gas"] {
        let scene = scenes::builtin(name).unwrap().unwrap();
        let mut long = Lockstep::new(&scene);
        long.run(2000);

        let mut first = Lockstep::new(&scene);
        first.run(1000);
        let path = dir.join(format!("{name}.csv"));
        write_state(&path, &first.bodies().to_balls()).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("id,kind,x,y,vx,vy,mass,diameter\n"));
        let balls = parse_state(&text, &path, &scene.field).unwrap();
        assert_eq!(balls, first.bodies().to_balls(), "{name}: the state file round-trips exactly");

        let mut continued = scene.clone();
        continued.balls = balls;
        let mut second = Lockstep::new(&continued);
        second.run(1000);
        assert_eq!(second.state_hash(), long.state_hash(), "{name}: 1000 + 1000 steps == 2000 steps");
    }
    std::fs::remove_dir_all(&dir).ok();
}
