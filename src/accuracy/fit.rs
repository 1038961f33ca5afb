//! The measured order of convergence: the slope of log(error) against log(dt) over the
//! asymptotic range of a sweep.

/// Errors above this are not in the asymptotic range (every measure is relative: 1 % off is
/// already far from "small dt").
pub const CEILING: f64 = 1e-2;
/// Errors below this are rounding whatever the estimate says (a few ulps of a relative measure).
pub const FLOOR: f64 = 1e-14;
/// A point is at rounding level unless its error is at least this many times its estimated
/// rounding part.
pub const ROUNDING_MARGIN: f64 = 10.0;
/// The fewest points a slope is fitted on.
const MIN_POINTS: usize = 3;
/// The fit uses the finest steps above rounding level, over one decade of dt (or the finest
/// [`MIN_POINTS`] if a decade holds fewer): the order is a statement about dt → 0, and the
/// higher terms of the error still bend the curve at coarser steps.
const WINDOW: f64 = 10.0;

/// A fitted order of convergence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderFit {
    /// Least-squares slope of ln(error) against ln(dt).
    pub order: f64,
    /// Points used, and the range of dt they span.
    pub points: usize,
    /// The finest step of the points used, s.
    pub dt_min: f64,
    /// The coarsest step of the points used, s.
    pub dt_max: f64,
}

/// Fits the order of convergence to `(dt, error, rounding)` points, or `None` if fewer than three
/// points are in the asymptotic range.
///
/// The asymptotic range is chosen without reference to the expected order: the points whose
/// error is at most [`CEILING`], at least [`FLOOR`], and at least [`ROUNDING_MARGIN`] times the
/// estimate of its rounding part; of those, the finest decade of dt.
pub fn fit_order(points: &[(f64, f64, f64)]) -> Option<OrderFit> {
    let mut p: Vec<(f64, f64)> = points
        .iter()
        .filter(|&&(dt, e, rounding)| {
            dt > 0.0 && e.is_finite() && (FLOOR..=CEILING).contains(&e) && e >= ROUNDING_MARGIN * rounding
        })
        .map(|&(dt, e, _)| (dt, e))
        .collect();
    if p.len() < MIN_POINTS {
        return None;
    }
    p.sort_by(|a, b| b.0.total_cmp(&a.0));
    let finest = p[p.len() - 1].0;
    let in_window = p.iter().filter(|q| q.0 <= WINDOW * finest * (1.0 + 1e-9)).count().max(MIN_POINTS);
    let p = &p[p.len() - in_window..];
    let xs: Vec<f64> = p.iter().map(|q| q.0.ln()).collect();
    let ys: Vec<f64> = p.iter().map(|q| q.1.ln()).collect();
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    Some(OrderFit { order: sxy / sxx, points: p.len(), dt_min: p[p.len() - 1].0, dt_max: p[0].0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_the_finest_decade_above_rounding() {
        // error = dt⁴ + dt⁵ (bent at coarse steps), rounding 1e-13 below dt = 1e-3.
        let mut pts: Vec<(f64, f64, f64)> = (0..12)
            .map(|k| {
                let dt = 0.1 / 2f64.powi(k);
                (dt, dt.powi(4) + dt.powi(5), 1e-13)
            })
            .collect();
        pts.push((1.0, 0.5, 0.0));
        let fit = fit_order(&pts).unwrap();
        assert!((fit.order - 4.0).abs() < 0.01, "{fit:?}");
        assert!(fit.dt_min > 1e-3, "rounding-level points are left out: {fit:?}");
        assert!(fit_order(&[(1.0, 1e-15, 0.0), (0.5, 1e-16, 0.0), (0.25, 1e-16, 0.0)]).is_none());
    }
}
