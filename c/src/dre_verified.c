/*
 * Verified operations: writes read back and compared before save_config
 * (trajectory mode, angle range, baud rates) and the steps of dre_set_id
 * (see dre_client.h). The bus hands their replies and their waiting steps
 * back through the hooks attached here (bus->request_hooks).
 */
#include "dre_client_internal.h"

#include <string.h>

static void on_reply(dre_bus *bus, dre_request *r, const dre_msg *msg);
static void set_id_write(dre_bus *bus, dre_request *r, uint32_t now);

static const struct dre_request_hooks hooks = {on_reply, set_id_write};

/* Did the motor send back what was written? Compared as the Python client does: f32 bit for bit. */
static int same_value(const dre_request *r, const dre_msg *msg)
{
    const dre_value *want = &r->reply.u.param.value, *got = &msg->u.param.value;
    if (r->dtype == DRE_F32) {
        return msg->u.param.dtype == DRE_F32 && memcmp(&want->f32, &got->f32, sizeof got->f32) == 0;
    }
    return msg->u.param.dtype != DRE_F32 && want->i == got->i;
}

/*
 * A verified write read back another value: write it again, and read it
 * again (queued: dre_bus_poll sends it before any later request to the
 * motor, with retries of its own), as the Python client does.
 */
static void rewrite(dre_bus *bus, dre_request *r)
{
    dre_msg w;

    memset(&w, 0, sizeof w);
    w.type = DRE_MSG_WRITE_PARAM;
    w.node = r->node;
    w.u.param.address = r->address;
    w.u.param.dtype = r->dtype;
    w.u.param.value = r->reply.u.param.value; /* what was written */
    r->link++;
    r->tries = 0u;
    r->sent_ms = bus->cfg.tick(bus->cfg.user);
    if (!dre_i_room(bus, 1u) || dre_i_send_as(bus, &w, 0) != DRE_OK) {
        dre_i_fail(bus, r, SLOT_SEND_FAILED);
        return;
    }
    r->state = SLOT_QUEUED;
}

/*
 * Hook: the reply `msg` answered `r`. A probe of dre_set_id ends it (a motor
 * answers at the new id) or takes it to its write; a verified read-back that
 * differs is written again or fails; a match sends save_config when asked.
 */
static void on_reply(dre_bus *bus, dre_request *r, const dre_msg *msg)
{
    if (r->step == STEP_ID_FREE) {
        dre_i_fail(bus, r, SLOT_TAKEN); /* a motor answers at the new id */
    } else if (r->step == STEP_ID_HERE) {
        r->state = SLOT_WAIT; /* the motor answers: on to the write */
        r->sent_ms = bus->cfg.tick(bus->cfg.user);
    } else if ((r->flags & FLAG_VERIFY) != 0u && !same_value(r, msg)) {
        if ((r->flags & FLAG_REWRITE) != 0u && r->link < bus->cfg.retries) {
            rewrite(bus, r);
            return; /* the reply keeps the value written */
        }
        dre_i_fail(bus, r, SLOT_MISMATCH);
    } else if ((r->flags & FLAG_SAVE) != 0u && dre_i_system_op(bus, r->node, DRE_SYS_SAVE_CONFIG) != DRE_OK) {
        dre_i_fail(bus, r, SLOT_SEND_FAILED);
    } else {
        r->state = SLOT_DONE;
    }
    r->reply = *msg;
}

/*
 * Write params[i] = values[i] (i < k) to motor m, then read each back to
 * verify it; with `save`, save_config goes out once every value matched.
 * Checks room for the frames sent at once and free slots before sending
 * anything.
 */
static dre_status verified_writes(const dre_motor *m, uint8_t k, const dre_param_t *params, const dre_value *values,
                                  int save, dre_req *req)
{
    dre_bus *bus = m->bus;
    dre_frame f[3];
    dre_msg w[3];
    dre_status st;
    uint8_t i;

    for (i = 0u; i < k; i++) {
        w[i] = dre_i_write_msg(m, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]), values[i]);
        st = dre_i_encode(bus, &w[i], &f[i]);
        if (st != DRE_OK) {
            bus->bad_index = i;
            return st;
        }
    }
    if (dre_i_free_slots(bus) < k || !dre_i_room(bus, k + (dre_i_node_idle(bus, m->node) ? 1u : 0u))) {
        return DRE_E_BUSY;
    }
    bus->request_hooks = &hooks;
    for (i = 0u; i < k; i++) {
        st = dre_i_transmit(bus, &f[i]);
        if (st != DRE_OK) {
            return st;
        }
        dre_i_note(bus, &w[i]);
    }
    for (i = 0u; i < k; i++) {
        uint8_t last = i + 1u == k;
        dre_request r = dre_i_request(m->node, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]));
        r.flags = (uint8_t)(FLAG_VERIFY | FLAG_REWRITE | (last ? (save ? FLAG_SAVE : 0u) : FLAG_CHAIN));
        r.reply.u.param.value = values[i];
        (void)dre_i_issue(bus, &r, 1, &req[i]);
    }
    return DRE_OK;
}

/*
 * Step 1 of set_id: the fast reads of the current id (the helper, sent first
 * as the Python client does) and of the new id (the caller's request). Steps
 * 2 to 4 follow in the hooks: set_id_write (from dre_bus_poll) and on_reply.
 */
dre_status dre_set_id(const dre_motor *m, uint8_t new_id, dre_req *req)
{
    dre_bus *bus = m->bus;
    uint8_t node = m->node, apart = node != new_id;
    dre_request here = dre_i_request(node, 0u, DRE_F32), probe = dre_i_request(new_id, 0u, DRE_F32);
    unsigned frames;
    dre_req helper = 0u;
    dre_msg read_here = dre_i_read_msg(node, 0u, DRE_F32);
    dre_status st;
    dre_frame f;

    if (new_id == DRE_BROADCAST || new_id > DRE_MAX_NODE) {
        return dre_i_range_error(bus, DRE_FIELD_VALUE, 0u);
    }
    st = dre_i_encode(bus, &read_here, &f); /* is the current id valid? */
    if (st != DRE_OK) {
        return st;
    }
    frames = (dre_i_node_idle(bus, new_id) ? 1u : 0u) + (apart && dre_i_node_idle(bus, node) ? 1u : 0u);
    if (dre_i_free_slots(bus) < (apart ? 2u : 1u) || !dre_i_room(bus, frames)) {
        return DRE_E_BUSY;
    }
    bus->request_hooks = &hooks;
    probe.link = node;
    if (!apart) {
        probe.step = STEP_ID_HERE;
        return dre_i_issue(bus, &probe, 0, req);
    }
    here.step = STEP_ID_HELPER;
    st = dre_i_issue(bus, &here, 0, &helper);
    if (st != DRE_OK) {
        return st;
    }
    probe.step = STEP_ID_FREE;
    (void)dre_i_issue(bus, &probe, 1, req); /* a free slot was checked: queued at worst */
    bus->slots[helper & 0xFFu].link = (uint8_t)(*req & 0xFFu);
    return DRE_OK;
}

/*
 * Hook, step 2 of dre_set_id, once its probes are over (SLOT_WAIT): with the current
 * id answering and the new one silent, send the write and turn `r` into the
 * verified read of the new id (step 3, saved when it matches: step 4).
 */
static void set_id_write(dre_bus *bus, dre_request *r, uint32_t now)
{
    uint8_t old = r->link, new_id = r->node;
    dre_value id;
    dre_msg w;
    dre_frame f;

    if (r->step == STEP_ID_FREE) {
        dre_request *h = dre_i_helper_of(bus, r);
        uint8_t hs = h == NULL ? (uint8_t)SLOT_SEND_FAILED : h->state;
        if (hs == SLOT_PENDING || hs == SLOT_QUEUED) {
            r->sent_ms = now; /* the current id has yet to answer */
            return;
        }
        if (hs != SLOT_DONE) {
            dre_i_fail(bus, r, hs == SLOT_TIMEOUT ? (uint8_t)SLOT_ABSENT : (uint8_t)SLOT_SEND_FAILED);
            return;
        }
    }
    if (!dre_i_room(bus, 2u)) {
        if ((uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
            dre_i_fail(bus, r, SLOT_SEND_FAILED);
        }
        return;
    }
    dre_i_release_helper(bus, r);
    id.i = new_id;
    memset(&w, 0, sizeof w);
    w.type = DRE_MSG_WRITE_PARAM;
    w.node = old;
    w.u.param.address = DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    w.u.param.dtype = DRE_PARAM_DTYPE(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    w.u.param.value = id;
    if (dre_i_encode(bus, &w, &f) != DRE_OK || dre_i_transmit(bus, &f) != DRE_OK) {
        r->step = STEP_NONE;
        r->state = SLOT_SEND_FAILED;
        return;
    }
    if (old != new_id) {
        dre_i_traj_forget(bus, old);
        dre_i_traj_forget(bus, new_id);
    }
    r->step = STEP_NONE;
    r->link = 0u;
    r->tries = 0u; /* the read of the new id is a request of its own, with retries of its own */
    r->address = DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    r->dtype = w.u.param.dtype;
    r->flags = FLAG_VERIFY | FLAG_SAVE;
    memset(&r->reply, 0, sizeof r->reply);
    r->reply.u.param.value = id;
    r->state = SLOT_QUEUED; /* sent below once the new id has no other request in flight */
    r->sent_ms = now;
}

dre_status dre_set_traj_mode(const dre_motor *m, uint8_t mode, dre_req *req)
{
    static const dre_param_t param = DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE;
    dre_value v;

    if (mode != DRE_TRAJ_TRAPEZOID && mode != DRE_TRAJ_S_CURVE) {
        return dre_i_range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    v.i = mode;
    return verified_writes(m, 1u, &param, &v, 0, req);
}

dre_status dre_set_angle_range(const dre_motor *m, float angle_min, float angle_max, float position,
                               dre_req req[3])
{
    static const dre_param_t params[3] = {DRE_P_AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN,
                                          DRE_P_AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX,
                                          DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT};
    dre_value v[3];

    if (!dre_i_is_finite(angle_min)) {
        return dre_i_range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    if (!dre_i_is_finite(angle_max) || !(angle_min < angle_max)) {
        return dre_i_range_error(m->bus, DRE_FIELD_VALUE, 1u);
    }
    if (!(position >= angle_min && position <= angle_max)) {
        return dre_i_range_error(m->bus, DRE_FIELD_POSITION, 0u);
    }
    v[0].i = 0;
    v[1].i = 0;
    v[0].f32 = angle_min;
    v[1].f32 = angle_max;
    v[2].i = 1;
    return verified_writes(m, 3u, params, v, 1, req);
}

static dre_status set_baud(const dre_motor *m, dre_param_t param, const uint32_t *rates, uint32_t rate,
                           dre_req *req)
{
    dre_value v;
    uint8_t i;

    i = 0u;
    while (i < 4u && rates[i] != rate) {
        i++;
    }
    if (i == 4u) {
        return dre_i_range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    v.i = rate;
    return verified_writes(m, 1u, &param, &v, 1, req);
}

dre_status dre_set_can_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req)
{
    static const uint32_t rates[4] = {125000u, 250000u, 500000u, 1000000u};
    return set_baud(m, DRE_P_CAN_CONFIG_BAUD_RATE, rates, baud_rate, req);
}

dre_status dre_set_uart_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req)
{
    static const uint32_t rates[4] = {9600u, 19200u, 57600u, 115200u};
    return set_baud(m, DRE_P_CONFIG_UART_BAUDRATE, rates, baud_rate, req);
}
