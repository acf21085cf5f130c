/* The client layer against a scripted fake bus: requests, timeouts, matching, batches. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "drempower/dre_client.h"

/* ------------------------------------------------------------------ fake bus */

typedef struct {
    dre_frame sent[48];
    unsigned nsent;
    int fail_from; /* sends from this index on fail; -1 = never */
    int room;      /* what tx_free reports; -1 = no tx_free callback */
    uint32_t now;
    dre_msg unmatched[8];
    unsigned nunmatched;
} fake;

static int fake_send(void *user, const dre_frame *f)
{
    fake *k = (fake *)user;
    if (k->fail_from >= 0 && k->nsent >= (unsigned)k->fail_from) {
        return -1;
    }
    if (k->nsent < 48u) {
        k->sent[k->nsent] = *f;
    }
    k->nsent++;
    return 0;
}

static uint32_t fake_tick(void *user)
{
    return ((fake *)user)->now;
}

static unsigned fake_tx_free(void *user)
{
    return (unsigned)((fake *)user)->room;
}

static void fake_unmatched(void *user, const dre_msg *m)
{
    fake *k = (fake *)user;
    if (k->nunmatched < 8u) {
        k->unmatched[k->nunmatched] = *m;
    }
    k->nunmatched++;
}

static fake bus_fake;
static dre_bus bus;
static dre_request slots[8];
static dre_frame rxq[4];

/* A bus with 4 request slots (8 with `many`), start policy `start`, and a tx_free callback when room >= 0. */
static void setup_with(uint8_t start, int room, int many)
{
    dre_bus_config cfg;
    memset(&bus_fake, 0, sizeof bus_fake);
    bus_fake.fail_from = -1;
    bus_fake.room = room;
    memset(&cfg, 0, sizeof cfg);
    cfg.send = fake_send;
    cfg.tick = fake_tick;
    cfg.user = &bus_fake;
    cfg.on_unmatched = fake_unmatched;
    cfg.tx_free = room >= 0 ? fake_tx_free : NULL;
    cfg.start = start;
    CHECK(dre_bus_init(&bus, &cfg, slots, many ? 8u : 4u, rxq, 4u) == DRE_OK);
}

static void setup(void)
{
    setup_with(DRE_START_TO_AUTO, -1, 0);
}

static dre_frame frame_of(uint16_t id, const char *hex)
{
    dre_frame f;
    unsigned i;
    memset(&f, 0, sizeof f);
    f.id = id;
    f.len = 8u;
    for (i = 0u; i < 8u; i++) {
        unsigned v;
        (void)sscanf(hex + 2u * i, "%2x", &v);
        f.data[i] = (uint8_t)v;
    }
    return f;
}

/* Was frame `i` sent with this id and these bytes? */
static int sent_is(unsigned i, uint16_t id, const char *hex)
{
    dre_frame want = frame_of(id, hex);
    return i < bus_fake.nsent && bus_fake.sent[i].id == id && bus_fake.sent[i].len == 8u &&
           memcmp(bus_fake.sent[i].data, want.data, 8u) == 0;
}

static void feed(uint16_t id, const char *hex)
{
    dre_frame f = frame_of(id, hex);
    CHECK(dre_bus_feed(&bus, &f) == DRE_OK);
}

/* ------------------------------------------------------------------ requests */

static void test_get_state(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req = 0u;
    dre_msg reply;

    setup();
    CHECK(dre_get_state(&m, &req) == DRE_OK && req != 0u);
    CHECK(bus_fake.nsent == 1u && sent_is(0u, 0x03E, "0000000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    feed((2u << 5) | 0x03u, "0000B4420000E803"); /* node 2 answers: not ours */
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    CHECK(bus_fake.nunmatched == 1u && bus_fake.unmatched[0].node == 2u);
    feed((1u << 5) | 0x07u, "0000B442F4010CFE"); /* state of node 1: 90 deg, 5 r/min, -5 Nm, T and E */
    CHECK(dre_result(&bus, req, &reply) == DRE_OK);
    CHECK(reply.type == DRE_MSG_STATE && reply.node == 1u && reply.u.state.position == 90.0f &&
          reply.u.state.speed == 5.0f && reply.u.state.torque == -5.0f && reply.u.state.trajectory_done == 1u &&
          reply.u.state.error == 1u);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_ARG); /* the slot was freed */
    CHECK(bus.stats.rx_frames == 2u && bus.stats.rx_unmatched == 1u);
}

static void test_read_matching(void)
{
    dre_motor m = {&bus, 4u};
    dre_req req = 0u;
    dre_msg reply;

    setup();
    CHECK(dre_read_param(&m, DRE_P_AXIS0_OUTPUT_SHAFT_POS_ESTIMATE, &req) == DRE_OK);
    CHECK(sent_is(0u, 0x09E, "7794000000000000"));
    feed(0x03E, "7794000038F0B8C2");             /* node 1, same address */
    feed(0x09E, "0100000000004040");             /* node 4, other address */
    feed((4u << 5) | 0x01u, "0000000000000000"); /* a state frame of node 4 (e.g. a heartbeat) */
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING && bus_fake.nunmatched == 3u);
    feed(0x09E, "7794000038F0B8C2");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK);
    CHECK(reply.type == DRE_MSG_PARAM_VALUE && reply.u.param.address == 38007u && reply.u.param.dtype == DRE_F32 &&
          reply.u.param.value.f32 == -92.46917724609375f);
    CHECK(bus.stats.rx_unmatched == 3u);
    CHECK(dre_read_property(&m, 0u, DRE_F32, &req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_ADDRESS);
}

static void test_dtype_echo(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req = 0u;
    dre_msg reply;

    setup();
    CHECK(dre_read_property(&m, 31001u, DRE_U32, &req) == DRE_OK && sent_is(0u, 0x03E, "1979030000000000"));
    feed(0x03E, "1979040001000000"); /* can_node_id as s32: an anomaly, not the answer */
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    CHECK(bus.stats.rx_anomalies == 1u && bus.stats.rx_unmatched == 1u && bus_fake.nunmatched == 1u);
    feed(0x03E, "1979030001000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.i == 1);
    feed(0x03E, "1979040001000000"); /* nobody waits: unmatched, no anomaly */
    CHECK(bus.stats.rx_anomalies == 1u && bus.stats.rx_unmatched == 2u);
}

static void test_zero_reply_grace(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req = 0u;
    dre_msg reply;

    /* no other host seen: a reply of value 0 is the answer at once */
    setup();
    CHECK(dre_read_property(&m, 30001u, DRE_U32, &req) == DRE_OK);
    feed(0x03E, "3175030000000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.i == 0 && bus.other_hosts == 0u);

    /* another host's command (an estop to motor 5): a zero reply waits for the grace */
    {
        dre_frame f = frame_of((5u << 5) | 0x08u, "0700000000000000");
        CHECK(dre_bus_feed(&bus, &f) == DRE_E_PROTOCOL && bus.other_hosts == 1u);
    }
    bus_fake.now = 1u;
    CHECK(dre_read_property(&m, 30001u, DRE_U32, &req) == DRE_OK);
    bus_fake.now = 3u;
    feed(0x03E, "3175030000000000");
    feed(0x03E, "3175030000000000"); /* a second one: the first one's grace runs on */
    bus_fake.now = 3u + DRE_ZERO_REPLY_GRACE_MS - 1u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now++;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.type == DRE_MSG_PARAM_VALUE && reply.node == 1u &&
          reply.u.param.address == 30001u && reply.u.param.dtype == DRE_U32 && reply.u.param.value.i == 0);

    /* a non-zero reply within the grace is the answer */
    CHECK(dre_read_property(&m, 30001u, DRE_U32, &req) == DRE_OK);
    feed(0x03E, "3175030000000000");
    bus_fake.now += 5u;
    feed(0x03E, "3175030040000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.i == 0x40);
    bus_fake.now += 20u;
    dre_bus_poll(&bus);
    CHECK(bus.stats.rx_unmatched == 0u);

    /* the held reply is the answer at the request's timeout when the grace runs past it */
    CHECK(dre_read_property(&m, 30001u, DRE_F32, &req) == DRE_OK);
    bus_fake.now += DRE_DEFAULT_TIMEOUT_MS - 2u;
    feed(0x03E, "3175000000000000");
    bus_fake.now += 1u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now += 1u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.f32 == 0.0f && bus.stats.timeouts == 0u);

    /* a zero reply that answers nothing is taken for another host's read request */
    setup();
    feed(0x03E, "3175030000000000");
    CHECK(bus.other_hosts == 1u && bus.stats.rx_unmatched == 1u);
}

static void test_oldest_first_and_broadcast(void)
{
    dre_motor m1 = {&bus, 1u}, all = {&bus, 0u};
    dre_req a = 0u, b = 0u, c = 0u;
    dre_msg reply;

    setup();
    CHECK(dre_read_property(&m1, 1u, DRE_F32, &a) == DRE_OK);
    bus_fake.now = 3u;
    CHECK(dre_read_property(&m1, 1u, DRE_F32, &b) == DRE_OK);
    CHECK(bus_fake.nsent == 1u); /* the second read to motor 1 waits for the first */
    feed(0x03E, "010000000000803F"); /* 1.0 V */
    CHECK(dre_result(&bus, a, &reply) == DRE_OK && reply.u.param.value.f32 == 1.0f);
    CHECK(dre_result(&bus, b, &reply) == DRE_PENDING);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && sent_is(1u, 0x03E, "0100000000000000"));
    feed(0x03E, "0100000000000040");
    CHECK(dre_result(&bus, b, &reply) == DRE_OK && reply.u.param.value.f32 == 2.0f);

    /* a read sent to node 0 is answered by whichever motor is on the bus */
    CHECK(dre_read_param(&all, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, &c) == DRE_OK);
    CHECK(sent_is(2u, 0x01E, "1979030000000000"));
    feed((9u << 5) | 0x1Eu, "1979030009000000");
    CHECK(dre_result(&bus, c, &reply) == DRE_OK && reply.node == 9u && reply.u.param.value.i == 9);
}

static void test_timeouts(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req = 0u;
    dre_msg reply;

    setup();
    bus_fake.now = 0xFFFFFFF0u; /* the tick wraps during the request */
    CHECK(dre_get_state(&m, &req) == DRE_OK);
    bus_fake.now = 0x00000021u; /* 49 ms later */
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now = 0x00000022u; /* 50 ms: the default timeout */
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_TIMEOUT);
    CHECK(bus.stats.timeouts == 1u);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_ARG);
    feed(0x021, "0000000000000000"); /* the late reply completes nothing */
    CHECK(bus_fake.nunmatched == 1u);

    /* a reply that was queued before the deadline is taken before expiring */
    CHECK(dre_get_state(&m, &req) == DRE_OK);
    {
        dre_frame f = frame_of(0x021, "0000803F00000000");
        CHECK(dre_bus_isr_push(&bus, &f) == 1);
    }
    bus_fake.now += 500u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.state.position == 1.0f);
}

static unsigned busy_slots(void);

/* cfg.retries: a request whose reply did not come goes out again, each try with the whole timeout. */
static void test_retries(void)
{
    dre_motor m1 = {&bus, 1u}, m2 = {&bus, 2u};
    dre_req req = 0u, other = 0u;
    dre_msg reply;
    dre_bus_config cfg;

    /* the first reply lost: the fast read goes out again at the timeout and its reply is the answer */
    setup();
    cfg = bus.cfg;
    cfg.retries = 2u;
    CHECK(dre_bus_init(&bus, &cfg, slots, 4u, rxq, 4u) == DRE_OK && bus.cfg.retries == 2u);
    CHECK(dre_get_state(&m1, &req) == DRE_OK && bus_fake.nsent == 1u);
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS - 1u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 1u && dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && sent_is(1u, 0x03E, "0000000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING && bus.stats.timeouts == 0u);
    bus_fake.now = 70u;
    feed(0x021, "0000B44200000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.type == DRE_MSG_STATE && reply.u.state.position == 90.0f);
    bus_fake.now = 500u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && bus.stats.timeouts == 0u && busy_slots() == 0u);

    /* every reply lost: retries + 1 sends, at 0, 50 and 100 ms, then DRE_E_TIMEOUT at 150 ms */
    setup();
    bus.cfg.retries = 2u;
    CHECK(dre_read_property(&m1, 31001u, DRE_U32, &req) == DRE_OK);
    for (bus_fake.now = 1u; bus_fake.now < 3u * DRE_DEFAULT_TIMEOUT_MS; bus_fake.now++) {
        dre_bus_poll(&bus);
        CHECK(bus_fake.nsent == 1u + bus_fake.now / DRE_DEFAULT_TIMEOUT_MS);
    }
    CHECK(sent_is(0u, 0x03E, "1979030000000000") && sent_is(1u, 0x03E, "1979030000000000") &&
          sent_is(2u, 0x03E, "1979030000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING && bus.stats.timeouts == 0u);
    bus_fake.now = 3u * DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_TIMEOUT && bus_fake.nsent == 3u && bus.stats.timeouts == 1u);
    bus_fake.now += 200u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u);

    /* a retry keeps its motor's turn: a request queued behind it waits until it is answered */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_read_property(&m1, 31001u, DRE_U32, &req) == DRE_OK);
    CHECK(dre_get_state(&m1, &other) == DRE_OK && bus_fake.nsent == 1u);
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && sent_is(1u, 0x03E, "1979030000000000"));
    feed(0x03E, "1979030001000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.i == 1);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x03E, "0000000000000000"));

    /* a retry the port cannot take waits as a queued request: sent when it can be, or expired a timeout later */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_get_state(&m1, &req) == DRE_OK && dre_get_state(&m2, &other) == DRE_OK);
    bus_fake.fail_from = 2;
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING && dre_result(&bus, other, &reply) == DRE_PENDING);
    bus_fake.now = 70u;
    bus_fake.fail_from = 3; /* room for one: motor 1's retry (the older request) */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x03E, "0000000000000000"));
    feed(0x021, "0000000000000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK);
    bus_fake.now = 2u * DRE_DEFAULT_TIMEOUT_MS - 1u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, other, &reply) == DRE_PENDING && bus.stats.timeouts == 0u);
    bus_fake.now = 2u * DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, other, &reply) == DRE_E_TIMEOUT && bus_fake.nsent == 3u && bus.stats.timeouts == 1u);

    /* dre_set_id: a silent new id is read again before it counts as free; then the write */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK && bus_fake.nsent == 2u);
    feed(0x021, "0000000000000000"); /* motor 1 answers */
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x0BE, "0000000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now = 2u * DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 5u && sent_is(3u, 0x03F, "1979030005000000") && sent_is(4u, 0x0BE, "1979030000000000"));
    /* the read of the new id has retries of its own */
    bus_fake.now = 3u * DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 6u && sent_is(5u, 0x0BE, "1979030000000000"));
    feed(0x0BE, "1979030005000000");
    CHECK(bus_fake.nsent == 7u && sent_is(6u, 0x0A8, "0100000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.node == 5u && bus.stats.timeouts == 0u);

    /* a motor that has gone: the new id is read twice, then the current id's silence ends it */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now = 2u * DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_NO_MOTOR && bus_fake.nsent == 4u && busy_slots() == 0u);
}

/* The interrupt queues a reply while dre_bus_poll reads the tick, and the tick passes the deadline then. */
static uint32_t racing_tick(void *user)
{
    fake *k = (fake *)user;
    if (k->now == 19u) {
        dre_frame reply = frame_of(0x021, "0000000000000000");
        CHECK(dre_bus_isr_push(&bus, &reply) == 1);
        k->now = 20u;
    }
    return k->now;
}

static void test_poll_reads_tick_first(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req = 0u;
    dre_msg reply;

    setup();
    bus.cfg.timeout_ms = 20u;
    bus.cfg.tick = racing_tick;
    CHECK(dre_get_state(&m, &req) == DRE_OK); /* sent at 0 ms */
    bus_fake.now = 19u;
    dre_bus_poll(&bus); /* the reply arrived at 19 ms, before the 20 ms deadline */
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.node == 1u);
    CHECK(bus.stats.timeouts == 0u && bus.rx_head == bus.rx_tail);
}

static void test_slots_and_send_failure(void)
{
    dre_motor m[5] = {{&bus, 1u}, {&bus, 2u}, {&bus, 3u}, {&bus, 4u}, {&bus, 5u}};
    dre_req reqs[5], old;
    dre_msg reply;
    unsigned i;

    setup();
    for (i = 0u; i < 4u; i++) {
        CHECK(dre_get_state(&m[i], &reqs[i]) == DRE_OK);
    }
    CHECK(dre_get_state(&m[4], &reqs[4]) == DRE_E_BUSY && bus_fake.nsent == 4u);
    dre_cancel(&bus, reqs[2]);
    CHECK(dre_result(&bus, reqs[2], &reply) == DRE_E_ARG);
    CHECK(dre_get_state(&m[4], &reqs[4]) == DRE_OK);

    /* a handle of a finished request does not reach the request now using its slot */
    old = reqs[2];
    CHECK((reqs[4] & 0xFFu) == (old & 0xFFu) && reqs[4] != old);
    CHECK(dre_result(&bus, old, &reply) == DRE_E_ARG && dre_result(&bus, reqs[4], &reply) == DRE_PENDING);

    setup();
    bus_fake.fail_from = 0;
    for (i = 0u; i < 6u; i++) {
        CHECK(dre_get_state(&m[0], &reqs[0]) == DRE_E_SEND); /* never takes a slot */
    }
    bus_fake.fail_from = -1;
    CHECK(dre_get_state(&m[0], &reqs[0]) == DRE_OK);
    CHECK(dre_result(&bus, 0u, &reply) == DRE_E_ARG && dre_result(&bus, 0xFFFFFFFFu, &reply) == DRE_E_ARG);
}

static void test_one_request_per_motor(void)
{
    dre_motor m1 = {&bus, 1u}, m2 = {&bus, 2u};
    dre_req a, b, c, d;
    dre_msg reply;

    setup();
    CHECK(dre_get_state(&m1, &a) == DRE_OK && dre_read_param(&m1, DRE_P_VBUS_VOLTAGE, &b) == DRE_OK);
    CHECK(dre_get_state(&m2, &c) == DRE_OK); /* another motor goes out at once */
    CHECK(bus_fake.nsent == 2u && sent_is(0u, 0x03E, "0000000000000000") && sent_is(1u, 0x05E, "0000000000000000"));
    CHECK(dre_result(&bus, b, &reply) == DRE_PENDING);

    /* the waiting request is not expired while it waits, and its timeout starts when it is sent */
    bus_fake.now = 40u;
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, a, &reply) == DRE_OK && bus_fake.nsent == 3u && sent_is(2u, 0x03E, "0100000000000000"));
    bus_fake.now = 89u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, b, &reply) == DRE_PENDING && dre_result(&bus, c, &reply) == DRE_E_TIMEOUT);
    bus_fake.now = 90u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, b, &reply) == DRE_E_TIMEOUT);

    /* cancelling the request in flight lets the next one go */
    CHECK(dre_get_state(&m1, &a) == DRE_OK && dre_get_state(&m1, &d) == DRE_OK && bus_fake.nsent == 4u);
    dre_cancel(&bus, a);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 5u && dre_result(&bus, d, &reply) == DRE_PENDING);

    /* a waiting request whose turn came but that cannot be sent expires after a timeout */
    setup();
    CHECK(dre_get_state(&m1, &a) == DRE_OK && dre_get_state(&m1, &b) == DRE_OK);
    bus_fake.fail_from = 1;
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, b, &reply) == DRE_PENDING);
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, b, &reply) == DRE_E_TIMEOUT && bus_fake.nsent == 1u);
}

static void test_isr_queue(void)
{
    dre_motor m = {&bus, 3u};
    dre_req req = 0u;
    dre_msg reply;
    dre_frame f = frame_of(0x061, "0000000000000000"), bad = f;
    unsigned i;

    setup();
    CHECK(dre_get_state(&m, &req) == DRE_OK);
    for (i = 0u; i < 4u; i++) {
        CHECK(dre_bus_isr_push(&bus, &f) == 1);
    }
    CHECK(dre_bus_isr_push(&bus, &f) == 0 && bus.rx_overflows == 1u);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING); /* nothing happens until the main loop polls */
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.node == 3u);
    CHECK(bus.stats.rx_frames == 4u && bus.stats.rx_unmatched == 3u);

    /* the queue wraps its indices many times */
    for (i = 0u; i < 1000u; i++) {
        CHECK(dre_bus_isr_push(&bus, &f) == 1);
        if (i % 3u == 2u) {
            dre_bus_poll(&bus);
        }
    }
    dre_bus_poll(&bus);
    CHECK(bus.stats.rx_frames == 1004u && bus.rx_overflows == 1u);

    bad.len = 7u;
    CHECK(dre_bus_feed(&bus, &bad) == DRE_E_PROTOCOL && bus.stats.rx_malformed == 1u);
}

static void test_init(void)
{
    dre_bus b;
    dre_bus_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.send = fake_send;
    cfg.tick = fake_tick;
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, rxq, 3u) == DRE_E_ARG);
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, rxq, 0u) == DRE_E_ARG);
    CHECK(dre_bus_init(&b, &cfg, slots, 0u, NULL, 0u) == DRE_E_ARG);
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, NULL, 0u) == DRE_OK);
    CHECK(b.cfg.timeout_ms == DRE_DEFAULT_TIMEOUT_MS);
    {
        dre_frame f = frame_of(0x021, "0000000000000000");
        CHECK(dre_bus_isr_push(&b, &f) == 0); /* no queue configured */
    }
    cfg.start = 3u;
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, NULL, 0u) == DRE_E_ARG);
    cfg.start = DRE_START_TO_NODE;
    cfg.traj_mode = 3u;
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, NULL, 0u) == DRE_E_ARG);
    cfg.traj_mode = DRE_TRAJ_S_CURVE;
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, NULL, 0u) == DRE_OK);
    cfg.tick = NULL;
    CHECK(dre_bus_init(&b, &cfg, slots, 4u, NULL, 0u) == DRE_E_ARG);
}

/* ------------------------------------------------------------------ commands */

static void test_single_motor_commands(void)
{
    dre_motor m1 = {&bus, 1u}, m2 = {&bus, 2u}, m3 = {&bus, 3u};
    dre_value v;

    setup();
    CHECK(dre_set_angle(&m1, 90.0f, 0.0f, 10.0f, DRE_ANGLE_T) == DRE_OK && sent_is(0u, 0x039, "0000B4420000E803"));
    CHECK(dre_set_angle(&m1, -150.0f, 10.0f, 5.0f, DRE_ANGLE_Q) == DRE_OK && sent_is(1u, 0x03A, "000016C3E803F401"));
    CHECK(dre_set_angle(&m2, 45.0f, 5.0f, 0.5f, DRE_ANGLE_P) == DRE_OK && sent_is(2u, 0x05B, "00003442F4013200"));
    CHECK(dre_set_speed(&m1, 20.0f, 1.5f, DRE_VEL_PASSTHROUGH) == DRE_OK && sent_is(3u, 0x03C, "0000A04196000100"));
    CHECK(dre_set_speed(&m1, 20.0f, 5.0f, DRE_VEL_RAMP) == DRE_OK && sent_is(4u, 0x03C, "0000A041F4010200"));
    CHECK(dre_set_torque(&m1, 0.5f, 0.0f, DRE_TORQUE_DIRECT) == DRE_OK && sent_is(5u, 0x03D, "0000003F00000100"));
    CHECK(dre_set_torque(&m1, 0.5f, 2.0f, DRE_TORQUE_RAMP) == DRE_OK && sent_is(6u, 0x03D, "0000003FC8000600"));
    CHECK(dre_estop(&m3) == DRE_OK && sent_is(7u, 0x068, "0600000000000000"));
    CHECK(dre_set_mode(&m1, DRE_MODE_CLOSED_LOOP) == DRE_OK && sent_is(8u, 0x03F, "3375030008000000"));
    CHECK(dre_set_mode(&m1, DRE_MODE_IDLE) == DRE_OK && sent_is(9u, 0x03F, "3375030001000000"));
    CHECK(dre_clear_error(&m1) == DRE_OK && sent_is(10u, 0x028, "0400000000000000"));
    CHECK(dre_save_config(&m1) == DRE_OK && sent_is(11u, 0x028, "0100000000000000"));
    CHECK(dre_reboot(&m1) == DRE_OK && sent_is(12u, 0x028, "0300000000000000"));
    CHECK(dre_set_zero_position(&m1) == DRE_OK && sent_is(13u, 0x028, "0500000000000000"));
    v.i = 1;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE, v) == DRE_OK &&
          sent_is(14u, 0x03F, "EE79030001000000"));
    v.f32 = -1.5f;
    CHECK(dre_write_property(&m2, 38023u, DRE_F32, v) == DRE_OK && sent_is(15u, 0x05F, "879400000000C0BF"));
    CHECK(bus_fake.nsent == 16u);

    /* refusals send nothing and name the field */
    CHECK(dre_set_angle(&m1, 0.0f, 0.0f, 5.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_SPEED);
    CHECK(dre_set_angle(&m1, 0.0f, 5.0f, -1.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_ACCEL);
    CHECK(dre_set_angle(&m1, 0.0f, 5.0f, 0.005f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_ACCEL);
    CHECK(dre_set_angle(&m1, 0.0f, 5.0f, 1.0f, 3u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_angle(&m1, NAN, 5.0f, 1.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_POSITION);
    CHECK(dre_set_angle(&m1, NAN, 0.0f, 0.0f, DRE_ANGLE_P) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_POSITION);
    CHECK(dre_set_speed(&m1, 1.0f, 400.0f, DRE_VEL_RAMP) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torque(&m1, 1.0f, 0.0f, 2u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_mode(&m1, 3u) == DRE_E_RANGE);
    v.i = 2;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE, v) == DRE_E_RANGE);
    v.f32 = 1.0f;
    CHECK(dre_write_param(&m1, DRE_P_VBUS_VOLTAGE, v) == DRE_E_ACCESS);
    v.i = 70000;
    CHECK(dre_write_property(&m1, 100u, DRE_U16, v) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE);
    {
        dre_motor bad = {&bus, 64u};
        dre_req req;
        CHECK(dre_estop(&bad) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_NODE);
        CHECK(dre_get_state(&bad, &req) == DRE_E_RANGE);
    }
    CHECK(bus_fake.nsent == 16u);

    bus_fake.fail_from = 16;
    CHECK(dre_estop(&m1) == DRE_E_SEND);
}

/* T mode as the Python client: 0 < bandwidth <= 300 (a negative one is refused), |speed| sent. */
static void test_t_mode_bandwidth(void)
{
    static const uint8_t ids[2] = {1u, 2u};
    static const float angles[2] = {10.0f, 20.0f};
    dre_motor m1 = {&bus, 1u};

    setup();
    CHECK(dre_set_angle(&m1, 10.0f, -3.0f, 5.0f, DRE_ANGLE_T) == DRE_OK && sent_is(0u, 0x039, "000020412C01F401"));
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, 300.0f, DRE_ANGLE_T) == DRE_OK && sent_is(1u, 0x039, "0000204100003075"));
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, -300.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, -20.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(bus_fake.nsent == 2u);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, 0.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, 0.004f, DRE_ANGLE_T) == DRE_E_RANGE);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, 300.5f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, -1000.0f, DRE_ANGLE_T) == DRE_E_RANGE);
    CHECK(dre_set_angle(&m1, 10.0f, 0.0f, NAN, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angle(&m1, 10.0f, INFINITY, 5.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_SPEED);
    CHECK(bus_fake.nsent == 2u);

    /* the same rule for T presets */
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, -3.0f, -5.0f, DRE_ANGLE_T) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, -3.0f, 5.0f, DRE_ANGLE_T) == DRE_OK);
    CHECK(sent_is(2u, 0x02C, "000020412C01F401") && sent_is(4u, 0x008, "1000000000000000"));
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, 0.0f, 0.0f, DRE_ANGLE_T) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_BANDWIDTH);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, 0.0f, 301.0f, DRE_ANGLE_T) == DRE_E_RANGE);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, NAN, 5.0f, DRE_ANGLE_T) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_SPEED);
    CHECK(bus_fake.nsent == 5u);
}

/* set_speed(s) / set_torque(s) parameters as the vendor and the Python client send them. */
static void test_speed_torque_params(void)
{
    static const uint8_t ids[3] = {1u, 2u, 3u};
    static const float speeds[3] = {10.0f, 0.0f, -0.0f}, torques[2] = {1.5f, -1.5f};
    dre_motor m1 = {&bus, 1u};

    setup();
    /* passthrough at speed 0: no feed-forward torque, whatever param says (a NaN is refused all the same) */
    CHECK(dre_set_speed(&m1, 0.0f, 1.5f, DRE_VEL_PASSTHROUGH) == DRE_OK && sent_is(0u, 0x03C, "0000000000000100"));
    CHECK(dre_set_speed(&m1, 0.0f, NAN, DRE_VEL_PASSTHROUGH) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    /* mode 0 is the ramp, as the vendor's docs use it */
    CHECK(dre_set_speed(&m1, 20.0f, 5.0f, 0u) == DRE_OK && sent_is(1u, 0x03C, "0000A041F4010200"));
    /* direct torque: param is not sent, but must be a number */
    CHECK(dre_set_torque(&m1, 1.5f, 5.0f, DRE_TORQUE_DIRECT) == DRE_OK && sent_is(2u, 0x03D, "0000C03F00000100"));
    CHECK(dre_set_torque(&m1, 1.5f, NAN, DRE_TORQUE_DIRECT) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torque(&m1, 1.5f, 5.0f, 0u) == DRE_OK && sent_is(3u, 0x03D, "0000C03FF4010600"));
    CHECK(bus_fake.nsent == 4u);

    /* a ramp rate must be > 0 on the wire; a feed-forward torque finite */
    CHECK(dre_set_speed(&m1, 20.0f, 0.0f, DRE_VEL_RAMP) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_speed(&m1, 20.0f, 0.004f, 0u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_speed(&m1, 20.0f, NAN, DRE_VEL_PASSTHROUGH) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_speed(&m1, NAN, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_SPEED);
    CHECK(dre_set_speed(&m1, 1.0f, 0.0f, 3u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_torque(&m1, 1.0f, -2.0f, DRE_TORQUE_RAMP) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torque(&m1, INFINITY, 0.0f, DRE_TORQUE_DIRECT) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_TORQUE);
    CHECK(bus_fake.nsent == 4u);

    /* the batch forms: per motor for speeds, for all for torques */
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 1.5f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(sent_is(4u, 0x02C, "0000204196006400") && sent_is(5u, 0x04C, "0000000000006400") &&
          sent_is(6u, 0x06C, "0000008000006400") && sent_is(7u, 0x008, "1300000000000000"));
    CHECK(dre_set_speeds(&bus, 1u, ids, speeds, 5.0f, 0u) == DRE_OK && sent_is(8u, 0x02C, "00002041F401C800"));
    CHECK(dre_set_torques(&bus, 2u, ids, torques, 5.0f, DRE_TORQUE_DIRECT) == DRE_OK);
    CHECK(sent_is(10u, 0x02C, "0000C03F00006400") && sent_is(11u, 0x04C, "0000C0BF00006400"));
    CHECK(dre_set_torques(&bus, 2u, ids, torques, NAN, DRE_TORQUE_DIRECT) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torques(&bus, 1u, ids, torques, 5.0f, 0u) == DRE_OK && sent_is(13u, 0x02C, "0000C03FF4015802"));
    CHECK(bus_fake.nsent == 15u);
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_RAMP) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, NAN, DRE_VEL_PASSTHROUGH) == DRE_E_RANGE);
    CHECK(dre_set_torques(&bus, 2u, ids, torques, 0.0f, DRE_TORQUE_RAMP) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torques(&bus, 2u, ids, torques, 1.0f, 2u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(bus_fake.nsent == 15u);
}

/* ------------------------------------------------------------------ several motors */

static void test_batches(void)
{
    static const uint8_t ids[3] = {1u, 2u, 3u};
    const float angles[3] = {90.0f, -90.0f, 0.0f}, from[3] = {0.0f, 0.0f, 0.0f};
    const float speeds[1] = {10.0f}, torques[1] = {3.0f};
    float bad_angles[3] = {1.0f, 2.0f, 0.0f};
    dre_motor m1 = {&bus, 1u};

    /* the vendor's frames (PROTOCOL.md 1.7), which broadcast every start */
    setup_with(DRE_START_TO_BROADCAST, -1, 0);
    /* set_angles([1,2],[90,-90],10,20,1) from 0 deg gives T = 2.0 s */
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(bus_fake.nsent == 3u && sent_is(0u, 0x02C, "0000B442C800D007") && sent_is(1u, 0x04C, "0000B4C2C800D007") &&
          sent_is(2u, 0x008, "1100000000000000"));
    CHECK(dre_step_angles(&bus, 2u, ids, angles, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(bus_fake.nsent == 6u && sent_is(3u, 0x02C, "0000B442C800D007") && sent_is(5u, 0x008, "1100000001000000"));
    CHECK(dre_set_speeds(&bus, 1u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(sent_is(6u, 0x02C, "0000204100006400") && sent_is(7u, 0x008, "1300000000000000"));
    CHECK(dre_set_torques(&bus, 1u, ids, torques, 10.0f, DRE_TORQUE_RAMP) == DRE_OK);
    CHECK(sent_is(8u, 0x02C, "00004040E8035802") && sent_is(9u, 0x008, "1400000000000000"));
    CHECK(dre_impedance_control(&m1, 180.0f, 0.0f, 0.0f, 0.5f, 0.2f) == DRE_OK);
    CHECK(sent_is(10u, 0x02C, "0000344300000000") && sent_is(11u, 0x008, "1500000032001400"));
    CHECK(dre_set_angles(&bus, 3u, ids, angles, NULL, 5.0f, 50.0f, DRE_ANGLE_T) == DRE_OK);
    CHECK(sent_is(14u, 0x06C, "00000000F4018813") && sent_is(15u, 0x008, "1000000000000000"));
    CHECK(dre_set_angles(&bus, 1u, ids, angles, NULL, -2.5f, 0.75f, DRE_ANGLE_P) == DRE_OK);
    CHECK(sent_is(16u, 0x02C, "0000B44206FF4B00") && sent_is(17u, 0x008, "1200000000000000"));
    CHECK(bus_fake.nsent == 18u);

    /* by default (as the Python client) a one-motor batch starts that motor only */
    setup();
    CHECK(dre_set_speeds(&bus, 1u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(sent_is(0u, 0x02C, "0000204100006400") && sent_is(1u, 0x028, "1300000000000000"));
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(bus_fake.nsent == 5u && sent_is(4u, 0x008, "1100000000000000"));
    /* DRE_START_TO_NODE: one start per motor */
    setup_with(DRE_START_TO_NODE, -1, 0);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(bus_fake.nsent == 4u && sent_is(2u, 0x028, "1100000000000000") && sent_is(3u, 0x048, "1100000000000000"));

    /* validation happens before anything is sent */
    setup();
    bad_angles[2] = NAN;
    CHECK(dre_set_angles(&bus, 3u, ids, bad_angles, NULL, 5.0f, 50.0f, DRE_ANGLE_T) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_POSITION && bus.bad_index == 2u);
    CHECK(dre_set_angles(&bus, 3u, ids, angles, NULL, 400.0f, 0.0f, DRE_ANGLE_P) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_SPEED_FF && bus.bad_index == 0u);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_ARG);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 0.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 400.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_SPEED);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, 7u) == DRE_E_RANGE);
    /* a move of 100 turns at 1 r/min takes far longer than the 327.67 s a preset can carry */
    {
        const float far[1] = {36000.0f};
        CHECK(dre_set_angles(&bus, 1u, ids, far, from, 1.0f, 1.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
        CHECK(bus.bad_field == DRE_FIELD_TIME);
    }
    CHECK(dre_set_speeds(&bus, 1u, ids, speeds, 0.0f, 5u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_torques(&bus, 1u, ids, torques, 1000.0f, DRE_TORQUE_RAMP) == DRE_E_RANGE);
    CHECK(dre_set_speeds(&bus, 0u, ids, speeds, 0.0f, DRE_VEL_RAMP) == DRE_E_ARG);
    CHECK(bus_fake.nsent == 0u);

    /* a failed send stops the batch before the start */
    bus_fake.fail_from = 1;
    CHECK(dre_set_angles(&bus, 3u, ids, angles, NULL, 5.0f, 50.0f, DRE_ANGLE_T) == DRE_E_SEND);
    CHECK(bus_fake.nsent == 1u && bus_fake.sent[0].id == 0x02C);
}

/* Q moves: the slowest motor's time, each motor with its own profile, rounded up to 0.01 s. */
static void test_q_batch_time(void)
{
    static const uint8_t ids[2] = {1u, 2u};
    const float angles[2] = {90.0f, -90.0f}, from[2] = {0.0f, 0.0f}, near_move[1] = {16.0f};
    dre_motor m2 = {&bus, 2u};
    dre_req req;
    dre_msg reply;

    setup();
    /* 16 deg at 10 r/min, 20 (r/min)/s: 2 sqrt(16/120) = 0.7303 s, sent as 0.74 (nearest would be 0.73) */
    CHECK(dre_set_angles(&bus, 1u, ids, near_move, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(0u, 0x02C, "000080414A00D007"));
    /* no distance: the shortest time a preset carries */
    CHECK(dre_step_angles(&bus, 1u, ids, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(2u, 0x02C, "000000000100D007"));

    /* motor 2 reports the S-curve: 90 deg then take 1.5 + 1.0 = 2.5 s (trapezoid: 2.0 s) */
    CHECK(dre_get_traj_mode(&m2, &req) == DRE_OK && sent_is(4u, 0x05E, "2089030000000000"));
    feed(0x05E, "2089030002000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.u.param.value.i == 2);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(5u, 0x02C, "0000B442FA00D007") && sent_is(6u, 0x04C, "0000B4C2FA00D007"));
    /* motor 1 alone keeps the trapezoid of cfg.traj_mode */
    CHECK(dre_set_angles(&bus, 1u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(8u, 0x02C, "0000B442C800D007"));
    /* a reboot forgets the profile (it is not saved) */
    CHECK(dre_reboot(&m2) == DRE_OK);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(11u, 0x02C, "0000B442C800D007"));
    /* so does a broadcast write of it */
    CHECK(dre_set_traj_mode(&m2, DRE_TRAJ_S_CURVE, &req) == DRE_OK);
    CHECK(sent_is(14u, 0x05F, "2089030002000000") && sent_is(15u, 0x05E, "2089030000000000"));
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(16u, 0x02C, "0000B442FA00D007"));
    {
        dre_motor all = {&bus, 0u};
        dre_value v;
        v.i = 2;
        CHECK(dre_write_param(&all, DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, v) == DRE_OK);
    }
    CHECK(bus.traj_known == 0u);
}

/* A non-finite current position, target or delta is refused, naming it and its index. */
static void test_q_non_finite(void)
{
    static const uint8_t ids[3] = {1u, 2u, 3u};
    float target[3] = {90.0f, 3000.0f, 0.0f}, from[3] = {0.0f, NAN, 0.0f};

    setup();
    CHECK(dre_set_angles(&bus, 3u, ids, target, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_FROM && bus.bad_index == 1u);
    from[1] = 0.0f;
    from[2] = -INFINITY;
    CHECK(dre_set_angles(&bus, 3u, ids, target, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_FROM && bus.bad_index == 2u);
    from[2] = 0.0f;
    target[0] = INFINITY;
    CHECK(dre_set_angles(&bus, 3u, ids, target, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_POSITION && bus.bad_index == 0u);
    target[0] = 90.0f;
    target[2] = NAN;
    CHECK(dre_step_angles(&bus, 3u, ids, target, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_POSITION && bus.bad_index == 2u);
    CHECK(bus_fake.nsent == 0u);
}

/* Motor ids of every batch: distinct, 1..63. */
static void test_batch_ids(void)
{
    static const uint8_t twice[3] = {1u, 2u, 1u}, zero[2] = {2u, 0u}, high[1] = {64u};
    static const float v[3] = {1.0f, 2.0f, 3.0f}, from[3] = {0.0f, 0.0f, 0.0f};
    dre_msg presets[2], start;
    dre_motor all = {&bus, 0u};

    setup();
    CHECK(dre_set_speeds(&bus, 3u, twice, v, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_ARG && bus.bad_index == 2u &&
          bus.bad_field == DRE_FIELD_NODE);
    CHECK(dre_set_torques(&bus, 3u, twice, v, 0.0f, DRE_TORQUE_DIRECT) == DRE_E_ARG);
    CHECK(dre_set_angles(&bus, 3u, twice, v, from, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_ARG);
    CHECK(dre_step_angles(&bus, 3u, twice, v, 0.0f, 10.0f, DRE_ANGLE_T) == DRE_E_ARG);
    CHECK(dre_set_speeds(&bus, 2u, zero, v, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_NODE && bus.bad_index == 1u);
    CHECK(dre_set_angles(&bus, 1u, high, v, NULL, 0.0f, 0.0f, DRE_ANGLE_P) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_NODE && bus.bad_index == 0u);
    CHECK(dre_step_angle(&all, 10.0f, 0.0f, 0.0f, DRE_ANGLE_P) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_NODE);

    memset(presets, 0, sizeof presets);
    memset(&start, 0, sizeof start);
    presets[0].type = presets[1].type = DRE_MSG_PRESET;
    presets[0].node = presets[1].node = 3u;
    start.type = DRE_MSG_START;
    start.u.start.kind = DRE_START_P;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_ARG && bus.bad_index == 1u);
    presets[1].node = 0u;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_NODE);
    CHECK(bus_fake.nsent == 0u);
}

static void test_impedance(void)
{
    dre_motor m1 = {&bus, 1u};

    setup();
    /* the start goes to the motor by default, as in the Python client */
    CHECK(dre_impedance_control(&m1, 180.0f, 0.0f, 0.0f, 0.5f, 0.2f) == DRE_OK);
    CHECK(bus_fake.nsent == 2u && sent_is(0u, 0x02C, "0000344300000000") && sent_is(1u, 0x028, "1500000032001400"));
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 0.0f, 327.67f) == DRE_OK);
    CHECK(sent_is(3u, 0x028, "150000000000FF7F"));

    /* gains are 0..327.67 */
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, -50.0f, 2.0f) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_KP);
    CHECK(bus.bad_index == 1u); /* index n: the start frame */
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 50.0f, -2.0f) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_KD);
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, -0.001f, 0.0f) == DRE_E_RANGE);
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 327.674f, 0.0f) == DRE_E_RANGE);
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, NAN, 0.0f) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_KP);
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 1000.0f, 0.0f) == DRE_E_RANGE);
    CHECK(dre_impedance_control(&m1, NAN, 0.0f, 0.0f, 1.0f, 1.0f) == DRE_E_RANGE &&
          bus.bad_field == DRE_FIELD_POSITION && bus.bad_index == 0u);
    CHECK(bus_fake.nsent == 4u);

    /* the vendor's broadcast start as an option */
    setup_with(DRE_START_TO_BROADCAST, -1, 0);
    CHECK(dre_impedance_control(&m1, 180.0f, 0.0f, 0.0f, 0.5f, 0.2f) == DRE_OK);
    CHECK(sent_is(1u, 0x008, "1500000032001400"));
}

static void test_preset_start(void)
{
    dre_msg presets[2], start;

    setup();
    memset(presets, 0, sizeof presets);
    memset(&start, 0, sizeof start);
    presets[0].type = DRE_MSG_PRESET_V;
    presets[0].node = 1u;
    presets[0].u.velocity.speed = 10.0f;
    presets[0].u.velocity.mode = DRE_VEL_PASSTHROUGH;
    presets[1].type = DRE_MSG_PRESET;
    presets[1].node = 2u;
    presets[1].u.preset.p1 = 20.0f;
    presets[1].u.preset.p3 = 1.0f;
    start.type = DRE_MSG_START;
    start.u.start.kind = DRE_START_V;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_OK && bus_fake.nsent == 3u);
    CHECK(sent_is(0u, 0x02C, "0000204100006400") && sent_is(1u, 0x04C, "0000A04100006400") &&
          sent_is(2u, 0x008, "1300000000000000"));

    start.u.start.kind = DRE_START_Q; /* a V preset cannot run under a Q start */
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_ARG && bus.bad_index == 0u);
    presets[0].type = DRE_MSG_FAST_READ;
    start.u.start.kind = DRE_START_V;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_ARG);
    start.type = DRE_MSG_SYSTEM;
    presets[0].type = DRE_MSG_PRESET;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_ARG);
    start.type = DRE_MSG_START_IMPEDANCE;
    start.u.start_impedance.kp = -1.0f;
    presets[0].type = presets[1].type = DRE_MSG_PRESET_D;
    CHECK(dre_preset_start(&bus, presets, 2u, &start) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_KP &&
          bus.bad_index == 2u);
    CHECK(bus_fake.nsent == 3u);
}

/* ------------------------------------------------------------------ transmit room */

/* Three hardware mailboxes and no software queue: a batch that does not fit sends nothing. */
static void test_tx_room(void)
{
    static const uint8_t ids[6] = {1u, 2u, 3u, 4u, 5u, 6u};
    static const float speeds[6] = {10.0f, 10.0f, 10.0f, 10.0f, 10.0f, 10.0f};
    dre_motor m1 = {&bus, 1u};
    dre_req req[3];

    setup_with(DRE_START_TO_AUTO, 3, 0);
    CHECK(dre_set_speeds(&bus, 6u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_BUSY && bus_fake.nsent == 0u);
    CHECK(bus.presets_pending == 0u);
    CHECK(dre_set_speeds(&bus, 2u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK && bus_fake.nsent == 3u);
    bus_fake.room = 2;
    CHECK(dre_set_speeds(&bus, 2u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_BUSY);
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 1.0f, 1.0f) == DRE_OK && bus_fake.nsent == 5u);
    /* other operations of several frames: a verified write needs the write and the read */
    bus_fake.room = 1;
    CHECK(dre_set_traj_mode(&m1, DRE_TRAJ_TRAPEZOID, req) == DRE_E_BUSY);
    bus_fake.room = 3;
    CHECK(dre_set_angle_range(&m1, -90.0f, 90.0f, 0.0f, req) == DRE_E_BUSY);
    CHECK(bus_fake.nsent == 5u);
    bus_fake.room = 7;
    CHECK(dre_set_speeds(&bus, 6u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK && bus_fake.nsent == 12u);
    CHECK(sent_is(11u, 0x008, "1300000000000000"));
}

/* A port's transmit ring: the send callback pushes, the "TX-complete interrupt" drains into 3 mailboxes. */
static dre_txq txq;
static dre_frame txq_storage[8];

static int ring_send(void *user, const dre_frame *f)
{
    (void)user;
    return dre_txq_send(&txq, f);
}

static unsigned ring_free(void *user)
{
    (void)user;
    return dre_txq_free(&txq);
}

/* The hardware takes up to `n` frames, in order. */
static void drain(unsigned n)
{
    dre_frame f;
    while (n-- > 0u && dre_txq_peek(&txq, &f)) {
        CHECK(fake_send(&bus_fake, &f) == 0);
        dre_txq_pop(&txq);
    }
}

static void test_txq(void)
{
    static const uint8_t ids[6] = {1u, 2u, 3u, 4u, 5u, 6u};
    static const float speeds[6] = {10.0f, 10.0f, 10.0f, 10.0f, 10.0f, 10.0f};
    dre_frame f = frame_of(0x028, "0600000000000000"), g;
    unsigned i;

    CHECK(dre_txq_init(&txq, txq_storage, 6u) == DRE_E_ARG && dre_txq_init(&txq, NULL, 8u) == DRE_E_ARG);
    CHECK(dre_txq_init(&txq, txq_storage, 1u) == DRE_E_ARG);
    CHECK(dre_txq_init(&txq, txq_storage, 8u) == DRE_OK && dre_txq_free(&txq) == 8u);
    CHECK(dre_txq_peek(&txq, &g) == 0);
    dre_txq_pop(&txq); /* popping an empty ring does nothing */
    CHECK(dre_txq_free(&txq) == 8u);
    for (i = 0u; i < 8u; i++) {
        f.data[1] = (uint8_t)i;
        CHECK(dre_txq_send(&txq, &f) == 0);
    }
    CHECK(dre_txq_send(&txq, &f) == -1 && dre_txq_free(&txq) == 0u);
    for (i = 0u; i < 300u; i++) { /* the indices wrap many times */
        CHECK(dre_txq_peek(&txq, &g) == 1 && g.data[1] == (uint8_t)i);
        dre_txq_pop(&txq);
        f.data[1] = (uint8_t)(i + 8u);
        CHECK(dre_txq_send(&txq, &f) == 0 && dre_txq_free(&txq) == 0u);
    }

    /* a port wired to it: a 6-motor batch goes into the ring whole and leaves in order */
    setup_with(DRE_START_TO_AUTO, -1, 0);
    CHECK(dre_txq_init(&txq, txq_storage, 8u) == DRE_OK);
    bus.cfg.send = ring_send;
    bus.cfg.tx_free = ring_free;
    CHECK(dre_set_speeds(&bus, 6u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK && dre_txq_free(&txq) == 1u);
    CHECK(dre_set_speeds(&bus, 6u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_BUSY); /* no room for 7 more */
    drain(3u);
    drain(3u);
    drain(3u);
    CHECK(bus_fake.nsent == 7u && sent_is(0u, 0x02C, "0000204100006400") && sent_is(5u, 0x0CC, "0000204100006400") &&
          sent_is(6u, 0x008, "1300000000000000"));
    CHECK(dre_txq_free(&txq) == 8u);
}

/* A send failing midway: the motors left holding a preset are started by id, never by a broadcast. */
static void test_stale_presets(void)
{
    static const uint8_t ids[5] = {1u, 2u, 3u, 4u, 5u};
    static const float speeds[5] = {10.0f, 10.0f, 10.0f, 10.0f, 10.0f};

    setup();
    bus_fake.fail_from = 2; /* presets of motors 1 and 2 go out, the third fails */
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_SEND);
    CHECK(bus.presets_pending == ((1u << 1) | (1u << 2)));
    bus_fake.fail_from = -1;

    /* motors 4 and 5: a broadcast would start 1 and 2 too */
    CHECK(dre_set_speeds(&bus, 2u, ids + 3, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(bus_fake.nsent == 6u && sent_is(4u, 0x088, "1300000000000000") && sent_is(5u, 0x0A8, "1300000000000000"));
    CHECK(bus.presets_pending == ((1u << 1) | (1u << 2)));
    /* motor 2 alone is started by its id, and forgotten */
    CHECK(dre_set_speeds(&bus, 1u, ids + 1, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(sent_is(7u, 0x048, "1300000000000000") && bus.presets_pending == (1u << 1));
    /* a batch holding motor 1 may broadcast: every pending preset belongs to it */
    CHECK(dre_set_speeds(&bus, 2u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(sent_is(10u, 0x008, "1300000000000000") && bus.presets_pending == 0u);
    CHECK(dre_set_speeds(&bus, 2u, ids + 3, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(bus_fake.nsent == 14u && sent_is(13u, 0x008, "1300000000000000"));

    /* a failed start leaves every motor of the batch pending; starts by id clear them one by one */
    setup();
    bus_fake.fail_from = 3;
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_SEND);
    CHECK(bus.presets_pending == ((1u << 1) | (1u << 2) | (1u << 3)));
    setup_with(DRE_START_TO_NODE, -1, 0);
    bus_fake.fail_from = 3; /* both presets and the first start go out */
    CHECK(dre_set_speeds(&bus, 2u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_SEND);
    CHECK(bus.presets_pending == (1u << 2));
}

/* ------------------------------------------------------------------ start after presets */

/* A bxCAN-like port: frames wait in a FIFO (txq), fill three mailboxes in order, and the
 * mailboxes arbitrate by identifier: the lowest id goes on the wire first. */
static dre_frame mbox[3];
static int mbox_full[3];

static int mb_send(void *user, const dre_frame *f)
{
    (void)user;
    return dre_txq_send(&txq, f);
}

static int mb_done(void *user)
{
    (void)user;
    return dre_txq_free(&txq) == 8u && !mbox_full[0] && !mbox_full[1] && !mbox_full[2];
}

/* Put up to `n` frames on the wire (recorded as sent by the fake). */
static void mb_wire(unsigned n)
{
    while (n-- > 0u) {
        int k, best = -1;
        for (k = 0; k < 3; k++) {
            if (!mbox_full[k] && dre_txq_peek(&txq, &mbox[k])) {
                dre_txq_pop(&txq);
                mbox_full[k] = 1;
            }
        }
        for (k = 0; k < 3; k++) {
            if (mbox_full[k] && (best < 0 || mbox[k].id < mbox[best].id)) {
                best = k;
            }
        }
        if (best < 0) {
            return;
        }
        CHECK(fake_send(&bus_fake, &mbox[best]) == 0);
        mbox_full[best] = 0;
    }
}

static void setup_mailboxes(int with_tx_done)
{
    setup();
    memset(mbox_full, 0, sizeof mbox_full);
    CHECK(dre_txq_init(&txq, txq_storage, 8u) == DRE_OK);
    bus.cfg.send = mb_send;
    bus.cfg.tx_done = with_tx_done ? mb_done : NULL;
}

/* The scripted cases of the Python client's start-after-presets rule, on a three-mailbox port. */
static void test_start_after_presets(void)
{
    static const uint8_t ids[5] = {1u, 2u, 3u, 4u, 5u};
    static const float speeds[5] = {10.0f, 10.0f, 10.0f, 10.0f, 10.0f};
    static const char *preset = "0000204100006400";
    static const char *start = "1300000000000000";

    /* without tx_done the broadcast start takes the first freed mailbox and wins over two presets */
    setup_mailboxes(0);
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    mb_wire(8u);
    CHECK(bus_fake.nsent == 4u && sent_is(0u, 0x02C, preset) && sent_is(1u, 0x008, start) &&
          sent_is(2u, 0x04C, preset) && sent_is(3u, 0x06C, preset));

    /* with tx_done the start is held until every preset is on the wire */
    setup_mailboxes(1);
    CHECK(dre_batch_status(&bus) == DRE_OK);
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_PENDING);
    CHECK(dre_batch_status(&bus) == DRE_PENDING && dre_txq_free(&txq) == 5u);
    CHECK(dre_set_speeds(&bus, 2u, ids + 3, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_E_BUSY);
    CHECK(dre_txq_free(&txq) == 5u); /* the refused batch sent nothing */
    dre_bus_poll(&bus);
    CHECK(dre_batch_status(&bus) == DRE_PENDING && dre_txq_free(&txq) == 5u);
    mb_wire(2u);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && dre_batch_status(&bus) == DRE_PENDING);
    mb_wire(1u);
    dre_bus_poll(&bus);
    CHECK(dre_batch_status(&bus) == DRE_OK && bus.presets_pending == 0u && dre_txq_free(&txq) == 7u);
    mb_wire(8u);
    CHECK(bus_fake.nsent == 4u && sent_is(0u, 0x02C, preset) && sent_is(1u, 0x04C, preset) &&
          sent_is(2u, 0x06C, preset) && sent_is(3u, 0x008, start));

    /* a port whose presets leave at once: the start follows without waiting */
    setup_mailboxes(1);
    bus.cfg.send = fake_send; /* straight to the wire */
    bus.cfg.user = &bus_fake;
    CHECK(dre_set_speeds(&bus, 2u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x008, start) && dre_batch_status(&bus) == DRE_OK);

    /* the wire stays busy: after the timeout the start is given up, its presets stay pending and
     * the next batch starts its own motors by id, so the stale presets never fire */
    setup_mailboxes(1);
    CHECK(dre_set_speeds(&bus, 3u, ids, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_PENDING);
    bus_fake.now += bus.cfg.timeout_ms;
    dre_bus_poll(&bus);
    CHECK(dre_batch_status(&bus) == DRE_E_TIMEOUT && bus.stats.timeouts == 1u);
    CHECK(bus.presets_pending == ((1u << 1) | (1u << 2) | (1u << 3)));
    mb_wire(8u);
    CHECK(bus_fake.nsent == 3u); /* three presets, no start */
    CHECK(dre_set_speeds(&bus, 2u, ids + 3, speeds, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_PENDING);
    mb_wire(2u);
    dre_bus_poll(&bus);
    CHECK(dre_batch_status(&bus) == DRE_OK);
    mb_wire(8u);
    CHECK(bus_fake.nsent == 7u && sent_is(5u, 0x088, start) && sent_is(6u, 0x0A8, start));
    CHECK(bus.presets_pending == ((1u << 1) | (1u << 2) | (1u << 3)));
}

/* ------------------------------------------------------------------ vendor functions */

static void test_reads(void)
{
    static const char *const words[DRE_ERROR_WORDS] = {"3175030000000000", "E980030000000000", "D184030000000000",
                                                       "017D030000000000", "214E030000000000", "A18C030000000000",
                                                       "8990030000000000"};
    dre_motor m1 = {&bus, 1u}, m2 = {&bus, 2u};
    dre_req req[DRE_ERROR_WORDS], id, other;
    dre_msg reply;
    unsigned i;

    setup_with(DRE_START_TO_AUTO, -1, 1);
    CHECK(dre_get_id(&m2, &id) == DRE_OK && sent_is(0u, 0x05E, "1979030000000000"));
    feed(0x05E, "1979030002000000");
    CHECK(dre_result(&bus, id, &reply) == DRE_OK && reply.u.param.value.i == 2);

    /* get_volcur: two reads, the second once the first is answered */
    CHECK(dre_get_volcur(&m1, req) == DRE_OK && bus_fake.nsent == 2u && sent_is(1u, 0x03E, "0100000000000000"));
    feed(0x03E, "010000000000C041"); /* 24 V */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x03E, "B681000000000000"));
    feed(0x03E, "B681000000000040"); /* 2 A */
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && reply.u.param.value.f32 == 24.0f);
    CHECK(dre_result(&bus, req[1], &reply) == DRE_OK && reply.u.param.value.f32 == 2.0f);

    /* dump_error: the seven words in the vendor's order, needing seven free slots */
    CHECK(dre_get_state(&m2, &id) == DRE_OK && dre_get_state(&m2, &other) == DRE_OK);
    CHECK(dre_dump_error(&m1, req) == DRE_E_BUSY && bus_fake.nsent == 4u);
    dre_cancel(&bus, id);
    dre_cancel(&bus, other);
    CHECK(dre_dump_error(&m1, req) == DRE_OK);
    for (i = 0u; i < DRE_ERROR_WORDS; i++) {
        dre_frame f;
        CHECK(bus_fake.nsent == 5u + i && sent_is(4u + i, 0x03E, words[i]));
        f = frame_of(0x03E, words[i]);
        f.data[4] = (uint8_t)(i + 1u);
        CHECK(dre_bus_feed(&bus, &f) == DRE_OK);
        dre_bus_poll(&bus);
    }
    for (i = 0u; i < DRE_ERROR_WORDS; i++) {
        CHECK(dre_result(&bus, req[i], &reply) == DRE_OK && reply.u.param.value.i == (int64_t)(i + 1u));
    }
    CHECK(bus_fake.nsent == 11u);
}

static void test_verified_writes(void)
{
    dre_motor m1 = {&bus, 1u}, m3 = {&bus, 3u};
    dre_req req[3];
    dre_msg reply;

    /* set_traj_mode: write, read back, remembered, not saved */
    setup();
    CHECK(dre_set_traj_mode(&m1, DRE_TRAJ_S_CURVE, req) == DRE_OK);
    CHECK(bus_fake.nsent == 2u && sent_is(0u, 0x03F, "2089030002000000") && sent_is(1u, 0x03E, "2089030000000000"));
    feed(0x03E, "2089030002000000");
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && bus_fake.nsent == 2u);
    CHECK(bus.traj_known == (1u << 1) && bus.traj_scurve == (1u << 1));
    CHECK(dre_set_traj_mode(&m1, DRE_TRAJ_TRAPEZOID, req) == DRE_OK);
    feed(0x03E, "2089030002000000"); /* the motor kept the S-curve */
    CHECK(dre_result(&bus, req[0], &reply) == DRE_E_VERIFY && reply.u.param.value.i == 2);
    CHECK(dre_set_traj_mode(&m1, 0u, req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);

    /* set_can_baud_rate: save only after the value reads back */
    setup();
    CHECK(dre_set_can_baud_rate(&m1, 1000000u, req) == DRE_OK);
    CHECK(sent_is(0u, 0x03F, "0952030040420F00") && sent_is(1u, 0x03E, "0952030000000000"));
    feed(0x03E, "0952030040420F00");
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x028, "0100000000000000"));
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK);
    CHECK(dre_set_can_baud_rate(&m1, 1000001u, req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE);
    CHECK(dre_set_uart_baud_rate(&m1, 115200u, req) == DRE_OK && sent_is(3u, 0x03F, "1127030000C20100"));
    feed(0x03E, "1127030080250000"); /* 9600: not what was written */
    CHECK(dre_result(&bus, req[0], &reply) == DRE_E_VERIFY && bus_fake.nsent == 5u);
    CHECK(dre_set_uart_baud_rate(&m1, 1000000u, req) == DRE_E_RANGE);

    /* set_angle_range: three verified writes, saved once all three read back */
    setup();
    CHECK(dre_set_angle_range(&m1, -90.0f, 90.0f, 0.0f, req) == DRE_OK);
    CHECK(bus_fake.nsent == 4u && sent_is(0u, 0x03F, "7A9400000000B4C2") && sent_is(1u, 0x03F, "7B9400000000B442") &&
          sent_is(2u, 0x03F, "E279030001000000") && sent_is(3u, 0x03E, "7A94000000000000"));
    feed(0x03E, "7A9400000000B4C2");
    dre_bus_poll(&bus);
    CHECK(sent_is(4u, 0x03E, "7B94000000000000"));
    feed(0x03E, "7B9400000000B442");
    dre_bus_poll(&bus);
    CHECK(sent_is(5u, 0x03E, "E279030000000000") && bus_fake.nsent == 6u);
    feed(0x03E, "E279030001000000");
    CHECK(bus_fake.nsent == 7u && sent_is(6u, 0x028, "0100000000000000"));
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && dre_result(&bus, req[1], &reply) == DRE_OK &&
          dre_result(&bus, req[2], &reply) == DRE_OK);
    /* a limit that does not read back: nothing saved */
    CHECK(dre_set_angle_range(&m3, -90.0f, 90.0f, 0.0f, req) == DRE_OK && bus_fake.nsent == 11u);
    feed(0x07E, "7A9400000000B4C2");
    dre_bus_poll(&bus);
    feed(0x07E, "7B9400000000B443"); /* 360, not 90 */
    dre_bus_poll(&bus);
    feed(0x07E, "E279030001000000");
    CHECK(bus_fake.nsent == 13u);
    CHECK(dre_result(&bus, req[1], &reply) == DRE_E_VERIFY && dre_result(&bus, req[2], &reply) == DRE_OK);
    /* refusals */
    CHECK(dre_set_angle_range(&m1, 90.0f, -90.0f, 0.0f, req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE &&
          bus.bad_index == 1u);
    CHECK(dre_set_angle_range(&m1, NAN, 90.0f, 0.0f, req) == DRE_E_RANGE && bus.bad_index == 0u);
    CHECK(dre_set_angle_range(&m1, -90.0f, 90.0f, 91.0f, req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_POSITION);
    CHECK(dre_set_angle_range(&m1, -90.0f, 90.0f, NAN, req) == DRE_E_RANGE);
    CHECK(bus_fake.nsent == 13u);
}

/* cfg.retries and verified writes: a read-back that differs is written and read again, as the Python client. */
static void test_verified_rewrites(void)
{
    dre_motor m1 = {&bus, 1u};
    dre_req req[3];
    dre_msg reply;

    /* the first read-back differs: written again, read again, then DRE_OK and remembered */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_traj_mode(&m1, DRE_TRAJ_S_CURVE, req) == DRE_OK && bus_fake.nsent == 2u);
    feed(0x03E, "2089030001000000"); /* still the trapezoid */
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x03F, "2089030002000000"));
    CHECK(dre_result(&bus, req[0], &reply) == DRE_PENDING);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && sent_is(3u, 0x03E, "2089030000000000"));
    feed(0x03E, "2089030002000000");
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && reply.u.param.value.i == 2);
    CHECK(bus.traj_known == (1u << 1) && bus.traj_scurve == (1u << 1));

    /* every read-back differs: retries + 1 writes, then DRE_E_VERIFY with the value read */
    CHECK(dre_set_traj_mode(&m1, DRE_TRAJ_TRAPEZOID, req) == DRE_OK && bus_fake.nsent == 6u);
    feed(0x03E, "2089030002000000");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 8u && sent_is(6u, 0x03F, "2089030001000000") && sent_is(7u, 0x03E, "2089030000000000"));
    feed(0x03E, "2089030002000000");
    CHECK(dre_result(&bus, req[0], &reply) == DRE_E_VERIFY && reply.u.param.value.i == 2);
    bus_fake.now = 500u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 8u);

    /* the read after a rewrite has its timeout retries; the save follows once the value reads back */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_can_baud_rate(&m1, 1000000u, req) == DRE_OK);
    feed(0x03E, "0952030020A10700"); /* 500000 */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && sent_is(2u, 0x03F, "0952030040420F00") && sent_is(3u, 0x03E, "0952030000000000"));
    bus_fake.now = DRE_DEFAULT_TIMEOUT_MS;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 5u && sent_is(4u, 0x03E, "0952030000000000"));
    feed(0x03E, "0952030040420F00");
    CHECK(bus_fake.nsent == 6u && sent_is(5u, 0x028, "0100000000000000"));
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && bus.stats.timeouts == 0u);

    /* three writes: a limit read back wrong is written again before the next one is read, saved at the end */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_angle_range(&m1, -90.0f, 90.0f, 0.0f, req) == DRE_OK && bus_fake.nsent == 4u);
    feed(0x03E, "7A94000000000000"); /* 0, not -90 */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 6u && sent_is(4u, 0x03F, "7A9400000000B4C2") && sent_is(5u, 0x03E, "7A94000000000000"));
    feed(0x03E, "7A9400000000B4C2");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 7u && sent_is(6u, 0x03E, "7B94000000000000"));
    feed(0x03E, "7B9400000000B442");
    dre_bus_poll(&bus);
    feed(0x03E, "E279030001000000");
    CHECK(bus_fake.nsent == 9u && sent_is(8u, 0x028, "0100000000000000"));
    CHECK(dre_result(&bus, req[0], &reply) == DRE_OK && dre_result(&bus, req[1], &reply) == DRE_OK &&
          dre_result(&bus, req[2], &reply) == DRE_OK);

    /* dre_set_id's read at the new id is never a rewrite: another id there is DRE_E_VERIFY at once */
    setup();
    bus.cfg.retries = 1u;
    CHECK(dre_set_id(&m1, 1u, req) == DRE_OK);
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(1u, 0x03F, "1979030001000000") && sent_is(2u, 0x03E, "1979030000000000"));
    feed(0x03E, "1979030007000000");
    CHECK(dre_result(&bus, req[0], &reply) == DRE_E_VERIFY && bus_fake.nsent == 3u);
}

/* Request slots in use (the helper probe of set_id included). */
static unsigned busy_slots(void)
{
    unsigned i, n = 0u;
    for (i = 0u; i < sizeof slots / sizeof slots[0]; i++) {
        n += slots[i].state != 0u ? 1u : 0u;
    }
    return n;
}

/* set_id as the Python client: the current id must answer and the new one must not before the write. */
static void test_set_id(void)
{
    dre_motor m1 = {&bus, 1u}, m2 = {&bus, 2u}, m3 = {&bus, 3u}, m4 = {&bus, 4u}, all = {&bus, 0u};
    dre_req req, other[3];
    dre_msg reply;

    /* the whole way: both fast reads at once, the write once 5 stayed silent, the read at 5, the save there */
    setup();
    feed(0x03E, "2089030002000000"); /* motor 1 runs the S-curve (learned) */
    CHECK(bus.traj_known == (1u << 1));
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    CHECK(bus_fake.nsent == 2u && sent_is(0u, 0x03E, "0000000000000000") && sent_is(1u, 0x0BE, "0000000000000000"));
    CHECK(busy_slots() == 2u);
    feed(0x021, "0000000000000000"); /* motor 1 answers */
    bus_fake.now = 49u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING && bus_fake.nsent == 2u);
    bus_fake.now = 50u; /* nobody answers at 5 */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && sent_is(2u, 0x03F, "1979030005000000") && sent_is(3u, 0x0BE, "1979030000000000"));
    CHECK(busy_slots() == 1u && bus.traj_known == 0u);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    feed(0x0BE, "1979030005000000");
    CHECK(bus_fake.nsent == 5u && sent_is(4u, 0x0A8, "0100000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_OK && reply.node == 5u && reply.u.param.value.i == 5);
    CHECK(bus.stats.timeouts == 0u && busy_slots() == 0u);

    /* a motor at the new id: refused at once, nothing written, the other probe dropped */
    setup();
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    feed(0x0A1, "0000B44200000000"); /* motor 5 answers (motor 1 does not: a taken id is reported first) */
    CHECK(dre_result(&bus, req, &reply) == DRE_E_ID_TAKEN && reply.type == DRE_MSG_STATE && reply.node == 5u &&
          reply.u.state.position == 90.0f);
    CHECK(busy_slots() == 0u);
    feed(0x021, "0000000000000000"); /* motor 1, late: answers nothing */
    CHECK(bus_fake.nunmatched == 1u);
    bus_fake.now = 100u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u);

    /* no motor at the current id: refused once the new id's read has timed out, nothing written */
    setup();
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_NO_MOTOR && bus_fake.nsent == 2u && busy_slots() == 0u);
    bus_fake.now = 200u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u);

    /* the current id busy: its read waits its turn, and the write waits for its answer */
    setup();
    CHECK(dre_get_state(&m1, &other[0]) == DRE_OK);
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK && bus_fake.nsent == 2u && sent_is(1u, 0x0BE, "0000000000000000"));
    bus_fake.now = 30u;
    feed(0x021, "0000000000000000");
    CHECK(dre_result(&bus, other[0], &reply) == DRE_OK);
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(2u, 0x03E, "0000000000000000"));
    bus_fake.now = 50u; /* 5 is free, 1 has not answered yet */
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && dre_result(&bus, req, &reply) == DRE_PENDING);
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 5u && sent_is(3u, 0x03F, "1979030005000000") && sent_is(4u, 0x0BE, "1979030000000000"));
    /* after the write: no answer at the new id, or another id reported: nothing saved */
    bus_fake.now = 100u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_TIMEOUT && bus_fake.nsent == 5u);
    CHECK(dre_get_state(&m1, &other[0]) == DRE_OK);
    CHECK(dre_set_id(&m1, 6u, &req) == DRE_OK && bus_fake.nsent == 7u); /* 1 busy again: only 6 is read */
    feed(0x021, "0000000000000000");
    CHECK(dre_result(&bus, other[0], &reply) == DRE_OK);
    dre_bus_poll(&bus); /* the read of 1 goes out now */
    feed(0x021, "0000000000000000");
    bus_fake.now = 150u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 10u && sent_is(8u, 0x03F, "1979030006000000"));
    feed(0x0DE, "1979030001000000"); /* the motor at 6 says 1 */
    CHECK(dre_result(&bus, req, &reply) == DRE_E_VERIFY && reply.u.param.value.i == 1 && bus_fake.nsent == 10u);
    /* the current id answering while the new one's read is still due: the write waits for that read */
    CHECK(dre_set_id(&m1, 7u, &req) == DRE_OK && bus_fake.nsent == 12u);
    bus_fake.now = 160u;
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 12u);
    bus_fake.now = 200u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 14u && sent_is(12u, 0x03F, "1979030007000000"));
    dre_cancel(&bus, req);
    CHECK(busy_slots() == 0u);

    /* the id it already has: only its own read, which must be answered */
    setup();
    CHECK(dre_set_id(&m1, 1u, &req) == DRE_OK && bus_fake.nsent == 1u && sent_is(0u, 0x03E, "0000000000000000"));
    CHECK(busy_slots() == 1u);
    feed(0x021, "0000000000000000");
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 3u && sent_is(1u, 0x03F, "1979030001000000") && sent_is(2u, 0x03E, "1979030000000000"));
    feed(0x03E, "1979030001000000");
    CHECK(bus_fake.nsent == 4u && sent_is(3u, 0x028, "0100000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_OK);
    CHECK(dre_set_id(&m1, 1u, &req) == DRE_OK);
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_NO_MOTOR && bus_fake.nsent == 5u);

    /* broadcast: any motor answering at 0 will do; the write goes to 0, the save to the new id */
    setup();
    CHECK(dre_set_id(&all, 7u, &req) == DRE_OK);
    CHECK(sent_is(0u, 0x01E, "0000000000000000") && sent_is(1u, 0x0FE, "0000000000000000"));
    feed(0x061, "0000000000000000"); /* motor 3 */
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && sent_is(2u, 0x01F, "1979030007000000") && sent_is(3u, 0x0FE, "1979030000000000"));
    feed(0x0FE, "1979030007000000");
    CHECK(bus_fake.nsent == 5u && sent_is(4u, 0x0E8, "0100000000000000"));
    CHECK(dre_result(&bus, req, &reply) == DRE_OK);

    /* cancelled during the reads: both slots are freed, nothing is written */
    setup();
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    feed(0x021, "0000000000000000");
    dre_cancel(&bus, req);
    CHECK(busy_slots() == 0u);
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && dre_result(&bus, req, &reply) == DRE_E_ARG);

    /* refusals send nothing; two free slots are needed, one for the id it has */
    setup();
    CHECK(dre_set_id(&m1, 64u, &req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE);
    CHECK(dre_set_id(&m1, 0u, &req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE);
    {
        dre_motor bad = {&bus, 64u};
        CHECK(dre_set_id(&bad, 5u, &req) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_NODE);
    }
    CHECK(dre_get_state(&m2, &other[0]) == DRE_OK && dre_get_state(&m3, &other[1]) == DRE_OK &&
          dre_get_state(&m4, &other[2]) == DRE_OK);
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_E_BUSY && bus_fake.nsent == 3u && busy_slots() == 3u);
    CHECK(dre_set_id(&m1, 1u, &req) == DRE_OK && bus_fake.nsent == 4u);
    setup();
    bus_fake.fail_from = 0;
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_E_SEND && busy_slots() == 0u);

    /* the write not sent: DRE_E_SEND, and nothing was written */
    setup();
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    feed(0x021, "0000000000000000");
    bus_fake.fail_from = 2;
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_SEND && bus_fake.nsent == 2u && busy_slots() == 0u);
    CHECK(reply.type != DRE_MSG_PARAM_VALUE);
    /* the save not sent: DRE_E_SEND with the id read back, changed but not saved */
    setup();
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK);
    feed(0x021, "0000000000000000");
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    bus_fake.fail_from = 4;
    feed(0x0BE, "1979030005000000");
    CHECK(dre_result(&bus, req, &reply) == DRE_E_SEND && bus_fake.nsent == 4u);
    CHECK(reply.type == DRE_MSG_PARAM_VALUE && reply.u.param.value.i == 5);

    /* with tx_free: room for the reads at once, and later for the write and its read together */
    setup_with(DRE_START_TO_AUTO, 1, 0);
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_E_BUSY && bus_fake.nsent == 0u);
    bus_fake.room = 2;
    CHECK(dre_set_id(&m1, 5u, &req) == DRE_OK && bus_fake.nsent == 2u);
    feed(0x021, "0000000000000000");
    bus_fake.room = 1;
    bus_fake.now = 50u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 2u && dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.room = 2;
    bus_fake.now = 60u;
    dre_bus_poll(&bus);
    CHECK(bus_fake.nsent == 4u && sent_is(2u, 0x03F, "1979030005000000"));
    dre_cancel(&bus, req);
    bus_fake.room = 1;
    CHECK(dre_set_id(&m1, 1u, &req) == DRE_OK);
    feed(0x021, "0000000000000000");
    bus_fake.now = 109u;
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_PENDING);
    bus_fake.now = 110u; /* no room for a whole timeout */
    dre_bus_poll(&bus);
    CHECK(dre_result(&bus, req, &reply) == DRE_E_SEND && bus_fake.nsent == 5u);
}

/* Modes and states take only the values of their enums, as in the Python client; refusals name the parameter. */
static void test_mode_params(void)
{
    dre_motor m1 = {&bus, 1u}, all = {&bus, 0u};
    dre_value v;
    dre_msg w;
    uint8_t lo = 0xFFu, hi = 0xFFu;

    setup();
    v.i = 11; /* in AxisState, outside the soft domain {1, 8}: an expert forces it */
    CHECK(dre_write_property_forced(&m1, 30003u, DRE_U32, v) == DRE_OK && sent_is(0u, 0x03F, "337503000B000000"));
    v.i = 4;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONTROLLER_CONFIG_CONTROL_MODE, v) == DRE_OK &&
          sent_is(1u, 0x03F, "697D030004000000"));
    v.i = 7;
    CHECK(dre_write_property(&all, 32106u, DRE_U32, v) == DRE_OK && sent_is(2u, 0x01F, "6A7D030007000000"));
    v.i = 2;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, v) == DRE_OK &&
          sent_is(3u, 0x03F, "2089030002000000"));
    CHECK(bus_fake.nsent == 4u);

    v.i = 12;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_REQUESTED_STATE, v) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE &&
          bus.bad_address == 30003u && bus.bad_index == 0u);
    v.i = -1;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_REQUESTED_STATE, v) == DRE_E_RANGE);
    v.i = 5;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONTROLLER_CONFIG_CONTROL_MODE, v) == DRE_E_RANGE &&
          bus.bad_address == 32105u);
    v.i = 8;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONTROLLER_CONFIG_INPUT_MODE, v) == DRE_E_RANGE &&
          bus.bad_address == 32106u);
    CHECK(dre_write_property(&m1, 32106u, DRE_U16, v) == DRE_E_RANGE && bus.bad_address == 32106u);
    v.i = 0;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, v) == DRE_E_RANGE &&
          bus.bad_address == 35104u);
    v.i = 3;
    CHECK(dre_write_property(&all, 35104u, DRE_S32, v) == DRE_E_RANGE && bus.bad_address == 35104u);
    v.i = 0;
    v.f32 = 1.0f; /* the sets are integers */
    CHECK(dre_write_property(&m1, 35104u, DRE_F32, v) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_DTYPE &&
          bus.bad_address == 35104u);
    /* dre_send checks a raw write the same way */
    memset(&w, 0, sizeof w);
    w.type = DRE_MSG_WRITE_PARAM;
    w.node = 1u;
    w.u.param.address = 30003u;
    w.u.param.dtype = DRE_U32;
    w.u.param.value.i = 12;
    CHECK(dre_send(&bus, &w) == DRE_E_RANGE && bus.bad_address == 30003u);
    w.u.param.value.i = 8;
    CHECK(dre_send(&bus, &w) == DRE_OK && sent_is(4u, 0x03F, "3375030008000000"));
    CHECK(bus_fake.nsent == 5u && bus.traj_known == (1u << 1)); /* refused writes teach nothing */
    /* any other refusal leaves no parameter named */
    CHECK(dre_set_angle(&m1, 0.0f, 0.0f, 5.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_address == 0u);

    CHECK(dre_param_choices(30003u, &lo, &hi) == 1 && lo == 0u && hi == 11u);
    CHECK(dre_param_choices(32105u, &lo, &hi) == 1 && lo == 0u && hi == 4u);
    CHECK(dre_param_choices(32106u, &lo, &hi) == 1 && lo == 0u && hi == 7u);
    CHECK(dre_param_choices(35104u, &lo, &hi) == 1 && lo == 1u && hi == 2u);
    CHECK(dre_param_choices(31001u, &lo, &hi) == 0 && dre_param_choices(0u, &lo, &hi) == 0);
}

/* Writes outside a parameter's domain (spec/parameters.csv) are refused, naming it; force passes soft bounds only. */
static void test_param_domains(void)
{
    dre_motor m1 = {&bus, 1u};
    dre_value v;
    const dre_param_domain *d;

    setup();
    v.i = 64;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, v) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_VALUE &&
          bus.bad_address == 31001u);
    v.i = 0;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, v) == DRE_E_RANGE);
    CHECK(dre_write_property_forced(&m1, 31001u, DRE_U32, v) == DRE_E_RANGE); /* hard: never */
    v.i = 3;                                                                   /* a calibration state */
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_REQUESTED_STATE, v) == DRE_E_RANGE && bus.bad_address == 30003u);
    v.f32 = 1e30f;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONTROLLER_CONFIG_POS_GAIN, v) == DRE_E_RANGE && bus.bad_address == 32108u);
    v.f32 = -5.0f;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT, v) == DRE_E_RANGE);
    v.f32 = NAN;
    CHECK(dre_write_property_forced(&m1, 32108u, DRE_F32, v) == DRE_E_RANGE);
    v.i = 123456;
    CHECK(dre_write_param(&m1, DRE_P_CAN_CONFIG_BAUD_RATE, v) == DRE_E_RANGE &&
          dre_write_property_forced(&m1, 21001u, DRE_U32, v) == DRE_E_RANGE);
    CHECK(bus_fake.nsent == 0u);

    /* force: outside a soft bound, sent as given */
    v.f32 = 1e30f;
    CHECK(dre_write_property_forced(&m1, 32108u, DRE_F32, v) == DRE_OK && sent_is(0u, 0x03F, "6C7D0000CAF24971"));
    v.i = 3;
    CHECK(dre_write_property_forced(&m1, 30003u, DRE_U32, v) == DRE_OK && sent_is(1u, 0x03F, "3375030003000000"));
    v.f32 = -5.0f;
    CHECK(dre_write_property_forced(&m1, 31209u, DRE_F32, v) == DRE_OK && sent_is(2u, 0x03F, "E97900000000A0C0"));
    /* at the bounds: sent */
    v.i = 63;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, v) == DRE_OK && bus_fake.nsent == 4u);
    v.f32 = 0.0f;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_EXTRA_SETTING_STALL_CURRENT_LIMIT, v) == DRE_OK);
    CHECK(bus_fake.nsent == 5u);

    d = dre_param_domain_of(31001u);
    CHECK(d != NULL && d->flags == (DRE_PD_MIN | DRE_PD_MAX | DRE_PD_HARD) && d->lo == 1.0f && d->hi == 63.0f);
    d = dre_param_domain_of(30003u);
    CHECK(d != NULL && (d->flags & DRE_PD_SET) != 0u && d->count == 2u && dre_param_allowed[d->first] == 1.0f &&
          dre_param_allowed[d->first + 1u] == 8.0f);
    d = dre_param_domain_of(32108u);
    CHECK(d != NULL && (d->flags & (DRE_PD_HARD | DRE_PD_INFERRED)) == DRE_PD_INFERRED);
    CHECK(dre_param_domain_of(38023u) == NULL && dre_param_domain_of(1u) == NULL); /* signed setpoint; read-only */
}

static void test_step_angle(void)
{
    dre_motor m2 = {&bus, 2u};

    setup();
    CHECK(dre_step_angle(&m2, 30.0f, 10.0f, 20.0f, DRE_ANGLE_P) == DRE_OK);
    CHECK(bus_fake.nsent == 2u && sent_is(0u, 0x04C, "0000F041E803D007") && sent_is(1u, 0x048, "1200000001000000"));
    /* Q: |delta| sets the time; 90 deg at 10 r/min, 20 (r/min)/s = 2.0 s */
    CHECK(dre_step_angle(&m2, -90.0f, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_OK);
    CHECK(sent_is(2u, 0x04C, "0000B4C2C800D007") && sent_is(3u, 0x048, "1100000001000000"));
    CHECK(dre_step_angle(&m2, NAN, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_POSITION);
}

static void test_position_done(void)
{
    static const uint8_t ids[2] = {1u, 2u};
    dre_motor m1 = {&bus, 1u};
    dre_done d, dd[2];

    setup();
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 1u);
    CHECK(sent_is(0u, 0x03E, "0000000000000000"));
    feed(0x021, "0000A04100000000"); /* moving, at 20 deg */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && d.state.u.state.position == 20.0f);
    CHECK(bus_fake.nsent == 1u); /* the next read waits for the poll interval */
    bus_fake.now = DRE_POLL_INTERVAL_MS;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 2u);
    feed(0x023, "0000B44200000000"); /* T bit: done at 90 deg */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK && d.state.u.state.position == 90.0f);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK && bus_fake.nsent == 2u);

    /* an error bit ends the wait at once */
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 0u) == DRE_PENDING);
    feed(0x025, "0000000000000000");
    CHECK(dre_position_done(&m1, &d, 0u) == DRE_E_FAULT && d.phase == 0u);
    /* an unanswered fast read, and the overall limit */
    CHECK(dre_position_done(&m1, &d, 0u) == DRE_PENDING);
    bus_fake.now += 50u;
    dre_bus_poll(&bus);
    CHECK(dre_position_done(&m1, &d, 0u) == DRE_E_TIMEOUT);
    CHECK(dre_position_done(&m1, &d, 100u) == DRE_PENDING);
    bus_fake.now += 100u;
    CHECK(dre_position_done(&m1, &d, 100u) == DRE_E_TIMEOUT);
    CHECK(dre_result(&bus, d.req, &d.state) == DRE_E_ARG); /* its read was cancelled */

    /* several motors: done when all are; a fault names the motor */
    setup();
    memset(dd, 0, sizeof dd);
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_PENDING && bus_fake.nsent == 2u);
    feed(0x023, "0000000000000000");
    feed(0x041, "0000000000000000");
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_PENDING);
    bus_fake.now = 20u;
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_PENDING && bus_fake.nsent == 3u &&
          sent_is(2u, 0x05E, "0000000000000000"));
    feed(0x043, "0000000000000000");
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_OK);
    memset(dd, 0, sizeof dd);
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_PENDING);
    feed(0x045, "0000000000000000");
    CHECK(dre_positions_done(&bus, 2u, ids, dd, 0u) == DRE_E_FAULT && bus.bad_index == 1u);
    CHECK(dre_positions_done(&bus, 0u, ids, dd, 0u) == DRE_E_ARG);
}

/* dre_positions_done with the moves the bus commanded (the Python client's rules). */
static void test_move_done_rules(void)
{
    dre_motor m1 = {&bus, 1u};
    dre_done d;

    /* a T = 1 state before the motor showed it took the move does not end the wait */
    setup();
    CHECK(dre_set_angle(&m1, 90.0f, 10.0f, 20.0f, DRE_ANGLE_T) == DRE_OK);
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 2u);
    bus_fake.now = 2u;
    feed(0x023, "0000000000000000"); /* T = 1 at 0 deg: the old move's end */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 11u;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 2u); /* 10 ms after the answer */
    bus_fake.now = 12u;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 3u);
    bus_fake.now = 13u;
    feed(0x021, "0000344200000000"); /* T = 0 at 45 deg: it took the move */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 23u;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING && bus_fake.nsent == 4u);
    bus_fake.now = 24u;
    feed(0x023, "0000B44200000000"); /* T = 1 at 90 deg */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK && d.state.u.state.position == 90.0f);

    /* at the target, T = 1 ends the wait without a T = 0 seen; off the target it is DRE_E_MOVE */
    CHECK(dre_set_angle(&m1, 90.0f, 10.0f, 20.0f, DRE_ANGLE_T) == DRE_OK);
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 25u;
    feed(0x023, "CDCCB34200000000"); /* 89.9 deg */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK);
    CHECK(dre_set_angle(&m1, 90.0f, 10.0f, 20.0f, DRE_ANGLE_T) == DRE_OK);
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 26u;
    feed(0x021, "0000204200000000"); /* T = 0 */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 36u;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 37u;
    feed(0x023, "0000A04200000000"); /* T = 1 at 80 deg */
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_E_MOVE && bus.bad_index == 0u && d.phase == 0u);
    CHECK(d.state.u.state.position == 80.0f);

    /* a velocity command ends the record: the first T = 1 state ends the wait */
    CHECK(dre_set_speed(&m1, 10.0f, 0.0f, DRE_VEL_PASSTHROUGH) == DRE_OK);
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 38u;
    feed(0x023, "0000000000000000");
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK);

    /* a relative move (target unknown) needs the T = 0 sign */
    CHECK(dre_step_angle(&m1, 30.0f, 10.0f, 20.0f, DRE_ANGLE_T) == DRE_OK);
    memset(&d, 0, sizeof d);
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 39u;
    feed(0x023, "0000F04100000000");
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    feed(0x021, "0000F04100000000"); /* a T = 0 state (reply-state on) */
    bus_fake.now = 49u;
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_PENDING);
    bus_fake.now = 50u;
    feed(0x023, "0000F04100000000");
    CHECK(dre_position_done(&m1, &d, 1000u) == DRE_OK && d.state.u.state.position == 30.0f);
}

static int near(float a, float b)
{
    return fabsf(a - b) < 1e-5f;
}

static void test_q_move_time(void)
{
    float t = -1.0f;

    CHECK(dre_q_move_time(90.0f, 10.0f, 20.0f, DRE_TRAJ_TRAPEZOID, &t) == DRE_OK && near(t, 2.0f));
    CHECK(dre_q_move_time(180.0f, 10.0f, 20.0f, 0u, &t) == DRE_OK && near(t, 3.5f));
    CHECK(dre_q_move_time(15.0f, 10.0f, 20.0f, DRE_TRAJ_TRAPEZOID, &t) == DRE_OK && near(t, 0.70710678f));
    CHECK(dre_q_move_time(180.0f, 10.0f, 20.0f, DRE_TRAJ_S_CURVE, &t) == DRE_OK && near(t, 4.0f));
    CHECK(dre_q_move_time(30.0f, 10.0f, 20.0f, DRE_TRAJ_S_CURVE, &t) == DRE_OK && near(t, 1.41421356f));
    CHECK(dre_q_move_time(0.0f, 10.0f, 20.0f, DRE_TRAJ_S_CURVE, &t) == DRE_OK && t == 0.0f);
    CHECK(dre_q_move_time(10.0f, 0.0f, 20.0f, DRE_TRAJ_TRAPEZOID, &t) == DRE_E_RANGE);
    CHECK(dre_q_move_time(10.0f, 10.0f, INFINITY, DRE_TRAJ_TRAPEZOID, &t) == DRE_E_RANGE);
    CHECK(dre_q_move_time(-1.0f, 10.0f, 20.0f, DRE_TRAJ_TRAPEZOID, &t) == DRE_E_RANGE);
    CHECK(dre_q_move_time(NAN, 10.0f, 20.0f, DRE_TRAJ_TRAPEZOID, &t) == DRE_E_RANGE);
    CHECK(dre_q_move_time(10.0f, 10.0f, 20.0f, 3u, &t) == DRE_E_RANGE);
}

int main(void)
{
    test_get_state();
    test_read_matching();
    test_dtype_echo();
    test_zero_reply_grace();
    test_oldest_first_and_broadcast();
    test_timeouts();
    test_retries();
    test_poll_reads_tick_first();
    test_slots_and_send_failure();
    test_one_request_per_motor();
    test_isr_queue();
    test_init();
    test_single_motor_commands();
    test_t_mode_bandwidth();
    test_speed_torque_params();
    test_batches();
    test_q_batch_time();
    test_q_non_finite();
    test_batch_ids();
    test_impedance();
    test_preset_start();
    test_tx_room();
    test_txq();
    test_stale_presets();
    test_start_after_presets();
    test_reads();
    test_verified_writes();
    test_verified_rewrites();
    test_set_id();
    test_mode_params();
    test_param_domains();
    test_step_angle();
    test_position_done();
    test_q_move_time();
    test_move_done_rules();
    return check_report("test_client");
}
