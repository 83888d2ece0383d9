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

fn four_unescaped(text: &str) -> Result<[f64; 4], String> {
    parse_numbers::<4>(text)
}

/// Four joint angles, rad: finite, and within ±[`SIN_COS_LIMIT`] (1.6·10⁶ rad), beyond which
/// the sines and cosines the kinematics and dynamics take would be NaN.
///
/// [`SIN_COS_LIMIT`]: chessarm_core::lanes::SIN_COS_LIMIT
fn angles_unescaped(text: &str) -> Result<[f64; 4], String> {
    let values = parse_numbers::<4>(text)?;
    let limit = chessarm_core::lanes::SIN_COS_LIMIT;
    match values.iter().position(|v| v.abs() > limit) {
        Some(j) => Err(format!(
            "'{}' rad is beyond ±{limit:e} rad, where sines lose their accuracy (in '{text}')",
            text.split(',').nth(j).unwrap_or_default().trim()
        )),
        None => Ok(values),
    }
}

fn three_unescaped(text: &str) -> Result<[f64; 3], String> {
    parse_numbers::<3>(text)
}

/// A finite number ≥ 0.
fn non_negative_unescaped(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} must be finite and >= 0")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// A finite number > 0.
fn positive_unescaped(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} must be finite and > 0")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// A board's square size for `board --fit --square-size`, m, and the text it was typed as
/// (for messages).
#[derive(Debug, Clone, PartialEq)]
pub struct SquareSize {
    pub metres: f64,
    pub typed: String,
}

/// A board's square size for `board --fit --square-size`, m: within the sizes the fit searches,
/// 1 cm to 20 cm (a value in mm, as 25, is refused with a hint).
fn square_size_unescaped(text: &str) -> Result<SquareSize, String> {
    let metres = match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => v,
        Ok(_) => return Err(format!("'{text}' must be a finite number of metres > 0, e.g. 0.025")),
        Err(_) => return Err(format!("'{text}' is not a number")),
    };
    if metres > 0.2 {
        Err(format!("'{text}' m is larger than a board's squares can be (at most 0.2 m); give metres, e.g. 0.025"))
    } else if metres < 0.01 {
        Err(format!("'{text}' m is smaller than the squares the fit tries (at least 0.01 m)"))
    } else {
        Ok(SquareSize { metres, typed: text.to_string() })
    }
}

/// A sample rate in [1, 10 000] Hz for `--export-rate`.
fn export_rate_unescaped(text: &str) -> Result<f64, String> {
    use chessarm_core::plan::hardware::{MAX_EXPORT_RATE, MIN_EXPORT_RATE};
    let value = positive_unescaped(text)?;
    if value > MAX_EXPORT_RATE {
        Err(format!("{value} Hz is above the highest export rate, {MAX_EXPORT_RATE} Hz"))
    } else if value < MIN_EXPORT_RATE {
        Err(format!(
            "{value} Hz is below the lowest export rate, {MIN_EXPORT_RATE} Hz (a driver interpolates between samples)"
        ))
    } else {
        Ok(value)
    }
}

/// A servo bus's goal rate for `--bus-rate`, Hz: within
/// [[`MIN_BUS_RATE`], [`MAX_BUS_RATE`]].
///
/// [`MIN_BUS_RATE`]: chessarm_core::control::servo_host::MIN_BUS_RATE
/// [`MAX_BUS_RATE`]: chessarm_core::control::servo_host::MAX_BUS_RATE
fn bus_rate_unescaped(text: &str) -> Result<f64, String> {
    use chessarm_core::control::servo_host::{MAX_BUS_RATE, MIN_BUS_RATE};
    let value = positive_unescaped(text)?;
    if value < MIN_BUS_RATE {
        Err(format!(
            "{value} Hz is below {MIN_BUS_RATE} Hz: goals that far apart do not follow a plan (a move's \
             simulation would wait {} s for each goal); servo buses send 50-1000 goals a second",
            crate::app::resources::show(1.0 / value)
        ))
    } else if value > MAX_BUS_RATE {
        Err(format!(
            "{value} Hz is above {MAX_BUS_RATE} Hz, faster than a servo bus can carry goal packets for four servos"
        ))
    } else {
        Ok(value)
    }
}

/// A wait for the arm to be in position, s: in (0, 60] (each of a move's fine points may wait
/// this long, simulated step by step; an arm that has not settled in a minute will not).
fn wait_unescaped(text: &str) -> Result<f64, String> {
    let value = positive_unescaped(text)?;
    if value > 60.0 {
        Err(format!("{value} s is longer than a minute, the longest wait for a fine point"))
    } else {
        Ok(value)
    }
}

/// A calibration's largest residual, mm: in (0, 20] (a board off by more than 20 mm cannot
/// place a piece within any square's tolerance).
fn residual_mm_unescaped(text: &str) -> Result<f64, String> {
    let value = positive_unescaped(text)?;
    if value > 20.0 {
        Err(format!("{value} mm is above 20 mm: touches that disagree by more cannot place a piece on its square"))
    } else {
        Ok(value)
    }
}

/// A finite number.
fn finite_unescaped(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not finite")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// One number for every joint, or exactly four comma-separated numbers; each finite and ≥ 0.
fn gain_unescaped(text: &str) -> Result<[f64; 4], String> {
    let values = if text.contains(',') { four_unescaped(text)? } else { [finite_unescaped(text)?; 4] };
    match values.iter().find(|v| **v < 0.0) {
        Some(v) => Err(format!("gain {v} in '{text}' must be >= 0")),
        None => Ok(values),
    }
}

/// One time constant for every joint or one per joint (`a,b,c,d`), s, each finite and >= 0.
fn time_constants_unescaped(text: &str) -> Result<[f64; 4], String> {
    let values = if text.contains(',') { four_unescaped(text)? } else { [finite_unescaped(text)?; 4] };
    match values.iter().find(|v| **v < 0.0) {
        Some(v) => Err(format!("time constant {v} s in '{text}' must be >= 0")),
        None => Ok(values),
    }
}

/// A count of at least 1.
fn count_unescaped(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(0) => Err("needs at least 1".to_owned()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

pub use crate::app::studies::tune::GainRange;

/// Parses `A..B:N` ([`GainRange::parse`]).
fn range_unescaped(text: &str) -> Result<GainRange, String> {
    GainRange::parse(text)
}

/// Parses `K/N` with `1 ≤ K ≤ N`.
fn shard_unescaped(text: &str) -> Result<(usize, usize), String> {
    let (k, n) = text.split_once('/').ok_or_else(|| format!("'{text}' is not a shard K/N (e.g. 2/8)"))?;
    let parse =
        |part: &str| part.trim().parse::<usize>().map_err(|_| format!("'{part}' in '{text}' is not a whole number"));
    let (k, n) = (parse(k)?, parse(n)?);
    if n == 0 || k == 0 || k > n {
        return Err(format!("shard {k}/{n} needs 1 <= K <= N"));
    }
    Ok((k, n))
}

/// A game number of a PGN file: a whole number from 1.
fn game_number_unescaped(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(0) => Err("games are counted from 1".to_owned()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

// The value parsers clap calls: their messages quote the value as typed, with control
// characters escaped (clap's renderer would drop them, hiding what was typed).
macro_rules! escaped {
    ($($name:ident => $inner:ident -> $value:ty;)*) => {$(
        #[doc = concat!("See `", stringify!($inner), "`; the message's control characters escaped.")]
        pub fn $name(text: &str) -> Result<$value, String> {
            $inner(text).map_err(|message| crate::app::text::escape_controls(&message))
        }
    )*};
}

escaped! {
    four => four_unescaped -> [f64; 4];
    angles => angles_unescaped -> [f64; 4];
    three => three_unescaped -> [f64; 3];
    non_negative => non_negative_unescaped -> f64;
    positive => positive_unescaped -> f64;
    export_rate => export_rate_unescaped -> f64;
    square_size => square_size_unescaped -> SquareSize;
    bus_rate => bus_rate_unescaped -> f64;
    wait => wait_unescaped -> f64;
    residual_mm => residual_mm_unescaped -> f64;
    finite => finite_unescaped -> f64;
    gain => gain_unescaped -> [f64; 4];
    range => range_unescaped -> GainRange;
    shard => shard_unescaped -> (usize, usize);
    game_number => game_number_unescaped -> usize;
    time_constants => time_constants_unescaped -> [f64; 4];
    count => count_unescaped -> usize;
    share => share_unescaped -> f64;
    mass => mass_unescaped -> f64;
    locks => locks_unescaped -> Locks;
    servo_command => servo_command_unescaped -> chessarm_core::control::servo_host::ServoCommand;
    fault => fault_unescaped -> crate::app::bus::simulator::Fault;
}

/// `ID@N`: servo `ID` (0–252) misbehaves from the `N`-th goal packet on (N ≥ 1).
fn fault_unescaped(text: &str) -> Result<crate::app::bus::simulator::Fault, String> {
    let (id, after) = text
        .split_once('@')
        .ok_or_else(|| format!("'{text}' is not ID@N (a servo ID and the goal packet it fails from, e.g. 3@120)"))?;
    let id: u8 = id
        .trim()
        .parse()
        .ok()
        .filter(|i| *i <= 252)
        .ok_or_else(|| format!("'{id}' is not a servo ID 0–252 (in '{text}')"))?;
    let after: usize = after
        .trim()
        .parse()
        .ok()
        .filter(|n| *n >= 1)
        .ok_or_else(|| format!("'{after}' is not a packet count >= 1 (in '{text}')"))?;
    Ok(crate::app::bus::simulator::Fault { id, after })
}

/// `plain`, `sag` or `feedforward`.
fn servo_command_unescaped(text: &str) -> Result<chessarm_core::control::servo_host::ServoCommand, String> {
    use chessarm_core::control::servo_host::ServoCommand;
    ServoCommand::from_name(text.trim())
        .ok_or_else(|| format!("'{text}' is not a servo command; use plain, sag or feedforward"))
}

/// `JOINT=VALUE[,JOINT=VALUE…]`: joints to hold, each at a finite value (rad, or m for a
/// prismatic joint).
fn locks_unescaped(text: &str) -> Result<Locks, String> {
    text.split(',')
        .map(|part| {
            let (name, value) =
                part.split_once('=').ok_or_else(|| format!("'{part}' needs JOINT=VALUE (in '{text}')"))?;
            let name = name.trim();
            if name.is_empty() {
                return Err(format!("'{part}' names no joint (in '{text}')"));
            }
            let value =
                value.trim().parse::<f64>().map_err(|_| format!("'{}' is not a number (in '{text}')", value.trim()))?;
            if !value.is_finite() {
                return Err(format!("'{}' is not finite (in '{text}')", value));
            }
            Ok((name.to_string(), value))
        })
        .collect::<Result<_, _>>()
        .map(Locks)
}

/// The joints `--lock` holds, by name, with their values as typed.
#[derive(Debug, Clone, PartialEq)]
pub struct Locks(pub Vec<(String, f64)>);

/// A mass, kg: finite, ≥ 0 and at most [`MAX_MASS`] (the model refuses heavier bodies).
///
/// [`MAX_MASS`]: chessarm_core::arm::model::MAX_MASS
fn mass_unescaped(text: &str) -> Result<f64, String> {
    let value = non_negative_unescaped(text)?;
    let most = chessarm_core::arm::model::MAX_MASS;
    if value > most {
        Err(format!(
            "{} kg is beyond {} kg, a typo in units",
            chessarm_core::short_number(value),
            chessarm_core::short_number(most)
        ))
    } else {
        Ok(value)
    }
}

/// A share in (0, 1].
fn share_unescaped(text: &str) -> Result<f64, String> {
    let value = finite_unescaped(text)?;
    if value > 0.0 && value <= 1.0 { Ok(value) } else { Err(format!("'{text}' must lie in (0, 1]")) }
}

/// The shard to run: `--shard K/N` as given, or with `--shard-from-env` the batch scheduler's
/// array index from `env` (Slurm: `SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN` (default 0) + 1
/// of `SLURM_ARRAY_TASK_COUNT`; Kubernetes: `JOB_COMPLETION_INDEX` + 1 of `--shards`).
///
/// # Errors
///
/// Both `--shard` and `--shard-from-env`, `--shards` without it, no scheduler variable, a
/// variable that is not a whole number, or an index outside `1..=N`; each names the flag or
/// variable and the value as set.
pub fn resolve_shard(
    given: Option<(usize, usize)>,
    (shard_from_env, shards): (bool, Option<usize>),
    env: impl Fn(&str) -> Option<String>,
) -> Result<Option<(usize, usize)>, String> {
    if !shard_from_env {
        if let Some(n) = shards {
            return Err(format!("--shards {n} goes with --shard-from-env"));
        }
        return Ok(given);
    }
    if let Some((k, n)) = given {
        return Err(format!("--shard {k}/{n} and --shard-from-env both choose the shard: give one"));
    }
    let number = |name: &str| -> Result<Option<usize>, String> {
        env(name)
            .map(|text| {
                text.trim()
                    .parse::<usize>()
                    .map_err(|_| format!("{name}={} is not a whole number", crate::app::text::escape_controls(&text)))
            })
            .transpose()
    };
    let (k, n, from) = if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let count = number("SLURM_ARRAY_TASK_COUNT")?
            .ok_or("--shard-from-env: SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not")?;
        if id < min {
            return Err(format!("SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}"));
        }
        (id - min + 1, count, format!("SLURM_ARRAY_TASK_ID={id} (from {min}) of SLURM_ARRAY_TASK_COUNT={count}"))
    } else if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let n = shards.ok_or("--shard-from-env with JOB_COMPLETION_INDEX needs --shards N (the Job's completions)")?;
        (index + 1, n, format!("JOB_COMPLETION_INDEX={index} of --shards {n}"))
    } else {
        return Err("--shard-from-env: neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set".into());
    };
    if n == 0 || k == 0 || k > n {
        return Err(format!("--shard-from-env: {from} gives shard {k}/{n}, outside 1..={n}"));
    }
    Ok(Some((k, n)))
}
