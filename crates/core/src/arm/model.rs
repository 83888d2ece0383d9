//! The arm model: an immutable description of a serial chain of revolute joints in standard
//! Denavit–Hartenberg convention, built from its links ([`super::link`]: DH parameters,
//! inertial parameters, joint limits, motors and friction) after checking every one, with the
//! payload and gravity.
//!
//! All quantities are SI: metres, radians, kilograms, kg·m², N·m, seconds.

use crate::arm::outline::Outline;
use nalgebra::{SVector, SymmetricEigen, Vector3};

use super::link::{Friction, Inertial, Link};
use super::yaw_pitch::YawPitch;
use crate::short_number as short;

/// A vector with one entry per joint (rad, rad/s, rad/s² or N·m depending on use).
pub type JointVector<const N: usize> = SVector<f64, N>;

/// Standard gravitational acceleration used by the report, m/s². Kept as the default so results
/// compare with the report (ERRATA item 11).
pub const REPORT_GRAVITY: f64 = 9.8;

/// The largest length a model takes (DH `a` and `d`, a centre of mass), m: a desk arm is well
/// under a metre; beyond this a value is a typo in units, and its squares would overflow.
pub const MAX_LENGTH: f64 = 100.0;

/// The largest mass a model takes (a link, a motor, a payload), kg: a chess arm's link or piece
/// heavier than ten tonnes is a typo in units, and the mass matrix would lose its definiteness.
pub const MAX_MASS: f64 = 1.0e4;

/// The largest constant angle a model takes (DH `alpha`, `theta_offset`), rad: one turn either
/// way says every angle there is.
pub const MAX_CONSTANT_ANGLE: f64 = std::f64::consts::TAU;

/// Why a value beyond [`MAX_LENGTH`], [`MAX_MASS`] or `MAX_MASS·MAX_LENGTH²` is refused.
const TOO_LONG: &str = "a length beyond ±100 m (MAX_LENGTH) is a typo in units";
const TOO_HEAVY: &str = "a mass beyond 10 000 kg (MAX_MASS) is a typo in units";
const TOO_MUCH_INERTIA: &str = "beyond MAX_MASS·MAX_LENGTH² (1e8 kg·m²)";

/// A gripped object rigidly attached to the tool frame (the last DH frame, at the tool tip).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Payload {
    /// Mass properties in the tool frame.
    pub inertial: Inertial,
}

impl Payload {
    /// A solid cylinder of `mass` kg, `height` m tall and `radius` m, standing upright and
    /// gripped with the tool tip `grip_height` m above its base. The tool points down (tool x
    /// axis = world −z), so the centre of mass lies `grip_height − height/2` along tool x;
    /// `I = m r²/2` about its axis, `m (3r² + h²)/12` across it.
    pub fn upright_cylinder(mass: f64, height: f64, radius: f64, grip_height: f64) -> Self {
        let com = Vector3::new(grip_height - height / 2.0, 0.0, 0.0);
        let axial = 0.5 * mass * radius * radius;
        let transverse = mass * (3.0 * radius * radius + height * height) / 12.0;
        Self { inertial: Inertial { mass, com, inertia: crate::arm::outline::upright_inertia(axial, transverse) } }
    }

    /// A solid of `outline` and uniform density, `mass` kg, standing upright and gripped with
    /// the tool tip `grip_height` m above its base. The tool points down (tool x axis = world
    /// −z), so the centre of mass lies `grip_height − z_c` along tool x (`z_c` its height above
    /// the base); the inertia about it is [`Outline::mass_properties`]'s. A cylinder is
    /// [`Payload::upright_cylinder`], its closed form (the same numbers, to the last bit).
    pub fn upright(mass: f64, outline: &Outline, grip_height: f64) -> Self {
        if let (Some([radius, height]), None) = (outline.as_cylinder(), outline.block()) {
            return Self::upright_cylinder(mass, height, radius, grip_height);
        }
        let (com_height, axial, transverse) = outline.mass_properties(mass);
        Self {
            inertial: Inertial {
                mass,
                com: Vector3::new(grip_height - com_height, 0.0, 0.0),
                inertia: crate::arm::outline::upright_inertia(axial, transverse),
            },
        }
    }

    /// The same body turned by `angle` rad about the tool frame's z axis (the last pitch
    /// axis): `c' = R c`, `I' = R I Rᵀ` with `R = Rz(angle)`. A piece gripped upright with the
    /// tool tilted lies turned so in the tool frame ([`crate::arm::task::held_turn`]).
    pub fn turned(self, angle: f64) -> Self {
        if angle == 0.0 {
            return self;
        }
        let rotation = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), angle);
        let r = rotation.matrix();
        let inertial = self.inertial;
        Self { inertial: Inertial { com: r * inertial.com, inertia: r * inertial.inertia * r.transpose(), ..inertial } }
    }

    /// A point mass at the tool tip.
    pub fn point_mass(mass: f64) -> Self {
        Self { inertial: Inertial::point(mass, Vector3::zeros()) }
    }
}

/// Which parameter of a model failed validation, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    #[error("{field} = {value}: {reason}")]
    InvalidField { field: String, value: String, reason: &'static str },
}

fn invalid(field: String, value: impl std::fmt::Display, reason: &'static str) -> ModelError {
    ModelError::InvalidField { field, value: value.to_string(), reason }
}

/// An immutable arm model with `N` revolute joints (the chess arm has `N = 4`).
///
/// Per-body mass properties (link ⊕ motor of the next joint ⊕ payload on the last link) are
/// combined once at construction; algorithms read them through [`ArmModel::body`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmModel<const N: usize = 4> {
    links: [Link; N],
    gravity: Vector3<f64>,
    /// Where the base yaw axis stands in the base frame: the origin of DH frame 0, m.
    base: Vector3<f64>,
    payload: Option<Payload>,
    bodies: [Inertial; N],
    /// `(sin α_i, cos α_i)` of every link, cached for the kinematics.
    twist_trig: [(f64, f64); N],
    /// Whether any joint has friction, cached so frictionless forward dynamics skips it.
    has_friction: bool,
    /// The structured constants when the arm is of the yaw–pitch family (and the fast path is
    /// not switched off): the dynamics then take [`super::yaw_pitch`]'s path.
    yaw_pitch: Option<YawPitch<f64>>,
    /// Whether the structured path may be used (see [`ArmModel::with_general_dynamics`]).
    structured: bool,
}

impl<const N: usize> ArmModel<N> {
    /// Builds a model after checking every parameter. `gravity` is the gravitational
    /// acceleration vector in the base frame, m/s² (the report: `(0, 0, −9.8)`).
    pub fn new(links: [Link; N], gravity: Vector3<f64>) -> Result<Self, ModelError> {
        if N == 0 {
            return Err(invalid("links".into(), 0, "the arm needs at least one joint"));
        }
        for (index, link) in links.iter().enumerate() {
            validate_link(index, link)?;
        }
        for (axis, value) in ["x", "y", "z"].iter().zip(gravity.iter()) {
            if !value.is_finite() {
                return Err(invalid(format!("gravity.{axis}"), value, "must be finite"));
            }
        }
        let twist_trig = std::array::from_fn(|i| crate::lanes::sin_cos(links[i].dh.alpha));
        let has_friction = links.iter().any(|link| link.friction != Friction::default());
        let mut model = Self {
            links,
            gravity,
            base: Vector3::zeros(),
            payload: None,
            bodies: [Inertial::zero(); N],
            twist_trig,
            has_friction,
            yaw_pitch: None,
            structured: true,
        };
        model.bodies = model.combined_bodies();
        model.yaw_pitch = model.structured_constants();
        Ok(model)
    }

    /// The same arm carrying `payload` at the tool (or nothing, with `None`).
    pub fn with_payload(&self, payload: Option<Payload>) -> Result<Self, ModelError> {
        if let Some(p) = &payload {
            // Not bounded by MAX_MASS: a library user may study any load; one too heavy for the
            // arithmetic is caught where the mass matrix is factored (the edges bound it).
            check_inertial("payload", &p.inertial, true, false)?;
        }
        let mut model = *self;
        model.payload = payload;
        model.bodies = model.combined_bodies();
        if self.structured {
            model.yaw_pitch = model.structured_constants();
        }
        Ok(model)
    }

    /// The same arm standing with DH frame 0 at `base` in the base frame (m): a URDF's root
    /// link need not lie on the yaw axis. Frame 0 keeps the base frame's axes, so only
    /// positions move (`p = base + T_0i·p_i`); torques do not change (gravity is uniform and
    /// the base does not move).
    pub fn with_base(&self, base: Vector3<f64>) -> Result<Self, ModelError> {
        for (axis, value) in ["x", "y", "z"].iter().zip(base.iter()) {
            if !value.is_finite() {
                return Err(invalid(format!("base.{axis}"), short(*value), "must be finite"));
            }
            if value.abs() > MAX_LENGTH {
                return Err(invalid(format!("base.{axis}"), short(*value), TOO_LONG));
            }
        }
        let mut model = *self;
        model.base = base;
        if self.structured {
            model.yaw_pitch = model.structured_constants();
        }
        Ok(model)
    }

    /// The origin of DH frame 0 (on the base yaw axis) in the base frame, m.
    pub fn base(&self) -> Vector3<f64> {
        self.base
    }

    /// The yaw–pitch constants, when the dynamics take the structured path.
    pub fn yaw_pitch(&self) -> Option<&YawPitch<f64>> {
        self.yaw_pitch.as_ref()
    }

    /// The same arm with the structured path switched off: every dynamics call takes the
    /// general recursive algorithms (the fast path's test oracle, and a benchmark's baseline).
    pub fn with_general_dynamics(&self) -> Self {
        let mut model = *self;
        model.yaw_pitch = None;
        model.structured = false;
        model
    }

    /// The same arm with other links (e.g. other limits), keeping gravity and payload.
    pub fn with_links(&self, links: [Link; N]) -> Result<Self, ModelError> {
        let model = Self::new(links, self.gravity)?.with_base(self.base)?;
        let model = if self.structured { model } else { model.with_general_dynamics() };
        model.with_payload(self.payload)
    }

    /// Whether any joint has viscous or Coulomb friction.
    pub fn has_friction(&self) -> bool {
        self.has_friction
    }

    pub fn links(&self) -> &[Link; N] {
        &self.links
    }

    pub fn link(&self, index: usize) -> &Link {
        &self.links[index]
    }

    /// `(sin α_i, cos α_i)` of link `index`.
    pub fn twist_trig(&self, index: usize) -> (f64, f64) {
        self.twist_trig[index]
    }

    /// Gravitational acceleration in the base frame, m/s².
    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    pub fn payload(&self) -> Option<&Payload> {
        self.payload.as_ref()
    }

    /// Mass properties of moving body `index` in its DH frame: the link, the motor of the next
    /// joint, and on the last body the payload.
    pub fn body(&self, index: usize) -> &Inertial {
        &self.bodies[index]
    }

    /// Per-joint torque limits, N·m.
    pub fn torque_limits(&self) -> JointVector<N> {
        JointVector::from_fn(|i, _| self.links[i].limits.torque)
    }

    /// Per-joint rotor inertias (armature), kg·m².
    pub fn rotor_inertias(&self) -> JointVector<N> {
        JointVector::from_fn(|i, _| self.links[i].rotor_inertia)
    }

    /// The first joint whose angle lies outside its limits, as `(index, value, lower, upper)`.
    pub fn first_limit_violation(&self, q: &JointVector<N>) -> Option<(usize, f64, f64, f64)> {
        self.links.iter().enumerate().find_map(|(i, link)| {
            let v = q[i];
            let inside = v >= link.limits.lower && v <= link.limits.upper;
            (!inside).then_some((i, v, link.limits.lower, link.limits.upper))
        })
    }

    /// The yaw–pitch constants of this arm as it stands (links, bodies, gravity, base), if it is
    /// of the family.
    fn structured_constants(&self) -> Option<YawPitch<f64>> {
        YawPitch::new(&self.links, &self.bodies, self.gravity, self.base).ok()
    }

    fn combined_bodies(&self) -> [Inertial; N] {
        std::array::from_fn(|i| {
            let mut body = self.links[i].inertial;
            if i + 1 < N {
                // The motor of joint i+2 (1-based) sits at the origin of frame i+1, on this link.
                body = body.combine(&Inertial::point(self.links[i + 1].motor_mass, Vector3::zeros()));
            }
            if i + 1 == N
                && let Some(payload) = &self.payload
            {
                body = body.combine(&payload.inertial);
            }
            body
        })
    }
}

fn validate_link(index: usize, link: &Link) -> Result<(), ModelError> {
    let name = |field: &str| format!("link {} ({field})", index + 1);
    let dh = &link.dh;
    for (field, value) in [("a", dh.a), ("alpha", dh.alpha), ("d", dh.d), ("theta_offset", dh.theta_offset)] {
        if !value.is_finite() {
            return Err(invalid(name(field), short(value), "must be finite"));
        }
    }
    for (field, value) in [("a", dh.a), ("d", dh.d)] {
        if value.abs() > MAX_LENGTH {
            return Err(invalid(name(field), short(value), TOO_LONG));
        }
    }
    for (field, value) in [("alpha", dh.alpha), ("theta_offset", dh.theta_offset)] {
        if value.abs() > MAX_CONSTANT_ANGLE {
            return Err(invalid(
                name(field),
                short(value),
                "an angle beyond one turn (±2π rad); give it within [-2π, 2π]",
            ));
        }
    }
    if dh.a < 0.0 {
        return Err(invalid(name("a"), dh.a, "a link length must not be negative"));
    }
    validate_inertial(&format!("link {}", index + 1), &link.inertial, false)?;
    for (field, value) in [("motor_mass", link.motor_mass), ("rotor_inertia", link.rotor_inertia)] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(invalid(name(field), short(value), "must be finite and >= 0"));
        }
    }
    if link.motor_mass > MAX_MASS {
        return Err(invalid(name("motor_mass"), short(link.motor_mass), TOO_HEAVY));
    }
    if link.rotor_inertia > MAX_MASS * MAX_LENGTH * MAX_LENGTH {
        return Err(invalid(name("rotor_inertia"), short(link.rotor_inertia), TOO_MUCH_INERTIA));
    }
    let lim = &link.limits;
    if !(lim.lower.is_finite() && lim.upper.is_finite()) || lim.lower >= lim.upper {
        return Err(invalid(
            name("lower/upper"),
            format!("[{}, {}]", lim.lower, lim.upper),
            "joint limits must be finite with lower < upper",
        ));
    }
    for (field, value) in [("velocity_limit", lim.velocity), ("torque_limit", lim.torque)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(invalid(name(field), value, "must be finite and > 0"));
        }
    }
    for (field, value) in [("viscous", link.friction.viscous), ("coulomb", link.friction.coulomb)] {
        if !(value.is_finite() && value >= 0.0) {
            return Err(invalid(name(field), value, "friction must be finite and >= 0"));
        }
    }
    Ok(())
}

/// Checks mass, centre of mass and inertia tensor. A physical inertia tensor is symmetric with
/// principal moments that are positive (non-negative for a point-like body) and satisfy the
/// triangle inequality `I_a + I_b ≥ I_c`. A body beyond [`MAX_MASS`], a centre of mass beyond
/// [`MAX_LENGTH`] or a moment beyond `MAX_MASS·MAX_LENGTH²` is refused as a typo in units.
pub fn validate_inertial(owner: &str, inertial: &Inertial, allow_point: bool) -> Result<(), ModelError> {
    check_inertial(owner, inertial, allow_point, true)
}

/// [`validate_inertial`], with the bounds [`MAX_MASS`] and [`MAX_LENGTH`] only when `bounded`.
fn check_inertial(owner: &str, inertial: &Inertial, allow_point: bool, bounded: bool) -> Result<(), ModelError> {
    let mass_ok = inertial.mass.is_finite() && if allow_point { inertial.mass >= 0.0 } else { inertial.mass > 0.0 };
    if !mass_ok {
        let reason = if allow_point { "mass must be finite and >= 0" } else { "mass must be finite and > 0" };
        return Err(invalid(format!("{owner} mass"), short(inertial.mass), reason));
    }
    if bounded && inertial.mass > MAX_MASS {
        return Err(invalid(format!("{owner} mass"), short(inertial.mass), TOO_HEAVY));
    }
    let shown_com = || format!("[{}]", inertial.com.iter().map(|v| short(*v)).collect::<Vec<_>>().join(", "));
    if inertial.com.iter().any(|v| !v.is_finite()) {
        return Err(invalid(format!("{owner} com"), shown_com(), "must be finite"));
    }
    if bounded && inertial.com.iter().any(|v| v.abs() > MAX_LENGTH) {
        return Err(invalid(format!("{owner} com"), shown_com(), TOO_LONG));
    }
    let tensor = &inertial.inertia;
    let shown = || format!("[{}]", tensor.iter().map(|v| short(*v)).collect::<Vec<_>>().join(", "));
    if tensor.iter().any(|v| !v.is_finite()) {
        return Err(invalid(format!("{owner} inertia"), shown(), "must be finite"));
    }
    if bounded && tensor.iter().any(|v| v.abs() > MAX_MASS * MAX_LENGTH * MAX_LENGTH) {
        return Err(invalid(format!("{owner} inertia"), shown(), TOO_MUCH_INERTIA));
    }
    let scale = tensor.abs().max().max(f64::MIN_POSITIVE);
    if (tensor - tensor.transpose()).abs().max() > 1e-12 * scale {
        return Err(invalid(format!("{owner} inertia"), shown(), "an inertia tensor must be symmetric"));
    }
    let moments = SymmetricEigen::new(*tensor).eigenvalues;
    let tolerance = 1e-12 * scale;
    let positive =
        if allow_point { moments.iter().all(|&m| m >= -tolerance) } else { moments.iter().all(|&m| m > 0.0) };
    if !positive {
        return Err(invalid(format!("{owner} inertia"), shown(), "principal moments of inertia must be positive"));
    }
    let (a, b, c) = (moments[0], moments[1], moments[2]);
    if a + b < c - tolerance || b + c < a - tolerance || a + c < b - tolerance {
        return Err(invalid(
            format!("{owner} inertia"),
            shown(),
            "principal moments violate the triangle inequality (I_a + I_b >= I_c)",
        ));
    }
    Ok(())
}
