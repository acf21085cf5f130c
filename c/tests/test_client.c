/* The client layer against a scripted fake bus: requests, timeouts, matching, batches. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "drempower/dre_client.h"

/* ------------------------------------------------------------------ fake bus */

typedef struct {
    dre_frame sent[32];
    unsigned nsent;
    int fail_from; /* sends from this index on fail; -1 = never */
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
    if (k->nsent < 32u) {
        k->sent[k->nsent] = *f;
    }
    k->nsent++;
    return 0;
}

static uint32_t fake_tick(void *user)
{
    return ((fake *)user)->now;
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
static dre_request slots[4];
static dre_frame rxq[4];

static void setup(void)
{
    dre_bus_config cfg;
    memset(&bus_fake, 0, sizeof bus_fake);
    bus_fake.fail_from = -1;
    memset(&cfg, 0, sizeof cfg);
    cfg.send = fake_send;
    cfg.tick = fake_tick;
    cfg.user = &bus_fake;
    cfg.on_unmatched = fake_unmatched;
    CHECK(dre_bus_init(&bus, &cfg, slots, 4u, rxq, 4u) == DRE_OK);
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
    feed(0x03E, "010000000000803F"); /* 1.0 V */
    CHECK(dre_result(&bus, a, &reply) == DRE_OK && reply.u.param.value.f32 == 1.0f);
    CHECK(dre_result(&bus, b, &reply) == DRE_PENDING);
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

static void test_slots_and_send_failure(void)
{
    dre_motor m = {&bus, 1u};
    dre_req reqs[5], old;
    dre_msg reply;
    unsigned i;

    setup();
    for (i = 0u; i < 4u; i++) {
        CHECK(dre_get_state(&m, &reqs[i]) == DRE_OK);
    }
    CHECK(dre_get_state(&m, &reqs[4]) == DRE_E_BUSY && bus_fake.nsent == 4u);
    dre_cancel(&bus, reqs[2]);
    CHECK(dre_result(&bus, reqs[2], &reply) == DRE_E_ARG);
    CHECK(dre_get_state(&m, &reqs[4]) == DRE_OK);

    /* a handle of a finished request does not reach the request now using its slot */
    old = reqs[2];
    CHECK((reqs[4] & 0xFFu) == (old & 0xFFu) && reqs[4] != old);
    CHECK(dre_result(&bus, old, &reply) == DRE_E_ARG && dre_result(&bus, reqs[4], &reply) == DRE_PENDING);

    setup();
    bus_fake.fail_from = 0;
    for (i = 0u; i < 6u; i++) {
        CHECK(dre_get_state(&m, &reqs[0]) == DRE_E_SEND); /* never takes a slot */
    }
    bus_fake.fail_from = -1;
    CHECK(dre_get_state(&m, &reqs[0]) == DRE_OK);
    CHECK(dre_result(&bus, 0u, &reply) == DRE_E_ARG && dre_result(&bus, 0xFFFFFFFFu, &reply) == DRE_E_ARG);
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
    CHECK(dre_set_id(&m1, 5u) == DRE_OK && sent_is(14u, 0x03F, "1979030005000000") &&
          sent_is(15u, 0x0A8, "0100000000000000"));
    v.i = 1;
    CHECK(dre_write_param(&m1, DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE, v) == DRE_OK &&
          sent_is(16u, 0x03F, "EE79030001000000"));
    v.f32 = -1.5f;
    CHECK(dre_write_property(&m2, 38012u, DRE_F32, v) == DRE_OK && sent_is(17u, 0x05F, "7C9400000000C0BF"));
    CHECK(bus_fake.nsent == 18u);

    /* refusals send nothing and name the field */
    CHECK(dre_set_angle(&m1, 0.0f, 0.0f, 5.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_SPEED);
    CHECK(dre_set_angle(&m1, 0.0f, 5.0f, -1.0f, DRE_ANGLE_Q) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_ACCEL);
    CHECK(dre_set_angle(&m1, 0.0f, 5.0f, 1.0f, 3u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_angle(&m1, NAN, 5.0f, 1.0f, DRE_ANGLE_T) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_POSITION);
    CHECK(dre_set_speed(&m1, 1.0f, 400.0f, DRE_VEL_RAMP) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_PARAM);
    CHECK(dre_set_torque(&m1, 1.0f, 0.0f, 2u) == DRE_E_RANGE && bus.bad_field == DRE_FIELD_MODE);
    CHECK(dre_set_mode(&m1, 3u) == DRE_E_RANGE);
    CHECK(dre_set_id(&m1, 64u) == DRE_E_RANGE && dre_set_id(&m1, 0u) == DRE_E_RANGE);
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
    CHECK(bus_fake.nsent == 18u);

    bus_fake.fail_from = 18;
    CHECK(dre_estop(&m1) == DRE_E_SEND);
}

/* ------------------------------------------------------------------ several motors */

static void test_batches(void)
{
    static const uint8_t ids[3] = {1u, 2u, 3u};
    const float angles[3] = {90.0f, -90.0f, 0.0f}, from[3] = {0.0f, 0.0f, 0.0f};
    const float speeds[1] = {10.0f}, torques[1] = {3.0f};
    float bad_angles[3] = {1.0f, 2.0f, 0.0f};
    dre_motor m1 = {&bus, 1u};

    setup();
    /* PROTOCOL.md 1.7: set_angles([1,2],[90,-90],10,20,1) from 0 deg gives T = 2.0 s */
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

    /* validation happens before anything is sent */
    bad_angles[2] = NAN;
    CHECK(dre_set_angles(&bus, 3u, ids, bad_angles, NULL, 5.0f, 50.0f, DRE_ANGLE_T) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_POSITION && bus.bad_index == 2u);
    CHECK(dre_set_angles(&bus, 3u, ids, angles, NULL, 400.0f, 0.0f, DRE_ANGLE_P) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_SPEED_FF && bus.bad_index == 0u);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, NULL, 10.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_ARG);
    CHECK(dre_set_angles(&bus, 2u, ids, angles, from, 0.0f, 20.0f, DRE_ANGLE_Q) == DRE_E_RANGE);
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
    CHECK(dre_impedance_control(&m1, 0.0f, 0.0f, 0.0f, 1000.0f, 0.0f) == DRE_E_RANGE);
    CHECK(bus.bad_field == DRE_FIELD_KP && bus.bad_index == 1u); /* index n: the start frame */
    CHECK(bus_fake.nsent == 18u);

    /* a failed send stops the batch before the start */
    bus_fake.fail_from = 19;
    CHECK(dre_set_angles(&bus, 3u, ids, angles, NULL, 5.0f, 50.0f, DRE_ANGLE_T) == DRE_E_SEND);
    CHECK(bus_fake.nsent == 19u && bus_fake.sent[18].id == 0x02C);
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
    CHECK(bus_fake.nsent == 3u);
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
    test_oldest_first_and_broadcast();
    test_timeouts();
    test_slots_and_send_failure();
    test_isr_queue();
    test_init();
    test_single_motor_commands();
    test_batches();
    test_preset_start();
    test_q_move_time();
    return check_report("test_client");
}
