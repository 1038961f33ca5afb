//! The resting contacts of a small island, solved exactly when the Gauss–Seidel passes do not
//! converge.
//!
//! Projected Gauss–Seidel gains, on a light ball pressed between a wall and a heavy ball, only a
//! factor `m_light/m_heavy` of the remaining error a pass: each pass can move the pair's impulse
//! by what the light ball's mass allows. A 1 kg, 2 cm ball pinned to a wall by a 1,000 kg ball at
//! e = 0 (every impact plastic, so both must end at rest) kept the impulse the last span's solve
//! left as its warm start, and the heavy ball left at 3.0 m/s after
//! [`MAX_RESTING_PASSES`](super::MAX_RESTING_PASSES) passes.
//! The passes are the right tool for a pile of a thousand balls; a few touching balls are one
//! small linear complementarity problem, which this solves directly.
//!
//! After the passes reached their cap, every island of touching balls (balls joined by their
//! active pair contacts; walls join nothing) of at most [`MAX_ISLAND_CONTACTS`] contacts whose
//! passes left more than the tolerance is solved as the LCP the passes iterate on: with the
//! island's current impulses taken out of the velocities (`v₀`), find `λ ≥ 0` with
//! `w = J·v₀ − target + A·λ ≥ 0` and `λᵀw = 0`, `A = J·M⁻¹·Jᵀ`. Principal pivoting with the
//! least-index rule (Murty 1974) from the passes' active set: for a P-matrix (`A` positive
//! definite; regularised by a ten-billionth of its diagonal when a redundant contact makes it
//! singular) it ends in finitely many pivots at the unique solution, whatever the order of the
//! contacts (to rounding). An island whose pivoting does not end within its cap keeps the passes' impulses.
//! Only velocities and the contacts' impulses change, as in a pass.

use glam::DVec2;

use super::contact_solver::{Contact, WALL};
use super::sleep::Islands;

/// Largest island (in contacts) solved directly: a dense `m × m` system, `m³/6` a factorisation.
pub const MAX_ISLAND_CONTACTS: usize = 32;

/// Pivots allowed per island contact before its pivoting is given up.
const PIVOTS_PER_CONTACT: usize = 4;

/// Whether, and to what tolerance, a solver solves the islands of its resting contacts directly
/// after its resting passes ([`solve_resting_islands`]): `converged` whether the passes met
/// their `tolerance` before their cap, `active` the resting contacts, `weighed` whether a uniform
/// acceleration acts. Every solver (lockstep's contact solver, the resting phase of its elastic
/// passes, the threaded monitor's solver) asks this, so they decide alike:
/// - where the passes reached their cap, the islands they left off target, to `tolerance`;
/// - when a few contacts rest in all (at most [`MAX_ISLAND_CONTACTS`]) under a uniform
///   acceleration, every island exactly (tolerance 0). The passes, converged to their tolerance
///   (a thousandth of g·h a pass), still depend on the order they take the contacts in: a pyramid
///   of three balls released on a frictionless floor came out of lockstep (and of the threaded
///   monitor) with its bottom balls at −1.2013297 and 1.2013300 m/s after 1.5 s, the ties of its
///   contacts' heights broken by index. Solved exactly, a few balls come out mirror images to
///   rounding. A pile is one island too big for it; its passes are as before. Not without a
///   uniform acceleration: then no contact carries weight, and the resting targets only close
///   overlaps of a rounding, which the exact solve turns into balls parting at 1e-12 m/s (a row
///   of touching balls struck plastically from both ends, no gravity: 1.75e-12 m/s where the
///   rounds have them at rest to 3e-15);
/// - otherwise none (`None`).
pub fn islands_after_passes(converged: bool, active: u64, weighed: bool, tolerance: f64) -> Option<f64> {
    if !converged {
        Some(tolerance)
    } else if weighed && active <= MAX_ISLAND_CONTACTS as u64 {
        Some(0.0)
    } else {
        None
    }
}

/// Scratch of [`solve_resting_islands`], kept to reuse the memory.
#[derive(Clone, Debug, Default)]
pub struct RestingIslands {
    islands: Islands,
    /// Every active contact `(root of its island, list, index)`, sorted by island (stably: list
    /// order within one).
    members: Vec<(u32, u32, u32)>,
    /// Active contacts of each island, by root.
    sizes: Vec<u32>,
    a: Vec<f64>,
    q: Vec<f64>,
    lambda: Vec<f64>,
    basic: Vec<bool>,
    factor: Vec<f64>,
    rhs: Vec<f64>,
    set: Vec<usize>,
}

/// Solves the islands of `lists`' active contacts (see the module comment) whose resting passes
/// left a contact off its target by more than `tolerance` (m/s, as the passes measure a change):
/// `v` the velocities the contacts index (whole, base 0, with `n` balls). Returns how many islands
/// it solved.
pub fn solve_resting_islands(
    lists: &mut [Vec<Contact>],
    v: &mut [DVec2],
    n: usize,
    tolerance: f64,
    s: &mut RestingIslands,
) -> u64 {
    s.islands.reset(n);
    for c in lists.iter().flatten().filter(|c| c.active && c.b != WALL) {
        s.islands.join(c.a, c.b);
    }
    // Each island's contacts counted first: only the small islands' are gathered and sorted (a
    // settled pile is one island of thousands of contacts, which the passes keep; sorting them
    // all took a twentieth of the monitor's solve there).
    s.sizes.clear();
    s.sizes.resize(n, 0);
    for c in lists.iter().flatten().filter(|c| c.active) {
        let root = s.islands.find(c.a) as usize;
        s.sizes[root] += 1;
    }
    s.members.clear();
    for (l, list) in lists.iter().enumerate() {
        for (k, c) in list.iter().enumerate().filter(|(_, c)| c.active) {
            let root = s.islands.find(c.a);
            if s.sizes[root as usize] as usize <= MAX_ISLAND_CONTACTS {
                s.members.push((root, l as u32, k as u32));
            }
        }
    }
    s.members.sort_by_key(|m| m.0);
    let mut solved = 0;
    let mut start = 0;
    let members = std::mem::take(&mut s.members);
    while start < members.len() {
        let root = members[start].0;
        let end = start + members[start..].iter().take_while(|m| m.0 == root).count();
        let island = &members[start..end];
        start = end;
        if island.len() > MAX_ISLAND_CONTACTS || off_target(lists, island, v) <= tolerance {
            continue;
        }
        if solve_island(lists, island, v, s) {
            solved += 1;
        }
    }
    s.members = members;
    solved
}

fn contact<'a>(lists: &'a [Vec<Contact>], m: &(u32, u32, u32)) -> &'a Contact {
    &lists[m.1 as usize][m.2 as usize]
}

fn normal_speed(c: &Contact, v: &[DVec2]) -> f64 {
    let vb = if c.b == WALL { DVec2::ZERO } else { v[c.b as usize] };
    (vb - v[c.a as usize]).dot(c.normal)
}

/// How far the island's contacts are from the complementarity the passes aim at: a contact
/// pushing (`λ > 0`) off its target either way, or one not pushing below it.
fn off_target(lists: &[Vec<Contact>], island: &[(u32, u32, u32)], v: &[DVec2]) -> f64 {
    island.iter().fold(0.0f64, |worst, m| {
        let c = contact(lists, m);
        let w = normal_speed(c, v) - c.target;
        worst.max(if c.impulse > 0.0 { w.abs() } else { (-w).max(0.0) })
    })
}

/// The coupling of contacts `i` and `j` through their shared balls: `(J·M⁻¹·Jᵀ)_ij`.
fn coupling(ci: &Contact, cj: &Contact) -> f64 {
    let mut sum = 0.0;
    // A contact pushes a with −n and b with +n.
    for (bi, si, wi) in [(ci.a, -1.0, ci.inverse_mass_a), (ci.b, 1.0, ci.inverse_mass_b)] {
        if bi == WALL {
            continue;
        }
        for (bj, sj) in [(cj.a, -1.0), (cj.b, 1.0)] {
            if bj == bi {
                sum += si * sj * wi * ci.normal.dot(cj.normal);
            }
        }
    }
    sum
}

/// Solves one island's LCP (see the module comment) and applies it; false if the pivoting did not
/// end within its cap (nothing changed then).
fn solve_island(
    lists: &mut [Vec<Contact>],
    island: &[(u32, u32, u32)],
    v: &mut [DVec2],
    s: &mut RestingIslands,
) -> bool {
    let m = island.len();
    s.a.clear();
    s.a.resize(m * m, 0.0);
    for i in 0..m {
        for j in 0..m {
            s.a[i * m + j] = coupling(contact(lists, &island[i]), contact(lists, &island[j]));
        }
    }
    // q = J·v₀ − target, v₀ the velocities without the island's impulses.
    s.q.clear();
    for (i, mi) in island.iter().enumerate() {
        let c = contact(lists, mi);
        let mut vn = normal_speed(c, v);
        for (j, mj) in island.iter().enumerate() {
            vn -= s.a[i * m + j] * contact(lists, mj).impulse;
        }
        s.q.push(vn - c.target);
    }
    if s.q.iter().any(|q| !q.is_finite()) {
        return false;
    }
    let scale = s.q.iter().fold(0.0f64, |x, q| x.max(q.abs()));
    let slack = 1e-12 * scale + f64::MIN_POSITIVE;
    s.basic.clear();
    s.basic.extend(island.iter().map(|mi| contact(lists, mi).impulse > 0.0));
    s.lambda.clear();
    s.lambda.resize(m, 0.0);
    let mut ended = false;
    let mut regularised = false;
    for _ in 0..PIVOTS_PER_CONTACT * m + 8 {
        if !basic_solution(s, m) {
            // A redundant contact (more contacts than the balls' freedoms) makes `A` singular:
            // regularised by a ten-billionth of its largest diagonal, once.
            if regularised {
                break;
            }
            regularised = true;
            let largest = (0..m).fold(0.0f64, |d, i| d.max(s.a[i * m + i]));
            for i in 0..m {
                s.a[i * m + i] += 1e-10 * largest;
            }
            continue;
        }
        // The least index whose complementary solution is infeasible changes sides.
        let mut flip = None;
        for i in 0..m {
            let infeasible = if s.basic[i] {
                s.lambda[i] < 0.0
            } else {
                let w = s.q[i] + (0..m).map(|j| s.a[i * m + j] * s.lambda[j]).sum::<f64>();
                w < -slack
            };
            if infeasible {
                flip = Some(i);
                break;
            }
        }
        match flip {
            Some(i) => s.basic[i] = !s.basic[i],
            None => {
                ended = true;
                break;
            }
        }
    }
    // A non-finite target (a span of zero length leaves a gap's target at −∞) or velocity has
    // no solution to take: the passes' impulses stay.
    if !ended || s.lambda.iter().any(|l| !l.is_finite()) {
        return false;
    }
    for (i, mi) in island.iter().enumerate() {
        let c = &mut lists[mi.1 as usize][mi.2 as usize];
        let delta = s.lambda[i] - c.impulse;
        c.impulse = s.lambda[i];
        v[c.a as usize] -= (delta * c.inverse_mass_a) * c.normal;
        if c.b != WALL {
            v[c.b as usize] += (delta * c.inverse_mass_b) * c.normal;
        }
    }
    true
}

/// The complementary basic solution of the current sides: `λ_B = −A_BB⁻¹·q_B`, zero off `B`
/// (Cholesky). False if the factorisation fails (`A_BB` not positive definite).
fn basic_solution(s: &mut RestingIslands, m: usize) -> bool {
    s.set.clear();
    s.set.extend((0..m).filter(|&i| s.basic[i]));
    let k = s.set.len();
    s.lambda.iter_mut().for_each(|l| *l = 0.0);
    if k == 0 {
        return true;
    }
    s.factor.clear();
    s.factor.resize(k * k, 0.0);
    for r in 0..k {
        for c in 0..=r {
            let mut sum = s.a[s.set[r] * m + s.set[c]];
            for p in 0..c {
                sum -= s.factor[r * k + p] * s.factor[c * k + p];
            }
            if r == c {
                // A pivot lost to rounding is a singular `A_BB`.
                if sum <= 1e-12 * s.a[s.set[r] * m + s.set[r]] || !sum.is_finite() {
                    return false;
                }
                s.factor[r * k + r] = sum.sqrt();
            } else {
                s.factor[r * k + c] = sum / s.factor[c * k + c];
            }
        }
    }
    // L·y = −q_B, then Lᵀ·x = y.
    s.rhs.clear();
    for r in 0..k {
        let mut sum = -s.q[s.set[r]];
        for p in 0..r {
            sum -= s.factor[r * k + p] * s.rhs[p];
        }
        s.rhs.push(sum / s.factor[r * k + r]);
    }
    for r in (0..k).rev() {
        let mut sum = s.rhs[r];
        for p in r + 1..k {
            sum -= s.factor[p * k + r] * s.rhs[p];
        }
        s.rhs[r] = sum / s.factor[r * k + r];
    }
    for (r, &i) in s.set.iter().enumerate() {
        s.lambda[i] = s.rhs[r];
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::field::Wall;

    fn contact(a: u32, b: u32, normal: DVec2, wa: f64, wb: f64, target: f64, impulse: f64) -> Contact {
        Contact {
            a,
            b,
            normal,
            reach: 1.0,
            size: 1.0,
            plane: 0.0,
            tau: 0.0,
            persistent: true,
            bias: 0.0,
            inverse_mass_a: wa,
            inverse_mass_b: wb,
            restitution: 0.0,
            impulse,
            target,
            impact: 0.0,
            active: true,
            wall: Wall::Left,
            key: 0,
        }
    }

    /// A 100 kg ball resting on two 1 kg balls on the floor, mirror images of each other about
    /// the heavy ball's vertical, the heavy one falling at 2 m/s into them and every impulse
    /// warm-started wrong: solved, nothing approaches any more, the two light balls mirror each
    /// other to rounding, and listing the contacts the other way round gives the same answer.
    /// Seen to fail with the coupling of two contacts taken without the cosine of their normals
    /// (a contact still approached at 65 m/s).
    #[test]
    fn an_island_comes_out_mirror_symmetric_in_any_order() {
        let (w_heavy, w_light) = (1e-2, 1.0);
        // Balls: 0 heavy on top, 1 left, 2 right; a pair's normal from its light ball up to the
        // heavy one, the floor's out of the field.
        let up_right = DVec2::new(0.5, 0.75f64.sqrt());
        let up_left = DVec2::new(-0.5, 0.75f64.sqrt());
        let contacts = vec![
            contact(1, WALL, DVec2::NEG_Y, w_light, 0.0, 0.0, 3.0),
            contact(2, WALL, DVec2::NEG_Y, w_light, 0.0, 0.0, 40.0),
            contact(1, 0, up_right, w_light, w_heavy, 0.0, 7.0),
            contact(2, 0, up_left, w_light, w_heavy, 0.0, 0.5),
        ];
        let solve = |list: Vec<Contact>| {
            let mut lists = vec![list];
            let mut v = vec![DVec2::new(0.0, -2.0), DVec2::ZERO, DVec2::ZERO];
            // The velocities as the warm starts left them.
            for c in &lists[0] {
                v[c.a as usize] -= c.impulse * c.inverse_mass_a * c.normal;
                if c.b != WALL {
                    v[c.b as usize] += c.impulse * c.inverse_mass_b * c.normal;
                }
            }
            let mut s = RestingIslands::default();
            assert_eq!(solve_resting_islands(&mut lists, &mut v, 3, 1e-9, &mut s), 1);
            (lists.remove(0), v)
        };
        let (forward, v) = solve(contacts.clone());
        let (mut backward, vb) = solve(contacts.iter().rev().copied().collect());
        backward.reverse();
        for c in &forward {
            let vn = (if c.b == WALL { DVec2::ZERO } else { v[c.b as usize] } - v[c.a as usize]).dot(c.normal);
            assert!(vn > -1e-12, "a contact still approaches at {vn}");
        }
        assert!((v[1].x + v[2].x).abs() < 1e-12 && (v[1].y - v[2].y).abs() < 1e-12, "not a mirror image: {v:?}");
        assert!(v[0].x.abs() < 1e-12, "the heavy ball moves sideways: {}", v[0]);
        for (f, b) in forward.iter().zip(&backward) {
            assert!(
                (f.impulse - b.impulse).abs() <= 1e-12 * f.impulse.abs().max(1.0),
                "{} against {}",
                f.impulse,
                b.impulse
            );
        }
        assert!((forward[2].impulse - forward[3].impulse).abs() < 1e-12 * forward[2].impulse);
        assert!((v[0] - vb[0]).length() < 1e-12);
    }

    /// A 1 kg ball against the left wall and a 1,000 kg ball pressing on it at 20 m/s, the pair's
    /// impulse far too large from a warm start (the heavy ball sent back at 3 m/s): solved, both
    /// stop, the wall takes the heavy ball's momentum. Seen to fail with the islands left alone
    /// (none solved) and with the coupling taken without the normals' cosine.
    #[test]
    fn a_light_ball_pinned_by_a_heavy_one_stops_both() {
        let mut lists = vec![vec![
            contact(0, WALL, DVec2::NEG_X, 1.0, 0.0, 0.0, 5_000.0),
            contact(0, 1, DVec2::X, 1.0, 1e-3, 0.0, 23_000.0),
        ]];
        // Velocities as the warm-started, unconverged passes left them: the heavy ball leaves.
        let mut v = vec![DVec2::new(-1.0, 0.0), DVec2::new(3.0, 0.0)];
        // Take the impulses out: the velocities before them (what the LCP sees).
        let v0 = [v[0] + DVec2::new(23_000.0 - 5_000.0, 0.0), v[1] - DVec2::new(23.0, 0.0)];
        let mut s = RestingIslands::default();
        assert_eq!(solve_resting_islands(&mut lists, &mut v, 2, 1e-6, &mut s), 1);
        // Momentum: the heavy ball's 1,000 kg·(v0) and the light one's go to the wall.
        assert!(v[0].length() < 1e-9 && v[1].length() < 1e-9, "left moving: {v:?}");
        let wall = lists[0][0].impulse;
        let expected = -(v0[0].x * 1.0 + v0[1].x * 1000.0);
        assert!((wall - expected).abs() < 1e-9 * expected.abs(), "wall {wall}, expected {expected}");
    }
}
