#!/usr/bin/env bash
# scripts/hil without a board: what it says and how it exits when it cannot run, against a
# stand-in `probe-rs` on PATH that logs its arguments (`list` prints no probe, or one probe as
# probe-rs 0.2x does: "[0]: STLink V2 -- 0483:3748:... (ST-LINK)"; every other command fails,
# so a flash attempt would show in the log and in the exit status). Checked:
#   - a failed build (`--build-only`, as CI runs it) says "hil: build failed: ..." and exits 1,
#     before any probe is asked
#     (the build made to fail for real: an option rustc does not know, through RUSTFLAGS);
#   - no probe: "hil: not run: no probe attached", exit 3, nothing flashed;
#   - probe-rs not installed: the same, naming the install command (skipped where one is);
#   - a probe but no serial port (neither --port nor HIL_PORT), or a port that does not
#     exist: "hil: not run: ..." naming it, exit 3, nothing flashed;
#   - an unknown argument, or --port without a value: exit 2;
#   - stage 1's checks against the device emulator on a pty (below), the flash and resets
#     stood in for;
#   - the DFU route (`--dfu`) against a stand-in `dfu-util` (its `-l` lists a DfuSe device with
#     the layout FAKE_LAYOUT, or none; `-D` keeps what it was given, `-U` gives it back,
#     FAKE_CORRUPT=1 one byte changed): not run without a port, without dfu-util or without a
#     device; a layout not writable from 0x08003000 exactly writes nothing and fails; the whole
#     route with the emulator as the USB port, and a read-back that differs.
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
  download|reset|run) [ "${FAKE_FLASH:-0}" = 1 ] && exit 0 ;;&
  *) echo "stand-in probe-rs: '$1' is not expected here" >&2; exit 99 ;;
esac
FAKE
chmod +x "$t/bin/probe-rs"
export FAKE_LOG="$t/probe-rs.calls"

mkdir -p "$t/dfubin"
cat >"$t/dfubin/dfu-util" <<'FAKE'
#!/usr/bin/env bash
printf '%s\n' "$*" >>"$FAKE_DFU_LOG"
case "$*" in
  -l)
    echo "dfu-util 0.11"
    [ -n "$FAKE_LAYOUT" ] &&
      echo "Found DFU: [0483:df11] ver=0200, devnum=7, cfg=1, intf=0, path=\"1-2\", alt=0, name=\"@Internal Flash  $FAKE_LAYOUT\", serial=\"STM32\""
    exit 0 ;;
  *" -D "*) cp "${@: -1}" "$FAKE_DFU_MEM"; exit 0 ;;
  *" -U "*)
    cp "$FAKE_DFU_MEM" "${@: -1}"
    [ "${FAKE_CORRUPT:-0}" = 1 ] && printf 'X' | dd of="${@: -1}" bs=1 seek=100 conv=notrunc 2>/dev/null
    exit 0 ;;
esac
echo "stand-in dfu-util: '$*' is not expected here" >&2
exit 99
FAKE
chmod +x "$t/dfubin/dfu-util"
export FAKE_DFU_LOG="$t/dfu-util.calls" FAKE_DFU_MEM="$t/dfu-mem.bin"

# run NAME EXPECTED_STATUS ARGS...: runs scripts/hil, output in $t/NAME.out (stdout and stderr).
run() {
  local name=$1 want=$2
  shift 2
  : >"$FAKE_LOG"
  : >"$FAKE_DFU_LOG"
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

# probe-rs not installed (skipped where a real one is installed: removing it from PATH could
# remove cargo with it).
if command -v probe-rs >/dev/null 2>&1; then
  echo "hil test: the case without probe-rs skipped: a real probe-rs is installed ($(command -v probe-rs))"
else
  run not-installed 3 "$hil" --port /dev/null
  says not-installed "hil: not run: no probe attached (probe-rs is not installed"
fi

# A probe, but no serial port for stage 1; then one that does not exist. Nothing flashed.
run no-port 3 env PATH="$t/bin:$PATH" FAKE_PROBE=1 "$hil"
says no-port "hil: not run: no serial port given for stage 1"
probe_calls no-port "list"
run missing-port 3 env PATH="$t/bin:$PATH" FAKE_PROBE=1 HIL_PORT="$t/ttyNONE" "$hil"
says missing-port "hil: not run: serial port $t/ttyNONE does not exist"
probe_calls missing-port "list"

# Stage 1 against the device emulator on a pseudo-terminal (`ahrs-tool emulate --pty`: the
# firmware's library with simulated sensors, answering on the pty as the board on its port),
# the stand-in's download, reset and run succeeding without doing anything. The emulator does
# not restart on a reset, and with `--broken-mag` its magnetometer does not answer (its
# SELFTEST otherwise reads as a healthy board's, WARN): stage 1 must find no boot sentence and a
# SELFTEST that is FAIL, and pass VER, the SET/GET round trip, the $PINAH rate (10 Hz), SAVE
# and the value after the "reset"; then stage 2 runs, and the exit is 1 with 3 failures.
tool="${CARGO_TARGET_DIR:-$root/target}/debug/ahrs-tool"
if (cd "$root" && cargo build -q --locked -p ahrs-tool); then
  # start_emulator ARGS...: the emulator in the background (pid in $emu), its pty in $pty.
  start_emulator() {
    "$tool" emulate --pty "$@" >"$t/emu.out" 2>&1 &
    emu=$!
    pty=""
    for _ in $(seq 100); do
      pty=$(head -n1 "$t/emu.out" 2>/dev/null)
      [[ "$pty" == /dev/* ]] && break
      sleep 0.1
    done
  }
  start_emulator --broken-mag
  if [[ "$pty" == /dev/* ]]; then
    run emulator 1 env PATH="$t/bin:$PATH" FAKE_PROBE=1 FAKE_FLASH=1 "$hil" --port "$pty"
    says emulator "hil: FAILED: no boot sentence \$PINAB with version"
    says emulator "hil: ok: VER: \$PINAR,OK,VER,inemo-ahrs,"
    says emulator "hil: FAILED: SELFTEST is not PASS or WARN: \$PINAR,OK,SELFTEST,FAIL,"
    says emulator "hil: ok: SET/GET mag.declination: "
    grep -Eq '^hil: ok: (9[5-9]|10[0-6]) \$PINAH in 10 s at output.rate 10 Hz$' "$t/emulator.out" \
      || fail "emulator: the \$PINAH count: $(grep PINAH "$t/emulator.out")"
    says emulator "hil: ok: SAVE: \$PINAR,OK,SAVE,"
    says emulator "hil: ok: after SAVE and a reset mag.declination reads 12.5"
    says emulator "hil: 3 check(s) failed"
    fw="${CARGO_TARGET_DIR:-$root/target}/thumbv7m-none-eabi/release/inemo-ahrs"
    suite=$(sed -n 's/^hil: on-target suite built: //p' "$t/emulator.out")
    probe_calls emulator "list
download --chip STM32F103RE $fw
reset --chip STM32F103RE
reset --chip STM32F103RE
run --chip STM32F103RE $suite"

    # The DFU route, the emulator standing in for the firmware's USB port (its SELFTEST reads
    # as a healthy board's: WARN, crystal 8000 kHz).
    kill "$emu" 2>/dev/null
    wait "$emu" 2>/dev/null
    start_emulator
    image="$root/target/inemo-ahrs-dfu.bin"
    size=$(stat -c %s "$image" 2>/dev/null || echo 0)
    good="/0x08000000/06*002Ka,250*002Kg"
    run dfu 0 env PATH="$t/dfubin:$PATH" FAKE_LAYOUT="$good" "$hil" --dfu --port "$pty"
    says dfu "hil: ok: DFU layout $good: writable from 0x08003000"
    says dfu "hil: ok: DFU download of $image ($size B)"
    says dfu "hil: ok: read back equal ($size B from 0x08003000)"
    says dfu "hil: ok: VER: \$PINAR,OK,VER,inemo-ahrs,"
    says dfu "hil: ok: SELFTEST over USB: \$PINAR,OK,SELFTEST,WARN,10100,8000,"
    says dfu "hil: all checks passed (DFU route)"
    [ "$(cat "$FAKE_DFU_LOG")" = "-l
-a 0 -s 0x08003000 -D $image
-a 0 -s 0x08003000:$size -U $(sed -n 's/^-a 0 -s 0x08003000:[0-9]* -U //p' "$FAKE_DFU_LOG")
-a 0 -s 0x08003000:leave -D $image" ] || fail "dfu: dfu-util was called with '$(cat "$FAKE_DFU_LOG")'"
    probe_calls dfu ""
    run dfu-readback 1 env PATH="$t/dfubin:$PATH" FAKE_LAYOUT="$good" FAKE_CORRUPT=1 "$hil" --dfu --port "$pty"
    says dfu-readback "hil: FAILED: the read-back differs from the image"
    says dfu-readback "hil: 1 check(s) failed"
  else
    fail "the emulator gave no pseudo-terminal: $(cat "$t/emu.out")"
  fi
  kill "$emu" 2>/dev/null
  wait "$emu" 2>/dev/null
else
  fail "cargo build -p ahrs-tool"
fi

# The DFU route's refusals: no port; no dfu-util; no device; a layout that would put the image
# anywhere but 0x08003000 (nothing written: the listing is the only call).
run dfu-no-port 3 env PATH="$t/dfubin:$PATH" FAKE_LAYOUT="/0x08000000/06*002Ka,250*002Kg" "$hil" --dfu
says dfu-no-port "hil: not run: no serial port given for the DFU route"
if command -v dfu-util >/dev/null 2>&1; then
  echo "hil test: the case without dfu-util skipped: a real one is installed ($(command -v dfu-util))"
else
  run dfu-not-installed 3 "$hil" --dfu --port /dev/null
  says dfu-not-installed "hil: not run: dfu-util is not installed"
fi
run dfu-no-device 3 env PATH="$t/dfubin:$PATH" FAKE_LAYOUT="" "$hil" --dfu --port /dev/null
says dfu-no-device "hil: not run: no DFU device (hold KEY"
[ "$(cat "$FAKE_DFU_LOG")" = "-l" ] || fail "dfu-no-device: dfu-util called with '$(cat "$FAKE_DFU_LOG")'"
for layout in "/0x08000000/256*002Kg" "/0x08000000/04*002Ka,252*002Kg" "/0x08000000/06*002Ka,250*002Ka" "/08000000/junk"; do
  run dfu-layout 1 env PATH="$t/dfubin:$PATH" FAKE_LAYOUT="$layout" "$hil" --dfu --port /dev/null
  says dfu-layout "hil: FAILED: DFU layout '$layout' (alt 0) is not writable from 0x08003000 exactly"
  [ "$(cat "$FAKE_DFU_LOG")" = "-l" ] || fail "dfu-layout $layout: dfu-util called with '$(cat "$FAKE_DFU_LOG")'"
done
probe_calls dfu-layout ""

if [ "$failures" -gt 0 ]; then
  echo "hil test: $failures failure(s)" >&2
  exit 1
fi
echo "hil test: scripts/hil without a board: every case passed"
