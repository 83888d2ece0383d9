//! The dynamics of the arm family chessarm plans for — a base yaw joint, then three pitch
//! joints with parallel horizontal axes, then the tool — in a form that exploits it.
//!
//! **The yaw frame.** Let `Y` be the base frame turned by the yaw angle `ψ = q₁ + θ₁` about the
//! vertical: the base axis is `Y`'s z axis, every pitch axis is `±y`, and every body's pose in
//! `Y` depends on the pitch angles only. With `β_j = Σ_{i≤j} α_i` (the twists so far, ±90° for
//! the first three frames in the family) and the cumulative pitch `φ_j = φ_{j−1} + σ_j (q_j + θ_j)`
//! (`φ₀ = 0`, `σ_j = −sin β_{j−1} = ±1` the direction of joint j's axis along `y`), frame j is
//! `R_j = R_y(φ_j) R_x(β_j)` with origin `o_j = o_{j−1} + R_y(φ_j) ℓ_j`,
//! `ℓ_j = R_x(β_{j−1}) (a_j, 0, d_j)` (0-based: `o₀ = (a₀, 0, d₀)`). So forward kinematics is
//! three planar rotations `R_y(φ)v = (c v_x + s v_z, v_y, −s v_x + c v_z)` of constant vectors,
//! each body's centre of mass is `c_j = o_{j−1} + R_y(φ_j) ĉ_j` and its inertia
//! `R_y(φ_j) Î_j R_y(φ_j)ᵀ` with `ĉ_j`, `Î_j` fixed once per model. Torques do not depend on
//! `ψ` (gravity is vertical), so the dynamics is computed in `Y` and `ψ` enters the tool tip only.
//!
//! **Mass matrix** (composite rigid bodies in `Y`): with the composite mass `m`, first moment
//! `h = Σ m c` and rotational inertia `Ī = Σ (I_c + m(|c|²E − c cᵀ))` of bodies `j..4` about
//! `Y`'s origin, joint j's unit motion `S_j = (σ_j y, σ_j p_j × y)` gives the force
//! `f = σ_j (h_z − m p_z, 0, m p_x − h_x)` and the moment components
//! `n_y = σ_j (Ī_yy − h_x p_x − h_z p_z)`, `n_z = σ_j (Ī_yz + h_y p_z)`, hence
//! `M_ij = σ_i (n_y − p_iz f_x + p_ix f_z)` for pitch joints `i ≤ j`, `M_1j = n_z` and
//! `M_11 = Ī_zz` (all bodies), plus the rotor inertias on the diagonal.
//!
//! **Bias torques** (recursive Newton–Euler in `Y`): the angular velocity is `ω = (0, w, r)`
//! (`r = q̇₁`, `w = Σ σ_j q̇_j`) and, with `q̈ = 0`, the angular acceleration is `α = (−r w, 0, 0)`,
//! so every cross product of the recursion is sparse; with `q̈` it is `α = (−r w, Σ σ_j q̈_j, q̈₁)`.
//! The torques are `τ₁ = (Σ N)_z` and `τ_j = σ_j ((Σ N)_y − p_jz (Σ F)_x + p_jx (Σ F)_z)`.
//!
//! Every kernel is written once over [`Real`]: one run (`f64`) or several side by side
//! ([`crate::lanes::Lanes`]), the same operations in the same order, so a lane equals the scalar
//! result bit for bit. The general RNEA/CRBA of [`super::dynamics`] stays the test oracle and the
//! path for every other arm.

// The kernels index several arrays by joint, as their equations do.
#![allow(clippy::needless_range_loop)]

use super::dynamics::MassMatrix;
use super::model::{ArmModel, JointVector};
use crate::lanes::{Real, SimdLevel};
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
pub struct Sym<S> {
    pub xx: S,
    pub yy: S,
    pub zz: S,
    pub xy: S,
    pub xz: S,
    pub yz: S,
}

/// The constants of one arm of the family (or of `L` arms, one per lane), fixed once per
/// model: the yaw-frame quantities of the module's equations, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct YawPitch<S> {
    /// `θ_j`, the DH angle offsets, rad.
    pub offset: [S; 4],
    /// `σ_j` (±1) for the pitch joints; `sign[0]` is 1.
    pub sign: [S; 4],
    /// `o₀`: the point of joint 2 in `Y`, m.
    pub shoulder: [S; 3],
    /// `ℓ_j` (j = 1..3): the next frame's origin before `R_y(φ_j)`, m; `link[0]` unused (zero).
    pub link: [[S; 3]; 4],
    /// Body 0's centre of mass in `Y`; for j ≥ 1, `ĉ_j` (before `R_y(φ_j)`, from `o_{j−1}`), m.
    pub com: [[S; 3]; 4],
    /// Body masses (links, motors, payload), kg.
    pub mass: [S; 4],
    /// Body 0's inertia about its centre of mass in `Y`; for j ≥ 1, `Î_j`, kg·m².
    pub inertia: [Sym<S>; 4],
    /// For j ≥ 1: `(Î_xx + Î_zz)/2` and `(Î_xx − Î_zz)/2`, for the double-angle rotation.
    pub inertia_mean: [S; 4],
    pub inertia_half: [S; 4],
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
    /// The constants of `model`, or why it is not of the family: joint 1 must turn about the
    /// vertical with a ±90° twist (`α₁`), `α₂` and `α₃` must be 0 or 180° (parallel pitch axes),
    /// gravity vertical. The tool's twist `α₄`, the offsets `a`, `d`, `θ`, the inertias, motors,
    /// payload and friction are free.
    pub fn new<const N: usize>(model: &ArmModel<N>) -> Result<Self, NotYawPitch> {
        if N != 4 {
            return Err(NotYawPitch(format!("{N} joints (the family has 4)")));
        }
        let g = model.gravity();
        if g.x.abs().max(g.y.abs()) > STRUCTURE_TOLERANCE * g.norm() {
            return Err(NotYawPitch(format!("gravity ({}, {}, {}) m/s² is not along the base axis", g.x, g.y, g.z)));
        }
        // (sin β_j, cos β_j) by angle addition of the links' twists, the first three made exact.
        let mut beta = [(0.0, 1.0); 4];
        let mut running = (0.0f64, 1.0f64);
        for j in 0..4 {
            let (sa, ca) = model.twist_trig(j);
            running = (running.0 * ca + running.1 * sa, running.1 * ca - running.0 * sa);
            if j < 3 {
                if running.1.abs() > STRUCTURE_TOLERANCE {
                    let what = if j == 0 { "alpha = ±90°" } else { "alpha = 0 or 180°" };
                    return Err(NotYawPitch(format!(
                        "link {} needs {what} (joint {}'s axis horizontal and parallel to the pitch axes), has alpha = {} rad",
                        j + 1,
                        j + 2,
                        model.link(j).dh.alpha
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
        let dh = |j: usize| model.link(j).dh;
        let shoulder = [dh(0).a, 0.0, dh(0).d];
        let mut link = [[0.0; 3]; 4];
        let mut com = [[0.0; 3]; 4];
        let mut inertia = [sym(&Matrix3::zeros()); 4];
        let (mut inertia_mean, mut inertia_half) = ([0.0; 4], [0.0; 4]);
        for j in 0..4 {
            let body = model.body(j);
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
                inertia_half[j] = 0.5 * (turned[(0, 0)] - turned[(2, 2)]);
            }
        }
        let links = model.links();
        Ok(Self {
            offset: std::array::from_fn(|j| dh(j).theta_offset),
            sign,
            shoulder,
            link,
            com,
            mass: std::array::from_fn(|j| model.body(j).mass),
            inertia,
            inertia_mean,
            inertia_half,
            rotor: std::array::from_fn(|j| links[j].rotor_inertia),
            gravity_z: g.z,
            viscous: std::array::from_fn(|j| links[j].friction.viscous),
            coulomb: std::array::from_fn(|j| links[j].friction.coulomb),
            has_friction: model.has_friction(),
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
        let tensor = |j: usize| Sym {
            xx: lanes(&|a| a.inertia[j].xx),
            yy: lanes(&|a| a.inertia[j].yy),
            zz: lanes(&|a| a.inertia[j].zz),
            xy: lanes(&|a| a.inertia[j].xy),
            xz: lanes(&|a| a.inertia[j].xz),
            yz: lanes(&|a| a.inertia[j].yz),
        };
        Self {
            offset: v4(&|a, j| a.offset[j]),
            sign: v4(&|a, j| a.sign[j]),
            shoulder: v3(&|a, k| a.shoulder[k]),
            link: std::array::from_fn(|j| v3(&|a, k| a.link[j][k])),
            com: std::array::from_fn(|j| v3(&|a, k| a.com[j][k])),
            mass: v4(&|a, j| a.mass[j]),
            inertia: std::array::from_fn(tensor),
            inertia_mean: v4(&|a, j| a.inertia_mean[j]),
            inertia_half: v4(&|a, j| a.inertia_half[j]),
            rotor: v4(&|a, j| a.rotor[j]),
            gravity_z: lanes(&|a| a.gravity_z),
            viscous: v4(&|a, j| a.viscous[j]),
            coulomb: v4(&|a, j| a.coulomb[j]),
            has_friction: arms.iter().any(|a| a.has_friction),
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
        for j in 1..4 {
            (sin[j], cos[j]) = angle[j].sin_cos();
        }
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

/// `R_y(φ) v` for `(sin φ, cos φ) = (s, c)`.
#[inline(always)]
fn turn_y<S: Real>(s: S, c: S, v: &[S; 3]) -> [S; 3] {
    [c * v[0] + s * v[2], v[1], c * v[2] - s * v[0]]
}

#[inline(always)]
fn add<S: Real>(a: &[S; 3], b: &[S; 3]) -> [S; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
fn sub<S: Real>(a: &[S; 3], b: &[S; 3]) -> [S; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn cross<S: Real>(a: &[S; 3], b: &[S; 3]) -> [S; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// `ω × (ω × v) = ω (ω·v) − v |ω|²` for `ω = (0, w, r)` with `|ω|² = norm2`.
#[inline(always)]
fn centripetal<S: Real>(w: S, r: S, norm2: S, v: &[S; 3]) -> [S; 3] {
    let d = w * v[1] + r * v[2];
    [-(v[0] * norm2), w * d - v[1] * norm2, r * d - v[2] * norm2]
}

/// Everything about one configuration the dynamics needs: the angles, joint points, centres of
/// mass and inertias in `Y`, the tool tip in `Y`, `M(q)` and its `L D Lᵀ` factor.
///
/// A configuration belongs to the model it was last set or refreshed with: its methods must be
/// given that model (it holds only what moves with the angles, and reads the model's constants).
/// The entries it does not hold stay zero, whatever the model, so two configurations of one
/// model at the same angles are equal (and print the same) however they were reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Configuration<S> {
    pub angles: Angles<S>,
    /// `p_j`: a point on joint j's axis, m, for j = 2, 3 only: `p₀ = 0` and `p₁ = o₀` (the
    /// model's `shoulder`) are constants, read from the model rather than copied here.
    point: [[S; 3]; 4],
    /// The tool tip in `Y`, m.
    pub tip: [S; 3],
    /// The centres of mass (m) and inertias (kg·m²) in `Y` of bodies 1..3; body 0's and every
    /// `yy` entry are constants, read from the model (`com_of`, `inertia_of`), so these entries
    /// are not written (zero from [`Configuration::new`] on).
    com: [[S; 3]; 4],
    inertia: [Sym<S>; 4],
    /// `M(q)`, both triangles, kg·m².
    pub mass_matrix: [[S; 4]; 4],
    pub factor: Factor<S>,
}

impl<S: Real> Configuration<S> {
    /// At the configuration of `angles` (rad): kinematics, `M` and its factor. Whether the factor
    /// is usable is [`Factor::positive_definite`]'s to say.
    #[inline(always)]
    pub fn new(model: &YawPitch<S>, angles: Angles<S>) -> Self {
        let zero = S::splat(0.0);
        let mut configuration = Self {
            angles,
            point: [[zero; 3]; 4],
            tip: [zero; 3],
            com: [[zero; 3]; 4],
            inertia: [Sym { xx: zero, yy: zero, zz: zero, xy: zero, xz: zero, yz: zero }; 4],
            mass_matrix: [[zero; 4]; 4],
            factor: Factor { lower: [[zero; 4]; 4], pivot: [zero; 4], inverse_pivot: [zero; 4] },
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
    /// in place by [`Angles::set`] or [`Angles::shift_into`], without a copy).
    #[inline(always)]
    pub fn refresh(&mut self, model: &YawPitch<S>) {
        self.refresh_mass_matrix(model);
        self.factor.set(&self.mass_matrix);
    }

    /// [`Configuration::refresh`] without the factor, which is left as it was: for `M`, the
    /// bias and the tip alone (a controller's terms), not for accelerations.
    #[inline(always)]
    pub fn refresh_mass_matrix(&mut self, model: &YawPitch<S>) {
        let Self { angles, point, tip, com, inertia, .. } = self;
        // Body by body (a macro, so that it is unrolled and every index is a constant), writing
        // only the entries that move with the configuration.
        macro_rules! body {
            ($j:literal) => {{
                let j: usize = $j;
                let (s, c) = (angles.sin[j], angles.cos[j]);
                let base = if j == 1 { model.shoulder } else { point[j] };
                com[j] = add(&base, &turn_y(s, c, &model.com[j]));
                let next = add(&base, &turn_y(s, c, &model.link[j]));
                if j < 3 {
                    point[j + 1] = next;
                } else {
                    *tip = next;
                }
                // R_y(φ) Î R_y(φ)ᵀ by the double angle (c₂, s₂) = (cos 2φ, sin 2φ); `yy` is Î's.
                let (c2, s2) = (c * c - s * s, S::splat(2.0) * s * c);
                let body = &model.inertia[j];
                let (mean, half) = (model.inertia_mean[j], model.inertia_half[j]);
                let spin = half * c2 + body.xz * s2;
                let turned = &mut inertia[j];
                turned.xx = mean + spin;
                turned.zz = mean - spin;
                turned.xy = c * body.xy + s * body.yz;
                turned.xz = body.xz * c2 - half * s2;
                turned.yz = c * body.yz - s * body.xy;
            }};
        }
        body!(1);
        body!(2);
        body!(3);
        mass_matrix(model, self);
    }

    /// `p_j`, m: the model's constants for j = 0, 1.
    #[inline(always)]
    fn point_of(&self, model: &YawPitch<S>, j: usize) -> [S; 3] {
        match j {
            0 => [S::splat(0.0); 3],
            1 => model.shoulder,
            _ => self.point[j],
        }
    }

    /// Body j's centre of mass in `Y`, m.
    #[inline(always)]
    fn com_of<'a>(&'a self, model: &'a YawPitch<S>, j: usize) -> &'a [S; 3] {
        if j == 0 { &model.com[0] } else { &self.com[j] }
    }

    /// Body j's inertia in `Y` about its centre of mass, kg·m², but for its `yy` entry, which is
    /// not kept here (zero): `R_y` leaves it alone, so it is [`YawPitch::inertia`]'s.
    #[inline(always)]
    fn inertia_of<'a>(&'a self, model: &'a YawPitch<S>, j: usize) -> &'a Sym<S> {
        if j == 0 { &model.inertia[0] } else { &self.inertia[j] }
    }

    /// The tool tip in the base frame, m: `R_z(ψ)` of the tip in `Y`.
    #[inline(always)]
    pub fn tip_in_base(&self) -> [S; 3] {
        let (s, c) = self.angles.angle[0].sin_cos();
        [c * self.tip[0] - s * self.tip[1], s * self.tip[0] + c * self.tip[1], self.tip[2]]
    }

    /// `C(q, q̇) q̇ + g(q)`, N·m.
    #[inline(always)]
    pub fn bias(&self, model: &YawPitch<S>, qd: &[S; 4]) -> [S; 4] {
        newton_euler::<S, false>(model, self, qd, &[S::splat(0.0); 4])
    }

    /// `M q̈ + C q̇ + g` by the recursion with `q̈`, N·m (friction not included).
    #[inline(always)]
    pub fn inverse_dynamics(&self, model: &YawPitch<S>, qd: &[S; 4], qdd: &[S; 4]) -> [S; 4] {
        newton_euler::<S, true>(model, self, qd, qdd)
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
        self.factor.solve(&net)
    }

    /// [`Configuration::acceleration_with_bias`] with the bias at `qd` computed here.
    #[inline(always)]
    pub fn acceleration(&self, model: &YawPitch<S>, qd: &[S; 4], torque: &[S; 4]) -> [S; 4] {
        self.acceleration_with_bias(model, qd, torque, &self.bias(model, qd))
    }
}

/// Joint friction `−(b q̇ + τ_c tanh(q̇ / ε))` (ε = [`super::dynamics::COULOMB_SMOOTHING`]), lane
/// by lane as [`super::dynamics::friction_torques`] computes it.
#[inline(always)]
fn friction<S: Real>(model: &YawPitch<S>, qd: &[S; 4]) -> [S; 4] {
    crate::lanes::array4(|j| {
        let coulomb = S::from_fn(|i| {
            let coulomb = model.coulomb[j].lane(i);
            if coulomb == 0.0 { 0.0 } else { coulomb * (qd[j].lane(i) / super::dynamics::COULOMB_SMOOTHING).tanh() }
        });
        -(model.viscous[j] * qd[j] + coulomb)
    })
}

/// The composite-rigid-body mass matrix of the module's equations, into `at.mass_matrix`.
#[inline(always)]
fn mass_matrix<S: Real>(model: &YawPitch<S>, at: &mut Configuration<S>) {
    let zero = S::splat(0.0);
    let mut mass = zero;
    let mut h = [zero; 3];
    let (mut iyy, mut iyz, mut izz) = (zero, zero, zero);
    // Tip to base, unrolled by a macro so that every index is a constant; every entry of `M` is
    // written (in place: no copy of the whole).
    macro_rules! body {
        ($j:literal) => {{
            let j: usize = $j;
            let m = model.mass[j];
            let c = *at.com_of(model, j);
            mass += m;
            let weighted = [c[0] * m, c[1] * m, c[2] * m];
            h = add(&h, &weighted);
            let (yz, zz) = (at.inertia_of(model, j).yz, at.inertia_of(model, j).zz);
            iyy += model.inertia[j].yy + (weighted[0] * c[0] + weighted[2] * c[2]);
            iyz += yz - weighted[1] * c[2];
            izz += zz + (weighted[0] * c[0] + weighted[1] * c[1]);
            if j == 0 {
                at.mass_matrix[0][0] = izz + model.rotor[0];
            } else {
                let p = at.point_of(model, j);
                let sign = model.sign[j];
                let force_x = sign * (h[2] - mass * p[2]);
                let force_z = sign * (mass * p[0] - h[0]);
                let moment_y = sign * (iyy - h[0] * p[0] - h[2] * p[2]);
                let moment_z = sign * (iyz + h[1] * p[2]);
                for i in 1..j + 1 {
                    let pi = at.point_of(model, i);
                    let value = model.sign[i] * (moment_y - pi[2] * force_x + pi[0] * force_z);
                    let value = if i == j { value + model.rotor[j] } else { value };
                    at.mass_matrix[i][j] = value;
                    at.mass_matrix[j][i] = value;
                }
                at.mass_matrix[0][j] = moment_z;
                at.mass_matrix[j][0] = moment_z;
            }
        }};
    }
    body!(3);
    body!(2);
    body!(1);
    body!(0);
}

/// Recursive Newton–Euler in `Y`, sparse as the module explains; `ACCELERATION = false` leaves
/// the terms in `q̈` out (the bias torques), rather than multiplying by zero.
#[inline(always)]
fn newton_euler<S: Real, const ACCELERATION: bool>(
    model: &YawPitch<S>,
    at: &Configuration<S>,
    qd: &[S; 4],
    qdd: &[S; 4],
) -> [S; 4] {
    let zero = S::splat(0.0);
    // ω = (0, w, r), α = (ax, ay, az); the acceleration of the current joint point.
    let (mut w, mut r) = (zero, zero);
    let (mut ax, mut ay, mut az) = (zero, zero, zero);
    let mut point_acceleration = [zero, zero, -model.gravity_z];
    // Each body's force and moment, base to tip, as the array's elements are evaluated (in
    // order): zero-filled arrays written in a loop cost a `memset` call each at 8 lanes, and
    // `array::from_fn`'s closure is not unrolled.
    macro_rules! body {
        ($j:literal) => {{
            let j: usize = $j;
            if j > 0 {
                let norm2 = w * w + r * r;
                let lever = sub(&at.point_of(model, j), &at.point_of(model, j - 1));
                let spin =
                    if ACCELERATION { cross(&[ax, ay, az], &lever) } else { [zero, -(ax * lever[2]), ax * lever[1]] };
                let turn = centripetal(w, r, norm2, &lever);
                point_acceleration = add(&point_acceleration, &add(&spin, &turn));
                ax -= model.sign[j] * qd[j] * r;
                if ACCELERATION {
                    ay += model.sign[j] * qdd[j];
                }
                w += model.sign[j] * qd[j];
            } else {
                if ACCELERATION {
                    az += qdd[0];
                }
                r = qd[0];
            }
            let norm2 = w * w + r * r;
            let com = at.com_of(model, j);
            let lever = sub(com, &at.point_of(model, j));
            let spin =
                if ACCELERATION { cross(&[ax, ay, az], &lever) } else { [zero, -(ax * lever[2]), ax * lever[1]] };
            let com_acceleration = add(&point_acceleration, &add(&spin, &centripetal(w, r, norm2, &lever)));
            let m = model.mass[j];
            let f = [com_acceleration[0] * m, com_acceleration[1] * m, com_acceleration[2] * m];
            let i = at.inertia_of(model, j);
            let yy = model.inertia[j].yy;
            let angular = if ACCELERATION {
                [i.xx * ax + i.xy * ay + i.xz * az, i.xy * ax + yy * ay + i.yz * az, i.xz * ax + i.yz * ay + i.zz * az]
            } else {
                [i.xx * ax, i.xy * ax, i.xz * ax]
            };
            let spun = [i.xy * w + i.xz * r, yy * w + i.yz * r, i.yz * w + i.zz * r];
            let gyroscopic = [w * spun[2] - r * spun[1], r * spun[0], -(w * spun[0])];
            (f, add(&cross(com, &f), &add(&angular, &gyroscopic)))
        }};
    }
    let body: [([S; 3], [S; 3]); 4] = [body!(0), body!(1), body!(2), body!(3)];
    let mut torque = [zero; 4];
    let (mut total_force, mut total_moment) = ([zero; 3], [zero; 3]);
    for j in (0..4).rev() {
        total_force = add(&total_force, &body[j].0);
        total_moment = add(&total_moment, &body[j].1);
        torque[j] = if j == 0 {
            total_moment[2]
        } else {
            let p = at.point_of(model, j);
            model.sign[j] * (total_moment[1] - p[2] * total_force[0] + p[0] * total_force[2])
        };
        if ACCELERATION {
            torque[j] += model.rotor[j] * qdd[j];
        }
    }
    torque
}

/// `M = L D Lᵀ` of a 4×4 symmetric matrix, with the reciprocals of the pivots, as
/// [`super::mass_factor::MassMatrixFactor`] (its doc has the equations), over [`Real`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Factor<S> {
    lower: [[S; 4]; 4],
    pivot: [S; 4],
    inverse_pivot: [S; 4],
}

impl<S: Real> Factor<S> {
    /// Factorises `matrix` in place (only its lower triangle is read).
    #[inline(always)]
    pub fn set(&mut self, matrix: &[[S; 4]; 4]) {
        let zero = S::splat(0.0);
        let Self { lower, pivot, inverse_pivot } = self;
        // Column by column, unrolled by a macro: a loop over the columns stayed a loop, its
        // stores waiting on each division with the next column's loads behind them.
        macro_rules! column {
            ($j:literal) => {{
                let j: usize = $j;
                let mut scaled_row = [zero; 4];
                let mut d = matrix[j][j];
                for k in 0..j {
                    scaled_row[k] = lower[j][k] * pivot[k];
                    d -= lower[j][k] * scaled_row[k];
                }
                pivot[j] = d;
                inverse_pivot[j] = S::splat(1.0) / d;
                for i in j + 1..4 {
                    let mut entry = matrix[i][j];
                    for k in 0..j {
                        entry -= lower[i][k] * scaled_row[k];
                    }
                    lower[i][j] = entry * inverse_pivot[j];
                }
            }};
        }
        column!(0);
        column!(1);
        column!(2);
        column!(3);
    }

    /// Whether lane `lane` was positive definite: every pivot > 0 (NaN fails) with a finite
    /// reciprocal, the test of `MassMatrixFactor::new`.
    #[inline(always)]
    pub fn positive_definite(&self, lane: usize) -> bool {
        self.failed_lanes() & (1 << lane) == 0
    }

    /// The lanes that were not positive definite, bit `i` for lane `i`: all lanes at once,
    /// without branches, so that it vectorises.
    #[inline(always)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(d > 0)` is what catches NaN
    pub fn failed_lanes(&self) -> u64 {
        let mut failed = 0u64;
        for j in 0..4 {
            // `d > 0` is false for NaN, so `!(d > 0)` takes NaN; `|1/d| = ∞` is `is_infinite()`.
            failed |= self.pivot[j].lanes_where2(self.inverse_pivot[j], |d, r| !(d > 0.0) | (r.abs() == f64::INFINITY));
        }
        failed
    }

    /// `x = M⁻¹ b`.
    #[inline(always)]
    pub fn solve(&self, b: &[S; 4]) -> [S; 4] {
        let mut x = *b;
        for i in 0..4 {
            for k in 0..i {
                x[i] -= self.lower[i][k] * x[k];
            }
        }
        for i in 0..4 {
            x[i] *= self.inverse_pivot[i];
        }
        for i in (0..4).rev() {
            for k in i + 1..4 {
                x[i] -= self.lower[k][i] * x[k];
            }
        }
        x
    }
}

/// `f` of the model's configuration at `q` (rad), for the free functions of
/// [`super::dynamics`]: both compiled for the CPU's best SIMD level ([`SimdLevel::detect`]; the
/// same bits at every level), so `f` must be an `#[inline(always)]` closure.
#[inline(always)]
pub(crate) fn at<const N: usize, R>(
    model: &YawPitch<f64>,
    q: &JointVector<N>,
    f: impl FnOnce(&Configuration<f64>) -> R,
) -> R {
    SimdLevel::detect().run(
        #[inline(always)]
        || f(&Configuration::new(model, Angles::new(model, &to_array(q)))),
    )
}

/// The entries of a 4×4 matrix as an `N × N` one (`N = 4` whenever the structured path runs).
pub(crate) fn from_rows<const N: usize>(rows: &[[f64; 4]; 4]) -> MassMatrix<N> {
    MassMatrix::<N>::from_fn(|i, j| rows[i][j])
}

/// A joint vector's four entries (`N = 4` whenever the structured path runs).
pub(crate) fn to_array<const N: usize>(v: &JointVector<N>) -> [f64; 4] {
    std::array::from_fn(|j| v[j])
}

pub(crate) fn from_array<const N: usize>(v: [f64; 4]) -> JointVector<N> {
    JointVector::<N>::from_fn(|j, _| v[j])
}
