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
use serde::Deserialize;

use crate::physics::{
    AIR_DENSITY, AIR_VISCOSITY, Attraction, Ball, BallId, BallKind, Collisions, DEFAULT_OPENING_ANGLE, Drag, Effects,
    Field, Gravity, Integrator, NEWTON_G, SPHERE_DRAG_COEFFICIENT, STANDARD_GRAVITY,
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
    pub name: String,
    pub description: String,
    pub field: Field,
    pub integrator: Integrator,
    /// Lockstep time step, s.
    pub dt: f64,
    pub seed: u64,
    pub max_balls: usize,
    /// Period a threaded ball aims for between its updates, s.
    pub ball_cycle: f64,
    pub effects: Effects,
    /// The force of the arrow keys on the key ball, N.
    pub pull: f64,
    /// All balls: the key ball first (id 0) if there is one, then the listed, then the generated.
    pub balls: Vec<Ball>,
}

/// Where a scene came from, for messages: a file path or a label such as `<builtin default>`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Origin(pub String);

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The cause is part of the message (and deliberately not a `source()`, so that printing
    /// the error chain does not say it twice).
    #[error("{file}: cannot read the scene: {cause}")]
    Read { file: PathBuf, cause: std::io::Error },
    /// The TOML is malformed, a key is unknown or missing, or a value has the wrong type.
    #[error("{file}:{line}: {message}")]
    Parse { file: String, line: usize, message: String },
    /// A value parsed but is not allowed.
    #[error("{file}{}: `{key}` = {value}: {problem}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid { file: String, line: Option<usize>, key: String, value: String, problem: String },
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

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields, rename_all = "kebab-case", default)]
struct DragSpec {
    model: String,
    rho: Option<f64>,
    cd: Option<f64>,
    mu: Option<f64>,
}
impl Default for DragSpec {
    fn default() -> Self {
        DragSpec { model: "quadratic".into(), rho: None, cd: None, mu: None }
    }
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
    /// `random` (uniform, no overlap) or `lattice` (hexagonal rows from the bottom-left).
    #[serde(default = "default_layout")]
    layout: String,
    /// Gap between neighbours on a lattice, as a fraction of the diameter.
    #[serde(default)]
    gap: f64,
}

fn default_layout() -> String {
    "random".into()
}

// ---------------------------------------------------------------------------------------------
// Key paths and their lines.

/// A path to a key, such as `balls[3].mass`.
#[derive(Clone, Debug)]
enum Seg {
    Key(&'static str),
    Index(usize),
}

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
                if let Some(list) = self.cells.get(&(cx + dx, cy + dy)) {
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

    /// The id the next added ball should get.
    pub fn next_id(&self) -> BallId {
        BallId(self.balls.iter().map(|b| b.id.0 + 1).max().unwrap_or(0))
    }
}

fn build(file: SceneFile, c: &Checker<'_>) -> Result<Scene, SceneError> {
    use Seg::{Index, Key};
    let field_path = [Key("field")];
    let width = c.positive(&with(&field_path, Key("width")), file.field.width)?;
    let height = c.positive(&with(&field_path, Key("height")), file.field.height)?;
    let restitution = c.unit_interval(&with(&field_path, Key("restitution")), file.field.restitution)?;
    let field = Field { width, height, restitution };

    let sim = [Key("simulation")];
    let integrator: Integrator =
        file.simulation.integrator.parse().map_err(|e: crate::physics::UnknownIntegrator| {
            c.invalid(with(&sim, Key("integrator")), format!("\"{}\"", e.0), e.to_string())
        })?;
    let dt = c.positive(&with(&sim, Key("dt")), file.simulation.dt)?;
    if dt > 1.0 {
        return Err(c.invalid(with(&sim, Key("dt")), dt, "must be at most 1 s"));
    }
    let max_balls = file.simulation.max_balls;
    if max_balls < 1 || max_balls as u64 > HARD_MAX_BALLS as u64 {
        return Err(c.invalid(
            with(&sim, Key("max-balls")),
            max_balls,
            format!("must be between 1 and {HARD_MAX_BALLS}"),
        ));
    }
    let max_balls = max_balls as usize;
    let ball_cycle = c.positive(&with(&sim, Key("ball-cycle")), file.simulation.ball_cycle)?;
    if ball_cycle > 0.1 {
        return Err(c.invalid(with(&sim, Key("ball-cycle")), ball_cycle, "must be at most 0.1 s"));
    }

    let fx = [Key("effects")];
    let mut effects = Effects::default();
    if let Some(col) = &file.effects.collisions {
        let p = with(&with(&fx, Key("collisions")), Key("restitution"));
        effects.collisions = Some(Collisions { restitution: c.unit_interval(&p, col.restitution)? });
    }
    if let Some(g) = &file.effects.gravity {
        let p = with(&with(&fx, Key("gravity")), Key("g"));
        effects.gravity = Some(Gravity { g: c.vector(&p, g.g)? });
    }
    if let Some(d) = &file.effects.drag {
        let base = with(&fx, Key("drag"));
        let drag = match d.model.as_str() {
            "quadratic" => {
                if let Some(mu) = d.mu {
                    return Err(c.invalid(
                        with(&base, Key("mu")),
                        mu,
                        "belongs to model = \"linear\", not \"quadratic\"",
                    ));
                }
                let rho = c.positive(&with(&base, Key("rho")), d.rho.unwrap_or(AIR_DENSITY))?;
                let cd = c.positive(&with(&base, Key("cd")), d.cd.unwrap_or(SPHERE_DRAG_COEFFICIENT))?;
                Drag::Quadratic { rho, cd }
            }
            "linear" => {
                for (key, v) in [("rho", d.rho), ("cd", d.cd)] {
                    if let Some(v) = v {
                        return Err(c.invalid(
                            with(&base, Key(key)),
                            v,
                            "belongs to model = \"quadratic\", not \"linear\"",
                        ));
                    }
                }
                Drag::Linear { mu: c.positive(&with(&base, Key("mu")), d.mu.unwrap_or(AIR_VISCOSITY))? }
            }
            other => {
                return Err(c.invalid(
                    with(&base, Key("model")),
                    format!("\"{other}\""),
                    "must be \"quadratic\" or \"linear\"",
                ));
            }
        };
        effects.drag = Some(drag);
    }
    if let Some(a) = &file.effects.attraction {
        let base = with(&fx, Key("attraction"));
        let g_constant = c.non_negative(&with(&base, Key("g-constant")), a.g_constant)?;
        let p = with(&base, Key("opening-angle"));
        let opening_angle = a.opening_angle;
        if !(0.0..=MAX_OPENING_ANGLE).contains(&opening_angle) {
            return Err(c.invalid(
                p,
                opening_angle,
                format!("must be between 0 (the direct sum always) and {MAX_OPENING_ANGLE}"),
            ));
        }
        effects.attraction = Some(Attraction { g_constant, opening_angle });
    }

    // Balls: checked one by one, then for overlaps, then generated around them.
    let mut balls: Vec<Ball> = Vec::new();
    let mut paths: Vec<Vec<Seg>> = Vec::new();
    let check_ball = |path: &[Seg], position: [f64; 2], velocity: [f64; 2], mass: f64, diameter: f64| {
        let mass = c.positive(&with(path, Key("mass")), mass)?;
        let diameter = c.positive(&with(path, Key("diameter")), diameter)?;
        if diameter > width.min(height) {
            return Err(c.invalid(
                with(path, Key("diameter")),
                diameter,
                format!("is larger than the field ({width} m × {height} m)"),
            ));
        }
        let p = c.vector(&with(path, Key("position")), position)?;
        let v = c.vector(&with(path, Key("velocity")), velocity)?;
        if !field.contains(p.x, p.y, 0.5 * diameter, 0.0) {
            return Err(c.invalid(
                with(path, Key("position")),
                format!("[{}, {}]", p.x, p.y),
                format!("puts a ball of diameter {diameter} m outside the field ({width} m × {height} m)"),
            ));
        }
        Ok((p, v, mass, diameter))
    };
    let mut pull = 0.0;
    if let Some(k) = &file.key_ball {
        let path = vec![Key("key-ball")];
        let (p, v, mass, diameter) = check_ball(&path, k.position, k.velocity, k.mass, k.diameter)?;
        pull = c.non_negative(&with(&path, Key("pull")), k.pull)?;
        balls.push(Ball { id: BallId(0), kind: BallKind::Key, position: p, velocity: v, mass, diameter });
        paths.push(path);
    }
    for (i, b) in file.balls.iter().enumerate() {
        let path = vec![Key("balls"), Index(i)];
        let (p, v, mass, diameter) = check_ball(&path, b.position, b.velocity, b.mass, b.diameter)?;
        let id = BallId(balls.len() as u32);
        balls.push(Ball { id, kind: BallKind::Ball, position: p, velocity: v, mass, diameter });
        paths.push(path);
    }

    let mut total: i64 = balls.len() as i64;
    for (i, g) in file.generate.iter().enumerate() {
        let p = vec![Key("generate"), Index(i)];
        if g.count < 0 {
            return Err(c.invalid(with(&p, Key("count")), g.count, "must be zero or more"));
        }
        total = total.saturating_add(g.count);
        if total > max_balls as i64 {
            return Err(c.invalid(
                with(&p, Key("count")),
                g.count,
                format!("brings the scene to {total} balls, more than simulation.max-balls = {max_balls}"),
            ));
        }
    }

    let largest = balls
        .iter()
        .map(|b| b.diameter)
        .chain(file.generate.iter().map(|g| if g.diameter.is_finite() { g.diameter } else { 0.0 }))
        .fold(0.0f64, f64::max);
    let allow_overlap = file.simulation.allow_overlap;
    let mut placed = Placed::new(largest);
    for (k, b) in balls.iter().enumerate() {
        if allow_overlap {
            placed.insert(b.position, b.radius());
            continue;
        }
        if let Some(other) = placed.overlapping(b.position, b.radius()) {
            return Err(c.invalid(
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

    for (gi, g) in file.generate.iter().enumerate() {
        let p = vec![Key("generate"), Index(gi)];
        let diameter = c.positive(&with(&p, Key("diameter")), g.diameter)?;
        let mass = c.positive(&with(&p, Key("mass")), g.mass)?;
        let speed = c.non_negative(&with(&p, Key("speed")), g.speed)?;
        let gap = if allow_overlap {
            if !(g.gap.is_finite() && g.gap > -0.5) {
                return Err(c.invalid(with(&p, Key("gap")), g.gap, "must be a finite number above -0.5"));
            }
            g.gap
        } else {
            c.non_negative(&with(&p, Key("gap")), g.gap)?
        };
        if diameter > width.min(height) {
            return Err(c.invalid(
                with(&p, Key("diameter")),
                diameter,
                format!("is larger than the field ({width} m × {height} m)"),
            ));
        }
        let r = 0.5 * diameter;
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
                    return Err(c.invalid(
                        with(&p, Key("region")),
                        format!("[{}, {}, {}, {}]", reg[0], reg[1], reg[2], reg[3]),
                        format!("must be [x0, y0, x1, y1] inside the field ({width} m × {height} m) and at least one diameter wide and high"),
                    ));
                }
                reg
            }
        };
        let mut rng = Uniform::new(file.simulation.seed, gi as u64 + 1);
        let count = g.count as usize;
        let add = |pos: DVec2, rng: &mut Uniform, balls: &mut Vec<Ball>| {
            let angle = std::f64::consts::TAU * rng.next();
            let velocity = speed * DVec2::new(angle.cos(), angle.sin());
            let id = BallId(balls.len() as u32);
            balls.push(Ball { id, kind: BallKind::Ball, position: pos, velocity, mass, diameter });
        };
        match g.layout.as_str() {
            "random" => {
                let (x0, y0) = (region[0] + r, region[1] + r);
                let (sx, sy) = (region[2] - region[0] - diameter, region[3] - region[1] - diameter);
                for n in 0..count {
                    let mut done = false;
                    for _ in 0..10_000 {
                        let pos = DVec2::new(x0 + sx * rng.next(), y0 + sy * rng.next());
                        if placed.overlapping(pos, r).is_none() {
                            placed.insert(pos, r);
                            add(pos, &mut rng, &mut balls);
                            done = true;
                            break;
                        }
                    }
                    if !done {
                        return Err(c.invalid(
                            with(&p, Key("count")),
                            g.count,
                            format!("only {n} balls of diameter {diameter} m fit in the region without overlap (try layout = \"lattice\" or a larger region)"),
                        ));
                    }
                }
            }
            "lattice" => {
                // Hexagonal rows from the bottom-left corner of the region; odd rows shifted by
                // half a spacing. Spots taken by other balls are skipped.
                let spacing = diameter * (1.0 + gap);
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
                            add(pos, &mut rng, &mut balls);
                            n += 1;
                        }
                    }
                }
                if n < count {
                    return Err(c.invalid(
                        with(&p, Key("count")),
                        g.count,
                        format!("only {n} balls of diameter {diameter} m fit in the region on a lattice"),
                    ));
                }
            }
            other => {
                return Err(c.invalid(
                    with(&p, Key("layout")),
                    format!("\"{other}\""),
                    "must be \"random\" or \"lattice\"",
                ));
            }
        }
    }
    if balls.len() > max_balls {
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
        integrator,
        dt,
        seed: file.simulation.seed,
        max_balls,
        ball_cycle,
        effects,
        pull,
        balls,
    })
}
