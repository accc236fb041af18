/* The virtual CPU (machine.c) as the rest of the stand-in sees it: the clock, the services a
 * peripheral asks of it, and the terms of the run the world set. Not seen by the firmware.
 *
 * The machine knows the peripherals and the world only through the two interfaces it is
 * given at power-on (peripheral_interface.h, world_interface.h), so nothing it calls calls
 * back into a file that calls it: the peripherals and the transport sit above it. */
#ifndef SIL_MACHINE_H
#define SIL_MACHINE_H

#include "peripheral_interface.h"
#include "world_interface.h"

/* Virtual time, in nanoseconds since power-on. */
extern uint64_t sil_now;

void sil_touch(void);                  /* something outside the CPU changed: not idle */
void sil_service(void);                /* run what is due: events, interrupts, the world */
void sil_wake(void);                   /* an event may now be due earlier: re-plan */
void sil_request_yield(void);          /* hand control to the world at the next chance */
void sil_spend(uint64_t ns);           /* the CPU is busy (a bus transfer, a wait) for ns */

/* The world the model's events go to (set by sil_machine_power_on). */
extern const struct sil_world *sil_world;

/* The world's run frame: run no further than limit_ns without asking it; with
 * yield_on_host_idle, also stop when the command port falls idle (its answer is complete). */
void sil_run_until(uint64_t limit_ns, int yield_on_host_idle);
int sil_yields_on_host_idle(void);

/* Power-on: the environment's settings (BUILDHAT_SIL_NS_PER_BLOCK, BUILDHAT_SIL_STATS), the
 * peripherals that have events or interrupts (a NULL-ended list) and the world. */
void sil_machine_power_on(const struct sil_peripheral *const *peripherals, const struct sil_world *world);

#endif
