/* Bytes on a serial wire, each with its arrival time and baud rate: the host's bytes to the
 * command port (uart.c) and each device's bytes to its port (pio.c). The world hands them over
 * ahead of time; they arrive one after another at the sender's pace. */
#ifndef SIL_WIRE_H
#define SIL_WIRE_H

#include "sil_sdk.h"

/* An 8N1 byte is 10 bits on the wire (start, 8 data, stop): at 1 baud it takes this many ns,
 * so at `baud` it takes SIL_NS_PER_BYTE_AT_1_BAUD / baud. */
#define SIL_NS_PER_BYTE_AT_1_BAUD (10ull * 1000000000ull)

struct sil_wire {
    uint8_t *bytes;
    uint64_t *arrival;                 /* when each byte has fully arrived (virtual ns) */
    uint32_t *baud;                    /* the rate each was sent at */
    size_t head, tail, cap;            /* bytes[head..tail) are still on their way */
    uint64_t free_at;                  /* when the sender's next byte can start */
};

/* Queue count bytes sent at baud (0: 115200), the first starting no earlier than start. */
void sil_wire_push(struct sil_wire *wire, uint64_t start, uint32_t baud, const uint8_t *bytes, uint16_t count);
/* When the next byte arrives (UINT64_MAX: none on the way). */
uint64_t sil_wire_next(const struct sil_wire *wire);
/* Take the next byte off the wire (its rate in *baud when baud is not NULL). */
uint8_t sil_wire_take(struct sil_wire *wire, uint32_t *baud);
/* The sender stopped at t: bytes that arrived by then stay, the rest are dropped. */
void sil_wire_cut(struct sil_wire *wire, uint64_t t);

#endif
