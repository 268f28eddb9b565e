#!/usr/bin/env bash
# Install the system libraries synthcompose needs (headless EGL via Mesa, assimp) when missing.
# Debian/Ubuntu; uses apt-get as root, or sudo when available. --test: also what the tests use.
set -euo pipefail

need=()
have_lib() { ldconfig -p 2>/dev/null | grep -q "$1"; }
have_lib 'libEGL.so.1'      || need+=(libegl1)
have_lib 'libEGL_mesa.so.0' || need+=(libegl-mesa0)
ls /usr/lib/*/dri/swrast_dri.so /usr/lib/*/dri/kms_swrast_dri.so >/dev/null 2>&1 || need+=(libgl1-mesa-dri)
have_lib 'libGL.so.1'       || need+=(libgl1)
have_lib 'libassimp.so'     || need+=(libassimp5)
if [ "${1:-}" = "--test" ]; then  # the tests also open the batch report in a headless browser
  command -v chromium >/dev/null || need+=(chromium)
  command -v Xvfb >/dev/null || need+=(xvfb)          # the preview window's tests run under Xvfb
  have_lib 'libGLX_mesa.so.0' || need+=(libglx-mesa0)  # ... with Mesa's GLX (llvmpipe)
  have_lib 'libXrandr.so.2' || need+=(libxrandr2 libxcursor1 libxi6 libxinerama1)  # what GLFW loads
fi

if [ ${#need[@]} -eq 0 ]; then
  exit 0
fi
echo "installing system packages: ${need[*]}"
if ! command -v apt-get >/dev/null; then
  echo "error: missing ${need[*]} and no apt-get here; install the equivalent packages by hand" >&2
  exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "error: need root (or sudo) to install ${need[*]}" >&2; exit 1; }
  SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${need[@]}"
