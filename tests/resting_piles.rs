//! Resting piles rest and walls are contacts (issue 13, points 3 and 4), on the lockstep engine: a
//! pile dropped at any e < 1 settles with every overlap within 1 % of a diameter, no motion a
//! player could see, and a floor that carries its weight (the floor's impulse over a second equals
//! M·g·T within 1 %); a pile placed at rest at e = 1 stays at rest, and a heavy ball on a light
//! one at every e.

mod common;

use ballfield::Lockstep;
use ballfield::physics::{Ball, Collisions, Effects, Field, Gravity, Integrator};
use common::*;
use glam::DVec2;

const G: f64 = 9.81;

/// 200 balls of 0.8–1.2 m (mass ∝ d²) on a loose lattice, dropped from 1–15 m into a 20.5 m wide
/// box with small random sideways speeds.
fn dropped(seed: u64) -> Vec<Ball> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..200u32)
        .map(|k| {
            let d = 0.8 + 0.4 * next();
            let (i, j) = (k % 15, k / 15);
            ball(k, 0.7 + 1.35 * i as f64, 1.0 + 1.35 * j as f64, next() - 0.5, 0.0, d * d, d)
        })
        .collect()
}

fn engine_for(balls: &[Ball], e: f64, width: f64, integrator: Integrator) -> Lockstep {
    engine_on(balls, e, e, width, integrator)
}

/// [`engine_for`] with walls of restitution `walls`.
fn engine_on(balls: &[Ball], e: f64, walls: f64, width: f64, integrator: Integrator) -> Lockstep {
    let field = Field { width, height: 40.0, restitution: walls };
    let effects = Effects {
        collisions: Some(Collisions { restitution: e }),
        gravity: Some(Gravity { g: DVec2::new(0.0, -G) }),
        ..Effects::default()
    };
    engine(field, effects, integrator, 1e-3, balls)
}

/// What a settled pile shows over one more second: the floor's impulse over M·g·T, the largest
/// overlap (of a diameter) and kinetic energy at any step, and the farthest a ball moved.
struct Rest {
    floor: f64,
    overlap: f64,
    kinetic: f64,
    moved: f64,
}

fn watch(engine: &mut Lockstep, mass: f64) -> Rest {
    let (floor0, t0) = (engine.wall_impulses().bottom, engine.time());
    let x0 = engine.bodies().position.clone();
    let (mut overlap, mut kinetic) = (0.0f64, 0.0f64);
    for _ in 0..1000 {
        engine.step();
        let d = engine.diagnostics();
        overlap = overlap.max(d.largest_overlap_ratio);
        kinetic = kinetic.max(d.kinetic);
    }
    let floor = (engine.wall_impulses().bottom - floor0) / (mass * G * (engine.time() - t0));
    let moved = engine.bodies().position.iter().zip(&x0).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
    Rest { floor, overlap, kinetic, moved }
}

/// 80 balls of 100 kg and 80 of 1 kg, all 1 m across, generated in the top two thirds of a
/// 20 m × 30 m field.
const MASSES: &str = "[[generate]]\ncount = 80\ndiameter = 1.0\nmass = 100.0\nspeed = 1.0\n\
    region = [0.0, 10.0, 20.0, 30.0]\n[[generate]]\ncount = 80\ndiameter = 1.0\nmass = 1.0\nspeed = 1.0\n\
    region = [0.0, 10.0, 20.0, 30.0]\n";

/// A scene named `name` of the balls `generate` (TOML `[[generate]]` tables) in a field of
/// `size` (m) whose walls have restitution 0.5, the balls' `e`, under gravity, dt 1 ms, seed 7.
fn pile_scene(name: &str, (width, height): (f64, f64), e: f64, generate: &str) -> ballfield::Scene {
    let source = format!(
        "name = \"{name}\"\n[field]\nwidth = {width}\nheight = {height}\nrestitution = 0.5\n[simulation]\n\
         dt = 0.001\nseed = 7\nmax-balls = 4096\n[effects]\ncollisions = {{ restitution = {e} }}\n\
         gravity = {{ g = [0.0, -9.81] }}\n{generate}"
    );
    ballfield::Scene::from_toml_str(&source, &ballfield::scene::Origin("test".into())).unwrap()
}

/// Dropped at e = 0, 0.3, 0.5, 0.8 and 0.9, the pile settles within 12 s and then, for a second:
/// the floor carries its weight within 1 %, no overlap exceeds 1 % of a diameter, and nothing
/// moves a player could see (half a pixel at 10 px/m: 5 cm in the second). Measured (12 s
/// settled, 2026-12-07): floor 0.999999–1.000002 of M·g, overlap ≤ 0.495 % (the position
/// phase's slop is 0.5 %), kinetic ≤ 3.7e-5 J, moved ≤ 2.2 mm (e = 0; when this was written,
/// 8e-5 J and 1.2 cm, one frictionless ball gliding slowly on the heap at e = 0.5).
///
/// On main the support pass had the floor carry about a tenth of the weight (`clamp_to_field`
/// counted no impulse), and a pile at e = 0.5 kept bouncing. Seen to fail by leaving the
/// resting impulses off the walls' gauges (`resting_end` adding only `c.impact`): the floor
/// read 0.0 of the weight.
#[test]
fn a_dropped_pile_settles_and_its_floor_carries_its_weight_at_every_e() {
    for e in [0.0, 0.3, 0.5, 0.8, 0.9] {
        dropped_pile_settles(e, e, 1e-2);
    }
}

/// [`dropped`] (seed 7) at ball restitution `e` on walls of `walls`, run 12 s, then watched for
/// a second: the floor carries the weight within 1 %, overlaps stay within 1 % of a diameter, no
/// ball moves 5 cm, and the kinetic energy stays under `kinetic` J.
fn dropped_pile_settles(e: f64, walls: f64, kinetic: f64) {
    let balls = dropped(7);
    let mass: f64 = balls.iter().map(|b| b.mass).sum();
    let mut engine = engine_on(&balls, e, walls, 20.5, Integrator::SemiImplicitEuler);
    engine.run(12_000);
    let rest = watch(&mut engine, mass);
    eprintln!(
        "e {e}, walls {walls}: floor {:.6} of M·g, overlap {:.5} of a diameter, kinetic ≤ {:.3e} J, moved ≤ {:.3e} m",
        rest.floor, rest.overlap, rest.kinetic, rest.moved
    );
    assert!((rest.floor - 1.0).abs() < 0.01, "e {e}: the floor carries {} of the weight", rest.floor);
    assert!(rest.overlap <= 0.01, "e {e}: overlap {} of a diameter", rest.overlap);
    assert!(rest.moved < 0.05, "e {e}: a ball moved {} m in the last second", rest.moved);
    assert!(rest.kinetic < kinetic, "e {e}: kinetic energy {} J", rest.kinetic);
}

/// The dropped pile at e = 0.99 and 1 on walls of 0.5, which take the energy an elastic pile
/// cannot lose in its own contacts: it settles as the e < 1 piles do. After 12 s, for a second:
/// the floor carries the weight within 1 %, overlaps within 1 % of a diameter, kinetic energy
/// under 1e-3 J and nothing moving a player could see (5 cm in the second, as above). Measured:
/// e = 0.99 floor 1.000001, overlap 0.475 %, kinetic ≤ 1.0e-4 J, moved ≤ 8.6 mm (one ball gliding
/// on the heap); e = 1 floor 1.000000, overlap 0.481 %, kinetic ≤ 1.2e-7 J, moved ≤ 3.0e-5 m.
/// Seen to fail with e = 1 sent through the elastic passes, as every e = 1 field was until
/// 2026-12-07: kinetic ≤ 0.565 J (floor 0.999786).
#[test]
fn a_dropped_elastic_pile_on_walls_that_take_energy_settles() {
    for e in [0.99, 1.0] {
        dropped_pile_settles(e, 0.5, 1e-3);
    }
}

/// A hexagonal stack of 76 equal balls placed at rest on the floor, wall to wall, stays put at
/// every e, e = 1 included: for e < 1 no ball moves more than 1e-6 m in a second and the floor
/// carries the weight to 1e-6. Measured: e < 1 moved ≤ 2.9e-10 m, floor 1.000000000, overlap
/// ≤ 9.6e-7; e = 1 moved ≤ 4.9e-15 m, floor 1.000000000, overlap ≤ 1.4e-5 (semi-implicit Euler
/// and leapfrog). Before the elastic passes had a resting phase
/// (`src/engine/lockstep/elastic_resting.rs`) the e = 1 stack moved 1.2 mm with overlaps of
/// 4.7e-4 (the bound was 5 mm then): its floor and side walls were impacts every step. Seen to
/// fail with the side walls' slow contacts left out of that phase (only the walls balls are
/// pressed into): the floor carried 0.99970 of the weight.
#[test]
fn a_stack_placed_at_rest_stays_at_rest_at_every_e() {
    let mut balls = Vec::new();
    for j in 0..8u32 {
        for i in 0..(10 - (j % 2)) {
            let x = 0.5 + i as f64 + 0.5 * (j % 2) as f64;
            let y = 0.5 + j as f64 * 3f64.sqrt() / 2.0;
            balls.push(ball(balls.len() as u32, x, y, 0.0, 0.0, 1.0, 1.0));
        }
    }
    let mass: f64 = balls.iter().map(|b| b.mass).sum();
    for integrator in [Integrator::SemiImplicitEuler, Integrator::Leapfrog] {
        for e in [0.0, 0.5, 0.99, 1.0] {
            let mut engine = engine_for(&balls, e, 10.0, integrator);
            engine.run(1000);
            let rest = watch(&mut engine, mass);
            eprintln!(
                "{integrator} e {e}: floor {:.9} of M·g, overlap {:.3e}, kinetic ≤ {:.3e} J, moved ≤ {:.3e} m",
                rest.floor, rest.overlap, rest.kinetic, rest.moved
            );
            let (floor, moved) = (1e-6, 1e-6);
            assert!((rest.floor - 1.0).abs() < floor, "{integrator} e {e}: the floor carries {}", rest.floor);
            assert!(rest.moved < moved, "{integrator} e {e}: a ball moved {} m", rest.moved);
            assert!(rest.overlap < 1e-3, "{integrator} e {e}: overlap {}", rest.overlap);
        }
    }
}

/// A heavy ball resting on a light one against a wall stays at rest at every e and mass ratio:
/// 1 kg under 1, 10, 100 and 1,000 kg, ball and wall restitution 0, 0.5, 0.99 and 1, on the floor
/// under gravity and against the left wall under gravity pointing left, with semi-implicit Euler
/// and leapfrog. Over a second after a second at rest: neither ball moves more than 1e-6 m, the
/// wall carries the weight to 1e-6, no overlap beyond 1e-6 of a diameter.
///
/// At e = 1 the elastic passes took the wall's support for an impact every step, so the light
/// ball bounced between the wall and the heavy one: 100 kg on 1 kg kept overlaps of 3.4 % and a
/// periodic 4.8 J, where e = 0.99 rested to 1e-14 m. Measured now at e = 1: moved ≤ 6.7e-16 m,
/// the wall carrying the weight to rounding, overlap ≤ 2.9e-8 (the resting impulse and its drift
/// put each ball back where it was); at e < 1 (the contact solver) within 9.1e-7 of the weight,
/// moved ≤ 3.8e-7 m, overlap ≤ 5.6e-7 (1,000 kg). Seen to fail with the elastic passes' resting phase left out: 1 kg on 1 kg
/// at e = 1 overlapped 2.6e-5 of a diameter.
#[test]
fn a_heavy_ball_on_a_light_one_rests_at_every_e_and_mass_ratio() {
    for integrator in [Integrator::SemiImplicitEuler, Integrator::Leapfrog] {
        for down in [DVec2::new(0.0, -1.0), DVec2::new(-1.0, 0.0)] {
            for heavy in [1.0, 10.0, 100.0, 1000.0] {
                for e in [0.0, 0.5, 0.99, 1.0] {
                    // The light ball on the wall `down` points at, the heavy one on it.
                    let at = |k: f64| DVec2::new(2.0, 2.0) + down * (1.5 - k);
                    let (light, top) = (at(0.0), at(1.0));
                    let balls =
                        [ball(0, light.x, light.y, 0.0, 0.0, 1.0, 1.0), ball(1, top.x, top.y, 0.0, 0.0, heavy, 1.0)];
                    let field = Field { width: 4.0, height: 4.0, restitution: e };
                    let effects = Effects {
                        collisions: Some(Collisions { restitution: e }),
                        gravity: Some(Gravity { g: down * G }),
                        ..Effects::default()
                    };
                    let mut engine = engine(field, effects, integrator, 1e-3, &balls);
                    engine.run(1000);
                    let walls = |engine: &Lockstep| {
                        let w = engine.wall_impulses();
                        if down.y < 0.0 { w.bottom } else { w.left }
                    };
                    let (wall0, t0) = (walls(&engine), engine.time());
                    let x0 = engine.bodies().position.clone();
                    let mut overlap = 0.0f64;
                    for _ in 0..1000 {
                        engine.step();
                        overlap = overlap.max(engine.diagnostics().largest_overlap_ratio);
                    }
                    let carried = (walls(&engine) - wall0) / ((1.0 + heavy) * G * (engine.time() - t0));
                    let moved =
                        engine.bodies().position.iter().zip(&x0).map(|(a, b)| a.distance(*b)).fold(0.0, f64::max);
                    let case = format!("{integrator}, down {down}, {heavy} kg on 1 kg, e {e}");
                    eprintln!("{case}: wall {carried:.12} of the weight, overlap {overlap:.3e}, moved {moved:.3e} m");
                    assert!((carried - 1.0).abs() < 1e-6, "{case}: the wall carries {carried} of the weight");
                    assert!(moved < 1e-6, "{case}: a ball moved {moved} m");
                    assert!(overlap < 1e-6, "{case}: overlap {overlap}");
                }
            }
        }
    }
}

/// Three piles of an independent review's (2026-12-04), each settled 14 s on lockstep and then
/// watched for a second: 80 balls of 100 kg and 80 of 1 kg (1 m, e = 0.3); 100 balls of 1 m and
/// 150 of 0.4 m (e = 0); 200 balls of 0.1 m in a box exactly 20 of them wide (e = 0.3). Each
/// rests as the pile of equal balls above does: overlaps within 1 % of the smaller diameter, the
/// floor carrying the weight within 1 %, nothing moving a player could see.
///
/// Measured: overlap 0.499 / 0.498 / 0.500 %, floor 1.000000 of M·g for each, kinetic ≤ 3.0e-4 /
/// 5.6e-6 / 2.5e-19 J, moved ≤ 2.7e-5 / 1.09e-2 / 1.6e-11 m, and the finish pass bounced no ball
/// off a wall in the whole run (the contact solver held every ball it moved). Since the small
/// islands a capped resting solve leaves are solved directly (2026-12-05), the mixed pile settles
/// another way and four of its 0.4 m balls end sliding on the floor, in the gaps between the 1 m
/// balls, at a steady 1.8–8.5 mm/s: frictionless balls keep sliding until they meet something
/// (each has no contact at all; its velocity is the same to the bit at 15 s and 16 s). "Nothing a
/// player could see" is then 2 cm in the last second (0.2 px/s at the default 10 px/m), not 5 mm:
/// since a few resting contacts are solved exactly (2026-12-06) the pile settles another way
/// again, and a ball slides at 10.9 mm/s. Before every ball near a wall had its
/// wall contact in every sub-step (2026-12-05) they overlapped 22 %, 8.6 % and 5.0 % and kept
/// 113 J, 0.17 J and 4e-3 J: a ball that a neighbour's impact or push moved into a wall it had
/// not touched in free motion went past the wall unseen, and the finish pass bounced it back,
/// every step. Seen to fail with that contact left out again (`wall_contact` returning no contact
/// for a ball clear of its wall): overlaps 22 %, 8.6 %, 5.0 %. The 0.4 m balls on 1 m ones kept
/// 0.87 % while the slop was a share of the contact distance, not of the smaller diameter.
#[test]
fn piles_of_unequal_balls_and_a_snug_box_settle() {
    let piles = [
        ("masses", 20.0, 30.0, 0.3, MASSES),
        (
            "mixed",
            20.0,
            30.0,
            0.0,
            "[[generate]]\ncount = 100\ndiameter = 1.0\nmass = 1.0\nspeed = 1.0\nregion = [0.0, 10.0, 20.0, 30.0]\n[[generate]]\ncount = 150\ndiameter = 0.4\nmass = 0.064\nspeed = 1.0\nregion = [0.0, 10.0, 20.0, 30.0]\n",
        ),
        (
            "snug box",
            2.0,
            4.0,
            0.3,
            "[[generate]]\ncount = 200\ndiameter = 0.1\nmass = 0.01\nspeed = 0.5\nlayout = \"lattice\"\ngap = 0.3\nregion = [0.0, 1.5, 2.0, 4.0]\n",
        ),
    ];
    for (name, width, height, e, balls) in piles {
        let scene = pile_scene(name, (width, height), e, balls);
        let mass: f64 = scene.balls.iter().map(|b| b.mass).sum();
        let mut engine = Lockstep::new(&scene);
        engine.run(14_000);
        let rest = watch(&mut engine, mass);
        eprintln!(
            "{name}: floor {:.6} of M·g, overlap {:.5} of a diameter, kinetic ≤ {:.3e} J, moved ≤ {:.3e} m, {} finish bounces",
            rest.floor,
            rest.overlap,
            rest.kinetic,
            rest.moved,
            engine.counters().finish_bounces
        );
        assert!((rest.floor - 1.0).abs() < 0.01, "{name}: the floor carries {} of the weight", rest.floor);
        assert!(rest.overlap <= 0.0055, "{name}: overlap {} of the smaller diameter", rest.overlap);
        assert!(rest.moved < 2e-2, "{name}: a ball moved {} m in the last second", rest.moved);
        assert!(rest.kinetic < 2e-3, "{name}: kinetic energy {} J", rest.kinetic);
        let bounces = engine.counters().finish_bounces;
        assert_eq!(bounces, 0, "{name}: the contact solver left balls past a wall {bounces} times");
    }
}

/// The pile of 80 balls of 100 kg and 80 of 1 kg above, at e = 1 (walls 0.5): it stays hot (its
/// balls keep their energy; only the walls take any), but light balls rattling in pockets between
/// heavy ones and a wall must not be pressed into them. Watched every step from 10 to 12 s: the
/// largest overlap stays within 1 % of a diameter, the bound for lockstep. Measured:
/// 0.500 % (since 2026-12-07, when a field whose walls take energy went through the contact
/// solver at e = 1 too; 0.755 % through the elastic passes, and with at most 64 position passes
/// a step instead of 256 there, 0.72 % on one build and 1.10 % on the next, which only moved the
/// pile's chaos). Before the resting phase looked for balls the elastic passes push past a wall (out of
/// a pair whose heavy ball takes a hundredth of the push), a light ball on the floor stayed 2.6 %
/// into a heavy one (2.85 % was this test's figure, its bound 3.5 %); seen to fail that way again
/// with those balls left out: 4.3 %. (Half-second samples of `lockstep_timeline` on the scene, 3
/// to 20 s: 0.57-1.07 %; before, 2.3-2.5 % from 10 s and 28 % at 3 s.)
#[test]
fn an_elastic_pile_of_heavy_and_light_balls_keeps_its_overlaps_small() {
    let scene = pile_scene("masses e = 1", (20.0, 30.0), 1.0, MASSES);
    let mut engine = Lockstep::new(&scene);
    engine.run(10_000);
    let mut overlap = 0.0f64;
    for _ in 0..2000 {
        engine.step();
        overlap = overlap.max(engine.diagnostics().largest_overlap_ratio);
    }
    eprintln!("elastic masses pile: largest overlap {overlap:.5} of a diameter, 10-12 s");
    assert!(overlap <= 0.01, "overlap {overlap} of a diameter");
}

/// The pile of 80 balls of 100 kg and 80 of 1 kg above at e = 0.99 and 0.5 (walls 0.5), through
/// the contact solver, watched every step of its landing (0–3 s), where 1 kg balls squeezed
/// between falling 100 kg ones leave at 100–340 m/s (10–34 cm a step): the largest overlap stays
/// near what lockstep's step resolves. Measured: 10.83 % at 1.962 s (e = 0.99) and 7.96 % at
/// 1.895 s (e = 0.5); over seeds 1–8, 10.8–17.3 % and 2.7–8.0 %. The 1 % is a settled
/// pile's (above); the landing's transient is not there yet.
///
/// Before the contacts found after a step's first impacts acted no earlier than the impacts
/// that sent their balls there (see `impact_phase`), a 1 kg ball rattling between 100 kg ones was
/// struck round after round at an instant before the one that last turned it back: 0.43 m of
/// replay in one step at under 75 m/s, ending 39.6 % into a 100 kg ball at 1.879 s (e = 0.99) and
/// 16.5 % (e = 0.5); over seeds 1–8, 10.5–83 % and 4.6–61 %.
#[test]
fn a_landing_pile_of_heavy_and_light_balls_keeps_its_overlaps_within_a_step_s_reach() {
    for (e, bound) in [(0.99, 0.12), (0.5, 0.09)] {
        let scene = pile_scene(&format!("masses e = {e}"), (20.0, 30.0), e, MASSES);
        let mut engine = Lockstep::new(&scene);
        let (mut overlap, mut at) = (0.0f64, 0.0);
        for _ in 0..3000 {
            engine.step();
            let o = engine.diagnostics().largest_overlap_ratio;
            if o > overlap {
                (overlap, at) = (o, engine.time());
            }
        }
        eprintln!("masses pile at e = {e}, landing: largest overlap {overlap:.5} of a diameter at {at:.3} s");
        assert!(overlap <= bound, "e = {e}: overlap {overlap} of a diameter at {at} s");
    }
}
