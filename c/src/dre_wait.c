/*
 * Waiting for moves: polled fast reads until each move the bus commanded
 * (its record in dre_moves.c) is over and at its target (see dre_client.h).
 */
#include "dre_client_internal.h"

#include <math.h>
#include <stddef.h>

enum { DONE_IDLE = 0, DONE_POLLING, DONE_FINISHED };

/* Is tick `a` later than tick `b` (wrapping)? */
static int later(uint32_t a, uint32_t b)
{
    return a != b && (uint32_t)(a - b) < 0x80000000u;
}

/* Does the state in `p` show that the move of its motor is over? */
static int finished(const dre_bus *bus, const dre_done *p, uint8_t node)
{
    const dre_move *mv = dre_i_move_of((dre_bus *)bus, node);

    if (!p->state.u.state.trajectory_done) {
        return 0;
    }
    if (mv == NULL || (mv->flags & MOVE_ARMED) != 0u) {
        return 1;
    }
    if (!later(p->state_ms, mv->sent_ms)) {
        return 0;
    }
    if ((mv->flags & MOVE_TOOK) != 0u && later(p->state_ms, mv->took_ms)) {
        return 1;
    }
    if (mv->move_ms != 0u && (uint32_t)(p->state_ms - mv->sent_ms) >= mv->move_ms) {
        return 1;
    }
    return (mv->flags & MOVE_TARGET) != 0u && fabsf(p->state.u.state.position - mv->target) <= DRE_MOVE_TOLERANCE;
}

/* Is the motor that finished in `p` away from its move's known target? */
static int off_target(const dre_bus *bus, const dre_done *p, uint8_t node)
{
    const dre_move *mv = dre_i_move_of((dre_bus *)bus, node);
    return mv != NULL && (mv->flags & (MOVE_TARGET | MOVE_ARMED)) == MOVE_TARGET &&
           !(fabsf(p->state.u.state.position - mv->target) <= DRE_MOVE_TOLERANCE);
}

/* ----------------------------------------------------------------- waiting */

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
            st = dre_i_result_at(bus, p->req, &p->state, &p->state_ms);
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
                p->sent_ms = now; /* the next read waits the poll interval from this answer */
                if (finished(bus, p, ids[i])) {
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
    if (st == DRE_OK && !waiting) {
        for (i = 0u; i < n && !off_target(bus, &d[i], ids[i]); i++) {
        }
        st = i < n ? DRE_E_MOVE : DRE_OK; /* every motor is done: one ended away from its target */
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
