/* dre_health.h: the five-read health reading (golden frames), and the heap-free supervisor step. */
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "drempower/dre.h"

typedef struct {
    dre_frame sent[16];
    unsigned nsent;
    uint32_t now;
} fake;

static int fake_send(void *user, const dre_frame *f)
{
    fake *k = (fake *)user;
    if (k->nsent < 16u) {
        k->sent[k->nsent] = *f;
    }
    k->nsent++;
    return 0;
}

static uint32_t fake_tick(void *user)
{
    return ((fake *)user)->now;
}

static fake bus_fake;
static dre_bus bus;
static dre_request slots[8];
static dre_frame rxq[4];

static void setup(void)
{
    dre_bus_config cfg;
    memset(&bus_fake, 0, sizeof bus_fake);
    memset(&cfg, 0, sizeof cfg);
    cfg.send = fake_send;
    cfg.tick = fake_tick;
    cfg.user = &bus_fake;
    CHECK(dre_bus_init(&bus, &cfg, slots, 8u, rxq, 4u) == DRE_OK);
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

static int sent_is(unsigned i, uint16_t id, const char *hex)
{
    dre_frame want = frame_of(id, hex);
    return i < bus_fake.nsent && bus_fake.sent[i].id == id && memcmp(bus_fake.sent[i].data, want.data, 8u) == 0;
}

static void feed(uint16_t id, const char *hex)
{
    dre_frame f = frame_of(id, hex);
    CHECK(dre_bus_feed(&bus, &f) == DRE_OK);
}

/* Five reads of motor 1 in one exchange, their replies, the reading. */
static void test_read_health(void)
{
    dre_motor m = {&bus, 1u};
    dre_req req[DRE_HEALTH_READS];
    dre_msg replies[DRE_HEALTH_READS];
    dre_health h;
    unsigned i;
    static const char *const asked[DRE_HEALTH_READS] = {
        "8A90000000000000", /* 37002 motor_thermistor.temperature, f32 */
        "A28C000000000000", /* 36002 fet_thermistor.temperature */
        "EB80000000000000", /* 33003 motor.effective_current_lim */
        "5681000000000000", /* 33110 motor.config.current_lim */
        "3175030000000000"  /* 30001 axis0.error, u32 */
    };
    static const char *const answers[DRE_HEALTH_READS] = {
        "8A9000000000C342", /* 97.5 degC */
        "A28C000000004842", /* 50.0 degC */
        "EB8000000000F040", /* 7.5 A */
        "5681000000007041", /* 15.0 A */
        "3175030000000000"  /* no error */
    };

    setup();
    CHECK(dre_read_health(&m, req) == DRE_OK);
    /* queued together; the bus keeps one read of a motor in flight, so each goes out when the last is answered */
    for (i = 0u; i < DRE_HEALTH_READS; i++) {
        CHECK(bus_fake.nsent == i + 1u && sent_is(i, 0x03E, asked[i]));
        feed(0x03E, answers[i]);
        dre_bus_poll(&bus);
    }
    CHECK(bus_fake.nsent == DRE_HEALTH_READS);
    for (i = 0u; i < DRE_HEALTH_READS; i++) {
        CHECK(dre_result(&bus, req[i], &replies[i]) == DRE_OK);
    }
    CHECK(dre_health_from(replies, &h) == DRE_OK);
    CHECK(h.motor_temp_c == 97.5f && h.driver_temp_c == 50.0f);
    CHECK(h.current_limit_a == 7.5f && h.configured_limit_a == 15.0f && h.axis_error == 0u);
    CHECK(dre_health_derating(&h) == 0.5f);
    replies[2].u.param.address = 33110u; /* a reply of another parameter in its place */
    CHECK(dre_health_from(replies, &h) == DRE_E_ARG);
}

static dre_health reading(float motor_c, float limit_a, uint32_t axis_error)
{
    dre_health h;
    h.motor_temp_c = motor_c;
    h.driver_temp_c = 30.0f;
    h.current_limit_a = limit_a;
    h.configured_limit_a = 15.0f;
    h.axis_error = axis_error;
    return h;
}

/* Warn at 80, act (idle) at 90, before the firmware derates at 95; each condition reported once. */
static void test_step_warns_then_acts_before_the_derating(void)
{
    dre_health_policy p;
    dre_health_watch w;
    dre_health_verdict v;
    dre_health h;

    dre_health_policy_init(&p, 1.0f, 12.0f);
    p.on_overheat = (uint8_t)DRE_ON_IDLE;
    memset(&w, 0, sizeof w);
    h = reading(79.9f, 15.0f, 0u);
    dre_health_step(&w, &p, &h, NULL, 0u, &v);
    CHECK(v.began == 0u && v.active == 0u && v.action == DRE_ON_WARN);
    h = reading(80.0f, 15.0f, 0u);
    dre_health_step(&w, &p, &h, NULL, 1000u, &v);
    CHECK(v.began == DRE_HEALTH_HOT && v.action == DRE_ON_WARN);
    h = reading(85.0f, 15.0f, 0u);
    dre_health_step(&w, &p, &h, NULL, 2000u, &v);
    CHECK(v.began == 0u && v.active == DRE_HEALTH_HOT);
    h = reading(90.0f, 15.0f, 0u);
    dre_health_step(&w, &p, &h, NULL, 3000u, &v);
    CHECK(v.began == DRE_HEALTH_OVERHEAT && v.action == DRE_ON_IDLE);
    h = reading(89.0f, 15.0f, 0u); /* cooling: "hot" again is no news */
    dre_health_step(&w, &p, &h, NULL, 4000u, &v);
    CHECK(v.began == 0u && v.active == DRE_HEALTH_HOT && v.action == DRE_ON_WARN);
    h = reading(96.0f, 12.0f, 0u);
    dre_health_step(&w, &p, &h, NULL, 5000u, &v);
    CHECK(v.began == DRE_HEALTH_DERATING && v.action == DRE_ON_IDLE);
    h = reading(101.0f, 0.0f, 0x40000u); /* AXIS_ERROR_OVER_TEMP */
    dre_health_step(&w, &p, &h, NULL, 6000u, &v);
    CHECK(v.began == DRE_HEALTH_FAULT && (v.active & DRE_HEALTH_DERATING) != 0u && v.action == DRE_ON_WARN);
}

static dre_msg state_of(float torque, uint8_t done)
{
    dre_msg s;
    memset(&s, 0, sizeof s);
    s.type = DRE_MSG_STATE;
    s.node = 1u;
    s.u.state.torque = torque;
    s.u.state.trajectory_done = done;
    return s;
}

/* The torque at 95 % of its limit with the target not reached for stall_ms: a stall, held. */
static void test_step_catches_a_stall(void)
{
    dre_health_policy p;
    dre_health_watch w;
    dre_health_verdict v;
    dre_health h = reading(40.0f, 15.0f, 0u);
    dre_msg pinned = state_of(-11.5f, 0u), free_ = state_of(3.0f, 0u), done = state_of(-11.9f, 1u);

    dre_health_policy_init(&p, 1.0f, 12.0f); /* 12 Nm: torque_lim below 15 A x 1 Nm/A */
    p.on_stall = (uint8_t)DRE_ON_HOLD;
    memset(&w, 0, sizeof w);
    dre_health_step(&w, &p, &h, &pinned, 100u, &v);
    CHECK(v.began == 0u);
    dre_health_step(&w, &p, &h, &pinned, 1099u, &v);
    CHECK(v.began == 0u);
    dre_health_step(&w, &p, &h, &pinned, 1100u, &v);
    CHECK(v.began == DRE_HEALTH_STALL && v.action == DRE_ON_HOLD);
    dre_health_step(&w, &p, &h, &pinned, 1200u, &v);
    CHECK(v.began == 0u && v.active == DRE_HEALTH_STALL && v.action == DRE_ON_WARN);
    dre_health_step(&w, &p, &h, &free_, 1300u, &v); /* the torque let go: the count starts again */
    CHECK(v.active == 0u);
    dre_health_step(&w, &p, &h, &pinned, 1400u, &v);
    dre_health_step(&w, &p, &h, &pinned, 2300u, &v);
    CHECK(v.active == 0u);
    dre_health_step(&w, &p, &h, &done, 2500u, &v); /* at its target: pushing there is no stall */
    CHECK(v.active == 0u);
    h = reading(97.0f, 6.0f, 0u); /* derated to 6 A: 5.8 Nm is at the limit now */
    pinned = state_of(5.8f, 0u);
    dre_health_step(&w, &p, &h, &pinned, 3000u, &v);
    dre_health_step(&w, &p, &h, &pinned, 4000u, &v);
    CHECK((v.active & DRE_HEALTH_STALL) != 0u);
}

static void test_act_sends_idle_or_speed_zero(void)
{
    dre_motor m = {&bus, 1u};
    setup();
    CHECK(dre_health_act(&m, DRE_ON_WARN) == DRE_OK && bus_fake.nsent == 0u);
    CHECK(dre_health_act(&m, DRE_ON_IDLE) == DRE_OK);
    CHECK(sent_is(0u, 0x03F, "3375030001000000")); /* requested_state (30003) = 1 */
    CHECK(dre_health_act(&m, DRE_ON_HOLD) == DRE_OK);
    CHECK(sent_is(1u, 0x03C, "0000000000000100")); /* V: 0 r/min, passthrough */
}

int main(void)
{
    test_read_health();
    test_step_warns_then_acts_before_the_derating();
    test_step_catches_a_stall();
    test_act_sends_idle_or_speed_zero();
    return check_report("test_health");
}
