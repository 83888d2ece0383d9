"""python-chess reads a game.pgn that chessarm wrote (crates/cli/tests/cli_live.rs).

Usage: read_pgn.py GAME.PGN

Prints one JSON object: the headers, the main line in UCI as python-chess plays it from the
start position (its [FEN] tag if any), the comments per move, the result, python-chess's own
SAN of each move, and any errors python-chess noted while reading (an illegal or ambiguous move
would be one).
"""
import json
import sys

import chess
import chess.pgn

with open(sys.argv[1], encoding="utf-8") as handle:
    game = chess.pgn.read_game(handle)
board = game.board()
uci, san, comments = [], [], []
for node in game.mainline():
    san.append(board.san(node.move))
    uci.append(node.move.uci())
    comments.append(node.comment or None)
    board.push(node.move)
print(json.dumps({
    "headers": dict(game.headers),
    "uci": uci,
    "san": san,
    "comments": comments,
    "errors": [str(e) for e in game.errors],
    "final_fen": board.fen(),
}))
