#!/usr/bin/env bash
# The platform stage's set-up (docs/platforms.md), sourced by tools/run-tests after
# tools/bootstrap.sh (GM_PLATFORMS=0 leaves it out): installs what is missing, then builds the
# multi-platform FMU into build-platforms/ (incremental after the first run).
#   * Debian packages: wine and wine64 (run the win64 binary), llvm-14 (llvm-lipo joins the macOS
#     slices), unzip, maven and Java 17 (VDMCheck2; the JDK's compiler runs the FMI4j driver of
#     tests/python/test_masters.py, which fetches its masters into the cache itself);
#   * the Zig toolchain comes with the venv (ziglang, tools/requirements.txt);
#   * fmi-sim (crates.io, built by cargo) and VDMCheck2 (Maven Central, by mvn): into the
#     git-ignored cache, $GM_CACHE (default .cache/ in the repository), with the downloads.
# cargo must be on the PATH (Rust >= 1.85, for fmi-sim's 2024 edition: rustup; Debian 12's is too old).
set -euo pipefail
: "${GM_REPO:?source tools/bootstrap.sh first}"
GM_CACHE="${GM_CACHE:-$GM_REPO/.cache}"
export GM_CACHE
GM_FMI_SIM_VERSION=0.7.0
GM_VDMCHECK_DIR="$GM_CACHE/vdmcheck2"

gm_platforms_fail() {
  echo "gearmesh: $*" >&2
  return 1
}

gm_install_fmi_sim() {
  local bin="$GM_CACHE/cargo/bin/fmi-sim" version=""
  [ -x "$bin" ] && version=$("$bin" --version 2>&1 || true)  # it prints the version as an error
  [[ "$version" == *"fmi-sim $GM_FMI_SIM_VERSION"* ]] && return 0
  command -v cargo >/dev/null || gm_platforms_fail "cargo not found: install Rust (rustup) to build fmi-sim"
  echo "gearmesh: building fmi-sim $GM_FMI_SIM_VERSION from crates.io (cargo install)"
  # --debug: a third of the release build's CPU time (197 s against 566 s), and a checker's speed
  # does not matter
  CARGO_HOME="$GM_CACHE/cargo-home" CARGO_TARGET_DIR="$GM_CACHE/cargo-target" \
    cargo install --quiet --locked --debug fmi-sim --version "$GM_FMI_SIM_VERSION" --root "$GM_CACHE/cargo"
}

gm_install_vdmcheck() {
  [ -f "$GM_VDMCHECK_DIR/vdmcheck2.jar" ] && [ -d "$GM_VDMCHECK_DIR/fmi2-static-model" ] && return 0
  echo "gearmesh: fetching VDMCheck2 from Maven Central (tools/checkers/pom.xml)"
  rm -rf "$GM_VDMCHECK_DIR"
  mvn -q -B -f "$GM_REPO/tools/checkers/pom.xml" -Dmaven.repo.local="$GM_CACHE/m2" \
    dependency:copy-dependencies -DoutputDirectory="$GM_VDMCHECK_DIR" -Dmdep.stripVersion=true
  # vdmcheck2.jar reads its VDM-SL models and the FMI 2.0 schema as files beside it, the layout of
  # its release zip: unpack them from the jars Maven Central has.
  (cd "$GM_VDMCHECK_DIR" && unzip -q -o static-model.jar 'fmi2-static-model/*' &&
    unzip -q -o rule-model.jar 'fmi2-rule-model/*' && unzip -q -o vdmcheck2.jar 'fmi2schema/*')
}

gm_install_debian_packages wine wine64 llvm-14 unzip maven openjdk-17-jre-headless openjdk-17-jdk-headless
gm_install_fmi_sim
gm_install_vdmcheck
echo "gearmesh: building the multi-platform FMU (build-platforms/GearMesh.fmu)"
"$GM_VENV/bin/gearmesh-dev" platforms --jobs "$(nproc)"
