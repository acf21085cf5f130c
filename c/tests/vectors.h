/* The golden vectors as a C table (generated into the build directory). */
#ifndef VECTORS_H
#define VECTORS_H

#include <stdint.h>

#include "drempower/dre_codec.h"

enum { VEC_VALID, VEC_RANGE, VEC_PROTOCOL };

typedef struct {
    const char *file;
    const char *name;
    int host;        /* 1: a host command (decode_command), 0: a motor reply (decode_reply) */
    int kind;        /* VEC_VALID, VEC_RANGE (encode refused) or VEC_PROTOCOL (decode refused) */
    dre_msg msg;     /* the message to encode */
    dre_msg expect;  /* what decoding gives */
    uint16_t id;
    uint8_t len;     /* data bytes in the vector (may differ from 8 in invalid ones) */
    uint8_t data[8];
    const char *field; /* VEC_RANGE: the field the encoder must name */
} vec_case;

extern const vec_case vec_cases[];
extern const unsigned vec_count;

#endif /* VECTORS_H */
