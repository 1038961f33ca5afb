//! Many-body problems, with the exact engine as the reference: the hard-disk gases they are
//! built from.

use glam::DVec2;

use crate::engine::Placement;
use crate::physics::{Ball, BallId, BallKind, Field};

/// A gas of `count` disks of diameter 1 m and mass 1 kg in a square field with elastic walls,
/// covering the fraction `packing` of its area (`N·π/4 / L²`), on a square lattice (which fits
/// up to π/4 ≈ 0.785; a gas melts from it within a few collisions per disk), moving at 1 m/s in
/// directions from `seed`, with the mean velocity taken out (the centre of mass at rest).
///
/// `None` if `count` is 0 or `packing` is not in (0, 0.78].
pub fn disk_gas(count: usize, packing: f64, seed: u64) -> Option<(Field, Vec<Ball>)> {
    if count == 0 || !(packing > 0.0 && packing <= 0.78) {
        return None;
    }
    let side = (count as f64 * std::f64::consts::FRAC_PI_4 / packing).sqrt();
    let k = (count as f64).sqrt().ceil() as usize;
    let spacing = side / k as f64;
    let mut placement = Placement::new(seed);
    let mut balls: Vec<Ball> = (0..count)
        .map(|i| {
            let (cx, cy) = (i % k, i / k);
            let angle = std::f64::consts::TAU * placement.next_uniform();
            Ball {
                id: BallId(i as u32),
                kind: BallKind::Ball,
                position: DVec2::new((cx as f64 + 0.5) * spacing, (cy as f64 + 0.5) * spacing),
                velocity: DVec2::from_angle(angle),
                mass: 1.0,
                diameter: 1.0,
            }
        })
        .collect();
    let mean = balls.iter().map(|b| b.velocity).sum::<DVec2>() / count as f64;
    for b in &mut balls {
        b.velocity -= mean;
    }
    Some((Field { width: side, height: side, restitution: 1.0 }, balls))
}
