/**
 * @file dre_framing.h
 * @brief Serial framings of CAN frames with resynchronising stream decoders.
 *
 * - The 11-byte frame of a G-series motor's UART (and of the USB-CAN
 *   adapter's TTL->CAN mode): `08 idH idL d0..d7`.
 * - The vendor USB-CAN adapter's 0xAA frame (standard mode):
 *   `AA ext flag N id3 id2 id1 id0 data[N]`, a big-endian 4-byte id, N a byte
 *   count (0..8, or a CAN-FD length); 16 bytes for a DrEmpower frame.
 *
 * The decoders take one byte at a time (safe to call from a UART receive
 * interrupt if that is their only caller), skip garbage one byte at a time
 * until a plausible header lines up again, and count what they dropped. They
 * follow the rules of the Python core's framing module byte for byte. They
 * have no clock: after a long gap inside a frame call the flush function.
 */
#ifndef DRE_FRAMING_H
#define DRE_FRAMING_H

#include <stddef.h>
#include <stdint.h>

#include "dre_codec.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DRE_UART11_LEN 11u     /**< bytes of an 11-byte frame */
#define DRE_AA_HEADER 0xAAu    /**< first byte of an adapter frame */
#define DRE_AA_MAX_DATA 64u    /**< largest data length (CAN-FD) */
#define DRE_AA_CAN_LEN 16u     /**< bytes of an adapter frame carrying 8 data bytes */

/** Called for each completed frame by the feed functions. */
typedef void (*dre_frame_cb)(void *ctx, const dre_frame *frame);

/* ------------------------------------------------------------ 11-byte */

/**
 * Optional filter for the 11-byte decoder: the framing has no checksum, so a
 * header that lines up by chance inside data is only rejected when this
 * returns 0 (e.g. `return dre_decode_reply(f, &m) == DRE_OK;`).
 */
typedef int (*dre_accept_fn)(void *ctx, const dre_frame *frame);

/** Incremental 11-byte decoder. Treat as opaque except the counters. */
typedef struct {
    uint8_t buf[DRE_UART11_LEN];
    uint8_t len;      /**< bytes held waiting for the rest of a frame */
    uint32_t dropped; /**< bytes discarded while resynchronising */
    uint32_t frames;  /**< frames decoded */
    dre_accept_fn accept;
    void *accept_ctx;
} dre_uart11_decoder;

/** Write the 11-byte frame for `f` (standard id, 8 data bytes); returns 11, or 0 if `f` does not fit. */
size_t dre_uart11_encode(const dre_frame *f, uint8_t out[DRE_UART11_LEN]);

/** Reset `d`; `accept` may be NULL. */
void dre_uart11_init(dre_uart11_decoder *d, dre_accept_fn accept, void *accept_ctx);

/** Add one received byte; returns 1 and fills `out` when it completes a frame, else 0. */
int dre_uart11_push(dre_uart11_decoder *d, uint8_t byte, dre_frame *out);

/** Add `n` bytes, calling `cb` for each completed frame; returns the number of frames. */
size_t dre_uart11_feed(dre_uart11_decoder *d, const uint8_t *bytes, size_t n, dre_frame_cb cb, void *ctx);

/** Drop a partial frame (e.g. after a gap on the line); returns the bytes dropped. */
size_t dre_uart11_flush(dre_uart11_decoder *d);

/* ------------------------------------------------------------ 0xAA */

/** Frame flag byte of the adapter frame. */
enum { DRE_AA_DATA = 0x00, DRE_AA_REMOTE = 0x01, DRE_AA_FD = 0x02, DRE_AA_FD_BRS = 0x06 };

/** A frame as the adapter carries it (possibly extended, remote or CAN-FD). */
typedef struct {
    uint32_t id;  /**< 11-bit, or 29-bit when ext */
    uint8_t ext;  /**< 1 = extended 29-bit id */
    uint8_t flag; /**< DRE_AA_DATA, DRE_AA_REMOTE, DRE_AA_FD or DRE_AA_FD_BRS */
    uint8_t len;  /**< data bytes */
    uint8_t data[DRE_AA_MAX_DATA];
} dre_aa_frame;

/** Incremental 0xAA decoder. Treat as opaque except the counters. */
typedef struct {
    uint8_t buf[8u + DRE_AA_MAX_DATA];
    uint8_t len;        /**< bytes held waiting for the rest of a frame */
    uint32_t dropped;   /**< bytes discarded while resynchronising */
    uint32_t frames;    /**< frames decoded */
    uint32_t fd_frames; /**< of which CAN-FD (DrEmpower motors send none) */
} dre_aa_decoder;

/** Write the adapter frame for `f` (standard data frame); returns 8 + len, or 0 if `f` does not fit. */
size_t dre_aa_encode(const dre_frame *f, uint8_t out[DRE_AA_CAN_LEN]);

/** Reset `d`. */
void dre_aa_init(dre_aa_decoder *d);

/** Add one received byte; returns 1 and fills `out` when it completes a frame, else 0. */
int dre_aa_push(dre_aa_decoder *d, uint8_t byte, dre_aa_frame *out);

/**
 * Add `n` bytes, calling `cb` for each completed standard data frame of at
 * most 8 bytes (other frames are counted but not passed on); returns the
 * number of frames passed to `cb`.
 */
size_t dre_aa_feed(dre_aa_decoder *d, const uint8_t *bytes, size_t n, dre_frame_cb cb, void *ctx);

/** Drop a partial frame; returns the bytes dropped. */
size_t dre_aa_flush(dre_aa_decoder *d);

/** The CAN frame inside `in`: DRE_E_PROTOCOL unless it is a standard data frame of at most 8 bytes. */
dre_status dre_aa_to_frame(const dre_aa_frame *in, dre_frame *out);

#ifdef __cplusplus
}
#endif

#endif /* DRE_FRAMING_H */
