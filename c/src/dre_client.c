/* Per-motor commands, request tracking and multi-motor moves (see dre_client.h). */
#include "drempower/dre_client.h"

#include <float.h>
#include <math.h>
#include <string.h>

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
 * when it matches; a failure cancels the save of the next request (seq + 1). */
enum { FLAG_VERIFY = 1, FLAG_SAVE = 2, FLAG_CHAIN = 4 };

/*
 * Steps of dre_set_id before its write (dre_request.step). STEP_ID_FREE: the
 * caller's request, a fast read of the new id, which must go unanswered; its
 * helper (STEP_ID_HELPER, a slot the caller has no handle for, `link` = the
 * request's slot index) fast-reads the current id, which must answer.
 * STEP_ID_HERE: the new id is the current one, whose fast read must answer.
 * The request's `link` holds the current id, where the write goes.
 */
enum { STEP_NONE = 0, STEP_ID_FREE, STEP_ID_HERE, STEP_ID_HELPER };

enum { DONE_IDLE = 0, DONE_POLLING, DONE_FINISHED };

#define ALL_MOTORS (~(uint64_t)1) /* bits 1..63 */
#define S16_MAX 327.67f
#define TRAJ_ADDRESS DRE_PARAM_ADDRESS(DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE)

/* The bit of motor `node`; a broadcast (0) stands for every motor. */
static uint64_t motor_bits(uint8_t node)
{
    return node == DRE_BROADCAST ? ALL_MOTORS : (uint64_t)1 << (node & 63u);
}

static int is_finite(float v)
{
    return v >= -FLT_MAX && v <= FLT_MAX;
}

static int positive(float v)
{
    return v > 0.0f && v <= FLT_MAX;
}

/* > 0 and still > 0 on the wire: x 100 rounds to at least 1 (0.005f x 100 rounds to 0). */
static int wire_positive(float v)
{
    return v > 0.005f && v <= FLT_MAX;
}

static dre_status range_error(dre_bus *bus, dre_field field, uint8_t index)
{
    bus->bad_field = field;
    bus->bad_index = index;
    bus->bad_address = 0u;
    return DRE_E_RANGE;
}

/* ----------------------------------------------------------------- parameters with a fixed set of values */

/*
 * The modes and states that take only the values of an enum, from the Python
 * client (python/src/drempower/protocol/parameters.py, _CHOICES, with the
 * enums of protocol/enums.py); each set is a contiguous range. Constant, so
 * it stays in flash; tests/test_tables.c checks it against the Python table.
 */
typedef struct {
    uint16_t address;
    uint8_t lo, hi;
} choice_range;

static const choice_range choices[] = {
    {DRE_PARAM_ADDRESS(DRE_P_AXIS0_REQUESTED_STATE), 0u, 11u},               /* AxisState */
    {DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONTROLLER_CONFIG_CONTROL_MODE), 0u, 4u}, /* ControlMode */
    {DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONTROLLER_CONFIG_INPUT_MODE), 0u, 7u},   /* InputMode */
    {DRE_PARAM_ADDRESS(DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE), 1u, 2u},     /* TrajMode */
};

int dre_param_choices(uint16_t address, uint8_t *lo, uint8_t *hi)
{
    unsigned i;
    for (i = 0u; i < sizeof choices / sizeof choices[0]; i++) {
        if (choices[i].address == address) {
            *lo = choices[i].lo;
            *hi = choices[i].hi;
            return 1;
        }
    }
    return 0;
}

/*
 * DRE_OK, or DRE_E_RANGE naming the parameter when `msg` writes a value it does
 * not take: outside its fixed set, or outside its domain (dre_param_check; a
 * soft bound only when `force` is 0).
 */
static dre_status check_write(dre_bus *bus, const dre_msg *msg, int force)
{
    uint16_t address = (uint16_t)msg->u.param.address;
    uint8_t lo, hi;
    dre_field bad;

    /* an address beyond 16 bits is no parameter: dre_encode refuses it */
    if (msg->type != DRE_MSG_WRITE_PARAM || msg->u.param.address > 0xFFFFu) {
        return DRE_OK;
    }
    if (dre_param_choices(address, &lo, &hi) && msg->u.param.dtype == DRE_F32) {
        bad = DRE_FIELD_DTYPE; /* the sets are integers */
    } else if (dre_param_choices(address, &lo, &hi) && (msg->u.param.value.i < lo || msg->u.param.value.i > hi)) {
        bad = DRE_FIELD_VALUE;
    } else if (dre_param_check(address, msg->u.param.dtype, msg->u.param.value, force) != DRE_OK) {
        bad = DRE_FIELD_VALUE;
    } else {
        return DRE_OK;
    }
    (void)range_error(bus, bad, 0u);
    bus->bad_address = address;
    return DRE_E_RANGE;
}

/* ----------------------------------------------------------------- what the bus learns */

/* A motor's Q profile (35104) was written or read as `value`; node 0: all unknown. */
static void traj_learn(dre_bus *bus, uint8_t node, uint8_t dtype, int64_t value)
{
    uint64_t bit = motor_bits(node);

    bus->traj_known &= ~bit;
    bus->traj_scurve &= ~bit;
    if (node != DRE_BROADCAST && dtype != DRE_F32 && (value == DRE_TRAJ_TRAPEZOID || value == DRE_TRAJ_S_CURVE)) {
        bus->traj_known |= bit;
        if (value == DRE_TRAJ_S_CURVE) {
            bus->traj_scurve |= bit;
        }
    }
}

static void traj_forget(dre_bus *bus, uint8_t node)
{
    traj_learn(bus, node, DRE_F32, 0);
}

/* The profile set_angles uses for motor `node`. */
static uint8_t traj_of(const dre_bus *bus, uint8_t node)
{
    uint64_t bit = motor_bits(node);
    if ((bus->traj_known & bit) == 0u) {
        return bus->cfg.traj_mode;
    }
    return (bus->traj_scurve & bit) != 0u ? (uint8_t)DRE_TRAJ_S_CURVE : (uint8_t)DRE_TRAJ_TRAPEZOID;
}

/* Track what a sent message changes. */
static void note(dre_bus *bus, const dre_msg *msg)
{
    if (msg->type == DRE_MSG_WRITE_PARAM && msg->u.param.address == TRAJ_ADDRESS) {
        traj_learn(bus, msg->node, msg->u.param.dtype, msg->u.param.value.i);
    } else if (msg->type == DRE_MSG_SYSTEM &&
               (msg->u.system.op == DRE_SYS_INIT_CONFIG || msg->u.system.op == DRE_SYS_ERASE_CONFIG ||
                msg->u.system.op == DRE_SYS_REBOOT)) {
        traj_forget(bus, msg->node);
    }
}

/* ----------------------------------------------------------------- bus */

static int ring_ok(const dre_frame *storage, uint8_t capacity)
{
    return storage != NULL && capacity >= 2u && capacity <= 128u && (capacity & (uint8_t)(capacity - 1u)) == 0u;
}

dre_status dre_bus_init(dre_bus *bus, const dre_bus_config *cfg, dre_request *slots, uint8_t nslots,
                        dre_frame *rx_storage, uint8_t rx_capacity)
{
    int rx_ok = rx_storage == NULL ? rx_capacity == 0u : ring_ok(rx_storage, rx_capacity);

    if (cfg->send == NULL || cfg->tick == NULL || slots == NULL || nslots == 0u || !rx_ok ||
        cfg->traj_mode > DRE_TRAJ_S_CURVE || cfg->start > DRE_START_TO_NODE) {
        return DRE_E_ARG;
    }
    memset(bus, 0, sizeof *bus);
    memset(slots, 0, sizeof *slots * nslots);
    bus->cfg = *cfg;
    if (bus->cfg.timeout_ms == 0u) {
        bus->cfg.timeout_ms = DRE_DEFAULT_TIMEOUT_MS;
    }
    bus->slots = slots;
    bus->nslots = nslots;
    bus->rx_buf = rx_storage;
    bus->rx_mask = (uint8_t)(rx_capacity - 1u);
    return DRE_OK;
}

int dre_bus_isr_push(dre_bus *bus, const dre_frame *frame)
{
    uint8_t head = bus->rx_head;

    if (bus->rx_buf == NULL || (uint8_t)(head - bus->rx_tail) > bus->rx_mask) {
        bus->rx_overflows++;
        return 0;
    }
    bus->rx_buf[head & bus->rx_mask] = *frame;
    DRE_BARRIER();
    bus->rx_head = (uint8_t)(head + 1u);
    return 1;
}

/* Consumer side of the queue: 1 and the oldest frame, or 0 when empty. */
static int rx_pop(dre_bus *bus, dre_frame *out)
{
    uint8_t tail = bus->rx_tail;

    if (tail == bus->rx_head) {
        return 0;
    }
    DRE_BARRIER();
    *out = bus->rx_buf[tail & bus->rx_mask];
    DRE_BARRIER();
    bus->rx_tail = (uint8_t)(tail + 1u);
    return 1;
}

/* Encode what the bus sends; parameter writes are checked against their fixed sets and domains first. */
static dre_status encode_as(dre_bus *bus, const dre_msg *msg, dre_frame *f, int force)
{
    dre_field bad;
    if (check_write(bus, msg, force) != DRE_OK) {
        return DRE_E_RANGE;
    }
    if (dre_encode(msg, f, &bad) != DRE_OK) {
        return range_error(bus, bad, 0u);
    }
    return DRE_OK;
}

static dre_status transmit(dre_bus *bus, const dre_frame *f)
{
    return bus->cfg.send(bus->cfg.user, f) == 0 ? DRE_OK : DRE_E_SEND;
}

/* Can the port take `frames` frames now? */
static int room(dre_bus *bus, unsigned frames)
{
    return bus->cfg.tx_free == NULL || bus->cfg.tx_free(bus->cfg.user) >= frames;
}

static dre_status encode(dre_bus *bus, const dre_msg *msg, dre_frame *f)
{
    return encode_as(bus, msg, f, 0);
}

static dre_status send_as(dre_bus *bus, const dre_msg *msg, int force)
{
    dre_frame f;
    dre_status st = encode_as(bus, msg, &f, force);
    if (st == DRE_OK) {
        st = transmit(bus, &f);
    }
    if (st == DRE_OK) {
        note(bus, msg);
    }
    return st;
}

dre_status dre_send(dre_bus *bus, const dre_msg *msg)
{
    return send_as(bus, msg, 0);
}

static dre_status system_op(dre_bus *bus, uint8_t node, uint8_t op)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = DRE_MSG_SYSTEM;
    msg.node = node;
    msg.u.system.op = op;
    return dre_send(bus, &msg);
}

/* ----------------------------------------------------------------- requests */

/* Is `a` older than `b` (issued earlier)? */
static int older(const dre_bus *bus, const dre_request *a, const dre_request *b)
{
    return (uint16_t)(bus->seq - a->seq) > (uint16_t)(bus->seq - b->seq);
}

static int active(const dre_request *r)
{
    return r->state == SLOT_PENDING || r->state == SLOT_QUEUED || r->state == SLOT_WAIT;
}

/* Must `r` wait: has its motor a request in flight (or between two steps), or an older one waiting? */
static int must_wait(const dre_bus *bus, const dre_request *r)
{
    uint8_t i;
    for (i = 0u; i < bus->nslots; i++) {
        const dre_request *s = &bus->slots[i];
        if (s != r && s->node == r->node &&
            (s->state == SLOT_PENDING || s->state == SLOT_WAIT || (s->state == SLOT_QUEUED && older(bus, s, r)))) {
            return 1;
        }
    }
    return 0;
}

static int node_idle(const dre_bus *bus, uint8_t node)
{
    uint8_t i;
    for (i = 0u; i < bus->nslots; i++) {
        if (bus->slots[i].node == node && active(&bus->slots[i])) {
            return 0;
        }
    }
    return 1;
}

static uint8_t free_slots(const dre_bus *bus)
{
    uint8_t i, n = 0u;
    for (i = 0u; i < bus->nslots; i++) {
        n = (uint8_t)(n + (bus->slots[i].state == SLOT_FREE ? 1u : 0u));
    }
    return n;
}

/* The read (address 0: fast read) a request sends. */
static dre_msg read_msg(uint8_t node, uint16_t address, uint8_t dtype)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = address == 0u ? (uint8_t)DRE_MSG_FAST_READ : (uint8_t)DRE_MSG_READ_PARAM;
    msg.node = node;
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    return msg;
}

/* A failed request of a chain: the requests after it save nothing. */
static void break_chain(dre_bus *bus, const dre_request *r)
{
    uint16_t seq = r->seq;
    uint8_t flags = r->flags, i;

    while ((flags & FLAG_CHAIN) != 0u) {
        dre_request *next = NULL;
        seq = (uint16_t)(seq + 1u);
        for (i = 0u; i < bus->nslots; i++) {
            dre_request *s = &bus->slots[i];
            if (s->seq == seq && s->node == r->node && active(s)) {
                next = s;
            }
        }
        if (next == NULL) {
            return;
        }
        next->flags &= (uint8_t)~FLAG_SAVE;
        flags = next->flags;
    }
}

/* The helper probe of a dre_set_id request `r` in STEP_ID_FREE, or NULL. */
static dre_request *helper_of(dre_bus *bus, const dre_request *r)
{
    uint8_t i;
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *s = &bus->slots[i];
        if (s->state != SLOT_FREE && s->step == STEP_ID_HELPER && s->link == (uint8_t)(r - bus->slots)) {
            return s;
        }
    }
    return NULL;
}

/* Free the helper of `r`, if it has one (a late reply to it then goes to on_unmatched). */
static void release_helper(dre_bus *bus, const dre_request *r)
{
    if (r->step == STEP_ID_FREE) {
        dre_request *h = helper_of(bus, r);
        if (h != NULL) {
            h->state = SLOT_FREE;
        }
    }
}

static void fail(dre_bus *bus, dre_request *r, uint8_t state)
{
    break_chain(bus, r);
    release_helper(bus, r);
    r->state = state;
}

/* A request for a read of `address` (0: fast read) from `node`, to fill in and give to issue(). */
static dre_request request(uint8_t node, uint16_t address, uint8_t dtype)
{
    dre_request r;
    memset(&r, 0, sizeof r);
    r.node = node;
    r.address = address;
    r.dtype = dtype;
    return r;
}

/*
 * Put request `want` (its read, flags, step, link and in reply.u.param.value
 * the value a verified write expects) in a free slot: sent at once when the
 * motor has no other request in flight or waiting, otherwise queued for
 * dre_bus_poll(). When sending fails, `may_queue` leaves it queued (an
 * operation that already sent frames); otherwise the slot is released and
 * DRE_E_SEND returned.
 */
static dre_status issue(dre_bus *bus, const dre_request *want, int may_queue, dre_req *req)
{
    dre_msg msg = read_msg(want->node, want->address, want->dtype);
    dre_request *r = NULL;
    dre_frame f;
    dre_status st;
    uint8_t i;

    st = encode(bus, &msg, &f);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < bus->nslots && r == NULL; i++) {
        if (bus->slots[i].state == SLOT_FREE) {
            r = &bus->slots[i];
        }
    }
    if (r == NULL) {
        return DRE_E_BUSY;
    }
    *r = *want;
    r->state = SLOT_FREE;
    if (!node_idle(bus, want->node)) {
        r->state = SLOT_QUEUED;
    } else if (transmit(bus, &f) == DRE_OK) {
        r->state = SLOT_PENDING;
    } else if (may_queue) {
        r->state = SLOT_QUEUED;
    } else {
        return DRE_E_SEND;
    }
    if (++bus->seq == 0u) {
        bus->seq = 1u; /* handles are never 0 */
    }
    r->seq = bus->seq;
    r->sent_ms = bus->cfg.tick(bus->cfg.user);
    *req = ((uint32_t)r->seq << 8) | (uint32_t)(r - bus->slots);
    return DRE_OK;
}

/* Start reading `k` parameters of one motor; each request waits for the one before. */
static dre_status read_params(const dre_motor *m, uint8_t k, const dre_param_t *params, dre_req *req)
{
    dre_status st = DRE_OK;
    uint8_t i;

    if (free_slots(m->bus) < k) {
        return DRE_E_BUSY;
    }
    for (i = 0u; i < k && st == DRE_OK; i++) {
        dre_request r = request(m->node, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]));
        st = issue(m->bus, &r, i > 0u, &req[i]);
    }
    return st;
}

/* Did the motor send back what was written? Compared as the Python client does: f32 bit for bit. */
static int same_value(const dre_request *r, const dre_msg *msg)
{
    const dre_value *want = &r->reply.u.param.value, *got = &msg->u.param.value;
    if (r->dtype == DRE_F32) {
        return msg->u.param.dtype == DRE_F32 && memcmp(&want->f32, &got->f32, sizeof got->f32) == 0;
    }
    return msg->u.param.dtype != DRE_F32 && want->i == got->i;
}

static int answers(const dre_request *r, const dre_msg *msg)
{
    if (r->state != SLOT_PENDING || (r->node != DRE_BROADCAST && r->node != msg->node)) {
        return 0;
    }
    if (msg->type == DRE_MSG_STATE) {
        return r->address == 0u;
    }
    return r->address != 0u && r->address == msg->u.param.address;
}

static void complete(dre_bus *bus, dre_request *r, const dre_msg *msg)
{
    if (r->step == STEP_ID_FREE) {
        fail(bus, r, SLOT_TAKEN); /* a motor answers at the new id */
    } else if (r->step == STEP_ID_HERE) {
        r->state = SLOT_WAIT; /* the motor answers: on to the write */
        r->sent_ms = bus->cfg.tick(bus->cfg.user);
    } else if ((r->flags & FLAG_VERIFY) != 0u && !same_value(r, msg)) {
        fail(bus, r, SLOT_MISMATCH);
    } else if ((r->flags & FLAG_SAVE) != 0u && system_op(bus, r->node, DRE_SYS_SAVE_CONFIG) != DRE_OK) {
        fail(bus, r, SLOT_SEND_FAILED);
    } else {
        r->state = SLOT_DONE;
    }
    r->reply = *msg;
}

dre_status dre_bus_feed(dre_bus *bus, const dre_frame *frame)
{
    dre_msg msg;
    dre_request *best = NULL;
    uint8_t i;

    bus->stats.rx_frames++;
    if (dre_decode_reply(frame, &msg) != DRE_OK) {
        bus->stats.rx_malformed++;
        return DRE_E_PROTOCOL;
    }
    if (msg.type == DRE_MSG_PARAM_VALUE && msg.u.param.address == TRAJ_ADDRESS && msg.node != DRE_BROADCAST) {
        traj_learn(bus, msg.node, msg.u.param.dtype, msg.u.param.value.i);
    }
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        /* the oldest request is the one furthest behind the sequence counter */
        if (answers(r, &msg) && (best == NULL || older(bus, r, best))) {
            best = r;
        }
    }
    if (best != NULL) {
        complete(bus, best, &msg);
    } else {
        bus->stats.rx_unmatched++;
        if (bus->cfg.on_unmatched != NULL) {
            bus->cfg.on_unmatched(bus->cfg.user, &msg);
        }
    }
    return DRE_OK;
}

/*
 * Step 2 of dre_set_id, once its probes are over (SLOT_WAIT): with the current
 * id answering and the new one silent, send the write and turn `r` into the
 * verified read of the new id (step 3, saved when it matches: step 4).
 */
static void set_id_write(dre_bus *bus, dre_request *r, uint32_t now)
{
    uint8_t old = r->link, new_id = r->node;
    dre_value id;
    dre_msg w;
    dre_frame f;

    if (r->step == STEP_ID_FREE) {
        dre_request *h = helper_of(bus, r);
        uint8_t hs = h == NULL ? (uint8_t)SLOT_SEND_FAILED : h->state;
        if (hs == SLOT_PENDING || hs == SLOT_QUEUED) {
            r->sent_ms = now; /* the current id has yet to answer */
            return;
        }
        if (hs != SLOT_DONE) {
            fail(bus, r, hs == SLOT_TIMEOUT ? (uint8_t)SLOT_ABSENT : (uint8_t)SLOT_SEND_FAILED);
            return;
        }
    }
    if (!room(bus, 2u)) {
        if ((uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
            fail(bus, r, SLOT_SEND_FAILED);
        }
        return;
    }
    release_helper(bus, r);
    id.i = new_id;
    memset(&w, 0, sizeof w);
    w.type = DRE_MSG_WRITE_PARAM;
    w.node = old;
    w.u.param.address = DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    w.u.param.dtype = DRE_PARAM_DTYPE(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    w.u.param.value = id;
    if (encode(bus, &w, &f) != DRE_OK || transmit(bus, &f) != DRE_OK) {
        r->step = STEP_NONE;
        r->state = SLOT_SEND_FAILED;
        return;
    }
    if (old != new_id) {
        traj_forget(bus, old);
        traj_forget(bus, new_id);
    }
    r->step = STEP_NONE;
    r->link = 0u;
    r->address = DRE_PARAM_ADDRESS(DRE_P_AXIS0_CONFIG_CAN_NODE_ID);
    r->dtype = w.u.param.dtype;
    r->flags = FLAG_VERIFY | FLAG_SAVE;
    memset(&r->reply, 0, sizeof r->reply);
    r->reply.u.param.value = id;
    r->state = SLOT_QUEUED; /* sent below once the new id has no other request in flight */
    r->sent_ms = now;
}

static void release_start(dre_bus *bus, uint32_t now);

void dre_bus_poll(dre_bus *bus)
{
    dre_frame f;
    uint32_t now = bus->cfg.tick(bus->cfg.user); /* before draining: a reply queued by then counts */
    uint8_t i;

    while (rx_pop(bus, &f)) {
        (void)dre_bus_feed(bus, &f);
    }
    release_start(bus, now);
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        if (r->state == SLOT_PENDING && (uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
            if (r->step == STEP_ID_FREE) {
                r->state = SLOT_WAIT; /* nobody answers at the new id: it is free */
                r->sent_ms = now;
            } else {
                fail(bus, r, r->step == STEP_ID_HERE ? (uint8_t)SLOT_ABSENT : (uint8_t)SLOT_TIMEOUT);
                bus->stats.timeouts++;
            }
        }
    }
    for (i = 0u; i < bus->nslots; i++) {
        if (bus->slots[i].state == SLOT_WAIT) {
            set_id_write(bus, &bus->slots[i], now);
        }
    }
    /* Send the requests whose turn has come; one that cannot be sent for a
     * whole timeout once its turn came expires. */
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        if (r->state != SLOT_QUEUED) {
            continue;
        }
        if (must_wait(bus, r)) {
            r->sent_ms = now;
        } else {
            dre_msg msg = read_msg(r->node, r->address, r->dtype);
            if (room(bus, 1u) && encode(bus, &msg, &f) == DRE_OK && transmit(bus, &f) == DRE_OK) {
                r->state = SLOT_PENDING;
                r->sent_ms = now;
            } else if ((uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
                if (r->step != STEP_NONE) {
                    fail(bus, r, SLOT_SEND_FAILED); /* a probe of dre_set_id that never went out */
                } else {
                    fail(bus, r, SLOT_TIMEOUT);
                    bus->stats.timeouts++;
                }
            }
        }
    }
}

static dre_request *slot_of(dre_bus *bus, dre_req req)
{
    uint32_t index = req & 0xFFu;
    dre_request *r;

    if (index >= bus->nslots) {
        return NULL;
    }
    r = &bus->slots[index];
    return r->state != SLOT_FREE && r->seq == (uint16_t)(req >> 8) && (req >> 24) == 0u ? r : NULL;
}

dre_status dre_result(dre_bus *bus, dre_req req, dre_msg *reply)
{
    dre_request *r = slot_of(bus, req);
    dre_status st;

    if (r == NULL) {
        return DRE_E_ARG;
    }
    switch (r->state) {
    case SLOT_QUEUED:
    case SLOT_PENDING:
    case SLOT_WAIT:
        return DRE_PENDING;
    case SLOT_DONE:
        st = DRE_OK;
        break;
    case SLOT_MISMATCH:
        st = DRE_E_VERIFY;
        break;
    case SLOT_SEND_FAILED:
        st = DRE_E_SEND;
        break;
    case SLOT_TAKEN:
        st = DRE_E_ID_TAKEN;
        break;
    case SLOT_ABSENT:
        r->state = SLOT_FREE;
        return DRE_E_NO_MOTOR;
    default:
        r->state = SLOT_FREE;
        return DRE_E_TIMEOUT;
    }
    *reply = r->reply;
    r->state = SLOT_FREE;
    return st;
}

void dre_cancel(dre_bus *bus, dre_req req)
{
    dre_request *r = slot_of(bus, req);
    if (r != NULL) {
        if (active(r)) {
            break_chain(bus, r);
            release_helper(bus, r);
        }
        r->state = SLOT_FREE;
    }
}

/* ----------------------------------------------------------------- transmit ring */

dre_status dre_txq_init(dre_txq *q, dre_frame *storage, uint8_t capacity)
{
    if (!ring_ok(storage, capacity)) {
        return DRE_E_ARG;
    }
    q->buf = storage;
    q->mask = (uint8_t)(capacity - 1u);
    q->head = 0u;
    q->tail = 0u;
    return DRE_OK;
}

int dre_txq_send(dre_txq *q, const dre_frame *frame)
{
    uint8_t head = q->head;

    if ((uint8_t)(head - q->tail) > q->mask) {
        return -1;
    }
    q->buf[head & q->mask] = *frame;
    DRE_BARRIER();
    q->head = (uint8_t)(head + 1u);
    return 0;
}

unsigned dre_txq_free(const dre_txq *q)
{
    return (unsigned)q->mask + 1u - (uint8_t)(q->head - q->tail);
}

int dre_txq_peek(dre_txq *q, dre_frame *out)
{
    uint8_t tail = q->tail;

    if (tail == q->head) {
        return 0;
    }
    DRE_BARRIER();
    *out = q->buf[tail & q->mask];
    return 1;
}

void dre_txq_pop(dre_txq *q)
{
    uint8_t tail = q->tail;

    if (tail != q->head) {
        DRE_BARRIER();
        q->tail = (uint8_t)(tail + 1u);
    }
}

/* ----------------------------------------------------------------- motor */

void dre_motor_init(dre_motor *m, dre_bus *bus, uint8_t node)
{
    m->bus = bus;
    m->node = node;
}

static dre_msg msg_for(const dre_motor *m, uint8_t type)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = type;
    msg.node = m->node;
    return msg;
}

/* The T-mode filter bandwidth (0 < bw <= 300; a negative one is refused, as in Python), or DRE_E_RANGE. */
static dre_status bandwidth(dre_bus *bus, float param, float *bw)
{
    *bw = param;
    return wire_positive(*bw) && *bw <= DRE_MAX_BANDWIDTH ? DRE_OK : range_error(bus, DRE_FIELD_BANDWIDTH, 0u);
}

/* The single-motor position message for `mode`, or DRE_E_RANGE. */
static dre_status angle_msg(dre_bus *bus, dre_msg *msg, float angle, float speed, float param, uint8_t mode)
{
    float bw;

    if (mode > DRE_ANGLE_P) {
        return range_error(bus, DRE_FIELD_MODE, 0u);
    }
    if (!is_finite(angle)) {
        return range_error(bus, DRE_FIELD_POSITION, 0u);
    }
    switch (mode) {
    case DRE_ANGLE_T:
        if (bandwidth(bus, param, &bw) != DRE_OK) {
            return DRE_E_RANGE;
        }
        if (!is_finite(speed)) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        msg->type = DRE_MSG_POSITION_T;
        msg->u.position_t.position = angle;
        msg->u.position_t.speed = fabsf(speed);
        msg->u.position_t.bandwidth = bw;
        return DRE_OK;
    case DRE_ANGLE_Q:
        if (!wire_positive(speed)) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!wire_positive(param)) {
            return range_error(bus, DRE_FIELD_ACCEL, 0u);
        }
        msg->type = DRE_MSG_POSITION_Q;
        msg->u.position_q.position = angle;
        msg->u.position_q.speed = speed;
        msg->u.position_q.accel = param;
        return DRE_OK;
    default:
        msg->type = DRE_MSG_POSITION_P;
        msg->u.position_p.position = angle;
        msg->u.position_p.speed_ff = speed;
        msg->u.position_p.torque_ff = param;
        return DRE_OK;
    }
}

dre_status dre_set_angle(const dre_motor *m, float angle, float speed, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_NONE);
    dre_status st = angle_msg(m->bus, &msg, angle, speed, param, mode);
    return st == DRE_OK ? dre_send(m->bus, &msg) : st;
}

dre_status dre_step_angle(const dre_motor *m, float delta, float speed, float param, uint8_t mode)
{
    return dre_step_angles(m->bus, 1u, &m->node, &delta, speed, param, mode);
}

/* Wire mode of set_speed(s): 1 passthrough; 2, or 0 as the vendor's docs use it, ramp; 0 if invalid. */
static uint8_t velocity_mode(uint8_t mode)
{
    return mode == DRE_VEL_PASSTHROUGH ? (uint8_t)DRE_VEL_PASSTHROUGH
                                       : mode == 0u || mode == DRE_VEL_RAMP ? (uint8_t)DRE_VEL_RAMP : 0u;
}

/* Wire mode of set_torque(s): 1 direct; 6, or 0, ramp; 0 if invalid. */
static uint8_t torque_mode(uint8_t mode)
{
    return mode == DRE_TORQUE_DIRECT ? (uint8_t)DRE_TORQUE_DIRECT
                                     : mode == 0u || mode == DRE_TORQUE_RAMP ? (uint8_t)DRE_TORQUE_RAMP : 0u;
}

dre_status dre_set_speed(const dre_motor *m, float speed, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_VELOCITY);
    uint8_t wire = velocity_mode(mode);

    if (wire == 0u) {
        return range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    if (!is_finite(speed)) {
        return range_error(m->bus, DRE_FIELD_SPEED, 0u);
    }
    if (!is_finite(param)) {
        return range_error(m->bus, DRE_FIELD_PARAM, 0u); /* even where it is unused: NaN is a mistake */
    }
    if (wire == DRE_VEL_PASSTHROUGH && speed == 0.0f) {
        param = 0.0f; /* no feed-forward torque for a motor told to stand still, as the vendor does */
    } else if (wire == DRE_VEL_RAMP ? !wire_positive(param) : !is_finite(param)) {
        return range_error(m->bus, DRE_FIELD_PARAM, 0u);
    }
    msg.u.velocity.speed = speed;
    msg.u.velocity.param = param;
    msg.u.velocity.mode = wire;
    return dre_send(m->bus, &msg);
}

dre_status dre_set_torque(const dre_motor *m, float torque, float param, uint8_t mode)
{
    dre_msg msg = msg_for(m, DRE_MSG_TORQUE);
    uint8_t wire = torque_mode(mode);

    if (wire == 0u) {
        return range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    if (!is_finite(torque)) {
        return range_error(m->bus, DRE_FIELD_TORQUE, 0u);
    }
    if (!is_finite(param) || (wire == DRE_TORQUE_RAMP && !wire_positive(param))) {
        return range_error(m->bus, DRE_FIELD_PARAM, 0u); /* a NaN param is refused even in direct mode */
    }
    msg.u.torque.torque = torque;
    msg.u.torque.param = wire == DRE_TORQUE_DIRECT ? 0.0f : param;
    msg.u.torque.mode = wire;
    return dre_send(m->bus, &msg);
}

dre_status dre_system(const dre_motor *m, uint8_t op)
{
    return system_op(m->bus, m->node, op);
}

dre_status dre_estop(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_ESTOP);
}

dre_status dre_clear_error(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_CLEAR_ERRORS);
}

dre_status dre_save_config(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_SAVE_CONFIG);
}

dre_status dre_reboot(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_REBOOT);
}

dre_status dre_set_zero_position(const dre_motor *m)
{
    return dre_system(m, DRE_SYS_SET_ZERO_POSITION);
}

static dre_msg write_msg(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = msg_for(m, DRE_MSG_WRITE_PARAM);
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    msg.u.param.value = value;
    return msg;
}

dre_status dre_set_mode(const dre_motor *m, uint8_t mode)
{
    dre_value state;
    if (mode != DRE_MODE_IDLE && mode != DRE_MODE_CLOSED_LOOP) {
        return range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    state.i = mode == DRE_MODE_IDLE ? 1 : 8; /* AXIS_STATE_IDLE, AXIS_STATE_CLOSED_LOOP_CONTROL */
    return dre_write_param(m, DRE_P_AXIS0_REQUESTED_STATE, state);
}

dre_status dre_write_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = write_msg(m, address, dtype, value);
    return dre_send(m->bus, &msg);
}

dre_status dre_write_property_forced(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = write_msg(m, address, dtype, value);
    return send_as(m->bus, &msg, 1);
}

dre_status dre_write_param(const dre_motor *m, dre_param_t param, dre_value value)
{
    uint8_t flags = DRE_PARAM_FLAGS(param);

    if ((flags & DRE_PF_RW) == 0u) {
        return DRE_E_ACCESS;
    }
    if ((flags & DRE_PF_BOOL) != 0u && value.i != 0 && value.i != 1) {
        return range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    return dre_write_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), value);
}

dre_status dre_read_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_req *req)
{
    dre_request r = request(m->node, address, dtype);
    if (address == 0u) {
        return range_error(m->bus, DRE_FIELD_ADDRESS, 0u); /* address 0 is the fast read */
    }
    return issue(m->bus, &r, 0, req);
}

dre_status dre_read_param(const dre_motor *m, dre_param_t param, dre_req *req)
{
    return dre_read_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), req);
}

dre_status dre_get_state(const dre_motor *m, dre_req *req)
{
    dre_request r = request(m->node, 0u, DRE_F32);
    return issue(m->bus, &r, 0, req);
}

/* ----------------------------------------------------------------- operations */

dre_status dre_get_id(const dre_motor *m, dre_req *req)
{
    return dre_read_param(m, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, req);
}

dre_status dre_get_volcur(const dre_motor *m, dre_req req[2])
{
    static const dre_param_t params[2] = {DRE_P_VBUS_VOLTAGE, DRE_P_AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED};
    return read_params(m, 2u, params, req);
}

dre_status dre_dump_error(const dre_motor *m, dre_req req[DRE_ERROR_WORDS])
{
    static const dre_param_t words[DRE_ERROR_WORDS] = {
        DRE_P_AXIS0_ERROR, DRE_P_AXIS0_MOTOR_ERROR, DRE_P_AXIS0_ENCODER_ERROR,
        DRE_P_AXIS0_CONTROLLER_ERROR, DRE_P_CAN_ERROR, DRE_P_AXIS0_FET_THERMISTOR_ERROR,
        DRE_P_AXIS0_MOTOR_THERMISTOR_ERROR};
    return read_params(m, DRE_ERROR_WORDS, words, req);
}

dre_status dre_get_traj_mode(const dre_motor *m, dre_req *req)
{
    return dre_read_param(m, DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE, req);
}

/*
 * Write params[i] = values[i] (i < k) to motor m, then read each back to
 * verify it; with `save`, save_config goes out once every value matched.
 * Checks room for the frames sent at once and free slots before sending
 * anything.
 */
static dre_status verified_writes(const dre_motor *m, uint8_t k, const dre_param_t *params, const dre_value *values,
                                  int save, dre_req *req)
{
    dre_bus *bus = m->bus;
    dre_frame f[3];
    dre_msg w[3];
    dre_status st;
    uint8_t i;

    for (i = 0u; i < k; i++) {
        w[i] = write_msg(m, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]), values[i]);
        st = encode(bus, &w[i], &f[i]);
        if (st != DRE_OK) {
            bus->bad_index = i;
            return st;
        }
    }
    if (free_slots(bus) < k || !room(bus, k + (node_idle(bus, m->node) ? 1u : 0u))) {
        return DRE_E_BUSY;
    }
    for (i = 0u; i < k; i++) {
        st = transmit(bus, &f[i]);
        if (st != DRE_OK) {
            return st;
        }
        note(bus, &w[i]);
    }
    for (i = 0u; i < k; i++) {
        uint8_t last = i + 1u == k;
        dre_request r = request(m->node, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]));
        r.flags = (uint8_t)(FLAG_VERIFY | (last ? (save ? FLAG_SAVE : 0u) : FLAG_CHAIN));
        r.reply.u.param.value = values[i];
        (void)issue(bus, &r, 1, &req[i]);
    }
    return DRE_OK;
}

/*
 * Step 1 of set_id: the fast reads of the current id (the helper, sent first
 * as the Python client does) and of the new id (the caller's request). Steps
 * 2 to 4 follow in dre_bus_poll() (set_id_write) and complete().
 */
dre_status dre_set_id(const dre_motor *m, uint8_t new_id, dre_req *req)
{
    dre_bus *bus = m->bus;
    uint8_t node = m->node, apart = node != new_id;
    dre_request here = request(node, 0u, DRE_F32), probe = request(new_id, 0u, DRE_F32);
    unsigned frames;
    dre_req helper = 0u;
    dre_msg read_here = read_msg(node, 0u, DRE_F32);
    dre_status st;
    dre_frame f;

    if (new_id == DRE_BROADCAST || new_id > DRE_MAX_NODE) {
        return range_error(bus, DRE_FIELD_VALUE, 0u);
    }
    st = encode(bus, &read_here, &f); /* is the current id valid? */
    if (st != DRE_OK) {
        return st;
    }
    frames = (node_idle(bus, new_id) ? 1u : 0u) + (apart && node_idle(bus, node) ? 1u : 0u);
    if (free_slots(bus) < (apart ? 2u : 1u) || !room(bus, frames)) {
        return DRE_E_BUSY;
    }
    probe.link = node;
    if (!apart) {
        probe.step = STEP_ID_HERE;
        return issue(bus, &probe, 0, req);
    }
    here.step = STEP_ID_HELPER;
    st = issue(bus, &here, 0, &helper);
    if (st != DRE_OK) {
        return st;
    }
    probe.step = STEP_ID_FREE;
    (void)issue(bus, &probe, 1, req); /* a free slot was checked: queued at worst */
    bus->slots[helper & 0xFFu].link = (uint8_t)(*req & 0xFFu);
    return DRE_OK;
}

dre_status dre_set_traj_mode(const dre_motor *m, uint8_t mode, dre_req *req)
{
    static const dre_param_t param = DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE;
    dre_value v;

    if (mode != DRE_TRAJ_TRAPEZOID && mode != DRE_TRAJ_S_CURVE) {
        return range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    v.i = mode;
    return verified_writes(m, 1u, &param, &v, 0, req);
}

dre_status dre_set_angle_range(const dre_motor *m, float angle_min, float angle_max, float position,
                               dre_req req[3])
{
    static const dre_param_t params[3] = {DRE_P_AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN,
                                          DRE_P_AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX,
                                          DRE_P_AXIS0_CONFIG_EXTRA_SETTING_ENABLE_CIRCULAR_SETPOINT_LIMIT};
    dre_value v[3];

    if (!is_finite(angle_min)) {
        return range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    if (!is_finite(angle_max) || !(angle_min < angle_max)) {
        return range_error(m->bus, DRE_FIELD_VALUE, 1u);
    }
    if (!(position >= angle_min && position <= angle_max)) {
        return range_error(m->bus, DRE_FIELD_POSITION, 0u);
    }
    v[0].i = 0;
    v[1].i = 0;
    v[0].f32 = angle_min;
    v[1].f32 = angle_max;
    v[2].i = 1;
    return verified_writes(m, 3u, params, v, 1, req);
}

static dre_status set_baud(const dre_motor *m, dre_param_t param, const uint32_t *rates, uint32_t rate,
                           dre_req *req)
{
    dre_value v;
    uint8_t i;

    i = 0u;
    while (i < 4u && rates[i] != rate) {
        i++;
    }
    if (i == 4u) {
        return range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    v.i = rate;
    return verified_writes(m, 1u, &param, &v, 1, req);
}

dre_status dre_set_can_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req)
{
    static const uint32_t rates[4] = {125000u, 250000u, 500000u, 1000000u};
    return set_baud(m, DRE_P_CAN_CONFIG_BAUD_RATE, rates, baud_rate, req);
}

dre_status dre_set_uart_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req)
{
    static const uint32_t rates[4] = {9600u, 19200u, 57600u, 115200u};
    return set_baud(m, DRE_P_CONFIG_UART_BAUDRATE, rates, baud_rate, req);
}

/* ----------------------------------------------------------------- waiting for moves */

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

/* ----------------------------------------------------------------- several motors */

/* How to build the i-th preset of a batch. */
typedef struct {
    const dre_msg *presets; /* given presets, or NULL to build them from the fields below */
    uint8_t type;           /* preset type */
    const uint8_t *ids;
    const float *values; /* first field of each preset */
    float second, third; /* T/Q/P: the other two fields in wire order; V/C: param in `second` */
    uint8_t mode;        /* V and C presets: the wire mode */
} batch;

static dre_msg batch_msg(const batch *b, uint8_t i)
{
    dre_msg m;
    float v;

    if (b->presets != NULL) {
        return b->presets[i];
    }
    v = b->values[i];
    memset(&m, 0, sizeof m);
    m.type = b->type;
    m.node = b->ids[i];
    switch (b->type) {
    case DRE_MSG_PRESET_T:
        m.u.position_t.position = v;
        m.u.position_t.speed = b->second;
        m.u.position_t.bandwidth = b->third;
        break;
    case DRE_MSG_PRESET_Q:
        m.u.preset_q.position = v;
        m.u.preset_q.time = b->second;
        m.u.preset_q.accel = b->third;
        break;
    case DRE_MSG_PRESET_P:
        m.u.position_p.position = v;
        m.u.position_p.speed_ff = b->second;
        m.u.position_p.torque_ff = b->third;
        break;
    case DRE_MSG_PRESET_V:
        m.u.velocity.speed = v;
        /* feed-forward torque is sent as 0 for a motor told to stand still, as the vendor does */
        m.u.velocity.param = b->mode == DRE_VEL_PASSTHROUGH && v == 0.0f ? 0.0f : b->second;
        m.u.velocity.mode = b->mode;
        break;
    default: /* DRE_MSG_PRESET_C */
        m.u.torque.torque = v;
        m.u.torque.param = b->second;
        m.u.torque.mode = b->mode;
        break;
    }
    return m;
}

/* The start kind a preset type belongs to; 0 for the generic preset, 0xFF for a non-preset. */
static uint8_t preset_kind(uint8_t type)
{
    static const uint8_t kinds[] = {0u, DRE_START_T, DRE_START_Q, DRE_START_P,
                                    DRE_START_V, DRE_START_C, DRE_START_D};
    return type >= DRE_MSG_PRESET && type <= DRE_MSG_PRESET_D ? kinds[type - DRE_MSG_PRESET] : 0xFFu;
}

static int gain_ok(float v)
{
    return v >= 0.0f && v <= S16_MAX;
}

/* Motor id number `index` of a batch: 1..63 and not seen before (added to *seen). */
static dre_status check_id(dre_bus *bus, uint64_t *seen, uint8_t id, uint8_t index)
{
    if (id == DRE_BROADCAST || id > DRE_MAX_NODE) {
        return range_error(bus, DRE_FIELD_NODE, index);
    }
    if ((*seen & motor_bits(id)) != 0u) {
        bus->bad_field = DRE_FIELD_NODE;
        bus->bad_index = index;
        return DRE_E_ARG;
    }
    *seen |= motor_bits(id);
    return DRE_OK;
}

static dre_status check_ids(dre_bus *bus, uint8_t n, const uint8_t *ids)
{
    uint64_t seen = 0u;
    dre_status st = DRE_OK;
    uint8_t i;

    for (i = 0u; i < n && st == DRE_OK; i++) {
        st = check_id(bus, &seen, ids[i], i);
    }
    return st;
}

/*
 * Send the start of a batch (bus->held_start) to broadcast (held_nodes == 1)
 * or to each motor of held_nodes; a motor leaves presets_pending when its
 * start (or the broadcast) went out.
 */
static dre_status send_starts(dre_bus *bus)
{
    dre_msg s = bus->held_start;
    uint64_t nodes = bus->held_nodes;
    dre_frame f;
    uint8_t node;

    bus->held_nodes = 0u;
    for (node = 0u; node <= 63u; node++) {
        if ((nodes & ((uint64_t)1u << node)) == 0u) {
            continue;
        }
        s.node = node == 0u ? (uint8_t)DRE_BROADCAST : node;
        (void)dre_encode(&s, &f, NULL);
        if (transmit(bus, &f) != DRE_OK) {
            bus->held_status = (int8_t)DRE_E_SEND;
            return DRE_E_SEND;
        }
        bus->presets_pending &= node == 0u ? 0u : ~motor_bits(node);
    }
    bus->held_status = (int8_t)DRE_OK;
    return DRE_OK;
}

/* With cfg.tx_done: send a held start once the presets are on the wire, or give it up after the timeout. */
static void release_start(dre_bus *bus, uint32_t now)
{
    if (bus->held_status != (int8_t)DRE_PENDING) {
        return;
    }
    if (bus->cfg.tx_done(bus->cfg.user)) {
        (void)send_starts(bus);
    } else if ((uint32_t)(now - bus->held_ms) >= bus->cfg.timeout_ms) {
        bus->held_nodes = 0u;
        bus->held_status = (int8_t)DRE_E_TIMEOUT;
        bus->stats.timeouts++;
    }
}

dre_status dre_batch_status(const dre_bus *bus)
{
    return (dre_status)bus->held_status;
}

/*
 * Validate every preset and the start, choose where the start goes (cfg.start),
 * check there is room for every frame, then send. Motors holding a preset
 * without a start are tracked in presets_pending.
 */
static dre_status run_batch(dre_bus *bus, const batch *b, uint8_t n, const dre_msg *start)
{
    uint8_t kind = start->type == DRE_MSG_START_IMPEDANCE ? (uint8_t)DRE_START_D : start->u.start.kind;
    uint64_t mask = 0u;
    dre_msg s = *start;
    dre_field bad;
    dre_frame f;
    dre_msg m;
    uint8_t i, broadcast;

    if (n == 0u || (start->type != DRE_MSG_START && start->type != DRE_MSG_START_IMPEDANCE)) {
        return DRE_E_ARG;
    }
    for (i = 0u; i < n; i++) {
        uint8_t k;
        m = batch_msg(b, i);
        k = preset_kind(m.type);
        if (k == 0xFFu || (k != 0u && k != kind)) {
            bus->bad_index = i;
            return DRE_E_ARG;
        }
        if (dre_encode(&m, &f, &bad) != DRE_OK) {
            return range_error(bus, bad, i);
        }
        mask |= motor_bits(m.node);
    }
    s.node = DRE_BROADCAST;
    if (dre_encode(&s, &f, &bad) != DRE_OK) {
        return range_error(bus, bad, n);
    }
    if (s.type == DRE_MSG_START_IMPEDANCE) {
        if (!gain_ok(s.u.start_impedance.kp)) {
            return range_error(bus, DRE_FIELD_KP, n);
        }
        if (!gain_ok(s.u.start_impedance.kd)) {
            return range_error(bus, DRE_FIELD_KD, n);
        }
    }
    broadcast = bus->cfg.start == DRE_START_TO_BROADCAST ||
                (bus->cfg.start == DRE_START_TO_AUTO && n > 1u && (bus->presets_pending & ~mask) == 0u);
    if (bus->held_status == (int8_t)DRE_PENDING || !room(bus, (unsigned)n + (broadcast ? 1u : n))) {
        return DRE_E_BUSY;
    }
    for (i = 0u; i < n; i++) {
        m = batch_msg(b, i);
        (void)dre_encode(&m, &f, NULL);
        if (transmit(bus, &f) != DRE_OK) {
            return DRE_E_SEND;
        }
        bus->presets_pending |= motor_bits(m.node);
    }
    bus->held_start = s;
    bus->held_nodes = broadcast ? 1u : mask;
    if (bus->cfg.tx_done != NULL && !bus->cfg.tx_done(bus->cfg.user)) {
        bus->held_status = (int8_t)DRE_PENDING; /* dre_bus_poll() sends the start once the presets are out */
        bus->held_ms = bus->cfg.tick(bus->cfg.user);
        return DRE_PENDING;
    }
    return send_starts(bus);
}

dre_status dre_preset_start(dre_bus *bus, const dre_msg *presets, uint8_t n, const dre_msg *start)
{
    uint64_t seen = 0u;
    batch b;
    uint8_t i;

    if (presets == NULL || start == NULL) {
        return DRE_E_ARG;
    }
    for (i = 0u; i < n; i++) {
        dre_status st = check_id(bus, &seen, presets[i].node, i);
        if (st != DRE_OK) {
            return st;
        }
    }
    memset(&b, 0, sizeof b);
    b.presets = presets;
    return run_batch(bus, &b, n, start);
}

dre_status dre_impedance_control(const dre_motor *m, float pos, float vel, float tff, float kp, float kd)
{
    dre_msg preset = msg_for(m, DRE_MSG_PRESET_D);
    dre_msg start = msg_for(m, DRE_MSG_START_IMPEDANCE);
    batch b;

    preset.u.preset_d.position = pos;
    preset.u.preset_d.speed = vel;
    preset.u.preset_d.torque_ff = tff;
    start.u.start_impedance.kp = kp;
    start.u.start_impedance.kd = kd;
    memset(&b, 0, sizeof b);
    b.presets = &preset;
    return run_batch(m->bus, &b, 1u, &start);
}

static dre_msg start_msg(uint8_t kind, uint8_t relative)
{
    dre_msg m;
    memset(&m, 0, sizeof m);
    m.type = DRE_MSG_START;
    m.node = DRE_BROADCAST;
    m.u.start.kind = kind;
    m.u.start.relative = relative;
    return m;
}

dre_status dre_q_move_time(float distance, float speed, float accel, uint8_t traj_mode, float *time_s)
{
    float v = speed, a = accel, d = distance;

    if (!positive(v) || !positive(a) || !(d >= 0.0f && d <= FLT_MAX)) {
        return DRE_E_RANGE;
    }
    /* 1 r/min = 6 deg/s; PROTOCOL.md 3.4.3 */
    if (traj_mode == DRE_TRAJ_S_CURVE) {
        *time_s = d <= 12.0f * v * v / a ? 4.0f * sqrtf(a * d / 12.0f) / a : d / (6.0f * v) + 2.0f * v / a;
    } else if (traj_mode == DRE_TRAJ_TRAPEZOID || traj_mode == 0u) {
        *time_s = d <= 6.0f * v * v / a ? 2.0f * sqrtf(d / (6.0f * a)) : v / a + d / (6.0f * v);
    } else {
        return DRE_E_RANGE;
    }
    return DRE_OK;
}

/*
 * The Q-preset time of the slowest move, each motor with its own profile,
 * rounded up to the 0.01 s the preset carries (at least 0.01 s) as the Python
 * client does; a product within float rounding error above a step stays on it.
 */
static dre_status q_batch_time(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *targets,
                               const float *from, float speed, float accel, float *time_s)
{
    float t = 0.0f, x;
    uint8_t i;

    for (i = 0u; i < n; i++) {
        float ti, d = fabsf(from == NULL ? targets[i] : targets[i] - from[i]);
        if (dre_q_move_time(d, speed, accel, traj_of(bus, ids[i]), &ti) != DRE_OK) {
            return range_error(bus, DRE_FIELD_TIME, i);
        }
        t = ti > t ? ti : t;
    }
    x = t * 100.0f;
    x = ceilf(x - x * 1.0e-6f);
    *time_s = (x < 1.0f ? 1.0f : x) / 100.0f;
    return *time_s <= S16_MAX ? DRE_OK : range_error(bus, DRE_FIELD_TIME, 0u);
}

static dre_status move_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *targets, const float *from,
                              float speed, float param, uint8_t mode, uint8_t relative)
{
    static const uint8_t types[] = {DRE_MSG_PRESET_T, DRE_MSG_PRESET_Q, DRE_MSG_PRESET_P};
    dre_msg start;
    dre_status st;
    batch b;
    uint8_t i;

    if (ids == NULL || targets == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    st = check_ids(bus, n, ids);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < n; i++) {
        if (!is_finite(targets[i])) {
            return range_error(bus, DRE_FIELD_POSITION, i);
        }
    }
    if (mode > DRE_ANGLE_P) {
        return range_error(bus, DRE_FIELD_MODE, 0u);
    }
    memset(&b, 0, sizeof b);
    b.type = types[mode];
    b.ids = ids;
    b.values = targets;
    b.second = speed; /* T: speed, bandwidth; Q: time (below), accel; P: speed_ff, torque_ff */
    b.third = param;
    if (mode == DRE_ANGLE_T) {
        if (bandwidth(bus, param, &b.third) != DRE_OK) {
            return DRE_E_RANGE;
        }
        if (!is_finite(speed)) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        b.second = fabsf(speed);
    } else if (mode == DRE_ANGLE_Q) {
        if (!relative && from == NULL) {
            return DRE_E_ARG;
        }
        if (!wire_positive(speed) || speed > S16_MAX) {
            return range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!wire_positive(param)) {
            return range_error(bus, DRE_FIELD_ACCEL, 0u);
        }
        for (i = 0u; i < n && !relative; i++) {
            if (!is_finite(from[i])) {
                return range_error(bus, DRE_FIELD_FROM, i);
            }
        }
        st = q_batch_time(bus, n, ids, targets, relative ? NULL : from, speed, param, &b.second);
        if (st != DRE_OK) {
            return st;
        }
    }
    start = start_msg((uint8_t)(DRE_START_T + mode), relative);
    return run_batch(bus, &b, n, &start);
}

dre_status dre_set_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *angles, const float *from,
                          float speed, float param, uint8_t mode)
{
    return move_angles(bus, n, ids, angles, from, speed, param, mode, 0u);
}

dre_status dre_step_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *deltas, float speed,
                           float param, uint8_t mode)
{
    return move_angles(bus, n, ids, deltas, NULL, speed, param, mode, 1u);
}

static dre_status speeds_or_torques(dre_bus *bus, uint8_t type, uint8_t n, const uint8_t *ids, const float *values,
                                    float param, uint8_t mode)
{
    uint8_t velocity = type == DRE_MSG_PRESET_V, wire, i;
    dre_msg start = start_msg(velocity ? (uint8_t)DRE_START_V : (uint8_t)DRE_START_C, 0u);
    dre_status st;
    batch b;

    if (ids == NULL || values == NULL || n == 0u) {
        return DRE_E_ARG;
    }
    st = check_ids(bus, n, ids);
    if (st != DRE_OK) {
        return st;
    }
    for (i = 0u; i < n; i++) {
        if (!is_finite(values[i])) {
            return range_error(bus, velocity ? DRE_FIELD_SPEED : DRE_FIELD_TORQUE, i);
        }
    }
    wire = velocity ? velocity_mode(mode) : torque_mode(mode);
    if (wire == 0u) {
        return range_error(bus, DRE_FIELD_MODE, 0u);
    }
    if (!is_finite(param)) {
        return range_error(bus, DRE_FIELD_PARAM, 0u); /* even where it is unused: NaN is a mistake */
    }
    if (!velocity && wire == DRE_TORQUE_DIRECT) {
        param = 0.0f; /* direct torque has no parameter */
    } else if (wire == DRE_VEL_RAMP || wire == DRE_TORQUE_RAMP ? !wire_positive(param) : !is_finite(param)) {
        return range_error(bus, DRE_FIELD_PARAM, 0u);
    }
    memset(&b, 0, sizeof b);
    b.type = type;
    b.ids = ids;
    b.values = values;
    b.second = param;
    b.mode = wire;
    return run_batch(bus, &b, n, &start);
}

dre_status dre_set_speeds(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *speeds, float param,
                          uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_V, n, ids, speeds, param, mode);
}

dre_status dre_set_torques(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *torques, float param,
                           uint8_t mode)
{
    return speeds_or_torques(bus, DRE_MSG_PRESET_C, n, ids, torques, param, mode);
}
