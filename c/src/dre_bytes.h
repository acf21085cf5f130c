/* Little-endian packing and float bit access, portable to 16-bit int targets. */
#ifndef DRE_BYTES_H
#define DRE_BYTES_H

#include <stdint.h>
#include <string.h>

/* The protocol's floats are IEEE-754 binary32; so must be the target's float. */
typedef char dre_float_is_32_bits[sizeof(float) == 4u ? 1 : -1];

static inline uint32_t dre_f32_bits(float v)
{
    uint32_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

static inline float dre_bits_f32(uint32_t b)
{
    float v;
    memcpy(&v, &b, sizeof v);
    return v;
}

static inline void dre_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static inline void dre_put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)((v >> 8) & 0xFFu);
    p[2] = (uint8_t)((v >> 16) & 0xFFu);
    p[3] = (uint8_t)(v >> 24);
}

static inline uint16_t dre_get16(const uint8_t *p)
{
    return (uint16_t)((unsigned)p[0] | ((unsigned)p[1] << 8));
}

static inline uint32_t dre_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

/* Two's-complement reinterpretation without implementation-defined conversions. */
static inline int16_t dre_s16_of(uint16_t u)
{
    return (u & 0x8000u) != 0u ? (int16_t)(-(int16_t)(0x7FFF - (u & 0x7FFF)) - 1) : (int16_t)u;
}

static inline int32_t dre_s32_of(uint32_t u)
{
    return (u & 0x80000000u) != 0u ? -(int32_t)(0x7FFFFFFFu - (u & 0x7FFFFFFFu)) - 1 : (int32_t)u;
}

#endif /* DRE_BYTES_H */
