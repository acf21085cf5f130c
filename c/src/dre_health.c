/* A motor's health reading and the heap-free supervisor step (see dre_health.h). */
#include "drempower/dre_health.h"

#include <math.h>
#include <stddef.h>

#include "drempower/dre_params.h"

/* What dre_read_health (dre_motor.c) reads, in order. */
static const dre_param_t health_params[DRE_HEALTH_READS] = {
    DRE_P_AXIS0_MOTOR_THERMISTOR_TEMPERATURE, DRE_P_AXIS0_FET_THERMISTOR_TEMPERATURE,
    DRE_P_AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM, DRE_P_AXIS0_MOTOR_CONFIG_CURRENT_LIM, DRE_P_AXIS0_ERROR};

void dre_health_policy_init(dre_health_policy *p, float kt, float torque_lim)
{
    p->warn_c = 80.0f;
    p->act_c = 90.0f;
    p->stall_fraction = 0.95f;
    p->stall_ms = 1000u;
    p->kt = kt;
    p->torque_lim = torque_lim;
    p->on_overheat = (uint8_t)DRE_ON_WARN;
    p->on_stall = (uint8_t)DRE_ON_WARN;
}

dre_status dre_health_from(const dre_msg replies[DRE_HEALTH_READS], dre_health *h)
{
    uint8_t i;
    for (i = 0u; i < DRE_HEALTH_READS; i++) {
        if (replies[i].type != DRE_MSG_PARAM_VALUE || replies[i].u.param.address != DRE_PARAM_ADDRESS(health_params[i])) {
            return DRE_E_ARG;
        }
    }
    h->motor_temp_c = replies[0].u.param.value.f32;
    h->driver_temp_c = replies[1].u.param.value.f32;
    h->current_limit_a = replies[2].u.param.value.f32;
    h->configured_limit_a = replies[3].u.param.value.f32;
    h->axis_error = (uint32_t)replies[4].u.param.value.i;
    return DRE_OK;
}

float dre_health_derating(const dre_health *h)
{
    float d;
    if (!(h->configured_limit_a > 0.0f)) {
        return 0.0f;
    }
    d = 1.0f - h->current_limit_a / h->configured_limit_a;
    return d < 0.0f ? 0.0f : d > 1.0f ? 1.0f : d;
}

static uint8_t stronger(uint8_t a, uint8_t b)
{
    return a > b ? a : b;
}

void dre_health_step(dre_health_watch *w, const dre_health_policy *p, const dre_health *h, const dre_msg *state,
                     uint32_t now_ms, dre_health_verdict *out)
{
    uint8_t now = 0u, action = (uint8_t)DRE_ON_WARN;
    float hottest = h->motor_temp_c > h->driver_temp_c ? h->motor_temp_c : h->driver_temp_c;

    if (h->axis_error != 0u) {
        now |= DRE_HEALTH_FAULT;
    }
    if (dre_health_derating(h) > 0.0f) {
        now |= DRE_HEALTH_DERATING;
    } else if (hottest >= p->act_c) {
        now |= DRE_HEALTH_OVERHEAT;
    } else if (hottest >= p->warn_c) {
        now |= DRE_HEALTH_HOT;
    }
    if (state != NULL && state->type == DRE_MSG_STATE && !state->u.state.error && p->kt > 0.0f) {
        float tlim = h->current_limit_a * p->kt;
        if (p->torque_lim < tlim) {
            tlim = p->torque_lim;
        }
        if (!state->u.state.trajectory_done && fabsf(state->u.state.torque) >= p->stall_fraction * tlim) {
            if (!w->stalling) {
                w->stalling = 1u;
                w->stall_from = now_ms;
            }
            if ((uint32_t)(now_ms - w->stall_from) >= p->stall_ms) {
                now |= DRE_HEALTH_STALL;
            }
        } else {
            w->stalling = 0u;
        }
    }
    out->began = (uint8_t)(now & (uint8_t)~w->active);
    /* a milder thermal condition after a stronger one is not news */
    if ((w->active & (DRE_HEALTH_OVERHEAT | DRE_HEALTH_DERATING)) != 0u) {
        out->began &= (uint8_t)~DRE_HEALTH_HOT;
    }
    if ((w->active & DRE_HEALTH_DERATING) != 0u) {
        out->began &= (uint8_t)~DRE_HEALTH_OVERHEAT;
    }
    if ((out->began & (DRE_HEALTH_OVERHEAT | DRE_HEALTH_DERATING)) != 0u) {
        action = stronger(action, p->on_overheat);
    }
    if ((out->began & DRE_HEALTH_STALL) != 0u) {
        action = stronger(action, p->on_stall);
    }
    w->active = now;
    out->active = now;
    out->action = action;
}

dre_status dre_health_act(const dre_motor *m, uint8_t action)
{
    if (action == (uint8_t)DRE_ON_IDLE) {
        return dre_set_mode(m, DRE_MODE_IDLE);
    }
    if (action == (uint8_t)DRE_ON_HOLD) {
        return dre_set_speed(m, 0.0f, 0.0f, DRE_VEL_PASSTHROUGH);
    }
    return DRE_OK;
}
