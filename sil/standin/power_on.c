/* Power-on: the stand-in put together before the firmware's main() runs. The machine gets the
 * peripherals that have events or interrupts and the world (the frame transport); the
 * peripherals start in their power-on state; then the world sets the HAT up and says run.
 *
 * Who calls whom, with no circle: this file calls everything; the frame transport calls the
 * peripherals' inputs and the machine's run terms; the peripherals call the machine; the
 * machine calls the peripherals and the world only through the tables it is given here. */
#include <stdlib.h>

#include "boot_signature.h"
#include "frame_transport.h"
#include "machine.h"
#include "peripherals.h"

/* In this order: their events run in it each time the clock is due (the command port first). */
static const struct sil_peripheral *const timed_peripherals[] = {
    &sil_uart_peripheral,
    &sil_pio_peripheral,
    &sil_adc_peripheral,
    NULL,
};

/* Early (priority 101): instrumented constructors of the firmware's objects (gcov's) must find
 * the clock stopped until the world has said how to run. */
__attribute__((constructor(101))) static void sil_power_on(void) {
    sil_machine_power_on(timed_peripherals, &sil_frame_world);
    sil_gpio_init();
    sil_adc_init();
    sil_boot_signature_map();
    sil_frame_transport_start();       /* the world's set-up frames, then its first run */
    sil_wake();
    /* BUILDHAT_SIL_START_NS: the chip starts its program that much later after power-on (a
     * real one is not exact to the microsecond). Every later instant moves by it against the
     * world's: sil mutate's phase controls learn which output depends on such a phase. */
    const char *start = getenv("BUILDHAT_SIL_START_NS");
    if (start && atoll(start) > 0) sil_spend((uint64_t)atoll(start));
}
