//! The per-step list of force passes built from the effects a scene turns on.
//!
//! An effect that is off is simply not in the list, so it costs nothing: no O(n²) attraction
//! loop when attraction is off, no square root for drag in vacuum.

use glam::DVec2;

use super::effects::{Attraction, Drag, Effects, attraction_force, drag_force};

/// Per-ball constants that forces need, as parallel slices indexed like the state.
#[derive(Clone, Copy, Debug)]
pub struct BodyProps<'a> {
    pub mass: &'a [f64],
    pub inverse_mass: &'a [f64],
    pub diameter: &'a [f64],
}

/// A force applied to one ball, e.g. the player's pull on the key ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointForce {
    pub index: usize,
    pub force: DVec2,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum ForcePass {
    /// Uniform acceleration g (independent of mass).
    Gravity(DVec2),
    Drag(Drag),
    Attraction(Attraction),
}

/// The force passes that run each step, in a fixed order (gravity, drag, attraction; then the
/// pull, when one is set). Deterministic: the order of floating-point sums never changes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Forces {
    passes: Vec<ForcePass>,
}

impl Forces {
    pub fn new(effects: &Effects) -> Self {
        let mut passes = Vec::new();
        if let Some(g) = effects.gravity {
            passes.push(ForcePass::Gravity(g.g));
        }
        if let Some(d) = effects.drag {
            passes.push(ForcePass::Drag(d));
        }
        if let Some(a) = effects.attraction {
            passes.push(ForcePass::Attraction(a));
        }
        Forces { passes }
    }

    /// Names of the passes that run, for reports.
    pub fn pass_names(&self) -> Vec<&'static str> {
        self.passes
            .iter()
            .map(|p| match p {
                ForcePass::Gravity(_) => "gravity",
                ForcePass::Drag(_) => "drag",
                ForcePass::Attraction(_) => "attraction",
            })
            .collect()
    }

    /// Whether the acceleration depends on velocity (drag is on).
    pub fn depends_on_velocity(&self) -> bool {
        self.passes.iter().any(|p| matches!(p, ForcePass::Drag(_)))
    }

    /// Whether each ball's acceleration depends only on that ball's own state (no attraction):
    /// the balls can then be integrated in any grouping with the same bits.
    pub fn is_local(&self) -> bool {
        !self.passes.iter().any(|p| matches!(p, ForcePass::Attraction(_)))
    }

    /// True when no force acts at all (vacuum without a pull): the integrators can skip evaluation.
    pub fn is_empty(&self) -> bool {
        self.passes.is_empty()
    }

    /// Fills `acc[i]` with the acceleration of ball i in the state (`pos`, `vel`), plus `pull`.
    ///
    /// Attraction is the direct O(n²) sum over pairs, each pair visited once (Newton's third law),
    /// in index order.
    pub fn accelerations(
        &self,
        props: BodyProps<'_>,
        pull: Option<PointForce>,
        pos: &[DVec2],
        vel: &[DVec2],
        acc: &mut [DVec2],
    ) {
        let n = pos.len();
        debug_assert!(vel.len() == n && acc.len() == n && props.mass.len() == n);
        acc.fill(DVec2::ZERO);
        for pass in &self.passes {
            match *pass {
                ForcePass::Gravity(g) => {
                    for a in acc.iter_mut() {
                        *a += g;
                    }
                }
                ForcePass::Drag(drag) => {
                    for i in 0..n {
                        acc[i] += drag_force(vel[i], props.diameter[i], &drag) * props.inverse_mass[i];
                    }
                }
                ForcePass::Attraction(attraction) => {
                    for i in 0..n {
                        let (pi, mi, ri) = (pos[i], props.mass[i], 0.5 * props.diameter[i]);
                        let mut sum = DVec2::ZERO;
                        for j in (i + 1)..n {
                            let f = attraction_force(
                                pi,
                                mi,
                                ri,
                                pos[j],
                                props.mass[j],
                                0.5 * props.diameter[j],
                                &attraction,
                            );
                            sum += f;
                            acc[j] -= f * props.inverse_mass[j];
                        }
                        acc[i] += sum * props.inverse_mass[i];
                    }
                }
            }
        }
        if let Some(p) = pull {
            acc[p.index] += p.force * props.inverse_mass[p.index];
        }
    }
}
