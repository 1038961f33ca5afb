//! Contacts: ball against ball, ball against wall. Named the parry way.
//!
//! A ball–ball contact is solved as one impulse along the line of centres (DESIGN.md, "Physics
//! in one page"): only the normal component of the relative velocity changes, so tangential
//! velocities are untouched; the impulse is equal and opposite, so momentum is conserved to
//! rounding for any mass ratio; with restitution 1 kinetic energy is conserved too.

use glam::DVec2;

use super::ball::BallId;
use super::field::{Field, Wall, WallImpulses};

/// What the contact solver needs to know of one ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactBody {
    pub id: BallId,
    pub position: DVec2,
    pub velocity: DVec2,
    pub inverse_mass: f64,
    pub radius: f64,
}

/// The response to one touching pair (a, b): apply `velocity_change_*` and `shift_*` to each ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallBallContact {
    /// Unit normal from a towards b.
    pub normal: DVec2,
    /// How far the balls overlap (≥ 0), m.
    pub penetration: f64,
    /// Magnitude of the normal impulse J (≥ 0), N·s; a receives −J·n, b receives +J·n.
    pub impulse: f64,
    pub velocity_change_a: DVec2,
    pub velocity_change_b: DVec2,
    /// Position corrections that push the pair apart to just touching, split by inverse mass so
    /// the centre of mass stays put.
    pub shift_a: DVec2,
    pub shift_b: DVec2,
}

/// The normal used when two centres coincide (or nearly so): a fixed direction chosen from the
/// two ids by the golden angle, so that n(a, b) = −n(b, a), the choice is the same on every
/// run, and a stack of coincident balls is spread in all directions rather than along one line.
pub fn coincident_normal(a: BallId, b: BallId) -> DVec2 {
    let (lo, hi, sign) = if a <= b { (a.0, b.0, 1.0) } else { (b.0, a.0, -1.0) };
    const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;
    let k = (lo as u64).wrapping_mul(7919).wrapping_add(hi as u64) % 1_000_003;
    let angle = GOLDEN_ANGLE * k as f64;
    sign * DVec2::new(angle.cos(), angle.sin())
}

/// Solves the contact between a and b, or returns `None` when they do not touch.
///
/// If they approach (`v_rel = (v_b − v_a)·n < 0`) the impulse is
/// `J = −(1 + e)·v_rel / (1/m_a + 1/m_b)`; if they separate already, no impulse (this is what
/// keeps a pair from being kicked twice). An overlap is removed by shifting both along n.
#[inline]
pub fn contact_ball_ball(a: &ContactBody, b: &ContactBody, restitution: f64) -> Option<BallBallContact> {
    let d = b.position - a.position;
    let reach = a.radius + b.radius;
    let dist2 = d.length_squared();
    if dist2 >= reach * reach {
        return None;
    }
    let dist = dist2.sqrt();
    // Below a billionth of the contact distance the direction of d is noise: use a fixed normal.
    let normal = if dist > 1e-9 * reach { d / dist } else { coincident_normal(a.id, b.id) };
    let penetration = reach - dist;
    let w = a.inverse_mass + b.inverse_mass;
    let v_rel = (b.velocity - a.velocity).dot(normal);
    let impulse = if v_rel < 0.0 { -(1.0 + restitution) * v_rel / w } else { 0.0 };
    let share_a = a.inverse_mass / w;
    let share_b = b.inverse_mass / w;
    Some(BallBallContact {
        normal,
        penetration,
        impulse,
        velocity_change_a: -impulse * a.inverse_mass * normal,
        velocity_change_b: impulse * b.inverse_mass * normal,
        shift_a: -penetration * share_a * normal,
        shift_b: penetration * share_b * normal,
    })
}

/// Keeps a ball inside the field: a ball past a wall is brought back (its overshoot mirrored and
/// scaled by the restitution, so a free bounce loses no distance) and, if it was moving into the
/// wall, its normal velocity is reflected with the field's restitution. The impulse the wall
/// takes, `m·(1 + e)·|v_n|`, is added to `impulses`. Returns whether any wall was touched.
#[inline]
pub fn contact_ball_wall(
    position: &mut DVec2,
    velocity: &mut DVec2,
    radius: f64,
    mass: f64,
    field: &Field,
    impulses: &mut WallImpulses,
) -> bool {
    let e = field.restitution;
    let mut touched = false;
    let (lo_x, hi_x) = (radius, field.width - radius);
    let (lo_y, hi_y) = (radius, field.height - radius);
    if position.x < lo_x {
        position.x = lo_x + e * (lo_x - position.x);
        if velocity.x < 0.0 {
            impulses.add(Wall::Left, -mass * (1.0 + e) * velocity.x);
            velocity.x = -e * velocity.x;
        }
        touched = true;
    } else if position.x > hi_x {
        position.x = hi_x - e * (position.x - hi_x);
        if velocity.x > 0.0 {
            impulses.add(Wall::Right, mass * (1.0 + e) * velocity.x);
            velocity.x = -e * velocity.x;
        }
        touched = true;
    }
    if position.y < lo_y {
        position.y = lo_y + e * (lo_y - position.y);
        if velocity.y < 0.0 {
            impulses.add(Wall::Bottom, -mass * (1.0 + e) * velocity.y);
            velocity.y = -e * velocity.y;
        }
        touched = true;
    } else if position.y > hi_y {
        position.y = hi_y - e * (position.y - hi_y);
        if velocity.y > 0.0 {
            impulses.add(Wall::Top, mass * (1.0 + e) * velocity.y);
            velocity.y = -e * velocity.y;
        }
        touched = true;
    }
    if touched {
        // A mirrored overshoot larger than the free width (a very fast ball) is clamped.
        position.x = position.x.clamp(lo_x.min(hi_x), hi_x.max(lo_x));
        position.y = position.y.clamp(lo_y.min(hi_y), hi_y.max(lo_y));
    }
    touched
}
