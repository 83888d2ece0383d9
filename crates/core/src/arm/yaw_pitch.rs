//! The dynamics of the arm family chessarm plans for — a base yaw joint, then three pitch
//! joints with parallel horizontal axes, then the tool — in closed form.
//!
//! **The yaw frame.** Let `Y` be the base frame turned by the yaw angle `ψ = q₁ + θ₁` about the
//! vertical: the base axis is `Y`'s z axis, every pitch axis is `±y`, and every body's pose in
//! `Y` depends on the pitch angles only. With `β_j = Σ_{i≤j} α_i` (the twists so far, ±90° for
//! the first three frames in the family) and the cumulative pitch `φ_j = φ_{j−1} + σ_j (q_j + θ_j)`
//! (`φ₀ = 0`, `σ_j = −sin β_{j−1} = ±1` the direction of joint j's axis along `y`), frame j is
//! `R_j = R_y(φ_j) R_x(β_j)` with origin `o_j = o_{j−1} + R_y(φ_j) ℓ_j`,
//! `ℓ_j = R_x(β_{j−1}) (a_j, 0, d_j)` (0-based: `o₀ = (a₀, 0, d₀)`). So forward kinematics is
//! three planar rotations `R_y(φ)v = (c v_x + s v_z, v_y, −s v_x + c v_z)` of constant vectors:
//! body j's centre of mass is `c_j = o_{j−1} + R_y(φ_j) ĉ_j` and its inertia
//! `R_y(φ_j) Î_j R_y(φ_j)ᵀ`, with `ĉ_j`, `Î_j` fixed once per model. Every `y` coordinate is a
//! constant (`y_j` of body j), and `d/dφ (R_y(φ)v)_x = (R_y(φ)v)_z`, `d/dφ (R_y(φ)v)_z =
//! −(R_y(φ)v)_x`. Torques do not depend on `ψ` (gravity is vertical).
//!
//! **Kinetic energy** in the coordinates `u = (ψ, φ₁, φ₂, φ₃)`, rates `r = ψ̇`, `w_k = φ̇_k`:
//! a point at `(x, y, z)` of `Y` moves at `(ẋ − r y, r x, ż)` and body j spins at `(0, w_j, r)`,
//! so `T = ½ M_ψψ r² + r Σ_k M_ψk w_k + ½ Σ_kl M_kl w_k w_l` with
//! - `M_ψψ = Σ_j m_j (x_j² + y_j²) + I_zz,j(φ_j)` (body 0 a constant),
//! - `M_ψk = I_yz,k(φ_k) − (R_y(φ_k) E_k)_z`, `E_k = Σ_{j≥k} m_j y_j a_k^{(j)}`,
//! - `M_kk = Σ_{j≥k} m_j |a_k^{(j)}|² + Î_yy,k` (constant) and, for `k < l`,
//!   `M_kl = u_k · g_l` with `u_k = R_y(φ_k) ℓ_k`, `g_l = R_y(φ_l) G_l`, `G_l = Σ_{j≥l} m_j a_l^{(j)}`,
//!
//! where `a_k^{(j)}` is `ĉ_k` for `j = k` and `ℓ_k` for `j > k` (planar `x, z` parts in the
//! dot products), and the rotated inertia has `I_zz(φ) = Ī − (h cos 2φ + Î_xz sin 2φ)`,
//! `I_yz(φ) = Î_yz cos φ − Î_xy sin φ`, `I_xy(φ) = Î_xy cos φ + Î_yz sin φ` (`Ī`, `h` the mean
//! and half difference of `Î_xx` and `Î_zz`).
//!
//! **Bias torques** from Lagrange's equations: `M_kl` depends on `φ_l − φ_k` only and `M_ψk` on
//! `φ_k` only, so the Coriolis terms collapse to squares of the rates:
//! `b_ψ = r Σ_k D_k w_k + Σ_k K_k w_k²`,
//! `b_k = Σ_{l≠k} P_kl w_l² − ½ D_k r² + g_z (R_y(φ_k) G_k)_x`, with
//! `D_k = ∂M_ψψ/∂φ_k = 2 (m_k x_k (R_y(φ_k) ĉ_k)_z + (u_k)_z Σ_{j>k} m_j x_j) + I_zz,k′`,
//! `K_k = dM_ψk/dφ_k = (R_y(φ_k) E_k)_x − I_xy,k(φ_k)` and `P_kl = ∂M_kl/∂φ_l =
//! u_kx g_lz − u_kz g_lx` (`= −(u_k × g_l)_y`; and `P_lk = −P_kl`).
//!
//! **Joint coordinates**: `u̇ = S q̇` with `S` the signs `σ` summed down the pitch joints, so
//! `M(q) = Sᵀ M_u S + diag(rotor)` (`M_ij = σ_i σ_j Σ_{k≥i, l≥j} M_kl`) and `τ_bias = Sᵀ b`
//! (`τ_i = σ_i Σ_{k≥i} b_k`). A configuration costs three sines and cosines and ~200 flops; a
//! bias at it ~45 flops, inverse dynamics `M q̈ + τ_bias` 16 more.
//!
//! Every kernel is written once over [`Real`]: one run (`f64`) or several side by side
//! ([`crate::lanes::Lanes`]), the same operations in the same order, so a lane equals the scalar
//! result bit for bit. The general RNEA/CRBA of [`super::dynamics`] stays the test oracle and the
//! path for every other arm.

// The kernels index several arrays by joint, as their equations do.
#![allow(clippy::needless_range_loop)]

use super::link::{COULOMB_SMOOTHING, Inertial, Link};
use crate::lanes::Real;
use nalgebra::{Matrix3, Vector3};

/// `|cos β|` (or `|sin β|`) below which a twist counts as exactly ±90° (or 0°/180°), and the
/// relative size of a horizontal gravity component below which gravity counts as vertical: the
/// rounding of `π/2` in a file, far below anything the physics could notice.
pub const STRUCTURE_TOLERANCE: f64 = 1e-12;

/// Why a model is outside the yaw–pitch family (the general algorithms serve it instead).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("not a yaw–pitch arm: {0}")]
pub struct NotYawPitch(pub String);

/// A symmetric 3×3 tensor by its six entries, kg·m².
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sym<S> {
    pub xx: S,
    pub yy: S,
    pub zz: S,
    pub xy: S,
    pub xz: S,
    pub yz: S,
}

/// The constants of one arm of the family (or of `L` arms, one per lane), fixed once per
/// model: the yaw-frame quantities of the module's equations, SI units. Index `j` is joint
/// (body) `j`, 0-based; the pitch quantities use 1..3 and leave entry 0 zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct YawPitch<S> {
    /// `θ_j`, the DH angle offsets, rad.
    pub offset: [S; 4],
    /// `σ_j` (±1) for the pitch joints; `sign[0]` is 1.
    pub sign: [S; 4],
    /// `o₀`: the point of joint 2 in `Y`, m.
    pub shoulder: [S; 3],
    /// `ℓ_j` (j = 1..3): the next frame's origin before `R_y(φ_j)`, m.
    pub link: [[S; 3]; 4],
    /// For j ≥ 1, `ĉ_j` (before `R_y(φ_j)`, from `o_{j−1}`); body 0's centre of mass in `Y`, m.
    pub com: [[S; 3]; 4],
    /// Body masses (links, motors, payload), kg.
    pub mass: [S; 4],
    /// `G_k = m_k ĉ_k + (Σ_{j>k} m_j) ℓ_k`, its `x` and `z`, kg·m.
    pub moment: [[S; 2]; 4],
    /// The yaw coupling's constants `(Î_xy − E_x, Î_yz − E_z)` of body k, with
    /// `E_k = m_k y_k ĉ_k + (Σ_{j>k} m_j y_j) ℓ_k`, kg·m²: `R_y(φ_k)` of them is `(−K_k, M_ψk)`.
    pub coupling: [[S; 2]; 4],
    /// The constant part of `M(q)`'s pitch block: `σ_i σ_j Σ_{k≥max(i,j)} M_kk`, with `M_kk`
    /// the constant diagonal of the pitch block in `u`, plus the rotor inertia on the diagonal,
    /// kg·m² (row and column 0 zero).
    pub pitch_base: [[S; 4]; 4],
    /// The constant part of `M(q)₁₁`: body 0's `I_zz + m₀ (x₀² + y₀²)`, `Σ_{j≥1} (m_j y_j² + Ī_j)`
    /// and the base rotor, kg·m².
    pub yaw_inertia: S,
    /// The tool tip's `y` in `Y`, m.
    pub tip_y: S,
    /// Where `Y`'s origin (on the base axis) stands in the base frame, m (the model's base).
    pub base: [S; 3],
    /// `(h_j, Î_xz,j)` (j ≥ 1), `h = (Î_xx − Î_zz)/2`: `R_y(2φ_j)` of them is
    /// `(Ī_j − I_zz,j(φ_j), −I_zz,j′(φ_j)/2)`, kg·m².
    pub spin: [[S; 2]; 4],
    /// Rotor inertias (armature), kg·m².
    pub rotor: [S; 4],
    /// Gravity along the base z axis, m/s² (−9.8 for the report).
    pub gravity_z: S,
    /// Joint friction, N·m·s/rad and N·m.
    pub viscous: [S; 4],
    pub coulomb: [S; 4],
    /// Whether any joint (of any lane) has friction.
    pub has_friction: bool,
}

fn rx(beta_sin: f64, beta_cos: f64) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, 0.0, 0.0, beta_cos, -beta_sin, 0.0, beta_sin, beta_cos)
}

fn sym(m: &Matrix3<f64>) -> Sym<f64> {
    Sym { xx: m[(0, 0)], yy: m[(1, 1)], zz: m[(2, 2)], xy: m[(0, 1)], xz: m[(0, 2)], yz: m[(1, 2)] }
}

fn array(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

impl YawPitch<f64> {
    /// The constants of the arm with these `links`, moving `bodies` (each link with the next
    /// joint's motor, the last with the payload, in its DH frame), `gravity` (m/s²) and DH frame
    /// 0 at `base` (m), all in the base frame, or why it is not of the family: joint 1 must turn
    /// about the vertical with a ±90° twist (`α₁`), `α₂` and `α₃` must be 0 or 180° (parallel
    /// pitch axes), gravity vertical. The tool's twist `α₄`, the offsets `a`, `d`, `θ`, the
    /// inertias, motors, payload and friction are free. A model keeps the constants of its own
    /// arm (`ArmModel::yaw_pitch`).
    pub fn new<const N: usize>(
        links: &[Link; N],
        bodies: &[Inertial; N],
        gravity: Vector3<f64>,
        base: Vector3<f64>,
    ) -> Result<Self, NotYawPitch> {
        if N != 4 {
            return Err(NotYawPitch(format!("{N} joints (the family has 4)")));
        }
        let g = gravity;
        if g.x.abs().max(g.y.abs()) > STRUCTURE_TOLERANCE * g.norm() {
            return Err(NotYawPitch(format!("gravity ({}, {}, {}) m/s² is not along the base axis", g.x, g.y, g.z)));
        }
        // (sin β_j, cos β_j) by angle addition of the links' twists, the first three made exact.
        let mut beta = [(0.0, 1.0); 4];
        let mut running = (0.0f64, 1.0f64);
        for j in 0..4 {
            let (sa, ca) = crate::lanes::sin_cos(links[j].dh.alpha);
            running = (running.0 * ca + running.1 * sa, running.1 * ca - running.0 * sa);
            if j < 3 {
                if running.1.abs() > STRUCTURE_TOLERANCE {
                    let what = if j == 0 { "alpha = ±90°" } else { "alpha = 0 or 180°" };
                    return Err(NotYawPitch(format!(
                        "link {} needs {what} (joint {}'s axis horizontal and parallel to the pitch axes), has alpha = {} rad",
                        j + 1,
                        j + 2,
                        links[j].dh.alpha
                    )));
                }
                running = (running.0.signum(), 0.0);
            }
            beta[j] = running;
        }
        let turn = |j: usize| rx(beta[j].0, beta[j].1);
        let mut sign = [1.0; 4];
        for j in 1..4 {
            sign[j] = -beta[j - 1].0;
        }
        let dh = |j: usize| links[j].dh;
        let shoulder = [dh(0).a, 0.0, dh(0).d];
        let mut link = [[0.0; 3]; 4];
        let mut com = [[0.0; 3]; 4];
        let mut inertia = [sym(&Matrix3::zeros()); 4];
        let (mut inertia_mean, mut spin) = ([0.0; 4], [[0.0; 2]; 4]);
        for j in 0..4 {
            let body = &bodies[j];
            let rotation = turn(j);
            let turned = rotation * body.inertia * rotation.transpose();
            inertia[j] = sym(&turned);
            if j == 0 {
                com[0] = array(Vector3::from(shoulder) + rotation * body.com);
            } else {
                let offset = turn(j - 1) * Vector3::new(dh(j).a, 0.0, dh(j).d);
                link[j] = array(offset);
                com[j] = array(offset + rotation * body.com);
                inertia_mean[j] = 0.5 * (turned[(0, 0)] + turned[(2, 2)]);
                spin[j] = [0.5 * (turned[(0, 0)] - turned[(2, 2)]), turned[(0, 2)]];
            }
        }
        let mass: [f64; 4] = std::array::from_fn(|j| bodies[j].mass);
        let rotor: [f64; 4] = std::array::from_fn(|j| links[j].rotor_inertia);
        // y_j, the constant y of body j's centre of mass, and the sums over the bodies beyond k.
        let mut height = [0.0; 4];
        let mut y_so_far = shoulder[1];
        for j in 1..4 {
            height[j] = y_so_far + com[j][1];
            y_so_far += link[j][1];
        }
        let beyond = |k: usize, f: &dyn Fn(usize) -> f64| (k + 1..4).map(f).sum::<f64>();
        let planar = |v: &[f64; 3]| v[0] * v[0] + v[2] * v[2];
        let mut moment = [[0.0; 2]; 4];
        let mut coupling = [[0.0; 2]; 4];
        let mut pitch_inertia = [0.0; 4];
        for k in 1..4 {
            let (distal_mass, distal_height) = (beyond(k, &|j| mass[j]), beyond(k, &|j| mass[j] * height[j]));
            let (c, l) = (&com[k], &link[k]);
            moment[k] = [mass[k] * c[0] + distal_mass * l[0], mass[k] * c[2] + distal_mass * l[2]];
            let own = mass[k] * height[k];
            let e = [own * c[0] + distal_height * l[0], own * c[2] + distal_height * l[2]];
            coupling[k] = [inertia[k].xy - e[0], inertia[k].yz - e[1]];
            pitch_inertia[k] = mass[k] * planar(c) + distal_mass * planar(l) + inertia[k].yy;
        }
        let mut pitch_base = [[0.0; 4]; 4];
        for i in 1..4 {
            for j in 1..4 {
                let shared: f64 = (i.max(j)..4).map(|k| pitch_inertia[k]).sum();
                pitch_base[i][j] = sign[i] * sign[j] * shared + if i == j { rotor[i] } else { 0.0 };
            }
        }
        let yaw_inertia = inertia[0].zz
            + mass[0] * (com[0][0] * com[0][0] + com[0][1] * com[0][1])
            + (1..4).map(|j| mass[j] * height[j] * height[j] + inertia_mean[j]).sum::<f64>()
            + rotor[0];
        let viscous = std::array::from_fn(|j| links[j].friction.viscous);
        let coulomb = std::array::from_fn(|j| links[j].friction.coulomb);
        Ok(Self {
            offset: std::array::from_fn(|j| dh(j).theta_offset),
            sign,
            shoulder,
            link,
            com,
            mass,
            moment,
            coupling,
            pitch_base,
            yaw_inertia,
            tip_y: y_so_far,
            base: array(base),
            spin,
            rotor,
            gravity_z: g.z,
            viscous,
            coulomb,
            has_friction: viscous.iter().chain(&coulomb).any(|v| *v != 0.0),
        })
    }
}

impl<const L: usize> YawPitch<crate::lanes::Lanes<L>> {
    /// `L` arms side by side: lane `i` holds `arms[i]`.
    pub fn gather(arms: [&YawPitch<f64>; L]) -> Self {
        use crate::lanes::Lanes;
        let lanes = |f: &dyn Fn(&YawPitch<f64>) -> f64| Lanes(arms.map(f));
        let v4 = |f: &dyn Fn(&YawPitch<f64>, usize) -> f64| std::array::from_fn(|j| lanes(&|a| f(a, j)));
        let v3 = |f: &dyn Fn(&YawPitch<f64>, usize) -> f64| std::array::from_fn(|k| lanes(&|a| f(a, k)));
        let v2 = |f: &dyn Fn(&YawPitch<f64>, usize) -> f64| std::array::from_fn(|k| lanes(&|a| f(a, k)));
        let m4 = |f: &dyn Fn(&YawPitch<f64>, usize, usize) -> f64| {
            std::array::from_fn(|i| std::array::from_fn(|j| lanes(&|a| f(a, i, j))))
        };
        Self {
            offset: v4(&|a, j| a.offset[j]),
            sign: v4(&|a, j| a.sign[j]),
            shoulder: v3(&|a, k| a.shoulder[k]),
            link: std::array::from_fn(|j| v3(&|a, k| a.link[j][k])),
            com: std::array::from_fn(|j| v3(&|a, k| a.com[j][k])),
            mass: v4(&|a, j| a.mass[j]),
            moment: std::array::from_fn(|j| v2(&|a, k| a.moment[j][k])),
            coupling: std::array::from_fn(|j| v2(&|a, k| a.coupling[j][k])),
            pitch_base: m4(&|a, i, j| a.pitch_base[i][j]),
            yaw_inertia: lanes(&|a| a.yaw_inertia),
            tip_y: lanes(&|a| a.tip_y),
            base: v3(&|a, k| a.base[k]),
            spin: std::array::from_fn(|j| v2(&|a, k| a.spin[j][k])),
            rotor: v4(&|a, j| a.rotor[j]),
            gravity_z: lanes(&|a| a.gravity_z),
            viscous: v4(&|a, j| a.viscous[j]),
            coulomb: v4(&|a, j| a.coulomb[j]),
            has_friction: arms.iter().any(|a| a.has_friction),
        }
    }

    /// Lane `i`'s constants (as they were gathered; `has_friction` from the lane's own values).
    pub fn lane(&self, i: usize) -> YawPitch<f64> {
        let v2 = |v: &[crate::lanes::Lanes<L>; 2]| v.map(|x| x.get(i));
        let v3 = |v: &[crate::lanes::Lanes<L>; 3]| v.map(|x| x.get(i));
        let v4 = |v: &[crate::lanes::Lanes<L>; 4]| v.map(|x| x.get(i));
        let viscous = v4(&self.viscous);
        let coulomb = v4(&self.coulomb);
        YawPitch {
            offset: v4(&self.offset),
            sign: v4(&self.sign),
            shoulder: v3(&self.shoulder),
            link: self.link.map(|v| v3(&v)),
            com: self.com.map(|v| v3(&v)),
            mass: v4(&self.mass),
            moment: self.moment.map(|v| v2(&v)),
            coupling: self.coupling.map(|v| v2(&v)),
            pitch_base: self.pitch_base.map(|row| v4(&row)),
            yaw_inertia: self.yaw_inertia.get(i),
            tip_y: self.tip_y.get(i),
            base: v3(&self.base),
            spin: self.spin.map(|v| v2(&v)),
            rotor: v4(&self.rotor),
            gravity_z: self.gravity_z.get(i),
            viscous,
            coulomb,
            has_friction: viscous.iter().chain(&coulomb).any(|v| *v != 0.0),
        }
    }
}

/// Largest angle step (rad) a configuration is moved by series ([`Real::small_sin_cos`]);
/// beyond it the sines and cosines are computed afresh.
const SERIES_STEP: f64 = 0.05;

/// The yaw angle and the cumulative pitch angles `(ψ, φ₁, φ₂, φ₃)` with the sines and cosines
/// of the pitches, rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Angles<S> {
    pub angle: [S; 4],
    pub sin: [S; 4],
    pub cos: [S; 4],
}

impl<S: Real> Angles<S> {
    /// At joint angles `q`; the yaw's sine and cosine are left to [`Configuration::tip_in_base`].
    #[inline(always)]
    pub fn new(model: &YawPitch<S>, q: &[S; 4]) -> Self {
        let mut angles = Self { angle: [S::splat(0.0); 4], sin: [S::splat(0.0); 4], cos: [S::splat(1.0); 4] };
        angles.set(model, q);
        angles
    }

    /// [`Angles::new`] in place (every entry written: no copy of the whole).
    #[inline(always)]
    pub fn set(&mut self, model: &YawPitch<S>, q: &[S; 4]) {
        let Self { angle, sin, cos } = self;
        angle[0] = q[0] + model.offset[0];
        angle[1] = model.sign[1] * (q[1] + model.offset[1]);
        for j in 2..4 {
            angle[j] = angle[j - 1] + model.sign[j] * (q[j] + model.offset[j]);
        }
        (sin[0], cos[0]) = (S::splat(0.0), S::splat(1.0));
        // Written out, not a loop over the joints: LLVM vectorised such a loop across the three
        // joints (masked 256-bit registers, with gathers and scatters between lanes) instead of
        // across the lanes.
        (sin[1], cos[1]) = angle[1].sin_cos();
        (sin[2], cos[2]) = angle[2].sin_cos();
        (sin[3], cos[3]) = angle[3].sin_cos();
    }

    /// The same for the joints moved by `delta` (rad): the pitches by angle addition with the
    /// series of each step when it is below `SERIES_STEP`, afresh otherwise (lane by lane).
    #[inline(always)]
    pub fn shifted(&self, model: &YawPitch<S>, delta: &[S; 4]) -> Self {
        let mut out = *self;
        self.shift_into(model, delta, &mut out);
        out
    }

    /// [`Angles::shifted`] into `out` (every entry written: no copy of the whole).
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(|s| ≤ step)` takes NaN, as `all(small)` did
    pub fn shift_into(&self, model: &YawPitch<S>, delta: &[S; 4], out: &mut Self) {
        (out.sin[0], out.cos[0]) = (self.sin[0], self.cos[0]);
        out.angle[0] = self.angle[0] + delta[0];
        let mut step = S::splat(0.0);
        for j in 1..4 {
            step += model.sign[j] * delta[j];
            out.angle[j] = self.angle[j] + step;
            let (sd, cd) = step.small_sin_cos();
            let (sin, cos) = (self.sin[j] * cd + self.cos[j] * sd, self.cos[j] * cd - self.sin[j] * sd);
            let angle = out.angle[j];
            let small = |i: usize| step.lane(i).abs() <= SERIES_STEP;
            // A NaN step is not small: the lane's sine is computed afresh (and is NaN).
            if step.lanes_where(|s| !(s.abs() <= SERIES_STEP)) == 0 {
                (out.sin[j], out.cos[j]) = (sin, cos);
            } else {
                out.sin[j] =
                    S::from_fn(|i| if small(i) { sin.lane(i) } else { crate::lanes::sin_cos(angle.lane(i)).0 });
                out.cos[j] =
                    S::from_fn(|i| if small(i) { cos.lane(i) } else { crate::lanes::sin_cos(angle.lane(i)).1 });
            }
        }
    }
}

/// `R_y(φ) v` in the plane, `(x, z)`, for `(sin φ, cos φ) = (s, c)` and `v = (x, ·, z)`.
#[inline(always)]
fn turn<S: Real>(s: S, c: S, x: S, z: S) -> [S; 2] {
    [c * x + s * z, c * z - s * x]
}

/// Everything about one configuration the dynamics needs: the angles, the tool tip in `Y`,
/// `M(q)` and its inverse, and the derivatives of `M_u` and the gravity levers of the
/// module's bias torques.
///
/// Every entry is written by [`Configuration::refresh`] (those of index 0 of the pitch arrays
/// stay zero), so two configurations of one model at the same angles are equal (and print the
/// same) however they were reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Configuration<S> {
    pub angles: Angles<S>,
    /// The tool tip in `Y`, m.
    pub tip: [S; 3],
    /// `D_k = ∂M_ψψ/∂φ_k`, kg·m²/rad (k = 1..3).
    yaw_slope: [S; 4],
    /// `K_k = dM_ψk/dφ_k`, kg·m²/rad (k = 1..3).
    coupling_slope: [S; 4],
    /// `P_kl = ∂M_kl/∂φ_l` for `(k, l)` = (1, 2), (1, 3), (2, 3), kg·m²/rad.
    pitch_slope: [S; 3],
    /// `(R_y(φ_k) G_k)_x`, kg·m: `g_z` times it is pitch k's gravity torque in `u`.
    lever: [S; 4],
    /// `M(q)`, both triangles, kg·m².
    pub mass_matrix: [[S; 4]; 4],
    pub inverse: Inverse<S>,
}

impl<S: Real> Configuration<S> {
    /// At the configuration of `angles` (rad): kinematics, `M` and its inverse. Whether the
    /// inverse is usable is [`Inverse::positive_definite`]'s to say.
    #[inline(always)]
    pub fn new(model: &YawPitch<S>, angles: Angles<S>) -> Self {
        let zero = S::splat(0.0);
        let mut configuration = Self {
            angles,
            tip: [zero; 3],
            yaw_slope: [zero; 4],
            coupling_slope: [zero; 4],
            pitch_slope: [zero; 3],
            lever: [zero; 4],
            mass_matrix: [[zero; 4]; 4],
            inverse: Inverse::zeros(),
        };
        configuration.set(model, angles);
        configuration
    }

    /// [`Configuration::new`] in place: scratch refilled every stage without moving it.
    #[inline(always)]
    pub fn set(&mut self, model: &YawPitch<S>, angles: Angles<S>) {
        self.angles = angles;
        self.refresh(model);
    }

    /// Everything of [`Configuration::set`] from the angles already in `self.angles` (written
    /// in place by [`Angles::set`] or [`Angles::shift_into`], without a copy). Returns the lanes
    /// whose `M` is not positive definite ([`Inverse::set`]).
    #[inline(always)]
    pub fn refresh(&mut self, model: &YawPitch<S>) -> u64 {
        self.refresh_mass_matrix(model);
        self.inverse.set(&self.mass_matrix)
    }

    /// [`Configuration::refresh`] without the inverse, which is left as it was: for `M`, the
    /// bias and the tip alone (a controller's terms), not for accelerations.
    #[inline(always)]
    pub fn refresh_mass_matrix(&mut self, model: &YawPitch<S>) {
        let two = S::splat(2.0);
        let Self { angles, tip, yaw_slope, coupling_slope, pitch_slope, lever, mass_matrix, .. } = self;
        // Per pitch body k (a macro, so that every index is a constant): the rotated link `u_k`,
        // centre of mass `R ĉ_k` and first moment `g_k`, the yaw coupling `(−K_k, M_ψk)` and, by the
        // double angle, the inertia's `(Ī_k − I_zz,k, −I_zz,k′/2)`.
        macro_rules! body {
            ($k:literal) => {{
                let k: usize = $k;
                let (s, c) = (angles.sin[k], angles.cos[k]);
                let (l, h, g) = (&model.link[k], &model.com[k], &model.moment[k]);
                let (e, i) = (&model.coupling[k], &model.spin[k]);
                let (c2, s2) = (c * c - s * s, two * s * c);
                (
                    turn(s, c, l[0], l[2]),
                    turn(s, c, h[0], h[2]),
                    turn(s, c, g[0], g[1]),
                    turn(s, c, e[0], e[1]),
                    turn(s2, c2, i[0], i[1]),
                )
            }};
        }
        let (u1, c1, g1, e1, i1) = body!(1);
        let (u2, c2, g2, e2, i2) = body!(2);
        let (u3, c3, g3, e3, i3) = body!(3);
        // Forward kinematics in the plane: the joint points' and centres' x, the tip.
        let o1 = [model.shoulder[0] + u1[0], model.shoulder[2] + u1[1]];
        let o2 = [o1[0] + u2[0], o1[1] + u2[1]];
        *tip = [o2[0] + u3[0], model.tip_y, o2[1] + u3[1]];
        let x1 = model.shoulder[0] + c1[0];
        let x2 = o1[0] + c2[0];
        let x3 = o2[0] + c3[0];
        let (mx1, mx2, mx3) = (model.mass[1] * x1, model.mass[2] * x2, model.mass[3] * x3);
        // M_u's yaw row and its derivatives.
        let yaw = model.yaw_inertia + ((mx1 * x1 - i1[0]) + (mx2 * x2 - i2[0]) + (mx3 * x3 - i3[0]));
        *yaw_slope = [
            S::splat(0.0),
            two * ((mx1 * c1[1] + u1[1] * (mx2 + mx3)) - i1[1]),
            two * ((mx2 * c2[1] + u2[1] * mx3) - i2[1]),
            two * (mx3 * c3[1] - i3[1]),
        ];
        let couple = [e1[1], e2[1], e3[1]];
        *coupling_slope = [S::splat(0.0), -e1[0], -e2[0], -e3[0]];
        // M_u's pitch block off the diagonal, and its derivatives.
        let dot = |u: &[S; 2], g: &[S; 2]| u[0] * g[0] + u[1] * g[1];
        let cross = |u: &[S; 2], g: &[S; 2]| u[0] * g[1] - u[1] * g[0];
        let (a12, a13, a23) = (dot(&u1, &g2), dot(&u1, &g3), dot(&u2, &g3));
        *pitch_slope = [cross(&u1, &g2), cross(&u1, &g3), cross(&u2, &g3)];
        *lever = [S::splat(0.0), g1[0], g2[0], g3[0]];
        // M(q) = Sᵀ M_u S + rotors: the sums down the pitch joints, signed.
        let base = &model.pitch_base;
        let sign = &model.sign;
        let twice23 = a23 + a23;
        let m = mass_matrix;
        m[0][0] = yaw;
        m[0][3] = sign[3] * couple[2];
        m[0][2] = sign[2] * (couple[1] + couple[2]);
        m[0][1] = sign[1] * (couple[0] + (couple[1] + couple[2]));
        m[3][3] = base[3][3];
        m[2][3] = base[2][3] + (sign[2] * sign[3]) * a23;
        m[2][2] = base[2][2] + twice23;
        m[1][3] = base[1][3] + (sign[1] * sign[3]) * (a13 + a23);
        m[1][2] = base[1][2] + (sign[1] * sign[2]) * ((a12 + a13) + twice23);
        m[1][1] = base[1][1] + two * ((a12 + a13) + a23);
        for i in 0..4 {
            for j in i + 1..4 {
                m[j][i] = m[i][j];
            }
        }
    }

    /// The tool tip in the base frame, m: `base + R_z(ψ)` of the tip in `Y`, with `base` the
    /// model's [`YawPitch::base`].
    #[inline(always)]
    pub fn tip_in_base(&self, base: &[S; 3]) -> [S; 3] {
        let (s, c) = self.angles.angle[0].sin_cos();
        let [bx, by, bz] = *base;
        [bx + (c * self.tip[0] - s * self.tip[1]), by + (s * self.tip[0] + c * self.tip[1]), bz + self.tip[2]]
    }

    /// `C(q, q̇) q̇ + g(q)`, N·m: the module's `b` from the rates, then `Sᵀ b`.
    #[inline(always)]
    pub fn bias(&self, model: &YawPitch<S>, qd: &[S; 4]) -> [S; 4] {
        let sign = &model.sign;
        let r = qd[0];
        let w1 = sign[1] * qd[1];
        let w2 = w1 + sign[2] * qd[2];
        let w3 = w2 + sign[3] * qd[3];
        let (s1, s2, s3) = (w1 * w1, w2 * w2, w3 * w3);
        let half_r2 = r * r * S::splat(0.5);
        let (d, k, p, g) = (&self.yaw_slope, &self.coupling_slope, &self.pitch_slope, &self.lever);
        let gz = model.gravity_z;
        let yaw = r * (d[1] * w1 + d[2] * w2 + d[3] * w3) + (k[1] * s1 + k[2] * s2 + k[3] * s3);
        let b1 = gz * g[1] + (p[0] * s2 + p[1] * s3) - d[1] * half_r2;
        let b2 = gz * g[2] + (p[2] * s3 - p[0] * s1) - d[2] * half_r2;
        let b3 = gz * g[3] - (p[1] * s1 + p[2] * s2) - d[3] * half_r2;
        let b23 = b2 + b3;
        [yaw, sign[1] * (b1 + b23), sign[2] * b23, sign[3] * b3]
    }

    /// `M q̈ + C q̇ + g`, N·m (friction not included; the rotors' inertia is in `M`).
    #[inline(always)]
    pub fn inverse_dynamics(&self, model: &YawPitch<S>, qd: &[S; 4], qdd: &[S; 4]) -> [S; 4] {
        let bias = self.bias(model, qd);
        let m = &self.mass_matrix;
        crate::lanes::array4(|i| bias[i] + (m[i][0] * qdd[0] + m[i][1] * qdd[1] + m[i][2] * qdd[2] + m[i][3] * qdd[3]))
    }

    /// `q̈ = M⁻¹ (τ + τ_friction(q̇) − bias)`, rad/s².
    #[inline(always)]
    pub fn acceleration_with_bias(&self, model: &YawPitch<S>, qd: &[S; 4], torque: &[S; 4], bias: &[S; 4]) -> [S; 4] {
        let mut net = [S::splat(0.0); 4];
        if model.has_friction {
            let friction = friction(model, qd);
            for j in 0..4 {
                net[j] = torque[j] + friction[j] - bias[j];
            }
        } else {
            for j in 0..4 {
                net[j] = torque[j] - bias[j];
            }
        }
        self.inverse.solve(&net)
    }

    /// [`Configuration::acceleration_with_bias`] with the bias at `qd` computed here.
    #[inline(always)]
    pub fn acceleration(&self, model: &YawPitch<S>, qd: &[S; 4], torque: &[S; 4]) -> [S; 4] {
        self.acceleration_with_bias(model, qd, torque, &self.bias(model, qd))
    }
}

/// Joint friction `−(b q̇ + τ_c tanh(q̇ / ε))` (ε = [`COULOMB_SMOOTHING`]), lane
/// by lane as [`super::dynamics::friction_torques`] computes it.
#[inline(always)]
fn friction<S: Real>(model: &YawPitch<S>, qd: &[S; 4]) -> [S; 4] {
    crate::lanes::array4(|j| {
        let coulomb = S::from_fn(|i| {
            let coulomb = model.coulomb[j].lane(i);
            if coulomb == 0.0 { 0.0 } else { coulomb * (qd[j].lane(i) / COULOMB_SMOOTHING).tanh() }
        });
        -(model.viscous[j] * qd[j] + coulomb)
    })
}

/// `M⁻¹` of a symmetric 4×4 matrix by blocks and cofactors, with principal minors that decide
/// whether it is positive definite, over [`Real`].
///
/// With `M = [a bᵀ; b P]` (`a = m₀₀`, `b = (m₀₁, m₀₂, m₀₃)`, `P` the lower 3×3 block), `A = adj P`
/// (its cofactors, `A₁₁ = p₂₂p₃₃ − p₂₃²`, `A₁₂ = p₁₃p₂₃ − p₁₂p₃₃`, …), `Δ₃ = det P = p₁·A₁`
/// (first row by first column), `z = A b` and `Δ = det M = a Δ₃ − bᵀz` (the Schur complement
/// `a − bᵀP⁻¹b = Δ/Δ₃`), one reciprocal `r = 1/(Δ₃ Δ)` gives all of
/// `M⁻¹ = [Δ₃ ; −zᵀ ; −z ; (Δ A + z zᵀ)/Δ₃] / Δ`:
/// `(M⁻¹)₀₀ = Δ₃ (Δ₃ r)`, `(M⁻¹)₀ₖ = −z_k (Δ₃ r)`, `(M⁻¹)_kl = (Δ A_kl + z_k z_l) r`.
/// `M` is positive definite iff the nested principal minors `p₃₃`, `A₁₁`, `Δ₃` and `Δ` are
/// all positive (Sylvester's criterion, which holds for any nested chain of them).
///
/// Why not `L D Lᵀ`: its four divisions and the two substitutions form one chain of ~150
/// cycles per solve, on the critical path of every integrator stage (a stage's configuration
/// waits for the previous stage's acceleration); here the chain is a few products, one division
/// and a matrix–vector product, for ~75 flops against ~35 (one run 4.45 → 3.8 ms). Its rounding
/// grows like κ²ε where `L D Lᵀ`'s grows like κε (κ the condition number): for the arm's `M`
/// (κ ≤ ~500) both are a few 1e-15, and the general path's `L D Lᵀ` agrees to 1e-12 (tested).
/// A matrix with `Δ₃ Δ` outside the range of `f64` is refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inverse<S> {
    /// `(M⁻¹)₀₀ = Δ₃/Δ`.
    corner: S,
    /// `z/Δ = −(M⁻¹)₀ₖ`, k = 1..3.
    edge: [S; 3],
    /// `(M⁻¹)_kl` for `(k, l)` = (1, 1), (1, 2), (1, 3), (2, 2), (2, 3), (3, 3).
    block: [S; 6],
    /// The nested principal minors `p₃₃`, `A₁₁`, `Δ₃`, `Δ`.
    minors: [S; 4],
    /// `1 / (Δ₃ Δ)`.
    reciprocal: S,
}

impl<S: Real> Inverse<S> {
    /// Scratch to be filled by [`Inverse::set`] (all zero: refused until then).
    #[inline(always)]
    pub fn zeros() -> Self {
        let zero = S::splat(0.0);
        Self { corner: zero, edge: [zero; 3], block: [zero; 6], minors: [zero; 4], reciprocal: zero }
    }

    /// Inverts `matrix` in place (symmetric: only its upper triangle is read). Returns the
    /// lanes that are not positive definite ([`Inverse::failed_lanes`]), tested on the minors
    /// while they are in registers: loaded back right after their stores, they waited for them
    /// (a fifth of the batch's step's time at AVX-512).
    #[inline(always)]
    pub fn set(&mut self, matrix: &[[S; 4]; 4]) -> u64 {
        let m = matrix;
        let (p11, p12, p13, p22, p23, p33) = (m[1][1], m[1][2], m[1][3], m[2][2], m[2][3], m[3][3]);
        let a11 = p22 * p33 - p23 * p23;
        let a12 = p13 * p23 - p12 * p33;
        let a13 = p12 * p23 - p13 * p22;
        let a22 = p11 * p33 - p13 * p13;
        let a23 = p12 * p13 - p11 * p23;
        let a33 = p11 * p22 - p12 * p12;
        let det3 = p11 * a11 + (p12 * a12 + p13 * a13);
        let (b1, b2, b3) = (m[0][1], m[0][2], m[0][3]);
        let z1 = a11 * b1 + (a12 * b2 + a13 * b3);
        let z2 = a12 * b1 + (a22 * b2 + a23 * b3);
        let z3 = a13 * b1 + (a23 * b2 + a33 * b3);
        let det = m[0][0] * det3 - (b1 * z1 + (b2 * z2 + b3 * z3));
        let reciprocal = S::splat(1.0) / (det3 * det);
        let inverse_det = det3 * reciprocal;
        self.corner = det3 * inverse_det;
        self.edge = [z1 * inverse_det, z2 * inverse_det, z3 * inverse_det];
        let entry = |a: S, zk: S, zl: S| (det * a + zk * zl) * reciprocal;
        self.block = [
            entry(a11, z1, z1),
            entry(a12, z1, z2),
            entry(a13, z1, z3),
            entry(a22, z2, z2),
            entry(a23, z2, z3),
            entry(a33, z3, z3),
        ];
        self.minors = [p33, a11, det3, det];
        self.reciprocal = reciprocal;
        failed_of(&[p33, a11, det3, det], reciprocal)
    }

    /// Whether lane `lane` was positive definite: every minor > 0 (NaN fails) with a finite,
    /// non-zero reciprocal (`Δ₃ Δ` within the range of `f64`).
    #[inline(always)]
    pub fn positive_definite(&self, lane: usize) -> bool {
        self.failed_lanes() & (1 << lane) == 0
    }

    /// The lanes that were not positive definite, bit `i` for lane `i`: all lanes at once,
    /// without branches, so that it vectorises.
    #[inline(always)]
    pub fn failed_lanes(&self) -> u64 {
        failed_of(&self.minors, self.reciprocal)
    }

    /// `x = M⁻¹ b`.
    #[inline(always)]
    pub fn solve(&self, b: &[S; 4]) -> [S; 4] {
        let (c, e, p) = (self.corner, &self.edge, &self.block);
        [
            c * b[0] - (e[0] * b[1] + (e[1] * b[2] + e[2] * b[3])),
            (p[0] * b[1] + (p[1] * b[2] + p[2] * b[3])) - e[0] * b[0],
            (p[1] * b[1] + (p[3] * b[2] + p[4] * b[3])) - e[1] * b[0],
            (p[2] * b[1] + (p[4] * b[2] + p[5] * b[3])) - e[2] * b[0],
        ]
    }
}

/// The lanes of an inverse with Sylvester's nested `minors` and `reciprocal = 1/(Δ₃ Δ)` that
/// are not positive definite: a minor not > 0 (NaN fails), or the reciprocal infinite (the
/// product underflowed) or zero (it overflowed), out of range.
#[inline(always)]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(d > 0)` is what catches NaN
fn failed_of<S: Real>(minors: &[S; 4], reciprocal: S) -> u64 {
    // Each its own compare: `|r| = ∞ or r = 0` as one test became a class test of the bits,
    // lane by lane.
    let mut failed = reciprocal.lanes_where(|r| r.abs() == f64::INFINITY) | reciprocal.lanes_where(|r| r == 0.0);
    for minor in minors {
        failed |= minor.lanes_where(|d| !(d > 0.0));
    }
    failed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes::Lanes;
    use nalgebra::Matrix4;
    use proptest::prelude::*;

    fn rows(m: &Matrix4<f64>) -> [[f64; 4]; 4] {
        std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
    }

    fn inverse_of(m: &Matrix4<f64>) -> Inverse<f64> {
        let mut inverse = Inverse::zeros();
        inverse.set(&rows(m));
        inverse
    }

    /// `M⁻¹` column by column, through `solve`.
    fn as_matrix(inverse: &Inverse<f64>) -> Matrix4<f64> {
        let mut out = Matrix4::zeros();
        for j in 0..4 {
            let column = inverse.solve(&std::array::from_fn(|i| if i == j { 1.0 } else { 0.0 }));
            for i in 0..4 {
                out[(i, j)] = column[i];
            }
        }
        out
    }

    proptest! {
        /// On random symmetric positive-definite matrices (`AᵀA + εI`, condition numbers up to
        /// ~2·10³; the report's arm's `M` stays below ~5·10² over random poses), `M⁻¹ M = I` and
        /// `M⁻¹` equals nalgebra's Cholesky inverse to rounding. This inverse's rounding grows
        /// like κ²ε (`L D Lᵀ`'s like κε); over 200 000 such matrices the worst relative
        /// difference was 3·10⁻¹³, so 1e-11 has a margin of 30 and still fails any wrong
        /// cofactor or sign (an error of order 1).
        #[test]
        fn the_inverse_inverts_positive_definite_matrices(
            entries in prop::array::uniform16(-1.0f64..1.0),
            shift in 1e-2f64..1.0,
            scale in prop::sample::select(vec![1e-6, 1e-3, 1.0, 1e3]),
        ) {
            let a = Matrix4::from_row_slice(&entries);
            let m = (a.transpose() * a + Matrix4::identity() * shift) * scale;
            let inverse = inverse_of(&m);
            prop_assert!(inverse.positive_definite(0));
            let ours = as_matrix(&inverse);
            let theirs = m.cholesky().unwrap().inverse();
            prop_assert!((ours - theirs).amax() <= 1e-11 * theirs.amax(), "{ours} vs {theirs}");
            prop_assert!((ours * m - Matrix4::identity()).amax() <= 1e-11, "{}", ours * m);
            prop_assert!(ours == ours.transpose());
        }

        /// Symmetric matrices with one to four negative eigenvalues (`Q diag(λ) Qᵀ`, `Q` a
        /// random rotation) are refused: with two negative eigenvalues `det M` is positive, so
        /// the smaller minors must catch them.
        #[test]
        fn matrices_with_negative_eigenvalues_are_refused(
            entries in prop::array::uniform16(-1.0f64..1.0),
            magnitudes in prop::array::uniform4(0.1f64..10.0),
            negative in 1usize..16,
        ) {
            let q = Matrix4::from_row_slice(&entries).qr().q();
            prop_assume!((q.transpose() * q - Matrix4::identity()).amax() < 1e-12);
            let eigenvalues = nalgebra::Vector4::from_fn(|i, _| {
                if negative & (1 << i) != 0 { -magnitudes[i] } else { magnitudes[i] }
            });
            let m = q * Matrix4::from_diagonal(&eigenvalues) * q.transpose();
            let m = (m + m.transpose()) * 0.5;
            prop_assert!(!inverse_of(&m).positive_definite(0), "eigenvalues {eigenvalues}");
        }

        /// A symmetric matrix with a negative eigenvalue, wherever it is, is refused: one of the
        /// nested minors is then negative (Sylvester), whichever the eigenvector.
        #[test]
        fn indefinite_matrices_are_refused(
            entries in prop::array::uniform16(-1.0f64..1.0),
            direction in prop::array::uniform4(-1.0f64..1.0),
            depth in 0.1f64..10.0,
        ) {
            let v = nalgebra::Vector4::from(direction);
            prop_assume!(v.norm() > 0.1);
            let a = Matrix4::from_row_slice(&entries);
            let positive = a.transpose() * a + Matrix4::identity() * 1e-3;
            // Push the Rayleigh quotient along v below zero.
            let v = v.normalize();
            let m = positive - v * v.transpose() * ((v.transpose() * positive * v)[0] + depth);
            prop_assert!(m.symmetric_eigenvalues().min() < 0.0);
            prop_assert!(!inverse_of(&m).positive_definite(0));
        }
    }

    #[test]
    fn singular_and_not_a_number_matrices_are_refused() {
        let singular = Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, 2.0, 0.0, 3.0));
        assert!(!inverse_of(&singular).positive_definite(0));
        let mut nan = Matrix4::identity();
        nan[(1, 2)] = f64::NAN;
        nan[(2, 1)] = f64::NAN;
        assert!(!inverse_of(&nan).positive_definite(0));
        // Indefinite matrices that each nested minor alone catches (the others positive): p₃₃,
        // then the 2×2 (of rows 2–3), the 3×3 (1–3) and the whole.
        let mut only_a11 = Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, -1.0, 1.0, 1.0));
        (only_a11[(2, 3)], only_a11[(3, 2)]) = (2.0, 2.0);
        for (which, m) in [
            ("p33", Matrix4::from_diagonal(&nalgebra::Vector4::new(1.0, 1.0, -1.0, -1.0))),
            ("A11", only_a11),
            ("det P", Matrix4::from_diagonal(&nalgebra::Vector4::new(-1.0, -1.0, 1.0, 1.0))),
            ("det M", Matrix4::from_diagonal(&nalgebra::Vector4::new(-1.0, 1.0, 1.0, 1.0))),
        ] {
            let inverse = inverse_of(&m);
            assert_eq!(inverse.minors.iter().filter(|minor| **minor < 0.0).count(), 1, "{which}: {:?}", inverse.minors);
            assert!(!inverse.positive_definite(0), "{which}");
        }
        assert!(inverse_of(&Matrix4::identity()).positive_definite(0));
        // Beyond the range of `Δ₃ Δ` (inertias below ~1e-44 or above ~1e44 kg·m², far from any
        // arm): refused rather than inverted wrongly (an infinite reciprocal, or a zero one
        // that would make every acceleration zero).
        assert!(!inverse_of(&(Matrix4::identity() * 1e-50)).positive_definite(0));
        assert!(!inverse_of(&(Matrix4::identity() * 1e50)).positive_definite(0));
        assert!(inverse_of(&(Matrix4::identity() * 1e-40)).positive_definite(0));
        assert!(inverse_of(&(Matrix4::identity() * 1e40)).positive_definite(0));
    }

    #[test]
    fn lanes_invert_as_the_scalar_does_and_flag_only_their_own_failures() {
        let matrices: [Matrix4<f64>; 4] = std::array::from_fn(|k| {
            let a = Matrix4::from_fn(|i, j| ((k * 16 + i * 4 + j) as f64 * 0.37).sin());
            a.transpose() * a + Matrix4::identity() * 0.1
        });
        let mut broken = matrices;
        broken[2][(3, 3)] = -1.0;
        let gathered: [[Lanes<4>; 4]; 4] =
            std::array::from_fn(|i| std::array::from_fn(|j| Lanes(std::array::from_fn(|k| broken[k][(i, j)]))));
        let mut inverse = Inverse::<Lanes<4>>::zeros();
        inverse.set(&gathered);
        assert_eq!(inverse.failed_lanes(), 0b0100);
        let b = [
            Lanes([1.0, -2.0, 0.5, 3.0]),
            Lanes([0.25, 1.0, -1.0, 2.0]),
            Lanes([2.0, 0.0, 1.0, -1.0]),
            Lanes([-0.5, 0.75, 1.5, 0.0]),
        ];
        let x = inverse.solve(&b);
        for k in [0, 1, 3] {
            let scalar = inverse_of(&broken[k]).solve(&b.map(|v| v.get(k)));
            for i in 0..4 {
                assert_eq!(x[i].get(k).to_bits(), scalar[i].to_bits(), "lane {k}, entry {i}");
            }
        }
    }
}
