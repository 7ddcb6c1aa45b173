#!/usr/bin/env bash
# Installs the Debian packages celldem needs. Safe to run repeatedly.
# Usage: tools/install-deps.sh [--with-crosscheck]   (with the cross-check codes and the fuzzers' compiler)
set -euo pipefail
pkgs=(build-essential cmake ninja-build libeigen3-dev nlohmann-json3-dev libgtest-dev libgmock-dev libcli11-dev
      libboost-dev zlib1g-dev python3-numpy python3-matplotlib python3-scipy python3-pandas python3-pytest python3-vtk9
      python3-venv python3-pip python3-mypy)
if [[ "${1:-}" == "--with-crosscheck" ]]; then
  # The test suite's extras: the codes of the cross-checks, and clang with its sanitizer runtimes and libomp
  # for the fuzzers (tools/fuzz.sh), clang-format for the check of changed lines (tools/check_format.sh).
  pkgs+=(lammps liggghts openmpi-bin clang libclang-rt-14-dev libomp-dev clang-format)
fi
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
