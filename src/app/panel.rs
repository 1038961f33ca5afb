//! The control panel (egui): readouts, a live energy plot, sliders and toggles. It only returns
//! [`Command`]s; the app carries them out.

use std::collections::VecDeque;

use egui::{Color32, RichText};

use crate::engine::EngineKind;
use crate::scenes::BUILTIN;

/// What the user asked for, by key, mouse or panel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    AddBall,
    RemoveLast,
    TogglePause,
    Step,
    Reset,
    ToggleGravity,
    ToggleDrag,
    ToggleAttraction,
    ToggleCollisions,
    Scene(usize),
    Engine(EngineKind),
    TogglePanel,
    ToggleHelp,
    ToggleVectors,
    ToggleCentreOfMass,
    ToggleTraces,
    Quit,
    SetPull(f64),
    SetKeyMass(f64),
    SetRestitution(f64),
    SetTimeScale(f64),
}

/// The hotkeys, as the help overlay lists them.
pub const HELP: &[(&str, &str)] = &[
    ("← ↑ → ↓", "pull the key ball (hold; keys combine)"),
    ("A", "add a ball"),
    ("Backspace / Delete", "remove the last ball"),
    ("Space / P", "pause / resume"),
    ("S", "single step (while paused)"),
    ("R", "reset the scene"),
    ("G / D / N / C", "gravity / drag / attraction / collisions"),
    ("1 – 8", "switch scene"),
    ("E", "switch engine (threaded / lockstep)"),
    ("V / M / T", "velocity vectors / centre of mass / traces"),
    ("Tab", "show / hide the panel"),
    ("H / F1", "this help"),
    ("Esc / Q", "quit"),
    ("mouse: drag a ball", "grab it and throw it"),
    ("mouse: click elsewhere", "drop a new ball there"),
];

/// One sample of the energy plot.
#[derive(Clone, Copy, Debug, Default)]
pub struct EnergySample {
    pub t: f64,
    pub kinetic: f64,
    pub potential: f64,
    pub total: f64,
    pub momentum: f64,
}

/// What the panel shows (refreshed by the app).
#[derive(Clone, Debug, Default)]
pub struct Readouts {
    pub scene: String,
    pub engine: Option<EngineKind>,
    pub balls: usize,
    pub frame_rate: f64,
    /// Median time to draw a frame over the last 60, ms.
    pub frame_ms: f64,
    pub sim_rate: f64,
    pub paused: bool,
    pub kinetic: f64,
    pub potential: f64,
    pub total: f64,
    pub momentum: [f64; 2],
    /// Mean pressure on the walls over the last second, N/m (force per metre of wall).
    pub pressure: f64,
    pub history: VecDeque<EnergySample>,
    pub adapter: String,
    pub message: String,
}

/// The settings the panel edits (the app owns them).
#[derive(Clone, Debug)]
pub struct Settings {
    pub pull: f64,
    pub key_mass: f64,
    pub restitution: f64,
    pub time_scale: f64,
    pub gravity: bool,
    pub drag: bool,
    pub attraction: bool,
    pub collisions: bool,
    pub vectors: bool,
    pub centre_of_mass: bool,
    pub traces: bool,
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
        let unit = match r.engine {
            Some(EngineKind::Lockstep) => "steps/s",
            Some(EngineKind::Exact) => "events/s",
            _ => "cycles/s per ball",
        };
        row(ui, "simulation", format!("{:.0} {unit}", r.sim_rate));
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
            for (k, what) in HELP {
                ui.label(RichText::new(*k).monospace().strong());
                ui.label(*what);
                ui.end_row();
            }
        });
    });
}
