/* Serial framings and their stream decoders (see dre_framing.h). */
#include "drempower/dre_framing.h"

#include <string.h>

/* Discard the first held byte and count it. */
static void drop_first(uint8_t *buf, uint8_t *len, uint32_t *dropped)
{
    (*len)--;
    memmove(buf, buf + 1, *len);
    (*dropped)++;
}

/* ------------------------------------------------------------ 11-byte */

size_t dre_uart11_encode(const dre_frame *f, uint8_t out[DRE_UART11_LEN])
{
    if (f->id > DRE_MAX_ID || f->len != 8u) {
        return 0u;
    }
    out[0] = 0x08u;
    out[1] = (uint8_t)(f->id >> 8);
    out[2] = (uint8_t)(f->id & 0xFFu);
    memcpy(out + 3, f->data, 8u);
    return DRE_UART11_LEN;
}

void dre_uart11_init(dre_uart11_decoder *d, dre_accept_fn accept, void *accept_ctx)
{
    memset(d, 0, sizeof *d);
    d->accept = accept;
    d->accept_ctx = accept_ctx;
}

int dre_uart11_push(dre_uart11_decoder *d, uint8_t byte, dre_frame *out)
{
    dre_frame f;

    d->buf[d->len++] = byte;
    for (;;) {
        if (d->len == 0u) {
            return 0;
        }
        if (d->buf[0] != 0x08u) {
            drop_first(d->buf, &d->len, &d->dropped);
            continue;
        }
        if (d->len < 2u) {
            return 0;
        }
        if (d->buf[1] > 0x07u) {
            drop_first(d->buf, &d->len, &d->dropped);
            continue;
        }
        if (d->len < DRE_UART11_LEN) {
            return 0;
        }
        f.id = (uint16_t)(((unsigned)d->buf[1] << 8) | d->buf[2]);
        f.len = 8u;
        memcpy(f.data, d->buf + 3, 8u);
        if (d->accept != NULL && !d->accept(d->accept_ctx, &f)) {
            drop_first(d->buf, &d->len, &d->dropped);
            continue;
        }
        d->len = 0u;
        d->frames++;
        *out = f;
        return 1;
    }
}

size_t dre_uart11_feed(dre_uart11_decoder *d, const uint8_t *bytes, size_t n, dre_frame_cb cb, void *ctx)
{
    size_t i, count = 0u;
    dre_frame f;

    for (i = 0u; i < n; i++) {
        if (dre_uart11_push(d, bytes[i], &f)) {
            cb(ctx, &f);
            count++;
        }
    }
    return count;
}

size_t dre_uart11_flush(dre_uart11_decoder *d)
{
    size_t n = d->len;
    d->dropped += d->len;
    d->len = 0u;
    return n;
}

/* ------------------------------------------------------------ 0xAA */

static int fd_length_ok(uint8_t n)
{
    return n <= 8u || n == 12u || n == 16u || n == 20u || n == 24u || n == 32u || n == 48u || n == 64u;
}

/* 0 = cannot be a header; -1 = plausible so far, need more bytes; else the total frame length. */
static int aa_header(const uint8_t *b, unsigned avail)
{
    if (b[0] != DRE_AA_HEADER) {
        return 0;
    }
    if (avail >= 2u && b[1] > 1u) {
        return 0;
    }
    if (avail >= 3u && b[2] != DRE_AA_DATA && b[2] != DRE_AA_REMOTE && b[2] != DRE_AA_FD && b[2] != DRE_AA_FD_BRS) {
        return 0;
    }
    if (avail < 4u) {
        return -1;
    }
    if (b[2] <= DRE_AA_REMOTE ? b[3] > 8u : !fd_length_ok(b[3])) {
        return 0;
    }
    if (b[1] == 0u) {
        /* standard id: bytes 4-5 zero, byte 6 at most 0x07 */
        if ((avail > 4u && b[4] != 0u) || (avail > 5u && b[5] != 0u) || (avail > 6u && b[6] > 0x07u)) {
            return 0;
        }
    } else if (avail > 4u && b[4] > 0x1Fu) {
        return 0; /* 29-bit id */
    }
    return avail < 8u ? -1 : 8 + (int)b[3];
}

size_t dre_aa_encode(const dre_frame *f, uint8_t out[DRE_AA_CAN_LEN])
{
    if (f->id > DRE_MAX_ID || f->len > 8u) {
        return 0u;
    }
    out[0] = DRE_AA_HEADER;
    out[1] = 0u;
    out[2] = DRE_AA_DATA;
    out[3] = f->len;
    out[4] = 0u;
    out[5] = 0u;
    out[6] = (uint8_t)(f->id >> 8);
    out[7] = (uint8_t)(f->id & 0xFFu);
    memcpy(out + 8, f->data, f->len);
    return 8u + (size_t)f->len;
}

void dre_aa_init(dre_aa_decoder *d)
{
    memset(d, 0, sizeof *d);
}

int dre_aa_push(dre_aa_decoder *d, uint8_t byte, dre_aa_frame *out)
{
    const uint8_t *b = d->buf;
    int total;

    d->buf[d->len++] = byte;
    for (;;) {
        if (d->len == 0u) {
            return 0;
        }
        total = aa_header(b, d->len);
        if (total == 0) {
            drop_first(d->buf, &d->len, &d->dropped);
            continue;
        }
        if (total < 0 || d->len < (unsigned)total) {
            return 0;
        }
        out->id = ((uint32_t)b[4] << 24) | ((uint32_t)b[5] << 16) | ((uint32_t)b[6] << 8) | (uint32_t)b[7];
        out->ext = b[1];
        out->flag = b[2];
        out->len = b[3];
        memcpy(out->data, b + 8, b[3]);
        if (b[2] == DRE_AA_FD || b[2] == DRE_AA_FD_BRS) {
            d->fd_frames++;
        }
        d->frames++;
        d->len = 0u;
        return 1;
    }
}

dre_status dre_aa_to_frame(const dre_aa_frame *in, dre_frame *out)
{
    if (in->ext != 0u || in->flag != DRE_AA_DATA || in->len > 8u || in->id > DRE_MAX_ID) {
        return DRE_E_PROTOCOL;
    }
    out->id = (uint16_t)in->id;
    out->len = in->len;
    memset(out->data, 0, sizeof out->data);
    memcpy(out->data, in->data, in->len);
    return DRE_OK;
}

size_t dre_aa_feed(dre_aa_decoder *d, const uint8_t *bytes, size_t n, dre_frame_cb cb, void *ctx)
{
    size_t i, count = 0u;
    dre_aa_frame af;
    dre_frame f;

    for (i = 0u; i < n; i++) {
        if (dre_aa_push(d, bytes[i], &af) && dre_aa_to_frame(&af, &f) == DRE_OK) {
            cb(ctx, &f);
            count++;
        }
    }
    return count;
}

size_t dre_aa_flush(dre_aa_decoder *d)
{
    size_t n = d->len;
    d->dropped += d->len;
    d->len = 0u;
    return n;
}
