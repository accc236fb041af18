/* The RP2040 peripherals a Build HAT firmware uses, modelled at the level the firmware sees:
 *
 * - uart0, the command port: a PL011 with its FIFO off (one holding register each way), bytes
 *   on the wire at the programmed baud rate; the host's bytes come from the world.
 * - PIO state machines running an 8N1 UART program (which one is known from the program's
 *   text): 4-word FIFOs, the FIFO-level interrupt flags, bytes at the rate the state
 *   machine's clock divider gives; the device's bytes come from the world.
 * - GPIO: direction, output, pulls; the ID lines and fault pins as the world sets them.
 * - I2C: the four ports' motor drivers (a register file; drive, faults and ID pins behind
 *   it) and the accelerometer, at 400 kHz bus time.
 * - ADC: the input voltage the world sets.
 *
 * Register writes the firmware makes directly (inte0, clkdiv, imsc, ...) are plain memory;
 * they are read here when they matter. Frames to the world: sil/frames.py.
 */
#include "sil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#define CLK_SYS_HZ 125000000u
#define I2C_NS_PER_BYTE 22500u         /* 9 bits at 400 kHz */
#define DR_UNTOUCHED 0xA5A50000u       /* a value no byte write can leave in uart dr */
#define SIG_NONE 0x0CC0u               /* what an empty port's ID lines read (devices.json) */

uart_hw_t sil_uart_hw[2];
pio_hw_t sil_pio_hw[2];
i2c_inst_t sil_i2c[2] = {{0}, {1}};
adc_hw_t sil_adc_hw;

#define W32(reg) (*(volatile uint32_t *)&(reg))   /* write a register the firmware only reads */

/* ---- bytes on a wire, each with its arrival time -------------------------------------- */
struct wire {
    uint8_t *b;
    uint64_t *t;
    uint32_t *baud;
    size_t head, tail, cap;
    uint64_t free_at;                  /* when the sender's next byte can start */
};

static void wire_push(struct wire *w, uint64_t start, uint32_t baud, const uint8_t *b, uint16_t n) {
    if (baud == 0) baud = 115200;
    uint64_t byte_ns = 10ull * 1000000000ull / baud;
    if (start < sil_now) start = sil_now;          /* nothing arrives in the past */
    if (start < w->free_at) start = w->free_at;
    for (uint16_t i = 0; i < n; i++) {
        if (w->tail == w->cap) {
            if (w->head > 0) {                         /* slide down before growing */
                size_t live = w->tail - w->head;
                memmove(w->b, w->b + w->head, live);
                memmove(w->t, w->t + w->head, live * sizeof *w->t);
                memmove(w->baud, w->baud + w->head, live * sizeof *w->baud);
                w->head = 0;
                w->tail = live;
            }
            if (w->tail == w->cap) {
                w->cap = w->cap ? w->cap * 2 : 256;
                w->b = realloc(w->b, w->cap);
                w->t = realloc(w->t, w->cap * sizeof *w->t);
                w->baud = realloc(w->baud, w->cap * sizeof *w->baud);
                if (!w->b || !w->t || !w->baud) abort();
            }
        }
        start += byte_ns;
        w->b[w->tail] = b[i];
        w->t[w->tail] = start;
        w->baud[w->tail] = baud;
        w->tail++;
    }
    w->free_at = start;
}

static uint64_t wire_next(const struct wire *w) { return w->head < w->tail ? w->t[w->head] : UINT64_MAX; }

/* ---- command-port UART ---------------------------------------------------------------- */
static struct {
    uint64_t byte_ns;
    struct wire rx;
    int rx_full;                       /* the receive holding register has a byte */
    uint8_t rx_byte;
    int tx_busy, tx_irq, entered_rx;
    int entered_tx;                    /* a handler that saw room to send has not returned yet */
    uint64_t tx_done;
    uint8_t tx_byte;
} cu = {.byte_ns = 86806};

uint uart_init(uart_inst_t *uart, uint baudrate) {
    if (uart == uart0 && baudrate) cu.byte_ns = 10ull * 1000000000ull / baudrate;
    return baudrate;
}

void uart_set_fifo_enabled(uart_inst_t *uart, bool enabled) { (void)uart; (void)enabled; }

/* Bytes to the host go to the world in one frame per stretch (the frame's time is the last
 * byte's): one frame a byte would cost the world more than the firmware. */
static uint8_t host_out[4096];
static uint16_t host_out_n;
static uint64_t host_out_t;

void periph_flush_output(void) {
    if (host_out_n == 0) return;
    link_emit('h', 0, host_out_t, host_out, host_out_n);
    host_out_n = 0;
}

static void host_out_add(uint64_t t, uint8_t b) {
    if (host_out_n == sizeof host_out) periph_flush_output();
    host_out[host_out_n++] = b;
    host_out_t = t;
}

/* Bit 0: nothing is leaving on the command port (no byte on the wire, no send request the
 * handler has yet to see); bit 1: no byte from the host is on its way or unread. The world
 * reads it at each yield to let a TX ring drain no longer than it takes (fuzz pauses). */
uint8_t periph_host_status(void) {
    /* A stop may come inside the handler (time moves there): one that saw room to send may
     * still write the next byte of the ring, so the port is not at rest until it returns. */
    uint8_t tx_idle = !cu.tx_busy && !cu.tx_irq && !cu.entered_tx;
    uint8_t rx_idle = wire_next(&cu.rx) == UINT64_MAX && !cu.rx_full;
    return (uint8_t)(tx_idle | rx_idle << 1);
}

void periph_host_bytes(uint64_t t, const uint8_t *b, uint16_t n) {
    wire_push(&cu.rx, t, (uint32_t)(10ull * 1000000000ull / cu.byte_ns), b, n);
}

/* ---- PIO ------------------------------------------------------------------------------ */
struct sm {
    int kind, port, enabled;
    uint32_t txf[4], rxf[4];
    int txn, rxn;
    int shifting;
    uint64_t shift_done;
    uint8_t shift_byte;
    uint32_t shift_baud;
};
static struct sm sms[2][4];
static struct wire port_rx[SIL_PORTS];
static uint8_t pio_kinds[2][32];        /* program kind by load offset */
static uint32_t pio_used[2];

static int pio_index(PIO pio) { return pio == pio1 ? 1 : 0; }

static uint32_t sm_baud(int pi, int s) {
    uint32_t reg = sil_pio_hw[pi].sm[s].clkdiv;
    double div = reg ? reg / 65536.0 : 65536.0;     /* 16.8 fixed point in bits 31..8 */
    if (div < 1.0) div = 1.0;
    return (uint32_t)(CLK_SYS_HZ / (8.0 * div) + 0.5);   /* the UART programs take 8 cycles a bit */
}

static void sm_start_shift(int pi, int s) {
    struct sm *m = &sms[pi][s];
    if (m->shifting || m->txn == 0 || !m->enabled) return;
    m->shift_byte = (uint8_t)m->txf[0];
    memmove(m->txf, m->txf + 1, 3 * sizeof m->txf[0]);
    m->txn--;
    m->shift_baud = sm_baud(pi, s);
    m->shift_done = sil_now + 10ull * 1000000000ull / m->shift_baud;
    m->shifting = 1;
}

pio_sm_config sil_pio_default_config(uint offset) {
    pio_sm_config c;
    memset(&c, 0, sizeof c);
    c.clkdiv = 1u << 16;
    c.out_pin = c.in_pin = -1;
    (void)offset;                      /* the generated header sets the kind */
    return c;
}
void sm_config_set_out_shift(pio_sm_config *c, bool r, bool a, uint th) { (void)c; (void)r; (void)a; (void)th; }
void sm_config_set_in_shift(pio_sm_config *c, bool r, bool a, uint th) { (void)c; (void)r; (void)a; (void)th; }
void sm_config_set_out_pins(pio_sm_config *c, uint base, uint count) { (void)count; c->out_pin = (int)base; }
void sm_config_set_sideset_pins(pio_sm_config *c, uint base) { (void)c; (void)base; }
void sm_config_set_in_pins(pio_sm_config *c, uint base) { c->in_pin = (int)base; }
void sm_config_set_jmp_pin(pio_sm_config *c, uint pin) { (void)c; (void)pin; }
void sm_config_set_clkdiv(pio_sm_config *c, float div) {
    uint32_t whole = (uint32_t)div;
    uint32_t frac = (uint32_t)((div - (float)whole) * 256.0f);
    c->clkdiv = (whole << 16) | (frac << 8);
}

int pio_add_program(PIO pio, const pio_program_t *program) {
    int pi = pio_index(pio), len = program->length ? program->length : 1;
    for (int off = 32 - len; off >= 0; off--) {          /* the SDK fills from the top */
        uint32_t mask = (len >= 32 ? 0xffffffffu : ((1u << len) - 1u)) << off;
        if (pio_used[pi] & mask) continue;
        pio_used[pi] |= mask;
        pio_kinds[pi][off] = program->sil_kind;
        return off;
    }
    fprintf(stderr, "sil: PIO%d program memory full\n", pi);
    abort();
}

void pio_clear_instruction_memory(PIO pio) { pio_used[pio_index(pio)] = 0; }

int pio_sm_init(PIO pio, uint s, uint initial_pc, const pio_sm_config *config) {
    int pi = pio_index(pio);
    struct sm *m = &sms[pi][s & 3];
    memset(m, 0, sizeof *m);
    m->kind = config->kind ? config->kind : pio_kinds[pi][initial_pc & 31];
    int pin = m->kind == SIL_PIO_UART_TX ? config->out_pin : config->in_pin;
    m->port = pin >= 0 ? board_port_of_pin((uint)pin, NULL) : -1;
    sil_pio_hw[pi].sm[s & 3].clkdiv = config->clkdiv;
    sil_touch();
    return 0;
}

void pio_sm_set_enabled(PIO pio, uint s, bool on) {
    int pi = pio_index(pio);
    struct sm *m = &sms[pi][s & 3];
    if (m->enabled == (int)on) return;
    m->enabled = on;
    sil_touch();
    if (m->kind == SIL_PIO_UART_RX && m->port >= 0) {
        uint8_t msg[5] = {(uint8_t)on};
        uint32_t baud = sm_baud(pi, (int)(s & 3));
        memcpy(msg + 1, &baud, 4);
        link_emit('u', (uint8_t)m->port, sil_now, msg, sizeof msg);
        if (!on) { m->rxn = 0; }
        sil_request_yield();           /* a device starts or stops talking */
    }
    if (on) sm_start_shift(pi, (int)(s & 3));
    sil_wake();
}

void pio_sm_set_pins_with_mask(PIO p, uint s, uint32_t v, uint32_t m) { (void)p; (void)s; (void)v; (void)m; }
void pio_sm_set_pindirs_with_mask(PIO p, uint s, uint32_t d, uint32_t m) { (void)p; (void)s; (void)d; (void)m; }
int pio_sm_set_consecutive_pindirs(PIO p, uint s, uint b, uint c, bool o) {
    (void)p; (void)s; (void)b; (void)c; (void)o;
    return 0;
}
void gpio_set_function(uint gpio, enum gpio_function fn);
void pio_gpio_init(PIO pio, uint pin) { gpio_set_function(pin, pio == pio1 ? GPIO_FUNC_PIO1 : GPIO_FUNC_PIO0); }

bool pio_sm_is_tx_fifo_full(PIO pio, uint s) { return sms[pio_index(pio)][s & 3].txn >= 4; }
bool pio_sm_is_tx_fifo_empty(PIO pio, uint s) { return sms[pio_index(pio)][s & 3].txn == 0; }
bool pio_sm_is_rx_fifo_full(PIO pio, uint s) { return sms[pio_index(pio)][s & 3].rxn >= 4; }

/* A firmware reads the RX FIFO register right after it saw the FIFO not empty: the word
 * is moved into rxf[] at that moment (the register read itself is invisible here). */
bool pio_sm_is_rx_fifo_empty(PIO pio, uint s) {
    int pi = pio_index(pio);
    struct sm *m = &sms[pi][s & 3];
    if (m->rxn == 0) return true;
    W32(sil_pio_hw[pi].rxf[s & 3]) = m->rxf[0];
    memmove(m->rxf, m->rxf + 1, 3 * sizeof m->rxf[0]);
    m->rxn--;
    sil_touch();
    return false;
}

uint32_t pio_sm_get(PIO pio, uint s) {
    pio_sm_is_rx_fifo_empty(pio, s);
    return sil_pio_hw[pio_index(pio)].rxf[s & 3];
}

uint32_t pio_sm_get_blocking(PIO pio, uint s) {
    while (sms[pio_index(pio)][s & 3].rxn == 0) sil_spend(1000);
    return pio_sm_get(pio, s);
}

void pio_sm_put(PIO pio, uint s, uint32_t data) {
    int pi = pio_index(pio);
    struct sm *m = &sms[pi][s & 3];
    if (m->txn >= 4) return;                       /* the hardware drops a put to a full FIFO */
    m->txf[m->txn++] = data;
    sil_touch();
    sm_start_shift(pi, (int)(s & 3));
    sil_wake();
}

void pio_sm_put_blocking(PIO pio, uint s, uint32_t data) {
    while (pio_sm_is_tx_fifo_full(pio, s)) sil_spend(1000);
    pio_sm_put(pio, s, data);
}

void periph_port_bytes(int port, uint64_t t, uint32_t baud, const uint8_t *b, uint16_t n) {
    if (port >= 0 && port < SIL_PORTS) wire_push(&port_rx[port], t, baud, b, n);
}

void periph_port_cut(int port, uint64_t t) {
    if (port < 0 || port >= SIL_PORTS) return;
    struct wire *w = &port_rx[port];
    while (w->head < w->tail && w->t[w->head] <= t) w->head++;   /* bytes already sent stay */
    w->tail = w->head;
    w->free_at = t;
}

/* A byte from a device reaches the port's receiving state machine; a baud rate more than
 * 5 % off what it listens at gives no byte (a real UART would see framing errors). A fifth
 * byte before the firmware has read any is lost, as on the chip, which says nothing; here the
 * world is told ('r'), so a device message the firmware never saw is not a mystery. */
static void port_byte_arrives(int port, uint8_t b, uint32_t baud) {
    for (int pi = 0; pi < 2; pi++) {
        for (int s = 0; s < 4; s++) {
            struct sm *m = &sms[pi][s];
            if (m->kind != SIL_PIO_UART_RX || m->port != port || !m->enabled) continue;
            uint32_t want = sm_baud(pi, s);
            uint32_t diff = want > baud ? want - baud : baud - want;
            if (diff * 20 > want) return;
            if (m->rxn < 4) m->rxf[m->rxn++] = (uint32_t)b << 24;   /* shifted in from the right */
            else link_emit('r', (uint8_t)port, sil_now, &b, 1);
            sil_touch();
            return;
        }
    }
}

/* ---- GPIO ----------------------------------------------------------------------------- */
#define NPINS 30
static struct { uint8_t out_dir, out, pull, func; } pins[NPINS];   /* pull: 0 none, 1 up, 2 down */
static struct { uint16_t signature; uint8_t rx_idle; } ids[SIL_PORTS];
static uint8_t portfault_ok = 1, motorfault_ok = 1, leds_seen = 0xff;

void gpio_init(uint g) {
    if (g >= NPINS) return;
    pins[g].out_dir = 0;
    pins[g].out = 0;
    pins[g].func = GPIO_FUNC_SIO;
    sil_touch();
}

void gpio_set_dir(uint g, bool out) {
    if (g < NPINS && pins[g].out_dir != out) { pins[g].out_dir = out; sil_touch(); }
}

static void leds_changed(void) {
    uint8_t bits = (uint8_t)((pins[board_pin_led0].out ? 1 : 0) | (pins[board_pin_led1].out ? 2 : 0));
    if (bits == leds_seen) return;
    leds_seen = bits;
    link_emit('l', 0, sil_now, &bits, 1);
}

void gpio_put(uint g, bool v) {
    if (g >= NPINS || pins[g].out == v) return;
    pins[g].out = v;
    sil_touch();
    if (g == board_pin_poweron) {
        uint8_t on = v;
        link_emit('o', 0, sil_now, &on, 1);
        sil_request_yield();
    } else if (g == board_pin_led0 || g == board_pin_led1) {
        leds_changed();
    }
}

void gpio_pull_up(uint g) { if (g < NPINS) { pins[g].pull = 1; sil_touch(); } }
void gpio_pull_down(uint g) { if (g < NPINS) { pins[g].pull = 2; sil_touch(); } }
void gpio_disable_pulls(uint g) { if (g < NPINS) { pins[g].pull = 0; sil_touch(); } }
void gpio_set_function(uint g, enum gpio_function fn) { if (g < NPINS) { pins[g].func = (uint8_t)fn; sil_touch(); } }

bool gpio_get(uint g) {
    if (g >= NPINS) return false;
    if (pins[g].out_dir && pins[g].func == GPIO_FUNC_SIO) return pins[g].out;
    if (g == board_pin_portfault) return portfault_ok;
    if (g == board_pin_motorfault) return motorfault_ok;
    int is_tx = 0, port = board_port_of_pin(g, &is_tx);
    if (port >= 0 && !is_tx && ids[port].rx_idle == 0) return false;   /* the device holds the line low */
    return pins[g].pull != 2;
}

/* The ID lines (connector pins 5 and 6) as the port's driver reads them. A device's
 * signature word holds, for each of the eight ways the firmware may bias the UART lines
 * (one line floating, the other driven low, pulled down, driven high or pulled up; RX then
 * TX), pin 5 in the low byte and pin 6 in the high byte. */
static int line_bias(uint g) {
    if (pins[g].out_dir && pins[g].func == GPIO_FUNC_SIO) return pins[g].out ? 2 : 0;
    if (pins[g].pull == 1) return 3;
    if (pins[g].pull == 2) return 1;
    return -1;
}

static uint8_t id_pins(int port, uint tx, uint rx) {
    int bt = line_bias(tx), br = line_bias(rx), k;
    if (bt < 0 && br >= 0) k = br;
    else if (br < 0 && bt >= 0) k = 4 + bt;
    else return 0;
    uint16_t sig = ids[port].signature;
    return (uint8_t)((((sig >> k) & 1) << 6) | (((sig >> (8 + k)) & 1) << 7));
}

void periph_set_id(int port, uint16_t signature, uint8_t rx_idle_level) {
    if (port < 0 || port >= SIL_PORTS) return;
    ids[port].signature = signature;
    ids[port].rx_idle = rx_idle_level;
    sil_touch();
}

void periph_set_fault_pins(uint8_t port_ok, uint8_t motor_ok) {
    portfault_ok = port_ok;
    motorfault_ok = motor_ok;
    sil_touch();
}

/* ---- I2C: motor drivers and the accelerometer ------------------------------------------ */
#define ACCEL_ADDR 0x6a
static uint8_t regs[SIL_PORTS][256], reg_ptr[SIL_PORTS], fault_regs[SIL_PORTS][3];
static int16_t drive_seen[SIL_PORTS];
/* Ports whose drive changes stop the firmware at once ('W'): a motor's shaft or a device that
 * reacts to its power must see the change as it happens; a light or an empty port only needs
 * the frame, with its time, at the next stop (a ramp changes the duty every millisecond). */
static uint8_t drive_stops = 0xff;

void periph_set_drive_stops(uint8_t mask) { drive_stops = mask; }
static uint8_t drive_mode_seen[SIL_PORTS];   /* 0 coast (outputs off), 1 driven */
static uint port_tx_pin[SIL_PORTS], port_rx_pin[SIL_PORTS];

void periph_set_fault_regs(int port, const uint8_t *r3) {
    if (port >= 0 && port < SIL_PORTS) memcpy(fault_regs[port], r3, 3);
}

/* Drive as the driver's flag register (0x4C: outputs on, direction) and duty (0xA1) set it. */
static void drive_changed(int p) {
    uint8_t flags = regs[p][0x4C];
    int on = (flags & 0x1F) == 0x1F;
    int16_t duty = on ? (int16_t)((flags & 0x20) ? regs[p][0xA1] : -(int)regs[p][0xA1]) : 0;
    uint8_t mode = (uint8_t)on;
    if (duty == drive_seen[p] && mode == drive_mode_seen[p]) return;
    drive_seen[p] = duty;
    drive_mode_seen[p] = mode;
    uint8_t msg[3];
    memcpy(msg, &duty, 2);
    msg[2] = mode;
    link_emit('d', (uint8_t)p, sil_now, msg, sizeof msg);
    if (drive_stops & (1u << p)) sil_request_yield();
}

static void driver_write(int p, uint8_t r, uint8_t v) {
    regs[p][r] = v;
    if (r == 0xF5 && (v & 1)) {                       /* soft reset */
        memset(regs[p], 0, sizeof regs[p]);
        drive_changed(p);
    } else if (r == 0x4C) {
        if ((v & 0x0F) == 0) link_emit('f', (uint8_t)p, sil_now, NULL, 0);   /* faults cleared */
        drive_changed(p);
    } else if (r == 0xA1) {
        drive_changed(p);
    }
}

static uint8_t driver_read(int p, uint8_t r) {
    if (r == 0x4B) return id_pins(p, port_tx_pin[p], port_rx_pin[p]);
    if (r >= 0x4D && r <= 0x4F) return fault_regs[p][r - 0x4D];
    return regs[p][r];
}

uint i2c_init(i2c_inst_t *i2c, uint baudrate) { (void)i2c; sil_touch(); return baudrate; }
void i2c_deinit(i2c_inst_t *i2c) { (void)i2c; sil_touch(); }

int i2c_write_timeout_us(i2c_inst_t *i2c, uint8_t addr, const uint8_t *src, size_t len, bool nostop,
                         uint timeout_us) {
    (void)nostop; (void)timeout_us;
    sil_touch();
    sil_spend((uint64_t)(len + 1) * I2C_NS_PER_BYTE);
    int p = board_port_of_driver(i2c->bus, addr);
    if (p < 0) return (i2c->bus == 0 && addr == ACCEL_ADDR) ? (int)len : PICO_ERROR_GENERIC;
    if (len == 0) return 0;
    reg_ptr[p] = src[0];
    for (size_t i = 1; i < len; i++) driver_write(p, reg_ptr[p]++, src[i]);
    return (int)len;
}

int i2c_read_timeout_us(i2c_inst_t *i2c, uint8_t addr, uint8_t *dst, size_t len, bool nostop,
                        uint timeout_us) {
    (void)nostop; (void)timeout_us;
    sil_touch();
    sil_spend((uint64_t)(len + 1) * I2C_NS_PER_BYTE);
    int p = board_port_of_driver(i2c->bus, addr);
    if (p < 0) {
        if (i2c->bus != 0 || addr != ACCEL_ADDR) return PICO_ERROR_GENERIC;
        memset(dst, 0, len);
        return (int)len;
    }
    for (size_t i = 0; i < len; i++) dst[i] = driver_read(p, reg_ptr[p]++);
    return (int)len;
}

int i2c_write_blocking(i2c_inst_t *i2c, uint8_t a, const uint8_t *s, size_t n, bool ns) {
    return i2c_write_timeout_us(i2c, a, s, n, ns, 0);
}
int i2c_read_blocking(i2c_inst_t *i2c, uint8_t a, uint8_t *d, size_t n, bool ns) {
    return i2c_read_timeout_us(i2c, a, d, n, ns, 0);
}

/* ---- ADC, clocks, resets -------------------------------------------------------------- */
void adc_init(void) {}
void adc_gpio_init(uint gpio) { (void)gpio; }
void adc_select_input(uint input) { (void)input; }
uint16_t adc_read(void) { return (uint16_t)sil_adc_hw.result; }
void periph_set_adc(uint16_t raw) { W32(sil_adc_hw.result) = raw; }

uint32_t clock_get_hz(enum clock_index clk) { return clk == clk_usb || clk == clk_adc ? 48000000u : CLK_SYS_HZ; }
void reset_block(uint32_t bits) { (void)bits; }
void unreset_block(uint32_t bits) { (void)bits; }
void unreset_block_wait(uint32_t bits) { (void)bits; }

/* ---- events and interrupt sources ----------------------------------------------------- */
uint64_t periph_next_event(void) {
    uint64_t t = wire_next(&cu.rx);
    if (cu.tx_busy && cu.tx_done < t) t = cu.tx_done;
    for (int p = 0; p < SIL_PORTS; p++) {
        uint64_t w = wire_next(&port_rx[p]);
        if (w < t) t = w;
    }
    for (int pi = 0; pi < 2; pi++)
        for (int s = 0; s < 4; s++)
            if (sms[pi][s].shifting && sms[pi][s].shift_done < t) t = sms[pi][s].shift_done;
    return t;
}

void periph_run_events(void) {
    while (wire_next(&cu.rx) <= sil_now) {
        struct wire *w = &cu.rx;
        if (!cu.rx_full) {                             /* else overrun: the new byte is lost */
            cu.rx_full = 1;
            cu.rx_byte = w->b[w->head];
        }
        w->head++;
        sil_touch();
    }
    if (cu.tx_busy && cu.tx_done <= sil_now) {
        host_out_add(cu.tx_done, cu.tx_byte);
        cu.tx_busy = 0;
        cu.tx_irq = 1;
        sil_touch();
    }
    for (int p = 0; p < SIL_PORTS; p++) {
        struct wire *w = &port_rx[p];
        while (wire_next(w) <= sil_now) {
            port_byte_arrives(p, w->b[w->head], w->baud[w->head]);
            w->head++;
        }
    }
    for (int pi = 0; pi < 2; pi++) {
        for (int s = 0; s < 4; s++) {
            struct sm *m = &sms[pi][s];
            if (!m->shifting || m->shift_done > sil_now) continue;
            uint8_t msg[5];
            memcpy(msg, &m->shift_baud, 4);
            msg[4] = m->shift_byte;
            link_emit('p', (uint8_t)(m->port < 0 ? 0xff : m->port), m->shift_done, msg, sizeof msg);
            m->shifting = 0;
            sil_touch();
            sm_start_shift(pi, s);
            if (!m->shifting) sil_request_yield();     /* a whole message is out: the device reacts */
        }
    }
}

static uint32_t pio_intr(int pi) {
    uint32_t v = 0;
    for (int s = 0; s < 4; s++) {
        if (sms[pi][s].rxn > 0) v |= 1u << s;
        if (sms[pi][s].txn < 4) v |= 1u << (4 + s);
    }
    return v;
}

int periph_irq_level(uint num) {
    switch (num) {
    case UART0_IRQ: {
        uint32_t imsc = sil_uart_hw[0].imsc;
        return (cu.rx_full && (imsc & 0x10)) || (cu.tx_irq && (imsc & 0x20));
    }
    case PIO0_IRQ_0: return (pio_intr(0) & sil_pio_hw[0].inte0) != 0;
    case PIO0_IRQ_1: return (pio_intr(0) & sil_pio_hw[0].inte1) != 0;
    case PIO1_IRQ_0: return (pio_intr(1) & sil_pio_hw[1].inte0) != 0;
    case PIO1_IRQ_1: return (pio_intr(1) & sil_pio_hw[1].inte1) != 0;
    default: return 0;
    }
}

/* A pending UART interrupt set by software is a request to look at the transmitter: it is
 * kept as the transmit condition, so a receive-only call of the handler cannot swallow it. */
int periph_irq_pend(uint num) {
    if (num != UART0_IRQ) return 0;
    cu.tx_irq = 1;
    return 1;
}

/* The PL011's flag register says either "a byte to read" or "room to send", never both in
 * one call, so a handler's read of dr and write of dr can be told apart (both are plain
 * memory here). */
void periph_irq_enter(uint num) {
    if (num != UART0_IRQ) return;
    uart_hw_t *u = &sil_uart_hw[0];
    /* The handler reads the flags and the data register as it enters, so what it sees is
     * taken now: time moves inside a handler, and a byte that arrives or finishes sending
     * meanwhile raises the interrupt again, as the PL011's levels do. Cleared at the exit
     * instead, such an interrupt was lost: a received byte dropped as an overrun, or the rest
     * of the TX ring left unsent until the firmware queued another byte. */
    cu.entered_rx = cu.rx_full && (u->imsc & 0x10);
    if (cu.entered_rx) {
        cu.rx_full = 0;                                /* the holding register is read */
        W32(u->fr) = 0;                                /* RX not empty; TX not empty */
        W32(u->dr) = cu.rx_byte;
    } else {
        cu.tx_irq = 0;
        cu.entered_tx = !cu.tx_busy;
        W32(u->fr) = (cu.tx_busy ? 0u : 0x80u) | 0x10u;   /* TX empty?; RX empty */
        W32(u->dr) = DR_UNTOUCHED;
    }
}

void periph_irq_exit(uint num) {
    if (num != UART0_IRQ) return;
    uart_hw_t *u = &sil_uart_hw[0];
    if (cu.entered_rx) return;
    cu.entered_tx = 0;
    uint32_t dr = u->dr;
    if (dr != DR_UNTOUCHED && !cu.tx_busy) {
        cu.tx_byte = (uint8_t)dr;
        cu.tx_busy = 1;
        cu.tx_done = sil_now + cu.byte_ns;
    } else if (!cu.tx_busy && !cu.tx_irq && link_yield_on_host_idle) {
        sil_request_yield();                           /* the answer is complete for now */
    }
}

void periph_init(void) {
    for (int p = 0; p < SIL_PORTS; p++) {
        ids[p].signature = SIG_NONE;
        ids[p].rx_idle = 1;
        drive_mode_seen[p] = 0;
    }
    for (uint g = 0; g < NPINS; g++) {
        int is_tx = 0, p = board_port_of_pin(g, &is_tx);
        if (p < 0) continue;
        if (is_tx) port_tx_pin[p] = g;
        else port_rx_pin[p] = g;
    }
    W32(sil_adc_hw.result) = 0x3ff;
    /* The bootloader leaves the image's signature at the top of RAM (0x2003FF00); the
     * firmware's `signature` command reads it there, so that address must exist here. */
    void *pad = mmap((void *)0x2003f000, 0x1000, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0);
    if (pad == MAP_FAILED || pad != (void *)0x2003f000)
        fprintf(stderr, "sil: could not map the bootloader pad at 0x2003F000\n");
}
