#!/usr/bin/env bash
# Fails if the bare-metal image links heap or exception machinery; prints its static RAM.
set -euo pipefail
elf=${1:?usage: check-baremetal.sh IMAGE.elf}
forbidden='^(malloc|free|calloc|realloc|_malloc_r|_free_r|_Znwj|_Znaj|_Znwm|_Znam|_ZdlPv|_ZdaPv|_ZdlPvj|__cxa_allocate_exception|__cxa_throw|__cxa_begin_catch|__gxx_personality_v0|_Unwind_Resume|__cxa_pure_virtual_heap)$'
found=$(arm-none-eabi-nm --defined-only -g "$elf" | awk '{print $3}' | grep -E "$forbidden" || true)
undef=$(arm-none-eabi-nm -u "$elf" | awk '{print $2}' | grep -E "$forbidden" || true)
if [ -n "$found$undef" ]; then
  echo "check-baremetal: FORBIDDEN symbols in $elf:"; echo "$found $undef"; exit 1
fi
arm-none-eabi-size -A "$elf" | awk '
  $1==".data"{d=$2} $1==".bss"{b=$2} $1==".text"{t=$2}
  END{printf "check-baremetal: no malloc/free/new/delete/exception symbols; .text %d B, static RAM .data+.bss = %d B (%.1f KiB)\n", t, d+b, (d+b)/1024}'
