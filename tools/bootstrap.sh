#!/usr/bin/env bash
# Set-up shared by tools/run-main and tools/run-tests (sourced, not run): Debian packages,
# the git-ignored venv in .venv, and the CMake build in build/. Each step is skipped when
# already done, so a second run costs only an incremental build.
set -euo pipefail
GM_REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
GM_VENV="$GM_REPO/.venv"
GM_BUILD="$GM_REPO/build"

# Compilers, CMake, Eigen, SuiteSparse, GoogleTest, Python, the shared libraries the gmsh
# wheel loads (GL/X11 client libraries; no display is needed), and OpenBLAS, which Debian's
# alternatives then put behind libblas.so.3 (CHOLMOD's supernodal factorization of a gear body
# runs about 4x faster than on the reference BLAS), CalculiX (ccx) for the independent FE
# reference of reference_fe/, and clang with its compiler-rt (libFuzzer, the sanitizers) for
# tools/run-sanitizers.
GM_APT_PACKAGES=(
  build-essential cmake ninja-build pkg-config binutils
  libeigen3-dev libsuitesparse-dev libgtest-dev libopenblas0-pthread
  python3 python3-venv python3-pip
  libglu1-mesa libgl1 libxrender1 libxcursor1 libxft2 libxinerama1 libgomp1
  calculix-ccx
  clang libclang-rt-14-dev
  clang-format-19 # tools/check-style: the version .clang-format is written for
)

# Installs those of the named Debian packages that are missing (tools/bootstrap-platforms.sh too).
gm_install_debian_packages() {
  local missing=() p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  echo "gearmesh: installing Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -eq 0 ] || sudo=sudo
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# The venv: the pinned packages (tools/requirements.txt, the CI lock file), then the repository's
# three Python packages as editable installs without their dependencies: gearmesh (the root
# pyproject.toml; GM_PACKAGE_BINARIES=OFF builds no binaries into it, it finds the FMUs in build/
# through GEARMESH_CHECKOUT), the maintainer tools gearmesh-dev (tools/) and the FE reference
# gearmesh-reference-fe (reference_fe/).
gm_make_venv() {
  local stamp="$GM_VENV/.requirements.sha256" want
  want=$(cat "$GM_REPO/tools/requirements.txt" "$GM_REPO/pyproject.toml" "$GM_REPO/tools/pyproject.toml" \
    "$GM_REPO/reference_fe/pyproject.toml" | sha256sum | cut -d' ' -f1)
  if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x "$GM_VENV/bin/python" ]; then
    return 0
  fi
  echo "gearmesh: preparing the Python environment in .venv"
  [ -x "$GM_VENV/bin/python" ] || "${PYTHON:-python3}" -m venv "$GM_VENV"
  "$GM_VENV/bin/python" -m pip install -q --upgrade pip
  "$GM_VENV/bin/python" -m pip install -q -r "$GM_REPO/tools/requirements.txt"
  "$GM_VENV/bin/python" -m pip uninstall -q -y gearmesh 2>/dev/null || true # an older tools/ install
  GM_PACKAGE_BINARIES=OFF "$GM_VENV/bin/python" -m pip install -q --no-deps --no-build-isolation \
    -e "$GM_REPO" -e "$GM_REPO/tools" -e "$GM_REPO/reference_fe"
  echo "$want" >"$stamp"
}

gm_build() {
  if [ ! -f "$GM_BUILD/CMakeCache.txt" ]; then
    cmake -S "$GM_REPO" -B "$GM_BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DPython3_EXECUTABLE="$GM_VENV/bin/python"
  fi
  cmake --build "$GM_BUILD" --parallel "$(nproc)"
}

# gearmesh.paths: the package of the editable install finds the FMUs, scenes and tools here
export GEARMESH_CHECKOUT="$GM_REPO"
gm_install_debian_packages "${GM_APT_PACKAGES[@]}"
gm_make_venv
gm_build
