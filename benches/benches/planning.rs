//! Time-optimal planning: one pick-and-place parameterised by TOPP-RA, and a whole move
//! planned (legs, blends, clearance, timing, the check at every control period, the joint
//! trajectory).

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::motion::{TimingMode, plan_move};
use chessarm_chess::pieces::PieceSet;
use chessarm_chess::play::home_tool;
use chessarm_chess::shakmaty::uci::UciMove;
use chessarm_chess::shakmaty::{Chess, Position};
use chessarm_chess::table::Table;
use chessarm_chess::tasks::MotionLimits;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::plan::constraints::{
    JointAcceleration, JointSpeed, JointTorque, PathConstraint, ToolAcceleration, ToolSpeed,
};
use chessarm_core::plan::geometric::GeometricPath;
use chessarm_core::plan::optimal::time_leg;
use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use std::hint::black_box;

fn planning(c: &mut Criterion) {
    let arm = report_arm();
    let pieces = PieceSet::default();
    let limits = MotionLimits::default();
    // A pick-and-place of a pawn from e2 to e4 (0.12 m), the default limits: the empty leg
    // from above d1 to the pawn, the carrying leg, each with its blended corners.
    let (h, z) = (0.128, 0.05);
    let empty = GeometricPath::polyline(
        &[
            Vector3::new(0.0, 0.12, 0.2),
            Vector3::new(0.0, 0.12, h),
            Vector3::new(0.03, 0.18, h),
            Vector3::new(0.03, 0.18, z),
        ],
        |_| limits.blend,
    )
    .expect("path");
    let carrying = GeometricPath::polyline(
        &[
            Vector3::new(0.03, 0.18, z),
            Vector3::new(0.03, 0.18, h),
            Vector3::new(0.03, 0.30, h),
            Vector3::new(0.03, 0.30, z),
        ],
        |_| limits.blend,
    )
    .expect("path");
    let loaded = arm.with_payload(Some(pieces.payload(chessarm_chess::shakmaty::Role::Pawn))).expect("payload");
    let max_speed = arm.links().map(|l| l.limits.velocity);
    let speed = JointSpeed { max: max_speed };
    let acceleration = JointAcceleration { max: limits.joint_acceleration };
    let torque = JointTorque { model: arm, margin: limits.torque_margin, max_speed };
    let torque_loaded = JointTorque { model: loaded, margin: limits.torque_margin, max_speed };
    let tool = ToolSpeed { max: limits.tool_speed };
    let carry = ToolAcceleration {
        max: limits.carry_acceleration,
        gravity: Vector3::zeros(),
        label: "tool acceleration while carrying".into(),
    };
    let empty_limits: [&dyn PathConstraint<4>; 4] = [&speed, &acceleration, &torque, &tool];
    let carrying_limits: [&dyn PathConstraint<4>; 5] = [&speed, &acceleration, &torque_loaded, &tool, &carry];
    let plan = |path: &GeometricPath, constraints: &[&dyn PathConstraint<4>]| {
        time_leg(&arm, path, constraints, limits.grid_step, 0, 1e-3).expect("feasible")
    };
    let (a, b) = (plan(&empty, &empty_limits), plan(&carrying, &carrying_limits));
    println!(
        "pick-and-place e2–e4: empty leg {:.3} s on {} grid points, carrying leg {:.3} s on {} grid points",
        a.leg.duration(),
        a.points.len(),
        b.leg.duration(),
        b.points.len()
    );
    let mut group = c.benchmark_group("planning");
    group.bench_function("TOPP-RA: one pick-and-place (empty + carrying leg)", |bench| {
        bench.iter(|| {
            black_box(plan(black_box(&empty), &empty_limits));
            black_box(plan(black_box(&carrying), &carrying_limits))
        })
    });
    let board = BoardGeometry::default();
    let start = Chess::default();
    let table = Table::from_position(board, &start);
    let home = home_tool(&board, &pieces, &limits);
    for (name, uci) in [("quiet e2e4", "e2e4"), ("knight g1f3", "g1f3")] {
        let mv = uci.parse::<UciMove>().expect("uci").to_move(&start).expect("legal");
        assert!(start.is_legal(mv));
        group.bench_function(format!("whole move planned and checked ({name})"), |bench| {
            bench.iter(|| {
                plan_move(home, &start, &mv, &table, &pieces, &limits, &arm, TimingMode::Optimal, 1e-3).expect("plan")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, planning);
criterion_main!(benches);
