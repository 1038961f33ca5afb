//! The exact engine on an elastic gas: energy kept to rounding over 10⁶ collisions, and the
//! momentum the balls gain equal to the impulses the walls gave them (and gravity's `M·g·t`).
//!
//! Seen to fail on broken builds: the collision's outgoing speed as `0.999 999 9·|v_n|` (energy
//! error 2.0e-4 after 10⁶ collisions, 5.3e-5 under gravity); a wall bounce that gauges half its
//! impulse (momentum error 2.4e-4, 0.55 under gravity); the collision impulse along the rounded
//! unit normal instead of `Δr` (energy drift 6.7e-14, 1.2e-14 under gravity).

use ballfield::accuracy::many_body::disk_gas;
use ballfield::engine::{Engine, ExactEngine};
use ballfield::physics::{Collisions, Diagnostics, Effects, Gravity};
use glam::DVec2;

fn elastic(gravity: Option<DVec2>) -> Effects {
    Effects {
        collisions: Some(Collisions { restitution: 1.0 }),
        gravity: gravity.map(|g| Gravity { g }),
        ..Effects::default()
    }
}

/// The momentum the walls gave the balls so far: each wall's impulse along its inward normal.
fn wall_momentum(d: &Diagnostics) -> DVec2 {
    let w = d.wall_impulses;
    DVec2::new(w.left - w.right, w.bottom - w.top)
}

/// Runs `collisions` collisions of a 1,000-disk gas at packing 0.3; returns the relative energy
/// error, the momentum balance's error relative to the walls' total impulse, and the largest
/// overlap (m).
fn run(collisions: u64, gravity: Option<DVec2>) -> (f64, f64, f64) {
    let (field, balls) = disk_gas(1000, 0.3, 7).unwrap();
    let mut e = ExactEngine::from_parts(field, elastic(gravity), &balls).unwrap();
    let start = e.diagnostics();
    e.run_collisions(collisions);
    let end = e.diagnostics();
    assert_eq!(e.stats().counters.collisions, collisions);
    let mass = balls.len() as f64;
    let gained = DVec2::from(end.momentum) - DVec2::from(start.momentum);
    let expected = wall_momentum(&end) + mass * gravity.unwrap_or_default() * e.time();
    let w = end.wall_impulses;
    let total = w.left + w.right + w.bottom + w.top;
    let energy = (end.total - start.total).abs() / start.total;
    ((energy), (gained - expected).length() / total, end.largest_overlap)
}

/// Measured over 10⁶ collisions (620 s simulated, about a second of a release build): energy
/// 9.1e-16, momentum 5.0e-16 of the walls' total impulse, overlap 2.1e-13 m. Bounds 1e-14, 1e-14,
/// 1e-12 m. (With the impulse along the rounded unit normal instead of `Δr`, the energy drifted
/// steadily to 1.3e-13 in 2·10⁶ collisions.)
#[test]
fn an_elastic_gas_keeps_its_energy_over_a_million_collisions_and_the_walls_account_for_its_momentum() {
    let (energy, momentum, overlap) = run(1_000_000, None);
    eprintln!("1e6 collisions: energy {energy:e}, momentum {momentum:e}, overlap {overlap:e}");
    assert!(energy < 1e-14, "energy error {energy:e}");
    assert!(momentum < 1e-14, "momentum error {momentum:e}");
    assert!(overlap < 1e-12, "overlap {overlap:e} m");
}

/// Under gravity (9.81 m/s², the gas at 1 m/s a layer a few balls deep on the floor) the total
/// energy is what is kept, and gravity's `M·g·t` joins the walls' impulses. Measured over 10⁶
/// collisions: energy 3.4e-15, momentum 1.4e-15, overlap 0 m. Bounds 1e-14, 1e-14, 1e-12 m.
#[test]
fn under_gravity_the_total_energy_is_kept_and_gravity_joins_the_walls() {
    let (energy, momentum, overlap) = run(1_000_000, Some(DVec2::new(0.0, -9.81)));
    eprintln!("1e6 collisions under gravity: energy {energy:e}, momentum {momentum:e}, overlap {overlap:e}");
    assert!(energy < 1e-14, "energy error {energy:e}");
    assert!(momentum < 1e-14, "momentum error {momentum:e}");
    assert!(overlap < 1e-12, "overlap {overlap:e} m");
}
