/* The world as the model (the machine and its peripherals) sees it: where its events go, and
 * whom it hands control to. The frame transport (frame_transport.c) implements it with frames
 * (sil/frames.py lists them); the model only calls through this table, so it never calls the
 * transport by name. Each event carries its virtual time in ns. */
#ifndef SIL_WORLD_INTERFACE_H
#define SIL_WORLD_INTERFACE_H

#include <stdbool.h>
#include <stdint.h>

struct sil_world {
    /* hand control to the world; returns when the world says run again */
    void (*yield)(void);
    /* bytes the command port sent to the host (t: the end of the last one) */
    void (*host_bytes)(uint64_t t, const uint8_t *bytes, uint16_t count);
    /* a byte a port's PIO sent to its device at baud (t: its end; port -1: a pin of no port) */
    void (*port_byte)(int port, uint64_t t, uint32_t baud, uint8_t byte);
    /* a port's PIO receiver was switched on or off, listening at baud */
    void (*port_receiver)(int port, uint64_t t, bool on, uint32_t baud);
    /* a byte from a port's device was lost: the PIO RX FIFO was full */
    void (*port_byte_lost)(int port, uint64_t t, uint8_t byte);
    /* a port's motor driver drives duty (-255..255); driven false: its outputs are off */
    void (*drive)(int port, uint64_t t, int16_t duty, bool driven);
    /* a port's motor driver's fault latch was cleared */
    void (*faults_cleared)(int port, uint64_t t);
    /* the ports' power was switched */
    void (*port_power)(uint64_t t, bool on);
    /* the two status LEDs (bit 0: LED 0, bit 1: LED 1) */
    void (*leds)(uint64_t t, uint8_t bits);
};

#endif
