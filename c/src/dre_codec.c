/* Encode and decode DrEmpower CAN frames (see dre_codec.h). */
#include "drempower/dre_codec.h"

#include <string.h>

#include "dre_bytes.h"

/* --------------------------------------------------------------- scalars */

static int f32_finite(float v)
{
    return (dre_f32_bits(v) & 0x7F800000u) != 0x7F800000u;
}

/*
 * value x 100 rounded to the nearest integer, ties to even, computed exactly
 * from the binary32 bits (the product of a 24-bit mantissa and 100 fits in 31
 * bits). This is what Python's round(value * 100) gives for the same binary32
 * value (see dre_codec.h for decimals that are not binary32 values).
 * Returns 0 when the result does not fit s16 or the value is not finite.
 */
static int s16_scaled(float v, int16_t *out)
{
    uint32_t bits = dre_f32_bits(v);
    uint32_t exponent = (bits >> 23) & 0xFFu;
    uint32_t mag;

    if (exponent == 0xFFu) {
        return 0;
    }
    if (exponent == 0u) {
        mag = 0u; /* zero or subnormal: |v x 100| < 2^-100 */
    } else {
        uint32_t product = ((bits & 0x7FFFFFu) | 0x800000u) * 100u;
        uint32_t shift;
        if (exponent >= 150u) {
            return 0; /* |v| >= 2^23 */
        }
        shift = 150u - exponent;
        if (shift > 31u) {
            mag = 0u; /* product < 2^31 <= half of 2^shift */
        } else {
            uint32_t rem = product & (((uint32_t)1 << shift) - 1u);
            uint32_t half = (uint32_t)1 << (shift - 1u);
            mag = product >> shift;
            if (rem > half || (rem == half && (mag & 1u) != 0u)) {
                mag++;
            }
        }
    }
    if ((bits >> 31) != 0u) {
        if (mag > 32768u) {
            return 0;
        }
        *out = (int16_t)(-(int32_t)mag);
    } else {
        if (mag > 32767u) {
            return 0;
        }
        *out = (int16_t)mag;
    }
    return 1;
}

static float unscale(uint16_t raw)
{
    return (float)dre_s16_of(raw) / 100.0f;
}

/* --------------------------------------------------------------- encode */

/* data = f32 a, s16 b x100, s16 c x100. Returns the failing field or NONE. */
static dre_field put_fss(uint8_t *d, float a, dre_field fa, float b, dre_field fb, float c, dre_field fc)
{
    int16_t rb, rc;
    if (!f32_finite(a)) {
        return fa;
    }
    if (!s16_scaled(b, &rb)) {
        return fb;
    }
    if (!s16_scaled(c, &rc)) {
        return fc;
    }
    dre_put32(d, dre_f32_bits(a));
    dre_put16(d + 4, (uint16_t)rb);
    dre_put16(d + 6, (uint16_t)rc);
    return DRE_FIELD_NONE;
}

/* data = f32 a, s16 b x100, u16 mode. */
static dre_field put_fsu(uint8_t *d, float a, dre_field fa, float b, dre_field fb, uint16_t mode)
{
    dre_field f = put_fss(d, a, fa, b, fb, 0.0f, DRE_FIELD_NONE);
    dre_put16(d + 6, mode);
    return f;
}

static int vel_mode_ok(uint8_t mode)
{
    return mode == DRE_VEL_PASSTHROUGH || mode == DRE_VEL_RAMP;
}

static int torque_mode_ok(uint8_t mode)
{
    return mode == DRE_TORQUE_DIRECT || mode == DRE_TORQUE_RAMP;
}

/* data = u16 address, u16 dtype, value (2 or 4 bytes). */
static dre_field put_rw(uint8_t *d, uint32_t address, uint8_t dtype, dre_value v)
{
    if (address == 0u || address > 0xFFFFu) {
        return DRE_FIELD_ADDRESS;
    }
    switch (dtype) {
    case DRE_F32:
        if (!f32_finite(v.f32)) {
            return DRE_FIELD_VALUE;
        }
        dre_put32(d + 4, dre_f32_bits(v.f32));
        break;
    case DRE_U16:
        if (v.i < 0 || v.i > 0xFFFF) {
            return DRE_FIELD_VALUE;
        }
        dre_put16(d + 4, (uint16_t)v.i);
        break;
    case DRE_S16:
        if (v.i < -32768 || v.i > 32767) {
            return DRE_FIELD_VALUE;
        }
        dre_put16(d + 4, (uint16_t)(v.i & 0xFFFF));
        break;
    case DRE_U32:
        if (v.i < 0 || v.i > (int64_t)0xFFFFFFFFu) {
            return DRE_FIELD_VALUE;
        }
        dre_put32(d + 4, (uint32_t)v.i);
        break;
    case DRE_S32:
        if (v.i < -(int64_t)0x80000000u || v.i > (int64_t)0x7FFFFFFF) {
            return DRE_FIELD_VALUE;
        }
        dre_put32(d + 4, (uint32_t)(v.i & (int64_t)0xFFFFFFFFu));
        break;
    default:
        return DRE_FIELD_DTYPE;
    }
    dre_put16(d, (uint16_t)address);
    dre_put16(d + 2, dtype);
    return DRE_FIELD_NONE;
}

/* Fill d and *cmd for msg; returns the failing field or NONE. */
static dre_field encode_data(const dre_msg *m, uint8_t *d, uint8_t *cmd)
{
    int16_t kp, kd;

    switch (m->type) {
    case DRE_MSG_POSITION_T:
    case DRE_MSG_PRESET_T:
        *cmd = m->type == DRE_MSG_POSITION_T ? DRE_CMD_POSITION_T : DRE_CMD_PRESET;
        return put_fss(d, m->u.position_t.position, DRE_FIELD_POSITION, m->u.position_t.speed, DRE_FIELD_SPEED,
                       m->u.position_t.bandwidth, DRE_FIELD_BANDWIDTH);
    case DRE_MSG_POSITION_Q:
        *cmd = DRE_CMD_POSITION_Q;
        return put_fss(d, m->u.position_q.position, DRE_FIELD_POSITION, m->u.position_q.speed, DRE_FIELD_SPEED,
                       m->u.position_q.accel, DRE_FIELD_ACCEL);
    case DRE_MSG_POSITION_P:
    case DRE_MSG_PRESET_P:
        *cmd = m->type == DRE_MSG_POSITION_P ? DRE_CMD_POSITION_P : DRE_CMD_PRESET;
        return put_fss(d, m->u.position_p.position, DRE_FIELD_POSITION, m->u.position_p.speed_ff,
                       DRE_FIELD_SPEED_FF, m->u.position_p.torque_ff, DRE_FIELD_TORQUE_FF);
    case DRE_MSG_VELOCITY:
    case DRE_MSG_PRESET_V:
        if (!vel_mode_ok(m->u.velocity.mode)) {
            return DRE_FIELD_MODE;
        }
        *cmd = m->type == DRE_MSG_VELOCITY ? DRE_CMD_VELOCITY : DRE_CMD_PRESET;
        return put_fsu(d, m->u.velocity.speed, DRE_FIELD_SPEED, m->u.velocity.param, DRE_FIELD_PARAM,
                       (uint16_t)(m->type == DRE_MSG_VELOCITY ? m->u.velocity.mode : m->u.velocity.mode * 100u));
    case DRE_MSG_TORQUE:
    case DRE_MSG_PRESET_C:
        if (!torque_mode_ok(m->u.torque.mode)) {
            return DRE_FIELD_MODE;
        }
        *cmd = m->type == DRE_MSG_TORQUE ? DRE_CMD_TORQUE : DRE_CMD_PRESET;
        return put_fsu(d, m->u.torque.torque, DRE_FIELD_TORQUE, m->u.torque.param, DRE_FIELD_PARAM,
                       (uint16_t)(m->type == DRE_MSG_TORQUE ? m->u.torque.mode : m->u.torque.mode * 100u));
    case DRE_MSG_PRESET:
        *cmd = DRE_CMD_PRESET;
        return put_fss(d, m->u.preset.p1, DRE_FIELD_P1, m->u.preset.p2, DRE_FIELD_P2, m->u.preset.p3,
                       DRE_FIELD_P3);
    case DRE_MSG_PRESET_Q:
        *cmd = DRE_CMD_PRESET;
        return put_fss(d, m->u.preset_q.position, DRE_FIELD_POSITION, m->u.preset_q.time, DRE_FIELD_TIME,
                       m->u.preset_q.accel, DRE_FIELD_ACCEL);
    case DRE_MSG_PRESET_D:
        *cmd = DRE_CMD_PRESET;
        return put_fss(d, m->u.preset_d.position, DRE_FIELD_POSITION, m->u.preset_d.speed, DRE_FIELD_SPEED,
                       m->u.preset_d.torque_ff, DRE_FIELD_TORQUE_FF);
    case DRE_MSG_SYSTEM:
        if (m->u.system.op > DRE_SYS_ENTER_DFU_MODE) {
            return DRE_FIELD_OP;
        }
        *cmd = DRE_CMD_SYSTEM;
        d[0] = m->u.system.op;
        return DRE_FIELD_NONE;
    case DRE_MSG_START:
        if (m->u.start.kind < DRE_START_T || m->u.start.kind > DRE_START_C) {
            return DRE_FIELD_KIND;
        }
        if (m->u.start.relative != 0u && m->u.start.kind > DRE_START_P) {
            return DRE_FIELD_RELATIVE;
        }
        *cmd = DRE_CMD_SYSTEM;
        d[0] = m->u.start.kind;
        d[4] = m->u.start.relative != 0u ? 1u : 0u;
        return DRE_FIELD_NONE;
    case DRE_MSG_START_IMPEDANCE:
        if (!s16_scaled(m->u.start_impedance.kp, &kp)) {
            return DRE_FIELD_KP;
        }
        if (!s16_scaled(m->u.start_impedance.kd, &kd)) {
            return DRE_FIELD_KD;
        }
        *cmd = DRE_CMD_SYSTEM;
        d[0] = DRE_START_D;
        dre_put16(d + 4, (uint16_t)kp);
        dre_put16(d + 6, (uint16_t)kd);
        return DRE_FIELD_NONE;
    case DRE_MSG_READ_PARAM:
        if (m->u.param.address == 0u || m->u.param.address > 0xFFFFu) {
            return DRE_FIELD_ADDRESS;
        }
        if (m->u.param.dtype > DRE_S32) {
            return DRE_FIELD_DTYPE;
        }
        *cmd = DRE_CMD_READ;
        dre_put16(d, (uint16_t)m->u.param.address);
        dre_put16(d + 2, m->u.param.dtype);
        return DRE_FIELD_NONE;
    case DRE_MSG_FAST_READ:
        *cmd = DRE_CMD_READ;
        return DRE_FIELD_NONE;
    case DRE_MSG_WRITE_PARAM:
    case DRE_MSG_PARAM_VALUE:
        *cmd = m->type == DRE_MSG_WRITE_PARAM ? DRE_CMD_WRITE : DRE_CMD_READ;
        return put_rw(d, m->u.param.address, m->u.param.dtype, m->u.param.value);
    case DRE_MSG_STATE:
        if (m->u.state.spare_bits > 3u) {
            return DRE_FIELD_SPARE_BITS;
        }
        *cmd = (uint8_t)(((unsigned)m->u.state.spare_bits << 3) | (m->u.state.error != 0u ? 4u : 0u) |
                         (m->u.state.trajectory_done != 0u ? 2u : 0u) | 1u);
        return put_fss(d, m->u.state.position, DRE_FIELD_POSITION, m->u.state.speed, DRE_FIELD_SPEED,
                       m->u.state.torque, DRE_FIELD_TORQUE);
    default:
        return DRE_FIELD_TYPE;
    }
}

dre_status dre_encode(const dre_msg *msg, dre_frame *out, dre_field *bad)
{
    uint8_t data[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    uint8_t cmd = 0u;
    dre_field f = msg->node > DRE_MAX_NODE ? DRE_FIELD_NODE : encode_data(msg, data, &cmd);

    if (bad != NULL) {
        *bad = f;
    }
    if (f != DRE_FIELD_NONE) {
        return DRE_E_RANGE;
    }
    out->id = (uint16_t)(((uint16_t)msg->node << 5) | cmd);
    out->len = 8u;
    memcpy(out->data, data, sizeof data);
    return DRE_OK;
}

/* --------------------------------------------------------------- decode */

static void get_fss(const uint8_t *d, float *a, float *b, float *c)
{
    *a = dre_bits_f32(dre_get32(d));
    *b = unscale(dre_get16(d + 4));
    *c = unscale(dre_get16(d + 6));
}

static dre_value get_value(const uint8_t *d, uint8_t dtype)
{
    dre_value v;
    switch (dtype) {
    case DRE_F32:
        v.f32 = dre_bits_f32(dre_get32(d));
        break;
    case DRE_U16:
        v.i = dre_get16(d);
        break;
    case DRE_S16:
        v.i = dre_s16_of(dre_get16(d));
        break;
    case DRE_U32:
        v.i = (int64_t)dre_get32(d);
        break;
    default:
        v.i = dre_s32_of(dre_get32(d));
        break;
    }
    return v;
}

static dre_status decode_system(const uint8_t *d, dre_msg *m)
{
    uint32_t op = dre_get32(d);
    uint16_t d1 = dre_get16(d + 4);

    if (op <= DRE_SYS_ENTER_DFU_MODE) {
        m->type = DRE_MSG_SYSTEM;
        m->u.system.op = (uint8_t)op;
    } else if (op >= DRE_START_T && op <= DRE_START_C) {
        if (op <= DRE_START_P && d1 > 1u) {
            return DRE_E_PROTOCOL;
        }
        m->type = DRE_MSG_START;
        m->u.start.kind = (uint8_t)op;
        m->u.start.relative = op <= DRE_START_P ? (uint8_t)d1 : 0u;
    } else if (op == DRE_START_D) {
        m->type = DRE_MSG_START_IMPEDANCE;
        m->u.start_impedance.kp = unscale(d1);
        m->u.start_impedance.kd = unscale(dre_get16(d + 6));
    } else {
        return DRE_E_PROTOCOL;
    }
    return DRE_OK;
}

static dre_status decode_host(uint8_t cmd, const uint8_t *d, dre_msg *m)
{
    uint16_t word = dre_get16(d + 6);
    uint16_t address = dre_get16(d);
    uint16_t dtype = dre_get16(d + 2);

    switch (cmd) {
    case DRE_CMD_SYSTEM:
        return decode_system(d, m);
    case DRE_CMD_PRESET:
        m->type = DRE_MSG_PRESET;
        get_fss(d, &m->u.preset.p1, &m->u.preset.p2, &m->u.preset.p3);
        return DRE_OK;
    case DRE_CMD_POSITION_T:
        m->type = DRE_MSG_POSITION_T;
        get_fss(d, &m->u.position_t.position, &m->u.position_t.speed, &m->u.position_t.bandwidth);
        return DRE_OK;
    case DRE_CMD_POSITION_Q:
        m->type = DRE_MSG_POSITION_Q;
        get_fss(d, &m->u.position_q.position, &m->u.position_q.speed, &m->u.position_q.accel);
        return DRE_OK;
    case DRE_CMD_POSITION_P:
        m->type = DRE_MSG_POSITION_P;
        get_fss(d, &m->u.position_p.position, &m->u.position_p.speed_ff, &m->u.position_p.torque_ff);
        return DRE_OK;
    case DRE_CMD_VELOCITY:
        if (word != DRE_VEL_PASSTHROUGH && word != DRE_VEL_RAMP) {
            return DRE_E_PROTOCOL;
        }
        m->type = DRE_MSG_VELOCITY;
        m->u.velocity.speed = dre_bits_f32(dre_get32(d));
        m->u.velocity.param = unscale(dre_get16(d + 4));
        m->u.velocity.mode = (uint8_t)word;
        return DRE_OK;
    case DRE_CMD_TORQUE:
        if (word != DRE_TORQUE_DIRECT && word != DRE_TORQUE_RAMP) {
            return DRE_E_PROTOCOL;
        }
        m->type = DRE_MSG_TORQUE;
        m->u.torque.torque = dre_bits_f32(dre_get32(d));
        m->u.torque.param = unscale(dre_get16(d + 4));
        m->u.torque.mode = (uint8_t)word;
        return DRE_OK;
    case DRE_CMD_READ:
        if (address == 0u) {
            if (dtype != 0u) {
                return DRE_E_PROTOCOL;
            }
            m->type = DRE_MSG_FAST_READ;
            return DRE_OK;
        }
        if (dtype > DRE_S32) {
            return DRE_E_PROTOCOL;
        }
        m->type = DRE_MSG_READ_PARAM;
        break;
    case DRE_CMD_WRITE:
        if (dtype > DRE_S32 || address == 0u) {
            return DRE_E_PROTOCOL;
        }
        m->type = DRE_MSG_WRITE_PARAM;
        m->u.param.value = get_value(d + 4, (uint8_t)dtype);
        break;
    default:
        return DRE_E_PROTOCOL;
    }
    m->u.param.address = address;
    m->u.param.dtype = (uint8_t)dtype;
    return DRE_OK;
}

static int frame_ok(const dre_frame *f)
{
    return f->len == 8u && f->id <= DRE_MAX_ID;
}

dre_status dre_decode_command(const dre_frame *frame, dre_msg *out)
{
    dre_msg m;
    dre_status st;

    if (!frame_ok(frame)) {
        return DRE_E_PROTOCOL;
    }
    memset(&m, 0, sizeof m);
    m.node = (uint8_t)(frame->id >> 5);
    st = decode_host((uint8_t)(frame->id & 0x1Fu), frame->data, &m);
    if (st == DRE_OK) {
        *out = m;
    }
    return st;
}

dre_status dre_decode_reply(const dre_frame *frame, dre_msg *out)
{
    dre_msg m;
    uint8_t cmd;
    uint16_t address, dtype;

    if (!frame_ok(frame)) {
        return DRE_E_PROTOCOL;
    }
    cmd = (uint8_t)(frame->id & 0x1Fu);
    memset(&m, 0, sizeof m);
    m.node = (uint8_t)(frame->id >> 5);
    if ((cmd & 1u) != 0u) {
        m.type = DRE_MSG_STATE;
        get_fss(frame->data, &m.u.state.position, &m.u.state.speed, &m.u.state.torque);
        m.u.state.trajectory_done = (uint8_t)((cmd >> 1) & 1u);
        m.u.state.error = (uint8_t)((cmd >> 2) & 1u);
        m.u.state.spare_bits = (uint8_t)(cmd >> 3);
    } else if (cmd == DRE_CMD_READ) {
        address = dre_get16(frame->data);
        dtype = dre_get16(frame->data + 2);
        if (dtype > DRE_S32 || address == 0u) {
            return DRE_E_PROTOCOL;
        }
        m.type = DRE_MSG_PARAM_VALUE;
        m.u.param.address = address;
        m.u.param.dtype = (uint8_t)dtype;
        m.u.param.value = get_value(frame->data + 4, (uint8_t)dtype);
    } else {
        return DRE_E_PROTOCOL;
    }
    *out = m;
    return DRE_OK;
}

/* --------------------------------------------------------------- presets */

dre_status dre_preset_as_kind(const dre_msg *preset, uint8_t kind, dre_msg *out)
{
    dre_msg m;
    float p1 = preset->u.preset.p1, p2 = preset->u.preset.p2, p3 = preset->u.preset.p3;
    int16_t code = 0;

    if (preset->type != DRE_MSG_PRESET) {
        return DRE_E_ARG;
    }
    memset(&m, 0, sizeof m);
    m.node = preset->node;
    switch (kind) {
    case DRE_START_T:
        m.type = DRE_MSG_PRESET_T;
        m.u.position_t.position = p1;
        m.u.position_t.speed = p2;
        m.u.position_t.bandwidth = p3;
        break;
    case DRE_START_Q:
        m.type = DRE_MSG_PRESET_Q;
        m.u.preset_q.position = p1;
        m.u.preset_q.time = p2;
        m.u.preset_q.accel = p3;
        break;
    case DRE_START_P:
        m.type = DRE_MSG_PRESET_P;
        m.u.position_p.position = p1;
        m.u.position_p.speed_ff = p2;
        m.u.position_p.torque_ff = p3;
        break;
    case DRE_START_D:
        m.type = DRE_MSG_PRESET_D;
        m.u.preset_d.position = p1;
        m.u.preset_d.speed = p2;
        m.u.preset_d.torque_ff = p3;
        break;
    case DRE_START_V:
        if (!s16_scaled(p3, &code) || (code != 100 && code != 200)) {
            return DRE_E_PROTOCOL;
        }
        m.type = DRE_MSG_PRESET_V;
        m.u.velocity.speed = p1;
        m.u.velocity.param = p2;
        m.u.velocity.mode = (uint8_t)(code / 100);
        break;
    case DRE_START_C:
        if (!s16_scaled(p3, &code) || (code != 100 && code != 600)) {
            return DRE_E_PROTOCOL;
        }
        m.type = DRE_MSG_PRESET_C;
        m.u.torque.torque = p1;
        m.u.torque.param = p2;
        m.u.torque.mode = (uint8_t)(code / 100);
        break;
    default:
        return DRE_E_ARG;
    }
    *out = m;
    return DRE_OK;
}

/* --------------------------------------------------------------- names */

const char *dre_field_name(dre_field field)
{
    static const char *const names[] = {
        "",         "node",      "type", "position", "speed", "accel", "bandwidth", "speed_ff", "torque_ff",
        "torque",   "param",     "mode", "p1",       "p2",    "p3",    "time",      "op",       "kind",
        "relative", "kp",        "kd",   "address",  "dtype", "value", "spare_bits", "from"};
    return (unsigned)field < sizeof names / sizeof names[0] ? names[field] : "?";
}

const char *dre_status_name(dre_status status)
{
    switch (status) {
    case DRE_OK:
        return "ok";
    case DRE_PENDING:
        return "pending";
    case DRE_E_RANGE:
        return "range";
    case DRE_E_PROTOCOL:
        return "protocol";
    case DRE_E_ARG:
        return "argument";
    case DRE_E_BUSY:
        return "busy";
    case DRE_E_SEND:
        return "send";
    case DRE_E_TIMEOUT:
        return "timeout";
    case DRE_E_ACCESS:
        return "read-only";
    case DRE_E_FAULT:
        return "fault";
    case DRE_E_VERIFY:
        return "verify";
    case DRE_E_ID_TAKEN:
        return "id taken";
    case DRE_E_NO_MOTOR:
        return "no motor";
    case DRE_E_MOVE:
        return "move";
    default:
        return "?";
    }
}
