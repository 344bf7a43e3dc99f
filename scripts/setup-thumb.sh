#!/usr/bin/env bash
# Make `thumbv7m-none-eabi` (Cortex-M3, soft-float) builds work on this machine: the target and
# flip-link, the linker of every thumb build (.cargo/config.toml).
#
# Route 1 (a laptop, or any machine where rustup can fetch targets): the rustup target.
# Route 2 (package registries only): Debian's rustc-web / cargo-web / rust-web-src (Rust 1.96,
#   /usr/bin/rustc, /usr/bin/cargo) with RUSTC_BOOTSTRAP=1 and -Zbuild-std=core, linked with
#   rust-lld from the rustup toolchain, or Debian's ld.lld. Installs (apt, root or sudo) rustc-web,
#   cargo-web, rust-web-src and, when no rust-lld is found, lld.
#
# Idempotent and quiet when already done. Writes the chosen route to target/thumb-route.env,
# which scripts/cargo-thumb reads. Set THUMB_ROUTE=buildstd to force route 2 (used to test it);
# the choice sticks until target/thumb-route.env is deleted.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
env_file="$root/target/thumb-route.env"
target=thumbv7m-none-eabi
mkdir -p "$root/target"

log() { echo "setup-thumb: $*" >&2; }

write_env() { # route cargo rustc linker
  cat >"$env_file.tmp" <<EOT
THUMB_ROUTE=$1
THUMB_CARGO=$2
THUMB_RUSTC=$3
THUMB_LINKER=$4
EOT
  mv "$env_file.tmp" "$env_file"
}

# knurling's flip-link, the linker of every thumb build (.cargo/config.toml: the stack below the
# static data, so that an overflow faults). From crates.io, built here; about a minute once.
if ! command -v flip-link >/dev/null 2>&1; then
  log "installing flip-link (cargo install flip-link --locked)"
  cargo install -q flip-link --locked >/dev/null 2>&1 || { log "could not install flip-link"; exit 1; }
fi

# Fast path: a previous run chose a route and it is still valid.
if [ -f "$env_file" ] && [ -z "${THUMB_ROUTE:-}" ]; then
  # shellcheck disable=SC1090
  . "$env_file"
  case "$THUMB_ROUTE" in
    rustup) rustup target list --installed 2>/dev/null | grep -qx "$target" && exit 0 ;;
    buildstd) [ -x "$THUMB_CARGO" ] && [ -x "$THUMB_RUSTC" ] && [ -x "$THUMB_LINKER" ] && exit 0 ;;
  esac
fi

want=${THUMB_ROUTE:-auto}

# Route 1: rustup target.
if [ "$want" != buildstd ] && command -v rustup >/dev/null 2>&1; then
  if rustup target list --installed 2>/dev/null | grep -qx "$target" \
    || timeout 300 rustup target add "$target" >/dev/null 2>&1; then
    write_env rustup "$(command -v cargo)" "$(command -v rustc)" rust-lld
    exit 0
  fi
  log "rustup could not install $target; falling back to Debian's rustc-web with build-std"
fi

# Route 2: Debian rustc-web + rust-web-src, build-std=core.
# The three packages must be installed at one version: rust-web-src does not depend on rustc-web,
# and build-std needs the library sources of exactly the compiler in use.
debs="rustc-web cargo-web rust-web-src"
debs_ok() {
  local st
  st=$(dpkg-query -W -f='${db:Status-Abbrev}${Version}\n' $debs 2>/dev/null | sort -u) || return 1
  [ "$(printf '%s\n' "$st" | wc -l)" -eq 1 ] && [ "${st:0:2}" = ii ] \
    && [ -d "$(/usr/bin/rustc --print sysroot)/lib/rustlib/src/rust/library/core" ]
}
# Update first: with stale lists apt would install bookworm's old rustc-web (1.85) instead of the
# bookworm-security one (1.96). Root or sudo, waiting for the package manager's lock: lib/apt.sh.
APT_UPDATE_FIRST=1
# shellcheck source=scripts/lib/apt.sh
. "$root/scripts/lib/apt.sh"
deb_rustc=/usr/bin/rustc
deb_cargo=/usr/bin/cargo
if ! debs_ok; then
  log "installing Debian $debs"
  apt_install $debs || exit 1
  debs_ok || { log "Debian $debs not usable (mixed versions, or no library/core in the sysroot)"; exit 1; }
  log "using $("$deb_rustc" -V)"
fi

# Linker: rust-lld from any rustup toolchain; else Debian's rust-lld (only a working link when lld-22
# is installed, rust-web-llvm ships just the symlink); else Debian's ld.lld (package lld).
linker=""
for cand in "${RUSTUP_HOME:-$HOME/.rustup}"/toolchains/*/lib/rustlib/x86_64-unknown-linux-gnu/bin/rust-lld \
  /usr/bin/rust-lld /usr/bin/ld.lld; do
  [ -x "$cand" ] && { linker=$cand; break; }
done
if [ -z "$linker" ]; then
  log "installing Debian lld"
  apt_install lld || exit 1
  linker=/usr/bin/ld.lld
fi
write_env buildstd "$deb_cargo" "$deb_rustc" "$linker"
