/**
 * @file dre_health.h
 * @brief A motor's health (temperatures, effective current limit, errors) and a supervisor step.
 *
 * dre_read_health() queues the five reads of one reading at once (as the Python
 * client's Motor.health): winding temperature (37002), driver-board temperature
 * (36002), effective current limit (33003), configured current limit (33110) and
 * axis0.error (30001); the bus sends each as the previous is answered (one read
 * of a motor in flight). dre_health_from() takes their replies.
 *
 * dre_health_step() is the supervisor of one motor, called once per control
 * cycle (or per reading): pure, no heap, no I/O, a few dozen float operations.
 * It returns what began (DRE_HEALTH_* bits) and the action to take; the caller
 * sends it with dre_health_act() (idle: requested_state 1; hold: speed 0). The
 * rules are the Python supervisor's (drempower.client.supervisor): warn at
 * warn_c, act at act_c (set them below temp_limit_lower, 95 degC by default, so
 * the joint is stopped before the firmware derates and trips), warn and act on
 * derating, a stall when the target is not reached (T bit 0) while the torque
 * sits at stall_fraction of the derated limit for stall_ms.
 */
#ifndef DRE_HEALTH_H
#define DRE_HEALTH_H

#include <stdint.h>

#include "dre_client.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DRE_HEALTH_READS 5u /**< requests of dre_read_health() */

/** One reading. Temperatures degC, limits A. */
typedef struct {
    float motor_temp_c;       /**< winding thermistor */
    float driver_temp_c;      /**< driver board (FET) thermistor */
    float current_limit_a;    /**< effective current limit, after the thermal derating */
    float configured_limit_a; /**< axis0.motor.config.current_lim */
    uint32_t axis_error;      /**< axis0.error: non-zero = faulted (read the words with dre_dump_error) */
} dre_health;

/** Conditions (bits of dre_health_verdict.began and .active). */
enum {
    DRE_HEALTH_HOT = 0x01u,      /**< at warn_c */
    DRE_HEALTH_OVERHEAT = 0x02u, /**< at act_c: on_overheat acts */
    DRE_HEALTH_DERATING = 0x04u, /**< effective limit below the configured one: on_overheat acts */
    DRE_HEALTH_STALL = 0x08u,    /**< torque at its limit, target not reached, for stall_ms: on_stall acts */
    DRE_HEALTH_FAULT = 0x10u     /**< axis0.error set */
};

/** What the supervisor does: nothing but report, hold (speed 0 in closed loop), idle (release). */
typedef enum { DRE_ON_WARN = 0, DRE_ON_HOLD = 1, DRE_ON_IDLE = 2 } dre_on_health;

typedef struct {
    float warn_c;         /**< warn at this temperature (default 80) */
    float act_c;          /**< act at this temperature (default 90) */
    float stall_fraction; /**< "at its limit": this fraction of the derated torque limit (default 0.95) */
    uint32_t stall_ms;    /**< a stall lasts this long before it counts (default 1000) */
    float kt;             /**< output torque per ampere, Nm/A (torque_constant x gear ratio) */
    float torque_lim;     /**< configured torque limit at the output, Nm (torque_lim x gear ratio) */
    uint8_t on_overheat;  /**< dre_on_health */
    uint8_t on_stall;     /**< dre_on_health */
} dre_health_policy;

/** The state one motor's supervisor keeps between steps (zero it, or dre_health_watch_init). */
typedef struct {
    uint8_t active;     /**< conditions of the last step */
    uint8_t stalling;   /**< 1 while the torque sits at its limit */
    uint32_t stall_from; /**< tick (ms) the current stall began */
} dre_health_watch;

typedef struct {
    uint8_t began;  /**< conditions that began in this step (report each once) */
    uint8_t active; /**< conditions now */
    uint8_t action; /**< dre_on_health to take now (DRE_ON_WARN: none) */
} dre_health_verdict;

/** The defaults above for a motor of `kt` Nm/A and `torque_lim` Nm at the output. */
void dre_health_policy_init(dre_health_policy *p, float kt, float torque_lim);
/** Start the five reads of one reading (req[0..4] in the order of dre_health's fields); DRE_E_BUSY
 * without five free slots (nothing sent). */
dre_status dre_read_health(const dre_motor *m, dre_req req[DRE_HEALTH_READS]);
/** Fill `h` from the five replies (DRE_MSG_PARAM_VALUE of the addresses above, in order); DRE_E_ARG when a
 * reply is of another type or address. */
dre_status dre_health_from(const dre_msg replies[DRE_HEALTH_READS], dre_health *h);
/** 0 = the whole current available, 1 = none left. */
float dre_health_derating(const dre_health *h);
/** One supervisor step at tick `now_ms` with reading `h` and the motor's latest state `state` (NULL: no
 * stall check this step). Pure: touches only `w` and `out`. */
void dre_health_step(dre_health_watch *w, const dre_health_policy *p, const dre_health *h, const dre_msg *state,
                     uint32_t now_ms, dre_health_verdict *out);
/** Send `action`: DRE_ON_IDLE writes requested_state 1, DRE_ON_HOLD sends speed 0, DRE_ON_WARN sends nothing. */
dre_status dre_health_act(const dre_motor *m, uint8_t action);

#ifdef __cplusplus
}
#endif

#endif /* DRE_HEALTH_H */
