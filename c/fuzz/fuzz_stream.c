/*
 * libFuzzer target: the 11-byte and 0xAA stream decoders. Every byte fed must
 * end up in exactly one of: a decoded frame, the dropped counter, the pending
 * buffer; decoded frames must be well formed and encode back to their bytes.
 * The first input byte picks an optional filter and where to flush.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "drempower/dre_framing.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int reply_only(void *ctx, const dre_frame *f)
{
    dre_msg m;
    (void)ctx;
    return dre_decode_reply(f, &m) == DRE_OK;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    dre_uart11_decoder u;
    dre_aa_decoder a;
    dre_frame f;
    dre_aa_frame af;
    uint8_t enc[DRE_AA_CAN_LEN];
    size_t i, u_bytes = 0u, a_bytes = 0u, flushed_u = 0u, flushed_a = 0u;
    uint8_t mode;

    if (size == 0u) {
        return 0;
    }
    mode = data[0];
    dre_uart11_init(&u, (mode & 1u) ? reply_only : NULL, NULL);
    dre_aa_init(&a);
    for (i = 1u; i < size; i++) {
        if (dre_uart11_push(&u, data[i], &f)) {
            if (f.id > DRE_MAX_ID || f.len != 8u || dre_uart11_encode(&f, enc) != DRE_UART11_LEN ||
                memcmp(enc, data + i - 10u, DRE_UART11_LEN) != 0) {
                abort();
            }
            u_bytes += DRE_UART11_LEN;
        }
        if (dre_aa_push(&a, data[i], &af)) {
            if (af.ext > 1u || af.len > DRE_AA_MAX_DATA || (!af.ext && af.id > DRE_MAX_ID) || af.id > 0x1FFFFFFFu) {
                abort();
            }
            if (dre_aa_to_frame(&af, &f) == DRE_OK &&
                (dre_aa_encode(&f, enc) != 8u + f.len || memcmp(enc, data + i + 1u - (8u + f.len), 8u + f.len) != 0)) {
                abort();
            }
            a_bytes += 8u + af.len;
        }
        if ((mode & 2u) && data[i] == mode) {
            flushed_u += dre_uart11_flush(&u);
            flushed_a += dre_aa_flush(&a);
        }
    }
    if (u_bytes + u.dropped + u.len != size - 1u || a_bytes + a.dropped + a.len != size - 1u ||
        u.dropped < flushed_u || a.dropped < flushed_a) {
        abort();
    }
    return 0;
}
