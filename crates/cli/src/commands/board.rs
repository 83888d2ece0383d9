//! `board`: whether the arm serves the setup's board (every square, slot and traverse a game can
//! ask for), and with `--fit` the largest board it serves, printed as a setup file.

use crate::app::setup::file::Setup;
use crate::app::studies::board::{BoardFit, BoardStudy, board_study};
use crate::cli::BoardArgs;
use anyhow::{Context, Result, anyhow};
use chessarm_chess::sag::SquareHold;
use serde_json::json;

/// Refuses, before any work, output paths the board's files cannot go to: a plot not named
/// `.png`, a file there that chessarm did not write.
fn check_outputs(args: &BoardArgs) -> Result<()> {
    for (flag, path) in [("--map", &args.map), ("--sag-map", &args.sag_map)] {
        let Some(path) = path else { continue };
        let png = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !png {
            anyhow::bail!(
                "{flag} {}: the map is drawn as a PNG image; give a file name ending in .png",
                path.display()
            );
        }
        crate::app::output::refuse_if_not_ours(path, flag).with_context(|| format!("{flag} {}", path.display()))?;
    }
    if let Some(path) = &args.save {
        if path.is_dir() {
            anyhow::bail!("--save {}: a folder; give the setup file's name (FILE.toml)", path.display());
        }
        crate::app::output::refuse_if_not_ours(path, "--save").with_context(|| format!("--save {}", path.display()))?;
    }
    Ok(())
}

/// How many of an unplaced board's failures the summary lists.
const SHOWN: usize = 12;

pub fn run(setup: &Setup, args: &BoardArgs) -> Result<()> {
    check_outputs(args)?;
    let fit = match (args.fit, &args.square_size) {
        (false, _) => BoardFit::Check,
        (true, None) => BoardFit::Largest,
        (true, Some(size)) => BoardFit::Place(size.metres),
    };
    let typed = args.square_size.as_ref().map_or(String::new(), |s| s.typed.clone());
    // A setup file an earlier run wrote at --save would look like this run's if this one
    // fails: it goes now (check_outputs refused any file chessarm did not write).
    if let Some(path) = &args.save {
        crate::app::output::remove_stale(std::slice::from_ref(path))
            .with_context(|| format!("--save {}", path.display()))?;
    }
    let BoardStudy { fitted, tried, seconds, check, margins, smallest, sag, fingers_need: needed, unplaced, failures } =
        board_study(setup, fit, args.sag_map.is_some())?;
    let listed = || {
        format!(
            "{}{}",
            failures.iter().take(SHOWN).map(|(_, why)| format!("  {why}\n")).collect::<String>(),
            match failures.len().saturating_sub(SHOWN) {
                0 => String::new(),
                more => format!("  … and {more} more (--json lists every one)\n"),
            }
        )
    };
    let failures_json: Vec<_> = failures.iter().map(|(place, why)| json!({"place": place, "why": why})).collect();
    if let Some(map) = &args.map {
        plot_reach_map(map, &fitted, &margins).with_context(|| format!("--map {}", map.display()))?;
    }
    if let (Some(path), Some(sag)) = (&args.sag_map, &sag) {
        plot_sag_map(path, sag).with_context(|| format!("--sag-map {}", path.display()))?;
    }
    let sag_text = sag.as_ref().map_or(String::new(), |sag| sag_table(setup, sag));
    let sag_json = sag.as_ref().map(|sag| sag_json(setup, sag));
    let board = &fitted.board;
    let summary = format!(
        "board: squares of {:.1} mm, centre ({:.4}, {:.4}) m, yaw {:.4} rad{}; {}{}\n",
        board.square_size * 1e3,
        board.center.x,
        board.center.y,
        board.yaw,
        match (tried, fit) {
            (None, _) => String::new(),
            (Some(n), BoardFit::Place(_)) if unplaced.is_some() => format!(" ({n} poses tried, in {seconds:.2} s)"),
            (Some(n), BoardFit::Place(_)) => format!(" (placed among {n} poses tried, in {seconds:.2} s)"),
            (Some(n), _) => format!(" (the largest of {n} poses tried, in {seconds:.2} s)"),
        },
        match &check {
            Ok(pitch) => format!(
                "every square, slot and traverse is served{}; smallest radial margin {:.1} mm",
                if *pitch == chessarm_core::arm::task::TOOL_DOWN {
                    String::new()
                } else {
                    format!(
                        " with the tool {} ([motion] max_tilt)",
                        chessarm_chess::clearance::columns::tilt_words(*pitch)
                    )
                },
                smallest * 1e3
            ),
            Err(error) => match &unplaced {
                // Each reason names its place; the first few, the rest counted (--json has all).
                Some(_) => format!("NOT placed: {error}:\n{}", listed()),
                None => format!(
                    "NOT served: {error}\n{} place{} fail{} with the tool straight down:\n{}",
                    failures.len(),
                    if failures.len() == 1 { "" } else { "s" },
                    if failures.len() == 1 { "s" } else { "" },
                    listed()
                ),
            },
        },
        args.map.as_ref().map_or(String::new(), |m| format!("; reach map {}", m.display())),
    );
    let file = crate::app::studies::board::file_fingers(setup);
    let fingers_text = format!(
        "{}: squares of at least {:.1} mm keep them {:.1} mm from the neighbours of the piece they open around{}\n",
        file.map_or("fingers".to_string(), |f| format!(
            "the file's fingers ({:.1} mm thick, {:.1} mm wide across the tool tip, closing to {:.1} mm, opening to {:.1} \
             mm)",
            f.gripper.finger_thickness * 1e3,
            f.gripper.finger_width * 1e3,
            f.gaps[0] * 1e3,
            f.gaps[1] * 1e3
        )),
        needed * 1e3,
        setup.clearance.margin * 1e3,
        if board.square_size < needed { " — these squares are SMALLER: the planner will refuse moves" } else { "" }
    );
    let summary = format!("{summary}{fingers_text}{sag_text}");
    if let Some(nearest) = &unplaced {
        // Squares of the size asked for fit nowhere: no setup file is written or printed.
        let failures = &failures_json;
        crate::emit(
            &summary,
            &json!({
                "served": false,
                "square_size_m": board.square_size,
                "nearest": {"center_m": [board.center.x, board.center.y], "yaw_rad": board.yaw,
                            "tool_pitch_rad": nearest.pitch},
                "failures": failures,
                "poses_tried": tried,
                "seconds": seconds,
                "fingers_need_square_size_m": needed,
            }),
        )?;
        anyhow::bail!(
            "--square-size {typed}: {nearest} ({}){}",
            if crate::json_output() { "each in the JSON's failures" } else { "listed above" },
            args.map.as_ref().map_or(String::new(), |m| format!("; the nearest pose's reach map is {}", m.display()))
        );
    }
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
            "tool_pitch_rad": check.as_ref().ok(),
            "smallest_margin_m": smallest,
            "poses_tried": tried,
            "seconds": seconds,
            "setup": text,
            "setup_file": args.save.as_ref().map(|p| p.display().to_string()),
            "sag": sag_json,
            "fingers_need_square_size_m": needed,
        });
        match &args.save {
            // The setup in its file, the summary on stdout.
            Some(path) => {
                crate::app::output::write_atomic(path, |out| Ok(out.write_all(text.as_bytes())?))
                    .with_context(|| format!("--save {}", path.display()))?;
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
            &json!({
                "served": check.is_ok(),
                "tool_pitch_rad": check.as_ref().ok(),
                "why_not": check.as_ref().err().map(ToString::to_string),
                "failures": failures_json,
                "smallest_margin_m": smallest,
                "sag": sag_json,
                "fingers_need_square_size_m": needed,
            }),
        )?;
    }
    // A board that is not served is a failed check.
    check.map(|_| ()).map_err(|e| anyhow!("the board is not served: {e}"))
}

/// Per square, the radial margin (mm) or grey where it is not served.
fn plot_reach_map(
    path: &std::path::Path,
    setup: &Setup,
    margins: &[(chessarm_chess::shakmaty::Square, std::result::Result<f64, String>)],
) -> Result<()> {
    let title = format!(
        "reach margin per square (mm): squares of {:.1} mm, yaw {:.3} rad",
        setup.board.square_size * 1e3,
        setup.board.yaw
    );
    let values =
        margins.iter().map(|(square, margin)| (*square, margin.as_ref().map(|m| m * 1e3).map_err(Clone::clone)));
    crate::app::formats::plots::plot_squares(path, &title, "radial margin (mm)", values, "not served")
}

/// The sag table for people: per rank (8 at the top), the largest horizontal tool-tip error of
/// any piece on each square (mm; `--` where the arm does not reach), the largest drop, then the
/// least headroom.
fn sag_table(setup: &Setup, sag: &[SquareHold]) -> String {
    let mut text = format!(
        "sag with plain goals ({}): largest tool-tip error across the board per square, mm (files a–h)\n",
        setup.actuator_names.join(", ")
    );
    for rank in (0..8).rev() {
        text.push_str(&format!("  {} ", rank + 1));
        for file in 0..8 {
            let hold = &sag[rank * 8 + file];
            text.push_str(&hold.worst_error().map_or("    --".to_string(), |e| format!(" {:5.2}", e * 1e3)));
        }
        text.push('\n');
    }
    let drop = sag.iter().filter_map(|h| h.worst_drop().map(|d| (d, h.square))).max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((drop, square)) = drop {
        text.push_str(&format!(
            "largest drop of the tool below its planned height: {:.2} mm, on {square}\n",
            drop * 1e3
        ));
    }
    let least =
        sag.iter().filter_map(|h| h.least_headroom().map(|(r, j)| (r, j, h.square))).min_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((headroom, joint, square)) = least {
        text.push_str(&format!(
            "least torque headroom: {:.0} % of joint {joint}'s stall torque left, on {square}{}\n",
            headroom * 100.0,
            if headroom < 0.0 { " (it cannot hold the piece there)" } else { "" }
        ));
    }
    text
}

/// The sag per square for `--json` (SI, and mm for the placement error).
fn sag_json(setup: &Setup, sag: &[SquareHold]) -> serde_json::Value {
    let squares: Vec<serde_json::Value> = sag
        .iter()
        .map(|hold| match &hold.pieces {
            Err(why) => json!({ "square": hold.square.to_string(), "reached": false, "why_not": why }),
            Ok(pieces) => json!({
                "square": hold.square.to_string(),
                "reached": true,
                "worst_error_mm": hold.worst_error().map(|e| e * 1e3),
                "worst_drop_mm": hold.worst_drop().map(|e| e * 1e3),
                "least_headroom": hold.least_headroom().map(|(r, _)| r),
                "least_headroom_joint": hold.least_headroom().map(|(_, j)| j),
                "pieces": pieces.iter().map(|p| json!({
                    "piece": chessarm_chess::pieces::role_name(p.role),
                    "error_mm": p.error * 1e3,
                    "height_error_mm": p.height_error * 1e3,
                    "sag_rad": setup.convention.user(p.sag),
                    "load_nm": setup.convention.user(p.load),
                    "headroom": p.headroom,
                })).collect::<Vec<_>>(),
            }),
        })
        .collect();
    json!({ "actuators": setup.actuator_names, "squares": squares })
}

/// Per square, the largest horizontal tool-tip error (mm) with plain goals, grey where not
/// reached.
fn plot_sag_map(path: &std::path::Path, sag: &[SquareHold]) -> Result<()> {
    let least = sag.iter().filter_map(SquareHold::least_headroom).min_by(|a, b| a.0.total_cmp(&b.0));
    let title = format!(
        "sag, plain goals: tool-tip error across the board (mm){}",
        least.map_or(String::new(), |(r, j)| format!("; least headroom {:.0} % (joint {j})", r * 100.0))
    );
    let values = sag.iter().map(|hold| {
        let value = match &hold.pieces {
            Ok(_) => Ok(hold.worst_error().unwrap_or(0.0) * 1e3),
            Err(why) => Err(why.clone()),
        };
        (hold.square, value)
    });
    crate::app::formats::plots::plot_squares(path, &title, "tool-tip error (mm)", values, "not reached")
}
