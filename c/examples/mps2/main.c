/*
 * The library's tour (examples/tour/) as bare-metal firmware for an MPS2
 * board (qemu-system-arm -M mps2-an386, Cortex-M4; mps2-an385, Cortex-M3).
 *
 * UART0 is the link to the bus: the USB-CAN adapter's 0xAA frames, encoded in
 * the send callback and decoded byte by byte in the UART0 receive interrupt,
 * which pushes each frame into the bus's receive queue (dre_bus_isr_push). The
 * main loop polls the bus; SysTick counts milliseconds. UART1 prints the tour's
 * lines. At the end the firmware leaves qemu through semihosting: exit status
 * 0 when the tour passed. Run against the simulator's adapter pty:
 *
 *     drempower sim --ids 1,2 --adapter-pty      (prints the pty)
 *     qemu-system-arm -M mps2-an386 -display none -monitor none -serial PTY -serial stdio \
 *         -semihosting-config enable=on,target=native -kernel tour_mps2_an386.elf
 */
#include <stdint.h>

#include "drempower/dre.h"
#include "tour/tour.h"

#define SYSCLK_HZ 25000000u /* the MPS2 boards' system clock */
#define LINK_BAUD 115200u   /* qemu does not pace the UART; a real link would */

/* CMSDK APB UART registers (ARM DDI 0479) */
typedef struct {
    volatile uint32_t data;
    volatile uint32_t state; /* bit 0 TX full, bit 1 RX full */
    volatile uint32_t ctrl;  /* bit 0 TX enable, 1 RX enable, 2 TX interrupt, 3 RX interrupt */
    volatile uint32_t intstatus; /* write 1 to clear: bit 0 TX, bit 1 RX */
    volatile uint32_t bauddiv;
} cmsdk_uart;

#define UART0 ((cmsdk_uart *)0x40004000u)
#define UART1 ((cmsdk_uart *)0x40005000u)
#define UART_TX_FULL 1u
#define UART_RX_FULL 2u
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define NVIC_ISER0 (*(volatile uint32_t *)0xE000E100u)

#define IDS 2u
static const uint8_t ids[IDS] = {1u, 2u};

static volatile uint32_t ticks;
static dre_bus bus;
static dre_request slots[8];
static dre_frame rx_queue[32];
static dre_aa_decoder rx_dec; /* the receive interrupt's alone */

void systick_handler(void);
void uart0_rx_handler(void);

void systick_handler(void)
{
    ticks++;
}

void uart0_rx_handler(void)
{
    /* clear first, then drain: a byte that arrives after the last check raises the interrupt again */
    UART0->intstatus = 2u;
    while ((UART0->state & UART_RX_FULL) != 0u) {
        dre_aa_frame af;
        dre_frame f;
        if (dre_aa_push(&rx_dec, (uint8_t)UART0->data, &af) && dre_aa_to_frame(&af, &f) == DRE_OK) {
            (void)dre_bus_isr_push(&bus, &f);
        }
    }
}

static void uart_put(cmsdk_uart *u, uint8_t b)
{
    while ((u->state & UART_TX_FULL) != 0u) {
    }
    u->data = b;
}

static int send_frame(void *user, const dre_frame *f)
{
    uint8_t out[DRE_AA_CAN_LEN];
    size_t n = dre_aa_encode(f, out), i;
    (void)user;
    for (i = 0u; i < n; i++) {
        uart_put(UART0, out[i]);
    }
    return n == 0u ? -1 : 0;
}

static uint32_t tick_ms(void *user)
{
    (void)user;
    return ticks;
}

static void pump(void *user, uint32_t ms)
{
    uint32_t t0 = ticks;
    (void)user;
    for (;;) {
        dre_bus_poll(&bus);
        if ((uint32_t)(ticks - t0) >= ms) {
            return;
        }
        __asm volatile("wfi"); /* the next tick or received byte */
    }
}

static void print_line(void *user, const char *line)
{
    (void)user;
    while (*line != '\0') {
        uart_put(UART1, (uint8_t)*line++);
    }
    uart_put(UART1, '\n');
}

/* Semihosting SYS_EXIT: qemu exits 0 for ADS_Stopped_ApplicationExit, 1 otherwise. */
static void semihost_exit(int ok)
{
    register uint32_t r0 __asm("r0") = 0x18u;
    register uint32_t r1 __asm("r1") = ok ? 0x20026u : 0x20023u;
    __asm volatile("bkpt 0xAB" : : "r"(r0), "r"(r1) : "memory");
}

int main(void)
{
    dre_bus_config cfg = {0};
    dre_tour_port tour;
    int rc;

    UART1->bauddiv = SYSCLK_HZ / LINK_BAUD;
    UART1->ctrl = 1u;
    UART0->bauddiv = SYSCLK_HZ / LINK_BAUD;
    dre_aa_init(&rx_dec);
    cfg.send = send_frame;
    cfg.tick = tick_ms;
    cfg.timeout_ms = 250u; /* the simulator, a Python process, may answer late on a busy host */
    cfg.retries = 2u;
    if (dre_bus_init(&bus, &cfg, slots, 8u, rx_queue, 32u) != DRE_OK) {
        print_line(NULL, "FAIL 0: dre_bus_init");
        semihost_exit(0);
    }
    SYST_RVR = SYSCLK_HZ / 1000u - 1u;
    SYST_CVR = 0u;
    SYST_CSR = 7u; /* processor clock, interrupt, enable */
    UART0->ctrl = 1u | 2u | 8u; /* TX, RX, RX interrupt */
    NVIC_ISER0 = 1u;            /* IRQ 0: UART0 receive */
#if defined(__ARM_ARCH_7EM__)
    print_line(NULL, "mps2: Cortex-M4, 0xAA link on UART0");
#else
    print_line(NULL, "mps2: Cortex-M3, 0xAA link on UART0");
#endif
    tour.bus = &bus;
    tour.pump = pump;
    tour.print = print_line;
    tour.user = NULL;
    rc = dre_tour_run(&tour, IDS, ids);
    if (rc != 0) {
        char line[64] = "link: ";
        size_t n = 6u;
        uint32_t v = rx_dec.dropped, div = 1000000000u;
        while (div > 1u && v / div == 0u) {
            div /= 10u;
        }
        for (; div > 0u; div /= 10u) {
            line[n++] = (char)('0' + (v / div) % 10u);
        }
        line[n] = '\0';
        print_line(NULL, line);
        print_line(NULL, "bytes dropped by the 0xAA decoder");
    }
    semihost_exit(rc == 0);
    return rc;
}
