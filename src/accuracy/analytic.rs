//! Exact answers for the reference problems: the two-body (Kepler) orbit, the fall with quadratic
//! drag, the projectile in vacuum, and an elastic collision between two free balls.
//!
//! Every solution is built from an initial state (the scene's balls), so a scene can be edited and
//! the exact answer follows.

use glam::DVec2;

use crate::physics::quadratic_terminal_speed;

/// Solves Kepler's equation `E − e·sin E = M` for the eccentric anomaly E (0 ≤ e < 1).
///
/// Newton's method, safeguarded by bisection: `E − e·sin E − M` is increasing and changes sign on
/// `[M − e, M + e]`, so the answer is always found, to a few ulps, in a handful of iterations.
pub fn solve_kepler(mean_anomaly: f64, e: f64) -> f64 {
    solve_monotone(mean_anomaly, e, |x| (x - e * x.sin() - mean_anomaly, 1.0 - e * x.cos()))
}

/// Root of an increasing function `f` (given as `x ↦ (f(x), f'(x))`) in `[centre − half_width,
/// centre + half_width]`, where it changes sign: Newton's steps, falling back to bisection whenever
/// a step would leave the bracket.
fn solve_monotone(centre: f64, half_width: f64, f: impl Fn(f64) -> (f64, f64)) -> f64 {
    let (mut lo, mut hi) = (centre - half_width - 1e-12, centre + half_width + 1e-12);
    let mut x = centre;
    for _ in 0..100 {
        let (fx, dfx) = f(x);
        if fx == 0.0 {
            return x;
        }
        if fx < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - fx / dfx;
        let next = if newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
        if (next - x).abs() <= 4.0 * f64::EPSILON * x.abs().max(1.0) {
            return next;
        }
        x = next;
    }
    x
}

/// Two balls under their mutual Newtonian attraction: the exact (Keplerian) motion.
///
/// The centre of mass moves in a straight line; the relative position `r = x₂ − x₁` follows a
/// Kepler ellipse with `μ = G·(m₁ + m₂)`. Positions at any time come from Kepler's equation in its
/// eccentric-anomaly-difference form and Lagrange's f and g functions, which are regular for the
/// circular orbit too (where the direction of periapsis is undefined).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoBody {
    /// The gravitational constant G of the scene, m³/(kg·s²).
    pub g_constant: f64,
    /// The two masses, kg, in the scene's order.
    pub masses: [f64; 2],
    /// `G·(m₁ + m₂)`, m³/s².
    pub mu: f64,
    /// Centre of mass at t = 0, m.
    pub centre: DVec2,
    /// Velocity of the centre of mass, m/s: constant, as no outside force acts.
    pub centre_velocity: DVec2,
    /// Relative position `x₂ − x₁` at t = 0, m.
    pub r0: DVec2,
    /// Relative velocity `v₂ − v₁` at t = 0, m/s.
    pub v0: DVec2,
    /// Semi-major axis, m.
    pub a: f64,
    /// Eccentricity.
    pub e: f64,
    /// Mean motion `sqrt(μ/a³)`, rad/s.
    pub mean_motion: f64,
    /// Orbital period, s.
    pub period: f64,
}

impl TwoBody {
    /// The orbit of two balls from their state at t = 0, or `None` if they are not bound.
    pub fn new(g_constant: f64, masses: [f64; 2], positions: [DVec2; 2], velocities: [DVec2; 2]) -> Option<Self> {
        let total = masses[0] + masses[1];
        let mu = g_constant * total;
        let centre = (masses[0] * positions[0] + masses[1] * positions[1]) / total;
        let centre_velocity = (masses[0] * velocities[0] + masses[1] * velocities[1]) / total;
        let r0 = positions[1] - positions[0];
        let v0 = velocities[1] - velocities[0];
        let r = r0.length();
        let inverse_a = 2.0 / r - v0.length_squared() / mu;
        if !(mu > 0.0 && inverse_a > 0.0) {
            return None;
        }
        let a = 1.0 / inverse_a;
        let e_vector = ((v0.length_squared() - mu / r) * r0 - r0.dot(v0) * v0) / mu;
        let mean_motion = (mu / (a * a * a)).sqrt();
        Some(TwoBody {
            g_constant,
            masses,
            mu,
            centre,
            centre_velocity,
            r0,
            v0,
            a,
            e: e_vector.length(),
            mean_motion,
            period: std::f64::consts::TAU / mean_motion,
        })
    }

    /// Relative position and velocity `(x₂ − x₁, v₂ − v₁)` at time t.
    pub fn relative_at(&self, t: f64) -> (DVec2, DVec2) {
        let (a, mu) = (self.a, self.mu);
        let r0 = self.r0.length();
        let sigma0 = self.r0.dot(self.v0) / mu.sqrt();
        // Whole periods change nothing: solve over the remainder only.
        let tau = t - (t / self.period).floor() * self.period;
        let mean = self.mean_motion * tau;
        // Kepler's equation for ΔE = E − E₀:  n·τ = ΔE − (1 − r₀/a)·sin ΔE + (σ₀/√a)·(1 − cos ΔE),
        // where e·cos E₀ = 1 − r₀/a and e·sin E₀ = σ₀/√a. The derivative is r/a > 0.
        let (c1, c2) = (1.0 - r0 / a, sigma0 / a.sqrt());
        let de = solve_monotone(mean, 2.0 * self.e, |x| {
            (x - c1 * x.sin() + c2 * (1.0 - x.cos()) - mean, 1.0 - c1 * x.cos() + c2 * x.sin())
        });
        let (s, c) = de.sin_cos();
        let r = a + (r0 - a) * c + sigma0 * a.sqrt() * s;
        let f = 1.0 - a / r0 * (1.0 - c);
        let g = tau - (de - s) / self.mean_motion;
        let f_dot = -(mu * a).sqrt() * s / (r * r0);
        let g_dot = 1.0 - a / r * (1.0 - c);
        (f * self.r0 + g * self.v0, f_dot * self.r0 + g_dot * self.v0)
    }

    /// Positions of the two balls at time t.
    pub fn positions_at(&self, t: f64) -> [DVec2; 2] {
        let (r, _) = self.relative_at(t);
        let total = self.masses[0] + self.masses[1];
        let centre = self.centre + self.centre_velocity * t;
        [centre - r * (self.masses[1] / total), centre + r * (self.masses[0] / total)]
    }

    /// Total energy (kinetic + potential), constant along the exact orbit, J.
    pub fn energy(&self) -> f64 {
        let total = self.masses[0] + self.masses[1];
        let reduced = self.masses[0] * self.masses[1] / total;
        0.5 * total * self.centre_velocity.length_squared() + 0.5 * reduced * self.v0.length_squared()
            - self.g_constant * self.masses[0] * self.masses[1] / self.r0.length()
    }
}

/// A ball released from rest under gravity g (magnitude) and quadratic drag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DragFall {
    /// Magnitude of the gravitational acceleration, m/s² (positive, pointing down).
    pub g: f64,
    /// Terminal speed `sqrt(2·m·g/(ρ·C_d·A))`, m/s.
    pub terminal_speed: f64,
}

impl DragFall {
    /// The fall of a ball of `mass` (kg) and `diameter` (m) under gravity `g` (m/s², magnitude)
    /// in air of density `rho` (kg/m³) with drag coefficient `cd`.
    pub fn new(mass: f64, diameter: f64, g: f64, rho: f64, cd: f64) -> Self {
        DragFall { g, terminal_speed: quadratic_terminal_speed(mass, diameter, g, rho, cd) }
    }

    /// Speed at time t: `v_t·tanh(g·t/v_t)`.
    pub fn speed(&self, t: f64) -> f64 {
        self.terminal_speed * (self.g * t / self.terminal_speed).tanh()
    }

    /// Distance fallen by time t: `(v_t²/g)·ln cosh(g·t/v_t)`, written so that it neither
    /// overflows nor loses digits (ln cosh x = x + ln(1 + e^{−2x}) − ln 2).
    pub fn fallen(&self, t: f64) -> f64 {
        let vt = self.terminal_speed;
        let x = self.g * t / vt;
        let ln_cosh = x + (-2.0 * x).exp().ln_1p() - std::f64::consts::LN_2;
        vt * vt / self.g * ln_cosh
    }
}

/// Position at time t of a ball thrown from `x0` at `v0` under uniform acceleration `g`.
pub fn projectile(x0: DVec2, v0: DVec2, g: DVec2, t: f64) -> DVec2 {
    x0 + v0 * t + 0.5 * g * t * t
}

/// Two free balls (uniform gravity at most, the same for both) that meet once and bounce with
/// restitution e: the exact positions at any time.
///
/// Uniform gravity accelerates both balls alike, so their relative motion is a straight line and
/// the moment of contact is the first root of `|Δx₀ + Δv·t| = r₁ + r₂`. At that moment the
/// impulse `J = −(1+e)·v_rel / (1/m₁ + 1/m₂)` acts along the line of centres; before and after,
/// each ball flies on its parabola.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collision {
    /// The uniform acceleration both balls share, m/s² (zero without gravity).
    pub g: DVec2,
    /// Time of contact, s.
    pub contact_time: f64,
    /// Positions and velocities at t = 0.
    pub start: [(DVec2, DVec2); 2],
    /// Positions and velocities just after the contact.
    pub after: [(DVec2, DVec2); 2],
}

impl Collision {
    /// `None` if the balls never touch.
    pub fn new(
        g: DVec2,
        restitution: f64,
        masses: [f64; 2],
        radii: [f64; 2],
        positions: [DVec2; 2],
        velocities: [DVec2; 2],
    ) -> Option<Self> {
        let reach = radii[0] + radii[1];
        let dx = positions[1] - positions[0];
        let dv = velocities[1] - velocities[0];
        // |dx + dv·t|² = reach²: a·t² + 2·b·t + c = 0.
        let (a, b, c) = (dv.length_squared(), dx.dot(dv), dx.length_squared() - reach * reach);
        let discriminant = b * b - a * c;
        if !(a > 0.0 && b < 0.0 && c > 0.0 && discriminant >= 0.0) {
            return None;
        }
        // The smaller root, in the form that does not cancel: t = c / (−b + √D).
        let contact_time = c / (-b + discriminant.sqrt());
        let at =
            |k: usize| (projectile(positions[k], velocities[k], g, contact_time), velocities[k] + g * contact_time);
        let (pa, va) = at(0);
        let (pb, vb) = at(1);
        let n = (pb - pa) / reach;
        let v_rel = (vb - va).dot(n);
        let j = -(1.0 + restitution) * v_rel / (1.0 / masses[0] + 1.0 / masses[1]);
        Some(Collision {
            g,
            contact_time,
            start: [(positions[0], velocities[0]), (positions[1], velocities[1])],
            after: [(pa, va - n * (j / masses[0])), (pb, vb + n * (j / masses[1]))],
        })
    }

    /// Positions of the two balls at time t.
    pub fn positions_at(&self, t: f64) -> [DVec2; 2] {
        let at = |k: usize| {
            if t <= self.contact_time {
                projectile(self.start[k].0, self.start[k].1, self.g, t)
            } else {
                projectile(self.after[k].0, self.after[k].1, self.g, t - self.contact_time)
            }
        };
        [at(0), at(1)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kepler_equation_is_solved_to_rounding() {
        for e in [0.0, 0.1, 0.5, 0.9, 0.99] {
            for k in 0..100 {
                let m = -7.0 + 0.14 * k as f64;
                let big_e = solve_kepler(m, e);
                assert!((big_e - e * big_e.sin() - m).abs() < 1e-14, "e {e} M {m}");
            }
        }
    }

    #[test]
    fn circular_orbit_turns_a_quarter_in_a_quarter_period() {
        let mu: f64 = 4.0;
        let v = (mu / 2.0).sqrt();
        let o = TwoBody::new(1.0, [3.0, 1.0], [DVec2::ZERO, DVec2::new(2.0, 0.0)], [DVec2::ZERO, DVec2::new(0.0, v)])
            .unwrap();
        assert!(o.e < 1e-15 && (o.a - 2.0).abs() < 1e-14);
        let (r, _) = o.relative_at(0.25 * o.period);
        assert!(r.distance(DVec2::new(0.0, 2.0)) < 1e-14, "{r}");
        let (r, _) = o.relative_at(o.period * 37.0);
        assert!(r.distance(DVec2::new(2.0, 0.0)) < 1e-12, "{r}");
    }

    #[test]
    fn eccentric_orbit_keeps_energy_and_angular_momentum_and_reaches_apoapsis() {
        let (mu, a, e): (f64, f64, f64) = (2.0, 3.0, 0.6);
        let rp = a * (1.0 - e);
        let vp = (mu * (1.0 + e) / rp).sqrt();
        let o = TwoBody::new(1.0, [1.5, 0.5], [DVec2::ZERO, DVec2::new(rp, 0.0)], [DVec2::ZERO, DVec2::new(0.0, vp)])
            .unwrap();
        assert!((o.a - a).abs() < 1e-13 && (o.e - e).abs() < 1e-13);
        let (r, _) = o.relative_at(0.5 * o.period);
        assert!(r.distance(DVec2::new(-a * (1.0 + e), 0.0)) < 1e-12, "{r}");
        for k in 0..50 {
            let (r, v) = o.relative_at(0.37 * k as f64);
            let energy = 0.5 * v.length_squared() - mu / r.length();
            assert!((energy + mu / (2.0 * a)).abs() < 1e-13);
            assert!((r.perp_dot(v) - rp * vp).abs() < 1e-12);
        }
    }

    #[test]
    fn drag_fall_starts_as_free_fall_and_ends_at_terminal_speed() {
        let d = DragFall::new(1.0, 0.5, 9.81, 1.225, 0.47);
        let t = 1e-3;
        assert!((d.fallen(t) - 0.5 * 9.81 * t * t).abs() < 1e-12);
        assert!((d.speed(100.0) - d.terminal_speed).abs() < 1e-12);
        assert!(d.fallen(1e4).is_finite());
    }

    #[test]
    fn head_on_collision_swaps_velocities_of_equal_masses() {
        let c = Collision::new(
            DVec2::ZERO,
            1.0,
            [1.0, 1.0],
            [0.5, 0.5],
            [DVec2::ZERO, DVec2::new(5.0, 0.0)],
            [DVec2::new(1.0, 0.0), DVec2::new(-1.0, 0.0)],
        )
        .unwrap();
        assert!((c.contact_time - 2.0).abs() < 1e-15);
        let [a, b] = c.positions_at(3.0);
        assert!(a.distance(DVec2::new(1.0, 0.0)) < 1e-14 && b.distance(DVec2::new(4.0, 0.0)) < 1e-14);
    }
}
