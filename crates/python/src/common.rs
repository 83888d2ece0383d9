//! What the in-memory objects share: arguments read from Python (checked, the argument named in
//! the error), read-only NumPy arrays made from the studies' results, warnings, and the CLI's
//! messages said in Python's words.

use numpy::IntoPyArray;
use numpy::ndarray::{Array1, Array2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyString;

/// An error and its causes on one line, with the command line's flags (`--control-rate`) named
/// as Python's arguments (`control_rate`).
pub fn pythonic(error: &anyhow::Error) -> String {
    flags_as_arguments(&chessarm::app::text::one_line(error))
}

/// `--kebab-case` flags in `text` as `kebab_case` argument names (not inside backquotes, which
/// quote a command to type).
pub fn flags_as_arguments(text: &str) -> String {
    text.split('`')
        .enumerate()
        .map(|(i, part)| if i % 2 == 1 { part.to_string() } else { unquoted_flags(part) })
        .collect::<Vec<_>>()
        .join("`")
}

fn unquoted_flags(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find("--") {
        let (before, after) = rest.split_at(at);
        out.push_str(before);
        let name: String = after[2..].chars().take_while(|c| c.is_ascii_lowercase() || *c == '-').collect();
        let starts_a_word = before.is_empty() || before.ends_with([' ', '(', '"', '\'', ',']);
        if starts_a_word && name.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push_str(&name.replace('-', "_"));
            rest = &after[2 + name.len()..];
        } else {
            out.push_str("--");
            rest = &after[2..];
        }
    }
    out.push_str(rest);
    out
}

/// A `ValueError` naming the argument and the value as Python shows it.
pub fn bad_value(name: &str, value: &Bound<'_, PyAny>, why: &str) -> PyErr {
    let shown = value.repr().map_or_else(|_| "?".to_string(), |r| r.to_string());
    PyValueError::new_err(format!("{name}={shown}: {why}"))
}

/// A finite number > 0 (`what` says the unit in the message).
pub fn positive(name: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(PyValueError::new_err(format!("{name}={value}: must be a finite number > 0")))
    }
}

/// A finite number ≥ 0.
pub fn non_negative(name: &str, value: f64) -> PyResult<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(PyValueError::new_err(format!("{name}={value}: must be a finite number >= 0")))
    }
}

/// `K` finite numbers from a sequence (a list, a tuple, a NumPy array).
pub fn numbers<const K: usize>(name: &str, value: &Bound<'_, PyAny>) -> PyResult<[f64; K]> {
    if value.is_instance_of::<PyString>() {
        return Err(bad_value(name, value, &format!("needs {K} numbers, not a string")));
    }
    let values: Vec<f64> =
        value.extract().map_err(|_| bad_value(name, value, &format!("needs a sequence of {K} numbers")))?;
    let values: [f64; K] = values
        .try_into()
        .map_err(|v: Vec<f64>| bad_value(name, value, &format!("has {} numbers; it needs {K}", v.len())))?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(bad_value(name, value, "every number must be finite"));
    }
    Ok(values)
}

/// One number for every joint or one per joint (4), each finite and ≥ 0 (gains, time constants).
pub fn per_joint(name: &str, value: &Bound<'_, PyAny>) -> PyResult<[f64; 4]> {
    let values = match value.extract::<f64>() {
        Ok(one) if !value.is_instance_of::<pyo3::types::PyBool>() => [one; 4],
        _ => numbers::<4>(name, value)
            .map_err(|_| bad_value(name, value, "needs one number for every joint or 4, one per joint"))?,
    };
    if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
        return Err(bad_value(name, value, &format!("{v} must be finite and >= 0")));
    }
    Ok(values)
}

/// [`per_joint`] of an optional argument.
pub fn optional_per_joint(name: &str, value: Option<&Bound<'_, PyAny>>) -> PyResult<Option<[f64; 4]>> {
    value.filter(|v| !v.is_none()).map(|v| per_joint(name, v)).transpose()
}

/// One name or a list of names.
pub fn names(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    if let Ok(one) = value.extract::<String>() {
        return Ok(vec![one]);
    }
    let many: Vec<String> = value.extract().map_err(|_| bad_value(name, value, "needs a name or a list of names"))?;
    if many.is_empty() {
        return Err(bad_value(name, value, "needs at least one name"));
    }
    Ok(many)
}

/// A clap value (`pd`, `kalman-two-state`, `rkn4`) by its command-line name; `_` may stand for `-`.
pub fn choice<T: clap::ValueEnum>(name: &str, value: &str) -> PyResult<T> {
    let spelled = value.replace('_', "-");
    T::from_str(&spelled, true).map_err(|_| {
        let known: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
            .collect();
        PyValueError::new_err(format!("{name}={value:?}: not one of {}", known.join(", ")))
    })
}

/// A read-only array of shape `(n, K)`.
pub fn rows<const K: usize>(py: Python<'_>, rows: impl IntoIterator<Item = [f64; K]>) -> PyResult<Py<PyAny>> {
    let flat: Vec<f64> = rows.into_iter().flatten().collect();
    let n = flat.len() / K;
    let array = Array2::from_shape_vec((n, K), flat).expect("whole rows").into_pyarray(py);
    frozen(array.into_any())
}

/// A read-only array of shape `(n,)`.
pub fn column(py: Python<'_>, values: impl IntoIterator<Item = f64>) -> PyResult<Py<PyAny>> {
    let array = Array1::from_iter(values).into_pyarray(py);
    frozen(array.into_any())
}

/// The array, flagged read-only: a result's numbers are the study's, not to be edited in place.
fn frozen(array: Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(array.unbind())
}

/// A JSON value as Python's (dicts, lists, floats, …).
pub fn json_to_python(py: Python<'_>, value: &serde_json::Value) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// Warns (`chessarm.ChessarmWarning`) with a note of chessarm's (a URDF's, the conditions'),
/// without its `warning:` or `note:` prefix and its line break.
pub fn warn(py: Python<'_>, text: &str) -> PyResult<()> {
    let line = text.trim_end();
    let line = line.strip_prefix("warning: ").or_else(|| line.strip_prefix("note: ")).unwrap_or(line);
    let message = std::ffi::CString::new(flags_as_arguments(line).replace('\0', " ")).expect("no NUL left");
    let category = py.get_type::<crate::errors::ChessarmWarning>();
    PyErr::warn(py, &category, &message, caller_level(py).unwrap_or(1))
}

/// The stack level of the first frame outside the chessarm package (1: the innermost Python
/// frame), so that a warning names the user's line, not the package's wrapper that called Rust.
fn caller_level(py: Python<'_>) -> PyResult<i32> {
    let init: String = py.import("chessarm")?.getattr("__file__")?.extract()?;
    let package = std::path::Path::new(&init).parent().map(|p| p.to_string_lossy().into_owned()).unwrap_or_default();
    let mut frame = py.import("sys")?.call_method1("_getframe", (0,))?;
    let mut level = 1;
    while !frame.is_none() && level < 50 {
        let file: String = frame.getattr("f_code")?.getattr("co_filename")?.extract()?;
        if package.is_empty() || !file.starts_with(&package) {
            break;
        }
        level += 1;
        frame = frame.getattr("f_back")?;
    }
    Ok(level)
}

#[cfg(test)]
mod tests {
    use super::flags_as_arguments;

    #[test]
    fn flags_become_argument_names() {
        assert_eq!(
            flags_as_arguments("--control-rate 500 Hz must be a multiple of --dt 0.003 s"),
            "control_rate 500 Hz must be a multiple of dt 0.003 s"
        );
        assert_eq!(flags_as_arguments("a -- b --x"), "a -- b x");
        assert_eq!(flags_as_arguments("(--sensors hobby)"), "(sensors hobby)");
        assert_eq!(flags_as_arguments("e--x"), "e--x");
        assert_eq!(flags_as_arguments("--a `chessarm board --fit` --b"), "a `chessarm board --fit` b");
    }
}
