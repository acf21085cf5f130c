/*
 * socketcan_scan: find DrEmpower motors on a Linux CAN interface and move one.
 *
 *     socketcan_scan can0                 scan ids 1..63 with fast reads
 *     socketcan_scan can0 ID ANGLE        scan, then move motor ID to ANGLE deg
 *                                         (Q mode, 10 r/min, 20 (r/min)/s) and
 *                                         report its state until it arrives
 *
 * Bring the interface up first, e.g. `ip link set can0 up type can bitrate 1000000`
 * (or `slcand -o -c -s8 /dev/ttyACM0 can0` for the vendor's USB adapter).
 */
#define _DEFAULT_SOURCE

#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <linux/can.h>
#include <linux/can/raw.h>

#include "drempower/dre.h"

#define SCAN_SLOTS 63u

typedef struct {
    int fd;
} link_t;

static int send_frame(void *user, const dre_frame *f)
{
    const link_t *link = (const link_t *)user;
    struct can_frame cf;

    memset(&cf, 0, sizeof cf);
    cf.can_id = f->id;
    cf.can_dlc = f->len;
    memcpy(cf.data, f->data, f->len);
    return write(link->fd, &cf, sizeof cf) == (ssize_t)sizeof cf ? 0 : -1;
}

static uint32_t tick_ms(void *user)
{
    struct timespec ts;
    (void)user;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u);
}

static int open_can(const char *ifname)
{
    struct sockaddr_can addr;
    unsigned index = if_nametoindex(ifname);
    int fd;

    if (index == 0u) {
        perror(ifname);
        return -1;
    }
    fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (fd < 0) {
        perror("socket");
        return -1;
    }
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = (int)index;
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr) < 0) {
        perror("bind");
        close(fd);
        return -1;
    }
    return fd;
}

/* Wait up to `ms` for frames, feed each standard data frame to the bus, then poll it. */
static void pump(dre_bus *bus, int fd, int ms)
{
    struct pollfd p;
    struct can_frame cf;
    dre_frame f;

    p.fd = fd;
    p.events = POLLIN;
    while (poll(&p, 1, ms) > 0 && (p.revents & POLLIN) != 0) {
        if (read(fd, &cf, sizeof cf) != (ssize_t)sizeof cf) {
            break;
        }
        if ((cf.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) == 0u && cf.can_dlc <= 8u) {
            f.id = (uint16_t)(cf.can_id & CAN_SFF_MASK);
            f.len = cf.can_dlc;
            memset(f.data, 0, sizeof f.data);
            memcpy(f.data, cf.data, cf.can_dlc);
            (void)dre_bus_feed(bus, &f);
        }
        ms = 0; /* drain what is queued, then return */
    }
    dre_bus_poll(bus);
}

static void print_state(const dre_msg *s)
{
    printf("  node %2u: %10.2f deg %8.2f r/min %7.2f Nm%s%s\n", (unsigned)s->node, (double)s->u.state.position,
           (double)s->u.state.speed, (double)s->u.state.torque, s->u.state.trajectory_done ? "  done" : "",
           s->u.state.error ? "  ERROR" : "");
}

/* Fast-read every id at once; returns how many answered. */
static unsigned scan(dre_bus *bus, int fd)
{
    dre_req reqs[SCAN_SLOTS];
    dre_msg reply;
    unsigned id, found = 0u, waiting;
    dre_status st;

    for (id = 1u; id <= SCAN_SLOTS; id++) {
        dre_motor m = {bus, (uint8_t)id};
        unsigned tries = 0u;
        /* the interface's transmit queue is short: wait for room when it is full */
        while ((st = dre_get_state(&m, &reqs[id - 1u])) == DRE_E_SEND && ++tries < 100u) {
            pump(bus, fd, 1);
        }
        if (st != DRE_OK) {
            fprintf(stderr, "fast read of %u: %s\n", id, dre_status_name(st));
            reqs[id - 1u] = 0u;
        }
        pump(bus, fd, 0); /* keep the receive queue short while sending */
    }
    do {
        pump(bus, fd, 5);
        waiting = 0u;
        for (id = 1u; id <= SCAN_SLOTS; id++) {
            if (reqs[id - 1u] == 0u) {
                continue;
            }
            st = dre_result(bus, reqs[id - 1u], &reply);
            if (st == DRE_PENDING) {
                waiting++;
                continue;
            }
            if (st == DRE_OK) {
                print_state(&reply);
                found++;
            }
            reqs[id - 1u] = 0u;
        }
    } while (waiting > 0u);
    return found;
}

/* Move `node` to `angle` and report its state every 200 ms until the trajectory is done. */
static int move(dre_bus *bus, int fd, uint8_t node, float angle)
{
    dre_motor m = {bus, node};
    dre_status st = dre_set_angle(&m, angle, 10.0f, 20.0f, DRE_ANGLE_Q);
    dre_msg reply;
    dre_req req;
    unsigned tries;

    if (st != DRE_OK) {
        fprintf(stderr, "set_angle: %s (%s)\n", dre_status_name(st), dre_field_name(bus->bad_field));
        return 1;
    }
    pump(bus, fd, 100);
    for (tries = 0u; tries < 300u; tries++) {
        if (dre_get_state(&m, &req) != DRE_OK) {
            return 1;
        }
        do {
            pump(bus, fd, 5);
            st = dre_result(bus, req, &reply);
        } while (st == DRE_PENDING);
        if (st != DRE_OK) {
            fprintf(stderr, "node %u: %s\n", (unsigned)node, dre_status_name(st));
            return 1;
        }
        print_state(&reply);
        if (reply.u.state.trajectory_done || reply.u.state.error) {
            return reply.u.state.error ? 1 : 0;
        }
        pump(bus, fd, 200);
    }
    return 1;
}

int main(int argc, char **argv)
{
    static dre_request slots[SCAN_SLOTS];
    dre_bus_config cfg;
    dre_bus bus;
    link_t link;
    unsigned found;
    int rc = 0;

    if (argc != 2 && argc != 4) {
        fprintf(stderr, "usage: %s IFACE [ID ANGLE]\n", argv[0]);
        return 2;
    }
    link.fd = open_can(argv[1]);
    if (link.fd < 0) {
        return 1;
    }
    memset(&cfg, 0, sizeof cfg);
    cfg.send = send_frame;
    cfg.tick = tick_ms;
    cfg.user = &link;
    cfg.timeout_ms = 20u;
    if (dre_bus_init(&bus, &cfg, slots, SCAN_SLOTS, NULL, 0u) != DRE_OK) {
        close(link.fd);
        return 1;
    }
    printf("scanning %s, ids 1..63\n", argv[1]);
    found = scan(&bus, link.fd);
    printf("%u motor(s) answered\n", found);
    if (argc == 4) {
        long id = strtol(argv[2], NULL, 10);
        if (id < 1 || id > 63) {
            fprintf(stderr, "ID must be 1..63\n");
            rc = 2;
        } else {
            rc = move(&bus, link.fd, (uint8_t)id, strtof(argv[3], NULL));
        }
    }
    close(link.fd);
    return rc;
}
