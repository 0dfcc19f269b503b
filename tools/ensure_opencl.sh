#!/usr/bin/env bash
# Make sure an OpenCL CPU device exists for sgpipe's renderer.
# Installs Debian's PoCL ICD when running as root and none is found; otherwise prints the fix.
set -u
PY="${1:-.venv/bin/python}"
has_device() {
  "$PY" - <<'PYEOF' 2>/dev/null
import sys, pyopencl as cl
try:
    sys.exit(0 if any(p.get_devices() for p in cl.get_platforms()) else 1)
except Exception:
    sys.exit(1)
PYEOF
}
if has_device; then
  echo "opencl: device found"
  exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "opencl: no device; installing Debian's pocl-opencl-icd"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq pocl-opencl-icd >/dev/null
  if has_device; then echo "opencl: PoCL installed"; exit 0; fi
fi
echo "opencl: no OpenCL device; fix: sudo apt-get update && sudo apt-get install -y pocl-opencl-icd" >&2
exit 1
