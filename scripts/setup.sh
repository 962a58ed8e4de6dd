#!/usr/bin/env bash
# One-time set-up of a fresh Debian/Ubuntu machine: C toolchains and QEMU for processor-in-the-loop
# runs (apt), then vsegen with its test tools (pip, from pyproject.toml). Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(gcc g++ clang binutils make cmake gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm cppcheck valgrind time)
missing=()
for package in "${packages[@]}"; do
  dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${missing[@]}"
fi

PIP_ROOT_USER_ACTION=ignore python3 -m pip install -q -e ".[test]"
echo "vsegen set up: $(vsegen --version)"
