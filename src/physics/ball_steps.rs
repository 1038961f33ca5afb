//! One ball's sub-steps over a stretch of time, for an engine that advances each ball by itself:
//! the threaded runtime's ball threads, and its monitor when it carries a ball over a span to
//! predict where the ball's thread takes it. Both call [`advance_ball`], so the prediction is the
//! thread's own arithmetic, and a fix to the loop is made once.
//!
//! Each sub-step is judged afresh by the step policy from the rates where the ball is: a stretch
//! can be long (a starved or stalled thread catches up in one), and on the way a ball can fall
//! into a stiffer drag or a heavier ball's pull than at the stretch's start. Sub-steps sized by
//! the start's rates let the explicit stages overshoot through zero and run away to NaN, and the
//! drag guard rail, judged at the start too, was never on. Judged at each sub-step, the split
//! follows the rate as it grows, down to the policy's floor, where the guard rail takes over.

use glam::DVec2;

use super::forces::{BallForces, OtherBalls};
use super::integrator::{Integrator, IntegratorScratch, integrate};
use super::step_policy::{SpanRates, StepPolicy, cap_speed};

/// What a stretch of one ball's sub-steps came to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BallSteps {
    /// Sub-steps taken.
    pub count: u32,
    /// Whether any of them had the drag guard rail on.
    pub drag_limited: bool,
    /// How many of them ended faster than [`crate::physics::MAX_SPEED`] (capped to it).
    pub speed_limited: u32,
}

/// Advances one ball at `(x, v)` by `dt` seconds under `forces`, in sub-steps that `policy` splits
/// from the rates `rates(x, v)` gives where the ball is before each (the policy holds the floor and
/// the engine's longest step; travel is the caller's to bound, or not). Each sub-step integrates
/// with `integrator` through the force passes under the guard rail its split asks for (a straight
/// drift when no force acts, as lockstep's integration takes it), then calls `after_each` (a
/// ball thread's walls), then applies the speed guard rail. Nothing happens for a `dt` that is
/// not positive (NaN included).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn advance_ball<O: OtherBalls + Copy>(
    integrator: Integrator,
    policy: &StepPolicy,
    dt: f64,
    forces: BallForces<'_, O>,
    mut rates: impl FnMut(DVec2, DVec2) -> SpanRates,
    (x, v): (&mut DVec2, &mut DVec2),
    scratch: &mut IntegratorScratch,
    mut after_each: impl FnMut(&mut DVec2, &mut DVec2),
) -> BallSteps {
    let mut steps = BallSteps::default();
    if dt.is_nan() || dt <= 0.0 {
        return steps;
    }
    let drift = forces.is_empty();
    let velocity_dependent = forces.depends_on_velocity();
    let mut left = dt;
    while left > 0.0 {
        // With one sub-step, `h` is exactly what is left, so `left` becomes exactly zero.
        let sub = policy.split(left, &rates(*x, *v));
        if drift {
            *x += *v * sub.h;
        } else {
            // Drag too stiff even for the policy's shortest sub-step gets the guard rail.
            let forces = forces.with_drag_rate_limit(sub.drag_rate_limit);
            steps.drag_limited |= sub.drag_limited();
            let (mut xs, mut vs) = ([*x], [*v]);
            integrate(integrator, sub.h, &mut xs, &mut vs, velocity_dependent, scratch, |x, v, a| {
                a[0] = forces.acceleration(x[0], v[0]);
            });
            (*x, *v) = (xs[0], vs[0]);
        }
        after_each(x, v);
        // The speed guard rail, for fields faster than the shortest sub-step resolves.
        if cap_speed(v) {
            steps.speed_limited += 1;
        }
        left -= sub.h;
        steps.count += 1;
    }
    steps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{BallProps, Drag, Effects, Forces, Gravity, MAX_SPEED, NoOtherBalls};

    fn props() -> BallProps {
        BallProps { mass: 2.0, inverse_mass: 0.5, diameter: 1.0 }
    }

    #[test]
    fn a_stretch_under_gravity_alone_is_the_integrators_steps() {
        let g = DVec2::new(0.0, -9.81);
        let forces = Forces::new(&Effects { gravity: Some(Gravity { g }), ..Effects::default() });
        let (mut x, mut v) = (DVec2::new(1.0, 2.0), DVec2::new(3.0, 0.0));
        let policy = StepPolicy::new(0.01).with_max_step(0.004);
        let steps = advance_ball(
            Integrator::SemiImplicitEuler,
            &policy,
            0.01,
            forces.on_ball(props(), DVec2::ZERO, NoOtherBalls),
            |_, _| SpanRates::default(),
            (&mut x, &mut v),
            &mut IntegratorScratch::default(),
            |_, _| {},
        );
        // 0.01 s in steps of at most 4 ms: three equal sub-steps, each v += g·h, x += v·h.
        assert_eq!(steps, BallSteps { count: 3, drag_limited: false, speed_limited: 0 });
        let (mut xe, mut ve) = (DVec2::new(1.0, 2.0), DVec2::new(3.0, 0.0));
        let mut left = 0.01;
        for _ in 0..3 {
            let h = policy.split(left, &SpanRates::default()).h;
            ve += g * h;
            xe += ve * h;
            left -= h;
        }
        assert_eq!((x, v), (xe, ve));
    }

    /// One stretch of a ball under no force, leapfrog, from `(x, v)`.
    fn drift(x: DVec2, v: DVec2) -> (DVec2, DVec2, BallSteps) {
        let forces = Forces::new(&Effects::default());
        let (mut x, mut v) = (x, v);
        let steps = advance_ball(
            Integrator::Leapfrog,
            &StepPolicy::new(1e-3),
            1e-3,
            forces.on_ball(props(), DVec2::ZERO, NoOtherBalls),
            |_, _| SpanRates::default(),
            (&mut x, &mut v),
            &mut IntegratorScratch::default(),
            |_, _| {},
        );
        (x, v, steps)
    }

    #[test]
    fn no_force_is_a_straight_drift() {
        // One drift x += v·h, as lockstep takes it; leapfrog's two half drifts round otherwise
        // here (…294 instead of …295 in the last digits).
        let (x0, v0) = (DVec2::new(6.718212205620061, 0.0), DVec2::new(20.846024216233957, 0.0));
        let (x, v, steps) = drift(x0, v0);
        assert_eq!(steps, BallSteps { count: 1, drag_limited: false, speed_limited: 0 });
        assert_eq!((x, v), (x0 + v0 * 1e-3, v0));
    }

    #[test]
    fn the_speed_rail_caps_and_counts() {
        let (_, v, steps) = drift(DVec2::ZERO, DVec2::new(2.0 * MAX_SPEED, 0.0));
        assert_eq!(steps.speed_limited, 1);
        assert_eq!(v.length(), MAX_SPEED);
    }

    #[test]
    fn stiff_drag_splits_each_sub_step_and_never_runs_away() {
        let drag = Drag::Quadratic { rho: 1.225, cd: 0.47 };
        let forces = Forces::new(&Effects { drag: Some(drag), ..Effects::default() });
        // A light, large ball at speed: its drag rate is far above what 1 ms resolves.
        let light = BallProps { mass: 1.6e-3, inverse_mass: 1.0 / 1.6e-3, diameter: 2.2 };
        let ball = forces.on_ball(light, DVec2::ZERO, NoOtherBalls);
        let (mut x, mut v) = (DVec2::ZERO, DVec2::new(300.0, 0.0));
        let steps = advance_ball(
            Integrator::ExplicitEuler,
            &StepPolicy::new(1e-3),
            1e-3,
            ball,
            |x, v| SpanRates { drag: ball.drag_rate(x, v), ..SpanRates::default() },
            (&mut x, &mut v),
            &mut IntegratorScratch::default(),
            |_, _| {},
        );
        assert!(steps.count > 1, "{steps:?}");
        assert!(v.is_finite() && v.x > 0.0 && v.x < 300.0, "{v}");
        assert!(x.is_finite(), "{x}");
    }

    #[test]
    fn a_stretch_that_is_not_positive_takes_no_step() {
        let forces = Forces::new(&Effects::default());
        for dt in [0.0, -1.0, f64::NAN] {
            let (mut x, mut v) = (DVec2::ONE, DVec2::ONE);
            let steps = advance_ball(
                Integrator::Rk4,
                &StepPolicy::new(1e-3),
                dt,
                forces.on_ball(props(), DVec2::ZERO, NoOtherBalls),
                |_, _| SpanRates::default(),
                (&mut x, &mut v),
                &mut IntegratorScratch::default(),
                |_, _| {},
            );
            assert_eq!(steps.count, 0);
            assert_eq!((x, v), (DVec2::ONE, DVec2::ONE));
        }
    }
}
