//! `board`: whether the arm serves the setup's board (every square, slot and traverse a game can
//! ask for), and with `--fit` the largest board it serves, printed as a setup file.

use crate::cli::BoardArgs;
use crate::config::Setup;
use crate::plots::{HeatMap, plot_heat_map};
use anyhow::{Result, anyhow};
use chessarm_chess::reach::{check_table, fit_board, square_margins};
use serde_json::json;

pub fn run(setup: &Setup, args: &BoardArgs) -> Result<()> {
    let limits = setup.motion;
    let started = std::time::Instant::now();
    let mut fitted = setup.clone();
    let mut tried = None;
    if args.fit {
        let fit = fit_board(
            &setup.arm,
            &setup.pieces,
            setup.board.square_size,
            &limits,
            (setup.board.surface_height, setup.board.base_clearance),
        )
        .map_err(|e| anyhow!("{e}"))?;
        fitted.board = fit.board;
        fitted.pieces = fit.pieces;
        tried = Some(fit.tried);
    }
    let seconds = started.elapsed().as_secs_f64();
    let check = check_table(&setup.arm, &fitted.board, &fitted.pieces, &limits);
    let margins = square_margins(&setup.arm, &fitted.board, &fitted.pieces, &limits);
    if let Some(map) = &args.map {
        plot_reach_map(map, &fitted, &margins)?;
    }
    let board = &fitted.board;
    let smallest = margins.iter().filter_map(|(_, m)| m.as_ref().ok()).copied().fold(f64::INFINITY, f64::min);
    let summary = format!(
        "board: squares of {:.1} mm, centre ({:.4}, {:.4}) m, yaw {:.4} rad{}; {}{}\n",
        board.square_size * 1e3,
        board.center.x,
        board.center.y,
        board.yaw,
        tried.map_or(String::new(), |n| format!(" (the largest of {n} poses tried, in {seconds:.2} s)")),
        match &check {
            Ok(()) =>
                format!("every square, slot and traverse is served; smallest radial margin {:.1} mm", smallest * 1e3),
            Err(error) => format!("NOT served: {error}"),
        },
        args.map.as_ref().map_or(String::new(), |m| format!("; reach map {}", m.display())),
    );
    if args.fit {
        let mut text = fitted.to_toml_beside_urdf()?;
        if setup.urdf_path.is_some() {
            text = format!(
                "# The board fitted to the arm of --urdf {}: use it with the same --urdf ([urdf] holds its --lock and \
                 --tool).\n{text}",
                setup.urdf_path.as_ref().map_or(String::new(), |p| p.display().to_string())
            );
        }
        let value = json!({
            "square_size_m": board.square_size,
            "center_m": [board.center.x, board.center.y],
            "yaw_rad": board.yaw,
            "served": check.is_ok(),
            "smallest_margin_m": smallest,
            "poses_tried": tried,
            "seconds": seconds,
            "setup": text,
            "setup_file": args.save.as_ref().map(|p| p.display().to_string()),
        });
        match &args.save {
            // The setup in its file, the summary on stdout.
            Some(path) => {
                crate::output::write_atomic(path, |out| Ok(out.write_all(text.as_bytes())?))?;
                crate::emit(&format!("{summary}setup file: {}\n", path.display()), &value)?;
            }
            // The setup file on stdout (with --json, one JSON line instead); the summary on stderr.
            None => {
                crate::tell(&summary);
                crate::emit(&text, &value)?;
            }
        }
    } else {
        crate::emit(
            &summary,
            &json!({ "served": check.is_ok(), "why_not": check.as_ref().err().map(ToString::to_string), "smallest_margin_m": smallest }),
        )?;
    }
    // A board that is not served is a failed check.
    check.map_err(|e| anyhow!("the board is not served: {e}"))
}

/// Per square, the radial margin (mm) or grey where it is not served.
fn plot_reach_map(
    path: &std::path::Path,
    setup: &Setup,
    margins: &[(chessarm_chess::shakmaty::Square, std::result::Result<f64, String>)],
) -> Result<()> {
    let mut cells = vec![vec![None; 8]; 8];
    let mut failed = Vec::new();
    for (square, margin) in margins {
        let (file, rank) = (usize::from(u8::from(square.file())), usize::from(u8::from(square.rank())));
        match margin {
            Ok(m) => cells[rank][file] = Some(m * 1e3),
            Err(why) => failed.push(why.clone()),
        }
    }
    let files: Vec<f64> = (1..=8).map(f64::from).collect();
    let title = format!(
        "reach margin per square (mm): squares of {:.1} mm, yaw {:.3} rad",
        setup.board.square_size * 1e3,
        setup.board.yaw
    );
    plot_heat_map(
        path,
        &HeatMap {
            title: &title,
            x_label: "file (1 = a)",
            y_label: "rank",
            value_label: "radial margin (mm)",
            x_values: &files,
            y_values: &files,
            values: &cells,
            marked: None,
            note: failed.first().map(|why| format!("grey: not served ({} squares), e.g. {why}", failed.len())),
        },
    )
}
