#!/usr/bin/env bash
# Configure, build and test the C library twice: a normal optimised build
# (build/c) and a build under AddressSanitizer + UndefinedBehaviorSanitizer
# (build/c-san). Exits non-zero on any failure.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

generator=()
if command -v ninja >/dev/null 2>&1; then
    generator=(-G Ninja)
fi

# The tests that drive the examples against the simulator need `drempower sim`: the virtual
# environment's (make test creates it), or DRE_DREMPOWER. Without it they are skipped, saying so.
drempower="${DRE_DREMPOWER:-$root/.venv/bin/drempower}"
if [ ! -x "$drempower" ]; then
    echo "note: no drempower at $drempower: the examples are not run against the simulator (make test creates it)"
    drempower=""
fi

build_and_test() {
    local dir="$1"
    shift
    echo "== $dir"
    cmake -S c -B "$dir" "${generator[@]}" -DDRE_DREMPOWER="$drempower" "$@"
    cmake --build "$dir"
    (cd "$dir" && ctest --output-on-failure)
}

build_and_test build/c -DCMAKE_BUILD_TYPE=Release
ASAN_OPTIONS=abort_on_error=1:detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    build_and_test build/c-san -DCMAKE_BUILD_TYPE=Debug -DDRE_SANITIZE=ON
echo "C library: all tests passed (normal and ASan+UBSan builds)"
