/* The shared client-behaviour vectors (spec/vectors/client (JSON)) as a C table: client_vectors_table.c,
 * written by gen_client_vectors.py (ctest runs it with --check). */
#ifndef CLIENT_VECTORS_H
#define CLIENT_VECTORS_H

#include <stdint.h>

#include "drempower/dre_codec.h"

/* Step kinds: actions (CV_READ .. CV_WAIT_DONE), frames in (CV_RX), the frames written since the
 * previous CV_TX (CV_TX), the transport's confirmation (CV_TX_DONE) and one outcome (CV_EXPECT). */
enum { CV_READ, CV_GET_STATE, CV_PRESET_START, CV_SEND, CV_WAIT_DONE, CV_RX, CV_TX, CV_TX_DONE, CV_EXPECT };
enum { CV_PENDING, CV_OK, CV_TIMEOUT, CV_MOVE_ERROR, CV_FAULT };
#define CV_NO_REQ 0xFFu  /* an expect step that checks only the counters */
#define CV_NOT_CHECKED (-1)

typedef struct {
    uint32_t at;          /* ms */
    uint8_t kind;         /* CV_* */
    uint8_t req;          /* the request's index in its vector (order of first appearance), or CV_NO_REQ */
    uint8_t node;         /* read, get_state */
    uint8_t dtype;        /* read */
    uint16_t address;     /* read */
    uint16_t first;       /* rx/tx: into cv_frames; send/preset_start: into cv_msgs; wait_done: into cv_nodes */
    uint16_t count;
    dre_msg start;        /* preset_start */
    uint32_t timeout_ms;  /* wait_done */
    uint32_t poll_ms;     /* wait_done */
    uint8_t status;       /* expect: CV_PENDING .. CV_FAULT */
    uint8_t has_value, has_position, has_tdone;
    int64_t value;
    float position;
    uint8_t trajectory_done;
    int32_t unmatched, anomalies; /* CV_NOT_CHECKED or the expected counter */
} cv_step;

typedef struct {
    const char *file;
    const char *name;
    uint32_t timeout_ms;
    uint8_t tx_confirmed; /* 1: "tx": "confirmed" (cfg.tx_done), 0: "in_order" */
    uint8_t retries;      /* cfg.retries */
    uint16_t first, count; /* into cv_steps */
} cv_vector;

extern const cv_vector cv_vectors[];
extern const unsigned cv_nvectors;
extern const cv_step cv_steps[];
extern const dre_frame cv_frames[];
extern const dre_msg cv_msgs[];
extern const uint8_t cv_nodes[];

#endif /* CLIENT_VECTORS_H */
