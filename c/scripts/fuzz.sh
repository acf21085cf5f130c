#!/usr/bin/env bash
# Build the libFuzzer targets (clang, with ASan + UBSan) and run each for a
# bounded time, then print executions, coverage and crashes per target.
#
#   bash c/scripts/fuzz.sh [SECONDS_PER_TARGET]     (default 60, or $FUZZ_SECONDS)
#
# Installs clang with apt-get when it (or its libFuzzer runtime) is missing.
# Corpora persist in build/c-fuzz/corpus-<target>; crash inputs land in
# build/c-fuzz/. Exits non-zero if a target crashes.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"
seconds="${1:-${FUZZ_SECONDS:-60}}"
out=build/c-fuzz
mkdir -p "$out"

have_libfuzzer() {
    command -v clang >/dev/null 2>&1 &&
        echo 'int LLVMFuzzerTestOneInput(const char *d, long n) { (void)d; (void)n; return 0; }' |
        clang -fsanitize=fuzzer -x c - -o "$out/probe" >/dev/null 2>&1
}
if ! have_libfuzzer; then
    echo "installing clang and its libFuzzer runtime"
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y clang libclang-rt-dev
fi

flags=(-std=c99 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -Wall -Wextra -Werror -Ic/include)
sources=(c/src/dre_codec.c c/src/dre_errors.c c/src/dre_framing.c)

seed() { # target name hex
    python3 -c "import sys; open(sys.argv[1], 'wb').write(bytes.fromhex(sys.argv[2]))" "$out/corpus-$1/seed-$2" "$3"
}

# Field $3 (space separated) of the last match of pattern $1 in file $2, or "?".
last() {
    local v
    v=$(grep -o "$1" "$2" | tail -n 1 | cut -d' ' -f"$3") || true
    echo "${v:-?}"
}

targets=(fuzz_decode fuzz_stream)
summary=()
failed=0
for t in "${targets[@]}"; do
    clang "${flags[@]}" "c/fuzz/$t.c" "${sources[@]}" -lm -o "$out/$t"
    mkdir -p "$out/corpus-$t"
    if [ -z "$(ls -A "$out/corpus-$t")" ]; then
        if [ "$t" = fuzz_decode ]; then # id (LE), length, data
            seed "$t" q 3A0008000016C3E803F401
            seed "$t" state 2700080000B9C2D204C8FF
            seed "$t" reply 3E00087794000038F0B8C2
            seed "$t" start 0800081100000001000000
        else # mode byte, stream
            seed "$t" uart11 0008003A000016C3E803F401
            seed "$t" aa 00AA0000080000003A000016C3E803F401
        fi
    fi
    log="$out/$t.log"
    status=0
    (cd "$out" && "./$t" "corpus-$t" -max_total_time="$seconds" -print_final_stats=1 >"$t.log" 2>&1) || status=$?
    runs=$(last 'Done [0-9]* runs' "$log" 2)
    secs=$(last 'runs in [0-9]* second' "$log" 3)
    cov=$(last 'cov: [0-9]*' "$log" 2)
    ft=$(last 'ft: [0-9]*' "$log" 2)
    corp=$(last 'corp: [0-9]*' "$log" 2)
    crashes=$(grep -c '^==[0-9]*==ERROR\|^SUMMARY: \|deadly signal' "$log" || true)
    if [ "$status" -ne 0 ]; then
        failed=1
        crashes=$((crashes > 0 ? crashes : 1))
        tail -n 30 "$log" >&2
    fi
    summary+=("$(printf '%-12s %12s %6s %6s %7s %7s %8s' "$t" "$runs" "$secs" "$cov" "$ft" "$corp" "$crashes")")
done

echo
printf '%-12s %12s %6s %6s %7s %7s %8s\n' target runs "time_s" cov features corpus crashes
printf '%s\n' "${summary[@]}"
exit "$failed"
