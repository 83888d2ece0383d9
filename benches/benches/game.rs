//! A 40-move (80-ply) master game planned and simulated by the arm.

use chessarm_chess::board::BoardGeometry;
use chessarm_chess::motion::TimingMode;
use chessarm_chess::notation::parse_pgn;
use chessarm_chess::play::{Game, Mover, PlaySettings};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::control::gains::{Gains, REPORT_PD};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Instant;

fn play_game(record: &chessarm_chess::notation::GameRecord, plies: usize, timing: TimingMode, clearance: bool) -> f64 {
    let mut settings = PlaySettings::new("pd", Gains::uniform(REPORT_PD.0, REPORT_PD.1, 0.0).expect("valid"));
    settings.record_every = 0;
    settings.timing = timing;
    if !clearance {
        settings.clearance = None;
    }
    let mut game = Game::new(report_arm(), BoardGeometry::default(), record.start.clone(), settings).expect("setup");
    for mv in record.moves.iter().take(plies) {
        game.play(mv, Mover::Robot).expect("playable");
    }
    assert_eq!(game.fen_physical(), game.fen_rules());
    game.robot_time()
}

fn game(c: &mut Criterion) {
    let text = include_str!("../../crates/chess/tests/fixtures/kasparov_topalov_1999.pgn");
    let record = parse_pgn(text).expect("valid PGN").remove(0);
    let mut group = c.benchmark_group("game");
    group.sample_size(10);
    // The clearance check's cost: the time-optimal game with and without it.
    group.bench_function("40-move game (80 plies), time-optimal, PD, 1 kHz, without the clearance check", |b| {
        b.iter(|| play_game(&record, 80, TimingMode::Optimal, false))
    });
    for (name, timing) in [("time-optimal", TimingMode::Optimal), ("LSPB", TimingMode::Lspb)] {
        let started = Instant::now();
        let robot_time = play_game(&record, 80, timing, true);
        let wall = started.elapsed().as_secs_f64();
        println!(
            "40 moves of Kasparov–Topalov, {name}: robot time {robot_time:.1} s, wall {wall:.3} s, {:.0}× real time",
            robot_time / wall
        );
        group.bench_function(format!("40-move game (80 plies) planned and simulated, {name}, PD, 1 kHz"), |b| {
            b.iter(|| play_game(&record, 80, timing, true))
        });
    }
    group.finish();
}

criterion_group!(benches, game);
criterion_main!(benches);
