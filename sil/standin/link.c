/* The link to the world: frames on stdin (from the world) and stdout (to it).
 *
 * Every frame is a 16-byte header (type, port, payload length, 4 spare bytes, time in ns;
 * little-endian) and its payload. The firmware runs only between a run frame ('R') and the
 * yield frame ('y') it answers with; in between it owns the clock. The frame types and their
 * payloads are listed once, in sil/frames.py, which the Python side reads.
 */
#include "sil.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

uint64_t link_limit;
int link_yield_on_host_idle;

struct header {
    uint8_t type, port;
    uint16_t len;
    uint32_t spare;
    uint64_t t;
};

static uint8_t out[1 << 16];
static size_t out_len;

static void write_all(const uint8_t *p, size_t n) {
    while (n > 0) {
        ssize_t k = write(1, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) _exit(0);          /* the world has gone: nothing left to run for */
        p += k;
        n -= (size_t)k;
    }
}

void link_flush(void) {
    write_all(out, out_len);
    out_len = 0;
}

void link_emit(uint8_t type, uint8_t port, uint64_t t, const void *data, uint16_t len) {
    struct header h = {type, port, len, 0, t};
    if (out_len + sizeof h + len > sizeof out) link_flush();
    memcpy(out + out_len, &h, sizeof h);
    out_len += sizeof h;
    if (len) memcpy(out + out_len, data, len);
    out_len += len;
}

static void read_all(uint8_t *p, size_t n) {
    while (n > 0) {
        ssize_t k = read(0, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) _exit(0);
        p += k;
        n -= (size_t)k;
    }
}

/* 'K': a copy of this HAT, as it is now, for another run (the world's snapshot of a booted
 * HAT). The child connects to the world's socket and carries on from here over it; the parent
 * answers 'k' with the child's pid and waits for the world as before. */
static void fork_copy(const char *socket_path, const char *stderr_path) {
    pid_t pid = fork();
    if (pid < 0) {
        int err = -errno;
        link_emit('k', 0, sil_now, &err, sizeof err);
        link_flush();
        return;
    }
    if (pid > 0) {
        int32_t child = (int32_t)pid;
        link_emit('k', 0, sil_now, &child, sizeof child);
        link_flush();
        return;
    }
    out_len = 0;                                   /* the parent's unsent frames are not ours */
    periph_flush_output();                         /* (empty at a yield, where copies are made) */
    out_len = 0;
    int fd = socket(AF_UNIX, SOCK_STREAM, 0);
    struct sockaddr_un addr;
    memset(&addr, 0, sizeof addr);
    addr.sun_family = AF_UNIX;
    strncpy(addr.sun_path, socket_path, sizeof addr.sun_path - 1);
    if (fd < 0 || connect(fd, (struct sockaddr *)&addr, sizeof addr) != 0) _exit(71);
    dup2(fd, 0);
    dup2(fd, 1);
    close(fd);
    if (stderr_path[0] && !freopen(stderr_path, "w", stderr)) _exit(72);
    int32_t self = (int32_t)getpid();
    uint8_t hello[8] = {'S', 'I', 'L', '1'};
    memcpy(hello + 4, &self, 4);
    link_emit('y', 0, sil_now, hello, sizeof hello);
    link_flush();
}

/* Obey the world's frames until it says run (or quit). */
static void obey(void) {
    static uint8_t payload[65536 + 1];            /* + room for a terminating NUL */
    for (;;) {
        struct header h;
        read_all((uint8_t *)&h, sizeof h);
        read_all(payload, h.len);
        switch (h.type) {
        case 'R':
            link_limit = h.t;
            link_yield_on_host_idle = h.len > 0 && (payload[0] & 1);
            return;
        case 'H': periph_host_bytes(h.t, payload, h.len); break;
        case 'P':
            if (h.len >= 4) {
                uint32_t baud;
                memcpy(&baud, payload, 4);
                periph_port_bytes(h.port, h.t, baud, payload + 4, (uint16_t)(h.len - 4));
            }
            break;
        case 'C': periph_port_cut(h.port, h.t); break;
        case 'I':
            if (h.len >= 3) {
                uint16_t sig;
                memcpy(&sig, payload, 2);
                periph_set_id(h.port, sig, payload[2]);
            }
            break;
        case 'G': if (h.len >= 2) periph_set_fault_pins(payload[0], payload[1]); break;
        case 'F': if (h.len >= 3) periph_set_fault_regs(h.port, payload); break;
        case 'A':
            if (h.len >= 2) {
                uint16_t raw;
                memcpy(&raw, payload, 2);
                periph_set_adc(raw);
            }
            break;
        case 'W': if (h.len >= 1) periph_set_drive_stops(payload[0]); break;
        case 'S': memcpy((void *)0x2003ff00, payload, h.len < 256 ? h.len : 256); break;
        case 'Q': link_flush(); exit(0);   /* exit(), not _exit(): coverage data is written */
        case 'K': {                    /* payload: socket path, NUL, stderr path */
            payload[h.len] = 0;
            const char *sock = (const char *)payload;
            size_t n = strlen(sock) + 1;
            fork_copy(sock, n < h.len ? sock + n : "");
            break;
        }
        default:
            fprintf(stderr, "sil: unknown frame type 0x%02x from the world\n", h.type);
            exit(70);
        }
    }
}

void link_yield(void) {
    periph_flush_output();
    uint8_t status = periph_host_status();
    link_emit('y', 0, sil_now, &status, 1);
    link_flush();
    obey();
}

/* A fatal signal no sanitizer handles (a plain build's wild store) says its name on stderr
 * before the program dies of it: a copy ('K') is not the world's child, so its exit status is
 * not seen; this line is what tells a crash from an exit (sil/process.py). */
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
        if (sigaction(fatal[i], NULL, &now) == 0 && now.sa_handler == SIG_DFL) signal(fatal[i], say_fatal_signal);
    }
}

static void flush_at_exit(void) {
    periph_flush_output();
    link_flush();
}

void link_start(void) {
    static const char hello[] = "SIL1";
    atexit(flush_at_exit);
    signal(SIGCHLD, SIG_IGN);                      /* copies ('K') are reaped by the system */
    catch_fatal_signals();
    link_emit('y', 0, 0, hello, 4);
    link_flush();
    obey();
}
