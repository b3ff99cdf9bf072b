#!/usr/bin/env bash
# Installs the Debian packages rayproof builds with, only those missing. libcgal-demo ships CGAL's
# data.tar.gz, whose meshes (the Stanford bunny, ...) the bundled audit scenes use.
# Works as root or through sudo; does nothing when everything is present.
set -euo pipefail
packages=(build-essential cmake pkg-config libcgal-dev libgmp-dev libmpfr-dev libeigen3-dev
          googletest libgtest-dev libbenchmark-dev nlohmann-json3-dev libcli11-dev libpng-dev
          libembree-dev python3 libcgal-demo pybind11-dev python3-dev python3-numpy)
# `install-deps.sh fuzz` or `sanitize`: also clang with libFuzzer and the sanitizer runtimes.
if [ "${1:-}" = fuzz ] || [ "${1:-}" = sanitize ]; then packages+=(clang libclang-rt-dev); fi
# `install-deps.sh test` (make test) or `sanitize`: also headless Chromium, for the one test that
# opens an audit's report.html in a real browser.
# And clang-format, for the test that the tree follows .clang-format.
if [ "${1:-}" = test ] || [ "${1:-}" = sanitize ]; then packages+=(chromium clang-format); fi
# `install-deps.sh test`: also pytest, for the Python module's suite (python/tests). Open3D
# (python3-open3d) is an example, never installed here: its test skips when it is absent.
if [ "${1:-}" = test ]; then packages+=(python3-pytest); fi
# `install-deps.sh bench` (make bench): also valgrind, whose callgrind counts instructions per call
# (scripts/instruction-counts.py).
if [ "${1:-}" = bench ]; then packages+=(valgrind); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0
echo "rayproof: installing missing Debian packages: ${missing[*]}" >&2
if [ "$(id -u)" -eq 0 ]; then sudo=(); else sudo=(sudo); fi
"${sudo[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
