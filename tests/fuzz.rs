//! Property tests (proptest): thousands of random scene texts and random initial states.
//! Scene parsing never panics and every refusal names the file; random fields never produce NaN,
//! never lose a ball through a wall and never panic.
//!
//! Reproducible: every run draws its cases from one fixed seed (`CI_SEED`), so CI runs the same
//! cases every time and a failure there is a failure on every machine. `PROPTEST_RNG_SEED=N`
//! draws another set (the longer runs by hand, below). Failures are kept: proptest appends the
//! seed of every failing case to `tests/fuzz.proptest-regressions` (committed), and every run
//! replays the cases listed there before drawing new ones.
//!
//! The longer run by hand, with other seeds and more cases (about 4 minutes per 1,000 random
//! fields on two cores; the seeds run so far, and what they found, are in docs/measurements.md, *Fuzz findings*):
//!
//! ```sh
//! PROPTEST_RNG_SEED=16 BALLFIELD_FUZZ_CASES=1000 cargo test --release --test fuzz
//! ```
//!
//! Seen to fail, and to keep its failure, with the sub-step split turned off
//! (`adaptive_substeps: false` in `Lockstep::from_parts`): the random-field property failed at
//! its CI seed, proptest shrank the field and wrote its seed to the regressions file, and the next
//! run of that build failed on the replayed case before drawing any new one.

mod common;

use ballfield::Lockstep;
use ballfield::physics::{Attraction, Ball, BallId, BallKind, Collisions, Drag, Effects, Field, Gravity, Integrator};
use ballfield::scene::{Origin, Scene};
use ballfield::scenes::BUILTIN;
use glam::DVec2;
use proptest::prelude::*;
use proptest::test_runner::{FileFailurePersistence, RngSeed};

/// The seed the cases are drawn from unless `PROPTEST_RNG_SEED` names another.
const CI_SEED: u64 = 12;

/// `cases` cases from the fixed seed (or `PROPTEST_RNG_SEED`), failures kept in
/// `tests/fuzz.proptest-regressions` (unless `PROPTEST_DISABLE_FAILURE_PERSISTENCE` is set).
fn config(cases: u32) -> ProptestConfig {
    let mut config = ProptestConfig { cases, ..ProptestConfig::default() };
    if config.rng_seed == RngSeed::Random {
        config.rng_seed = RngSeed::Fixed(CI_SEED);
    }
    if config.failure_persistence.is_some() {
        config.failure_persistence = Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions")));
    }
    config
}

/// Values a user might type by mistake, as TOML.
fn bad_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0.0".to_string()),
        Just("-1.0".to_string()),
        Just("1e308".to_string()),
        Just("1e-320".to_string()),
        Just("\"text\"".to_string()),
        Just("[]".to_string()),
        Just("[1.0, 2.0, 3.0]".to_string()),
        Just("{}".to_string()),
        Just("true".to_string()),
        Just("99999999999999999999".to_string()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        any::<i64>().prop_map(|v| v.to_string()),
    ]
}

/// A built-in scene with one line changed: its value replaced, the line deleted or duplicated,
/// or random bytes spliced in.
fn mutated_scene() -> impl Strategy<Value = String> {
    let scenes: Vec<&'static str> = BUILTIN.iter().map(|(_, t)| *t).filter(|t| t.len() < 4000).collect();
    (prop::sample::select(scenes), any::<prop::sample::Index>(), 0..4u8, bad_value(), "[ -~]{0,12}").prop_map(
        |(text, line, how, value, junk)| {
            let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
            let k = line.index(lines.len());
            match how {
                0 => {
                    if let Some((key, _)) = lines[k].split_once('=') {
                        lines[k] = format!("{key}= {value}");
                    }
                }
                1 => {
                    lines.remove(k);
                }
                2 => {
                    let l = lines[k].clone();
                    lines.insert(k, l);
                }
                _ => {
                    let at = lines[k].len() / 2;
                    let mut l = lines[k].clone();
                    if l.is_char_boundary(at) {
                        l.insert_str(at, &junk);
                    }
                    lines[k] = l;
                }
            }
            lines.join("\n")
        },
    )
}

proptest! {
    #![proptest_config(config(3000))]

    #[test]
    fn scene_parsing_never_panics_and_names_the_file(text in mutated_scene()) {
        match Scene::from_toml_str(&text, &Origin("fuzz.toml".into())) {
            Ok(scene) => {
                // Whatever was accepted is sound.
                for b in &scene.balls {
                    prop_assert!(b.is_finite() && b.mass > 0.0 && b.diameter > 0.0);
                    prop_assert!(scene.field.contains(b.position.x, b.position.y, b.radius(), 1e-9));
                }
                prop_assert!(scene.dt > 0.0 && scene.dt.is_finite());
            }
            Err(e) => prop_assert!(e.to_string().starts_with("fuzz.toml"), "{e}"),
        }
    }
}

fn random_ball(id: u32, field: Field) -> impl Strategy<Value = Ball> {
    (0.0..1.0f64, 0.0..1.0f64, -300.0..300.0f64, -300.0..300.0f64, -3.0..6.0f64, -3.0..0.5f64).prop_map(
        move |(u, v, vx, vy, log_m, log_d)| {
            let d = 10f64.powf(log_d);
            let r = d / 2.0;
            Ball {
                id: BallId(id),
                kind: BallKind::Ball,
                position: DVec2::new(r + u * (field.width - d), r + v * (field.height - d)),
                velocity: DVec2::new(vx, vy),
                mass: 10f64.powf(log_m),
                diameter: d,
            }
        },
    )
}

fn random_effects() -> impl Strategy<Value = Effects> {
    (any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>(), 0.0..=1.0f64).prop_map(|(g, d, a, c, e)| Effects {
        gravity: g.then(Gravity::default),
        drag: d.then(Drag::default),
        attraction: a.then_some(Attraction { g_constant: 1.0, ..Attraction::default() }),
        collisions: c.then_some(Collisions { restitution: e }),
    })
}

/// Cases of the random-field property per run: 100 in CI (about 25 s: the stiffest fields take
/// every one of the 4,096 sub-steps a step allows); `BALLFIELD_FUZZ_CASES=3000` by hand.
fn random_field_cases() -> u32 {
    std::env::var("BALLFIELD_FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(100)
}

proptest! {
    #![proptest_config(config(random_field_cases()))]

    /// Random balls from 1 mm to 3 m, 1 g to 1e6 kg, up to 400 m/s, overlapping as they fall,
    /// under random effects (attraction with G = 1: stiff pairs) and integrators: 50 steps
    /// without NaN or escape.
    ///
    /// Findings so far, each fixed in the shared mechanism: stiff drag on a light, large, fast
    /// ball and close pairs under strong attraction blew up explicit steps (now sub-stepped,
    /// re-judged before every sub-step); a field that wanted more than the sub-step cap all the
    /// way through spent its last sub-step on a third of dt and blew up (sub-steps now have a
    /// floor of dt / 4,096 instead of a count cap); fields faster than even that floor resolves
    /// could still run away under explicit Euler (speeds now capped at `MAX_SPEED`, counted); a
    /// light ball pulled hard into its drag turned stiff within a sub-step (the split now bounds
    /// the drag rate by the terminal speed); drag too stiff even for the shortest sub-step threw
    /// balls to infinity (its rate is now capped at 1/h, counted). The last two are tests below.
    #[test]
    fn random_fields_stay_finite_and_inside(
        balls in (1usize..40).prop_flat_map(|n| {
            let field = Field { width: 20.0, height: 10.0, restitution: 1.0 };
            (0..n as u32).map(|id| random_ball(id, field)).collect::<Vec<_>>()
        }),
        effects in random_effects(),
        integrator in prop::sample::select(Integrator::ALL.to_vec()),
        restitution in 0.0..=1.0f64,
    ) {
        let field = Field { width: 20.0, height: 10.0, restitution };
        let mut e = Lockstep::from_parts(field, effects, integrator, 1e-3, balls.len(), &balls);
        e.run(50);
        let d = e.diagnostics();
        prop_assert_eq!(d.non_finite, 0);
        prop_assert_eq!(d.outside, 0);
    }
}

/// A field of 1-row-per-ball `(x, y, vx, vy, mass, diameter)` in the fuzzer's 20 m × 10 m field,
/// under Yoshida's method, gravity, quadratic drag and attraction with G = 1: the shape of both
/// findings below.
fn fuzz_finding(rows: &[(f64, f64, f64, f64, f64, f64)], collisions: Option<f64>, walls: f64) -> Lockstep {
    let balls: Vec<Ball> =
        rows.iter().enumerate().map(|(i, &(x, y, vx, vy, m, d))| common::ball(i as u32, x, y, vx, vy, m, d)).collect();
    let field = Field { width: 20.0, height: 10.0, restitution: walls };
    let effects = Effects {
        gravity: Some(Gravity::default()),
        drag: Some(Drag::default()),
        attraction: Some(Attraction { g_constant: 1.0, ..Attraction::default() }),
        collisions: collisions.map(|restitution| Collisions { restitution }),
    };
    common::engine(field, effects, Integrator::Yoshida4, 1e-3, &balls)
}

/// The random-field property's finding with `PROPTEST_RNG_SEED=12`, 1,000 cases (shrunk by
/// proptest). A 1.6 g ball of 2.2 m nearly at rest has a 2e5 kg grain of 1.5 mm pass inside it;
/// the grain pulls it at 2e4 m/s², and within one 0.33 ms sub-step its drag turns fifteen times
/// stiffer than at the sub-step's start. The step split only looked at the drag rate at the
/// start, the explicit stages overshot and it went to NaN at step 19 (and every ball with it,
/// through attraction). The split now also bounds the rate by the terminal speed the other forces
/// drive each ball to (`drag_rate_bound`, `Forces::take_terminal_drag_rate`): the run is finite,
/// resolved by the sub-steps alone, with neither guard rail.
#[test]
fn a_light_ball_pulled_hard_into_its_drag_stays_finite() {
    let rows = common::PULLED_INTO_DRAG;
    let mut e = fuzz_finding(&rows, None, 0.0);
    e.run(50);
    let d = e.diagnostics();
    assert_eq!((d.non_finite, d.outside), (0, 0));
    assert_eq!(e.counters().speed_limited, 0, "the sub-steps resolved it, not the speed guard rail");
    assert_eq!(e.counters().drag_limited, 0, "the sub-steps resolved it, not the drag guard rail");
}

/// The next finding of the same run (case 932; not shrunk): 34 balls, several of them grains of
/// 1e5–5e5 kg and a few millimetres, orbiting at rates no sub-step of dt/4,096 resolves. From step
/// ~20 every step takes all 4,096 sub-steps and speeds reach the 1e5 m/s guard rail; a 1 g ball
/// of 1 m thrown that fast meets a drag rate of 2e7/s, and at 0.24 µs each explicit stage
/// multiplied its speed by about −5 and squared it again: infinity within one sub-step, then NaN
/// everywhere. Drag too stiff for the shortest sub-step now has its rate capped at 1/h (a guard
/// rail, counted as `drag_limited`; see `Forces::set_drag_rate_limit`).
#[test]
fn drag_too_stiff_for_the_shortest_sub_step_stays_finite() {
    let rows = [
        (
            7.4074148115605665,
            6.825383676529604,
            59.51320424772785,
            183.962606107422,
            0.04073384918300225,
            0.9325924114140496,
        ),
        (
            3.2490145370269787,
            2.2677142003959703,
            81.5682434368056,
            -231.9535100530119,
            1044.3980313145526,
            0.5992753081002151,
        ),
        (
            1.4733182830083094,
            5.450915174923428,
            -286.27967932909166,
            -191.18049529817836,
            72885.88044055943,
            0.042734433184276124,
        ),
        (
            9.325936379338385,
            1.632774655194342,
            -256.4513693371584,
            -173.6765873778208,
            1.9885844279489227,
            0.004616676287744733,
        ),
        (
            3.053081502353775,
            0.6798596396374375,
            -187.8770843255683,
            -246.98167494287114,
            485853.9484038577,
            0.00793770578368691,
        ),
        (
            5.746590849197012,
            7.846653479065198,
            -88.60823189017381,
            -147.77437784107636,
            0.5136621877807253,
            0.21520181129949384,
        ),
        (
            12.56177280956273,
            0.2620583352471848,
            201.86056885364027,
            288.6831085247493,
            0.0018694243619374127,
            0.1401585787004388,
        ),
        (
            16.299971966047192,
            8.388796181016906,
            196.1952291732962,
            222.6969488910793,
            80.68951939579897,
            0.009088345148660396,
        ),
        (
            5.0735894190651125,
            0.7328173641716094,
            225.17230024177505,
            103.07940775868265,
            444523.6023627815,
            0.11724115539924508,
        ),
        (
            3.7737866861216145,
            1.4635379646749656,
            66.3155941931055,
            -227.78942064335305,
            0.001348093161572055,
            0.18757534969863127,
        ),
        (
            15.886418397078282,
            8.75233551231112,
            -101.37078297381511,
            158.8247210122752,
            0.0011261356391760763,
            1.0111350996887518,
        ),
        (
            8.15227198678723,
            4.80519640878686,
            -237.66824352062488,
            75.6193879174533,
            1.105800429865834,
            0.17964322515898795,
        ),
        (
            6.026147923412908,
            7.178071256289807,
            146.37935855937243,
            204.5011664386888,
            414.77167241495084,
            1.0201439168051933,
        ),
        (
            19.02094386322513,
            8.05495727907194,
            -129.2702492191582,
            162.08468240640875,
            6.7713386088759,
            0.014946289965921723,
        ),
        (
            8.898570511493215,
            8.905195756346158,
            -228.58139004706038,
            -232.21137519483807,
            0.003127068238262084,
            0.23386757119804122,
        ),
        (
            4.807534715252784,
            8.190935660995457,
            200.27815431269198,
            -268.5106014877082,
            0.04538922208934516,
            0.007181057700210303,
        ),
        (
            12.195992398726592,
            7.833176496533467,
            -41.41009354675285,
            -287.57507776251833,
            0.06082659187625857,
            0.007270528866271747,
        ),
        (
            19.74205371092438,
            3.5262774906613457,
            -136.93069155134245,
            258.8639518599905,
            1.6506769530457166,
            0.00565458654823471,
        ),
        (
            4.464264725653372,
            0.608536405777484,
            28.702593635050903,
            -174.41052414823488,
            282.9051400535537,
            0.9702583430494816,
        ),
        (
            5.023178560978683,
            2.3198776935490457,
            26.881094435778873,
            -267.2454270547239,
            515194.62009205046,
            0.07779946647122891,
        ),
        (
            19.951243221098117,
            1.703310061677621,
            -28.22197502820511,
            -192.9930059645206,
            2017.2683387742197,
            0.023471148627578174,
        ),
        (
            0.3946386000665883,
            7.5627379006148265,
            160.16961028444726,
            -36.67376805548394,
            23.313352319426464,
            0.007394579561572936,
        ),
        (
            12.833141197970518,
            5.526735441045138,
            50.424090711724496,
            -223.69100768241785,
            11.580200193963186,
            0.011516291319999341,
        ),
        (
            9.547791184880777,
            5.8987172049326,
            181.12529772513057,
            -247.59345604650682,
            0.03105370777704822,
            0.013046960738017166,
        ),
        (
            8.034821204759906,
            2.279760967052369,
            -35.79875044696699,
            -11.172871088543875,
            0.8596889277812804,
            0.06042146897912371,
        ),
        (
            9.008182798082782,
            1.4902658356190408,
            -4.842019285695877,
            -128.87231822922922,
            32449.140142603588,
            0.0012573163851429046,
        ),
        (
            19.189341155218628,
            1.1940901553016856,
            -54.92199877267418,
            75.52348905567088,
            0.025482254748788066,
            0.09772576370375427,
        ),
        (
            12.966300462287169,
            2.071962569588456,
            1.074245606918979,
            59.14915959847667,
            35.70161985108034,
            2.4663561677578927,
        ),
        (
            16.503542538998122,
            6.972364698300043,
            56.48944001801273,
            24.451979417259164,
            3865.3055217233245,
            0.010120379634084834,
        ),
        (
            7.9337162847816645,
            7.51228185076792,
            249.98185507057718,
            127.9082069701094,
            4445.687656749354,
            0.38123668628977714,
        ),
        (
            13.527363830469705,
            6.8773516776741035,
            -89.6181279619839,
            132.77078320118,
            5.435556648707393,
            0.9936225326985035,
        ),
        (
            10.671942958721385,
            5.137370464872532,
            285.3375940406394,
            -192.03516984818788,
            2.062408668576339,
            1.3822214520418612,
        ),
        (
            10.084762644766643,
            3.3510683114236,
            82.87784147582073,
            -260.5675711023029,
            5595.112144815907,
            1.8351316191960472,
        ),
        (
            18.034129812093276,
            7.1375902640363895,
            -15.484310962229593,
            -212.46378466207432,
            155322.398752136,
            0.007719848806559498,
        ),
    ];
    let mut e = fuzz_finding(&rows, Some(0.994526961591501), 0.8938069538368095);
    // Past step 26, where it went to NaN (the steps at the sub-step floor take ~0.3 s each).
    e.run(30);
    let d = e.diagnostics();
    assert_eq!((d.non_finite, d.outside), (0, 0));
    assert!(e.counters().drag_limited > 0, "this field needs the drag guard rail");
}
