/* Serial framings: encoders, stream decoders, and a differential run against the Python core's decoders. */
#include <string.h>

#include "check.h"
#include "drempower/dre_framing.h"
#include "reference.h"

/* ------------------------------------------------------------------ differential */

static void check_uart11_stream(unsigned index, const ref_stream *s)
{
    dre_uart11_decoder d;
    dre_frame f;
    unsigned i, n = 0u;

    dre_uart11_init(&d, NULL, NULL);
    for (i = 0u; i < s->nbytes; i++) {
        if (dre_uart11_push(&d, s->bytes[i], &f)) {
            const ref_frame *r = &s->frames[n < s->nframes ? n : 0u];
            CHECKF(n < s->nframes && f.id == r->id && f.len == 8u && r->len == 8u && memcmp(f.data, r->data, 8u) == 0,
                   "stream %u: frame %u differs", index, n);
            n++;
        }
    }
    CHECKF(n == s->nframes, "stream %u: %u frames, Python %u", index, n, s->nframes);
    CHECKF(d.dropped == s->dropped, "stream %u: dropped %lu, Python %lu", index, (unsigned long)d.dropped,
           (unsigned long)s->dropped);
    CHECKF(d.len == s->pending, "stream %u: pending %u, Python %u", index, (unsigned)d.len, s->pending);
    CHECKF(d.frames == s->nframes, "stream %u: frame counter", index);
}

static void check_aa_stream(unsigned index, const ref_stream *s)
{
    dre_aa_decoder d;
    dre_aa_frame f;
    unsigned i, n = 0u;

    dre_aa_init(&d);
    for (i = 0u; i < s->nbytes; i++) {
        if (dre_aa_push(&d, s->bytes[i], &f)) {
            const ref_frame *r = &s->frames[n < s->nframes ? n : 0u];
            CHECKF(n < s->nframes && f.id == r->id && f.ext == r->ext && (f.flag == DRE_AA_REMOTE) == r->remote &&
                       f.len == r->len && memcmp(f.data, r->data, f.len) == 0,
                   "stream %u: frame %u differs", index, n);
            n++;
        }
    }
    CHECKF(n == s->nframes, "stream %u: %u frames, Python %u", index, n, s->nframes);
    CHECKF(d.dropped == s->dropped, "stream %u: dropped %lu, Python %lu", index, (unsigned long)d.dropped,
           (unsigned long)s->dropped);
    CHECKF(d.len == s->pending, "stream %u: pending %u, Python %u", index, (unsigned)d.len, s->pending);
    CHECKF(d.fd_frames == s->fd_frames, "stream %u: fd frames", index);
}

static void test_against_python(void)
{
    unsigned i, frames = 0u, dropped = 0u, fd = 0u, ext = 0u;

    for (i = 0u; i < ref_stream_count; i++) {
        const ref_stream *s = &ref_streams[i];
        unsigned k;
        if (s->aa) {
            check_aa_stream(i, s);
        } else {
            check_uart11_stream(i, s);
        }
        frames += s->nframes;
        dropped += s->dropped != 0u;
        fd += s->fd_frames != 0u;
        for (k = 0u; k < s->nframes; k++) {
            ext += (unsigned)s->frames[k].ext;
        }
    }
    printf("%u reference streams: %u frames; %u streams with dropped bytes, %u with CAN-FD, %u extended frames\n",
           ref_stream_count, frames, dropped, fd, ext);
    /* the reference must exercise what it is meant to */
    CHECK(frames > 100u && dropped > 20u && fd > 5u && ext > 5u);
}

/* ------------------------------------------------------------------ 11-byte */

typedef struct {
    dre_frame frames[8];
    unsigned n;
} sink;

static void collect(void *ctx, const dre_frame *f)
{
    sink *s = (sink *)ctx;
    if (s->n < 8u) {
        s->frames[s->n] = *f;
    }
    s->n++;
}

static const dre_frame doc_frame = {0x03A, 8u, {0x00, 0x00, 0x16, 0xC3, 0xE8, 0x03, 0xF4, 0x01}};

static void test_uart11(void)
{
    uint8_t buf[32];
    dre_frame bad = doc_frame;
    dre_uart11_decoder d;
    sink s;
    static const uint8_t expect[11] = {0x08, 0x00, 0x3A, 0x00, 0x00, 0x16, 0xC3, 0xE8, 0x03, 0xF4, 0x01};

    CHECK(dre_uart11_encode(&doc_frame, buf) == 11u && memcmp(buf, expect, 11u) == 0);
    bad.id = 0x800;
    CHECK(dre_uart11_encode(&bad, buf) == 0u);
    bad = doc_frame;
    bad.len = 7u;
    CHECK(dre_uart11_encode(&bad, buf) == 0u);

    /* garbage, a header with an impossible id high byte, then two frames back to back */
    memset(&s, 0, sizeof s);
    dre_uart11_init(&d, NULL, NULL);
    {
        static const uint8_t lead[] = {0x55, 0x08, 0x08, 0x09};
        memcpy(buf, lead, sizeof lead);
        memcpy(buf + 4, expect, 11u);
        CHECK(dre_uart11_feed(&d, buf, 15u, collect, &s) == 1u);
        CHECK(dre_uart11_feed(&d, expect, 11u, collect, &s) == 1u);
    }
    CHECK(s.n == 2u && s.frames[0].id == 0x03A && memcmp(s.frames[1].data, doc_frame.data, 8u) == 0);
    CHECK(d.dropped == 4u && d.frames == 2u && d.len == 0u);

    /* a partial frame waits; flush drops it */
    CHECK(dre_uart11_feed(&d, expect, 5u, collect, &s) == 0u && d.len == 5u);
    CHECK(dre_uart11_flush(&d) == 5u && d.len == 0u && d.dropped == 9u);
}

/* Accept only frames that are valid motor replies. */
static int reply_only(void *ctx, const dre_frame *f)
{
    dre_msg m;
    (*(unsigned *)ctx)++;
    return dre_decode_reply(f, &m) == DRE_OK;
}

static void test_uart11_accept(void)
{
    /* "08 00" then a reply frame: without the filter the decoder locks onto the stray header */
    static const uint8_t stream[] = {0x08, 0x00, 0x08, 0x00, 0x3E, 0x77, 0x94, 0x00, 0x00, 0x38, 0xF0, 0xB8, 0xC2};
    dre_uart11_decoder d;
    sink s;
    unsigned calls = 0u;

    memset(&s, 0, sizeof s);
    dre_uart11_init(&d, NULL, NULL);
    CHECK(dre_uart11_feed(&d, stream, sizeof stream, collect, &s) == 1u && s.frames[0].id == 0x0008u);

    memset(&s, 0, sizeof s);
    dre_uart11_init(&d, reply_only, &calls);
    CHECK(dre_uart11_feed(&d, stream, sizeof stream, collect, &s) == 1u);
    CHECK(s.frames[0].id == 0x03E && s.frames[0].data[0] == 0x77 && s.frames[0].data[7] == 0xC2);
    CHECK(d.dropped == 2u && calls == 2u);
}

/* ------------------------------------------------------------------ 0xAA */

static void test_aa(void)
{
    static const uint8_t expect[16] = {0xAA, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x3A,
                                       0x00, 0x00, 0x16, 0xC3, 0xE8, 0x03, 0xF4, 0x01};
    /* an extended remote frame, a CAN-FD frame of 12 bytes, then the DrEmpower frame */
    static const uint8_t others[] = {0xAA, 0x01, 0x01, 0x00, 0x1F, 0xFF, 0xFF, 0xFF, 0xAA, 0x00, 0x06, 0x0C,
                                     0x00, 0x00, 0x01, 0x23, 1,    2,    3,    4,    5,    6,    7,    8,
                                     9,    10,   11,   12};
    uint8_t buf[32];
    dre_frame bad = doc_frame, f;
    dre_aa_frame af;
    dre_aa_decoder d;
    sink s;
    unsigned i, got = 0u;

    CHECK(dre_aa_encode(&doc_frame, buf) == 16u && memcmp(buf, expect, 16u) == 0);
    bad.id = 0x800;
    CHECK(dre_aa_encode(&bad, buf) == 0u);

    dre_aa_init(&d);
    for (i = 0u; i < sizeof others; i++) {
        if (dre_aa_push(&d, others[i], &af)) {
            got++;
            if (got == 1u) {
                CHECK(af.ext == 1u && af.flag == DRE_AA_REMOTE && af.id == 0x1FFFFFFFu && af.len == 0u);
                CHECK(dre_aa_to_frame(&af, &f) == DRE_E_PROTOCOL);
            } else {
                CHECK(af.flag == DRE_AA_FD_BRS && af.len == 12u && af.id == 0x123u && af.data[11] == 12u);
                CHECK(dre_aa_to_frame(&af, &f) == DRE_E_PROTOCOL);
            }
        }
    }
    CHECK(got == 2u && d.fd_frames == 1u && d.dropped == 0u);

    /* feed passes on only standard data frames; garbage before the header is dropped */
    memset(&s, 0, sizeof s);
    CHECK(dre_aa_feed(&d, others, sizeof others, collect, &s) == 0u);
    buf[0] = 0xAA;
    buf[1] = 0x02; /* impossible extended flag: this 0xAA is not a header */
    CHECK(dre_aa_feed(&d, buf, 2u, collect, &s) == 0u);
    CHECK(dre_aa_feed(&d, expect, sizeof expect, collect, &s) == 1u);
    CHECK(s.n == 1u && s.frames[0].id == 0x03A && s.frames[0].len == 8u &&
          memcmp(s.frames[0].data, doc_frame.data, 8u) == 0);
    CHECK(d.dropped == 2u && d.frames == 5u);

    CHECK(dre_aa_feed(&d, expect, 9u, collect, &s) == 0u && d.len == 9u);
    CHECK(dre_aa_flush(&d) == 9u && d.dropped == 11u && d.len == 0u);
}

int main(void)
{
    test_against_python();
    test_uart11();
    test_uart11_accept();
    test_aa();
    return check_report("test_framing");
}
