//! The setup file (`--arm FILE`): the arm model and the board, as TOML.
//!
//! Every section and field is optional and defaults to the report's setup, so a file may say
//! only what differs. Units are SI: m, rad, kg, kg·m², N·m, s.

use anyhow::{Context, Result, anyhow};
use chessarm_chess::board::BoardGeometry;
use chessarm_chess::pieces::{PieceDimensions, PieceSet};
use chessarm_core::arm::model::{ArmModel, DhParameters, Friction, Inertial, JointLimits, Link};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::nalgebra::{Matrix3, Rotation3, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One link of the arm in the file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LinkFile {
    /// DH link length a, m.
    pub a: f64,
    /// DH twist alpha, rad.
    pub alpha: f64,
    /// DH offset d, m.
    pub d: f64,
    /// Constant added to the joint angle, rad.
    #[serde(default)]
    pub theta_offset: f64,
    /// Link mass, kg.
    pub mass: f64,
    /// Centre of mass in DH frame i, m.
    pub com: [f64; 3],
    /// Inertia tensor about the COM, kg·m², in the frame given by `inertia_rpy`.
    pub inertia: [[f64; 3]; 3],
    /// Roll, pitch, yaw (rad) of the tensor's frame relative to DH frame i. The report's CAD
    /// tensors for links 2 and 3 look exported with the link along y; state that here.
    #[serde(default)]
    pub inertia_rpy: [f64; 3],
    /// Motor mass at this joint, kg (a point mass on link i−1 at the joint axis).
    #[serde(default)]
    pub motor_mass: f64,
    /// Reflected rotor inertia, kg·m².
    #[serde(default)]
    pub rotor_inertia: f64,
    /// Lowest joint angle, rad.
    pub lower: f64,
    /// Highest joint angle, rad.
    pub upper: f64,
    /// Largest joint speed, rad/s.
    pub velocity_limit: f64,
    /// Largest motor torque, N·m.
    pub torque_limit: f64,
    /// Viscous friction, N·m·s/rad (plant only).
    #[serde(default)]
    pub viscous: f64,
    /// Coulomb friction, N·m (plant only).
    #[serde(default)]
    pub coulomb: f64,
}

/// The board in the file.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoardFile {
    /// Distance between square centres, m.
    pub square_size: f64,
    /// Centre of the board in the base frame (x, y), m.
    pub center: [f64; 2],
    /// Height of the board surface, m.
    pub surface_height: f64,
}

/// One kind of chess piece in the file.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PieceFile {
    /// Height, m.
    pub height: f64,
    /// Base diameter, m.
    pub base_diameter: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Height above the piece's base where the tool tip grips it, m.
    pub grip_height: f64,
}

/// The piece set in the file (each kind optional).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct PiecesFile {
    pub pawn: Option<PieceFile>,
    pub knight: Option<PieceFile>,
    pub bishop: Option<PieceFile>,
    pub rook: Option<PieceFile>,
    pub queen: Option<PieceFile>,
    pub king: Option<PieceFile>,
}

/// The whole setup file. Fields left out take the report's values.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct SetupFile {
    /// Gravitational acceleration in the base frame, m/s².
    pub gravity: [f64; 3],
    pub board: BoardFile,
    /// The chess pieces as physical objects.
    pub pieces: PiecesFile,
    /// Links from the base to the tool, in order.
    pub links: Vec<LinkFile>,
}

/// What a setup file describes, validated.
#[derive(Debug, Clone)]
pub struct Setup {
    pub arm: ArmModel<4>,
    pub board: BoardGeometry,
    pub pieces: PieceSet,
}

impl Default for Setup {
    fn default() -> Self {
        Self { arm: report_arm(), board: BoardGeometry::default(), pieces: PieceSet::default() }
    }
}

impl Setup {
    /// The report's setup, or the one in `path` with defaults for what it leaves out.
    pub fn load(path: Option<&Path>) -> Result<Self> {
        match path {
            None => Ok(Self::default()),
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read arm file {}", path.display()))?;
                Self::parse(&text).with_context(|| format!("arm file {}", path.display()))
            }
        }
    }

    /// Parses and validates a setup from TOML text.
    pub fn parse(text: &str) -> Result<Self> {
        let file: SetupFile = toml::from_str(text).map_err(|e| anyhow!(one_line_toml_error(text, &e)))?;
        file.to_setup()
    }

    /// The setup as TOML, with a header that names the units.
    pub fn to_toml(&self) -> Result<String> {
        let body = toml::to_string_pretty(&SetupFile::from(self))?;
        Ok(format!("{HEADER}{body}"))
    }
}

const HEADER: &str = "\
# chessarm setup: the arm (standard DH, one [[links]] table per joint, base to tool), the board
# and the chess pieces (height, base diameter, mass, grip height above the piece's base).
# Units: m, rad, kg, kg·m² (inertia about the COM in DH frame i, rotated by inertia_rpy), N·m, s.
# Every field may be left out; the report's values are the defaults.
";

/// `message (line L, column C)` from a TOML error, on one line.
fn one_line_toml_error(text: &str, error: &toml::de::Error) -> String {
    let message = error.message().trim().replace('\n', " ");
    match error.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: {message}")
        }
        None => message,
    }
}

impl SetupFile {
    fn to_setup(&self) -> Result<Setup> {
        let links: [LinkFile; 4] = self.links.clone().try_into().map_err(|links: Vec<LinkFile>| {
            anyhow!("links: the chess arm has 4 joints, the file lists {}", links.len())
        })?;
        let links = links.map(|link| link.to_link());
        let gravity = Vector3::from(self.gravity);
        let arm = ArmModel::new(links, gravity)?;
        let board = BoardGeometry {
            square_size: self.board.square_size,
            center: Vector2::from(self.board.center),
            surface_height: self.board.surface_height,
        }
        .validated()?;
        let defaults = PieceSet::default();
        let pick = |given: Option<PieceFile>, default: PieceDimensions| {
            given.map_or(default, |p| PieceDimensions {
                height: p.height,
                base_diameter: p.base_diameter,
                mass: p.mass,
                grip_height: p.grip_height,
            })
        };
        let pieces = PieceSet {
            pawn: pick(self.pieces.pawn, defaults.pawn),
            knight: pick(self.pieces.knight, defaults.knight),
            bishop: pick(self.pieces.bishop, defaults.bishop),
            rook: pick(self.pieces.rook, defaults.rook),
            queen: pick(self.pieces.queen, defaults.queen),
            king: pick(self.pieces.king, defaults.king),
        }
        .validated()?;
        Ok(Setup { arm, board, pieces })
    }
}

impl LinkFile {
    fn to_link(&self) -> Link {
        let [roll, pitch, yaw] = self.inertia_rpy;
        let rotation = Rotation3::from_euler_angles(roll, pitch, yaw);
        let tensor = Matrix3::from_fn(|r, c| self.inertia[r][c]);
        Link {
            dh: DhParameters { a: self.a, alpha: self.alpha, d: self.d, theta_offset: self.theta_offset },
            inertial: Inertial {
                mass: self.mass,
                com: Vector3::from(self.com),
                inertia: rotation.matrix() * tensor * rotation.matrix().transpose(),
            },
            motor_mass: self.motor_mass,
            rotor_inertia: self.rotor_inertia,
            limits: JointLimits {
                lower: self.lower,
                upper: self.upper,
                velocity: self.velocity_limit,
                torque: self.torque_limit,
            },
            friction: Friction { viscous: self.viscous, coulomb: self.coulomb },
        }
    }
}

impl Default for SetupFile {
    fn default() -> Self {
        Self::from(&Setup::default())
    }
}

impl From<&Setup> for SetupFile {
    fn from(setup: &Setup) -> Self {
        let links = setup
            .arm
            .links()
            .iter()
            .map(|link| LinkFile {
                a: link.dh.a,
                alpha: link.dh.alpha,
                d: link.dh.d,
                theta_offset: link.dh.theta_offset,
                mass: link.inertial.mass,
                com: link.inertial.com.into(),
                inertia: std::array::from_fn(|r| std::array::from_fn(|c| link.inertial.inertia[(r, c)])),
                inertia_rpy: [0.0; 3],
                motor_mass: link.motor_mass,
                rotor_inertia: link.rotor_inertia,
                lower: link.limits.lower,
                upper: link.limits.upper,
                velocity_limit: link.limits.velocity,
                torque_limit: link.limits.torque,
                viscous: link.friction.viscous,
                coulomb: link.friction.coulomb,
            })
            .collect();
        SetupFile {
            gravity: setup.arm.gravity().into(),
            board: BoardFile {
                square_size: setup.board.square_size,
                center: setup.board.center.into(),
                surface_height: setup.board.surface_height,
            },
            pieces: {
                let file = |d: &PieceDimensions| {
                    Some(PieceFile {
                        height: d.height,
                        base_diameter: d.base_diameter,
                        mass: d.mass,
                        grip_height: d.grip_height,
                    })
                };
                let p = &setup.pieces;
                PiecesFile {
                    pawn: file(&p.pawn),
                    knight: file(&p.knight),
                    bishop: file(&p.bishop),
                    rook: file(&p.rook),
                    queen: file(&p.queen),
                    king: file(&p.king),
                }
            },
            links,
        }
    }
}
