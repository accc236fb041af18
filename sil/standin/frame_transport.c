/* The frame transport to the world: frames on stdin (from the world) and stdout (to it).
 *
 * Every frame is a 16-byte header (type, port, payload length, 4 spare bytes, time in ns;
 * little-endian) and its payload. The firmware runs only between a run frame (FRAME_RUN) and
 * the yield frame (FRAME_YIELD) it answers with; in between it owns the clock. The frame types
 * are named in frame_types.h; they and their payloads are listed in sil/frames.py, which the
 * Python side reads.
 *
 * Frames from the world go to the peripherals' inputs (peripherals.h); the model's events come
 * back through the world interface (world_interface.h), which this file implements as frames.
 */
#include "frame_transport.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "boot_signature.h"
#include "frame_types.h"
#include "machine.h"
#include "peripherals.h"

#define HELLO "SIL1"                   /* the first yield's payload: this protocol, version 1 */
#define NO_PORT 0xff                   /* the port byte of a frame about no port */

struct header {
    uint8_t type, port;
    uint16_t len;
    uint32_t spare;
    uint64_t t;
};

static uint8_t out[1 << 16];
static size_t out_len;

static void write_all(const uint8_t *bytes, size_t count) {
    while (count > 0) {
        ssize_t written = write(1, bytes, count);
        if (written < 0 && errno == EINTR) continue;
        if (written <= 0) _exit(0);    /* the world has gone: nothing left to run for */
        bytes += written;
        count -= (size_t)written;
    }
}

static void flush(void) {
    write_all(out, out_len);
    out_len = 0;
}

static void emit(enum sil_frame_type type, uint8_t port, uint64_t t, const void *payload, uint16_t len) {
    struct header header = {(uint8_t)type, port, len, 0, t};
    if (out_len + sizeof header + len > sizeof out) flush();
    memcpy(out + out_len, &header, sizeof header);
    out_len += sizeof header;
    if (len) memcpy(out + out_len, payload, len);
    out_len += len;
}

static void read_all(uint8_t *bytes, size_t count) {
    while (count > 0) {
        ssize_t got = read(0, bytes, count);
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) _exit(0);
        bytes += got;
        count -= (size_t)got;
    }
}

/* ---- the model's events, as frames (payloads: sil/frames.py) ---------------------------- */
static void obey(void);

static void yield(void) {
    sil_uart_flush_output();
    uint8_t status = sil_uart_host_status();
    emit(FRAME_YIELD, 0, sil_now, &status, 1);
    flush();
    obey();
}

static void host_bytes(uint64_t t, const uint8_t *bytes, uint16_t count) {
    emit(FRAME_TO_HOST, 0, t, bytes, count);
}

static void port_byte(int port, uint64_t t, uint32_t baud, uint8_t byte) {
    uint8_t payload[5];
    memcpy(payload, &baud, 4);
    payload[4] = byte;
    emit(FRAME_TO_PORT, (uint8_t)(port < 0 ? NO_PORT : port), t, payload, sizeof payload);
}

static void port_receiver(int port, uint64_t t, bool on, uint32_t baud) {
    uint8_t payload[5] = {(uint8_t)on};
    memcpy(payload + 1, &baud, 4);
    emit(FRAME_RECEIVER, (uint8_t)port, t, payload, sizeof payload);
}

static void port_byte_lost(int port, uint64_t t, uint8_t byte) {
    emit(FRAME_BYTE_LOST, (uint8_t)port, t, &byte, 1);
}

static void drive(int port, uint64_t t, int16_t duty, bool driven) {
    uint8_t payload[3];
    memcpy(payload, &duty, 2);
    payload[2] = (uint8_t)driven;
    emit(FRAME_DRIVE, (uint8_t)port, t, payload, sizeof payload);
}

static void faults_cleared(int port, uint64_t t) { emit(FRAME_FAULTS_CLEARED, (uint8_t)port, t, NULL, 0); }

static void port_power(uint64_t t, bool on) {
    uint8_t payload = (uint8_t)on;
    emit(FRAME_POWER, 0, t, &payload, 1);
}

static void leds(uint64_t t, uint8_t bits) { emit(FRAME_LEDS, 0, t, &bits, 1); }

const struct sil_world sil_frame_world = {
    .yield = yield,
    .host_bytes = host_bytes,
    .port_byte = port_byte,
    .port_receiver = port_receiver,
    .port_byte_lost = port_byte_lost,
    .drive = drive,
    .faults_cleared = faults_cleared,
    .port_power = port_power,
    .leds = leds,
};

/* ---- the world's frames ----------------------------------------------------------------- */
/* FRAME_COPY: a copy of this HAT, as it is now, for another run (the world's snapshot of a
 * booted HAT). The child connects to the world's socket and carries on from here over it; the
 * parent answers FRAME_COPY_MADE with the child's pid and waits for the world as before. */
static void fork_copy(const char *socket_path, const char *stderr_path) {
    pid_t pid = fork();
    if (pid < 0) {
        int err = -errno;
        emit(FRAME_COPY_MADE, 0, sil_now, &err, sizeof err);
        flush();
        return;
    }
    if (pid > 0) {
        int32_t child = (int32_t)pid;
        emit(FRAME_COPY_MADE, 0, sil_now, &child, sizeof child);
        flush();
        return;
    }
    out_len = 0;                                   /* the parent's unsent frames are not ours */
    sil_uart_flush_output();                       /* (empty at a yield, where copies are made) */
    out_len = 0;
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr;
    memset(&addr, 0, sizeof addr);
    addr.sun_family = AF_UNIX;
    size_t path_len = strlen(socket_path);          /* cut to fit, NUL-ended (addr is zeroed) */
    if (path_len > sizeof addr.sun_path - 1) path_len = sizeof addr.sun_path - 1;
    memcpy(addr.sun_path, socket_path, path_len);
    if (fd < 0 || connect(fd, (struct sockaddr *)&addr, sizeof addr) != 0) _exit(71);
    dup2(fd, 0);
    dup2(fd, 1);
    close(fd);
    if (stderr_path[0] && !freopen(stderr_path, "w", stderr)) _exit(72);
    int32_t self = (int32_t)getpid();
    uint8_t hello[8] = {HELLO[0], HELLO[1], HELLO[2], HELLO[3]};   /* and the copy's pid */
    memcpy(hello + 4, &self, 4);
    emit(FRAME_YIELD, 0, sil_now, hello, sizeof hello);
    flush();
}

static uint16_t u16_at(const uint8_t *bytes) {
    uint16_t value;
    memcpy(&value, bytes, 2);
    return value;
}

static uint32_t u32_at(const uint8_t *bytes) {
    uint32_t value;
    memcpy(&value, bytes, 4);
    return value;
}

/* Obey the world's frames until it says run (or quit). A frame too short for its payload is
 * ignored. */
static void obey(void) {
    static uint8_t payload[65536 + 1];            /* + room for a terminating NUL */
    for (;;) {
        struct header header;
        read_all((uint8_t *)&header, sizeof header);
        read_all(payload, header.len);
        uint16_t len = header.len;
        switch (header.type) {
        case FRAME_RUN:                           /* payload bit 0: stop when the command port falls idle */
            sil_run_until(header.t, len > 0 && (payload[0] & 1));
            return;
        case FRAME_HOST_BYTES: sil_uart_host_bytes(header.t, payload, len); break;
        case FRAME_PORT_BYTES:                    /* baud (u32), bytes */
            if (len >= 4)
                sil_pio_port_bytes(header.port, header.t, u32_at(payload), payload + 4, (uint16_t)(len - 4));
            break;
        case FRAME_PORT_CUT: sil_pio_port_cut(header.port, header.t); break;
        case FRAME_ID_LINES:                      /* signature (u16), RX line level when idle (u8) */
            if (len >= 3) sil_gpio_set_id(header.port, u16_at(payload), payload[2]);
            break;
        case FRAME_FAULT_PINS: if (len >= 2) sil_gpio_set_fault_pins(payload[0], payload[1]); break;
        case FRAME_FAULT_REGS: if (len >= 3) sil_i2c_set_fault_regs(header.port, payload); break;
        case FRAME_ADC: if (len >= 2) sil_adc_set_vin(u16_at(payload)); break;
        case FRAME_DRIVE_STOPS: if (len >= 1) sil_i2c_set_drive_stops(payload[0]); break;
        case FRAME_SIGNATURE: sil_boot_signature_store(payload, len); break;
        case FRAME_QUIT: flush(); exit(0);        /* exit(), not _exit(): coverage data is written */
        case FRAME_COPY: {                        /* payload: socket path, NUL, stderr path */
            payload[len] = 0;
            const char *sock = (const char *)payload;
            size_t sock_size = strlen(sock) + 1;
            fork_copy(sock, sock_size < len ? sock + sock_size : "");
            break;
        }
        default:
            fprintf(stderr, "sil: unknown frame type 0x%02x from the world\n", header.type);
            exit(70);
        }
    }
}

/* ---- start and end ---------------------------------------------------------------------- */
/* A fatal signal no sanitizer handles (a plain build's wild store) says its name on stderr
 * before the program dies of it: a copy (FRAME_COPY) is not the world's child, so its exit
 * status is not seen; this line is what tells a crash from an exit (sil/process.py). */
static void say_fatal_signal(int sig) {
    static const char head[] = "sil: the firmware was killed by ";
    const char *name = sig == SIGSEGV ? "SIGSEGV" : sig == SIGBUS ? "SIGBUS" : sig == SIGILL ? "SIGILL"
                       : sig == SIGFPE ? "SIGFPE" : "SIGABRT";
    if (write(2, head, sizeof head - 1) < 0 || write(2, name, strlen(name)) < 0 || write(2, "\n", 1) < 0) {
        /* nothing more can be said */
    }
    signal(sig, SIG_DFL);
    raise(sig);
}

static void catch_fatal_signals(void) {
    static const int fatal[] = {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};
    for (size_t i = 0; i < sizeof fatal / sizeof fatal[0]; i++) {
        struct sigaction now;
        /* a sanitizer's own handler (it says more) is left in place */
        if (sigaction(fatal[i], NULL, &now) == 0 && now.sa_handler == SIG_DFL)
            signal(fatal[i], say_fatal_signal);
    }
}

static void flush_at_exit(void) {
    sil_uart_flush_output();
    flush();
}

void sil_frame_transport_start(void) {
    atexit(flush_at_exit);
    signal(SIGCHLD, SIG_IGN);                      /* copies (FRAME_COPY) are reaped by the system */
    catch_fatal_signals();
    emit(FRAME_YIELD, 0, 0, HELLO, 4);
    flush();
    obey();
}
