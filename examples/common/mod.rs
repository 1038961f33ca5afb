//! What the examples share (each example is its own binary and takes this module with `mod common;`).

/// A clap value parser for a positive number of seconds up to an hour.
pub fn positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 && x <= 3600.0 => Ok(x),
        _ => Err(format!("{s:?} is not a positive number up to 3600")),
    }
}
