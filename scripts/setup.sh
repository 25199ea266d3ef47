#!/usr/bin/env bash
# Installs every Debian package the project needs, only what is missing.
# Quiet when everything is present. Runs as root, or through sudo.
set -euo pipefail

packages=(
  build-essential cmake pkg-config make
  povray
  libopenimageio-dev openimageio-tools libopenexr-dev
  libfftw3-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev
  python3 python3-numpy python3-matplotlib
  time
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -eq 0 ]; then
  sudo=()
elif command -v sudo >/dev/null; then
  sudo=(sudo)
else
  echo "setup: need root or sudo to install: ${missing[*]}" >&2
  exit 1
fi

echo "setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
