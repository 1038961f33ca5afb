//! The reference problems: a built-in scene, how to sweep its time step, and how far a run is
//! from the exact answer.

use glam::DVec2;

use super::AccuracyError;
use super::analytic::{Collision, DragFall, TwoBody, projectile};
use crate::engine::lockstep::Lockstep;
use crate::physics::{Attraction, Bodies, Drag, Effects, attraction_potential_energy, kinetic_energy};
use crate::scene::Scene;
use crate::scenes;

/// What kind of exact answer a problem has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Two balls on a Kepler orbit: energy over the run, position after whole periods.
    Kepler,
    /// Balls released from rest under gravity and quadratic drag.
    DragFall,
    /// Balls thrown in uniform gravity.
    Projectile,
    /// Two balls that meet once (uniform gravity at most).
    Collision,
}

/// A reference problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Problem {
    /// Short name, e.g. `kepler-e05`; the scene is `reference/<name>`.
    pub name: &'static str,
    /// What kind of exact answer it has, which decides its measures and its sweep.
    pub kind: Kind,
}

/// Every reference problem, in the order of the report.
pub const PROBLEMS: [Problem; 6] = [
    Problem { name: "kepler-e0", kind: Kind::Kepler },
    Problem { name: "kepler-e05", kind: Kind::Kepler },
    Problem { name: "drag-fall", kind: Kind::DragFall },
    Problem { name: "projectile", kind: Kind::Projectile },
    Problem { name: "collision-head-on", kind: Kind::Collision },
    Problem { name: "collision-oblique", kind: Kind::Collision },
];

/// Drag fall: the run length and the interval at which the error is sampled, s.
const DRAG_DURATION: f64 = 3.0;
const DRAG_SAMPLE: f64 = 0.5;
/// Projectile: the run length, s.
const PROJECTILE_DURATION: f64 = 1.5;

/// One error measure of a problem (a problem may have several, from the same run).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Measure {
    /// Short name in the table and the CSV (`energy`, `position`, `fall`).
    pub name: &'static str,
    /// What the number means, for the table's legend.
    pub meaning: &'static str,
}

pub const ENERGY: Measure = Measure { name: "energy", meaning: "worst |E − E₀|/|E₀| over the run (every step)" };
pub const ORBIT: Measure = Measure {
    name: "position",
    meaning: "worst |r − r_exact|/a over the run (every step, so whole periods too), r = x₂ − x₁, r_exact from Kepler's equation",
};
pub const FALL: Measure = Measure {
    name: "fall",
    meaning: "worst relative error in speed (/v_t) and distance fallen, every 0.5 s, over the balls",
};
pub const FLIGHT: Measure =
    Measure { name: "position", meaning: "worst |x − x_exact| over the balls at t = 1.5 s / distance flown" };
pub const AFTER_CONTACT: Measure = Measure {
    name: "position",
    meaning: "worst |x − x_exact| over the balls at t = 2·t_contact / the distance that ball moved after the contact",
};

impl Problem {
    /// The built-in scene's name, `reference/<name>`.
    pub fn scene_name(&self) -> String {
        format!("reference/{}", self.name)
    }

    /// The problem's built-in scene, parsed.
    pub fn scene(&self) -> Result<Scene, AccuracyError> {
        let name = self.scene_name();
        match scenes::builtin(&name) {
            Some(scene) => Ok(scene?),
            None => Err(AccuracyError::Problem(format!("no built-in scene `{name}`"))),
        }
    }

    /// The error measures a run of this problem is judged by, in the order
    /// [`Exact::errors`] returns them.
    pub fn measures(&self) -> &'static [Measure] {
        match self.kind {
            Kind::Kepler => &[ENERGY, ORBIT],
            Kind::DragFall => &[FALL],
            Kind::Projectile => &[FLIGHT],
            Kind::Collision => &[AFTER_CONTACT],
        }
    }

    /// The exact answer for this scene.
    pub fn exact(&self, scene: &Scene) -> Result<Exact, AccuracyError> {
        let b = &scene.balls;
        let bad = |why: &str| AccuracyError::Problem(format!("scene `{}`: {why}", scene.name));
        let gravity = scene.effects.gravity.map(|g| g.g).unwrap_or(DVec2::ZERO);
        Ok(match self.kind {
            Kind::Kepler => {
                let attraction = scene.effects.attraction.ok_or_else(|| bad("attraction is off"))?;
                if b.len() != 2 || scene.effects.gravity.is_some() || scene.effects.drag.is_some() {
                    return Err(bad("a Kepler problem is two balls under attraction alone"));
                }
                let orbit = TwoBody::new(
                    attraction.g_constant,
                    [b[0].mass, b[1].mass],
                    [b[0].position, b[1].position],
                    [b[0].velocity, b[1].velocity],
                )
                .ok_or_else(|| bad("the two balls are not on a bound orbit"))?;
                let pericentre = orbit.a * (1.0 - orbit.e);
                if pericentre <= b[0].radius() + b[1].radius() {
                    return Err(bad("the balls touch at periapsis, where attraction is softened"));
                }
                Exact::Kepler(orbit)
            }
            Kind::DragFall => {
                let Some(Drag::Quadratic { rho, cd }) = scene.effects.drag else {
                    return Err(bad("quadratic drag is off"));
                };
                if gravity.x != 0.0 || gravity.y >= 0.0 || b.iter().any(|b| b.velocity != DVec2::ZERO) {
                    return Err(bad("the balls must start at rest under downward gravity"));
                }
                Exact::DragFall(b.iter().map(|b| DragFall::new(b.mass, b.diameter, -gravity.y, rho, cd)).collect())
            }
            Kind::Projectile => {
                if scene.effects.drag.is_some() || scene.effects.attraction.is_some() {
                    return Err(bad("a projectile flies in vacuum"));
                }
                Exact::Projectile { g: gravity }
            }
            Kind::Collision => {
                let restitution = scene.effects.collisions.ok_or_else(|| bad("collisions are off"))?.restitution;
                if b.len() != 2 || scene.effects.drag.is_some() || scene.effects.attraction.is_some() {
                    return Err(bad("a collision problem is two balls, with uniform gravity at most"));
                }
                Exact::Collision(
                    Collision::new(
                        gravity,
                        restitution,
                        [b[0].mass, b[1].mass],
                        [b[0].radius(), b[1].radius()],
                        [b[0].position, b[1].position],
                        [b[0].velocity, b[1].velocity],
                    )
                    .ok_or_else(|| bad("the balls never meet"))?,
                )
            }
        })
    }
}

/// The exact answer of a problem.
#[derive(Clone, Debug, PartialEq)]
pub enum Exact {
    /// The pair's Keplerian orbit.
    Kepler(TwoBody),
    /// Each ball's fall, in the scene's order.
    DragFall(Vec<DragFall>),
    /// Every ball flies on its parabola from its own start.
    Projectile {
        /// The uniform acceleration, m/s² (zero without gravity).
        g: DVec2,
    },
    /// The pair's one bounce.
    Collision(Collision),
}

/// One point of a sweep: the step and the number of steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepPoint {
    /// Time step, s.
    pub dt: f64,
    /// Steps of `dt` in the run.
    pub steps: u64,
}

impl Exact {
    /// The sweep of time steps: `resolutions` are steps per orbit (Kepler), per 0.5 s sample (drag
    /// fall), per run (projectile) or whole steps before the contact (collisions).
    ///
    /// For collisions the step is `t_c / (n + ½)`: the contact always falls half a step before a
    /// step boundary, the average lag, so the error measures the lag and not the luck of the phase
    /// (at another phase it is anywhere from zero to twice as large).
    pub fn sweep(&self, resolutions: &[u64], orbits: u64) -> Vec<SweepPoint> {
        resolutions
            .iter()
            .map(|&k| match self {
                Exact::Kepler(o) => SweepPoint { dt: o.period / k as f64, steps: k * orbits },
                Exact::DragFall(_) => {
                    SweepPoint { dt: DRAG_SAMPLE / k as f64, steps: k * (DRAG_DURATION / DRAG_SAMPLE).round() as u64 }
                }
                Exact::Projectile { .. } => SweepPoint { dt: PROJECTILE_DURATION / k as f64, steps: k },
                Exact::Collision(c) => SweepPoint { dt: c.contact_time / (k as f64 + 0.5), steps: 2 * k + 1 },
            })
            .collect()
    }

    /// Runs `engine` (at t = 0, with the scene's balls) for `point.steps` steps and returns each
    /// of the problem's measures, in the order of [`Problem::measures`].
    ///
    /// `twin` is the same problem translated by [`TWIN_SHIFT`]: every force here depends only on
    /// differences of positions, so its truncation error is the same and only its rounding differs.
    /// The same measure taken on the difference of the two runs estimates the rounding error.
    pub fn errors(
        &self,
        engine: &mut Lockstep,
        twin: &mut Lockstep,
        point: SweepPoint,
    ) -> Result<Vec<Measured>, AccuracyError> {
        let start: Vec<(DVec2, DVec2)> =
            (0..engine.bodies().len()).map(|i| (engine.bodies().position[i], engine.bodies().velocity[i])).collect();
        let shift = twin.bodies().position[0] - engine.bodies().position[0];
        let both = |engine: &mut Lockstep, twin: &mut Lockstep, n: u64| {
            engine.run(n);
            twin.run(n);
        };
        let measured = match self {
            Exact::Kepler(orbit) => {
                let effects = Effects {
                    attraction: Some(Attraction { g_constant: orbit.g_constant, ..Attraction::default() }),
                    ..Effects::default()
                };
                let energy = |b: &Bodies| kinetic_energy(b) + attraction_potential_energy(b, &effects);
                let relative = |b: &Bodies| b.position[1] - b.position[0];
                let (e0, e0_twin) = (energy(engine.bodies()), energy(twin.bodies()));
                let mut worst_energy = Measured::default();
                let mut worst_position = Measured::default();
                for step in 1..=point.steps {
                    engine.step();
                    twin.step();
                    let (b, c) = (engine.bodies(), twin.bodies());
                    let (de, de_twin) = (energy(b) - e0, energy(c) - e0_twin);
                    worst_energy.update((de / e0).abs(), ((de - de_twin) / e0).abs());
                    let (r_exact, _) = orbit.relative_at(step as f64 * point.dt);
                    let r = relative(b);
                    worst_position.update(r.distance(r_exact) / orbit.a, r.distance(relative(c)) / orbit.a);
                    if !worst_energy.error.is_finite() || !worst_position.error.is_finite() {
                        break;
                    }
                }
                vec![worst_energy, worst_position]
            }
            Exact::DragFall(falls) => {
                let per_sample = (DRAG_SAMPLE / point.dt).round() as u64;
                let mut worst = Measured::default();
                for step in (per_sample..=point.steps).step_by(per_sample as usize) {
                    both(engine, twin, per_sample);
                    let t = step as f64 * point.dt;
                    let (b, c) = (engine.bodies(), twin.bodies());
                    for (i, fall) in falls.iter().enumerate() {
                        let (vt, fallen) = (fall.terminal_speed, fall.fallen(t));
                        let speed = |b: &Bodies| -b.velocity[i].y;
                        let drop = |b: &Bodies, x0: DVec2| x0 - b.position[i];
                        let (d, d_twin) = (drop(b, start[i].0), drop(c, start[i].0 + shift));
                        let error = ((speed(b) - fall.speed(t)).abs() / vt)
                            .max((d.y - fallen).abs() / fallen)
                            .max(d.x.abs() / fallen);
                        let rounding = ((speed(b) - speed(c)).abs() / vt).max(d.distance(d_twin) / fallen);
                        worst.update(error, rounding);
                    }
                }
                vec![worst]
            }
            Exact::Projectile { g } => {
                both(engine, twin, point.steps);
                let t = point.steps as f64 * point.dt;
                let (b, c) = (engine.bodies(), twin.bodies());
                let mut worst = Measured::default();
                for (i, &(x0, v0)) in start.iter().enumerate() {
                    let exact = projectile(x0, v0, *g, t);
                    let flown = exact.distance(x0);
                    worst.update(
                        b.position[i].distance(exact) / flown,
                        (c.position[i] - shift).distance(b.position[i]) / flown,
                    );
                }
                vec![worst]
            }
            Exact::Collision(c) => {
                both(engine, twin, point.steps);
                let t = point.steps as f64 * point.dt;
                for e in [&*engine, &*twin] {
                    let counters = e.counters();
                    if counters.impulses != 1 || counters.wall_contacts != 0 {
                        return Err(AccuracyError::Problem(format!(
                            "collision problem at dt = {}: {} ball–ball impulses and {} wall contacts, expected 1 and 0",
                            point.dt, counters.impulses, counters.wall_contacts
                        )));
                    }
                }
                let (b, d) = (engine.bodies(), twin.bodies());
                let exact = c.positions_at(t);
                let mut worst = Measured::default();
                for (i, (&x_exact, &(x_contact, _))) in exact.iter().zip(&c.after).enumerate() {
                    let moved = x_exact.distance(x_contact);
                    worst.update(
                        b.position[i].distance(x_exact) / moved,
                        (d.position[i] - shift).distance(b.position[i]) / moved,
                    );
                }
                vec![worst]
            }
        };
        Ok(measured)
    }
}

/// How far the twin run is translated: a few centimetres, in no round numbers, so that every
/// coordinate rounds differently (the reference scenes keep their balls that far from the walls).
pub const TWIN_SHIFT: DVec2 = DVec2::new(0.012_345_678_9, -0.009_876_543_21);

/// A measure's error against the exact answer, and an estimate of the part of it that is
/// floating-point rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measured {
    /// The measure's error against the exact answer (relative, see [`Measure::meaning`]).
    pub error: f64,
    /// The same measure of the difference between the run and its translated twin: the
    /// rounding part of `error`.
    pub rounding: f64,
}

impl Measured {
    /// Keeps the worst of each (a NaN counts as infinitely wrong).
    fn update(&mut self, error: f64, rounding: f64) {
        self.error = self.error.max(nan_to_inf(error));
        self.rounding = self.rounding.max(nan_to_inf(rounding));
    }
}

fn nan_to_inf(x: f64) -> f64 {
    if x.is_nan() { f64::INFINITY } else { x }
}
