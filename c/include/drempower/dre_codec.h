/**
 * @file dre_codec.h
 * @brief Encode and decode every DrEmpower CAN frame.
 *
 * Pure functions: no I/O, no clock, no heap, no globals. A frame is a
 * standard 11-bit id `(node << 5) | command` with 8 data bytes, little-endian,
 * floats IEEE-754 binary32.
 *
 * Units are those of the wire, at the output shaft: positions in degrees,
 * speeds in r/min, torques in Nm, accelerations and ramp rates in (r/min)/s or
 * Nm/s, filter bandwidth in 1/s, Q-preset time in s, impedance gains Kp in
 * Nm/rad and Kd in Nm/(rad/s).
 *
 * Fields sent as s16 scaled by 0.01 hold -327.68..327.67. Encoding rounds
 * the binary32 value x 100, computed exactly, to the nearest integer (ties to
 * even) and refuses anything outside the range; NaN and infinity are refused
 * in every float field. Nothing is clipped.
 *
 * The Python core rounds the double value x 100 (also ties to even). The two
 * agree for every value that is exactly a binary32 (x 100 is then exact in
 * double, ties included: 0.125 -> 12, 0.375 -> 38) and for every value with at
 * most two decimals. They can differ for a decimal with more digits that is
 * not a binary32, because C sees the float nearest to it: 0.015 x 100 is 1.5
 * in double (Python: 2) but 0.015f is 0.01499999966 (C: 1); 2.675 gives 268
 * in Python and 267 in C.
 */
#ifndef DRE_CODEC_H
#define DRE_CODEC_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define DRE_BROADCAST 0u /**< node id addressing every motor */
#define DRE_MAX_NODE 63u /**< highest node id */
#define DRE_MAX_ID 0x7FFu /**< highest 11-bit arbitration id */

/** Result of every library call. Negative values are errors. */
typedef enum {
    DRE_OK = 0,
    DRE_PENDING = 1,       /**< the request still waits for its reply */
    DRE_E_RANGE = -1,      /**< a field does not fit the wire (dre_field), or a value a parameter does not take */
    DRE_E_PROTOCOL = -2,   /**< a frame or byte stream does not follow the protocol */
    DRE_E_ARG = -3,        /**< bad argument: NULL, unknown handle, empty batch, wrong message type */
    DRE_E_BUSY = -4,       /**< no free request slot, or no room to send every frame of an operation */
    DRE_E_SEND = -5,       /**< the send callback reported a failure */
    DRE_E_TIMEOUT = -6,    /**< no reply arrived in time */
    DRE_E_ACCESS = -7,     /**< write to a read-only parameter */
    DRE_E_FAULT = -8,      /**< the motor reports an error (E bit of its state) */
    DRE_E_VERIFY = -9,     /**< a value read back differs from the one written */
    DRE_E_ID_TAKEN = -10,  /**< dre_set_id: a motor already answers at the new id; nothing was written */
    DRE_E_NO_MOTOR = -11,  /**< dre_set_id: no motor answers at the current id; nothing was written */
    DRE_E_MOVE = -12       /**< dre_positions_done: a move ended away from its target */
} dre_status;

/** Command field (low 5 bits of the id) of host frames. */
enum {
    DRE_CMD_SYSTEM = 0x08,
    DRE_CMD_PRESET = 0x0C,
    DRE_CMD_POSITION_T = 0x19,
    DRE_CMD_POSITION_Q = 0x1A,
    DRE_CMD_POSITION_P = 0x1B,
    DRE_CMD_VELOCITY = 0x1C,
    DRE_CMD_TORQUE = 0x1D,
    DRE_CMD_READ = 0x1E,
    DRE_CMD_WRITE = 0x1F
};

/** Parameter data type codes of read/write frames. */
typedef enum { DRE_F32 = 0, DRE_U16 = 1, DRE_S16 = 2, DRE_U32 = 3, DRE_S32 = 4 } dre_dtype;

/** Mode of velocity commands: raw u16 in 0x1C, x100 in V presets. */
typedef enum {
    DRE_VEL_PASSTHROUGH = 1, /**< speed jumps to the target; param = torque feed-forward, Nm */
    DRE_VEL_RAMP = 2         /**< speed ramps to the target; param = ramp rate, (r/min)/s */
} dre_vel_mode;

/** Mode of torque commands: raw u16 in 0x1D, x100 in C presets. */
typedef enum {
    DRE_TORQUE_DIRECT = 1, /**< torque equals the target at once; param unused */
    DRE_TORQUE_RAMP = 6    /**< torque ramps to the target; param = ramp rate, Nm/s */
} dre_torque_mode;

/** Single-shot system commands (0x08, sys_num 0x00..0x07). */
typedef enum {
    DRE_SYS_INIT_CONFIG = 0x00,
    DRE_SYS_SAVE_CONFIG = 0x01,
    DRE_SYS_ERASE_CONFIG = 0x02,
    DRE_SYS_REBOOT = 0x03,
    DRE_SYS_CLEAR_ERRORS = 0x04,
    DRE_SYS_SET_ZERO_POSITION = 0x05,
    DRE_SYS_ESTOP = 0x06,
    DRE_SYS_ENTER_DFU_MODE = 0x07
} dre_sys_op;

/** Start commands (0x08, sys_num 0x10..0x15): which preset interpretation runs. */
typedef enum {
    DRE_START_T = 0x10,
    DRE_START_Q = 0x11,
    DRE_START_P = 0x12,
    DRE_START_V = 0x13,
    DRE_START_C = 0x14,
    DRE_START_D = 0x15 /**< impedance; sent as DRE_MSG_START_IMPEDANCE */
} dre_start_kind;

/** Message types. Host commands first, then the two motor replies. */
typedef enum {
    DRE_MSG_NONE = 0,
    DRE_MSG_POSITION_T,      /**< 0x19, u.position_t */
    DRE_MSG_POSITION_Q,      /**< 0x1A, u.position_q */
    DRE_MSG_POSITION_P,      /**< 0x1B, u.position_p */
    DRE_MSG_VELOCITY,        /**< 0x1C, u.velocity */
    DRE_MSG_TORQUE,          /**< 0x1D, u.torque */
    DRE_MSG_PRESET,          /**< 0x0C generic form (what decoding gives), u.preset */
    DRE_MSG_PRESET_T,        /**< 0x0C for start T, u.position_t */
    DRE_MSG_PRESET_Q,        /**< 0x0C for start Q, u.preset_q */
    DRE_MSG_PRESET_P,        /**< 0x0C for start P, u.position_p */
    DRE_MSG_PRESET_V,        /**< 0x0C for start V, u.velocity (mode sent x100) */
    DRE_MSG_PRESET_C,        /**< 0x0C for start C, u.torque (mode sent x100) */
    DRE_MSG_PRESET_D,        /**< 0x0C for impedance start, u.preset_d */
    DRE_MSG_SYSTEM,          /**< 0x08 sys_num 0x00..0x07, u.system */
    DRE_MSG_START,           /**< 0x08 sys_num 0x10..0x14, u.start */
    DRE_MSG_START_IMPEDANCE, /**< 0x08 sys_num 0x15, u.start_impedance */
    DRE_MSG_READ_PARAM,      /**< 0x1E, u.param (value unused) */
    DRE_MSG_FAST_READ,       /**< 0x1E address 0: the motor answers with a state frame */
    DRE_MSG_WRITE_PARAM,     /**< 0x1F, u.param */
    DRE_MSG_PARAM_VALUE,     /**< reply to a read, u.param */
    DRE_MSG_STATE            /**< real-time state reply, u.state */
} dre_msg_type;

/** The field that made an encode fail with DRE_E_RANGE. */
typedef enum {
    DRE_FIELD_NONE = 0,
    DRE_FIELD_NODE,
    DRE_FIELD_TYPE,
    DRE_FIELD_POSITION,
    DRE_FIELD_SPEED,
    DRE_FIELD_ACCEL,
    DRE_FIELD_BANDWIDTH,
    DRE_FIELD_SPEED_FF,
    DRE_FIELD_TORQUE_FF,
    DRE_FIELD_TORQUE,
    DRE_FIELD_PARAM,
    DRE_FIELD_MODE,
    DRE_FIELD_P1,
    DRE_FIELD_P2,
    DRE_FIELD_P3,
    DRE_FIELD_TIME,
    DRE_FIELD_OP,
    DRE_FIELD_KIND,
    DRE_FIELD_RELATIVE,
    DRE_FIELD_KP,
    DRE_FIELD_KD,
    DRE_FIELD_ADDRESS,
    DRE_FIELD_DTYPE,
    DRE_FIELD_VALUE,
    DRE_FIELD_SPARE_BITS,
    DRE_FIELD_FROM /**< a current position given to dre_set_angles */
} dre_field;

/** One CAN frame: 11-bit id and its data bytes (always 8 for DrEmpower). */
typedef struct {
    uint16_t id;
    uint8_t len;
    uint8_t data[8];
} dre_frame;

/**
 * A parameter value. `f32` for DRE_F32, `i` for the integer types; `i` is
 * wide enough to hold every u32 and s32, so an out-of-range value is refused
 * by the encoder instead of wrapping on the way in.
 */
typedef union {
    float f32;
    int64_t i;
} dre_value;

/** A message with its fields in engineering units (see the file comment). */
typedef struct {
    uint8_t type; /**< dre_msg_type */
    uint8_t node; /**< 0..63, 0 = broadcast */
    union {
        struct {
            float position, bandwidth, speed; /**< speed is carried but ignored by the motor */
        } position_t;
        struct {
            float position, speed, accel;
        } position_q;
        struct {
            float position, speed_ff, torque_ff;
        } position_p;
        struct {
            float speed, param;
            uint8_t mode; /**< dre_vel_mode */
        } velocity;
        struct {
            float torque, param;
            uint8_t mode; /**< dre_torque_mode */
        } torque;
        struct {
            float p1, p2, p3;
        } preset;
        struct {
            float position, time, accel;
        } preset_q;
        struct {
            float position, speed, torque_ff;
        } preset_d;
        struct {
            uint8_t op; /**< dre_sys_op */
        } system;
        struct {
            uint8_t kind;     /**< dre_start_kind T..C */
            uint8_t relative; /**< 1 = targets relative to the current position (T, Q, P only) */
        } start;
        struct {
            float kp, kd;
        } start_impedance;
        struct {
            uint32_t address; /**< 1..65535 (0 is the fast read) */
            uint8_t dtype;    /**< dre_dtype */
            dre_value value;
        } param;
        struct {
            float position, speed, torque;
            uint8_t trajectory_done; /**< T bit: target reached */
            uint8_t error;           /**< E bit: axis0.error != 0 */
            uint8_t spare_bits;      /**< bits 3-4 of the command field, unspecified (0..3) */
        } state;
    } u;
} dre_msg;

/**
 * Encode `msg` into `out` (id, len = 8, data).
 * @param bad  optional; on DRE_E_RANGE receives the offending field.
 * @return DRE_OK, or DRE_E_RANGE (nothing written to `out`).
 */
dre_status dre_encode(const dre_msg *msg, dre_frame *out, dre_field *bad);

/** Decode a host frame (what a motor receives). DRE_E_PROTOCOL when malformed. */
dre_status dre_decode_command(const dre_frame *frame, dre_msg *out);

/**
 * Decode a motor frame (what a host receives): a command field with bit 0 set
 * is a state frame (bit 1 = T, bit 2 = E, bits 3-4 kept in spare_bits), 0x1E
 * is a parameter value. DRE_E_PROTOCOL when malformed.
 */
dre_status dre_decode_reply(const dre_frame *frame, dre_msg *out);

/**
 * Interpret a generic preset (DRE_MSG_PRESET, as decoded) for the start
 * command `kind`, giving the typed preset. DRE_E_PROTOCOL when a V/C mode
 * code is not 100/200 or 100/600; DRE_E_ARG for a non-preset or unknown kind.
 */
dre_status dre_preset_as_kind(const dre_msg *preset, uint8_t kind, dre_msg *out);

/** The field's name as in the golden vectors ("speed", "kp"...). */
const char *dre_field_name(dre_field field);

/** A short name of a status ("ok", "range", "timeout"...). */
const char *dre_status_name(dre_status status);

#ifdef __cplusplus
}
#endif

#endif /* DRE_CODEC_H */
