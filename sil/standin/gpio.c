/* GPIO: each pin's direction, output level, pulls and function; the inputs the world sets
 * (the ports' ID lines, the two fault pins); the pins the world watches (port power, the
 * status LEDs), which go to it as events. */
#include "board.h"
#include "machine.h"
#include "peripherals.h"

#define PINS 30                        /* the RP2040's GPIOs 0..29 */
#define SIGNATURE_NONE 0x0CC0u         /* what an empty port's ID lines read (devices.json) */

enum pull { PULL_NONE, PULL_UP, PULL_DOWN };

static struct { uint8_t out_dir, out, pull, func; } pins[PINS];
static struct { uint16_t signature; uint8_t rx_idle; } ids[SIL_PORTS];
static uint port_tx_pin[SIL_PORTS], port_rx_pin[SIL_PORTS];
static uint8_t portfault_ok = 1, motorfault_ok = 1;
static uint8_t leds_seen = 0xff;       /* no LED state told yet: the first change is */

void gpio_init(uint gpio) {
    if (gpio >= PINS) return;
    pins[gpio].out_dir = 0;
    pins[gpio].out = 0;
    pins[gpio].func = GPIO_FUNC_SIO;
    sil_touch();
}

void gpio_set_dir(uint gpio, bool out) {
    if (gpio < PINS && pins[gpio].out_dir != out) {
        pins[gpio].out_dir = out;
        sil_touch();
    }
}

static void leds_changed(void) {
    uint8_t bits = (uint8_t)((pins[board_pin_led0].out ? 1 : 0) | (pins[board_pin_led1].out ? 2 : 0));
    if (bits == leds_seen) return;
    leds_seen = bits;
    sil_world->leds(sil_now, bits);
}

void gpio_put(uint gpio, bool value) {
    if (gpio >= PINS || pins[gpio].out == value) return;
    pins[gpio].out = value;
    sil_touch();
    if (gpio == board_pin_poweron) {
        sil_world->port_power(sil_now, value);
        sil_request_yield();
    } else if (gpio == board_pin_led0 || gpio == board_pin_led1) {
        leds_changed();
    }
}

static void set_pull(uint gpio, enum pull pull) {
    if (gpio < PINS) {
        pins[gpio].pull = (uint8_t)pull;
        sil_touch();
    }
}

void gpio_pull_up(uint gpio) { set_pull(gpio, PULL_UP); }
void gpio_pull_down(uint gpio) { set_pull(gpio, PULL_DOWN); }
void gpio_disable_pulls(uint gpio) { set_pull(gpio, PULL_NONE); }

void gpio_set_function(uint gpio, enum gpio_function fn) {
    if (gpio < PINS) {
        pins[gpio].func = (uint8_t)fn;
        sil_touch();
    }
}

static int driven_by_software(uint gpio) { return pins[gpio].out_dir && pins[gpio].func == GPIO_FUNC_SIO; }

bool gpio_get(uint gpio) {
    if (gpio >= PINS) return false;
    if (driven_by_software(gpio)) return pins[gpio].out;
    if (gpio == board_pin_portfault) return portfault_ok;
    if (gpio == board_pin_motorfault) return motorfault_ok;
    int is_tx = 0, port = board_port_of_pin(gpio, &is_tx);
    if (port >= 0 && !is_tx && ids[port].rx_idle == 0) return false;   /* the device holds the line low */
    return pins[gpio].pull != PULL_DOWN;
}

/* ---- the ID lines ----------------------------------------------------------------------- */
/* The ID lines (connector pins 5 and 6) as the port's driver reads them. A device's
 * signature word holds, for each of the eight ways the firmware may bias the UART lines
 * (one line floating, the other driven low, pulled down, driven high or pulled up; RX then
 * TX), pin 5 in the low byte and pin 6 in the high byte. */
enum bias { FLOATING = -1, DRIVEN_LOW, PULLED_DOWN, DRIVEN_HIGH, PULLED_UP, BIASES };
#define ID_PIN5_BIT 6                  /* where the driver's register shows each ID pin */
#define ID_PIN6_BIT 7

static enum bias line_bias(uint gpio) {
    if (driven_by_software(gpio)) return pins[gpio].out ? DRIVEN_HIGH : DRIVEN_LOW;
    if (pins[gpio].pull == PULL_UP) return PULLED_UP;
    if (pins[gpio].pull == PULL_DOWN) return PULLED_DOWN;
    return FLOATING;
}

uint8_t sil_gpio_id_pins(int port) {
    enum bias tx = line_bias(port_tx_pin[port]), rx = line_bias(port_rx_pin[port]);
    int way;                           /* which of the signature's eight bits */
    if (tx == FLOATING && rx != FLOATING) way = rx;
    else if (rx == FLOATING && tx != FLOATING) way = BIASES + tx;
    else return 0;
    uint16_t signature = ids[port].signature;
    uint8_t pin5 = (signature >> way) & 1, pin6 = (signature >> (8 + way)) & 1;   /* low byte, high byte */
    return (uint8_t)(pin5 << ID_PIN5_BIT | pin6 << ID_PIN6_BIT);
}

void sil_gpio_set_id(int port, uint16_t signature, uint8_t rx_idle_level) {
    if (port < 0 || port >= SIL_PORTS) return;
    ids[port].signature = signature;
    ids[port].rx_idle = rx_idle_level;
    sil_touch();
}

void sil_gpio_set_fault_pins(uint8_t port_ok, uint8_t motor_ok) {
    portfault_ok = port_ok;
    motorfault_ok = motor_ok;
    sil_touch();
}

/* Power-on: every port empty (its ID lines as no device's, its RX line idle high). */
void sil_gpio_init(void) {
    for (int port = 0; port < SIL_PORTS; port++) {
        ids[port].signature = SIGNATURE_NONE;
        ids[port].rx_idle = 1;
    }
    for (uint gpio = 0; gpio < PINS; gpio++) {
        int is_tx = 0, port = board_port_of_pin(gpio, &is_tx);
        if (port < 0) continue;
        if (is_tx) port_tx_pin[port] = gpio;
        else port_rx_pin[port] = gpio;
    }
}
