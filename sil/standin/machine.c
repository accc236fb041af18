/* The virtual CPU: time, interrupts and idling for a firmware built for the host.
 *
 * The firmware's own files are compiled with -fsanitize-coverage=trace-pc, so the compiler
 * calls __sanitizer_cov_trace_pc() at the start of every basic block. That call is the
 * clock: each block costs ns_per_block of virtual time, so loops that never call the SDK
 * (a spin on a flag an interrupt sets) still move time, and interrupts are taken between
 * blocks, as on the chip. Nothing here reads the wall clock; the same inputs give the same
 * bytes at the same virtual times.
 *
 * Idling: a main loop that polls the timer and finds nothing to do would burn host CPU for
 * every virtual microsecond. When two timer reads in a row were separated by the same number
 * of blocks and nothing outside the CPU changed in between, the loop is polling; the clock
 * then jumps over whole polling passes: to the first pass end at or after the next millisecond
 * edge of the timer, or to the last pass end before the next event, whichever comes first. So
 * the loop reads the timer at the very instants it would have read it pass by pass, and its
 * phase against the events does not depend on when the world stops it (landing exactly on
 * the edge or the event would move the phase by part of a pass at every jump). An event taken
 * while the loop stood at its timer read (the jump lands on it) was seen by the whole pass
 * after it: if that pass is as long as the polling pass, the loop is still polling, and the
 * clock jumps again at once. See sil/README.md for why this keeps behaviour unchanged.
 */
#include "machine.h"

#include <stdio.h>
#include <stdlib.h>

/* What a basic block costs: five or six Cortex-M0+ instructions, about ten cycles at 133 MHz.
 * Calibrated on a fact: a `list` of a motor, a distance and a colour sensor stretches its
 * main-loop pass to deltat=00000003, as on a real HAT (docs/FIRMWARE-BEHAVIOUR.md#fb-stall).
 * The environment variable BUILDHAT_SIL_NS_PER_BLOCK changes it (a faster or slower chip). */
#define NS_PER_BLOCK_DEFAULT 80
static uint64_t ns_per_block = NS_PER_BLOCK_DEFAULT;
/* How often (in blocks) a running program is checked for interrupts that a register write
 * (which the stand-in cannot see as it happens) may have enabled: about 2.5 us. */
#define IRQ_POLL_BLOCKS 64
/* Reading the timer costs a register access. */
#define NS_PER_TIMER_READ 20
/* One software floating-point operation on the Cortex-M0+ (the chip has no FPU): about 60
 * cycles at 133 MHz (sil/asm_cost.py charges it per float instruction of a block). */
#ifndef NS_PER_SOFT_FLOAT
#define NS_PER_SOFT_FLOAT 450
#endif

uint64_t sil_now;
const struct sil_world *sil_world;

/* The peripherals with events or interrupts, in the order their events run (power-on's). */
static const struct sil_peripheral *const no_peripherals[] = {NULL};
static const struct sil_peripheral *const *attached = no_peripherals;
/* The world's run frame (sil_run_until). */
static uint64_t run_limit;
static int stop_on_host_idle;

static uint64_t blocks;
static uint64_t handler_blocks;         /* of those, run inside interrupt handlers */
static uint64_t next_due = UINT64_MAX;  /* when sil_service must run next (never before power-on) */
static int in_service, in_irq, yield_wanted;
static irq_handler_t handlers[SIL_NUM_IRQS];
static uint8_t is_enabled[SIL_NUM_IRQS], pending[SIL_NUM_IRQS];
static uint32_t armed;                  /* interrupts enabled with a handler: the only ones to ask */

/* Timer-read idling (see above). Intervals count the main loop's blocks only: a handler that
 * ran in between is an event, not a longer pass. */
static int touched = 1, touched_at_read, quiet_reads;
static uint64_t last_read_blocks, last_interval, idle_interval, first_read_us;
static uint64_t last_read_ns;           /* sil_now at the last timer read, after any jump */
static int have_first_read;
static uint64_t stat_reads, stat_jumps, stat_jumped_ns, stat_irqs;   /* BUILDHAT_SIL_STATS, below */

void sil_touch(void) { touched = 1; }

void sil_request_yield(void) {
    yield_wanted = 1;
    next_due = sil_now;
}

void sil_run_until(uint64_t limit_ns, int yield_on_host_idle) {
    run_limit = limit_ns;
    stop_on_host_idle = yield_on_host_idle;
}

int sil_yields_on_host_idle(void) { return stop_on_host_idle; }

/* ---- what the peripherals say (peripheral_interface.h) -------------------------------------------- */
static uint64_t next_event(void) {
    uint64_t next = UINT64_MAX;
    for (const struct sil_peripheral *const *each = attached; *each; each++) {
        uint64_t t = (*each)->next_event ? (*each)->next_event() : UINT64_MAX;
        if (t < next) next = t;
    }
    return next;
}

static void run_events(void) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->run_events) (*each)->run_events();
}

static int irq_level(uint num) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->irq_level && (*each)->irq_level(num)) return 1;
    return 0;
}

static int irq_kept_pending(uint num) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->irq_pend && (*each)->irq_pend(num)) return 1;
    return 0;
}

static void irq_enter(uint num) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->irq_enter) (*each)->irq_enter(num);
}

static void irq_exit(uint num) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->irq_exit) (*each)->irq_exit(num);
}

static void timer_read(void) {
    for (const struct sil_peripheral *const *each = attached; *each; each++)
        if ((*each)->timer_read) (*each)->timer_read();
}

/* ---- the clock and interrupts ----------------------------------------------------------- */
void sil_wake(void) {
    uint64_t next = next_event();
    next_due = next < run_limit ? next : run_limit;
    if (yield_wanted) next_due = sil_now;
}

static void rearm(uint num) {
    uint32_t bit = 1u << num;
    armed = (is_enabled[num] && handlers[num]) ? (armed | bit) : (armed & ~bit);
}

static int irq_wanted(uint num) {
    return (armed >> num & 1u) && (pending[num] || irq_level(num));
}

/* Take one interrupt, lowest number first (the NVIC's order at equal priority). */
static int take_interrupt(void) {
    for (uint32_t left = armed; left; left &= left - 1) {
        uint num = (uint)__builtin_ctz(left);
        if (!irq_wanted(num)) continue;
        pending[num] = 0;
        in_irq = 1;
        in_service = 0;                /* events and the world go on during a long handler */
        irq_enter(num);
        stat_irqs++;
        uint64_t start = blocks;
        handlers[num]();
        handler_blocks += blocks - start;
        irq_exit(num);
        in_service = 1;
        in_irq = 0;
        touched = 1;
        return 1;
    }
    return 0;
}

void sil_service(void) {
    if (in_service) return;
    in_service = 1;
    for (;;) {
        run_events();
        if (yield_wanted || sil_now >= run_limit) {
            yield_wanted = 0;
            sil_world->yield();
            if (run_limit <= sil_now) run_limit = sil_now + 1;
            continue;
        }
        if (!in_irq && take_interrupt()) continue;
        break;
    }
    in_service = 0;
    sil_wake();
}

static int any_irq_wanted(void) {
    for (uint32_t left = armed; left; left &= left - 1)
        if (irq_wanted((uint)__builtin_ctz(left))) return 1;
    return 0;
}

/* The compiler's per-block hook (see the file comment). */
void __sanitizer_cov_trace_pc(void);
void __sanitizer_cov_trace_pc(void) {
    sil_now += ns_per_block;
    blocks++;
    if (sil_now >= next_due) {
        if (!in_service) sil_service();
    } else if ((blocks % IRQ_POLL_BLOCKS) == 0 && !in_irq && !in_service && any_irq_wanted()) {
        sil_service();
    }
}

/* The clock call of a block with N float operations (sil/asm_cost.py). */
#define SOFT_FLOAT_BLOCK(n)                                   \
    void __sil_cov_fp##n(void);                               \
    void __sil_cov_fp##n(void) {                              \
        sil_now += (uint64_t)(n) * NS_PER_SOFT_FLOAT;         \
        __sanitizer_cov_trace_pc();                           \
    }
SOFT_FLOAT_BLOCK(1) SOFT_FLOAT_BLOCK(2) SOFT_FLOAT_BLOCK(3) SOFT_FLOAT_BLOCK(4)
SOFT_FLOAT_BLOCK(5) SOFT_FLOAT_BLOCK(6) SOFT_FLOAT_BLOCK(7) SOFT_FLOAT_BLOCK(8)
SOFT_FLOAT_BLOCK(9) SOFT_FLOAT_BLOCK(10) SOFT_FLOAT_BLOCK(11) SOFT_FLOAT_BLOCK(12)
SOFT_FLOAT_BLOCK(13) SOFT_FLOAT_BLOCK(14) SOFT_FLOAT_BLOCK(15) SOFT_FLOAT_BLOCK(16)

void sil_spend(uint64_t ns) {
    uint64_t end = sil_now + ns;
    while (sil_now < end) {
        uint64_t step = end - sil_now;
        if (next_due > sil_now && next_due - sil_now < step) step = next_due - sil_now;
        sil_now += step;
        if (sil_now >= next_due) sil_service();
    }
}

/* Jump over a polling loop's idle time, whole passes of pass_ns each (see the file comment). */
static void skip_idle(uint64_t pass_ns) {
    sil_service();                    /* an interrupt that is due comes first */
    if (touched || pass_ns == 0) return;
    /* The timer's millisecond edges are 1 us past each whole ms since the first read (a
     * tick counts when the time is *greater* than the last edge); jump to the next one only:
     * a loop that waits for a tick value must see every tick. */
    uint64_t d = sil_now / 1000 - first_read_us;
    uint64_t edge = (first_read_us + (d + 999) / 1000 * 1000 + 1) * 1000;
    uint64_t passes;
    if (edge <= next_due && edge > sil_now)
        passes = (edge - sil_now + pass_ns - 1) / pass_ns;       /* the first pass end past the edge */
    else
        passes = 0;
    if (sil_now + passes * pass_ns > next_due)                    /* the event first: the last pass */
        passes = next_due > sil_now ? (next_due - sil_now) / pass_ns : 0;    /* end before it */
    if (passes) {
        stat_jumps++;
        stat_jumped_ns += passes * pass_ns;
        sil_now += passes * pass_ns;
    }
    if (sil_now >= next_due) sil_service();
}

uint64_t time_us_64(void) {
    stat_reads++;
    timer_read();
    uint64_t main_blocks = blocks - handler_blocks;
    uint64_t interval = main_blocks - last_read_blocks;
    last_read_blocks = main_blocks;
    if (touched)                      /* something changed during the pass: it may have missed it */
        quiet_reads = 0;
    else if (touched_at_read)         /* changed before the pass began: the pass saw all of it */
        quiet_reads = idle_interval && interval == idle_interval ? 2 : 0;
    else if (interval == last_interval)
        quiet_reads++;
    else
        quiet_reads = 0;
    if (quiet_reads == 0) idle_interval = 0;
    last_interval = interval;
    touched = 0;
    uint64_t pass_ns = sil_now - last_read_ns;    /* this pass, timer read included */
    if (!have_first_read) {
        have_first_read = 1;
        first_read_us = sil_now / 1000;
    } else if (quiet_reads >= 2) {
        idle_interval = interval;
        skip_idle(pass_ns);
    }
    last_read_ns = sil_now;
    sil_spend(NS_PER_TIMER_READ);
    touched_at_read = touched;        /* events and interrupts the jump landed on */
    touched = 0;
    return sil_now / 1000;
}

uint32_t time_us_32(void) { return (uint32_t)time_us_64(); }
absolute_time_t get_absolute_time(void) { return time_us_64(); }
void busy_wait_us(uint64_t us) { sil_touch(); sil_spend(us * 1000); }
void busy_wait_us_32(uint32_t us) { busy_wait_us(us); }
void busy_wait_ms(uint32_t ms) { busy_wait_us((uint64_t)ms * 1000); }
void sleep_us(uint64_t us) { busy_wait_us(us); }
void sleep_ms(uint32_t ms) { busy_wait_ms(ms); }
void tight_loop_contents(void) {}
bool stdio_init_all(void) { return true; }

void irq_set_exclusive_handler(uint num, irq_handler_t handler) {
    if (num >= SIL_NUM_IRQS) return;
    handlers[num] = handler;
    rearm(num);
}

void irq_set_enabled(uint num, bool enabled) {
    if (num >= SIL_NUM_IRQS) return;
    is_enabled[num] = enabled;
    rearm(num);
    sil_touch();
    if (enabled) sil_service();
}

void irq_set_pending(uint num) {
    if (num >= SIL_NUM_IRQS) return;
    if (!irq_kept_pending(num)) pending[num] = 1;
    sil_touch();
    sil_service();
}

/* The firmware's critical sections: while "disabled", no interrupt is taken. */
uint32_t save_and_disable_interrupts(void) {
    uint32_t was = (uint32_t)in_irq;
    in_irq = 1;
    return was;
}

void restore_interrupts(uint32_t status) {
    in_irq = (int)status;
    if (!in_irq) sil_service();
}

/* BUILDHAT_SIL_STATS=FILE: at exit, one line of what the run cost is appended to FILE (for
 * tuning the idling above: blocks and timer reads per virtual millisecond, jumps taken). */
static const char *stats_path;

static void write_stats(void) {
    FILE *f = fopen(stats_path, "a");
    if (!f) return;
    fprintf(f, "ns %llu blocks %llu handler_blocks %llu irqs %llu reads %llu jumps %llu jumped_ns %llu\n",
            (unsigned long long)sil_now, (unsigned long long)blocks, (unsigned long long)handler_blocks,
            (unsigned long long)stat_irqs, (unsigned long long)stat_reads, (unsigned long long)stat_jumps,
            (unsigned long long)stat_jumped_ns);
    fclose(f);
}

void sil_machine_power_on(const struct sil_peripheral *const *peripherals, const struct sil_world *world) {
    const char *cost = getenv("BUILDHAT_SIL_NS_PER_BLOCK");
    if (cost && atoi(cost) > 0) ns_per_block = (uint64_t)atoi(cost);
    stats_path = getenv("BUILDHAT_SIL_STATS");
    if (stats_path && *stats_path) atexit(write_stats);
    attached = peripherals;
    sil_world = world;
}
