/**
 * @file dre_client.h
 * @brief Per-motor commands, request tracking with timeouts, multi-motor moves.
 *
 * All state lives in caller-owned structs: no heap, no globals, no blocking.
 * The user supplies a send callback and a millisecond tick, feeds received
 * frames in, and polls requests for their replies.
 *
 * Implemented by job, in layers: src/dre_bus.c (the bus, requests, reply
 * matching, timers, the transmit ring), src/dre_moves.c (the moves the bus
 * commanded), src/dre_motor.c (single-motor commands), src/dre_verified.c
 * (verified writes, dre_set_id), src/dre_wait.c (waiting for the moves) and
 * src/dre_batch.c (multi-motor batches).
 *
 * Concurrency: dre_bus_isr_push() is the one function that may run in an
 * interrupt (one producer). Every other dre_bus / dre_motor function belongs
 * to the main loop (one consumer), including dre_bus_feed() and dre_bus_poll().
 * The transmit ring (dre_txq) has the mirror split: the send callback pushes
 * from the main loop, the TX-complete interrupt (or the poll loop) drains.
 *
 *     CAN RX interrupt:  dre_bus_isr_push(&bus, &frame);
 *     main loop:         dre_bus_poll(&bus);   // drains the queue, expires requests
 *                        if (dre_result(&bus, req, &reply) == DRE_OK) ...
 *
 * Functions that validate set bus->bad_field (and bus->bad_index for the
 * motor index in a batch) when they return DRE_E_RANGE. Nothing is sent
 * when a function returns DRE_E_RANGE, DRE_E_ARG, DRE_E_ACCESS or DRE_E_BUSY.
 *
 * Every parameter write the bus sends (dre_write_param, dre_write_property,
 * dre_send, the verified writes) is checked against the parameters whose
 * values form a fixed set (see dre_param_choices) and against each
 * parameter's domain (dre_param_check, from spec/parameters.csv): a value
 * outside them is refused before anything is sent, with DRE_E_RANGE,
 * DRE_FIELD_VALUE (DRE_FIELD_DTYPE for an f32 to a fixed set) and
 * bus->bad_address naming the parameter. Only dre_write_property_forced
 * writes outside a soft bound.
 *
 * Requests to the same motor go out one at a time, as in the Python client: a
 * read reply carries the same CAN id as every read request to that motor, so a
 * second request sent while the reply is due could collide with it on the
 * wire. A request to a motor that already has one in flight waits in its slot
 * (dre_result() says DRE_PENDING) and dre_bus_poll() sends it when its turn
 * comes; its timeout runs from then.
 */
#ifndef DRE_CLIENT_H
#define DRE_CLIENT_H

#include <stdint.h>

#include "dre_codec.h"
#include "dre_params.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Memory barrier between writing a queued frame and publishing its index.
 * GCC and clang (also arm-none-eabi, Xtensa/RISC-V for ESP32, avr-gcc) get a
 * full barrier; define DRE_BARRIER() yourself for other compilers (e.g.
 * CMSIS __DMB() for IAR).
 */
#ifndef DRE_BARRIER
#if defined(__GNUC__) || defined(__clang__)
#define DRE_BARRIER() __sync_synchronize()
#else
#error "define DRE_BARRIER() as a memory barrier for this compiler"
#endif
#endif

#define DRE_DEFAULT_TIMEOUT_MS 50u /**< request timeout when the config gives 0 */
#define DRE_POLL_INTERVAL_MS 10u   /**< pause between the fast reads of dre_positions_done() */
#define DRE_ERROR_WORDS 7u         /**< requests of dre_dump_error() */
#ifndef DRE_MOVE_RECORDS
/** Position moves the bus remembers (the latest per motor) for dre_positions_done(); 1..63. */
#define DRE_MOVE_RECORDS 8u
#endif
#define DRE_MOVE_TOLERANCE 0.5f /**< largest distance (deg) between a finished move's position and its target */
#ifndef DRE_ZERO_REPLY_GRACE_MS
/** How long (ms) a parameter reply of value 0 is held back once another host was seen (see dre_bus_feed). */
#define DRE_ZERO_REPLY_GRACE_MS 10u
#endif

/** Queue one frame for transmission; return 0 on success, nonzero if it could not be queued. Never wait. */
typedef int (*dre_send_fn)(void *user, const dre_frame *frame);
/** A free-running millisecond counter (may wrap at 2^32). */
typedef uint32_t (*dre_tick_fn)(void *user);
/** A valid motor frame that completed no request (heartbeat, state after a control frame, late reply). */
typedef void (*dre_msg_fn)(void *user, const dre_msg *msg);
/** How many frames the send callback can take right now without failing. */
typedef unsigned (*dre_tx_free_fn)(void *user);
/**
 * Nonzero once every frame handed to the send callback has been transmitted
 * on the bus (bxCAN: every transmit mailbox empty, TXOKx set; SocketCAN: the
 * echo of the last frame seen). See dre_bus_config.tx_done.
 */
typedef int (*dre_tx_done_fn)(void *user);

/** Velocity profile of Q moves (axis0.trap_traj.config.traj_mode, 35104). */
typedef enum { DRE_TRAJ_TRAPEZOID = 1, DRE_TRAJ_S_CURVE = 2 } dre_traj_mode;

/** The vendor's set_angle modes. */
typedef enum {
    DRE_ANGLE_T = 0, /**< trajectory tracking: param = filter bandwidth 0 < bw <= 300 1/s, |speed| carried */
    DRE_ANGLE_Q = 1, /**< trapezoid/S-curve: speed = cruise r/min (> 0), param = accel (r/min)/s (> 0) */
    DRE_ANGLE_P = 2  /**< feed-forward: speed = speed FF r/min, param = torque FF Nm */
} dre_angle_mode;

/** dre_set_mode() states. */
enum { DRE_MODE_IDLE = 1, DRE_MODE_CLOSED_LOOP = 2 };

/**
 * Where the start command of a preset batch goes (dre_bus_config.start), as
 * the Python client's `start` option.
 */
typedef enum {
    /** One motor: to that motor. Several: broadcast, unless a motor outside the
     *  batch may still hold a preset from this bus; then to each motor. */
    DRE_START_TO_AUTO = 0,
    DRE_START_TO_BROADCAST = 1, /**< always broadcast (the vendor libraries' behaviour) */
    DRE_START_TO_NODE = 2       /**< always one start per motor, to its own id */
} dre_start_to;

#define DRE_MAX_BANDWIDTH 300.0f /**< largest T-mode filter bandwidth (1/s) the vendor documents */

typedef struct {
    dre_send_fn send;        /**< required */
    dre_tick_fn tick;        /**< required */
    void *user;              /**< passed to the callbacks */
    dre_msg_fn on_unmatched; /**< optional */
    /**
     * Optional: how many frames the port can queue now. Every operation that
     * sends several frames (batches, set_id, verified writes...) checks for
     * room for all of them first and returns DRE_E_BUSY, sending nothing,
     * when there is too little. NULL = unlimited (a deep software queue).
     */
    dre_tx_free_fn tx_free;
    /**
     * Optional, required when the controller arbitrates its transmit mailboxes
     * by identifier (bxCAN and most CAN peripherals with several mailboxes):
     * a batch's start (id node*32+8) would overtake its presets (id
     * node*32+12) still waiting in the mailboxes, and the motors whose preset
     * was overtaken would keep it for the next start. With tx_done set, a
     * batch sends its presets and, unless tx_done() says they have all left
     * already, holds the start and returns DRE_PENDING: dre_bus_poll() sends
     * it once tx_done() is nonzero; dre_batch_status() reports the outcome.
     * NULL: the port transmits in the order given (one mailbox, or a FIFO
     * such as dre_txq feeding one mailbox at a time), so the start follows at once.
     */
    dre_tx_done_fn tx_done;
    uint32_t timeout_ms; /**< per request; 0 = DRE_DEFAULT_TIMEOUT_MS */
    /** Q-move profile (dre_traj_mode) assumed for motors whose profile the bus
     *  has not learned (see dre_get_traj_mode); 0 = trapezoid. */
    uint8_t traj_mode;
    uint8_t start; /**< dre_start_to; 0 = DRE_START_TO_AUTO */
    /**
     * How often a request whose reply did not come is sent again, as the
     * Python client's `retries`: at its timeout a request (a read, a fast
     * read, the read-back of a verified write, a probe of dre_set_id) goes
     * out again to the same motor, with a whole timeout of its own, up to
     * `retries` times; DRE_E_TIMEOUT comes after the last try. A reply of
     * value 0 held back for it (see dre_bus_feed) is its answer at the
     * timeout, before any retry. A verified write (dre_set_traj_mode,
     * dre_set_angle_range, the baud rates) whose read-back differs is written
     * and read again, up to `retries` times, before DRE_E_VERIFY. 0 = sent
     * once, so a timeout is exactly the time waited. Motion commands get no
     * reply and are never sent again.
     */
    uint8_t retries;
} dre_bus_config;

/** A request slot; the caller provides an array of them. Opaque. */
typedef struct {
    dre_msg reply; /**< the reply; before it arrives, the value a verified write expects */
    uint32_t sent_ms;
    uint16_t address; /**< 0 for a fast read */
    uint16_t seq;
    uint8_t node;
    uint8_t dtype;
    uint8_t state;
    uint8_t flags;
    uint8_t step; /**< the step of a multi-step request (dre_set_id), 0 for others */
    uint8_t link; /**< dre_set_id: the current id; its helper probe: the slot index of the request;
                       a verified write: the times it was written again (up to cfg.retries) */
    uint8_t held_node; /**< the node of a reply of value 0 held back for this request */
    uint8_t tries;     /**< times sent again after a timeout (up to cfg.retries) */
    uint32_t reply_ms; /**< when its answer, or the reply of value 0 held back for it, arrived */
} dre_request;

/** The last position move the bus commanded to one motor (what dre_positions_done checks). Opaque. */
typedef struct {
    float target;     /**< deg, when known */
    uint32_t sent_ms; /**< tick when its command or start was sent */
    uint32_t took_ms; /**< tick of the first state with T = 0 after sent_ms */
    uint32_t move_ms; /**< planned time of a Q move (ms), 0 = none */
    uint8_t node;     /**< 0 = a free record */
    uint8_t flags;
} dre_move;

/** Handle of a pending request; 0 is never a valid handle. */
typedef uint32_t dre_req;

/** Counters for diagnostics. */
typedef struct {
    uint32_t rx_frames;    /**< frames fed or drained */
    uint32_t rx_malformed; /**< frames that are not valid motor replies */
    uint32_t rx_unmatched; /**< valid replies that completed no request */
    /** Replies for a waiting read whose echoed data type differs from the request's: never taken as
     *  answers (also counted in rx_unmatched), as the Python client's `anomalies`. */
    uint32_t rx_anomalies;
    uint32_t timeouts;     /**< requests that expired (not the probe of a free id in dre_set_id) */
} dre_bus_stats;

struct dre_move_hooks;    /* private: see dre_bus.move_hooks */
struct dre_request_hooks; /* private: see dre_bus.request_hooks */

/**
 * One CAN bus. Fields are private except bad_field, bad_index, bad_address,
 * stats, rx_overflows and presets_pending, which the caller may read.
 */
typedef struct {
    dre_bus_config cfg;
    dre_request *slots;
    dre_frame *rx_buf;
    uint8_t nslots;
    uint8_t rx_mask;
    uint16_t seq;
    volatile uint8_t rx_head; /**< written by the producer only */
    volatile uint8_t rx_tail; /**< written by the consumer only */
    /**
     * Frames lost because the receive queue was full; written by the
     * interrupt. A 16-bit counter: on an 8-bit target the main loop can read
     * it torn while the interrupt increments it, so read it with the receive
     * interrupt masked there (or read it twice until two reads agree).
     */
    volatile uint16_t rx_overflows;
    /**
     * After DRE_E_RANGE for a write of a value the parameter does not take
     * (dre_param_choices, dre_param_check): its address, for
     * dre_param_by_address(), dre_param_choices() and dre_param_domain_of();
     * 0 after any other DRE_E_RANGE.
     */
    uint16_t bad_address;
    dre_field bad_field;
    uint8_t bad_index;
    dre_bus_stats stats;
    /**
     * Bit n set: motor n holds a preset this bus sent and has not started yet
     * (a batch stopped by a send failure). While such a motor is outside a
     * batch, DRE_START_TO_AUTO starts the batch's motors by their own ids.
     */
    uint64_t presets_pending;
    uint64_t held_nodes; /**< with cfg.tx_done: motors whose start is held (bit 0: one broadcast start) */
    dre_msg held_start;  /**< the held start */
    uint32_t held_ms;    /**< tick when the start was held */
    int8_t held_status;  /**< DRE_PENDING while held, then DRE_OK, DRE_E_TIMEOUT or DRE_E_SEND */
    uint8_t other_hosts; /**< 1 once frames of another host were seen (see dre_bus_feed) */
    /** Bit n: motor n's state frames carry bits 3-4 as 0 (bits_zero) or keep those of the command they
     *  answer (bits_kept), as learned from its answers (PROTOCOL.md 1.6); set one before use to say so up
     *  front, as a firmware profile does. */
    uint64_t bits_zero;
    uint64_t bits_kept;
    uint64_t traj_known;  /**< bit n: the Q profile of motor n is known */
    uint64_t traj_scurve; /**< bit n: motor n runs the S-curve profile */
    dre_move moves[DRE_MOVE_RECORDS]; /**< see dre_positions_done */
    uint8_t move_next;                /**< the record a new motor takes when all are in use */
    /** What the modules above the bus attach (private): the move records, once a command that can move was
     *  sent (dre_moves.c), and the verified writes' steps, once one was issued (dre_verified.c). */
    const struct dre_move_hooks *move_hooks;
    const struct dre_request_hooks *request_hooks;
} dre_bus;

/** A motor on a bus. Initialise as {&bus, node} or with dre_motor_init(). */
typedef struct {
    dre_bus *bus;
    uint8_t node; /**< 1..63, or 0 to address every motor */
} dre_motor;

/* ----------------------------------------------------------------- bus */

/**
 * Initialise `bus`. `slots` holds up to `nslots` (1..255) requests in flight.
 * `rx_storage` is the receive queue for dre_bus_isr_push(), `rx_capacity` a
 * power of two 2..128; pass NULL and 0 when frames are only given to
 * dre_bus_feed(). DRE_E_ARG when a callback, size or option is invalid.
 */
dre_status dre_bus_init(dre_bus *bus, const dre_bus_config *cfg, dre_request *slots, uint8_t nslots,
                        dre_frame *rx_storage, uint8_t rx_capacity);

/** Interrupt side: queue a received frame. Returns 1, or 0 when the queue is full (counted). */
int dre_bus_isr_push(dre_bus *bus, const dre_frame *frame);

/**
 * Main loop: process one received frame now. It completes the oldest pending
 * request it answers (by node, command, address and, for a parameter read,
 * the data type it echoes) or goes to on_unmatched. A reply whose node and
 * address a read waits for but whose data type differs answers nothing: it
 * is counted in stats.rx_anomalies (and rx_unmatched).
 *
 * Another host on the bus: a parameter reply of value 0 has the bytes of a
 * read request, so another host's read of the parameter a request waits for
 * looks exactly like its answer. Once the bus has seen another host
 * (bus->other_hosts: a command only a host sends, 0x08, 0x0C, 0x1A or 0x1C,
 * a 0x19/0x1B/0x1D/0x1F frame that is no state by the rule of PROTOCOL.md 1.6,
 * or a reply of value 0 that answered nothing), such a reply is held
 * back for DRE_ZERO_REPLY_GRACE_MS: a non-zero reply meanwhile is the answer;
 * otherwise dre_bus_poll() takes the held one at the end of the grace (or at
 * the request's timeout, if that comes first). As the Python client.
 * DRE_E_PROTOCOL when it is not a valid motor reply (ignored, counted).
 */
dre_status dre_bus_feed(dre_bus *bus, const dre_frame *frame);

/**
 * Main loop: read the tick, feed every queued frame, expire requests older
 * than the timeout at that tick (or queue them to be sent again, while they
 * have cfg.retries left), take dre_set_id requests to their next step, then
 * send the requests whose turn has come (a retry before any later request to
 * its motor).
 */
void dre_bus_poll(dre_bus *bus);

/**
 * The outcome of request `req`: DRE_PENDING; DRE_OK with the reply in `reply`
 * (DRE_MSG_PARAM_VALUE, or DRE_MSG_STATE for dre_get_state); DRE_E_TIMEOUT;
 * DRE_E_VERIFY when a verified write reads back another value (the reply
 * holds what was read); DRE_E_SEND when a frame the request had to send later
 * could not be sent; DRE_E_ID_TAKEN (the reply is the state of the motor
 * answering at the new id) or DRE_E_NO_MOTOR from dre_set_id; DRE_E_ARG for
 * an unknown handle. A finished request's slot is freed here.
 */
dre_status dre_result(dre_bus *bus, dre_req req, dre_msg *reply);

/** Forget request `req` (a late reply then goes to on_unmatched; a save it would trigger is not sent). */
void dre_cancel(dre_bus *bus, dre_req req);

/** Encode and send any message (a parameter write is checked as by dre_write_property). */
dre_status dre_send(dre_bus *bus, const dre_msg *msg);

/**
 * Does the parameter at `address` take only the values lo..hi? Returns 1
 * and sets *lo and *hi for the modes and states with a fixed set, as the
 * Python client's parameters (_CHOICES):
 *
 *     30003 axis0.requested_state                   0..11 (AXIS_STATE_*)
 *     32105 axis0.controller.config.control_mode    0..4
 *     32106 axis0.controller.config.input_mode      0..7
 *     35104 axis0.trap_traj.config.traj_mode        1..2 (dre_traj_mode)
 *
 * and 0 for every other address. Writes of other values, or of an f32, are
 * refused (DRE_E_RANGE; bad_field DRE_FIELD_VALUE or DRE_FIELD_DTYPE).
 */
int dre_param_choices(uint16_t address, uint8_t *lo, uint8_t *hi);

/* ----------------------------------------------------------------- transmit ring */

/**
 * A transmit ring for ports whose hardware queue is short (3 mailboxes on
 * bxCAN, FDCAN and MCP2515). The send callback pushes with dre_txq_send()
 * (main loop, one producer); the TX-complete interrupt or the poll loop moves
 * frames to the hardware with dre_txq_peek() / dre_txq_pop() (one consumer);
 * dre_txq_free() is what the bus config's tx_free returns. Caller-owned, like
 * the receive queue.
 */
typedef struct {
    dre_frame *buf;
    uint8_t mask;
    volatile uint8_t head; /**< written by the producer only */
    volatile uint8_t tail; /**< written by the consumer only */
} dre_txq;

/** `capacity` frames of `storage`, a power of two 2..128; DRE_E_ARG otherwise. */
dre_status dre_txq_init(dre_txq *q, dre_frame *storage, uint8_t capacity);
/** Producer: queue a copy of `frame`; 0, or -1 when the ring is full (the send-callback convention). */
int dre_txq_send(dre_txq *q, const dre_frame *frame);
/** Producer: how many frames dre_txq_send() can take now. */
unsigned dre_txq_free(const dre_txq *q);
/** Consumer: copy the oldest frame to `out` and return 1, or return 0 when the ring is empty. */
int dre_txq_peek(dre_txq *q, dre_frame *out);
/** Consumer: drop the oldest frame (once the hardware has taken it). */
void dre_txq_pop(dre_txq *q);

/* ----------------------------------------------------------------- motor */

/** Bind `m` to `bus` and `node` (checked when a frame is built: 0..63). */
void dre_motor_init(dre_motor *m, dre_bus *bus, uint8_t node);

/**
 * Move to `angle` deg; `mode` is a dre_angle_mode (what speed and param mean
 * is there). T: the filter bandwidth must be 0 < param <= 300 (the vendor
 * sends |param|; a negative bandwidth is refused here, as in the Python
 * client) and the absolute value of speed is sent, as the vendor does.
 */
dre_status dre_set_angle(const dre_motor *m, float angle, float speed, float param, uint8_t mode);
/**
 * Move by `delta` deg from where the motor is: a preset and a relative start
 * (dre_step_angles for one motor; the start goes to this motor unless
 * cfg.start is DRE_START_TO_BROADCAST). The motor id must be 1..63.
 */
dre_status dre_step_angle(const dre_motor *m, float delta, float speed, float param, uint8_t mode);
/**
 * Run at `speed` r/min. mode 1 (DRE_VEL_PASSTHROUGH): param = torque FF Nm,
 * sent as 0 when speed is 0, as the vendor does; mode 2 (DRE_VEL_RAMP, or 0 as
 * the vendor's docs use it): param = ramp rate (r/min)/s. A non-finite param
 * is refused (DRE_FIELD_PARAM) even where it is not sent.
 */
dre_status dre_set_speed(const dre_motor *m, float speed, float param, uint8_t mode);
/**
 * Apply `torque` Nm. mode 1 (DRE_TORQUE_DIRECT): param is ignored and sent as
 * 0, but a non-finite one is refused (DRE_FIELD_PARAM); mode 6
 * (DRE_TORQUE_RAMP, or 0): param = ramp rate Nm/s.
 */
dre_status dre_set_torque(const dre_motor *m, float torque, float param, uint8_t mode);
/**
 * Impedance control: preset (pos deg, vel r/min, tff Nm) to this motor, then a
 * start carrying kp Nm/rad and kd Nm/(rad/s), both 0..327.67. The start goes
 * to this motor (broadcast when cfg.start is DRE_START_TO_BROADCAST).
 */
dre_status dre_impedance_control(const dre_motor *m, float pos, float vel, float tff, float kp, float kd);

/** Any single-shot system command (dre_sys_op). */
dre_status dre_system(const dre_motor *m, uint8_t op);
dre_status dre_estop(const dre_motor *m);
dre_status dre_clear_error(const dre_motor *m);
dre_status dre_save_config(const dre_motor *m);
dre_status dre_reboot(const dre_motor *m);
dre_status dre_set_zero_position(const dre_motor *m);
/** DRE_MODE_IDLE or DRE_MODE_CLOSED_LOOP (writes axis0.requested_state 1 or 8). */
dre_status dre_set_mode(const dre_motor *m, uint8_t mode);

/**
 * Write `value` to `address` as `dtype` (RAM only; save_config to keep it).
 * DRE_E_RANGE, sending nothing, for a value outside the fixed set of a mode
 * parameter (dre_param_choices; bus->bad_address names it).
 */
dre_status dre_write_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value);
/**
 * dre_write_property for an expert: a value outside the parameter's soft
 * bound (dre_param_domain without DRE_PD_HARD) is sent. Hard bounds, fixed
 * sets and the wire range still refuse it (DRE_E_RANGE, nothing sent).
 */
dre_status dre_write_property_forced(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value);
/**
 * Write a parameter from the table; DRE_E_ACCESS if read-only, DRE_E_RANGE if
 * a bool is not 0/1, a mode parameter is given a value it does not take, or
 * the value is outside the parameter's domain (dre_param_check).
 */
dre_status dre_write_param(const dre_motor *m, dre_param_t param, dre_value value);
/** Start reading `address` as `dtype`; the reply is a DRE_MSG_PARAM_VALUE. */
dre_status dre_read_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_req *req);
/** Start reading a parameter from the table. */
dre_status dre_read_param(const dre_motor *m, dre_param_t param, dre_req *req);
/** Start a fast read; the reply is a DRE_MSG_STATE (position deg, speed r/min, torque Nm, flags). */
dre_status dre_get_state(const dre_motor *m, dre_req *req);

/* Operations with more than one frame. Each needs room for the frames it
 * sends at once (cfg.tx_free) and free slots for its requests, or returns
 * DRE_E_BUSY having sent nothing. A verified write reads the value back; its
 * request ends DRE_OK when the motor holds what was written, DRE_E_VERIFY
 * when not (after cfg.retries more writes and reads; not for dre_set_id,
 * which reports another id at once); "then save" means save_config goes out
 * only after that check succeeded (of every value, for set_angle_range). */

/** Start reading the id the motor reports (axis0.config.can_node_id); reply value in .i. */
dre_status dre_get_id(const dre_motor *m, dre_req *req);
/**
 * Give the motor `new_id` (1..63), so that two motors never share an id, as
 * the Python client's set_id. One request (`req`) that dre_bus_poll() takes
 * through its steps:
 *
 *  1. Fast reads at the current id (m->node; 0: any motor) and at `new_id`,
 *     sent together. A motor answering at `new_id` ends the request
 *     DRE_E_ID_TAKEN at once (the reply is its state); once that read has
 *     timed out (after cfg.retries more reads, as every read of the steps
 *     below), no answer at the current id ends it DRE_E_NO_MOTOR. Both
 *     leave the motor untouched: no write is sent. When `new_id` is the
 *     current id, only the motor's own read goes out, and it must answer.
 *  2. The write of axis0.config.can_node_id = new_id to the current id.
 *  3. A read of can_node_id at `new_id`: DRE_E_TIMEOUT when the motor does not
 *     answer there, DRE_E_VERIFY when it reports another id (in the reply).
 *  4. save_config to `new_id`, and DRE_OK. Nothing is saved after an error.
 *
 * It takes two free slots (one when `new_id` is the current id) and room for
 * the reads of step 1, or returns DRE_E_BUSY having sent nothing. Step 2
 * waits, up to a timeout, for room for the write and the read. DRE_E_SEND
 * when a read of step 1 or the write could not be sent (nothing was written),
 * or the save of step 4 (the reply is then the DRE_MSG_PARAM_VALUE read back:
 * the motor answers at `new_id` until it reboots). DRE_E_RANGE for `new_id`
 * outside 1..63 (DRE_FIELD_VALUE) or a current id outside 0..63
 * (DRE_FIELD_NODE). dre_cancel() stops it at any step; before step 2 nothing
 * has been written.
 */
dre_status dre_set_id(const dre_motor *m, uint8_t new_id, dre_req *req);
/** Start reading the supply voltage (req[0], V, .f32) and q-axis current (req[1], A, .f32). */
dre_status dre_get_volcur(const dre_motor *m, dre_req req[2]);
/**
 * Start reading the seven error words, in the vendor's dump_error order:
 * axis0.error, motor, encoder, controller, can, fet thermistor, motor
 * thermistor. Each reply is a DRE_MSG_PARAM_VALUE (u32 in .i); decode it with
 * dre_error_format(dre_error_word_find(reply.u.param.address), ...).
 */
dre_status dre_dump_error(const dre_motor *m, dre_req req[DRE_ERROR_WORDS]);
/** Start reading the Q-move profile (35104, reply .i: 1 trapezoid, 2 S-curve); the bus remembers it. */
dre_status dre_get_traj_mode(const dre_motor *m, dre_req *req);
/** Set the Q-move profile (DRE_TRAJ_TRAPEZOID or DRE_TRAJ_S_CURVE): verified write, remembered, not saved. */
dre_status dre_set_traj_mode(const dre_motor *m, uint8_t mode, dre_req *req);
/**
 * Enable software limits [angle_min, angle_max] deg: verified writes of
 * axis0.output_shaft.circular_setpoint_min/_max and
 * enable_circular_setpoint_limit = 1 (req[0..2]), then save. `position` is the
 * motor's current position (deg, from a fresh dre_get_state), which must lie
 * inside the limits. DRE_E_RANGE names DRE_FIELD_VALUE with bad_index 0 (min)
 * or 1 (max) for a non-finite or reversed limit, DRE_FIELD_POSITION for the
 * position.
 */
dre_status dre_set_angle_range(const dre_motor *m, float angle_min, float angle_max, float position,
                               dre_req req[3]);
/** CAN bitrate 125000, 250000, 500000 or 1000000: verified write, then save (applies after a reboot). */
dre_status dre_set_can_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req);
/** UART rate of an M-series motor, 9600, 19200, 57600 or 115200: verified write, then save. */
dre_status dre_set_uart_baud_rate(const dre_motor *m, uint32_t baud_rate, dre_req *req);

/* ----------------------------------------------------------------- waiting for moves */

/** Caller-owned progress of one motor in dre_position_done(); zero it (or {0}) before the first call. */
typedef struct {
    dre_msg state;     /**< the latest state read (the final one once done) */
    dre_req req;       /**< the fast read in flight, 0 = none */
    uint32_t state_ms; /**< tick when that state arrived */
    uint32_t start_ms; /**< tick of the first call */
    uint32_t sent_ms;  /**< tick of the latest fast read, then of its answer (the next read waits from there) */
    uint8_t phase;     /**< 0 = not started, 1 = polling, 2 = done */
} dre_done;

/**
 * Poll until the motor has finished its move (vendor position_done, without
 * blocking, with the Python client's rules): call it each main-loop pass with
 * the same `d` (zeroed before the first call). It sends a fast read, and the
 * next one DRE_POLL_INTERVAL_MS after each answer, and returns DRE_PENDING
 * until a state shows the move is over, then DRE_OK (final state in
 * d->state).
 *
 * For a position move this bus commanded (dre_set_angle, dre_send of a
 * position command, or a batch of position presets and their start: the bus
 * remembers the latest move of up to DRE_MOVE_RECORDS motors) a state ends
 * the wait only when it arrived after the move's command or start was sent,
 * has the T bit set, and the motor has shown that it took the move: a state
 * with T = 0 arrived after the start, or the planned Q move time has passed,
 * or it is within DRE_MOVE_TOLERANCE of the target. A move whose target is
 * known then ends DRE_E_MOVE when the final position is further than
 * DRE_MOVE_TOLERANCE from it (an angle limit, a stall, an estop). For a motor
 * without a record (not moved by this bus, a relative move, a velocity or
 * torque command since), the first state with T set ends the wait.
 *
 * DRE_E_FAULT as soon as the motor reports an error (read the words with
 * dre_dump_error); DRE_E_TIMEOUT when a fast read goes unanswered (after
 * cfg.retries more tries) or `timeout_ms` (0 = no limit) has passed since
 * the first call. After an error `d` is reset, so the next call starts again.
 */
dre_status dre_position_done(const dre_motor *m, dre_done *d, uint32_t timeout_ms);
/**
 * dre_position_done for motors ids[0..n-1] (d[] one per motor): DRE_OK when
 * every one is done and at its target; on DRE_E_FAULT, DRE_E_TIMEOUT or
 * DRE_E_MOVE bus->bad_index is the motor's index and every d[] is reset
 * (fast reads in flight are cancelled).
 */
dre_status dre_positions_done(dre_bus *bus, uint8_t n, const uint8_t *ids, dre_done *d, uint32_t timeout_ms);

/* ----------------------------------------------------------------- several motors */

/*
 * Batches: n presets, then the start (where to: cfg.start). Every value and
 * the motor ids (distinct, 1..63) are checked before anything is sent
 * (DRE_E_RANGE naming DRE_FIELD_NODE for an id outside 1..63, DRE_E_ARG with
 * bad_index at the second use of an id). With cfg.tx_free set, a batch needs
 * room for all its frames at once, or returns DRE_E_BUSY having sent nothing.
 * If a send fails midway (DRE_E_SEND), the motors that got a preset but no
 * start are remembered in presets_pending (see DRE_START_TO_AUTO).
 * With cfg.tx_done set, a batch whose presets are not yet all on the wire
 * returns DRE_PENDING and holds its start (see dre_batch_status); another
 * batch meanwhile returns DRE_E_BUSY, sending nothing.
 */

/**
 * Outcome of the last batch whose start was held (cfg.tx_done): DRE_PENDING
 * while dre_bus_poll() waits for tx_done(); DRE_OK once the start was sent;
 * DRE_E_TIMEOUT when tx_done() stayed 0 for cfg.timeout_ms (the start was
 * never sent: its motors stay in presets_pending, so no later broadcast start
 * fires their presets); DRE_E_SEND when the start could not be sent. DRE_OK
 * when no start was ever held.
 */
dre_status dre_batch_status(const dre_bus *bus);

/**
 * Send `n` presets (DRE_MSG_PRESET or typed presets matching `start`), then
 * `start` (DRE_MSG_START or DRE_MSG_START_IMPEDANCE, whose Kp and Kd must be
 * 0..327.67; its node is set by cfg.start).
 */
dre_status dre_preset_start(dre_bus *bus, const dre_msg *presets, uint8_t n, const dre_msg *start);

/**
 * Move motors ids[0..n-1] to angles[] deg together. speed and param as in
 * dre_set_angle. In DRE_ANGLE_Q mode every motor gets the time the slowest
 * move |angles[i] - from[i]| takes at `speed` and accel `param` with that
 * motor's profile (learned, or cfg.traj_mode), rounded up to the 0.01 s the
 * preset carries; `from` holds fresh positions (deg) and is required in that
 * mode only (a non-finite one is refused as DRE_FIELD_FROM at its index).
 */
dre_status dre_set_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *angles, const float *from,
                          float speed, float param, uint8_t mode);
/** As dre_set_angles with angles relative to each motor's current position. */
dre_status dre_step_angles(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *deltas, float speed,
                           float param, uint8_t mode);
/** Run motors at speeds[] r/min together; param and mode as in dre_set_speed. */
dre_status dre_set_speeds(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *speeds, float param,
                          uint8_t mode);
/** Apply torques[] Nm together; param and mode as in dre_set_torque. */
dre_status dre_set_torques(dre_bus *bus, uint8_t n, const uint8_t *ids, const float *torques, float param,
                           uint8_t mode);

/**
 * Time (s) a Q move of `distance` deg takes at cruise `speed` r/min and
 * `accel` (r/min)/s with profile `traj_mode` (0 = trapezoid), the vendor's
 * formula. DRE_E_RANGE when speed or accel is not > 0, distance is negative,
 * a value is not finite, or traj_mode is unknown.
 */
dre_status dre_q_move_time(float distance, float speed, float accel, uint8_t traj_mode, float *time_s);

#ifdef __cplusplus
}
#endif

#endif /* DRE_CLIENT_H */
