#!/usr/bin/env bash
# scripts/hil without a board: what it says and how it exits when it cannot run, against a
# stand-in `probe-rs` on PATH that logs its arguments (`list` prints no probe, or one probe as
# probe-rs 0.2x does: "[0]: STLink V2 -- 0483:3748:... (ST-LINK)"; every other command fails,
# so a flash attempt would show in the log and in the exit status). Checked:
#   - a failed build (`--build-only`, as CI runs it) says "hil: build failed: ..." and exits 1,
#     before any probe is asked
#     (the build made to fail for real: an option rustc does not know, through RUSTFLAGS);
#   - no probe: "hil: not run: no probe attached", exit 3, nothing flashed;
#   - probe-rs not installed: the same, naming the install command;
#   - a probe but no serial port (neither --port nor HIL_PORT), or a port that does not
#     exist: "hil: not run: ..." naming it, exit 3, nothing flashed;
#   - an unknown argument, or --port without a value: exit 2.
# The builds are real (warm after `scripts/hil --build-only`, which scripts/test-all runs first).
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
hil="$root/scripts/hil"
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
failures=0
fail() { echo "hil test: FAILED: $*" >&2; failures=$((failures + 1)); }
unset HIL_PORT

mkdir -p "$t/bin"
cat >"$t/bin/probe-rs" <<'FAKE'
#!/usr/bin/env bash
printf '%s\n' "$*" >>"$FAKE_LOG"
case "$1" in
  list)
    if [ "$FAKE_PROBE" = 1 ]; then
      echo "The following debug probes were found:"
      echo "[0]: STLink V2 -- 0483:3748:0000000000000001 (ST-LINK)"
    else
      echo "No debug probes were found."
    fi
    exit 0 ;;
  *) echo "stand-in probe-rs: '$1' is not expected here" >&2; exit 99 ;;
esac
FAKE
chmod +x "$t/bin/probe-rs"
export FAKE_LOG="$t/probe-rs.calls"

# run NAME EXPECTED_STATUS ARGS...: runs scripts/hil, output in $t/NAME.out (stdout and stderr).
run() {
  local name=$1 want=$2
  shift 2
  : >"$FAKE_LOG"
  "$@" >"$t/$name.out" 2>&1
  local rc=$?
  [ "$rc" = "$want" ] || fail "$name: exit $rc, expected $want; output: $(tail -n 5 "$t/$name.out")"
}
says() { grep -qF -- "$2" "$t/$1.out" || fail "$1: does not say '$2'; output: $(tail -n 5 "$t/$1.out")"; }
probe_calls() { # NAME EXPECTED: the stand-in's calls, one per line
  local got
  got=$(cat "$FAKE_LOG")
  [ "$got" = "$2" ] || fail "$1: probe-rs was called with '$got', expected '$2'"
}

run bad-arg 2 "$hil" --frobnicate
says bad-arg "hil: unknown argument '--frobnicate'"
run port-without-value 2 "$hil" --port
says port-without-value "hil: --port needs a serial port"

# A failed build: said, exit 1, the probe never asked.
run build-fails 1 env PATH="$t/bin:$PATH" RUSTFLAGS=--hil-test-unknown-option "$hil" --build-only
says build-fails "hil: build failed: the firmware image"
probe_calls build-fails ""

# No probe.
run no-probe 3 env PATH="$t/bin:$PATH" FAKE_PROBE=0 "$hil" --port /dev/null
says no-probe "hil: not run: no probe attached"
probe_calls no-probe "list"
grep -q "hil: firmware image built" "$t/no-probe.out" || fail "no-probe: the image was not built first"

# probe-rs not installed: PATH without any probe-rs (skipped where a real one is installed in
# a directory the build needs).
nopath=""
IFS=: read -ra dirs <<<"$PATH"
for d in "${dirs[@]}"; do
  [ -x "$d/probe-rs" ] || nopath="$nopath${nopath:+:}$d"
done
run not-installed 3 env PATH="$nopath" "$hil" --port /dev/null
says not-installed "hil: not run: no probe attached (probe-rs is not installed"

# A probe, but no serial port for stage 1; then one that does not exist. Nothing flashed.
run no-port 3 env PATH="$t/bin:$PATH" FAKE_PROBE=1 "$hil"
says no-port "hil: not run: no serial port given for stage 1"
probe_calls no-port "list"
run missing-port 3 env PATH="$t/bin:$PATH" FAKE_PROBE=1 HIL_PORT="$t/ttyNONE" "$hil"
says missing-port "hil: not run: serial port $t/ttyNONE does not exist"
probe_calls missing-port "list"

if [ "$failures" -gt 0 ]; then
  echo "hil test: $failures failure(s)" >&2
  exit 1
fi
echo "hil test: scripts/hil without a board: every case passed"
