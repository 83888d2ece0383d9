//! The arm's limits and efforts: speed and torque limits the file does not give, taken as the
//! other arm joints' smallest; and values checked against the arm's physics (torque limits far
//! above what gravity asks of the joints, inertias beyond the arm's reach), told as placeholders.

use super::read::{JointElement, at, inertial};
use chessarm_core::arm::chain::ChainJoint;
use chessarm_core::arm::link::JointLimits;
use chessarm_core::arm::model::ArmModel;
use roxmltree::Node;
use std::collections::BTreeMap;

/// A torque limit more than this many times the largest gravity torque is a placeholder.
pub const PLACEHOLDER_TORQUE_RATIO: f64 = 20.0;

/// Speed and torque limits not given (a continuous joint without `<limit>`, or 0): the other
/// arm joints' smallest, said as a warning (returned); none given at all is a problem.
pub(super) fn fill_missing_limits(
    chain_joints: &mut [ChainJoint],
    joints: &[JointElement<'_, '_>],
    arm: &[usize],
    problems: &mut Vec<String>,
) -> Vec<String> {
    let mut filled = Vec::new();
    for k in 0..chain_joints.len() {
        for (name, pick) in [("velocity", 0), ("effort", 1)] {
            let get = |l: &JointLimits| if pick == 0 { l.velocity } else { l.torque };
            if get(&chain_joints[k].limits) > 0.0 {
                continue;
            }
            let others = chain_joints.iter().map(|j| get(&j.limits)).filter(|v| *v > 0.0).fold(f64::INFINITY, f64::min);
            let node = at(&joints[arm[k]].node);
            if others.is_finite() {
                let limits = &mut chain_joints[k].limits;
                if pick == 0 {
                    limits.velocity = others
                } else {
                    limits.torque = others
                }
                filled.push(format!(
                    "{node}: no {name} limit given (missing or 0): taken as {} {}, the smallest of the other arm joints'",
                    chessarm_core::short_number(others),
                    if pick == 0 { "rad/s" } else { "N·m" }
                ));
            } else {
                problems.push(format!("{node}: no arm joint gives a {name} limit: add <limit {name}=\"…\"/>"));
            }
        }
    }
    filled
}

/// Values that look like a URDF's placeholders rather than the arm's physics: torque limits
/// far above what holding the arm against gravity needs (more than [`PLACEHOLDER_TORQUE_RATIO`]
/// times the largest gravity torque of the pitch joints over their ranges), and links whose
/// inertia means a radius of gyration beyond the whole arm's reach: (the efforts', the links').
pub(super) fn placeholder_warnings(
    model: &ArmModel<4>,
    names: &[String; 4],
    joints: &[JointElement<'_, '_>],
    links: &BTreeMap<String, Node<'_, '_>>,
    by_name: &BTreeMap<String, usize>,
    arm: &[usize],
) -> (Vec<String>, Vec<String>) {
    let mut efforts = Vec::new();
    let mut warnings = Vec::new();
    let need = gravity_need(model);
    let largest = need.iter().copied().fold(0.0, f64::max);
    for (k, name) in names.iter().enumerate() {
        let torque = model.link(k).limits.torque;
        // The yaw holds no weight: it is compared with the largest pitch need.
        let reference = if k == 0 { largest } else { need[k] };
        if reference > 0.0 && torque > PLACEHOLDER_TORQUE_RATIO * reference {
            let node = by_name.get(name).map(|j| at(&joints[*j].node)).unwrap_or_default();
            efforts.push(format!(
                "{node}: effort=\"{}\" N·m is {:.0}× the {:.3} N·m gravity asks of it at worst: a placeholder? The \
                 planner and the controllers take it as the motor's limit (give the servo's stall torque)",
                chessarm_core::short_number(torque),
                torque / reference,
                reference
            ));
        }
    }
    let reach: f64 = model.links().iter().map(|l| l.dh.a.abs() + l.dh.d.abs()).sum::<f64>() + model.base().norm();
    let _ = arm;
    for (name, node) in links {
        let Ok(Some(body)) = inertial(node) else { continue };
        if body.mass <= 0.0 {
            continue;
        }
        let largest_moment = body.inertia.symmetric_eigenvalues().max();
        let gyration = (largest_moment.max(0.0) / body.mass).sqrt();
        if gyration > reach {
            warnings.push(format!(
                "{}: link '{name}' of {} kg has an inertia of {} kg·m², as if its mass were {:.2} m from its centre, \
                 beyond the arm's reach of {:.2} m: a placeholder? It is taken as given",
                at(node),
                chessarm_core::short_number(body.mass),
                chessarm_core::short_number(largest_moment),
                gyration,
                reach
            ));
        }
    }
    (efforts, warnings)
}

/// The largest gravity torque of each joint over a grid of its pitch joints' ranges, N·m.
pub(super) fn gravity_need(model: &ArmModel<4>) -> [f64; 4] {
    let mut need = [0.0; 4];
    let steps = 7;
    let value = |k: usize, i: usize| {
        let limits = model.link(k).limits;
        limits.lower + (limits.upper - limits.lower) * i as f64 / (steps - 1) as f64
    };
    for a in 0..steps {
        for b in 0..steps {
            for c in 0..steps {
                let q = chessarm_core::arm::model::JointVector::<4>::new(0.0, value(1, a), value(2, b), value(3, c));
                let torque = chessarm_core::arm::dynamics::gravity_torques(model, &q);
                for k in 0..4 {
                    need[k] = f64::max(need[k], torque[k].abs());
                }
            }
        }
    }
    need
}
