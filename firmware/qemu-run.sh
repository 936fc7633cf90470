#!/usr/bin/env bash
# Cargo runner for the QEMU run (`cargo qemu`): netduinoplus2 (STM32F405) with
# instruction counting, semihosting for the verdict and the exit code, defmt frames on
# stdout decoded by defmt-print when it is installed, and the protocol UART (USART1) on
# QEMU's first serial port:
# - by default to a file (QEMU_TELEMETRY, default target/.../telemetry.bin);
# - QEMU_SERIAL=<chardev> instead, e.g. `unix:/tmp/fw.sock,server=on,wait=on` for a test
#   that sends commands (QEMU then waits for the client before starting the guest).
# Guest time runs ahead of the host clock (-icount sleep=off): with sleep=on QEMU raises
# the timer interrupts late in guest time and the firmware rightly counts lost periods.
set -uo pipefail
elf="$1"
telemetry="${QEMU_TELEMETRY:-$(dirname "$elf")/telemetry.bin}"
serial="${QEMU_SERIAL:-file:$telemetry}"
qemu=(timeout "${QEMU_TIMEOUT:-60}" qemu-system-arm -machine netduinoplus2 -nographic -monitor none
      -semihosting-config enable=on,target=native -icount shift=0,sleep=off
      -serial "$serial" -kernel "$elf")
if command -v defmt-print >/dev/null 2>&1; then
  "${qemu[@]}" | defmt-print -e "$elf"
  code=${PIPESTATUS[0]}
else
  echo "defmt-print not installed: defmt log not decoded (cargo install defmt-print)" >&2
  "${qemu[@]}" > /dev/null
  code=$?
fi
if [ -z "${QEMU_SERIAL:-}" ]; then
  echo "protocol frames written to $telemetry (host-sim telemetry $telemetry)" >&2
fi
exit "$code"
