//! The arm's solids: what it is made of in space, for drawing it (the URDF export, the replay)
//! and for keeping it clear of the pieces and the board.
//!
//! Every joint has a motor housing, a cylinder of [`JOINT_RADIUS`] and [`JOINT_LENGTH`] about
//! its axis centred on the axis' point `p_j` of its DH frame; every link a cylinder of
//! [`LINK_RADIUS`] from its joint's point to the next frame's origin (none where they
//! coincide); a pedestal of twice the joint radius stands under the base, and the tool tip
//! carries a sphere of [`TOOL_RADIUS`]. All positions are in the base frame, m.

use crate::arm::kinematics::FrameChain;
use crate::arm::model::{ArmModel, JointVector};
use nalgebra::Vector3;

/// Radius of the links' cylinders, m.
pub const LINK_RADIUS: f64 = 0.015;
/// Radius and length of the joints' motor housings, m.
pub const JOINT_RADIUS: f64 = 0.022;
pub const JOINT_LENGTH: f64 = 0.05;
/// Radius of the tool's sphere, m.
pub const TOOL_RADIUS: f64 = 0.008;

/// A convex solid in the base frame, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// A cylinder of `radius` whose end faces are centred on `a` and `b`.
    Cylinder { a: Vector3<f64>, b: Vector3<f64>, radius: f64 },
    /// A sphere of `radius` about `centre`.
    Sphere { centre: Vector3<f64>, radius: f64 },
}

/// The part of the arm a solid belongs to (joints and links 1-based, as the report counts them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    Pedestal,
    Housing(usize),
    Link(usize),
    Tool,
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Part::Pedestal => write!(f, "pedestal"),
            Part::Housing(j) => write!(f, "joint {j}'s housing"),
            Part::Link(i) => write!(f, "link {i}"),
            Part::Tool => write!(f, "tool"),
        }
    }
}

/// One solid of the arm and the part it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmSolid {
    pub part: Part,
    pub solid: Solid,
}

/// The arm's solids at the joint angles `q` (rad) into `out` (cleared first; at most `2N + 2`,
/// so a buffer kept between calls allocates once): the pedestal, then per joint its housing and
/// its link, then the tool.
pub fn solids_into<const N: usize>(model: &ArmModel<N>, q: &JointVector<N>, out: &mut Vec<ArmSolid>) {
    out.clear();
    let chain = FrameChain::new(model, q);
    out.push(ArmSolid {
        part: Part::Pedestal,
        solid: Solid::Cylinder { a: -JOINT_LENGTH * Vector3::z(), b: Vector3::zeros(), radius: 2.0 * JOINT_RADIUS },
    });
    for j in 0..N {
        let (axis, point) = chain.joint_axis(j);
        let half = 0.5 * JOINT_LENGTH * axis;
        out.push(ArmSolid {
            part: Part::Housing(j + 1),
            solid: Solid::Cylinder { a: point - half, b: point + half, radius: JOINT_RADIUS },
        });
        let next = chain.body_pose(j).translation.vector;
        if (next - point).norm() > 1e-9 {
            out.push(ArmSolid {
                part: Part::Link(j + 1),
                solid: Solid::Cylinder { a: point, b: next, radius: LINK_RADIUS },
            });
        }
    }
    out.push(ArmSolid { part: Part::Tool, solid: Solid::Sphere { centre: chain.tip(), radius: TOOL_RADIUS } });
}
