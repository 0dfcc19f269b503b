#!/usr/bin/env bash
# Make sure headless Chromium and chromedriver exist for the HTML report's browser test.
# Installs Debian's chromium + chromium-driver when running as root; otherwise prints the fix.
set -u
if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then
  echo "browser: chromium found"
  exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "browser: installing Debian's chromium and chromium-driver"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq >/dev/null && apt-get install -y -qq chromium chromium-driver >/dev/null
  if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then
    echo "browser: chromium installed"; exit 0
  fi
fi
echo "browser: no chromium; fix: sudo apt-get update && sudo apt-get install -y chromium chromium-driver" >&2
exit 1
