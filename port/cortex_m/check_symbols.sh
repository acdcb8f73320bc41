#!/usr/bin/env bash
# Fails if a linked firmware ELF contains (defines or references) any heap or
# exception-runtime symbol: malloc/free/calloc/realloc (and newlib's _r
# variants), _sbrk, operator new/delete (_Znw*, _Zna*, _Zdl*, _Zda*),
# __cxa_throw, __cxa_allocate_exception.
#
#   port/cortex_m/check_symbols.sh build-m4/feedid_m4.elf [more.elf ...]
#
# Run after every firmware link (port/cortex_m/CMakeLists.txt) and by
# .ci/firmware.sh. Also reports, without failing, whether software
# double-precision arithmetic (__aeabi_d*) was linked.
set -euo pipefail
NM=${NM:-arm-none-eabi-nm}
forbidden='^(malloc|_malloc_r|free|_free_r|calloc|_calloc_r|realloc|_realloc_r|_sbrk|_sbrk_r|sbrk|__cxa_throw|__cxa_allocate_exception|_Znw.*|_Zna.*|_Zdl.*|_Zda.*)$'
status=0
for elf in "$@"; do
  if [ ! -f "$elf" ]; then echo "check_symbols: $elf: no such file" >&2; status=1; continue; fi
  # Every symbol name, defined or undefined.
  names=$("$NM" "$elf" | awk '{print $NF}' | sort -u)
  bad=$(printf '%s\n' "$names" | grep -E "$forbidden" || true)
  if [ -n "$bad" ]; then
    echo "check_symbols: FAIL: $elf contains forbidden symbols:" >&2
    printf '  %s\n' $bad >&2
    status=1
  else
    soft_double=$(printf '%s\n' "$names" | grep -cE '^__aeabi_d(add|sub|mul|div|cmp.*|2f|2iz|2uiz)$' || true)
    echo "check_symbols: OK: $elf has no malloc, _sbrk, free, operator new/delete, __cxa_throw, __cxa_allocate_exception (soft-double helpers linked: $soft_double)"
  fi
done
exit $status
