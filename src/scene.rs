//! Scenes: what is on the field and which effects are on, read from TOML.
//!
//! Parsing (`Scene::from_toml_str`) is separate from file I/O (`Scene::load`). Every problem is a
//! [`SceneError`] naming the file, the key (with its line when it can be found) and the bad value;
//! nothing here panics on bad input.

use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

use glam::DVec2;
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::de::{Error as _, IntoDeserializer};
use serde::{Deserialize, Deserializer};

use crate::physics::{
    AIR_DENSITY, AIR_VISCOSITY, Attraction, Ball, BallId, BallKind, Collisions, DEFAULT_OPENING_ANGLE, Drag, Effects,
    Field, Gravity, Integrator, MAX_MASS, MAX_SPEED, MIN_MASS, NEWTON_G, SPHERE_DRAG_COEFFICIENT, STANDARD_GRAVITY,
};

/// The ball limit when a scene does not set one (the original design's 1,024).
pub const DEFAULT_MAX_BALLS: usize = 1024;
/// No scene may ask for more balls than this.
pub const HARD_MAX_BALLS: usize = 1_000_000;
/// Largest Barnes–Hut opening angle a scene may ask for: beyond it the tree's error grows fast.
pub const MAX_OPENING_ANGLE: f64 = 1.0;

/// A scene that has been read and checked: every number finite and in range, every ball inside
/// the field, no two listed balls overlapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene's `name`, as the window's title and the report give it.
    pub name: String,
    /// One line on what the scene shows (may be empty).
    pub description: String,
    /// The walled field: its size, m, and the walls' restitution.
    pub field: Field,
    /// The integrator both engines step with, unless the command line picks another.
    pub integrator: Integrator,
    /// Lockstep time step, s.
    pub dt: f64,
    /// Seed of the generated balls' positions and directions.
    pub seed: u64,
    /// The most balls the scene may hold, adding at run time included.
    pub max_balls: usize,
    /// Period a threaded ball aims for between its updates, s.
    pub ball_cycle: f64,
    /// The effects that are on; an absent one is off.
    pub effects: Effects,
    /// The force of the arrow keys on the key ball, N.
    pub pull: f64,
    /// All balls: the key ball first (id 0) if there is one, then the listed, then the generated.
    pub balls: Vec<Ball>,
}

/// Where a scene came from, for messages: a file path, or for a built-in scene the path of the
/// file it was built from (`assets/scenes/gas.toml`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Origin(pub String);

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// Why a scene was refused. Every message starts with the file (and its line where there is one).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file cannot be read. The cause is part of the message (and deliberately not a
    /// `source()`, so that printing the error chain does not say it twice).
    #[error("{file}: cannot read the scene: {cause}")]
    Read {
        /// The file asked for.
        file: PathBuf,
        /// What the system said.
        cause: std::io::Error,
    },
    /// The TOML is malformed, a key is unknown or missing, or a value has the wrong type.
    #[error("{file}:{line}: {message}")]
    Parse {
        /// Where the scene came from ([`Origin`]).
        file: String,
        /// 1-based; 0 when the parser gave no position.
        line: usize,
        /// The parser's message, after the key path (`` `balls[1].mass`: ``) when it is known.
        message: String,
    },
    /// A value parsed but is not allowed.
    #[error("{file}{}: `{key}` = {value}: {problem}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        /// Where the scene came from ([`Origin`]).
        file: String,
        /// 1-based line of the key, when the document writes it.
        line: Option<usize>,
        /// The key path, such as `balls[1].mass`.
        key: String,
        /// The value as read.
        value: String,
        /// What is wrong with it, as the end of a sentence (`must be between 0 and 1`).
        problem: String,
    },
}

// ---------------------------------------------------------------------------------------------
// The file format (serde). Keys are kebab-case; unknown keys are rejected; an absent effect is off.

/// Reads exactly N numbers: serde's own `[f64; N]` silently ignores extra elements in TOML.
fn exact<'de, D: serde::Deserializer<'de>, const N: usize>(d: D) -> Result<[f64; N], D::Error> {
    let v: Vec<f64> = Deserialize::deserialize(d)?;
    let len = v.len();
    v.try_into().map_err(|_| serde::de::Error::invalid_length(len, &format!("length {N}").as_str()))
}

fn exact_opt<'de, D: serde::Deserializer<'de>, const N: usize>(d: D) -> Result<Option<[f64; N]>, D::Error> {
    exact::<D, N>(d).map(Some)
}

/// Reads an enum from its kebab-case name. Through serde's own enum support TOML would also take
/// a table (`layout = { lattice = {} }`) and call a number "not a variant identifier"; read as a
/// string first, a wrong type says "expected a string" as every other key does, and an unknown
/// name is serde's `unknown variant` error, which [`Scene::from_toml_str`] words as a bad value.
fn by_name<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<T, D::Error> {
    let name = String::deserialize(d)?;
    T::deserialize(name.as_str().into_deserializer()).map_err(|e: serde::de::value::Error| D::Error::custom(e))
}

fn default_width() -> f64 {
    70.0
}
fn default_height() -> f64 {
    50.0
}
fn one() -> f64 {
    1.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct SceneFile {
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default)]
    field: FieldSpec,
    #[serde(default)]
    simulation: SimulationSpec,
    #[serde(default)]
    effects: EffectsSpec,
    key_ball: Option<KeyBallSpec>,
    #[serde(default)]
    balls: Vec<BallSpec>,
    #[serde(default)]
    generate: Vec<GenerateSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct FieldSpec {
    #[serde(default = "default_width")]
    width: f64,
    #[serde(default = "default_height")]
    height: f64,
    #[serde(default = "one")]
    restitution: f64,
}

impl Default for FieldSpec {
    fn default() -> Self {
        FieldSpec { width: default_width(), height: default_height(), restitution: 1.0 }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct SimulationSpec {
    /// Let listed balls overlap and lattices be packed tighter than touching (for hard cases).
    allow_overlap: bool,
    integrator: String,
    dt: f64,
    seed: u64,
    max_balls: i64,
    ball_cycle: f64,
}

impl Default for SimulationSpec {
    fn default() -> Self {
        SimulationSpec {
            allow_overlap: false,
            integrator: Integrator::default().name().to_string(),
            dt: 0.001,
            seed: 42,
            max_balls: DEFAULT_MAX_BALLS as i64,
            ball_cycle: 0.001,
        }
    }
}

#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct EffectsSpec {
    collisions: Option<CollisionsSpec>,
    gravity: Option<GravitySpec>,
    drag: Option<DragSpec>,
    attraction: Option<AttractionSpec>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct CollisionsSpec {
    restitution: f64,
}
impl Default for CollisionsSpec {
    fn default() -> Self {
        CollisionsSpec { restitution: 1.0 }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct GravitySpec {
    #[serde(deserialize_with = "exact")]
    g: [f64; 2],
}
impl Default for GravitySpec {
    fn default() -> Self {
        GravitySpec { g: [0.0, -STANDARD_GRAVITY] }
    }
}

/// `drag = { model = "quadratic", rho = …, cd = … }` or `{ model = "linear", mu = … }`; the model
/// is quadratic when absent, and each key left out takes its model's default (air).
///
/// One table for both models, not [`Drag`]'s own tagged form (`#[serde(tag = "model")]`, which
/// writes the same TOML): serde reads a tagged table into a buffer and the variant from the
/// buffer, so an error inside it loses its key (`effects.drag` instead of `effects.drag.mu`, the
/// table's line instead of the key's), and a tag cannot be left out (`drag = {}`).
/// [`Checker::drag`] turns it into a [`Drag`] and refuses the other model's keys by name.
#[derive(Deserialize, Debug, Default)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct DragSpec {
    #[serde(deserialize_with = "by_name")]
    model: DragModel,
    rho: Option<f64>,
    cd: Option<f64>,
    mu: Option<f64>,
}

/// The models of [`Drag`], by their names in a scene file.
#[derive(Deserialize, Debug, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum DragModel {
    #[default]
    Quadratic,
    Linear,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct AttractionSpec {
    g_constant: f64,
    /// Barnes–Hut opening angle θ for large fields; 0 = the direct sum always.
    opening_angle: f64,
}
impl Default for AttractionSpec {
    fn default() -> Self {
        AttractionSpec { g_constant: NEWTON_G, opening_angle: DEFAULT_OPENING_ANGLE }
    }
}

fn default_pull() -> f64 {
    200.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct KeyBallSpec {
    #[serde(deserialize_with = "exact")]
    position: [f64; 2],
    #[serde(default, deserialize_with = "exact")]
    velocity: [f64; 2],
    mass: f64,
    diameter: f64,
    #[serde(default = "default_pull")]
    pull: f64,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct BallSpec {
    #[serde(deserialize_with = "exact")]
    position: [f64; 2],
    #[serde(default, deserialize_with = "exact")]
    velocity: [f64; 2],
    mass: f64,
    diameter: f64,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
struct GenerateSpec {
    count: i64,
    diameter: f64,
    mass: f64,
    /// Speed of every generated ball, m/s, in a random direction.
    #[serde(default)]
    speed: f64,
    /// `[x0, y0, x1, y1]` to place them in; the whole field by default.
    #[serde(default, deserialize_with = "exact_opt")]
    region: Option<[f64; 4]>,
    #[serde(default, deserialize_with = "by_name")]
    layout: Layout,
    /// Gap between neighbours on a lattice, as a fraction of the diameter.
    #[serde(default)]
    gap: f64,
}

/// How a `[[generate]]` entry places its balls.
#[derive(Deserialize, Debug, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
enum Layout {
    /// Uniformly at random in the region, none overlapping another.
    #[default]
    Random,
    /// Hexagonal rows from the region's bottom-left corner, `gap` diameters apart.
    Lattice,
}

// ---------------------------------------------------------------------------------------------
// Key paths and their lines.

/// A number as a message shows it: in exponent form when it is very large or very small
/// (`1e-320`, not three hundred zeros).
pub(crate) fn number(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) { format!("{v:e}") } else { v.to_string() }
}

/// A path to a key, such as `balls[3].mass`.
#[derive(Clone, Debug)]
enum Seg {
    Key(&'static str),
    Index(usize),
}
use Seg::{Index, Key};

struct KeyPath(Vec<Seg>);

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, s) in self.0.iter().enumerate() {
            match s {
                Seg::Key(k) if i == 0 => write!(f, "{k}")?,
                Seg::Key(k) => write!(f, ".{k}")?,
                Seg::Index(n) => write!(f, "[{n}]")?,
            }
        }
        Ok(())
    }
}

fn line_of_offset(source: &str, offset: usize) -> usize {
    source.as_bytes()[..offset.min(source.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The line where the key at `path` is written, if the document says it at all.
fn line_of_key(source: &str, path: &[Seg]) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(source).ok()?;
    let Some((Seg::Key(first), rest)) = path.split_first() else { return None };
    let (_, mut value) = root.get_ref().iter().find(|(k, _)| k.get_ref().as_ref() == *first)?;
    for seg in rest {
        let next = match (seg, value.get_ref()) {
            (Seg::Key(k), DeValue::Table(_)) => value.get_ref().get(*k),
            (Seg::Index(i), DeValue::Array(_)) => value.get_ref().get(*i),
            _ => None,
        };
        match next {
            Some(v) => value = v,
            None => break,
        }
    }
    Some(line_of_offset(source, value.span().start))
}

/// The key path (`balls[1].mass`) of the key written at byte `offset`: the nearest table header
/// above it (`[field]`, or the n-th `[[balls]]`) and the key at the offset.
fn path_at_offset(source: &str, offset: usize) -> Option<String> {
    let offset = offset.min(source.len());
    let before = &source[..offset];
    let mut table = String::new();
    let mut arrays: HashMap<String, usize> = HashMap::new();
    for line in before.lines() {
        let t = line.split('#').next().unwrap_or("").trim();
        if let Some(name) = t.strip_prefix("[[").and_then(|r| r.strip_suffix("]]")) {
            let name = name.trim().to_string();
            let n = arrays.entry(name.clone()).and_modify(|n| *n += 1).or_insert(0);
            table = format!("{name}[{n}]");
        } else if let Some(name) = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            table = name.trim().to_string();
        }
    }
    let key = source[offset..].split(['=', '\n']).next().unwrap_or("").trim();
    let key_ok = !key.is_empty() && key.chars().all(|c| c.is_alphanumeric() || c == '-' || c == '_');
    match (table.is_empty(), key_ok) {
        (true, true) => Some(key.to_string()),
        (false, true) => Some(format!("{table}.{key}")),
        (false, false) => Some(table),
        (true, false) => None,
    }
}

struct Checker<'a> {
    origin: &'a Origin,
    source: &'a str,
}

impl Checker<'_> {
    fn invalid(&self, path: Vec<Seg>, value: impl fmt::Display, problem: impl Into<String>) -> SceneError {
        let line = line_of_key(self.source, &path);
        SceneError::Invalid {
            file: self.origin.0.clone(),
            line,
            key: KeyPath(path).to_string(),
            value: value.to_string(),
            problem: problem.into(),
        }
    }

    fn positive(&self, path: &[Seg], v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(path.to_vec(), v, "must be a finite number greater than zero"))
        }
    }

    /// A mass an engine accepts: between [`MIN_MASS`] and [`MAX_MASS`].
    fn mass(&self, path: &[Seg], v: f64) -> Result<f64, SceneError> {
        let v = self.positive(path, v)?;
        if (MIN_MASS..=MAX_MASS).contains(&v) {
            Ok(v)
        } else {
            Err(self.invalid(path.to_vec(), number(v), format!("must be a mass from {MIN_MASS:e} to {MAX_MASS:e} kg")))
        }
    }

    /// A speed an engine does not cap: at most [`MAX_SPEED`].
    fn speed(&self, path: &[Seg], v: f64) -> Result<f64, SceneError> {
        let v = self.non_negative(path, v)?;
        if v <= MAX_SPEED {
            Ok(v)
        } else {
            Err(self.invalid(path.to_vec(), number(v), format!("must be a speed from 0 to {MAX_SPEED:e} m/s")))
        }
    }

    /// A velocity whose speed is at most [`MAX_SPEED`].
    fn velocity(&self, path: &[Seg], v: [f64; 2]) -> Result<DVec2, SceneError> {
        let u = self.vector(path, v)?;
        if u.length() <= MAX_SPEED {
            Ok(u)
        } else {
            Err(self.invalid(
                path.to_vec(),
                format!("[{}, {}]", number(v[0]), number(v[1])),
                format!("is faster than the speed limit, {MAX_SPEED:e} m/s"),
            ))
        }
    }

    fn non_negative(&self, path: &[Seg], v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(path.to_vec(), v, "must be a finite number, zero or more"))
        }
    }

    fn unit_interval(&self, path: &[Seg], v: f64) -> Result<f64, SceneError> {
        if (0.0..=1.0).contains(&v) { Ok(v) } else { Err(self.invalid(path.to_vec(), v, "must be between 0 and 1")) }
    }

    fn vector(&self, path: &[Seg], v: [f64; 2]) -> Result<DVec2, SceneError> {
        if v[0].is_finite() && v[1].is_finite() {
            Ok(DVec2::new(v[0], v[1]))
        } else {
            Err(self.invalid(path.to_vec(), format!("[{}, {}]", v[0], v[1]), "must be two finite numbers"))
        }
    }
}

fn with(path: &[Seg], seg: Seg) -> Vec<Seg> {
    let mut p = path.to_vec();
    p.push(seg);
    p
}

// ---------------------------------------------------------------------------------------------

/// Uniform random numbers in [0, 1) from a seeded PCG.
struct Uniform(Pcg64Mcg);

impl Uniform {
    fn new(seed: u64, stream: u64) -> Self {
        Uniform(Pcg64Mcg::seed_from_u64(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15)))
    }
    fn next(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Already-placed balls, hashed by cell for overlap checks while building a scene.
struct Placed {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
    balls: Vec<(DVec2, f64)>,
}

impl Placed {
    fn new(cell: f64) -> Self {
        Placed { cell: cell.max(1e-9), cells: HashMap::new(), balls: Vec::new() }
    }
    fn key(&self, p: DVec2) -> (i64, i64) {
        ((p.x / self.cell).floor() as i64, (p.y / self.cell).floor() as i64)
    }
    /// Index of a placed ball that (p, r) would overlap, if any. Exactly touching is allowed.
    fn overlapping(&self, p: DVec2, r: f64) -> Option<usize> {
        let (cx, cy) = self.key(p);
        let reach = ((r / self.cell).ceil() as i64).max(1);
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                // Keys saturate beyond 9.2e18 cells from the origin (a field of 1e20 m): the
                // neighbours of a saturated key are itself, not an overflow.
                if let Some(list) = self.cells.get(&(cx.saturating_add(dx), cy.saturating_add(dy))) {
                    for &k in list {
                        let (q, rq) = self.balls[k];
                        let s = r + rq;
                        if p.distance_squared(q) < s * s * (1.0 - 1e-12) {
                            return Some(k);
                        }
                    }
                }
            }
        }
        None
    }
    fn insert(&mut self, p: DVec2, r: f64) {
        let k = self.key(p);
        self.cells.entry(k).or_default().push(self.balls.len());
        self.balls.push((p, r));
    }
}

impl Scene {
    /// Reads and checks a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let text =
            std::fs::read_to_string(path).map_err(|cause| SceneError::Read { file: path.to_path_buf(), cause })?;
        Scene::from_toml_str(&text, &Origin(path.display().to_string()))
    }

    /// Parses and checks scene text; `origin` names it in messages.
    pub fn from_toml_str(source: &str, origin: &Origin) -> Result<Scene, SceneError> {
        let parse_error = |e: toml::de::Error, path: Option<String>| {
            let offset = e.span().map(|s| s.start);
            let line = offset.map(|o| line_of_offset(source, o)).unwrap_or(0);
            // Syntax errors (a duplicate key, say) come before serde knows a path: find it from
            // the position instead.
            let path = path.or_else(|| offset.and_then(|o| path_at_offset(source, o)));
            let message = e.message().trim();
            // A name that is not one of an enum's (`layout = "spiral"`) is a bad value like any
            // other: say it the way the checks below do.
            if let (Some(key), Some((value, problem))) = (&path, unknown_variant(message)) {
                let line = offset.map(|_| line);
                return SceneError::Invalid { file: origin.0.clone(), line, key: key.clone(), value, problem };
            }
            // serde names a missing field in the message, not in the path: add it to the path.
            let path = match (path, message.strip_prefix("missing field `").and_then(|r| r.split('`').next())) {
                (Some(p), Some(field)) if !p.is_empty() && p != "." => Some(format!("{p}.{field}")),
                (None, Some(field)) => Some(field.to_string()),
                (p, _) => p,
            };
            let message = match path {
                Some(p) if !p.is_empty() && p != "." => format!("`{p}`: {message}"),
                _ => message.to_string(),
            };
            SceneError::Parse { file: origin.0.clone(), line, message }
        };
        let deserializer = toml::de::Deserializer::parse(source).map_err(|e| parse_error(e, None))?;
        let file: SceneFile = serde_path_to_error::deserialize(deserializer).map_err(|e| {
            let path = e.path().to_string();
            parse_error(e.into_inner(), Some(path))
        })?;
        let c = Checker { origin, source };
        build(file, &c)
    }

    /// The threaded runtime's ball cycle as a duration.
    pub fn ball_cycle_duration(&self) -> std::time::Duration {
        std::time::Duration::from_secs_f64(self.ball_cycle)
    }
}

/// serde's ``unknown variant `x`, expected `a` or `b` `` as `(value, problem)`:
/// `("\"x\"", "must be \"a\" or \"b\"")`.
fn unknown_variant(message: &str) -> Option<(String, String)> {
    let (name, expected) = message.strip_prefix("unknown variant `")?.split_once("`, expected ")?;
    Some((format!("\"{name}\""), format!("must be {}", expected.replace('`', "\""))))
}

// ---------------------------------------------------------------------------------------------
// From the parsed file to a checked scene, one part of the file at a time.

/// The checked `[simulation]` table, but for the seed and `allow-overlap` (read as they are).
struct Simulation {
    integrator: Integrator,
    dt: f64,
    max_balls: usize,
    ball_cycle: f64,
}

/// The listed balls, checked one by one: the key ball first (id 0) if there is one.
struct Listed {
    balls: Vec<Ball>,
    /// Where each ball is written (`key-ball`, `balls[3]`), for messages.
    paths: Vec<Vec<Seg>>,
    /// The key ball's pull, N (0 without a key ball).
    pull: f64,
}

/// A `[[generate]]` entry's checked numbers.
struct Batch {
    count: usize,
    diameter: f64,
    mass: f64,
    speed: f64,
    /// Gap between lattice neighbours, as a fraction of the diameter.
    gap: f64,
    /// `[x0, y0, x1, y1]`, inside the field and at least one diameter wide and high.
    region: [f64; 4],
}

impl Batch {
    /// A generated ball at `position`, moving at the batch's speed in a direction drawn from `rng`.
    fn ball(&self, position: DVec2, rng: &mut Uniform, id: usize) -> Ball {
        let angle = std::f64::consts::TAU * rng.next();
        let velocity = self.speed * DVec2::new(angle.cos(), angle.sin());
        Ball {
            id: BallId(id as u32),
            kind: BallKind::Ball,
            position,
            velocity,
            mass: self.mass,
            diameter: self.diameter,
        }
    }
}

/// Checks the parsed file and builds the scene, in the order the file reads: the field, the
/// simulation, the effects, the listed balls, then the generated balls around them.
fn build(file: SceneFile, c: &Checker<'_>) -> Result<Scene, SceneError> {
    let field = c.field(&file.field)?;
    let sim = c.simulation(&file.simulation)?;
    let effects = c.effects(&file.effects)?;
    let Listed { mut balls, paths, pull } = c.listed(file.key_ball.as_ref(), &file.balls, &field)?;
    c.counts(&file.generate, balls.len(), sim.max_balls)?;
    let allow_overlap = file.simulation.allow_overlap;
    let mut placed = c.place_listed(&balls, &paths, &file.generate, allow_overlap)?;
    for (i, spec) in file.generate.iter().enumerate() {
        let path = vec![Key("generate"), Index(i)];
        let batch = c.batch(&path, spec, &field, allow_overlap)?;
        // One random stream per entry, so that adding an entry leaves the others' balls alone.
        let mut rng = Uniform::new(file.simulation.seed, i as u64 + 1);
        match spec.layout {
            Layout::Random => c.place_random(&path, &batch, &mut rng, &mut placed, &mut balls)?,
            Layout::Lattice => c.place_lattice(&path, &batch, allow_overlap, &mut rng, &mut placed, &mut balls)?,
        }
    }
    if balls.len() > sim.max_balls {
        let max_balls = sim.max_balls;
        return Err(c.invalid(
            vec![Key("balls")],
            balls.len(),
            format!("the scene has {} balls, more than simulation.max-balls = {max_balls}", balls.len()),
        ));
    }

    Ok(Scene {
        name: file.name,
        description: file.description,
        field,
        integrator: sim.integrator,
        dt: sim.dt,
        seed: file.simulation.seed,
        max_balls: sim.max_balls,
        ball_cycle: sim.ball_cycle,
        effects,
        pull,
        balls,
    })
}

impl Checker<'_> {
    fn field(&self, spec: &FieldSpec) -> Result<Field, SceneError> {
        let path = [Key("field")];
        let width = self.positive(&with(&path, Key("width")), spec.width)?;
        let height = self.positive(&with(&path, Key("height")), spec.height)?;
        let restitution = self.unit_interval(&with(&path, Key("restitution")), spec.restitution)?;
        Ok(Field { width, height, restitution })
    }

    fn simulation(&self, spec: &SimulationSpec) -> Result<Simulation, SceneError> {
        let path = [Key("simulation")];
        let integrator: Integrator = spec.integrator.parse().map_err(|e: crate::physics::UnknownIntegrator| {
            self.invalid(with(&path, Key("integrator")), format!("\"{}\"", e.0), e.to_string())
        })?;
        let dt = self.positive(&with(&path, Key("dt")), spec.dt)?;
        if dt > 1.0 {
            return Err(self.invalid(with(&path, Key("dt")), dt, "must be at most 1 s"));
        }
        let max_balls = spec.max_balls;
        if max_balls < 1 || max_balls as u64 > HARD_MAX_BALLS as u64 {
            return Err(self.invalid(
                with(&path, Key("max-balls")),
                max_balls,
                format!("must be between 1 and {HARD_MAX_BALLS}"),
            ));
        }
        let ball_cycle = self.positive(&with(&path, Key("ball-cycle")), spec.ball_cycle)?;
        if ball_cycle > 0.1 {
            return Err(self.invalid(with(&path, Key("ball-cycle")), ball_cycle, "must be at most 0.1 s"));
        }
        Ok(Simulation { integrator, dt, max_balls: max_balls as usize, ball_cycle })
    }

    fn effects(&self, spec: &EffectsSpec) -> Result<Effects, SceneError> {
        let path = [Key("effects")];
        let mut effects = Effects::default();
        if let Some(col) = &spec.collisions {
            let p = with(&with(&path, Key("collisions")), Key("restitution"));
            effects.collisions = Some(Collisions { restitution: self.unit_interval(&p, col.restitution)? });
        }
        if let Some(g) = &spec.gravity {
            let p = with(&with(&path, Key("gravity")), Key("g"));
            effects.gravity = Some(Gravity { g: self.vector(&p, g.g)? });
        }
        if let Some(d) = &spec.drag {
            effects.drag = Some(self.drag(&with(&path, Key("drag")), d)?);
        }
        if let Some(a) = &spec.attraction {
            effects.attraction = Some(self.attraction(&with(&path, Key("attraction")), a)?);
        }
        Ok(effects)
    }

    fn drag(&self, path: &[Seg], spec: &DragSpec) -> Result<Drag, SceneError> {
        // The keys of the model not chosen, and the words that say so.
        let (foreign, problem) = match spec.model {
            DragModel::Quadratic => (vec![("mu", spec.mu)], "belongs to model = \"linear\", not \"quadratic\""),
            DragModel::Linear => {
                (vec![("rho", spec.rho), ("cd", spec.cd)], "belongs to model = \"quadratic\", not \"linear\"")
            }
        };
        if let Some((key, Some(v))) = foreign.into_iter().find(|(_, v)| v.is_some()) {
            return Err(self.invalid(with(path, Key(key)), v, problem));
        }
        Ok(match spec.model {
            DragModel::Quadratic => Drag::Quadratic {
                rho: self.positive(&with(path, Key("rho")), spec.rho.unwrap_or(AIR_DENSITY))?,
                cd: self.positive(&with(path, Key("cd")), spec.cd.unwrap_or(SPHERE_DRAG_COEFFICIENT))?,
            },
            DragModel::Linear => {
                Drag::Linear { mu: self.positive(&with(path, Key("mu")), spec.mu.unwrap_or(AIR_VISCOSITY))? }
            }
        })
    }

    fn attraction(&self, path: &[Seg], spec: &AttractionSpec) -> Result<Attraction, SceneError> {
        let g_constant = self.non_negative(&with(path, Key("g-constant")), spec.g_constant)?;
        let opening_angle = spec.opening_angle;
        if !(0.0..=MAX_OPENING_ANGLE).contains(&opening_angle) {
            return Err(self.invalid(
                with(path, Key("opening-angle")),
                opening_angle,
                format!("must be between 0 (the direct sum always) and {MAX_OPENING_ANGLE}"),
            ));
        }
        Ok(Attraction { g_constant, opening_angle })
    }

    /// Refuses a ball too large for the field.
    fn fits(&self, path: &[Seg], diameter: f64, field: &Field) -> Result<(), SceneError> {
        let (width, height) = (field.width, field.height);
        if diameter > width.min(height) {
            return Err(self.invalid(
                with(path, Key("diameter")),
                diameter,
                format!("is larger than the field ({width} m × {height} m)"),
            ));
        }
        Ok(())
    }

    /// Checks one listed ball: `(position, velocity, mass, diameter)`.
    fn ball(
        &self,
        path: &[Seg],
        [position, velocity]: [[f64; 2]; 2],
        mass: f64,
        diameter: f64,
        field: &Field,
    ) -> Result<(DVec2, DVec2, f64, f64), SceneError> {
        let mass = self.mass(&with(path, Key("mass")), mass)?;
        let diameter = self.positive(&with(path, Key("diameter")), diameter)?;
        self.fits(path, diameter, field)?;
        let p = self.vector(&with(path, Key("position")), position)?;
        let v = self.velocity(&with(path, Key("velocity")), velocity)?;
        if !field.contains(p.x, p.y, 0.5 * diameter, 0.0) {
            let (width, height) = (field.width, field.height);
            return Err(self.invalid(
                with(path, Key("position")),
                format!("[{}, {}]", p.x, p.y),
                format!("puts a ball of diameter {diameter} m outside the field ({width} m × {height} m)"),
            ));
        }
        Ok((p, v, mass, diameter))
    }

    /// The key ball and the `[[balls]]`, each checked alone (overlaps come later).
    fn listed(&self, key_ball: Option<&KeyBallSpec>, specs: &[BallSpec], field: &Field) -> Result<Listed, SceneError> {
        let mut listed = Listed { balls: Vec::new(), paths: Vec::new(), pull: 0.0 };
        if let Some(k) = key_ball {
            let path = vec![Key("key-ball")];
            let (position, velocity, mass, diameter) =
                self.ball(&path, [k.position, k.velocity], k.mass, k.diameter, field)?;
            listed.pull = self.non_negative(&with(&path, Key("pull")), k.pull)?;
            listed.balls.push(Ball { id: BallId(0), kind: BallKind::Key, position, velocity, mass, diameter });
            listed.paths.push(path);
        }
        for (i, b) in specs.iter().enumerate() {
            let path = vec![Key("balls"), Index(i)];
            let (position, velocity, mass, diameter) =
                self.ball(&path, [b.position, b.velocity], b.mass, b.diameter, field)?;
            let id = BallId(listed.balls.len() as u32);
            listed.balls.push(Ball { id, kind: BallKind::Ball, position, velocity, mass, diameter });
            listed.paths.push(path);
        }
        Ok(listed)
    }

    /// Refuses a negative count, and counts that bring the scene past `max_balls`, before
    /// anything is generated.
    fn counts(&self, specs: &[GenerateSpec], listed: usize, max_balls: usize) -> Result<(), SceneError> {
        let mut total = listed as i64;
        for (i, g) in specs.iter().enumerate() {
            let p = vec![Key("generate"), Index(i)];
            if g.count < 0 {
                return Err(self.invalid(with(&p, Key("count")), g.count, "must be zero or more"));
            }
            total = total.saturating_add(g.count);
            if total > max_balls as i64 {
                return Err(self.invalid(
                    with(&p, Key("count")),
                    g.count,
                    format!("brings the scene to {total} balls, more than simulation.max-balls = {max_balls}"),
                ));
            }
        }
        Ok(())
    }

    /// Refuses listed balls that overlap (unless `allow_overlap`), and returns them placed, for
    /// the generated balls to keep clear of.
    fn place_listed(
        &self,
        balls: &[Ball],
        paths: &[Vec<Seg>],
        generate: &[GenerateSpec],
        allow_overlap: bool,
    ) -> Result<Placed, SceneError> {
        // Cells as large as the largest ball, generated ones included (a bad diameter is
        // refused later; here it must only not spoil the cell size).
        let largest = balls
            .iter()
            .map(|b| b.diameter)
            .chain(generate.iter().map(|g| if g.diameter.is_finite() { g.diameter } else { 0.0 }))
            .fold(0.0f64, f64::max);
        let mut placed = Placed::new(largest);
        for (k, b) in balls.iter().enumerate() {
            if !allow_overlap && let Some(other) = placed.overlapping(b.position, b.radius()) {
                return Err(self.invalid(
                    with(&paths[k], Key("position")),
                    format!("[{}, {}]", b.position.x, b.position.y),
                    format!(
                        "overlaps {} at [{}, {}]",
                        KeyPath(paths[other].clone()),
                        balls[other].position.x,
                        balls[other].position.y
                    ),
                ));
            }
            placed.insert(b.position, b.radius());
        }
        Ok(placed)
    }

    /// Checks a `[[generate]]` entry's numbers and region (its count is checked by
    /// [`Checker::counts`]).
    fn batch(&self, p: &[Seg], g: &GenerateSpec, field: &Field, allow_overlap: bool) -> Result<Batch, SceneError> {
        let diameter = self.positive(&with(p, Key("diameter")), g.diameter)?;
        let mass = self.mass(&with(p, Key("mass")), g.mass)?;
        let speed = self.speed(&with(p, Key("speed")), g.speed)?;
        let gap = if allow_overlap {
            if !(g.gap.is_finite() && g.gap > -0.5) {
                return Err(self.invalid(with(p, Key("gap")), g.gap, "must be a finite number above -0.5"));
            }
            g.gap
        } else {
            self.non_negative(&with(p, Key("gap")), g.gap)?
        };
        self.fits(p, diameter, field)?;
        let (width, height) = (field.width, field.height);
        let region = match g.region {
            None => [0.0, 0.0, width, height],
            Some(reg) => {
                let ok = reg.iter().all(|v| v.is_finite())
                    && reg[0] >= 0.0
                    && reg[1] >= 0.0
                    && reg[2] <= width
                    && reg[3] <= height
                    && reg[2] - reg[0] >= diameter
                    && reg[3] - reg[1] >= diameter;
                if !ok {
                    return Err(self.invalid(
                        with(p, Key("region")),
                        format!("[{}, {}, {}, {}]", reg[0], reg[1], reg[2], reg[3]),
                        format!("must be [x0, y0, x1, y1] inside the field ({width} m × {height} m) and at least one diameter wide and high"),
                    ));
                }
                reg
            }
        };
        Ok(Batch { count: g.count as usize, diameter, mass, speed, gap, region })
    }

    /// Places a batch uniformly at random in its region, each ball clear of every placed one.
    fn place_random(
        &self,
        p: &[Seg],
        batch: &Batch,
        rng: &mut Uniform,
        placed: &mut Placed,
        balls: &mut Vec<Ball>,
    ) -> Result<(), SceneError> {
        let (region, diameter) = (batch.region, batch.diameter);
        let r = 0.5 * diameter;
        let (x0, y0) = (region[0] + r, region[1] + r);
        let (sx, sy) = (region[2] - region[0] - diameter, region[3] - region[1] - diameter);
        for n in 0..batch.count {
            // A bounded number of tries: a region too full to take the ball is an error, not a hang.
            let spot = (0..10_000).find_map(|_| {
                let pos = DVec2::new(x0 + sx * rng.next(), y0 + sy * rng.next());
                placed.overlapping(pos, r).is_none().then_some(pos)
            });
            let Some(pos) = spot else {
                return Err(self.invalid(
                    with(p, Key("count")),
                    batch.count,
                    format!("only {n} balls of diameter {diameter} m fit in the region without overlap (try layout = \"lattice\" or a larger region)"),
                ));
            };
            placed.insert(pos, r);
            balls.push(batch.ball(pos, rng, balls.len()));
        }
        Ok(())
    }

    /// Places a batch on hexagonal rows from the bottom-left corner of its region, odd rows
    /// shifted by half a spacing; spots taken by other balls are skipped (unless `allow_overlap`).
    fn place_lattice(
        &self,
        p: &[Seg],
        batch: &Batch,
        allow_overlap: bool,
        rng: &mut Uniform,
        placed: &mut Placed,
        balls: &mut Vec<Ball>,
    ) -> Result<(), SceneError> {
        let (region, diameter, count) = (batch.region, batch.diameter, batch.count);
        let r = 0.5 * diameter;
        let spacing = diameter * (1.0 + batch.gap);
        let row_height = spacing * 3f64.sqrt() / 2.0;
        // Spots are counted, not stepped through by adding floats (which stalls when the
        // spacing is below the rounding of x); and the search is bounded.
        let rows = ((region[3] - region[1] - diameter) / row_height).floor() as u64 + 1;
        let cols = ((region[2] - region[0] - diameter) / spacing).floor() as u64 + 1;
        let budget = (count as u64).saturating_mul(20).saturating_add(1_000_000);
        let mut n = 0;
        let mut tried = 0u64;
        'rows: for row in 0..rows {
            let y = region[1] + r + row as f64 * row_height;
            let shift = if row % 2 == 1 { 0.5 * spacing } else { 0.0 };
            for col in 0..cols {
                if n == count || tried >= budget {
                    break 'rows;
                }
                tried += 1;
                let x = region[0] + r + shift + col as f64 * spacing;
                if x + r > region[2] {
                    continue;
                }
                let pos = DVec2::new(x, y);
                if allow_overlap || placed.overlapping(pos, r).is_none() {
                    placed.insert(pos, r);
                    balls.push(batch.ball(pos, rng, balls.len()));
                    n += 1;
                }
            }
        }
        if n < count {
            return Err(self.invalid(
                with(p, Key("count")),
                count,
                format!("only {n} balls of diameter {diameter} m fit in the region on a lattice"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(text: &str) -> Result<Scene, SceneError> {
        Scene::from_toml_str(&format!("name = \"t\"\n{text}"), &Origin("t.toml".into()))
    }

    /// The physics type's serde form is the scene file's: a drag written out reads back the same.
    /// (Fails with `Drag`'s serde attributes removed: it then writes `[drag.Quadratic]`.)
    #[test]
    fn drag_writes_as_a_scene_file_reads_it() {
        #[derive(serde::Serialize)]
        struct File {
            effects: Fx,
        }
        #[derive(serde::Serialize)]
        struct Fx {
            drag: Drag,
        }
        for drag in [Drag::Quadratic { rho: 1.2, cd: 0.4 }, Drag::Linear { mu: 2e-5 }] {
            let text = toml::to_string(&File { effects: Fx { drag } }).expect("a drag serialises");
            let read = scene(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
            assert_eq!(read.effects.drag, Some(drag), "{text}");
            let table: toml::Table = toml::from_str(&text).unwrap();
            assert_eq!(table["effects"]["drag"].clone().try_into::<Drag>(), Ok(drag), "{text}");
        }
    }

    #[test]
    fn drag_model_and_keys_default_to_air() {
        assert_eq!(scene("[effects]\ndrag = {}\n").unwrap().effects.drag, Some(Drag::default()));
        let linear = scene("[effects]\ndrag = { model = \"linear\" }\n").unwrap();
        assert_eq!(linear.effects.drag, Some(Drag::Linear { mu: AIR_VISCOSITY }));
    }

    #[test]
    fn unknown_variant_reads_serdes_message() {
        let say = |m: &str| unknown_variant(m).map(|(v, p)| format!("{v}: {p}"));
        assert_eq!(say("unknown variant `x`, expected `a`").as_deref(), Some("\"x\": must be \"a\""));
        assert_eq!(say("unknown variant `x`, expected `a` or `b`").as_deref(), Some("\"x\": must be \"a\" or \"b\""));
        assert_eq!(
            say("unknown variant `x`, expected one of `a`, `b`, `c`").as_deref(),
            Some("\"x\": must be one of \"a\", \"b\", \"c\"")
        );
        assert_eq!(say("unknown field `x`, expected `a`"), None);
    }
}
