#!/usr/bin/env bash
# One set-up path for the README, CI and developers. Idempotent; quiet when already done.
#
#   scripts/setup.sh              everything the tests need (scripts/test-all, .ci/run)
#   scripts/setup.sh --emulated   only what the main job needs (scripts/run-emulated)
#
# The main job (--emulated):
#  - the thumbv7m-none-eabi route and flip-link (scripts/setup-thumb.sh);
#  - qemu-system-arm for the emulated runs;
#  - gcc-arm-none-eabi, for libgcc's soft-float routines (tools/soft_float.rs).
# The tests, in addition:
#  - host toolchain components (rustfmt, clippy) when rustup manages the toolchain;
#  - node, npm and python3's venv, then the real NMEA clients of the marine tests (pynmea2,
#    Signal K's parser) under target/ (scripts/marine-clients);
#  - g++ for libFuzzer (scripts/fuzz).
# Debian packages come through scripts/lib/apt.sh: as root or with sudo, waiting (and saying so)
# while another install holds the package manager's lock, and naming the package and the
# command to run by hand when an install fails.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

mode=all
case "${1:-}" in
  "") ;;
  --emulated) mode=emulated ;;
  *) echo "setup: unknown argument '$1' (scripts/setup.sh [--emulated])" >&2; exit 2 ;;
esac

log() { echo "setup: $*" >&2; }
# shellcheck source=scripts/lib/apt.sh
. "$root/scripts/lib/apt.sh"

"$root/scripts/setup-thumb.sh"

if ! command -v qemu-system-arm >/dev/null 2>&1; then
  log "installing qemu-system-arm"
  apt_install qemu-system-arm
fi

# libgcc's Cortex-M3 soft-float (linked by tools/soft_float.rs; about twice as fast as
# compiler-builtins' routines): Debian's gcc-arm-none-eabi carries it.
if [ -z "${AHRS_LIBGCC:-}" ] && [ "${AHRS_SOFTFLOAT:-}" != builtins ] \
  && ! command -v "${ARM_NONE_EABI_GCC:-arm-none-eabi-gcc}" >/dev/null 2>&1; then
  log "installing gcc-arm-none-eabi (libgcc's soft-float for the Cortex-M3)"
  apt_install gcc-arm-none-eabi || {
    log "thumb builds need libgcc's soft-float (tools/soft_float.rs; AHRS_SOFTFLOAT=builtins for a different image on purpose)"
    exit 1
  }
fi

[ "$mode" = emulated ] && exit 0

if command -v rustup >/dev/null 2>&1; then
  for c in rustfmt clippy; do
    rustup component list --installed 2>/dev/null | grep -q "^$c" \
      || { log "adding $c"; rustup component add "$c" >/dev/null 2>&1 || log "could not add $c"; }
  done
fi

# The marine tests read the device's sentences with real clients (ahrs-tool/tests/marine.rs):
# node and npm for Signal K's parser, python3's venv for pynmea2; both packages from their
# registries into target/ (scripts/marine-clients, pinned in tools/marine/).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  log "installing nodejs and npm"
  apt_install nodejs npm
fi
if ! python3 -c 'import ensurepip, venv' >/dev/null 2>&1; then
  log "installing python3-venv"
  apt_install python3-venv
fi
"$root/scripts/marine-clients"

# The fuzz targets (scripts/fuzz) link libFuzzer, which libfuzzer-sys compiles from C++.
if ! command -v c++ >/dev/null 2>&1; then
  log "installing g++ (libFuzzer for scripts/fuzz)"
  apt_install g++
fi
