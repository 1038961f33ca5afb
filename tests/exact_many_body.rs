//! The accuracy report's many-body section (`ballfield accuracy --many-body --quick`) runs and
//! measures what it says: the exact engine's Newton's cradle is the closed form, the gas under
//! gravity is chaotic with a positive λ and the stepped engines' errors fall with dt inside it, and
//! the walls' gauge gives hard-disk pressure near Henderson's.
//!
//! Measured (quick): the exact cradle's last ball at 5 m/s exactly, leaving at the closed form's
//! 1.6008 s to 0; λ = 19.8 /s; lockstep's (semi-implicit Euler) gas error at the shorter horizon
//! 6.0e-3, 5.7e-4 and 5.7e-5 m at dt = 1e-2, 1e-3 and 1e-4 s; Z = 2.20 at η = 0.3 (400 disks;
//! Henderson 2.06, the walls' share of so small a field included). Bounds: the cradle to 1e-12, λ between 5 and 50 /s,
//! each tenfold smaller dt at least 4 times smaller an error, Z within 8 % of Henderson.
//!
//! Seen to fail on a broken build: the pressure's kinetic energy taken as N·kT/2 (Z = 4.33).

use ballfield::accuracy::equation_of_state::henderson_z;
use ballfield::accuracy::many_body::{ManyBodyConfig, run};

#[test]
fn the_many_body_section_measures_what_it_says() {
    let r = run(&ManyBodyConfig::quick(), |_| {}).unwrap();
    let exact = r.cradle.iter().find(|c| c.engine == "exact").unwrap();
    assert!((exact.speed - 5.0).abs() < 1e-12 && (exact.leave - r.cradle_leave).abs() < 1e-12, "{exact:?}");
    assert!((r.cradle_leave - 1.6008).abs() < 1e-12, "the closed form: {}", r.cradle_leave);
    assert!(r.lyapunov > 5.0 && r.lyapunov < 50.0, "λ = {}", r.lyapunov);
    let shorter = r.gas.iter().map(|g| g.horizon).fold(f64::INFINITY, f64::min);
    let errors: Vec<(f64, f64)> = r
        .gas
        .iter()
        .filter(|g| g.engine == "lockstep" && g.horizon == shorter)
        .map(|g| (g.dt.unwrap(), g.error))
        .collect();
    eprintln!("λ = {:.2} /s, lockstep at the shorter horizon: {errors:?}", r.lyapunov);
    for w in errors.windows(2) {
        assert!(w[1].1 < w[0].1 / 4.0, "a tenfold smaller dt, at least 4 times smaller an error: {errors:?}");
    }
    let z = &r.pressure[0];
    let henderson = henderson_z(z.packing);
    eprintln!("Z = {:.4} at η = {} (Henderson {henderson:.4}); bulk {:?}", z.z, z.packing, r.bulk);
    assert!((z.z - henderson).abs() < 0.08 * henderson, "{z:?}");
}
