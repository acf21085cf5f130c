/* Codec behaviour beyond the golden vectors: rounding, refusals, malformed frames, round trips. */
#include <math.h>
#include <string.h>

#include "check.h"
#include "drempower/dre_codec.h"

static dre_msg msg_of(uint8_t type, uint8_t node)
{
    dre_msg m;
    memset(&m, 0, sizeof m);
    m.type = type;
    m.node = node;
    return m;
}

static dre_msg preset(float p1, float p2, float p3)
{
    dre_msg m = msg_of(DRE_MSG_PRESET, 1u);
    m.u.preset.p1 = p1;
    m.u.preset.p2 = p2;
    m.u.preset.p3 = p3;
    return m;
}

/* The s16 written for p2 of a preset, or -99999 if the encoder refused it. */
static long raw_p2(float value)
{
    dre_msg m = preset(0.0f, value, 0.0f);
    dre_frame f;
    if (dre_encode(&m, &f, NULL) != DRE_OK) {
        return -99999L;
    }
    return (long)(int16_t)(uint16_t)(f.data[4] | (f.data[5] << 8));
}

static dre_field refused_field(const dre_msg *m)
{
    dre_frame f;
    dre_field bad = DRE_FIELD_NONE;
    return dre_encode(m, &f, &bad) == DRE_E_RANGE ? bad : DRE_FIELD_NONE;
}

static void test_rounding(void)
{
    /* ties go to even, as Python's round(): 12.5 -> 12, 37.5 -> 38, 62.5 -> 62, 87.5 -> 88 */
    CHECK(raw_p2(0.125f) == 12L && raw_p2(0.375f) == 38L && raw_p2(0.625f) == 62L && raw_p2(0.875f) == 88L);
    CHECK(raw_p2(-0.125f) == -12L && raw_p2(-0.375f) == -38L && raw_p2(1.125f) == 112L);
    /* decimals that are no binary32 round as the float nearest to them (dre_codec.h):
     * 0.015f is 0.01499999966 and 2.675f is 2.67499995, where Python's double gives 2 and 268 */
    CHECK(raw_p2(0.015f) == 1L && raw_p2(2.675f) == 267L);
    CHECK(raw_p2(0.005f) == 0L && raw_p2(0.0050001f) == 1L);
    /* nearest, not truncation (the vendor C library's int(x/0.01) bug) */
    CHECK(raw_p2(0.29f) == 29L && raw_p2(1.15f) == 115L && raw_p2(0.57f) == 57L && raw_p2(-0.29f) == -29L);
    CHECK(raw_p2(0.004f) == 0L && raw_p2(0.006f) == 1L && raw_p2(-0.006f) == -1L);
    CHECK(raw_p2(-0.0f) == 0L && raw_p2(1e-30f) == 0L && raw_p2(1e-45f) == 0L);
    /* the ends of the range */
    CHECK(raw_p2(327.67f) == 32767L && raw_p2(-327.68f) == -32768L);
    CHECK(raw_p2(327.675f) == 32767L);        /* the float is 327.674987..., rounds down */
    CHECK(raw_p2(327.67502f) == -99999L);     /* rounds to 32768 */
    CHECK(raw_p2(-327.68503f) == -99999L);    /* rounds to -32769 */
    CHECK(raw_p2(8388608.0f) == -99999L && raw_p2(3.0e38f) == -99999L && raw_p2(-1.0e10f) == -99999L);
}

static void test_non_finite(void)
{
    static const float bad_values[3] = {NAN, INFINITY, -INFINITY};
    unsigned i;

    for (i = 0u; i < 3u; i++) {
        float v = bad_values[i];
        dre_msg m = preset(v, 0.0f, 0.0f);
        CHECK(refused_field(&m) == DRE_FIELD_P1);
        m = preset(0.0f, 0.0f, v);
        CHECK(refused_field(&m) == DRE_FIELD_P3);
        m = msg_of(DRE_MSG_WRITE_PARAM, 1u);
        m.u.param.address = 38012u;
        m.u.param.dtype = DRE_F32;
        m.u.param.value.f32 = v;
        CHECK(refused_field(&m) == DRE_FIELD_VALUE);
        m = msg_of(DRE_MSG_START_IMPEDANCE, 0u);
        m.u.start_impedance.kd = v;
        CHECK(refused_field(&m) == DRE_FIELD_KD);
    }
}

static void test_refusals(void)
{
    dre_msg m;
    dre_frame f;
    dre_field bad = DRE_FIELD_NONE;

    m = preset(0.0f, 0.0f, 0.0f);
    m.node = 64u;
    CHECK(refused_field(&m) == DRE_FIELD_NODE);
    m = msg_of(DRE_MSG_NONE, 1u);
    CHECK(refused_field(&m) == DRE_FIELD_TYPE);
    m = msg_of(DRE_MSG_STATE + 1u, 1u);
    CHECK(refused_field(&m) == DRE_FIELD_TYPE);

    m = msg_of(DRE_MSG_VELOCITY, 1u);
    m.u.velocity.mode = 3u;
    CHECK(refused_field(&m) == DRE_FIELD_MODE);
    m.type = DRE_MSG_PRESET_V;
    CHECK(refused_field(&m) == DRE_FIELD_MODE);
    m = msg_of(DRE_MSG_TORQUE, 1u);
    m.u.torque.mode = 2u;
    CHECK(refused_field(&m) == DRE_FIELD_MODE);
    m.type = DRE_MSG_PRESET_C;
    m.u.torque.mode = 0u;
    CHECK(refused_field(&m) == DRE_FIELD_MODE);

    m = msg_of(DRE_MSG_SYSTEM, 1u);
    m.u.system.op = 8u;
    CHECK(refused_field(&m) == DRE_FIELD_OP);
    m = msg_of(DRE_MSG_START, 0u);
    m.u.start.kind = DRE_START_D; /* impedance has its own message */
    CHECK(refused_field(&m) == DRE_FIELD_KIND);
    m.u.start.kind = DRE_START_V;
    m.u.start.relative = 1u;
    CHECK(refused_field(&m) == DRE_FIELD_RELATIVE);
    m.u.start.kind = DRE_START_P;
    CHECK(dre_encode(&m, &f, &bad) == DRE_OK && f.data[4] == 1u && bad == DRE_FIELD_NONE);

    m = msg_of(DRE_MSG_READ_PARAM, 1u);
    m.u.param.address = 1u;
    m.u.param.dtype = 5u;
    CHECK(refused_field(&m) == DRE_FIELD_DTYPE);
    m.type = DRE_MSG_WRITE_PARAM;
    CHECK(refused_field(&m) == DRE_FIELD_DTYPE);
    m.u.param.address = 0u;
    m.u.param.dtype = DRE_U32;
    CHECK(refused_field(&m) == DRE_FIELD_ADDRESS);

    m = msg_of(DRE_MSG_STATE, 1u);
    m.u.state.spare_bits = 4u;
    CHECK(refused_field(&m) == DRE_FIELD_SPARE_BITS);

    /* integer values at and beyond the ends of each type */
    m = msg_of(DRE_MSG_WRITE_PARAM, 1u);
    m.u.param.address = 100u;
    m.u.param.dtype = DRE_S32;
    m.u.param.value.i = -2147483647 - 1;
    CHECK(dre_encode(&m, &f, NULL) == DRE_OK && f.data[7] == 0x80u && f.data[4] == 0u);
    m.u.param.value.i = (int64_t)-2147483647 - 2;
    CHECK(refused_field(&m) == DRE_FIELD_VALUE);
    m.u.param.dtype = DRE_U16;
    m.u.param.value.i = -1;
    CHECK(refused_field(&m) == DRE_FIELD_VALUE);
    m.u.param.dtype = DRE_S16;
    m.u.param.value.i = 32768;
    CHECK(refused_field(&m) == DRE_FIELD_VALUE);
    m.u.param.value.i = -32768;
    CHECK(dre_encode(&m, &f, NULL) == DRE_OK && f.data[5] == 0x80u && f.data[6] == 0u && f.data[7] == 0u);
    m.u.param.dtype = DRE_U32;
    m.u.param.value.i = (int64_t)1 << 32;
    CHECK(refused_field(&m) == DRE_FIELD_VALUE);
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

static void test_decode(void)
{
    dre_frame f;
    dre_msg m;
    unsigned cmd;

    /* every command field the host side does not use is refused */
    for (cmd = 0u; cmd < 32u; cmd++) {
        int known = cmd == 0x08 || cmd == 0x0C || (cmd >= 0x19 && cmd <= 0x1F);
        f = frame_of((uint16_t)(0x20u | cmd), "0100000000000100");
        CHECKF((dre_decode_command(&f, &m) == DRE_OK) == known, "command 0x%02X", cmd);
        /* replies: odd commands are state frames, 0x1E a value, the rest refused */
        CHECKF((dre_decode_reply(&f, &m) == DRE_OK) == ((cmd & 1u) != 0u || cmd == 0x1E), "reply 0x%02X", cmd);
    }
    f = frame_of(0x03E, "0000000000000000");
    CHECK(dre_decode_reply(&f, &m) == DRE_E_PROTOCOL); /* a reply never has address 0 */
    f.len = 0u;
    CHECK(dre_decode_command(&f, &m) == DRE_E_PROTOCOL);

    /* state flags and spare bits */
    f = frame_of((uint16_t)((5u << 5) | 0x1Fu), "0000B4428813ECFF");
    CHECK(dre_decode_reply(&f, &m) == DRE_OK && m.type == DRE_MSG_STATE && m.node == 5u);
    CHECK(m.u.state.position == 90.0f && m.u.state.speed == 50.0f && m.u.state.torque == -0.2f);
    CHECK(m.u.state.trajectory_done == 1u && m.u.state.error == 1u && m.u.state.spare_bits == 3u);

    /* start 0x13/0x14 ignore sys_data1; 0x10..0x12 accept only 0/1 */
    f = frame_of(0x008, "1300000007000000");
    CHECK(dre_decode_command(&f, &m) == DRE_OK && m.type == DRE_MSG_START && m.u.start.relative == 0u);
    f = frame_of(0x008, "1000000002000000");
    CHECK(dre_decode_command(&f, &m) == DRE_E_PROTOCOL);

    /* fast read ignores bytes 4..7, a 16-bit value sits in bytes 4-5 */
    f = frame_of(0x03E, "00000000FFFFFFFF");
    CHECK(dre_decode_command(&f, &m) == DRE_OK && m.type == DRE_MSG_FAST_READ);
    f = frame_of(0x03E, "54810200FEFFAAAA");
    CHECK(dre_decode_reply(&f, &m) == DRE_OK && m.u.param.dtype == DRE_S16 && m.u.param.value.i == -2);
    f = frame_of(0x03E, "54810400FEFFFFFF");
    CHECK(dre_decode_reply(&f, &m) == DRE_OK && m.u.param.value.i == -2);
    f = frame_of(0x03E, "54810300FEFFFFFF");
    CHECK(dre_decode_reply(&f, &m) == DRE_OK && m.u.param.value.i == 4294967294);
}

static void test_preset_as_kind(void)
{
    dre_msg generic = preset(10.0f, 5.0f, 2.0f), typed;

    CHECK(dre_preset_as_kind(&generic, DRE_START_V, &typed) == DRE_OK && typed.type == DRE_MSG_PRESET_V &&
          typed.u.velocity.mode == DRE_VEL_RAMP && typed.u.velocity.param == 5.0f);
    CHECK(dre_preset_as_kind(&generic, DRE_START_C, &typed) == DRE_E_PROTOCOL); /* 200 is not a torque mode */
    generic.u.preset.p3 = 6.0f;
    CHECK(dre_preset_as_kind(&generic, DRE_START_C, &typed) == DRE_OK && typed.u.torque.mode == DRE_TORQUE_RAMP);
    CHECK(dre_preset_as_kind(&generic, DRE_START_T, &typed) == DRE_OK && typed.u.position_t.bandwidth == 6.0f &&
          typed.u.position_t.speed == 5.0f);
    CHECK(dre_preset_as_kind(&generic, 0x16u, &typed) == DRE_E_ARG);
    generic.type = DRE_MSG_PRESET_T;
    CHECK(dre_preset_as_kind(&generic, DRE_START_T, &typed) == DRE_E_ARG);
}

/* Decode random frames; whatever decodes must re-encode, and re-decode to the same bytes. */
static void test_round_trip(void)
{
    uint32_t x = 12345u;
    unsigned i, k, decoded = 0u, encoded = 0u;

    for (i = 0u; i < 200000u; i++) {
        dre_frame f, g, h;
        dre_msg m, m2;
        int host = (int)(i & 1u);
        memset(&f, 0, sizeof f);
        x = x * 1664525u + 1013904223u;
        f.id = (uint16_t)(x >> 21);
        f.len = 8u;
        for (k = 0u; k < 8u; k++) {
            x = x * 1664525u + 1013904223u;
            /* mostly small bytes so that modes, types and addresses are often valid */
            f.data[k] = (uint8_t)((x >> 28) < 12u ? (x >> 24) & 0x07u : x >> 24);
        }
        if ((host ? dre_decode_command(&f, &m) : dre_decode_reply(&f, &m)) != DRE_OK) {
            continue;
        }
        decoded++;
        if (dre_encode(&m, &g, NULL) != DRE_OK) {
            continue; /* e.g. a NaN on the wire cannot be sent back */
        }
        encoded++;
        CHECKF(g.id == f.id, "id 0x%03X re-encoded as 0x%03X", f.id, g.id);
        CHECKF((host ? dre_decode_command(&g, &m2) : dre_decode_reply(&g, &m2)) == DRE_OK &&
                   dre_encode(&m2, &h, NULL) == DRE_OK && memcmp(g.data, h.data, 8u) == 0,
               "id 0x%03X: second round trip differs", f.id);
    }
    printf("round trip: %u decoded, %u re-encoded\n", decoded, encoded);
    CHECK(decoded > 50000u && encoded > 40000u);
}

static void test_names(void)
{
    CHECK(strcmp(dre_field_name(DRE_FIELD_TORQUE_FF), "torque_ff") == 0);
    CHECK(strcmp(dre_field_name(DRE_FIELD_SPARE_BITS), "spare_bits") == 0);
    CHECK(strcmp(dre_field_name((dre_field)99), "?") == 0);
    CHECK(strcmp(dre_status_name(DRE_E_TIMEOUT), "timeout") == 0);
    CHECK(strcmp(dre_status_name(DRE_PENDING), "pending") == 0);
    CHECK(strcmp(dre_status_name(DRE_E_FAULT), "fault") == 0 && strcmp(dre_status_name(DRE_E_VERIFY), "verify") == 0);
    CHECK(strcmp(dre_status_name(DRE_E_ID_TAKEN), "id taken") == 0);
    CHECK(strcmp(dre_status_name(DRE_E_NO_MOTOR), "no motor") == 0);
    CHECK(strcmp(dre_status_name(DRE_E_MOVE), "move") == 0);
    CHECK(strcmp(dre_field_name(DRE_FIELD_FROM), "from") == 0);
    CHECK(strcmp(dre_status_name((dre_status)-99), "?") == 0);
}

int main(void)
{
    test_rounding();
    test_non_finite();
    test_refusals();
    test_decode();
    test_preset_as_kind();
    test_round_trip();
    test_names();
    return check_report("test_codec");
}
