/* The PIO blocks, as the Build HAT firmware uses them: state machines running an 8N1 UART
 * program, one transmitter and one receiver per port. Which program a state machine runs is
 * known from the program's text (sil/pio_header.py), so its job is modelled, not its code:
 * 4-word FIFOs, the FIFO-level interrupt flags, bytes at the rate the state machine's clock
 * divider gives. The devices' bytes come from the world (a wire per port, wire.h); the bytes
 * sent, a receiver switched on or off and a byte lost to a full FIFO go to it as events.
 *
 * The firmware's own register writes (inte0/inte1, a state machine's clkdiv) are plain memory,
 * read here when they matter. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "board.h"
#include "machine.h"
#include "peripherals.h"
#include "wire.h"

#define PIO_BLOCKS 2
#define SMS_PER_PIO 4
#define FIFO_DEPTH 4                   /* words in each TX and RX FIFO (joined FIFOs: not used) */
#define INSTRUCTION_SLOTS 32           /* a PIO block's instruction memory */
#define CLKDIV_ONE (1u << 16)          /* clkdiv is 16.8 fixed point in bits 31..8 */
#define UART_CYCLES_PER_BIT 8          /* the UART programs take 8 cycles a bit */
#define RX_BYTE_SHIFT 24               /* a received byte, shifted in from the right, sits at the top */
#define BAUD_TOLERANCE 20              /* a byte more than 1/20 (5 %) off the receiver's rate is lost */
#define POLL_NS 1000                   /* a blocking FIFO call looks again every microsecond */
/* The INTR register: bit n, state machine n's RX FIFO is not empty; bit 4 + n, its TX FIFO
 * is not full (RP2040 datasheet, PIO registers). */
#define INTR_RXNEMPTY(sm) (1u << (sm))
#define INTR_TXNFULL(sm) (1u << (4 + (sm)))

pio_hw_t sil_pio_hw[PIO_BLOCKS];

struct state_machine {
    int kind, port, enabled;           /* kind: enum sil_pio_kind; port -1: a pin of no port */
    uint32_t txf[FIFO_DEPTH], rxf[FIFO_DEPTH];
    int tx_count, rx_count;
    int shifting;                      /* a byte is leaving: shift_byte, done at shift_done */
    uint64_t shift_done;
    uint8_t shift_byte;
    uint32_t shift_baud;
};
static struct state_machine machines[PIO_BLOCKS][SMS_PER_PIO];
static struct sil_wire port_rx[SIL_PORTS];            /* each port's device's bytes on their way */
static uint8_t program_kinds[PIO_BLOCKS][INSTRUCTION_SLOTS];   /* program kind by load offset */
static uint32_t slots_used[PIO_BLOCKS];

static int pio_index(PIO pio) { return pio == pio1 ? 1 : 0; }

/* A state machine's number within its block: the SDK takes 0..3; a larger number keeps its
 * low two bits, as the registers' state-machine fields do, so the model's arrays stay in bounds. */
static uint sm_slot(uint sm) { return sm & (SMS_PER_PIO - 1); }

static struct state_machine *state_machine(PIO pio, uint sm) { return &machines[pio_index(pio)][sm_slot(sm)]; }

/* The rate a UART program runs at under the state machine's clock divider. */
static uint32_t sm_baud(int block, uint sm) {
    uint32_t reg = sil_pio_hw[block].sm[sm].clkdiv;
    double div = reg ? reg / (double)CLKDIV_ONE : (double)CLKDIV_ONE;   /* 0 means 65536 */
    if (div < 1.0) div = 1.0;
    return (uint32_t)(SIL_CLK_SYS_HZ / ((double)UART_CYCLES_PER_BIT * div) + 0.5);
}

/* A transmitter takes its FIFO's next word and starts shifting it out. */
static void start_shift(int block, uint sm) {
    struct state_machine *machine = &machines[block][sm];
    if (machine->shifting || machine->tx_count == 0 || !machine->enabled) return;
    machine->shift_byte = (uint8_t)machine->txf[0];
    memmove(machine->txf, machine->txf + 1, (FIFO_DEPTH - 1) * sizeof machine->txf[0]);
    machine->tx_count--;
    machine->shift_baud = sm_baud(block, sm);
    machine->shift_done = sil_now + SIL_NS_PER_BYTE_AT_1_BAUD / machine->shift_baud;
    machine->shifting = 1;
}

/* ---- configuration ---------------------------------------------------------------------- */
pio_sm_config sil_pio_default_config(uint offset) {
    pio_sm_config config;
    memset(&config, 0, sizeof config);
    config.clkdiv = CLKDIV_ONE;
    config.out_pin = config.in_pin = -1;
    (void)offset;                      /* the generated header sets the kind */
    return config;
}

/* Shifts, side-set and jump pins are the program's business: the model knows its job. */
void sm_config_set_out_shift(pio_sm_config *config, bool shift_right, bool autopull, uint threshold) {
    (void)config; (void)shift_right; (void)autopull; (void)threshold;
}
void sm_config_set_in_shift(pio_sm_config *config, bool shift_right, bool autopush, uint threshold) {
    (void)config; (void)shift_right; (void)autopush; (void)threshold;
}
void sm_config_set_sideset_pins(pio_sm_config *config, uint sideset_base) { (void)config; (void)sideset_base; }
void sm_config_set_jmp_pin(pio_sm_config *config, uint pin) { (void)config; (void)pin; }
void sm_config_set_out_pins(pio_sm_config *config, uint out_base, uint out_count) {
    (void)out_count;
    config->out_pin = (int)out_base;
}
void sm_config_set_in_pins(pio_sm_config *config, uint in_base) { config->in_pin = (int)in_base; }

void sm_config_set_clkdiv(pio_sm_config *config, float div) {
    uint32_t whole = (uint32_t)div;
    uint32_t frac = (uint32_t)((div - (float)whole) * 256.0f);
    config->clkdiv = (whole << 16) | (frac << 8);
}

int pio_add_program(PIO pio, const pio_program_t *program) {
    int block = pio_index(pio), len = program->length ? program->length : 1;
    for (int off = INSTRUCTION_SLOTS - len; off >= 0; off--) {   /* the SDK fills from the top */
        uint32_t mask = (len >= INSTRUCTION_SLOTS ? 0xffffffffu : ((1u << len) - 1u)) << off;
        if (slots_used[block] & mask) continue;
        slots_used[block] |= mask;
        program_kinds[block][off] = program->sil_kind;
        return off;
    }
    fprintf(stderr, "sil: PIO%d program memory full\n", block);
    abort();
}

void pio_clear_instruction_memory(PIO pio) { slots_used[pio_index(pio)] = 0; }

int pio_sm_init(PIO pio, uint sm, uint initial_pc, const pio_sm_config *config) {
    int block = pio_index(pio);
    struct state_machine *machine = state_machine(pio, sm);
    memset(machine, 0, sizeof *machine);
    machine->kind = config->kind ? config->kind : program_kinds[block][initial_pc % INSTRUCTION_SLOTS];
    int pin = machine->kind == SIL_PIO_UART_TX ? config->out_pin : config->in_pin;
    machine->port = pin >= 0 ? board_port_of_pin((uint)pin, NULL) : -1;
    sil_pio_hw[block].sm[sm_slot(sm)].clkdiv = config->clkdiv;
    sil_touch();
    return 0;
}

void pio_sm_set_enabled(PIO pio, uint sm, bool enabled) {
    int block = pio_index(pio);
    struct state_machine *machine = state_machine(pio, sm);
    if (machine->enabled == (int)enabled) return;
    machine->enabled = enabled;
    sil_touch();
    if (machine->kind == SIL_PIO_UART_RX && machine->port >= 0) {
        sil_world->port_receiver(machine->port, sil_now, enabled, sm_baud(block, sm_slot(sm)));
        if (!enabled) machine->rx_count = 0;
        sil_request_yield();           /* a device starts or stops talking */
    }
    if (enabled) start_shift(block, sm_slot(sm));
    sil_wake();
}

/* The pins follow the program: the model does not drive them. */
void pio_sm_set_pins_with_mask(PIO pio, uint sm, uint32_t pin_values, uint32_t pin_mask) {
    (void)pio; (void)sm; (void)pin_values; (void)pin_mask;
}
void pio_sm_set_pindirs_with_mask(PIO pio, uint sm, uint32_t pin_dirs, uint32_t pin_mask) {
    (void)pio; (void)sm; (void)pin_dirs; (void)pin_mask;
}
int pio_sm_set_consecutive_pindirs(PIO pio, uint sm, uint pin_base, uint pin_count, bool is_out) {
    (void)pio; (void)sm; (void)pin_base; (void)pin_count; (void)is_out;
    return 0;
}
void pio_gpio_init(PIO pio, uint pin) { gpio_set_function(pin, pio == pio1 ? GPIO_FUNC_PIO1 : GPIO_FUNC_PIO0); }

/* ---- FIFOs ------------------------------------------------------------------------------ */
bool pio_sm_is_tx_fifo_full(PIO pio, uint sm) { return state_machine(pio, sm)->tx_count >= FIFO_DEPTH; }
bool pio_sm_is_tx_fifo_empty(PIO pio, uint sm) { return state_machine(pio, sm)->tx_count == 0; }
bool pio_sm_is_rx_fifo_full(PIO pio, uint sm) { return state_machine(pio, sm)->rx_count >= FIFO_DEPTH; }

/* A firmware reads the RX FIFO register right after it saw the FIFO not empty: the word
 * is moved into rxf[] at that moment (the register read itself is invisible here). */
bool pio_sm_is_rx_fifo_empty(PIO pio, uint sm) {
    struct state_machine *machine = state_machine(pio, sm);
    if (machine->rx_count == 0) return true;
    SIL_SET_REG(sil_pio_hw[pio_index(pio)].rxf[sm_slot(sm)]) = machine->rxf[0];
    memmove(machine->rxf, machine->rxf + 1, (FIFO_DEPTH - 1) * sizeof machine->rxf[0]);
    machine->rx_count--;
    sil_touch();
    return false;
}

uint32_t pio_sm_get(PIO pio, uint sm) {
    pio_sm_is_rx_fifo_empty(pio, sm);
    return sil_pio_hw[pio_index(pio)].rxf[sm_slot(sm)];
}

uint32_t pio_sm_get_blocking(PIO pio, uint sm) {
    while (state_machine(pio, sm)->rx_count == 0) sil_spend(POLL_NS);
    return pio_sm_get(pio, sm);
}

void pio_sm_put(PIO pio, uint sm, uint32_t data) {
    struct state_machine *machine = state_machine(pio, sm);
    if (machine->tx_count >= FIFO_DEPTH) return;   /* the hardware drops a put to a full FIFO */
    machine->txf[machine->tx_count++] = data;
    sil_touch();
    start_shift(pio_index(pio), sm_slot(sm));
    sil_wake();
}

void pio_sm_put_blocking(PIO pio, uint sm, uint32_t data) {
    while (pio_sm_is_tx_fifo_full(pio, sm)) sil_spend(POLL_NS);
    pio_sm_put(pio, sm, data);
}

/* ---- the devices' bytes ----------------------------------------------------------------- */
void sil_pio_port_bytes(int port, uint64_t t, uint32_t baud, const uint8_t *bytes, uint16_t count) {
    if (port >= 0 && port < SIL_PORTS) sil_wire_push(&port_rx[port], t, baud, bytes, count);
}

void sil_pio_port_cut(int port, uint64_t t) {
    if (port >= 0 && port < SIL_PORTS) sil_wire_cut(&port_rx[port], t);
}

/* A byte from a device reaches the port's receiving state machine; a baud rate more than
 * 5 % off what it listens at gives no byte (a real UART would see framing errors). A fifth
 * byte before the firmware has read any is lost, as on the chip, which says nothing; here the
 * world is told, so a device message the firmware never saw is not a mystery. */
static void port_byte_arrives(int port, uint8_t byte, uint32_t baud) {
    for (int block = 0; block < PIO_BLOCKS; block++) {
        for (uint sm = 0; sm < SMS_PER_PIO; sm++) {
            struct state_machine *machine = &machines[block][sm];
            if (machine->kind != SIL_PIO_UART_RX || machine->port != port || !machine->enabled) continue;
            uint32_t want = sm_baud(block, sm);
            uint32_t diff = want > baud ? want - baud : baud - want;
            if (diff * BAUD_TOLERANCE > want) return;
            if (machine->rx_count < FIFO_DEPTH)
                machine->rxf[machine->rx_count++] = (uint32_t)byte << RX_BYTE_SHIFT;
            else
                sil_world->port_byte_lost(port, sil_now, byte);
            sil_touch();
            return;
        }
    }
}

/* ---- events and interrupts -------------------------------------------------------------- */
static uint64_t next_event(void) {
    uint64_t t = UINT64_MAX;
    for (int port = 0; port < SIL_PORTS; port++) {
        uint64_t arrival = sil_wire_next(&port_rx[port]);
        if (arrival < t) t = arrival;
    }
    for (int block = 0; block < PIO_BLOCKS; block++)
        for (int sm = 0; sm < SMS_PER_PIO; sm++) {
            const struct state_machine *machine = &machines[block][sm];
            if (machine->shifting && machine->shift_done < t) t = machine->shift_done;
        }
    return t;
}

static void run_events(void) {
    for (int port = 0; port < SIL_PORTS; port++) {
        struct sil_wire *wire = &port_rx[port];
        while (sil_wire_next(wire) <= sil_now) {
            uint32_t baud;
            uint8_t byte = sil_wire_take(wire, &baud);
            port_byte_arrives(port, byte, baud);
        }
    }
    for (int block = 0; block < PIO_BLOCKS; block++) {
        for (uint sm = 0; sm < SMS_PER_PIO; sm++) {
            struct state_machine *machine = &machines[block][sm];
            if (!machine->shifting || machine->shift_done > sil_now) continue;
            sil_world->port_byte(machine->port, machine->shift_done, machine->shift_baud, machine->shift_byte);
            machine->shifting = 0;
            sil_touch();
            start_shift(block, sm);
            if (!machine->shifting) sil_request_yield();   /* a whole message is out: the device reacts */
        }
    }
}

/* What the block's INTR register reads. */
static uint32_t intr(int block) {
    uint32_t flags = 0;
    for (uint sm = 0; sm < SMS_PER_PIO; sm++) {
        if (machines[block][sm].rx_count > 0) flags |= INTR_RXNEMPTY(sm);
        if (machines[block][sm].tx_count < FIFO_DEPTH) flags |= INTR_TXNFULL(sm);
    }
    return flags;
}

static int irq_level(uint num) {
    switch (num) {
    case PIO0_IRQ_0: return (intr(0) & sil_pio_hw[0].inte0) != 0;
    case PIO0_IRQ_1: return (intr(0) & sil_pio_hw[0].inte1) != 0;
    case PIO1_IRQ_0: return (intr(1) & sil_pio_hw[1].inte0) != 0;
    case PIO1_IRQ_1: return (intr(1) & sil_pio_hw[1].inte1) != 0;
    default: return 0;
    }
}

const struct sil_peripheral sil_pio_peripheral = {
    .next_event = next_event,
    .run_events = run_events,
    .irq_level = irq_level,
};
