#!/usr/bin/env bash
# Installs probecast's build and test dependencies on Debian 12 (apt packages only).
# Idempotent: packages already present are left alone; safe to run on every build.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  glslang-tools            # glslangValidator: GLSL -> SPIR-V at build time
  libvulkan-dev            # Vulkan loader and headers
  mesa-vulkan-drivers      # lavapipe (Vulkan on the CPU) for headless runs and CI
  vulkan-validationlayers  # tests run with VK_LAYER_KHRONOS_validation
  libtinygltf-dev libstb-dev nlohmann-json3-dev  # glTF / GLB loading, image decoding
  libpng-dev libturbojpeg0-dev                   # PNG and JPEG output
  libjpeg62-turbo-dev      # libjpeg API of libjpeg-turbo: restart intervals for striped JPEG
  libopenexr-dev           # OpenEXR 3 (OpenEXRCore, its C API): .exr environment images
  libmicrohttpd-dev libwebsockets-dev libcjson-dev  # probecast serve: HTTP API, frame stream, JSON
  libssl-dev               # checks --tls-cert/--tls-key (OpenSSL, which libwebsockets links)
  libvpx-dev libsvtav1enc-dev  # video frames: VP8/VP9 (libvpx 1.12) and AV1 (SVT-AV1 1.4.1) encoders
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "installing: ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
