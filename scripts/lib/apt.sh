# Sourced by scripts/setup.sh and scripts/setup-thumb.sh: one way to install Debian packages.
#  - as root, or through sudo when not root (a clear error when neither is possible);
#  - waits for the package manager's lock when another install holds it (unattended upgrades on a
#    fresh machine, another terminal), saying which process holds it and for how long it has
#    waited, up to APT_LOCK_WAIT seconds (default 600); apt itself then waits up to the same time
#    (DPkg::Lock::Timeout) for the lock taken between the check and its start;
#  - `apt-get update` once per run, and only when an install fails without it (or always, with
#    APT_UPDATE_FIRST=1: setup-thumb.sh needs the current lists);
#  - on failure names the packages and the command to run by hand, with apt's last lines.
# The caller defines log().

apt_lock_wait=${APT_LOCK_WAIT:-600}
apt_updated=""

# The process holding an apt/dpkg lock (fcntl record locks, as apt takes them), or nothing.
apt_lock_holder() {
  python3 - "$1" <<'PY' 2>/dev/null
import fcntl, os, struct, sys
try:
    fd = os.open(sys.argv[1], os.O_RDONLY)
except OSError:
    sys.exit(0)
# struct flock on Linux x86-64/aarch64: short l_type, l_whence; off_t l_start, l_len; pid_t l_pid.
req = struct.pack("hhqqi4x", fcntl.F_WRLCK, 0, 0, 0, 0)
l_type, _, _, _, pid = struct.unpack("hhqqi4x", fcntl.fcntl(fd, fcntl.F_GETLK, req))
if l_type != fcntl.F_UNLCK and pid > 0:
    try:
        cmd = " ".join(open(f"/proc/{pid}/cmdline", "rb").read().decode(errors="replace").replace("\0", " ").split())
    except OSError:
        cmd = "?"
    print(f"process {pid} ({cmd[:60]})")
PY
}

# Wait until no apt/dpkg lock is held, reporting every 30 s. Fails after $apt_lock_wait s.
apt_wait_for_lock() {
  local t0=$SECONDS said=-30 lock holder
  while :; do
    holder=""
    for lock in /var/lib/dpkg/lock-frontend /var/lib/dpkg/lock /var/lib/apt/lists/lock /var/cache/apt/archives/lock; do
      holder=$(apt_lock_holder "$lock")
      [ -n "$holder" ] && break
    done
    if [ -z "$holder" ]; then
      [ "$said" -ge 0 ] && log "the package manager is free after $((SECONDS - t0)) s of waiting"
      return 0
    fi
    if [ $((SECONDS - t0)) -ge "$apt_lock_wait" ]; then
      log "gave up after $apt_lock_wait s: $lock is still held by $holder (APT_LOCK_WAIT=<seconds> waits longer)"
      return 1
    fi
    if [ $((SECONDS - said)) -ge 30 ]; then
      log "waiting for the package manager: $lock is held by $holder, $((SECONDS - t0)) s so far (up to $apt_lock_wait s)"
      said=$SECONDS
    fi
    sleep 2
  done
}

apt_run() { # apt_run ARGS...: apt-get as root (sudo when needed), lock-aware; output kept in $apt_out
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null 2>&1; then
      apt_out="not root and no sudo: run 'apt-get $*' as root"
      return 1
    fi
    sudo=(sudo)
  fi
  apt_wait_for_lock || { apt_out="the package manager's lock stayed held"; return 1; }
  apt_out=$(DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get -o DPkg::Lock::Timeout="$apt_lock_wait" \
    -o Acquire::Retries=3 "$@" 2>&1)
}

apt_install() { # apt_install PKG...
  local sudo_hint=""
  [ "$(id -u)" -ne 0 ] && sudo_hint="sudo "
  if [ -z "$apt_updated" ] && [ "${APT_UPDATE_FIRST:-0}" = 1 ]; then
    apt_run update -qq && apt_updated=1
  fi
  if apt_run install -y -qq --no-install-recommends "$@"; then
    return 0
  fi
  if [ -z "$apt_updated" ]; then
    apt_run update -qq && apt_updated=1
    apt_run install -y -qq --no-install-recommends "$@" && return 0
  fi
  log "could not install $* with apt-get; its last lines:"
  printf '%s\n' "$apt_out" | tail -n 5 | sed 's/^/    /' >&2
  log "run by hand: ${sudo_hint}apt-get update && ${sudo_hint}apt-get install --no-install-recommends $*"
  return 1
}
