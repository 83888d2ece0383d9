//! Metrics of a recorded response.

/// Settling time and overshoot of an error response that starts at `e(0) = initial` and should
/// decay to zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorResponse {
    /// Last instant (s) at which `|e| > band · |e(0)|`; 0 if it never leaves the band.
    pub settling_time: f64,
    /// Largest excursion past zero (opposite sign to `e(0)`), % of `|e(0)|`.
    pub overshoot_percent: f64,
}

/// Measures `samples` of `(t, e)` against a settling `band` (0.02 for the 2 % criterion).
/// Returns `None` when `e(0)` is zero.
pub fn error_response(samples: &[(f64, f64)], band: f64) -> Option<ErrorResponse> {
    let &(t0, initial) = samples.first()?;
    if initial == 0.0 {
        return None;
    }
    let threshold = band * initial.abs();
    let settling_time = samples.iter().rev().find(|(_, e)| e.abs() > threshold).map_or(0.0, |(t, _)| t - t0);
    let overshoot = samples.iter().map(|(_, e)| -e * initial.signum()).fold(0.0f64, f64::max);
    Some(ErrorResponse { settling_time, overshoot_percent: 100.0 * overshoot / initial.abs() })
}
