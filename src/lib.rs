//! ballfield: a 2D ball-physics game. Real balls — mass in kg, diameter in m, velocity in m/s —
//! in a walled field under the effects a scene turns on.
//!
//! Rooms, dependencies pointing down only (see DESIGN.md):
//! - [`app`] — the window: input, panel, the 15 ms sampling loop;
//! - [`headless`] — runs without a window: the report, state files and frames;
//! - [`render`] — draws a snapshot with wgpu, in a window or offscreen;
//! - [`engine`] — the one interface every engine is driven through, and its three engines:
//!   [`runtime`] (one thread per ball, the game's default), [`lockstep`] (the deterministic
//!   reference) and the exact, event-driven one; the first two are re-exported here by name;
//! - [`physics`] — pure f64 functions on plain data, which every engine calls;
//! - [`scene`] / [`scenes`] — what is on the field (TOML);
//! - [`accuracy`] — the accuracy report (`ballfield accuracy`), run on the engines.

#![warn(missing_docs)]

pub mod accuracy;
pub mod app;
pub mod engine;
pub mod headless;
pub mod physics;
pub mod render;
pub mod scene;
pub mod scenes;

pub use engine::{Engine, EngineError, EngineKind, lockstep, runtime};
pub use lockstep::{Lockstep, StepCounters};
pub use scene::{Scene, SceneError};
