//! What a game asks of the arm's reach: the pre-flight check of the report's board
//! (every location at every height, every traverse between two of them, every column's
//! clearance), and `board --fit`'s search for a maker's arm from its official URDF (the
//! OpenManipulator-X, as published), on reach alone, and `board --fit --square-size`'s
//! placement of the report's arm's board of 5 cm squares, columns checked.

use chessarm::app::setup::file::Setup;
use chessarm_chess::reach::{check_table, fit_board, place_board};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn reach(c: &mut Criterion) {
    let mut group = c.benchmark_group("reach");
    group.sample_size(10);
    let setup = Setup::default();
    group.bench_function("pre-flight check, the report's arm and board", |b| {
        b.iter(|| {
            check_table(black_box(&setup.arm), &setup.board, &setup.pieces, &setup.motion, Some(&setup.clearance))
                .expect("the report's board is served")
        })
    });
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../crates/cli/tests/fixtures/real-arms/open_manipulator_x.urdf");
    let arm = chessarm::app::setup::urdf_import::load(std::path::Path::new(path), &Default::default())
        .expect("the arm loads");
    group.bench_function("board --fit, OpenManipulator-X", |b| {
        b.iter(|| {
            let square = setup.board.square_size;
            fit_board(black_box(&arm.model), &setup.pieces, square, &setup.motion, (0.0, 0.05), None)
                .expect("a board fits")
        })
    });
    group.bench_function("board --fit --square-size 0.05, the report's arm", |b| {
        b.iter(|| {
            let square = setup.board.square_size;
            let table = (setup.board.surface_height, setup.board.base_clearance);
            place_board(
                black_box(&setup.arm),
                &setup.pieces,
                square,
                0.05,
                &setup.motion,
                table,
                Some(&setup.clearance),
            )
            .expect("5 cm squares are placed")
        })
    });
    group.finish();
}

criterion_group!(benches, reach);
criterion_main!(benches);
