/* Reference outputs of the Python core (generated into the build directory). */
#ifndef REFERENCE_H
#define REFERENCE_H

#include <stdint.h>

#include "drempower/dre_params.h"

typedef struct {
    uint32_t id;
    int ext;
    int remote;
    unsigned len;
    uint8_t data[64];
} ref_frame;

typedef struct {
    int aa; /* 0: 11-byte framing, 1: 0xAA framing */
    const uint8_t *bytes;
    unsigned nbytes;
    const ref_frame *frames;
    unsigned nframes;
    uint32_t dropped;
    unsigned pending;
    uint32_t fd_frames;
} ref_stream;

typedef struct {
    uint16_t address;
    uint32_t value;
    const char *text;
} ref_error;

typedef struct {
    const char *name;
    const char *unit;
    uint16_t address;
    uint8_t dtype;
    uint8_t flags;
    int choices; /* 1: only the values lo..hi */
    uint8_t lo, hi;
} ref_param;

/* One write the Python client accepts or refuses (wire range, fixed set, domain). */
typedef struct {
    uint16_t address;
    uint8_t dtype;
    float f;   /* the value of an f32 parameter */
    int64_t i; /* the value of an integer parameter */
    int force;
    int ok; /* 1: Python sends it */
} ref_write;

extern const ref_stream ref_streams[];
extern const unsigned ref_stream_count;
extern const ref_error ref_errors[];
extern const unsigned ref_error_count;
extern const ref_param ref_params[];
extern const unsigned ref_param_count;
extern const ref_write ref_writes[];
extern const unsigned ref_write_count;

#endif /* REFERENCE_H */
