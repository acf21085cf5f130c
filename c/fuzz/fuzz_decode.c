/*
 * libFuzzer target: the frame decoders, the encoder on what they accept,
 * preset interpretation and error-word formatting.
 * Input: id (2 bytes LE), length byte, then up to 8 data bytes.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "drempower/dre_codec.h"
#include "drempower/dre_errors.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Whatever decodes must encode (unless a NaN/inf came off the wire) and survive a second round trip. */
static void round_trip(const dre_frame *f, int host)
{
    dre_msg m, m2, typed;
    dre_frame g, h;
    uint8_t kind;

    if ((host ? dre_decode_command(f, &m) : dre_decode_reply(f, &m)) != DRE_OK) {
        return;
    }
    if (m.type == DRE_MSG_PRESET) {
        for (kind = DRE_START_T; kind <= DRE_START_D; kind++) {
            dre_status st = dre_preset_as_kind(&m, kind, &typed);
            if (st == DRE_OK && dre_encode(&typed, &g, NULL) == DRE_OK && memcmp(g.data, f->data, 8u) != 0) {
                abort(); /* a typed preset must encode back to the same bytes */
            }
        }
    }
    if (dre_encode(&m, &g, NULL) != DRE_OK) {
        return;
    }
    if (g.id != f->id || (host ? dre_decode_command(&g, &m2) : dre_decode_reply(&g, &m2)) != DRE_OK ||
        dre_encode(&m2, &h, NULL) != DRE_OK || memcmp(g.data, h.data, 8u) != 0) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    dre_frame f;
    char text[640];
    uint32_t word;
    unsigned i;

    if (size < 3u) {
        return 0;
    }
    memset(&f, 0, sizeof f);
    f.id = (uint16_t)(data[0] | ((unsigned)data[1] << 8));
    f.len = (uint8_t)(data[2] % 10u == 9u ? 8u : data[2] % 10u); /* mostly 8, sometimes other lengths */
    memcpy(f.data, data + 3, size - 3u < 8u ? size - 3u : 8u);
    round_trip(&f, 1);
    round_trip(&f, 0);

    word = (uint32_t)f.data[0] | ((uint32_t)f.data[1] << 8) | ((uint32_t)f.data[2] << 16) |
           ((uint32_t)f.data[3] << 24);
    for (i = 0u; i < DRE_ERROR_WORD_COUNT; i++) {
        size_t cap = (size_t)(data[2] % 64u) * 10u + 1u;
        size_t n = dre_error_format(&dre_error_words[i], word, text, cap);
        if (strlen(text) != (n < cap ? n : cap - 1u)) {
            abort();
        }
    }
    return 0;
}
