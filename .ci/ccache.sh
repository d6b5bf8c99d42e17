# Sourced by the build scripts (tests/run-tests.sh, tests/run-sanitized.sh, fuzz/run-ci.sh) after they
# cd to the repository: sets `launcher` to the CMake option that compiles through ccache when it is
# installed (.ci/install-deps.sh installs it), with the repository as ccache's base folder so that
# clones at other paths share the cache (and no build folder's path goes into the hashes).
launcher=()
if command -v ccache > /dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
fi
