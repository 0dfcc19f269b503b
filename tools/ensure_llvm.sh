#!/usr/bin/env bash
# Make sure Debian's libllvm19 exists for Mitsuba's llvm_ad_rgb variant (make validate).
# Installs it when running as root; otherwise prints the fix.
set -u
lib=$(ls /usr/lib/x86_64-linux-gnu/libLLVM-19.so* /usr/lib/*/libLLVM.so.19* 2>/dev/null | head -1)
if [ -n "$lib" ]; then echo "llvm: $lib"; exit 0; fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "llvm: installing Debian's libllvm19"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq libllvm19 >/dev/null && exit 0
fi
echo "llvm: no libLLVM 19; fix: sudo apt-get update && sudo apt-get install -y libllvm19" >&2
exit 1
