//! Event prediction for hard balls under piecewise-constant accelerations: when two balls, a
//! ball and a wall, or a ball and a cell boundary next meet, and what a collision does.
//!
//! Between events every ball flies a parabola, `x(t) = x₀ + v₀·t + ½·a·t²` ([`flight`]). Balls
//! under the same acceleration (uniform gravity) move in straight lines relative to each other,
//! so the squared gap of a pair, `f(t) = |Δr + Δv·t|² − σ²`, is a quadratic in t; a ball's
//! distance to a wall or a cell boundary is one too. A pair whose accelerations differ (the
//! pulled key ball, or a ball at rest against a falling one) has a quartic `f`, solved here by
//! isolating its monotone pieces — no closed form, whose rounding is unusable near contact.
//!
//! **When is an event due.** Following Bannerman, Strobl, Pöschel & Lue, "Stable algorithm for
//! event detection in event-driven particle dynamics" (Comput. Part. Mech. 1, 2014), an event is
//! the first instant `t ≥ 0` at which the gap function is non-positive *and decreasing*: not the
//! root of `f` the formula gives. Rounding leaves balls that have just collided touching or a
//! hair inside each other; judged by the sign of `f` alone such a pair would collide again at
//! once, or never (an overlapping pair has no root ahead and passes through). Judged by
//! "`f ≤ 0` and `f′ < 0`", a pair that is touching or overlapping collides now if it approaches
//! and is left alone if it separates, so it is never stuck and never missed. When the pair
//! separates but is being accelerated back (a ball dropped on one at rest), the event is where
//! `f′` turns negative while `f ≤ 0`, or else where `f` crosses zero downwards on the way back.
//! All the roots here are taken in forms that do not cancel.

use glam::DVec2;

/// Where a ball flying from `x0` at `v0` under a constant `a` is after `t` seconds, and its
/// velocity there.
#[inline]
pub fn flight(x0: DVec2, v0: DVec2, a: DVec2, t: f64) -> (DVec2, DVec2) {
    (x0 + (v0 + 0.5 * a * t) * t, v0 + a * t)
}

/// The first `t ≥ 0` at which `f(t) = a·t² + b·t + c` is `≤ 0` and not increasing (see the
/// module comment), or `None` if there is none.
///
/// Cases, with `c` the gap now and `b` its rate:
/// - touching or overlapping (`c ≤ 0`): now if closing (`b < 0`); if opening with `a ≥ 0`, never;
///   if opening with `a < 0` (accelerated back), at the turning point `−b/2a` when the gap is
///   still closed there, else where it closes again (the larger root);
/// - apart (`c > 0`): the smaller positive root of a closing parabola (`a > 0`, `b < 0`, real
///   roots), the only positive root when `a < 0`, `c/−b` when `a = 0`.
///
/// Roots use the form `q = −½·(b + sign(b)·√D)`, `t ∈ {q/a, c/q}`, which never subtracts nearly
/// equal numbers.
///
/// Coefficients whose `b² − 4ac` overflows (a ball 1e308 m above the floor of a field that wide)
/// are taken scaled by a power of two: the roots are ratios of the coefficients and do not change,
/// and an infinite `√D` would put the event at t = 0.
#[inline]
pub fn entry_time(a: f64, b: f64, c: f64) -> Option<f64> {
    entry_time_scaled(a, b, c, true)
}

/// [`entry_time`], scaling the coefficients when `rescale` and `D` is not finite.
#[inline]
fn entry_time_scaled(a: f64, b: f64, c: f64, rescale: bool) -> Option<f64> {
    if c <= 0.0 {
        if b < 0.0 {
            return Some(0.0);
        }
        if a >= 0.0 {
            return None;
        }
        // Opening (b ≥ 0) but pulled back (a < 0): f peaks at t* = b / (−2a).
        let turn = b / (-2.0 * a);
        let peak = c + 0.5 * b * turn;
        if peak <= 0.0 {
            return Some(turn);
        }
        // It opens, then closes again at the larger root, (b + √D) / (−2a) (b ≥ 0: no
        // cancellation).
        let d = b * b - 4.0 * a * c;
        if rescale && !d.is_finite() {
            return rescaled(a, b, c);
        }
        return Some(if d > 0.0 { (b + d.sqrt()) / (-2.0 * a) } else { turn });
    }
    if a == 0.0 {
        return if b < 0.0 { Some(c / -b) } else { None };
    }
    if a > 0.0 {
        if b >= 0.0 {
            return None;
        }
        let d = b * b - 4.0 * a * c;
        if rescale && !d.is_finite() {
            return rescaled(a, b, c);
        }
        if d <= 0.0 {
            // No real root, or a graze that touches without entering.
            return None;
        }
        // The smaller root c/q with q = −½(b − √D) > 0.
        return Some(c / (0.5 * (d.sqrt() - b)));
    }
    // a < 0 < c: f falls to −∞ and crosses zero once for t > 0 (the roots' product c/a is < 0).
    let d = b * b - 4.0 * a * c;
    if rescale && !d.is_finite() {
        return rescaled(a, b, c);
    }
    let d = d.max(0.0);
    Some(if b >= 0.0 { -0.5 * (b + d.sqrt()) / a } else { c / (0.5 * (d.sqrt() - b)) })
}

/// [`entry_time`] of finite coefficients whose `D` overflowed, scaled so that the largest is
/// below 1 in magnitude: then `b² − 4ac` is at most 5 and cannot overflow. The scale is a power
/// of two, exact unless a coefficient falls below the smallest normal float — a loss below the
/// largest's rounding. `D` overflows only when a coefficient exceeds 6.7e153 (2⁵¹¹), so the
/// scale is 2^−k·2^−512 with k in 0..=512, each factor a normal float. Infinite or NaN
/// coefficients are taken as they are.
#[cold]
fn rescaled(a: f64, b: f64, c: f64) -> Option<f64> {
    let largest = a.abs().max(b.abs()).max(c.abs());
    if !largest.is_finite() {
        return entry_time_scaled(a, b, c, false);
    }
    // The largest's binary exponent e: it is below 2^(e + 1).
    let e = ((largest.to_bits() >> 52) & 0x7ff) as i64 - 1023;
    let k = (e + 1 - 512).clamp(0, 512);
    let (s, base) = (f64::from_bits(((1023 - k) as u64) << 52), f64::from_bits(((1023 - 512) as u64) << 52));
    entry_time_scaled(a * s * base, b * s * base, c * s * base, false)
}

/// When a ball whose surface is `gap` m from a plane (a wall or a cell boundary; negative: past
/// it) and which moves away from it at `v_n` m/s under an acceleration `a_n` m/s² (both along
/// the plane's normal, pointing away from it) next reaches the plane moving towards it.
#[inline]
pub fn plane_time(gap: f64, v_n: f64, a_n: f64) -> Option<f64> {
    entry_time(0.5 * a_n, v_n, gap)
}

/// The coefficients `[c₀, c₁, c₂, c₃, c₄]` of a pair's gap function
/// `f(t) = |Δr + Δv·t + ½·Δa·t²|² − σ²` (`Δ` = b − a, σ = the sum of the radii).
#[inline]
pub fn pair_gap_polynomial(dr: DVec2, dv: DVec2, da: DVec2, sigma: f64) -> [f64; 5] {
    [
        dr.length_squared() - sigma * sigma,
        2.0 * dr.dot(dv),
        dv.length_squared() + dr.dot(da),
        dv.dot(da),
        0.25 * da.length_squared(),
    ]
}

/// How far below zero the `Δr·Δv` of a touching pair may be for the pair still to count as not
/// closing, in units of `ε·σ·s` (ε the machine epsilon, σ the contact distance, `s` the sum of the
/// two balls' speeds): a few times what rounding leaves in that dot product, which is computed
/// from velocities known to `ε·s`.
pub const CLOSING_SLACK: f64 = 16.0;

/// The slack of [`CLOSING_SLACK`] for a pair of contact distance `sigma` whose speeds sum to
/// `speeds` (m/s; the engine uses the 1-norms `|v_x| + |v_y|`, which bound the lengths).
#[inline]
pub fn closing_slack(sigma: f64, speeds: f64) -> f64 {
    CLOSING_SLACK * f64::EPSILON * sigma * speeds
}

/// When two balls next collide, within `horizon` seconds (infinite: ever), given their relative
/// position `dr`, velocity `dv` and acceleration `da` (b − a), `sigma`, the sum of their radii,
/// and `speeds`, the sum of their speeds (see [`closing_slack`]).
///
/// With `da = 0` (balls under the same uniform acceleration) the gap is a quadratic and the root
/// is [`entry_time`]'s; otherwise it is [`first_entry`] of the quartic. A touching or overlapping
/// pair that closes by less than [`closing_slack`] counts as not closing: that approach is a
/// rounding of the impulse that just separated it (or of the impulses of a cluster solved at
/// once), and judged by its sign alone the pair would be due again at once, for ever. The result
/// is the same function of the arguments on every machine (no fused operations, a fixed order of
/// operations), so a run is reproducible bit for bit.
#[inline]
pub fn pair_time(dr: DVec2, dv: DVec2, da: DVec2, sigma: f64, horizon: f64, speeds: f64) -> Option<f64> {
    let c = dr.length_squared() - sigma * sigma;
    let mut b = dr.dot(dv);
    if c <= 0.0 && b < 0.0 && b >= -closing_slack(sigma, speeds) {
        b = 0.0;
    }
    if da == DVec2::ZERO {
        // Apart and not closing, or a graze: the common case in a gas, decided without a root.
        if c > 0.0 && b >= 0.0 {
            return None;
        }
        return entry_time(dv.length_squared(), 2.0 * b, c).filter(|&t| t <= horizon);
    }
    let mut p = pair_gap_polynomial(dr, dv, da, sigma);
    p[1] = 2.0 * b;
    first_entry(&p, horizon)
}

/// `p(t)` for coefficients `p[k]·t^k` (Horner).
#[inline]
fn eval(p: &[f64], t: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, &c| acc * t + c)
}

/// The derivative's coefficients (the last one is 0).
#[inline]
fn derivative(p: &[f64; 5]) -> [f64; 5] {
    [p[1], 2.0 * p[2], 3.0 * p[3], 4.0 * p[4], 0.0]
}

/// The degree of `p` (the highest non-zero coefficient), or `None` for the zero polynomial.
fn degree(p: &[f64; 5]) -> Option<usize> {
    (0..5).rev().find(|&k| p[k] != 0.0)
}

/// Cauchy's bound: every real root of `p` lies within `1 + max |p_k / p_n|` of zero.
fn root_bound(p: &[f64; 5]) -> f64 {
    match degree(p) {
        None | Some(0) => 0.0,
        Some(n) => 1.0 + (0..n).map(|k| (p[k] / p[n]).abs()).fold(0.0, f64::max),
    }
}

/// A root of `p` in `[lo, hi]` (both ≥ 0, `p(lo)` and `p(hi)` of opposite signs or zero), found
/// by bisecting the bit patterns of the two ends: non-negative floats are ordered as their bits
/// are, so this takes at most 64 halvings on any interval and ends on two adjacent floats.
/// Returns the end where `p` has the sign `p` has at `lo` changed, i.e. the first float at which
/// `p` is on `hi`'s side.
fn bisect(p: &[f64; 5], lo: f64, hi: f64) -> f64 {
    let lo_positive = eval(p, lo) > 0.0;
    let (mut a, mut b) = (lo.to_bits(), hi.to_bits());
    while b - a > 1 {
        let m = a + (b - a) / 2;
        if (eval(p, f64::from_bits(m)) > 0.0) == lo_positive {
            a = m;
        } else {
            b = m;
        }
    }
    f64::from_bits(b)
}

/// At most five cut points: the ends of an interval and the (at most three) roots of a cubic
/// between them. A fixed array, so that a root search allocates nothing.
#[derive(Clone, Copy)]
struct Cuts {
    t: [f64; 6],
    len: usize,
}

impl Cuts {
    fn new(first: f64) -> Cuts {
        Cuts { t: [first, 0.0, 0.0, 0.0, 0.0, 0.0], len: 1 }
    }

    fn push(&mut self, t: f64) {
        if self.len < self.t.len() {
            self.t[self.len] = t;
            self.len += 1;
        }
    }

    fn as_slice(&self) -> &[f64] {
        &self.t[..self.len]
    }
}

/// The roots of `p` (degree ≤ 3 here) strictly inside `(lo, hi)` (`0 ≤ lo < hi`, finite), in
/// increasing order, into `out`: the critical points (roots of `p′`, found the same way) cut the
/// interval into pieces on which `p` is monotone, and each piece whose ends differ in sign holds
/// one root.
fn roots_between(p: &[f64; 5], lo: f64, hi: f64, out: &mut Cuts) {
    let Some(n) = degree(p) else { return };
    if n == 0 {
        return;
    }
    if n == 1 {
        let t = -p[0] / p[1];
        if t > lo && t < hi {
            out.push(t);
        }
        return;
    }
    let mut cuts = Cuts::new(lo);
    roots_between(&derivative(p), lo, hi, &mut cuts);
    cuts.push(hi);
    for w in cuts.as_slice().windows(2) {
        let (fa, fb) = (eval(p, w[0]), eval(p, w[1]));
        if (fa > 0.0) != (fb > 0.0) {
            let t = bisect(p, w[0], w[1]);
            if t > lo && t < hi {
                out.push(t);
            }
        }
    }
}

/// The first `t` in `[0, horizon]` at which the polynomial `p` (degree ≤ 4) is `≤ 0` and
/// decreasing — the event rule of the module comment, for any degree. `horizon` may be infinite
/// when `p`'s leading coefficient is positive (as a pair's `¼|Δa|²` is): beyond Cauchy's bound
/// such a `p` only grows.
///
/// The interval is cut at the roots of `p′` into monotone pieces, taken in order: on a
/// decreasing piece the event is its start if `p ≤ 0` there (a turning point while closed, or
/// now), or else the root inside it if `p` ends `≤ 0`.
pub fn first_entry(p: &[f64; 5], horizon: f64) -> Option<f64> {
    let dp = derivative(p);
    let end = horizon.min(root_bound(p).max(root_bound(&dp)) * 2.0);
    if !(end > 0.0 && end.is_finite()) {
        // The zero polynomial, or one whose bound overflowed: nothing to find.
        return (p[0] <= 0.0 && p[1] < 0.0).then_some(0.0);
    }
    let mut cuts = Cuts::new(0.0);
    roots_between(&dp, 0.0, end, &mut cuts);
    cuts.push(end);
    for w in cuts.as_slice().windows(2) {
        let (a, b) = (w[0], w[1]);
        if eval(&dp, 0.5 * (a + b)) >= 0.0 {
            continue;
        }
        if eval(p, a) <= 0.0 {
            return Some(a);
        }
        if eval(p, b) <= 0.0 {
            return Some(bisect(p, a, b));
        }
    }
    None
}

/// How a ball answers an impulse at a collision: its inverse mass "matrix" `W`, so that an
/// impulse `P` changes its velocity by `W·P`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mobility {
    /// A free ball: `W = I/m`.
    Free {
        /// 1/m, 1/kg.
        inverse_mass: f64,
    },
    /// A ball sliding on a wall whose inward normal is `wall`: the wall takes the normal part of
    /// any impulse that presses the ball into it, `W = (I − n·nᵀ)/m`.
    Sliding {
        /// 1/m, 1/kg.
        inverse_mass: f64,
        /// The wall's inward unit normal.
        wall: DVec2,
    },
    /// A ball held by the floor through its supports (at rest in a pile): `W = 0`.
    Fixed,
}

impl Mobility {
    /// `nᵀ·W·n`: how much velocity along `n` an impulse of `n` gives, with `n` of any length (see
    /// [`collide`]).
    #[inline]
    pub fn along(&self, n: DVec2) -> f64 {
        match *self {
            Mobility::Free { inverse_mass } => inverse_mass * n.length_squared(),
            Mobility::Sliding { inverse_mass, wall } => {
                // Along the wall's normal to within 3e-5 rad the wall takes the whole impulse:
                // what the subtraction leaves there is rounding, and dividing by it would give
                // the ball the rounding's inverse as a velocity.
                let (n2, c) = (n.length_squared(), n.dot(wall));
                let free = n2 - c * c;
                if free > 1e-9 * n2 { inverse_mass * free } else { 0.0 }
            }
            Mobility::Fixed => 0.0,
        }
    }

    /// `W·P`: the velocity change an impulse `P` gives.
    #[inline]
    pub fn response(&self, impulse: DVec2) -> DVec2 {
        match *self {
            Mobility::Free { inverse_mass } => inverse_mass * impulse,
            Mobility::Sliding { inverse_mass, wall } => inverse_mass * (impulse - impulse.dot(wall) * wall),
            Mobility::Fixed => DVec2::ZERO,
        }
    }
}

/// The result of a ball–ball collision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collision {
    /// The impulse per unit of the direction [`collide`] was given, `J` (≥ 0): a receives
    /// `−J·d`, b receives `+J·d` (N·s for a unit `d`; N·s/m for `d = Δr`).
    pub impulse: f64,
    /// The velocity change of ball a, m/s.
    pub velocity_change_a: DVec2,
    /// The velocity change of ball b, m/s.
    pub velocity_change_b: DVec2,
}

/// The collision of a and b along the direction `d` (from a towards b, any length): the impulse
/// `J·d` that turns the relative velocity along it, `v_rel = (v_b − v_a)·d`, into `outgoing`
/// (≥ 0, in the same units: `−e·v_rel` for restitution e), given how each ball answers an
/// impulse.
///
/// `J = (outgoing − v_rel) / (dᵀW_a d + dᵀW_b d)`. For two free balls and a unit `d` this is
/// DESIGN.md's `J = −(1 + e)·v_rel / (1/m_a + 1/m_b)`: equal and opposite impulses (momentum
/// exact at any mass ratio), tangential velocities untouched, and for e = 1 the kinetic energy
/// kept, as the relative velocity along `d` is reversed exactly. `d`'s length drops out, so the
/// caller may pass the centres' difference `Δr` itself (as the exact engine does): a unit normal
/// `Δr/|Δr|` is of length 1 only to rounding, and its rounding biases the energy of an elastic
/// gas (see `World::collide_pair`). With a constrained ball (sliding on a wall, held in a pile) the
/// constraint takes the rest of the impulse; e = 1 still keeps the energy, since `W` is
/// symmetric. Returns `None` when neither ball can move along `d`, or the pair already separates
/// at least at `outgoing`.
#[inline]
pub fn collide(n: DVec2, v_rel: f64, outgoing: f64, a: Mobility, b: Mobility) -> Option<Collision> {
    let w = a.along(n) + b.along(n);
    if w.is_nan() || w <= 0.0 || v_rel >= outgoing {
        return None;
    }
    let impulse = (outgoing - v_rel) / w;
    Some(Collision { impulse, velocity_change_a: a.response(-impulse * n), velocity_change_b: b.response(impulse * n) })
}

/// The restitution of a collision at normal approach speed `speed` for a material of
/// restitution `e` (the scene's), under the velocity-dependent model of Bizon, Shattuck, Swift,
/// McCormick & Swinney ("Patterns in 3D vertically oscillated granular layers", Phys. Rev. Lett.
/// 80, 1998): `e` at and above `v0`, rising continuously to 1 as the speed falls to 0,
/// `1 − (1 − e)·(speed/v0)^¾` below.
///
/// With a constant e < 1, a cluster of balls can collide infinitely often in a finite time, the
/// relative speeds shrinking geometrically (the inelastic collapse, McNamara & Young 1992); an
/// event-driven engine would grind to a halt on it. Collisions slower than `v0` losing ever less
/// of their speed stop the collapse while leaving everything faster as the scene says (the TC
/// model of Luding & McNamara 1998 stops it too, by making collisions elastic when they come
/// faster than a time `tc`, but a squeezed, fast-rattling row then keeps its energy for ever).
/// `e = 1` is returned unchanged.
#[inline]
pub fn soft_restitution(e: f64, speed: f64, v0: f64) -> f64 {
    if e >= 1.0 || speed.is_nan() || speed >= v0 {
        return e;
    }
    // A pair that does not close (speed ≤ 0) has nothing to lose.
    1.0 - (1.0 - e) * (speed.max(0.0) / v0).powf(0.75)
}

/// Whether the cone spanned by the contact normals `normals` (unit vectors pointing from each
/// support into the ball) contains the direction `dir`, to an angle of `slack` radians: whether
/// frictionless supports along those normals can balance a force along `dir` (for a ball at rest,
/// `dir` is `−a`, against its acceleration). In 2D it does if a normal points along `dir`, or if
/// two normals on either side of `dir` span less than a half-turn.
pub fn cone_contains(normals: &[DVec2], dir: DVec2, slack: f64) -> bool {
    let Some(dir) = dir.try_normalize() else { return true };
    // Each normal's signed angle from dir, in (−π, π].
    let mut left = f64::INFINITY; // smallest angle > 0 (counter-clockwise of dir)
    let mut right = f64::NEG_INFINITY; // largest angle < 0
    for n in normals {
        let angle = dir.perp_dot(*n).atan2(dir.dot(*n));
        if angle.abs() <= slack {
            return true;
        }
        if angle > 0.0 {
            left = left.min(angle);
        } else {
            right = right.max(angle);
        }
    }
    left.is_finite() && right.is_finite() && left - right <= std::f64::consts::PI + slack
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closing speed of a pair's test: 1 m/s summed over both balls.
    const SPEEDS: f64 = 1.0;

    /// Relative difference, against `b`.
    fn relative(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Two balls touching (centres exactly σ apart) and approaching collide now, not never: the
    /// gap is zero and closing, so the event rule has it due at t = 0. Seen to fail with `b`'s sign
    /// flipped in `pair_time` (`−dr·dv`: None), with the touching case's test as `b > 0.0` in
    /// `entry_time` (None), and, under a differing acceleration, with `first_entry` taking [0, end]
    /// as one monotone piece.
    #[test]
    fn touching_and_approaching_collide_now() {
        for (dr, dv) in [
            (DVec2::new(1.0, 0.0), DVec2::new(-1.0, 0.0)),
            (DVec2::new(0.6, 0.8), DVec2::new(-0.3, 0.2)),
            (DVec2::new(0.0, -1.0), DVec2::new(5.0, 2.0)),
        ] {
            assert_eq!(dr.length_squared(), 1.0, "exactly touching");
            assert_eq!(pair_time(dr, dv, DVec2::ZERO, 1.0, f64::INFINITY, SPEEDS), Some(0.0), "{dr} {dv}");
            // Under a differing acceleration too (the quartic's path).
            assert_eq!(pair_time(dr, dv, DVec2::new(0.0, -9.81), 1.0, f64::INFINITY, SPEEDS), Some(0.0));
        }
    }

    /// Touching and separating, there is no event: the pair parts (under the same acceleration,
    /// for ever). Seen to fail with `b`'s sign flipped in `pair_time`, and with the touching case's
    /// test as `b > 0.0` in `entry_time` (each: Some(0.0)).
    #[test]
    fn touching_and_separating_is_no_event() {
        for (dr, dv) in [
            (DVec2::new(1.0, 0.0), DVec2::new(1.0, 0.0)),
            (DVec2::new(0.6, 0.8), DVec2::new(0.3, -0.2)),
            (DVec2::new(0.0, -1.0), DVec2::new(5.0, -2.0)),
        ] {
            assert_eq!(pair_time(dr, dv, DVec2::ZERO, 1.0, f64::INFINITY, SPEEDS), None, "{dr} {dv}");
        }
    }

    /// Slightly overlapping (by 1e-9 of σ, as rounding after a collision leaves a pair) and
    /// separating is never stuck: no event, so the pair parts instead of colliding again at once
    /// for ever; overlapping and approaching, it collides now (Bannerman et al. 2014's rule: due
    /// where the gap is `≤ 0` and decreasing). A touching pair whose `Δr·Δv` is below zero by
    /// rounding only (1e-17, against a slack of 3.6e-15 here) counts as not closing. Seen to fail
    /// with `b`'s sign flipped in `pair_time` and with the touching case's test as `b > 0.0` in
    /// `entry_time` (each: the separating pair due at 0), and with the slack dropped
    /// (`CLOSING_SLACK = 0.0`: the rounding-closing pair due at 0).
    #[test]
    fn overlapping_and_separating_is_never_stuck() {
        let dr = DVec2::new(1.0 - 1e-9, 0.0);
        let out = DVec2::new(1e-3, 0.0);
        assert_eq!(pair_time(dr, out, DVec2::ZERO, 1.0, f64::INFINITY, SPEEDS), None);
        assert_eq!(pair_time(dr, -out, DVec2::ZERO, 1.0, f64::INFINITY, SPEEDS), Some(0.0));
        // Sliding past each other, closing by rounding alone.
        let grazing = DVec2::new(-1e-17, 1.0);
        assert_eq!(pair_time(DVec2::X, grazing, DVec2::ZERO, 1.0, f64::INFINITY, SPEEDS), None);
        // Overlapping and separating but pulled back (a ball dropped on one at rest): the gap
        // −t² + 2e-6·t − 1e-9 peaks at −b/2a = 1e-6 s still closed, and the event is that turn,
        // where it starts closing again; −t² + 2e-3·t − 1e-9 opens (peak 1e-6) and the event is
        // where it closes again, the larger root 1e-3 + √(1e-6 − 1e-9).
        let again = entry_time(-1.0, 2e-3, -1e-9).unwrap();
        assert!(relative(again, 1e-3 + (1e-6f64 - 1e-9).sqrt()) < 1e-15, "{again:e}");
        let t = entry_time(-1.0, 2e-6, -1e-9).unwrap();
        assert!(relative(t, 1e-6) < 1e-15, "the turn at −b/2a = 1e-6 s: {t:e}");
    }

    /// Apart and approaching, the contact time is the smaller root of `|Δv|²t² + 2(Δr·Δv)t + c`,
    /// `(−Δr·Δv − √((Δr·Δv)² − |Δv|²c)) / |Δv|²`, to rounding: measured 0 (the same bits) over
    /// these pairs. Bound: 4e-16 (2 ulps). Seen to fail with the larger root taken (`q/a` for
    /// `c/q` in `entry_time`: 2.0 relative) and with `b`'s sign flipped in `pair_time` (None).
    #[test]
    fn approaching_from_a_distance_at_the_closed_form() {
        let mut worst = 0.0f64;
        for (dr, dv, sigma) in [
            (DVec2::new(3.0, 0.4), DVec2::new(-2.0, 0.1), 1.0),
            (DVec2::new(-10.0, 7.0), DVec2::new(3.0, -2.5), 2.5),
            (DVec2::new(0.0, 1e-3), DVec2::new(1e-4, -1.0), 5e-4),
            (DVec2::new(1e3, 1e3), DVec2::new(-1e2, -99.99), 1.0),
        ] {
            let (a, b, c) = (dv.length_squared(), dr.dot(dv), dr.length_squared() - sigma * sigma);
            let closed = (-b - (b * b - a * c).sqrt()) / a;
            let t = pair_time(dr, dv, DVec2::ZERO, sigma, f64::INFINITY, SPEEDS).expect("they meet");
            worst = worst.max(relative(t, closed));
            // Exactly touching there, to rounding of the positions.
            assert!(((dr + dv * t).length() - sigma).abs() < 1e-12 * dr.length().max(1.0));
            // And not within a horizon short of it.
            assert_eq!(pair_time(dr, dv, DVec2::ZERO, sigma, 0.5 * t, SPEEDS), None);
        }
        eprintln!("largest difference from the closed form {worst:e}");
        assert!(worst <= 4e-16, "{worst:e}");
    }

    /// A ball under constant acceleration against a wall: thrown up, dropped and thrown down
    /// from `h` above a floor under −g, it lands at `(v + √(v² + 2gh)) / g` (the root of
    /// `h + v·t − g·t²/2`, here without cancellation as v ≥ 0 or computed as `2h / (√(v² + 2gh) −
    /// v)` for v < 0); a ball touching the floor and thrown up comes back at `2v/g`; one moving
    /// off a plane without acceleration never meets it, and one moving towards it at `gap/|v|`.
    /// Measured: 0 (the same bits) from the closed forms. Bound 4e-16 (2 ulps). Seen to fail with
    /// the half dropped in `plane_time` (`entry_time(a_n, ..)`: 0.5 relative), and with the
    /// touching case's test as `b > 0.0` in `entry_time` (the ball thrown up off the floor due at
    /// once: 1.0 relative); from 1e308 m, with the overflowed discriminant taken unscaled
    /// (`entry_time` without its `rescaled`: the ball due at the floor at t = 0).
    #[test]
    fn plane_time_at_the_closed_form() {
        let g: f64 = 9.81;
        let mut worst = 0.0f64;
        for (h, v) in [(10.0f64, 0.0f64), (10.0, 3.0), (10.0, -3.0), (0.25, 20.0), (1e3, -1.0)] {
            let root = (v * v + 2.0 * g * h).sqrt();
            let closed = if v >= 0.0 { (v + root) / g } else { 2.0 * h / (root - v) };
            let t = plane_time(h, v, -g).expect("it lands");
            worst = worst.max(relative(t, closed));
        }
        let back = plane_time(0.0, 4.0, -g).expect("it comes back");
        worst = worst.max(relative(back, 2.0 * 4.0 / g));
        eprintln!("largest difference from the closed form {worst:e}");
        assert!(worst <= 4e-16, "{worst:e}");
        // From 1e308 m up, where b² − 4ac overflows: the fall time √(2h/g) (the 1 m/s downwards
        // changes it by 1e-154 of itself). Measured 1 ulp (1.7e-16 relative).
        let (h, v) = (1e308f64, -1.0);
        let far = plane_time(h, v, -g).expect("it lands");
        let fall = (2.0 / g).sqrt() * h.sqrt();
        eprintln!("from 1e308 m: {far:e} s against {fall:e} s");
        assert!(relative(far, fall) < 1e-15, "{far:e} s against {fall:e} s");
        assert_eq!(plane_time(2.0, 1.0, 0.0), None, "moving away, no acceleration");
        assert_eq!(plane_time(2.0, -4.0, 0.0), Some(0.5));
        assert_eq!(plane_time(0.0, -4.0, 0.0), Some(0.0), "touching and moving in");
    }

    /// The pulled key ball's pairs (accelerations that differ: a quartic gap) against a brute
    /// force scan: the gap `|Δr + Δv·t + ½Δa·t²|² − σ²` and its derivative evaluated directly (not
    /// from `pair_gap_polynomial`'s coefficients) at 200,001 instants over 10 s, the event the
    /// first instant where the gap is `≤ 0` and decreasing. 400 seeded random pairs, apart,
    /// touching and overlapping, with accelerations up to 20 m/s², of which 144 meet within 10 s:
    /// `pair_time` finds each within one scan step (5e-5 s) after its root, and no event where
    /// the scan finds none. Seen to fail with the `Δr·Δa` term dropped from
    /// `pair_gap_polynomial`'s t² coefficient, with `first_entry` taking [0, end] as one monotone
    /// piece (no cut at the roots of p′), and with `b`'s sign flipped in `pair_time`.
    #[test]
    fn first_entry_against_a_fine_scan() {
        let mut state = 2014u64;
        let mut rnd = |lo: f64, hi: f64| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((state >> 11) as f64 / (1u64 << 53) as f64)
        };
        let (horizon, samples) = (10.0, 200_000);
        let step = horizon / samples as f64;
        let mut met = 0;
        for case in 0..400 {
            let sigma = rnd(0.5, 2.0);
            let dist = match case % 4 {
                0 => sigma,
                1 => sigma * (1.0 - 1e-6),
                _ => sigma + rnd(0.0, 5.0),
            };
            let angle = rnd(0.0, std::f64::consts::TAU);
            let dr = dist * DVec2::new(angle.cos(), angle.sin());
            let dv = DVec2::new(rnd(-3.0, 3.0), rnd(-3.0, 3.0));
            let da = DVec2::new(rnd(-20.0, 20.0), rnd(-20.0, 20.0));
            let gap = |t: f64| (dr + dv * t + 0.5 * da * t * t).length_squared() - sigma * sigma;
            let slope = |t: f64| 2.0 * (dr + dv * t + 0.5 * da * t * t).dot(dv + da * t);
            let scan = (0..=samples).map(|k| k as f64 * step).find(|&t| gap(t) <= 0.0 && slope(t) < 0.0);
            let got = pair_time(dr, dv, da, sigma, horizon, SPEEDS);
            match (scan, got) {
                (Some(s), Some(t)) => {
                    met += 1;
                    assert!(t <= s && s - t <= step * (1.0 + 1e-9), "case {case}: {t} against the scan's {s}");
                }
                (None, None) => {}
                _ => panic!("case {case}: {got:?} against the scan's {scan:?} ({dr} {dv} {da} σ {sigma})"),
            }
        }
        eprintln!("{met} of 400 pairs meet");
        assert!(met > 100, "the cases meet often enough to test: {met}");
    }
}
