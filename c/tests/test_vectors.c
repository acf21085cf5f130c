/* Runs every golden vector of spec/vectors: encode from fields, decode from bytes, refuse invalid input. */
#include <string.h>

#include "check.h"
#include "vectors.h"

/* f32 fields travel exactly: compare the bits (so -0.0 stays -0.0). */
static int same_f32(float a, float b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/*
 * s16 fields decode to raw / 100 rounded to binary32, the same float the
 * vector's decimal value converts to; compare exactly.
 */
static int same_s16(float a, float b)
{
    return a == b;
}

static int same_msg(const dre_msg *a, const dre_msg *b)
{
    if (a->type != b->type || a->node != b->node) {
        return 0;
    }
    switch (a->type) {
    case DRE_MSG_POSITION_T:
    case DRE_MSG_PRESET_T:
        return same_f32(a->u.position_t.position, b->u.position_t.position) &&
               same_s16(a->u.position_t.bandwidth, b->u.position_t.bandwidth) &&
               same_s16(a->u.position_t.speed, b->u.position_t.speed);
    case DRE_MSG_POSITION_Q:
        return same_f32(a->u.position_q.position, b->u.position_q.position) &&
               same_s16(a->u.position_q.speed, b->u.position_q.speed) &&
               same_s16(a->u.position_q.accel, b->u.position_q.accel);
    case DRE_MSG_POSITION_P:
    case DRE_MSG_PRESET_P:
        return same_f32(a->u.position_p.position, b->u.position_p.position) &&
               same_s16(a->u.position_p.speed_ff, b->u.position_p.speed_ff) &&
               same_s16(a->u.position_p.torque_ff, b->u.position_p.torque_ff);
    case DRE_MSG_VELOCITY:
    case DRE_MSG_PRESET_V:
        return same_f32(a->u.velocity.speed, b->u.velocity.speed) &&
               same_s16(a->u.velocity.param, b->u.velocity.param) && a->u.velocity.mode == b->u.velocity.mode;
    case DRE_MSG_TORQUE:
    case DRE_MSG_PRESET_C:
        return same_f32(a->u.torque.torque, b->u.torque.torque) && same_s16(a->u.torque.param, b->u.torque.param) &&
               a->u.torque.mode == b->u.torque.mode;
    case DRE_MSG_PRESET:
        return same_f32(a->u.preset.p1, b->u.preset.p1) && same_s16(a->u.preset.p2, b->u.preset.p2) &&
               same_s16(a->u.preset.p3, b->u.preset.p3);
    case DRE_MSG_PRESET_Q:
        return same_f32(a->u.preset_q.position, b->u.preset_q.position) &&
               same_s16(a->u.preset_q.time, b->u.preset_q.time) && same_s16(a->u.preset_q.accel, b->u.preset_q.accel);
    case DRE_MSG_PRESET_D:
        return same_f32(a->u.preset_d.position, b->u.preset_d.position) &&
               same_s16(a->u.preset_d.speed, b->u.preset_d.speed) &&
               same_s16(a->u.preset_d.torque_ff, b->u.preset_d.torque_ff);
    case DRE_MSG_SYSTEM:
        return a->u.system.op == b->u.system.op;
    case DRE_MSG_START:
        return a->u.start.kind == b->u.start.kind && a->u.start.relative == b->u.start.relative;
    case DRE_MSG_START_IMPEDANCE:
        return same_s16(a->u.start_impedance.kp, b->u.start_impedance.kp) &&
               same_s16(a->u.start_impedance.kd, b->u.start_impedance.kd);
    case DRE_MSG_FAST_READ:
        return 1;
    case DRE_MSG_READ_PARAM:
        return a->u.param.address == b->u.param.address && a->u.param.dtype == b->u.param.dtype;
    case DRE_MSG_WRITE_PARAM:
    case DRE_MSG_PARAM_VALUE:
        return a->u.param.address == b->u.param.address && a->u.param.dtype == b->u.param.dtype &&
               (a->u.param.dtype == DRE_F32 ? same_f32(a->u.param.value.f32, b->u.param.value.f32)
                                            : a->u.param.value.i == b->u.param.value.i);
    case DRE_MSG_STATE:
        return same_f32(a->u.state.position, b->u.state.position) && same_s16(a->u.state.speed, b->u.state.speed) &&
               same_s16(a->u.state.torque, b->u.state.torque) &&
               a->u.state.trajectory_done == b->u.state.trajectory_done && a->u.state.error == b->u.state.error &&
               a->u.state.spare_bits == b->u.state.spare_bits;
    default:
        return 0;
    }
}

/* The start kind of a typed preset, or 0. */
static uint8_t typed_preset_kind(uint8_t type)
{
    switch (type) {
    case DRE_MSG_PRESET_T:
        return DRE_START_T;
    case DRE_MSG_PRESET_Q:
        return DRE_START_Q;
    case DRE_MSG_PRESET_P:
        return DRE_START_P;
    case DRE_MSG_PRESET_V:
        return DRE_START_V;
    case DRE_MSG_PRESET_C:
        return DRE_START_C;
    case DRE_MSG_PRESET_D:
        return DRE_START_D;
    default:
        return 0u;
    }
}

static dre_status decode(const vec_case *v, const dre_frame *f, dre_msg *out)
{
    return v->host ? dre_decode_command(f, out) : dre_decode_reply(f, out);
}

static void run_valid(const vec_case *v)
{
    dre_frame f;
    dre_msg m, typed;
    dre_field bad = DRE_FIELD_TYPE;
    uint8_t kind;

    CHECKF(dre_encode(&v->msg, &f, &bad) == DRE_OK, "%s: %s: encode refused (%s)", v->file, v->name,
           dre_field_name(bad));
    CHECKF(bad == DRE_FIELD_NONE, "%s: %s: bad field set on success", v->file, v->name);
    CHECKF(f.id == v->id && f.len == 8u && v->len == 8u && memcmp(f.data, v->data, 8u) == 0,
           "%s: %s: encoded bytes differ", v->file, v->name);

    memset(&f, 0, sizeof f);
    f.id = v->id;
    f.len = v->len;
    memcpy(f.data, v->data, 8u);
    CHECKF(decode(v, &f, &m) == DRE_OK, "%s: %s: decode refused", v->file, v->name);
    CHECKF(same_msg(&m, &v->expect), "%s: %s: decoded fields differ", v->file, v->name);

    /* a typed preset decodes to the generic form; interpreting it for its start gives the fields back */
    kind = typed_preset_kind(v->msg.type);
    if (kind != 0u) {
        CHECKF(dre_preset_as_kind(&m, kind, &typed) == DRE_OK && same_msg(&typed, &v->msg), "%s: %s: as_kind",
               v->file, v->name);
    }
}

static void run_range(const vec_case *v)
{
    dre_frame f, before;
    dre_field bad = DRE_FIELD_NONE;

    memset(&f, 0xA5, sizeof f);
    before = f;
    CHECKF(dre_encode(&v->msg, &f, &bad) == DRE_E_RANGE, "%s: %s: encode accepted", v->file, v->name);
    CHECKF(strcmp(dre_field_name(bad), v->field) == 0, "%s: %s: field %s, expected %s", v->file, v->name,
           dre_field_name(bad), v->field);
    CHECKF(memcmp(&f, &before, sizeof f) == 0, "%s: %s: frame written", v->file, v->name);
}

static void run_protocol(const vec_case *v)
{
    dre_frame f;
    dre_msg m, before;

    memset(&f, 0, sizeof f);
    f.id = v->id;
    f.len = v->len;
    memcpy(f.data, v->data, 8u);
    memset(&m, 0x5A, sizeof m);
    before = m;
    CHECKF(decode(v, &f, &m) == DRE_E_PROTOCOL, "%s: %s: decode accepted", v->file, v->name);
    CHECKF(memcmp(&m, &before, sizeof m) == 0, "%s: %s: output written", v->file, v->name);
}

int main(void)
{
    unsigned i, counts[3] = {0u, 0u, 0u};

    for (i = 0u; i < vec_count; i++) {
        const vec_case *v = &vec_cases[i];
        counts[v->kind]++;
        if (v->kind == VEC_VALID) {
            run_valid(v);
        } else if (v->kind == VEC_RANGE) {
            run_range(v);
        } else {
            run_protocol(v);
        }
    }
    printf("%u vectors: %u valid, %u refused by the encoder, %u refused by the decoder\n", vec_count, counts[0],
           counts[1], counts[2]);
    CHECK(counts[VEC_VALID] > 0u && counts[VEC_RANGE] > 0u && counts[VEC_PROTOCOL] > 0u);
    return check_report("test_vectors");
}
