#!/usr/bin/env bash
# Installs the Debian packages the toolkit needs, if any is missing. As root it runs apt-get itself;
# otherwise it prints the apt-get line to run and fails. Sourced by experiments/main-job.sh and
# tests/run-tests.sh.
set -euo pipefail

SMSEG_PACKAGES=(
  build-essential cmake pkg-config ccache universal-ctags  # ctags: tests/architecture/function_sizes.py
  libeigen3-dev libopencv-dev libopencv-contrib-dev libpcl-dev libtbb-dev
  nlohmann-json3-dev libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev libmaxflow-dev
  libhwy-dev   # Google Highway, headers only: the classifier's SIMD kernels (libforest/src/forest_simd.cpp)
  libzstd-dev  # the stacks' values files (features/stacks/src/frame_values.cpp)
  python3-matplotlib python3-numpy jupyter-nbconvert python3-nbformat python3-ipykernel
  libceres-dev libgoogle-glog-dev libsuitesparse-dev
  python3-dev python3-pybind11 python3-pytest python3-sklearn python3-pandas  # pandas: the DataFrame checks of check_estimator
  python3-venv python3-pip python3-setuptools python3-wheel   # `pip install .` offline (tests/package/check_pip.sh)
  dpkg-dev   # dpkg-shlibdeps: the Depends of `cpack -G DEB` (tests/package/check_deb.sh)
  slurmctld slurmd slurm-client munge   # the Slurm tests' one-node cluster (tests/slurm)
)

missing=()
for p in "${SMSEG_PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  if [[ $(id -u) -ne 0 ]]; then
    echo "missing Debian packages; run as root:" >&2
    echo "  apt-get update && apt-get install -y --no-install-recommends ${missing[*]}" >&2
    exit 1
  fi
  echo "installing: ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >&2
  apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
fi
