//! The limits of a timed path, as rows `α u + β x ≤ γ` in `(u, x) = (s̈, ṡ²)` for
//! [`super::topp`]. Each row is scaled so that `γ` is about 1 where the limit is far and the
//! row's relative slack compares across limits.
//!
//! With `q̇ = q' ṡ`, `q̈ = q' u + q'' x`, tool velocity `ṗ = p' ṡ` and acceleration
//! `p̈ = p' u + p'' x`:
//! - joint speed `|q'_j| √x ≤ v_j`: `(q'_j / v_j)² x ≤ 1`;
//! - joint acceleration `|q'_j u + q''_j x| ≤ a_j`;
//! - joint torque `|(M q')_j u + (M q'' + C(q, q') q')_j x + g_j + f_j| ≤ m τ_j` with the
//!   margin `m`, for every friction torque `f_j` the plant can produce there: Coulomb between 0
//!   and `τ_c sign(q'_j)` (it fades as a joint stops), viscous between 0 and `b |q'_j| √x_max`,
//!   its value at the point's top joint speed `x_max`;
//! - tool speed `|p'|² x ≤ v²`;
//! - tool acceleration `‖p' u + p'' x − g‖ ≤ A` (with `g = 0` a plain acceleration limit,
//!   with gravity the specific force a friction grip must hold). In the orthonormal frame
//!   `e₁ = p'/|p'|`, `e₂` along the part of `p''` normal to `e₁` (or of `g` when the path is
//!   straight there), `e₃ = e₁ × e₂`, it is `w₁² + w₂² ≤ A² − (g·e₃)²` with
//!   `w₁ = |p'| u + (p''·e₁) x − g·e₁`, `w₂ = (p''·e₂) x − g·e₂`. Where the path is straight
//!   `w₂` is constant and the disc is an exact interval of `u`; where it curves the disc is
//!   replaced by the inscribed regular polygon of [`POLYGON_SIDES`] sides, at most
//!   `1 − cos(π/64) = 0.12 %` inside it (conservative).

use super::topp::{ConstraintTable, LimitId};
use crate::arm::dynamics::{BodyFrames, rnea_with_frames};
use crate::arm::model::{ArmModel, JointVector};
use nalgebra::Vector3;

/// Share of every limit the planner keeps back for what happens between grid points: the rows
/// hold at the grid points only, and in between the limits drift by O(step²). Measured on the
/// report's arm with 5 mm steps everywhere: up to 0.33 % over within a stage on a 4 cm blend
/// against the grid points' values, 0.11 % over the limit; with the blends at half the step
/// ([`super::geometric::GeometricPath::grid`]) and 0.2 % kept back, the largest share used is 99.9 % (tests at
/// 10× the grid). [`super::optimal::check_motion`] checks the full limits.
pub const GRID_SLACK: f64 = 0.002;

/// Sides of the polygon that stands for a tool-acceleration disc where the path curves.
pub const POLYGON_SIDES: usize = 64;

/// The path and its derivatives with respect to the path parameter at one grid point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint<const N: usize> {
    pub s: f64,
    pub q: JointVector<N>,
    /// `dq/ds`.
    pub dq: JointVector<N>,
    /// `d²q/ds²`.
    pub ddq: JointVector<N>,
    /// Tool tip `p`, m, and `dp/ds`, `d²p/ds²`.
    pub tip: Vector3<f64>,
    pub dtip: Vector3<f64>,
    pub ddtip: Vector3<f64>,
}

/// A family of limits on a timed path.
pub trait PathConstraint<const N: usize> {
    /// How many separately named limits it has (rows carry `first + part`).
    fn parts(&self) -> usize;
    /// Name of limit `part` for reports, e.g. "joint 2 torque".
    fn name(&self, part: usize) -> String;
    /// Appends this family's rows at `point` to the table's current point.
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable);
    /// Why limit `part` cannot be kept at `point` even at rest (for errors).
    fn explain(&self, _point: &PathPoint<N>, part: usize) -> String {
        format!("{} cannot be kept", self.name(part))
    }
}

fn id(first: u16, part: usize) -> LimitId {
    LimitId(first + part as u16)
}

/// `|q̇_j| ≤ max_j`, rad/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSpeed<const N: usize> {
    pub max: [f64; N],
}

impl<const N: usize> PathConstraint<N> for JointSpeed<N> {
    fn parts(&self) -> usize {
        N
    }
    fn name(&self, part: usize) -> String {
        format!("joint {} speed", part + 1)
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        for j in 0..N {
            let k = point.dq[j] / self.max[j];
            if k != 0.0 {
                table.push_row(0.0, k * k, 1.0, id(first, j));
            }
        }
    }
}

/// `|q̈_j| ≤ max_j`, rad/s².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointAcceleration<const N: usize> {
    pub max: [f64; N],
}

impl<const N: usize> PathConstraint<N> for JointAcceleration<N> {
    fn parts(&self) -> usize {
        N
    }
    fn name(&self, part: usize) -> String {
        format!("joint {} acceleration", part + 1)
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        for j in 0..N {
            let (a, b) = (point.dq[j] / self.max[j], point.ddq[j] / self.max[j]);
            table.push_row(a, b, 1.0, id(first, j));
            table.push_row(-a, -b, 1.0, id(first, j));
        }
    }
}

/// `|τ_j| ≤ margin · τ_max,j` with the dynamics of `model` (which carries the gripped piece
/// as its payload, if any) and its friction, N·m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointTorque<const N: usize> {
    pub model: ArmModel<N>,
    /// Fraction of each motor's torque limit the plan may use (the rest is the controller's).
    pub margin: f64,
    /// Joint speed limits used to bound viscous friction, rad/s.
    pub max_speed: [f64; N],
}

impl<const N: usize> JointTorque<N> {
    /// The torque coefficients `(a, b, c)` of `τ = a u + b x + c` at `point`, friction left out.
    pub fn coefficients(&self, point: &PathPoint<N>) -> (JointVector<N>, JointVector<N>, JointVector<N>) {
        let zero = JointVector::<N>::zeros();
        let frames = BodyFrames::new(&self.model, &point.q);
        let weightless = Vector3::zeros();
        let a = rnea_with_frames(&self.model, &frames, &zero, &point.dq, &weightless);
        let b = rnea_with_frames(&self.model, &frames, &point.dq, &point.ddq, &weightless);
        let c = rnea_with_frames(&self.model, &frames, &zero, &zero, &self.model.gravity());
        (a, b, c)
    }
}

impl<const N: usize> PathConstraint<N> for JointTorque<N> {
    fn parts(&self) -> usize {
        N
    }
    fn name(&self, part: usize) -> String {
        format!("joint {} torque", part + 1)
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        let (a, b, c) = self.coefficients(point);
        // The top joint speed at this point sets the largest viscous torque.
        let top_speed = (0..N)
            .filter(|&j| point.dq[j] != 0.0)
            .map(|j| self.max_speed[j] / point.dq[j].abs())
            .fold(f64::INFINITY, f64::min);
        for j in 0..N {
            let link = self.model.link(j);
            let limit = self.margin * link.limits.torque;
            let friction = link.friction;
            // The plant's Coulomb friction τ_c tanh(q̇/ε) lies between 0 and τ_c sign(q'_j)
            // (it fades as the joint stops), the viscous between 0 and its top value: the
            // motor torque lies in [lin + c + low, lin + c + high].
            let coulomb = friction.coulomb * point.dq[j].signum() * f64::from(point.dq[j] != 0.0);
            let viscous = if top_speed.is_finite() { friction.viscous * point.dq[j].abs() * top_speed } else { 0.0 };
            let (low, high) = (coulomb.min(0.0) - viscous, coulomb.max(0.0) + viscous);
            table.push_row(a[j] / limit, b[j] / limit, 1.0 - (c[j] + high) / limit, id(first, j));
            table.push_row(-a[j] / limit, -b[j] / limit, 1.0 + (c[j] + low) / limit, id(first, j));
        }
    }
    fn explain(&self, point: &PathPoint<N>, part: usize) -> String {
        let (_, _, c) = self.coefficients(point);
        let limit = self.model.link(part).limits.torque;
        let coulomb = self.model.link(part).friction.coulomb;
        let friction =
            if coulomb > 0.0 { format!(" (plus up to {coulomb} N·m of Coulomb friction)") } else { String::new() };
        format!(
            "joint {} must hold {:.4} N·m against gravity there{friction}, above {:.0} % of its {limit} N·m torque limit ({:.4} N·m, of which the plan uses {:.4} N·m)",
            part + 1,
            c[part].abs(),
            100.0 * self.margin,
            self.margin * limit,
            (1.0 - GRID_SLACK) * self.margin * limit
        )
    }
}

/// `|ṗ| ≤ max`, m/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolSpeed {
    pub max: f64,
}

impl<const N: usize> PathConstraint<N> for ToolSpeed {
    fn parts(&self) -> usize {
        1
    }
    fn name(&self, _: usize) -> String {
        "tool speed".to_string()
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        let k = point.dtip.norm_squared() / (self.max * self.max);
        if k > 0.0 {
            table.push_row(0.0, k, 1.0, id(first, 0));
        }
    }
}

/// `‖p̈ − gravity‖ ≤ max`, m/s² (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ToolAcceleration {
    pub max: f64,
    pub gravity: Vector3<f64>,
    pub label: String,
}

impl<const N: usize> PathConstraint<N> for ToolAcceleration {
    fn parts(&self) -> usize {
        1
    }
    fn name(&self, _: usize) -> String {
        self.label.clone()
    }
    fn explain(&self, _: &PathPoint<N>, _: usize) -> String {
        format!(
            "{}: holding still takes {:.4} m/s², above its {} m/s² limit (of which the plan uses {:.4} m/s²)",
            self.label,
            self.gravity.norm(),
            self.max,
            (1.0 - GRID_SLACK) * self.max
        )
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        // Straight lines have p'' = 0 exactly; blends curve at 1/(blend length) ≫ 1e-9 per m.
        push_norm_rows(table, &point.dtip, &point.ddtip, &self.gravity, self.max, 1e-9, id(first, 0));
    }
}

/// Rows for `‖a u + b x − c‖ ≤ max` (module docs, with `a`, `b`, `c` for `p'`, `p''`, `g`):
/// an exact interval of `u` where the part of `b` across `a` is at most `straight`, the
/// inscribed polygon of the disc otherwise.
#[allow(clippy::too_many_arguments)]
fn push_norm_rows(
    table: &mut ConstraintTable,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
    max: f64,
    straight: f64,
    limit: LimitId,
) {
    let speed = a.norm();
    if speed == 0.0 {
        return;
    }
    let e1 = a / speed;
    let g = c;
    let normal = b - e1 * b.dot(&e1);
    let curved = normal.norm() > straight;
    let e2 = if curved {
        normal.normalize()
    } else {
        let across = g - e1 * g.dot(&e1);
        across.try_normalize(0.0).unwrap_or_else(|| any_normal(&e1))
    };
    let e3 = e1.cross(&e2);
    let radius_squared = max * max - g.dot(&e3).powi(2);
    let scale = max;
    // w₁ = speed·u + k1·x − g1, w₂ = k2·x − g2.
    let (k1, g1) = (b.dot(&e1), g.dot(&e1));
    let (k2, g2) = (b.dot(&e2), g.dot(&e2));
    if !curved {
        // w₂ = k2·x − g2 with k2 = 0 (b along a): |w₁| ≤ √(R² − g2²).
        let half = radius_squared - g2 * g2;
        if half < 0.0 {
            table.push_row(0.0, 0.0, -1.0, limit);
            return;
        }
        let half = half.sqrt();
        table.push_row(speed / scale, k1 / scale, (half + g1) / scale, limit);
        table.push_row(-speed / scale, -k1 / scale, (half - g1) / scale, limit);
        return;
    }
    if radius_squared < 0.0 {
        table.push_row(0.0, 0.0, -1.0, limit);
        return;
    }
    let inner = radius_squared.sqrt() * (std::f64::consts::PI / POLYGON_SIDES as f64).cos();
    for side in 0..POLYGON_SIDES {
        let angle = 2.0 * std::f64::consts::PI * side as f64 / POLYGON_SIDES as f64;
        let (sin, cos) = angle.sin_cos();
        // cos·w₁ + sin·w₂ ≤ inner
        let alpha = cos * speed;
        let beta = cos * k1 + sin * k2;
        let gamma = inner + cos * g1 + sin * g2;
        let alpha = if alpha.abs() < 1e-12 * speed { 0.0 } else { alpha };
        table.push_row(alpha / scale, beta / scale, gamma / scale, limit);
    }
}

/// The tracking error a carried piece of uncertain mass adds, kept within a budget.
///
/// A computed-torque loop `τ = M̂(q̈_d + K_d ė + K_p e) + ĥ` whose model has the nominal piece
/// while the true one is heavier or lighter by `Δm` feels the extra force `Δm (p̈ − g)` at
/// the tip: `ë + K_d ė + K_p e = M⁻¹ Jᵀ Δm (p̈ − g)` (`J` the tip's linear Jacobian, `M` the
/// arm's inertia with the nominal piece). While the acceleration changes slowly against the
/// loop, `e ≈ K_p⁻¹ M⁻¹ Jᵀ Δm (p̈ − g)` and the tip is off by
/// `δp = J e = Δm W (p̈ − g)`, `W = J K_p⁻¹ M⁻¹ Jᵀ`. Its gravity part is there at rest too (the
/// controller's to remove); the motion adds `Δm W p̈`, which after an acceleration step rises
/// to at most `overshoot` times that (1 for `ζ ≥ 1`, `1 + e^{−πζ/√(1−ζ²)}` below). The
/// limit: `‖W p̈‖ ≤ budget / (Δm · overshoot)`, a norm of `(W p') u + (W p'') x`, in rows as
/// [`ToolAcceleration`]'s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackingBudget<const N: usize> {
    /// The arm with the nominal piece, as the controller models it.
    pub model: ArmModel<N>,
    /// Proportional gains, 1/s², per joint.
    pub kp: [f64; N],
    /// Largest overshoot factor of the joints' loops (1 when all are damped at least critically).
    pub overshoot: f64,
    /// Largest difference between the true and the nominal piece mass, kg.
    pub mass_error: f64,
    /// Largest tracking error the motion may add, m.
    pub budget: f64,
    /// Position servos instead of a computed-torque loop: each one's static stiffness
    /// `kp kt V / R`, N·m/rad ([`crate::sim::actuator::ServoSpec::stiffness`]); `kp` and the
    /// mass matrix are then not used.
    pub stiffness: Option<[f64; N]>,
}

impl<const N: usize> TrackingBudget<N> {
    /// The overshoot factor of a step disturbance on `ë + 2ζω ė + ω² e`: 1 for `ζ ≥ 1`.
    pub fn overshoot_of(damping_ratio: f64) -> f64 {
        if damping_ratio >= 1.0 {
            1.0
        } else {
            let z = damping_ratio.max(0.0);
            1.0 + (-std::f64::consts::PI * z / (1.0 - z * z).sqrt()).exp()
        }
    }

    /// `W = J K_p⁻¹ M⁻¹ Jᵀ` at `q` (m per N): the tip's error per unit of a force at the tip
    /// the computed-torque loop does not know. With servos `W = J K⁻¹ Jᵀ`, `K` their
    /// stiffnesses: the static error of their proportional loops.
    pub fn compliance(&self, q: &JointVector<N>) -> nalgebra::Matrix3<f64> {
        let chain = crate::arm::kinematics::FrameChain::new(&self.model, q);
        let (jacobian, _) = chain.point_jacobian(&chain.tip(), N - 1);
        if let Some(stiffness) = &self.stiffness {
            let inverse =
                nalgebra::SMatrix::<f64, N, N>::from_diagonal(&JointVector::<N>::from(stiffness.map(|k| 1.0 / k)));
            return jacobian * inverse * jacobian.transpose();
        }
        let mass = crate::arm::dynamics::mass_matrix(&self.model, q);
        let inverse = mass.try_inverse().unwrap_or_else(nalgebra::SMatrix::<f64, N, N>::zeros);
        let gains = nalgebra::SMatrix::<f64, N, N>::from_diagonal(&JointVector::<N>::from(self.kp.map(|k| 1.0 / k)));
        jacobian * gains * inverse * jacobian.transpose()
    }

    /// The largest `‖W p̈‖` the budget allows, m/kg.
    pub fn limit(&self) -> f64 {
        self.budget / (self.mass_error * self.overshoot)
    }
}

impl<const N: usize> PathConstraint<N> for TrackingBudget<N> {
    fn parts(&self) -> usize {
        1
    }
    fn name(&self, _: usize) -> String {
        "tracking budget (carried piece)".to_string()
    }
    fn push_rows(&self, point: &PathPoint<N>, first: u16, table: &mut ConstraintTable) {
        // No error to bound, or a budget too large to bind (its limit overflows).
        if !(self.mass_error > 0.0 && self.limit().is_finite()) {
            return;
        }
        // W in s²/kg, so ‖W p̈‖ in m/kg; the rows are scaled by the limit. On straight lines
        // W p'' = 0 exactly.
        let w = self.compliance(&point.q);
        let (a, b) = (w * point.dtip, w * point.ddtip);
        push_norm_rows(table, &a, &b, &Vector3::zeros(), self.limit(), 1e-9 * b.norm(), id(first, 0));
    }
}

/// A unit vector normal to the unit vector `v`.
fn any_normal(v: &Vector3<f64>) -> Vector3<f64> {
    let other = if v.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    v.cross(&other).normalize()
}

/// The rows of every constraint at every point, and the names of their limits (the index of
/// a name is its [`LimitId`]).
pub fn constraint_table<const N: usize>(
    points: &[PathPoint<N>],
    constraints: &[&dyn PathConstraint<N>],
) -> (ConstraintTable, Vec<String>) {
    let mut names = Vec::new();
    let mut firsts = Vec::with_capacity(constraints.len());
    for c in constraints {
        firsts.push(names.len() as u16);
        names.extend((0..c.parts()).map(|k| c.name(k)));
    }
    let mut table = ConstraintTable::new();
    for point in points {
        table.push_point(point.s);
        for (c, first) in constraints.iter().zip(&firsts) {
            c.push_rows(point, *first, &mut table);
        }
    }
    (table, names)
}
