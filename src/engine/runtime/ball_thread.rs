//! The life of one ball on its own thread: measure dt, sub-step the effects, bounce off the
//! walls, apply the messages in its inbox, publish to the table, wait for the next cycle.
//!
//! **Time.** A ball's state is of an instant on the runtime clock (`Shared::clock`), published
//! with it. Each cycle the ball integrates from that instant to the clock now, but never past the
//! monitor's horizon: the instant up to which the monitor has judged every contact. A ball that
//! wakes late (the machine starved it) catches up to the horizon; what the monitor judged for it
//! meanwhile is in its inbox, each response applied as at its own instant. A ball that wakes after
//! a stall of the whole process finds the horizon where the monitor left it and waits for the
//! next pass, which drops the stalled time from the clock: it never integrates through contacts
//! nobody watched.

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, TryRecvError};
use glam::DVec2;

use super::contact_ring::ContactRing;
use super::message::{Contact, Message, clock_seconds};
use super::shared::{Params, Shared};
use super::table::BallRecord;
use super::wide_registers::WideRegisters;
use crate::physics::Field;
use crate::physics::{
    Attraction, Ball, BallForces, BallKind, BallProps, BallSteps, Effects, Forces, IntegratorScratch, NearBall,
    OtherBalls, SpanRates, StepPolicy, WallImpulses, advance_ball, attraction_force, attraction_rate_squared,
    contact_ball_wall, near_force,
};

/// Clears the ball's slot if its thread unwinds, so nobody keeps reading a ghost, and counts the
/// panic. The runtime reports it when it joins the thread.
struct PanicGuard<'a> {
    shared: &'a Shared,
    slot: usize,
}

impl Drop for PanicGuard<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            // This thread is still the slot's only writer, so it may clear it.
            self.shared.table.clear(self.slot);
            // Relaxed: a statistic, read only for reports.
            self.shared.panicked.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// What the thread keeps between cycles.
struct BallState {
    ball: Ball,
    slot: usize,
    pull: DVec2,
    applied: u64,
    updates: u64,
    walls: WallImpulses,
    /// The instant the state is of (runtime clock, ns).
    time: u64,
    /// Contact messages received and not applied yet, oldest first (see `catch_up`).
    held: VecDeque<Contact>,
    /// Contact responses taken from the ring and from the channel so far (see `contact_ring`).
    taken: u64,
    from_channel: u64,
    /// Cycles since the last flush that took attraction from the tree / read the table directly.
    tree_cycles: u64,
    direct_cycles: u64,
    /// This ball's longest cycle so far, as `Shared::pack_cycle` packs it.
    longest_cycle: u64,
    /// Whether the monitor has put the ball to sleep (see [`Rest`]): its cycles then move the
    /// clock on and nothing else, until a wake.
    asleep: bool,
}

/// What a ball thread reuses from cycle to cycle, so that a cycle allocates nothing.
struct CycleScratch {
    integrator: IntegratorScratch,
    /// The force passes of the parameters' effects, the very ones lockstep runs; built again only
    /// when the parameters change (their generation moved), as building allocates. Boxed: most of
    /// a `Forces` is lockstep's whole-field scratch, which a ball thread never touches, and on the
    /// stack it makes the ball threads' stacks reach further (0.6–1.3 KB more memory per ball at
    /// 1,024 attracting balls).
    forces: Box<Forces>,
    /// The other balls, read directly from the table (attraction below TREE_MIN_BALLS).
    others: Vec<BallRecord>,
    /// The near balls of the tree snapshot, copied (attraction from TREE_MIN_BALLS on).
    near: Vec<NearBall>,
}

impl CycleScratch {
    fn new(effects: &Effects) -> Self {
        CycleScratch {
            integrator: IntegratorScratch::default(),
            forces: Box::new(Forces::new(effects)),
            others: Vec::new(),
            near: Vec::new(),
        }
    }
}

/// A ball adds its attraction cycle counts to the shared counters every this many updates (and
/// when it pauses or stops): see `Shared::attraction_tree_cycles`.
const COUNTER_FLUSH: u64 = 16;

/// Where a cycle's attraction came from.
#[derive(Clone, Copy, PartialEq, Eq)]
enum AttractionSource {
    Off,
    Tree,
    Direct,
}

impl BallState {
    fn publish(&self, shared: &Shared, params: &Params) {
        let gravity = params.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
        shared.table.write(
            self.slot,
            &BallRecord {
                slot: self.slot,
                ball: self.ball,
                applied: self.applied,
                updates: self.updates,
                wall_impulses: self.walls,
                time: self.time,
                acceleration: gravity + self.pull / self.ball.mass,
                asleep: self.asleep,
            },
        );
    }

    /// Applies a contact response as at its stamp (see [`Contact`]), now, at the state's instant.
    fn apply(&mut self, m: &Contact, params: &Params) {
        self.ball.velocity += m.dv;
        self.ball.position += m.shift_at(self.time, params.time_scale);
        self.applied += 1;
        // Without collisions (a response came before they were turned off), a shift that takes
        // the ball past a wall is bounced back, as in a step.
        let r = self.ball.radius();
        ball_walls(
            &mut self.ball.position,
            &mut self.ball.velocity,
            r,
            self.ball.mass,
            DVec2::ZERO,
            params,
            &mut self.walls,
        );
    }

    fn count(&mut self, source: AttractionSource) {
        match source {
            AttractionSource::Off => {}
            AttractionSource::Tree => self.tree_cycles += 1,
            AttractionSource::Direct => self.direct_cycles += 1,
        }
    }

    fn flush_counts(&mut self, shared: &Shared) {
        // Relaxed: statistics only.
        if self.tree_cycles > 0 {
            shared.attraction_tree_cycles.fetch_add(std::mem::take(&mut self.tree_cycles), Ordering::Relaxed);
        }
        if self.direct_cycles > 0 {
            shared.attraction_direct_cycles.fetch_add(std::mem::take(&mut self.direct_cycles), Ordering::Relaxed);
        }
    }
}

enum Handled {
    Continue,
    /// The thread slept (the stall test hook, built only with the feature `test-hooks`).
    #[cfg_attr(not(feature = "test-hooks"), allow(dead_code))]
    Stalled,
    Stop,
}

/// Runs one ball until it is told to stop (or every sender is gone); returns how many contact
/// messages it was sent and never applied (those in flight when it stopped). `ball` is already in
/// the table at `slot` (written by the runtime before this thread started).
///
/// Each cycle: wait for it, take what arrived ([`take_arrivals`]), pick up new parameters, then
/// either stand at the horizon while paused ([`Cycles::paused`]) or catch up to the clock
/// ([`Cycles::running`]).
pub(crate) fn run_ball(
    shared: Arc<Shared>,
    slot: usize,
    ball: Ball,
    inbox: Receiver<Message>,
    contacts: Arc<ContactRing>,
) -> u64 {
    let _guard = PanicGuard { shared: &shared, slot };
    // The key ball is the one the player steers and watches: it keeps the ordinary policy, so its
    // updates (the pull's answer) never wait behind the crowd or another program's load. One
    // thread more at the ordinary policy costs the window nothing measurable.
    if ball.kind != BallKind::Key {
        background_scheduling();
    }
    let cycle = shared.config.ball_cycle;
    // The runtime wrote the first record, with the instant it was placed at.
    let time = shared.table.read(slot).map_or_else(|| shared.clock(Instant::now()), |r| r.time);
    let state = BallState {
        ball,
        slot,
        pull: DVec2::ZERO,
        applied: 0,
        updates: 0,
        walls: WallImpulses::default(),
        time,
        held: VecDeque::new(),
        taken: 0,
        from_channel: 0,
        tree_cycles: 0,
        direct_cycles: 0,
        longest_cycle: 0,
        asleep: false,
    };
    let params: Params = shared.params.read().clone();
    // Acquire pairs with the Release increment in `Shared::update_params`: seeing the new
    // generation means the read lock below returns the parameters written before it.
    let mut generation = shared.params_generation.load(Ordering::Acquire);
    let scratch = CycleScratch::new(&params.effects);
    let mut ball = Cycles { shared: &shared, state, commands: Commands::default(), params, scratch };
    let mut last = Instant::now();
    let mut waiter = Waiter::new(shared.epoch, cycle, shared.config.yield_when_crowded);
    let wide = WideRegisters::detect();
    loop {
        // Before each wait: a switch with the AVX-512 registers in use saves and restores them
        // (see `wide_registers`); the thread starts with them in use, copied from its parent.
        wide.release();
        let mut now = waiter.wait(last);
        let Some((horizon, received)) =
            take_arrivals(&shared, &inbox, &contacts, &mut ball.state, &mut ball.commands, &mut now)
        else {
            let Cycles { mut state, mut commands, params, .. } = ball;
            commands.apply(&mut state);
            state.publish(&shared, &params);
            state.flush_counts(&shared);
            // Everything the monitor sent is in the inbox by now (it sends nothing once the
            // runtime has taken the ball off its list, before the stop): what the ball holds and
            // what is left in its ring were sent and will never be applied.
            take_ring(&contacts, &mut state);
            return state.held.len() as u64;
        };
        last = now;
        let g = shared.params_generation.load(Ordering::Acquire);
        if g != generation {
            generation = g;
            ball.params = shared.params.read().clone();
            *ball.scratch.forces = Forces::new(&ball.params.effects);
        }
        // Relaxed: pausing carries no data; a ball that notices a cycle late loses nothing. A
        // command sent after the pause was asked for is seen with it: the send happens after the
        // store, and the receive above after the send (the channel orders them).
        if shared.paused.load(Ordering::Relaxed) {
            ball.paused(horizon, received);
        } else {
            ball.running(now, horizon, received);
        }
    }
}

/// What a ball's thread carries from cycle to cycle: its state, the commands not yet in effect,
/// the parameters and the scratch memory of its cycles.
struct Cycles<'a> {
    shared: &'a Shared,
    state: BallState,
    /// Commands taken from the inbox and not yet in effect (see `Commands`).
    commands: Commands,
    params: Params,
    scratch: CycleScratch,
}

/// Takes what arrived since the last cycle; returns the horizon the monitor had published by
/// then and whether anything arrived, or `None` when the ball is told to stop. The horizon is
/// read before the inbox (Acquire; see `Shared::horizon`): every contact message of the pass
/// that published it is in the inbox by then. A stall (the test hook sleeps while the inbox is
/// taken) ends with both read again and `now` moved to its end: the cycle starts after it, as it
/// would after a stall of the thread before the cycle.
fn take_arrivals(
    shared: &Shared,
    inbox: &Receiver<Message>,
    contacts: &ContactRing,
    state: &mut BallState,
    commands: &mut Commands,
    now: &mut Instant,
) -> Option<(u64, bool)> {
    let mut received = false;
    loop {
        let horizon = shared.horizon.load(Ordering::Acquire);
        match take_inbox(inbox, contacts, state, commands) {
            Inbox::Quiet => return Some((horizon, received)),
            Inbox::Received => return Some((horizon, true)),
            Inbox::Stalled => {
                received = true;
                *now = Instant::now();
            }
            Inbox::Stop => return None,
        }
    }
}

impl Cycles<'_> {
    /// A cycle while paused. The monitor judges nothing while paused, so the horizon stands: the
    /// ball catches up to it, applying each response it holds at its instant, and stops there.
    /// The paused table is then one instant for every ball, with every message applied (the
    /// monitor sees them applied). That is at most a horizon of simulated time after the pause
    /// was asked for.
    fn paused(&mut self, horizon: u64, received: bool) {
        let Cycles { shared, state, commands, params, scratch } = self;
        state.flush_counts(shared);
        let (from, applied) = (state.time, state.applied);
        catch_up(horizon, horizon, state, params, shared.config.max_step, shared, scratch);
        // The commands take effect at the paused instant, so that a velocity set while paused is
        // the velocity the paused table shows: once the ball stands at the horizon as it is now
        // (the one read before may be older, if the thread waited since).
        let commanded = state.time >= shared.horizon.load(Ordering::Acquire) && commands.apply(state);
        if received || commanded || state.applied != applied || state.time != from {
            state.publish(shared, params);
        }
    }

    /// A cycle while running: the commands take effect, then the ball catches up to the clock
    /// at `now`, no further than the horizon, and publishes if anything changed.
    fn running(&mut self, now: Instant, horizon: u64, received: bool) {
        let Cycles { shared, state, commands, params, scratch } = self;
        let commanded = commands.apply(state);
        let clock = shared.clock(now);
        if clock > horizon {
            // Relaxed: a statistic.
            shared.horizon_waits.fetch_add(1, Ordering::Relaxed);
        }
        let (from, applied) = (state.time, state.applied);
        let source = catch_up(clock.min(horizon), horizon, state, params, shared.config.max_step, shared, scratch);
        if state.time > from {
            state.count(source);
            state.updates += 1;
        }
        if state.time > from || state.applied != applied || received || commanded {
            state.publish(shared, params);
        }
        if state.updates.is_multiple_of(COUNTER_FLUSH) {
            state.flush_counts(shared);
        }
    }
}

/// What taking the inbox came to.
enum Inbox {
    /// Nothing arrived.
    Quiet,
    /// Messages arrived and were taken.
    Received,
    /// Messages arrived, and one was a stall (the test hook): the thread slept while taking them.
    Stalled,
    /// The ball is to stop (told to, or every sender is gone).
    Stop,
}

/// Takes every message in the inbox: contact responses are held (applied in `catch_up`) in the
/// order the monitor sent them, commands kept in `commands` until they take effect.
///
/// The order (see `contact_ring`): the ring first, and the ring again before each response from
/// the channel (the ring may have filled while the thread was away since, a stall or the machine
/// starving it, with responses older than that one); each response from the channel is counted
/// for the monitor once it is held, which is when the monitor may use the ring again.
fn take_inbox(
    inbox: &Receiver<Message>,
    contacts: &ContactRing,
    state: &mut BallState,
    commands: &mut Commands,
) -> Inbox {
    let mut got = if take_ring(contacts, state) { Inbox::Received } else { Inbox::Quiet };
    loop {
        match inbox.try_recv() {
            Ok(message) => {
                let contact = matches!(message, Message::Contact(_));
                if contact {
                    take_ring(contacts, state);
                }
                let handled = handle(message, state, commands);
                if contact {
                    state.from_channel += 1;
                    contacts.note_from_channel(state.from_channel);
                }
                match handled {
                    Handled::Stop => return Inbox::Stop,
                    Handled::Stalled => got = Inbox::Stalled,
                    Handled::Continue => {
                        if let Inbox::Quiet = got {
                            got = Inbox::Received;
                        }
                    }
                }
            }
            Err(TryRecvError::Empty) => return got,
            Err(TryRecvError::Disconnected) => return Inbox::Stop,
        }
    }
}

/// Takes every response in the ring into `held`; returns whether there was any.
fn take_ring(contacts: &ContactRing, state: &mut BallState) -> bool {
    let before = state.taken;
    while let Some(contact) = contacts.pop(&mut state.taken) {
        state.held.push_back(contact);
    }
    if state.taken == before {
        return false;
    }
    contacts.release(state.taken);
    true
}

/// Integrates the ball from its state's instant towards `target` (runtime clock), applying each
/// held contact response on the way at the instant it is due (its `apply_at`; already due ones at
/// once), so the ball never integrates through an impact the monitor judged. Responses not due
/// by `target` stay held. `horizon` is the monitor's horizon read with the inbox: an instant of
/// the grid (see [`Grid`]). Returns where the last stretch's attraction came from.
///
/// The ball's stretches are the monitor's (see `monitor::follow` and `Motion::advance`, which
/// carry the ball the same way): up to each response's `apply_at`, and once a response is
/// applied, on to the end of the span it was judged over (its `stamp`), even past `target` and
/// the horizon read before the inbox (a response is in the inbox only once its span is judged,
/// every contact of the ball in it included); free motion only up to the last instant of the
/// grid at or before `target`; and every stretch cut at the grid's instants. The ball then ends
/// where the monitor put it, under any integrator: cut at the ball's own cycles instead, a
/// stretch ends elsewhere under one that is not exact for a uniform force (semi-implicit Euler
/// drops `g·Σh²/2` over steps `h`), a ball resting in a pile rose a few micrometres above where
/// the monitor had put it every pass and fell back the next, and two balls in flight did not move
/// in a straight line relative to each other.
#[allow(clippy::too_many_arguments)]
fn catch_up(
    target: u64,
    horizon: u64,
    state: &mut BallState,
    params: &Params,
    max_step: f64,
    shared: &Shared,
    scratch: &mut CycleScratch,
) -> AttractionSource {
    let grid = shared.grid(horizon);
    let mut source = AttractionSource::Off;
    let (from, mut substeps) = (state.time, 0);
    let mut cross = |state: &mut BallState, to: u64, source: &mut AttractionSource, substeps: &mut u64| {
        if state.asleep {
            // Held still: only the clock moves on.
            state.time = state.time.max(to);
            return;
        }
        for (a, b) in grid.pieces(state.time, to) {
            let taken;
            (*source, taken) =
                advance(state, clock_seconds(b, a) * params.time_scale, max_step, params, shared, scratch);
            *substeps += taken;
            state.time = b;
        }
    };
    while let Some(m) = state.held.front().copied() {
        if m.apply_at > target {
            break;
        }
        if m.apply_at > state.time {
            cross(state, m.apply_at, &mut source, &mut substeps);
        } else if m.apply_at < state.time {
            // Relaxed: a statistic.
            shared.responses_late.fetch_add(1, Ordering::Relaxed);
        }
        state.held.pop_front();
        state.apply(&m, params);
        cross(state, m.stamp, &mut source, &mut substeps);
        if state.time == m.stamp && params.effects.collisions.is_some() {
            // At the end of its span the response has put the ball inside the field, as the
            // monitor carried it; what is left past a wall is what its motion and the monitor's
            // differ by (micrometres, after a long starvation), which the wall holds.
            let radius = state.ball.radius();
            hold_inside(&mut state.ball.position, radius, &params.field);
        }
        m.rest.apply(&mut state.asleep);
    }
    cross(state, grid.at_or_before(target), &mut source, &mut substeps);
    // The longest cycle so far and its sub-steps, for the report (a stall shows as one long
    // cycle).
    if state.time > from {
        let packed = Shared::pack_cycle(clock_seconds(state.time, from) * params.time_scale, substeps);
        if packed > state.longest_cycle {
            state.longest_cycle = packed;
            // Relaxed: a statistic (see `Shared::longest_cycle`).
            shared.longest_cycle.fetch_max(packed, Ordering::Relaxed);
        }
    }
    source
}

/// A yield that hands the core back sooner than this found nobody else waiting for it.
const CROWDED_TURN: Duration = Duration::from_micros(50);

/// How a ball thread waits between its cycles. Two ways, chosen by what the thread sees:
///
/// - **Sleeping** (few balls for the cores): sleep to the next instant of a grid of whole cycles
///   shared by all balls (the runtime's epoch plus whole cycles), so the kernel serves all their
///   timers with one interrupt per cycle instead of one per ball. A ball that fell behind skips
///   the instants it missed rather than catching up in a burst. 64 balls sleep almost all the time.
/// - **Crowded** (more runnable ball threads than the cores can serve at the cycle): yield the
///   core (`sched_yield`) instead of sleeping, and update at each turn the scheduler gives, but
///   never sooner than half a cycle after the previous update. With a thousand threads on two
///   cores a ball waits for its turn anyway; a sleep adds a timer, a dequeue and a wake-up to
///   every turn, which makes an update cost well over the plain switch a yield is (the figures:
///   docs/measurements.md, "Thread per ball"). The yield only rotates the run queue.
///   Ball threads are `SCHED_IDLE`, so yielding ones never take the CPU from the monitor, the
///   render loop or any other ordinary thread: those preempt them on wake-up.
///
/// A sleeping ball turns crowded when it wakes more than half a cycle late (it waited in a run
/// queue: the cores are saturated); a crowded ball goes back to sleeping when a yield brings its
/// turn back before it is due, or almost at once (`CROWDED_TURN`): the cores have time to spare,
/// and spinning would burn it. (Tolerating one early turn before falling back gains nothing clear
/// at 1,024 balls, and at a few hundred balls it keeps balls yielding at half as much CPU again
/// as sleeping takes.)
struct Waiter {
    epoch: Instant,
    cycle: Duration,
    crowded: bool,
    /// `RuntimeConfig::yield_when_crowded`: off, the ball always sleeps.
    may_yield: bool,
}

impl Waiter {
    fn new(epoch: Instant, cycle: Duration, may_yield: bool) -> Self {
        Waiter { epoch, cycle, crowded: false, may_yield }
    }

    /// The first instant of the shared grid after `t`.
    fn next_tick(&self, t: Instant) -> Instant {
        let since = t.saturating_duration_since(self.epoch).as_nanos();
        let period = self.cycle.as_nanos().max(1);
        self.epoch + Duration::from_nanos(((since / period + 1) * period) as u64)
    }

    /// Returns when the cycle after the one that started at `last` is due, with the time it
    /// returned (read once: a clock read is a noticeable part of a cycle's own cost).
    fn wait(&mut self, last: Instant) -> Instant {
        if self.crowded {
            let due = last + self.cycle / 2;
            let before = Instant::now();
            if before >= due {
                return before;
            }
            std::thread::yield_now();
            let back = Instant::now();
            if back >= due && back - before >= CROWDED_TURN {
                return back;
            }
            // The turn came back early, or at once: there is CPU to spare. Sleep from here on.
            self.crowded = false;
        }
        // A plain sleep is one timer wake-up per cycle; a blocking receive with a deadline
        // (crossbeam's) first spins and yields, which with a thousand threads burns the CPU the
        // balls need.
        let due = self.next_tick(last);
        let mut now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
            now = Instant::now();
        }
        if self.may_yield && now.saturating_duration_since(due) > self.cycle / 2 {
            self.crowded = true;
        }
        now
    }
}

/// Commands taken from the inbox (the last of each kind wins: each sets a value), kept until the
/// ball is at the instant they take effect: the start of its next stretch when running, the
/// paused instant when paused (see `run_ball`).
#[derive(Default)]
struct Commands {
    pull: Option<DVec2>,
    mass: Option<f64>,
    velocity: Option<DVec2>,
}

impl Commands {
    /// Applies the commands held and forgets them; returns whether there were any.
    fn apply(&mut self, state: &mut BallState) -> bool {
        let any = self.pull.is_some() || self.mass.is_some() || self.velocity.is_some();
        if let Some(force) = self.pull.take() {
            state.pull = force;
        }
        if let Some(mass) = self.mass.take() {
            state.ball.mass = mass;
        }
        if let Some(velocity) = self.velocity.take() {
            state.ball.velocity = velocity;
        }
        any
    }
}

fn handle(message: Message, state: &mut BallState, commands: &mut Commands) -> Handled {
    match message {
        // Applied in `catch_up`, in the order sent (the monitor counts them so), each no earlier
        // than it is due.
        Message::Contact(contact) => state.held.push_back(contact),
        Message::Pull(force) => commands.pull = Some(force),
        Message::SetMass(mass) => commands.mass = Some(mass),
        Message::Throw(velocity) => commands.velocity = Some(velocity),
        Message::Stop => return Handled::Stop,
        #[cfg(feature = "test-hooks")]
        Message::Stall(d) => {
            std::thread::sleep(d);
            return Handled::Stalled;
        }
        #[cfg(feature = "test-hooks")]
        Message::Panic => panic!("ball {} was asked to panic (test hook)", state.ball.id),
    }
    Handled::Continue
}

/// Advances the ball by `dt` seconds in sub-steps of at most `max_step`, so a stall (a dragged
/// window, a loaded machine) never becomes one giant step. Returns where attraction came from.
///
/// Two named steps: the other balls' pull for the cycle ([`gather_others`]), then the sub-steps
/// ([`take_substeps`]), each judged by the step policy as it comes ([`judge_split`]). The forces
/// are lockstep's own passes (`physics::Forces`), evaluated on this ball alone.
fn advance(
    state: &mut BallState,
    dt: f64,
    max_step: f64,
    params: &Params,
    shared: &Shared,
    scratch: &mut CycleScratch,
) -> (AttractionSource, u64) {
    // A NaN dt (from a NaN time scale) takes no step either.
    if dt.is_nan() || dt <= 0.0 {
        return (AttractionSource::Off, 0);
    }
    let CycleScratch { integrator, forces, others, near } = scratch;
    let ball = &state.ball;
    let body = BallProps { mass: ball.mass, inverse_mass: 1.0 / ball.mass, diameter: ball.diameter };
    // Gravity and the pull: the ball's uniform acceleration, for the tree split's margin and for
    // an exact bounce off a wall.
    let gravity = params.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
    let uniform = gravity + state.pull * body.inverse_mass;
    let others = gather_others(state, uniform, dt, params, shared, others, near);
    let ball_forces = forces.on_ball(body, state.pull, &others);
    let policy = StepPolicy::new(dt).with_max_step(max_step);
    let taken = take_substeps(state, dt, policy, ball_forces, uniform, params, shared, integrator);
    if taken.drag_limited {
        // Relaxed: a statistic (see `Shared::drag_limited`).
        shared.drag_limited.fetch_add(1, Ordering::Relaxed);
    }
    (others.source(), taken.count as u64)
}

/// The other balls' pull on this one, frozen for a whole cycle (every sub-step): see
/// [`gather_others`]. Only this ball's own position moves through the sub-steps.
enum OthersPull<'a> {
    /// Attraction is off.
    Off,
    /// From the monitor's tree snapshot, split once for the cycle: the far nodes' force (N) at the
    /// cycle's start, the near balls (summed exactly at each sub-step), the fastest orbit rate²
    /// at the cycle's start (1/s², far nodes and near balls), and the attraction's parameters
    /// (for the near balls' orbit rate where the ball is later in the cycle).
    Split { far: DVec2, near: &'a [NearBall], orbit_rate2: f64, attraction: Attraction },
    /// Every other ball as last published, read directly from the table, and the attraction's
    /// parameters (for the orbit rate).
    Direct { table: &'a [BallRecord], attraction: Attraction },
}

impl OtherBalls for OthersPull<'_> {
    #[inline]
    fn force_at(&self, x: DVec2, mass: f64, radius: f64, att: &Attraction) -> DVec2 {
        match self {
            OthersPull::Off => DVec2::ZERO,
            OthersPull::Split { far, near, .. } => *far + near_force(near, x, mass, radius, att),
            OthersPull::Direct { table, .. } => table.iter().fold(DVec2::ZERO, |f, o| {
                let ob = &o.ball;
                f + attraction_force(x, mass, radius, ob.position, ob.mass, ob.radius(), att)
            }),
        }
    }
}

impl OthersPull<'_> {
    fn source(&self) -> AttractionSource {
        match self {
            OthersPull::Off => AttractionSource::Off,
            OthersPull::Split { .. } => AttractionSource::Tree,
            OthersPull::Direct { .. } => AttractionSource::Direct,
        }
    }

    /// The fastest orbit rate ω (1/s) of a ball of `mass` and `radius` at `x` with any of them.
    /// With the tree split, the near balls' rate is taken at `x` and the far nodes' at the cycle's
    /// start (whichever is larger, never less than the start's whole rate): the ball may have
    /// moved far into a near ball's pull since.
    fn orbit_rate(&self, x: DVec2, mass: f64, radius: f64) -> f64 {
        match self {
            OthersPull::Off => 0.0,
            OthersPull::Split { near, orbit_rate2, attraction, .. } => {
                let w2 = near.iter().fold(*orbit_rate2, |w, b| {
                    w.max(attraction_rate_squared(x, mass, radius, b.position, b.mass, b.radius, attraction))
                });
                w2.sqrt()
            }
            OthersPull::Direct { table, attraction } => {
                let w2 = table.iter().fold(0.0f64, |w, o| {
                    let ob = &o.ball;
                    w.max(attraction_rate_squared(x, mass, radius, ob.position, ob.mass, ob.radius(), attraction))
                });
                w2.sqrt()
            }
        }
    }
}

/// The other balls' pull for this cycle: either taken from the monitor's latest tree snapshot,
/// once here (from TREE_MIN_BALLS balls on; the field as the monitor read it at the start of its
/// last pass), or below that from the table read directly here into `table` (each ball as last
/// published).
///
/// With the tree, the pull is split once per cycle (`BarnesHut::split_at`): the far nodes' pull
/// is taken at the cycle's start and kept for its sub-steps, and only the near balls (those of
/// the leaves the walk opened, copied to `near`) are summed exactly at each sub-step. A tree walk
/// per sub-step would cost n × 500 walks a second at the 2 ms sub-step limit — more than two
/// cores at 4,096 balls. The far nodes lie beyond twice the distance the ball can travel in the
/// cycle, so keeping their pull fixed errs about as much as freezing the other balls does.
/// Because the near balls are copied, the snapshot is held only for the split (one walk), not for
/// the cycle: a ball preempted in mid-cycle keeps no snapshot from being rebuilt.
fn gather_others<'a>(
    state: &BallState,
    uniform: DVec2,
    dt: f64,
    params: &Params,
    shared: &Shared,
    table: &'a mut Vec<BallRecord>,
    near: &'a mut Vec<NearBall>,
) -> OthersPull<'a> {
    table.clear();
    let Some(att) = &params.effects.attraction else { return OthersPull::Off };
    let ball = &state.ball;
    // How far the ball can go this cycle from its speed and the uniform forces (the pull of the
    // near balls, summed exactly at every sub-step, needs no margin).
    let travel = ball.velocity.length() * dt + 0.5 * uniform.length() * dt * dt;
    // Lock-free: never waits for the monitor (see `attraction_tree.rs`). The guard is a
    // temporary, dropped at the end of this statement. A snapshot built with other parameters
    // (just changed) is not used: the table is read directly this cycle.
    let split = shared
        .attraction_tree
        .load()
        .as_deref()
        .filter(|t| t.attraction() == att)
        .map(|t| t.split_on(state.slot, ball.position, ball.mass, ball.radius(), 2.0 * travel, near));
    match split {
        Some((far, orbit_rate2)) => OthersPull::Split { far, near, orbit_rate2, attraction: *att },
        None => {
            // Acquire: pairs with the runtime's Release store after it wrote a new slot's record.
            let high = shared.high_water.load(Ordering::Acquire);
            shared.table.read_all(high, table);
            table.retain(|r| r.slot != state.slot);
            OthersPull::Direct { table, attraction: *att }
        }
    }
}

/// The rates the step policy splits the ball's next sub-step by (see `StepPolicy`), at the
/// ball's state `(x, v)`: drag at the speed now or at the terminal speed the other forces drive
/// the ball to (`BallForces::drag_rate`), and the fastest orbit with another ball. Travel is not
/// bounded here: contacts are the monitor's, judged at its own period.
fn rates_at(x: DVec2, v: DVec2, ball: &Ball, forces: &BallForces<'_, &OthersPull<'_>>) -> SpanRates {
    SpanRates {
        travel: 0.0,
        drag: forces.drag_rate(x, v),
        orbit: forces.others().orbit_rate(x, ball.mass, ball.radius()),
    }
}

/// Sub-steps over `dt` (`physics::advance_ball`, which the monitor's prediction calls too), each
/// judged afresh by the step policy before it is taken ([`rates_at`]; `policy` holds the cycle's
/// floor and the runtime's `max_step`), integrated through the force passes and followed by the
/// walls (`uniform`: the ball's uniform acceleration) and lockstep's speed guard rail. A cycle of
/// one sub-step (the common one) is judged once.
#[allow(clippy::too_many_arguments)]
fn take_substeps(
    state: &mut BallState,
    dt: f64,
    policy: StepPolicy,
    forces: BallForces<'_, &OthersPull<'_>>,
    uniform: DVec2,
    params: &Params,
    shared: &Shared,
    scratch: &mut IntegratorScratch,
) -> BallSteps {
    let ball = &mut state.ball;
    let (radius, mass) = (ball.radius(), ball.mass);
    let props = *ball;
    let walls = &mut state.walls;
    let steps = advance_ball(
        params.integrator,
        &policy,
        dt,
        forces,
        |x, v| rates_at(x, v, &props, &forces),
        (&mut ball.position, &mut ball.velocity),
        scratch,
        |x, v| ball_walls(x, v, radius, mass, uniform, params, walls),
    );
    if steps.speed_limited > 0 {
        // Relaxed: a statistic (see `Shared::speed_limited`).
        shared.speed_limited.fetch_add(u64::from(steps.speed_limited), Ordering::Relaxed);
    }
    steps
}

/// Puts a ball that is past a wall back on it, leaving its velocity alone.
pub(super) fn hold_inside(position: &mut DVec2, radius: f64, field: &Field) {
    position.x = position.x.clamp(radius.min(field.width - radius), (field.width - radius).max(radius));
    position.y = position.y.clamp(radius.min(field.height - radius), (field.height - radius).max(radius));
}

/// The walls as a ball's own thread meets them. With collisions on, walls are contacts in the
/// monitor's solver, judged ahead with the ball's other contacts (that is what stands a pile on
/// the floor) and sent as part of its responses: between responses the ball moves in free motion,
/// as the monitor predicts it, and its thread does nothing at a wall within a span (at a span's
/// end `catch_up` holds it inside, as the monitor does). Holding it inside here as well would be
/// a second response to the one contact, unknown to the monitor: a ball held on the
/// floor while the solver's response lifted it out of the overlap it predicted ended that much
/// too high (millimetres per pass in a pile, which then never came to rest). A ball is past a
/// wall only inside a span whose response, judged ahead, puts it back by the span's end. Without
/// collisions the monitor judges nothing and the ball bounces itself, counting the impulse on
/// its gauge.
fn ball_walls(
    position: &mut DVec2,
    velocity: &mut DVec2,
    radius: f64,
    mass: f64,
    acceleration: DVec2,
    params: &Params,
    walls: &mut WallImpulses,
) {
    if params.effects.collisions.is_none() {
        contact_ball_wall(position, velocity, radius, mass, acceleration, &params.field, walls);
    }
}

/// Ball threads (all but the key ball) are scheduled as `SCHED_IDLE`: they get the CPU the rest of the program does not
/// use. With hundreds of them runnable on two cores, any ordinary policy lets their sheer number
/// outweigh the monitor, the render loop, Mesa's threads and the X server, and the window falls
/// far behind its 15 ms cadence (at 500 balls under `SCHED_BATCH` at nice +5 it draws 1.8 frames
/// a second).
/// Each ball measures its own dt, so a ball that gets less CPU takes longer sub-stepped steps
/// rather than going wrong. Lowering a thread's own policy needs no privilege; elsewhere, or if
/// refused, nothing changes.
fn background_scheduling() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sched_setscheduler with pid 0 acts on the calling thread; `param` is a valid,
        // initialised sched_param that outlives the call; nothing is shared after it returns.
        let param = libc::sched_param { sched_priority: 0 };
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) };
        if rc != 0 {
            log::debug!("SCHED_IDLE refused: {}", std::io::Error::last_os_error());
        }
    }
}
