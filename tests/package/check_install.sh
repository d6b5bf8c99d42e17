#!/usr/bin/env bash
# The installed package from a downstream project's side: `cmake --install` into a temporary prefix,
# then against it, each configured with find_package(smseg), built and run:
#   the README's "Use it as a library" C++ example (its CMakeLists.txt and its source, cut out of
#   README.md), on the small corridor's work folder;
#   tests/package/consumers/all: every library, from a C++-only project (smseg::cloud without C or MPI);
#   tests/package/consumers/forest: COMPONENTS forest, whose configure must load no PCL, VTK, OpenCV or
#   Ceres (its CMake trace is searched for their configs);
# and a request for a component that does not exist must fail in one line.
# Usage: check_install.sh SOURCE_DIR BUILD_DIR WORK_FOLDER [SANITIZERS]
# SANITIZERS: the build's SMSEG_SANITIZE; its static libraries need the downstream program to link the
# same sanitizer runtimes.
set -euo pipefail
src="$1" build="$2" work="$3" sanitize="${4:-}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log"
for f in lib/cmake/smseg/smsegConfig.cmake lib/cmake/smseg/smsegConfigVersion.cmake bin/train-forest \
         include/smseg/forest/train.hpp include/smseg/stacks/stack.hpp; do
  [[ -e "$tmp/prefix/$f" ]] || { echo "not installed: $f"; exit 1; }
done
# Only the public headers: nothing of a module's src/ folder.
if [[ -e "$tmp/prefix/include/smseg/sfm/sfm_matching.hpp" || -e "$tmp/prefix/include/sfm_matching.hpp" ]]; then
  echo "a private header was installed"; exit 1
fi

# The README's blocks: the first ```cmake and the first ```cpp block after "## Use it as a library".
mkdir -p "$tmp/node"
extract() {  # extract LANGUAGE: the block's lines
  awk -v lang="$1" '/^## Use it as a library/ {on = 1} on && $0 == "```" lang {inside = 1; next}
                    inside && /^```/ {exit} inside {print}' "$src/README.md"
}
extract cmake > "$tmp/node/CMakeLists.txt"
extract cpp > "$tmp/node/corridor_node.cpp"
[[ -s "$tmp/node/CMakeLists.txt" && -s "$tmp/node/corridor_node.cpp" ]] || { echo "README: example blocks not found"; exit 1; }

sanitizer_flags=()
[[ -z "$sanitize" ]] || sanitizer_flags=(-DCMAKE_CXX_FLAGS="-fsanitize=$sanitize" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$sanitize")
cmake -S "$tmp/node" -B "$tmp/node/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$tmp/prefix" \
  "${sanitizer_flags[@]}" > "$tmp/configure.log" \
  || { cat "$tmp/configure.log"; exit 1; }
cmake --build "$tmp/node/build" -j2 > "$tmp/build.log" || { cat "$tmp/build.log"; exit 1; }
out="$("$tmp/node/build/corridor-node" "$work")"
echo "$out"
# "7 trees from 6 frames; frame 20: 61.3% of the labelled pixels right" (better than chance: 6 classes)
[[ "$out" =~ ^7\ trees\ from\ 6\ frames\;\ frame\ 20:\ ([0-9.]+)%\ of\ the\ labelled\ pixels\ right$ ]] \
  || { echo "unexpected output"; exit 1; }
awk -v a="${BASH_REMATCH[1]}" 'BEGIN {exit !(a > 30)}' || { echo "accuracy ${BASH_REMATCH[1]}% is not above chance"; exit 1; }
# A wrong work folder: one line naming it, exit status 1.
if err="$("$tmp/node/build/corridor-node" "$tmp/missing" 2>&1)"; then echo "a missing work folder was accepted"; exit 1; fi
[[ "$err" == *"$tmp/missing"* ]] || { echo "the error does not name the folder: $err"; exit 1; }

consumer() {  # consumer NAME [CMAKE ARGS...]: configures and builds tests/package/consumers/NAME
  local name="$1"
  shift
  cp -r "$src/tests/package/consumers/$name" "$tmp/$name"
  cmake -S "$tmp/$name" -B "$tmp/$name/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$tmp/prefix" \
    "${sanitizer_flags[@]}" "$@" > "$tmp/$name/configure.log" 2>&1 || { cat "$tmp/$name/configure.log"; exit 1; }
  cmake --build "$tmp/$name/build" -j2 > "$tmp/$name/build.log" 2>&1 || { cat "$tmp/$name/build.log"; exit 1; }
}

consumer all
mkdir -p "$tmp/scratch"
"$tmp/all/build/all-consumer" "$tmp/scratch" || { echo "all-consumer failed"; exit 1; }

# The trace lists every CMake file the configure ran: the forest's TBB config must be there (the trace
# works), no config of PCL, VTK, OpenCV or Ceres.
consumer forest --trace --trace-redirect="$tmp/forest/trace.log"
grep -q "TBBConfig.cmake" "$tmp/forest/trace.log" || { echo "forest consumer: no TBB config in the trace"; exit 1; }
loaded="$(grep -Eo "[^ ]*/(PCLConfig|VTKConfig|vtk-config|OpenCVConfig|CeresConfig)\.cmake" "$tmp/forest/trace.log" | sort -u || true)"
[[ -z "$loaded" ]] || { echo "COMPONENTS forest loaded: $loaded"; exit 1; }
for line in "PCL_FOUND is not defined" "VTK_FOUND is not defined" "OpenCV_FOUND is not defined" \
            "target smseg::forest defined" "target smseg::common defined" "target smseg::cloud not defined"; do
  grep -q "consumer: $line" "$tmp/forest/configure.log" || { echo "forest consumer: not '$line'"; cat "$tmp/forest/configure.log"; exit 1; }
done
grep "consumer: " "$tmp/forest/configure.log"
out="$("$tmp/forest/build/forest-consumer")" || { echo "forest-consumer failed: $out"; exit 1; }
echo "$out"

# A component that does not exist: one line naming it.
mkdir -p "$tmp/bad"
printf 'cmake_minimum_required(VERSION 3.25)\nproject(bad CXX)\nfind_package(smseg CONFIG REQUIRED COMPONENTS forest nosuch)\n' \
  > "$tmp/bad/CMakeLists.txt"
if cmake -S "$tmp/bad" -B "$tmp/bad/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/bad/configure.log" 2>&1; then
  echo "COMPONENTS nosuch was accepted"; exit 1
fi
grep -q "no component 'nosuch'" "$tmp/bad/configure.log" || { echo "COMPONENTS nosuch: no clear error"; cat "$tmp/bad/configure.log"; exit 1; }
echo "install, find_package(smseg), build and run: ok"
