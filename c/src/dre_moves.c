/*
 * The moves the bus commanded: one record per motor (up to DRE_MOVE_RECORDS)
 * of the last position move sent to it, kept through the hooks it attaches to
 * the bus, for dre_positions_done (dre_wait.c).
 */
#include "dre_client_internal.h"

#include <stddef.h>

static void move_sent(dre_bus *bus, const dre_msg *msg);
static void moves_started(dre_bus *bus, int sent);
static void move_state(dre_bus *bus, const dre_msg *state);

static const struct dre_move_hooks hooks = {move_sent, moves_started, move_state};

void dre_i_moves_attach(dre_bus *bus)
{
    bus->move_hooks = &hooks;
}

dre_move *dre_i_move_of(dre_bus *bus, uint8_t node)
{
    uint8_t i;
    for (i = 0u; i < DRE_MOVE_RECORDS; i++) {
        if (bus->moves[i].node == node && node != DRE_BROADCAST) {
            return &bus->moves[i];
        }
    }
    return NULL;
}

/* End the record of `node` (every record for a broadcast). */
static void move_drop(dre_bus *bus, uint8_t node)
{
    uint8_t i;
    for (i = 0u; i < DRE_MOVE_RECORDS; i++) {
        if (node == DRE_BROADCAST || bus->moves[i].node == node) {
            bus->moves[i].node = 0u;
        }
    }
}

/* The record of `node`, new or reused: a free one, else the next in turn. */
static dre_move *move_new(dre_bus *bus, uint8_t node)
{
    dre_move *mv = dre_i_move_of(bus, node);
    uint8_t i;

    for (i = 0u; i < DRE_MOVE_RECORDS && mv == NULL; i++) {
        if (bus->moves[i].node == 0u) {
            mv = &bus->moves[i];
        }
    }
    if (mv == NULL) {
        mv = &bus->moves[bus->move_next];
        bus->move_next = (uint8_t)((bus->move_next + 1u) % DRE_MOVE_RECORDS);
    }
    mv->node = node;
    mv->flags = 0u;
    mv->target = 0.0f;
    mv->move_ms = 0u;
    mv->took_ms = 0u;
    mv->sent_ms = bus->cfg.tick(bus->cfg.user);
    return mv;
}

/* Hook: a message went out; a position command records its move, other motion commands end the record. */
static void move_sent(dre_bus *bus, const dre_msg *msg)
{
    switch (msg->type) {
    case DRE_MSG_POSITION_T:
    case DRE_MSG_POSITION_Q:
    case DRE_MSG_POSITION_P:
        if (msg->node == DRE_BROADCAST) {
            move_drop(bus, DRE_BROADCAST); /* which motors it reached is unknown */
        } else {
            dre_move *mv = move_new(bus, msg->node);
            /* position is the first field of the three position commands */
            mv->target = msg->type == DRE_MSG_POSITION_T   ? msg->u.position_t.position
                         : msg->type == DRE_MSG_POSITION_Q ? msg->u.position_q.position
                                                           : msg->u.position_p.position;
            mv->flags = MOVE_TARGET;
        }
        break;
    case DRE_MSG_VELOCITY:
    case DRE_MSG_TORQUE:
    case DRE_MSG_START:
    case DRE_MSG_START_IMPEDANCE:
        move_drop(bus, msg->node); /* a start sent on its own: what it starts is unknown */
        break;
    default:
        break;
    }
}

void dre_i_move_armed(dre_bus *bus, uint8_t node, int position, int known, float target, float move_s)
{
    dre_move *mv;
    dre_i_moves_attach(bus);
    if (!position) {
        move_drop(bus, node);
        return;
    }
    mv = move_new(bus, node);
    mv->flags = (uint8_t)(MOVE_ARMED | (known ? MOVE_TARGET : 0u));
    mv->target = target;
    mv->move_ms = move_s > 0.0f ? (uint32_t)(move_s * 1000.0f + 0.5f) : 0u;
}

/* Hook: the held start of a batch went out (`sent` 1) or never will (0). */
static void moves_started(dre_bus *bus, int sent)
{
    uint32_t now = bus->cfg.tick(bus->cfg.user);
    uint8_t i;
    for (i = 0u; i < DRE_MOVE_RECORDS; i++) {
        dre_move *mv = &bus->moves[i];
        if (mv->node != 0u && (mv->flags & MOVE_ARMED) != 0u) {
            mv->flags &= (uint8_t)~MOVE_ARMED;
            mv->sent_ms = now;
            if (!sent) {
                mv->node = 0u;
            }
        }
    }
}

/* Hook: a state frame arrived; a T = 0 state after a move's start shows that the motor took it. */
static void move_state(dre_bus *bus, const dre_msg *state)
{
    dre_move *mv = dre_i_move_of(bus, state->node);
    uint32_t now;

    if (mv == NULL || state->u.state.trajectory_done || (mv->flags & (MOVE_TOOK | MOVE_ARMED)) != 0u) {
        return;
    }
    now = bus->cfg.tick(bus->cfg.user);
    if (now != mv->sent_ms && (uint32_t)(now - mv->sent_ms) < 0x80000000u) {
        mv->flags |= MOVE_TOOK;
        mv->took_ms = now;
    }
}
