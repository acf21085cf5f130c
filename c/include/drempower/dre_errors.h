/**
 * @file dre_errors.h
 * @brief The seven error words of the motor and the names of their flags.
 *
 * Read a word with a parameter read (e.g. DRE_P_AXIS0_ERROR) and decode it
 * here. Flag names are those of the Python core (drempower.protocol.flags).
 */
#ifndef DRE_ERRORS_H
#define DRE_ERRORS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* axis0.error (30001) */
#define DRE_AXIS_ERROR_INVALID_STATE 0x00000001u
#define DRE_AXIS_ERROR_DC_BUS_UNDER_VOLTAGE 0x00000002u
#define DRE_AXIS_ERROR_DC_BUS_OVER_VOLTAGE 0x00000004u
#define DRE_AXIS_ERROR_CURRENT_MEASUREMENT_TIMEOUT 0x00000008u
#define DRE_AXIS_ERROR_BRAKE_RESISTOR_DISARMED 0x00000010u
#define DRE_AXIS_ERROR_MOTOR_DISARMED 0x00000020u
#define DRE_AXIS_ERROR_MOTOR_FAILED 0x00000040u
#define DRE_AXIS_ERROR_SENSORLESS_ESTIMATOR_FAILED 0x00000080u
#define DRE_AXIS_ERROR_ENCODER_FAILED 0x00000100u
#define DRE_AXIS_ERROR_CONTROLLER_FAILED 0x00000200u
#define DRE_AXIS_ERROR_POS_CTRL_DURING_SENSORLESS 0x00000400u
#define DRE_AXIS_ERROR_WATCHDOG_TIMER_EXPIRED 0x00000800u
#define DRE_AXIS_ERROR_MIN_ENDSTOP_PRESSED 0x00001000u
#define DRE_AXIS_ERROR_MAX_ENDSTOP_PRESSED 0x00002000u
#define DRE_AXIS_ERROR_ESTOP_REQUESTED 0x00004000u
#define DRE_AXIS_ERROR_UNKNOWN_ERROR_CODE1 0x00008000u
#define DRE_AXIS_ERROR_UNKNOWN_ERROR_CODE2 0x00010000u
#define DRE_AXIS_ERROR_HOMING_WITHOUT_ENDSTOP 0x00020000u
#define DRE_AXIS_ERROR_OVER_TEMP 0x00040000u

/* axis0.motor.error (33001) */
#define DRE_MOTOR_ERROR_PHASE_RESISTANCE_OUT_OF_RANGE 0x00000001u
#define DRE_MOTOR_ERROR_PHASE_INDUCTANCE_OUT_OF_RANGE 0x00000002u
#define DRE_MOTOR_ERROR_ADC_FAILED 0x00000004u
#define DRE_MOTOR_ERROR_DRV_FAULT 0x00000008u
#define DRE_MOTOR_ERROR_CONTROL_DEADLINE_MISSED 0x00000010u
#define DRE_MOTOR_ERROR_NOT_IMPLEMENTED_MOTOR_TYPE 0x00000020u
#define DRE_MOTOR_ERROR_BRAKE_CURRENT_OUT_OF_RANGE 0x00000040u
#define DRE_MOTOR_ERROR_MODULATION_MAGNITUDE 0x00000080u
#define DRE_MOTOR_ERROR_BRAKE_DEADTIME_VIOLATION 0x00000100u
#define DRE_MOTOR_ERROR_UNEXPECTED_TIMER_CALLBACK 0x00000200u
#define DRE_MOTOR_ERROR_CURRENT_SENSE_SATURATION 0x00000400u
#define DRE_MOTOR_ERROR_UNKNOWN_ERROR_CODE 0x00000800u
#define DRE_MOTOR_ERROR_CURRENT_LIMIT_VIOLATION 0x00001000u
#define DRE_MOTOR_ERROR_BRAKE_DUTY_CYCLE_NAN 0x00002000u
#define DRE_MOTOR_ERROR_DC_BUS_OVER_REGEN_CURRENT 0x00004000u
#define DRE_MOTOR_ERROR_DC_BUS_OVER_CURRENT 0x00008000u
#define DRE_MOTOR_ERROR_STALL_LIMIT_VIOLATION 0x00010000u

/* axis0.encoder.error (34001) */
#define DRE_ENCODER_ERROR_UNSTABLE_GAIN 0x00000001u
#define DRE_ENCODER_ERROR_CPR_POLEPAIRS_MISMATCH 0x00000002u
#define DRE_ENCODER_ERROR_NO_RESPONSE 0x00000004u
#define DRE_ENCODER_ERROR_UNSUPPORTED_ENCODER_MODE 0x00000008u
#define DRE_ENCODER_ERROR_ILLEGAL_HALL_STATE 0x00000010u
#define DRE_ENCODER_ERROR_INDEX_NOT_FOUND_YET 0x00000020u
#define DRE_ENCODER_ERROR_ABS_SPI_TIMEOUT 0x00000040u
#define DRE_ENCODER_ERROR_ABS_SPI_COM_FAIL 0x00000080u
#define DRE_ENCODER_ERROR_ABS_SPI_NOT_READY 0x00000100u
#define DRE_ENCODER_ERROR_EDR_OVER_RANGE 0x00000200u
#define DRE_ENCODER_ERROR_EDR_POWER_FAILURE 0x00000400u
#define DRE_ENCODER_ERROR_EDR_BATTERY_LOW 0x00000800u
#define DRE_ENCODER_ERROR_OFFSET_CALIBRATE_FAILURE 0x00001000u
#define DRE_ENCODER_ERROR_INCORRECT_OFFSET 0x00002000u
#define DRE_ENCODER_ERROR_TURNS_COUNTER_WARNING 0x00004000u

/* axis0.controller.error (32001) */
#define DRE_CONTROLLER_ERROR_OVERSPEED 0x00000001u
#define DRE_CONTROLLER_ERROR_INVALID_INPUT_MODE 0x00000002u
#define DRE_CONTROLLER_ERROR_UNSTABLE_GAIN 0x00000004u
#define DRE_CONTROLLER_ERROR_INVALID_MIRROR_AXIS 0x00000008u
#define DRE_CONTROLLER_ERROR_INVALID_LOAD_ENCODER 0x00000010u
#define DRE_CONTROLLER_ERROR_INVALID_ESTIMATE 0x00000020u

/* can.error (20001) */
#define DRE_CAN_ERROR_DUPLICATE_CAN_IDS 0x00000001u

/* axis0.fet_thermistor.error (36001) */
#define DRE_FET_THERMISTOR_ERROR_OVER_TEMP 0x00000001u

/* axis0.motor_thermistor.error (37001) */
#define DRE_MOTOR_THERMISTOR_ERROR_OVER_TEMP 0x00000001u

/** An error word: its parameter, short label and flag names by bit. */
typedef struct {
    const char *name;          /**< parameter name, e.g. "axis0.error" */
    uint16_t address;          /**< parameter address, e.g. 30001 */
    const char *label;         /**< short label, e.g. "axis" */
    uint8_t count;             /**< flags known: bits 0..count-1 */
    const char *const *flags;  /**< flags[bit], e.g. "ESTOP_REQUESTED" */
} dre_error_word;

#define DRE_ERROR_WORD_COUNT 7u

/** The seven words in the order the vendor's dump_error reads them:
 *  axis, motor, encoder, controller, can, fet thermistor, motor thermistor. */
extern const dre_error_word dre_error_words[DRE_ERROR_WORD_COUNT];

/** The error word at parameter `address`, or NULL. */
const dre_error_word *dre_error_word_find(uint16_t address);

/** Name of flag `bit` (0..31) of `word`, or NULL when the bit has no name. */
const char *dre_error_flag_name(const dre_error_word *word, uint8_t bit);

/**
 * Write the names of the flags set in `value`, separated by '|', known flags
 * first, then unknown bits as UNKNOWN_0x%08X; "" when `value` is 0. Writes at
 * most `cap` bytes including the terminating NUL (truncating if needed, as
 * snprintf does) and returns the length of the full text. A NULL `word` (what
 * dre_error_word_find() gives for an address that is no error word) names
 * every set bit UNKNOWN_0x%08X.
 */
size_t dre_error_format(const dre_error_word *word, uint32_t value, char *buf, size_t cap);

#ifdef __cplusplus
}
#endif

#endif /* DRE_ERRORS_H */
