//! The setup file's `[sensors.NAME]` and `[uncertainty]` tables as written (and the same
//! fields in a `--sensors FILE` or `--uncertainty FILE`), read and checked into the core's
//! sensor profiles and model-error ranges.

use anyhow::{Result, anyhow, bail};
use chessarm_chess::pieces::role_name;
use chessarm_chess::shakmaty::Role;
use chessarm_chess::trial::{PieceMassSpread, Uncertainty};
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::uncertainty::{InertiaRotation, ModelUncertainty, Range};
use chessarm_core::sense::{EncoderSpec, SensorProfile};
use chessarm_core::sim::actuator::ActuatorSpread;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One number for every joint, or one per joint.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(untagged)]
pub enum PerJoint {
    One(f64),
    Each(Vec<f64>),
}

impl<'de> Deserialize<'de> for PerJoint {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = PerJoint;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a number, or a list of one number per joint")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<PerJoint, E> {
                Ok(PerJoint::One(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<PerJoint, E> {
                Ok(PerJoint::One(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<PerJoint, E> {
                Ok(PerJoint::One(v as f64))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<PerJoint, A::Error> {
                let mut values = Vec::new();
                while let Some(value) = seq.next_element::<f64>()? {
                    values.push(value);
                }
                Ok(PerJoint::Each(values))
            }
        }
        deserializer.deserialize_any(Visit)
    }
}

impl PerJoint {
    fn values(&self, field: &str) -> Result<[f64; 4]> {
        let values = match self {
            PerJoint::One(value) => [*value; 4],
            PerJoint::Each(values) => <[f64; 4]>::try_from(values.as_slice())
                .map_err(|_| anyhow!("{field} has {} numbers; give one, or one per joint (4)", values.len()))?,
        };
        if let Some(value) = values.iter().find(|v| !v.is_finite()) {
            bail!("{field} = {value} is not a finite number");
        }
        Ok(values)
    }
}

/// A sensor profile as a setup file's `[sensors.NAME]` table or a `--sensors FILE` gives it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct SensorFile {
    /// Encoder counts per revolution (whole numbers); left out: exact angles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub counts_per_rev: Option<PerJoint>,
    /// σ of the encoder noise, counts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_counts: Option<PerJoint>,
    /// Calibration offset of each encoder, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset: Option<PerJoint>,
    /// Delay of a reading, whole control samples.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub delay_samples: Option<f64>,
    /// σ of a velocity sensor, rad/s; left out: no velocity sensor.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rate_noise: Option<PerJoint>,
}

impl SensorFile {
    /// The profile named `name`, every number checked (errors name `sensors.NAME.field`).
    pub fn to_profile(&self, name: &str) -> Result<SensorProfile<4>> {
        let field = |f: &str| format!("sensors.{name}.{f}");
        if self.counts_per_rev.is_none()
            && self.noise_counts.is_none()
            && self.offset.is_none()
            && self.delay_samples.is_none()
            && self.rate_noise.is_none()
        {
            bail!(
                "sensors.{name}: the table is empty; give counts_per_rev, noise_counts, offset, delay_samples or \
                 rate_noise (exact sensors are --sensors ideal)"
            );
        }
        let counts = self.counts_per_rev.as_ref().map(|c| c.values(&field("counts_per_rev"))).transpose()?;
        let noise = self.noise_counts.as_ref().map(|c| c.values(&field("noise_counts"))).transpose()?;
        let offset = self.offset.as_ref().map(|c| c.values(&field("offset"))).transpose()?;
        let delay = self.delay_samples.unwrap_or(0.0);
        if !(delay.is_finite() && delay >= 0.0 && delay.fract() == 0.0) {
            bail!("{} = {delay}: must be a whole number of control samples >= 0", field("delay_samples"));
        }
        let most = chessarm_core::sense::sensors::MAX_DELAY_SAMPLES;
        if delay > most as f64 {
            bail!("{} = {delay}: must be at most {most} samples", field("delay_samples"));
        }
        let rate_noise = self.rate_noise.as_ref().map(|c| c.values(&field("rate_noise"))).transpose()?;
        let encoders = std::array::from_fn(|j| EncoderSpec {
            counts_per_rev: counts.map(|c| c[j]),
            noise_counts: noise.map_or(0.0, |n| n[j]),
            offset: offset.map_or(0.0, |o| o[j]),
        });
        let profile = SensorProfile {
            name: name.to_string(),
            encoders,
            delay_samples: delay as usize,
            rate_noise: rate_noise.map(JointVector::<4>::from),
        };
        // `validate` names fields as `sensors.NAME joint J field`.
        profile.validate()?;
        Ok(profile)
    }
}

/// How the plant's inertia tensors are turned: `"none"`, `"errata"`, or a largest random
/// angle in rad.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(untagged)]
pub enum RotationFile {
    Named(String),
    MaxAngle(f64),
}

impl<'de> Deserialize<'de> for RotationFile {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = RotationFile;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("\"none\", \"errata\" or a largest angle in rad")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<RotationFile, E> {
                Ok(RotationFile::Named(v.to_string()))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<RotationFile, E> {
                Ok(RotationFile::MaxAngle(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<RotationFile, E> {
                Ok(RotationFile::MaxAngle(v as f64))
            }
        }
        deserializer.deserialize_any(Visit)
    }
}

/// The `[uncertainty]` table (or a `--uncertainty FILE`'s top level).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct UncertaintyFile {
    /// ± relative error of every link's mass (0.1 = ±10 %); the inertia scales with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub link_mass: Option<f64>,
    /// ± error of every link's centre of mass per axis, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub com: Option<f64>,
    /// "none", "errata" (links 2–3 tensors exported with the link along y), or a largest
    /// random rotation angle of every tensor, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inertia_rotation: Option<RotationFile>,
    /// Range [low, high] of every joint's viscous friction, N·m·s/rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viscous: Option<Vec<f64>>,
    /// Range [low, high] of every joint's Coulomb friction, N·m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coulomb: Option<Vec<f64>>,
    /// ± relative error of every piece kind's mass without its own range.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub piece_mass: Option<f64>,
    /// Per kind (pawn, knight, bishop, rook, queen, king): a range [low, high] of true masses, kg.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub piece_mass_kg: BTreeMap<String, Vec<f64>>,
    /// Servos: ± relative error of each one's torque constant (its back-EMF constant with it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub torque_constant: Option<f64>,
    /// Servos: ± relative error of each one's winding resistance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub winding_resistance: Option<f64>,
    /// Servos: ± relative error of the supply voltage (one supply for the arm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supply_voltage: Option<f64>,
    /// Servos and steppers: ± relative error of each gear's friction (Coulomb and viscous).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gear_friction: Option<f64>,
    /// Servos: range [low, high] of each one's backlash, full width, rad.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backlash: Option<Vec<f64>>,
    /// Steppers: ± relative error of each one's holding torque.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub holding_torque: Option<f64>,
}

fn range(field: &str, given: &[f64]) -> Result<Range> {
    match given {
        [low, high] => Ok(Range::new(*low, *high)),
        _ => bail!("{field} has {} numbers; it needs [low, high]", given.len()),
    }
}

impl UncertaintyFile {
    /// The draws it describes, every number checked (errors name `uncertainty.field`).
    pub fn to_uncertainty(&self) -> Result<Uncertainty> {
        let inertia_rotation = match &self.inertia_rotation {
            None => InertiaRotation::None,
            Some(RotationFile::Named(name)) => match name.as_str() {
                "none" => InertiaRotation::None,
                "errata" => InertiaRotation::Errata,
                other => bail!(
                    "uncertainty.inertia_rotation = {other:?}: give \"none\", \"errata\" or a largest angle in rad"
                ),
            },
            Some(RotationFile::MaxAngle(angle)) => InertiaRotation::Random { max_angle: *angle },
        };
        let model = ModelUncertainty {
            link_mass: self.link_mass.unwrap_or(0.0),
            com: self.com.unwrap_or(0.0),
            inertia_rotation,
            viscous: self.viscous.as_deref().map(|r| range("uncertainty.viscous", r)).transpose()?,
            coulomb: self.coulomb.as_deref().map(|r| range("uncertainty.coulomb", r)).transpose()?,
        };
        let mut per_kind = [None; 6];
        for (kind, given) in &self.piece_mass_kg {
            let index = Role::ALL.iter().position(|role| role_name(*role) == kind).ok_or_else(|| {
                anyhow!(
                    "uncertainty.piece_mass_kg.{kind}: unknown piece kind (pawn, knight, bishop, rook, queen, king)"
                )
            })?;
            per_kind[index] = Some(range(&format!("uncertainty.piece_mass_kg.{kind}"), given)?);
        }
        let actuators = ActuatorSpread {
            torque_constant: self.torque_constant.unwrap_or(0.0),
            resistance: self.winding_resistance.unwrap_or(0.0),
            supply_voltage: self.supply_voltage.unwrap_or(0.0),
            friction: self.gear_friction.unwrap_or(0.0),
            backlash: self.backlash.as_deref().map(|r| range("uncertainty.backlash", r)).transpose()?,
            holding_torque: self.holding_torque.unwrap_or(0.0),
        };
        let uncertainty = Uncertainty {
            model,
            piece_mass: PieceMassSpread { relative: self.piece_mass.unwrap_or(0.0), per_kind },
            actuators,
        };
        uncertainty.validate()?;
        Ok(uncertainty)
    }
}
