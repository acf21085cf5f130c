/*
 * What the client modules share (dre_bus.c, dre_moves.c, dre_motor.c,
 * dre_verified.c, dre_wait.c, dre_batch.c): request slot states and flags,
 * the hooks the modules above the bus attach to it, and the bus, request and
 * message-building functions the others call. Private: not installed, not
 * part of the API; every name with external linkage starts with dre_i_.
 *
 * The modules call one another in layers, never in a cycle (c/scripts/layers.py
 * checks it on the object files): bus < moves < motor < {wait, verified, batch}.
 * The bus keeps the slots, reply matching and timers; what the higher modules
 * must learn from it (a message sent, a state received, a batch's start, a
 * verified reply) it tells through the hooks they attach (struct
 * dre_move_hooks, struct dre_request_hooks).
 */
#ifndef DRE_CLIENT_INTERNAL_H
#define DRE_CLIENT_INTERNAL_H

#include <stdint.h>

#include "drempower/dre_client.h"

/* Slot states. SLOT_WAIT: a dre_set_id probe is over and dre_bus_poll() takes
 * the request to its next step. SLOT_TAKEN and SLOT_ABSENT end dre_set_id. */
enum {
    SLOT_FREE = 0,
    SLOT_QUEUED,
    SLOT_PENDING,
    SLOT_WAIT,
    SLOT_DONE,
    SLOT_TIMEOUT,
    SLOT_MISMATCH,
    SLOT_SEND_FAILED,
    SLOT_TAKEN,
    SLOT_ABSENT
};

/* Request flags: compare the reply with the written value; send save_config
 * when it matches; a failure cancels the save of the next request (seq + 1);
 * a reply of value 0 is held back for it (the zero-reply grace: held_ms, held_node);
 * a read-back that differs writes the value again and reads again, up to cfg.retries
 * times (counted in `link`; the verified writes, not dre_set_id). */
enum { FLAG_VERIFY = 1, FLAG_SAVE = 2, FLAG_CHAIN = 4, FLAG_HELD = 8, FLAG_REWRITE = 16 };

/* Commands only a host sends (system/start, preset, Q position, velocity): seeing one means another host
 * is on the bus, as this bus never receives its own frames. 0x19/0x1B/0x1D/0x1F may also be a motor's state
 * frame (PROTOCOL.md 1.6): dre_bus_feed tells them apart. */
static inline int dre_i_host_only(uint16_t id)
{
    uint16_t cmd = (uint16_t)(id & 0x1Fu);
    return cmd == 0x08u || cmd == 0x0Cu || cmd == 0x1Au || cmd == 0x1Cu;
}

/*
 * Steps of dre_set_id before its write (dre_request.step). STEP_ID_FREE: the
 * caller's request, a fast read of the new id, which must go unanswered; its
 * helper (STEP_ID_HELPER, a slot the caller has no handle for, `link` = the
 * request's slot index) fast-reads the current id, which must answer.
 * STEP_ID_HERE: the new id is the current one, whose fast read must answer.
 * The request's `link` holds the current id, where the write goes.
 */
enum { STEP_NONE = 0, STEP_ID_FREE, STEP_ID_HERE, STEP_ID_HELPER };

#define ALL_MOTORS (~(uint64_t)1) /* bits 1..63 */

/* The bit of motor `node`; a broadcast (0) stands for every motor. */
static inline uint64_t dre_i_motor_bits(uint8_t node)
{
    return node == DRE_BROADCAST ? ALL_MOTORS : (uint64_t)1 << (node & 63u);
}

/* Wire mode of set_speed(s): 1 passthrough; 2, or 0 as the vendor's docs use it, ramp; 0 if invalid. */
static inline uint8_t dre_i_velocity_mode(uint8_t mode)
{
    return mode == DRE_VEL_PASSTHROUGH ? (uint8_t)DRE_VEL_PASSTHROUGH
                                       : mode == 0u || mode == DRE_VEL_RAMP ? (uint8_t)DRE_VEL_RAMP : 0u;
}

/* Wire mode of set_torque(s): 1 direct; 6, or 0, ramp; 0 if invalid. */
static inline uint8_t dre_i_torque_mode(uint8_t mode)
{
    return mode == DRE_TORQUE_DIRECT ? (uint8_t)DRE_TORQUE_DIRECT
                                     : mode == 0u || mode == DRE_TORQUE_RAMP ? (uint8_t)DRE_TORQUE_RAMP : 0u;
}

/* ----------------------------------------------------------------- dre_bus.c */

/* DRE_E_RANGE, naming `field` (and the motor `index` of a batch) in bus->bad_field and bus->bad_index. */
dre_status dre_i_range_error(dre_bus *bus, dre_field field, uint8_t index);
/* A finite float; > 0 and still > 0 on the wire (x 100 rounds to at least 1). */
int dre_i_is_finite(float v);
int dre_i_wire_positive(float v);

/* What the bus learns of each motor's Q profile (axis0.trap_traj.config.traj_mode). */
void dre_i_traj_forget(dre_bus *bus, uint8_t node);
uint8_t dre_i_traj_of(const dre_bus *bus, uint8_t node);
void dre_i_note(dre_bus *bus, const dre_msg *msg);

/* Encoding and sending: parameter writes checked against their sets and domains (soft bounds only without force). */
dre_status dre_i_encode(dre_bus *bus, const dre_msg *msg, dre_frame *f);
dre_status dre_i_transmit(dre_bus *bus, const dre_frame *f);
int dre_i_room(dre_bus *bus, unsigned frames);
dre_status dre_i_send_as(dre_bus *bus, const dre_msg *msg, int force);
dre_status dre_i_system_op(dre_bus *bus, uint8_t node, uint8_t op);

/* Request slots. dre_i_request: a read of `address` (0: fast read), to fill in and give to dre_i_issue(). */
dre_msg dre_i_read_msg(uint8_t node, uint16_t address, uint8_t dtype);
dre_request dre_i_request(uint8_t node, uint16_t address, uint8_t dtype);
int dre_i_node_idle(const dre_bus *bus, uint8_t node);
uint8_t dre_i_free_slots(const dre_bus *bus);
dre_request *dre_i_helper_of(dre_bus *bus, const dre_request *r);
void dre_i_release_helper(dre_bus *bus, const dre_request *r);
void dre_i_fail(dre_bus *bus, dre_request *r, uint8_t state);
dre_status dre_i_issue(dre_bus *bus, const dre_request *want, int may_queue, dre_req *req);

/* The held start of a batch (bus->held_start) to its motors. */
dre_status dre_i_send_starts(dre_bus *bus);
/* dre_result, and the tick when the answer arrived (left as is when `req` is unknown). */
dre_status dre_i_result_at(dre_bus *bus, dre_req req, dre_msg *reply, uint32_t *at_ms);

/* ----------------------------------------------------------------- hooks the higher modules attach */

/* The move records (dre_moves.c): attached by every function that sends a command that can move a motor. */
struct dre_move_hooks {
    /* A message went out: a position command records its move, other motion commands end the record. */
    void (*sent)(dre_bus *bus, const dre_msg *msg);
    /* The batch's start went out (`sent` 1: its armed moves start now) or never will (0: they are dropped). */
    void (*started)(dre_bus *bus, int sent);
    /* A state frame arrived: a T = 0 state after a move's start shows that the motor took it. */
    void (*state)(dre_bus *bus, const dre_msg *state);
};

/* The verified writes and dre_set_id (dre_verified.c): attached before their first request is issued. */
struct dre_request_hooks {
    /* The reply `msg` answered `r`, a request with a step or FLAG_VERIFY / FLAG_SAVE: finish it or take it on. */
    void (*reply)(dre_bus *bus, dre_request *r, const dre_msg *msg);
    /* `r` waits in SLOT_WAIT (its probes are over): its next step, at tick `now`. */
    void (*step)(dre_bus *bus, dre_request *r, uint32_t now);
};

/* ----------------------------------------------------------------- dre_moves.c: the moves the bus commanded */

/* dre_move.flags: the target is known; a T = 0 state came after the start; armed by a batch whose start
 * has not gone out yet (not a move until it has). */
enum { MOVE_TARGET = 1, MOVE_TOOK = 2, MOVE_ARMED = 4 };

/* Attach the move records to the bus (bus->move_hooks); before sending anything that can move a motor. */
void dre_i_moves_attach(dre_bus *bus);
/* The record of `node`, or NULL. */
dre_move *dre_i_move_of(dre_bus *bus, uint8_t node);
/* A batch's preset to `node` went out: arm the move its start makes (`target` deg when `known`; `move_s` the
 * planned Q time, 0 = none), or end the record when the start makes no position move (`position` 0). */
void dre_i_move_armed(dre_bus *bus, uint8_t node, int position, int known, float target, float move_s);

/* ----------------------------------------------------------------- dre_motor.c */

/* A message of `type` to motor m, all other fields 0; a parameter write to motor m. */
dre_msg dre_i_msg_for(const dre_motor *m, uint8_t type);
dre_msg dre_i_write_msg(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value);
/* The T-mode filter bandwidth, or DRE_E_RANGE. */
dre_status dre_i_bandwidth(dre_bus *bus, float param, float *bw);

#endif /* DRE_CLIENT_INTERNAL_H */
