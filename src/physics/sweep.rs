//! Swept motion over a span of time: the circle that holds a ball's whole path, for a broad phase
//! that must not miss a pair that touches only in mid-span (two fast balls that the free motion
//! took through each other). When in the span they touched is the contact solver's to find
//! (`contact_solver.rs`, `pair_contact`).
//!
//! Free motion is the motion under a uniform acceleration alone (gravity, a steady pull):
//! `x(t) = x + v·t + ½·a·t²`, a parabola.

use glam::DVec2;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_circle_holds_the_whole_parabola() {
        // Thrown at 3 m/s sideways and 4 m/s up under g = 10 for 0.8 s: every point of the path
        // lies within the circle grown by the ball's radius.
        let (x0, v0, a, span, r) = (DVec2::new(1.0, 2.0), DVec2::new(3.0, 4.0), DVec2::new(0.0, -10.0), 0.8, 0.25);
        let at = |t: f64| x0 + v0 * t + 0.5 * t * t * a;
        let (centre, reach) = swept_circle(x0, at(span), a, span, r);
        for k in 0..=1000 {
            let t = span * k as f64 / 1000.0;
            assert!(at(t).distance(centre) + r <= reach + 1e-12, "t = {t}");
        }
    }
}
