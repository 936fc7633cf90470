#!/usr/bin/env bash
# Cargo runner for the QEMU smoke run (`cargo qemu`): netduinoplus2 (STM32F405) with
# instruction counting, semihosting for the verdict and the exit code, defmt frames on
# stdout decoded by defmt-print when it is installed, telemetry (USART1) to a file.
set -uo pipefail
elf="$1"
telemetry="${QEMU_TELEMETRY:-$(dirname "$elf")/telemetry.bin}"
qemu=(timeout "${QEMU_TIMEOUT:-60}" qemu-system-arm -machine netduinoplus2 -nographic -monitor none
      -semihosting-config enable=on,target=native -icount shift=0,sleep=off
      -serial "file:$telemetry" -kernel "$elf")
if command -v defmt-print >/dev/null 2>&1; then
  "${qemu[@]}" | defmt-print -e "$elf"
  code=${PIPESTATUS[0]}
else
  echo "defmt-print not installed: defmt log not decoded (cargo install defmt-print)" >&2
  "${qemu[@]}" > /dev/null
  code=$?
fi
echo "telemetry frames written to $telemetry" >&2
exit "$code"
