//! The scenes shipped in `assets/scenes/`, built into the binary so `--scene gas` works anywhere.

use std::path::Path;

use crate::scene::{Origin, Scene, SceneError};

/// `(name, TOML text)` of every built-in scene.
pub const BUILTIN: &[(&str, &str)] = &[
    ("default", include_str!("../assets/scenes/default.toml")),
    ("vacuum", include_str!("../assets/scenes/vacuum.toml")),
    ("gravity", include_str!("../assets/scenes/gravity.toml")),
    ("drag", include_str!("../assets/scenes/drag.toml")),
    ("attraction", include_str!("../assets/scenes/attraction.toml")),
    ("pile", include_str!("../assets/scenes/pile.toml")),
    ("gas", include_str!("../assets/scenes/gas.toml")),
    ("cradle", include_str!("../assets/scenes/cradle.toml")),
    ("reference/kepler-e0", include_str!("../assets/scenes/reference/kepler-e0.toml")),
    ("reference/kepler-e05", include_str!("../assets/scenes/reference/kepler-e05.toml")),
    ("reference/drag-fall", include_str!("../assets/scenes/reference/drag-fall.toml")),
    ("reference/projectile", include_str!("../assets/scenes/reference/projectile.toml")),
    ("reference/collision-head-on", include_str!("../assets/scenes/reference/collision-head-on.toml")),
    ("reference/collision-oblique", include_str!("../assets/scenes/reference/collision-oblique.toml")),
    ("hard/pile", include_str!("../assets/scenes/hard/pile.toml")),
    ("hard/elastic-pile", include_str!("../assets/scenes/hard/elastic-pile.toml")),
    ("hard/cradle", include_str!("../assets/scenes/hard/cradle.toml")),
    ("hard/mass-ratio", include_str!("../assets/scenes/hard/mass-ratio.toml")),
    ("hard/fast", include_str!("../assets/scenes/hard/fast.toml")),
    ("hard/close-attraction", include_str!("../assets/scenes/hard/close-attraction.toml")),
    ("hard/crowd", include_str!("../assets/scenes/hard/crowd.toml")),
    ("hard/coincident", include_str!("../assets/scenes/hard/coincident.toml")),
    ("hard/corners", include_str!("../assets/scenes/hard/corners.toml")),
    ("hard/scales", include_str!("../assets/scenes/hard/scales.toml")),
];

/// Loads a built-in scene by name.
pub fn builtin(name: &str) -> Option<Result<Scene, SceneError>> {
    BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(n, text)| Scene::from_toml_str(text, &Origin(format!("assets/scenes/{n}.toml"))))
}

/// Resolves a `--scene` argument: an existing file, or else the name of a built-in scene.
pub fn resolve(arg: &str) -> Result<Scene, SceneError> {
    let path = Path::new(arg);
    if path.exists() {
        return Scene::load(path);
    }
    let stem = arg.strip_suffix(".toml").unwrap_or(arg);
    if let Some(scene) = builtin(stem) {
        return scene;
    }
    let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
    Err(SceneError::Read {
        file: path.to_path_buf(),
        cause: std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("no such file, and not a built-in scene (built-in: {})", names.join(", ")),
        ),
    })
}
