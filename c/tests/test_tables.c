/* The parameter table and the error words, checked against the Python core. */
#include <string.h>

#include "check.h"
#include "drempower/dre_client.h"
#include "drempower/dre_codec.h"
#include "drempower/dre_errors.h"
#include "drempower/dre_params.h"
#include "reference.h"

static void test_params_match_python(void)
{
    unsigned i;

    CHECKF(ref_param_count == DRE_PARAM_COUNT, "C table has %u parameters, Python %u", (unsigned)DRE_PARAM_COUNT,
           ref_param_count);
    for (i = 0u; i < ref_param_count && i < DRE_PARAM_COUNT; i++) {
        const ref_param *r = &ref_params[i];
        const dre_param_info *p = &dre_param_table[i];
        CHECKF(strcmp(p->name, r->name) == 0 && strcmp(p->unit, r->unit) == 0 &&
                   DRE_PARAM_ADDRESS(p->param) == r->address && DRE_PARAM_DTYPE(p->param) == r->dtype &&
                   DRE_PARAM_FLAGS(p->param) == r->flags,
               "parameter %u (%s) differs from the Python registry", i, r->name);
    }
}

/* The client's parameters with a fixed set of values are those of the Python client, with its ranges. */
static void test_choices_match_python(void)
{
    unsigned i, n = 0u;

    for (i = 0u; i < ref_param_count; i++) {
        const ref_param *r = &ref_params[i];
        uint8_t lo = 0u, hi = 0u;
        int c = dre_param_choices(r->address, &lo, &hi);
        CHECKF(c == r->choices && (!c || (lo == r->lo && hi == r->hi)), "%s: C %d %u..%u, Python %d %u..%u", r->name,
               c, (unsigned)lo, (unsigned)hi, r->choices, (unsigned)r->lo, (unsigned)r->hi);
        n += (unsigned)r->choices;
    }
    CHECK(n == 4u);
}

/* A write the Python client sends passes the C checks (fixed set, then domain), and one it refuses does not. */
static void test_domains_match_python(void)
{
    unsigned i, refused = 0u, forced = 0u;

    for (i = 0u; i < ref_write_count; i++) {
        const ref_write *r = &ref_writes[i];
        dre_value v;
        uint8_t lo, hi;
        int ok;
        if (r->dtype == DRE_F32) {
            v.f32 = r->f;
        } else {
            v.i = r->i;
        }
        ok = dre_param_check(r->address, r->dtype, v, r->force) == DRE_OK;
        if (dre_param_choices(r->address, &lo, &hi) && (r->i < lo || r->i > hi)) {
            ok = 0;
        }
        CHECKF(ok == r->ok, "%u = %g / %lld (force %d): C %d, Python %d", (unsigned)r->address, (double)r->f,
               (long long)r->i, r->force, ok, r->ok);
        refused += (unsigned)!r->ok;
        forced += (unsigned)(r->force && r->ok && i > 0u && !ref_writes[i - 1u].ok);
    }
    /* the cases cover refusals and soft bounds that force lets through */
    CHECK(ref_write_count > 500u && refused > 100u && forced > 20u);
}

static void test_param_lookup(void)
{
    unsigned i;
    const dre_param_info *p;

    for (i = 0u; i < DRE_PARAM_COUNT; i++) {
        const dre_param_info *e = &dre_param_table[i];
        CHECKF(dre_param_find(e->name) == e, "find %s", e->name);
        CHECKF(dre_param_by_address(DRE_PARAM_ADDRESS(e->param)) == e, "address of %s", e->name);
        if (i > 0u) {
            CHECK(DRE_PARAM_ADDRESS(dre_param_table[i - 1u].param) < DRE_PARAM_ADDRESS(e->param));
        }
    }
    p = dre_param_find("axis1.output_shaft.pos_estimate");
    CHECK(p != NULL && p->param == DRE_P_AXIS0_OUTPUT_SHAFT_POS_ESTIMATE);
    CHECK(dre_param_find("axis12.error") == dre_param_find("axis0.error"));
    CHECK(dre_param_find("axis.error") == NULL);
    CHECK(dre_param_find("axis0.no_such_thing") == NULL);
    CHECK(dre_param_find("") == NULL);
    CHECK(dre_param_by_address(0u) == NULL && dre_param_by_address(7u) == NULL && dre_param_by_address(65535u) == NULL);

    /* the packed constants */
    CHECK(DRE_PARAM_ADDRESS(DRE_P_AXIS0_OUTPUT_SHAFT_POS_ESTIMATE) == 38007u);
    CHECK(DRE_PARAM_DTYPE(DRE_P_AXIS0_OUTPUT_SHAFT_POS_ESTIMATE) == DRE_F32);
    CHECK((DRE_PARAM_FLAGS(DRE_P_VBUS_VOLTAGE) & DRE_PF_RW) == 0u);
    CHECK(DRE_PARAM_FLAGS(DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE) == (DRE_PF_RW | DRE_PF_USER | DRE_PF_BOOL));
    CHECK(DRE_PARAM_DTYPE(DRE_P_AXIS0_CONFIG_EXTRA_SETTING_STORED_TURNS_COUNTS) == DRE_S32);
}

static void test_errors_match_python(void)
{
    char buf[1024];
    unsigned i;

    for (i = 0u; i < ref_error_count; i++) {
        const ref_error *r = &ref_errors[i];
        const dre_error_word *w = dre_error_word_find(r->address);
        size_t n;
        CHECKF(w != NULL, "word %u", (unsigned)r->address);
        if (w == NULL) {
            continue;
        }
        n = dre_error_format(w, r->value, buf, sizeof buf);
        CHECKF(strcmp(buf, r->text) == 0 && n == strlen(r->text), "%s 0x%08lX: \"%s\", Python \"%s\"", w->name,
               (unsigned long)r->value, buf, r->text);
    }
    CHECK(ref_error_count >= 7u * 34u);
}

static void test_errors(void)
{
    static const uint16_t order[DRE_ERROR_WORD_COUNT] = {30001u, 33001u, 34001u, 32001u, 20001u, 36001u, 37001u};
    const dre_error_word *axis = dre_error_word_find(30001u);
    char small[12], buf[64];
    unsigned i;

    for (i = 0u; i < DRE_ERROR_WORD_COUNT; i++) {
        CHECK(dre_error_words[i].address == order[i]);
    }
    CHECK(dre_error_word_find(30002u) == NULL);
    CHECK(axis != NULL && strcmp(axis->label, "axis") == 0);
    if (axis == NULL) {
        return;
    }
    CHECK(strcmp(dre_error_flag_name(axis, 14u), "ESTOP_REQUESTED") == 0);
    CHECK(dre_error_flag_name(axis, 19u) == NULL);
    CHECK(DRE_AXIS_ERROR_ESTOP_REQUESTED == 0x4000u && DRE_MOTOR_ERROR_STALL_LIMIT_VIOLATION == 0x10000u);

    /* truncation as snprintf: the full length is returned, the text is cut and terminated */
    CHECK(dre_error_format(axis, DRE_AXIS_ERROR_ESTOP_REQUESTED | DRE_AXIS_ERROR_OVER_TEMP, small, sizeof small) ==
          strlen("ESTOP_REQUESTED|OVER_TEMP"));
    CHECK(strcmp(small, "ESTOP_REQUE") == 0);
    CHECK(dre_error_format(axis, 1u, NULL, 0u) == strlen("INVALID_STATE"));

    /* an address that is no error word: every set bit is unknown, nothing is dereferenced */
    CHECK(dre_error_flag_name(dre_error_word_find(30002u), 0u) == NULL);
    CHECK(dre_error_format(dre_error_word_find(30002u), 0x4001u, buf, sizeof buf) ==
          strlen("UNKNOWN_0x00000001|UNKNOWN_0x00004000"));
    CHECK(strcmp(buf, "UNKNOWN_0x00000001|UNKNOWN_0x00004000") == 0);
}

int main(void)
{
    test_params_match_python();
    test_choices_match_python();
    test_domains_match_python();
    test_param_lookup();
    test_errors_match_python();
    test_errors();
    return check_report("test_tables");
}
