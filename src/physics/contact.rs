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
    /// The ball's id: it picks the normal of coincident centres ([`coincident_normal`]).
    pub id: BallId,
    /// Centre at the end of the step, m.
    pub position: DVec2,
    /// Velocity at the end of the step, m/s.
    pub velocity: DVec2,
    /// 1/mass, 1/kg.
    pub inverse_mass: f64,
    /// m.
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
    /// a's velocity change, −J·n/m_a, m/s.
    pub velocity_change_a: DVec2,
    /// b's velocity change, +J·n/m_b, m/s.
    pub velocity_change_b: DVec2,
    /// Position corrections that push the pair apart to just touching, split by inverse mass so
    /// the centre of mass stays put: a's share, m.
    pub shift_a: DVec2,
    /// b's share of the position correction (see `shift_a`), m.
    pub shift_b: DVec2,
    /// How long before the end of the step the pair touched, when the collision is replayed from
    /// that instant (the shifts are then each ball's `Δv·τ`); `None` when the pair is pushed apart
    /// instead (resting, or overlapping from the start).
    pub replayed: Option<f64>,
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

/// How far apart, as a share of their contact distance, two balls may be and still touch at the
/// same instant as a contact that overlaps: well above the positions' accumulated rounding
/// (1e-10 m after 10⁵ steps of a 1 m ball), well below any real difference. (At the touch margin,
/// 1e-6, two impacts 1.4e-8 m apart are struck at once where the exact engine takes them one
/// after the other, and lockstep strays from it by 1.4e-8 m: `tests/exact_convergence.rs`.)
pub const SAME_INSTANT: f64 = 1e-9;

/// How a pair that [`contact_ball_ball_or_touching`] strikes meets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallBallTouch {
    /// The balls overlap: the contact of [`contact_ball_ball`].
    Overlapping,
    /// The balls are short of touching by no more than [`SAME_INSTANT`] of their contact distance
    /// and closing: struck at the instant they touch, just after the step's end.
    AboutToTouch,
}

/// Solves the contact between a and b, or returns `None` when they do not touch.
///
/// If they approach (`v_rel = (v_b − v_a)·n < 0`) the impulse is
/// `J = −(1 + e)·v_rel / (1/m_a + 1/m_b)`; if they separate already, no impulse (this is what
/// keeps a pair from being kicked twice).
///
/// The overlap is removed in one of two ways. If the pair approached into it during the last
/// `dt` seconds (the overlap δ was covered at the approach speed in `τ = δ/|v_rel| ≤ dt`), the
/// collision is replayed from the instant they touched: rewound by τ, bounced, and moved on for τ
/// with the new velocities — each ball shifts by `Δv·τ`. Uniform forces (gravity) act alike on
/// both and drop out of the relative motion, so for e = 1 this is exact and adds no energy, where
/// pushing the balls apart would lift one against gravity at every contact. Otherwise (resting
/// contact, a crowd started overlapping) both are pushed apart to just touching, each by its share
/// of inverse mass. Either way the centre of mass stays put. Pass `dt = 0` to always push.
#[inline]
pub fn contact_ball_ball(a: &ContactBody, b: &ContactBody, restitution: f64, dt: f64) -> Option<BallBallContact> {
    let d = b.position - a.position;
    let reach = a.radius + b.radius;
    let dist2 = d.length_squared();
    if dist2 >= reach * reach {
        return None;
    }
    Some(overlapping_contact(a, b, restitution, dt, d, reach, dist2))
}

/// Solves the contact between a and b as [`contact_ball_ball`] does when they overlap, and strikes
/// them at the instant they touch when they are short of touching by no more than
/// [`SAME_INSTANT`] of their contact distance (a rounding) and closing; returns `None` otherwise.
///
/// A step that ends on an impact leaves the pair overlapping by a rounding or short of touching
/// by one, and two impacts of one instant (a row struck from both ends at once, each striker
/// reaching its end at t = 1 s exactly, dt = 1 ms) go one step apart when only overlaps count:
/// the wave from the end that overlapped first runs a ball ahead. The pair about to touch is
/// struck now as at its instant, just after the step's end: the normal is taken there, its
/// `replayed` instant is negative (after the end), and each ball moves back by its velocity
/// change times the time to that instant, so that from the instant on it is where the collision
/// at it puts it (the replay, run backwards). Struck at the end along the line of centres instead,
/// the collision comes early by up to the gap (lockstep strays from the exact engine by 4.7e-8 m
/// in `tests/exact_convergence.rs`, whose bound is 1e-9).
///
/// Inlined into the elastic passes, with the test that rejects a pair out of reach inline and
/// the rare pair about to touch out of line: called for every pair of every pass, an out-of-line
/// call cost the lockstep scale bench about a tenth of its step.
#[inline(always)]
pub fn contact_ball_ball_or_touching(
    a: &ContactBody,
    b: &ContactBody,
    restitution: f64,
    dt: f64,
) -> Option<(BallBallContact, BallBallTouch)> {
    let d = b.position - a.position;
    let reach = a.radius + b.radius;
    let dist2 = d.length_squared();
    if dist2 >= reach * reach {
        if out_of_reach(dist2, reach) {
            return None;
        }
        return touching_contact(a, b, restitution, d, reach, dist2).map(|c| (c, BallBallTouch::AboutToTouch));
    }
    Some((overlapping_contact(a, b, restitution, dt, d, reach, dist2), BallBallTouch::Overlapping))
}

/// Whether balls `dist2.sqrt()` apart whose radii sum to `reach` are farther apart than
/// touching by more than [`SAME_INSTANT`] of it: [`contact_ball_ball_or_touching`] has no contact
/// for them. A loop over many pairs tests this first, on the positions and radii alone, before it
/// reads the rest of the balls (most pairs of a gas are out of reach).
#[inline(always)]
pub fn out_of_reach(dist2: f64, reach: f64) -> bool {
    dist2 > (reach * (1.0 + SAME_INSTANT)).powi(2)
}

/// The contact of overlapping balls (see [`contact_ball_ball`]), from `d = x_b − x_a`, the
/// contact distance `reach` and `dist2 = |d|²`.
#[inline(always)]
fn overlapping_contact(
    a: &ContactBody,
    b: &ContactBody,
    restitution: f64,
    dt: f64,
    d: DVec2,
    reach: f64,
    dist2: f64,
) -> BallBallContact {
    let dist = dist2.sqrt();
    // Below a billionth of the contact distance the direction of d is noise: use a fixed normal.
    let mut normal = if dist > 1e-9 * reach { d / dist } else { coincident_normal(a.id, b.id) };
    let penetration = reach - dist;
    let w = a.inverse_mass + b.inverse_mass;
    let u = b.velocity - a.velocity;
    // A pair that approached into the overlap during the last `dt` is struck where it touched:
    // the instant solves |d − u·s| = R going back s (the larger root; uniform forces leave the
    // relative motion straight), and the normal is taken there, so an oblique collision comes
    // out as the exact one does.
    let (uu, du, disc) = touch_quadratic(d, u, dist2, reach);
    if dt > 0.0 && du < 0.0 && uu > 0.0 && disc >= 0.0 {
        let s = (du + disc.sqrt()) / uu;
        let at = d - u * s;
        let at_len = at.length();
        if s >= 0.0 && s <= dt && at_len > 1e-9 * reach {
            normal = at / at_len;
        }
    }
    let v_rel = u.dot(normal);
    let (impulse, velocity_change_a, velocity_change_b) = normal_impulse(a, b, normal, v_rel, restitution);
    let replayed = (v_rel < 0.0 && penetration <= -v_rel * dt).then(|| {
        // The time since contact along the relative motion (exact for head-on, where it is
        // penetration / |v_rel|).
        if uu > 0.0 && disc >= 0.0 { ((du + disc.sqrt()) / uu).max(0.0) } else { penetration / -v_rel }
    });
    let (shift_a, shift_b) = match replayed {
        Some(tau) => (velocity_change_a * tau, velocity_change_b * tau),
        None => (-penetration * (a.inverse_mass / w) * normal, penetration * (b.inverse_mass / w) * normal),
    };
    BallBallContact { normal, penetration, impulse, velocity_change_a, velocity_change_b, shift_a, shift_b, replayed }
}

/// The contact of balls that do not overlap (`dist2 ≥ reach²`, as [`overlapping_contact`] takes
/// them) but are within a rounding of touching and about to (see
/// [`contact_ball_ball_or_touching`]), or `None`.
#[cold]
#[inline(never)]
fn touching_contact(
    a: &ContactBody,
    b: &ContactBody,
    restitution: f64,
    d: DVec2,
    reach: f64,
    dist2: f64,
) -> Option<BallBallContact> {
    // The caller has told a pair out of reach already (`dist2 ≤ (reach·(1 + SAME_INSTANT))²`).
    let u = b.velocity - a.velocity;
    // The instant they touch, s ahead along the relative motion: |d + u·s| = R, the earlier
    // root; none if they pass each other by.
    let (uu, du, disc) = touch_quadratic(d, u, dist2, reach);
    if du >= 0.0 || uu <= 0.0 || disc < 0.0 {
        return None;
    }
    let s = ((-du - disc.sqrt()) / uu).max(0.0);
    let at = d + u * s;
    let normal = at / at.length();
    let v_rel = u.dot(normal);
    if v_rel >= 0.0 {
        return None;
    }
    let (impulse, velocity_change_a, velocity_change_b) = normal_impulse(a, b, normal, v_rel, restitution);
    Some(BallBallContact {
        normal,
        penetration: 0.0,
        impulse,
        velocity_change_a,
        velocity_change_b,
        shift_a: -velocity_change_a * s,
        shift_b: -velocity_change_b * s,
        replayed: Some(-s),
    })
}

/// The terms of the instants s at which balls `d = x_b − x_a` apart (`dist2 = |d|²`), of relative
/// velocity `u = v_b − v_a`, are `reach` apart: `|d + u·s|² = R²` is
/// `uu·s² + 2·du·s + (dist2 − R²) = 0`. Returns `(uu, du, disc)`, disc the discriminant over 4:
/// `du² − uu·(dist2 − R²)`. Both ways of meeting solve it, each for its own root.
#[inline(always)]
fn touch_quadratic(d: DVec2, u: DVec2, dist2: f64, reach: f64) -> (f64, f64, f64) {
    let (uu, du) = (u.length_squared(), d.dot(u));
    (uu, du, du * du - uu * (dist2 - reach * reach))
}

/// The impulse along `normal` of a pair whose normal relative velocity is `v_rel`:
/// `J = −(1 + e)·v_rel / (1/m_a + 1/m_b)` when it approaches (`v_rel < 0`), none when it
/// separates already; and the velocity changes it gives, −J·n/m_a to a and +J·n/m_b to b (equal
/// and opposite momenta). Returns `(J, Δv_a, Δv_b)`.
#[inline(always)]
fn normal_impulse(
    a: &ContactBody,
    b: &ContactBody,
    normal: DVec2,
    v_rel: f64,
    restitution: f64,
) -> (f64, DVec2, DVec2) {
    let impulse = if v_rel < 0.0 { -(1.0 + restitution) * v_rel / (a.inverse_mass + b.inverse_mass) } else { 0.0 };
    (impulse, -impulse * a.inverse_mass * normal, impulse * b.inverse_mass * normal)
}

/// One wall bounce along the wall's inward normal. `s` is the signed distance of the ball's
/// surface from the wall (negative: past it), `u` the normal velocity (negative: outwards), `alpha`
/// the normal component of the ball's constant acceleration during the step. Returns the new
/// `(s, u)` and the impulse the wall took.
///
/// Rather than mirroring the overshoot (which gains `2·m·g·δ` of energy per bounce under gravity),
/// the crossing is rewound along the constant-acceleration path to the time τ the ball met the
/// wall, its normal velocity there is reflected with the restitution, and the path is replayed for
/// τ. For e = 1 and constant acceleration this is exact: the ball leaves on the parabola it would
/// have followed. When the rewind has no solution (the integrator's state is not on that parabola,
/// as happens to a ball resting on the floor) it falls back to mirroring.
#[inline]
fn bounce(s: f64, u: f64, alpha: f64, e: f64, mass: f64) -> (f64, f64, f64) {
    if u >= 0.0 {
        // Past the wall but already moving in (pushed there by a contact): just put it back.
        return (0.0, u, 0.0);
    }
    // Solve ½·α·τ² − u·τ + s = 0 for the smallest τ > 0 (stable form of the quadratic formula).
    let (a, b, c) = (0.5 * alpha, -u, s);
    let disc = b * b - 4.0 * a * c;
    let (mut s_new, mut u_new, mut impulse) = if disc >= 0.0 {
        let q = -0.5 * (b + disc.sqrt()); // b > 0, so q < 0 and no cancellation
        let tau = c / q;
        let u_contact = u - alpha * tau;
        if tau >= 0.0 && u_contact < 0.0 {
            (
                -e * u_contact * tau + 0.5 * alpha * tau * tau,
                -e * u_contact + alpha * tau,
                -mass * (1.0 + e) * u_contact,
            )
        } else {
            (-e * s, -e * u, -mass * (1.0 + e) * u)
        }
    } else {
        (-e * s, -e * u, -mass * (1.0 + e) * u)
    };
    if s_new < 0.0 {
        // Still at the wall after the replay (e < 1, or resting): stay on it, stop moving out.
        s_new = 0.0;
        if u_new < 0.0 {
            impulse -= mass * u_new;
            u_new = 0.0;
        }
    }
    (s_new, u_new, impulse)
}

/// Keeps a ball inside the field: a ball past a wall is brought back and, if it was moving into
/// the wall, its normal velocity is reflected with the field's restitution (see `bounce` for how
/// the overshoot is handled exactly under a constant acceleration such as gravity). The impulse
/// the wall takes, `m·(1 + e)·|v_n|` at contact, is added to `impulses`. `acceleration` is the
/// ball's uniform acceleration during the step (gravity, plus the pull on the key ball), or zero.
/// Returns whether any wall was touched.
#[inline]
pub fn contact_ball_wall(
    position: &mut DVec2,
    velocity: &mut DVec2,
    radius: f64,
    mass: f64,
    acceleration: DVec2,
    field: &Field,
    impulses: &mut WallImpulses,
) -> bool {
    let e = field.restitution;
    let mut touched = false;
    let (lo_x, hi_x) = (radius, field.width - radius);
    let (lo_y, hi_y) = (radius, field.height - radius);
    // A ball exactly at a wall and moving into it (put there by the contact solver) bounces too.
    if position.x < lo_x || (position.x == lo_x && velocity.x < 0.0) {
        let (s, u, j) = bounce(position.x - lo_x, velocity.x, acceleration.x, e, mass);
        position.x = lo_x + s;
        velocity.x = u;
        impulses.add(Wall::Left, j);
        touched = true;
    } else if position.x > hi_x || (position.x == hi_x && velocity.x > 0.0) {
        let (s, u, j) = bounce(hi_x - position.x, -velocity.x, -acceleration.x, e, mass);
        position.x = hi_x - s;
        velocity.x = -u;
        impulses.add(Wall::Right, j);
        touched = true;
    }
    if position.y < lo_y || (position.y == lo_y && velocity.y < 0.0) {
        let (s, u, j) = bounce(position.y - lo_y, velocity.y, acceleration.y, e, mass);
        position.y = lo_y + s;
        velocity.y = u;
        impulses.add(Wall::Bottom, j);
        touched = true;
    } else if position.y > hi_y || (position.y == hi_y && velocity.y > 0.0) {
        let (s, u, j) = bounce(hi_y - position.y, -velocity.y, -acceleration.y, e, mass);
        position.y = hi_y - s;
        velocity.y = -u;
        impulses.add(Wall::Top, j);
        touched = true;
    }
    if touched {
        // A replayed path longer than the free width (a very fast ball) is clamped.
        position.x = position.x.clamp(lo_x.min(hi_x), hi_x.max(lo_x));
        position.y = position.y.clamp(lo_y.min(hi_y), hi_y.max(lo_y));
    }
    touched
}
