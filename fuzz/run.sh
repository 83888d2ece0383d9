#!/usr/bin/env bash
# Runs every fuzz target for RUNS executions from its corpus (fuzz/corpus/<target>) and its
# hand-made seeds (fuzz/seeds/<target>), then minimises the corpus.
#
#   fuzz/run.sh RUNS [TARGET...]      e.g. fuzz/run.sh 1000000
#
# Targets: pgn move_list fen setup_toml urdf numbers bus_feetech bus_dynamixel bus_simulator
# occupancy typed_move live_request, and uci_line unless FUZZ_UCI=0 (it needs the
# crate's `uci` feature, see README.md). Builds on the stable toolchain with `--sanitizer none`
# (release build with debug assertions, cargo-fuzz's default). Prints a summary table and
# writes it to fuzz/last-run.txt. Exits non-zero if any target crashed (crash inputs are in
# fuzz/artifacts/<target>/, which git ignores).
set -euo pipefail

usage() {
    echo "usage: $0 RUNS [TARGET...]" >&2
    exit 2
}
[[ $# -ge 1 && $1 =~ ^[0-9]+$ ]] || usage
runs=$1
shift

cd "$(dirname "$0")"

if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi

features=()
if [[ $# -gt 0 ]]; then
    targets=("$@")
else
    targets=(pgn move_list fen setup_toml urdf numbers bus_feetech bus_dynamixel bus_simulator occupancy typed_move live_request)
    if [[ ${FUZZ_UCI:-1} == 1 ]]; then
        targets+=(uci_line)
    fi
fi
for target in "${targets[@]}"; do
    if [[ $target == uci_line ]]; then
        features=(--features uci)
    fi
done

# libFuzzer limits. Each input is a few KiB at most in practice (a PGN file of one game, a setup
# file, a command-line argument); -max_len allows 64 KiB, far above that. No single allocation may
# exceed 512 MiB and the process must stay under 2 GiB resident: the parsers are meant to need
# memory linear in the input, so either limit means a bug. -timeout flags an input taking > 10 s.
limits=(-rss_limit_mb=2048 -malloc_limit_mb=512 -max_len=65536 -timeout=10)

logs=target/run-logs
mkdir -p "$logs"
cargo fuzz build --sanitizer none "${features[@]}"

# What is being fuzzed: the commit, marked when the code (not the corpus) differs from it.
revision=$(git rev-parse --short HEAD 2>/dev/null || echo '?')
if [[ -n $(git status --porcelain -- Cargo.toml Cargo.lock src fuzz_targets run.sh ../Cargo.toml ../Cargo.lock ../crates 2>/dev/null) ]]; then
    revision+=" with uncommitted changes"
fi

summary=$(mktemp)
trap 'rm -f "$summary"' EXIT
failed=0
total_start=$SECONDS
for target in "${targets[@]}"; do
    corpus=corpus/$target
    mkdir -p "$corpus" "artifacts/$target"
    before=$(find "artifacts/$target" -type f | wc -l)
    log=$logs/$target.log
    start=$SECONDS
    status=0
    # New inputs go to the first directory (the corpus); the hand-made seeds stay as they are.
    cargo fuzz run --sanitizer none "${features[@]}" "$target" "$corpus" "seeds/$target" -- \
        -runs="$runs" -print_final_stats=1 "${limits[@]}" >"$log" 2>&1 || status=$?
    seconds=$((SECONDS - start))
    crashes=$(($(find "artifacts/$target" -type f | wc -l) - before))
    if [[ $status -ne 0 && $crashes -eq 0 ]]; then
        crashes=1 # died without writing an artifact: count it, the log says why
    fi
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -n 1)
    last=$(grep -E '^#[0-9]+' "$log" | grep 'cov:' | tail -n 1 || true)
    cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
    ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
    if [[ $crashes -ne 0 ]]; then
        failed=1
        echo "== $target: crashed, see $log and artifacts/$target/" >&2
        grep -m 1 -A 2 'panicked at' "$log" >&2 || tail -n 20 "$log" >&2
    fi
    # Minimise the corpus: the smallest set of inputs (set cover) that reaches every edge the
    # corpus reaches. -use_counters=0 ignores hit counts, which keeps the committed corpus at a
    # few hundred small files per target rather than thousands; fuzzing regrows the rest.
    cargo fuzz cmin --sanitizer none "${features[@]}" "$target" "$corpus" -- "${limits[@]}" \
        -set_cover_merge=1 -use_counters=0 \
        >"$logs/$target.cmin.log" 2>&1 || echo "== $target: cmin failed, see $logs/$target.cmin.log" >&2
    files=$(find "$corpus" -type f | wc -l)
    bytes=$(du -sb "$corpus" | cut -f1)
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$target" "${execs:-?}" "$crashes" "${cov:-?}" "${ft:-?}" \
        "$files" "$bytes" "${rss:-?}" "$seconds" >>"$summary"
done

{
    echo "fuzz/run.sh $runs: $(date -u +%Y-%m-%dT%H:%MZ), $revision, $(rustc --version)"
    echo "libFuzzer ${limits[*]}; cov/ft: the final coverage counters and features of the run;"
    echo "corpus: files and bytes after cmin; time: fuzzing only, in seconds (total $((SECONDS - total_start)) s with cmin)"
    echo
    {
        printf 'target\texecutions\tcrashes\tcov\tft\tcorpus files\tcorpus bytes\tpeak rss MB\ttime s\n'
        cat "$summary"
    } | column -t -s $'\t'
} | tee last-run.txt

exit "$failed"
