/* Where the Build HAT wires its four LPF2 ports and status pins, from the board's published
 * pin-out (the same facts any Build HAT schematic gives). The stand-in needs them to know
 * which port a PIO pin or a motor-driver I2C address belongs to. */
#include "board.h"

struct port_wiring {
    uint tx_pin, rx_pin;     /* the RP2040 GPIOs of the port's UART lines */
    int bus;                 /* I2C bus of the port's motor driver */
    uint8_t driver_addr;     /* its 7-bit address */
};

static const struct port_wiring ports[SIL_PORTS] = {
    {11, 10, 0, 0x60},
    {5, 4, 0, 0x68},
    {25, 24, 1, 0x70},
    {21, 20, 1, 0x78},
};

const uint board_pin_led0 = 14, board_pin_led1 = 15;
const uint board_pin_portfault = 16, board_pin_poweron = 17, board_pin_motorfault = 28;

int board_port_of_pin(uint pin, int *is_tx) {
    for (int p = 0; p < SIL_PORTS; p++) {
        if (pin == ports[p].tx_pin || pin == ports[p].rx_pin) {
            if (is_tx) *is_tx = pin == ports[p].tx_pin;
            return p;
        }
    }
    return -1;
}

int board_port_of_driver(int bus, uint8_t addr) {
    for (int p = 0; p < SIL_PORTS; p++)
        if (ports[p].bus == bus && ports[p].driver_addr == addr) return p;
    return -1;
}
