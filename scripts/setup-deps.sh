#!/usr/bin/env bash
# Installs every build and run dependency of leap from Debian 12 packages.
# Idempotent: packages already present are left alone.
set -euo pipefail
PKGS=(
  build-essential cmake pkg-config
  libopenvdb-dev libboost-iostreams-dev libimath-dev libtbb-dev libblosc-dev zlib1g-dev
  libvulkan-dev mesa-vulkan-drivers vulkan-tools glslang-dev glslang-tools
  libopenimageio-dev openimageio-tools libcjson-dev libopenvdb-tools libnifti2-dev ffmpeg gnuplot-nox xvfb xauth libglfw3-dev libimgui-dev clang libclang-rt-14-dev
  python3-nibabel python3-openvdb mricron-data
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup-deps: all ${#PKGS[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
