//! State files: one CSV row per ball, `id,kind,x,y,vx,vy,mass,diameter`, SI units.
//!
//! Floats are written as the shortest decimal that reads back to the same bits, so a state
//! written and read again is exactly the state that was written: a run continued from
//! `--state-out` gives the same bits as one long run.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::DVec2;
use serde::{Deserialize, Serialize};

use crate::physics::{Ball, BallId, BallKind, Field, MAX_MASS, MAX_SPEED, MIN_MASS};

/// The columns of a state file, in order: the first line must name exactly these.
pub const HEADER: [&str; 8] = ["id", "kind", "x", "y", "vx", "vy", "mass", "diameter"];

/// Why a state file could not be read or written. Each message names the file and, where there
/// is one, the line.
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    /// The file could not be opened, read or written.
    ///
    /// The cause is part of the message, not a `source()`, so a printed chain says it once.
    #[error("{file}: {cause}")]
    Io {
        /// The state file.
        file: PathBuf,
        /// What the file system (or the CSV writer) said.
        cause: std::io::Error,
    },
    /// The text is not a state CSV: a wrong header, a row with the wrong number of fields, or
    /// CSV the reader cannot parse.
    #[error("{file}:{line}: {message}")]
    Malformed {
        /// The state file.
        file: PathBuf,
        /// Line of the fault, from 1 (0 when the CSV reader gives no position).
        line: u64,
        /// What is wrong with it.
        message: String,
    },
    /// A row is well formed but one of its values is not allowed (not a number, not finite, a
    /// mass or diameter that is not positive, an unknown kind, a second key ball, a repeated id,
    /// a ball outside the field).
    #[error("{file}:{line}: `{key}` = {value}: {problem}")]
    Invalid {
        /// The state file.
        file: PathBuf,
        /// Line of the row, from 1 (0 when the CSV reader gives no position).
        line: u64,
        /// The column, as named in [`HEADER`] (`x,y` for a ball outside the field).
        key: String,
        /// The value that is refused.
        value: String,
        /// What the value must be instead.
        problem: String,
    },
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

/// Line number (from 1) of byte `offset` in `text`.
/// Blank lines before the offset (which the csv reader skips as part of the record) are stepped over.
fn line_at(text: &str, offset: usize) -> u64 {
    let bytes = text.as_bytes();
    let mut offset = offset.min(bytes.len());
    while offset < bytes.len() && (bytes[offset] == b'\n' || bytes[offset] == b'\r') {
        offset += 1;
    }
    bytes[..offset].iter().filter(|&&b| b == b'\n').count() as u64 + 1
}

/// Writes the balls, in order, to `path`.
pub fn write_state(path: &Path, balls: &[Ball]) -> Result<(), StateFileError> {
    let io = |e: csv::Error| StateFileError::Io { file: path.to_path_buf(), cause: std::io::Error::other(e) };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    // The writer takes the header from the first row; a field without balls has none, and its
    // file must still read back.
    if balls.is_empty() {
        w.write_record(HEADER).map_err(io)?;
    }
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
    w.flush().map_err(|cause| StateFileError::Io { file: path.to_path_buf(), cause })
}

/// Reads a state file, checking every value against `field`.
pub fn read_state(path: &Path, field: &Field) -> Result<Vec<Ball>, StateFileError> {
    let text = std::fs::read_to_string(path).map_err(|cause| StateFileError::Io { file: path.to_path_buf(), cause })?;
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
    for record in reader.records() {
        let record = record.map_err(|e| StateFileError::Malformed {
            file: file.clone(),
            line: e.position().map(|p| line_at(text, p.byte() as usize)).unwrap_or(0),
            message: e.to_string(),
        })?;
        // The csv reader's own line count skips blank lines; count them from the byte offset.
        let line = record.position().map(|p| line_at(text, p.byte() as usize)).unwrap_or(0);
        let bad = |key: &str, value: String, problem: &str| StateFileError::Invalid {
            file: file.clone(),
            line,
            key: key.into(),
            value,
            problem: problem.into(),
        };
        if record.len() != HEADER.len() {
            return Err(StateFileError::Malformed {
                file: file.clone(),
                line,
                message: format!("{} fields, expected {}", record.len(), HEADER.len()),
            });
        }
        let number = |k: usize| -> Result<f64, StateFileError> {
            record[k].trim().parse::<f64>().map_err(|_| bad(HEADER[k], record[k].to_string(), "is not a number"))
        };
        let id: u32 = record[0]
            .trim()
            .parse()
            .map_err(|_| bad("id", record[0].to_string(), "must be a whole number from 0 to 4294967295"))?;
        let kind = match record[1].trim() {
            "key" => BallKind::Key,
            "ball" => BallKind::Ball,
            other => return Err(bad("kind", other.to_string(), "must be `key` or `ball`")),
        };
        let row = Row {
            id,
            kind: record[1].trim().to_string(),
            x: number(2)?,
            y: number(3)?,
            vx: number(4)?,
            vy: number(5)?,
            mass: number(6)?,
            diameter: number(7)?,
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
        if !(MIN_MASS..=MAX_MASS).contains(&row.mass) {
            return Err(bad(
                "mass",
                crate::scene::number(row.mass),
                &format!("must be a mass from {MIN_MASS:e} to {MAX_MASS:e} kg"),
            ));
        }
        if DVec2::new(row.vx, row.vy).length() > MAX_SPEED {
            return Err(bad(
                "vx,vy",
                format!("{},{}", crate::scene::number(row.vx), crate::scene::number(row.vy)),
                &format!("is faster than the speed limit, {MAX_SPEED:e} m/s"),
            ));
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
