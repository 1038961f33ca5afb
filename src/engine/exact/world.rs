//! The event-driven simulation itself: balls on parabolas, the calendar of their next events,
//! and what happens at each event.
//!
//! **State.** Every ball carries its position and velocity at the instant it last changed
//! course, that instant, and its constant acceleration since (Rapaport's "delayed states"): only
//! the balls an event involves are touched, and where any ball is at any instant follows from
//! [`flight`]. The clock [`World::now`] is the instant of the last event processed, or of the
//! last `advance_to`.
//!
//! **Events.** A ball that moves has one event of its own in the calendar (see `calendar.rs`):
//! the earliest of its next wall bounce, its next crossing into another cell and its next
//! collision with a ball of the 3 × 3 cells around it, predicted by [`crate::physics`]'s event
//! functions. A cell crossing changes no trajectory: the ball is moved to its new cell and
//! predicted again against its new neighbours. A collision or a bounce changes the balls' courses:
//! their counters go up (so every event predicted with their old course is dropped when it comes
//! up) and they are predicted again.
//!
//! **Accelerations.** Gravity is the same for every free ball, so two free balls move in straight
//! lines relative to each other and their contact time is the root of a quadratic. The key ball
//! adds its pull, constant between two changes of the pull; when it changes, the key ball's course
//! is cut at that instant and only its events are predicted again.
//!
//! **Resting contacts (the rest model).** Under gravity, a ball that bounces with e < 1 on the
//! floor bounces infinitely often in a finite time, and a ball lying on the floor at e = 1 would
//! "collide" with it continuously. Neither is a sequence of events an engine can finish, so:
//! - a ball that meets a surface it is pressed against (by gravity and the pull) with a rebound
//!   lower than `rest_height` times its diameter (rebound speed below `√(2·a·h)`) does not
//!   rebound: against a wall it *slides* along it (the wall takes the normal part of its
//!   acceleration and of any impulse pressing it in); if it is also slower than that and its
//!   supports — walls and balls at rest, within a millionth of a diameter — can hold its weight
//!   (the direction against its acceleration lies in the cone of their contact normals), it comes
//!   to *rest*: velocity and acceleration zero, no events of its own;
//! - a ball at rest stays so until it is pushed where its supports cannot hold it (an impulse
//!   outside the cone wakes it; inside, the pile is immovable and passes the impulse on to the
//!   walls), or a support of it wakes (balls resting on it are checked again, recursively); but a
//!   ball at rest touching no other ball at rest, or only a row of them lying on walls (up to
//!   [`MAX_GROUP`] balls in the round) or a stack (up to [`MAX_STACK`]), struck faster than the
//!   collapse speed, takes the impact, together with every other impact of that instant and
//!   with those balls, as the chain of sequential impacts it starts with their walls
//!   ([`World::strike_through_rest`]: a ball dropped on a ball lying on the floor, or on a stack
//!   of them, rebounds as that chain says; struck from both sides at once, it stays at rest)
//!   and wakes if it leaves them faster than its rest speed; so is one struck more slowly, if
//!   its striker would rebound faster than the rest speed (a hop on a stack is handed down to
//!   the floor, which takes its share, instead of coming back whole from a stack held
//!   immovable: at e = 1 on a floor of 0.5 a ball hopped a micrometre high for ever so);
//! - a ball held immovable in a pile passes what it is struck with on to the walls, so a
//!   collision with it keeps no more restitution than the walls have (the smaller of the balls'
//!   and the walls'): at e = 1 on walls of 0.5 the balls above a pile otherwise rattle on it for
//!   ever, losing energy only to the walls they reach;
//! - a slow ball pressed against a ball that cannot hold it (on the slope of one ball) leaves at
//!   the rebound speed `√(2·a·h)` instead of less: a hop of `h`, so that it slides off in events
//!   no shorter than `2·√(2h/a)`.
//!
//! Only a pile's own weight is checked against its supports' cones, not the loads of the balls
//! above (that is a statics problem): a frictionless pile that real physics would spread holds,
//! as if its resting contacts had a little static friction. The weight of every ball at rest
//! or sliding is carried by the walls' gauges at every instant (split by the signs of its
//! components: the floor takes a pile's weight under vertical gravity), as is every impulse a pile
//! passes on, so the walls' impulses balance the momentum exactly.
//!
//! - whatever the collision, a ball it leaves slower than the rest speed `√(2·a·h)` (a its
//!   acceleration) on supports that hold it comes to rest: a row of balls squeezed between two
//!   walls on the floor stops rattling.
//!
//! **Inelastic collapse** (infinitely many collisions in a finite time, in a cluster with e < 1)
//! is stopped by a restitution that rises to 1 for collisions slower than `collapse_speed`
//! ([`soft_restitution`], the model of Bizon et al. 1998), counted as `soft_collisions`. It is
//! chosen over the TC model of Luding & McNamara (1998), which makes a collision elastic when it
//! comes within a time `tc` of the ball's last: that keeps a ball rattling between two held
//! neighbours for ever, at the energy it had when its collisions came faster than `1/tc`.
//!
//! **Simultaneous impacts.** A collision faster than the collapse speed, while its balls touch
//! others closing on them faster than that (a ball striking two touching balls between them, a
//! ball at rest struck from both sides at once), is one round of simultaneous impacts, solved
//! together as the stepped engines solve an impact round
//! ([`crate::physics::solve_simultaneous`], [`World::strike_simultaneous`]): taken one after the
//! other, the first impact would deflect the striking ball (or set the struck one moving) before
//! the second, and the outcome would follow the balls' numbering. Free balls, sliding balls
//! and balls at rest outside piles (see above) are in rounds, the walls of the last two as
//! contacts of the round. Contacts with balls of a pile and the free balls' walls, and contacts
//! that are not closing fast (a row of touching balls struck at one end; the slow collisions
//! of a ball that stays wedged between two it struck, at e = 0), are their own events a moment
//! later in the same instant: sequential impacts.
//!
//! **Many collisions at one instant.** Touching balls held at both ends (a row between balls at
//! rest, a ball in a gap a hair narrower than itself) can pass slow collisions around without the
//! clock moving; [`World::note_instant`] bounds them: a ball's 17th slow collision at one
//! instant resolves its cluster of touching balls at once ([`World::resolve_cluster`]), its 65th
//! puts it to rest where it is, and any ball's 65,536th at one instant, in any scene, does too.
//! A wedged pair, or a cluster the resolution leaves jammed, that touches no wall and no ball at
//! rest through its touching balls is held by nothing: it moves on as one at its centre of mass's
//! velocity instead ([`World::centre_velocity`]), keeping its momentum.
//!
//! **Rounding.** An event is the first instant a gap function is `≤ 0` and decreasing
//! (`physics::event`, after Bannerman et al. 2014), so a pair that touches or overlaps after
//! rounding is never stuck; a touching pair that closes by less than a few roundings of its
//! speeds does not count as closing ([`closing_slack`]); balls given to the engine overlapping are
//! pushed apart first ([`World::separate_overlaps`]).
//!
//! None of this acts at e = 1 on balls that do not rest on each other: an elastic gas, with or
//! without gravity, is exact to rounding (its energy kept to 1e-15 over 10⁶ collisions,
//! `tests/exact_gas.rs`).

use glam::DVec2;
use serde::Serialize;

use super::calendar::{Calendar, CalendarStats, Event, Partner};
use super::cells::Cells;
use crate::physics::{
    Ball, BallId, BallKind, Collision, Effects, Field, Mobility, RoundContact, RoundScratch, WallImpulses,
    closing_slack, coincident_normal, collide, cone_contains, flight, pair_time, plane_time, soft_restitution,
    solve_simultaneous,
};

/// The walls' inward normals, in the order of [`Partner::Wall`]: left, right, bottom, top.
const WALL_NORMALS: [DVec2; 4] = [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y];

/// Angle, rad, within which a contact normal counts as pointing straight against the
/// acceleration (a ball balanced on top of one other).
const CONE_SLACK: f64 = 1e-9;

/// The most balls [`World::settle`] considers coming to rest together, and the most a round of
/// simultaneous impacts gathers ([`World::strike_simultaneous`]).
const MAX_GROUP: usize = 32;

/// The most collisions and bounces a ball has at one instant with the scene's restitution; the
/// ones after are plastic (see [`World::note_instant`]).
const MAX_AT_INSTANT: u32 = 16;

/// The most collisions and bounces a ball has at one instant: at the next it comes to rest where
/// it is (see [`World::note_instant`]).
const WEDGED_AT_INSTANT: u32 = 64;

/// The backstop of [`World::note_instant`]: the most collisions and bounces of any speed a ball
/// has at one instant before it rests where it is (the only rule there where every restitution
/// is 1; a ball of the crowd scene, packed tighter than the field holds, has 938 at its start).
const ELASTIC_AT_INSTANT: u32 = 1 << 16;

/// The most Gauss–Seidel sweeps [`World::resolve_cluster`] makes over a cluster's contacts.
const MAX_CLUSTER_SWEEPS: usize = 1_000;

/// The most times [`World::resolve_cluster`] solves a cluster again after waking a support.
const CLUSTER_PASSES: usize = 4;

/// The most balls at rest, not all of them on walls, that join a round of simultaneous impacts
/// as one group (a stack; see [`World::resting_group`]); a bigger group is a pile, held
/// immovable. Groups of up to [`MAX_GROUP`] made the 150-ball pile of `tests/exact_pile.rs`
/// grind at e = 0.95 (20 million events in a half second, stuck at 6.4 s simulated; seed 1):
/// its balls, struck through, woke and rattled in their pockets. With at most 4, over the same
/// seeds it runs as with rows alone (docs/accuracy/exact.md).
const MAX_STACK: usize = 4;

/// The most rounds of impacts of [`World::strike_through_rest`].
const MAX_REST_STRIKE_ROUNDS: usize = 64;

/// The most sweeps [`World::separate_overlaps`] makes over the balls.
const MAX_SEPARATION_SWEEPS: usize = 64;

/// The parameters of the rest and collapse models.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ExactParams {
    /// A rebound lower than this fraction of the ball's diameter ends in sliding or rest.
    pub rest_height: f64,
    /// Below this normal speed, m/s, a collision loses ever less of it (see [`soft_restitution`]).
    pub collapse_speed: f64,
}

/// The default rebound height below which a ball rests, as a fraction of its diameter: far below
/// what anyone sees, far above rounding.
pub const REST_HEIGHT: f64 = 1e-6;

impl ExactParams {
    /// The parameters for balls of smallest diameter `smallest` under `gravity` (m/s²), at a
    /// typical speed `speed` (m/s, for a field without gravity).
    ///
    /// With gravity the collapse speed is twice the smallest ball's rest speed `√(2·g·h)`: a
    /// bounce that slow still loses a good part of its speed (60 % of what the scene's e takes),
    /// so a bouncing ball gets below the rest speed in a few bounces and lands. Without gravity
    /// nothing rests, and it is a thousandth of the typical speed (at least 1 µm/s).
    pub fn for_scene(smallest: f64, gravity: f64, speed: f64) -> ExactParams {
        let h = REST_HEIGHT * smallest;
        let collapse_speed = if gravity > 0.0 { 2.0 * (2.0 * gravity * h).sqrt() } else { 1e-3 * speed.max(1e-3) };
        ExactParams { rest_height: REST_HEIGHT, collapse_speed }
    }
}

/// How a ball moves now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    Free,
    /// On wall `k` (0..4), its normal acceleration taken by the wall.
    Sliding(u8),
    /// At rest on its supports.
    Resting,
}

/// What a ball near a member of a round being gathered is to it ([`World::gather_round`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Join {
    /// Not joined by this pair.
    No,
    /// Joined: the ball is a member and the pair one of the round's.
    Yes,
    /// The round is refused: the gathering stops.
    Refuse,
}

/// What predicting and processing need of a ball, in one 64-byte cache line: its position and
/// velocity at instant `t`, its acceleration since, and its radius.
#[derive(Clone, Copy, Debug, Default)]
#[repr(align(64))]
struct Hot {
    x: DVec2,
    v: DVec2,
    a: DVec2,
    t: f64,
    r: f64,
}

/// The rest of a ball.
#[derive(Clone, Copy, Debug)]
struct Cold {
    id: BallId,
    kind: BallKind,
    mass: f64,
    inverse_mass: f64,
    diameter: f64,
    /// The pull on it (the key ball), N.
    force: DVec2,
    motion: Motion,
    /// Since when its weight is on the walls (resting or sliding).
    since: f64,
    /// The instant of its latest collision or bounce, and how many it had at that instant.
    instant: f64,
    at_instant: u32,
}

/// What the engine counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ExactCounters {
    /// Ball–ball collisions (a cluster resolved at once counts as one; a round of simultaneous
    /// impacts, as its contacts that took an impulse).
    pub collisions: u64,
    /// Rounds of simultaneous impacts: two or more fast contacts at one instant, solved
    /// together (see `World::strike_simultaneous`).
    pub simultaneous_rounds: u64,
    /// Balls at rest struck by fast collisions through to their walls (see
    /// `World::strike_through_rest`).
    pub rest_strikes: u64,
    /// Bounces off a wall.
    pub wall_bounces: u64,
    /// Crossings of a ball's centre into another cell of the grid.
    pub cell_crossings: u64,
    /// Balls predicted.
    pub predictions: u64,
    /// Collisions and bounces slower than the collapse speed, whose restitution the collapse
    /// model raised towards 1.
    pub soft_collisions: u64,
    /// Balls that came to rest.
    pub rests: u64,
    /// Balls that landed sliding on a wall.
    pub slides: u64,
    /// Balls woken from rest.
    pub wakes: u64,
    /// Groups of slow balls that came to rest together, each held by the others.
    pub group_rests: u64,
    /// Slow collisions on a ball that could not hold the other, given the minimum rebound.
    pub hops: u64,
    /// Collisions resolved with a second support at once (see `World::wedge_impact`).
    pub wedges: u64,
    /// Collisions whose impulse a second, rounding-sized top-up kept separating.
    pub separation_fixes: u64,
    /// Overlapping pairs pushed apart when the balls were loaded (see `World::separate_overlaps`).
    pub overlaps_separated: u64,
    /// Slow collisions and bounces made plastic as a ball's 17th or later at one instant (see
    /// `World::note_instant`).
    pub instant_plastic: u64,
    /// Clusters of touching balls whose contacts were resolved at once (see
    /// `World::resolve_cluster`).
    pub cluster_solves: u64,
    /// The Gauss–Seidel sweeps beyond the first that those took.
    pub cluster_sweeps: u64,
    /// The most collisions and bounces one ball had at one instant.
    pub most_at_instant: u32,
    /// Balls that came to rest wedged: at their 65th collision or bounce at one instant.
    pub wedged: u64,
    /// Clusters jammed: a contact still closing after the sweep limit (a row that fits exactly
    /// between balls at rest, whose balls' small vertical motions press its contacts through
    /// normals a hair off the horizontal); such a cluster comes to rest where it is.
    pub cluster_jams: u64,
    /// Clusters that the wedged and jammed rules found held by nothing (no wall, no ball at rest
    /// among their contacts: a light ball rattling between two heavy ones closing on it in free
    /// flight), which move on as one at their centre of mass's velocity, their momentum kept.
    pub clumps: u64,
}

/// The earliest collision a ball's last prediction found among its neighbours: its instant
/// (absolute, s; infinite: none), the partner and the partner's course counter then. `valid` is
/// false when a pair with a quartic gap was among them (searched only up to the earliest event
/// then, so the earliest collision is not known).
#[derive(Clone, Copy, Debug)]
struct Memo {
    time: f64,
    partner: u32,
    count: u32,
    valid: bool,
}

impl Default for Memo {
    fn default() -> Memo {
        Memo { time: f64::INFINITY, partner: 0, count: 0, valid: false }
    }
}

/// A contact of a cluster solved at once ([`World::resolve_cluster`]).
#[derive(Clone, Copy, Debug)]
enum Contact {
    /// Members a and b, along `Δr = x_b − x_a`, and their contact distance.
    Pair(usize, usize, DVec2, f64),
    /// Member a on ball s at rest, along the normal into a (not of unit length: `x_a − x_s`),
    /// and their contact distance.
    Support(usize, usize, DVec2, f64),
    /// Member a on wall `w` (see [`Partner::Wall`]).
    Wall(usize, u8),
}

impl Contact {
    /// The member the impulse pushes (with `−d`), the one pushed with `+d` if a member, and `d`.
    fn parts(&self) -> (usize, Option<usize>, DVec2) {
        match *self {
            Contact::Pair(a, b, d, _) => (a, Some(b), d),
            Contact::Support(a, _, d, _) => (a, None, d),
            Contact::Wall(a, w) => (a, None, WALL_NORMALS[w as usize]),
        }
    }

    /// How fast the contact opens, along `d` (negative: closing).
    fn velocity(&self, hot: &[Hot]) -> f64 {
        match *self {
            Contact::Pair(a, b, d, _) => (hot[b].v - hot[a].v).dot(d),
            Contact::Support(a, _, d, _) => hot[a].v.dot(d),
            Contact::Wall(a, w) => hot[a].v.dot(WALL_NORMALS[w as usize]),
        }
    }

    /// Whether the prediction would find the contact closing now (see [`pair_time`]'s slack).
    fn closing(&self, hot: &[Hot]) -> bool {
        let v = self.velocity(hot);
        match *self {
            Contact::Pair(a, b, _, sigma) => v < -closing_slack(sigma, l1(hot[a].v) + l1(hot[b].v)),
            Contact::Support(a, _, _, sigma) => v < -closing_slack(sigma, l1(hot[a].v)),
            Contact::Wall(..) => v < 0.0,
        }
    }
}

/// The event-driven simulation (see the module comment).
#[derive(Clone, Debug)]
pub struct World {
    hot: Vec<Hot>,
    cold: Vec<Cold>,
    /// Per ball: its course counter (up at every change of course), see `calendar.rs`.
    count: Vec<u32>,
    /// Per ball: the earliest collision of its last prediction (see [`World::predict_crossed`]).
    memo: Vec<Memo>,
    cells: Cells,
    calendar: Calendar,
    now: f64,
    field: Field,
    effects: Effects,
    gravity: DVec2,
    params: ExactParams,
    /// Collisions a ball has at one instant before the rules of [`World::note_instant`] act:
    /// before its cluster is resolved at once, and before it rests where it is.
    limits: (u32, u32),
    max_balls: usize,
    next_id: u32,
    /// Impulses the walls took, banked (the loads of balls at rest are added when read).
    impulses: WallImpulses,
    /// What it counted.
    pub counters: ExactCounters,
    /// Scratch: balls woken, and balls come to rest, during one event; contact normals.
    woken: Vec<usize>,
    rested: Vec<usize>,
    normals: Vec<DVec2>,
    /// Scratch: neighbours of a ball; a cluster's members and contacts, and which balls are
    /// members (`mark[k] == epoch`).
    near: Vec<usize>,
    members: Vec<usize>,
    contacts: Vec<Contact>,
    lambda: Vec<f64>,
    mark: Vec<u32>,
    epoch: u32,
}

/// `|v_x| + |v_y|`: the speed bound [`closing_slack`] is taken with (no square root in the loop
/// over neighbours).
#[inline]
fn l1(v: DVec2) -> f64 {
    v.x.abs() + v.y.abs()
}

/// Adds to the gauges the impulse `push` that a ball gives its supports (and they pass on to the
/// walls): its −x part to the left wall, +x to the right, −y to the floor, +y to the top.
fn transmit(impulses: &mut WallImpulses, push: DVec2) {
    if push.x < 0.0 {
        impulses.left -= push.x;
    } else {
        impulses.right += push.x;
    }
    if push.y < 0.0 {
        impulses.bottom -= push.y;
    } else {
        impulses.top += push.y;
    }
}

impl World {
    /// A world of `balls` (their ids kept; sorted by id) in `field` under `effects` (drag and
    /// attraction are the caller's to refuse; they are ignored here).
    pub fn new(field: Field, effects: Effects, balls: &[Ball], max_balls: usize, params: ExactParams) -> World {
        let mut sorted = balls.to_vec();
        sorted.sort_by_key(|b| b.id);
        let mut w = World {
            hot: Vec::new(),
            cold: Vec::new(),
            count: Vec::new(),
            memo: Vec::new(),
            cells: Cells::default(),
            calendar: Calendar::new(),
            now: 0.0,
            field,
            effects: Effects { drag: None, attraction: None, ..effects },
            gravity: effects.gravity.map_or(DVec2::ZERO, |g| g.g),
            params,
            limits: (0, 0),
            max_balls,
            next_id: sorted.iter().map(|b| b.id.0 + 1).max().unwrap_or(0),
            impulses: WallImpulses::default(),
            counters: ExactCounters::default(),
            woken: Vec::new(),
            rested: Vec::new(),
            normals: Vec::new(),
            near: Vec::new(),
            members: Vec::new(),
            contacts: Vec::new(),
            lambda: Vec::new(),
            mark: Vec::new(),
            epoch: 0,
        };
        for b in &sorted {
            w.push_ball(*b);
        }
        w.rebuild();
        w
    }

    fn push_ball(&mut self, b: Ball) {
        self.hot.push(Hot { x: b.position, v: b.velocity, a: DVec2::ZERO, t: self.now, r: b.radius() });
        self.cold.push(Cold {
            id: b.id,
            kind: b.kind,
            mass: b.mass,
            inverse_mass: 1.0 / b.mass,
            diameter: b.diameter,
            force: DVec2::ZERO,
            motion: Motion::Free,
            since: self.now,
            instant: f64::NEG_INFINITY,
            at_instant: 0,
        });
        self.count.push(0);
        self.memo.push(Memo::default());
        self.mark.push(0);
    }

    // ---- reading ------------------------------------------------------------------------

    /// The clock: the instant of the last event processed or of the last `advance_to`, s.
    pub fn now(&self) -> f64 {
        self.now
    }

    /// Balls on the field.
    pub fn len(&self) -> usize {
        self.hot.len()
    }

    /// Whether there are no balls.
    pub fn is_empty(&self) -> bool {
        self.hot.is_empty()
    }

    /// The field (its restitution as set now).
    pub fn field(&self) -> &Field {
        &self.field
    }

    /// The effects that act (never drag or attraction).
    pub fn effects(&self) -> &Effects {
        &self.effects
    }

    /// The rest and collapse models' parameters.
    pub fn params(&self) -> ExactParams {
        self.params
    }

    /// What the calendar counted.
    pub fn calendar_stats(&self) -> CalendarStats {
        self.calendar.stats
    }

    /// Events waiting in the calendar (at most one per ball).
    pub fn calendar_len(&self) -> usize {
        self.calendar.len()
    }

    /// Balls at rest now, and sliding on a wall.
    pub fn resting(&self) -> (usize, usize) {
        let r = self.cold.iter().filter(|c| c.motion == Motion::Resting).count();
        let s = self.cold.iter().filter(|c| matches!(c.motion, Motion::Sliding(_))).count();
        (r, s)
    }

    /// Position and velocity of ball `i` now.
    #[inline]
    fn at(&self, i: usize) -> (DVec2, DVec2) {
        let h = &self.hot[i];
        flight(h.x, h.v, h.a, self.now - h.t)
    }

    /// Ball `i` now.
    pub fn ball(&self, i: usize) -> Ball {
        let (position, velocity) = self.at(i);
        let c = &self.cold[i];
        Ball { id: c.id, kind: c.kind, position, velocity, mass: c.mass, diameter: c.diameter }
    }

    /// Every ball now, sorted by id, into `out` (cleared first).
    pub fn sample(&self, out: &mut Vec<Ball>) {
        out.clear();
        out.extend((0..self.len()).map(|i| self.ball(i)));
    }

    /// The index of the ball with `id`.
    pub fn index_of(&self, id: BallId) -> Option<usize> {
        self.cold.binary_search_by_key(&id, |c| c.id).ok()
    }

    /// The index of the key ball.
    pub fn key_index(&self) -> Option<usize> {
        self.cold.iter().position(|c| c.kind == BallKind::Key)
    }

    /// The walls' impulses so far, the weight of the balls at rest or sliding included up to now.
    pub fn wall_impulses(&self) -> WallImpulses {
        let mut w = self.impulses;
        for i in 0..self.len() {
            if self.cold[i].motion != Motion::Free {
                transmit(&mut w, self.static_push(i) * (self.now - self.cold[i].since));
            }
        }
        w
    }

    /// Debugging: every ball's motion and state, and how many events the calendar holds.
    pub fn dump(&self) -> String {
        let mut out = String::new();
        for i in 0..self.len() {
            let (x, v) = self.at(i);
            out += &format!("{i} {:?} x={x:?} v={v:?} a={:?}\n", self.cold[i].motion, self.hot[i].a);
        }
        out += &format!("calendar len {}\n", self.calendar.len());
        out
    }

    // ---- accelerations ------------------------------------------------------------------

    /// Gravity plus the pull: what ball `i` would accelerate at, free.
    #[inline]
    fn free_accel(&self, i: usize) -> DVec2 {
        let c = &self.cold[i];
        self.gravity + c.force * c.inverse_mass
    }

    /// The acceleration ball `i` moves with in its motion.
    fn motion_accel(&self, i: usize) -> DVec2 {
        let a = self.free_accel(i);
        match self.cold[i].motion {
            Motion::Free => a,
            Motion::Sliding(k) => {
                let n = WALL_NORMALS[k as usize];
                a - a.dot(n) * n
            }
            Motion::Resting => DVec2::ZERO,
        }
    }

    /// The force a ball at rest or sliding presses its supports with (its weight and pull, or
    /// their normal part for a slider).
    fn static_push(&self, i: usize) -> DVec2 {
        let c = &self.cold[i];
        let f = c.mass * self.free_accel(i);
        match c.motion {
            Motion::Free => DVec2::ZERO,
            Motion::Sliding(k) => {
                let n = WALL_NORMALS[k as usize];
                f.dot(n) * n
            }
            Motion::Resting => f,
        }
    }

    /// The rebound speed below which ball `i` pressed at `a` (m/s², the normal part towards its
    /// support) stays on it: `√(2·a·h)`, h its rest height.
    fn rest_speed(&self, i: usize, a: f64) -> f64 {
        if a > 0.0 { (2.0 * a * self.params.rest_height * self.cold[i].diameter).sqrt() } else { 0.0 }
    }

    /// Where wall `k` is from ball `i`'s surface at `x`.
    #[inline]
    fn wall_gap(&self, k: usize, x: DVec2, r: f64) -> f64 {
        match k {
            0 => x.x - r,
            1 => self.field.width - r - x.x,
            2 => x.y - r,
            _ => self.field.height - r - x.y,
        }
    }

    // ---- the grid and the calendar ------------------------------------------------------

    /// The limits of [`World::note_instant`] for the restitutions now: the inelastic rules where
    /// any restitution is below 1; where all are 1, only the backstop (an elastic sequence at one
    /// instant ends by itself unless balls at rest hold it at both ends).
    fn set_limits(&mut self) {
        let e = self.effects.collisions.map_or(1.0, |c| c.restitution).min(self.field.restitution);
        self.limits = if e < 1.0 { (MAX_AT_INSTANT, WEDGED_AT_INSTANT) } else { (u32::MAX, u32::MAX) };
    }

    /// Brings every ball to now as a free ball (the weight of those at rest banked), rebuilds the
    /// grid and predicts every ball again: after the balls or the effects changed.
    pub fn rebuild(&mut self) {
        self.set_limits();
        for i in 0..self.len() {
            self.end_static(i);
            self.sync(i);
            self.cold[i].motion = Motion::Free;
            self.hot[i].a = self.free_accel(i);
            self.count[i] = self.count[i].wrapping_add(1);
        }
        let largest = self.cold.iter().map(|c| c.diameter).fold(0.0, f64::max);
        self.cells = Cells::new(self.field.width, self.field.height, largest, self.len());
        self.cells.fill(self.hot.iter().map(|h| h.x));
        self.separate_overlaps();
        self.calendar.reset(self.len());
        for i in 0..self.len() {
            self.predict(i);
        }
    }

    /// Pushes overlapping balls apart to touching, positions only (velocities untouched), each
    /// pair by shares that keep its centre of mass, then back inside the field; in sweeps until
    /// none overlaps or [`MAX_SEPARATION_SWEEPS`] have run.
    ///
    /// Hard balls never overlap, but the balls the engine is given can: a scene placed by hand, a
    /// ball dropped onto others by the mouse, the state of a stepped engine switched from (whose
    /// contacts overlap a little). Left as they are, an overlapping pair that does not approach
    /// stays overlapped for ever, and one pressed together under gravity would hop on each other
    /// at the rest model's minimum rebound. What is left after the last sweep (a crowd packed
    /// tighter than the field holds) is left to the event rule, which lets overlapping pairs
    /// separate and collides those that approach.
    fn separate_overlaps(&mut self) {
        let mut moved = 0u64;
        for _ in 0..MAX_SEPARATION_SWEEPS {
            let mut any = false;
            for i in 0..self.len() {
                let mut near = std::mem::take(&mut self.near);
                near.clear();
                self.cells.for_each_near(i, |j| near.push(j));
                for &j in &near {
                    if j <= i {
                        continue;
                    }
                    let sigma = self.hot[i].r + self.hot[j].r;
                    let d = self.hot[j].x - self.hot[i].x;
                    let dist = d.length();
                    if dist >= sigma {
                        continue;
                    }
                    let n = if dist > 1e-9 * sigma {
                        d / dist
                    } else {
                        coincident_normal(self.cold[i].id, self.cold[j].id)
                    };
                    // A hair past touching, so that rounding leaves the pair apart.
                    let shift = (sigma - dist) + 1e-12 * sigma;
                    let (wi, wj) = (self.cold[i].inverse_mass, self.cold[j].inverse_mass);
                    self.hot[i].x -= n * (shift * wi / (wi + wj));
                    self.hot[j].x += n * (shift * wj / (wi + wj));
                    for k in [i, j] {
                        let r = self.hot[k].r;
                        let x = &mut self.hot[k].x;
                        x.x = x.x.clamp(r, self.field.width - r);
                        x.y = x.y.clamp(r, self.field.height - r);
                    }
                    any = true;
                    moved += 1;
                }
                self.near = near;
            }
            if !any {
                break;
            }
            self.cells.fill(self.hot.iter().map(|h| h.x));
        }
        self.counters.overlaps_separated += moved;
    }

    /// Moves ball `i`'s reference instant to now (same course, new starting point).
    #[inline]
    fn sync(&mut self, i: usize) {
        let (x, v) = self.at(i);
        let h = &mut self.hot[i];
        (h.x, h.v, h.t) = (x, v, self.now);
    }

    /// Banks the weight a ball at rest or sliding put on the walls up to now.
    fn bank_static(&mut self, i: usize) {
        if self.cold[i].motion != Motion::Free {
            let push = self.static_push(i) * (self.now - self.cold[i].since);
            transmit(&mut self.impulses, push);
        }
        self.cold[i].since = self.now;
    }

    /// Banks ball `i`'s weight and makes it free (its course is the caller's to set).
    fn end_static(&mut self, i: usize) {
        self.bank_static(i);
        self.cold[i].motion = Motion::Free;
    }

    /// Puts ball `i`'s one event in the calendar: the earliest of its wall bounces, its cell
    /// crossings and its collisions with the balls near it, from now on.
    fn predict(&mut self, i: usize) {
        self.predict_from(i, None);
    }

    /// [`World::predict`] for a ball that has just crossed into its cell across `side`: its
    /// course is the one it was predicted on, so of its neighbours only the three cells that
    /// joined its 3 × 3 block are new. Their collisions are compared with the earliest one its
    /// last full prediction found among the others ([`Memo`]), if that still stands; else it is
    /// predicted in full. (A ball that crosses is in a gas most of the time: at packing 0.3 there
    /// are 1.35 crossings per collision.)
    fn predict_crossed(&mut self, i: usize, side: u8) {
        self.predict_from(i, Some(side));
    }

    fn predict_from(&mut self, i: usize, crossed: Option<u8>) {
        if self.cold[i].motion == Motion::Resting {
            // Whatever it had in the calendar is superseded: a ball at rest has no event.
            self.calendar.remove(i as u32);
            return;
        }
        self.counters.predictions += 1;
        let (x, v) = self.at(i);
        let (a, r) = (self.hot[i].a, self.hot[i].r);
        let mut best = f64::INFINITY;
        let mut partner = None;
        let sliding_on = match self.cold[i].motion {
            Motion::Sliding(k) => k as usize,
            _ => 4,
        };
        // Only a ball in a cell along a wall can meet it before it crosses into another cell
        // (cells are wider than any ball): the others skip the walls.
        let (cx, cy) = self.cells.cell_of(i);
        let edge = [cx == 0, cx + 1 == self.cells.nx, cy == 0, cy + 1 == self.cells.ny];
        for (k, n) in WALL_NORMALS.iter().enumerate() {
            if k == sliding_on || !edge[k] {
                continue;
            }
            if let Some(t) = plane_time(self.wall_gap(k, x, r), v.dot(*n), a.dot(*n))
                && t < best
            {
                (best, partner) = (t, Some(Partner::Wall(k as u8)));
            }
        }
        let bounds = self.cells.bounds(i);
        let sides = [(x.x - bounds[0], v.x, a.x), (bounds[1] - x.x, -v.x, -a.x)];
        let sides_y = [(x.y - bounds[2], v.y, a.y), (bounds[3] - x.y, -v.y, -a.y)];
        for (s, &(gap, vn, an)) in sides.iter().chain(&sides_y).enumerate() {
            if gap.is_finite()
                && let Some(t) = plane_time(gap, vn, an)
                && t < best
            {
                (best, partner) = (t, Some(Partner::Cell(s as u8)));
            }
        }
        if self.effects.collisions.is_some() {
            let memo = self.memo[i];
            let standing = memo.valid
                && memo.time >= self.now
                && (memo.time == f64::INFINITY || self.count[memo.partner as usize] == memo.count);
            let (hot, now, count) = (&self.hot, self.now, &self.count);
            let speed = l1(v);
            // The earliest collision among the balls scanned, untruncated (absolute time), and
            // whether every pair scanned had a quadratic gap (a quartic one is searched only up
            // to the earliest event so far, so it leaves no earliest collision to remember).
            let mut found = Memo { time: f64::INFINITY, partner: 0, count: 0, valid: true };
            let scan = |j: usize, found: &mut Memo| {
                if j == i {
                    return;
                }
                let h = &hot[j];
                let (xj, vj) = flight(h.x, h.v, h.a, now - h.t);
                let da = h.a - a;
                let horizon = if da == DVec2::ZERO { f64::INFINITY } else { best };
                found.valid &= da == DVec2::ZERO;
                if let Some(t) = pair_time(xj - x, vj - v, da, r + h.r, horizon, speed + l1(vj))
                    && now + t < found.time
                {
                    *found = Memo { time: now + t, partner: j as u32, count: count[j], valid: found.valid };
                }
            };
            match crossed {
                Some(side) if standing => {
                    self.cells.for_each_joined(i, side, |j| scan(j, &mut found));
                    if !found.valid {
                        // A quartic pair among the newcomers: predicted in full after all.
                        found = Memo { time: f64::INFINITY, partner: 0, count: 0, valid: true };
                        self.cells.for_each_near(i, |j| scan(j, &mut found));
                    } else if memo.time < found.time {
                        found = memo;
                    }
                }
                _ => self.cells.for_each_near(i, |j| scan(j, &mut found)),
            }
            if found.time - self.now < best {
                best = found.time - self.now;
                partner = Some(Partner::Ball(found.partner, found.count));
            }
            self.memo[i] = found;
        }
        match partner {
            Some(p) => self.calendar.push(Event { time: self.now + best, owner: i as u32, partner: p }),
            None => self.calendar.remove(i as u32),
        }
    }

    // ---- running ------------------------------------------------------------------------

    /// Processes every event up to `t` and sets the clock to `t` (never back).
    pub fn advance_to(&mut self, t: f64) {
        self.advance_while(t, || true);
    }

    /// Processes events up to `t` while `go_on()` (asked every 1,024 events) says so. Returns
    /// whether `t` was reached; if not, the clock stands at the last event processed.
    pub fn advance_while(&mut self, t: f64, mut go_on: impl FnMut() -> bool) -> bool {
        let mut n = 0u32;
        while let Some(next) = self.calendar.next_time() {
            if next > t {
                break;
            }
            n = n.wrapping_add(1);
            if n.is_multiple_of(1024) && !go_on() {
                return false;
            }
            self.step();
        }
        if t > self.now {
            self.now = t;
        }
        true
    }

    /// Processes events until `n` more collisions have happened (or nothing is left to happen).
    pub fn run_collisions(&mut self, n: u64) {
        let target = self.counters.collisions + n;
        while self.counters.collisions < target && self.calendar.next_time().is_some() {
            self.step();
        }
    }

    /// Processes the next event of the calendar.
    fn step(&mut self) {
        let Some(ev) = self.calendar.pop() else { return };
        let i = ev.owner as usize;
        self.now = self.now.max(ev.time);
        match ev.partner {
            Partner::Ball(j, cj) => {
                if self.count[j as usize] != cj {
                    self.calendar.stats.stale_partner += 1;
                    self.predict(i);
                } else {
                    self.collide_pair(i, j as usize);
                }
            }
            Partner::Wall(k) => self.bounce(i, k as usize),
            Partner::Cell(s) => {
                self.counters.cell_crossings += 1;
                self.cells.cross(i, s);
                self.predict_crossed(i, s);
            }
        }
    }

    /// A changed course: a new counter, a new acceleration, a new event.
    fn restart_course(&mut self, i: usize) {
        self.hot[i].a = self.motion_accel(i);
        self.count[i] = self.count[i].wrapping_add(1);
    }

    /// Predicts the balls an event changed besides its own (`skip`): those it woke, and the
    /// moving neighbours of those it put to rest (a ball at rest predicts nothing, so its
    /// neighbours must find their collisions with it themselves).
    fn predict_others(&mut self, skip: [usize; 2]) {
        let woken = std::mem::take(&mut self.woken);
        for &k in &woken {
            if !skip.contains(&k) {
                self.predict(k);
            }
        }
        self.woken = woken;
        self.woken.clear();
        let rested = std::mem::take(&mut self.rested);
        let mut near = Vec::new();
        for &k in &rested {
            self.cells.for_each_near(k, |m| near.push(m));
        }
        near.sort_unstable();
        near.dedup();
        for m in near {
            if !skip.contains(&m) && self.cold[m].motion != Motion::Resting {
                self.predict(m);
            }
        }
        self.rested = rested;
        self.rested.clear();
    }

    // ---- collisions ---------------------------------------------------------------------

    /// The contact normals of ball `i` at `x` (pointing into it) from the walls and the balls at
    /// rest it touches, within a millionth of its diameter, into `self.normals`.
    fn contact_normals(&mut self, i: usize, x: DVec2) {
        self.normals.clear();
        let r = self.hot[i].r;
        let tol = 1e-6 * self.cold[i].diameter;
        for (k, n) in WALL_NORMALS.iter().enumerate() {
            if self.wall_gap(k, x, r) <= tol {
                self.normals.push(*n);
            }
        }
        let (hot, cold, normals) = (&self.hot, &self.cold, &mut self.normals);
        self.cells.for_each_near(i, |j| {
            if j != i && cold[j].motion == Motion::Resting {
                let d = x - hot[j].x;
                let dist = d.length();
                if dist - (r + hot[j].r) <= tol && dist > 0.0 {
                    normals.push(d / dist);
                }
            }
        });
    }

    /// Whether ball `k`, moving, is slower than its rest speed now.
    fn slow(&self, k: usize) -> bool {
        let a = self.free_accel(k).length();
        self.cold[k].motion != Motion::Resting && self.at(k).1.length() < self.rest_speed(k, a)
    }

    /// Puts ball `k` to rest if it is slow and held: by its supports (walls and balls at rest),
    /// or together with slow balls it touches, each held by the others and the supports (two
    /// balls leaning on each other in a gap would otherwise hop on each other for ever). The
    /// group is the largest such set among the slow balls reached from `k` through contacts (at
    /// most [`MAX_GROUP`]), found by dropping the balls not held until none is left to drop.
    /// Returns whether `k` came to rest; the caller restarts `k`'s course.
    fn settle(&mut self, k: usize) -> bool {
        if !self.slow(k) {
            return false;
        }
        if self.supported(k) {
            self.come_to_rest(k);
            return true;
        }
        let mut group = vec![k];
        let mut g = 0;
        while g < group.len() && group.len() < MAX_GROUP {
            let m = group[g];
            g += 1;
            let mut near = Vec::new();
            self.cells.for_each_near(m, |j| near.push(j));
            for j in near {
                if j != m && !group.contains(&j) && self.slow(j) && self.touching(m, j) {
                    group.push(j);
                }
            }
        }
        if group.len() == 1 {
            return false;
        }
        let mut held = vec![true; group.len()];
        loop {
            let mut dropped = false;
            for a in 0..group.len() {
                if !held[a] {
                    continue;
                }
                let m = group[a];
                let xm = self.at(m).0;
                self.contact_normals(m, xm);
                for b in 0..group.len() {
                    if b != a && held[b] && self.touching(m, group[b]) {
                        let d = xm - self.at(group[b]).0;
                        self.normals.push(d / d.length());
                    }
                }
                if !cone_contains(&self.normals, -self.free_accel(m), CONE_SLACK) {
                    held[a] = false;
                    dropped = true;
                }
            }
            if !dropped {
                break;
            }
        }
        if !held[0] {
            return false;
        }
        for (a, &m) in group.iter().enumerate() {
            if held[a] {
                self.come_to_rest(m);
                if m != k {
                    self.restart_course(m);
                    // Supersedes the event it had (a ball at rest has none).
                    self.predict(m);
                }
            }
        }
        self.counters.group_rests += 1;
        true
    }

    /// Whether balls `a` and `b` touch now (within a millionth of a diameter).
    fn touching(&self, a: usize, b: usize) -> bool {
        let d = self.at(a).0.distance(self.at(b).0);
        d > 0.0 && d - (self.hot[a].r + self.hot[b].r) <= 1e-6 * self.cold[a].diameter.min(self.cold[b].diameter)
    }

    /// Whether ball `i`'s supports (walls and balls at rest) can hold it against its acceleration.
    fn supported(&mut self, i: usize) -> bool {
        let (x, _) = self.at(i);
        self.contact_normals(i, x);
        cone_contains(&self.normals, -self.free_accel(i), CONE_SLACK)
    }

    /// Wakes ball `i` from rest (a free ball at rest where it is), and every ball at rest that it
    /// held and that its other supports cannot hold alone; all of them into `self.woken`.
    fn wake(&mut self, i: usize) {
        let mut stack = vec![i];
        while let Some(k) = stack.pop() {
            if self.cold[k].motion != Motion::Resting {
                continue;
            }
            self.end_static(k);
            self.sync(k);
            self.hot[k].v = DVec2::ZERO;
            // A ball woken on a wall it is pressed against slides on it.
            let (x, r, a) = (self.hot[k].x, self.hot[k].r, self.free_accel(k));
            let tol = 1e-6 * self.cold[k].diameter;
            if let Some(w) = (0..4).find(|&w| self.wall_gap(w, x, r) <= tol && a.dot(WALL_NORMALS[w]) < 0.0) {
                self.cold[k].motion = Motion::Sliding(w as u8);
            }
            self.restart_course(k);
            self.counters.wakes += 1;
            self.woken.push(k);
            let x = self.hot[k].x;
            let mut near = Vec::new();
            self.cells.for_each_near(k, |j| near.push(j));
            for j in near {
                if j != k && self.cold[j].motion == Motion::Resting {
                    let d = self.hot[j].x - x;
                    let reach = self.hot[j].r + self.hot[k].r;
                    if d.length() - reach <= 1e-6 * self.cold[j].diameter && !self.supported(j) {
                        stack.push(j);
                    }
                }
            }
        }
    }

    /// How ball `k` answers an impulse along `push` (unit): free; sliding, if it presses it into
    /// its wall (else it leaves the wall); fixed, if at rest and its supports hold against it
    /// (else it wakes).
    fn mobility(&mut self, k: usize, push: DVec2) -> Mobility {
        let inverse_mass = self.cold[k].inverse_mass;
        if self.cold[k].motion == Motion::Resting {
            let x = self.hot[k].x;
            self.contact_normals(k, x);
            if cone_contains(&self.normals, -push, CONE_SLACK) {
                return Mobility::Fixed;
            }
            // Woken: free, or sliding if it lies on a wall it is pressed against.
            self.wake(k);
        }
        match self.cold[k].motion {
            Motion::Free => Mobility::Free { inverse_mass },
            Motion::Sliding(w) => {
                let wall = WALL_NORMALS[w as usize];
                if push.dot(wall) <= 0.0 {
                    Mobility::Sliding { inverse_mass, wall }
                } else {
                    self.end_static(k);
                    Mobility::Free { inverse_mass }
                }
            }
            Motion::Resting => Mobility::Fixed,
        }
    }

    /// Gauges the part of an impulse `p` on ball `k` that its constraint took.
    fn gauge_constraint(&mut self, m: Mobility, p: DVec2) {
        match m {
            Mobility::Free { .. } => {}
            Mobility::Sliding { wall, .. } => transmit(&mut self.impulses, p.dot(wall) * wall),
            Mobility::Fixed => transmit(&mut self.impulses, p),
        }
    }

    /// Ball `k` comes to rest now: its remaining momentum goes to its supports.
    fn come_to_rest(&mut self, k: usize) {
        self.sync(k);
        self.bank_static(k);
        let push = self.cold[k].mass * self.hot[k].v;
        transmit(&mut self.impulses, push);
        self.hot[k].v = DVec2::ZERO;
        self.cold[k].motion = Motion::Resting;
        self.counters.rests += 1;
        self.rested.push(k);
    }

    /// Counts a collision or bounce of ball `k` now; returns how many it had at this instant.
    ///
    /// Balls that touch others which are held (a row on the floor between balls at rest, a ball
    /// dropped into a gap a hair narrower than itself) can be in a sequence of slow collisions
    /// that all fall on one instant: each passes the motion on to the next contact without the
    /// clock moving. With the collapse model's restitution, which rises to 1 for slow
    /// collisions, a pulse in a row held at both ends runs back and forth for ever; a ball in a
    /// narrow gap loses only the square of the gap's angle of its speed per collision. Hard
    /// balls have no answer for such simultaneous contacts (the order of the sequence picks
    /// one), and the engine would never leave that instant. So, in a scene with a restitution
    /// below 1, a ball has [`MAX_AT_INSTANT`] slow collisions (slower than the collapse speed) at
    /// one instant as the scene says; after that
    /// - a collision of two moving balls resolves their whole cluster of touching balls at once
    ///   ([`World::resolve_cluster`]: plastic, or at rest where jammed);
    /// - a collision with a ball at rest, or with a wall, is plastic (e = 0, the rest model's
    ///   hop still giving the minimum rebound to a ball pressed where it cannot rest);
    /// - the [`WEDGED_AT_INSTANT`]th puts the ball to rest where it is (with the moving balls it
    ///   touches moving on as one instead if none of them touches a wall or a ball at rest:
    ///   [`World::clump`]).
    ///
    /// In any scene, a ball's [`ELASTIC_AT_INSTANT`]th collision at one instant of any speed puts
    /// it to rest too: a backstop that no run seen has reached. Fast collisions at one instant
    /// (a crowd started overlapping) run as the scene says, and a ball in a touching Newton's
    /// cradle has two: the rules change nothing that has an answer.
    fn note_instant(&mut self, k: usize) -> u32 {
        let c = &mut self.cold[k];
        if c.instant == self.now {
            c.at_instant = c.at_instant.saturating_add(1);
        } else {
            (c.instant, c.at_instant) = (self.now, 1);
        }
        self.counters.most_at_instant = self.counters.most_at_instant.max(c.at_instant);
        c.at_instant
    }

    /// Resolves at once every contact of the cluster of moving balls that touch `seeds` (within
    /// a millionth of a diameter, through each other): plastic impulses, `J ≥ 0` on each contact
    /// (ball–ball, and ball–support against walls and balls at rest), that leave no contact
    /// closing as the prediction judges it, found by projected Gauss–Seidel sweeps.
    ///
    /// Taken one after the other, as events, such contacts can pass their motion around the
    /// cluster for ever at one instant (see [`World::note_instant`]); solved together they end
    /// in one event. A ball at rest that the solve pushes where its supports cannot hold it is
    /// woken and the cluster solved again with it (at most [`CLUSTER_PASSES`] times): a row
    /// squeezed between two balls at rest would otherwise be solved against two immovable ends,
    /// which leaves the row's small vertical motions nowhere to go but through contact normals a
    /// hair off the horizontal (a system the sweeps hardly converge on). The slow balls are then
    /// put to rest where their supports hold them (`settle`).
    fn resolve_cluster(&mut self, seeds: [usize; 2]) {
        self.counters.cluster_solves += 1;
        let mut members = std::mem::take(&mut self.members);
        let mut contacts = std::mem::take(&mut self.contacts);
        let mut lambda = std::mem::take(&mut self.lambda);
        let mut start = Vec::new();
        let mut jammed = false;
        for pass in 0..CLUSTER_PASSES {
            self.gather_cluster(seeds, &mut members, &mut contacts);
            start.clear();
            start.extend(members.iter().map(|&m| self.hot[m].v));
            let (walls, settled) = self.solve_cluster(&contacts, &mut lambda);
            jammed = !settled;
            // Supports pushed where they cannot hold: woken, and the cluster solved again from
            // its velocities before.
            let mut woke = false;
            if pass + 1 < CLUSTER_PASSES {
                for (c, contact) in contacts.iter().enumerate() {
                    if let Contact::Support(_, k, d, _) = *contact
                        && lambda[c] > 0.0
                        && self.cold[k].motion == Motion::Resting
                        && !self.holds(k, -d)
                    {
                        self.wake(k);
                        woke = true;
                    }
                }
            }
            if woke {
                for (&m, &v) in members.iter().zip(&start) {
                    self.hot[m].v = v;
                }
                continue;
            }
            // The walls and the balls at rest take the supports' impulses (the balls at rest
            // pass theirs on to the walls).
            transmit(&mut self.impulses, walls);
            for (c, contact) in contacts.iter().enumerate() {
                if let (_, None, d) = contact.parts() {
                    transmit(&mut self.impulses, -lambda[c] * d);
                }
            }
            break;
        }
        self.counters.collisions += 1;
        // Jammed with nothing to hold it (no wall, no ball at rest): it moves on as one, its
        // momentum kept; held by its own contacts and its supports, it comes to rest where it is.
        let held = contacts.iter().any(|c| !matches!(c, Contact::Pair(..)));
        let clump = (jammed && !held).then(|| self.centre_velocity(&members));
        if clump.is_some() {
            self.counters.clumps += 1;
        } else if jammed {
            self.counters.cluster_jams += 1;
        }
        for &m in &members {
            if let Some(v) = clump {
                self.hot[m].v = v;
                self.settle(m);
            } else if jammed {
                self.come_to_rest(m);
            } else {
                self.settle(m);
            }
            self.restart_course(m);
        }
        for &m in &members {
            self.predict(m);
        }
        self.predict_others([seeds[0], seeds[1]]);
        self.members = members;
        self.contacts = contacts;
        self.lambda = lambda;
    }

    /// The velocity of the centre of mass of `members` (moving balls, brought to now): a
    /// cluster that nothing outside it holds moves on at it as one under the inelastic rules
    /// rather than stop (stopped, its momentum would go to walls it does not touch).
    fn centre_velocity(&self, members: &[usize]) -> DVec2 {
        let (mut p, mut m) = (DVec2::ZERO, 0.0);
        for &k in members {
            p += self.cold[k].mass * self.hot[k].v;
            m += self.cold[k].mass;
        }
        p / m
    }

    /// Ends a wedged collision of balls `i` and `j` (see [`World::note_instant`]) when nothing
    /// holds them: the moving balls touching them, through each other, move on as one at their
    /// centre of mass's velocity. Returns false, changing nothing, when one of those slides on a
    /// wall, touches one or touches a ball at rest (the caller puts `i` and `j` to rest where
    /// they are): that is looked for before any ball is changed.
    fn clump(&mut self, i: usize, j: usize) -> bool {
        let mut members = std::mem::take(&mut self.members);
        self.flood_moving([i, j], &mut members);
        let held = self.held_by_something(&members);
        if !held {
            // None slides (held otherwise), so none has a wall to leave.
            for &m in &members {
                self.sync(m);
            }
            let v = self.centre_velocity(&members);
            self.counters.clumps += 1;
            for &m in &members {
                self.hot[m].v = v;
                self.settle(m);
                self.restart_course(m);
            }
            for &m in &members {
                self.predict(m);
            }
            self.predict_others([i, j]);
        }
        self.members = members;
        !held
    }

    /// Whether one of `members` (moving balls, brought to now with `at`) slides on a wall,
    /// touches one or touches a ball at rest: what [`World::list_cluster_contacts`] would list
    /// as a wall or a support, found without changing any ball.
    fn held_by_something(&self, members: &[usize]) -> bool {
        members.iter().any(|&m| {
            let (x, r) = (self.at(m).0, self.hot[m].r);
            let tol = 1e-6 * self.cold[m].diameter;
            let mut on_rest = false;
            self.cells.for_each_near(m, |k| {
                on_rest |= k != m && self.cold[k].motion == Motion::Resting && self.touching(m, k);
            });
            matches!(self.cold[m].motion, Motion::Sliding(_))
                || (0..4).any(|w| self.wall_gap(w, x, r) <= tol)
                || on_rest
        })
    }

    /// The moving balls that touch `seeds`, through each other, into `members` (marked with
    /// this epoch), and their contacts; each brought to now and made free (a wall it slid on is
    /// one of its contacts).
    fn gather_cluster(&mut self, seeds: [usize; 2], members: &mut Vec<usize>, contacts: &mut Vec<Contact>) {
        self.flood_moving(seeds, members);
        self.list_cluster_contacts(members, contacts);
    }

    /// The moving balls that touch `seeds`, through each other, into `members`, each marked
    /// with a new epoch; no ball is changed.
    fn flood_moving(&mut self, seeds: [usize; 2], members: &mut Vec<usize>) {
        members.clear();
        self.epoch = self.epoch.wrapping_add(1);
        for k in seeds {
            if self.mark[k] != self.epoch && self.cold[k].motion != Motion::Resting {
                self.mark[k] = self.epoch;
                members.push(k);
            }
        }
        let mut near = std::mem::take(&mut self.near);
        let mut g = 0;
        while g < members.len() {
            let m = members[g];
            g += 1;
            near.clear();
            self.cells.for_each_near(m, |k| near.push(k));
            for &k in &near {
                if k != m && self.mark[k] != self.epoch && self.cold[k].motion != Motion::Resting && self.touching(m, k)
                {
                    self.mark[k] = self.epoch;
                    members.push(k);
                }
            }
        }
        self.near = near;
    }

    /// Brings `members` (just flooded by [`World::flood_moving`], so marked with this epoch) to
    /// now, makes them free, and lists their contacts: with each other, with the walls they
    /// touch and with the balls at rest they touch (supports).
    fn list_cluster_contacts(&mut self, members: &[usize], contacts: &mut Vec<Contact>) {
        for &m in members {
            self.end_static(m);
            self.sync(m);
        }
        let mut near = std::mem::take(&mut self.near);
        contacts.clear();
        for &m in members {
            let (x, r) = (self.hot[m].x, self.hot[m].r);
            let tol = 1e-6 * self.cold[m].diameter;
            for w in 0..4 {
                if self.wall_gap(w, x, r) <= tol {
                    contacts.push(Contact::Wall(m, w as u8));
                }
            }
            near.clear();
            self.cells.for_each_near(m, |k| near.push(k));
            for &k in &near {
                if k == m || !self.touching(m, k) {
                    continue;
                }
                let sigma = r + self.hot[k].r;
                if self.mark[k] == self.epoch {
                    if k > m {
                        contacts.push(Contact::Pair(m, k, self.hot[k].x - x, sigma));
                    }
                } else if self.cold[k].motion == Motion::Resting {
                    contacts.push(Contact::Support(m, k, x - self.hot[k].x, sigma));
                }
            }
        }
        self.near = near;
    }

    /// Projected Gauss–Seidel over `contacts` (see [`World::resolve_cluster`]): each contact's
    /// impulse `λ ≥ 0` into `lambda`, the members' velocities changed. A wall's normal velocity,
    /// one component, is set exactly rather than to a rounding of 0; what that takes is returned
    /// as the walls' impulse, for the caller to gauge, with whether every contact ended opening.
    fn solve_cluster(&mut self, contacts: &[Contact], lambda: &mut Vec<f64>) -> (DVec2, bool) {
        lambda.clear();
        lambda.resize(contacts.len(), 0.0);
        let mut walls = DVec2::ZERO;
        for _ in 0..MAX_CLUSTER_SWEEPS {
            for (c, contact) in contacts.iter().enumerate() {
                let (a, b, d) = contact.parts();
                let ia = self.cold[a].inverse_mass;
                let w = (ia + b.map_or(0.0, |b| self.cold[b].inverse_mass)) * d.length_squared();
                let new = (lambda[c] - contact.velocity(&self.hot) / w).max(0.0);
                let dl = new - lambda[c];
                lambda[c] = new;
                match b {
                    Some(b) => {
                        self.hot[a].v -= ia * dl * d;
                        self.hot[b].v += self.cold[b].inverse_mass * dl * d;
                    }
                    None => self.hot[a].v += ia * dl * d,
                }
            }
            for contact in contacts {
                if let Contact::Wall(a, w) = *contact {
                    let v = &mut self.hot[a].v;
                    let before = *v;
                    match w {
                        0 => v.x = v.x.max(0.0),
                        1 => v.x = v.x.min(0.0),
                        2 => v.y = v.y.max(0.0),
                        _ => v.y = v.y.min(0.0),
                    }
                    walls += self.cold[a].mass * (before - *v);
                }
            }
            if contacts.iter().all(|c| !c.closing(&self.hot)) {
                return (walls, true);
            }
            self.counters.cluster_sweeps += 1;
        }
        (walls, false)
    }

    /// Whether ball `k`'s supports (walls and balls at rest) can hold an impulse on it along
    /// `push`.
    fn holds(&mut self, k: usize, push: DVec2) -> bool {
        let x = self.hot[k].x;
        self.contact_normals(k, x);
        cone_contains(&self.normals, -push, CONE_SLACK)
    }

    /// The collision of balls i and j, which touch now.
    fn collide_pair(&mut self, i: usize, j: usize) {
        self.sync(i);
        self.sync(j);
        let (xi, xj) = (self.hot[i].x, self.hot[j].x);
        let dr = xj - xi;
        let dist = dr.length();
        let sigma = self.hot[i].r + self.hot[j].r;
        // NaN-safe: a distance that is not clearly positive counts as coincident.
        let coincident = dist.partial_cmp(&(1e-9 * sigma)) != Some(std::cmp::Ordering::Greater);
        let n = if coincident { coincident_normal(self.cold[i].id, self.cold[j].id) } else { dr / dist };
        // The impulse acts along `d = Δr` itself, not along the unit `n`: `Δv·d` is the dot
        // product the prediction judged the pair by (so its sign is the one that made the event
        // due, and the one the next prediction sees), and an impulse along `d` carries no
        // rounding of a normalisation. Along `n = Δr/|Δr|`, whose length is 1 only to rounding,
        // the rounding of `|n|²` does not average out: an elastic gas's energy drifts steadily
        // (6.7e-14 in 10⁶ collisions, see `tests/exact_gas.rs`); along `Δr` it only wanders by its
        // roundings (9e-16).
        let (d, len) = if coincident { (n, 1.0) } else { (dr, dist) };
        let v_rel = |h: &[Hot]| (h[j].v - h[i].v).dot(d);
        let vd = v_rel(&self.hot);
        // The relative normal speed, m/s (negative: closing).
        let vn = vd / len;
        // How hard their accelerations press them together (> 0) in the motions that made this
        // event due; judged again below in the motions the collision leaves them in.
        let press_before = -(self.hot[j].a - self.hot[i].a).dot(n);
        let hits = self.note_instant(i).max(self.note_instant(j));
        // Only slow collisions count towards the rules (the collapse regime); any towards the
        // backstop.
        let slow_hits = if vn > -self.params.collapse_speed { hits } else { 0 };
        let moving = |w: &World, k: usize| w.cold[k].motion != Motion::Resting;
        if hits > ELASTIC_AT_INSTANT || slow_hits > self.limits.1 {
            // Wedged: it comes to rest where it is (see `note_instant`), or, held by nothing,
            // moves on with the balls it touches as one.
            if moving(self, i) && moving(self, j) && self.clump(i, j) {
                self.counters.collisions += 1;
                return;
            }
            for k in [i, j] {
                if moving(self, k) {
                    self.counters.wedged += 1;
                    self.come_to_rest(k);
                    self.restart_course(k);
                    self.predict(k);
                }
            }
            self.counters.collisions += 1;
            self.predict_others([i, j]);
            return;
        }
        if slow_hits > self.limits.0 && moving(self, i) && moving(self, j) {
            self.resolve_cluster([i, j]);
            return;
        }
        // A ball at rest struck more slowly than the collapse speed, but fast enough that its
        // striker would hop off it (the rest model's rebound speed), is struck through to its
        // walls too when it is part of a row or a stack: held immovable, an elastic stack sent a
        // ball hopping on it a micrometre high for ever (4.7 mm/s on a column of three at e = 1,
        // floor 0.5), where the chain hands each hop down to the floor, which takes its share.
        let e = match self.effects.collisions {
            Some(c) => c.restitution,
            None => 1.0,
        };
        let slow_onto_rest = moving(self, i) != moving(self, j) && {
            let k = if moving(self, i) { i } else { j };
            let outgoing = -vn * soft_restitution(e, -vn, self.params.collapse_speed);
            outgoing >= self.rest_speed(k, self.free_accel(k).length())
        };
        if (-vn > self.params.collapse_speed || slow_onto_rest) && self.strike_simultaneous(i, j) {
            return;
        }
        let mob_i = self.mobility(i, -n);
        let mob_j = self.mobility(j, n);
        // A collision with a ball held immovable in a pile (a ball hopping in a pocket of balls
        // at rest, or striking one) passes its impulse through the pile to the walls that hold it, which
        // take what their restitution takes: with the balls' e = 1 on a floor of 0.5, such a hop
        // went on for ever, the pile giving back all of it.
        let held = mob_i == Mobility::Fixed || mob_j == Mobility::Fixed;
        let e = if held { e.min(self.field.restitution) } else { e };
        let e_eff = if slow_hits > self.limits.0 {
            self.counters.instant_plastic += 1;
            0.0
        } else {
            soft_restitution(e, -vn, self.params.collapse_speed)
        };
        if e_eff != e && slow_hits <= self.limits.0 {
            self.counters.soft_collisions += 1;
        }
        // A free ball meeting a ball at rest while it touches another support it also closes on:
        // the two contacts act at once (see `wedge_impact`).
        let wedge = match (mob_i, mob_j) {
            (Mobility::Free { .. }, Mobility::Fixed) => Some((i, -n)),
            (Mobility::Fixed, Mobility::Free { .. }) => Some((j, n)),
            _ => None,
        };
        if let Some((k, nk)) = wedge
            && self.wedge_impact(k, nk, e_eff)
        {
            self.counters.collisions += 1;
            self.counters.wedges += 1;
            self.settle(k);
            self.restart_course(k);
            self.predict(k);
            self.predict_others([k, k]);
            return;
        }
        // At least a few units of rounding of their speeds: an event made due by an approach of
        // rounding size (vn ~ −1e-17) must leave a pair that separates in the same arithmetic,
        // or it is due again at once, for ever.
        let floor = 4.0 * f64::EPSILON * (self.hot[i].v.length() + self.hot[j].v.length());
        // The outgoing speed, along `d` (elastic: exactly `−vd`) and in m/s for the rest model.
        let out_d = if vd < 0.0 { (-e_eff * vd).max(floor * len) } else { 0.0 };
        let outgoing = out_d / len;
        let (outgoing, out_d, rest) =
            self.rest_model([i, j], (n, d, len), vd, press_before, [mob_i, mob_j], (outgoing, out_d));
        self.strike_and_separate([i, j], d, sigma, (len, vd, outgoing, out_d, floor), [mob_i, mob_j], rest);
        self.predict(i);
        self.predict(j);
        self.predict_others([i, j]);
    }

    /// The fast collision of balls i and j (or a slow one onto a ball at rest that its striker
    /// would leave faster than the rest speed; which touch now), struck together with every other
    /// contact of the balls touching them now, through each other, and closing faster than the
    /// collapse speed: one round of simultaneous impacts
    /// ([`crate::physics::solve_simultaneous`]), so that a ball striking two touching balls
    /// between them leaves them as mirror images, and a ball at rest struck from both sides at
    /// once stays at rest, whatever their numbering.
    ///
    /// A ball at rest or sliding is struck as a free ball, the walls it lies on being contacts
    /// of the round ([`World::strike_through_rest`]); a ball at rest is in the round only if
    /// every ball at rest it touches is in the round too: struck in it (a ball on walls alone,
    /// two balls lying side by side on the floor that a ball dropped between them strikes at
    /// once), or joined to it with the balls at rest it touches through each other, when they
    /// are a row or a stack ([`World::resting_group`]: a row on the floor, struck along it as a
    /// cradle; a stack, struck through to the floor). A ball of a pile stays held immovable (the
    /// rest model): it is left out of the round and struck by its own event at this instant,
    /// its pile passing the impulse on to the walls.
    ///
    /// Returns false, and changes nothing, when i or j is a ball at rest left out, or when the
    /// round is the pair alone and neither is at rest (a binary collision, struck by
    /// [`World::collide_pair`] along `Δr` itself).
    fn strike_simultaneous(&mut self, i: usize, j: usize) -> bool {
        let resting = |w: &World, k: usize| w.cold[k].motion == Motion::Resting;
        let closing_fast = |w: &World, a: usize, b: usize| {
            let ((xa, va), (xb, vb)) = (w.at(a), w.at(b));
            let d = xb - xa;
            (vb - va).dot(d) < -w.params.collapse_speed * d.length()
        };
        // Nearly every collision of two moving balls is binary: that is told first, without
        // gathering anything, by the neighbours' distances (most are out of reach at once). A
        // collision with a ball at rest is always gathered: it is struck through to its walls
        // even alone.
        let other_contact = |w: &World, m: usize, partner: usize| {
            let (xm, rm, dm) = (w.hot[m].x, w.hot[m].r, w.cold[m].diameter);
            let mut found = false;
            w.cells.for_each_near(m, |k| {
                if found || k == m || k == partner {
                    return;
                }
                let h = &w.hot[k];
                let d = flight(h.x, h.v, h.a, w.now - h.t).0 - xm;
                let reach = rm + h.r + 1e-6 * dm.min(w.cold[k].diameter);
                found = d.length_squared() <= reach * reach && w.touching(m, k) && closing_fast(w, m, k);
            });
            found
        };
        if !resting(self, i) && !resting(self, j) && !other_contact(self, i, j) && !other_contact(self, j, i) {
            return self.strike_free_cluster(i, j);
        }
        let mut members = vec![i, j];
        let mut pairs = vec![(0usize, 1usize)];
        let mut left_out: Vec<usize> = Vec::new();
        // Balls at rest on walls joined to the round with the one they lie beside (see below).
        let mut joined: Vec<usize> = Vec::new();
        let mut near = Vec::new();
        loop {
            members.truncate(2);
            members.extend(joined.iter().filter(|&&k| k != i && k != j));
            pairs.truncate(1);
            // Never refused: every contact closing fast joins, until the round holds MAX_GROUP
            // balls (the neighbours of the member that reaches it may still take it past).
            self.gather_round(&mut members, &mut pairs, &mut near, MAX_GROUP, |w, _, m, k| {
                if left_out.contains(&k) || !w.touching(m, k) || !closing_fast(w, m, k) { Join::No } else { Join::Yes }
            });
            // A ball at rest that touches a ball at rest outside the round: the balls at rest it
            // touches through each other join the round if they are a row on walls or a stack;
            // else it is in a pile, left out, and the round gathered again without it. A ball
            // joined with such a group leaves the round when it is left out in turn (the round
            // grew past what its group may join), and a group with a ball left out does not join:
            // each ball is left out once at most and joins at most once, so the gathering ends.
            // (Left out again on each pass, a joined ball kept the loop going for ever: the round
            // stayed the same and the list of balls left out grew.)
            let (before, joined_before) = (left_out.len(), joined.len());
            for &m in &members {
                if !resting(self, m) || !self.touches_resting(m, |k| !members.contains(&k)) {
                    continue;
                }
                match self.resting_group(m, &members, &left_out) {
                    Some(group) => {
                        for k in group {
                            if !joined.contains(&k) {
                                joined.push(k);
                            }
                        }
                    }
                    None if !left_out.contains(&m) => left_out.push(m),
                    None => {}
                }
            }
            joined.retain(|k| !left_out.contains(k));
            if left_out.len() == before && joined.len() == joined_before {
                break;
            }
            if left_out.contains(&i) || left_out.contains(&j) {
                return false;
            }
        }
        let all_free = members.iter().all(|&m| self.cold[m].motion == Motion::Free);
        if pairs.len() == 1 && !resting(self, i) && !resting(self, j) {
            return false;
        }
        // i and j have their collision at this instant noted by the caller.
        for (s, &m) in members.iter().enumerate() {
            self.sync(m);
            if s >= 2 {
                self.note_instant(m);
            }
        }
        if pairs.len() > 1 {
            self.counters.simultaneous_rounds += 1;
        }
        if all_free {
            self.strike_free_round(&members, &pairs);
        } else {
            self.strike_through_rest(&members, &pairs);
        }
        for &m in &members {
            self.predict(m);
        }
        self.predict_others([i, j]);
        true
    }

    /// The fast collision of free balls i and j, which no other contact closing fast joins,
    /// struck in rounds with every free ball touching them through each other when that cluster
    /// holds another contact closing fast at this instant: a row of touching balls struck from
    /// both ends at once. Taken as events, the impacts at one instant go in the calendar's order
    /// (by ball index), and the wave from the end numbered first ran through the whole row before
    /// the other end's impact was struck (2.24 and −3.32 m/s for strikers leaving at ∓2.56 m/s).
    /// In rounds ([`World::strike_through_rest`], every touching pair a contact) the two waves
    /// advance together, as the stepped engines' rounds have them. Returns false, and changes
    /// nothing, when i and j touch nothing else, when the cluster holds a ball that is not free
    /// or more than [`MAX_GROUP`] balls, or when no other contact in it closes fast.
    fn strike_free_cluster(&mut self, i: usize, j: usize) -> bool {
        let mut members = vec![i, j];
        // The touching pairs the cluster is joined by: not the round's contacts, found below.
        let mut joined = vec![(0usize, 1usize)];
        // Every ball touching the cluster joins; one that is not free, or one past MAX_GROUP
        // balls, refuses it (so the gathering itself needs no limit).
        let whole = self.gather_round(&mut members, &mut joined, &mut Vec::new(), usize::MAX, |w, members, m, k| {
            if members.contains(&k) || !w.touching(m, k) {
                Join::No
            } else if w.cold[k].motion != Motion::Free || members.len() == MAX_GROUP {
                Join::Refuse
            } else {
                Join::Yes
            }
        });
        if !whole || members.len() == 2 {
            return false;
        }
        // The contacts closing fast, as slots in `members`; the pair (i, j) first.
        let speed = self.params.collapse_speed;
        let mut pairs = vec![(0usize, 1usize)];
        for a in 0..members.len() {
            for b in a + 1..members.len() {
                let (ka, kb) = (members[a], members[b]);
                if (a, b) == (0, 1) || !self.touching(ka, kb) {
                    continue;
                }
                let ((xa, va), (xb, vb)) = (self.at(ka), self.at(kb));
                let d = xb - xa;
                if (vb - va).dot(d) < -speed * d.length() {
                    pairs.push((a, b));
                }
            }
        }
        if pairs.len() == 1 {
            return false;
        }
        for (s, &m) in members.iter().enumerate() {
            self.sync(m);
            if s >= 2 {
                self.note_instant(m);
            }
        }
        self.counters.simultaneous_rounds += 1;
        self.strike_through_rest(&members, &pairs);
        for &m in &members {
            self.predict(m);
        }
        self.predict_others([i, j]);
        true
    }

    /// The balls at rest that ball `m` (at rest) touches through each other, outside `members`,
    /// if none of them is `left_out`, the round stays within [`MAX_GROUP`] balls, and they are
    /// a row (every one lies on a wall that holds it against its acceleration: a row lying on the
    /// floor, balls side by side in a corner) or a stack (at most [`MAX_STACK`] balls with
    /// `m`). They join the round whole, and the impulse goes through them to their walls as the
    /// chain of sequential impacts: a ball struck into a row passes the impulse along it (a
    /// cradle lying on the floor); a ball dropped on a stack of two on the floor at e = 1, floor
    /// 0.5, rebounds at half its speed, where the stack held immovable sent it back at all of it.
    /// `None` for a pile (a bigger group with a ball at rest on other balls), whose balls stay
    /// held immovable (the rest model), its walls taking the impulse.
    fn resting_group(&self, m: usize, members: &[usize], left_out: &[usize]) -> Option<Vec<usize>> {
        let on_a_wall = |k: usize| {
            let (x, r, tol) = (self.hot[k].x, self.hot[k].r, 1e-6 * self.cold[k].diameter);
            let a = self.free_accel(k);
            (0..4).any(|w| WALL_NORMALS[w].dot(a) < 0.0 && self.wall_gap(w, x, r) <= tol)
        };
        // The group from m (slot 0), its pairs not needed.
        let mut group = vec![m];
        let whole = self.gather_round(&mut group, &mut Vec::new(), &mut Vec::new(), usize::MAX, |w, group, s, k| {
            if w.cold[k].motion != Motion::Resting || members.contains(&k) || group.contains(&k) || !w.touching(s, k) {
                Join::No
            } else if left_out.contains(&k) || members.len() + group.len() > MAX_GROUP {
                Join::Refuse
            } else {
                Join::Yes
            }
        });
        let row_or_stack = group.len() <= MAX_STACK || group.iter().all(|&k| on_a_wall(k));
        (whole && row_or_stack).then(|| group.split_off(1))
    }

    /// Gathers the balls of a round of simultaneous impacts from `members` (the two of a
    /// collision, slots 0 and 1) through their neighbours, for [`World::strike_simultaneous`]
    /// and [`World::strike_free_cluster`], which differ only in which neighbours join (and a group
    /// of balls at rest from one of them, for [`World::resting_group`]): each
    /// member in turn, while there are fewer than `limit`, asks `joins(world, members, m, k)` of
    /// every other ball k near it (m the member) whether k joins by the pair (m, k); k is then
    /// added to `members` and the pair to `pairs` (as slots in `members`, the lower first), each
    /// if new. Returns false as soon as `joins` refuses the round, `members` and `pairs` left
    /// part-gathered; `near` is scratch.
    fn gather_round(
        &self,
        members: &mut Vec<usize>,
        pairs: &mut Vec<(usize, usize)>,
        near: &mut Vec<usize>,
        limit: usize,
        joins: impl Fn(&World, &[usize], usize, usize) -> Join,
    ) -> bool {
        let mut g = 0;
        while g < members.len() && members.len() < limit {
            let m = members[g];
            near.clear();
            self.cells.for_each_near(m, |k| near.push(k));
            for &k in near.iter() {
                if k == m {
                    continue;
                }
                match joins(self, members, m, k) {
                    Join::No => continue,
                    Join::Refuse => return false,
                    Join::Yes => {}
                }
                let slot = match members.iter().position(|&x| x == k) {
                    Some(s) => s,
                    None => {
                        members.push(k);
                        members.len() - 1
                    }
                };
                let pair = (g.min(slot), g.max(slot));
                if !pairs.contains(&pair) {
                    pairs.push(pair);
                }
            }
            g += 1;
        }
        true
    }

    /// Whether ball `k` touches a ball at rest that `counts` (within a millionth of `k`'s
    /// diameter).
    fn touches_resting(&self, k: usize, counts: impl Fn(usize) -> bool) -> bool {
        let (x, r, tol) = (self.hot[k].x, self.hot[k].r, 1e-6 * self.cold[k].diameter);
        let mut found = false;
        self.cells.for_each_near(k, |m| {
            if !found && m != k && self.cold[m].motion == Motion::Resting && counts(m) {
                found = self.hot[m].x.distance(x) - (r + self.hot[m].r) <= tol;
            }
        });
        found
    }

    /// A round of free balls `members` (synced to now) along their contacts `pairs` (slots in
    /// `members`), every one closing faster than the collapse speed: solved once, each contact
    /// with the scene's restitution (the converged round leaves none closing).
    fn strike_free_round(&mut self, members: &[usize], pairs: &[(usize, usize)]) {
        let e = self.effects.collisions.map_or(1.0, |c| c.restitution);
        let mut v: Vec<DVec2> = members.iter().map(|&m| self.hot[m].v).collect();
        let mut round: Vec<RoundContact> = pairs
            .iter()
            .map(|&(a, b)| {
                let (ka, kb) = (members[a], members[b]);
                let normal = (self.hot[kb].x - self.hot[ka].x)
                    .normalize_or(coincident_normal(self.cold[ka].id, self.cold[kb].id));
                // Every contact of the round closes faster than the collapse speed, so keeps the
                // scene's restitution (`soft_restitution` leaves it so).
                let vn = (v[b] - v[a]).dot(normal);
                RoundContact {
                    target: -e * vn,
                    ..RoundContact::new(a, Some(b), normal, self.cold[ka].inverse_mass, self.cold[kb].inverse_mass)
                }
            })
            .collect();
        let mut counts = RoundScratch::whole_rounds();
        solve_simultaneous(&mut round, &mut v, &mut counts, 0.0);
        self.counters.collisions += round.iter().filter(|c| c.impulse > 0.0).count() as u64;
        // Every velocity first: settling one member can put others to rest with it (a group at
        // rest), and a velocity set after that would move a ball at rest.
        for (&m, &vm) in members.iter().zip(&v) {
            self.hot[m].v = vm;
        }
        for &m in members {
            if self.cold[m].motion != Motion::Resting {
                self.settle(m);
            }
            self.restart_course(m);
        }
    }

    /// A round with balls at rest or sliding among `members` (synced to now; `pairs`, slots in
    /// `members`, are its contacts closing faster than the collapse speed), struck as the chain
    /// of sequential impacts it starts: each ball at rest or sliding is struck as a free ball
    /// and meets the walls it lies on with their restitution (and the balls of the round it
    /// touches, with the scene's), may meet its strikers again, and so on, in rounds of impacts
    /// at this instant ([`crate::physics::solve_simultaneous`]) until no contact closes. A ball
    /// dropped on a ball lying on the floor rebounds as the chain of binary impacts says (at
    /// e = 0.8, 2.83 m/s from 4.43 m/s, where holding the struck ball immovable gives e·v =
    /// 3.54 m/s); struck from both sides at once, a ball at rest stays at rest. A ball at rest
    /// then wakes if it leaves faster than its rest speed (free, or sliding along a wall it is
    /// pressed against), or stays at rest and passes on what it kept; a sliding ball leaves its
    /// wall if the round lifts it off; every impulse on a wall goes on its gauge.
    ///
    /// Only for balls at rest whose every neighbour at rest is in the round (see
    /// [`World::strike_simultaneous`]: a row or a stack of balls at rest joins it whole): a ball
    /// in a pile stays held immovable, its pile passing
    /// the impulse on to the walls (the rest model). Struck through to its neighbours at rest
    /// (held immovable) and woken when it leaves them, the 150-ball pile of
    /// `tests/exact_pile.rs` had up to 8 times the events in its busiest half second (1.0–8.2
    /// times over eight seeds and restitutions), and, with the wake threshold at twice the rest
    /// speed, one run (e = 0.9) did not get through a half second of simulated time in 7
    /// minutes: knocked surface balls rattle in their pockets at the collapse model's
    /// near-elastic slow restitution.
    fn strike_through_rest(&mut self, members: &[usize], pairs: &[(usize, usize)]) {
        let resting: Vec<bool> = members.iter().map(|&m| self.cold[m].motion == Motion::Resting).collect();
        let on_walls: Vec<bool> = members.iter().map(|&m| self.cold[m].motion != Motion::Free).collect();
        // Members that touch without closing (two balls at rest side by side) are contacts of
        // the round too: the chain may press them together.
        let mut pairs = pairs.to_vec();
        for a in 0..members.len() {
            for b in a + 1..members.len() {
                if !pairs.contains(&(a, b)) && self.touching(members[a], members[b]) {
                    pairs.push((a, b));
                }
            }
        }
        let e_balls = self.effects.collisions.map_or(1.0, |c| c.restitution);
        let contact = RoundContact::new;
        let mut contacts: Vec<(RoundContact, f64)> = pairs
            .iter()
            .map(|&(a, b)| {
                let (ka, kb) = (members[a], members[b]);
                let normal = (self.hot[kb].x - self.hot[ka].x)
                    .normalize_or(coincident_normal(self.cold[ka].id, self.cold[kb].id));
                (contact(a, Some(b), normal, self.cold[ka].inverse_mass, self.cold[kb].inverse_mass), e_balls)
            })
            .collect();
        // The walls of the balls at rest or sliding are immovable (the normal from the ball to
        // the wall). The free balls' walls are left to their events at this instant: with them
        // in the rounds, the 150-ball pile of `tests/exact_pile.rs` at e = 0.9 (seed 6) ground on
        // more than 2e7 events in a half second.
        for (s, &m) in members.iter().enumerate() {
            if !on_walls[s] {
                continue;
            }
            let (x, r, tol) = (self.hot[m].x, self.hot[m].r, 1e-6 * self.cold[m].diameter);
            for (k, inward) in WALL_NORMALS.iter().enumerate() {
                if self.wall_gap(k, x, r) <= tol {
                    contacts.push((contact(s, None, -*inward, self.cold[m].inverse_mass, 0.0), self.field.restitution));
                }
            }
        }
        let mut v: Vec<DVec2> = members.iter().map(|&m| self.hot[m].v).collect();
        let mut total = vec![0.0; contacts.len()];
        let (mut round, mut these) = (Vec::new(), Vec::new());
        let mut counts = RoundScratch::whole_rounds();
        // A contact closing by less than a few roundings of the speeds is not struck again.
        let slack = 4.0 * f64::EPSILON * v.iter().map(|u| u.length()).fold(0.0, f64::max);
        let (mut struck, mut bounced) = (0u64, 0u64);
        for _ in 0..MAX_REST_STRIKE_ROUNDS {
            round.clear();
            these.clear();
            for (k, (c, e)) in contacts.iter().enumerate() {
                let vn = (c.b.map_or(DVec2::ZERO, |b| v[b]) - v[c.a]).dot(c.normal);
                if vn < -slack {
                    let e = soft_restitution(*e, -vn, self.params.collapse_speed);
                    round.push(k);
                    these.push(RoundContact { target: -e * vn, ..*c });
                }
            }
            if round.is_empty() {
                break;
            }
            solve_simultaneous(&mut these, &mut v, &mut counts, 0.0);
            for (&k, c) in round.iter().zip(&these) {
                total[k] += c.impulse;
                if c.impulse > 0.0 {
                    match c.b {
                        Some(_) => struck += 1,
                        None => bounced += 1,
                    }
                }
            }
        }
        for ((c, _), &lambda) in contacts.iter().zip(&total) {
            if c.b.is_none() && lambda > 0.0 {
                transmit(&mut self.impulses, lambda * c.normal);
            }
        }
        self.counters.collisions += struck;
        self.counters.wall_bounces += bounced;
        self.counters.rest_strikes += resting.iter().filter(|&&r| r).count() as u64;
        // Every velocity first (as in `strike_free_round`): the moving members', then the balls
        // at rest woken (before anything settles on them) or left at rest.
        for (s, &m) in members.iter().enumerate() {
            if !resting[s] {
                self.leave_with(m, v[s], slack);
            }
        }
        for (s, &m) in members.iter().enumerate() {
            if !resting[s] {
                continue;
            }
            let a = self.free_accel(m).length();
            // A member woken already (it leaned on another that woke) takes its velocity too.
            if v[s].length() >= self.rest_speed(m, a) || self.cold[m].motion != Motion::Resting {
                // Free, or sliding on a wall it is pressed against and moves along (a ball
                // knocked sideways along the floor).
                self.wake(m);
                self.leave_with(m, v[s], slack);
            } else {
                transmit(&mut self.impulses, self.cold[m].mass * v[s]);
            }
        }
        for &m in members {
            if self.cold[m].motion != Motion::Resting {
                self.settle(m);
            }
            self.restart_course(m);
        }
    }

    /// Sets the velocity `v` a round leaves moving ball `m` with: a ball sliding on a wall
    /// leaves it if `v` points off it by more than `slack` (rounding), else the wall takes what
    /// is left of the normal part.
    fn leave_with(&mut self, m: usize, mut v: DVec2, slack: f64) {
        if let Motion::Sliding(w) = self.cold[m].motion {
            let inward = WALL_NORMALS[w as usize];
            if v.dot(inward) > slack {
                self.end_static(m);
            } else {
                let normal_part = v.dot(inward) * inward;
                transmit(&mut self.impulses, self.cold[m].mass * normal_part);
                v -= normal_part;
            }
        }
        self.hot[m].v = v;
    }

    /// The rest model of [`World::collide_pair`]: a pair pressed together (their accelerations
    /// in the motions this collision leaves them in close the gap) that would part slower than a
    /// hop of the rest height either comes to rest plastically (if every ball that moves can
    /// stay where it is) or hops at that speed. `out` is the outgoing speed (m/s) and the same
    /// along `d` before the model; returns them after it, and which of the two come to rest.
    #[allow(clippy::too_many_arguments)]
    fn rest_model(
        &mut self,
        [i, j]: [usize; 2],
        (n, d, len): (DVec2, DVec2, f64),
        vd: f64,
        press_before: f64,
        [mob_i, mob_j]: [Mobility; 2],
        (mut outgoing, mut out_d): (f64, f64),
    ) -> (f64, f64, [bool; 2]) {
        let accel = |w: &World, k: usize, m: Mobility| match m {
            Mobility::Fixed => DVec2::ZERO,
            Mobility::Sliding { wall, .. } => {
                let a = w.free_accel(k);
                a - a.dot(wall) * wall
            }
            Mobility::Free { .. } => w.free_accel(k),
        };
        let press = press_before.max(-(accel(self, j, mob_j) - accel(self, i, mob_i)).dot(n));
        let h = self.params.rest_height * self.cold[i].diameter.min(self.cold[j].diameter);
        let v_rest = if press > 0.0 { (2.0 * press * h).sqrt() } else { 0.0 };
        let mut rest = [false; 2];
        if outgoing < v_rest {
            // Plastic first: can the moving ones stay where they are?
            if let Some(c) = collide(d, vd, 0.0, mob_i, mob_j) {
                for (s, (k, dv, m)) in
                    [(i, c.velocity_change_a, mob_i), (j, c.velocity_change_b, mob_j)].into_iter().enumerate()
                {
                    if m != Mobility::Fixed {
                        let speed = (self.hot[k].v + dv).length();
                        let a = self.free_accel(k).length();
                        rest[s] = speed < self.rest_speed(k, a) && self.supported(k);
                    }
                }
            }
            // Plastic only if every ball that moves stays: a ball at rest under one that is not
            // would only be pressed again at once.
            let movable = [mob_i != Mobility::Fixed, mob_j != Mobility::Fixed];
            if (rest[0] || !movable[0]) && (rest[1] || !movable[1]) {
                outgoing = 0.0;
            } else {
                rest = [false; 2];
                outgoing = v_rest;
                self.counters.hops += 1;
            }
            out_d = outgoing * len;
        }
        (outgoing, out_d, rest)
    }

    /// The impulse of [`World::collide_pair`], topped up until the pair separates, then each
    /// moving ball at rest or settled on its new course: `(vd, outgoing, out_d, floor)` are the
    /// closing speed along `d`, the outgoing speed (m/s) and along `d`, and the rounding floor
    /// of their speeds (m/s).
    fn strike_and_separate(
        &mut self,
        [i, j]: [usize; 2],
        d: DVec2,
        sigma: f64,
        (len, vd, outgoing, out_d, floor): (f64, f64, f64, f64, f64),
        [mob_i, mob_j]: [Mobility; 2],
        rest: [bool; 2],
    ) {
        let v_rel = |h: &[Hot]| (h[j].v - h[i].v).dot(d);
        if let Some(c) = collide(d, vd, out_d, mob_i, mob_j) {
            self.apply_collision(i, j, d, c, mob_i, mob_j);
        }
        // Rounding can leave the pair closing by a hair (an outgoing speed of rounding size):
        // top the impulse up by the floor until it separates, else it would be due again at
        // once, for ever.
        for _ in 0..4 {
            let after = v_rel(&self.hot);
            if after >= -closing_slack(sigma, l1(self.hot[i].v) + l1(self.hot[j].v)) {
                break;
            }
            let Some(c) = collide(d, after, (outgoing.max(0.0) + floor) * len, mob_i, mob_j) else { break };
            self.apply_collision(i, j, d, c, mob_i, mob_j);
            self.counters.separation_fixes += 1;
        }
        self.counters.collisions += 1;
        for (s, k, m) in [(0, i, mob_i), (1, j, mob_j)] {
            if m == Mobility::Fixed {
                continue;
            }
            if rest[s] {
                self.come_to_rest(k);
            } else {
                self.settle(k);
            }
            self.restart_course(k);
        }
    }

    /// Applies collision `c` of balls i and j along `d` (the direction [`collide`] was given),
    /// the constraints' shares to the gauges.
    fn apply_collision(&mut self, i: usize, j: usize, d: DVec2, c: Collision, mob_i: Mobility, mob_j: Mobility) {
        self.hot[i].v += c.velocity_change_a;
        self.hot[j].v += c.velocity_change_b;
        self.gauge_constraint(mob_i, -c.impulse * d);
        self.gauge_constraint(mob_j, c.impulse * d);
    }

    /// A free ball `k` that closes on a support along `nk` (the contact normal, pointing into
    /// `k`) while it touches one other support (a wall or a ball at rest) that it closes on too,
    /// now or once bounced off the first: both
    /// contacts take their impulses at once, each reversing its normal velocity with its
    /// restitution, `v′·n₁ = −e₁·v·n₁` and `v′·n₂ = −e₂·v·n₂` (in 2D the two fix `v′`).
    ///
    /// Resolved one after the other, such a pair of contacts passes the ball back and forth,
    /// each collision turning a little of the velocity from one normal to the other: a ball that
    /// drops into a gap a hair narrower than itself would take some 10⁵ collisions at one
    /// instant. Returns false (and changes nothing) unless exactly one other support is closed on,
    /// both impulses push and the ball leaves every support it touches.
    fn wedge_impact(&mut self, k: usize, nk: DVec2, ek: f64) -> bool {
        let v = self.hot[k].v;
        if v.dot(nk) >= 0.0 {
            return false;
        }
        let (x, r) = (self.hot[k].x, self.hot[k].r);
        self.contact_normals(k, x);
        let tol = 1e-6 * self.cold[k].diameter;
        let walls: Vec<DVec2> = (0..4).filter(|&w| self.wall_gap(w, x, r) <= tol).map(|w| WALL_NORMALS[w]).collect();
        // The other support it closes on now, or would close on once bounced off the first.
        let v1 = v - (1.0 + ek) * v.dot(nk) * nk;
        let mut other = None;
        for &c in &self.normals {
            if (c - nk).length_squared() < 1e-24 || (v.dot(c) >= 0.0 && v1.dot(c) >= 0.0) {
                continue;
            }
            if other.is_some() {
                return false;
            }
            other = Some(c);
        }
        let Some(nc) = other else { return false };
        let det = nk.perp_dot(nc);
        if det.abs() < 1e-12 {
            return false;
        }
        let ec = if walls.contains(&nc) {
            soft_restitution(self.field.restitution, -v.dot(nc), self.params.collapse_speed)
        } else {
            soft_restitution(
                self.effects.collisions.map_or(1.0, |c| c.restitution),
                -v.dot(nc),
                self.params.collapse_speed,
            )
        };
        let (tk, tc) = (-ek * v.dot(nk), -ec * v.dot(nc));
        let v_new = DVec2::new(tk * nc.y - tc * nk.y, nk.x * tc - nc.x * tk) / det;
        let dv = v_new - v;
        let m = self.cold[k].mass;
        let (lk, lc) = (m * dv.perp_dot(nc) / det, m * nk.perp_dot(dv) / det);
        if lk < 0.0 || lc < 0.0 || self.normals.iter().any(|n| v_new.dot(*n) < -1e-12 * v_new.length()) {
            return false;
        }
        self.hot[k].v = v_new;
        transmit(&mut self.impulses, -lk * nk);
        transmit(&mut self.impulses, -lc * nc);
        true
    }

    /// Ball i meets wall `k` now.
    fn bounce(&mut self, i: usize, k: usize) {
        self.sync(i);
        let n = WALL_NORMALS[k];
        let v = self.hot[i].v;
        let vn = v.dot(n);
        let hits = self.note_instant(i);
        let slow_hits = if vn > -self.params.collapse_speed { hits } else { 0 };
        if hits > ELASTIC_AT_INSTANT || slow_hits > self.limits.1 {
            self.counters.wedged += 1;
            self.counters.wall_bounces += 1;
            self.come_to_rest(i);
            self.restart_course(i);
            self.predict(i);
            self.predict_others([i, i]);
            return;
        }
        let e = if slow_hits > self.limits.0 {
            self.counters.instant_plastic += 1;
            0.0
        } else {
            let e = soft_restitution(self.field.restitution, -vn, self.params.collapse_speed);
            if e != self.field.restitution {
                self.counters.soft_collisions += 1;
            }
            e
        };
        let outgoing = if vn < 0.0 { -e * vn } else { 0.0 };
        let press = -self.hot[i].a.dot(n);
        let m = self.cold[i].mass;
        let landed = outgoing < self.rest_speed(i, press);
        let new_vn = if landed { 0.0 } else { outgoing };
        // The normal component set exactly (the walls are axis-aligned).
        let mut v_new = v;
        if k < 2 {
            v_new.x = new_vn * n.x;
        } else {
            v_new.y = new_vn * n.y;
        }
        transmit(&mut self.impulses, m * (v - v_new));
        self.hot[i].v = v_new;
        self.counters.wall_bounces += 1;
        if !self.settle(i) && landed {
            if self.cold[i].motion == Motion::Free {
                self.bank_static(i);
                self.cold[i].motion = Motion::Sliding(k as u8);
                self.counters.slides += 1;
            } else if let Motion::Sliding(w) = self.cold[i].motion
                && w as usize != k
            {
                // Into a corner while sliding: held by both walls.
                self.come_to_rest(i);
            }
        }
        self.restart_course(i);
        self.predict(i);
        self.predict_others([i, i]);
    }

    // ---- commands -----------------------------------------------------------------------

    /// Sets the pull on the key ball (N). Only its course changes: it is cut now and predicted
    /// again (woken first if it was at rest, off its wall if the pull lifts it).
    pub fn set_pull(&mut self, force: DVec2) {
        let Some(k) = self.key_index() else { return };
        if self.cold[k].force == force {
            return;
        }
        self.sync(k);
        self.bank_static(k);
        if self.cold[k].motion == Motion::Resting {
            self.wake(k);
        }
        self.cold[k].force = force;
        if let Motion::Sliding(w) = self.cold[k].motion
            && self.free_accel(k).dot(WALL_NORMALS[w as usize]) >= 0.0
        {
            self.end_static(k);
        }
        self.restart_course(k);
        self.predict(k);
        self.predict_others([k, k]);
    }

    /// The pull on the key ball now, N.
    pub fn pull(&self) -> DVec2 {
        self.key_index().map_or(DVec2::ZERO, |k| self.cold[k].force)
    }

    /// Sets ball `i`'s velocity now (it is free afterwards).
    pub fn set_velocity(&mut self, i: usize, velocity: DVec2) {
        self.sync(i);
        if self.cold[i].motion == Motion::Resting {
            self.wake(i);
        }
        self.end_static(i);
        self.hot[i].v = velocity;
        self.restart_course(i);
        self.predict(i);
        self.predict_others([i, i]);
    }

    /// Sets ball `i`'s mass (its course changes only if it is pulled).
    pub fn set_mass(&mut self, i: usize, mass: f64) {
        self.sync(i);
        self.bank_static(i);
        self.cold[i].mass = mass;
        self.cold[i].inverse_mass = 1.0 / mass;
        self.restart_course(i);
        self.predict(i);
    }

    /// Sets the walls' and the balls' restitution (from the next collision on).
    pub fn set_restitution(&mut self, walls: f64, balls: f64) {
        self.field.restitution = walls;
        if let Some(c) = &mut self.effects.collisions {
            c.restitution = balls;
        }
        self.set_limits();
    }

    /// Switches the effects (drag and attraction ignored): every ball is predicted again.
    pub fn set_effects(&mut self, effects: Effects, params: ExactParams) {
        for i in 0..self.len() {
            self.bank_static(i);
        }
        self.effects = Effects { drag: None, attraction: None, ..effects };
        self.gravity = effects.gravity.map_or(DVec2::ZERO, |g| g.g);
        self.params = params;
        self.rebuild();
    }

    /// Adds a ball (with a fresh id unless `keep_id`), then predicts every ball again.
    pub fn insert(&mut self, mut ball: Ball, keep_id: bool) -> Result<BallId, crate::engine::EngineError> {
        use crate::engine::EngineError;
        if self.len() >= self.max_balls {
            return Err(EngineError::TooManyBalls { limit: self.max_balls });
        }
        if keep_id {
            if self.index_of(ball.id).is_some() {
                return Err(EngineError::IdInUse(ball.id));
            }
        } else {
            ball.id = BallId(self.next_id);
        }
        self.next_id = self.next_id.max(ball.id.0 + 1);
        let pull = self.pull();
        let mut balls = Vec::new();
        self.sample(&mut balls);
        let at = balls.partition_point(|b| b.id < ball.id);
        balls.insert(at, ball);
        self.reload(&balls, pull);
        Ok(ball.id)
    }

    /// Takes ball `i` off the field (the others predicted again).
    pub fn remove(&mut self, i: usize) -> Ball {
        let pull = self.pull();
        let mut balls = Vec::new();
        self.sample(&mut balls);
        let ball = balls.remove(i);
        self.reload(&balls, pull);
        ball
    }

    /// Replaces the balls with `balls` (sorted by id) at the current instant.
    fn reload(&mut self, balls: &[Ball], pull: DVec2) {
        for i in 0..self.len() {
            self.bank_static(i);
        }
        self.hot.clear();
        self.cold.clear();
        self.count.clear();
        self.memo.clear();
        self.mark.clear();
        for b in balls {
            self.push_ball(*b);
        }
        if let Some(k) = self.key_index() {
            self.cold[k].force = pull;
        }
        self.rebuild();
    }
}
