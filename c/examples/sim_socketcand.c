/*
 * sim_socketcand: the library's tour (examples/tour/) over socketcand on TCP,
 * e.g. against the simulator, before any hardware:
 *
 *     drempower sim --ids 1,2 --socketcand-port 29536     (prints the port; 0 picks a free one)
 *     sim_socketcand 127.0.0.1 29536 1,2                  reads, a verified write, a synchronised
 *                                                         move and its wait, an estop
 *
 * A real socketcand server (socketcand -i can0) works the same. socketcand's
 * raw mode: the server greets with < hi >, the client opens the bus and asks
 * for raw mode (< open can0 >, < rawmode >, each answered < ok >), then frames
 * go as < send ID LEN B0 .. > and come as < frame ID SECS.USECS DATA >.
 */
#define _DEFAULT_SOURCE

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "drempower/dre.h"
#include "tour/tour.h"

typedef struct {
    int fd;
    char buf[4096]; /* received text not yet parsed */
    size_t len;
    int closed;
} link_t;

static uint32_t tick_ms(void *user)
{
    struct timespec ts;
    (void)user;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint32_t)((uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u);
}

static int write_all(int fd, const char *s, size_t n)
{
    while (n > 0u) {
        ssize_t w = send(fd, s, n, MSG_NOSIGNAL);
        if (w < 0 && errno == EINTR) {
            continue;
        }
        if (w <= 0) {
            return -1;
        }
        s += w;
        n -= (size_t)w;
    }
    return 0;
}

static int send_frame(void *user, const dre_frame *f)
{
    const link_t *link = (const link_t *)user;
    char text[64];
    int n = snprintf(text, sizeof text, "< send %03X %u", (unsigned)f->id, (unsigned)f->len);
    unsigned i;

    for (i = 0u; i < f->len; i++) {
        n += snprintf(text + n, sizeof text - (size_t)n, " %02X", (unsigned)f->data[i]);
    }
    n += snprintf(text + n, sizeof text - (size_t)n, " >");
    return write_all(link->fd, text, (size_t)n);
}

/* Read what the socket has within `ms` into link->buf; -1 once the server closed the connection. */
static int receive(link_t *link, int ms)
{
    struct pollfd p;
    ssize_t r;

    p.fd = link->fd;
    p.events = POLLIN;
    if (poll(&p, 1, ms) <= 0) {
        return 0;
    }
    if (link->len == sizeof link->buf) {
        link->len = 0u; /* a message longer than any socketcand sends: drop it */
    }
    r = recv(link->fd, link->buf + link->len, sizeof link->buf - link->len, 0);
    if (r <= 0) {
        link->closed = 1;
        return -1;
    }
    link->len += (size_t)r;
    return 1;
}

/* The next complete < ... > message (its inside, NUL-terminated, in `out`), or 0 when none has arrived yet. */
static int next_message(link_t *link, char *out, size_t cap)
{
    char *open = memchr(link->buf, '<', link->len), *close;
    size_t n;

    if (open == NULL) {
        link->len = 0u;
        return 0;
    }
    close = memchr(open, '>', link->len - (size_t)(open - link->buf));
    if (close == NULL) {
        return 0;
    }
    n = (size_t)(close - open - 1);
    if (n >= cap) {
        n = cap - 1u;
    }
    memcpy(out, open + 1, n);
    out[n] = '\0';
    link->len -= (size_t)(close + 1 - link->buf);
    memmove(link->buf, close + 1, link->len);
    return 1;
}

/* A < frame ID SECS DATA > message as a standard data frame; 0 for anything else. */
static int parse_frame(const char *msg, dre_frame *f)
{
    char id[16], secs[32], data[32];
    unsigned long ident;
    size_t i, n;

    if (sscanf(msg, " frame %15s %31s %31s", id, secs, data) != 3 || strlen(id) != 3u) {
        if (sscanf(msg, " frame %15s %31s", id, secs) != 2 || strlen(id) != 3u) {
            return 0;
        }
        data[0] = '\0'; /* a frame without data */
    }
    ident = strtoul(id, NULL, 16);
    n = strlen(data);
    if (ident > 0x7FFu || n % 2u != 0u || n > 16u) {
        return 0;
    }
    memset(f, 0, sizeof *f);
    f->id = (uint16_t)ident;
    f->len = (uint8_t)(n / 2u);
    for (i = 0u; i < f->len; i++) {
        char byte[3] = {data[2u * i], data[2u * i + 1u], '\0'};
        f->data[i] = (uint8_t)strtoul(byte, NULL, 16);
    }
    return 1;
}

/* Wait for the server's next message (up to 2 s) and check that it is `want`. */
static int expect(link_t *link, const char *want)
{
    char msg[128];
    uint32_t t0 = tick_ms(NULL);

    while (!next_message(link, msg, sizeof msg)) {
        if (link->closed || (uint32_t)(tick_ms(NULL) - t0) > 2000u) {
            fprintf(stderr, "socketcand: no < %s > from the server\n", want);
            return -1;
        }
        (void)receive(link, 10);
    }
    if (strcmp(msg, want) != 0 && !(msg[0] == ' ' && strncmp(msg + 1, want, strlen(want)) == 0)) {
        fprintf(stderr, "socketcand: expected < %s >, got <%s>\n", want, msg);
        return -1;
    }
    return 0;
}

typedef struct {
    dre_bus *bus;
    link_t *link;
} port_t;

static void pump(void *user, uint32_t ms)
{
    const port_t *port = (const port_t *)user;
    uint32_t t0 = tick_ms(NULL);
    char msg[128];
    dre_frame f;

    do {
        (void)receive(port->link, 1);
        while (next_message(port->link, msg, sizeof msg)) {
            if (parse_frame(msg, &f)) {
                (void)dre_bus_feed(port->bus, &f);
            }
        }
        dre_bus_poll(port->bus);
    } while ((uint32_t)(tick_ms(NULL) - t0) < ms && !port->link->closed);
}

static void print_line(void *user, const char *line)
{
    (void)user;
    printf("%s\n", line);
    fflush(stdout);
}

static int parse_ids(const char *text, uint8_t *ids, uint8_t cap, uint8_t *n)
{
    char *end;
    *n = 0u;
    for (;;) {
        long id = strtol(text, &end, 10);
        if (end == text || id < 1 || id > 63 || *n == cap) {
            return -1;
        }
        ids[(*n)++] = (uint8_t)id;
        if (*end == '\0') {
            return 0;
        }
        if (*end != ',') {
            return -1;
        }
        text = end + 1;
    }
}

int main(int argc, char **argv)
{
    static dre_request slots[8];
    static link_t link;
    struct sockaddr_in addr;
    dre_bus_config cfg;
    dre_tour_port tour;
    dre_bus bus;
    port_t port;
    uint8_t ids[4], n;
    long tcp_port;
    int one = 1, rc;

    if (argc != 4) {
        fprintf(stderr, "usage: %s HOST PORT ID[,ID...]   (e.g. 127.0.0.1 29536 1,2; up to 4 ids)\n", argv[0]);
        return 2;
    }
    tcp_port = strtol(argv[2], NULL, 10);
    memset(&addr, 0, sizeof addr);
    addr.sin_family = AF_INET;
    if (inet_pton(AF_INET, argv[1], &addr.sin_addr) != 1 || tcp_port < 1 || tcp_port > 65535) {
        fprintf(stderr, "%s: HOST must be an IPv4 address and PORT 1..65535\n", argv[0]);
        return 2;
    }
    if (parse_ids(argv[3], ids, 4u, &n) != 0) {
        fprintf(stderr, "%s: ids must be 1..63, up to 4, separated by commas: %s\n", argv[0], argv[3]);
        return 2;
    }
    addr.sin_port = htons((uint16_t)tcp_port);
    link.fd = socket(AF_INET, SOCK_STREAM, 0);
    if (link.fd < 0 || connect(link.fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        fprintf(stderr, "cannot reach socketcand at %s:%ld: %s\n", argv[1], tcp_port, strerror(errno));
        return 1;
    }
    (void)setsockopt(link.fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (expect(&link, "hi") != 0 || write_all(link.fd, "< open can0 >", 13u) != 0 || expect(&link, "ok") != 0 ||
        write_all(link.fd, "< rawmode >", 11u) != 0 || expect(&link, "ok") != 0) {
        close(link.fd);
        return 1;
    }
    printf("socketcand %s:%ld, can0, raw mode\n", argv[1], tcp_port);

    memset(&cfg, 0, sizeof cfg);
    cfg.send = send_frame;
    cfg.tick = tick_ms;
    cfg.user = &link;
    cfg.timeout_ms = 200u; /* frames cross TCP and the server's queue */
    if (dre_bus_init(&bus, &cfg, slots, 8u, NULL, 0u) != DRE_OK) {
        close(link.fd);
        return 1;
    }
    port.bus = &bus;
    port.link = &link;
    tour.bus = &bus;
    tour.pump = pump;
    tour.print = print_line;
    tour.user = &port;
    rc = dre_tour_run(&tour, n, ids);
    close(link.fd);
    return rc;
}
