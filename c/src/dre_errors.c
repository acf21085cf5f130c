/* Error words and flag names (see dre_errors.h). */
#include "drempower/dre_errors.h"

static const char *const axis_flags[] = {
    "INVALID_STATE",
    "DC_BUS_UNDER_VOLTAGE",
    "DC_BUS_OVER_VOLTAGE",
    "CURRENT_MEASUREMENT_TIMEOUT",
    "BRAKE_RESISTOR_DISARMED",
    "MOTOR_DISARMED",
    "MOTOR_FAILED",
    "SENSORLESS_ESTIMATOR_FAILED",
    "ENCODER_FAILED",
    "CONTROLLER_FAILED",
    "POS_CTRL_DURING_SENSORLESS",
    "WATCHDOG_TIMER_EXPIRED",
    "MIN_ENDSTOP_PRESSED",
    "MAX_ENDSTOP_PRESSED",
    "ESTOP_REQUESTED",
    "UNKNOWN_ERROR_CODE1",
    "UNKNOWN_ERROR_CODE2",
    "HOMING_WITHOUT_ENDSTOP",
    "OVER_TEMP"};

static const char *const motor_flags[] = {
    "PHASE_RESISTANCE_OUT_OF_RANGE",
    "PHASE_INDUCTANCE_OUT_OF_RANGE",
    "ADC_FAILED",
    "DRV_FAULT",
    "CONTROL_DEADLINE_MISSED",
    "NOT_IMPLEMENTED_MOTOR_TYPE",
    "BRAKE_CURRENT_OUT_OF_RANGE",
    "MODULATION_MAGNITUDE",
    "BRAKE_DEADTIME_VIOLATION",
    "UNEXPECTED_TIMER_CALLBACK",
    "CURRENT_SENSE_SATURATION",
    "UNKNOWN_ERROR_CODE",
    "CURRENT_LIMIT_VIOLATION",
    "BRAKE_DUTY_CYCLE_NAN",
    "DC_BUS_OVER_REGEN_CURRENT",
    "DC_BUS_OVER_CURRENT",
    "STALL_LIMIT_VIOLATION"};

static const char *const encoder_flags[] = {
    "UNSTABLE_GAIN",
    "CPR_POLEPAIRS_MISMATCH",
    "NO_RESPONSE",
    "UNSUPPORTED_ENCODER_MODE",
    "ILLEGAL_HALL_STATE",
    "INDEX_NOT_FOUND_YET",
    "ABS_SPI_TIMEOUT",
    "ABS_SPI_COM_FAIL",
    "ABS_SPI_NOT_READY",
    "EDR_OVER_RANGE",
    "EDR_POWER_FAILURE",
    "EDR_BATTERY_LOW",
    "OFFSET_CALIBRATE_FAILURE",
    "INCORRECT_OFFSET",
    "TURNS_COUNTER_WARNING"};

static const char *const controller_flags[] = {
    "OVERSPEED",
    "INVALID_INPUT_MODE",
    "UNSTABLE_GAIN",
    "INVALID_MIRROR_AXIS",
    "INVALID_LOAD_ENCODER",
    "INVALID_ESTIMATE"};

static const char *const can_flags[] = {
    "DUPLICATE_CAN_IDS"};

static const char *const fet_thermistor_flags[] = {
    "OVER_TEMP"};

static const char *const motor_thermistor_flags[] = {
    "OVER_TEMP"};

const dre_error_word dre_error_words[DRE_ERROR_WORD_COUNT] = {
    {"axis0.error", 30001u, "axis", 19u, axis_flags},
    {"axis0.motor.error", 33001u, "motor", 17u, motor_flags},
    {"axis0.encoder.error", 34001u, "encoder", 15u, encoder_flags},
    {"axis0.controller.error", 32001u, "controller", 6u, controller_flags},
    {"can.error", 20001u, "can", 1u, can_flags},
    {"axis0.fet_thermistor.error", 36001u, "fet_thermistor", 1u, fet_thermistor_flags},
    {"axis0.motor_thermistor.error", 37001u, "motor_thermistor", 1u, motor_thermistor_flags}};

const dre_error_word *dre_error_word_find(uint16_t address)
{
    unsigned i;
    for (i = 0u; i < DRE_ERROR_WORD_COUNT; i++) {
        if (dre_error_words[i].address == address) {
            return &dre_error_words[i];
        }
    }
    return NULL;
}

const char *dre_error_flag_name(const dre_error_word *word, uint8_t bit)
{
    return word != NULL && bit < word->count ? word->flags[bit] : NULL;
}

/* Append `text` at *len, writing only what fits before the terminator. */
static void append(char *buf, size_t cap, size_t *len, const char *text)
{
    for (; *text != '\0'; text++, (*len)++) {
        if (*len + 1u < cap) {
            buf[*len] = *text;
        }
    }
}

size_t dre_error_format(const dre_error_word *word, uint32_t value, char *buf, size_t cap)
{
    static const char hex[] = "0123456789ABCDEF";
    char unknown[19] = "UNKNOWN_0x";
    size_t len = 0u;
    uint8_t bit, pass, k;

    for (pass = 0u; pass < 2u; pass++) {
        for (bit = 0u; bit < 32u; bit++) {
            uint32_t flag = (uint32_t)1 << bit;
            const char *name = dre_error_flag_name(word, bit);
            if ((value & flag) == 0u || (pass == 0u) != (name != NULL)) {
                continue;
            }
            if (len > 0u) {
                append(buf, cap, &len, "|");
            }
            if (name == NULL) {
                for (k = 0u; k < 8u; k++) {
                    unknown[10u + k] = hex[(flag >> (28u - 4u * k)) & 0xFu];
                }
                name = unknown;
            }
            append(buf, cap, &len, name);
        }
    }
    if (cap > 0u) {
        buf[len < cap ? len : cap - 1u] = '\0';
    }
    return len;
}
