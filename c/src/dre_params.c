/* The parameter name table and its look-ups (see dre_params.h). */
#define DRE_PARAMS_IMPLEMENTATION
#include "drempower/dre_params.h"

#include <stddef.h>
#include <string.h>

const dre_param_info *dre_param_find(const char *name)
{
    const char *rest = name;
    unsigned i;

    /* The motors have one axis: "axis<N>.x" means "axis0.x". */
    if (strncmp(name, "axis", 4) == 0 && name[4] >= '0' && name[4] <= '9') {
        rest = name + 4;
        while (*rest >= '0' && *rest <= '9') {
            rest++;
        }
        if (*rest != '.') {
            rest = name;
        }
    }
    for (i = 0u; i < DRE_PARAM_COUNT; i++) {
        const char *n = dre_param_table[i].name;
        if (rest == name ? strcmp(n, name) == 0 : strncmp(n, "axis0", 5) == 0 && strcmp(n + 5, rest) == 0) {
            return &dre_param_table[i];
        }
    }
    return NULL;
}

const dre_param_info *dre_param_by_address(uint16_t address)
{
    size_t lo = 0u, hi = DRE_PARAM_COUNT;

    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2u;
        uint16_t a = DRE_PARAM_ADDRESS(dre_param_table[mid].param);
        if (a == address) {
            return &dre_param_table[mid];
        }
        if (a < address) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return NULL;
}

const dre_param_domain *dre_param_domain_of(uint16_t address)
{
    size_t lo = 0u, hi = DRE_PARAM_DOMAIN_COUNT;

    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2u;
        uint16_t a = dre_param_domains[mid].address;
        if (a == address) {
            return &dre_param_domains[mid];
        }
        if (a < address) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return NULL;
}

/* Is `value` inside domain `d`? Integers are compared exactly (bounds of integer parameters are whole). */
static int inside(const dre_param_domain *d, uint8_t dtype, dre_value value)
{
    unsigned i;

    if (dtype == DRE_F32) {
        float v = value.f32;
        if (v != v) {
            return 0; /* NaN */
        }
        if ((d->flags & DRE_PD_SET) != 0u) {
            for (i = 0u; i < d->count; i++) {
                if (dre_param_allowed[d->first + i] == v) {
                    return 1;
                }
            }
            return 0;
        }
        return ((d->flags & DRE_PD_MIN) == 0u || v >= d->lo) && ((d->flags & DRE_PD_MAX) == 0u || v <= d->hi);
    }
    if ((d->flags & DRE_PD_SET) != 0u) {
        for (i = 0u; i < d->count; i++) {
            if ((int64_t)dre_param_allowed[d->first + i] == value.i) {
                return 1;
            }
        }
        return 0;
    }
    return ((d->flags & DRE_PD_MIN) == 0u || value.i >= (int64_t)d->lo) &&
           ((d->flags & DRE_PD_MAX) == 0u || value.i <= (int64_t)d->hi);
}

dre_status dre_param_check(uint16_t address, uint8_t dtype, dre_value value, int force)
{
    const dre_param_domain *d = dre_param_domain_of(address);

    if (d == NULL || inside(d, dtype, value)) {
        return DRE_OK;
    }
    if (force && (d->flags & DRE_PD_HARD) == 0u) {
        return DRE_OK;
    }
    return DRE_E_RANGE;
}
