/* What the virtual CPU asks of a peripheral that has timed events or interrupt lines (the
 * command-port UART, the PIO blocks). Each such peripheral fills one of these; the machine
 * runs them in its list's order and never names them. A NULL entry: the peripheral has none. */
#ifndef SIL_PERIPHERAL_INTERFACE_H
#define SIL_PERIPHERAL_INTERFACE_H

#include "sil_sdk.h"

struct sil_peripheral {
    uint64_t (*next_event)(void);      /* earliest pending event time (UINT64_MAX: none) */
    void (*run_events)(void);          /* every event due at or before sil_now */
    int (*irq_level)(uint num);        /* the peripheral asserts interrupt num */
    int (*irq_pend)(uint num);         /* software set num pending: 1 if the peripheral keeps it */
    void (*irq_enter)(uint num);       /* set registers the handler reads */
    void (*irq_exit)(uint num);        /* take what the handler wrote */
    void (*timer_read)(void);          /* the CPU read the timer: a peripheral the firmware drives by
                                        * plain register writes looks at them (once a main-loop pass) */
};

#endif
