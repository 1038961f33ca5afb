//! The step policy: how long the next sub-step of a span of time may be, and the guard rails for
//! fields faster than the shortest sub-step resolves. Both engines judge their sub-steps here and
//! nowhere else — lockstep before every sub-step of its fixed step, a ball thread once for each
//! measured cycle — so a fix to the policy reaches both at once.
//!
//! The engines measure the rates (each from the data it has: lockstep from the speeds its last
//! pass left, a ball thread from its own state and the other balls' pull); the policy turns
//! them into a sub-step:
//!
//! - **travel** — with collisions on, no ball moves more than [`MAX_TRAVEL`] radii per sub-step,
//!   so two approaching balls never jump past each other between two contact checks;
//! - **drag** — `drag_rate·h ≤` [`MAX_DRAG_STEP`]: a light, large ball at high speed is a stiff
//!   problem, whose explicit stages would overshoot through zero and blow up;
//! - **orbit** — `ω·h ≤` [`MAX_ORBIT_STEP`] for the fastest attracting pair;
//! - **longest step** — at most `max_step` (a ball thread's measured dt after a stall);
//! - **floor** — no sub-step is shorter than `dt /` [`MAX_SUBSTEPS`], so a step takes at most
//!   that many (+1 for a rounding crumb), and never ends on one long remainder: capping the
//!   *count* instead left a field that wanted more than the cap all the way through with a last
//!   sub-step of a third of dt, and it blew up (found by tests/fuzz.rs).
//!
//! Where even the floor cannot resolve the dynamics, two guard rails keep the state finite: the
//! drag rate is capped at `1/h` ([`SubSteps::drag_rate_limit`], applied by
//! [`crate::physics::Forces::set_drag_rate_limit`]), and speeds at [`MAX_SPEED`] ([`cap_speed`]).
//! Both are counted by the engines, and no scene a person plays meets either.

use glam::DVec2;

use super::effects::{MAX_DRAG_STEP, MAX_ORBIT_STEP};

/// Largest distance a ball may travel in one (sub-)step with collisions on, in radii.
pub const MAX_TRAVEL: f64 = 0.5;

/// Most sub-steps one step is split into: the floor of a sub-step is `dt / MAX_SUBSTEPS`.
pub const MAX_SUBSTEPS: u32 = 4096;

/// Fastest a ball may move, m/s: a guard rail, not physics. A field whose dynamics are faster
/// than even [`MAX_SUBSTEPS`] sub-steps resolve (a 1 g ball of 2 m thrown into stiff drag, a
/// pair of 1e6 kg grains orbiting at 1e7 rad/s with G = 1) can still run away under an explicit
/// integrator; its speeds are then capped here (and counted by the engine) so the state stays
/// finite. No scene a person plays comes near it (the hard cases top out at 2,000 m/s), and a
/// run that hits it says so in its report.
pub const MAX_SPEED: f64 = 1e5;

/// Caps a speed at [`MAX_SPEED`] (a guard rail for fields faster than the sub-steps can resolve;
/// see there). A NaN fails the first test too, and becomes zero rather than spreading. Returns
/// whether it capped.
#[inline]
pub fn cap_speed(v: &mut DVec2) -> bool {
    let speed2 = v.length_squared();
    if speed2.is_nan() || speed2 > MAX_SPEED * MAX_SPEED {
        *v = if speed2.is_finite() { *v * (MAX_SPEED / speed2.sqrt()) } else { DVec2::ZERO };
        true
    } else {
        false
    }
}

/// The rates a span is judged by, 1/s, each the largest the engine measured over its balls at the
/// span's start (0 for an effect that is off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpanRates {
    /// `|v|/r`, with collisions on: how many radii a ball covers per second.
    pub travel: f64,
    /// The drag rate (see [`crate::physics::drag_rate`]), at the speed the ball has now or at the
    /// terminal speed its other forces drive it to, whichever is larger (see
    /// [`crate::physics::drag_rate_bound`]): a step judged by the rate now alone can start
    /// resolved and end stiff.
    pub drag: f64,
    /// The fastest orbit rate ω of an attracting pair (the square root of
    /// [`crate::physics::attraction_rate_squared`]).
    pub orbit: f64,
}

/// The policy's answer for a span: `count` sub-steps of `h` cover it (the last one of a re-judged
/// span is exactly what is left: see [`StepPolicy::split`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubSteps {
    /// Sub-steps the span needs, 1 to [`MAX_SUBSTEPS`].
    pub count: u32,
    /// Length of each, s: `span / count`, but never below the floor nor above the span.
    pub h: f64,
    /// The drag guard rail: `1/h` when the drag rate is too stiff even for `h` (only ever at the
    /// floor), `+∞` otherwise. For [`crate::physics::Forces::set_drag_rate_limit`].
    pub drag_rate_limit: f64,
}

impl SubSteps {
    /// Whether the drag guard rail is on for these sub-steps (the engines count them).
    #[inline]
    pub fn drag_limited(&self) -> bool {
        self.drag_rate_limit.is_finite()
    }
}

/// The sub-step policy for one step of `dt` (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepPolicy {
    /// The floor, `dt / MAX_SUBSTEPS`.
    shortest: f64,
    /// Longest sub-step, s (`+∞`: no limit but the step's own length).
    max_step: f64,
}

impl StepPolicy {
    /// The policy for a step of `dt` seconds, with no longest sub-step but the step itself.
    #[inline]
    pub fn new(dt: f64) -> Self {
        StepPolicy { shortest: dt / MAX_SUBSTEPS as f64, max_step: f64::INFINITY }
    }

    /// The same, with no sub-step longer than `max_step` seconds.
    #[inline]
    pub fn with_max_step(self, max_step: f64) -> Self {
        StepPolicy { max_step, ..self }
    }

    /// The floor: no sub-step of this step is shorter (but the step's last crumb).
    #[inline]
    pub fn shortest(&self) -> f64 {
        self.shortest
    }

    /// How to split the next `span` seconds of the step, given the `rates` at its start.
    ///
    /// An engine may take all `count` sub-steps of `h` (a ball thread, whose rates are frozen for
    /// its cycle), or take one and ask again for what is left (lockstep, which re-judges before
    /// every sub-step: a collision in the middle of a step can make a ball fast, or drag on a light
    /// ball stiff, at once). With `count == 1`, `h` is exactly `span`, so that re-judging ends on
    /// exactly zero left. Rates that are NaN are ignored (a NaN never wins a `max`); the count
    /// and `h` are always finite for a finite span.
    #[inline]
    pub fn split(&self, span: f64, rates: &SpanRates) -> SubSteps {
        let need = 1.0f64
            .max(span / self.max_step)
            .max(rates.travel * span / MAX_TRAVEL)
            .max(rates.drag * span / MAX_DRAG_STEP)
            .max(rates.orbit * span / MAX_ORBIT_STEP);
        // `as u32` saturates (+∞ becomes u32::MAX), so a huge need is capped, never wrapped.
        let count = if need <= 1.0 { 1 } else { (need.ceil() as u32).min(MAX_SUBSTEPS) };
        let h = if count == 1 { span } else { (span / count as f64).max(self.shortest).min(span) };
        // Drag that the shortest sub-step still cannot resolve gets its guard rail.
        let drag_rate_limit = if rates.drag * h > MAX_DRAG_STEP { 1.0 / h } else { f64::INFINITY };
        SubSteps { count, h, drag_rate_limit }
    }
}

#[cfg(test)]
mod tests {
    //! Each test names, in its comment, the deliberately broken policy it was seen to fail on.

    use super::*;

    /// A split judged by one rate alone.
    fn rates(travel: f64, drag: f64, orbit: f64) -> SpanRates {
        SpanRates { travel, drag, orbit }
    }

    /// Nothing fast: one sub-step, exactly the span, no guard rail. (Fails with the floor applied
    /// to a single sub-step too, `h = (span / count).max(shortest)`: a span shorter than the floor
    /// then overshoots.)
    #[test]
    fn a_calm_span_is_one_sub_step_of_exactly_the_span() {
        let policy = StepPolicy::new(0.001);
        for span in [0.001, 0.000_3, 1e-9] {
            let sub = policy.split(span, &rates(1.0, 1.0, 1.0));
            assert_eq!(sub, SubSteps { count: 1, h: span, drag_rate_limit: f64::INFINITY });
            assert!(!sub.drag_limited());
        }
    }

    /// Each criterion splits by its own bound, into the fewest sub-steps that keep to it:
    /// rate·h ≤ bound (measured: never over, to the last bit, in this sweep), and one sub-step
    /// fewer would not. (Fails with the travel term left out of the need, with the orbit judged by
    /// MAX_DRAG_STEP, and with the count rounded down instead of up.)
    #[test]
    fn each_rate_is_resolved_by_the_fewest_sub_steps() {
        let dt = 0.01;
        let policy = StepPolicy::new(dt);
        for (which, bound) in [(0, MAX_TRAVEL), (1, MAX_DRAG_STEP), (2, MAX_ORBIT_STEP)] {
            for k in 1..2000 {
                let rate = 3.7 * k as f64;
                let mut r = [0.0; 3];
                r[which] = rate;
                let sub = policy.split(dt, &rates(r[0], r[1], r[2]));
                assert!(sub.count < MAX_SUBSTEPS, "rate {rate} needs no floor");
                assert!(rate * sub.h <= bound, "criterion {which}, rate {rate}: {sub:?}");
                if sub.count > 1 {
                    let fewer = dt / (sub.count - 1) as f64;
                    assert!(rate * fewer > bound, "criterion {which}, rate {rate}: {} would do", sub.count - 1);
                }
            }
        }
        // 1,000 radii a second for 10 ms: 20 sub-steps of half a radius.
        let sub = policy.split(dt, &rates(1000.0, 0.0, 0.0));
        assert_eq!(sub.count, 20);
        assert_eq!(sub.h, dt / 20.0);
    }

    /// A ball thread's longest step: a cycle four times as long is four sub-steps; lockstep has no
    /// such bound. (Fails with the `span / max_step` term left out.)
    #[test]
    fn the_longest_step_splits_a_long_cycle() {
        // 2⁻⁷ s at most 2⁻⁹ s a sub-step (binary fractions, so the division is exact).
        let (cycle, longest) = (0.007_812_5, 0.001_953_125);
        let sub = StepPolicy::new(cycle).with_max_step(longest).split(cycle, &SpanRates::default());
        assert_eq!((sub.count, sub.h), (4, longest));
        assert_eq!(StepPolicy::new(cycle).split(cycle, &SpanRates::default()).count, 1);
    }

    /// No sub-step is shorter than dt / MAX_SUBSTEPS, however stiff the field and however little of
    /// the step is left — but for the last crumb, which is exactly what is left. (Fails with the
    /// floor left out, `h = span / count`; and with the count not capped at MAX_SUBSTEPS.)
    #[test]
    fn no_sub_step_is_shorter_than_the_floor() {
        let dt = 1.0;
        let policy = StepPolicy::new(dt);
        assert_eq!(policy.shortest(), dt / 4096.0);
        let stiff = rates(1e12, 1e12, 1e12);
        let sub = policy.split(dt, &stiff);
        assert_eq!((sub.count, sub.h), (MAX_SUBSTEPS, dt / 4096.0));
        // A quarter of the step left: still the step's floor, not a quarter of it.
        assert_eq!(policy.split(0.25, &stiff).h, dt / 4096.0);
        // A crumb shorter than the floor is taken whole.
        let crumb = 0.1 / 4096.0;
        assert_eq!(policy.split(crumb, &stiff).h, crumb);
    }

    /// Lockstep's loop, re-judged before every sub-step: it ends on exactly zero left, in at most
    /// MAX_SUBSTEPS + 1 sub-steps, whatever the rates. (Fails with `.min(span)` left out: the
    /// last sub-step at the floor then overshoots the step.)
    #[test]
    fn a_re_judged_step_ends_on_exactly_zero_left() {
        for dt in [0.001, 1.0 / 3.0, 0.017] {
            let policy = StepPolicy::new(dt);
            for rate in [0.0, 10.0, 123.456, 3e4, 7.77e5, 1e9, f64::INFINITY] {
                let (mut remaining, mut taken) = (dt, 0u32);
                while remaining > 0.0 {
                    let sub = policy.split(remaining, &rates(rate, 0.0, 0.0));
                    assert!(sub.h > 0.0 && sub.h <= remaining, "dt {dt}, rate {rate}: {sub:?}");
                    remaining -= sub.h;
                    taken += 1;
                }
                assert_eq!(remaining, 0.0, "dt {dt}, rate {rate}");
                assert!(taken <= MAX_SUBSTEPS + 1, "dt {dt}, rate {rate}: {taken} sub-steps");
            }
        }
    }

    /// The drag guard rail switches on exactly when drag_rate·h > MAX_DRAG_STEP, which only the
    /// floor can leave: with dt = 4,096 s the floor is 1 s, so a rate of MAX_DRAG_STEP is just
    /// resolved and the next float up is not. (Fails with `>=` for `>`, and with the rail judged
    /// at the span instead of at h.)
    #[test]
    fn the_drag_rail_switches_on_exactly_past_the_bound() {
        let policy = StepPolicy::new(4096.0);
        let at = policy.split(4096.0, &rates(0.0, MAX_DRAG_STEP, 0.0));
        assert_eq!((at.count, at.h, at.drag_rate_limit), (MAX_SUBSTEPS, 1.0, f64::INFINITY));
        let past = policy.split(4096.0, &rates(0.0, MAX_DRAG_STEP.next_up(), 0.0));
        assert_eq!((past.count, past.h, past.drag_rate_limit), (MAX_SUBSTEPS, 1.0, 1.0));
        assert!(past.drag_limited());
        // Stiffer still: the rate is capped at 1/h, h the floor.
        let stiffer = policy.split(4096.0, &rates(0.0, 1e6, 0.0));
        assert_eq!(stiffer.drag_rate_limit, 1.0);
        // Orbits and travel beyond the floor do not switch the drag rail on.
        assert!(!policy.split(4096.0, &rates(1e6, 0.0, 1e6)).drag_limited());
    }

    /// Bad rates never panic nor give a bad sub-step: a NaN is ignored, +∞ goes to the floor, a
    /// negative rate counts as none. (Fails with the maxima written `if need > x { need } else
    /// { x }`, under which a NaN wins and the count becomes 0.)
    #[test]
    fn bad_rates_give_a_finite_sub_step() {
        let policy = StepPolicy::new(0.001);
        let nan = policy.split(0.001, &rates(f64::NAN, f64::NAN, f64::NAN));
        assert_eq!(nan, SubSteps { count: 1, h: 0.001, drag_rate_limit: f64::INFINITY });
        let inf = policy.split(0.001, &rates(f64::INFINITY, f64::INFINITY, f64::INFINITY));
        assert_eq!((inf.count, inf.h), (MAX_SUBSTEPS, 0.001 / 4096.0));
        assert!(inf.drag_limited() && inf.drag_rate_limit.is_finite());
        let negative = policy.split(0.001, &rates(-1e9, -1e9, -1e9));
        assert_eq!(negative, SubSteps { count: 1, h: 0.001, drag_rate_limit: f64::INFINITY });
    }

    /// The speed rail: below MAX_SPEED nothing changes; above, the speed is MAX_SPEED in the same
    /// direction (measured: the speed exact, the direction within 1.1e-16); a NaN or infinite
    /// speed becomes zero. (Fails with the NaN test left out: a NaN then stays.)
    #[test]
    fn cap_speed_caps_and_zeroes_nan() {
        let mut slow = DVec2::new(3.0, -4.0);
        assert!(!cap_speed(&mut slow));
        assert_eq!(slow, DVec2::new(3.0, -4.0));
        let mut fast = DVec2::new(3e6, -4e6);
        assert!(cap_speed(&mut fast));
        assert!((fast.length() - MAX_SPEED).abs() <= MAX_SPEED * f64::EPSILON);
        assert!((fast.normalize() - DVec2::new(0.6, -0.8)).length() <= 1e-15);
        for bad in [DVec2::new(f64::NAN, 0.0), DVec2::new(f64::INFINITY, 1.0)] {
            let mut v = bad;
            assert!(cap_speed(&mut v));
            assert_eq!(v, DVec2::ZERO);
        }
    }
}
