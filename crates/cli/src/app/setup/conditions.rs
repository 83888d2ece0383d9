//! Realistic conditions of a run: the sensors (`--sensors`, `[sensors.NAME]` tables), the
//! estimator, the motors' torque lag, the true arm (`--plant FILE`) and random model errors
//! (`--uncertainty FILE` or the setup's `[uncertainty]` table), with the seeds that make a run
//! reproducible. Shared by `simulate`, `play`, `tune`, `gains` and `robustness`.

use crate::app::setup::condition_tables::{SensorFile, UncertaintyFile};
use crate::app::setup::file::Setup;
use anyhow::{Context, Result, anyhow, bail};
use chessarm_chess::pieces::{PieceSet, role_name};
use chessarm_chess::shakmaty::Role;
use chessarm_chess::trial::{DrawnTrial, Uncertainty};
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::sense::{Conditions, EstimatorSpec, KalmanSettings, SensorProfile};
use chessarm_core::sim::actuator::Actuators;
use serde::Serialize;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The state estimator between the sensors and the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
pub enum EstimatorChoice {
    /// Per-joint Kalman filter of angle, rate and a disturbance acceleration, from the angles
    /// and the commanded acceleration.
    Kalman,
    /// The Kalman filter without the disturbance state (angle and rate; σ_a 20 rad/s²).
    KalmanTwoState,
    /// Finite-difference rates through a first-order low-pass (the baseline).
    Lowpass,
    /// The measurements as they are (needs a velocity sensor, or the ideal profile).
    Direct,
}

/// Sensor, actuator and model-error options, the same for every study that simulates (the
/// command line's flags of these names, Python's keyword arguments).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ConditionOptions {
    /// Sensors: ideal (the exact state), hobby (12-bit encoders, σ 0.5 count, 1 sample delay),
    /// servo (17-bit, σ 0.5 count), a profile of the setup file's [sensors.NAME] tables, or a
    /// TOML FILE of one profile (counts_per_rev, noise_counts, offset, delay_samples, rate_noise).
    pub sensors: Option<String>,
    /// State estimator. Default: direct with ideal sensors, kalman otherwise.
    pub estimator: Option<EstimatorChoice>,
    /// σ of the acceleration the Kalman filter's motion model does not know, rad/s².
    pub kalman_acceleration_noise: Option<f64>,
    /// Time constant of the low-pass of the lowpass estimator, s.
    pub lowpass_time_constant: Option<f64>,
    /// Motors' first-order torque lag, s: one value or one per joint (default 0: none).
    pub torque_lag: Option<[f64; 4]>,
    /// The controller is told --arm's friction (viscous, coulomb) and compensates it; without
    /// it, friction acts in the plant only. The default with --urdf (the file's <dynamics> are
    /// part of its model).
    pub controller_knows_friction: bool,
    /// With --urdf: the controller does not compensate the file's <dynamics> friction (it acts
    /// in the plant only), as without --urdf.
    pub controller_ignores_friction: bool,
    /// The true arm and pieces: a second setup file (the controller keeps --arm's model).
    pub plant: Option<PathBuf>,
    /// Random model errors: a TOML file with the fields of an [uncertainty] table (default:
    /// the setup file's [uncertainty] table, if any).
    pub uncertainty: Option<PathBuf>,
    /// Seed of the sensor noise and the model draws of a run (robustness: of the study).
    pub seed: u64,
    /// Run one trial of `robustness` alone: the trial_seed of its row in robustness.csv.
    pub trial_seed: Option<u64>,
}

impl ConditionOptions {
    /// Whether the controllers compensate the arm's friction: `--controller-knows-friction`,
    /// or by default with `--urdf` (unless `--controller-ignores-friction`).
    pub fn knows_friction(&self, setup: &Setup) -> bool {
        self.controller_knows_friction || (setup.urdf_path.is_some() && !self.controller_ignores_friction)
    }
}

/// The conditions of a study, parsed once; [`Study::trial`] draws one run's.
#[derive(Debug, Clone)]
pub struct Study {
    pub sensors: SensorProfile<4>,
    pub estimator: EstimatorSpec,
    pub torque_lag: JointVector<4>,
    /// The nominal true arm and pieces (--plant's, or the controller's).
    pub plant: ArmModel<4>,
    pub plant_pieces: PieceSet,
    pub plant_file: Option<PathBuf>,
    pub uncertainty: Option<Uncertainty>,
    pub uncertainty_file: Option<UncertaintyFile>,
    /// Whether the controllers compensate --arm's friction.
    pub controller_knows_friction: bool,
    /// The setup's actuators, around which a trial draws the true ones.
    pub actuators: Actuators<4>,
}

/// How finely a run can put the tool tip at a fine point, m: the tip's move when every encoder
/// (and every servo's own encoder) moves a count, and the band within which servos or steppers
/// hold it still off their goals (0 with torque motors).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Resolution {
    pub tip_quantum: f64,
    pub holding_band: f64,
}

/// One run's conditions.
#[derive(Debug, Clone)]
pub struct Trial {
    pub seed: u64,
    pub conditions: Conditions<4>,
    pub plant: ArmModel<4>,
    pub pieces: PieceSet,
    /// The true actuators (the setup's, or drawn around them).
    pub actuators: Actuators<4>,
    /// The draws, when the study has model errors.
    pub drawn: Option<DrawnTrial>,
}

fn read_toml<T: serde::de::DeserializeOwned>(flag: &str, path: &Path) -> Result<T> {
    let text = crate::app::input::read_text(flag, path, crate::app::input::MAX_SETUP_BYTES)?;
    toml::from_str(&text)
        .map_err(|e| anyhow!("{flag} {}: {}", path.display(), crate::app::setup::file::toml_error(&text, &e)))
}

/// An uncertainty file: the fields at its top level, or a setup file's `[uncertainty]` table.
fn read_uncertainty(path: &Path) -> Result<UncertaintyFile> {
    let text = crate::app::input::read_text("--uncertainty", path, crate::app::input::MAX_SETUP_BYTES)?;
    let value: toml::Value = toml::from_str(&text)
        .map_err(|e| anyhow!("--uncertainty {}: {}", path.display(), crate::app::setup::file::toml_error(&text, &e)))?;
    let table = match value.get("uncertainty") {
        Some(table) => table.clone(),
        None => value,
    };
    table.try_into().map_err(|e: toml::de::Error| anyhow!("--uncertainty {}: {}", path.display(), e.message().trim()))
}

impl Study {
    /// The setup's tracking budget for a controller with `gains` (with servos, for their
    /// loops: [`chessarm_chess::tasks::Tracking::with_servos`]): the pieces' true masses as
    /// this study may draw them (its uncertainty's spread around the true pieces'), against the
    /// mass the controller is told (the nominal one of the kind with `feedforward`, nothing
    /// without, the true one when it `knows_payload`: no error).
    pub fn tracking(
        &self,
        setup: &Setup,
        gains: &chessarm_core::control::gains::Gains<4>,
        feedforward: bool,
        knows_payload: bool,
    ) -> chessarm_chess::tasks::Tracking {
        // Servo hosts' gains are not a loop's: the servos' stiffnesses are.
        let mut tracking = setup.motion.tracking.for_actuators(gains, &self.actuators, &setup.arm);
        tracking.mass_error = self.mass_errors(setup, feedforward, knows_payload);
        tracking
    }

    /// What the fine points can ask of the sensors and actuators: [`Resolution`].
    pub fn resolution(&self, setup: &Setup) -> Resolution {
        Resolution { tip_quantum: self.tip_quantum(setup), holding_band: setup.actuators.holding_band(&setup.arm) }
    }

    /// How far the estimated tip moves when every encoder moves a count, m (0: exact angles).
    /// With servos or steppers the host knows the angles no finer than their own counts (it
    /// reads the servos' position registers; it counts a stepper's microsteps).
    pub fn tip_quantum(&self, setup: &Setup) -> f64 {
        let mut encoders = self.sensors.encoders;
        for (encoder, actuator) in encoders.iter_mut().zip(&setup.actuators.joints) {
            if let Some(counts) = actuator.counts_per_revolution() {
                encoder.counts_per_rev = Some(encoder.counts_per_rev.map_or(counts, |c| c.min(counts)));
            }
        }
        chessarm_core::plan::fine_point::tip_quantum(&setup.arm, &encoders)
    }

    /// Per piece kind, the largest difference between a true mass and the one the controller
    /// is told, kg ([`Self::tracking`]).
    pub fn mass_errors(&self, setup: &Setup, feedforward: bool, knows_payload: bool) -> [f64; 6] {
        if knows_payload {
            return [0.0; 6];
        }
        let spread = self.uncertainty.as_ref().map(|u| &u.piece_mass);
        let told = feedforward.then_some(&setup.pieces);
        chessarm_chess::trial::largest_mass_errors(spread, &self.plant_pieces, told)
    }

    /// Parses `args` against `setup` (the controller's arm and pieces). Model errors come
    /// from `--uncertainty` only: a single run is never silently randomised by a table in
    /// the setup file.
    pub fn new(setup: &Setup, args: &ConditionOptions, control_period: f64) -> Result<Self> {
        Self::parse(setup, args, control_period, false)
    }

    /// [`Study::new`] for `robustness`, whose model errors may also come from the setup
    /// file's `[uncertainty]` table.
    pub fn for_trials(setup: &Setup, args: &ConditionOptions, control_period: f64) -> Result<Self> {
        Self::parse(setup, args, control_period, true)
    }

    fn parse(setup: &Setup, args: &ConditionOptions, control_period: f64, setup_uncertainty: bool) -> Result<Self> {
        let sensors = match args.sensors.as_deref() {
            None => SensorProfile::ideal(),
            Some(name) => match SensorProfile::named(name) {
                Some(profile) => profile,
                None => match setup.sensor_profiles.get(name) {
                    Some(file) => file.to_profile(name).with_context(|| "the setup file's [sensors] table")?,
                    None if Path::new(name).is_file() => {
                        let file: SensorFile = read_toml("--sensors", Path::new(name))?;
                        file.to_profile(name)
                            .with_context(|| format!("--sensors {}", crate::app::text::escape_controls(name)))?
                    }
                    None if Path::new(name).is_dir() => {
                        bail!(
                            "--sensors {}: is a folder; give a profile name or a TOML file",
                            crate::app::text::escape_controls(name)
                        )
                    }
                    None => {
                        let mut known: Vec<String> = SensorProfile::<4>::NAMES.iter().map(|s| s.to_string()).collect();
                        known.extend(setup.sensor_profiles.keys().cloned());
                        bail!(
                            "--sensors {}: no such profile ({}) and no such file",
                            crate::app::text::escape_controls(name),
                            known.join(", ")
                        );
                    }
                },
            },
        };
        let estimator = match args.estimator {
            None if sensors.is_ideal() => EstimatorSpec::Direct,
            Some(EstimatorChoice::Kalman | EstimatorChoice::KalmanTwoState) if sensors.is_ideal() => bail!(
                "--estimator {} with --sensors {}: the state is exact, there is nothing to filter (give encoder counts)",
                if args.estimator == Some(EstimatorChoice::Kalman) { "kalman" } else { "kalman-two-state" },
                sensors.name
            ),
            None | Some(EstimatorChoice::Kalman) | Some(EstimatorChoice::KalmanTwoState) => {
                let mut settings = if args.estimator == Some(EstimatorChoice::KalmanTwoState) {
                    KalmanSettings::TWO_STATE
                } else {
                    KalmanSettings::DEFAULT
                };
                if let Some(noise) = args.kalman_acceleration_noise {
                    settings.acceleration_noise = noise;
                }
                EstimatorSpec::Kalman(settings)
            }
            Some(EstimatorChoice::Lowpass) => EstimatorSpec::LowPass {
                time_constant: args
                    .lowpass_time_constant
                    .unwrap_or(chessarm_core::sense::LowPassVelocity::<4>::DEFAULT_TIME_CONSTANT),
            },
            Some(EstimatorChoice::Direct) => EstimatorSpec::Direct,
        };
        if args.kalman_acceleration_noise.is_some() && !matches!(estimator, EstimatorSpec::Kalman(_)) {
            bail!("--kalman-acceleration-noise is for the Kalman filter; the estimator is {}", estimator.name());
        }
        if args.lowpass_time_constant.is_some() && !matches!(estimator, EstimatorSpec::LowPass { .. }) {
            bail!("--lowpass-time-constant is for --estimator lowpass; the estimator is {}", estimator.name());
        }
        // Build once to check the estimator against the sensors (e.g. direct without a rate sensor).
        Conditions { sensors: sensors.clone(), estimator, torque_lag: JointVector::zeros(), seed: 0 }
            .feedback(control_period)
            .with_context(|| {
                let given = if args.estimator.is_some() { "--estimator" } else { "the default estimator" };
                format!("--sensors {} with {given} {}", sensors.name, estimator.name())
            })?;
        let torque_lag = JointVector::<4>::from(args.torque_lag.unwrap_or([0.0; 4]));
        let (plant, plant_pieces) = match &args.plant {
            None => (setup.arm, setup.pieces),
            Some(path) => {
                let plant = Setup::load(Some(path)).with_context(|| format!("--plant {}", path.display()))?;
                (plant.arm, plant.pieces)
            }
        };
        let uncertainty_file = match &args.uncertainty {
            Some(path) => Some(read_uncertainty(path)?),
            None if setup_uncertainty => setup.uncertainty.clone(),
            None => None,
        };
        let uncertainty = uncertainty_file
            .as_ref()
            .map(|file| {
                file.to_uncertainty().with_context(|| match &args.uncertainty {
                    Some(path) => format!("--uncertainty {}", path.display()),
                    None => "the setup file's [uncertainty] table".to_string(),
                })
            })
            .transpose()?;
        if let Some(uncertainty) = &uncertainty {
            uncertainty.actuators.check_for(&setup.actuators).with_context(|| match &args.uncertainty {
                Some(path) => format!("--uncertainty {}", path.display()),
                None => "the setup file's [uncertainty] table".to_string(),
            })?;
        }
        Ok(Self {
            sensors,
            estimator,
            torque_lag,
            plant,
            plant_pieces,
            plant_file: args.plant.clone(),
            uncertainty,
            uncertainty_file,
            controller_knows_friction: args.knows_friction(setup),
            actuators: setup.actuators,
        })
    }

    /// The plant's friction the controllers do not compensate, per joint (viscous N·m·s/rad,
    /// Coulomb N·m), or `None` when there is none or they do.
    pub fn unmodelled_friction(&self) -> Option<Vec<[f64; 2]>> {
        (!self.controller_knows_friction && self.plant.has_friction())
            .then(|| self.plant.links().iter().map(|l| [l.friction.viscous, l.friction.coulomb]).collect())
    }

    /// A line for the terminal when the plant has friction the controllers do not compensate:
    /// what it is, against the torque limits, and the flag that changes it.
    pub fn friction_note(&self) -> Option<String> {
        self.unmodelled_friction()?;
        let links = self.plant.links();
        let share = links
            .iter()
            .map(|l| (l.friction.coulomb + l.friction.viscous * l.limits.velocity) / l.limits.torque)
            .fold(0.0, f64::max);
        Some(format!(
            "note: the plant has friction the controller does not compensate (Coulomb {} N·m, viscous {} N·m·s/rad per joint; at top speed up to {:.1} % of a torque limit): tracking errors grow with it; --controller-knows-friction compensates it\n",
            links.iter().map(|l| chessarm_core::short_number(l.friction.coulomb)).collect::<Vec<_>>().join(", "),
            links.iter().map(|l| chessarm_core::short_number(l.friction.viscous)).collect::<Vec<_>>().join(", "),
            100.0 * share
        ))
    }

    /// Whether every run sees the exact state of the controller's own arm and pieces.
    pub fn is_ideal(&self, setup: &Setup) -> bool {
        self.sensors.is_ideal()
            && self.estimator == EstimatorSpec::Direct
            && self.torque_lag == JointVector::<4>::zeros()
            && self.plant == setup.arm
            && self.plant_pieces == setup.pieces
            && self.uncertainty.is_none()
            && !(self.controller_knows_friction && setup.arm.has_friction())
    }

    /// The run of trial seed `seed`: the model and piece draws (with model errors) and the
    /// sensors' seed.
    pub fn trial(&self, seed: u64) -> Result<Trial> {
        let drawn = self
            .uncertainty
            .as_ref()
            .map(|u| u.draw(seed, &self.plant, &self.plant_pieces, &self.actuators))
            .transpose()
            .context("drawing the model errors")?;
        let sensor_seed = drawn.as_ref().map_or(chessarm_core::sense::rng::derive_seed(seed, 1), |d| d.sensor_seed);
        let conditions = Conditions {
            sensors: self.sensors.clone(),
            estimator: self.estimator,
            torque_lag: self.torque_lag,
            seed: sensor_seed,
        };
        let (plant, pieces) = drawn.as_ref().map_or((self.plant, self.plant_pieces), |d| (d.plant, d.pieces));
        let actuators = drawn.as_ref().map_or(self.actuators, |d| d.actuators);
        Ok(Trial { seed, conditions, plant, pieces, actuators, drawn })
    }

    /// One line for the terminal: what is not ideal, and the trial seed.
    pub fn note(&self, seed: u64) -> String {
        let mut parts = vec![format!("sensors {}", self.sensors.name), format!("estimator {}", self.estimator.name())];
        if self.torque_lag != JointVector::<4>::zeros() {
            parts.push(format!("torque lag {:?} s", self.torque_lag.as_slice()));
        }
        if let Some(path) = &self.plant_file {
            parts.push(format!("true arm from {}", path.display()));
        }
        if self.uncertainty.is_some() {
            parts.push(format!("model errors drawn with trial seed {seed}"));
        } else {
            parts.push(format!("sensor noise seed {seed}"));
        }
        format!("conditions: {}\n", parts.join(", "))
    }

    /// The study's conditions for summary.json and game.json.
    pub fn describe(&self) -> Value {
        let encoders: Vec<Value> = self
            .sensors
            .encoders
            .iter()
            .map(|e| json!({ "counts_per_rev": e.counts_per_rev, "noise_counts": e.noise_counts, "offset_rad": e.offset }))
            .collect();
        let estimator = match self.estimator {
            EstimatorSpec::Direct => json!({ "name": "direct" }),
            EstimatorSpec::LowPass { time_constant } => json!({ "name": "lowpass", "time_constant_s": time_constant }),
            EstimatorSpec::Kalman(settings) => json!({
                "name": "kalman",
                "acceleration_noise_rad_per_s2": settings.acceleration_noise,
                "disturbance_noise_rad_per_s2": settings.disturbance_noise,
            }),
        };
        json!({
            "sensors": {
                "profile": self.sensors.name,
                "encoders": encoders,
                "delay_samples": self.sensors.delay_samples,
                "rate_noise_rad_per_s": self.sensors.rate_noise.map(|n| n.as_slice().to_vec()),
            },
            "estimator": estimator,
            "torque_lag_s": self.torque_lag.as_slice(),
            "controller_knows_friction": self.controller_knows_friction,
            "unmodelled_friction": self.unmodelled_friction(),
            "plant_file": self.plant_file.as_ref().map(|p| p.display().to_string()),
            "uncertainty": self.uncertainty_file,
        })
    }
}

impl Trial {
    /// `settings` playing on this trial's true arm, pieces and actuators, through its sensors.
    pub fn apply_to(&self, settings: &mut chessarm_chess::play::PlaySettings) {
        settings.plant = Some(self.plant);
        settings.true_pieces = Some(self.pieces);
        settings.conditions = self.conditions.clone();
        settings.true_actuators = Some(self.actuators);
    }

    /// What the trial drew, for reports (null without model errors).
    pub fn describe(&self) -> Value {
        let Some(drawn) = &self.drawn else { return json!({ "trial_seed": self.seed }) };
        let d = &drawn.drawn;
        json!({
            "trial_seed": self.seed,
            "link_mass_scale": d.mass_scale,
            "link_com_shift_m": d.com_shift.iter().map(|v| v.as_slice().to_vec()).collect::<Vec<_>>(),
            "inertia_rotation_rad": d.inertia_angle,
            "viscous_nms_per_rad": d.viscous,
            "coulomb_nm": d.coulomb,
            "piece_mass_kg": Role::ALL.iter().map(|r| (role_name(*r), drawn.pieces.dimensions(*r).mass)).collect::<BTreeMap<_, _>>(),
            "actuators": drawn.drawn_actuators.map(|a| json!({
                "supply_voltage_scale": a.supply_voltage_scale,
                "torque_constant_scale": a.torque_constant_scale,
                "winding_resistance_scale": a.resistance_scale,
                "gear_friction_scale": a.friction_scale,
                "backlash_rad": a.backlash,
                "holding_torque_scale": a.holding_torque_scale,
            })),
        })
    }

    /// The drawn parameters as CSV columns (names, values), in a fixed order.
    pub fn columns(&self) -> Vec<(String, f64)> {
        let mut columns = Vec::new();
        if let Some(drawn) = &self.drawn {
            let d = &drawn.drawn;
            for i in 0..4 {
                columns.push((format!("link_mass_scale_{}", i + 1), d.mass_scale[i]));
            }
            for i in 0..4 {
                for (axis, value) in ["x", "y", "z"].iter().zip(d.com_shift[i].iter()) {
                    columns.push((format!("link_com_shift_{axis}_{}", i + 1), *value));
                }
            }
            for i in 0..4 {
                columns.push((format!("inertia_rotation_{}", i + 1), d.inertia_angle[i]));
            }
            for i in 0..4 {
                columns.push((format!("viscous_{}", i + 1), d.viscous[i]));
            }
            for i in 0..4 {
                columns.push((format!("coulomb_{}", i + 1), d.coulomb[i]));
            }
            for role in Role::ALL {
                columns.push((format!("{}_mass", role_name(role)), drawn.pieces.dimensions(role).mass));
            }
            if let Some(a) = &drawn.drawn_actuators {
                columns.push(("supply_voltage_scale".into(), a.supply_voltage_scale));
                let per_joint = [
                    ("torque_constant_scale", &a.torque_constant_scale),
                    ("winding_resistance_scale", &a.resistance_scale),
                    ("gear_friction_scale", &a.friction_scale),
                    ("backlash_rad", &a.backlash),
                    ("holding_torque_scale", &a.holding_torque_scale),
                ];
                for (name, values) in per_joint {
                    for (i, value) in values.iter().enumerate() {
                        columns.push((format!("{name}_{}", i + 1), *value));
                    }
                }
            }
        }
        columns
    }
}

impl ConditionOptions {
    /// The options as given, as command-line flags (each with a leading space), for a
    /// command that replays a run under the same conditions. `--seed` and `--trial-seed` are
    /// left out (the replay names its trial).
    pub fn flags(&self) -> String {
        let mut flags = String::new();
        let mut add = |flag: &str, value: String| flags.push_str(&format!(" --{flag} {value}"));
        if let Some(sensors) = &self.sensors {
            add("sensors", crate::app::output::shell_word(sensors));
        }
        if let Some(estimator) = self.estimator {
            let name = match estimator {
                EstimatorChoice::Kalman => "kalman",
                EstimatorChoice::KalmanTwoState => "kalman-two-state",
                EstimatorChoice::Lowpass => "lowpass",
                EstimatorChoice::Direct => "direct",
            };
            add("estimator", name.to_string());
        }
        if let Some(noise) = self.kalman_acceleration_noise {
            add("kalman-acceleration-noise", noise.to_string());
        }
        if let Some(time_constant) = self.lowpass_time_constant {
            add("lowpass-time-constant", time_constant.to_string());
        }
        if let Some(lag) = self.torque_lag {
            add("torque-lag", lag.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","));
        }
        if let Some(plant) = &self.plant {
            add("plant", crate::app::output::shell_word(&plant.display().to_string()));
        }

        if let Some(uncertainty) = &self.uncertainty {
            add("uncertainty", crate::app::output::shell_word(&uncertainty.display().to_string()));
        }
        if self.controller_knows_friction {
            flags.push_str(" --controller-knows-friction");
        }
        flags
    }

    /// The trial seed of a single run: --trial-seed, else --seed.
    pub fn run_seed(&self) -> u64 {
        self.trial_seed.unwrap_or(self.seed)
    }
}
