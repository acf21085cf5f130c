/* Single-motor commands: moves, system operations, parameter writes and reads (see dre_client.h). */
#include "dre_client_internal.h"
#include "drempower/dre_health.h"

#include <math.h>
#include <string.h>

void dre_motor_init(dre_motor *m, dre_bus *bus, uint8_t node)
{
    m->bus = bus;
    m->node = node;
}

dre_msg dre_i_msg_for(const dre_motor *m, uint8_t type)
{
    dre_msg msg;
    memset(&msg, 0, sizeof msg);
    msg.type = type;
    msg.node = m->node;
    return msg;
}

dre_msg dre_i_write_msg(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = dre_i_msg_for(m, DRE_MSG_WRITE_PARAM);
    msg.u.param.address = address;
    msg.u.param.dtype = dtype;
    msg.u.param.value = value;
    return msg;
}

/* The T-mode filter bandwidth (0 < bw <= 300; a negative one is refused, as in Python), or DRE_E_RANGE. */
dre_status dre_i_bandwidth(dre_bus *bus, float param, float *bw)
{
    *bw = param;
    return dre_i_wire_positive(*bw) && *bw <= DRE_MAX_BANDWIDTH ? DRE_OK : dre_i_range_error(bus, DRE_FIELD_BANDWIDTH, 0u);
}

/* The single-motor position message for `mode`, or DRE_E_RANGE. */
static dre_status angle_msg(dre_bus *bus, dre_msg *msg, float angle, float speed, float param, uint8_t mode)
{
    float bw;

    if (mode > DRE_ANGLE_P) {
        return dre_i_range_error(bus, DRE_FIELD_MODE, 0u);
    }
    if (!dre_i_is_finite(angle)) {
        return dre_i_range_error(bus, DRE_FIELD_POSITION, 0u);
    }
    switch (mode) {
    case DRE_ANGLE_T:
        if (dre_i_bandwidth(bus, param, &bw) != DRE_OK) {
            return DRE_E_RANGE;
        }
        if (!dre_i_is_finite(speed)) {
            return dre_i_range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        msg->type = DRE_MSG_POSITION_T;
        msg->u.position_t.position = angle;
        msg->u.position_t.speed = fabsf(speed);
        msg->u.position_t.bandwidth = bw;
        return DRE_OK;
    case DRE_ANGLE_Q:
        if (!dre_i_wire_positive(speed)) {
            return dre_i_range_error(bus, DRE_FIELD_SPEED, 0u);
        }
        if (!dre_i_wire_positive(param)) {
            return dre_i_range_error(bus, DRE_FIELD_ACCEL, 0u);
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

/* Raw messages go out here (not in dre_bus.c) so that the move records see every command that can move. */
dre_status dre_send(dre_bus *bus, const dre_msg *msg)
{
    dre_i_moves_attach(bus);
    return dre_i_send_as(bus, msg, 0);
}

dre_status dre_set_angle(const dre_motor *m, float angle, float speed, float param, uint8_t mode)
{
    dre_msg msg = dre_i_msg_for(m, DRE_MSG_NONE);
    dre_status st = angle_msg(m->bus, &msg, angle, speed, param, mode);
    return st == DRE_OK ? dre_send(m->bus, &msg) : st;
}

dre_status dre_set_speed(const dre_motor *m, float speed, float param, uint8_t mode)
{
    dre_msg msg = dre_i_msg_for(m, DRE_MSG_VELOCITY);
    uint8_t wire = dre_i_velocity_mode(mode);

    if (wire == 0u) {
        return dre_i_range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    if (!dre_i_is_finite(speed)) {
        return dre_i_range_error(m->bus, DRE_FIELD_SPEED, 0u);
    }
    if (!dre_i_is_finite(param)) {
        return dre_i_range_error(m->bus, DRE_FIELD_PARAM, 0u); /* even where it is unused: NaN is a mistake */
    }
    if (wire == DRE_VEL_PASSTHROUGH && speed == 0.0f) {
        param = 0.0f; /* no feed-forward torque for a motor told to stand still, as the vendor does */
    } else if (wire == DRE_VEL_RAMP ? !dre_i_wire_positive(param) : !dre_i_is_finite(param)) {
        return dre_i_range_error(m->bus, DRE_FIELD_PARAM, 0u);
    }
    msg.u.velocity.speed = speed;
    msg.u.velocity.param = param;
    msg.u.velocity.mode = wire;
    return dre_send(m->bus, &msg);
}

dre_status dre_set_torque(const dre_motor *m, float torque, float param, uint8_t mode)
{
    dre_msg msg = dre_i_msg_for(m, DRE_MSG_TORQUE);
    uint8_t wire = dre_i_torque_mode(mode);

    if (wire == 0u) {
        return dre_i_range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    if (!dre_i_is_finite(torque)) {
        return dre_i_range_error(m->bus, DRE_FIELD_TORQUE, 0u);
    }
    if (!dre_i_is_finite(param) || (wire == DRE_TORQUE_RAMP && !dre_i_wire_positive(param))) {
        return dre_i_range_error(m->bus, DRE_FIELD_PARAM, 0u); /* a NaN param is refused even in direct mode */
    }
    msg.u.torque.torque = torque;
    msg.u.torque.param = wire == DRE_TORQUE_DIRECT ? 0.0f : param;
    msg.u.torque.mode = wire;
    return dre_send(m->bus, &msg);
}

dre_status dre_system(const dre_motor *m, uint8_t op)
{
    return dre_i_system_op(m->bus, m->node, op);
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

dre_status dre_set_mode(const dre_motor *m, uint8_t mode)
{
    dre_value state;
    if (mode != DRE_MODE_IDLE && mode != DRE_MODE_CLOSED_LOOP) {
        return dre_i_range_error(m->bus, DRE_FIELD_MODE, 0u);
    }
    state.i = mode == DRE_MODE_IDLE ? 1 : 8; /* AXIS_STATE_IDLE, AXIS_STATE_CLOSED_LOOP_CONTROL */
    return dre_write_param(m, DRE_P_AXIS0_REQUESTED_STATE, state);
}

dre_status dre_write_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = dre_i_write_msg(m, address, dtype, value);
    return dre_send(m->bus, &msg);
}

dre_status dre_write_property_forced(const dre_motor *m, uint16_t address, uint8_t dtype, dre_value value)
{
    dre_msg msg = dre_i_write_msg(m, address, dtype, value);
    return dre_i_send_as(m->bus, &msg, 1);
}

dre_status dre_write_param(const dre_motor *m, dre_param_t param, dre_value value)
{
    uint8_t flags = DRE_PARAM_FLAGS(param);

    if ((flags & DRE_PF_RW) == 0u) {
        return DRE_E_ACCESS;
    }
    if ((flags & DRE_PF_BOOL) != 0u && value.i != 0 && value.i != 1) {
        return dre_i_range_error(m->bus, DRE_FIELD_VALUE, 0u);
    }
    return dre_write_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), value);
}

dre_status dre_read_property(const dre_motor *m, uint16_t address, uint8_t dtype, dre_req *req)
{
    dre_request r = dre_i_request(m->node, address, dtype);
    if (address == 0u) {
        return dre_i_range_error(m->bus, DRE_FIELD_ADDRESS, 0u); /* address 0 is the fast read */
    }
    return dre_i_issue(m->bus, &r, 0, req);
}

dre_status dre_read_param(const dre_motor *m, dre_param_t param, dre_req *req)
{
    return dre_read_property(m, DRE_PARAM_ADDRESS(param), DRE_PARAM_DTYPE(param), req);
}

dre_status dre_get_state(const dre_motor *m, dre_req *req)
{
    dre_request r = dre_i_request(m->node, 0u, DRE_F32);
    return dre_i_issue(m->bus, &r, 0, req);
}

/* ----------------------------------------------------------------- reads */

dre_status dre_get_id(const dre_motor *m, dre_req *req)
{
    return dre_read_param(m, DRE_P_AXIS0_CONFIG_CAN_NODE_ID, req);
}

/* Start reading `k` parameters of one motor; each request waits for the one before. */
static dre_status read_params(const dre_motor *m, uint8_t k, const dre_param_t *params, dre_req *req)
{
    dre_status st = DRE_OK;
    uint8_t i;

    if (dre_i_free_slots(m->bus) < k) {
        return DRE_E_BUSY;
    }
    for (i = 0u; i < k && st == DRE_OK; i++) {
        dre_request r = dre_i_request(m->node, DRE_PARAM_ADDRESS(params[i]), DRE_PARAM_DTYPE(params[i]));
        st = dre_i_issue(m->bus, &r, i > 0u, &req[i]);
    }
    return st;
}

dre_status dre_get_volcur(const dre_motor *m, dre_req req[2])
{
    static const dre_param_t params[2] = {DRE_P_VBUS_VOLTAGE, DRE_P_AXIS0_MOTOR_CURRENT_CONTROL_IQ_MEASURED};
    return read_params(m, 2u, params, req);
}

dre_status dre_read_health(const dre_motor *m, dre_req req[DRE_HEALTH_READS])
{
    static const dre_param_t params[DRE_HEALTH_READS] = {
        DRE_P_AXIS0_MOTOR_THERMISTOR_TEMPERATURE, DRE_P_AXIS0_FET_THERMISTOR_TEMPERATURE,
        DRE_P_AXIS0_MOTOR_EFFECTIVE_CURRENT_LIM, DRE_P_AXIS0_MOTOR_CONFIG_CURRENT_LIM, DRE_P_AXIS0_ERROR};
    return read_params(m, DRE_HEALTH_READS, params, req);
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
