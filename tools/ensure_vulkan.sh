#!/usr/bin/env bash
# Make sure a Vulkan CPU device (Mesa's lavapipe) exists for the Khronos glTF-IBL-Sampler that
# the export tests and benchmarks run beside sgpipe. Installs Debian's mesa-vulkan-drivers when
# running as root and no lavapipe ICD is found; otherwise prints the fix.
set -u
ICD=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
if [ -f "$ICD" ]; then
  echo "vulkan: lavapipe found"
  exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "vulkan: no lavapipe; installing Debian's mesa-vulkan-drivers"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq --no-install-recommends \
    mesa-vulkan-drivers >/dev/null
  if [ -f "$ICD" ]; then echo "vulkan: lavapipe installed"; exit 0; fi
fi
echo "vulkan: no lavapipe ICD; fix: sudo apt-get update && sudo apt-get install -y mesa-vulkan-drivers" >&2
exit 1
