//! The window (DESIGN.md, "app"): a winit [`ApplicationHandler`] that turns keys, the mouse and
//! the panel into commands to the engine, samples the field every 15 ms (configurable) and draws
//! it through the same [`Renderer`] as the headless frames, with an egui panel on top.
//!
//! The window is created in `resumed()` and held in an `Arc` so the wgpu surface can be
//! `'static`. For GL the instance is created with the event loop's display handle (ci-notes.md).

mod keys;
mod panel;

use std::collections::{BTreeMap, HashMap, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec2;
use serde::Serialize;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

pub use keys::{Action, Arrow, HOTKEYS, Hotkey, help_lines};
pub use panel::{Command, EnergySample, MOUSE_HELP, PANEL_WIDTH, PanelFrame, PanelPainter, Readouts, Settings, run_ui};

use crate::engine::{self, Engine, EngineError, EngineKind};
use crate::physics::{
    Attraction, Ball, BallId, BallKind, Bodies, Effects, attraction_potential_energy, gravity_potential_energy,
    kinetic_energy, momentum,
};
use crate::render::{FrameSnapshot, Gpu, Layout, Renderer, instance_descriptor, palette, raise_render_priority};
use crate::scene::Scene;
use crate::scenes;

/// How the window runs.
#[derive(Clone, Debug)]
pub struct AppOptions {
    /// The scene's name or file, as given.
    pub scene_name: String,
    /// The scene the window opens on.
    pub scene: Scene,
    /// The engine the window starts with (the E key and the panel switch it).
    pub engine: EngineKind,
    /// How often the field is sampled and redrawn.
    pub sample_every: Duration,
    /// Close by itself after this long (for tests and demos).
    pub exit_after: Option<Duration>,
    /// Write an [`AppReport`] here when the window closes.
    pub report: Option<PathBuf>,
    /// Window size in pixels; `None` = the field at 10 px/m plus the panel.
    pub size: Option<(u32, u32)>,
    /// Whether the panel shows at start (Tab toggles it).
    pub panel: bool,
}

/// Why the window could not run, or could not write its report.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// winit could not create or run its event loop, usually for want of a display; the text is
    /// winit's error.
    #[error("cannot open a window: {0} (is there a display? `ballfield headless` needs none)")]
    EventLoop(String),
    /// The engine could not start on the scene.
    #[error("{0}")]
    Engine(#[from] EngineError),
    /// The window, its surface or the GPU device could not be set up; the text says which and
    /// why.
    #[error("{0}")]
    Start(String),
    /// The `--report` file could not be written. The window ran to its end.
    #[error("--report {file}: cannot write: {cause}")]
    Report {
        /// The file given as `--report`.
        file: PathBuf,
        /// What the file system said.
        cause: std::io::Error,
    },
}

/// What happened in the window, written at exit with `--report` (the end-to-end tests read it).
#[derive(Clone, Debug, Default, Serialize)]
pub struct AppReport {
    /// The scene last played: the name or file given at start, or the built-in scene's name
    /// after a switch (1–8 or the panel).
    pub scene: String,
    /// The engine that ran last ([`EngineKind::name`]).
    pub engine: String,
    /// The GPU adapter the window drew with: its name, backend and device type (empty if the
    /// window never got a surface).
    pub adapter: String,
    /// The surface's texture format, as wgpu's `Debug` writes it ("Bgra8Unorm", ...).
    pub surface_format: String,
    /// The surface's present mode, as wgpu's `Debug` writes it ("Fifo", "Mailbox", ...).
    pub present_mode: String,
    /// Wall-clock time the window was open, s.
    pub seconds: f64,
    /// Frames drawn.
    pub frames: u64,
    /// `frames / seconds`, the mean over the whole run.
    pub frames_per_second: f64,
    /// Median time from the start of a frame to the GPU having drawn it (panel included), ms.
    pub frame_ms_median: f64,
    /// Wall-clock time between two ticks from the first frame on, ms: the cadence the window
    /// kept, and how late it can be to see a key (an event waits for the frame being drawn).
    pub tick_gap_ms_median: f64,
    /// The longest of those gaps, ms.
    pub tick_gap_ms_max: f64,
    /// Balls in the scene the window opened on, the key ball included.
    pub balls_start: usize,
    /// Balls on the field at the last sample (a ball held by the mouse is off it).
    pub balls_end: usize,
    /// Balls added by a key, the panel or a mouse drop (refused additions not counted).
    pub balls_added: u64,
    /// Balls taken off by a key or the panel (a grab is not a removal).
    pub balls_removed: u64,
    /// The key ball's position at the first sample that has one, m; `None` if none did.
    pub key_start: Option<[f64; 2]>,
    /// The key ball's position at the last sample, m; `None` if it was not on the field.
    pub key_end: Option<[f64; 2]>,
    /// Key presses acted on (synthetic ones and the keyboard's repeats are ignored and not
    /// counted).
    pub key_presses: u64,
    /// The same, by key (winit's `KeyCode` name: "ArrowLeft", "KeyA", "NumpadAdd", ...).
    pub keys: BTreeMap<String, u64>,
    /// Commands carried out, by kind ("AddBall", "Scene", "Pull", "Throw", ...), whatever gave
    /// them: a key, the mouse or the panel.
    pub commands: BTreeMap<String, u64>,
    /// Every command in order, with the state right after it (the first [`MAX_LOG`]).
    pub log: Vec<CommandRecord>,
    /// Commands left out of `log` once it was full.
    pub log_dropped: u64,
    /// What closed the window: the key ("Escape", "KeyQ"), "exit-after" or "close-requested".
    pub closed_by: String,
    /// The state when the window closed.
    pub end: Option<WindowState>,
    /// What went wrong: commands the engine refused, ball threads that had panicked (the first
    /// [`MAX_ERRORS`]).
    pub errors: Vec<String>,
}

/// The longest [`AppReport::log`]: a command a frame for an hour of slider dragging stays in
/// memory, and a scripted run is far shorter.
pub const MAX_LOG: usize = 10_000;
/// The most [`AppReport::errors`] kept.
pub const MAX_ERRORS: usize = 100;

/// One command the window carried out, in the report's log.
#[derive(Clone, Debug, Serialize)]
pub struct CommandRecord {
    /// Wall-clock seconds since the window opened, when the command was carried out.
    pub at: f64,
    /// What gave it: a key (winit's `KeyCode` name), "mouse-left", "mouse-right" or "panel".
    pub source: String,
    /// The command: a [`Command`] as Rust writes it ("AddBall", "Scene(3)", "Engine(Lockstep)"),
    /// "Pull(Left)" / "Release(Left)" for an arrow going down / up, "Grab", "Throw", "Drop".
    pub command: String,
    /// The ball the command was about: the one added, removed, grabbed, thrown or dropped, as
    /// the engine has it afterwards (as it was taken off, for a removal or a grab).
    pub ball: Option<Ball>,
    /// The window's state right after the command (its fields sit beside these in the JSON).
    #[serde(flatten)]
    pub state: WindowState,
}

/// The window's state at one instant (after a command, or at the end).
#[derive(Clone, Debug, Default, Serialize)]
pub struct WindowState {
    /// The engine that runs ([`EngineKind::name`]).
    pub engine: String,
    /// The scene's own name (its `name` key), not the file it came from.
    pub scene: String,
    /// The engine's simulated clock, s: for the lockstep engine the time of its last step, from
    /// which a pull set now applies.
    pub time: f64,
    /// Whether the engine is paused (Space, P or the panel).
    pub paused: bool,
    /// Balls on the field (a grabbed ball is off it until it is thrown).
    pub balls: usize,
    /// The effects the engine runs ([`Effects::active_names`]).
    pub effects: Vec<String>,
    /// The pull the window asks for, N.
    pub pull: [f64; 2],
    /// The key ball as sampled; `None` when the scene has none or the mouse holds it.
    pub key_ball: Option<Ball>,
    /// Whether the panel shows (Tab).
    pub panel: bool,
    /// Whether the help overlay shows (H).
    pub help: bool,
    /// Whether velocity arrows are drawn on the balls (V).
    pub vectors: bool,
    /// Whether the centre of mass is marked (M).
    pub centre_of_mass: bool,
    /// Whether the traces of the key ball and of the balls with ids below 32 are drawn (T).
    pub traces: bool,
}

/// What a log record says the command was about.
enum Subject {
    None,
    /// This ball, as it is.
    Ball(Ball),
    /// The ball with this id, as the engine has it after the command.
    Id(BallId),
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
    panel: PanelPainter,
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
    /// The last tick from the first frame on, and the time between such ticks, s.
    last_tick_wall: Option<Instant>,
    tick_gaps: Vec<f64>,
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
/// How often the panel's readouts are redrawn when nothing else changes it.
const PANEL_REFRESH: Duration = Duration::from_millis(250);

impl App {
    fn new(options: AppOptions) -> Result<App, AppError> {
        let scene = options.scene.clone();
        let engine = engine::start(options.engine, &scene, None)?;
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
            last_tick_wall: None,
            tick_gaps: Vec::new(),
        })
    }

    fn finish(mut self) -> Result<AppReport, AppError> {
        if self.report.closed_by.is_empty() {
            // The event loop ended without being asked to (the display went away).
            self.report.closed_by = "event-loop".into();
        }
        self.report.end = Some(self.state());
        self.shutdown_engine();
        self.tick_gaps.sort_by(f64::total_cmp);
        let r = &mut self.report;
        r.tick_gap_ms_median = self.tick_gaps.get(self.tick_gaps.len() / 2).copied().unwrap_or(0.0) * 1e3;
        r.tick_gap_ms_max = self.tick_gaps.last().copied().unwrap_or(0.0) * 1e3;
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
            self.report_error(format!("a ball thread had panicked: {p}"));
        }
    }

    /// Shows `message` in the panel and keeps it for the report.
    fn report_error(&mut self, message: String) {
        if self.report.errors.len() < MAX_ERRORS {
            self.report.errors.push(message.clone());
        }
        self.readouts.message = message;
    }

    /// The window's state now (samples the engine into `balls`).
    fn state(&mut self) -> WindowState {
        self.engine.sample(&mut self.balls);
        WindowState {
            engine: self.engine.kind().name().into(),
            scene: self.scene.name.clone(),
            time: self.engine.time(),
            paused: self.engine.is_paused(),
            balls: self.balls.len(),
            effects: self.engine.effects().active_names().into_iter().map(String::from).collect(),
            pull: self.pull_force().to_array(),
            key_ball: self.balls.iter().find(|b| b.kind == BallKind::Key).copied(),
            panel: self.show_panel,
            help: self.show_help,
            vectors: self.settings.vectors,
            centre_of_mass: self.settings.centre_of_mass,
            traces: self.settings.traces,
        }
    }

    /// Counts a command and logs it with the state after it.
    fn record(&mut self, source: &str, command: String, subject: Subject) {
        let kind = command.split('(').next().unwrap_or_default().to_string();
        *self.report.commands.entry(kind).or_default() += 1;
        // Numbered from 1, and written once the state is taken: the end-to-end tests wait for
        // the line of the command they gave, and bound its instants by the line's.
        let n = self.report.log.len() as u64 + self.report.log_dropped + 1;
        if self.report.log.len() >= MAX_LOG {
            self.report.log_dropped += 1;
            log::info!("command {n}: {command} from {source}");
            return;
        }
        let state = self.state();
        let ball = match subject {
            Subject::None => None,
            Subject::Ball(b) => Some(b),
            Subject::Id(id) => self.balls.iter().find(|b| b.id == id).copied(),
        };
        let at = self.started.elapsed().as_secs_f64();
        log::info!("command {n}: {command} from {source}");
        self.report.log.push(CommandRecord { at, source: source.into(), command, ball, state });
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
        let panel = PanelPainter::new(&gpu.device, config.format);
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
        Ok(Graphics { window, surface, config, gpu, renderer, egui_state, panel, layer: None, copy_to_surface })
    }

    // ---- commands -------------------------------------------------------------------------

    /// The pull of the arrows held: one arrow's strength whichever of them are held.
    fn pull_force(&self) -> DVec2 {
        let held = Arrow::ALL.iter().filter(|a| self.arrows[**a as usize]);
        held.map(|a| a.direction()).sum::<DVec2>().normalize_or_zero() * self.settings.pull
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
                self.report_error(format!("cannot start the {kind} engine: {e}"));
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

    /// Carries out a command from the panel.
    fn apply(&mut self, command: Command, event_loop: &ActiveEventLoop) {
        self.carry_out(command, "panel", event_loop);
    }

    /// Carries out a command from `source` (see [`CommandRecord::source`]) and logs it.
    fn carry_out(&mut self, command: Command, source: &str, event_loop: &ActiveEventLoop) {
        self.readouts.message.clear();
        self.panel_dirty = true;
        let mut subject = Subject::None;
        match command {
            Command::AddBall => {
                let (m, d) = new_ball_shape(&self.scene);
                match self.engine.add_ball_at_free_spot(m, d) {
                    Ok(id) => {
                        self.report.balls_added += 1;
                        subject = Subject::Id(id);
                    }
                    Err(e) => self.report_error(e.to_string()),
                }
            }
            Command::RemoveLast => {
                if let Some(ball) = self.engine.remove_last() {
                    self.report.balls_removed += 1;
                    subject = Subject::Ball(ball);
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
            Command::Quit => {
                self.report.closed_by = source.into();
                event_loop.exit();
            }
            Command::SetPull(p) => {
                self.settings.pull = p.max(0.0);
                self.update_pull();
            }
            Command::SetKeyMass(m) => {
                self.settings.key_mass = m;
                if let Some(key) = self.engine.key_ball()
                    && let Err(e) = self.engine.set_mass(key, m)
                {
                    self.report_error(e.to_string());
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
        self.record(source, format!("{command:?}"), subject);
    }

    fn toggle_effect(&mut self, which: fn(&mut Settings) -> &mut bool) {
        let flag = which(&mut self.settings);
        *flag = !*flag;
        let effects = self.effects_from_settings();
        self.engine.set_effects(effects);
        // An engine that cannot run an effect (the exact one: drag, attraction) runs without it:
        // the switch goes back off and the panel says why.
        let got = self.engine.effects();
        let dropped: Vec<&str> = [
            ("drag", effects.drag.is_some() && got.drag.is_none()),
            ("attraction", effects.attraction.is_some() && got.attraction.is_none()),
        ]
        .into_iter()
        .filter_map(|(name, lost)| lost.then_some(name))
        .collect();
        if !dropped.is_empty() {
            *which(&mut self.settings) = false;
            let kind = self.engine.kind();
            self.report_error(EngineError::Unsupported { engine: kind, effects: dropped.join(" and ") }.to_string());
        }
    }

    /// A key went down (`pressed`) or up; `repeat`: the keyboard's own repeat of a held key.
    /// What it does comes from [`HOTKEYS`], as the help lists it.
    fn key(&mut self, code: KeyCode, pressed: bool, repeat: bool, event_loop: &ActiveEventLoop) {
        let Some(action) = keys::action(code) else { return };
        let source = format!("{code:?}");
        if pressed && !repeat {
            self.report.key_presses += 1;
            *self.report.keys.entry(source.clone()).or_default() += 1;
        }
        match action {
            Action::Pull(arrow) => {
                let k = arrow as usize;
                if self.arrows[k] != pressed {
                    self.arrows[k] = pressed;
                    self.update_pull();
                    let what = if pressed { "Pull" } else { "Release" };
                    self.record(&source, format!("{what}({arrow:?})"), Subject::None);
                }
            }
            _ if !pressed || repeat => {}
            Action::Do(command) => self.carry_out(command, &source, event_loop),
            Action::NextEngine => self.carry_out(Command::Engine(self.engine_tried.next()), &source, event_loop),
        }
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
                    Some(b) => match self.engine.remove_ball(b.id) {
                        Ok(ball) => {
                            let mut trail = VecDeque::new();
                            trail.push_back((Instant::now(), p));
                            self.grab = Some(Grab { ball, trail });
                            self.record("mouse-left", "Grab".into(), Subject::Ball(ball));
                        }
                        Err(e) => self.report_error(e.to_string()),
                    },
                    None => self.drop_ball_at(p, "mouse-left"),
                }
            }
            (MouseButton::Right, true) if inside => self.drop_ball_at(p, "mouse-right"),
            (MouseButton::Left, false) => {
                if let Some(grab) = self.grab.take() {
                    let v = throw_velocity(&grab.trail);
                    let ball = Ball { position: p, velocity: v, ..grab.ball };
                    // Back with its own id: the thrown ball is the one that was grabbed.
                    let subject = match self.engine.put_back(ball) {
                        Ok(id) => Subject::Id(id),
                        Err(e) => {
                            self.report_error(e.to_string());
                            Subject::None
                        }
                    };
                    if ball.kind == BallKind::Key {
                        self.update_pull();
                    }
                    self.record("mouse-left", "Throw".into(), subject);
                }
            }
            _ => {}
        }
    }

    fn drop_ball_at(&mut self, p: DVec2, source: &str) {
        let (mass, diameter) = new_ball_shape(&self.scene);
        let ball = Ball { id: BallId(0), kind: BallKind::Ball, position: p, velocity: DVec2::ZERO, mass, diameter };
        match self.engine.add_ball(ball) {
            Ok(id) => {
                self.report.balls_added += 1;
                self.record(source, "Drop".into(), Subject::Id(id));
            }
            Err(e) => self.report_error(e.to_string()),
        }
    }

    // ---- the 15 ms tick -------------------------------------------------------------------

    fn tick(&mut self) {
        let now = Instant::now();
        if self.report.frames > 0 {
            if let Some(last) = self.last_tick_wall {
                self.tick_gaps.push((now - last).as_secs_f64());
            }
            self.last_tick_wall = Some(now);
        }
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
            self.readouts.sim_rate_unit = self.engine.rate_unit();
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
        // potential is O(n²), as the effect itself is) into scratch kept across calls. Not
        // `measure`: it also finds the largest overlap, with a broad phase over a sorted copy of
        // all the balls, 25–60 ms at 100,000 balls every 100 ms, a stall of the 15 ms cadence;
        // these sums take about 1 ms there.
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
        s.fill(self.engine.field(), &self.balls);
        if let Some(g) = &self.grab {
            let p = self.cursor.zip(self.layout).map(|(c, l)| l.to_metres(c)).unwrap_or(g.ball.position);
            s.add_held(&g.ball, p);
        }
        if self.settings.traces {
            for t in self.traces.values() {
                s.add_trace(t.iter().copied(), palette::TRACE);
            }
        }
        if self.settings.vectors {
            s.add_velocity_vectors(&self.balls, 0.25);
        }
        if let Some(k) = self.balls.iter().find(|b| b.kind == BallKind::Key) {
            s.add_pull(k.position, pull);
        }
        if self.settings.centre_of_mass {
            s.add_centre_of_mass(&self.balls);
        }
    }

    /// Fits the field into what the panel leaves of the window and fills the snapshot.
    fn fill_snapshot_beside_panel(&mut self, size: PhysicalSize<u32>) {
        let panel_px = self.panel_width_px as f64;
        self.snapshot.viewport = Some([0.0, 0.0, (size.width as f64 - panel_px).max(1.0), size.height as f64]);
        self.fill_snapshot();
    }

    // ---- drawing --------------------------------------------------------------------------

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let Some(mut gfx) = self.gfx.take() else { return };
        let first = self.report.frames == 0;
        self.draw(&mut gfx, event_loop);
        self.gfx = Some(gfx);
        if first && self.report.frames == 1 {
            // The end-to-end tests wait for this line before they type.
            log::info!("first frame drawn");
        }
    }

    /// One frame: the surface's next texture, the field and the panel drawn into it, presented,
    /// and the time it took recorded.
    fn draw(&mut self, gfx: &mut Graphics, event_loop: &ActiveEventLoop) {
        let t0 = Instant::now();
        let size = gfx.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return; // minimised
        }
        let Some(frame) = gfx.acquire_frame(size) else { return };
        if self.panel_is_cached(gfx, size) {
            self.draw_with_cached_panel(gfx, &frame.texture, size);
        } else {
            self.draw_with_new_panel(gfx, &frame.texture, size, event_loop);
        }
        self.layout = Some(self.snapshot.layout(size.width, size.height));
        gfx.present(frame, size);
        self.time_frame(gfx, t0);
    }

    /// Whether this frame can copy the panel's pixels instead of drawing it.
    ///
    /// The panel is drawn (egui run, tessellated and rasterised) only when it may have changed: on
    /// input, after a command, while egui animates or shows a window over the field, and every
    /// PANEL_REFRESH for its readouts. In between, the frame draws the field and copies the
    /// panel's pixels from the layer it was last drawn into. On a CPU adapter rasterising the
    /// panel costs ~15 ms, the copy well under 1.
    fn panel_is_cached(&self, gfx: &Graphics, size: PhysicalSize<u32>) -> bool {
        gfx.layer.as_ref().is_some_and(|l| (l.width(), l.height()) == (size.width, size.height))
            && self.panel_width_px > 0
            && self.show_panel
            && !self.show_help
            && !self.panel_dirty
            && Instant::now() < self.panel_due
    }

    /// The field drawn into `frame`, and the panel's pixels copied from the layer.
    fn draw_with_cached_panel(&mut self, gfx: &mut Graphics, frame: &wgpu::Texture, size: PhysicalSize<u32>) {
        let view = frame.create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = gfx.encoder();
        self.fill_snapshot_beside_panel(size);
        gfx.renderer.encode(&mut encoder, &view, &self.snapshot);
        let layer = gfx.layer.as_ref().expect("a cached panel has its layer");
        copy_columns(&mut encoder, layer, frame, size.width.saturating_sub(self.panel_width_px), size);
        gfx.gpu.queue.submit([encoder.finish()]);
    }

    /// The panel laid out (the commands from it carried out), then the field and the panel drawn
    /// into the layer, which is copied into `frame`; or straight into `frame` when the surface
    /// cannot be copied into.
    fn draw_with_new_panel(
        &mut self,
        gfx: &mut Graphics,
        frame: &wgpu::Texture,
        size: PhysicalSize<u32>,
        event_loop: &ActiveEventLoop,
    ) {
        // The panel first: it decides how much room the field gets.
        let output = self.run_panel(gfx, event_loop);
        self.fill_snapshot_beside_panel(size);
        gfx.ensure_layer(size);
        let view = frame.create_view(&wgpu::TextureViewDescriptor::default());
        let layer_view = gfx.layer.as_ref().map(|l| l.create_view(&wgpu::TextureViewDescriptor::default()));
        let target = layer_view.as_ref().unwrap_or(&view);
        let mut encoder = gfx.encoder();
        gfx.renderer.encode(&mut encoder, target, &self.snapshot);
        let (device, queue) = (&gfx.gpu.device, &gfx.gpu.queue);
        let extra = gfx.panel.encode(
            &self.egui_ctx,
            device,
            queue,
            &mut encoder,
            target,
            [size.width, size.height],
            output.shapes,
            &output.textures_delta,
            output.pixels_per_point,
        );
        if let Some(layer) = &gfx.layer {
            copy_columns(&mut encoder, layer, frame, 0, size);
        }
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        gfx.panel.free(&output.textures_delta);
    }

    /// Runs the UI for this frame, hands egui's platform output to the window and carries out
    /// the commands from the panel. Returns what is left to draw.
    fn run_panel(&mut self, gfx: &mut Graphics, event_loop: &ActiveEventLoop) -> egui::FullOutput {
        let raw = gfx.egui_state.take_egui_input(&gfx.window);
        let (readouts, settings) = (&self.readouts, &self.settings);
        let mut ui = panel::run_ui(&self.egui_ctx, raw, readouts, settings, self.show_panel, &mut self.show_help);
        let platform = std::mem::take(&mut ui.output.platform_output);
        gfx.egui_state.handle_platform_output(&gfx.window, platform);
        let ppp = ui.output.pixels_per_point;
        // egui wants another pass soon (an animation, a hover): do not cache the next frame.
        let soon =
            ui.output.viewport_output.get(&egui::ViewportId::ROOT).is_some_and(|v| v.repaint_delay < PANEL_REFRESH);
        self.panel_dirty = soon || self.egui_ctx.is_pointer_over_egui();
        self.panel_due = Instant::now() + PANEL_REFRESH;
        for c in ui.commands {
            self.apply(c, event_loop);
        }
        self.panel_width_px = (ui.width_points * ppp).ceil() as u32;
        ui.output
    }

    /// Waits for the frame to be drawn and records its time.
    ///
    /// On a CPU adapter the drawing is real work on Mesa's threads, and a frame's time should
    /// include it (the next frame could not start its drawing earlier anyway). The measured time
    /// is the panel's "frame" figure and the report's frame_ms_median.
    fn time_frame(&mut self, gfx: &Graphics, t0: Instant) {
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

impl Graphics {
    fn encoder(&self) -> wgpu::CommandEncoder {
        self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("window frame") })
    }

    /// The surface's next texture, or `None` when there is none to draw this time (the surface
    /// is then reconfigured or made again as it asks, and another redraw requested).
    fn acquire_frame(&mut self, size: PhysicalSize<u32>) -> Option<wgpu::SurfaceTexture> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) => Some(f),
            wgpu::CurrentSurfaceTexture::Suboptimal(f) => {
                // Draw this one, reconfigure for the next.
                self.config.width = size.width;
                self.config.height = size.height;
                Some(f)
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.config.width = size.width;
                self.config.height = size.height;
                self.surface.configure(&self.gpu.device, &self.config);
                self.window.request_redraw();
                None
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                // The surface itself is gone: make a new one for the same window.
                match self.gpu.instance.create_surface(self.window.clone()) {
                    Ok(surface) => {
                        self.surface = surface;
                        self.config.width = size.width;
                        self.config.height = size.height;
                        self.surface.configure(&self.gpu.device, &self.config);
                        self.window.request_redraw();
                    }
                    Err(e) => log::error!("the window's surface was lost and cannot be made again: {e}"),
                }
                None
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => None,
            other => {
                log::warn!("cannot get the next frame: {other:?}");
                None
            }
        }
    }

    /// Makes the layer the panel is drawn into (kept for the cached frames) at the window's size,
    /// when the surface can be copied into.
    fn ensure_layer(&mut self, size: PhysicalSize<u32>) {
        if !self.copy_to_surface
            || self.layer.as_ref().is_some_and(|l| (l.width(), l.height()) == (size.width, size.height))
        {
            return;
        }
        self.layer = Some(self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("panel layer"),
            size: wgpu::Extent3d { width: size.width, height: size.height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.config.format,
            // COPY_DST: the renderer may splat small balls into it (`BallPath::Splat`).
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        }));
    }

    /// Presents `frame`, then reconfigures the surface if the window's size changed.
    fn present(&mut self, frame: wgpu::SurfaceTexture, size: PhysicalSize<u32>) {
        self.window.pre_present_notify();
        self.gpu.queue.present(frame);
        if self.config.width != size.width || self.config.height != size.height {
            self.surface.configure(&self.gpu.device, &self.config);
        }
    }
}

/// Records the copy of the columns from `x` to the right edge of a `size` window from `from`
/// into `to`, at the same place.
fn copy_columns(
    encoder: &mut wgpu::CommandEncoder,
    from: &wgpu::Texture,
    to: &wgpu::Texture,
    x: u32,
    size: PhysicalSize<u32>,
) {
    let at = |texture| wgpu::TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: wgpu::Origin3d { x, y: 0, z: 0 },
        aspect: wgpu::TextureAspect::All,
    };
    encoder.copy_texture_to_texture(
        at(from),
        at(to),
        wgpu::Extent3d { width: size.width - x, height: size.height, depth_or_array_layers: 1 },
    );
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
            // Keys go to the game unless a text field has focus (typing a slider's value): a
            // hotkey then reaches egui only, and otherwise the game only. egui must not see
            // them meanwhile: its Tab would focus a widget, which then takes every key (the
            // game's keys all stopped after Tab showed the panel), and a focused slider would
            // move with the arrows that pull the key ball.
            let typing = self.egui_ctx.text_edit_focused();
            let hotkey = matches!(&event, WindowEvent::KeyboardInput { event, .. }
                if matches!(event.physical_key, PhysicalKey::Code(c) if keys::action(c).is_some()));
            if typing || !hotkey {
                // egui asks for a repaint on nearly every event (RedrawRequested included, which
                // would loop): the 15 ms tick redraws anyway, so its answer is not needed.
                let _ = gfx.egui_state.on_window_event(&gfx.window, &event);
            }
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
            // The mouse goes to the game unless it is over egui.
            let egui_pointer = self.egui_ctx.is_pointer_over_egui() || self.egui_ctx.egui_wants_pointer_input();
            match &event {
                WindowEvent::MouseInput { .. } if egui_pointer && self.grab.is_none() => return,
                WindowEvent::KeyboardInput { .. } if typing => return,
                _ => {}
            }
        }
        match event {
            WindowEvent::CloseRequested => {
                self.report.closed_by = "close-requested".into();
                event_loop.exit();
            }
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
            // The end-to-end tests wait for this line before they type.
            WindowEvent::Focused(true) => log::info!("the window has the keyboard focus"),
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
            self.report.closed_by = "exit-after".into();
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
}
