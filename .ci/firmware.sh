#!/usr/bin/env bash
# The whole firmware check (docs/firmware.md):
#   1. install what is missing (arm-none-eabi toolchain with newlib and
#      libstdc++, qemu-system-arm; host g++/cmake/nlohmann-json via .ci/setup),
#   2. cross-build the Cortex-M4F firmware into build-m4/,
#   3. fail if any ELF contains malloc, _sbrk, free, operator new/delete,
#      __cxa_throw or __cxa_allocate_exception (arm-none-eabi-nm),
#   4. run it on QEMU's mps2-an386 exactly as the README says, and again
#      under -icount shift=0 for instruction counts, then the friction-health
#      tracking run (feedid_monitor_m4.elf); each must print PASS,
#   5. print the footprint: flash and RAM of the core, sizeof, per-sample and
#      solve cost.
# Takes about a minute on a warm machine. Exit 0 only if every step passed.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
build=${FEEDID_M4_BUILD:-build-m4}
qemu_timeout=${FEEDID_QEMU_TIMEOUT:-180}

# --- 1. packages ----------------------------------------------------------------
[ -f .ci/setup ] && bash .ci/setup
pkgs=(gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib qemu-system-arm)
missing=()
for p in "${pkgs[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -ne 0 ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "firmware: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

passed=0
failed=0
verdict() {  # name status
  if [ "$2" -eq 0 ]; then passed=$((passed + 1)); echo "firmware: $1: ok"
  else failed=$((failed + 1)); echo "firmware: $1: FAILED"; fi
}
finish() {
  echo "firmware check took $(( $(date +%s) - start )) s"
  echo "firmware: $passed passed, $failed failed"
  [ "$failed" -eq 0 ]
}

# --- 2. cross build ----------------------------------------------------------------
logs="$build/logs"
mkdir -p "$logs"
if cmake -S . -B "$build" -DCMAKE_TOOLCHAIN_FILE=port/cortex_m/toolchain.cmake -DCMAKE_BUILD_TYPE=Release >"$logs/configure.log" 2>&1 &&
   cmake --build "$build" -j2 2>&1 | tee "$logs/build.log" | grep -E 'error|warning|Memory region|FLASH:|RAM:|gen_trace: (double|float) final|check_symbols' ; [ "${PIPESTATUS[0]}" -eq 0 ]; then
  verdict "cross build (arm-none-eabi-g++ $(arm-none-eabi-g++ -dumpversion), Cortex-M4F hard float)" 0
else
  cat "$logs/configure.log" "$logs/build.log" 2>/dev/null | tail -40
  verdict "cross build" 1
  finish
  exit 1
fi
elfs=("$build/feedid_m4.elf" "$build/feedid_core_m4.elf" "$build/feedid_baseline_m4.elf" "$build/feedid_monitor_m4.elf")

# --- 3. no heap, no exceptions -------------------------------------------------------
rc=0
bash port/cortex_m/check_symbols.sh "${elfs[@]}" || rc=$?
verdict "symbol check (arm-none-eabi-nm: no malloc/_sbrk/free/new/delete/__cxa_throw/__cxa_allocate_exception)" $rc

# The servo ISR as compiled: straight-line code, no call, no interrupt masking.
# grep -q reads from a here-string, not a pipe: an early exit must not SIGPIPE a writer.
isr=$(arm-none-eabi-objdump -d "$build/feedid_m4.elf" | awk '/<SysTick_Handler>:/,/^$/')
isr_insns=$(printf '%s\n' "$isr" | grep -E '^ +[0-9a-f]+:' | grep -cv '\.word' || true)
if [ "$isr_insns" -gt 0 ] && ! grep -qE $'\t(cpsid|bl|blx)\b' <<<"$isr"; then
  verdict "servo ISR (SysTick_Handler): $isr_insns instructions, no call, no cpsid (never locks)" 0
else
  printf '%s\n' "$isr"
  verdict "servo ISR (SysTick_Handler) must not call or mask interrupts" 1
fi

# --- 4. emulated runs --------------------------------------------------------------
# The README's command. The firmware writes through semihosting, which QEMU
# prints on stderr; a run passes only with exit status 0 and a PASS line.
run_qemu() {  # elf log-file extra-args...
  local elf=$1 log=$2 rc=0; shift 2
  timeout "$qemu_timeout" qemu-system-arm -M mps2-an386 -nographic -semihosting "$@" \
    -kernel "$elf" >"$log" 2>&1 </dev/null || rc=$?
  if [ $rc -eq 124 ]; then echo "firmware: QEMU timed out after ${qemu_timeout} s" >>"$log"; fi
  grep -q '^PASS' "$log" && [ $rc -eq 0 ]
}
echo "--- qemu-system-arm -M mps2-an386 -nographic -semihosting -kernel $build/feedid_m4.elf"
rc=0
run_qemu "$build/feedid_m4.elf" "$build/qemu.log" || rc=$?
cat "$build/qemu.log"
verdict "emulated Cortex-M4 run (PASS line, exit status 0)" $rc

echo "--- the same under -icount shift=0,sleep=off (1 instruction = 1 ns of virtual time)"
rc=0
run_qemu "$build/feedid_m4.elf" "$build/qemu-icount.log" -icount shift=0,sleep=off || rc=$?
grep -E '^(servo|cost|  push|  solve|  hand-off|  feedforward|stack|timed|PASS|FAIL)' "$build/qemu-icount.log" || cat "$build/qemu-icount.log"
verdict "emulated run with instruction counting (PASS line, exit status 0)" $rc

echo "--- friction-health tracking: qemu-system-arm ... -icount shift=0,sleep=off -kernel $build/feedid_monitor_m4.elf"
rc=0
run_qemu "$build/feedid_monitor_m4.elf" "$build/qemu-monitor.log" -icount shift=0,sleep=off || rc=$?
cat "$build/qemu-monitor.log"
verdict "emulated tracking run: a Coulomb step alarmed within 60 s, as on the host (PASS line, exit status 0)" $rc

# --- 5. footprint ---------------------------------------------------------------------
# Flash = vector table + code + read-only data + .data load image; RAM = .data
# + .bss (the 16 KB .stack section is listed apart). The core's share is the
# core-only probe minus the start-up-only baseline.
section_sum() {  # elf section...
  local elf=$1; shift
  arm-none-eabi-size -A "$elf" | awk -v want=" $* " 'index(want, " " $1 " ") {s += $2} END {print s + 0}'
}
echo "--- footprint (arm-none-eabi-size -A; Release, -O2)"
arm-none-eabi-size "${elfs[@]}"
for e in "${elfs[@]}"; do
  printf '%-28s flash %7d B  RAM %6d B  + stack %d B\n' "$(basename "$e")" \
    "$(section_sum "$e" .isr_vector .text .ARM.exidx .data)" "$(section_sum "$e" .data .bss)" \
    "$(section_sum "$e" .stack)"
done
core_flash=$(( $(section_sum "${elfs[1]}" .isr_vector .text .ARM.exidx .data) - $(section_sum "${elfs[2]}" .isr_vector .text .ARM.exidx .data) ))
core_ram=$(( $(section_sum "${elfs[1]}" .data .bss) - $(section_sum "${elfs[2]}" .data .bss) ))
echo "core (Estimator<float,32,16>: init, push, solve bands; paper method not built): flash $core_flash B, static RAM $core_ram B"
echo "largest stack frames of the core (-fstack-usage, bytes):"
# awk reads all of sort's output and prints the first five itself: a `head`
# here closes the pipe early and, under pipefail, sort's SIGPIPE fails CI.
sort -t$'\t' -k2 -n -r "$build"/port/cortex_m/CMakeFiles/feedid_core_m4.dir/core_only.cpp.su 2>/dev/null |
  awk -F'\t' 'NR <= 5 {f = $1; sub(/^[^:]*:[0-9]+:[0-9]+:/, "", f); sub(/ \[with.*/, "", f); printf "  %6d  %s\n", $2, f}' || true
grep -E '^sizeof|^  push|^  solve|^  hand-off|^stack' "$build/qemu-icount.log" || true

# The figures the core is budgeted by (issue 34), on one line for tools:
# push_mean = the timed loop over the trace (incl. reading the sample),
# push_max = the costliest single push() of either run (identification and
# tracking), solve = the costlier of the two bands solves, tracker_close_max =
# the costliest HealthTracker::close_epoch(). Each is "= N instructions" of
# its line under -icount shift=0, rounded to the instruction.
cost_of() {  # log-file line-prefix
  awk -v want="$2" 'index($0, want) == 1 { for (i = 1; i < NF; i++) if ($i == "=") v = $(i + 1) } END { printf "%d", v + 0.5 }' "$1"
}
max_of() { if [ "$1" -gt "$2" ]; then echo "$1"; else echo "$2"; fi; }
push_mean=$(cost_of "$build/qemu-icount.log" "  push() mean per sample, loop over the trace")
push_max=$(max_of "$(cost_of "$build/qemu-icount.log" "  push() max:")" "$(cost_of "$build/qemu-monitor.log" "  HealthTracker push() max:")")
solve_max=$(max_of "$(cost_of "$build/qemu-icount.log" "  solve() mid-stream")" "$(cost_of "$build/qemu-icount.log" "  solve() final")")
close_max=$(cost_of "$build/qemu-monitor.log" "  close_epoch() max")
echo "m4 cost: push_mean=$push_mean push_max=$push_max solve=$solve_max tracker_close_max=$close_max instructions"

finish
