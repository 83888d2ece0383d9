//! Parsers for command-line values; each error names the value it rejects.

/// `N` comma-separated finite numbers, e.g. `0.1,0.2,-0.3,0`.
pub fn parse_numbers<const N: usize>(text: &str) -> Result<[f64; N], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!("expected {N} comma-separated numbers, got {} in '{text}'", parts.len()));
    }
    let mut values = [0.0; N];
    for (value, part) in values.iter_mut().zip(&parts) {
        *value = part.parse::<f64>().map_err(|_| format!("'{part}' is not a number (in '{text}')"))?;
        if !value.is_finite() {
            return Err(format!("'{part}' is not finite (in '{text}')"));
        }
    }
    Ok(values)
}

pub fn four(text: &str) -> Result<[f64; 4], String> {
    parse_numbers::<4>(text)
}

pub fn three(text: &str) -> Result<[f64; 3], String> {
    parse_numbers::<3>(text)
}

/// A finite number ≥ 0.
pub fn non_negative(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} must be finite and >= 0")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// A finite number > 0.
pub fn positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} must be finite and > 0")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// A finite number.
pub fn finite(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not finite")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// One number for every joint, or exactly four comma-separated numbers; each finite and ≥ 0.
pub fn gain(text: &str) -> Result<[f64; 4], String> {
    let values = if text.contains(',') { four(text)? } else { [finite(text)?; 4] };
    match values.iter().find(|v| **v < 0.0) {
        Some(v) => Err(format!("gain {v} in '{text}' must be >= 0")),
        None => Ok(values),
    }
}
