/* Bytes on a serial wire (see wire.h). */
#include "wire.h"

#include <stdlib.h>
#include <string.h>

#include "machine.h"

#define DEFAULT_BAUD 115200u           /* a sender that names no rate */
#define FIRST_CAPACITY 256             /* bytes a wire holds before it first grows */

/* Room for one more byte: slide the live bytes down to the start, else double the arrays. */
static void make_room(struct sil_wire *wire) {
    if (wire->head > 0) {
        size_t live = wire->tail - wire->head;
        memmove(wire->bytes, wire->bytes + wire->head, live);
        memmove(wire->arrival, wire->arrival + wire->head, live * sizeof *wire->arrival);
        memmove(wire->baud, wire->baud + wire->head, live * sizeof *wire->baud);
        wire->head = 0;
        wire->tail = live;
    }
    if (wire->tail == wire->cap) {
        wire->cap = wire->cap ? wire->cap * 2 : FIRST_CAPACITY;
        wire->bytes = realloc(wire->bytes, wire->cap);
        wire->arrival = realloc(wire->arrival, wire->cap * sizeof *wire->arrival);
        wire->baud = realloc(wire->baud, wire->cap * sizeof *wire->baud);
        if (!wire->bytes || !wire->arrival || !wire->baud) abort();
    }
}

void sil_wire_push(struct sil_wire *wire, uint64_t start, uint32_t baud, const uint8_t *bytes, uint16_t count) {
    if (baud == 0) baud = DEFAULT_BAUD;
    uint64_t byte_ns = SIL_NS_PER_BYTE_AT_1_BAUD / baud;
    if (start < sil_now) start = sil_now;          /* nothing arrives in the past */
    if (start < wire->free_at) start = wire->free_at;
    for (uint16_t i = 0; i < count; i++) {
        if (wire->tail == wire->cap) make_room(wire);
        start += byte_ns;
        wire->bytes[wire->tail] = bytes[i];
        wire->arrival[wire->tail] = start;
        wire->baud[wire->tail] = baud;
        wire->tail++;
    }
    wire->free_at = start;
}

uint64_t sil_wire_next(const struct sil_wire *wire) {
    return wire->head < wire->tail ? wire->arrival[wire->head] : UINT64_MAX;
}

uint8_t sil_wire_take(struct sil_wire *wire, uint32_t *baud) {
    if (baud) *baud = wire->baud[wire->head];
    return wire->bytes[wire->head++];
}

void sil_wire_cut(struct sil_wire *wire, uint64_t t) {
    while (wire->head < wire->tail && wire->arrival[wire->head] <= t) wire->head++;   /* already sent */
    wire->tail = wire->head;
    wire->free_at = t;
}
