//! State files: one CSV row per ball, `id,kind,x,y,vx,vy,mass,diameter`, SI units.
//!
//! Floats are written as the shortest decimal that reads back to the same bits, so a state
//! written and read again is exactly the state that was written: a run continued from
//! `--state-out` gives the same bits as one long run.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::DVec2;
use serde::{Deserialize, Serialize};

use crate::physics::{Ball, BallId, BallKind, Field};

pub const HEADER: [&str; 8] = ["id", "kind", "x", "y", "vx", "vy", "mass", "diameter"];

#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    #[error("{file}: {source}")]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}:{line}: {message}")]
    Malformed { file: PathBuf, line: u64, message: String },
    #[error("{file}:{line}: `{key}` = {value}: {problem}")]
    Invalid { file: PathBuf, line: u64, key: String, value: String, problem: String },
}

#[derive(Serialize, Deserialize)]
struct Row {
    id: u32,
    kind: String,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    mass: f64,
    diameter: f64,
}

/// Writes the balls, in order, to `path`.
pub fn write_state(path: &Path, balls: &[Ball]) -> Result<(), StateFileError> {
    let io = |e: csv::Error| StateFileError::Io { file: path.to_path_buf(), source: std::io::Error::other(e) };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    for b in balls {
        w.serialize(Row {
            id: b.id.0,
            kind: b.kind.as_str().into(),
            x: b.position.x,
            y: b.position.y,
            vx: b.velocity.x,
            vy: b.velocity.y,
            mass: b.mass,
            diameter: b.diameter,
        })
        .map_err(io)?;
    }
    w.flush().map_err(|source| StateFileError::Io { file: path.to_path_buf(), source })
}

/// Reads a state file, checking every value against `field`.
pub fn read_state(path: &Path, field: &Field) -> Result<Vec<Ball>, StateFileError> {
    let text =
        std::fs::read_to_string(path).map_err(|source| StateFileError::Io { file: path.to_path_buf(), source })?;
    parse_state(&text, path, field)
}

/// Parses state text; `path` names it in messages.
pub fn parse_state(text: &str, path: &Path, field: &Field) -> Result<Vec<Ball>, StateFileError> {
    let file = path.to_path_buf();
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| StateFileError::Malformed { file: file.clone(), line: 1, message: e.to_string() })?
        .iter()
        .map(str::to_string)
        .collect();
    if header != HEADER {
        return Err(StateFileError::Malformed {
            file,
            line: 1,
            message: format!("the header must be `{}`, found `{}`", HEADER.join(","), header.join(",")),
        });
    }
    let mut balls = Vec::new();
    let mut ids = HashSet::new();
    let mut keys = 0;
    for record in reader.deserialize::<Row>() {
        let row = record.map_err(|e| StateFileError::Malformed {
            file: file.clone(),
            line: e.position().map(|p| p.line()).unwrap_or(0),
            message: match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => format!(
                    "column `{}`: {}",
                    err.field().and_then(|f| HEADER.get(f as usize)).unwrap_or(&"?"),
                    err.kind()
                ),
                _ => e.to_string(),
            },
        })?;
        let line = balls.len() as u64 + 2;
        let bad = |key: &str, value: String, problem: &str| StateFileError::Invalid {
            file: file.clone(),
            line,
            key: key.into(),
            value,
            problem: problem.into(),
        };
        let kind = match row.kind.as_str() {
            "key" => BallKind::Key,
            "ball" => BallKind::Ball,
            other => return Err(bad("kind", other.into(), "must be `key` or `ball`")),
        };
        for (key, v) in [("x", row.x), ("y", row.y), ("vx", row.vx), ("vy", row.vy)] {
            if !v.is_finite() {
                return Err(bad(key, v.to_string(), "must be a finite number"));
            }
        }
        for (key, v) in [("mass", row.mass), ("diameter", row.diameter)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(key, v.to_string(), "must be a finite number greater than zero"));
            }
        }
        let tolerance = 1e-9 * field.width.max(field.height);
        if !field.contains(row.x, row.y, 0.5 * row.diameter, tolerance) {
            return Err(bad(
                "x,y",
                format!("{},{}", row.x, row.y),
                &format!(
                    "puts a ball of diameter {} m outside the field ({} m × {} m)",
                    row.diameter, field.width, field.height
                ),
            ));
        }
        if !ids.insert(row.id) {
            return Err(bad("id", row.id.to_string(), "appears twice"));
        }
        if kind == BallKind::Key {
            keys += 1;
            if keys > 1 {
                return Err(bad("kind", "key".into(), "there may be only one key ball"));
            }
        }
        balls.push(Ball {
            id: BallId(row.id),
            kind,
            position: DVec2::new(row.x, row.y),
            velocity: DVec2::new(row.vx, row.vy),
            mass: row.mass,
            diameter: row.diameter,
        });
    }
    Ok(balls)
}
