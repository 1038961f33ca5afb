//! The per-step list of force passes built from the effects a scene turns on.
//!
//! An effect that is off is simply not in the list, so it costs nothing: no O(n²) attraction
//! loop when attraction is off, no square root for drag in vacuum.

use glam::DVec2;

use super::barnes_hut::BarnesHut;
use super::effects::{
    Attraction, Drag, Effects, attraction_pair, cap_drag_rate, drag_force, drag_rate, drag_rate_bound,
};

/// Per-ball constants that forces need, as parallel slices indexed like the state.
#[derive(Clone, Copy, Debug)]
pub struct BodyProps<'a> {
    /// Each ball's mass, kg (positive).
    pub mass: &'a [f64],
    /// Each ball's `1/mass`, 1/kg: kept beside the mass so the passes multiply instead of divide.
    pub inverse_mass: &'a [f64],
    /// Each ball's diameter, m (positive).
    pub diameter: &'a [f64],
}

/// One ball's constants, for the passes evaluated on one ball alone ([`Forces::on_ball`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallProps {
    /// Mass, kg (positive).
    pub mass: f64,
    /// `1/mass`, 1/kg.
    pub inverse_mass: f64,
    /// Diameter, m (positive).
    pub diameter: f64,
}

/// A force applied to one ball, e.g. the player's pull on the key ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointForce {
    /// The ball's index in the state the force passes run on; it must be in range (the passes
    /// index with it and panic otherwise).
    pub index: usize,
    /// The force, N.
    pub force: DVec2,
}

/// The other balls' pull on one ball, for the passes evaluated on that ball alone
/// ([`Forces::on_ball`]): a tree split's far force plus its near balls, or a direct sum over the
/// others' last known states — whatever the engine holds.
pub trait OtherBalls {
    /// Their force (N), under `attraction`, on a ball of `mass` and `radius` at `x`.
    fn force_at(&self, x: DVec2, mass: f64, radius: f64, attraction: &Attraction) -> DVec2;
}

impl<T: OtherBalls + ?Sized> OtherBalls for &T {
    #[inline]
    fn force_at(&self, x: DVec2, mass: f64, radius: f64, attraction: &Attraction) -> DVec2 {
        (**self).force_at(x, mass, radius, attraction)
    }
}

/// No other balls: for passes on one ball whose engine leaves the others' pull out (the
/// threaded monitor's prediction of a ball's free motion; the ball's thread takes attraction from
/// the tree).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NoOtherBalls;

impl OtherBalls for NoOtherBalls {
    #[inline]
    fn force_at(&self, _: DVec2, _: f64, _: f64, _: &Attraction) -> DVec2 {
        DVec2::ZERO
    }
}

/// The force passes on one ball alone (see [`Forces::on_ball`]).
#[derive(Clone, Copy, Debug)]
pub struct BallForces<'a, O> {
    forces: &'a Forces,
    ball: BallProps,
    pull: DVec2,
    others: O,
    drag_rate_limit: f64,
}

impl<O: OtherBalls> BallForces<'_, O> {
    /// The ball's acceleration at `x` moving at `v`: the passes of [`Forces::accelerations`] in
    /// the same order (gravity, drag under its rate limit, attraction from the other balls, then
    /// the pull).
    #[inline]
    pub fn acceleration(&self, x: DVec2, v: DVec2) -> DVec2 {
        self.sum::<true>(x, v)
    }

    /// The largest drag rate the ball at `x` moving at `v` can meet (see
    /// [`crate::physics::drag_rate_bound`]): at its speed now, or at the terminal speed gravity,
    /// attraction and the pull drive it to. 0 with drag off.
    #[inline]
    pub fn drag_rate(&self, x: DVec2, v: DVec2) -> f64 {
        let Some(drag) = self.forces.drag() else { return 0.0 };
        drag_rate_bound(v, self.sum::<false>(x, v), self.ball.diameter, self.ball.mass, &drag)
    }

    /// The same, with the drag pass's rate capped at `limit` (1/s) for this ball: the guard rail of
    /// [`Forces::set_drag_rate_limit`], set per ball (from the step policy's
    /// [`crate::physics::SubSteps::drag_rate_limit`]) rather than for the whole field.
    #[inline]
    pub fn with_drag_rate_limit(self, limit: f64) -> Self {
        BallForces { drag_rate_limit: limit, ..self }
    }

    /// Whether no force acts on the ball at all (no pass, no pull): every integrator then reduces
    /// to a straight drift, as lockstep's integration takes it.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.forces.is_empty() && self.pull == DVec2::ZERO
    }

    /// The other balls, as given to [`Forces::on_ball`].
    #[inline]
    pub fn others(&self) -> &O {
        &self.others
    }

    /// Whether the acceleration depends on velocity (drag is on).
    #[inline]
    pub fn depends_on_velocity(&self) -> bool {
        self.forces.depends_on_velocity()
    }

    /// The acceleration, the drag pass included only when `DRAG`.
    #[inline]
    fn sum<const DRAG: bool>(&self, x: DVec2, v: DVec2) -> DVec2 {
        let BallProps { mass, inverse_mass, diameter } = self.ball;
        let mut acc = DVec2::ZERO;
        for pass in self.forces.passes.iter() {
            match pass {
                ForcePass::Gravity(g) => acc += *g,
                ForcePass::Drag(drag) if DRAG => {
                    let a = drag_force(v, diameter, drag) * inverse_mass;
                    // Under no limit the cap is the identity: its square root is spared, as in
                    // the whole-field pass.
                    let limit = self.drag_rate_limit;
                    acc += if limit.is_finite() { cap_drag_rate(a, v, limit) } else { a };
                }
                ForcePass::Drag(_) => {}
                ForcePass::Attraction(attraction) => {
                    acc += self.others.force_at(x, mass, 0.5 * diameter, attraction) * inverse_mass;
                }
            }
        }
        acc + self.pull * inverse_mass
    }
}

/// The passes in their order, held inline rather than behind a pointer: there are at most three
/// (one per effect), and a ball thread reads them every cycle, after its caches have gone cold
/// under a thousand other threads.
#[derive(Clone, Copy, PartialEq)]
struct PassList {
    passes: [ForcePass; 3],
    len: usize,
}

impl PassList {
    /// Appends a pass (at most one per effect, so never more than there is room for).
    fn push(&mut self, pass: ForcePass) {
        if let Some(slot) = self.passes.get_mut(self.len) {
            *slot = pass;
            self.len += 1;
        }
    }
}

impl Default for PassList {
    fn default() -> Self {
        // The unused slots hold a filler, never read (see `Deref`).
        PassList { passes: [ForcePass::Gravity(DVec2::ZERO); 3], len: 0 }
    }
}

impl std::ops::Deref for PassList {
    type Target = [ForcePass];
    fn deref(&self) -> &[ForcePass] {
        &self.passes[..self.len]
    }
}

impl std::fmt::Debug for PassList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum ForcePass {
    /// Uniform acceleration g (independent of mass).
    Gravity(DVec2),
    Drag(Drag),
    Attraction(Attraction),
}

/// Fields of at least this many balls compute attraction with the Barnes–Hut tree, smaller ones
/// with the direct sum. Measured with `cargo bench --bench attraction` (one force evaluation, the
/// default opening angle, two runs): the two cost the same at 100–128 balls (38–42 µs at 128);
/// the direct sum is 1.6× faster at 50, the tree 1.1× at 160, 2.3× at 500 and 15× at 10,000.
pub const TREE_MIN_BALLS: usize = 128;

/// How the attraction pass sums the pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AttractionMethod {
    /// Every pair, once each (Newton's third law), in index order: O(n²), exact.
    Direct,
    /// The Barnes–Hut tree ([`BarnesHut`]): O(n log n), far groups approximated.
    Tree,
}

impl AttractionMethod {
    /// The method for a field of `balls` balls: the tree from [`TREE_MIN_BALLS`] on, unless the
    /// opening angle is 0 (the direct sum always).
    pub fn choose(balls: usize, attraction: &Attraction) -> Self {
        if attraction.opening_angle > 0.0 && balls >= TREE_MIN_BALLS {
            AttractionMethod::Tree
        } else {
            AttractionMethod::Direct
        }
    }

    /// The pass's name in reports: `attraction (direct)` or `attraction (tree)`.
    pub fn label(self) -> &'static str {
        match self {
            AttractionMethod::Direct => "attraction (direct)",
            AttractionMethod::Tree => "attraction (tree)",
        }
    }
}

/// The force passes that run each step, in a fixed order (gravity, drag, attraction; then the
/// pull, when one is set). Deterministic: the order of floating-point sums never changes.
///
/// Besides the list it keeps scratch memory (the tree) and the fastest orbit rate the attraction
/// pass met since it was last asked for (see [`Forces::take_orbit_rate_squared`]).
#[derive(Clone, Debug, Default)]
pub struct Forces {
    passes: PassList,
    /// `None`: chosen by ball count (see [`AttractionMethod::choose`]).
    method: Option<AttractionMethod>,
    tree: BarnesHut,
    radius: Vec<f64>,
    scratch: Vec<DVec2>,
    orbit_rate_squared: Option<f64>,
    /// With attraction and quadratic drag on: the accelerations before the attraction pass, and
    /// the largest `(|a|·c)²` met since last asked, `a` a ball's acceleration without drag (see
    /// [`Forces::take_terminal_drag_rate`]).
    before_attraction: Vec<DVec2>,
    terminal_drag_rate4: Option<f64>,
    /// Largest drag rate the drag pass applies, 1/s (see [`Forces::set_drag_rate_limit`]).
    drag_rate_limit: f64,
}

impl Forces {
    /// The passes of the effects that are on, in their fixed order (gravity, drag, attraction;
    /// collisions are not a force pass), with no drag rate limit and attraction summed the way
    /// the ball count chooses.
    pub fn new(effects: &Effects) -> Self {
        let mut passes = PassList::default();
        if let Some(g) = effects.gravity {
            passes.push(ForcePass::Gravity(g.g));
        }
        if let Some(d) = effects.drag {
            passes.push(ForcePass::Drag(d));
        }
        if let Some(a) = effects.attraction {
            passes.push(ForcePass::Attraction(a));
        }
        Forces { passes, drag_rate_limit: f64::INFINITY, ..Forces::default() }
    }

    /// A guard rail for drag too stiff for the shortest step the engine takes: the drag pass
    /// then caps each ball's drag rate (`|a_drag|/|v|`) at `limit`, so an explicit stage can stop
    /// a ball but never throw it back faster. Lockstep sets here what the step policy says
    /// ([`crate::physics::SubSteps::drag_rate_limit`]; a ball thread sets it on its own ball,
    /// [`BallForces::with_drag_rate_limit`]): `1/h` for a sub-step whose drag rate the policy
    /// could not bring below `MAX_DRAG_STEP/h` (it splits down to a floor of dt/4,096 only) and
    /// `+∞` otherwise — the default, under which the pass is exactly the plain formula.
    /// Found by tests/fuzz.rs: a 1 g ball of 1 m thrown to 1e5 m/s by a 5e5 kg grain with G = 1
    /// meets a drag rate of 2e7/s; at the floor's 0.24 µs every stage multiplied its speed by
    /// about −5 and squared it again, to infinity within one sub-step.
    pub fn set_drag_rate_limit(&mut self, limit: f64) {
        self.drag_rate_limit = limit;
    }

    /// Names of the passes that run for a field of `balls` balls, for reports; attraction says
    /// how it is summed (`attraction (direct)` or `attraction (tree)`).
    pub fn pass_names(&self, balls: usize) -> Vec<&'static str> {
        self.passes
            .iter()
            .map(|p| match p {
                ForcePass::Gravity(_) => "gravity",
                ForcePass::Drag(_) => "drag",
                ForcePass::Attraction(a) => self.method.unwrap_or(AttractionMethod::choose(balls, a)).label(),
            })
            .collect()
    }

    /// How attraction is summed for a field of `balls` balls; `None` when attraction is off.
    pub fn attraction_method(&self, balls: usize) -> Option<AttractionMethod> {
        self.passes.iter().find_map(|p| match p {
            ForcePass::Attraction(a) => Some(self.method.unwrap_or(AttractionMethod::choose(balls, a))),
            _ => None,
        })
    }

    /// Fixes how attraction is summed whatever the ball count (benches and tests); `None` goes
    /// back to the automatic choice.
    pub fn set_attraction_method(&mut self, method: Option<AttractionMethod>) {
        self.method = method;
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

    /// The largest `ω²` (see [`crate::physics::attraction_rate_squared`]) the attraction pass met in the force
    /// evaluations since the last call, and forgets it; `None` if there was none (attraction off,
    /// or no evaluation since). Lockstep splits its steps by it without a pass of its own.
    pub fn take_orbit_rate_squared(&mut self) -> Option<f64> {
        self.orbit_rate_squared.take()
    }

    /// With attraction and quadratic drag on: the largest drag rate the balls would meet at the
    /// terminal speed their other forces (gravity, attraction, the pull) drive them to, as met in
    /// the force evaluations since the last call (see [`crate::physics::drag_rate_bound`]), and
    /// forgets it; `None` if there was none. Attraction can pull a light, large ball hard enough
    /// that drag turns stiff within one step: lockstep splits its steps by this rate too.
    pub fn take_terminal_drag_rate(&mut self) -> Option<f64> {
        self.terminal_drag_rate4.take().map(|r4| r4.sqrt().sqrt())
    }

    /// Forgets the orbit rate (and terminal drag rate) met so far (the balls changed: they no
    /// longer describe them).
    pub fn forget_orbit_rate(&mut self) {
        self.orbit_rate_squared = None;
        self.terminal_drag_rate4 = None;
    }

    /// The largest `ω²` of the balls at `pos` now (0 with attraction off), and the terminal drag
    /// rate of [`Forces::take_terminal_drag_rate`] (0 without quadratic drag), by one force
    /// evaluation of the attraction pass alone (without the pull, which the evaluation does not
    /// know). For when [`Forces::take_orbit_rate_squared`] has nothing.
    pub fn attraction_rates(&mut self, props: BodyProps<'_>, pos: &[DVec2]) -> (f64, f64) {
        let Some(attraction) = self.attraction_effect() else {
            return (0.0, 0.0);
        };
        let mut acc = std::mem::take(&mut self.scratch);
        acc.clear();
        acc.resize(pos.len(), DVec2::ZERO);
        let worst = self.attraction(props, pos, &attraction, &mut acc);
        let g = self.gravity();
        let terminal =
            self.quadratic_drag().map_or(0.0, |drag| terminal_drag_rate4(props, &drag, |i| acc[i] + g).sqrt().sqrt());
        self.scratch = acc;
        (worst, terminal)
    }

    fn attraction_effect(&self) -> Option<Attraction> {
        self.passes.iter().find_map(|p| match p {
            ForcePass::Attraction(a) => Some(*a),
            _ => None,
        })
    }

    fn gravity(&self) -> DVec2 {
        self.passes
            .iter()
            .find_map(|p| match p {
                ForcePass::Gravity(g) => Some(*g),
                _ => None,
            })
            .unwrap_or(DVec2::ZERO)
    }

    /// The drag, when it is quadratic (the only kind whose rate grows with speed).
    fn quadratic_drag(&self) -> Option<Drag> {
        self.passes.iter().find_map(|p| match p {
            ForcePass::Drag(d @ Drag::Quadratic { .. }) => Some(*d),
            _ => None,
        })
    }

    /// Fills `acc[i]` with the acceleration of ball i in the state (`pos`, `vel`), plus `pull`.
    ///
    /// Attraction is the direct O(n²) sum over pairs, each pair visited once (Newton's third law),
    /// in index order, for fields below [`TREE_MIN_BALLS`]; the Barnes–Hut tree above. `&mut`:
    /// the tree is built in the memory kept here, and the orbit rate met is kept.
    pub fn accelerations(
        &mut self,
        props: BodyProps<'_>,
        pull: Option<PointForce>,
        pos: &[DVec2],
        vel: &[DVec2],
        acc: &mut [DVec2],
    ) {
        let n = pos.len();
        debug_assert!(vel.len() == n && acc.len() == n && props.mass.len() == n);
        acc.fill(DVec2::ZERO);
        // Attraction with quadratic drag: what the drag (after gravity) added is kept aside, to
        // tell each ball's acceleration without it afterwards (the sums in `acc` are untouched).
        let drag = self.quadratic_drag().filter(|_| !self.is_local());
        for k in 0..self.passes.len() {
            match self.passes[k] {
                ForcePass::Attraction(attraction) => {
                    if drag.is_some() {
                        self.before_attraction.clear();
                        self.before_attraction.extend_from_slice(acc);
                    }
                    let worst = self.attraction(props, pos, &attraction, acc);
                    self.orbit_rate_squared = Some(self.orbit_rate_squared.map_or(worst, |w| w.max(worst)));
                }
                pass => local_pass(pass, self.drag_rate_limit, props, vel, acc),
            }
        }
        add_pull(pull, props, acc);
        if let Some(drag) = drag {
            // acc − (gravity + drag) + gravity: gravity, attraction and the pull.
            let (g, before) = (self.gravity(), &self.before_attraction);
            let worst = terminal_drag_rate4(props, &drag, |i| acc[i] - before[i] + g);
            self.terminal_drag_rate4 = Some(self.terminal_drag_rate4.map_or(worst, |w| w.max(worst)));
        }
    }

    /// [`Forces::accelerations`] for forces that are [local](Forces::is_local) (no attraction):
    /// `&self`, so that groups of balls can be evaluated on several threads at once. The same
    /// bits as `accelerations`. Panics if attraction is on.
    pub fn local_accelerations(
        &self,
        props: BodyProps<'_>,
        pull: Option<PointForce>,
        pos: &[DVec2],
        vel: &[DVec2],
        acc: &mut [DVec2],
    ) {
        assert!(self.is_local(), "attraction couples the balls: use `Forces::accelerations`");
        let n = pos.len();
        debug_assert!(vel.len() == n && acc.len() == n && props.mass.len() == n);
        acc.fill(DVec2::ZERO);
        for &pass in self.passes.iter() {
            local_pass(pass, self.drag_rate_limit, props, vel, acc);
        }
        add_pull(pull, props, acc);
    }

    /// The passes on one ball alone, for an engine that advances each ball by itself (the
    /// threaded runtime's ball threads): `ball` with the force `pull` (N) on it, and the other
    /// balls' pull from `others` (the caller holds the other balls, the passes do not). See
    /// [`BallForces`].
    #[inline]
    pub fn on_ball<O: OtherBalls>(&self, ball: BallProps, pull: DVec2, others: O) -> BallForces<'_, O> {
        BallForces { forces: self, ball, pull, others, drag_rate_limit: self.drag_rate_limit }
    }

    /// The drag, of either kind.
    fn drag(&self) -> Option<Drag> {
        self.passes.iter().find_map(|p| match p {
            ForcePass::Drag(d) => Some(*d),
            _ => None,
        })
    }

    /// Adds the attraction accelerations to `acc`; returns the largest `ω²` met.
    fn attraction(&mut self, props: BodyProps<'_>, pos: &[DVec2], attraction: &Attraction, acc: &mut [DVec2]) -> f64 {
        match self.method.unwrap_or(AttractionMethod::choose(pos.len(), attraction)) {
            AttractionMethod::Direct => attraction_direct(props, pos, attraction, acc),
            AttractionMethod::Tree => {
                self.radius.clear();
                self.radius.extend(props.diameter.iter().map(|d| 0.5 * d));
                self.tree.build(pos, props.mass, &self.radius, attraction);
                let mut worst = 0.0f64;
                // In tree order (neighbours one after the other): the same results as in index
                // order, with fewer cache misses.
                for &i in self.tree.order() {
                    let i = i as usize;
                    let (f, w) = self.tree.force_and_rate(i);
                    acc[i] += f * props.inverse_mass[i];
                    worst = worst.max(w);
                }
                worst
            }
        }
    }
}

/// Adds the acceleration of a pass that reads each ball alone (gravity, drag).
#[inline]
fn local_pass(pass: ForcePass, drag_rate_limit: f64, props: BodyProps<'_>, vel: &[DVec2], acc: &mut [DVec2]) {
    match pass {
        ForcePass::Gravity(g) => {
            for a in acc.iter_mut() {
                *a += g;
            }
        }
        ForcePass::Drag(drag) if drag_rate_limit.is_finite() => {
            // The guard rail (see `Forces::set_drag_rate_limit`): |a| ≤ limit·|v|.
            for i in 0..acc.len() {
                let a = drag_force(vel[i], props.diameter[i], &drag) * props.inverse_mass[i];
                acc[i] += cap_drag_rate(a, vel[i], drag_rate_limit);
            }
        }
        ForcePass::Drag(drag) => {
            for i in 0..acc.len() {
                acc[i] += drag_force(vel[i], props.diameter[i], &drag) * props.inverse_mass[i];
            }
        }
        ForcePass::Attraction(_) => unreachable!("attraction is not a local pass"),
    }
}

/// The largest `(|a_i|·c_i)²` over the balls, `a_i = accel(i)` a ball's acceleration without drag
/// and `c_i` its quadratic drag rate at 1 m/s: the fourth power of the largest drag rate at the
/// terminal speed (see [`crate::physics::drag_rate_bound`]), without a square root per ball.
fn terminal_drag_rate4(props: BodyProps<'_>, drag: &Drag, accel: impl Fn(usize) -> DVec2) -> f64 {
    (0..props.mass.len()).fold(0.0, |w, i| {
        let c = drag_rate(DVec2::X, props.diameter[i], props.mass[i], drag);
        w.max(accel(i).length_squared() * c * c)
    })
}

/// Adds the pull on one ball, last (after every pass).
#[inline]
fn add_pull(pull: Option<PointForce>, props: BodyProps<'_>, acc: &mut [DVec2]) {
    if let Some(p) = pull {
        acc[p.index] += p.force * props.inverse_mass[p.index];
    }
}

/// The direct sum: adds every ball's acceleration from every other to `acc`, each pair visited
/// once (Newton's third law) in index order; returns the largest pair `ω²` (see
/// [`attraction_pair`]). The forces are bit for bit those of the sum before the tree existed.
fn attraction_direct(props: BodyProps<'_>, pos: &[DVec2], attraction: &Attraction, acc: &mut [DVec2]) -> f64 {
    let n = pos.len();
    let mut worst = 0.0f64;
    for i in 0..n {
        let (pi, mi, ri, inv_mi) = (pos[i], props.mass[i], 0.5 * props.diameter[i], props.inverse_mass[i]);
        let mut sum = DVec2::ZERO;
        for j in (i + 1)..n {
            let inv_mj = props.inverse_mass[j];
            // The same force as `attraction_force`, and the pair's ω² for one more multiplication.
            let (f, k) = attraction_pair(pi, mi, ri, pos[j], props.mass[j], 0.5 * props.diameter[j], attraction);
            let w = k * (inv_mi + inv_mj);
            worst = if w > worst { w } else { worst };
            sum += f;
            acc[j] -= f * inv_mj;
        }
        acc[i] += sum * inv_mi;
    }
    worst
}
