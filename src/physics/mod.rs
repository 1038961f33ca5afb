//! Pure physics: f64 functions on plain data. No threads, no GPU, no I/O; deterministic.
//!
//! One file per concept (Box2D's habit); submodules are private and what is public is
//! re-exported here (Rapier's habit).

mod ball;
mod ball_steps;
mod barnes_hut;
mod bodies;
mod broad_phase;
mod contact;
mod contact_solver;
mod diagnostics;
mod effects;
mod event;
mod field;
mod forces;
mod impact_round;
mod integrator;
mod resting_island;
mod sleep;
mod step_policy;
mod sweep;

pub use ball::{Ball, BallId, BallKind, MAX_MASS, MIN_MASS, disc_area};
pub use ball_steps::{BallSteps, advance_ball};
pub use barnes_hut::{BarnesHut, LEAF_SIZE, NearBall, near_force};
pub use bodies::Bodies;
pub use broad_phase::{BIG_BALL_FACTOR, BroadPhase};
pub use contact::{
    BallBallContact, BallBallTouch, ContactBody, SAME_INSTANT, coincident_normal, contact_ball_ball,
    contact_ball_ball_or_touching, contact_ball_wall, out_of_reach,
};
pub use contact_solver::{
    BallResponse, Contact, ContactParams, ContactSolver, ImpactScratch, ImpactTally, MAX_IMPACT_ROUNDS,
    MAX_POSITION_PASSES, MAX_REDETECTIONS, MAX_RESTING_PASSES, MAX_ROUND_ITERATIONS, MAX_SUB_SPANS, NEVER, RESTED,
    SolveTally, SolverBall, TOUCH_MARGIN, Tolerances, WALL, WarmKey, impact_phase, iterate_position, iterate_resting,
    keeps_energy, near_a_wall, nearer_walls, pair_contact, position_pass, pushed_together, redetect_wall,
    resting_begin, resting_drift, resting_end, resting_pass, resting_warm_start, settling, wall_contact,
    wall_contact_rests, wall_gap_at_start, wall_pass, wall_plane,
};
pub use diagnostics::{
    Diagnostics, attraction_potential_energy, gravity_potential_energy, kinetic_energy, largest_overlap, measure,
    momentum,
};
pub use effects::{
    AIR_DENSITY, AIR_VISCOSITY, Attraction, Collisions, DEFAULT_OPENING_ANGLE, Drag, DragRateBound, Effects, Gravity,
    MAX_DRAG_STEP, MAX_ORBIT_STEP, NEWTON_G, SPHERE_DRAG_COEFFICIENT, STANDARD_GRAVITY, attraction_force,
    attraction_pair, attraction_potential, attraction_rate_squared, cap_drag_rate, drag_force, drag_rate,
    drag_rate_bound, gravity_force, gravity_potential, quadratic_terminal_speed,
};
pub use event::{
    CLOSING_SLACK, Collision, Mobility, closing_slack, collide, cone_contains, entry_time, first_entry, flight,
    pair_gap_polynomial, pair_time, plane_time, soft_restitution,
};
pub use field::{Field, Wall, WallImpulses};
pub use forces::{
    AttractionMethod, BallForces, BallProps, BodyProps, Forces, NoOtherBalls, OtherBalls, PointForce, TREE_MIN_BALLS,
};
pub use impact_round::{RoundContact, RoundScratch, solve_simultaneous};
pub use integrator::{Integrator, IntegratorScratch, UnknownIntegrator, integrate};
pub use resting_island::{MAX_ISLAND_CONTACTS, RestingIslands, islands_after_passes, solve_resting_islands};
pub use sleep::{Islands, TIME_TO_SLEEP, held_wall_forces, is_quiet, sleep_speed};
pub use step_policy::{MAX_SPEED, MAX_SUBSTEPS, MAX_TRAVEL, SpanRates, StepPolicy, SubSteps, cap_speed};
pub use sweep::swept_circle;
