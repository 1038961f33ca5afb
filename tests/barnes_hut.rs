//! The Barnes–Hut tree against the direct sum: accuracy at the default opening angle on a uniform
//! and a clustered field of 10,000 balls, θ = 0 equal to the direct sum, degenerate inputs, and
//! determinism. One 10,000-ball direct sum per field (50 million pairs); nothing here is timed.

use ballfield::physics::{
    Attraction, AttractionMethod, BarnesHut, BodyProps, DEFAULT_OPENING_ANGLE, Effects, Forces, TREE_MIN_BALLS,
    attraction_force, near_force,
};
use glam::DVec2;

/// SplitMix64: a fixed, dependency-free random stream.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn next(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A field of balls as the force passes see it.
struct Field {
    pos: Vec<DVec2>,
    mass: Vec<f64>,
    inverse_mass: Vec<f64>,
    diameter: Vec<f64>,
}

impl Field {
    fn new(pos: Vec<DVec2>, rng: &mut Rng) -> Self {
        let n = pos.len();
        // Masses 0.5–2 kg, diameters 0.2–1 m: different balls, so that the centre of mass of a
        // node is not its centroid.
        let mass: Vec<f64> = (0..n).map(|_| 0.5 + 1.5 * rng.next()).collect();
        let diameter = (0..n).map(|_| 0.2 + 0.8 * rng.next()).collect();
        let inverse_mass = mass.iter().map(|m| 1.0 / m).collect();
        Field { pos, mass, inverse_mass, diameter }
    }

    fn props(&self) -> BodyProps<'_> {
        BodyProps { mass: &self.mass, inverse_mass: &self.inverse_mass, diameter: &self.diameter }
    }

    fn radius(&self) -> Vec<f64> {
        self.diameter.iter().map(|d| 0.5 * d).collect()
    }

    /// Accelerations by the attraction pass with the given method, and the largest ω² it met.
    fn accelerations(&self, attraction: Attraction, method: AttractionMethod) -> (Vec<DVec2>, f64) {
        let effects = Effects { attraction: Some(attraction), ..Effects::default() };
        let mut forces = Forces::new(&effects);
        forces.set_attraction_method(Some(method));
        let mut acc = vec![DVec2::ZERO; self.pos.len()];
        let vel = vec![DVec2::ZERO; self.pos.len()];
        forces.accelerations(self.props(), None, &self.pos, &vel, &mut acc);
        (acc, forces.take_orbit_rate_squared().expect("the attraction pass ran"))
    }
}

/// 10,000 balls uniformly at random in a 300 m square (some overlap: the interior force is
/// exercised too).
fn uniform(n: usize, seed: u64) -> Field {
    let mut rng = Rng(seed);
    let pos = (0..n).map(|_| DVec2::new(300.0 * rng.next(), 300.0 * rng.next())).collect();
    Field::new(pos, &mut rng)
}

/// Ten clusters of different sizes and weights, each a Plummer sphere seen from above (dense
/// cores, long tails), plus a thin uniform background: the distribution a self-gravitating field
/// collapses into.
fn clustered(n: usize, seed: u64) -> Field {
    let mut rng = Rng(seed);
    let centres: Vec<(DVec2, f64)> = (0..10)
        .map(|_| (DVec2::new(50.0 + 400.0 * rng.next(), 50.0 + 400.0 * rng.next()), 2.0 + 20.0 * rng.next()))
        .collect();
    let pos = (0..n)
        .map(|k| {
            if k % 10 == 9 {
                return DVec2::new(500.0 * rng.next(), 500.0 * rng.next());
            }
            let (c, a) = centres[k % 10];
            // Plummer: the radius enclosing a uniform fraction u of the mass, capped.
            let u = rng.next().max(1e-12);
            let r = (a / (u.powf(-2.0 / 3.0) - 1.0).sqrt()).min(20.0 * a);
            // Projected onto the plane: a random direction in 3D, keep x and y.
            let z = 2.0 * rng.next() - 1.0;
            let phi = std::f64::consts::TAU * rng.next();
            let s = (1.0 - z * z).sqrt();
            c + r * DVec2::new(s * phi.cos(), s * phi.sin())
        })
        .collect();
    Field::new(pos, &mut rng)
}

/// Relative error of each acceleration against the reference, sorted.
fn relative_errors(approx: &[DVec2], exact: &[DVec2]) -> Vec<f64> {
    let mut e: Vec<f64> = approx.iter().zip(exact).map(|(a, b)| (*a - *b).length() / b.length()).collect();
    e.sort_by(f64::total_cmp);
    e
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// The tree's force error against the direct sum at the default opening angle, over every ball.
///
/// The error is the method's own approximation, and the same bits on every run (fixed fields,
/// fixed θ), not rounding: the bounds sit just above it rather than 10× above, so that a change to
/// the tree that costs accuracy shows. Measured at θ = 0.5 with the quadrupole: median 2.01e-3 and
/// 99th percentile 3.49e-2 on the uniform field, 1.49e-3 and 2.20e-2 on the clustered one
/// (max 0.49 and 0.29, single balls where the pulls nearly cancel); bounds: median 3e-3, 99th
/// percentile 5e-2. Seen to fail with the default opening angle at 0.6 (uniform: median 4.2e-3,
/// which the old bound, a median of 1 %, passed), and with the quadrupole left out (median
/// 1.26e-2 uniform, 1.49e-2 clustered).
fn check_accuracy(name: &str, field: &Field) {
    let attraction = Attraction { g_constant: 1.0, ..Attraction::default() };
    assert_eq!(attraction.opening_angle, DEFAULT_OPENING_ANGLE);
    let (exact, exact_rate) = field.accelerations(attraction, AttractionMethod::Direct);
    let (tree, tree_rate) = field.accelerations(attraction, AttractionMethod::Tree);
    let e = relative_errors(&tree, &exact);
    let (median, p99, max) = (quantile(&e, 0.5), quantile(&e, 0.99), e[e.len() - 1]);
    println!(
        "{name}: θ = {DEFAULT_OPENING_ANGLE}: relative force error median {median:.2e}, 99th percentile {p99:.2e}, \
         max {max:.2e}; ω² tree {tree_rate:.4e} / direct {exact_rate:.4e}"
    );
    assert!(median <= 3e-3, "{name}: median relative force error {median:.3e}");
    assert!(p99 <= 5e-2, "{name}: 99th percentile of the relative force error {p99:.3e}");
    assert!(tree.iter().all(|a| a.is_finite()));
    // Both find the fastest orbit, which is between touching neighbours: summed exactly by both.
    assert!(
        tree_rate >= exact_rate * (1.0 - 1e-12) && tree_rate <= 1.5 * exact_rate,
        "{name}: worst ω² {tree_rate:e} from the tree, {exact_rate:e} from the direct sum"
    );
}

#[test]
fn the_tree_is_close_to_the_direct_sum_on_a_uniform_field() {
    check_accuracy("uniform", &uniform(10_000, 1));
}

#[test]
fn the_tree_is_close_to_the_direct_sum_on_a_clustered_field() {
    check_accuracy("clustered", &clustered(10_000, 2));
}

/// θ = 0 opens every node: every pair is summed with `attraction_force`, only in another order.
#[test]
fn opening_angle_zero_is_the_direct_sum() {
    let field = clustered(2_000, 3);
    let zero = Attraction { g_constant: 1.0, opening_angle: 0.0 };
    let (exact, exact_rate) = field.accelerations(zero, AttractionMethod::Direct);
    let (tree, tree_rate) = field.accelerations(zero, AttractionMethod::Tree);
    let worst = relative_errors(&tree, &exact).pop().unwrap();
    assert!(worst < 1e-12, "θ = 0 differs from the direct sum by {worst:e}");
    assert!((tree_rate - exact_rate).abs() <= 1e-12 * exact_rate, "the same pairs, the same largest rate");
    // And the automatic choice takes the direct sum at θ = 0, however many balls.
    assert_eq!(AttractionMethod::choose(1_000_000, &zero), AttractionMethod::Direct);
}

/// The tree's force on one ball matches a pair-by-pair sum over the others, and excludes the
/// ball itself; `acceleration` is the force over the mass.
#[test]
fn one_query_is_the_force_from_every_other_ball() {
    let field = uniform(3_000, 4);
    let att = Attraction { g_constant: 1.0, opening_angle: 0.0 };
    let mut tree = BarnesHut::new();
    tree.build(&field.pos, &field.mass, &field.radius(), &att);
    let r = field.radius();
    for i in [0, 1, 1234, 2999] {
        let mut exact = DVec2::ZERO;
        for j in 0..field.pos.len() {
            if j != i {
                exact += attraction_force(field.pos[i], field.mass[i], r[i], field.pos[j], field.mass[j], r[j], &att);
            }
        }
        let f = tree.force(i);
        assert!((f - exact).length() <= 1e-12 * exact.length(), "ball {i}: {f} vs {exact}");
        let a = tree.acceleration(i);
        assert!((a - f / field.mass[i]).length() <= 1e-15 * a.length());
    }
}

#[test]
fn a_single_ball_feels_nothing_and_an_empty_field_builds() {
    let mut tree = BarnesHut::new();
    let att = Attraction::default();
    tree.build(&[], &[], &[], &att);
    assert!(tree.is_empty());
    tree.build(&[DVec2::new(3.0, 4.0)], &[2.0], &[0.5], &att);
    assert_eq!(tree.len(), 1);
    assert_eq!(tree.force_and_rate(0), (DVec2::ZERO, 0.0));
}

/// Coincident balls land in one leaf (no endless splitting) and pull each other with exactly
/// zero force (the uniform-ball interior force at r = 0); others see them as one heavy ball.
#[test]
fn coincident_balls_do_not_panic_or_make_nan() {
    let att = Attraction { g_constant: 1.0, ..Attraction::default() };
    let mut pos = vec![DVec2::new(10.0, 10.0); 5_000];
    pos.extend((0..5_000).map(|k| DVec2::new(100.0 + (k % 100) as f64, 100.0 + (k / 100) as f64)));
    let n = pos.len();
    let (mass, radius) = (vec![1.0; n], vec![0.1; n]);
    let mut tree = BarnesHut::new();
    tree.build(&pos, &mass, &radius, &att);
    assert!(tree.node_count() < n, "{} nodes", tree.node_count());
    for i in [0, 1, 4_999] {
        let (f, rate) = tree.force_and_rate(i);
        assert!(f.is_finite() && rate.is_finite(), "ball {i}: {f}, {rate}");
        // The lattice far away pulls up and to the right, the coincident balls not at all.
        assert!(f.x > 0.0 && f.y > 0.0);
    }
    assert!(tree.force_and_rate(5_000).0.is_finite());

    // Every ball on one point: a zero-size box.
    let same = vec![DVec2::new(-1.0, 2.0); 3_000];
    tree.build(&same, &vec![1.0; 3_000], &vec![0.1; 3_000], &att);
    for i in [0, 1_500, 2_999] {
        assert_eq!(tree.force(i), DVec2::ZERO);
    }

    // Through the force pass too.
    let field = Field { inverse_mass: vec![1.0; n], mass, diameter: vec![0.2; n], pos };
    let (acc, rate) = field.accelerations(att, AttractionMethod::Tree);
    assert!(acc.iter().all(|a| a.is_finite()) && rate.is_finite());
}

/// A non-finite position (a state gone bad elsewhere) gives non-finite forces, as the direct sum
/// would, but never a panic or an endless build.
#[test]
fn non_finite_positions_do_not_panic() {
    let att = Attraction { g_constant: 1.0, ..Attraction::default() };
    let mut pos: Vec<DVec2> = (0..500).map(|k| DVec2::new((k % 25) as f64, (k / 25) as f64)).collect();
    let n = pos.len();
    let mut tree = BarnesHut::new();
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        pos[7] = DVec2::new(bad, 3.0);
        pos[300] = DVec2::new(2.0, bad);
        tree.build(&pos, &vec![1.0; n], &vec![0.25; n], &att);
        for i in [0, 7, 300, 499] {
            let _ = tree.force_and_rate(i);
        }
    }
}

/// The same input gives the same bits, whatever the order the balls are asked in and however
/// often the tree is rebuilt in the same memory.
#[test]
fn the_tree_is_deterministic() {
    let field = clustered(5_000, 5);
    let r = field.radius();
    let att = Attraction { g_constant: 1.0, ..Attraction::default() };
    let mut a = BarnesHut::new();
    a.build(&field.pos, &field.mass, &r, &att);
    let forward: Vec<(DVec2, f64)> = (0..5_000).map(|i| a.force_and_rate(i)).collect();
    // Another tree, built after a different field in the same memory, asked backwards.
    let mut b = BarnesHut::new();
    let other = uniform(7_000, 6);
    b.build(&other.pos, &other.mass, &other.radius(), &att);
    b.build(&field.pos, &field.mass, &r, &att);
    let mut backward: Vec<(DVec2, f64)> = (0..5_000).rev().map(|i| b.force_and_rate(i)).collect();
    backward.reverse();
    let bits = |v: &[(DVec2, f64)]| -> Vec<[u64; 3]> {
        v.iter().map(|(f, w)| [f.x.to_bits(), f.y.to_bits(), w.to_bits()]).collect()
    };
    assert_eq!(bits(&forward), bits(&backward));
    // From several threads at once (disjoint halves): the same bits again.
    let tree = &a;
    let halves: Vec<Vec<(DVec2, f64)>> = std::thread::scope(|s| {
        let lo = s.spawn(move || (0..2_500).map(|i| tree.force_and_rate(i)).collect());
        let hi = s.spawn(move || (2_500..5_000).map(|i| tree.force_and_rate(i)).collect());
        vec![lo.join().unwrap(), hi.join().unwrap()]
    });
    assert_eq!(bits(&halves.concat()), bits(&forward));
}

/// The switch is automatic by ball count and named in the pass list.
#[test]
fn the_method_is_chosen_by_ball_count_and_reported() {
    let attraction = Attraction::default();
    let forces = Forces::new(&Effects { attraction: Some(attraction), ..Effects::default() });
    assert_eq!(forces.attraction_method(TREE_MIN_BALLS - 1), Some(AttractionMethod::Direct));
    assert_eq!(forces.attraction_method(TREE_MIN_BALLS), Some(AttractionMethod::Tree));
    assert_eq!(forces.pass_names(10), vec!["attraction (direct)"]);
    assert_eq!(forces.pass_names(100_000), vec!["attraction (tree)"]);
    assert_eq!(Forces::new(&Effects::default()).attraction_method(100_000), None);
}

/// Not a check: the error at several opening angles, with and without the quadrupole, for
/// choosing the default (`cargo test --release --test barnes_hut -- --ignored --nocapture`).
#[test]
#[ignore]
fn opening_angle_sweep() {
    for (name, field) in [("uniform", uniform(10_000, 1)), ("clustered", clustered(10_000, 2))] {
        let r = field.radius();
        let g1 = Attraction { g_constant: 1.0, opening_angle: 0.0 };
        let (exact, _) = field.accelerations(g1, AttractionMethod::Direct);
        for monopole in [true, false] {
            for theta in [0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0] {
                let att = Attraction { g_constant: 1.0, opening_angle: theta };
                let mut tree = BarnesHut::new();
                tree.set_monopole_only(monopole);
                tree.build(&field.pos, &field.mass, &r, &att);
                let approx: Vec<DVec2> = (0..field.pos.len()).map(|i| tree.acceleration(i)).collect();
                let e = relative_errors(&approx, &exact);
                println!(
                    "{name:9} {} θ = {theta:.1}: median {:.2e}  90% {:.2e}  99% {:.2e}  max {:.2e}",
                    if monopole { "monopole  " } else { "quadrupole" },
                    quantile(&e, 0.5),
                    quantile(&e, 0.9),
                    quantile(&e, 0.99),
                    e[e.len() - 1]
                );
            }
        }
    }
}

/// `[effects.attraction] opening-angle` reaches the engine; absent, it is the default.
#[test]
fn the_scene_sets_the_opening_angle() {
    use ballfield::scene::{Origin, Scene};
    let read = |effects: &str| {
        let text = format!("name = \"t\"\n[effects]\n{effects}\n");
        Scene::from_toml_str(&text, &Origin("t.toml".into())).unwrap().effects.attraction.unwrap()
    };
    assert_eq!(read("attraction = { g-constant = 1.0 }").opening_angle, DEFAULT_OPENING_ANGLE);
    assert_eq!(read("attraction = { opening-angle = 0.7 }").opening_angle, 0.7);
    let zero = read("attraction = { g-constant = 2.0, opening-angle = 0.0 }");
    assert_eq!(zero, Attraction { g_constant: 2.0, opening_angle: 0.0 });
    assert_eq!(AttractionMethod::choose(100_000, &zero), AttractionMethod::Direct);
}

/// Balls on a square lattice, 3 m apart, 1 kg, 1 m across, at rest.
fn lattice(n: usize) -> Vec<ballfield::physics::Ball> {
    use ballfield::physics::{Ball, BallId, BallKind};
    let side = (n as f64).sqrt().ceil() as usize;
    (0..n)
        .map(|k| Ball {
            id: BallId(k as u32),
            kind: BallKind::Ball,
            position: DVec2::new(5.0 + 3.0 * (k % side) as f64, 5.0 + 3.0 * (k / side) as f64),
            velocity: DVec2::ZERO,
            mass: 1.0,
            diameter: 1.0,
        })
        .collect()
}

/// The engine reports which sum it uses for the balls it has, and switches as balls come and go.
#[test]
fn the_engine_reports_the_switch() {
    use ballfield::Lockstep;
    use ballfield::physics::{Field, Integrator};
    let effects =
        Effects { attraction: Some(Attraction { g_constant: 1e-3, ..Attraction::default() }), ..Effects::default() };
    let field = Field { width: 200.0, height: 200.0, restitution: 1.0 };
    let mut e = Lockstep::from_parts(field, effects, Integrator::Leapfrog, 1e-3, 1_000, &lattice(TREE_MIN_BALLS));
    assert_eq!(e.active_effects(), vec!["attraction (tree)"]);
    e.run(3);
    e.remove_last().unwrap();
    assert_eq!(e.active_effects(), vec!["attraction (direct)"]);
    e.run(3);
    assert!(e.bodies().position.iter().all(|p| p.is_finite()));
}

/// The tree's pass feeds the step splitting: a tight, heavy pair among many balls makes the
/// engine sub-step, exactly as with the direct sum.
#[test]
fn a_fast_orbit_splits_the_step_with_the_tree_too() {
    use ballfield::Lockstep;
    use ballfield::physics::{Field, Integrator};
    let field = Field { width: 200.0, height: 200.0, restitution: 1.0 };
    let mut balls = lattice(400);
    // Two 1e4 kg balls 1.2 m apart at G = 10: ω² = G·2e4/1.2³ ≈ 1.16e5 /s², so ω·h ≈ 0.34 at
    // h = 1 ms, above MAX_ORBIT_STEP = 0.2: every step must be split at least in two.
    balls[0].mass = 1e4;
    balls[1].mass = 1e4;
    balls[1].position = balls[0].position + DVec2::new(1.2, 0.0);
    for theta in [DEFAULT_OPENING_ANGLE, 0.0] {
        let attraction = Attraction { g_constant: 10.0, opening_angle: theta };
        let effects = Effects { attraction: Some(attraction), ..Effects::default() };
        let mut e = Lockstep::from_parts(field, effects, Integrator::Leapfrog, 1e-3, 1_000, &balls);
        let expected = if theta > 0.0 { "attraction (tree)" } else { "attraction (direct)" };
        assert_eq!(e.active_effects(), vec![expected]);
        e.run(10);
        let c = e.counters();
        assert!(c.substeps >= 2 * c.steps, "θ = {theta}: {} sub-steps in {} steps", c.substeps, c.steps);
    }
}

/// The headless report names the sum that ran.
#[test]
fn the_headless_report_names_the_tree() {
    let dir = std::env::temp_dir().join(format!("ballfield-barnes-hut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("tree.toml");
    std::fs::write(
        &scene,
        "name = \"tree\"\n[effects]\nattraction = { g-constant = 0.001, opening-angle = 0.6 }\n\
         [[generate]]\ncount = 300\ndiameter = 1.0\nmass = 1.0\n",
    )
    .unwrap();
    let report = dir.join("r.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ballfield"))
        .args(["headless", "--scene"])
        .arg(&scene)
        .args(["--steps", "5", "--quiet", "--report"])
        .arg(&report)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["active_effects"], serde_json::json!(["attraction (tree)"]));
    std::fs::remove_dir_all(&dir).ok();
}

/// The tree of a field, and the balls' radii.
fn tree_of(field: &Field, att: &Attraction) -> (BarnesHut, Vec<f64>) {
    let r = field.radius();
    let mut tree = BarnesHut::new();
    tree.build(&field.pos, &field.mass, &r, att);
    (tree, r)
}

/// `force_at` at a ball's own state, excluding itself, is `force_and_rate` bit for bit (one walk
/// serves both), on a clustered field at the default θ where far nodes are approximated.
#[test]
fn force_at_a_balls_own_state_is_force_and_rate() {
    let field = clustered(3_000, 11);
    let att = Attraction { g_constant: 1.0, opening_angle: DEFAULT_OPENING_ANGLE };
    let (tree, r) = tree_of(&field, &att);
    for (i, (&p, &m)) in field.pos.iter().zip(&field.mass).enumerate() {
        let (f, w2) = tree.force_and_rate(i);
        let (g, v2) = tree.force_at(p, m, r[i], Some(i));
        assert_eq!((f.x.to_bits(), f.y.to_bits()), (g.x.to_bits(), g.y.to_bits()), "ball {i}: {f} vs {g}");
        assert_eq!(w2.to_bits(), v2.to_bits(), "ball {i}: rate {w2} vs {v2}");
    }
}

/// At θ = 0, `force_at` anywhere is the direct sum over the tree's balls less the excluded one —
/// for a body the tree does not hold (nothing excluded), and for a ball that has moved far from
/// its entry in the tree.
#[test]
fn force_at_with_theta_zero_is_the_direct_sum() {
    let field = uniform(2_000, 12);
    let att = Attraction { g_constant: 1.0, opening_angle: 0.0 };
    let (tree, r) = tree_of(&field, &att);
    let direct = |p: DVec2, m: f64, rad: f64, skip: Option<usize>| {
        let mut f = DVec2::ZERO;
        for (j, (&q, &mq)) in field.pos.iter().zip(&field.mass).enumerate() {
            if Some(j) != skip {
                f += attraction_force(p, m, rad, q, mq, r[j], &att);
            }
        }
        f
    };
    for (p, m, rad, skip) in [
        (DVec2::new(17.0, 250.0), 3.0, 0.4, None),
        (DVec2::new(-40.0, 500.0), 0.1, 2.0, None),
        (field.pos[5] + DVec2::new(80.0, -30.0), field.mass[5], r[5], Some(5)),
        (field.pos[1999], 7.0, 0.3, Some(1999)),
    ] {
        let (f, _) = tree.force_at(p, m, rad, skip);
        let exact = direct(p, m, rad, skip);
        assert!((f - exact).length() <= 1e-12 * exact.length(), "at {p}: {f} vs {exact}");
    }
}

/// A body that has moved away from its own (heavy) entry in the tree never feels that entry, even
/// where the node holding it is far enough to be approximated: the node is opened instead.
#[test]
fn force_at_never_counts_the_excluded_ball_in_a_multipole() {
    let mut rng = Rng(13);
    let mut pos: Vec<DVec2> = (0..500).map(|_| DVec2::new(100.0 * rng.next(), 100.0 * rng.next())).collect();
    let mut field = Field::new(std::mem::take(&mut pos), &mut rng);
    // Ball 0 is a thousand times heavier than all the others together, in a corner.
    field.pos[0] = DVec2::new(1.0, 1.0);
    field.mass[0] = 1e6;
    let att = Attraction { g_constant: 1.0, opening_angle: DEFAULT_OPENING_ANGLE };
    let (tree, r) = tree_of(&field, &att);
    // The same body, moved to the far corner.
    let p = DVec2::new(99.0, 99.0);
    let (f, _) = tree.force_at(p, field.mass[0], r[0], Some(0));
    let mut exact = DVec2::ZERO;
    for j in 1..field.pos.len() {
        exact += attraction_force(p, field.mass[0], r[0], field.pos[j], field.mass[j], r[j], &att);
    }
    let err = (f - exact).length() / exact.length();
    assert!(err < 0.01, "force {f} vs the others' {exact}: {err:e} off (its own old mass counted?)");
}

/// `split_at` with no margin is `force_at` bit for bit: the far force plus the near balls summed
/// exactly at the same point, and the same rate.
#[test]
fn split_at_without_margin_is_force_at() {
    let field = clustered(3_000, 14);
    let att = Attraction { g_constant: 1.0, opening_angle: DEFAULT_OPENING_ANGLE };
    let (tree, r) = tree_of(&field, &att);
    let mut near = Vec::new();
    for (i, (&p, &m)) in field.pos.iter().zip(&field.mass).enumerate() {
        let p = p + DVec2::new(0.003, -0.002);
        let (f, w2) = tree.force_at(p, m, r[i], Some(i));
        let (far, v2) = tree.split_at(p, m, r[i], Some(i), 0.0, &mut near);
        let g = far + near_force(&near, p, m, r[i], &att);
        assert_eq!((f.x.to_bits(), f.y.to_bits()), (g.x.to_bits(), g.y.to_bits()), "ball {i}: {f} vs {g}");
        assert_eq!(w2.to_bits(), v2.to_bits(), "ball {i}");
    }
}

/// Along a short path (a ball's sub-steps in one cycle), the far force kept from the start plus the
/// near balls summed exactly at each point stays close to the direct sum at that point: every ball
/// of a clustered field, moved by up to half the margin in a fixed direction.
#[test]
fn split_at_along_a_short_path_is_close_to_the_direct_sum() {
    let field = clustered(2_000, 15);
    let att = Attraction { g_constant: 1.0, opening_angle: DEFAULT_OPENING_ANGLE };
    let (tree, r) = tree_of(&field, &att);
    let (step, margin) = (0.05, 0.1);
    let mut near = Vec::new();
    let mut errors = Vec::new();
    let mut tree_errors = Vec::new();
    for (i, (&p0, &m)) in field.pos.iter().zip(&field.mass).enumerate() {
        let (far, _) = tree.split_at(p0, m, r[i], Some(i), margin, &mut near);
        let p = p0 + DVec2::new(0.6, 0.8) * step;
        let split = far + near_force(&near, p, m, r[i], &att);
        let mut exact = DVec2::ZERO;
        for (j, (&q, &mq)) in field.pos.iter().zip(&field.mass).enumerate() {
            if j != i {
                exact += attraction_force(p, m, r[i], q, mq, r[j], &att);
            }
        }
        errors.push((split - exact).length() / exact.length());
        tree_errors.push((tree.force_at(p, m, r[i], Some(i)).0 - exact).length() / exact.length());
    }
    errors.sort_by(f64::total_cmp);
    tree_errors.sort_by(f64::total_cmp);
    let (median, p99) = (quantile(&errors, 0.5), quantile(&errors, 0.99));
    let (tree_median, tree_p99) = (quantile(&tree_errors, 0.5), quantile(&tree_errors, 0.99));
    // Measured: median 0.31 %, 99th percentile 6.1 %, against 0.15 % and 1.9 % for the whole
    // walk at each point: freezing the far field over 5 cm costs about as much as the tree's own
    // approximation, the same order as freezing the other balls for the cycle.
    let what = format!("median {median:e}, 99th {p99:e}; the whole walk {tree_median:e}, {tree_p99:e}");
    assert!(median < 0.01 && p99 < 0.15, "{what}");
}
