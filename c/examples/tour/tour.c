/* The tour (see tour.h): every step prints what it saw; a failed step prints why and ends the tour. */
#include "tour.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#define TOUR_MAX 4u
#define MOVE_SPEED 60.0f    /* r/min */
#define MOVE_ACCEL 240.0f   /* (r/min)/s */
#define MOVE_TIMEOUT 5000u  /* ms */
#define AT_TARGET 1.0f      /* deg */

/* ----------------------------------------------------------------- a line, without printf */

typedef struct {
    char text[160];
    size_t len;
} line_t;

static void put(line_t *l, const char *s)
{
    while (*s != '\0' && l->len + 1u < sizeof l->text) {
        l->text[l->len++] = *s++;
    }
    l->text[l->len] = '\0';
}

static void put_uint(line_t *l, uint32_t v)
{
    char digits[11];
    size_t n = 0u;
    do {
        digits[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    while (n > 0u && l->len + 1u < sizeof l->text) {
        l->text[l->len++] = digits[--n];
    }
    l->text[l->len] = '\0';
}

/* `v` with two decimals, rounded to nearest. */
static void put_fixed(line_t *l, float v)
{
    float a = fabsf(v) * 100.0f + 0.5f;
    uint32_t c = a < 4.0e9f ? (uint32_t)a : 4000000000u;
    if (v < 0.0f && c != 0u) {
        put(l, "-");
    }
    put_uint(l, c / 100u);
    put(l, ".");
    put_uint(l, (c % 100u) / 10u);
    put_uint(l, c % 10u);
}

static void start(line_t *l, const char *step, uint8_t id)
{
    l->len = 0u;
    l->text[0] = '\0';
    put(l, step);
    put(l, " ");
    put_uint(l, id);
    put(l, ":");
}

static int fail(const dre_tour_port *p, const char *what, uint8_t id, dre_status st)
{
    line_t l;
    start(&l, "FAIL", id);
    put(&l, " ");
    put(&l, what);
    put(&l, ": ");
    put(&l, dre_status_name(st));
    if (st == DRE_E_RANGE) {
        put(&l, " (");
        put(&l, dre_field_name(p->bus->bad_field));
        put(&l, ")");
    }
    p->print(p->user, l.text);
    l.len = 0u;
    l.text[0] = '\0';
    put(&l, "bus: ");
    put_uint(&l, p->bus->stats.rx_frames);
    put(&l, " frames received, ");
    put_uint(&l, p->bus->stats.rx_unmatched);
    put(&l, " unmatched, ");
    put_uint(&l, p->bus->stats.rx_malformed);
    put(&l, " malformed, ");
    put_uint(&l, p->bus->stats.timeouts);
    put(&l, " timeouts, ");
    put_uint(&l, p->bus->rx_overflows);
    put(&l, " receive queue overflows");
    p->print(p->user, l.text);
    return 1;
}

/* ----------------------------------------------------------------- waiting for replies */

/* Poll `req` until it is answered or times out (the bus's timeout: it never hangs). */
static dre_status wait_reply(const dre_tour_port *p, dre_req req, dre_msg *reply)
{
    dre_status st;
    while ((st = dre_result(p->bus, req, reply)) == DRE_PENDING) {
        p->pump(p->user, 1u);
    }
    return st;
}

static dre_status read_state(const dre_tour_port *p, uint8_t id, dre_msg *state)
{
    dre_motor m = {p->bus, id};
    dre_req req;
    dre_status st = dre_get_state(&m, &req);
    return st == DRE_OK ? wait_reply(p, req, state) : st;
}

static void print_state(const dre_tour_port *p, const char *step, const dre_msg *s)
{
    line_t l;
    start(&l, step, s->node);
    put(&l, " position ");
    put_fixed(&l, s->u.state.position);
    put(&l, " deg, speed ");
    put_fixed(&l, s->u.state.speed);
    put(&l, " r/min, torque ");
    put_fixed(&l, s->u.state.torque);
    put(&l, " Nm, T=");
    put_uint(&l, s->u.state.trajectory_done);
    put(&l, " E=");
    put_uint(&l, s->u.state.error);
    p->print(p->user, l.text);
}

/* ----------------------------------------------------------------- the steps */

/* Fast read of the state, and the supply voltage and current (two parameter reads). */
static int step_read(const dre_tour_port *p, uint8_t id, float *position)
{
    dre_motor m = {p->bus, id};
    dre_msg state, v, i;
    dre_req req[2];
    dre_status st = read_state(p, id, &state);
    line_t l;

    if (st != DRE_OK) {
        return fail(p, "get_state", id, st);
    }
    print_state(p, "state", &state);
    *position = state.u.state.position;
    st = dre_get_volcur(&m, req);
    if (st == DRE_OK) {
        st = wait_reply(p, req[0], &v);
        if (st == DRE_OK) {
            st = wait_reply(p, req[1], &i);
        } else {
            dre_cancel(p->bus, req[1]);
        }
    }
    if (st != DRE_OK) {
        return fail(p, "get_volcur", id, st);
    }
    start(&l, "volcur", id);
    put(&l, " ");
    put_fixed(&l, v.u.param.value.f32);
    put(&l, " V, ");
    put_fixed(&l, i.u.param.value.f32);
    put(&l, " A");
    p->print(p->user, l.text);
    return 0;
}

/* The health reading (five reads) and one supervisor step: temperatures, limit, derating, what began. */
static int step_health(const dre_tour_port *p, uint8_t id)
{
    dre_motor m = {p->bus, id};
    dre_req req[DRE_HEALTH_READS];
    dre_msg replies[DRE_HEALTH_READS];
    dre_health h;
    dre_health_policy policy;
    dre_health_watch watch = {0u, 0u, 0u};
    dre_health_verdict v;
    dre_status st = dre_read_health(&m, req);
    line_t l;
    uint8_t k;

    for (k = 0u; k < DRE_HEALTH_READS; k++) {
        if (st == DRE_OK) {
            st = wait_reply(p, req[k], &replies[k]);
        } else if (k > 0u) {
            dre_cancel(p->bus, req[k]);
        }
    }
    if (st == DRE_OK) {
        st = dre_health_from(replies, &h);
    }
    if (st != DRE_OK) {
        return fail(p, "read_health", id, st);
    }
    dre_health_policy_init(&policy, 1.0f, 12.0f);
    dre_health_step(&watch, &policy, &h, NULL, 0u, &v);
    start(&l, "health", id);
    put(&l, " motor ");
    put_fixed(&l, h.motor_temp_c);
    put(&l, " degC, driver ");
    put_fixed(&l, h.driver_temp_c);
    put(&l, " degC, limit ");
    put_fixed(&l, h.current_limit_a);
    put(&l, " A, derating ");
    put_fixed(&l, dre_health_derating(&h));
    put(&l, ", active ");
    put_uint(&l, v.active);
    p->print(p->user, l.text);
    return 0;
}

/* A verified write (written, read back, compared), then closed loop. */
static int step_configure(const dre_tour_port *p, uint8_t id)
{
    dre_motor m = {p->bus, id};
    dre_msg reply;
    dre_req req;
    dre_status st = dre_set_traj_mode(&m, DRE_TRAJ_S_CURVE, &req);
    line_t l;

    if (st == DRE_OK) {
        st = wait_reply(p, req, &reply);
    }
    if (st != DRE_OK) {
        return fail(p, "set_traj_mode", id, st);
    }
    start(&l, "verified", id);
    put(&l, " traj_mode ");
    put_uint(&l, (uint32_t)reply.u.param.value.i);
    put(&l, " read back");
    p->print(p->user, l.text);
    st = dre_set_mode(&m, DRE_MODE_CLOSED_LOOP);
    if (st != DRE_OK) {
        return fail(p, "set_mode", id, st);
    }
    return 0;
}

/* One synchronised Q move of every motor (presets, then one start) and its wait. */
static int step_move(const dre_tour_port *p, uint8_t n, const uint8_t *ids, const float *from)
{
    static const float targets[TOUR_MAX] = {90.0f, -45.0f, 30.0f, -60.0f};
    dre_done done[TOUR_MAX];
    uint32_t t0, ms;
    dre_status st;
    line_t l;
    uint8_t i;

    memset(done, 0, sizeof done);
    st = dre_set_angles(p->bus, n, ids, targets, from, MOVE_SPEED, MOVE_ACCEL, DRE_ANGLE_Q);
    while (st == DRE_PENDING) { /* a start held until its presets are out */
        p->pump(p->user, 1u);
        st = dre_batch_status(p->bus);
    }
    if (st != DRE_OK) {
        return fail(p, "set_angles", ids[p->bus->bad_index < n ? p->bus->bad_index : 0u], st);
    }
    t0 = p->bus->cfg.tick(p->bus->cfg.user);
    l.len = 0u;
    l.text[0] = '\0';
    put(&l, "move: ");
    for (i = 0u; i < n; i++) {
        put(&l, i == 0u ? "" : ", ");
        put_uint(&l, ids[i]);
        put(&l, " to ");
        put_fixed(&l, targets[i]);
    }
    put(&l, " deg at ");
    put_fixed(&l, MOVE_SPEED);
    put(&l, " r/min");
    p->print(p->user, l.text);
    while ((st = dre_positions_done(p->bus, n, ids, done, MOVE_TIMEOUT)) == DRE_PENDING) {
        p->pump(p->user, 1u);
    }
    if (st != DRE_OK) {
        return fail(p, "positions_done", ids[p->bus->bad_index < n ? p->bus->bad_index : 0u], st);
    }
    ms = p->bus->cfg.tick(p->bus->cfg.user) - t0;
    l.len = 0u;
    l.text[0] = '\0';
    put(&l, "wait: done after ");
    put_uint(&l, ms);
    put(&l, " ms");
    p->print(p->user, l.text);
    for (i = 0u; i < n; i++) {
        dre_msg s;
        st = read_state(p, ids[i], &s);
        if (st != DRE_OK) {
            return fail(p, "get_state", ids[i], st);
        }
        print_state(p, "arrived", &s);
        if (!(fabsf(s.u.state.position - targets[i]) <= AT_TARGET)) {
            return fail(p, "not at its target", ids[i], DRE_E_MOVE);
        }
    }
    return 0;
}

/* Emergency stop of every motor (broadcast), then the state and the axis error word of each. */
static int step_estop(const dre_tour_port *p, uint8_t n, const uint8_t *ids)
{
    dre_motor all = {p->bus, DRE_BROADCAST};
    dre_status st = dre_estop(&all);
    uint8_t i;

    if (st != DRE_OK) {
        return fail(p, "estop", 0u, st);
    }
    p->pump(p->user, 20u);
    for (i = 0u; i < n; i++) {
        dre_motor m = {p->bus, ids[i]};
        dre_req req[DRE_ERROR_WORDS];
        char flags[96];
        dre_msg s, axis;
        line_t l;
        uint8_t k;

        st = read_state(p, ids[i], &s);
        if (st != DRE_OK) {
            return fail(p, "get_state", ids[i], st);
        }
        print_state(p, "estop", &s);
        st = dre_dump_error(&m, req);
        if (st != DRE_OK) {
            return fail(p, "dump_error", ids[i], st);
        }
        st = wait_reply(p, req[0], &axis); /* axis0.error */
        for (k = 1u; k < DRE_ERROR_WORDS; k++) {
            dre_msg other;
            if (st == DRE_OK) {
                st = wait_reply(p, req[k], &other);
            } else {
                dre_cancel(p->bus, req[k]);
            }
        }
        if (st != DRE_OK) {
            return fail(p, "dump_error", ids[i], st);
        }
        (void)dre_error_format(dre_error_word_find((uint16_t)axis.u.param.address), (uint32_t)axis.u.param.value.i,
                               flags, sizeof flags);
        start(&l, "errors", ids[i]);
        put(&l, " axis ");
        put(&l, flags[0] != '\0' ? flags : "none");
        p->print(p->user, l.text);
        if (!s.u.state.error) {
            return fail(p, "no error flag after the estop", ids[i], DRE_E_FAULT);
        }
    }
    return 0;
}

int dre_tour_run(const dre_tour_port *p, uint8_t n, const uint8_t *ids)
{
    float from[TOUR_MAX];
    uint8_t i;

    if (n == 0u || n > TOUR_MAX) {
        return fail(p, "motors", n, DRE_E_ARG);
    }
    for (i = 0u; i < n; i++) {
        if (step_read(p, ids[i], &from[i]) != 0 || step_health(p, ids[i]) != 0 || step_configure(p, ids[i]) != 0) {
            return 1;
        }
    }
    p->pump(p->user, 20u);
    if (step_move(p, n, ids, from) != 0 || step_estop(p, n, ids) != 0) {
        return 1;
    }
    p->print(p->user, "tour: ok");
    return 0;
}
