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
