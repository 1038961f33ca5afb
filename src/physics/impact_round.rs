//! Simultaneous impacts: contacts struck at one instant, solved together.
//!
//! A ball that strikes two touching balls between them, at one instant, meets both at once.
//! Taken one after the other, the first impact deflects the striking ball before the second is
//! seen, so the result depends on which is taken first (on the balls' numbering) and a
//! mirror-symmetric collision comes out lopsided. Solved together they give the symmetric
//! answer. It is the one impact round of every engine: the stepped solver's rounds
//! (`contact_solver.rs`, lockstep and the threaded monitor) and the exact engine's simultaneous
//! impacts (`engine/exact/world.rs`) call [`solve_simultaneous`]. Accumulated impulses
//! `λ ≥ 0` with `v_n⁺ ≥ −e·v_n⁻` and complementarity, by Jacobi sweeps in which each ball's mass
//! is split among its contacts (Tonge et al. 2012). Every update of a sweep is computed from the same velocities, so the
//! order of the contacts does not matter. A round of contacts that share no ball is one binary
//! collision each, solved in one sweep; for e = 1 the converged round keeps the energy (each
//! contact reverses its normal velocity).

use glam::DVec2;

use super::contact_solver::MAX_ROUND_ITERATIONS;

/// One contact of a round: ball `a` and ball `b` (`None`: an immovable support), the unit
/// normal from `a` to `b`, the inverse masses, the normal speed's bias, and the target normal
/// speed after the impact (`−e·v_n⁻`). `impulse` is the solution (N·s along `normal`, on `b`;
/// `−impulse` on `a`), accumulated from the value it comes in with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundContact {
    /// Index of ball a in the velocities.
    pub a: usize,
    /// Index of ball b, or `None` for an immovable support (a wall, a ball at rest).
    pub b: Option<usize>,
    /// Unit normal from a to b.
    pub normal: DVec2,
    /// 1/m of a.
    pub inverse_mass_a: f64,
    /// 1/m of b (0 for a support).
    pub inverse_mass_b: f64,
    /// Added to the normal speed `(v_b − v_a)·n` wherever it is judged (the stepped solver's
    /// wall bias; 0 elsewhere).
    pub bias: f64,
    /// The normal speed (with its bias) the impact aims at: `−e·v_n⁻`.
    pub target: f64,
    /// The impulse found.
    pub impulse: f64,
    /// The last sweep's change of `impulse` (scratch).
    pub delta: f64,
    /// The contact's share of its balls' split masses, `k_a/m_a + k_b/m_b` with `k` the ball's
    /// contacts in the round (scratch: set by [`solve_simultaneous`]).
    pub split: f64,
}

impl RoundContact {
    /// A contact of ball `a` with ball `b` (or an immovable support) along `normal`, no bias, its
    /// target and impulse zero (the caller sets the target before a round).
    pub fn new(a: usize, b: Option<usize>, normal: DVec2, inverse_mass_a: f64, inverse_mass_b: f64) -> Self {
        RoundContact {
            a,
            b,
            normal,
            inverse_mass_a,
            inverse_mass_b,
            bias: 0.0,
            target: 0.0,
            impulse: 0.0,
            delta: 0.0,
            split: 0.0,
        }
    }

    /// The normal speed with its bias.
    #[inline(always)]
    fn normal_speed(&self, v: &[DVec2]) -> f64 {
        let vb = self.b.map_or(DVec2::ZERO, |b| v[b]);
        (vb - v[self.a]).dot(self.normal) + self.bias
    }
}

/// Scratch of [`solve_simultaneous`], per ball of the velocities: kept by a caller that solves
/// many rounds, to reuse the memory (sized on demand).
#[derive(Clone, Debug, Default)]
pub struct RoundScratch {
    /// Contacts of the round on each ball (zero between rounds).
    counts: Vec<u32>,
    /// The round's groups: a union–find over the round's balls (valid for them alone).
    parent: Vec<u32>,
    /// Each contact's group in its high bits, its index in the low: sorted, the groups in turn.
    keys: Vec<u64>,
    /// One group's contacts while its sweeps run.
    group: Vec<RoundContact>,
    /// Every round swept as one group (see [`RoundScratch::whole_rounds`]).
    whole: bool,
}

impl RoundScratch {
    /// Scratch whose rounds are swept whole, every contact until the slowest group has converged
    /// (as every round was before 2026-12-06): the exact engine's. With its groups swept apart,
    /// its 150-ball pile (`tests/exact_pile.rs`) grinds at high restitution: 2.3e7 events in a
    /// half second at e = 0.9 (seed 2), and at seed 5 it stood at 3.8 s simulated after a minute
    /// (docs/accuracy/exact.md). The groups' answers differ from the whole round's only within
    /// the tolerance, 1e-14 of the largest approach, so its rest and collapse tests hinge on
    /// differences that small. (The pile's hang when this was first tried was, at least in part,
    /// a loop in the exact engine's gathering of a round, since mended.)
    pub fn whole_rounds() -> Self {
        RoundScratch { whole: true, ..Self::default() }
    }

    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }
}

/// Solves `contacts` together, changing the velocities `v` (indexed by the contacts' balls):
/// each contact's impulse is `≥ 0` and brings its normal speed to at least its target, with
/// complementarity. `s` is scratch (see [`RoundScratch`]).
///
/// The round falls into groups of contacts joined through shared balls, and no impulse of one
/// group reaches another: each group's sweeps run on their own, until none of its contacts
/// changes a relative speed by more than `1e-14` of the round's largest approach plus `slack`.
/// A group's answer so does not wait on what else strikes in the same round (a pile struck in
/// ten places at once is ten places' work, not the slowest place's sweeps over all of them: on
/// the landing 1,024-ball pile, rounds of 70 contacts took 40 sweeps each where most of their
/// groups need one); it depends on the others only through that tolerance. Returns false if a
/// group's sweeps reach [`MAX_ROUND_ITERATIONS`] first.
pub fn solve_simultaneous(contacts: &mut [RoundContact], v: &mut [DVec2], s: &mut RoundScratch, slack: f64) -> bool {
    if s.counts.len() < v.len() {
        s.counts.resize(v.len(), 0);
        s.parent.resize(v.len(), 0);
    }
    let mut shared = false;
    let mut scale = 0.0f64;
    for c in contacts.iter() {
        for i in std::iter::once(c.a).chain(c.b) {
            s.counts[i] += 1;
            shared |= s.counts[i] > 1;
            s.parent[i] = i as u32;
        }
        scale = scale.max(-c.normal_speed(v));
    }
    // One tolerance for the whole round: a group's own approach can be far below the rounding of
    // its balls' velocities (a group closing at 1e-9 m/s among balls at 1 m/s), and a tolerance
    // scaled to it alone could never be met.
    let tolerance = 1e-14 * scale + slack;
    let converged = if shared && !s.whole {
        solve_groups(contacts, v, s, tolerance)
    } else {
        sweeps(contacts, v, &s.counts, tolerance)
    };
    for c in contacts.iter() {
        for i in std::iter::once(c.a).chain(c.b) {
            s.counts[i] = 0;
        }
    }
    converged
}

/// [`solve_simultaneous`]'s groups, each by its own sweeps, the contacts' order kept within
/// each (so a group's velocities take their changes in the order they would in one sweep of
/// the whole round, to the bit).
fn solve_groups(contacts: &mut [RoundContact], v: &mut [DVec2], s: &mut RoundScratch, tolerance: f64) -> bool {
    for c in contacts.iter() {
        if let Some(b) = c.b {
            let (ra, rb) = (s.find(c.a as u32), s.find(b as u32));
            // The larger root joins the smaller: the same groups whatever the contacts' order.
            let (low, high) = if ra <= rb { (ra, rb) } else { (rb, ra) };
            s.parent[high as usize] = low;
        }
    }
    s.keys.clear();
    for (k, c) in contacts.iter().enumerate() {
        let root = s.find(c.a as u32);
        s.keys.push((u64::from(root) << 32) | k as u64);
    }
    s.keys.sort_unstable();
    let root = |key: u64| key >> 32;
    if root(s.keys[0]) == root(s.keys[s.keys.len() - 1]) {
        return sweeps(contacts, v, &s.counts, tolerance);
    }
    let mut converged = true;
    let mut start = 0;
    while start < s.keys.len() {
        let group_root = root(s.keys[start]);
        let end = start + s.keys[start..].iter().take_while(|&&key| root(key) == group_root).count();
        s.group.clear();
        s.group.extend(s.keys[start..end].iter().map(|&key| contacts[key as u32 as usize]));
        converged &= sweeps(&mut s.group, v, &s.counts, tolerance);
        for (&key, c) in s.keys[start..end].iter().zip(&s.group) {
            contacts[key as u32 as usize] = *c;
        }
        start = end;
    }
    converged
}

/// The Jacobi sweeps over `contacts` (one group, or contacts that share no ball), `counts` each
/// ball's contacts in the round, until no contact's relative speed changes by more than
/// `tolerance`.
fn sweeps(contacts: &mut [RoundContact], v: &mut [DVec2], counts: &[u32], tolerance: f64) -> bool {
    let mut shared = false;
    // The counts hold through the sweeps: each contact's split is found once, the same bits as
    // in every sweep, instead of from both balls' counts in each. (The monitor's solver on the
    // landing `pile`, 4.75–7.5 s, two runs each way alternating: 1.04 / 1.06 ms a solve against
    // 1.13 / 1.10 ms, every tally and energy the same.)
    for c in contacts.iter_mut() {
        let ka = counts[c.a];
        let kb = c.b.map_or(0, |b| counts[b]);
        shared |= ka > 1 || kb > 1;
        c.split = f64::from(ka) * c.inverse_mass_a + f64::from(kb) * c.inverse_mass_b;
    }
    for _ in 0..MAX_ROUND_ITERATIONS {
        let mut largest = 0.0f64;
        for c in contacts.iter_mut() {
            let vn = c.normal_speed(v);
            let impulse = (c.impulse + (c.target - vn) / c.split).max(0.0);
            c.delta = impulse - c.impulse;
            c.impulse = impulse;
            // A comparison, not `f64::max`: the same value (a NaN change is skipped either way),
            // but one `maxsd` on the sweep's loop-carried chain instead of `max`'s NaN handling.
            let change = c.delta.abs() * (c.inverse_mass_a + c.inverse_mass_b);
            if change > largest {
                largest = change;
            }
        }
        for c in contacts.iter() {
            v[c.a] -= (c.delta * c.inverse_mass_a) * c.normal;
            if let Some(b) = c.b {
                v[b] += (c.delta * c.inverse_mass_b) * c.normal;
            }
        }
        // Without shared balls one sweep is the exact answer.
        if !shared || largest <= tolerance {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact(a: usize, b: Option<usize>, normal: DVec2, target: f64) -> RoundContact {
        let inverse_mass_b = if b.is_some() { 1.0 } else { 0.0 };
        RoundContact { target, ..RoundContact::new(a, b, normal, 1.0, inverse_mass_b) }
    }

    /// A ball at 5 m/s into two touching balls at ±30°, e = 1: B and C leave as mirror images, A
    /// straight on, and the energy is kept.
    #[test]
    fn a_strike_between_two_balls_is_symmetric_and_elastic() {
        let mut v = vec![DVec2::new(5.0, 0.0), DVec2::ZERO, DVec2::ZERO];
        let (n1, n2) = (DVec2::new(0.75f64.sqrt(), 0.5), DVec2::new(0.75f64.sqrt(), -0.5));
        let mut cs = [contact(0, Some(1), n1, n1.dot(v[0])), contact(0, Some(2), n2, n2.dot(v[0]))];
        let mut scratch = RoundScratch::default();
        assert!(solve_simultaneous(&mut cs, &mut v, &mut scratch, 0.0));
        assert!((v[1].x - v[2].x).abs() < 1e-14 && (v[1].y + v[2].y).abs() < 1e-14, "{v:?}");
        assert_eq!(v[0].y, 0.0);
        let energy: f64 = v.iter().map(|u| u.length_squared()).sum();
        assert!((energy - 25.0).abs() < 1e-12, "energy {energy}");
        for c in &cs {
            assert!((c.normal_speed(&v) - c.target).abs() < 1e-12);
        }
    }

    /// A round's groups are solved each on its own: a strike between two touching balls comes
    /// out of a round that also holds a long chain (which takes many more sweeps) exactly as
    /// it does alone, to the bit, and so does the chain, whatever the order of the contacts
    /// (the strike's approach is the round's largest, so the tolerance is its own).
    /// (Swept as one group, to the slower part's convergence, the strike came out 9.6e-5 m/s off
    /// its own answer.)
    #[test]
    fn each_group_of_a_round_comes_out_as_it_would_alone() {
        let (n1, n2) = (DVec2::new(0.75f64.sqrt(), 0.5), DVec2::new(0.75f64.sqrt(), -0.5));
        let mut v0 = vec![DVec2::ZERO; 9];
        v0[0] = DVec2::new(5.0, 0.0);
        v0[3] = DVec2::new(4.0, 0.0);
        // The strike: ball 0 between balls 1 and 2, e = 0.5.
        let strike = [contact(0, Some(1), n1, 0.5 * n1.dot(v0[0])), contact(0, Some(2), n2, 0.5 * n2.dot(v0[0]))];
        // The chain: ball 3 into a row of five touching balls, e = 0.5 on the first contact.
        let chain: Vec<RoundContact> =
            (3..8).map(|i| contact(i, Some(i + 1), DVec2::X, if i == 3 { 2.0 } else { 0.0 })).collect();
        let slack = 1e-3;
        let alone = |cs: &[RoundContact]| {
            let (mut cs, mut v) = (cs.to_vec(), v0.clone());
            solve_simultaneous(&mut cs, &mut v, &mut RoundScratch::default(), slack);
            v
        };
        let (strike_alone, chain_alone) = (alone(&strike), alone(&chain));
        // Interleaved, the chain first: the groups' order in the round is not theirs.
        let mut both = vec![chain[0], strike[1], chain[1], chain[2], strike[0], chain[3], chain[4]];
        let mut v = v0.clone();
        assert!(solve_simultaneous(&mut both, &mut v, &mut RoundScratch::default(), slack));
        for i in 0..3 {
            assert_eq!(v[i], strike_alone[i], "ball {i} of the strike: {v:?}");
        }
        for i in 3..9 {
            assert_eq!(v[i], chain_alone[i], "ball {i} of the chain: {v:?}");
        }
    }

    /// Contacts that share no ball are each the binary collision, in one sweep.
    #[test]
    fn separate_contacts_are_binary_collisions() {
        let mut v = vec![DVec2::new(2.0, 0.0), DVec2::ZERO, DVec2::new(0.0, -1.0)];
        let mut cs = [contact(0, Some(1), DVec2::X, 0.5 * 2.0), contact(2, None, DVec2::NEG_Y, 0.5)];
        let mut scratch = RoundScratch::default();
        assert!(solve_simultaneous(&mut cs, &mut v, &mut scratch, 0.0));
        // Equal masses at e = 0.5: a keeps 0.5 m/s, b takes 1.5 m/s; the wall returns 0.5 m/s.
        assert_eq!((v[0].x, v[1].x, v[2].y), (0.5, 1.5, 0.5));
    }
}
