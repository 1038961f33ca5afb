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
