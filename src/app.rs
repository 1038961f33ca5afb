//! The window (DESIGN.md, "app"): a winit [`ApplicationHandler`] that turns keys, the mouse and
//! the panel into commands to the engine, samples the field every 15 ms (configurable) and draws
//! it through the same [`Renderer`] as the headless frames, with an egui panel on top.
//!
//! The window is created in `resumed()` and held in an `Arc` so the wgpu surface can be
//! `'static`. For GL the instance is created with the event loop's display handle (ci-notes.md).

mod panel;

use std::collections::{HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec2;
use serde::Serialize;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

pub use panel::{Command, HELP};

use crate::engine::{self, Engine, EngineKind};
use crate::physics::{
    Attraction, Ball, BallId, BallKind, Bodies, Effects, attraction_potential_energy, gravity_potential_energy,
    kinetic_energy, momentum,
};
use crate::render::{
    BallSprite, BallStyle, FrameSnapshot, Gpu, Layout, Renderer, ball_colour, instance_descriptor, palette,
    raise_render_priority, with_style,
};
use crate::scene::Scene;
use crate::scenes;
use panel::{EnergySample, Readouts, Settings};

/// How the window runs.
#[derive(Clone, Debug)]
pub struct AppOptions {
    /// The scene's name or file, as given.
    pub scene_name: String,
    pub scene: Scene,
    pub engine: EngineKind,
    /// How often the field is sampled and redrawn.
    pub sample_every: Duration,
    /// Close by itself after this long (for tests and demos).
    pub exit_after: Option<Duration>,
    /// Write an [`AppReport`] here when the window closes.
    pub report: Option<PathBuf>,
    /// Window size in pixels; `None` = the field at 10 px/m plus the panel.
    pub size: Option<(u32, u32)>,
    pub panel: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum AppError {
    #[error("cannot open a window: {0} (is there a display? `ballfield headless` needs none)")]
    EventLoop(String),
    #[error("{0}")]
    Start(String),
    #[error("--report {file}: cannot write: {cause}")]
    Report { file: PathBuf, cause: std::io::Error },
}

/// What happened in the window, written at exit with `--report` (the end-to-end test reads it).
#[derive(Clone, Debug, Default, Serialize)]
pub struct AppReport {
    pub scene: String,
    pub engine: String,
    pub adapter: String,
    pub surface_format: String,
    pub present_mode: String,
    pub seconds: f64,
    pub frames: u64,
    pub frames_per_second: f64,
    /// Median time from the start of a frame to the GPU having drawn it (panel included), ms.
    pub frame_ms_median: f64,
    pub balls_start: usize,
    pub balls_end: usize,
    pub balls_added: u64,
    pub balls_removed: u64,
    /// The key ball's position at the first and the last sample, m.
    pub key_start: Option<[f64; 2]>,
    pub key_end: Option<[f64; 2]>,
    /// Key presses acted on (synthetic ones are ignored and not counted).
    pub key_presses: u64,
    pub errors: Vec<String>,
}

/// Runs the window until it is closed.
pub fn run(options: AppOptions) -> Result<AppReport, AppError> {
    let event_loop = EventLoop::new().map_err(|e| AppError::EventLoop(e.to_string()))?;
    let mut app = App::new(options)?;
    event_loop.run_app(&mut app).map_err(|e| AppError::EventLoop(e.to_string()))?;
    if let Some(e) = app.fatal.take() {
        return Err(e);
    }
    app.finish()
}

/// The GPU side of the window.
struct Graphics {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    renderer: Renderer,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    /// The last full frame, field and panel (see `draw`); `None` if the surface cannot be
    /// copied into.
    layer: Option<wgpu::Texture>,
    copy_to_surface: bool,
}

struct Grab {
    ball: Ball,
    /// Recent cursor positions (m) and when, for the throw's velocity.
    trail: VecDeque<(Instant, DVec2)>,
}

struct App {
    options: AppOptions,
    scene: Scene,
    engine: Box<dyn Engine>,
    /// The engine last switched to, whether it started or not: E goes on from it (so that an
    /// engine that refuses the scene, as the exact one refuses drag, is skipped by the next E).
    engine_tried: EngineKind,
    /// When the engine last ticked.
    last_tick: Instant,
    gfx: Option<Graphics>,
    egui_ctx: egui::Context,
    settings: Settings,
    readouts: Readouts,
    show_panel: bool,
    show_help: bool,
    /// Arrow keys held: left, right, down, up.
    arrows: [bool; 4],
    balls: Vec<Ball>,
    snapshot: FrameSnapshot,
    layout: Option<Layout>,
    cursor: Option<DVec2>,
    grab: Option<Grab>,
    traces: HashMap<BallId, VecDeque<DVec2>>,
    next_tick: Instant,
    started: Instant,
    last_diagnostics: Instant,
    last_rate: Instant,
    pressure_window: VecDeque<(Instant, f64)>,
    frame_times: Vec<f64>,
    frame_stamps: VecDeque<Instant>,
    /// Scratch for the diagnostics, kept for its memory.
    diag_bodies: Bodies,
    report: AppReport,
    fatal: Option<AppError>,
    /// The panel must be drawn anew at the next frame (input, a command, an animation).
    panel_dirty: bool,
    /// When the panel's readouts are next redrawn.
    panel_due: Instant,
    /// Width of the panel as last drawn, pixels.
    panel_width_px: u32,
}

/// What a new ball is like in this scene: the first plain ball's mass and size, or 1 kg and 1 m.
fn new_ball_shape(scene: &Scene) -> (f64, f64) {
    scene.balls.iter().find(|b| b.kind == BallKind::Ball).map(|b| (b.mass, b.diameter)).unwrap_or((1.0, 1.0))
}

fn settings_for(scene: &Scene, index: usize, effects: &Effects) -> Settings {
    Settings {
        pull: scene.pull,
        key_mass: scene.balls.iter().find(|b| b.kind == BallKind::Key).map(|b| b.mass).unwrap_or(5.0),
        restitution: scene.field.restitution,
        time_scale: 1.0,
        gravity: effects.gravity.is_some(),
        drag: effects.drag.is_some(),
        attraction: effects.attraction.is_some(),
        collisions: effects.collisions.is_some(),
        vectors: false,
        centre_of_mass: false,
        traces: false,
        scene: index,
    }
}

const HISTORY_SECONDS: f64 = 20.0;
const PANEL_WIDTH: f32 = 300.0;
/// How often the panel's readouts are redrawn when nothing else changes it.
const PANEL_REFRESH: Duration = Duration::from_millis(250);

impl App {
    fn new(options: AppOptions) -> Result<App, AppError> {
        let scene = options.scene.clone();
        let engine = engine::start(options.engine, &scene, None).map_err(|e| AppError::Start(e.to_string()))?;
        let index = scenes::BUILTIN.iter().position(|(n, _)| *n == scene.name).unwrap_or(0);
        let settings = settings_for(&scene, index, &scene.effects);
        let now = Instant::now();
        Ok(App {
            engine_tried: options.engine,
            show_panel: options.panel,
            report: AppReport {
                scene: options.scene_name.clone(),
                engine: options.engine.name().into(),
                balls_start: scene.balls.len(),
                ..Default::default()
            },
            options,
            engine,
            last_tick: Instant::now(),
            gfx: None,
            egui_ctx: egui::Context::default(),
            settings,
            readouts: Readouts { scene: describe_scene(&scene), ..Default::default() },
            show_help: false,
            arrows: [false; 4],
            balls: Vec::new(),
            snapshot: FrameSnapshot::new(scene.field),
            layout: None,
            cursor: None,
            grab: None,
            traces: HashMap::new(),
            next_tick: now,
            started: now,
            last_diagnostics: now,
            last_rate: now,
            pressure_window: VecDeque::new(),
            frame_times: Vec::new(),
            frame_stamps: VecDeque::new(),
            diag_bodies: Bodies::default(),
            scene,
            fatal: None,
            panel_dirty: true,
            panel_due: now,
            panel_width_px: 0,
        })
    }

    fn finish(mut self) -> Result<AppReport, AppError> {
        self.engine.sample(&mut self.balls);
        self.shutdown_engine();
        let r = &mut self.report;
        r.seconds = self.started.elapsed().as_secs_f64();
        r.frames_per_second = r.frames as f64 / r.seconds.max(1e-9);
        r.balls_end = self.balls.len();
        r.key_end = self.balls.iter().find(|b| b.kind == BallKind::Key).map(|b| b.position.to_array());
        self.frame_times.sort_by(f64::total_cmp);
        r.frame_ms_median = self.frame_times.get(self.frame_times.len() / 2).copied().unwrap_or(0.0) * 1e3;
        if let Some(file) = &self.options.report {
            let json = serde_json::to_string_pretty(r).expect("the report serialises") + "\n";
            std::fs::write(file, json).map_err(|cause| AppError::Report { file: file.clone(), cause })?;
        }
        Ok(self.report)
    }

    /// Stops the engine's threads and joins them, logging any ball thread that had panicked.
    fn shutdown_engine(&mut self) {
        for p in self.engine.shutdown().panics {
            log::error!("a ball thread had panicked: {p}");
        }
    }

    fn init_graphics(&mut self, event_loop: &ActiveEventLoop) -> Result<Graphics, String> {
        let (w, h) = self.options.size.unwrap_or_else(|| {
            let (w, h) = Layout::default_size(&self.scene.field);
            (w + if self.show_panel { PANEL_WIDTH as u32 } else { 0 }, h.max(680))
        });
        let attributes = Window::default_attributes()
            .with_title(format!("ballfield — {}", self.scene.name))
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h))
            .with_min_inner_size(winit::dpi::PhysicalSize::new(200, 150));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| e.to_string())?);
        raise_render_priority();
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle(Box::new(event_loop.owned_display_handle()));
        desc.backends = instance_descriptor().backends;
        let instance = wgpu::Instance::new(desc.with_env());
        let surface = instance.create_surface(window.clone()).map_err(|e| e.to_string())?;
        let gpu = Gpu::with_instance(instance, Some(&surface)).map_err(|e| e.to_string())?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
            .ok_or("the GPU adapter cannot present to this window")?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // A non-sRGB format if there is one: egui blends in gamma space and wants one, and the
        // ball shaders write gamma-space colour to such a target (the offscreen frames use an
        // sRGB texture; the two differ only in how anti-aliased edges blend).
        if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
            config.format = *f;
        }
        // GL presents only with Fifo; AutoVsync picks what the surface can do.
        config.present_mode = if caps.present_modes.contains(&wgpu::PresentMode::Fifo) {
            wgpu::PresentMode::Fifo
        } else {
            wgpu::PresentMode::AutoVsync
        };
        // The panel's cached pixels are copied into the frame (see `draw`), and the renderer
        // writes splatted balls into it (`BallPath::Splat`).
        let copy_to_surface = caps.usages.contains(wgpu::TextureUsages::COPY_DST);
        if copy_to_surface {
            config.usage |= wgpu::TextureUsages::COPY_DST;
        }
        surface.configure(&gpu.device, &config);
        let renderer = Renderer::new(&gpu.device, &gpu.queue, config.format);
        let egui_renderer = egui_wgpu::Renderer::new(
            &gpu.device,
            config.format,
            egui_wgpu::RendererOptions { dithering: false, ..Default::default() },
        );
        let egui_state = egui_winit::State::new(
            self.egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        self.report.adapter = gpu.describe();
        self.report.surface_format = format!("{:?}", config.format);
        self.report.present_mode = format!("{:?}", config.present_mode);
        self.readouts.adapter = gpu.describe();
        log::info!("window on {} ({:?}, {:?})", gpu.describe(), config.format, config.present_mode);
        Ok(Graphics { window, surface, config, gpu, renderer, egui_state, egui_renderer, layer: None, copy_to_surface })
    }

    // ---- commands -------------------------------------------------------------------------

    fn pull_force(&self) -> DVec2 {
        let [l, r, d, u] = self.arrows.map(|b| b as i32 as f64);
        DVec2::new(r - l, u - d).normalize_or_zero() * self.settings.pull
    }

    fn update_pull(&mut self) {
        let f = self.pull_force();
        self.engine.set_pull(f);
    }

    fn effects_from_settings(&self) -> Effects {
        let s = &self.settings;
        let base = &self.scene.effects;
        let mut e = Effects::default();
        if s.gravity {
            e.gravity = Some(base.gravity.unwrap_or_default());
        }
        if s.drag {
            e.drag = Some(base.drag.unwrap_or_default());
        }
        if s.attraction {
            // The real G moves nothing visible: scenes without attraction get the `attraction`
            // scene's scaled G = 1.
            e.attraction = Some(base.attraction.unwrap_or(Attraction { g_constant: 1.0, ..Attraction::default() }));
        }
        if s.collisions {
            let mut c = base.collisions.unwrap_or_default();
            c.restitution = s.restitution;
            e.collisions = Some(c);
        }
        e
    }

    fn restart(&mut self, scene: Scene, kind: EngineKind) {
        // The running engine stays if the new one cannot start: nothing running is lost.
        match engine::start(kind, &scene, None) {
            Ok(engine) => {
                self.shutdown_engine();
                self.engine = engine;
                self.last_tick = Instant::now();
                self.report.engine = kind.name().into();
            }
            Err(e) => {
                self.readouts.message = format!("cannot start the {kind} engine: {e}");
                return;
            }
        }
        let index = scenes::BUILTIN.iter().position(|(n, _)| *n == scene.name).unwrap_or(self.settings.scene);
        let keep = (self.settings.vectors, self.settings.centre_of_mass, self.settings.traces);
        self.settings = settings_for(&scene, index, &scene.effects);
        (self.settings.vectors, self.settings.centre_of_mass, self.settings.traces) = keep;
        self.readouts.scene = describe_scene(&scene);
        self.readouts.history.clear();
        self.pressure_window.clear();
        self.traces.clear();
        self.grab = None;
        self.snapshot.field = scene.field;
        self.scene = scene;
        self.update_pull();
    }

    fn apply(&mut self, command: Command, event_loop: &ActiveEventLoop) {
        self.readouts.message.clear();
        self.panel_dirty = true;
        match command {
            Command::AddBall => {
                let (m, d) = new_ball_shape(&self.scene);
                match self.engine.add_ball_at_free_spot(m, d) {
                    Ok(_) => self.report.balls_added += 1,
                    Err(e) => self.readouts.message = e.to_string(),
                }
            }
            Command::RemoveLast => {
                if self.engine.remove_last().is_some() {
                    self.report.balls_removed += 1;
                }
            }
            Command::TogglePause => {
                let p = !self.engine.is_paused();
                self.engine.set_paused(p);
                self.last_tick = Instant::now();
            }
            Command::Step => self.engine.single_step(self.options.sample_every),
            Command::Reset => self.restart(self.scene.clone(), self.engine.kind()),
            Command::ToggleGravity => self.toggle_effect(|s| &mut s.gravity),
            Command::ToggleDrag => self.toggle_effect(|s| &mut s.drag),
            Command::ToggleAttraction => self.toggle_effect(|s| &mut s.attraction),
            Command::ToggleCollisions => self.toggle_effect(|s| &mut s.collisions),
            Command::Scene(k) => {
                if let Some(Ok(scene)) = scenes::BUILTIN.get(k).and_then(|(n, _)| scenes::builtin(n)) {
                    self.report.scene = scene.name.clone();
                    self.restart(scene, self.engine.kind());
                    if let Some(g) = &self.gfx {
                        g.window.set_title(&format!("ballfield — {}", self.scene.name));
                    }
                }
            }
            Command::Engine(kind) => {
                self.engine_tried = kind;
                // The new engine starts from where the balls are now.
                let mut scene = self.scene.clone();
                self.engine.sample(&mut self.balls);
                scene.balls = self.balls.clone();
                scene.balls.sort_by_key(|b| (b.kind != BallKind::Key, b.id));
                scene.effects = self.effects_from_settings();
                scene.pull = self.settings.pull;
                let keep = self.settings.clone();
                self.restart(scene, kind);
                self.settings = keep;
                self.engine.set_restitution(self.settings.restitution, self.settings.restitution);
                self.engine.set_time_scale(self.settings.time_scale);
            }
            Command::TogglePanel => self.show_panel = !self.show_panel,
            Command::ToggleHelp => self.show_help = !self.show_help,
            Command::ToggleVectors => self.settings.vectors = !self.settings.vectors,
            Command::ToggleCentreOfMass => self.settings.centre_of_mass = !self.settings.centre_of_mass,
            Command::ToggleTraces => {
                self.settings.traces = !self.settings.traces;
                self.traces.clear();
            }
            Command::Quit => event_loop.exit(),
            Command::SetPull(p) => {
                self.settings.pull = p.max(0.0);
                self.update_pull();
            }
            Command::SetKeyMass(m) => {
                self.settings.key_mass = m;
                if let Some(key) = self.engine.key_ball()
                    && let Err(e) = self.engine.set_mass(key, m)
                {
                    self.readouts.message = e.to_string();
                }
            }
            Command::SetRestitution(e) => {
                self.settings.restitution = e;
                self.engine.set_restitution(e, e);
            }
            Command::SetTimeScale(t) => {
                self.settings.time_scale = t;
                self.engine.set_time_scale(t);
            }
        }
    }

    fn toggle_effect(&mut self, which: fn(&mut Settings) -> &mut bool) {
        let flag = which(&mut self.settings);
        *flag = !*flag;
        let effects = self.effects_from_settings();
        self.engine.set_effects(effects);
    }

    fn key(&mut self, code: KeyCode, pressed: bool, repeat: bool, event_loop: &ActiveEventLoop) {
        let arrow = match code {
            KeyCode::ArrowLeft => Some(0),
            KeyCode::ArrowRight => Some(1),
            KeyCode::ArrowDown => Some(2),
            KeyCode::ArrowUp => Some(3),
            _ => None,
        };
        if let Some(k) = arrow {
            if self.arrows[k] != pressed {
                self.arrows[k] = pressed;
                self.update_pull();
            }
            if pressed && !repeat {
                self.report.key_presses += 1;
            }
            return;
        }
        if !pressed || repeat {
            return;
        }
        let command = match code {
            KeyCode::KeyA | KeyCode::Equal | KeyCode::NumpadAdd => Command::AddBall,
            KeyCode::Backspace | KeyCode::Delete | KeyCode::Minus | KeyCode::NumpadSubtract => Command::RemoveLast,
            KeyCode::Space | KeyCode::KeyP => Command::TogglePause,
            KeyCode::KeyS | KeyCode::Period => Command::Step,
            KeyCode::KeyR => Command::Reset,
            KeyCode::KeyG => Command::ToggleGravity,
            KeyCode::KeyD => Command::ToggleDrag,
            KeyCode::KeyN => Command::ToggleAttraction,
            KeyCode::KeyC => Command::ToggleCollisions,
            KeyCode::KeyE => Command::Engine(self.engine_tried.next()),
            KeyCode::KeyV => Command::ToggleVectors,
            KeyCode::KeyM => Command::ToggleCentreOfMass,
            KeyCode::KeyT => Command::ToggleTraces,
            KeyCode::Tab => Command::TogglePanel,
            KeyCode::KeyH | KeyCode::F1 => Command::ToggleHelp,
            KeyCode::Escape | KeyCode::KeyQ => Command::Quit,
            KeyCode::Digit1 => Command::Scene(0),
            KeyCode::Digit2 => Command::Scene(1),
            KeyCode::Digit3 => Command::Scene(2),
            KeyCode::Digit4 => Command::Scene(3),
            KeyCode::Digit5 => Command::Scene(4),
            KeyCode::Digit6 => Command::Scene(5),
            KeyCode::Digit7 => Command::Scene(6),
            KeyCode::Digit8 => Command::Scene(7),
            _ => return,
        };
        self.report.key_presses += 1;
        self.apply(command, event_loop);
    }

    // ---- mouse ----------------------------------------------------------------------------

    fn cursor_metres(&self) -> Option<DVec2> {
        Some(self.layout?.to_metres(self.cursor?))
    }

    fn mouse(&mut self, button: MouseButton, pressed: bool) {
        let Some(p) = self.cursor_metres() else { return };
        let field = self.engine.field();
        let inside = p.x >= 0.0 && p.y >= 0.0 && p.x <= field.width && p.y <= field.height;
        match (button, pressed) {
            (MouseButton::Left, true) if inside => {
                // The topmost ball under the cursor, else a new ball here.
                let hit = self.balls.iter().rev().find(|b| b.position.distance(p) <= b.radius().max(0.3)).copied();
                match hit {
                    Some(b) => {
                        if let Ok(ball) = self.engine.remove_ball(b.id) {
                            let mut trail = VecDeque::new();
                            trail.push_back((Instant::now(), p));
                            self.grab = Some(Grab { ball, trail });
                        }
                    }
                    None => self.drop_ball_at(p),
                }
            }
            (MouseButton::Right, true) if inside => self.drop_ball_at(p),
            (MouseButton::Left, false) => {
                if let Some(grab) = self.grab.take() {
                    let v = throw_velocity(&grab.trail);
                    let ball = Ball { position: p, velocity: v, ..grab.ball };
                    if let Err(e) = self.engine.put_back(ball) {
                        self.readouts.message = e.to_string();
                    }
                    if ball.kind == BallKind::Key {
                        self.update_pull();
                    }
                }
            }
            _ => {}
        }
    }

    fn drop_ball_at(&mut self, p: DVec2) {
        let (mass, diameter) = new_ball_shape(&self.scene);
        let ball = Ball { id: BallId(0), kind: BallKind::Ball, position: p, velocity: DVec2::ZERO, mass, diameter };
        match self.engine.add_ball(ball) {
            Ok(_) => self.report.balls_added += 1,
            Err(e) => self.readouts.message = e.to_string(),
        }
    }

    // ---- the 15 ms tick -------------------------------------------------------------------

    fn tick(&mut self) {
        let now = Instant::now();
        self.engine.tick(now - self.last_tick);
        self.last_tick = now;
        self.engine.sample(&mut self.balls);
        if self.report.key_start.is_none() {
            self.report.key_start = self.balls.iter().find(|b| b.kind == BallKind::Key).map(|b| b.position.to_array());
        }
        if let Some(p) = self.cursor_metres()
            && let Some(g) = &mut self.grab
        {
            g.trail.push_back((now, p));
            while g.trail.len() > 2 && now - g.trail[0].0 > Duration::from_millis(100) {
                g.trail.pop_front();
            }
        }
        self.readouts.balls = self.balls.len() + self.grab.is_some() as usize;
        self.readouts.paused = self.engine.is_paused();
        self.readouts.engine = Some(self.engine.kind());
        if now - self.last_rate >= Duration::from_millis(500) {
            self.readouts.sim_rate = self.engine.rate();
            self.last_rate = now;
        }
        if now - self.last_diagnostics >= Duration::from_millis(100) {
            self.last_diagnostics = now;
            self.diagnostics(now);
        }
        if self.settings.traces {
            let keep: Vec<BallId> =
                self.balls.iter().filter(|b| b.kind == BallKind::Key || b.id.0 < 32).map(|b| b.id).collect();
            for b in self.balls.iter().filter(|b| keep.contains(&b.id)) {
                let t = self.traces.entry(b.id).or_default();
                if t.back().is_none_or(|q| q.distance(b.position) > 0.05) {
                    t.push_back(b.position);
                }
                while t.len() > 150 {
                    t.pop_front();
                }
            }
            self.traces.retain(|id, _| keep.contains(id));
        }
    }

    fn diagnostics(&mut self, now: Instant) {
        // What the panel shows: energies, momentum and pressure, O(n) sums (attraction's
        // potential is O(n²), as the effect itself is). `measure` also finds the largest overlap
        // with a broad phase over all the balls, and a sorted copy of them was made for it: 25–60
        // ms at 100,000 balls, every 100 ms, a stall of the 15 ms cadence; now about 1 ms.
        let bodies = &mut self.diag_bodies;
        bodies.clear();
        for b in &self.balls {
            bodies.push(*b);
        }
        let effects = self.engine.effects();
        let walls = self.engine.wall_impulses();
        let kinetic = kinetic_energy(bodies);
        let potential = gravity_potential_energy(bodies, &effects) + attraction_potential_energy(bodies, &effects);
        let d = Readout { kinetic, potential, total: kinetic + potential, momentum: momentum(bodies).to_array() };
        let r = &mut self.readouts;
        r.kinetic = d.kinetic;
        r.potential = d.potential;
        r.total = d.total;
        r.momentum = d.momentum;
        let t = (now - self.started).as_secs_f64();
        r.history.push_back(EnergySample {
            t,
            kinetic: d.kinetic,
            potential: d.potential,
            total: d.total,
            momentum: DVec2::from(d.momentum).length(),
        });
        while r.history.front().is_some_and(|s| t - s.t > HISTORY_SECONDS) {
            r.history.pop_front();
        }
        // Pressure: impulse on all walls per second per metre of wall, over the last second.
        let total = walls.total();
        self.pressure_window.push_back((now, total));
        while self.pressure_window.len() > 2 && now - self.pressure_window[0].0 > Duration::from_secs(1) {
            self.pressure_window.pop_front();
        }
        let (t0, j0) = self.pressure_window[0];
        let perimeter = 2.0 * (self.scene.field.width + self.scene.field.height);
        let dt = (now - t0).as_secs_f64();
        r.pressure = if dt > 0.0 { (total - j0).max(0.0) / dt / perimeter } else { 0.0 };
    }

    /// Fills the snapshot from the last sample, with the overlays that are on.
    fn fill_snapshot(&mut self) {
        let pull = self.pull_force();
        let s = &mut self.snapshot;
        s.field = self.engine.field();
        s.balls.clear();
        s.overlays.clear();
        s.balls.extend(self.balls.iter().map(|b| BallSprite {
            x: b.position.x as f32,
            y: b.position.y as f32,
            radius: b.radius() as f32,
            colour: ball_colour(b.kind, b.id.0),
        }));
        if let Some(g) = &self.grab {
            let p = self.cursor.zip(self.layout).map(|(c, l)| l.to_metres(c)).unwrap_or(g.ball.position);
            s.balls.push(BallSprite {
                x: p.x as f32,
                y: p.y as f32,
                radius: g.ball.radius() as f32,
                colour: with_style(ball_colour(g.ball.kind, g.ball.id.0), BallStyle::Held),
            });
        }
        if self.settings.traces {
            for t in self.traces.values() {
                let points: Vec<DVec2> = t.iter().copied().collect();
                s.add_trace(&points, palette::TRACE);
            }
        }
        if self.settings.vectors {
            s.add_velocity_vectors(self.balls.iter().map(|b| (b.position, b.velocity)), 0.25);
        }
        if pull != DVec2::ZERO
            && let Some(k) = self.balls.iter().find(|b| b.kind == BallKind::Key)
        {
            // The pull as a white line from the key ball: 1 m per 100 N.
            s.overlays.push(crate::render::Segment::line(k.position, k.position + pull / 100.0, 2.0, palette::PULL));
        }
        if self.settings.centre_of_mass && !self.balls.is_empty() {
            let m: f64 = self.balls.iter().map(|b| b.mass).sum();
            let com = self.balls.iter().map(|b| b.position * b.mass).sum::<DVec2>() / m;
            s.add_cross(com, 1.5, palette::CENTRE_OF_MASS);
        }
    }

    // ---- drawing --------------------------------------------------------------------------

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let Some(mut gfx) = self.gfx.take() else { return };
        self.draw(&mut gfx, event_loop);
        self.gfx = Some(gfx);
    }

    fn draw(&mut self, gfx: &mut Graphics, event_loop: &ActiveEventLoop) {
        let t0 = Instant::now();
        let size = gfx.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return; // minimised
        }
        let frame = match gfx.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) => f,
            wgpu::CurrentSurfaceTexture::Suboptimal(f) => {
                // Draw this one, reconfigure for the next.
                gfx.config.width = size.width;
                gfx.config.height = size.height;
                f
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                gfx.config.width = size.width;
                gfx.config.height = size.height;
                gfx.surface.configure(&gfx.gpu.device, &gfx.config);
                gfx.window.request_redraw();
                return;
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                // The surface itself is gone: make a new one for the same window.
                match gfx.gpu.instance.create_surface(gfx.window.clone()) {
                    Ok(surface) => {
                        gfx.surface = surface;
                        gfx.config.width = size.width;
                        gfx.config.height = size.height;
                        gfx.surface.configure(&gfx.gpu.device, &gfx.config);
                        gfx.window.request_redraw();
                    }
                    Err(e) => log::error!("the window's surface was lost and cannot be made again: {e}"),
                }
                return;
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return,
            other => {
                log::warn!("cannot get the next frame: {other:?}");
                return;
            }
        };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let device = gfx.gpu.device.clone();
        let queue = gfx.gpu.queue.clone();

        // The panel is drawn (egui run, tessellated and rasterised) only when it may have
        // changed: on input, after a command, while egui animates or shows a window over the
        // field, and every PANEL_REFRESH for its readouts. In between, the frame draws the field
        // and copies the panel's pixels from the layer it was last drawn into. On a CPU adapter
        // rasterising the panel costs ~15 ms, the copy well under 1.
        let cached = gfx.layer.as_ref().is_some_and(|l| (l.width(), l.height()) == (size.width, size.height))
            && self.panel_width_px > 0
            && self.show_panel
            && !self.show_help
            && !self.panel_dirty
            && Instant::now() < self.panel_due;
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("window frame") });
        if cached {
            let panel_px = self.panel_width_px as f64;
            self.snapshot.viewport = Some([0.0, 0.0, (size.width as f64 - panel_px).max(1.0), size.height as f64]);
            self.fill_snapshot();
            gfx.renderer.encode(&mut encoder, &view, &self.snapshot);
            let layer = gfx.layer.as_ref().expect("checked above");
            let x = size.width.saturating_sub(self.panel_width_px);
            let at = |texture| wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x, y: 0, z: 0 },
                aspect: wgpu::TextureAspect::All,
            };
            encoder.copy_texture_to_texture(
                at(layer),
                at(&frame.texture),
                wgpu::Extent3d { width: size.width - x, height: size.height, depth_or_array_layers: 1 },
            );
            queue.submit([encoder.finish()]);
        } else {
            // The panel first: it decides how much room the field gets.
            let raw = gfx.egui_state.take_egui_input(&gfx.window);
            let mut commands = Vec::new();
            let mut show_help = self.show_help;
            let mut panel_width_points = 0.0;
            let show_panel = self.show_panel;
            let (readouts, settings) = (&self.readouts, &self.settings);
            let output = self.egui_ctx.run_ui(raw, |ui| {
                if show_panel {
                    // No background of egui's own: the renderer's letterbox already paints the
                    // panel's area, opaque and cheaply, while egui's textured shader filling
                    // 300×680 pixels cost ~12 ms a frame on a CPU adapter.
                    let frame = egui::Frame::NONE.inner_margin(egui::Margin::symmetric(10, 8));
                    let panel = egui::Panel::right("panel").resizable(false).exact_size(PANEL_WIDTH).frame(frame);
                    let r = panel.show(ui, |ui| {
                        egui::ScrollArea::vertical().show(ui, |ui| panel::show(ui, readouts, settings, &mut commands));
                    });
                    panel_width_points = r.response.rect.width();
                } else {
                    egui::Area::new(egui::Id::unique("hint")).fixed_pos(egui::pos2(14.0, 12.0)).show(ui.ctx(), |ui| {
                        ui.label(egui::RichText::new("Tab: panel · H: help").color(egui::Color32::GRAY));
                    });
                }
                if show_help {
                    panel::help(ui.ctx(), &mut show_help);
                }
            });
            self.show_help = show_help;
            gfx.egui_state.handle_platform_output(&gfx.window, output.platform_output);
            let ppp = output.pixels_per_point;
            // egui wants another pass soon (an animation, a hover): do not cache the next frame.
            let soon =
                output.viewport_output.get(&egui::ViewportId::ROOT).is_some_and(|v| v.repaint_delay < PANEL_REFRESH);
            self.panel_dirty = soon || self.egui_ctx.is_pointer_over_egui();
            self.panel_due = Instant::now() + PANEL_REFRESH;
            for c in commands {
                self.apply(c, event_loop);
            }

            let panel_px = (panel_width_points * ppp).ceil() as f64;
            self.panel_width_px = panel_px as u32;
            self.snapshot.viewport = Some([0.0, 0.0, (size.width as f64 - panel_px).max(1.0), size.height as f64]);
            self.fill_snapshot();

            let jobs = self.egui_ctx.tessellate(output.shapes, ppp);
            let screen =
                egui_wgpu::ScreenDescriptor { size_in_pixels: [size.width, size.height], pixels_per_point: ppp };
            for (id, deltas) in &output.textures_delta.set {
                for delta in deltas {
                    gfx.egui_renderer.update_texture(&device, &queue, *id, delta);
                }
            }
            // Drawn into the layer (kept for the cached frames) when the surface can be copied
            // into, else straight into the surface.
            if gfx.copy_to_surface
                && gfx.layer.as_ref().is_none_or(|l| (l.width(), l.height()) != (size.width, size.height))
            {
                gfx.layer = Some(device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("panel layer"),
                    size: wgpu::Extent3d { width: size.width, height: size.height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: gfx.config.format,
                    // COPY_DST: the renderer may splat small balls into it (`BallPath::Splat`).
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::COPY_SRC
                        | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                }));
            }
            let layer_view = gfx.layer.as_ref().map(|l| l.create_view(&wgpu::TextureViewDescriptor::default()));
            let target = layer_view.as_ref().unwrap_or(&view);
            gfx.renderer.encode(&mut encoder, target, &self.snapshot);
            let extra = gfx.egui_renderer.update_buffers(&device, &queue, &mut encoder, &jobs, &screen);
            {
                let mut pass = encoder
                    .begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("egui"),
                        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                            view: target,
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                        })],
                        depth_stencil_attachment: None,
                        timestamp_writes: None,
                        occlusion_query_set: None,
                        multiview_mask: None,
                    })
                    .forget_lifetime();
                gfx.egui_renderer.render(&mut pass, &jobs, &screen);
            }
            if let Some(layer) = &gfx.layer {
                encoder.copy_texture_to_texture(
                    layer.as_image_copy(),
                    frame.texture.as_image_copy(),
                    wgpu::Extent3d { width: size.width, height: size.height, depth_or_array_layers: 1 },
                );
            }
            queue.submit(extra.into_iter().chain([encoder.finish()]));
            for id in &output.textures_delta.free {
                gfx.egui_renderer.free_texture(id);
            }
        }
        self.layout = Some(self.snapshot.layout(size.width, size.height));
        gfx.window.pre_present_notify();
        queue.present(frame);
        if gfx.config.width != size.width || gfx.config.height != size.height {
            gfx.surface.configure(&gfx.gpu.device, &gfx.config);
        }

        // Wait for the frame to be drawn: on a CPU adapter the drawing is real work on Mesa's
        // threads, and a frame's time should include it (the next frame could not start its
        // drawing earlier anyway). The measured time is the panel's "frame" figure and the
        // report's frame_ms_median.
        let _ = gfx.gpu.device.poll(wgpu::PollType::wait_indefinitely());
        let now = Instant::now();
        log::trace!("frame drawn in {:.2} ms", (now - t0).as_secs_f64() * 1e3);
        self.frame_times.push((now - t0).as_secs_f64());
        self.report.frames += 1;
        self.frame_stamps.push_back(now);
        while self.frame_stamps.len() > 2 && now - self.frame_stamps[0] > Duration::from_secs(1) {
            self.frame_stamps.pop_front();
        }
        if self.frame_stamps.len() >= 2 {
            let span = (now - self.frame_stamps[0]).as_secs_f64();
            self.readouts.frame_rate = (self.frame_stamps.len() - 1) as f64 / span.max(1e-9);
        }
        // The median over the last 60 frames: cached and panel frames differ a lot.
        let mut recent: Vec<f64> = self.frame_times.iter().rev().take(60).copied().collect();
        recent.sort_by(f64::total_cmp);
        self.readouts.frame_ms = recent[recent.len() / 2] * 1e3;
    }
}

/// The energies (J) and momentum (kg·m/s) of one diagnostics sample.
struct Readout {
    kinetic: f64,
    potential: f64,
    total: f64,
    momentum: [f64; 2],
}

fn describe_scene(scene: &Scene) -> String {
    format!("{} — {}", scene.name, scene.description)
}

/// The cursor's velocity over its recent trail, m/s (zero for a click without motion).
fn throw_velocity(trail: &VecDeque<(Instant, DVec2)>) -> DVec2 {
    let (Some(&(t0, p0)), Some(&(t1, p1))) = (trail.front(), trail.back()) else { return DVec2::ZERO };
    let dt = (t1 - t0).as_secs_f64();
    if dt < 1e-3 { DVec2::ZERO } else { ((p1 - p0) / dt).clamp_length_max(100.0) }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        match self.init_graphics(event_loop) {
            Ok(g) => {
                g.window.request_redraw();
                self.gfx = Some(g);
                self.next_tick = Instant::now();
            }
            Err(e) => {
                self.fatal = Some(AppError::Start(e));
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let Some(gfx) = &mut self.gfx {
            // egui asks for a repaint on nearly every event (RedrawRequested included, which
            // would loop): the 15 ms tick redraws anyway, so its answer is not needed.
            let _ = gfx.egui_state.on_window_event(&gfx.window, &event);
            // Pointer activity over the panel (or anywhere while egui holds the pointer, as when
            // a slider is dragged) and typing into it: the panel is drawn anew next frame.
            let width = gfx.window.inner_size().width as f64;
            let over_panel = |x: f64| x >= width - self.panel_width_px as f64;
            match &event {
                WindowEvent::CursorMoved { position, .. } if over_panel(position.x) => self.panel_dirty = true,
                WindowEvent::MouseInput { .. } | WindowEvent::MouseWheel { .. }
                    if self.cursor.is_some_and(|c| over_panel(c.x)) =>
                {
                    self.panel_dirty = true
                }
                WindowEvent::KeyboardInput { .. } if self.egui_ctx.egui_wants_keyboard_input() => {
                    self.panel_dirty = true
                }
                _ if self.egui_ctx.egui_wants_pointer_input() => self.panel_dirty = true,
                _ => {}
            }
            // Keys go to the game unless a text field has focus; the mouse unless it is over egui.
            let egui_pointer = self.egui_ctx.is_pointer_over_egui() || self.egui_ctx.egui_wants_pointer_input();
            match &event {
                WindowEvent::MouseInput { .. } if egui_pointer && self.grab.is_none() => return,
                WindowEvent::KeyboardInput { .. } if self.egui_ctx.egui_wants_keyboard_input() => return,
                _ => {}
            }
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(gfx) = &mut self.gfx
                    && size.width > 0
                    && size.height > 0
                {
                    gfx.config.width = size.width;
                    gfx.config.height = size.height;
                    gfx.surface.configure(&gfx.gpu.device, &gfx.config);
                    gfx.window.request_redraw();
                }
            }
            WindowEvent::KeyboardInput { event, is_synthetic, .. } => {
                // X11 reports keys already held when the window gains focus as synthetic presses:
                // they were not pressed *here*.
                if is_synthetic {
                    return;
                }
                if let PhysicalKey::Code(code) = event.physical_key {
                    self.key(code, event.state == ElementState::Pressed, event.repeat, event_loop);
                }
            }
            WindowEvent::Focused(false) => {
                // Keys released while we are not looking would pull forever.
                self.arrows = [false; 4];
                self.update_pull();
            }
            WindowEvent::CursorMoved { position, .. } => self.cursor = Some(DVec2::new(position.x, position.y)),
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseInput { state, button, .. } => self.mouse(button, state == ElementState::Pressed),
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        if let Some(limit) = self.options.exit_after
            && now - self.started >= limit
        {
            event_loop.exit();
            return;
        }
        if now >= self.next_tick {
            self.tick();
            if let Some(g) = &self.gfx {
                g.window.request_redraw();
            }
            self.next_tick += self.options.sample_every;
            if self.next_tick < now {
                // Fell behind (a slow frame): keep the cadence from now rather than catch up.
                self.next_tick = now + self.options.sample_every;
            }
        }
        event_loop.set_control_flow(ControlFlow::WaitUntil(self.next_tick));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn throw_velocity_from_trail() {
        let t0 = Instant::now();
        let mut trail = VecDeque::new();
        trail.push_back((t0, DVec2::new(1.0, 1.0)));
        assert_eq!(throw_velocity(&trail), DVec2::ZERO);
        trail.push_back((t0 + Duration::from_millis(100), DVec2::new(2.0, 1.0)));
        assert!((throw_velocity(&trail) - DVec2::new(10.0, 0.0)).length() < 1e-9);
    }

    #[test]
    fn every_hotkey_is_listed_once() {
        let keys: Vec<&str> = HELP.iter().map(|(k, _)| *k).collect();
        let mut sorted = keys.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), keys.len());
    }
}
