//! Swept motion over a span of time: where a ball in free motion goes, the circle that holds its
//! whole path (for a broad phase that must not miss a pair that touches only in mid-span), and
//! when in the span two balls, or a ball and a wall, first touched.
//!
//! Free motion is the motion under a uniform acceleration alone (gravity, a steady pull):
//! `x(t) = x + v·t + ½·a·t²`. Two balls under the same acceleration move relative to each other
//! in a straight line, so the instant they touch is a root of a quadratic; a ball meets a wall
//! along its parabola, a quadratic too. Both roots are taken in the stable form (no cancellation
//! between `b` and the square root of the discriminant).

// `!(x > 0.0)` on purpose: a NaN must take the "no impact" branch too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec2;

/// Where free motion from `position` and `velocity` under `acceleration` is after `t` seconds
/// (`t` may be negative: where it was), and its velocity there.
#[inline]
pub fn free_motion(position: DVec2, velocity: DVec2, acceleration: DVec2, t: f64) -> (DVec2, DVec2) {
    (position + velocity * t + 0.5 * t * t * acceleration, velocity + acceleration * t)
}

/// A circle holding the whole path of a ball of `radius` in free motion over a span of `span`
/// seconds that starts at `start` and ends at `end`, under `acceleration`: centred on the chord's
/// midpoint, grown by half the chord and by the parabola's largest distance from its chord
/// (`|a|·span²/8`). Two balls whose circles do not overlap cannot touch during the span. Returns
/// `(centre, radius)`.
#[inline]
pub fn swept_circle(start: DVec2, end: DVec2, acceleration: DVec2, span: f64, radius: f64) -> (DVec2, f64) {
    let centre = 0.5 * (start + end);
    (centre, radius + 0.5 * start.distance(end) + 0.125 * acceleration.length() * span * span)
}

/// When, in a span that has just ended, two balls moving at a constant relative velocity first
/// touched — the impact a check of the end state alone misses when they passed through each
/// other, or judges with the wrong normal when their centres crossed.
///
/// `d` is the relative position `x_b − x_a` at the end of the span, `u` the relative velocity
/// `v_b − v_a`, `reach` the sum of the radii. Returns `s` in `[0, span]`, how long before the end
/// they touched, if they were apart at the start of the span and touched in it; `None` if they
/// never touched in the span, or already touched at its start (an ongoing contact, not an
/// impact). At the instant returned they are approaching: it is where their path enters the
/// overlap.
#[inline]
pub fn impact_before_end(d: DVec2, u: DVec2, reach: f64, span: f64) -> Option<f64> {
    if !(span >= 0.0 && reach > 0.0) {
        return None;
    }
    // |d − u·s|² = reach²:  A·s² − 2·B·s + C = 0 with A = u·u, B = d·u, C = d·d − reach².
    let a = u.length_squared();
    let b = d.dot(u);
    let c = d.length_squared() - reach * reach;
    let apart_at_start = (d - u * span).length_squared() >= reach * reach;
    if !apart_at_start || !(a > 0.0) {
        return None;
    }
    let disc = b * b - a * c;
    if !(disc >= 0.0) {
        return None;
    }
    // The later root in s (the earlier instant) is where the path enters the overlap.
    let root = disc.sqrt();
    let s = if b > 0.0 { (b + root) / a } else { c / (b - root) };
    (s.is_finite() && (0.0..=span).contains(&s)).then_some(s)
}

/// When, in a span that has just ended, a ball's surface crossed a wall. `gap` is the signed
/// distance of the surface from the wall at the end (negative: past it), `speed` the velocity
/// along the wall's inward normal (negative: outwards), `acceleration` the normal component of
/// its uniform acceleration. Returns how long before the end it was at the wall, if it was inside
/// at the start of the span and crossed in it, moving out; `None` otherwise.
#[inline]
pub fn wall_impact_before_end(gap: f64, speed: f64, acceleration: f64, span: f64) -> Option<f64> {
    if !(gap < 0.0 && span >= 0.0) {
        return None;
    }
    // Rewound along the parabola: gap(−τ) = gap − speed·τ + ½·α·τ² = 0, smallest τ > 0.
    let (a, b, c) = (0.5 * acceleration, -speed, gap);
    let tau = if a == 0.0 {
        -c / b
    } else {
        let disc = b * b - 4.0 * a * c;
        if !(disc >= 0.0) {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let (t1, t2) = (q / a, c / q);
        let (lo, hi) = (t1.min(t2), t1.max(t2));
        if lo > 0.0 { lo } else { hi }
    };
    // Moving out at that instant: its normal velocity then was speed − α·τ.
    (tau.is_finite() && tau > 0.0 && tau <= span && speed - acceleration * tau < 0.0).then_some(tau)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_head_on_pass_through_is_found_with_its_instant() {
        // b went from 3 m right of a to 3 m left of it in 1 s at 6 m/s: they touched (reach 1)
        // when 2 m apart, 1/3 s after the start, so 2/3 s before the end.
        let s = impact_before_end(DVec2::new(-3.0, 0.0), DVec2::new(-6.0, 0.0), 1.0, 1.0).unwrap();
        assert!((s - 2.0 / 3.0).abs() < 1e-15, "{s}");
        // Apart at the start, still apart at the end, never within reach: none.
        assert_eq!(impact_before_end(DVec2::new(-3.0, 2.0), DVec2::new(-6.0, 0.0), 1.0, 1.0), None);
        // Overlapping at the start: an ongoing contact, not an impact.
        assert_eq!(impact_before_end(DVec2::new(0.5, 0.0), DVec2::new(0.1, 0.0), 1.0, 1.0), None);
        // Receding: none.
        assert_eq!(impact_before_end(DVec2::new(3.0, 0.0), DVec2::new(1.0, 0.0), 1.0, 1.0), None);
    }

    #[test]
    fn a_wall_crossing_is_rewound_along_the_parabola() {
        // Falling from 0.1 m above the floor at 1 m/s under g = 10 for 0.1 s: at the floor when
        // 0.1 = t + 5 t², t = (−1 + √3)/10; the end is 0.1 s after the start.
        let (t, span) = ((3f64.sqrt() - 1.0) / 10.0, 0.1);
        let gap = 0.1 - span - 5.0 * span * span;
        let speed = -1.0 - 10.0 * span;
        let tau = wall_impact_before_end(gap, speed, -10.0, span).unwrap();
        assert!((tau - (span - t)).abs() < 1e-15, "{tau}");
        assert_eq!(wall_impact_before_end(0.01, speed, -10.0, span), None);
    }
}
