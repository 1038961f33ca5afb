//! Diagnostics: energies, momentum, overlap. Read-only measurements of a state.

use glam::DVec2;
use serde::{Deserialize, Serialize};

use super::bodies::Bodies;
use super::broad_phase::BroadPhase;
use super::effects::{Effects, attraction_potential, gravity_potential};
use super::field::{Field, WallImpulses};

/// Everything the report says about one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Σ ½·m·|v|², J.
    pub kinetic: f64,
    /// Potential energy in uniform gravity (zero at the field's floor line y = 0), J.
    pub potential_gravity: f64,
    /// Potential energy of mutual attraction (zero at infinite separation), J.
    pub potential_attraction: f64,
    /// Sum of the potentials of the active fields, J.
    pub potential: f64,
    /// Kinetic + potential, J.
    pub total: f64,
    /// Σ m·v, kg·m/s.
    pub momentum: [f64; 2],
    /// Largest overlap between two balls, m.
    pub largest_overlap: f64,
    /// Largest overlap between two balls as a fraction of the smaller diameter of the pair (in a
    /// field of mixed sizes, not always the pair of [`Diagnostics::largest_overlap`]).
    pub largest_overlap_ratio: f64,
    /// Impulse taken by each wall so far, N·s.
    pub wall_impulses: WallImpulses,
    /// Number of balls with a non-finite position or velocity.
    pub non_finite: usize,
    /// Number of balls not wholly inside the field (1 µm tolerance).
    pub outside: usize,
}

/// Total kinetic energy `Σ ½·m·|v|²`, J.
pub fn kinetic_energy(bodies: &Bodies) -> f64 {
    bodies.mass.iter().zip(&bodies.velocity).map(|(m, v)| 0.5 * m * v.length_squared()).sum()
}

/// Total momentum `Σ m·v`, kg·m/s.
pub fn momentum(bodies: &Bodies) -> DVec2 {
    bodies.mass.iter().zip(&bodies.velocity).map(|(m, v)| *m * *v).sum()
}

/// Potential energy in uniform gravity, `Σ −m·g·x`, J (zero at y = 0, the floor); 0 with
/// gravity off.
pub fn gravity_potential_energy(bodies: &Bodies, effects: &Effects) -> f64 {
    match &effects.gravity {
        Some(g) => bodies.mass.iter().zip(&bodies.position).map(|(m, p)| gravity_potential(*m, *p, g)).sum(),
        None => 0.0,
    }
}

/// O(n²): only for diagnostics, never in the step.
pub fn attraction_potential_energy(bodies: &Bodies, effects: &Effects) -> f64 {
    let Some(a) = &effects.attraction else { return 0.0 };
    let n = bodies.len();
    let mut sum = 0.0;
    for i in 0..n {
        for j in (i + 1)..n {
            sum += attraction_potential(
                bodies.position[i],
                bodies.mass[i],
                bodies.radius[i],
                bodies.position[j],
                bodies.mass[j],
                bodies.radius[j],
                a,
            );
        }
    }
    sum
}

/// Largest overlap (m) over all pairs, and the largest overlap as a fraction of the pair's
/// smaller diameter (each its own pair: two small balls may overlap less in metres and more in
/// proportion than two large ones).
pub fn largest_overlap(bodies: &Bodies, field: &Field, scratch: &mut BroadPhase) -> (f64, f64) {
    scratch.update(&bodies.position, &bodies.radius, field.width, field.height);
    let (mut metres, mut ratio) = (0.0f64, 0.0f64);
    scratch.for_each_touching_pair(|i, j| {
        let reach = bodies.radius[i] + bodies.radius[j];
        let overlap = reach - bodies.position[i].distance(bodies.position[j]);
        if overlap > 0.0 {
            metres = metres.max(overlap);
            ratio = ratio.max(overlap / bodies.diameter[i].min(bodies.diameter[j]));
        }
    });
    (metres, ratio)
}

/// Measures a state.
pub fn measure(bodies: &Bodies, field: &Field, effects: &Effects, wall_impulses: WallImpulses) -> Diagnostics {
    let kinetic = kinetic_energy(bodies);
    let potential_gravity = gravity_potential_energy(bodies, effects);
    let potential_attraction = attraction_potential_energy(bodies, effects);
    let potential = potential_gravity + potential_attraction;
    let p = momentum(bodies);
    let (largest_overlap, largest_overlap_ratio) = largest_overlap(bodies, field, &mut BroadPhase::new());
    let non_finite =
        (0..bodies.len()).filter(|&i| !(bodies.position[i].is_finite() && bodies.velocity[i].is_finite())).count();
    let outside = (0..bodies.len())
        .filter(|&i| !field.contains(bodies.position[i].x, bodies.position[i].y, bodies.radius[i], 1e-6))
        .count();
    Diagnostics {
        kinetic,
        potential_gravity,
        potential_attraction,
        potential,
        total: kinetic + potential,
        momentum: [p.x, p.y],
        largest_overlap,
        largest_overlap_ratio,
        wall_impulses,
        non_finite,
        outside,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{Ball, BallId, BallKind};

    fn ball(id: u32, x: f64, y: f64, diameter: f64) -> Ball {
        Ball {
            id: BallId(id),
            kind: BallKind::Ball,
            position: DVec2::new(x, y),
            velocity: DVec2::ZERO,
            mass: 1.0,
            diameter,
        }
    }

    /// Two 10 m balls 1 cm into each other (0.1 % of a diameter) and two 0.1 m balls 5 mm into
    /// each other (5 %): the largest overlap is the big pair's in metres and the small pair's in
    /// proportion. (Taken as the ratio of the pair deepest in metres, it read 0.1 %.)
    #[test]
    fn the_largest_overlap_ratio_is_the_worst_pair_in_proportion() {
        let balls =
            [ball(0, 10.0, 10.0, 10.0), ball(1, 19.99, 10.0, 10.0), ball(2, 30.0, 1.0, 0.1), ball(3, 30.095, 1.0, 0.1)];
        let bodies = Bodies::from_balls(&balls);
        let field = Field { width: 40.0, height: 20.0, restitution: 1.0 };
        let (metres, ratio) = largest_overlap(&bodies, &field, &mut BroadPhase::new());
        assert!((metres - 0.01).abs() < 1e-12, "{metres}");
        assert!((ratio - 0.05).abs() < 1e-9, "{ratio}");
    }
}
