/*
 * The bus: initialisation, the receive queue, encoding and sending (with the
 * checks of parameter writes), what the bus learns of each motor, request
 * slots and reply matching (dre_bus_feed), timeouts and queued requests
 * (dre_bus_poll), a batch's start held until its presets are out, and the
 * transmit ring (see dre_client.h). It calls no module above it: the move
 * records and the verified writes learn what they need through the hooks they
 * attach (bus->move_hooks, bus->request_hooks).
 */
#include "dre_client_internal.h"

#include <float.h>
#include <string.h>

#define TRAJ_ADDRESS DRE_PARAM_ADDRESS(DRE_P_AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE)

/* ----------------------------------------------------------------- checks */

dre_status dre_i_range_error(dre_bus *bus, dre_field field, uint8_t index)
{
    bus->bad_field = field;
    bus->bad_index = index;
    bus->bad_address = 0u;
    return DRE_E_RANGE;
}

int dre_i_is_finite(float v)
{
    return v >= -FLT_MAX && v <= FLT_MAX;
}

/* > 0 and still > 0 on the wire: x 100 rounds to at least 1 (0.005f x 100 rounds to 0). */
int dre_i_wire_positive(float v)
{
    return v > 0.005f && v <= FLT_MAX;
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
    (void)dre_i_range_error(bus, bad, 0u);
    bus->bad_address = address;
    return DRE_E_RANGE;
}

/* ----------------------------------------------------------------- what the bus learns */

/* A motor's Q profile (35104) was written or read as `value`; node 0: all unknown. */
static void traj_learn(dre_bus *bus, uint8_t node, uint8_t dtype, int64_t value)
{
    uint64_t bit = dre_i_motor_bits(node);

    bus->traj_known &= ~bit;
    bus->traj_scurve &= ~bit;
    if (node != DRE_BROADCAST && dtype != DRE_F32 && (value == DRE_TRAJ_TRAPEZOID || value == DRE_TRAJ_S_CURVE)) {
        bus->traj_known |= bit;
        if (value == DRE_TRAJ_S_CURVE) {
            bus->traj_scurve |= bit;
        }
    }
}

void dre_i_traj_forget(dre_bus *bus, uint8_t node)
{
    traj_learn(bus, node, DRE_F32, 0);
}

/* The profile set_angles uses for motor `node`. */
uint8_t dre_i_traj_of(const dre_bus *bus, uint8_t node)
{
    uint64_t bit = dre_i_motor_bits(node);
    if ((bus->traj_known & bit) == 0u) {
        return bus->cfg.traj_mode;
    }
    return (bus->traj_scurve & bit) != 0u ? (uint8_t)DRE_TRAJ_S_CURVE : (uint8_t)DRE_TRAJ_TRAPEZOID;
}

/* Track what a sent message changes. */
void dre_i_note(dre_bus *bus, const dre_msg *msg)
{
    if (msg->type == DRE_MSG_WRITE_PARAM && msg->u.param.address == TRAJ_ADDRESS) {
        traj_learn(bus, msg->node, msg->u.param.dtype, msg->u.param.value.i);
    } else if (msg->type == DRE_MSG_SYSTEM &&
               (msg->u.system.op == DRE_SYS_INIT_CONFIG || msg->u.system.op == DRE_SYS_ERASE_CONFIG ||
                msg->u.system.op == DRE_SYS_REBOOT)) {
        dre_i_traj_forget(bus, msg->node);
    }
    if (bus->move_hooks != NULL) {
        bus->move_hooks->sent(bus, msg);
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
        return dre_i_range_error(bus, bad, 0u);
    }
    return DRE_OK;
}

dre_status dre_i_transmit(dre_bus *bus, const dre_frame *f)
{
    return bus->cfg.send(bus->cfg.user, f) == 0 ? DRE_OK : DRE_E_SEND;
}

/* Can the port take `frames` frames now? */
int dre_i_room(dre_bus *bus, unsigned frames)
{
    return bus->cfg.tx_free == NULL || bus->cfg.tx_free(bus->cfg.user) >= frames;
}

dre_status dre_i_encode(dre_bus *bus, const dre_msg *msg, dre_frame *f)
{
    return encode_as(bus, msg, f, 0);
}

dre_status dre_i_send_as(dre_bus *bus, const dre_msg *msg, int force)
{
    dre_frame f;
    dre_status st = encode_as(bus, msg, &f, force);
    if (st == DRE_OK) {
        st = dre_i_transmit(bus, &f);
    }
    if (st == DRE_OK) {
        dre_i_note(bus, msg);
    }
    return st;
}

dre_status dre_i_system_op(dre_bus *bus, uint8_t node, uint8_t op)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = DRE_MSG_SYSTEM;
    msg.node = node;
    msg.u.system.op = op;
    return dre_i_send_as(bus, &msg, 0);
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

int dre_i_node_idle(const dre_bus *bus, uint8_t node)
{
    uint8_t i;
    for (i = 0u; i < bus->nslots; i++) {
        if (bus->slots[i].node == node && active(&bus->slots[i])) {
            return 0;
        }
    }
    return 1;
}

uint8_t dre_i_free_slots(const dre_bus *bus)
{
    uint8_t i, n = 0u;
    for (i = 0u; i < bus->nslots; i++) {
        n = (uint8_t)(n + (bus->slots[i].state == SLOT_FREE ? 1u : 0u));
    }
    return n;
}

/* The read (address 0: fast read) a request sends. */
dre_msg dre_i_read_msg(uint8_t node, uint16_t address, uint8_t dtype)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = address == 0u ? (uint8_t)DRE_MSG_FAST_READ : (uint8_t)DRE_MSG_READ_PARAM;
    msg.node = node;
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    return msg;
}

/* A request for a read of `address` (0: fast read) from `node`, to fill in and give to dre_i_issue(). */
dre_request dre_i_request(uint8_t node, uint16_t address, uint8_t dtype)
{
    dre_request r;
    memset(&r, 0, sizeof r);
    r.node = node;
    r.address = address;
    r.dtype = dtype;
    return r;
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
dre_request *dre_i_helper_of(dre_bus *bus, const dre_request *r)
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
void dre_i_release_helper(dre_bus *bus, const dre_request *r)
{
    if (r->step == STEP_ID_FREE) {
        dre_request *h = dre_i_helper_of(bus, r);
        if (h != NULL) {
            h->state = SLOT_FREE;
        }
    }
}

void dre_i_fail(dre_bus *bus, dre_request *r, uint8_t state)
{
    break_chain(bus, r);
    dre_i_release_helper(bus, r);
    r->state = state;
}

/*
 * Put request `want` (its read, flags, step, link and in reply.u.param.value
 * the value a verified write expects) in a free slot: sent at once when the
 * motor has no other request in flight or waiting, otherwise queued for
 * dre_bus_poll(). When sending fails, `may_queue` leaves it queued (an
 * operation that already sent frames); otherwise the slot is released and
 * DRE_E_SEND returned.
 */
dre_status dre_i_issue(dre_bus *bus, const dre_request *want, int may_queue, dre_req *req)
{
    dre_msg msg = dre_i_read_msg(want->node, want->address, want->dtype);
    dre_request *r = NULL;
    dre_frame f;
    dre_status st;
    uint8_t i;

    st = dre_i_encode(bus, &msg, &f);
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
    if (!dre_i_node_idle(bus, want->node)) {
        r->state = SLOT_QUEUED;
    } else if (dre_i_transmit(bus, &f) == DRE_OK) {
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

/* Does `msg` answer `r`? 1 yes, 0 no, -1 its node and address match but not the data type it echoes. */
static int answers(const dre_request *r, const dre_msg *msg)
{
    if (r->state != SLOT_PENDING || (r->node != DRE_BROADCAST && r->node != msg->node)) {
        return 0;
    }
    if (msg->type == DRE_MSG_STATE) {
        return r->address == 0u;
    }
    if (r->address == 0u || r->address != msg->u.param.address) {
        return 0;
    }
    return r->dtype == msg->u.param.dtype ? 1 : -1;
}

/* A reply answered `r`: a request with a step or a check goes to the hooks of dre_verified.c, which issued it. */
static void complete(dre_bus *bus, dre_request *r, const dre_msg *msg)
{
    r->flags &= (uint8_t)~FLAG_HELD;
    if ((r->step != STEP_NONE || (r->flags & (FLAG_VERIFY | FLAG_SAVE)) != 0u) && bus->request_hooks != NULL) {
        bus->request_hooks->reply(bus, r, msg);
        return;
    }
    r->state = SLOT_DONE;
    r->reply = *msg;
}

/* Are the value bytes of a parameter reply all 0 (the bytes of a read request)? */
static int zero_value(const dre_frame *frame)
{
    return (frame->data[4] | frame->data[5] | frame->data[6] | frame->data[7]) == 0u;
}

/* Take the reply of value 0 held back for `r` as its answer. */
static void take_held(dre_bus *bus, dre_request *r)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = DRE_MSG_PARAM_VALUE;
    msg.node = r->held_node;
    msg.u.param.address = r->address;
    msg.u.param.dtype = r->dtype;
    if (r->dtype == DRE_F32) {
        msg.u.param.value.f32 = 0.0f;
    }
    complete(bus, r, &msg);
}

/*
 * Is a frame of `node` with bit 0 set its state (PROTOCOL.md 1.6, as the Python client)? 0x01..0x17 always
 * (one answering this bus, `answers` 1, shows bits 3-4 sent as 0; 0x09..0x17 shows them kept). 0x1F whose
 * bytes 0-3 are a valid write never. 0x19/0x1B/0x1D/other 0x1F: not when the motor sends bits 3-4 as 0;
 * yes when it answers a request of this bus (the motor is then taken to keep them); else only when the
 * motor keeps them and no other host was seen.
 */
static int status_frame(dre_bus *bus, const dre_frame *frame, uint8_t node, int answers)
{
    uint8_t cmd = (uint8_t)(frame->id & 0x1Fu);
    uint64_t bit = (uint64_t)1u << node;

    if (cmd < 0x18u) {
        if (cmd > 0x07u || answers) {
            bus->bits_zero = cmd < 0x08u ? bus->bits_zero | bit : bus->bits_zero & ~bit;
            bus->bits_kept = cmd < 0x08u ? bus->bits_kept & ~bit : bus->bits_kept | bit;
        }
        return 1;
    }
    if (cmd == 0x1Fu && (frame->data[0] | frame->data[1]) != 0u && frame->data[3] == 0u && frame->data[2] <= 4u) {
        return 0;
    }
    if ((bus->bits_zero & bit) != 0u) {
        return 0;
    }
    if (answers) {
        bus->bits_kept |= bit;
        return 1;
    }
    return (bus->bits_kept & bit) != 0u && !bus->other_hosts;
}

dre_status dre_bus_feed(dre_bus *bus, const dre_frame *frame)
{
    dre_msg msg;
    dre_request *best = NULL;
    int mismatched = 0;
    uint8_t i;

    bus->stats.rx_frames++;
    if (frame->len == 8u && dre_i_host_only(frame->id)) {
        bus->other_hosts = 1u;
    }
    if (dre_decode_reply(frame, &msg) != DRE_OK) {
        bus->stats.rx_malformed++;
        return DRE_E_PROTOCOL;
    }
    for (i = 0u; i < bus->nslots; i++) {
        dre_request *r = &bus->slots[i];
        /* the oldest request is the one furthest behind the sequence counter */
        int a = answers(r, &msg);
        if (a > 0 && (best == NULL || older(bus, r, best))) {
            best = r;
        }
        mismatched |= a < 0;
    }
    if (msg.type == DRE_MSG_STATE && !status_frame(bus, frame, msg.node, best != NULL)) {
        bus->other_hosts = 1u; /* another host's T, P, C or write (PROTOCOL.md 1.6) */
        bus->stats.rx_unmatched++;
        return DRE_OK;
    }
    if (msg.type == DRE_MSG_STATE && bus->move_hooks != NULL) {
        bus->move_hooks->state(bus, &msg);
    }
    if (msg.type == DRE_MSG_PARAM_VALUE && msg.u.param.address == TRAJ_ADDRESS && msg.node != DRE_BROADCAST) {
        traj_learn(bus, msg.node, msg.u.param.dtype, msg.u.param.value.i);
    }
    if (msg.type == DRE_MSG_PARAM_VALUE && zero_value(frame)) {
        if (best != NULL && (best->flags & FLAG_HELD) != 0u) {
            return DRE_OK; /* another such frame: the first one's grace runs on */
        }
        if (best != NULL && bus->other_hosts) {
            best->flags |= FLAG_HELD; /* perhaps another host's read request: wait for the grace */
            best->held_node = msg.node;
            best->reply_ms = bus->cfg.tick(bus->cfg.user);
            return DRE_OK;
        }
        if (best == NULL) {
            bus->other_hosts = 1u; /* most likely another host's read request */
        }
    }
    if (best != NULL) {
        best->reply_ms = bus->cfg.tick(bus->cfg.user);
        complete(bus, best, &msg);
    } else {
        bus->stats.rx_anomalies += mismatched ? 1u : 0u;
        bus->stats.rx_unmatched++;
        if (bus->cfg.on_unmatched != NULL) {
            bus->cfg.on_unmatched(bus->cfg.user, &msg);
        }
    }
    return DRE_OK;
}

/* ----------------------------------------------------------------- starts held until the presets are out */

/* Tell the move records that the held start went out (`sent` 1) or never will (0). */
static void moves_started(dre_bus *bus, int sent)
{
    if (bus->move_hooks != NULL) {
        bus->move_hooks->started(bus, sent);
    }
}

/*
 * Send the start of a batch (bus->held_start) to broadcast (held_nodes == 1)
 * or to each motor of held_nodes; a motor leaves presets_pending when its
 * start (or the broadcast) went out.
 */
dre_status dre_i_send_starts(dre_bus *bus)
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
        if (dre_i_transmit(bus, &f) != DRE_OK) {
            moves_started(bus, 0);
            bus->held_status = (int8_t)DRE_E_SEND;
            return DRE_E_SEND;
        }
        bus->presets_pending &= node == 0u ? 0u : ~dre_i_motor_bits(node);
    }
    moves_started(bus, 1);
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
        (void)dre_i_send_starts(bus);
    } else if ((uint32_t)(now - bus->held_ms) >= bus->cfg.timeout_ms) {
        bus->held_nodes = 0u;
        moves_started(bus, 0);
        bus->held_status = (int8_t)DRE_E_TIMEOUT;
        bus->stats.timeouts++;
    }
}

/* ----------------------------------------------------------------- polling and results */

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
        /* a held reply of value 0 is the answer once its grace ended, or at the request's timeout */
        if (r->state == SLOT_PENDING && (r->flags & FLAG_HELD) != 0u &&
            ((uint32_t)(now - r->reply_ms) >= DRE_ZERO_REPLY_GRACE_MS ||
             (uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms)) {
            take_held(bus, r);
        }
        if (r->state == SLOT_PENDING && (uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
            if (r->tries < bus->cfg.retries) {
                r->tries++; /* sent again below, to the same motor, with a whole timeout */
                r->state = SLOT_QUEUED;
                r->sent_ms = now;
            } else if (r->step == STEP_ID_FREE) {
                r->state = SLOT_WAIT; /* nobody answers at the new id: it is free */
                r->sent_ms = now;
            } else {
                dre_i_fail(bus, r, r->step == STEP_ID_HERE ? (uint8_t)SLOT_ABSENT : (uint8_t)SLOT_TIMEOUT);
                bus->stats.timeouts++;
            }
        }
    }
    for (i = 0u; i < bus->nslots; i++) {
        if (bus->slots[i].state == SLOT_WAIT && bus->request_hooks != NULL) {
            bus->request_hooks->step(bus, &bus->slots[i], now);
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
            dre_msg msg = dre_i_read_msg(r->node, r->address, r->dtype);
            if (dre_i_room(bus, 1u) && dre_i_encode(bus, &msg, &f) == DRE_OK && dre_i_transmit(bus, &f) == DRE_OK) {
                r->state = SLOT_PENDING;
                r->sent_ms = now;
            } else if ((uint32_t)(now - r->sent_ms) >= bus->cfg.timeout_ms) {
                if (r->step != STEP_NONE) {
                    dre_i_fail(bus, r, SLOT_SEND_FAILED); /* a probe of dre_set_id that never went out */
                } else {
                    dre_i_fail(bus, r, SLOT_TIMEOUT);
                    bus->stats.timeouts++;
                }
            }
        }
    }
}

static dre_request *slot_of(dre_bus *bus, dre_req req);

dre_status dre_i_result_at(dre_bus *bus, dre_req req, dre_msg *reply, uint32_t *at_ms)
{
    dre_request *r = slot_of(bus, req);
    if (r != NULL) {
        *at_ms = r->reply_ms;
    }
    return dre_result(bus, req, reply);
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
            dre_i_release_helper(bus, r);
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
