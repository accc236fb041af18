/* uart0, the command port: a PL011 with its FIFO off (one holding register each way), bytes on
 * the wire at the programmed baud rate. The host's bytes come from the world (a wire, wire.h);
 * the bytes sent go to the world in one event per stretch.
 *
 * The firmware's handler reads and writes the PL011's registers directly (imsc, fr, dr): they
 * are plain memory here, set as the handler enters and read as it returns. */
#include "machine.h"
#include "peripherals.h"
#include "wire.h"

/* PL011 register bits (RP2040 datasheet, UART registers) */
#define IMSC_RXIM 0x10u                /* interrupt when a byte was received */
#define IMSC_TXIM 0x20u                /* interrupt when there is room to send */
#define FR_RXFE 0x10u                  /* nothing to read */
#define FR_TXFE 0x80u                  /* nothing waiting to be sent */
#define DR_UNTOUCHED 0xA5A50000u       /* a value no byte write can leave in dr */
#define DEFAULT_BYTE_NS 86806u         /* 115200 baud until uart_init says otherwise (rounded) */

static struct {
    uint64_t byte_ns;
    struct sil_wire rx;                /* the host's bytes on their way */
    int rx_full;                       /* the receive holding register has a byte */
    uint8_t rx_byte;
    int tx_busy, tx_irq, entered_rx;
    int entered_tx;                    /* a handler that saw room to send has not returned yet */
    uint64_t tx_done;
    uint8_t tx_byte;
} command_port = {.byte_ns = DEFAULT_BYTE_NS};

uart_hw_t sil_uart_hw[2];

uint uart_init(uart_inst_t *uart, uint baudrate) {
    if (uart == uart0 && baudrate) command_port.byte_ns = SIL_NS_PER_BYTE_AT_1_BAUD / baudrate;
    return baudrate;
}

void uart_set_fifo_enabled(uart_inst_t *uart, bool enabled) { (void)uart; (void)enabled; }

/* ---- to the host ------------------------------------------------------------------------ */
/* One event per stretch (its time is the last byte's): one a byte would cost the world more
 * than the firmware. */
static uint8_t host_out[4096];
static uint16_t host_out_count;
static uint64_t host_out_t;

void sil_uart_flush_output(void) {
    if (host_out_count == 0) return;
    sil_world->host_bytes(host_out_t, host_out, host_out_count);
    host_out_count = 0;
}

static void host_out_add(uint64_t t, uint8_t byte) {
    if (host_out_count == sizeof host_out) sil_uart_flush_output();
    host_out[host_out_count++] = byte;
    host_out_t = t;
}

/* Bit 0: nothing is leaving on the command port (no byte on the wire, no send request the
 * handler has yet to see); bit 1: no byte from the host is on its way or unread. The world
 * reads it at each yield to let a TX ring drain no longer than it takes (fuzz pauses). */
uint8_t sil_uart_host_status(void) {
    /* A stop may come inside the handler (time moves there): one that saw room to send may
     * still write the next byte of the ring, so the port is not at rest until it returns. */
    uint8_t tx_idle = !command_port.tx_busy && !command_port.tx_irq && !command_port.entered_tx;
    uint8_t rx_idle = sil_wire_next(&command_port.rx) == UINT64_MAX && !command_port.rx_full;
    return (uint8_t)(tx_idle | rx_idle << 1);
}

/* ---- from the host ---------------------------------------------------------------------- */
void sil_uart_host_bytes(uint64_t t, const uint8_t *bytes, uint16_t count) {
    uint32_t baud = (uint32_t)(SIL_NS_PER_BYTE_AT_1_BAUD / command_port.byte_ns);
    sil_wire_push(&command_port.rx, t, baud, bytes, count);
}

/* ---- events and the interrupt ----------------------------------------------------------- */
static uint64_t next_event(void) {
    uint64_t t = sil_wire_next(&command_port.rx);
    if (command_port.tx_busy && command_port.tx_done < t) t = command_port.tx_done;
    return t;
}

static void run_events(void) {
    while (sil_wire_next(&command_port.rx) <= sil_now) {
        uint8_t byte = sil_wire_take(&command_port.rx, NULL);
        if (!command_port.rx_full) {       /* else overrun: the new byte is lost */
            command_port.rx_full = 1;
            command_port.rx_byte = byte;
        }
        sil_touch();
    }
    if (command_port.tx_busy && command_port.tx_done <= sil_now) {
        host_out_add(command_port.tx_done, command_port.tx_byte);
        command_port.tx_busy = 0;
        command_port.tx_irq = 1;
        sil_touch();
    }
}

static int irq_level(uint num) {
    if (num != UART0_IRQ) return 0;
    uint32_t imsc = sil_uart_hw[0].imsc;
    return (command_port.rx_full && (imsc & IMSC_RXIM)) || (command_port.tx_irq && (imsc & IMSC_TXIM));
}

/* A pending UART interrupt set by software is a request to look at the transmitter: it is
 * kept as the transmit condition, so a receive-only call of the handler cannot swallow it. */
static int irq_pend(uint num) {
    if (num != UART0_IRQ) return 0;
    command_port.tx_irq = 1;
    return 1;
}

/* The PL011's flag register says either "a byte to read" or "room to send", never both in
 * one call, so a handler's read of dr and write of dr can be told apart (both are plain
 * memory here). */
static void irq_enter(uint num) {
    if (num != UART0_IRQ) return;
    uart_hw_t *hw = &sil_uart_hw[0];
    /* The handler reads the flags and the data register as it enters, so what it sees is
     * taken now: time moves inside a handler, and a byte that arrives or finishes sending
     * meanwhile raises the interrupt again, as the PL011's levels do. Cleared at the exit
     * instead, such an interrupt was lost: a received byte dropped as an overrun, or the rest
     * of the TX ring left unsent until the firmware queued another byte. */
    command_port.entered_rx = command_port.rx_full && (hw->imsc & IMSC_RXIM);
    if (command_port.entered_rx) {
        command_port.rx_full = 0;          /* the holding register is read */
        SIL_SET_REG(hw->fr) = 0;                       /* RX not empty; TX not empty */
        SIL_SET_REG(hw->dr) = command_port.rx_byte;
    } else {
        command_port.tx_irq = 0;
        command_port.entered_tx = !command_port.tx_busy;
        SIL_SET_REG(hw->fr) = (command_port.tx_busy ? 0u : FR_TXFE) | FR_RXFE;
        SIL_SET_REG(hw->dr) = DR_UNTOUCHED;
    }
}

static void irq_exit(uint num) {
    if (num != UART0_IRQ) return;
    uart_hw_t *hw = &sil_uart_hw[0];
    if (command_port.entered_rx) return;
    command_port.entered_tx = 0;
    uint32_t dr = hw->dr;
    if (dr != DR_UNTOUCHED && !command_port.tx_busy) {   /* the handler wrote a byte to send */
        command_port.tx_byte = (uint8_t)dr;
        command_port.tx_busy = 1;
        command_port.tx_done = sil_now + command_port.byte_ns;
    } else if (!command_port.tx_busy && !command_port.tx_irq && sil_yields_on_host_idle()) {
        sil_request_yield();                           /* the answer is complete for now */
    }
}

const struct sil_peripheral sil_uart_peripheral = {
    .next_event = next_event,
    .run_events = run_events,
    .irq_level = irq_level,
    .irq_pend = irq_pend,
    .irq_enter = irq_enter,
    .irq_exit = irq_exit,
};
