#!/usr/bin/env bash
# Installs everything v2xloc needs on Debian 12 (idempotent, no prompts). Run as root or with sudo.
set -euo pipefail
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
PKGS=(cmake ninja-build g++ pkg-config libeigen3-dev googletest libgtest-dev libgmock-dev
      libbenchmark-dev libgpiod-dev libhidapi-dev libsocketcan-dev can-utils
      python3 python3-numpy python3-can python3-open3d python3-matplotlib
      g++-aarch64-linux-gnu qemu-user qemu-system-arm gcc-arm-none-eabi libstdc++-arm-none-eabi-newlib
      binutils-arm-none-eabi valgrind nodejs npm zlib1g-dev ca-certificates
      libmbedtls-dev libssl-dev nlohmann-json3-dev liblzf-dev libcli11-dev libpng-dev libdeflate-dev
      clang ccache libfuzzer-14-dev libclang-rt-14-dev llvm-14)
ARM64_PKGS=(libgpiod-dev:arm64 libhidapi-dev:arm64 libsocketcan-dev:arm64 libmbedtls-dev:arm64 libssl-dev:arm64 libpng-dev:arm64 liblzf-dev:arm64 zlib1g-dev:arm64)
missing=()
for p in "${PKGS[@]}" "${ARM64_PKGS[@]}"; do
  # NodeSource's nodejs bundles npm and conflicts with Debian's npm package: a working npm is enough.
  if [ "$p" = npm ] && command -v npm >/dev/null 2>&1; then continue; fi
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup-debian: installing ${missing[*]}"
  dpkg --print-foreign-architectures | grep -qx arm64 || $SUDO dpkg --add-architecture arm64
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
echo "setup-debian: all packages present"
