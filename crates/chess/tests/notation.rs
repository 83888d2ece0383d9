//! Tests of `chessarm_chess::notation`: PGN files, move lists and FEN parsing.
#![allow(clippy::unwrap_used)]

use chessarm_chess::notation::{
    GameRecord, MoveProblem, NotationError, parse_fen, parse_move_list, parse_pgn, select_game,
};
use shakmaty::fen::Fen;
use shakmaty::{CastlingSide, Chess, Color, EnPassantMode, Move, Position, Role, Square};

const OPERA: &str = include_str!("fixtures/opera_game.pgn");
const KASPAROV_TOPALOV: &str = include_str!("fixtures/kasparov_topalov_1999.pgn");
const SPECIAL: &str = include_str!("fixtures/special_moves.pgn");
const SEVERAL: &str = include_str!("fixtures/several_games.pgn");
const ANNOTATED: &str = include_str!("fixtures/annotated.pgn");
const FROM_FEN: &str = include_str!("fixtures/from_fen.pgn");
const ILLEGAL: &str = include_str!("fixtures/illegal_move.pgn");

const OPERA_FINAL: &str = "1n1Rkb1r/p4ppp/4q3/4p1B1/4P3/8/PPP2PPP/2K5 b k - 1 17";
const OPERA_SAN: &str = "e4 e5 Nf3 d6 d4 Bg4 dxe5 Bxf3 Qxf3 dxe5 Bc4 Nf6 Qb3 Qe7 Nc3 c6 Bg5 b5 Nxb5 cxb5 \
                         Bxb5+ Nbd7 O-O-O Rd8 Rxd7 Rxd7 Rd1 Qe6 Bxd7+ Nxd7 Qb8+ Nxb8 Rd8#";
const SPECIAL_UCI: &str = "e2e4 d7d5 e4e5 f7f5 e5f6 g8f6 g1f3 c8g4 f1e2 b8c6 e1g1 d8d6 d2d4 e8c8 a2a4 e7e5 \
                           a4a5 e5d4 a5a6 d4d3 a6b7 c8d7 b7b8q d8b8 c2c3 d3e2 f1e1 e2d1n e1d1";

fn fen(pos: &Chess) -> String {
    Fen::from_position(pos, EnPassantMode::Legal).to_string()
}

fn only_game(text: &str) -> GameRecord {
    let mut games = parse_pgn(text).unwrap();
    assert_eq!(games.len(), 1);
    games.remove(0)
}

#[test]
fn opera_game_parses_completely() {
    let game = only_game(OPERA);
    assert_eq!(game.moves.len(), 33);
    assert_eq!(game.header("White"), Some("Morphy, Paul"));
    assert_eq!(game.header("Black"), Some("Duke Karl / Count Isouard"));
    assert_eq!(game.header("Result"), Some("1-0"));
    assert_eq!(game.header("ECO"), Some("C41"));
    assert_eq!(game.header("Annotator"), None);
    assert_eq!(game.headers.len(), 8);
    assert_eq!(fen(&game.start), fen(&Chess::default()));
    assert_eq!(game.san_moves().join(" "), OPERA_SAN);
    // Black king e8 boxed in by its own pieces, rook d8 protected by the g5 bishop.
    let last = game.final_position();
    assert_eq!(fen(&last), OPERA_FINAL);
    assert!(last.is_checkmate());
    // 12. O-O-O is a queenside castle of the white king.
    assert_eq!(game.moves[22], Move::Castle { king: Square::E1, rook: Square::A1 });
    assert_eq!(game.moves[22].castling_side(), Some(CastlingSide::QueenSide));
}

#[test]
fn kasparov_topalov_1999_parses_completely() {
    let game = only_game(KASPAROV_TOPALOV);
    assert_eq!(game.moves.len(), 87, "44 white moves, 43 black moves");
    assert_eq!(game.header("White"), Some("Kasparov, Garry"));
    assert_eq!(game.header("Black"), Some("Topalov, Veselin"));
    assert_eq!(game.header("Result"), Some("1-0"));
    assert_eq!(game.header("Date"), Some("1999.01.20"));
    let san = game.san_moves();
    assert_eq!(san[46], "Rxd4", "24. Rxd4, the famous rook sacrifice");
    assert_eq!(san[47], "cxd4");
    assert_eq!(san.last().map(String::as_str), Some("Qa7"));
    // Final position: white Kc1 Qa7 Pf4 Pg3 Ph2; black Ke1 Rd2 Pc3 Pf5 Pg6 Ph7; black to move after 44. Qa7.
    assert_eq!(fen(&game.final_position()), "8/Q6p/6p1/5p2/5P2/2p3P1/3r3P/2K1k3 b - - 3 44");
}

#[test]
fn special_moves_castling_en_passant_promotion_underpromotion() {
    let game = only_game(SPECIAL);
    assert_eq!(game.moves.len(), 29);
    assert_eq!(game.header("Result"), Some("*"));
    // 3. exf6 e.p.
    assert_eq!(game.moves[4], Move::EnPassant { from: Square::E5, to: Square::F6 });
    // 6. O-O and 7... O-O-O
    assert_eq!(game.moves[10], Move::Castle { king: Square::E1, rook: Square::H1 });
    assert_eq!(game.moves[13], Move::Castle { king: Square::E8, rook: Square::A8 });
    // 12. b8=Q and 14... exd1=N (capturing the queen)
    assert_eq!(game.moves[22].promotion(), Some(Role::Queen));
    assert_eq!(game.moves[22].to(), Square::B8);
    assert_eq!(game.moves[27].promotion(), Some(Role::Knight));
    assert_eq!(game.moves[27].capture(), Some(Role::Queen));
    let san = game.san_moves();
    assert_eq!(san[4], "exf6");
    assert_eq!(san[22], "b8=Q");
    assert_eq!(san[27], "exd1=N");
    assert_eq!(fen(&game.final_position()), "1r3b1r/p1pk2pp/2nq1n2/3p4/6b1/2P2N2/1P3PPP/RNBR2K1 b - - 0 15");
}

#[test]
fn several_games_in_one_file() {
    let games = parse_pgn(SEVERAL).unwrap();
    assert_eq!(games.len(), 4);
    let plies: Vec<usize> = games.iter().map(|g| g.moves.len()).collect();
    assert_eq!(plies, [45, 7, 4, 6]);
    let results: Vec<&str> = games.iter().map(|g| g.header("Result").unwrap()).collect();
    assert_eq!(results, ["1-0", "1-0", "0-1", "*"]);
    assert_eq!(games[0].header("White"), Some("Anderssen, Adolf"));
    assert_eq!(games[0].header("Black"), Some("Kieseritzky, Lionel"));
    assert_eq!(games[2].header("Event"), Some("Fool's mate"));

    // Immortal game: 23. Be7#.
    let immortal = games[0].final_position();
    assert!(immortal.is_checkmate());
    assert_eq!(fen(&immortal), "r1bk3r/p2pBpNp/n4n2/1p1NP2P/6P1/3P4/P1P1K3/q5b1 b - - 1 23");
    // Fool's mate: 2... Qh4#.
    let fool = games[2].final_position();
    assert!(fool.is_checkmate());
    assert_eq!(fool.turn(), Color::White);
    assert_eq!(fen(&fool), "rnb1kbnr/pppp1ppp/8/4p3/6Pq/5P2/PPPPP2P/RNBQKBNR w KQkq - 1 3");
    assert!(!games[3].final_position().is_game_over());

    let scholar = select_game(games.clone(), 2).unwrap();
    assert_eq!(scholar.header("Event"), Some("Scholar's mate"));
    assert_eq!(scholar.san_moves().last().map(String::as_str), Some("Qxf7#"));
    assert_eq!(select_game(games.clone(), 4).unwrap().header("Event"), Some("Unfinished"));
}

#[test]
fn select_game_out_of_range() {
    let games = parse_pgn(SEVERAL).unwrap();
    let err = select_game(games.clone(), 5).unwrap_err();
    assert_eq!(err, NotationError::NoSuchGame { requested: 5, count: 4 });
    assert_eq!(err.to_string(), "game 5 requested but the file has 4 games");
    let err = select_game(games, 0).unwrap_err();
    assert_eq!(err, NotationError::NoSuchGame { requested: 0, count: 4 });
    let one = parse_pgn(OPERA).unwrap();
    assert_eq!(select_game(one, 2).unwrap_err().to_string(), "game 2 requested but the file has 1 game");
    assert_eq!(select_game(Vec::new(), 1).unwrap_err(), NotationError::NoSuchGame { requested: 1, count: 0 });
}

#[test]
fn comments_nags_and_variations_are_ignored() {
    let annotated = only_game(ANNOTATED);
    let plain = only_game(OPERA);
    assert_eq!(annotated.moves.len(), 33, "only the main line is played");
    assert_eq!(annotated.moves, plain.moves);
    assert_eq!(annotated.san_moves().join(" "), OPERA_SAN);
    assert_eq!(fen(&annotated.final_position()), OPERA_FINAL);
    assert_eq!(annotated.header("Annotator"), Some("chessarm test"));
}

#[test]
fn game_from_fen_header() {
    let game = only_game(FROM_FEN);
    assert_eq!(game.header("SetUp"), Some("1"));
    assert_eq!(fen(&game.start), "4k3/8/3K4/4P3/8/8/8/8 b - - 0 60");
    assert_eq!(game.start.turn(), Color::Black);
    assert_eq!(game.moves.len(), 10);
    assert_eq!(game.san_moves(), ["Kd8", "e6", "Ke8", "e7", "Kf7", "Kd7", "Kf6", "e8=Q", "Kf5", "Qe3"]);
    // White Kd7 and the new queen on e3, black king on f5; black to move at move 65.
    assert_eq!(fen(&game.final_position()), "8/3K4/8/5k2/8/4Q3/8/8 b - - 2 65");
}

#[test]
fn illegal_move_in_pgn_names_game_move_san_and_fen() {
    let err = parse_pgn(ILLEGAL).unwrap_err();
    let before = "r1bqkbnr/pppp1ppp/2n5/1B2p3/4P3/5N2/PPPP1PPP/RNBQK2R b KQkq - 3 3";
    assert_eq!(
        err,
        NotationError::PgnMove {
            game: 2,
            number: 3,
            color: Color::Black,
            san: "Nxe5".to_owned(),
            problem: MoveProblem::Illegal,
            fen: before.to_owned(),
        }
    );
    assert_eq!(err.to_string(), format!("game 2, move 3... (black): 'Nxe5' is illegal in {before}"));
}

#[test]
fn pgn_move_problems_are_distinguished() {
    // Not SAN at all: pgn-reader would skip it silently, the parser must not.
    let err = parse_pgn("1. e4 e5 2. Qh9 Nc6 *").unwrap_err();
    let after_e5 = "rnbqkbnr/pppp1ppp/8/4p3/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2";
    assert_eq!(err.to_string(), format!("game 1, move 2. (white): 'Qh9' is not valid SAN in {after_e5}"));
    assert!(matches!(err, NotationError::PgnMove { problem: MoveProblem::NotSan, .. }));

    let err = parse_pgn("1. e4 e5 2. Nf3x Nc6 *").unwrap_err();
    assert!(matches!(err, NotationError::PgnMove { problem: MoveProblem::NotSan, ref san, .. } if san == "Nf3x"));

    // Ambiguous: rooks a3 and h1 can both reach h3.
    let err = parse_pgn("1. a4 a5 2. h4 h5 3. Ra3 Ra6 4. Rh3 *").unwrap_err();
    assert_eq!(
        err.to_string(),
        "game 1, move 4. (white): 'Rh3' is ambiguous in 1nbqkbnr/1pppppp1/r7/p6p/P6P/R7/1PPPPPP1/1NBQKBNR w Kk - 2 4"
    );

    // Illegal (the f6 knight blocks the bishop), black to move, in the third game of a file.
    let text = format!("{OPERA}\n{OPERA}\n[White \"X\"]\n\n1. d4 d5 2. c4 e6 3. Nc3 Nf6 4. Bg5 Be7 5. e3 Bxg5?? *\n");
    let err = parse_pgn(&text).unwrap_err();
    assert!(err.to_string().starts_with("game 3, move 5... (black): 'Bxg5' is illegal in "), "{err}");
}

#[test]
fn castling_with_zeros_and_result_token_ends_game() {
    let game = only_game("1. e4 e5 2. Nf3 Nf6 3. Bc4 Bc5 4. 0-0 0-0 *");
    assert_eq!(game.san_moves(), ["e4", "e5", "Nf3", "Nf6", "Bc4", "Bc5", "O-O", "O-O"]);

    let games = parse_pgn("1. e4 e5 1-0 1. d4 d5 0-1").unwrap();
    assert_eq!(games.len(), 2);
    assert_eq!(games[1].san_moves(), ["d4", "d5"]);
}

#[test]
fn empty_or_gameless_pgn_is_an_error() {
    assert_eq!(parse_pgn("").unwrap_err(), NotationError::NoGames);
    assert_eq!(parse_pgn(" \n\n\t\n").unwrap_err(), NotationError::NoGames);
    assert_eq!(parse_pgn("{ just a comment }\n").unwrap_err().to_string(), "no games in the PGN");
}

#[test]
fn bad_fen_tags_variants_and_broken_pgn() {
    let text = format!("{OPERA}\n[SetUp \"1\"]\n[FEN \"rnbqkbnr/pppppppp/8/8 w KQkq - 0 1\"]\n\n1. e4 *\n");
    let err = parse_pgn(&text).unwrap_err();
    assert_eq!(
        err,
        NotationError::InvalidFenTag {
            game: 2,
            fen: "rnbqkbnr/pppppppp/8/8 w KQkq - 0 1".to_owned(),
            reason: "invalid board part in fen".to_owned()
        }
    );

    let err = parse_pgn("[Variant \"Chess960\"]\n\n1. e4 *\n").unwrap_err();
    assert_eq!(err.to_string(), "game 1: variant 'Chess960' is not supported (standard chess only)");

    let err = parse_pgn("[White \"A\"]\n\n1. e4 { never closed").unwrap_err();
    assert!(matches!(err, NotationError::MalformedPgn { game: 1, .. }), "{err}");
}

#[test]
fn parse_fen_valid_and_invalid() {
    let pos = parse_fen(" 4k3/8/3K4/4P3/8/8/8/8 b - - 0 60 ").unwrap();
    assert_eq!(pos.turn(), Color::Black);
    assert_eq!(pos.fullmoves().get(), 60);
    assert_eq!(
        fen(&parse_fen("rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1").unwrap()),
        fen(&Chess::default())
    );

    let err = parse_fen("xyz").unwrap_err();
    assert_eq!(err.to_string(), "invalid FEN 'xyz': invalid board part in fen");
    let err = parse_fen("8/8/8/8/8/8/8/8 w - - 0 1").unwrap_err();
    assert!(matches!(err, NotationError::InvalidFen { .. }));
    assert!(err.to_string().starts_with("invalid FEN '8/8/8/8/8/8/8/8 w - - 0 1': illegal position"), "{err}");
    // Both kings in check / impossible castling rights are illegal setups.
    assert!(parse_fen("4k3/8/8/8/8/8/8/4K3 w KQkq - 0 1").is_err());
}

#[test]
fn move_lists_in_san_uci_and_mixed_agree() {
    let san = parse_move_list("e4 e5 Bc4 Nc6 Qh5 Nf6 Qxf7#", Chess::default()).unwrap();
    let uci = parse_move_list("e2e4 e7e5 f1c4 b8c6 d1h5 g8f6 h5f7", Chess::default()).unwrap();
    let mixed = parse_move_list("1. e4 e5, 2. f1c4 Nc6 3.Qh5 3... g8f6 4. Qxf7# 1-0", Chess::default()).unwrap();
    assert_eq!(san.moves.len(), 7);
    assert_eq!(san.moves, uci.moves);
    assert_eq!(san.moves, mixed.moves);
    assert!(san.headers.is_empty());
    assert!(mixed.final_position().is_checkmate());
    assert_eq!(uci.san_moves(), ["e4", "e5", "Bc4", "Nc6", "Qh5", "Nf6", "Qxf7#"]);

    // Castling both sides, en passant and (under)promotion in UCI give the PGN's moves.
    let pgn = only_game(SPECIAL);
    let uci = parse_move_list(SPECIAL_UCI, Chess::default()).unwrap();
    assert_eq!(uci.moves, pgn.moves);
    let san_list = parse_move_list(&pgn.san_moves().join(", "), Chess::default()).unwrap();
    assert_eq!(san_list.moves, pgn.moves);

    // From a FEN start, black to move; result token skipped.
    let start = parse_fen("4k3/8/3K4/4P3/8/8/8/8 b - - 0 60").unwrap();
    let list = parse_move_list("60... Kd8 61. e6 Ke8 62. e7 Kf7 63. Kd7 Kf6 64. e7e8q Kf5 65. Qe3 *", start).unwrap();
    assert_eq!(list.moves, only_game(FROM_FEN).moves);

    let empty = parse_move_list("  ", Chess::default()).unwrap();
    assert!(empty.moves.is_empty());
}

#[test]
fn move_list_errors() {
    let after_e5 = "rnbqkbnr/pppp1ppp/8/4p3/4P3/8/PPPP1PPP/RNBQKBNR w KQkq - 0 2";
    let err = parse_move_list("1. e4 e5 2. Qh9", Chess::default()).unwrap_err();
    assert_eq!(
        err,
        NotationError::ListMove {
            index: 3,
            number: 2,
            color: Color::White,
            token: "Qh9".to_owned(),
            problem: MoveProblem::NotSanOrUci,
            fen: after_e5.to_owned(),
        }
    );
    assert_eq!(err.to_string(), format!("move 3 'Qh9' (game move 2. white) is not valid SAN or UCI in {after_e5}"));

    let err = parse_move_list("e4 e5 Ke3", Chess::default()).unwrap_err();
    assert!(matches!(err, NotationError::ListMove { index: 3, problem: MoveProblem::Illegal, .. }), "{err}");

    let err = parse_move_list("e4 e5 e2e4", Chess::default()).unwrap_err();
    assert!(matches!(err, NotationError::ListMove { index: 3, problem: MoveProblem::Illegal, .. }), "{err}");

    let err = parse_move_list("a4 a5 h4 h5 Ra3 Ra6 Rh3", Chess::default()).unwrap_err();
    assert!(matches!(err, NotationError::ListMove { index: 7, problem: MoveProblem::Ambiguous, .. }), "{err}");
    assert!(err.to_string().contains("'Rh3' (game move 4. white) is ambiguous"), "{err}");

    let err = parse_move_list("e4 xyz", Chess::default()).unwrap_err();
    assert!(err.to_string().starts_with("move 2 'xyz' (game move 1... black) is not valid SAN or UCI in "), "{err}");
}

/// A tag value may hold a line feed escaped by a backslash (found by the PGN fuzz target): the
/// messages that quote tag values show it escaped, on one line.
#[test]
fn tag_values_with_line_breaks_are_quoted_on_one_line() {
    for pgn in ["[FEN \"\\\n1\"]\n\n*\n", "[Variant \"x\\\ny\"]\n\n1. e4 *\n"] {
        let error = chessarm_chess::notation::parse_pgn(pgn).unwrap_err().to_string();
        assert!(!error.contains('\n') && error.contains("\\n"), "{error:?}");
    }
}
