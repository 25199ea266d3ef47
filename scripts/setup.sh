#!/usr/bin/env bash
# Installs every Debian package the project needs, only what is missing.
# Quiet when everything is present. Runs as root, or through sudo.
set -euo pipefail

packages=(
  build-essential cmake pkg-config make
  povray
  libopenimageio-dev openimageio-tools libopenexr-dev libimath-dev
  libfftw3-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev
  python3 python3-venv python3-pip python3-dev
  chromium
  time ffmpeg
  slurmctld slurmd slurm-client munge
)

here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$here")

# The scripts' Python packages: a project-local virtual environment from the
# pinned requirements, rebuilt only when they change.
setup_python() {
  local venv=$root/.venv req=$here/requirements.txt
  if [ -x "$venv/bin/python" ] && cmp -s "$req" "$venv/requirements.installed"; then
    return 0
  fi
  echo "setup: installing the scripts' Python packages into .venv" >&2
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check -r "$req"
  cp "$req" "$venv/requirements.installed"
}

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  setup_python
  exit 0
fi

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
setup_python
