/* Per-motor commands, request tracking and multi-motor moves (see dre_client.h). */
#include "drempower/dre_client.h"

#include <float.h>
#include <math.h>
#include <string.h>

enum { SLOT_FREE = 0, SLOT_PENDING, SLOT_DONE, SLOT_TIMEOUT };

/* ----------------------------------------------------------------- bus */

dre_status dre_bus_init(dre_bus *bus, const dre_bus_config *cfg, dre_request *slots, uint8_t nslots,
                        dre_frame *rx_storage, uint8_t rx_capacity)
{
    int ring_ok = rx_storage == NULL ? rx_capacity == 0u
                                     : rx_capacity >= 2u && rx_capacity <= 128u &&
                                           (rx_capacity & (uint8_t)(rx_capacity - 1u)) == 0u;

    if (cfg->send == NULL || cfg->tick == NULL || slots == NULL || nslots == 0u || !ring_ok) {
        return DRE_E_ARG;
    }
    memset(bus, 0, sizeof *bus);
    memset(slots, 0, sizeof *slots * nslots);
    bus->cfg = *cfg;
    if (bus->cfg.timeout_ms == 0u) {
        bus->cfg.timeout_ms = DRE_DEFAULT_TIMEOUT_MS;
    }
    bus->slots = slots;
    bus->nslots = nslots;
    bus->rx_buf = rx_storage;
    bus->rx_mask = (uint8_t)(rx_capacity - 1u);
    return DRE_OK;
}

int dre_bus_isr_push(dre_bus *bus, const dre_frame *frame)
{
    uint8_t head = bus->rx_head;

    if (bus->rx_buf == NULL || (uint8_t)(head - bus->rx_tail) > bus->rx_mask) {
        bus->rx_overflows++;
        return 0;
    }
    bus->rx_buf[head & bus->rx_mask] = *frame;
    DRE_BARRIER();
    bus->rx_head = (uint8_t)(head + 1u);
    return 1;
}

/* Consumer side of the queue: 1 and the oldest frame, or 0 when empty. */
static int rx_pop(dre_bus *bus, dre_frame *out)
{
    uint8_t tail = bus->rx_tail;

    if (tail == bus->rx_head) {
        return 0;
    }
    DRE_BARRIER();
    *out = bus->rx_buf[tail & bus->rx_mask];
    DRE_BARRIER();
    bus->rx_tail = (uint8_t)(tail + 1u);
    return 1;
}

static int answers(const dre_request *r, const dre_msg *msg)
{
    if (r->state != SLOT_PENDING || (r->node != DRE_BROADCAST && r->node != msg->node)) {
        return 0;
    }
    if (msg->type == DRE_MSG_STATE) {
        return r->address == 0u;
    }
    return r->address != 0u && r->address == msg->u.param.address;
}

dre_status dre_bus_feed(dre_bus *bus, const dre_frame *frame)
{
    dre_msg msg;
    dre_request *best = NULL;
    uint8_t i;

    bus->stats.rx_frames++;
    if (dre_decode_reply(frame, &msg) != DRE_OK) {
        bus->stats.rx_malformed++;
        return DRE_E_PROTOCOL;
    }
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        /* the oldest request is the one furthest behind the sequence counter */
        if (answers(r, &msg) &&
            (best == NULL || (uint16_t)(bus->seq - r->seq) > (uint16_t)(bus->seq - best->seq))) {
            best = r;
        }
    }
    if (best != NULL) {
        best->reply = msg;
        best->state = SLOT_DONE;
    } else {
        bus->stats.rx_unmatched++;
        if (bus->cfg.on_unmatched != NULL) {
            bus->cfg.on_unmatched(bus->cfg.user, &msg);
        }
    }
    return DRE_OK;
}

void dre_bus_poll(dre_bus *bus)
{
    dre_frame f;
    uint32_t now;
    uint8_t i;

    while (rx_pop(bus, &f)) {
        (void)dre_bus_feed(bus, &f);
    }
    now = bus->cfg.tick(bus->cfg.user);
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        if (r->state == SLOT_PENDING && (uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
            r->state = SLOT_TIMEOUT;
            bus->stats.timeouts++;
        }
    }
}

static dre_request *slot_of(dre_bus *bus, dre_req req)
{
    uint32_t index = req & 0xFFu;
    dre_request *r;

    if (index >= bus->nslots) {
        return NULL;
    }
    r = &bus->slots[index];
    return r->state != SLOT_FREE && r->seq == (uint16_t)(req >> 8) ? r : NULL;
}

dre_status dre_result(dre_bus *bus, dre_req req, dre_msg *reply)
{
    dre_request *r = slot_of(bus, req);

    if (r == NULL) {
        return DRE_E_ARG;
    }
    switch (r->state) {
    case SLOT_PENDING:
        return DRE_PENDING;
    case SLOT_DONE:
        *reply = r->reply;
        r->state = SLOT_FREE;
        return DRE_OK;
    default:
        r->state = SLOT_FREE;
        return DRE_E_TIMEOUT;
    }
}

void dre_cancel(dre_bus *bus, dre_req req)
{
    dre_request *r = slot_of(bus, req);
    if (r != NULL) {
        r->state = SLOT_FREE;
    }
}

static dre_status encode(dre_bus *bus, const dre_msg *msg, dre_frame *f)
{
    dre_field bad;
    if (dre_encode(msg, f, &bad) != DRE_OK) {
        bus->bad_field = bad;
        bus->bad_index = 0u;
        return DRE_E_RANGE;
    }
    return DRE_OK;
}

static dre_status transmit(dre_bus *bus, const dre_frame *f)
{
    return bus->cfg.send(bus->cfg.user, f) == 0 ? DRE_OK : DRE_E_SEND;
}

dre_status dre_send(dre_bus *bus, const dre_msg *msg)
{
    dre_frame f;
    dre_status st = encode(bus, msg, &f);
    return st == DRE_OK ? transmit(bus, &f) : st;
}

/* Send a request and track its reply. */
static dre_status request(const dre_motor *m, const dre_msg *msg, dre_req *req)
{
    dre_bus *bus = m->bus;
    dre_frame f;
    dre_request *r = NULL;
    dre_status st;
    uint8_t i;

    st = encode(bus, msg, &f);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < bus->nslots && r == NULL; i++) {
        if (bus->slots[i].state == SLOT_FREE) {
            r = &bus->slots[i];
        }
    }
    if (r == NULL) {
        return DRE_E_BUSY;
    }
    st = transmit(bus, &f);
    if (st != DRE_OK) {
        return st;
    }
    if (++bus->seq == 0u) {
        bus->seq = 1u; /* handles are never 0 */
    }
    r->seq = bus->seq;
    r->node = msg->node;
    r->address = msg->type == DRE_MSG_FAST_READ ? 0u : (uint16_t)msg->u.param.address;
    r->sent_ms = bus->cfg.tick(bus->cfg.user);
    r->state = SLOT_PENDING;
    *req = ((uint32_t)r->seq << 8) | (uint32_t)(r - bus->slots);
    return DRE_OK;
}

/* ----------------------------------------------------------------- motor */

void dre_motor_init(dre_motor *m, dre_bus *bus, uint8_t node)
{
    m->bus = bus;
    m->node = node;
}

static dre_msg msg_for(const dre_motor *m, uint8_t type)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = type;
    msg.node = m->node;
    return msg;
}

static dre_status range_error(dre_bus *bus, dre_field field, uint8_t index)
{
    bus->bad_field = field;
    bus->bad_index = index;
    return DRE_E_RANGE;
}

static int positive(float v)
{
    return v > 0.0f && v <= FLT_MAX;
}

/* The single-motor position message for `mode`, or DRE_E_RANGE. */
static dre_status angle_msg(dre_bus *bus, dre_msg *msg, float angle, float speed, float param, uint8_t mode)
{
    switch (mode) {
    case DRE_ANGLE_T:
        msg->type = DRE_MSG_POSITION_T;
        msg->u.position_t.position = angle;
        msg->u.position_t.speed = speed;
        msg->u.position_t.bandwidth = param;
        return DRE_OK;
    case DRE_ANGLE_Q:
        if (!positive(speed)) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!positive(param)) {
            return range_error(bus, DRE_FIELD_ACCEL, 0u);
        }
        msg->type = DRE_MSG_POSITION_Q;
        msg->u.position_q.position = angle;
        msg->u.position_q.speed = speed;
        msg->u.position_q.accel = param;
        return DRE_OK;
    case DRE_ANGLE_P:
        msg->type = DRE_MSG_POSITION_P;
        msg->u.position_p.position = angle;
        msg->u.position_p.speed_ff = speed;
        msg->u.position_p.torque_ff = param;
        return DRE_OK;
    default:
        return range_error(bus, DRE_FIELD_MODE, 0u);
    }
}

dre_status dre_set_angle(const dre_motor *m, float angle, float speed, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_NONE);
    dre_status st = angle_msg(m->bus, &msg, angle, speed, param, mode);
    return st == DRE_OK ? dre_send(m->bus, &msg) : st;
}

dre_status dre_set_speed(const dre_motor *m, float speed, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_VELOCITY);
    msg.u.velocity.speed = speed;
    msg.u.velocity.param = param;
    msg.u.velocity.mode = mode;
    return dre_send(m->bus, &msg);
}

dre_status dre_set_torque(const dre_motor *m, float torque, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_TORQUE);
    msg.u.torque.torque = torque;
    msg.u.torque.param = param;
    msg.u.torque.mode = mode;
    return dre_send(m->bus, &msg);
}

dre_status dre_impedance_control(const dre_motor *m, float pos, float vel, float tff, float kp, float kd)
{
    dre_msg preset = msg_for(m, DRE_MSG_PRESET_D);
    dre_msg start;

    preset.u.preset_d.position = pos;
    preset.u.preset_d.speed = vel;
    preset.u.preset_d.torque_ff = tff;
    memset(&start, 0, sizeof start);
    start.type = DRE_MSG_START_IMPEDANCE;
    start.node = DRE_BROADCAST;
    start.u.start_impedance.kp = kp;
    start.u.start_impedance.kd = kd;
    return dre_preset_start(m->bus, &preset, 1u, &start);
}

dre_status dre_system(const dre_motor *m, uint8_t op)
{
    dre_msg msg = msg_for(m, DRE_MSG_SYSTEM);
    msg.u.system.op = op;
    return dre_send(m->bus, &msg);
}

dre_status dre_estop(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_ESTOP);
}

dre_status dre_clear_error(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_CLEAR_ERRORS);
}

dre_status dre_save_config(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_SAVE_CONFIG);
}

dre_status dre_reboot(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_REBOOT);
}

dre_status dre_set_zero_position(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_SET_ZERO_POSITION);
}

static dre_msg write_msg(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = msg_for(m, DRE_MSG_WRITE_PARAM);
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    msg.u.param.value = value;
    return msg;
}

dre_status dre_set_mode(const dre_motor *m, uint8_t mode)
{
    dre_value state;
    if (mode != DRE_MODE_IDLE && mode != DRE_MODE_CLOSED_LOOP) {
        return range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    state.i = mode == DRE_MODE_IDLE ? 1 : 8; /* AXIS_STATE_IDLE, AXIS_STATE_CLOSED_LOOP_CONTROL */
    return dre_write_param(m, DRE_P_AXIS0_REQUESTED_STATE, state);
}

dre_status dre_set_id(const dre_motor *m, uint8_t new_id)
{
    dre_value id;
    dre_msg write, save;
    dre_frame fw, fs;
    dre_status st;

    if (new_id == DRE_BROADCAST || new_id > DRE_MAX_NODE) {
        return range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    id.i = new_id;
    write = write_msg(m, DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONFIG_CAN_NODE_ID),
                      DRE_PARAM_DTYPE(DRE_P_AXIS0_CONFIG_CAN_NODE_ID), id);
    save = msg_for(m, DRE_MSG_SYSTEM);
    save.node = new_id;
    save.u.system.op = DRE_SYS_SAVE_CONFIG;
    st = encode(m->bus, &write, &fw);
    if (st == DRE_OK) {
        st = encode(m->bus, &save, &fs);
    }
    if (st == DRE_OK) {
        st = transmit(m->bus, &fw);
    }
    return st == DRE_OK ? transmit(m->bus, &fs) : st;
}

dre_status dre_write_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = write_msg(m, address, dtype, value);
    return dre_send(m->bus, &msg);
}

dre_status dre_write_param(const dre_motor *m, dre_param_t param, dre_value value)
{
    uint8_t flags = DRE_PARAM_FLAGS(param);

    if ((flags & DRE_PF_RW) == 0u) {
        return DRE_E_ACCESS;
    }
    if ((flags & DRE_PF_BOOL) != 0u && value.i != 0 && value.i != 1) {
        return range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    return dre_write_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), value);
}

dre_status dre_read_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_req *req)
{
    dre_msg msg = msg_for(m, DRE_MSG_READ_PARAM);
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    return request(m, &msg, req);
}

dre_status dre_read_param(const dre_motor *m, dre_param_t param, dre_req *req)
{
    return dre_read_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), req);
}

dre_status dre_get_state(const dre_motor *m, dre_req *req)
{
    dre_msg msg = msg_for(m, DRE_MSG_FAST_READ);
    return request(m, &msg, req);
}

/* ----------------------------------------------------------------- several motors */

/* How to build the i-th preset of a batch. */
typedef struct {
    const dre_msg *presets; /* given presets, or NULL to build them from the fields below */
    uint8_t type;           /* preset type */
    const uint8_t *ids;
    const float *values; /* first field of each preset */
    float second, third; /* T/Q/P: the other two fields in wire order; V/C: param in `second` */
    uint8_t mode;        /* V and C presets */
} batch;

static dre_msg batch_msg(const batch *b, uint8_t i)
{
    dre_msg m;
    float v;

    if (b->presets != NULL) {
        return b->presets[i];
    }
    v = b->values[i];
    memset(&m, 0, sizeof m);
    m.type = b->type;
    m.node = b->ids[i];
    switch (b->type) {
    case DRE_MSG_PRESET_T:
        m.u.position_t.position = v;
        m.u.position_t.speed = b->second;
        m.u.position_t.bandwidth = b->third;
        break;
    case DRE_MSG_PRESET_Q:
        m.u.preset_q.position = v;
        m.u.preset_q.time = b->second;
        m.u.preset_q.accel = b->third;
        break;
    case DRE_MSG_PRESET_P:
        m.u.position_p.position = v;
        m.u.position_p.speed_ff = b->second;
        m.u.position_p.torque_ff = b->third;
        break;
    case DRE_MSG_PRESET_V:
        m.u.velocity.speed = v;
        m.u.velocity.param = b->second;
        m.u.velocity.mode = b->mode;
        break;
    default: /* DRE_MSG_PRESET_C */
        m.u.torque.torque = v;
        m.u.torque.param = b->second;
        m.u.torque.mode = b->mode;
        break;
    }
    return m;
}

/* The start kind a preset type belongs to; 0 for the generic preset, 0xFF for a non-preset. */
static uint8_t preset_kind(uint8_t type)
{
    static const uint8_t kinds[] = {0u, DRE_START_T, DRE_START_Q, DRE_START_P,
                                    DRE_START_V, DRE_START_C, DRE_START_D};
    return type >= DRE_MSG_PRESET && type <= DRE_MSG_PRESET_D ? kinds[type - DRE_MSG_PRESET] : 0xFFu;
}

static dre_status run_batch(dre_bus *bus, const batch *b, uint8_t n, const dre_msg *start)
{
    uint8_t kind = start->type == DRE_MSG_START_IMPEDANCE ? (uint8_t)DRE_START_D : start->u.start.kind;
    dre_field bad;
    dre_frame f;
    dre_msg m;
    uint8_t i;

    if (n == 0u || (start->type != DRE_MSG_START && start->type != DRE_MSG_START_IMPEDANCE)) {
        return DRE_E_ARG;
    }
    for (i = 0u; i < n; i++) {
        uint8_t k;
        m = batch_msg(b, i);
        k = preset_kind(m.type);
        if (k == 0xFFu || (k != 0u && k != kind)) {
            bus->bad_index = i;
            return DRE_E_ARG;
        }
        if (dre_encode(&m, &f, &bad) != DRE_OK) {
            return range_error(bus, bad, i);
        }
    }
    if (dre_encode(start, &f, &bad) != DRE_OK) {
        return range_error(bus, bad, n);
    }
    for (i = 0u; i < n; i++) {
        m = batch_msg(b, i);
        (void)dre_encode(&m, &f, NULL);
        if (transmit(bus, &f) != DRE_OK) {
            return DRE_E_SEND;
        }
    }
    return dre_send(bus, start);
}

dre_status dre_preset_start(dre_bus *bus, const dre_msg *presets, uint8_t n, const dre_msg *start)
{
    batch b;
    if (presets == NULL || start == NULL) {
        return DRE_E_ARG;
    }
    memset(&b, 0, sizeof b);
    b.presets = presets;
    return run_batch(bus, &b, n, start);
}

static dre_msg start_msg(uint8_t kind, uint8_t relative)
{
    dre_msg m;
    memset(&m, 0, sizeof m);
    m.type = DRE_MSG_START;
    m.node = DRE_BROADCAST;
    m.u.start.kind = kind;
    m.u.start.relative = relative;
    return m;
}

dre_status dre_q_move_time(float distance, float speed, float accel, uint8_t traj_mode, float *time_s)
{
    float v = speed, a = accel, d = distance;

    if (!positive(v) || !positive(a) || !(d >= 0.0f && d <= FLT_MAX)) {
        return DRE_E_RANGE;
    }
    /* 1 r/min = 6 deg/s; PROTOCOL.md 3.4.3 */
    if (traj_mode == DRE_TRAJ_S_CURVE) {
        *time_s = d <= 12.0f * v * v / a ? 4.0f * sqrtf(a * d / 12.0f) / a : d / (6.0f * v) + 2.0f * v / a;
    } else if (traj_mode == DRE_TRAJ_TRAPEZOID || traj_mode == 0u) {
        *time_s = d <= 6.0f * v * v / a ? 2.0f * sqrtf(d / (6.0f * a)) : v / a + d / (6.0f * v);
    } else {
        return DRE_E_RANGE;
    }
    return DRE_OK;
}

static dre_status move_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *targets, const float *from,
                              float speed, float param, uint8_t mode, uint8_t relative)
{
    static const uint8_t types[] = {DRE_MSG_PRESET_T, DRE_MSG_PRESET_Q, DRE_MSG_PRESET_P};
    dre_msg start;
    batch b;
    uint8_t i;

    if (ids == NULL || targets == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    if (mode > DRE_ANGLE_P) {
        return range_error(bus, DRE_FIELD_MODE, 0u);
    }
    memset(&b, 0, sizeof b);
    b.type = types[mode];
    b.ids = ids;
    b.values = targets;
    b.second = speed; /* T: speed, bandwidth; Q: time (below), accel; P: speed_ff, torque_ff */
    b.third = param;
    if (mode == DRE_ANGLE_Q) {
        float d = 0.0f;
        if (!relative && from == NULL) {
            return DRE_E_ARG;
        }
        if (!positive(speed)) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!positive(param)) {
            return range_error(bus, DRE_FIELD_ACCEL, 0u);
        }
        for (i = 0u; i < n; i++) {
            float delta = fabsf(relative ? targets[i] : targets[i] - from[i]);
            d = delta > d ? delta : d; /* NaN deltas are caught as a bad position below */
        }
        if (dre_q_move_time(d, speed, param, bus->cfg.traj_mode, &b.second) != DRE_OK) {
            return range_error(bus, DRE_FIELD_TIME, 0u);
        }
    }
    start = start_msg((uint8_t)(DRE_START_T + mode), relative);
    return run_batch(bus, &b, n, &start);
}

dre_status dre_set_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *angles, const float *from,
                          float speed, float param, uint8_t mode)
{
    return move_angles(bus, n, ids, angles, from, speed, param, mode, 0u);
}

dre_status dre_step_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *deltas, float speed,
                           float param, uint8_t mode)
{
    return move_angles(bus, n, ids, deltas, NULL, speed, param, mode, 1u);
}

static dre_status speeds_or_torques(dre_bus *bus, uint8_t type, uint8_t kind, uint8_t n, const uint8_t *ids,
                                    const float *values, float param, uint8_t mode)
{
    dre_msg start = start_msg(kind, 0u);
    batch b;

    if (ids == NULL || values == NULL) {
        return DRE_E_ARG;
    }
    memset(&b, 0, sizeof b);
    b.type = type;
    b.ids = ids;
    b.values = values;
    b.second = param;
    b.mode = mode;
    return run_batch(bus, &b, n, &start);
}

dre_status dre_set_speeds(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *speeds, float param,
                          uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_V, DRE_START_V, n, ids, speeds, param, mode);
}

dre_status dre_set_torques(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *torques, float param,
                           uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_C, DRE_START_C, n, ids, torques, param, mode);
}
