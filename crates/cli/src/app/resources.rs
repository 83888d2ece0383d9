//! Bounds on the work a command line may ask for, set from what this machine can hold: memory
//! is estimated before anything large is allocated, and worker threads are capped.

use anyhow::{Result, bail};

/// Share of the memory available at start that one run may plan to fill.
const MEMORY_SHARE: f64 = 0.5;
/// Assumed available memory where `/proc/meminfo` cannot be read, bytes (4 GiB).
const FALLBACK_AVAILABLE: f64 = 4.0 * 1024.0 * 1024.0 * 1024.0;
/// Most worker threads per available core.
pub const THREADS_PER_CORE: usize = 4;

/// Memory the system can still give out, bytes (`MemAvailable` of `/proc/meminfo`).
pub fn available_memory() -> f64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|line| line.starts_with("MemAvailable:"))?;
            let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(kib * 1024.0)
        })
        .unwrap_or(FALLBACK_AVAILABLE)
}

/// `bytes` in short human form: `512 B`, `3.4 MB`, `55 GB`.
pub fn show_bytes(bytes: f64) -> String {
    const UNITS: [&str; 6] = ["B", "kB", "MB", "GB", "TB", "PB"];
    if bytes.is_nan() || bytes >= 1e18 {
        return format!("{bytes:.1e} B");
    }
    let mut value = bytes;
    let mut unit = 0;
    while value >= 1000.0 && unit + 1 < UNITS.len() {
        value /= 1000.0;
        unit += 1;
    }
    if unit == 0 { format!("{value:.0} {}", UNITS[unit]) } else { format!("{value:.1} {}", UNITS[unit]) }
}

/// Checks that `samples` items of `bytes_each` fit in the memory this run may use; the error
/// names `cause` (the flags as typed, e.g. `--dt 1.3e-7`) and what would have been needed.
///
/// # Errors
///
/// When the estimate exceeds [`MEMORY_SHARE`] of [`available_memory`] (or is not finite).
pub fn ensure_fits(cause: &str, what: &str, samples: f64, bytes_each: f64) -> Result<()> {
    let needed = samples * bytes_each;
    let budget = MEMORY_SHARE * available_memory();
    if !(needed.is_finite() && needed <= budget) {
        bail!(
            "{cause} asks for {} {what}, about {} of memory; this machine can give {} to one run: \
             ask for fewer",
            show_count(samples),
            show_bytes(needed),
            show_bytes(budget)
        );
    }
    Ok(())
}

/// A count as a whole number, or in short scientific form when huge.
pub fn show_count(count: f64) -> String {
    if count.is_finite() && count < 1e12 { format!("{count:.0}") } else { format!("{count:.3e}") }
}

/// A number as typed, in short form: plain when moderate, scientific when huge or tiny
/// (`1e308`, `1e-320`); see [`chessarm_core::short_number`].
pub fn show(value: f64) -> String {
    chessarm_core::short_number(value)
}

/// Numbers as typed, comma-separated, each in [`show`]'s form (`1e308,0,0,0`).
pub fn show_list(values: &[f64]) -> String {
    values.iter().map(|v| show(*v)).collect::<Vec<_>>().join(",")
}

/// The worker-thread count for `--threads`: all cores by default, at most
/// [`THREADS_PER_CORE`] per core.
///
/// # Errors
///
/// `--threads 0` or more than the cap, naming the flag and the value.
pub fn worker_threads(requested: Option<usize>) -> Result<usize> {
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get);
    let cap = THREADS_PER_CORE * cores;
    match requested {
        None => Ok(cores),
        Some(0) => bail!("--threads 0: need at least one thread"),
        Some(n) if n > cap => bail!(
            "--threads {n} is more than {cap} ({THREADS_PER_CORE} per core on this machine's {cores}): \
             more threads than cores only add overhead"
        ),
        Some(n) => Ok(n),
    }
}

/// How sweeps and campaigns batch their runs: `CHESSARM_LANES` (1, 4 or 8 runs side by side;
/// 8 when unset) and `CHESSARM_SIMD` (`avx512`, `avx2` or `sse2`; when unset the best the
/// CPU has for 8 lanes, else AVX2 where it has it: `SimdLevel::for_lanes`). Neither changes a
/// result, only the speed: every run's metrics are the same bit for bit (see
/// `chessarm_core::sim::batch`).
///
/// # Errors
///
/// A value that is not one of those, or a level this CPU lacks, naming the variable and the
/// value as typed.
pub fn batching() -> Result<(chessarm_core::sim::batch::LaneCount, chessarm_core::sim::batch::SimdLevel)> {
    use chessarm_core::sim::batch::{LaneCount, SimdLevel};
    let read = |name: &str| match std::env::var(name) {
        Ok(value) => Ok(Some(value)),
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(value)) => Err(anyhow::anyhow!("{name}={value:?} is not UTF-8 text")),
    };
    let lanes = match read("CHESSARM_LANES")? {
        None => LaneCount::default(),
        Some(typed) => typed
            .trim()
            .parse()
            .ok()
            .and_then(LaneCount::from_count)
            .ok_or_else(|| anyhow::anyhow!("CHESSARM_LANES={typed:?}: the runs side by side are 1, 4 or 8"))?,
    };
    let level = match read("CHESSARM_SIMD")? {
        None => SimdLevel::for_lanes(lanes.get()),
        Some(typed) => {
            let available: Vec<&str> =
                SimdLevel::ALL.into_iter().filter(|level| level.available()).map(SimdLevel::name).collect();
            let level = SimdLevel::from_name(typed.trim())
                .ok_or_else(|| anyhow::anyhow!("CHESSARM_SIMD={typed:?}: the levels are avx512, avx2 and sse2"))?;
            if !level.available() {
                bail!("CHESSARM_SIMD={typed:?}: this CPU does not have it (it has {})", available.join(", "));
            }
            level
        }
    };
    Ok((lanes, level))
}

/// How many of `runs` runs one task of a sweep or campaign takes: a batch of `lanes`, or fewer
/// when that would leave some of `threads` threads without work (the results do not depend on
/// it).
pub fn per_task(runs: usize, threads: usize, lanes: chessarm_core::sim::batch::LaneCount) -> usize {
    lanes.get().min(runs.div_ceil(threads.max(1))).max(1)
}

/// The indices of shard `k` of `n` (1-based) of `total` runs or candidates: contiguous blocks.
pub fn shard_range(total: usize, shard: Option<(usize, usize)>) -> std::ops::Range<usize> {
    match shard {
        None => 0..total,
        Some((k, n)) => (total * (k - 1) / n)..(total * k / n),
    }
}
