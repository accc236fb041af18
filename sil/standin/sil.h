/* What the stand-in's own files share: the virtual clock (machine.c), the peripherals
 * (periph.c, board.c) and the link to the world (link.c). Not seen by the firmware. */
#ifndef SIL_H
#define SIL_H

#include "sil_sdk.h"

/* Virtual time, in nanoseconds since power-on. */
extern uint64_t sil_now;

/* machine.c */
void sil_touch(void);                  /* something outside the CPU changed: not idle */
void sil_service(void);                /* run what is due: events, interrupts, the world */
void sil_wake(void);                   /* an event may now be due earlier: re-plan */
void sil_request_yield(void);          /* hand control to the world at the next chance */
void sil_spend(uint64_t ns);           /* the CPU is busy (a bus transfer, a wait) for ns */

/* periph.c: events and interrupt sources of the modelled peripherals */
uint64_t periph_next_event(void);      /* earliest pending event time (UINT64_MAX: none) */
void periph_run_events(void);          /* every event due at or before sil_now */
int periph_irq_level(uint num);        /* the peripheral asserts interrupt num */
int periph_irq_pend(uint num);         /* software set num pending: 1 if the peripheral keeps it */
void periph_irq_enter(uint num);       /* set registers the handler reads */
void periph_irq_exit(uint num);        /* take what the handler wrote */
void periph_host_bytes(uint64_t t, const uint8_t *b, uint16_t n);
void periph_port_bytes(int port, uint64_t t, uint32_t baud, const uint8_t *b, uint16_t n);
void periph_port_cut(int port, uint64_t t);   /* the device stopped: drop its unsent bytes */
void periph_set_id(int port, uint16_t signature, uint8_t rx_idle_level);
void periph_set_fault_pins(uint8_t port_ok, uint8_t motor_ok);
void periph_set_fault_regs(int port, const uint8_t *regs3);
void periph_set_adc(uint16_t raw);
void periph_set_drive_stops(uint8_t mask);   /* ports whose drive changes stop the firmware */
void periph_init(void);
uint8_t periph_host_status(void);      /* the command port at rest: see periph.c */
void periph_flush_output(void);       /* bytes to the host not yet in a frame */

/* board.c: where the Build HAT wires its ports (from its published pin-out) */
#define SIL_PORTS 4
int board_port_of_pin(uint pin, int *is_tx);      /* -1: not a port's UART pin */
int board_port_of_driver(int bus, uint8_t addr);  /* -1: no motor driver at that address */
extern const uint board_pin_portfault, board_pin_motorfault, board_pin_poweron;
extern const uint board_pin_led0, board_pin_led1;

/* link.c: frames to and from the world (format: sil/frames.py) */
extern uint64_t link_limit;            /* run no further than this without asking the world */
extern int link_yield_on_host_idle;    /* the world waits for an answer to finish */
void link_emit(uint8_t type, uint8_t port, uint64_t t, const void *data, uint16_t len);
void link_yield(void);                 /* flush, then obey the world until it says run */
void link_start(void);
void link_flush(void);

#endif
