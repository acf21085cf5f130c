/*
 * A tour of the library against motors on a bus: reads, a verified write, a
 * synchronised move with its wait, and an emergency stop. The same code runs
 * on Linux (examples/sim_socketcand.c, through socketcand) and on a Cortex-M
 * (examples/mps2/, in qemu through the adapter's 0xAA link); the port supplies
 * the bus, a way to wait and a way to print.
 */
#ifndef DRE_TOUR_H
#define DRE_TOUR_H

#include <stdint.h>

#include "drempower/dre.h"

typedef struct {
    dre_bus *bus;
    /* Wait `ms` milliseconds, feeding received frames to the bus (or letting the receive interrupt push them)
     * and calling dre_bus_poll(). */
    void (*pump)(void *user, uint32_t ms);
    /* Print one line (no newline in `line`). */
    void (*print)(void *user, const char *line);
    void *user;
} dre_tour_port;

/* Run the tour on motors ids[0..n-1] (n <= 4, each at 0 deg or near it); 0 when every step did what it should. */
int dre_tour_run(const dre_tour_port *port, uint8_t n, const uint8_t *ids);

#endif /* DRE_TOUR_H */
