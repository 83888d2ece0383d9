//! Model errors: random draws of the true arm (the plant) around the model the controller
//! knows.
//!
//! A draw scales each link's mass (and with it its inertia tensor: the same shape, denser or
//! lighter) by a factor uniform in `[1 − r, 1 + r]`, shifts each link's centre of mass by a
//! uniform `[−c, c]` on each axis of its DH frame, turns the inertia tensors (`I' = R I Rᵀ`),
//! and draws each joint's viscous and Coulomb friction uniformly from their ranges. The
//! ERRATA case — the report's CAD tensors of links 2 and 3 exported with the link along y —
//! is the rotation `R = Rz(π/2)` of those two tensors, which puts their smallest principal
//! moment about x, the links' long axis.

use crate::arm::link::Friction;

use crate::arm::model::{ArmModel, ModelError};
use crate::sense::rng::SeededRng;
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

/// How the plant's inertia tensors are turned relative to the controller's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum InertiaRotation {
    /// As given.
    #[default]
    None,
    /// Links 2 and 3 turned by `Rz(π/2)` (ERRATA: the CAD tensors were exported with the link
    /// along y).
    Errata,
    /// Every link's tensor turned about a random axis (uniform on the sphere) by an angle
    /// uniform in `[0, max]`, rad.
    Random { max_angle: f64 },
}

/// A closed range `[low, high]`, drawn uniformly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Range {
    pub low: f64,
    pub high: f64,
}

impl Range {
    pub fn new(low: f64, high: f64) -> Self {
        Self { low, high }
    }

    /// The single value `value`.
    pub fn fixed(value: f64) -> Self {
        Self { low: value, high: value }
    }

    /// A uniform draw (no draw at all when the range is one value, so a fixed range does not
    /// shift the generator's sequence).
    pub fn draw(&self, rng: &mut SeededRng) -> f64 {
        if self.low == self.high { self.low } else { rng.uniform(self.low, self.high) }
    }

    /// Checks that both bounds are finite and at least `least`, and in order, naming `field`.
    pub(crate) fn validate(&self, field: &str, least: f64) -> Result<(), ModelError> {
        for value in [self.low, self.high] {
            if !(value.is_finite() && value >= least) {
                return Err(ModelError::InvalidField {
                    field: field.to_string(),
                    value: format!("[{}, {}]", self.low, self.high),
                    reason: if least == 0.0 { "bounds must be finite and >= 0" } else { "bounds must be finite" },
                });
            }
        }
        if self.low > self.high {
            return Err(ModelError::InvalidField {
                field: field.to_string(),
                value: format!("[{}, {}]", self.low, self.high),
                reason: "the lower bound is above the upper one",
            });
        }
        Ok(())
    }
}

/// The spread of the true arm around the nominal model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelUncertainty {
    /// ± relative error of every link's mass (0.1: ±10 %).
    pub link_mass: f64,
    /// ± error of every link's centre of mass on each axis of its DH frame, m.
    pub com: f64,
    pub inertia_rotation: InertiaRotation,
    /// Per-joint viscous friction of the plant, N·m·s/rad (`None`: the nominal model's).
    pub viscous: Option<Range>,
    /// Per-joint Coulomb friction of the plant, N·m (`None`: the nominal model's).
    pub coulomb: Option<Range>,
}

/// What a draw gave, per link/joint, for reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnModel<const N: usize> {
    /// True mass / nominal mass.
    pub mass_scale: [f64; N],
    /// True COM − nominal COM, m (DH frame i).
    pub com_shift: [Vector3<f64>; N],
    /// Angle by which each tensor is turned, rad.
    pub inertia_angle: [f64; N],
    pub viscous: [f64; N],
    pub coulomb: [f64; N],
}

impl ModelUncertainty {
    /// Checks every number, naming the field (`uncertainty.link_mass`).
    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |field: &str, value: f64, reason: &'static str| ModelError::InvalidField {
            field: format!("uncertainty.{field}"),
            value: value.to_string(),
            reason,
        };
        if !(self.link_mass.is_finite() && (0.0..1.0).contains(&self.link_mass)) {
            return Err(bad("link_mass", self.link_mass, "must be a relative error in [0, 1)"));
        }
        if !(self.com.is_finite() && self.com >= 0.0) {
            return Err(bad("com", self.com, "must be finite and >= 0 m"));
        }
        if let InertiaRotation::Random { max_angle } = self.inertia_rotation
            && !(max_angle.is_finite() && (0.0..=std::f64::consts::PI).contains(&max_angle))
        {
            return Err(bad("inertia_rotation", max_angle, "must be an angle in [0, π] rad"));
        }
        if let Some(range) = &self.viscous {
            range.validate("uncertainty.viscous", 0.0)?;
        }
        if let Some(range) = &self.coulomb {
            range.validate("uncertainty.coulomb", 0.0)?;
        }
        Ok(())
    }

    /// The true arm of one draw from `rng`, and what was drawn. The nominal model's payload
    /// and gravity are kept. The draws come in a fixed order (per link: mass, COM x y z,
    /// rotation, then per joint: viscous, Coulomb), so a seed gives one arm.
    pub fn draw<const N: usize>(
        &self,
        nominal: &ArmModel<N>,
        rng: &mut SeededRng,
    ) -> Result<(ArmModel<N>, DrawnModel<N>), ModelError> {
        self.validate()?;
        let mut links = *nominal.links();
        let mut drawn = DrawnModel {
            mass_scale: [1.0; N],
            com_shift: [Vector3::zeros(); N],
            inertia_angle: [0.0; N],
            viscous: [0.0; N],
            coulomb: [0.0; N],
        };
        for (i, link) in links.iter_mut().enumerate() {
            let scale = Range::new(1.0 - self.link_mass, 1.0 + self.link_mass).draw(rng);
            let shift = Vector3::from_fn(|_, _| if self.com > 0.0 { rng.uniform(-self.com, self.com) } else { 0.0 });
            let rotation = match self.inertia_rotation {
                InertiaRotation::None => None,
                InertiaRotation::Errata => (i == 1 || i == 2)
                    .then(|| Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2)),
                InertiaRotation::Random { max_angle } => {
                    // A direction uniform on the sphere: z uniform in [−1, 1], azimuth uniform.
                    let z = rng.uniform(-1.0, 1.0);
                    let azimuth = rng.uniform(0.0, std::f64::consts::TAU);
                    let radial = (1.0 - z * z).max(0.0).sqrt();
                    let axis = Unit::new_normalize(Vector3::new(radial * azimuth.cos(), radial * azimuth.sin(), z));
                    Some(Rotation3::from_axis_angle(&axis, rng.uniform(0.0, max_angle)))
                }
            };
            link.inertial.mass *= scale;
            link.inertial.inertia *= scale;
            link.inertial.com += shift;
            if let Some(rotation) = rotation {
                let r: Matrix3<f64> = *rotation.matrix();
                link.inertial.inertia = r * link.inertial.inertia * r.transpose();
                drawn.inertia_angle[i] = rotation.angle();
            }
            drawn.mass_scale[i] = scale;
            drawn.com_shift[i] = shift;
        }
        for (j, link) in links.iter_mut().enumerate() {
            if let Some(range) = &self.viscous {
                link.friction.viscous = range.draw(rng);
            }
            if let Some(range) = &self.coulomb {
                link.friction.coulomb = range.draw(rng);
            }
            let Friction { viscous, coulomb } = link.friction;
            drawn.viscous[j] = viscous;
            drawn.coulomb[j] = coulomb;
        }
        Ok((nominal.with_links(links)?, drawn))
    }
}
