/*
 * The shared client-behaviour vectors (spec/vectors/client (JSON), as client_vectors_table.c) against
 * dre_bus on scripted time: the tick callback returns the script's millisecond, dre_bus_poll() runs at
 * every millisecond up to each step (as a main loop would), and the send callback records the frames.
 * The Python client runs the same files (python/tests/client/test_client_vectors.py).
 */
#include <math.h>
#include <string.h>

#include "check.h"
#include "client_vectors.h"
#include "drempower/dre_client.h"

#define MAX_SENT 64u
#define MAX_REQS 8u
#define MAX_WAIT 4u

typedef struct {
    uint32_t now;
    dre_frame sent[MAX_SENT];
    unsigned nsent;
    int tx_done; /* the transport's word: every frame handed over is on the wire */
} script;

enum { R_NONE, R_REQUEST, R_BATCH, R_WAIT };

typedef struct {
    uint8_t what;       /* R_* */
    dre_req handle;     /* R_REQUEST */
    dre_status status;  /* the final outcome once known, else DRE_PENDING */
    dre_msg reply;      /* R_REQUEST: the reply; R_WAIT: the final state */
    const cv_step *wait; /* R_WAIT: its step */
    dre_done done[MAX_WAIT];
} outcome;

static script sc;
static dre_bus bus;
static dre_request slots[8];
static outcome reqs[MAX_REQS];
static int failed_before;

static int on_send(void *user, const dre_frame *f)
{
    script *s = (script *)user;
    if (s->nsent < MAX_SENT) {
        s->sent[s->nsent] = *f;
    }
    s->nsent++;
    s->tx_done = 0;
    return 0;
}

static uint32_t on_tick(void *user)
{
    return ((script *)user)->now;
}

static int on_tx_done(void *user)
{
    return ((script *)user)->tx_done;
}

/* Bring every outcome up to date (a wait is polled as its caller's main loop would). */
static void service(void)
{
    unsigned i;
    for (i = 0u; i < MAX_REQS; i++) {
        outcome *o = &reqs[i];
        if (o->status != DRE_PENDING) {
            continue;
        }
        if (o->what == R_REQUEST) {
            o->status = dre_result(&bus, o->handle, &o->reply);
        } else if (o->what == R_BATCH) {
            o->status = dre_batch_status(&bus);
        } else if (o->what == R_WAIT) {
            const cv_step *w = o->wait;
            o->status = dre_positions_done(&bus, (uint8_t)w->count, &cv_nodes[w->first], o->done, w->timeout_ms);
            if (o->status != DRE_PENDING) {
                o->reply = o->done[0].state;
            }
        }
    }
}

/* Run the main loop at every millisecond after the current one up to `at`, then once at `at`. */
static void run_until(uint32_t at)
{
    while (sc.now < at) {
        sc.now++;
        dre_bus_poll(&bus);
        service();
    }
    dre_bus_poll(&bus);
    service();
}

static int status_of(dre_status st)
{
    switch (st) {
    case DRE_PENDING:
        return CV_PENDING;
    case DRE_OK:
        return CV_OK;
    case DRE_E_TIMEOUT:
        return CV_TIMEOUT;
    case DRE_E_MOVE:
        return CV_MOVE_ERROR;
    case DRE_E_FAULT:
        return CV_FAULT;
    default:
        return -1;
    }
}

static void act(const cv_vector *v, const cv_step *s)
{
    outcome *o = s->req == CV_NO_REQ ? NULL : &reqs[s->req];
    dre_motor m;
    dre_status st = DRE_OK;
    unsigned i;

    m.bus = &bus;
    m.node = s->node;
    switch (s->kind) {
    case CV_READ:
        o->what = R_REQUEST;
        st = dre_read_property(&m, s->address, s->dtype, &o->handle);
        o->status = DRE_PENDING;
        break;
    case CV_GET_STATE:
        o->what = R_REQUEST;
        st = dre_get_state(&m, &o->handle);
        o->status = DRE_PENDING;
        break;
    case CV_PRESET_START:
        o->what = R_BATCH;
        o->status = dre_preset_start(&bus, &cv_msgs[s->first], (uint8_t)s->count, &s->start);
        st = o->status == DRE_PENDING ? DRE_OK : o->status;
        break;
    case CV_SEND:
        for (i = 0u; i < s->count && st == DRE_OK; i++) {
            st = dre_send(&bus, &cv_msgs[s->first + i]);
        }
        break;
    case CV_WAIT_DONE:
        CHECKF(s->poll_ms == DRE_POLL_INTERVAL_MS && s->count <= MAX_WAIT, "%s: %s: wait_done", v->file, v->name);
        o->what = R_WAIT;
        o->wait = s;
        memset(o->done, 0, sizeof o->done);
        o->status = DRE_PENDING;
        service();
        break;
    case CV_RX:
        (void)dre_bus_feed(&bus, &cv_frames[s->first]); /* DRE_E_PROTOCOL for another host's command */
        service();
        break;
    case CV_TX_DONE:
        sc.tx_done = 1;
        dre_bus_poll(&bus);
        service();
        break;
    case CV_TX:
        CHECKF(sc.nsent == s->count, "%s: %s: at %u ms: %u frames written, %u expected", v->file, v->name,
               (unsigned)s->at, sc.nsent, (unsigned)s->count);
        for (i = 0u; i < s->count && i < sc.nsent && i < MAX_SENT; i++) {
            const dre_frame *want = &cv_frames[s->first + i], *got = &sc.sent[i];
            CHECKF(got->id == want->id && got->len == want->len && memcmp(got->data, want->data, 8u) == 0,
                   "%s: %s: at %u ms: frame %u is id %u, expected id %u", v->file, v->name, (unsigned)s->at, i,
                   (unsigned)got->id, (unsigned)want->id);
        }
        sc.nsent = 0u;
        break;
    default: /* CV_EXPECT */
        if (o != NULL) {
            int got = status_of(o->status);
            CHECKF(got == (int)s->status, "%s: %s: at %u ms: status %d (dre_status %d), expected %d", v->file,
                   v->name, (unsigned)s->at, got, (int)o->status, (int)s->status);
            if (got == CV_OK && s->has_value) {
                CHECKF(o->reply.type == DRE_MSG_PARAM_VALUE && o->reply.u.param.value.i == s->value,
                       "%s: %s: at %u ms: value", v->file, v->name, (unsigned)s->at);
            }
            if (got == CV_OK && s->has_position) {
                CHECKF(o->reply.type == DRE_MSG_STATE && fabsf(o->reply.u.state.position - s->position) < 1e-4f,
                       "%s: %s: at %u ms: position %g, expected %g", v->file, v->name, (unsigned)s->at,
                       (double)o->reply.u.state.position, (double)s->position);
            }
            if (got == CV_OK && s->has_tdone) {
                CHECKF(o->reply.u.state.trajectory_done == s->trajectory_done, "%s: %s: at %u ms: T bit", v->file,
                       v->name, (unsigned)s->at);
            }
        }
        if (s->unmatched != CV_NOT_CHECKED) {
            CHECKF(bus.stats.rx_unmatched == (uint32_t)s->unmatched, "%s: %s: at %u ms: %u unmatched, expected %d",
                   v->file, v->name, (unsigned)s->at, (unsigned)bus.stats.rx_unmatched, (int)s->unmatched);
        }
        if (s->anomalies != CV_NOT_CHECKED) {
            CHECKF(bus.stats.rx_anomalies == (uint32_t)s->anomalies, "%s: %s: at %u ms: %u anomalies, expected %d",
                   v->file, v->name, (unsigned)s->at, (unsigned)bus.stats.rx_anomalies, (int)s->anomalies);
        }
        return;
    }
    CHECKF(st == DRE_OK, "%s: %s: at %u ms: step kind %d returned %d", v->file, v->name, (unsigned)s->at,
           (int)s->kind, (int)st);
}

static void run_vector(const cv_vector *v)
{
    dre_bus_config cfg;
    unsigned i;

    memset(&sc, 0, sizeof sc);
    memset(reqs, 0, sizeof reqs);
    memset(&cfg, 0, sizeof cfg);
    cfg.send = on_send;
    cfg.tick = on_tick;
    cfg.user = &sc;
    cfg.tx_done = v->tx_confirmed ? on_tx_done : NULL;
    cfg.timeout_ms = v->timeout_ms;
    cfg.retries = v->retries;
    CHECK(dre_bus_init(&bus, &cfg, slots, 8u, NULL, 0u) == DRE_OK);
    for (i = 0u; i < v->count; i++) {
        const cv_step *s = &cv_steps[v->first + i];
        run_until(s->at);
        act(v, s);
    }
    if (check_failed != failed_before) {
        fprintf(stderr, "  ^ vector %s: %s\n", v->file, v->name);
    }
    failed_before = check_failed;
}

int main(void)
{
    unsigned i;
    CHECK(cv_nvectors >= 35u); /* every vector of spec/vectors/client (35 when written) */
    for (i = 0u; i < cv_nvectors; i++) {
        run_vector(&cv_vectors[i]);
    }
    return check_report("test_client_vectors");
}
