#!/usr/bin/env bash
# CI's fuzzing step (.ci/run): installs clang and libFuzzer's runtime when missing (Debian's clang-14 and
# libclang-rt-14-dev), configures build-fuzz/ with SMSEG_FUZZ=ON (only the libraries and the fuzzers
# are built), then runs every fuzzer for SECONDS (default 30) with fuzz/run-all.sh, which fails on any
# crash, leak, timeout or out-of-memory. Usage: bash fuzz/run-ci.sh [SECONDS]   (env FUZZ_BUILD_DIR)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
seconds="${1:-30}"
build="${FUZZ_BUILD_DIR:-build-fuzz}"

missing=()
for p in clang libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  if [[ $(id -u) -ne 0 ]]; then
    echo "missing Debian packages; run as root: apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >&2
  apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
fi

source .ci/ccache.sh
cmake -S . -B "$build" -DCMAKE_CXX_COMPILER=clang++ -DSMSEG_FUZZ=ON -DSMSEG_BUILD_TESTS=OFF \
  -DSMSEG_BUILD_BENCHMARKS=OFF "${launcher[@]}" > "${TMPDIR:-/tmp}/smseg-fuzz-configure.log" || { cat "${TMPDIR:-/tmp}/smseg-fuzz-configure.log"; exit 1; }
cmake --build "$build" -j"$(nproc)" --target smseg_fuzzers
bash fuzz/run-all.sh "$seconds" "$build"
