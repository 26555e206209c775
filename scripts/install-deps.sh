#!/usr/bin/env bash
# Installs flapstab's build dependencies from Debian 12 packages (run as root).
# Skips the apt step entirely when every package is already installed.
set -euo pipefail
PKGS=(build-essential cmake pkg-config
      libeigen3-dev libsundials-dev coinor-libipopt-dev libnlopt-cxx-dev
      libfftw3-dev libhdf5-dev
      libcli11-dev nlohmann-json3-dev libtomlplusplus-dev libfmt-dev
      libgtest-dev libbenchmark-dev gnuplot-nox ninja-build)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "install-deps: all packages present"
fi
