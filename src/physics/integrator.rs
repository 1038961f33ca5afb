//! Time integrators for `ẋ = v, v̇ = a(x, v)` over a whole set of balls at once.
//!
//! The acceleration is a closure so that the same integrator advances the lockstep engine's
//! whole field and a threaded ball on its own (with the other balls frozen at their last
//! published state). Nothing here allocates: [`IntegratorScratch`] holds the stage buffers.

use std::fmt;
use std::str::FromStr;

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// The integration method.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// Explicit (forward) Euler, the original design's loop: `x += v·dt; v += a(x, v)·dt`.
    /// Order 1, not symplectic: orbits spiral outwards, energy grows.
    ExplicitEuler,
    /// Semi-implicit (symplectic) Euler: `v += a(x, v)·dt; x += v·dt`. Order 1, symplectic for
    /// position-only forces: energy error stays bounded instead of drifting. One force evaluation.
    #[default]
    SemiImplicitEuler,
    /// Leapfrog / Störmer–Verlet in drift–kick–drift form: `x += v·dt/2; v += a(x, v)·dt;
    /// x += v·dt/2`. Order 2, symplectic and time-reversible for position-only forces. One force
    /// evaluation per step (the same trajectory as velocity Verlet, sampled at half steps).
    Leapfrog,
    /// Classic fourth-order Runge–Kutta. Order 4, not symplectic: very accurate per step, but its
    /// energy error drifts slowly over long runs. Four force evaluations.
    Rk4,
    /// Yoshida's fourth-order symplectic composition of three leapfrog steps (the same method as
    /// Forest–Ruth). Order 4, symplectic. Three force evaluations.
    Yoshida4,
}

impl Integrator {
    /// Every method, by order of accuracy (the two Euler methods first); the accuracy study
    /// compares them in this order.
    pub const ALL: [Integrator; 5] = [
        Integrator::ExplicitEuler,
        Integrator::SemiImplicitEuler,
        Integrator::Leapfrog,
        Integrator::Rk4,
        Integrator::Yoshida4,
    ];

    /// The kebab-case name used in scene files and on the command line (`semi-implicit-euler`).
    pub fn name(self) -> &'static str {
        match self {
            Integrator::ExplicitEuler => "explicit-euler",
            Integrator::SemiImplicitEuler => "semi-implicit-euler",
            Integrator::Leapfrog => "leapfrog",
            Integrator::Rk4 => "rk4",
            Integrator::Yoshida4 => "yoshida4",
        }
    }

    /// Order of global convergence for smooth forces.
    pub fn order(self) -> u32 {
        match self {
            Integrator::ExplicitEuler | Integrator::SemiImplicitEuler => 1,
            Integrator::Leapfrog => 2,
            Integrator::Rk4 | Integrator::Yoshida4 => 4,
        }
    }

    /// Whether the method is symplectic, so that its energy error stays bounded for
    /// position-only forces instead of drifting.
    pub fn is_symplectic(self) -> bool {
        !matches!(self, Integrator::ExplicitEuler | Integrator::Rk4)
    }

    /// Force evaluations per step, the main cost driver, for position-only forces (with drag on,
    /// each kick of leapfrog costs 1 + 2 evaluations and each of Yoshida's three kicks 1 + 3: see
    /// `symmetric_kick`).
    pub fn force_evaluations(self) -> u32 {
        match self {
            Integrator::ExplicitEuler | Integrator::SemiImplicitEuler | Integrator::Leapfrog => 1,
            Integrator::Yoshida4 => 3,
            Integrator::Rk4 => 4,
        }
    }
}

impl fmt::Display for Integrator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An integrator name that is not one of [`Integrator::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown integrator `{0}` (expected one of: explicit-euler, semi-implicit-euler, leapfrog, rk4, yoshida4)")]
pub struct UnknownIntegrator(pub String);

impl FromStr for Integrator {
    type Err = UnknownIntegrator;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "explicit-euler" | "euler" => Integrator::ExplicitEuler,
            "semi-implicit-euler" | "symplectic-euler" => Integrator::SemiImplicitEuler,
            "leapfrog" | "velocity-verlet" | "verlet" => Integrator::Leapfrog,
            "rk4" | "runge-kutta-4" => Integrator::Rk4,
            "yoshida4" | "forest-ruth" => Integrator::Yoshida4,
            other => return Err(UnknownIntegrator(other.to_string())),
        })
    }
}

/// Stage buffers, sized on first use and reused (no allocation once warm).
#[derive(Clone, Debug, Default)]
pub struct IntegratorScratch {
    acc: Vec<DVec2>,
    x0: Vec<DVec2>,
    v0: Vec<DVec2>,
    sum_x: Vec<DVec2>,
    sum_v: Vec<DVec2>,
}

impl IntegratorScratch {
    fn resize(&mut self, n: usize) {
        for buf in [&mut self.acc, &mut self.x0, &mut self.v0, &mut self.sum_x, &mut self.sum_v] {
            buf.resize(n, DVec2::ZERO);
        }
    }
}

/// Yoshida's coefficients: w1 = 1/(2 − 2^{1/3}), w0 = −2^{1/3}/(2 − 2^{1/3}).
const YOSHIDA_W1: f64 = 1.351_207_191_959_657_8;
const YOSHIDA_W0: f64 = -1.702_414_383_919_315_3;

fn drift(x: &mut [DVec2], v: &[DVec2], h: f64) {
    for (xi, vi) in x.iter_mut().zip(v) {
        *xi += *vi * h;
    }
}

fn kick(v: &mut [DVec2], a: &[DVec2], h: f64) {
    for (vi, ai) in v.iter_mut().zip(a) {
        *vi += *ai * h;
    }
}

/// Fixed-point iterations of the implicit-midpoint kick for velocity-dependent forces, per
/// method. The explicit first guess is off by O(h²) from the implicit-midpoint solution and each
/// iteration gains one power of h, so after m iterations the kick's local error is O(h^(2+m)):
/// a method of order p needs m ≥ p − 1 for its global error to stay O(h^p). Leapfrog (p = 2)
/// takes 2; Yoshida (p = 4) needs 3 — with 2 it fell to order 3 with drag on (measured by
/// `ballfield accuracy` on the drag fall).
const LEAPFROG_MIDPOINT_ITERATIONS: usize = 2;
const YOSHIDA_MIDPOINT_ITERATIONS: usize = 3;

/// The kick of the symplectic methods: `v += h·a(x, v)`. When the force depends on velocity
/// (drag), an explicit kick would be only first order and not time-symmetric; the kick is then
/// the implicit midpoint `v' = v + h·a(x, (v + v')/2)`, solved by `iterations` fixed-point
/// iterations (each contracts the error by about `h·|∂a/∂v|/2`, tiny for air drag). This keeps
/// leapfrog second order and Yoshida fourth order with drag on, at `iterations` extra force
/// evaluations per kick. `acc` must hold `a(x, v)` on entry.
fn symmetric_kick<F>(
    x: &[DVec2],
    v: &mut [DVec2],
    h: f64,
    velocity_dependent: bool,
    iterations: usize,
    scratch: &mut IntegratorScratch,
    accel: &mut F,
) where
    F: FnMut(&[DVec2], &[DVec2], &mut [DVec2]),
{
    if !velocity_dependent {
        kick(v, &scratch.acc, h);
        return;
    }
    let IntegratorScratch { acc, v0, sum_v: v_mid, .. } = scratch;
    v0.copy_from_slice(v);
    kick(v, acc, h);
    for _ in 0..iterations {
        for i in 0..v.len() {
            v_mid[i] = 0.5 * (v0[i] + v[i]);
        }
        accel(x, v_mid, acc);
        for i in 0..v.len() {
            v[i] = v0[i] + acc[i] * h;
        }
    }
}

/// Advances `x` and `v` by `dt` with `method`; `accel(x, v, a)` must fill `a`.
/// `velocity_dependent` says whether `a` depends on `v` (drag): the symplectic methods then use a
/// time-symmetric kick (see `symmetric_kick`) so they keep their order.
pub fn integrate<F>(
    method: Integrator,
    dt: f64,
    x: &mut [DVec2],
    v: &mut [DVec2],
    velocity_dependent: bool,
    scratch: &mut IntegratorScratch,
    mut accel: F,
) where
    F: FnMut(&[DVec2], &[DVec2], &mut [DVec2]),
{
    let n = x.len();
    debug_assert_eq!(n, v.len());
    scratch.resize(n);
    match method {
        Integrator::ExplicitEuler => {
            accel(x, v, &mut scratch.acc);
            drift(x, v, dt);
            kick(v, &scratch.acc, dt);
        }
        Integrator::SemiImplicitEuler => {
            accel(x, v, &mut scratch.acc);
            kick(v, &scratch.acc, dt);
            drift(x, v, dt);
        }
        Integrator::Leapfrog => {
            drift(x, v, 0.5 * dt);
            accel(x, v, &mut scratch.acc);
            symmetric_kick(x, v, dt, velocity_dependent, LEAPFROG_MIDPOINT_ITERATIONS, scratch, &mut accel);
            drift(x, v, 0.5 * dt);
        }
        Integrator::Yoshida4 => {
            let (w1, w0) = (YOSHIDA_W1, YOSHIDA_W0);
            drift(x, v, 0.5 * w1 * dt);
            accel(x, v, &mut scratch.acc);
            symmetric_kick(x, v, w1 * dt, velocity_dependent, YOSHIDA_MIDPOINT_ITERATIONS, scratch, &mut accel);
            drift(x, v, 0.5 * (w0 + w1) * dt);
            accel(x, v, &mut scratch.acc);
            symmetric_kick(x, v, w0 * dt, velocity_dependent, YOSHIDA_MIDPOINT_ITERATIONS, scratch, &mut accel);
            drift(x, v, 0.5 * (w0 + w1) * dt);
            accel(x, v, &mut scratch.acc);
            symmetric_kick(x, v, w1 * dt, velocity_dependent, YOSHIDA_MIDPOINT_ITERATIONS, scratch, &mut accel);
            drift(x, v, 0.5 * w1 * dt);
        }
        Integrator::Rk4 => {
            let h = dt;
            let IntegratorScratch { acc, x0, v0, sum_x, sum_v } = scratch;
            x0.copy_from_slice(x);
            v0.copy_from_slice(v);
            // Stage 1 at (x0, v0).
            accel(x, v, acc);
            sum_x.copy_from_slice(v0);
            sum_v.copy_from_slice(acc);
            // Stages 2 and 3 at the midpoint, stage 4 at the end. At each stage the slices
            // (x, v) hold the stage state; the stage's dx/dt is that v and its dv/dt is acc.
            for (c, w) in [(0.5, 2.0), (0.5, 2.0), (1.0, 1.0)] {
                for i in 0..n {
                    // x_s = x0 + c·h·(previous stage v); v_s = v0 + c·h·(previous stage a).
                    x[i] = x0[i] + v[i] * (c * h);
                    v[i] = v0[i] + acc[i] * (c * h);
                }
                accel(x, v, acc);
                for i in 0..n {
                    sum_x[i] += v[i] * w;
                    sum_v[i] += acc[i] * w;
                }
            }
            for i in 0..n {
                x[i] = x0[i] + sum_x[i] * (h / 6.0);
                v[i] = v0[i] + sum_v[i] * (h / 6.0);
            }
        }
    }
}
