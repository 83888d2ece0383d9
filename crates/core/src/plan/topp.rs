//! Time-optimal path parameterisation by reachability analysis (TOPP-RA, Pham & Pham 2018).
//!
//! A geometric path is timed by `s(t)`. With `u = s̈` and `x = ṡ²`, every limit this crate
//! plans with is linear in `(u, x)` at a given `s` (see [`super::constraints`]): a joint's
//! torque `τ = M q̈ + C q̇ + g` with `q̇ = q' ṡ`, `q̈ = q' s̈ + q'' ṡ²` is
//! `τ = (M q') u + (M q'' + C(q, q') q') x + g(q)`, affine in `(u, x)`. The limits at grid point
//! `s_i` are rows `α u + β x ≤ γ`.
//!
//! Along a stage `[s_i, s_{i+1}]` of length `Δ_i` the acceleration `u_i` is constant, so
//! `x_{i+1} = x_i + 2 Δ_i u_i` exactly (`dx/ds = 2 s̈`). The stage's feasible set `Ω_i` holds
//! the rows of point `i` at `(u, x)` and those of point `i + 1` at `(u, x + 2 Δ_i u)` (the
//! paper's first-order interpolation), so the limits hold at both ends of every stage.
//!
//! - Controllable sets, backward: `K_N = [x_end, x_end]`,
//!   `K_i = {x ≥ 0 : ∃u, (u, x) ∈ Ω_i, x + 2 Δ_i u ∈ K_{i+1}}`. Each `K_i` is an interval:
//!   the projection of a convex polygon of the `(u, x)` plane on the `x` axis ([`project`]).
//! - Forward, greedy: `x_0 = x_start`, `u_i = max{u : (u, x_i) ∈ Ω_i, x_i + 2 Δ_i u ∈ K_{i+1}}`.
//!   This is time-optimal for the discretised problem (Pham & Pham 2018, Theorem 2).
//! - Time: `t_{i+1} = t_i + 2 Δ_i / (√x_i + √x_{i+1})`.

/// Which limit a row comes from (an index the caller names).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LimitId(pub u16);

/// One linear limit `alpha·u + beta·x ≤ gamma` on `(u, x) = (s̈, ṡ²)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    pub alpha: f64,
    pub beta: f64,
    pub gamma: f64,
    pub limit: LimitId,
}

/// The grid `s_0 < … < s_N` and the rows of every grid point.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConstraintTable {
    s: Vec<f64>,
    rows: Vec<Row>,
    /// `rows[starts[i]..starts[i + 1]]` belong to point `i`.
    starts: Vec<usize>,
}

impl ConstraintTable {
    pub fn new() -> Self {
        Self { s: Vec::new(), rows: Vec::new(), starts: vec![0] }
    }

    /// Starts grid point `s` (greater than the last one); rows pushed next belong to it.
    pub fn push_point(&mut self, s: f64) {
        if !self.s.is_empty() {
            self.starts.push(self.rows.len());
        }
        self.s.push(s);
    }

    /// Adds `alpha·u + beta·x ≤ gamma` to the current point.
    pub fn push_row(&mut self, alpha: f64, beta: f64, gamma: f64, limit: LimitId) {
        self.rows.push(Row { alpha, beta, gamma, limit });
    }

    /// Moves every row's bound in by `by` (`γ → γ − by`): with rows scaled to their limit,
    /// a share `by` of every limit is kept back.
    pub fn tighten(&mut self, by: f64) {
        for row in &mut self.rows {
            row.gamma -= by;
        }
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.s.is_empty()
    }

    pub fn grid(&self) -> &[f64] {
        &self.s
    }

    /// The rows of grid point `i`.
    pub fn rows(&self, i: usize) -> &[Row] {
        let end = if i + 1 < self.s.len() { self.starts[i + 1] } else { self.rows.len() };
        &self.rows[self.starts[i]..end]
    }
}

/// Why a path cannot be timed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ToppError {
    #[error("the path grid needs at least 2 increasing, finite points (got {0})")]
    Grid(usize),
    #[error("start and end speeds x = {start}, {end} must be finite and >= 0")]
    Boundary { start: f64, end: f64 },
    /// No speed at grid point `index` (path parameter `s`) satisfies the limits and can still
    /// reach the end; `limit` is the row violated by standing still there, if one is.
    #[error("no feasible motion at s = {s:.4} (grid point {index})")]
    Infeasible { index: usize, s: f64, limit: Option<LimitId> },
    #[error("the path cannot start moving at s = {s:.4}: every limit allows only rest there")]
    Stuck { s: f64 },
}

/// The time-optimal timing on the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    /// Grid `s_i`.
    pub s: Vec<f64>,
    /// `x_i = ṡ²` at the grid points.
    pub x: Vec<f64>,
    /// `u_i = s̈` on stage `i` (one fewer than the points).
    pub u: Vec<f64>,
    /// `t_i`, s, from 0.
    pub t: Vec<f64>,
    /// The controllable sets `K_i = [lo, hi]` of `x`.
    pub controllable: Vec<(f64, f64)>,
    /// The row closest to binding on each stage (smallest relative slack).
    pub active: Vec<Option<LimitId>>,
}

impl Timing {
    pub fn duration(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0)
    }

    /// `(s, ṡ, s̈)` at time `t` (s): at `t = 0` the first stage's acceleration (the motion
    /// leaves rest with it), held at rest outside `[0, T)`.
    pub fn sample(&self, t: f64) -> (f64, f64, f64) {
        let n = self.s.len();
        if t < 0.0 {
            return (self.s[0], self.x[0].sqrt(), 0.0);
        }
        if t == 0.0 {
            return (self.s[0], self.x[0].sqrt(), self.u[0]);
        }
        if t >= self.duration() {
            return (self.s[n - 1], self.x[n - 1].sqrt(), 0.0);
        }
        let i = (self.t.partition_point(|&ti| ti <= t).max(1) - 1).min(n - 2);
        let tau = t - self.t[i];
        let (v0, u) = (self.x[i].sqrt(), self.u[i]);
        let s = (self.s[i] + v0 * tau + 0.5 * u * tau * tau).min(self.s[i + 1]);
        ((s), (v0 + u * tau).max(0.0), u)
    }
}

/// Rows of point `i` and, interpolated, of point `i + 1`, as seen by stage `i`.
fn stage_rows<'a>(table: &'a ConstraintTable, i: usize, delta: f64) -> impl Iterator<Item = Row> + Clone + 'a {
    let here = table.rows(i).iter().copied();
    let next = table.rows(i + 1).iter().map(move |r| Row { alpha: r.alpha + 2.0 * delta * r.beta, ..*r });
    here.chain(next)
}

/// Rows whose `|α|` is below this share of `|β| + |γ|` count as pure bounds on `x`: their `u`
/// term is rounding (for `|u|` up to 10⁶ it moves the bound by 10⁻⁶ of its size).
const PURE_ROW: f64 = 1e-12;

/// The projection `[lo, hi]` on `x ≥ 0` of `{(u, x) : rows}` (`None` if empty).
///
/// A pure row (`α = 0`) bounds `x` directly. The others bound `u` from above (`α > 0`) or
/// below (`α < 0`) by lines `u = (γ − β x)/α`: `x` is feasible iff
/// `g(x) = max(lower lines) − min(upper lines) ≤ 0`, and `g` is convex and piecewise linear.
/// The largest feasible `x` is found by Newton's method from the top of the pure bounds: from a
/// point with `g > 0` and left slope `s > 0`, the tangent's root lies between the largest root
/// and the point (convexity), so the iterates fall monotonically onto it, one linear piece per
/// step, exactly in finitely many steps; a point with `g > 0` and `s ≤ 0` has nothing feasible
/// to its left. The smallest feasible `x` likewise from the bottom. O(rows) per step, a few
/// steps (the tests compare it with Fourier–Motzkin elimination of `u`, every pair of an upper
/// and a lower line, on random rows).
pub fn project<I: Iterator<Item = Row> + Clone>(rows: I) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (0.0_f64, f64::INFINITY);
    let (mut lower, mut upper) = (false, false);
    for r in rows.clone() {
        if r.alpha.abs() <= PURE_ROW * (r.beta.abs() + r.gamma.abs()) {
            if r.beta > 0.0 {
                hi = hi.min(r.gamma / r.beta);
            } else if r.beta < 0.0 {
                lo = lo.max(r.gamma / r.beta);
            } else if r.gamma < 0.0 {
                return None;
            }
        } else if r.alpha > 0.0 {
            upper = true;
        } else {
            lower = true;
        }
    }
    if lo > hi || lo.is_nan() || hi.is_nan() {
        return None;
    }
    if !(lower && upper) {
        return Some((lo, hi));
    }
    // g(x), its slope from the left (`leftward`) or from the right, its scale, and the two
    // lines that give it there.
    let g = |x: f64, leftward: bool| -> (f64, f64, f64, Row, Row) {
        let none = Row { alpha: 0.0, beta: 0.0, gamma: 0.0, limit: LimitId(0) };
        let (mut low, mut low_slope, mut low_row) = (f64::NEG_INFINITY, 0.0, none);
        let (mut high, mut high_slope, mut high_row) = (f64::INFINITY, 0.0, none);
        for r in rows.clone() {
            if r.alpha.abs() <= PURE_ROW * (r.beta.abs() + r.gamma.abs()) {
                continue;
            }
            let (value, slope) = ((r.gamma - r.beta * x) / r.alpha, -r.beta / r.alpha);
            if r.alpha < 0.0 {
                // max of lower lines: on a tie the left slope is the smaller, the right the larger
                let better = if leftward { slope < low_slope } else { slope > low_slope };
                if value > low || (value == low && better) {
                    (low, low_slope, low_row) = (value, slope, r);
                }
            } else {
                let better = if leftward { slope > high_slope } else { slope < high_slope };
                if value < high || (value == high && better) {
                    (high, high_slope, high_row) = (value, slope, r);
                }
            }
        }
        (low - high, low_slope - high_slope, low.abs() + high.abs(), low_row, high_row)
    };
    // Where two lines meet: αₖ(γⱼ − βⱼ x) = αⱼ(γₖ − βₖ x).
    let meet = |j: &Row, k: &Row| (k.alpha * j.gamma - j.alpha * k.gamma) / (k.alpha * j.beta - j.alpha * k.beta);
    let feasible = |value: f64, scale: f64| value <= 1e-12 * (1.0 + scale);
    const STEPS: usize = 100;
    // Without a pure upper bound, g's fate at +∞ is that of the steepest lower line against the
    // flattest upper one: below it the set is unbounded; above it, g ≥ 0 from where they meet
    // on, and the largest root is no further.
    let mut start = hi;
    if !hi.is_finite() {
        let pick = |lower: bool| {
            rows.clone()
                .filter(|r| r.alpha.abs() > PURE_ROW * (r.beta.abs() + r.gamma.abs()) && (r.alpha < 0.0) == lower)
                .map(|r| (-r.beta / r.alpha, r.gamma / r.alpha, r))
                .reduce(|a, b| {
                    let steeper = if lower {
                        b.0 > a.0 || (b.0 == a.0 && b.1 > a.1)
                    } else {
                        b.0 < a.0 || (b.0 == a.0 && b.1 < a.1)
                    };
                    if steeper { b } else { a }
                })
        };
        let (Some((slope_j, at_j, j)), Some((slope_k, at_k, k))) = (pick(true), pick(false)) else { return None };
        if slope_j < slope_k || (slope_j == slope_k && at_j <= at_k) {
            start = f64::INFINITY;
        } else {
            let x = meet(&j, &k);
            start = if x.is_finite() { x.max(lo) } else { 1e15 };
        }
    }
    // Largest root, from the top. A Newton step on g = L_j − U_k lands where the two lines
    // meet, computed from the lines themselves so that no digits are lost.
    let mut x = start;
    let mut top = if start.is_infinite() { Some(f64::INFINITY) } else { None };
    let steps = if top.is_some() { 0 } else { STEPS };
    for _ in 0..steps {
        let (value, slope, scale, j, k) = g(x, true);
        if feasible(value, scale) {
            top = Some(x);
            break;
        }
        if slope <= 0.0 {
            return None;
        }
        let next = meet(&j, &k);
        if next.is_nan() || next < lo {
            return None;
        }
        if next >= x {
            // The active lines meet here: g(x) > 0 is rounding (steep lines amplify it), or
            // the set is empty.
            if value <= 1e-9 * (1.0 + scale) {
                top = Some(x);
                break;
            }
            return None;
        }
        x = next;
    }
    let top = top?;
    // Smallest root, from the bottom.
    let mut x = lo;
    for _ in 0..STEPS {
        let (value, slope, scale, j, k) = g(x, false);
        if feasible(value, scale) {
            return Some((x, top.max(x)));
        }
        if slope >= 0.0 {
            return None;
        }
        let next = meet(&j, &k);
        if next.is_nan() || next > top {
            return None;
        }
        if next <= x {
            return (value <= 1e-9 * (1.0 + scale)).then_some((x, top.max(x)));
        }
        x = next;
    }
    None
}

/// The largest and smallest `u` the rows allow at `x`: `(u_min, u_max)`.
pub fn acceleration_bounds<I: Iterator<Item = Row>>(rows: I, x: f64) -> (f64, f64) {
    let (mut low, mut high) = (f64::NEG_INFINITY, f64::INFINITY);
    for r in rows {
        if r.alpha > 0.0 {
            high = high.min((r.gamma - r.beta * x) / r.alpha);
        } else if r.alpha < 0.0 {
            low = low.max((r.gamma - r.beta * x) / r.alpha);
        }
    }
    (low, high)
}

/// Relative slack of a row at `(u, x)`: 0 when binding, about 1 when far from it.
fn relative_slack(r: &Row, u: f64, x: f64) -> f64 {
    let used = r.alpha * u + r.beta * x;
    (r.gamma - used) / (r.gamma.abs() + (r.alpha * u).abs() + (r.beta * x).abs() + 1e-300)
}

/// The time-optimal timing of the grid's path from speed `x_start` to `x_end` (`ṡ²`; 0 for
/// rest), by TOPP-RA (module docs). Allocates the result only.
pub fn time_optimal(table: &ConstraintTable, x_start: f64, x_end: f64) -> Result<Timing, ToppError> {
    let n = table.len();
    let increasing = table.s.windows(2).all(|w| w[1] > w[0]) && table.s.iter().all(|s| s.is_finite());
    if n < 2 || !increasing {
        return Err(ToppError::Grid(n));
    }
    if !(x_start.is_finite() && x_start >= 0.0 && x_end.is_finite() && x_end >= 0.0) {
        return Err(ToppError::Boundary { start: x_start, end: x_end });
    }
    let infeasible = |index: usize| {
        let limit = table.rows(index).iter().filter(|r| r.gamma < 0.0).min_by(|a, b| a.gamma.total_cmp(&b.gamma));
        let limit = limit.map(|r| r.limit);
        ToppError::Infeasible { index, s: table.s[index], limit }
    };
    let mut controllable = vec![(0.0, 0.0); n];
    // The end point's own rows bound x_end (speed limits); its acceleration is free.
    let end_ok = table.rows(n - 1).iter().all(|r| r.alpha != 0.0 || r.beta * x_end <= r.gamma * (1.0 + 1e-12));
    if !end_ok {
        return Err(infeasible(n - 1));
    }
    controllable[n - 1] = (x_end, x_end);
    for i in (0..n - 1).rev() {
        let delta = table.s[i + 1] - table.s[i];
        let (lo, hi) = controllable[i + 1];
        let reach = [
            Row { alpha: 2.0 * delta, beta: 1.0, gamma: hi, limit: LimitId(u16::MAX) },
            Row { alpha: -2.0 * delta, beta: -1.0, gamma: -lo, limit: LimitId(u16::MAX) },
        ];
        let rows = stage_rows(table, i, delta).chain(reach);
        controllable[i] = project(rows).ok_or_else(|| infeasible(i))?;
    }
    let (lo0, hi0) = controllable[0];
    if x_start < lo0 * (1.0 - 1e-9) || x_start > hi0 * (1.0 + 1e-9) + 1e-300 {
        return Err(infeasible(0));
    }
    let mut x = Vec::with_capacity(n);
    let mut u = Vec::with_capacity(n - 1);
    let mut t = Vec::with_capacity(n);
    let mut active = Vec::with_capacity(n - 1);
    x.push(x_start);
    t.push(0.0);
    for i in 0..n - 1 {
        let delta = table.s[i + 1] - table.s[i];
        let xi = x[i];
        let (lo, hi) = controllable[i + 1];
        let (_, high) = acceleration_bounds(stage_rows(table, i, delta), xi);
        // Greedy: the largest acceleration that stays controllable, clamped into K_{i+1}
        // against rounding.
        let ui = high.min((hi - xi) / (2.0 * delta)).max((lo - xi) / (2.0 * delta));
        let next = (xi + 2.0 * delta * ui).clamp(lo, hi).max(0.0);
        let ui = (next - xi) / (2.0 * delta);
        let speed_sum = xi.sqrt() + next.sqrt();
        if speed_sum <= 0.0 {
            return Err(ToppError::Stuck { s: table.s[i] });
        }
        let binding = stage_rows(table, i, delta)
            .map(|r| (relative_slack(&r, ui, xi), r.limit))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, limit)| limit);
        active.push(binding);
        u.push(ui);
        t.push(t[i] + 2.0 * delta / speed_sum);
        x.push(next);
    }
    Ok(Timing { s: table.s.clone(), x, u, t, controllable, active })
}

/// The largest `x = ṡ²` the rows of point `i` alone allow (its speed limit curve), counting
/// only rows whose limit passes `keep`; `f64::INFINITY` when they do not bound it.
pub fn limit_curve(table: &ConstraintTable, i: usize, keep: impl Fn(LimitId) -> bool) -> f64 {
    let rows = table.rows(i).iter().copied().filter(|r| keep(r.limit));
    project(rows).map_or(0.0, |(_, hi)| hi)
}
