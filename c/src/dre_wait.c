/* Waiting for moves: polled fast reads until the trajectory is done (see dre_client.h). */
#include "dre_client_internal.h"

#include <stddef.h>

enum { DONE_IDLE = 0, DONE_POLLING, DONE_FINISHED };

dre_status dre_position_done(const dre_motor *m, dre_done *d, uint32_t timeout_ms)
{
    return dre_positions_done(m->bus, 1u, &m->node, d, timeout_ms);
}

dre_status dre_positions_done(dre_bus *bus, uint8_t n, const uint8_t *ids, dre_done *d, uint32_t timeout_ms)
{
    uint32_t now;
    dre_status st = DRE_OK;
    int waiting = 0;
    uint8_t i;

    if (ids == NULL || d == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    now = bus->cfg.tick(bus->cfg.user);
    for (i = 0u; i < n; i++) {
        dre_done *p = &d[i];
        if (p->phase == DONE_FINISHED) {
            continue;
        }
        if (p->phase != DONE_POLLING) {
            p->phase = DONE_POLLING;
            p->req = 0u;
            p->start_ms = now;
            p->sent_ms = now - DRE_POLL_INTERVAL_MS;
        }
        if (p->req != 0u) {
            st = dre_result(bus, p->req, &p->state);
            if (st == DRE_PENDING) {
                st = DRE_OK;
            } else {
                p->req = 0u;
                if (st != DRE_OK) {
                    break;
                }
                if (p->state.u.state.error) {
                    st = DRE_E_FAULT;
                    break;
                }
                if (p->state.u.state.trajectory_done) {
                    p->phase = DONE_FINISHED;
                    continue;
                }
            }
        }
        waiting = 1;
        if (timeout_ms != 0u && (uint32_t)(now - p->start_ms) >= timeout_ms) {
            st = DRE_E_TIMEOUT;
            break;
        }
        if (p->req == 0u && (uint32_t)(now - p->sent_ms) >= DRE_POLL_INTERVAL_MS) {
            dre_motor m;
            m.bus = bus;
            m.node = ids[i];
            st = dre_get_state(&m, &p->req);
            if (st == DRE_OK) {
                p->sent_ms = now;
            } else if (st == DRE_E_BUSY || st == DRE_E_SEND) {
                st = DRE_OK; /* no slot or no room yet: try again on the next call */
                p->req = 0u;
            } else {
                break;
            }
        }
    }
    if (st != DRE_OK) {
        uint8_t j;
        bus->bad_index = i;
        for (j = 0u; j < n; j++) {
            if (d[j].req != 0u) {
                dre_cancel(bus, d[j].req);
            }
            d[j].req = 0u;
            d[j].phase = DONE_IDLE;
        }
        return st;
    }
    return waiting ? DRE_PENDING : DRE_OK;
}
