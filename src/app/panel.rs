//! The control panel (egui): readouts, a live energy plot, sliders and toggles. It only returns
//! [`Command`]s; the app carries them out.
//!
//! [`run_ui`] lays out a frame of the window's UI and [`PanelPainter`] draws it over the field:
//! the window uses both, and so does the golden test of the panel, offscreen.

use std::collections::VecDeque;

use egui::{Color32, RichText};

use crate::engine::EngineKind;
use crate::scenes::BUILTIN;

/// What the user asked for, by key, mouse or panel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Adds a ball at rest at a free spot, of the mass and size of the scene's first plain ball
    /// (1 kg, 1 m if it has none). Refused, with a message, when the field is full or no spot is
    /// free.
    AddBall,
    /// Takes off the most recently added ball that is not the key ball; nothing if there is none.
    RemoveLast,
    /// Pauses the engine, or resumes it.
    TogglePause,
    /// While paused, advances one sampling period (15 ms by default) of wall-clock time's worth
    /// of simulation, times the time scale; nothing while running.
    Step,
    /// Starts the running engine again on the current scene: as it was loaded, or as the balls
    /// stood at the last engine switch.
    Reset,
    /// Turns gravity on or off (on: the scene's, or the default 9.81 m/s² down).
    ToggleGravity,
    /// Turns drag on or off (on: the scene's, or the default quadratic drag in air).
    ToggleDrag,
    /// Turns mutual attraction on or off (on: the scene's, or G = 1 m³/(kg·s²), which moves
    /// balls visibly where the real G would not).
    ToggleAttraction,
    /// Turns ball–ball collisions on or off (on: at the panel's restitution).
    ToggleCollisions,
    /// Switches to the built-in scene at this index of [`crate::scenes::BUILTIN`] (an index past
    /// the end does nothing), on the running engine.
    Scene(usize),
    /// Switches to this engine, carrying over the balls as they are now, the effects, the pull,
    /// the restitution and the time scale. If it cannot start, the running engine stays.
    Engine(EngineKind),
    /// Shows or hides the panel.
    TogglePanel,
    /// Shows or hides the help overlay.
    ToggleHelp,
    /// Draws the balls' velocity arrows, or stops.
    ToggleVectors,
    /// Marks the centre of mass, or stops.
    ToggleCentreOfMass,
    /// Draws the traces of the key ball and of the balls with ids below 32, or stops (the
    /// traces start afresh each time).
    ToggleTraces,
    /// Closes the window.
    Quit,
    /// The strength of the arrow keys' pull on the key ball, N (a negative value counts as 0).
    SetPull(f64),
    /// The key ball's mass, kg, set in place (it keeps its id and velocity). A mass that is not
    /// finite and positive is refused with a message.
    SetKeyMass(f64),
    /// The restitution of the walls and of ball–ball collisions both, clamped to [0, 1].
    SetRestitution(f64),
    /// Simulated seconds per wall-clock second (the panel offers 0.05–2); a negative or
    /// non-finite scale is ignored.
    SetTimeScale(f64),
}

/// The mouse's lines of the help overlay (the keys' come from [`super::keys::HOTKEYS`]).
pub const MOUSE_HELP: &[(&str, &str)] = &[
    ("mouse: drag a ball", "grab it and throw it"),
    ("mouse: click elsewhere", "drop a new ball there (right button: anywhere)"),
];

/// Width of the panel, points.
pub const PANEL_WIDTH: f32 = 300.0;

/// One frame of the window's UI, laid out by [`run_ui`].
pub struct PanelFrame {
    /// What egui made of the frame: the shapes to paint, texture changes, platform output.
    pub output: egui::FullOutput,
    /// What the user asked for through the panel this frame.
    pub commands: Vec<Command>,
    /// How wide the panel came out (0 when it is hidden), points.
    pub width_points: f32,
}

/// Lays out one frame of the window's UI: the panel on the right (or, when it is hidden, a hint in
/// the corner), and the help window over the field while `show_help` (which its close button
/// clears).
pub fn run_ui(
    ctx: &egui::Context,
    raw: egui::RawInput,
    readouts: &Readouts,
    settings: &Settings,
    show_panel: bool,
    show_help: &mut bool,
) -> PanelFrame {
    let mut commands = Vec::new();
    let mut width_points = 0.0;
    let output = ctx.run_ui(raw, |ui| {
        if show_panel {
            // No background of egui's own: the renderer's letterbox already paints the panel's
            // area, opaque and cheaply, while egui's textured shader filling 300×680 pixels cost
            // ~12 ms a frame on a CPU adapter.
            let frame = egui::Frame::NONE.inner_margin(egui::Margin::symmetric(10, 8));
            let panel = egui::Panel::right("panel").resizable(false).exact_size(PANEL_WIDTH).frame(frame);
            let r = panel.show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| show(ui, readouts, settings, &mut commands));
            });
            width_points = r.response.rect.width();
        } else {
            egui::Area::new(egui::Id::unique("hint")).fixed_pos(egui::pos2(14.0, 12.0)).show(ui.ctx(), |ui| {
                ui.label(egui::RichText::new("Tab: panel · H: help").color(egui::Color32::GRAY));
            });
        }
        if *show_help {
            help(ui.ctx(), show_help);
        }
    });
    PanelFrame { output, commands, width_points }
}

/// Draws egui's shapes over a target the field is already drawn into.
pub struct PanelPainter {
    renderer: egui_wgpu::Renderer,
}

impl PanelPainter {
    /// For targets of `format`. No dithering: the same UI gives the same pixels every frame.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> PanelPainter {
        let options = egui_wgpu::RendererOptions { dithering: false, ..Default::default() };
        PanelPainter { renderer: egui_wgpu::Renderer::new(device, format, options) }
    }

    /// Uploads the textures egui changed, tessellates `shapes` and records their drawing over
    /// `target` (kept, not cleared), a `size` pixels target, on `encoder`. Returns the command
    /// buffers to submit before `encoder`'s. Call [`Self::free`] once they are submitted.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        ctx: &egui::Context,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        size: [u32; 2],
        shapes: Vec<egui::epaint::ClippedShape>,
        textures: &egui::TexturesDelta,
        pixels_per_point: f32,
    ) -> Vec<wgpu::CommandBuffer> {
        let jobs = ctx.tessellate(shapes, pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: size, pixels_per_point };
        for (id, deltas) in &textures.set {
            for delta in deltas {
                self.renderer.update_texture(device, queue, *id, delta);
            }
        }
        let extra = self.renderer.update_buffers(device, queue, encoder, &jobs, &screen);
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
        self.renderer.render(&mut pass, &jobs, &screen);
        extra
    }

    /// Frees the textures egui let go of this frame: after the frame is submitted, as freeing
    /// destroys them.
    pub fn free(&mut self, textures: &egui::TexturesDelta) {
        for id in &textures.free {
            self.renderer.free_texture(id);
        }
    }
}

/// One sample of the energy plot.
#[derive(Clone, Copy, Debug, Default)]
pub struct EnergySample {
    /// Wall-clock seconds since the window opened.
    pub t: f64,
    /// Kinetic energy of the balls on the field, J.
    pub kinetic: f64,
    /// Potential energy of gravity and attraction (those that are on), J.
    pub potential: f64,
    /// `kinetic + potential`, J.
    pub total: f64,
    /// Length of the total momentum, kg·m/s.
    pub momentum: f64,
}

/// What the panel shows (refreshed by the app).
#[derive(Clone, Debug, Default)]
pub struct Readouts {
    /// The scene's name and description, "name — description".
    pub scene: String,
    /// The engine that runs; `None` until the first tick.
    pub engine: Option<EngineKind>,
    /// Balls in play: on the field, plus the one the mouse holds.
    pub balls: usize,
    /// Frames drawn per second over the last second.
    pub frame_rate: f64,
    /// Median time to draw a frame over the last 60, ms.
    pub frame_ms: f64,
    /// [`crate::engine::Engine::rate`]: steps per second (lockstep), events per second (exact)
    /// or the median ball's cycles per second (threaded), read every 0.5 s.
    pub sim_rate: f64,
    /// What `sim_rate` counts ([`crate::engine::Engine::rate_unit`]).
    pub sim_rate_unit: &'static str,
    /// Whether the engine is paused.
    pub paused: bool,
    /// Kinetic energy of the balls on the field, J (refreshed every 0.1 s, as are the figures
    /// below).
    pub kinetic: f64,
    /// Potential energy of gravity and attraction (those that are on), J.
    pub potential: f64,
    /// `kinetic + potential`, J.
    pub total: f64,
    /// Total momentum, kg·m/s.
    pub momentum: [f64; 2],
    /// Mean pressure on the walls over the last second, N/m (force per metre of wall).
    pub pressure: f64,
    /// The energy plot's samples, oldest first: the last 20 s.
    pub history: VecDeque<EnergySample>,
    /// The GPU adapter: its name, backend and device type.
    pub adapter: String,
    /// The last command's refusal or error, shown in red; cleared by the next command.
    pub message: String,
}

/// The settings the panel edits (the app owns them).
#[derive(Clone, Debug)]
pub struct Settings {
    /// Strength of the arrow keys' pull on the key ball, N (slider 0–2,000).
    pub pull: f64,
    /// The key ball's mass, kg (slider 0.1–100).
    pub key_mass: f64,
    /// Restitution of the walls and of ball–ball collisions, in [0, 1].
    pub restitution: f64,
    /// Simulated seconds per wall-clock second (slider 0.05–2).
    pub time_scale: f64,
    /// Whether gravity is on.
    pub gravity: bool,
    /// Whether drag is on.
    pub drag: bool,
    /// Whether mutual attraction is on.
    pub attraction: bool,
    /// Whether ball–ball collisions are on.
    pub collisions: bool,
    /// Whether velocity arrows are drawn.
    pub vectors: bool,
    /// Whether the centre of mass is marked.
    pub centre_of_mass: bool,
    /// Whether traces are drawn.
    pub traces: bool,
    /// Index in [`crate::scenes::BUILTIN`] of the scene the panel's list shows (0 at start for a
    /// scene from a file).
    pub scene: usize,
}

pub fn show(ui: &mut egui::Ui, r: &Readouts, s: &Settings, out: &mut Vec<Command>) {
    ui.heading("ballfield");
    ui.label(RichText::new(&r.scene).strong());
    egui::Grid::new("readouts").num_columns(2).spacing([12.0, 2.0]).show(ui, |ui| {
        let row = |ui: &mut egui::Ui, k: &str, v: String| {
            ui.label(k);
            ui.label(RichText::new(v).monospace());
            ui.end_row();
        };
        row(ui, "balls", r.balls.to_string());
        row(ui, "frame rate", format!("{:.0} /s ({:.1} ms)", r.frame_rate, r.frame_ms));
        row(ui, "simulation", format!("{:.0} {}", r.sim_rate, r.sim_rate_unit));
        row(ui, "kinetic", format!("{:.4e} J", r.kinetic));
        row(ui, "potential", format!("{:.4e} J", r.potential));
        row(ui, "total", format!("{:.4e} J", r.total));
        row(ui, "momentum", format!("({:.3}, {:.3}) kg·m/s", r.momentum[0], r.momentum[1]));
        row(ui, "wall pressure", format!("{:.3} N/m", r.pressure));
    });
    if r.paused {
        ui.label(RichText::new("PAUSED — S steps, Space resumes").color(Color32::YELLOW));
    }
    plot(ui, &r.history);

    ui.separator();
    let mut pull = s.pull;
    if ui.add(egui::Slider::new(&mut pull, 0.0..=2000.0).text("pull, N")).changed() {
        out.push(Command::SetPull(pull));
    }
    let mut mass = s.key_mass;
    if ui.add(egui::Slider::new(&mut mass, 0.1..=100.0).logarithmic(true).text("key mass, kg")).changed() {
        out.push(Command::SetKeyMass(mass));
    }
    let mut e = s.restitution;
    if ui.add(egui::Slider::new(&mut e, 0.0..=1.0).text("restitution")).changed() {
        out.push(Command::SetRestitution(e));
    }
    let mut ts = s.time_scale;
    if ui.add(egui::Slider::new(&mut ts, 0.05..=2.0).logarithmic(true).text("time scale")).changed() {
        out.push(Command::SetTimeScale(ts));
    }

    ui.separator();
    ui.horizontal_wrapped(|ui| {
        let mut toggle = |ui: &mut egui::Ui, on: bool, label: &str, c: Command| {
            let mut v = on;
            if ui.checkbox(&mut v, label).changed() {
                out.push(c);
            }
        };
        toggle(ui, s.gravity, "gravity", Command::ToggleGravity);
        toggle(ui, s.drag, "drag", Command::ToggleDrag);
        toggle(ui, s.attraction, "attraction", Command::ToggleAttraction);
        toggle(ui, s.collisions, "collisions", Command::ToggleCollisions);
        toggle(ui, s.vectors, "velocities", Command::ToggleVectors);
        toggle(ui, s.centre_of_mass, "centre of mass", Command::ToggleCentreOfMass);
        toggle(ui, s.traces, "traces", Command::ToggleTraces);
    });

    ui.separator();
    ui.horizontal(|ui| {
        ui.label("scene");
        let mut scene = s.scene;
        egui::ComboBox::from_id_salt("scene").selected_text(BUILTIN[s.scene].0).show_ui(ui, |ui| {
            for (k, (name, _)) in BUILTIN.iter().enumerate() {
                ui.selectable_value(&mut scene, k, format!("{} {name}", k + 1));
            }
        });
        if scene != s.scene {
            out.push(Command::Scene(scene));
        }
    });
    ui.horizontal(|ui| {
        ui.label("engine");
        for kind in EngineKind::ALL {
            if ui.selectable_label(r.engine == Some(kind), kind.name()).clicked() && r.engine != Some(kind) {
                out.push(Command::Engine(kind));
            }
        }
    });
    ui.horizontal(|ui| {
        if ui.button(if r.paused { "resume" } else { "pause" }).clicked() {
            out.push(Command::TogglePause);
        }
        if ui.add_enabled(r.paused, egui::Button::new("step")).clicked() {
            out.push(Command::Step);
        }
        if ui.button("add").clicked() {
            out.push(Command::AddBall);
        }
        if ui.button("remove").clicked() {
            out.push(Command::RemoveLast);
        }
        if ui.button("reset").clicked() {
            out.push(Command::Reset);
        }
    });
    if !r.message.is_empty() {
        ui.label(RichText::new(&r.message).color(Color32::LIGHT_RED));
    }
    ui.separator();
    ui.label(RichText::new(format!("H: help · {}", r.adapter)).small().weak());
}

/// Kinetic, potential and total energy (and |momentum|, scaled to fit) over the history.
fn plot(ui: &mut egui::Ui, history: &VecDeque<EnergySample>) {
    let width = ui.available_width();
    let (rect, _) = ui.allocate_exact_size(egui::vec2(width, 120.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_gray(20));
    let (Some(first), Some(last)) = (history.front(), history.back()) else { return };
    let (t0, t1) = (first.t, last.t.max(first.t + 1e-9));
    type Series = (fn(&EnergySample) -> f64, Color32, &'static str);
    let series: [Series; 4] = [
        (|s| s.kinetic, Color32::from_rgb(90, 170, 255), "kinetic"),
        (|s| s.potential, Color32::from_rgb(120, 220, 120), "potential"),
        (|s| s.total, Color32::from_rgb(255, 255, 255), "total"),
        (|s| s.momentum, Color32::from_rgb(255, 170, 60), "|p| (kg·m/s)"),
    ];
    // Energies share one axis; momentum has its own (different units).
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in history {
        for v in [s.kinetic, s.potential, s.total] {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let pmax = history.iter().map(|s| s.momentum).fold(0.0, f64::max).max(1e-12);
    if hi - lo < 1e-9 {
        hi = lo + 1.0;
    }
    let pad = 0.05 * (hi - lo);
    let (lo, hi) = (lo - pad, hi + pad);
    for (k, (get, colour, name)) in series.iter().enumerate() {
        let points: Vec<egui::Pos2> = history
            .iter()
            .map(|s| {
                let x = rect.left() + ((s.t - t0) / (t1 - t0)) as f32 * rect.width();
                let f = if k == 3 { get(s) / (pmax * 1.05) } else { (get(s) - lo) / (hi - lo) };
                egui::pos2(x, rect.bottom() - f as f32 * rect.height())
            })
            .collect();
        painter.add(egui::Shape::line(points, egui::Stroke::new(1.5, *colour)));
        painter.text(
            rect.left_top() + egui::vec2(4.0, 2.0 + 12.0 * k as f32),
            egui::Align2::LEFT_TOP,
            *name,
            egui::FontId::proportional(10.0),
            *colour,
        );
    }
    painter.text(
        rect.right_bottom() + egui::vec2(-4.0, -2.0),
        egui::Align2::RIGHT_BOTTOM,
        format!("last {:.0} s", t1 - t0),
        egui::FontId::proportional(10.0),
        Color32::GRAY,
    );
}

/// The help overlay.
pub fn help(ctx: &egui::Context, open: &mut bool) {
    egui::Window::new("help — keys and mouse").open(open).collapsible(false).resizable(false).show(ctx, |ui| {
        egui::Grid::new("help").num_columns(2).spacing([16.0, 4.0]).show(ui, |ui| {
            let mouse = MOUSE_HELP.iter().map(|&(k, what)| (k.to_string(), what));
            for (k, what) in super::keys::help_lines().chain(mouse) {
                ui.label(RichText::new(k).monospace().strong());
                ui.label(what);
                ui.end_row();
            }
        });
    });
}
