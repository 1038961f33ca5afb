//! The physical effects a scene can turn on, each a small pure function.
//!
//! Every function here returns a force (N) or a potential energy (J) for one ball or one pair;
//! the engines decide which effects run ([`crate::physics::Forces`] builds the per-step list).

use glam::DVec2;
use serde::{Deserialize, Serialize};

use super::ball::disc_area;

/// Standard gravity, m/s².
pub const STANDARD_GRAVITY: f64 = 9.81;
/// Density of air at sea level and 15 °C, kg/m³.
pub const AIR_DENSITY: f64 = 1.225;
/// Drag coefficient of a sphere at moderate Reynolds numbers.
pub const SPHERE_DRAG_COEFFICIENT: f64 = 0.47;
/// Dynamic viscosity of air at 15 °C, Pa·s (for the linear, Stokes, drag model).
pub const AIR_VISCOSITY: f64 = 1.81e-5;
/// Newton's gravitational constant, m³/(kg·s²).
pub const NEWTON_G: f64 = 6.674e-11;

/// Uniform gravity: every ball feels `m·g`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gravity {
    /// Acceleration vector, m/s² (y points up, so the default is `[0, -9.81]`).
    pub g: DVec2,
}

impl Default for Gravity {
    fn default() -> Self {
        Gravity { g: DVec2::new(0.0, -STANDARD_GRAVITY) }
    }
}

/// Air drag. Its serde form is a scene file's: `{ model = "quadratic", rho = 1.225, cd = 0.47 }`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Drag {
    /// `F = −½·ρ·C_d·A·|v|·v`, A = π(d/2)²: fast balls in air.
    Quadratic {
        /// Density ρ of the medium, kg/m³ (a scene's must be positive; air is
        /// [`AIR_DENSITY`]).
        rho: f64,
        /// Drag coefficient C_d, dimensionless (a scene's must be positive; a sphere's is
        /// [`SPHERE_DRAG_COEFFICIENT`]).
        cd: f64,
    },
    /// Stokes drag `F = −3·π·μ·d·v`: slow, small balls in a viscous fluid.
    Linear {
        /// Dynamic viscosity μ of the fluid, Pa·s (a scene's must be positive; air's is
        /// [`AIR_VISCOSITY`]).
        mu: f64,
    },
}

impl Default for Drag {
    fn default() -> Self {
        Drag::Quadratic { rho: AIR_DENSITY, cd: SPHERE_DRAG_COEFFICIENT }
    }
}

/// The Barnes–Hut opening angle a scene gets unless it says otherwise (see
/// [`Attraction::opening_angle`]).
pub const DEFAULT_OPENING_ANGLE: f64 = 0.5;

/// Mutual Newtonian attraction between every pair of balls.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Attraction {
    /// G, m³/(kg·s²). The real value is tiny; scenes scale it to make orbits visible.
    pub g_constant: f64,
    /// Opening angle θ of the Barnes–Hut tree that large fields use (see
    /// [`crate::physics::BarnesHut`]): a group of balls whose size over distance is below θ
    /// pulls as one body. 0 means the direct sum always.
    #[serde(default = "default_opening_angle")]
    pub opening_angle: f64,
}

fn default_opening_angle() -> f64 {
    DEFAULT_OPENING_ANGLE
}

impl Default for Attraction {
    fn default() -> Self {
        Attraction { g_constant: NEWTON_G, opening_angle: DEFAULT_OPENING_ANGLE }
    }
}

/// Elastic (or partly elastic) ball–ball collisions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Collisions {
    /// Coefficient of restitution e in [0, 1]: 1 keeps kinetic energy, 0 is perfectly plastic.
    pub restitution: f64,
}

impl Default for Collisions {
    fn default() -> Self {
        Collisions { restitution: 1.0 }
    }
}

/// Which effects are on. `None` is off and costs nothing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Effects {
    /// Uniform gravity on every ball.
    pub gravity: Option<Gravity>,
    /// Air (or fluid) drag on every ball.
    pub drag: Option<Drag>,
    /// Mutual attraction between every pair of balls.
    pub attraction: Option<Attraction>,
    /// Ball–ball collisions. Off, balls pass through each other; the walls act either way.
    pub collisions: Option<Collisions>,
}

impl Effects {
    /// Names of the effects that are on, in a fixed order, for reports.
    pub fn active_names(&self) -> Vec<&'static str> {
        let mut names = Vec::new();
        if self.gravity.is_some() {
            names.push("gravity");
        }
        if self.drag.is_some() {
            names.push("drag");
        }
        if self.attraction.is_some() {
            names.push("attraction");
        }
        if self.collisions.is_some() {
            names.push("collisions");
        }
        names
    }
}

/// Force of uniform gravity on a ball of mass `mass`.
#[inline]
pub fn gravity_force(mass: f64, gravity: &Gravity) -> DVec2 {
    mass * gravity.g
}

/// Potential energy of a ball in uniform gravity, zero at the origin (the field's lower-left corner):
/// `U = −m·g·x`.
#[inline]
pub fn gravity_potential(mass: f64, position: DVec2, gravity: &Gravity) -> f64 {
    -mass * gravity.g.dot(position)
}

/// Drag force on a ball of diameter `diameter` moving at `velocity` through still air.
#[inline]
pub fn drag_force(velocity: DVec2, diameter: f64, drag: &Drag) -> DVec2 {
    match *drag {
        Drag::Quadratic { rho, cd } => -0.5 * rho * cd * disc_area(diameter) * velocity.length() * velocity,
        Drag::Linear { mu } => -3.0 * std::f64::consts::PI * mu * diameter * velocity,
    }
}

/// How fast drag slows a ball, 1/s: `|dv/dt| / |v|` (`½·ρ·C_d·A·|v|/m` or `3·π·μ·d/m`). An
/// explicit step of length h is stable only while `rate·h` stays below about 1 — a light, large
/// ball at high speed is a stiff problem, and the engines split their steps to keep
/// `rate·h ≤` [`MAX_DRAG_STEP`].
#[inline]
pub fn drag_rate(velocity: DVec2, diameter: f64, mass: f64, drag: &Drag) -> f64 {
    match *drag {
        Drag::Quadratic { rho, cd } => 0.5 * rho * cd * disc_area(diameter) * velocity.length() / mass,
        Drag::Linear { mu } => 3.0 * std::f64::consts::PI * mu * diameter / mass,
    }
}

/// The largest drag rate (see [`drag_rate`]) a ball moving at `velocity` can meet while the other
/// forces on it give it `acceleration` (m/s², drag left out): its rate now, or, when those forces
/// drive it faster, the rate at the terminal speed they drive it to, `√(|a|·c)` for quadratic drag
/// (`|dv/dt| = c·|v|²`, `c` = [`drag_rate`] at 1 m/s). Linear drag's rate does not depend on the
/// speed.
///
/// A step judged by the rate now alone can start resolved and end stiff. Found by tests/fuzz.rs
/// (seed 12): a 1.6 g ball of 2.2 m nearly at rest, with a 2e5 kg grain inside it and G = 1, is
/// pulled at 2e4 m/s²; within one 0.33 ms step it meets drag fifteen times stiffer than at the
/// step's start, the explicit stages overshoot through zero, and it runs away to NaN.
#[inline]
pub fn drag_rate_bound(velocity: DVec2, acceleration: DVec2, diameter: f64, mass: f64, drag: &Drag) -> f64 {
    DragRateBound::new(acceleration, diameter, mass, drag).at(velocity)
}

/// [`drag_rate_bound`] for one ball under one acceleration, asked at many velocities: the
/// terminal-speed rate (two square roots and a division) worked out once. The same bits as
/// [`drag_rate_bound`] at every velocity. The threaded monitor asks it at every sub-step of every
/// ball it carries over a pass.
#[derive(Clone, Copy, Debug)]
pub struct DragRateBound<'a> {
    drag: &'a Drag,
    diameter: f64,
    mass: f64,
    /// The rate at the terminal speed (quadratic drag), or none (linear drag).
    terminal: Option<f64>,
}

impl<'a> DragRateBound<'a> {
    /// The bound for a ball of `diameter` and `mass` that the other forces give `acceleration`.
    #[inline]
    pub fn new(acceleration: DVec2, diameter: f64, mass: f64, drag: &'a Drag) -> Self {
        let terminal = match drag {
            Drag::Quadratic { .. } => Some((acceleration.length() * drag_rate(DVec2::X, diameter, mass, drag)).sqrt()),
            Drag::Linear { .. } => None,
        };
        DragRateBound { drag, diameter, mass, terminal }
    }

    /// The bound at `velocity`.
    #[inline]
    pub fn at(&self, velocity: DVec2) -> f64 {
        let now = drag_rate(velocity, self.diameter, self.mass, self.drag);
        self.terminal.map_or(now, |terminal| now.max(terminal))
    }
}

/// `a`, the drag acceleration of a ball moving at `v`, with its rate `|a|/|v|` capped at `limit`
/// (1/s): the engines' guard rail for drag too stiff for their shortest step (see
/// `Forces::set_drag_rate_limit`). An explicit stage of length h ≤ 1/limit can then stop the ball
/// but never throw it back faster.
#[inline]
pub fn cap_drag_rate(a: DVec2, v: DVec2, limit: f64) -> DVec2 {
    let cap = limit * v.length();
    let a2 = a.length_squared();
    if a2 > cap * cap { a * (cap / a2.sqrt()) } else { a }
}

/// The square of the angular frequency at which a pair of attracting balls would orbit (or, when
/// they overlap, oscillate through each other), `G·(ma + mb)/max(r, R)³`, 1/s². An explicit step h
/// resolves that motion only while `ω·h` is small; the engines split their steps to keep it at
/// most [`MAX_ORBIT_STEP`]. It is the force passes' own figure: the stiffness
/// [`attraction_pair`] gives, times `1/ma + 1/mb`.
#[inline]
pub fn attraction_rate_squared(
    pa: DVec2,
    ma: f64,
    ra: f64,
    pb: DVec2,
    mb: f64,
    rb: f64,
    attraction: &Attraction,
) -> f64 {
    let (_, k) = attraction_pair(pa, ma, ra, pb, mb, rb, attraction);
    k * (1.0 / ma + 1.0 / mb)
}

/// Largest `ω·h` a step may have for attracting pairs (see [`attraction_rate_squared`]).
pub const MAX_ORBIT_STEP: f64 = 0.2;

/// Largest `drag_rate · h` a step may have (see [`drag_rate`]).
pub const MAX_DRAG_STEP: f64 = 0.5;

/// Terminal speed of a ball falling under gravity `g` (magnitude) with quadratic drag:
/// `v_t = sqrt(2·m·g / (ρ·C_d·A))`.
pub fn quadratic_terminal_speed(mass: f64, diameter: f64, g: f64, rho: f64, cd: f64) -> f64 {
    (2.0 * mass * g / (rho * cd * disc_area(diameter))).sqrt()
}

/// Attraction force on ball a (at `pa`, mass `ma`, radius `ra`) from ball b.
///
/// Outside contact (`r ≥ R`, `R = ra + rb`) this is Newton's `G·ma·mb/r²` along the line of centres.
/// Balls have size, so when they overlap (`r < R`) the force is that of a point inside a uniform
/// ball of radius R: `G·ma·mb·r/R³`. It is continuous at `r = R`, falls linearly to zero at
/// `r = 0`, and is computed from the offset vector without dividing by r, so coincident centres
/// give exactly zero force, never NaN or infinity.
#[inline]
pub fn attraction_force(pa: DVec2, ma: f64, ra: f64, pb: DVec2, mb: f64, rb: f64, attraction: &Attraction) -> DVec2 {
    attraction_pair(pa, ma, ra, pb, mb, rb, attraction).0
}

/// [`attraction_force`] (the same bits) and its stiffness `k = G·ma·mb/max(r, R)³`, N/m: the force
/// is `k·(pb − pa)`. The pair's orbit rate follows at the cost of one multiplication,
/// `ω² = k·(1/ma + 1/mb)` ([`attraction_rate_squared`]), so the force passes
/// measure it while they sum the forces.
#[inline]
pub fn attraction_pair(
    pa: DVec2,
    ma: f64,
    ra: f64,
    pb: DVec2,
    mb: f64,
    rb: f64,
    attraction: &Attraction,
) -> (DVec2, f64) {
    let d = pb - pa;
    let r2 = d.length_squared();
    let contact = ra + rb;
    let gmm = attraction.g_constant * ma * mb;
    let k = if r2 >= contact * contact {
        let r = r2.sqrt();
        gmm / (r2 * r)
    } else {
        gmm / (contact * contact * contact)
    };
    (d * k, k)
}

/// Potential energy of a pair under [`attraction_force`]: `−G·ma·mb/r` outside contact and
/// `−G·ma·mb·(3R² − r²)/(2R³)` inside, so that its gradient is the force and it is finite at r = 0.
#[inline]
pub fn attraction_potential(pa: DVec2, ma: f64, ra: f64, pb: DVec2, mb: f64, rb: f64, attraction: &Attraction) -> f64 {
    let r2 = (pb - pa).length_squared();
    let contact = ra + rb;
    let gmm = attraction.g_constant * ma * mb;
    if r2 >= contact * contact {
        -gmm / r2.sqrt()
    } else {
        -gmm * (3.0 * contact * contact - r2) / (2.0 * contact * contact * contact)
    }
}
