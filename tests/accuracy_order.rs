//! The measured orders of convergence agree with theory: each integrator's error against the
//! exact answers of the reference problems, fitted over a short sweep of time steps, falls with
//! the power of dt that theory says (within ±0.2). No timing is asserted.

use std::time::Duration;

use ballfield::accuracy::{self, Config};
use ballfield::physics::Integrator;

/// A sweep short enough for CI: 10 orbits per Kepler run, steps down to where rounding starts.
fn short_sweep() -> Config {
    Config { min_timing: Duration::ZERO, ..Config::quick() }
}

#[test]
fn measured_orders_agree_with_theory() {
    let report = accuracy::run(&short_sweep(), |_| {}).expect("the reference problems run");
    let table = report.orders_table();
    println!("{table}");
    let mut failures = Vec::new();
    for f in &report.fits {
        if let (Some(theory), Some(fit)) = (f.theory, f.fit)
            && !theory.agrees(fit.order)
        {
            failures.push(format!(
                "{} {} {}: measured {:.2}, theory {theory}",
                f.problem,
                f.measure.name,
                f.integrator.name(),
                fit.order
            ));
        }
        if f.theory.is_none() {
            assert!(f.fit.is_none(), "{} {}: an exact method showed truncation error", f.problem, f.integrator);
        }
    }
    assert!(failures.is_empty(), "orders off by more than 0.2:\n{}\n{table}", failures.join("\n"));

    // Every integrator's order is actually measured (not skipped for want of points) on the
    // smooth problems where the sweep reaches its asymptotic range.
    let must_fit: &[(&str, &str, &[Integrator])] = &[
        ("drag-fall", "fall", &Integrator::ALL),
        ("projectile", "position", &[Integrator::ExplicitEuler, Integrator::SemiImplicitEuler]),
        (
            "kepler-e05",
            "position",
            &[Integrator::SemiImplicitEuler, Integrator::Leapfrog, Integrator::Rk4, Integrator::Yoshida4],
        ),
        ("kepler-e05", "energy", &[Integrator::SemiImplicitEuler, Integrator::Leapfrog, Integrator::Yoshida4]),
        // The collisions are not here: the contacts replay a collision from the instant of
        // contact with the normal taken there, which is exact at any angle, so their error is
        // at rounding level for every integrator (an oblique one converged at first order while
        // the normal was taken where the balls overlap).
    ];
    for (problem, measure, integrators) in must_fit {
        for &i in *integrators {
            let fit = report.fit(problem, measure, i).and_then(|f| f.fit);
            assert!(fit.is_some(), "{problem} {measure} {i}: no order fitted\n{table}");
        }
    }
}

#[test]
fn every_reference_scene_is_built_in_and_has_an_exact_answer() {
    for problem in accuracy::PROBLEMS {
        let scene = problem.scene().unwrap_or_else(|e| panic!("{}: {e}", problem.name));
        problem.exact(&scene).unwrap_or_else(|e| panic!("{}: {e}", problem.name));
    }
}
