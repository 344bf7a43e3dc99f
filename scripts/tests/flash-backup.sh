#!/usr/bin/env bash
# scripts/flash-backup without a board: its argument handling, its refusals, and what it does
# with what OpenOCD answers, against a stand-in `openocd` (OPENOCD=...) that logs the commands
# it was given and acts as OpenOCD 0.12 does in each case (no probe: "Error: open failed" and
# exit 1; `flash read_bank 0 NAME 0 N`: writes NAME in its working directory). Checked: exit
# codes and messages, that FILE is created only by a complete backup of 524,288 bytes, that an
# existing FILE (or symlink) is never touched and OpenOCD not even started, that no temporary
# file is left behind, and the exact OpenOCD commands of a backup and a restore.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
fb="$root/scripts/flash-backup"
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
failures=0
fail() { echo "flash-backup test: FAILED: $*" >&2; failures=$((failures + 1)); }

# The stand-in: FAKE_MODE = noprobe | short | full | error | race.
cat >"$t/openocd" <<'FAKE'
#!/usr/bin/env bash
printf '%s\n' "$@" >>"$FAKE_LOG"
# race: another program creates the backup's FILE while OpenOCD reads.
[ "$FAKE_MODE" = race ] && echo "other" >"$FAKE_RACE_FILE"
case "$FAKE_MODE" in
  noprobe) echo "Error: open failed" >&2; exit 1 ;;
  error) echo "Error: stm32x device protected" >&2; exit 1 ;;
esac
for a in "$@"; do
  if [[ "$a" =~ ^flash\ read_bank\ 0\ ([^ ]+)\ 0\ ([0-9]+)$ ]]; then
    name=${BASH_REMATCH[1]} n=${BASH_REMATCH[2]}
    [ "$FAKE_MODE" = short ] && n=1000
    # A vector table (SP 0x20005000, reset 0x08000101), then a pattern.
    { printf '\x00\x50\x00\x20\x01\x01\x00\x08'; head -c $((n - 8)) /dev/zero | tr '\0' '\252'; } >"$name"
  fi
  [[ "$a" =~ ^verify_image ]] && echo "verified 524288 bytes in 1.0s (512 KiB/s)"
done
exit 0
FAKE
chmod +x "$t/openocd"
export FAKE_LOG="$t/openocd.calls"

run() { # run EXPECTED_RC NAME ARGS...: runs flash-backup, keeps its output in $out
  local want=$1 name=$2 rc=0
  shift 2
  out=$("$fb" "$@" 2>&1) || rc=$?
  [ "$rc" = "$want" ] || fail "$name: exit $rc, not $want: $out"
}
calls() { [ -f "$FAKE_LOG" ] && cat "$FAKE_LOG"; }
leftovers() { find "$t/d" -name '.flash-backup.*' | grep -q . && fail "$1: a temporary file was left"; }

mkdir "$t/d"
export OPENOCD="$t/openocd" FAKE_MODE=full

# Usage.
run 2 "no arguments"
run 2 "one argument" backup
run 2 "three arguments" backup "$t/d/a.bin" extra
run 2 "unknown command" save "$t/d/a.bin"
run 2 "empty file name" backup ""
[ -e "$t/d/a.bin" ] && fail "usage errors created a file"

# Refusals before OpenOCD starts: an existing FILE, a symlink (even dangling), no directory.
echo "precious" >"$t/d/exists.bin"; before=$(sha256sum <"$t/d/exists.bin")
rm -f "$FAKE_LOG"
run 2 "existing FILE" backup "$t/d/exists.bin"
grep -q "refusing to overwrite" <<<"$out" || fail "existing FILE: no refusal message: $out"
[ "$(sha256sum <"$t/d/exists.bin")" = "$before" ] || fail "existing FILE was changed"
ln -s "$t/d/nowhere.bin" "$t/d/link.bin"
run 2 "dangling symlink" backup "$t/d/link.bin"
[ -e "$t/d/nowhere.bin" ] && fail "the symlink's target was created"
run 2 "missing directory" backup "$t/d/no/such/dir.bin"
[ -z "$(calls)" ] || fail "OpenOCD was started for a refused backup: $(calls)"

# No OpenOCD, or no probe: "not run: no probe attached", exit 3, no FILE.
OPENOCD="$t/not-installed" run 3 "openocd missing" backup "$t/d/b.bin"
grep -q "not run: no probe attached" <<<"$out" || fail "openocd missing: $out"
FAKE_MODE=noprobe run 3 "no probe" backup "$t/d/b.bin"
grep -q "not run: no probe attached" <<<"$out" || fail "no probe: $out"
[ -e "$t/d/b.bin" ] && fail "a failed backup created FILE"
leftovers "no probe"

# OpenOCD fails otherwise, or reads short: exit 1, no FILE.
FAKE_MODE=error run 1 "OpenOCD error" backup "$t/d/c.bin"
grep -q "stm32x device protected" <<<"$out" || fail "OpenOCD error: its log not shown: $out"
FAKE_MODE=short run 1 "short read" backup "$t/d/c.bin"
grep -q "read 1000 bytes, not 524288" <<<"$out" || fail "short read: $out"
[ -e "$t/d/c.bin" ] && fail "a short read created FILE"
leftovers "short read"

# FILE created by someone else while OpenOCD ran: kept as it is, the backup fails.
FAKE_MODE=race FAKE_RACE_FILE="$t/d/raced.bin" run 1 "FILE appearing meanwhile" backup "$t/d/raced.bin"
[ "$(cat "$t/d/raced.bin")" = other ] || fail "FILE appearing meanwhile: it was replaced"
leftovers "FILE appearing meanwhile"

# A whole backup: FILE of 524,288 bytes, its sha256 printed, the commands OpenOCD got.
rm -f "$FAKE_LOG"
run 0 "backup" backup "$t/d/full.bin"
[ "$(stat -c %s "$t/d/full.bin" 2>/dev/null)" = 524288 ] || fail "backup: FILE is not 524288 bytes"
sum=$(sha256sum "$t/d/full.bin" | cut -d' ' -f1)
grep -q "sha256 $sum" <<<"$out" || fail "backup: sha256 $sum not printed: $out"
for c in init "reset halt" "flash read_bank 0 flash.bin 0 524288" "target/stm32f1x.cfg"; do
  grep -qx -- "$c" "$FAKE_LOG" || fail "backup: OpenOCD did not get '$c'"
done
leftovers "backup"
# ... and a second backup to the same name is refused, the first one intact.
run 2 "backup over a backup" backup "$t/d/full.bin"
[ "$(sha256sum "$t/d/full.bin" | cut -d' ' -f1)" = "$sum" ] || fail "the first backup was changed"

# Restore refusals: missing, wrong size, hex text (the old page's `probe-rs read` output), blank.
rm -f "$FAKE_LOG"
run 2 "restore: missing FILE" restore "$t/d/none.bin"
run 2 "restore: wrong size" restore "$t/d/exists.bin"
grep -q "not 524288" <<<"$out" || fail "restore: wrong size: $out"
{ yes "0x20005000 0x08000101" | head -c 524288; } >"$t/d/hex.txt"
run 2 "restore: hex text" restore "$t/d/hex.txt"
grep -q "does not start with a vector table" <<<"$out" || fail "restore: hex text: $out"
head -c 524288 /dev/zero | tr '\0' '\377' >"$t/d/blank.bin"
run 2 "restore: erased flash" restore "$t/d/blank.bin"
[ -z "$(calls)" ] || fail "OpenOCD was started for a refused restore: $(calls)"

# A restore: the file's sha256, erase + write at 0x08000000, then verify; the file unchanged.
run 0 "restore" restore "$t/d/full.bin"
grep -q "$sum" <<<"$out" || fail "restore: sha256 not printed: $out"
grep -qx "flash write_image erase flash.bin 0x08000000 bin" "$FAKE_LOG" || fail "restore: no write_image erase at 0x08000000: $(calls)"
grep -qx "verify_image flash.bin 0x08000000 bin" "$FAKE_LOG" || fail "restore: no verify_image: $(calls)"
[ "$(sha256sum "$t/d/full.bin" | cut -d' ' -f1)" = "$sum" ] || fail "restore changed FILE"
FAKE_MODE=error run 1 "restore: OpenOCD error" restore "$t/d/full.bin"
FAKE_MODE=noprobe run 3 "restore: no probe" restore "$t/d/full.bin"
grep -q "not run: no probe attached" <<<"$out" || fail "restore: no probe: $out"

if [ "$failures" = 0 ]; then
  echo "flash-backup test: all cases passed (usage, refusals, no probe, short read, backup, restore)"
else
  echo "flash-backup test: $failures failure(s)" >&2
  exit 1
fi
