//! One randomised trial of a robustness study: the true arm and the true piece masses drawn
//! around the nominal ones, and the seed of the sensors' noise, all from one trial seed.
//!
//! Trial `k` of a study seeded with `S` has the seed `derive_seed(S, k)`; from a trial seed
//! `s`, the model and piece draws come from the stream `derive_seed(s, 0)` and the sensor noise
//! from `derive_seed(s, 1)`. A trial is therefore reproducible alone from its seed, whatever
//! the number of threads, shards or other trials. The actuators' draws (servos and steppers)
//! follow the pieces' on the model stream, so a study without them draws as before.

use crate::pieces::PieceSet;
use chessarm_core::arm::model::{ArmModel, ModelError};
use chessarm_core::arm::uncertainty::{DrawnModel, ModelUncertainty, Range};
use chessarm_core::sense::rng::{SeededRng, derive_seed};
use chessarm_core::sim::actuator::{ActuatorSpread, Actuators, DrawnActuators};
use shakmaty::Role;

/// The spread of the pieces' masses: each kind's mass is drawn from its own range if it has
/// one, else uniformly within ± `relative` of the nominal mass.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PieceMassSpread {
    /// ± relative error of every kind's mass without its own range (0.5: ±50 %).
    pub relative: f64,
    /// Per kind, pawn to king (shakmaty's `Role::ALL` order): a range of true masses, kg.
    pub per_kind: [Option<Range>; 6],
}

impl PieceMassSpread {
    /// The range of true masses of kind `k` (`Role::ALL` order) around the nominal `nominal`, kg.
    pub fn range(&self, k: usize, nominal: f64) -> Range {
        self.per_kind[k].unwrap_or(Range::new(nominal * (1.0 - self.relative), nominal * (1.0 + self.relative)))
    }
}

/// Per kind (`Role::ALL` order), the largest difference between a piece's true mass and the
/// mass the controller is told, kg: true masses `spread` around `true_pieces`' (exactly
/// theirs without a spread), told `told`'s (nothing: 0).
pub fn largest_mass_errors(
    spread: Option<&PieceMassSpread>,
    true_pieces: &PieceSet,
    told: Option<&PieceSet>,
) -> [f64; 6] {
    std::array::from_fn(|k| {
        let role = Role::ALL[k];
        let nominal = true_pieces.dimensions(role).mass;
        let range = spread.map_or(Range::fixed(nominal), |s| s.range(k, nominal));
        let told = told.map_or(0.0, |p| p.dimensions(role).mass);
        (range.high - told).abs().max((told - range.low).abs())
    })
}

/// Everything a trial draws.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Uncertainty {
    pub model: ModelUncertainty,
    pub piece_mass: PieceMassSpread,
    /// The servos' and steppers' spread around their datasheets.
    pub actuators: ActuatorSpread,
}

/// The draws of one trial.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawnTrial {
    pub seed: u64,
    /// The true arm.
    pub plant: ArmModel<4>,
    pub drawn: DrawnModel<4>,
    /// The true pieces (nominal shapes, drawn masses).
    pub pieces: PieceSet,
    /// Seed of the sensor noise.
    pub sensor_seed: u64,
    /// The true actuators, and what was drawn (`None`: no actuator spread).
    pub actuators: Actuators<4>,
    pub drawn_actuators: Option<DrawnActuators<4>>,
}

impl Uncertainty {
    /// Checks every number, naming the field.
    pub fn validate(&self) -> Result<(), ModelError> {
        self.model.validate()?;
        self.actuators.validate()?;
        let relative = self.piece_mass.relative;
        if !(relative.is_finite() && (0.0..1.0).contains(&relative)) {
            return Err(ModelError::InvalidField {
                field: "uncertainty.piece_mass".into(),
                value: relative.to_string(),
                reason: "must be a relative error in [0, 1)",
            });
        }
        for (role, range) in Role::ALL.iter().zip(&self.piece_mass.per_kind) {
            if let Some(range) = range
                && !(range.low.is_finite() && range.high.is_finite() && range.low >= 0.0 && range.low <= range.high)
            {
                return Err(ModelError::InvalidField {
                    field: format!("uncertainty.piece_mass_kg.{}", crate::pieces::role_name(*role)),
                    value: format!("[{}, {}]", range.low, range.high),
                    reason: "must be [low, high] kg with 0 <= low <= high",
                });
            }
        }
        Ok(())
    }

    /// The trial of seed `seed` around `arm`, `pieces` and `actuators`.
    pub fn draw(
        &self,
        seed: u64,
        arm: &ArmModel<4>,
        pieces: &PieceSet,
        actuators: &Actuators<4>,
    ) -> Result<DrawnTrial, ModelError> {
        self.validate()?;
        self.actuators.check_for(actuators)?;
        let mut rng = SeededRng::new(derive_seed(seed, 0));
        let (plant, drawn) = self.model.draw(arm, &mut rng)?;
        let mut true_pieces = *pieces;
        for (k, role) in Role::ALL.iter().enumerate() {
            let nominal = pieces.dimensions(*role).mass;
            let range = self.piece_mass.range(k, nominal);
            true_pieces.dimensions_mut(*role).mass = range.draw(&mut rng);
        }
        let (true_actuators, drawn_actuators) = if self.actuators.is_none() {
            (*actuators, None)
        } else {
            let (true_actuators, drawn) = self.actuators.draw(actuators, &mut rng)?;
            (true_actuators, Some(drawn))
        };
        Ok(DrawnTrial {
            seed,
            plant,
            drawn,
            pieces: true_pieces,
            sensor_seed: derive_seed(seed, 1),
            actuators: true_actuators,
            drawn_actuators,
        })
    }
}
