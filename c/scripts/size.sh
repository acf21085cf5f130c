#!/usr/bin/env bash
# Cross-compile the C library for a Cortex-M4 and print code (text) and RAM
# (data + bss) per module, as arm-none-eabi-size reports them for each object,
# with the client's modules (bus .. batch) summed as "client"; then compile it
# for an 8-bit AVR, whose int is 16 bits, with -Wconversion.
# Installs gcc-arm-none-eabi and gcc-avr with apt-get when they are missing.
# Fails when the codec grows beyond 4 KiB of code or gets RAM of its own.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

if ! command -v arm-none-eabi-gcc >/dev/null 2>&1 ||
    ! echo '#include <string.h>' | arm-none-eabi-gcc -E -x c - >/dev/null 2>&1; then
    echo "installing gcc-arm-none-eabi"
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y gcc-arm-none-eabi libnewlib-arm-none-eabi
fi
if ! command -v avr-gcc >/dev/null 2>&1; then
    echo "installing gcc-avr"
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends gcc-avr avr-libc
fi

out=build/c-size
mkdir -p "$out/soft" "$out/hard"
common=(-std=c99 -Os -mcpu=cortex-m4 -mthumb -ffunction-sections -fdata-sections
        -Wall -Wextra -Wpedantic -Werror -Ic/include)
modules=(codec params errors framing bus moves motor verified wait batch)
client_modules=" bus moves motor verified wait batch "

for m in "${modules[@]}"; do
    arm-none-eabi-gcc "${common[@]}" -c "c/src/dre_$m.c" -o "$out/soft/dre_$m.o"
    arm-none-eabi-gcc "${common[@]}" -mfloat-abi=hard -mfpu=fpv4-sp-d16 -c "c/src/dre_$m.c" -o "$out/hard/dre_$m.o"
done

echo "$(arm-none-eabi-gcc --version | head -n 1)"
echo "flags: ${common[*]:0:4} (soft-float ABI; 'M4F' column: -mfloat-abi=hard -mfpu=fpv4-sp-d16)"
echo
printf '%-10s %8s %8s %6s %6s %8s\n' module text "M4F" data bss RAM
total_text=0 total_hard=0 total_ram=0 codec_text=0 codec_ram=0
client_text=0 client_hard=0 client_ram=0
for m in "${modules[@]}"; do
    read -r text data bss _ < <(arm-none-eabi-size "$out/soft/dre_$m.o" | tail -n 1)
    read -r hard _ < <(arm-none-eabi-size "$out/hard/dre_$m.o" | tail -n 1)
    ram=$((data + bss))
    printf '%-10s %8d %8d %6d %6d %8d\n' "$m" "$text" "$hard" "$data" "$bss" "$ram"
    total_text=$((total_text + text)) total_hard=$((total_hard + hard)) total_ram=$((total_ram + ram))
    if [ "$m" = codec ]; then
        codec_text=$text codec_ram=$ram
    fi
    if [[ "$client_modules" == *" $m "* ]]; then
        client_text=$((client_text + text)) client_hard=$((client_hard + hard)) client_ram=$((client_ram + ram))
    fi
done
printf '%-10s %8d %8d %6s %6s %8d\n' "(client)" "$client_text" "$client_hard" "" "" "$client_ram"
printf '%-10s %8d %8d %6s %6s %8d\n' total "$total_text" "$total_hard" "" "" "$total_ram"

# The codec linked on its own: encode and both decoders with the libgcc float
# helpers and memcpy/memset they pull in (what a firmware pays for it).
cat > "$out/codec_only.c" <<'FW'
#include "drempower/dre_codec.h"
void entry(void);
volatile dre_frame io_frame;
volatile int io_status;
void entry(void)
{
    dre_msg m;
    dre_frame f = io_frame;
    io_status = dre_decode_command(&f, &m) + dre_decode_reply(&f, &m) + dre_encode(&m, &f, 0);
    io_frame = f;
    for (;;) {
    }
}
FW
link=(-nostartfiles -Wl,--gc-sections -Wl,-e,entry "$out/codec_only.c" c/src/dre_codec.c -lc_nano -lgcc)
arm-none-eabi-gcc "${common[@]}" "${link[@]}" -o "$out/codec_soft.elf"
arm-none-eabi-gcc "${common[@]}" -mfloat-abi=hard -mfpu=fpv4-sp-d16 "${link[@]}" -o "$out/codec_hard.elf"
read -r linked_soft _ < <(arm-none-eabi-size "$out/codec_soft.elf" | tail -n 1)
read -r linked_hard _ < <(arm-none-eabi-size "$out/codec_hard.elf" | tail -n 1)
echo
echo "codec linked alone (encode + both decoders + libgcc/libc helpers): $linked_soft bytes, M4F $linked_hard bytes"
echo "All state lives in caller-owned structs; params is the name table (const, in flash)."

# The same layering check as the ctest (no call cycle between the modules), on the Cortex-M objects.
python3 c/scripts/layers.py arm-none-eabi-nm "$out"/soft/*.o >/dev/null
echo "layers: no call cycle between the modules (Cortex-M4 objects)"

# 16-bit int: every module must compile cleanly, conversions included.
mkdir -p "$out/avr"
for m in "${modules[@]}"; do
    avr-gcc -std=c99 -Os -mmcu=atmega2560 -Wall -Wextra -Wpedantic -Werror -Wconversion -Wsign-conversion \
        -Ic/include -c "c/src/dre_$m.c" -o "$out/avr/dre_$m.o"
done
echo "16-bit int: all modules compile for ATmega2560 with -Wconversion -Wsign-conversion -Werror"

if [ "$codec_text" -gt 4096 ] || [ "$codec_ram" -ne 0 ]; then
    echo "codec: $codec_text bytes of code and $codec_ram of RAM; the budget is 4096 and 0" >&2
    exit 1
fi
