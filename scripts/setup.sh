#!/usr/bin/env bash
# Installs the Debian packages tdyn needs (PETSc, OpenMPI, METIS, HDF5 with MPI, gmsh, clang for
# bindgen, and LIGGGHTS, the peer code the sph tests cross-check against) when they are missing,
# then builds tdyn in release mode.
set -euo pipefail
pkgs=(libpetsc-real-dev libopenmpi-dev openmpi-bin libmetis-dev libhdf5-openmpi-dev gmsh
      libclang-dev pkg-config liggghts)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
command -v cargo >/dev/null || { echo "setup: cargo not found: install Rust (rustup)"; exit 1; }
cargo build --release --workspace --bins --examples
