/* Where the Build HAT wires its ports and status pins (board.c). */
#ifndef SIL_BOARD_H
#define SIL_BOARD_H

#include "sil_sdk.h"

#define SIL_PORTS 4
int board_port_of_pin(uint pin, int *is_tx);      /* -1: not a port's UART pin */
int board_port_of_driver(int bus, uint8_t addr);  /* -1: no motor driver at that address */
extern const uint board_pin_portfault, board_pin_motorfault, board_pin_poweron;
extern const uint board_pin_led0, board_pin_led1;

#endif
