#!/usr/bin/env bash
# Installs the Debian packages hysid needs to build, test, benchmark and plot.
# Skips apt entirely when every package is already installed, so repeated
# `make run` / `make test` calls cost nothing. Needs root (or sudo) otherwise.
# `install-deps.sh sanitize` installs what `make check-sanitize` needs in addition: clang 14 (its
# UBSan checks float-to-int casts, GCC's does not) and libFuzzer.
set -euo pipefail

packages=(
  g++ cmake ninja-build make git
  libeigen3-dev libsundials-dev libcgal-dev libbenchmark-dev libtbb-dev catch2 libfmt-dev
  libcli11-dev librandom123-dev libtomlplusplus-dev nlohmann-json3-dev libceres-dev
  libmuparser-dev                    # model files: the expressions of φ, ψ, guards, C, D
  pybind11-dev python3-dev           # the `hysid` Python module
  python3 python3-matplotlib python3-numpy python3-pytest python3-scipy  # scipy: the output-error reference (tests/reference, tests/usersys)
  slurm-wlm munge
)

if [ "${1:-}" = "sanitize" ]; then
  packages=(clang-14 libfuzzer-14-dev)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "hysid: installing Debian packages: ${missing[*]}" >&2
sudo=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
    echo "hysid: need root (or sudo) to install: ${missing[*]}" >&2; exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update
$sudo apt-get install -y --no-install-recommends "${missing[@]}"
