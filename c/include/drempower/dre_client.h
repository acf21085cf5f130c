/**
 * @file dre_client.h
 * @brief Per-motor commands, request tracking with timeouts, multi-motor moves.
 *
 * All state lives in caller-owned structs: no heap, no globals, no blocking.
 * The user supplies a send callback and a millisecond tick, feeds received
 * frames in, and polls requests for their replies.
 *
 * Concurrency: dre_bus_isr_push() is the one function that may run in an
 * interrupt (one producer). Every other function belongs to the main loop
 * (one consumer), including dre_bus_feed() and dre_bus_poll().
 *
 *     CAN RX interrupt:  dre_bus_isr_push(&bus, &frame);
 *     main loop:         dre_bus_poll(&bus);   // drains the queue, expires requests
 *                        if (dre_result(&bus, req, &reply) == DRE_OK) ...
 *
 * Functions that validate set bus->bad_field (and bus->bad_index for the
 * motor index in a batch) when they return DRE_E_RANGE. Nothing is sent
 * when a function returns DRE_E_RANGE, DRE_E_ARG or DRE_E_ACCESS.
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

/** Queue one frame for transmission; return 0 on success, nonzero if it could not be queued. */
typedef int (*dre_send_fn)(void *user, const dre_frame *frame);
/** A free-running millisecond counter (may wrap at 2^32). */
typedef uint32_t (*dre_tick_fn)(void *user);
/** A valid motor frame that completed no request (heartbeat, state after a control frame, late reply). */
typedef void (*dre_msg_fn)(void *user, const dre_msg *msg);

/** Velocity profile of Q moves (axis0.trap_traj.config.traj_mode, 35104). */
typedef enum { DRE_TRAJ_TRAPEZOID = 1, DRE_TRAJ_S_CURVE = 2 } dre_traj_mode;

/** The vendor's set_angle modes. */
typedef enum {
    DRE_ANGLE_T = 0, /**< trajectory tracking: speed carried, param = filter bandwidth 1/s */
    DRE_ANGLE_Q = 1, /**< trapezoid/S-curve: speed = cruise r/min (> 0), param = accel (r/min)/s (> 0) */
    DRE_ANGLE_P = 2  /**< feed-forward: speed = speed FF r/min, param = torque FF Nm */
} dre_angle_mode;

/** dre_set_mode() states. */
enum { DRE_MODE_IDLE = 1, DRE_MODE_CLOSED_LOOP = 2 };

typedef struct {
    dre_send_fn send;        /**< required */
    dre_tick_fn tick;        /**< required */
    void *user;              /**< passed to the callbacks */
    dre_msg_fn on_unmatched; /**< optional */
    uint32_t timeout_ms;     /**< per request; 0 = DRE_DEFAULT_TIMEOUT_MS */
    uint8_t traj_mode;       /**< dre_traj_mode of the motors, for synchronised Q moves; 0 = trapezoid */
} dre_bus_config;

/** A request slot; the caller provides an array of them. Opaque. */
typedef struct {
    dre_msg reply;
    uint32_t sent_ms;
    uint16_t address; /**< 0 for a fast read */
    uint16_t seq;
    uint8_t node;
    uint8_t state;
} dre_request;

/** Handle of a pending request; 0 is never a valid handle. */
typedef uint32_t dre_req;

/** Counters for diagnostics. */
typedef struct {
    uint32_t rx_frames;    /**< frames fed or drained */
    uint32_t rx_malformed; /**< frames that are not valid motor replies */
    uint32_t rx_unmatched; /**< valid replies that completed no request */
    uint32_t timeouts;     /**< requests that expired */
} dre_bus_stats;

/** One CAN bus. Fields are private except bad_field, bad_index and stats. */
typedef struct {
    dre_bus_config cfg;
    dre_request *slots;
    uint8_t nslots;
    uint16_t seq;
    dre_frame *rx_buf;
    uint8_t rx_mask;
    volatile uint8_t rx_head;         /**< written by the producer only */
    volatile uint8_t rx_tail;         /**< written by the consumer only */
    volatile uint16_t rx_overflows;   /**< frames lost because the queue was full */
    dre_field bad_field;
    uint8_t bad_index;
    dre_bus_stats stats;
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
 * dre_bus_feed(). DRE_E_ARG when a callback or size is invalid.
 */
dre_status dre_bus_init(dre_bus *bus, const dre_bus_config *cfg, dre_request *slots, uint8_t nslots,
                        dre_frame *rx_storage, uint8_t rx_capacity);

/** Interrupt side: queue a received frame. Returns 1, or 0 when the queue is full (counted). */
int dre_bus_isr_push(dre_bus *bus, const dre_frame *frame);

/**
 * Main loop: process one received frame now. It completes the oldest pending
 * request it answers (by node, command and address) or goes to on_unmatched.
 * DRE_E_PROTOCOL when it is not a valid motor reply (ignored, counted).
 */
dre_status dre_bus_feed(dre_bus *bus, const dre_frame *frame);

/** Main loop: feed every queued frame, then expire requests older than the timeout. */
void dre_bus_poll(dre_bus *bus);

/**
 * The outcome of request `req`: DRE_PENDING; DRE_OK with the reply in `reply`
 * (DRE_MSG_PARAM_VALUE, or DRE_MSG_STATE for dre_get_state); DRE_E_TIMEOUT;
 * DRE_E_ARG for an unknown handle. A finished request's slot is freed here.
 */
dre_status dre_result(dre_bus *bus, dre_req req, dre_msg *reply);

/** Forget request `req` (a late reply then goes to on_unmatched). */
void dre_cancel(dre_bus *bus, dre_req req);

/** Encode and send any message. */
dre_status dre_send(dre_bus *bus, const dre_msg *msg);

/* ----------------------------------------------------------------- motor */

/** Bind `m` to `bus` and `node` (checked when a frame is built: 0..63). */
void dre_motor_init(dre_motor *m, dre_bus *bus, uint8_t node);

/** Move to `angle` deg; `mode` is a dre_angle_mode (what speed and param mean is there). */
dre_status dre_set_angle(const dre_motor *m, float angle, float speed, float param, uint8_t mode);
/** Run at `speed` r/min; mode DRE_VEL_PASSTHROUGH (param = torque FF Nm) or DRE_VEL_RAMP (param = (r/min)/s). */
dre_status dre_set_speed(const dre_motor *m, float speed, float param, uint8_t mode);
/** Apply `torque` Nm; mode DRE_TORQUE_DIRECT (param unused) or DRE_TORQUE_RAMP (param = Nm/s). */
dre_status dre_set_torque(const dre_motor *m, float torque, float param, uint8_t mode);
/**
 * Impedance control: preset (pos deg, vel r/min, tff Nm) to this motor, then a
 * broadcast start carrying kp Nm/rad and kd Nm/(rad/s).
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
/** Write can_node_id = new_id (1..63), then save_config addressed to new_id. */
dre_status dre_set_id(const dre_motor *m, uint8_t new_id);

/** Write `value` to `address` as `dtype` (RAM only; save_config to keep it). */
dre_status dre_write_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value);
/** Write a parameter from the table; DRE_E_ACCESS if read-only, DRE_E_RANGE if a bool is not 0/1. */
dre_status dre_write_param(const dre_motor *m, dre_param_t param, dre_value value);
/** Start reading `address` as `dtype`; the reply is a DRE_MSG_PARAM_VALUE. */
dre_status dre_read_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_req *req);
/** Start reading a parameter from the table. */
dre_status dre_read_param(const dre_motor *m, dre_param_t param, dre_req *req);
/** Start a fast read; the reply is a DRE_MSG_STATE (position deg, speed r/min, torque Nm, flags). */
dre_status dre_get_state(const dre_motor *m, dre_req *req);

/* ----------------------------------------------------------------- several motors */

/**
 * Send `n` presets (DRE_MSG_PRESET or typed presets matching `start`), then
 * `start` (DRE_MSG_START or DRE_MSG_START_IMPEDANCE), after validating all of
 * them. If a send fails midway the start is not sent (DRE_E_SEND).
 */
dre_status dre_preset_start(dre_bus *bus, const dre_msg *presets, uint8_t n, const dre_msg *start);

/**
 * Move motors ids[0..n-1] to angles[] deg together (broadcast start).
 * speed and param as in dre_set_angle. In DRE_ANGLE_Q mode every motor gets
 * the time the biggest move |angles[i] - from[i]| takes at `speed` and accel
 * `param` (cfg.traj_mode profile); `from` holds fresh positions (deg) and is
 * required in that mode only.
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
