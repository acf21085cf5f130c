/*
 * Multi-motor batches: presets for several motors and their start (set_angles,
 * step_angles, set_speeds, set_torques, preset_start, impedance control) and
 * the Q-move time (see dre_client.h).
 */
#include "dre_client_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define S16_MAX 327.67f

static int positive(float v)
{
    return v > 0.0f && v <= FLT_MAX;
}

/* How to build the i-th preset of a batch. */
typedef struct {
    const dre_msg *presets; /* given presets, or NULL to build them from the fields below */
    uint8_t type;           /* preset type */
    const uint8_t *ids;
    const float *values; /* first field of each preset */
    float second, third; /* T/Q/P: the other two fields in wire order; V/C: param in `second` */
    uint8_t mode;        /* V and C presets: the wire mode */
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
        /* feed-forward torque is sent as 0 for a motor told to stand still, as the vendor does */
        m.u.velocity.param = b->mode == DRE_VEL_PASSTHROUGH && v == 0.0f ? 0.0f : b->second;
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

static int gain_ok(float v)
{
    return v >= 0.0f && v <= S16_MAX;
}

/* Motor id number `index` of a batch: 1..63 and not seen before (added to *seen). */
static dre_status check_id(dre_bus *bus, uint64_t *seen, uint8_t id, uint8_t index)
{
    if (id == DRE_BROADCAST || id > DRE_MAX_NODE) {
        return dre_i_range_error(bus, DRE_FIELD_NODE, index);
    }
    if ((*seen & dre_i_motor_bits(id)) != 0u) {
        bus->bad_field = DRE_FIELD_NODE;
        bus->bad_index = index;
        return DRE_E_ARG;
    }
    *seen |= dre_i_motor_bits(id);
    return DRE_OK;
}

static dre_status check_ids(dre_bus *bus, uint8_t n, const uint8_t *ids)
{
    uint64_t seen = 0u;
    dre_status st = DRE_OK;
    uint8_t i;

    for (i = 0u; i < n && st == DRE_OK; i++) {
        st = check_id(bus, &seen, ids[i], i);
    }
    return st;
}

dre_status dre_batch_status(const dre_bus *bus)
{
    return (dre_status)bus->held_status;
}

/* Arm the move record of preset `p`'s motor for a start of `kind` (see dre_i_move_armed): the target is the
 * preset's position unless the start is relative; a Q preset carries the planned time. */
static void arm_move(dre_bus *bus, const dre_msg *p, uint8_t kind, uint8_t relative)
{
    int position = kind == DRE_START_T || kind == DRE_START_Q || kind == DRE_START_P;
    float target = 0.0f, time = 0.0f;

    switch (p->type) {
    case DRE_MSG_PRESET:
        target = p->u.preset.p1;
        time = kind == DRE_START_Q ? p->u.preset.p2 : 0.0f;
        break;
    case DRE_MSG_PRESET_T:
        target = p->u.position_t.position;
        break;
    case DRE_MSG_PRESET_Q:
        target = p->u.preset_q.position;
        time = p->u.preset_q.time;
        break;
    case DRE_MSG_PRESET_P:
        target = p->u.position_p.position;
        break;
    default:
        position = 0;
        break;
    }
    dre_i_move_armed(bus, p->node, position, !relative, target, time);
}

/*
 * Validate every preset and the start, choose where the start goes (cfg.start),
 * check there is room for every frame, then send. Motors holding a preset
 * without a start are tracked in presets_pending.
 */
static dre_status run_batch(dre_bus *bus, const batch *b, uint8_t n, const dre_msg *start)
{
    uint8_t kind = start->type == DRE_MSG_START_IMPEDANCE ? (uint8_t)DRE_START_D : start->u.start.kind;
    uint64_t mask = 0u;
    dre_msg s = *start;
    dre_field bad;
    dre_frame f;
    dre_msg m;
    uint8_t i, broadcast;

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
            return dre_i_range_error(bus, bad, i);
        }
        mask |= dre_i_motor_bits(m.node);
    }
    s.node = DRE_BROADCAST;
    if (dre_encode(&s, &f, &bad) != DRE_OK) {
        return dre_i_range_error(bus, bad, n);
    }
    if (s.type == DRE_MSG_START_IMPEDANCE) {
        if (!gain_ok(s.u.start_impedance.kp)) {
            return dre_i_range_error(bus, DRE_FIELD_KP, n);
        }
        if (!gain_ok(s.u.start_impedance.kd)) {
            return dre_i_range_error(bus, DRE_FIELD_KD, n);
        }
    }
    broadcast = bus->cfg.start == DRE_START_TO_BROADCAST ||
                (bus->cfg.start == DRE_START_TO_AUTO && n > 1u && (bus->presets_pending & ~mask) == 0u);
    if (bus->held_status == (int8_t)DRE_PENDING || !dre_i_room(bus, (unsigned)n + (broadcast ? 1u : n))) {
        return DRE_E_BUSY;
    }
    for (i = 0u; i < n; i++) {
        m = batch_msg(b, i);
        (void)dre_encode(&m, &f, NULL);
        if (dre_i_transmit(bus, &f) != DRE_OK) {
            return DRE_E_SEND;
        }
        bus->presets_pending |= dre_i_motor_bits(m.node);
    }
    for (i = 0u; i < n; i++) {
        m = batch_msg(b, i);
        arm_move(bus, &m, kind, s.type == DRE_MSG_START ? s.u.start.relative : 0u);
    }
    bus->held_start = s;
    bus->held_nodes = broadcast ? 1u : mask;
    if (bus->cfg.tx_done != NULL && !bus->cfg.tx_done(bus->cfg.user)) {
        bus->held_status = (int8_t)DRE_PENDING; /* dre_bus_poll() sends the start once the presets are out */
        bus->held_ms = bus->cfg.tick(bus->cfg.user);
        return DRE_PENDING;
    }
    return dre_i_send_starts(bus);
}

dre_status dre_preset_start(dre_bus *bus, const dre_msg *presets, uint8_t n, const dre_msg *start)
{
    uint64_t seen = 0u;
    batch b;
    uint8_t i;

    if (presets == NULL || start == NULL) {
        return DRE_E_ARG;
    }
    for (i = 0u; i < n; i++) {
        dre_status st = check_id(bus, &seen, presets[i].node, i);
        if (st != DRE_OK) {
            return st;
        }
    }
    memset(&b, 0, sizeof b);
    b.presets = presets;
    return run_batch(bus, &b, n, start);
}

dre_status dre_impedance_control(const dre_motor *m, float pos, float vel, float tff, float kp, float kd)
{
    dre_msg preset = dre_i_msg_for(m, DRE_MSG_PRESET_D);
    dre_msg start = dre_i_msg_for(m, DRE_MSG_START_IMPEDANCE);
    batch b;

    preset.u.preset_d.position = pos;
    preset.u.preset_d.speed = vel;
    preset.u.preset_d.torque_ff = tff;
    start.u.start_impedance.kp = kp;
    start.u.start_impedance.kd = kd;
    memset(&b, 0, sizeof b);
    b.presets = &preset;
    return run_batch(m->bus, &b, 1u, &start);
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

/*
 * The Q-preset time of the slowest move, each motor with its own profile,
 * rounded up to the 0.01 s the preset carries (at least 0.01 s) as the Python
 * client does; a product within float rounding error above a step stays on it.
 */
static dre_status q_batch_time(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *targets,
                               const float *from, float speed, float accel, float *time_s)
{
    float t = 0.0f, x;
    uint8_t i;

    for (i = 0u; i < n; i++) {
        float ti, d = fabsf(from == NULL ? targets[i] : targets[i] - from[i]);
        if (dre_q_move_time(d, speed, accel, dre_i_traj_of(bus, ids[i]), &ti) != DRE_OK) {
            return dre_i_range_error(bus, DRE_FIELD_TIME, i);
        }
        t = ti > t ? ti : t;
    }
    x = t * 100.0f;
    x = ceilf(x - x * 1.0e-6f);
    *time_s = (x < 1.0f ? 1.0f : x) / 100.0f;
    return *time_s <= S16_MAX ? DRE_OK : dre_i_range_error(bus, DRE_FIELD_TIME, 0u);
}

static dre_status move_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *targets, const float *from,
                              float speed, float param, uint8_t mode, uint8_t relative)
{
    static const uint8_t types[] = {DRE_MSG_PRESET_T, DRE_MSG_PRESET_Q, DRE_MSG_PRESET_P};
    dre_msg start;
    dre_status st;
    batch b;
    uint8_t i;

    if (ids == NULL || targets == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    st = check_ids(bus, n, ids);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < n; i++) {
        if (!dre_i_is_finite(targets[i])) {
            return dre_i_range_error(bus, DRE_FIELD_POSITION, i);
        }
    }
    if (mode > DRE_ANGLE_P) {
        return dre_i_range_error(bus, DRE_FIELD_MODE, 0u);
    }
    memset(&b, 0, sizeof b);
    b.type = types[mode];
    b.ids = ids;
    b.values = targets;
    b.second = speed; /* T: speed, bandwidth; Q: time (below), accel; P: speed_ff, torque_ff */
    b.third = param;
    if (mode == DRE_ANGLE_T) {
        if (dre_i_bandwidth(bus, param, &b.third) != DRE_OK) {
            return DRE_E_RANGE;
        }
        if (!dre_i_is_finite(speed)) {
            return dre_i_range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        b.second = fabsf(speed);
    } else if (mode == DRE_ANGLE_Q) {
        if (!relative && from == NULL) {
            return DRE_E_ARG;
        }
        if (!dre_i_wire_positive(speed) || speed > S16_MAX) {
            return dre_i_range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!dre_i_wire_positive(param)) {
            return dre_i_range_error(bus, DRE_FIELD_ACCEL, 0u);
        }
        for (i = 0u; i < n && !relative; i++) {
            if (!dre_i_is_finite(from[i])) {
                return dre_i_range_error(bus, DRE_FIELD_FROM, i);
            }
        }
        st = q_batch_time(bus, n, ids, targets, relative ? NULL : from, speed, param, &b.second);
        if (st != DRE_OK) {
            return st;
        }
    }
    start = start_msg((uint8_t)(DRE_START_T + mode), relative);
    return run_batch(bus, &b, n, &start);
}

dre_status dre_step_angle(const dre_motor *m, float delta, float speed, float param, uint8_t mode)
{
    return dre_step_angles(m->bus, 1u, &m->node, &delta, speed, param, mode);
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

static dre_status speeds_or_torques(dre_bus *bus, uint8_t type, uint8_t n, const uint8_t *ids, const float *values,
                                    float param, uint8_t mode)
{
    uint8_t velocity = type == DRE_MSG_PRESET_V, wire, i;
    dre_msg start = start_msg(velocity ? (uint8_t)DRE_START_V : (uint8_t)DRE_START_C, 0u);
    dre_status st;
    batch b;

    if (ids == NULL || values == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    st = check_ids(bus, n, ids);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < n; i++) {
        if (!dre_i_is_finite(values[i])) {
            return dre_i_range_error(bus, velocity ? DRE_FIELD_SPEED : DRE_FIELD_TORQUE, i);
        }
    }
    wire = velocity ? dre_i_velocity_mode(mode) : dre_i_torque_mode(mode);
    if (wire == 0u) {
        return dre_i_range_error(bus, DRE_FIELD_MODE, 0u);
    }
    if (!dre_i_is_finite(param)) {
        return dre_i_range_error(bus, DRE_FIELD_PARAM, 0u); /* even where it is unused: NaN is a mistake */
    }
    if (!velocity && wire == DRE_TORQUE_DIRECT) {
        param = 0.0f; /* direct torque has no parameter */
    } else if (wire == DRE_VEL_RAMP || wire == DRE_TORQUE_RAMP ? !dre_i_wire_positive(param) : !dre_i_is_finite(param)) {
        return dre_i_range_error(bus, DRE_FIELD_PARAM, 0u);
    }
    memset(&b, 0, sizeof b);
    b.type = type;
    b.ids = ids;
    b.values = values;
    b.second = param;
    b.mode = wire;
    return run_batch(bus, &b, n, &start);
}

dre_status dre_set_speeds(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *speeds, float param,
                          uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_V, n, ids, speeds, param, mode);
}

dre_status dre_set_torques(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *torques, float param,
                           uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_C, n, ids, torques, param, mode);
}
