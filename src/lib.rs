//! ballfield: a 2D ball-physics game. Real balls — mass in kg, diameter in m, velocity in m/s —
//! in a walled field under the effects a scene turns on.
//!
//! Rooms, dependencies pointing down only (see DESIGN.md):
//! - [`physics`] — pure f64 functions on plain data;
//! - [`scene`] / [`scenes`] — what is on the field (TOML);
//! - [`lockstep`] — the deterministic reference engine;
//! - [`app`] — the window: input, panel, the 15 ms sampling loop;
//! - [`render`] — draws a snapshot with wgpu, in a window or offscreen;
//! - [`engine`] — the one interface every engine is driven through;
//! - [`headless`] — runs without a window: the report, state files and frames.

pub mod accuracy;
pub mod app;
pub mod engine;
pub mod headless;
pub mod lockstep;
pub mod physics;
pub mod render;
pub mod runtime;
pub mod scene;
pub mod scenes;

pub use engine::{Engine, EngineError, EngineKind};
pub use lockstep::{Lockstep, StepCounters};
pub use scene::{Scene, SceneError};
