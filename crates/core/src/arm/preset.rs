//! The report's arm (ERRATA "Facts to keep"), the built-in default model.

use super::link::{DhParameters, Friction, Inertial, JointLimits, Link};

use super::model::{ArmModel, REPORT_GRAVITY};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::{FRAC_PI_2, PI};

/// Height of the shoulder (joint 2) above the board, m (the report's `l1`).
pub const REPORT_L1: f64 = 0.1905;
/// Upper-arm length, m (`l2`).
pub const REPORT_L2: f64 = 0.3048;
/// Forearm length, m (`l3`).
pub const REPORT_L3: f64 = 0.3048;
/// Wrist-to-tool-tip length, m (`l4`).
pub const REPORT_L4: f64 = 0.09525;

/// Default joint limits. Angles: the base turns a full circle; the shoulder from 30° below
/// the horizontal to 150°; elbow and wrist fold to ±170° and ±150°, which covers every square
/// of the board at grip and clearance heights with the tool pointing down. Speeds: 3 rad/s.
/// Torques: what hobby servos of the arm's size deliver (base 10, shoulder 25, elbow 15,
/// wrist 5 N·m); the report's move needs at most a few N·m.
pub const REPORT_LIMITS: [JointLimits; 4] = [
    JointLimits { lower: -PI, upper: PI, velocity: 3.0, torque: 10.0 },
    JointLimits { lower: -PI / 6.0, upper: 5.0 * PI / 6.0, velocity: 3.0, torque: 25.0 },
    JointLimits { lower: -170.0 * PI / 180.0, upper: 170.0 * PI / 180.0, velocity: 3.0, torque: 15.0 },
    JointLimits { lower: -150.0 * PI / 180.0, upper: 150.0 * PI / 180.0, velocity: 3.0, torque: 5.0 },
];

/// The report's 4-DOF arm: base yaw, shoulder, elbow and wrist pitch, standard DH with
/// `d1 = l1, α1 = +90°` and `a2..a4 = l2, l3, l4`. Link masses and inertia tensors as given
/// (tensors about the COM in DH frame i, COM at mid-link), no motors, no friction, g = 9.8 m/s².
pub fn report_arm() -> ArmModel<4> {
    let diag = |x: f64, y: f64, z: f64| Matrix3::from_diagonal(&Vector3::new(x, y, z));
    let upper_tensor = diag(0.007064321, 0.001363701, 0.006558055);
    let link = |dh: DhParameters, mass: f64, com: Vector3<f64>, inertia: Matrix3<f64>, limits: JointLimits| Link {
        dh,
        inertial: Inertial { mass, com, inertia },
        motor_mass: 0.0,
        rotor_inertia: 0.0,
        limits,
        friction: Friction::default(),
    };
    let planar = |a: f64| DhParameters { a, alpha: 0.0, d: 0.0, theta_offset: 0.0 };
    let links = [
        link(
            DhParameters { a: 0.0, alpha: FRAC_PI_2, d: REPORT_L1, theta_offset: 0.0 },
            0.3447302,
            // Mid-link: half-way down the base column, which is frame 1's −y axis.
            Vector3::new(0.0, -REPORT_L1 / 2.0, 0.0),
            diag(0.000708188, 0.001290541, 0.001205675),
            REPORT_LIMITS[0],
        ),
        link(planar(REPORT_L2), 0.5261671, Vector3::new(-REPORT_L2 / 2.0, 0.0, 0.0), upper_tensor, REPORT_LIMITS[1]),
        link(planar(REPORT_L3), 0.5261671, Vector3::new(-REPORT_L3 / 2.0, 0.0, 0.0), upper_tensor, REPORT_LIMITS[2]),
        link(
            planar(REPORT_L4),
            0.2585477,
            Vector3::new(-REPORT_L4 / 2.0, 0.0, 0.0),
            diag(0.00072282, 0.000526751, 0.000579427),
            REPORT_LIMITS[3],
        ),
    ];
    ArmModel::new(links, Vector3::new(0.0, 0.0, -REPORT_GRAVITY)).expect("the report's arm is valid")
}
